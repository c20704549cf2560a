"""The angular daylight field at one depth: what the renderer's ambient lighting uses.

An :class:`AngularField` is the radiance distribution of daylight at the rig's
depth in a plane-parallel water column, split into

* the **unscattered sun beam** — a delta in the refracted sun direction, given by
  its irradiance normal to the beam (W·m⁻²·nm⁻¹), and
* the **diffuse field** — everything that was scattered at least once (by the
  water, a bottom, an internal reflection at the surface), tabulated as the
  radiance *seen looking* in bins of the viewing direction's zenith angle θ (from
  straight up, uniform bins in θ) and azimuth φ from the direction towards the
  sun (uniform on [0, π]: the field is symmetric about the sun's vertical plane),
  W·m⁻²·sr⁻¹·nm⁻¹;

plus how the field changes with height over the scene: every diffuse radiance as
``exp(K_diffuse (y − y₀))`` and the beam as ``exp((c/μ_w)(y − y₀))`` (y up, y₀ the
depth the field was computed at; the beam's law is exact, the diffuse one is the
asymptotic-regime approximation with the local vertical attenuation of the
diffuse downwelling irradiance).

Two models, as for the meter (``Daylight.model``):

* ``"monte-carlo"`` — :func:`angular_field_monte_carlo`: the meter's photon Monte
  Carlo (:func:`~rigsim.daylight.meter.ambient_light_monte_carlo`) with its angular
  tally; the integrals of the table reproduce the meter's own Ed, Eu and Eo.
* ``"kd"`` — :func:`angular_field_kd`: the Kd shortcut: the beam attenuated by c,
  the rest of Ed as a uniform downwelling hemisphere, upwelling a uniform
  hemisphere of radiance Eu/π (as :func:`~rigsim.daylight.underwater.ambient_light_field_at_depth`).

Scene frame as :mod:`rigsim.daylight.underwater`: x right, y up, z forward; the
horizontal direction towards the sun is ``(sin φ_s, 0, cos φ_s)``.

Equilibrium.  In a plane-parallel field the radiance seen looking horizontally
does not change along the line of sight, so the radiative transfer equation
reduces to ``c L(h) = b ∫ p L dω′`` (the in-scattered source balances
attenuation): :func:`equilibrium_residual` measures how well a tabulated field
satisfies it (the binning, the Monte Carlo noise and the phase function's forward
peak set the residual; see the tests).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from rigsim.daylight.meter import Bottom, ambient_light_monte_carlo
from rigsim.daylight.shortcut import ambient_light_kd
from rigsim.daylight.sky import SkyModel, sky_model
from rigsim.daylight.underwater import SunBeam, daylight_above_surface, sun_beam_below_surface
from rigsim.errors import ConfigError
from rigsim.scene.types import Daylight
from rigsim.spectrum import as_wavelengths
from rigsim.water.model import Water

__all__ = ["AngularField", "angular_field", "angular_field_monte_carlo", "angular_field_kd",
           "equilibrium_residual", "DEFAULT_N_THETA", "DEFAULT_N_PHI", "K_LAYER_M"]

#: Zenith bins of the tabulated field (5° each).
DEFAULT_N_THETA = 36
#: Azimuth bins over [0, π] (30° each).
DEFAULT_N_PHI = 6
#: Half-thickness of the layer over which the local K of the diffuse light is taken (m).
K_LAYER_M = 0.5


@dataclass(frozen=True, eq=False)
class AngularField:
    """Daylight at one depth as a sun beam and a tabulated diffuse radiance (see module docstring).

    Attributes
    ----------
    depth_m, wavelength_nm
        Depth (m) and wavelengths (nm).
    theta_edges_rad, phi_edges_rad
        Bin edges of the viewing direction: zenith angle from straight up, azimuth from the sun.
    diffuse, diffuse_stderr
        (n_wl, n_theta, n_phi) radiance seen looking into each bin, W·m⁻²·sr⁻¹·nm⁻¹.
    sun
        The unscattered beam at this depth (``irradiance_normal``, direction of propagation).
    k_diffuse, k_beam
        Vertical change of the diffuse radiances and of the beam: ``L(y) = L(y₀) exp(K (y − y₀))``, 1/m.
    c
        Beam attenuation of the water, 1/m.
    sun_azimuth_deg
        The sun's azimuth (scene frame).
    model
        ``"monte-carlo"`` or ``"kd"``.
    Ed, Eu, Eo
        The plane and scalar irradiances of the model run the field came from.
    meta
        JSON-ready description (model, sky, photons, seed, …).
    """

    depth_m: float
    wavelength_nm: np.ndarray
    theta_edges_rad: np.ndarray
    phi_edges_rad: np.ndarray
    diffuse: np.ndarray
    diffuse_stderr: np.ndarray
    sun: SunBeam
    k_diffuse: np.ndarray
    k_beam: np.ndarray
    c: np.ndarray
    sun_azimuth_deg: float
    model: str
    Ed: np.ndarray
    Eu: np.ndarray
    Eo: np.ndarray
    meta: dict = field(default_factory=dict)

    # -- geometry of the bins -------------------------------------------------------------
    @property
    def solid_angle_sr(self) -> np.ndarray:
        """(n_theta, n_phi) solid angle of each bin (both halves ±φ)."""
        te, pe = self.theta_edges_rad, self.phi_edges_rad
        return (2.0 * np.diff(pe))[None, :] * (np.cos(te[:-1]) - np.cos(te[1:]))[:, None]

    def bin_directions(self, sub: int = 4) -> tuple[np.ndarray, np.ndarray]:
        """Sub-sampled viewing directions of every bin: (dirs (nθ, nφ, 2 sub², 3), solid angle each).

        Directions are in the scene frame; both halves ±φ are included.
        """
        te, pe = self.theta_edges_rad, self.phi_edges_rad
        g = (np.arange(sub) + 0.5) / sub
        mu = np.cos(te[:-1])[:, None] + (np.cos(te[1:]) - np.cos(te[:-1]))[:, None] * g[None, :]  # (nθ, sub)
        ph = pe[:-1][:, None] + np.diff(pe)[:, None] * g[None, :]  # (nφ, sub)
        ph = np.concatenate([ph, -ph], axis=1)  # (nφ, 2 sub)
        MU = np.broadcast_to(mu[:, None, :, None], (mu.shape[0], ph.shape[0], sub, ph.shape[1]))
        PH = np.broadcast_to(ph[None, :, None, :], MU.shape)
        st = np.sqrt(np.clip(1.0 - MU * MU, 0.0, 1.0))
        a = np.radians(self.sun_azimuth_deg) + PH
        dirs = np.stack([st * np.sin(a), MU, st * np.cos(a)], axis=-1).reshape(mu.shape[0], ph.shape[0], -1, 3)
        return dirs, self.solid_angle_sr / dirs.shape[2]

    def view_angles(self, view_dirs) -> tuple[np.ndarray, np.ndarray]:
        """(zenith θ, azimuth φ from the sun, 0…π) of viewing directions (scene frame), rad."""
        v = np.asarray(view_dirs, float)
        v = v / np.linalg.norm(v, axis=-1, keepdims=True)
        th = np.arccos(np.clip(v[..., 1], -1.0, 1.0))
        ps = np.radians(self.sun_azimuth_deg)
        cos_p = (v[..., 0] * np.sin(ps) + v[..., 2] * np.cos(ps)) / np.maximum(np.hypot(v[..., 0], v[..., 2]), 1e-12)
        ph = np.arccos(np.clip(cos_p, -1.0, 1.0))
        return th, ph

    def view_bins(self, view_dirs) -> tuple[np.ndarray, np.ndarray]:
        """(θ bin, φ bin) of viewing directions (scene frame)."""
        th, ph = self.view_angles(view_dirs)
        nt, nph = self.diffuse.shape[1:]
        it = np.minimum((th / np.pi * nt).astype(int), nt - 1)
        ip = np.minimum((ph / np.pi * nph).astype(int), nph - 1)
        return it, ip

    def radiance(self, view_dirs, *, interpolate: bool = True) -> np.ndarray:
        """Diffuse radiance seen looking along ``view_dirs`` (…, 3): (…, n_wl).

        ``interpolate``: bilinear between bin centres in (θ, φ), ends clamped — what the
        renderer looks up; otherwise the value of the bin.  In the dtype of the table.
        """
        if not interpolate:
            it, ip = self.view_bins(view_dirs)
            return np.moveaxis(self.diffuse[:, it, ip], 0, -1)
        th, ph = self.view_angles(view_dirs)
        nt, nph = self.diffuse.shape[1:]
        tt = np.clip(th * nt / np.pi - 0.5, 0.0, nt - 1.0)
        tp = np.clip(ph * nph / np.pi - 0.5, 0.0, nph - 1.0)
        i0 = np.minimum(np.floor(tt).astype(int), max(nt - 2, 0))
        j0 = np.minimum(np.floor(tp).astype(int), max(nph - 2, 0))
        i1, j1 = np.minimum(i0 + 1, nt - 1), np.minimum(j0 + 1, nph - 1)
        D = np.ascontiguousarray(np.moveaxis(self.diffuse, 0, -1)).reshape(nt * nph, -1)
        ft, fp = (tt - i0)[..., None].astype(D.dtype), (tp - j0)[..., None].astype(D.dtype)

        def at(i, j):  # D[i, j, :] (take on the flat table: much faster than fancy indexing)
            return np.take(D, i * nph + j, axis=0)

        top = at(i0, j0) * (1 - fp) + at(i0, j1) * fp
        bot = at(i1, j0) * (1 - fp) + at(i1, j1) * fp
        return top * (1 - ft) + bot * ft

    # -- integrals -----------------------------------------------------------------------
    def irradiance(self, normal, *, beam: bool = True, diffuse: bool = True, sub: int = 4) -> np.ndarray:
        """Plane irradiance (W·m⁻²·nm⁻¹) on a surface whose normal is ``normal`` (scene frame), unoccluded."""
        n = np.asarray(normal, float)
        n = n / np.linalg.norm(n)
        out = np.zeros(self.wavelength_nm.shape)
        if diffuse:
            dirs, dw = self.bin_directions(sub)
            cosw = np.clip(dirs @ n, 0.0, None).sum(axis=-1) * dw  # (nθ, nφ)
            out = out + np.einsum("ltp,tp->l", self.diffuse, cosw)
        if beam:
            out = out + self.sun.irradiance_normal * max(0.0, float(-(self.sun.direction @ n)))
        return out

    def plane_irradiances(self) -> dict[str, np.ndarray]:
        """Ed, Eu, Eo of the tabulated field (beam included): compare with the model run's own."""
        te, pe = self.theta_edges_rad, self.phi_edges_rad
        cosint = (2.0 * np.diff(pe))[None, :] * ((np.sin(te[1:]) ** 2 - np.sin(te[:-1]) ** 2) / 2.0)[:, None]
        h = len(te) // 2
        mu_w = np.cos(np.radians(self.sun.zenith_water_deg))
        ed = np.einsum("ltp,tp->l", self.diffuse[:, :h], cosint[:h]) + self.sun.irradiance_normal * mu_w
        eu = -np.einsum("ltp,tp->l", self.diffuse[:, h:], cosint[h:])
        eo = np.einsum("ltp,tp->l", self.diffuse, self.solid_angle_sr) + self.sun.irradiance_normal
        return {"Ed": ed, "Eu": eu, "Eo": eo}

    def describe(self) -> dict:
        return dict(self.meta)


def _check(daylight: Daylight, water: Water, wavelength_nm):
    wl = np.atleast_1d(water.check_range(as_wavelengths(wavelength_nm)))
    z = float(daylight.depth_m)
    if not np.isfinite(z) or z <= 0:
        raise ConfigError(f"daylight depth must be > 0 m, got {daylight.depth_m}", field="daylight.depth_m",
                          allowed="> 0 m")
    return wl, z


def _beam(daylight: Daylight, water: Water, wl, sky_m, above) -> tuple[SunBeam, np.ndarray, np.ndarray]:
    beam0 = sun_beam_below_surface(daylight, wl, sky=sky_m, above=above)
    c = water.c_per_m(wl)
    mu_w = np.cos(np.radians(beam0.zenith_water_deg))
    sun = SunBeam(beam0.direction, beam0.zenith_water_deg, wl, beam0.at_depth(daylight.depth_m, c),
                  beam0.fresnel_transmittance)
    return sun, c, c / mu_w


def angular_field_monte_carlo(daylight: Daylight, water: Water, wavelength_nm, *, sky: str | SkyModel = "cie",
                              bottom: Bottom | None = None, photons: int = 20_000, seed: int = 0,
                              n_theta: int = DEFAULT_N_THETA, n_phi: int = DEFAULT_N_PHI,
                              batches: int = 10) -> AngularField:
    """The field by the Monte Carlo meter (flat surface; see module docstring).

    The meter tallies at ``z − δ, z, z + δ`` (δ = :data:`K_LAYER_M`, or z/2 if
    shallower) for the local vertical attenuation of the diffuse downwelling
    irradiance, ``K = −ln(Ed,diff(z+δ)/Ed,diff(z−δ)) / 2δ`` (it can be negative
    near the surface, where the diffuse light still builds up).
    """
    wl, z = _check(daylight, water, wavelength_nm)
    sky_m = sky_model(sky, daylight.sun_zenith_deg) if isinstance(sky, str) else sky
    above = daylight_above_surface(daylight, wl, sky_m)
    dz = min(K_LAYER_M, z / 2.0)
    if bottom is not None and bottom.depth_m is not None:
        dz = min(dz, (float(bottom.depth_m) - z) / 2.0)
    depths = [z - dz, z, z + dz]
    res = ambient_light_monte_carlo(water, wl, depths, sun_zenith_deg=daylight.sun_zenith_deg, sky=sky_m,
                                    above=above, bottom=bottom, photons=photons, batches=batches, seed=seed,
                                    angular_depth_m=z, n_theta=n_theta, n_phi=n_phi)
    sun, c, k_beam = _beam(daylight, water, wl, sky_m, above)
    mu_w = np.cos(np.radians(sun.zenith_water_deg))
    ed = res["Ed"]
    beam_plane = np.stack([sun.irradiance_normal * np.exp(-k_beam * (d - z)) * mu_w for d in depths])
    edd = np.maximum(ed - beam_plane, 1e-300)
    k_diff = -np.log(edd[2] / edd[0]) / (2.0 * dz)
    k_diff = np.where(np.isfinite(k_diff), k_diff, water.kd_per_m(wl, daylight.sun_zenith_deg))
    A = res.angular
    fld0 = AngularField(z, wl, A["theta_edges_rad"], A["phi_edges_rad"], A["radiance_scattered"],
                        A["radiance_scattered_stderr"], sun, k_diff, k_beam, c, float(daylight.sun_azimuth_deg),
                        "monte-carlo", ed[1], res["Eu"][1], res["Eo"][1])
    diffuse = A["radiance_scattered"] + _sky_through_window(fld0, daylight, wl, sky_m, above, c)
    # The bin-centre point estimate misses the part of the phase function's forward peak that falls
    # between bin centres (beyond the first scattering out of the beam, which is bin-averaged): scale
    # each hemisphere to the meter's own plane irradiance (exact crossing tallies) at this depth.
    fld1 = dataclasses.replace(fld0, diffuse=diffuse)
    pi_ = fld1.plane_irradiances()
    mu_w = np.cos(np.radians(sun.zenith_water_deg))
    h = diffuse.shape[1] // 2
    with np.errstate(divide="ignore", invalid="ignore"):
        f_down = (ed[1] - sun.irradiance_normal * mu_w) / (pi_["Ed"] - sun.irradiance_normal * mu_w)
        f_up = res["Eu"][1] / pi_["Eu"]
    f_down = np.where(np.isfinite(f_down) & (f_down > 0), f_down, 1.0)
    f_up = np.where(np.isfinite(f_up) & (f_up > 0), f_up, 1.0)
    diffuse = diffuse.copy()
    diffuse[:, :h] *= f_down[:, None, None]
    diffuse[:, h:] *= f_up[:, None, None]
    meta = {"model": "monte-carlo", "depth_m": z, "sky": sky_m.describe(), "photons": int(photons),
            "seed": int(seed), "batches": int(batches), "n_theta": int(n_theta), "n_phi": int(n_phi),
            "bottom": (bottom or Bottom()).describe(), "surface": "flat",
            "k_diffuse": f"local, Ed diffuse over {z - dz:g}-{z + dz:g} m"}
    meta["hemisphere_scale_down"] = [round(float(x), 4) for x in f_down]
    meta["hemisphere_scale_up"] = [round(float(x), 4) for x in f_up]
    meta["estimator"] = ("scattered light: point (local) estimate at bin centres; unscattered sky through "
                         "Snell's window: analytic, bin-averaged")
    return AngularField(z, wl, A["theta_edges_rad"], A["phi_edges_rad"], diffuse, A["radiance_scattered_stderr"],
                        sun, k_diff, k_beam, c, float(daylight.sun_azimuth_deg), "monte-carlo",
                        ed[1], res["Eu"][1], res["Eo"][1], meta)


def _sky_through_window(fld: AngularField, daylight: Daylight, wl, sky_m, above, c, sub: int = 6) -> np.ndarray:
    """Bin-averaged unscattered sky radiance seen looking up at depth: ``L_sky,w(θ, φ) e^{−c z/cos θ}``."""
    from rigsim.daylight.underwater import sky_radiance_below_surface

    if not sky_m.emits:
        return np.zeros_like(fld.diffuse)
    dirs, _ = fld.bin_directions(sub)  # (nθ, nφ, m, 3)
    mu = dirs[..., 1]
    ps = np.radians(fld.sun_azimuth_deg)
    cos_p = (dirs[..., 0] * np.sin(ps) + dirs[..., 2] * np.cos(ps)) / np.maximum(
        np.hypot(dirs[..., 0], dirs[..., 2]), 1e-12)
    phi = np.arccos(np.clip(cos_p, -1, 1))
    L = sky_radiance_below_surface(daylight, wl, np.clip(mu, 0, 1), phi, sky=sky_m, above=above)  # (…, n_wl)
    att = np.exp(-c[None, None, None, :] * fld.depth_m / np.maximum(mu, 1e-6)[..., None])
    L = np.where((mu > 0)[..., None], L * att, 0.0)
    return np.moveaxis(L.mean(axis=2), -1, 0)


def angular_field_kd(daylight: Daylight, water: Water, wavelength_nm, *, sky: str | SkyModel = "cie",
                     bottom: Bottom | None = None, n_theta: int = DEFAULT_N_THETA,
                     n_phi: int = DEFAULT_N_PHI, kd_method: str = "lee-2005") -> AngularField:
    """The field of the Kd shortcut: beam (c), uniform downwelling rest of Ed, uniform upwelling Eu/π."""
    wl, z = _check(daylight, water, wavelength_nm)
    sky_m = sky_model(sky, daylight.sun_zenith_deg) if isinstance(sky, str) else sky
    above = daylight_above_surface(daylight, wl, sky_m)
    res = ambient_light_kd(water, wl, [z], sun_zenith_deg=daylight.sun_zenith_deg, sky=sky_m, above=above,
                           bottom=bottom, kd_method=kd_method)
    sun, c, k_beam = _beam(daylight, water, wl, sky_m, above)
    mu_w = np.cos(np.radians(sun.zenith_water_deg))
    ed, eu = res["Ed"][0], res["Eu"][0]
    down = np.maximum(ed - sun.irradiance_normal * mu_w, 0.0) / np.pi
    up = eu / np.pi
    te = np.linspace(0.0, np.pi, n_theta + 1)
    pe = np.linspace(0.0, np.pi, n_phi + 1)
    h = n_theta // 2
    tab = np.empty((wl.size, n_theta, n_phi))
    tab[:, :h] = down[:, None, None]
    tab[:, h:] = up[:, None, None]
    kd = res["Kd"][0]
    meta = {"model": "kd", "kd_method": kd_method, "depth_m": z, "sky": sky_m.describe(),
            "bottom": (bottom or Bottom()).describe(), "n_theta": int(n_theta), "n_phi": int(n_phi)}
    return AngularField(z, wl, te, pe, tab, np.zeros_like(tab), sun, kd, k_beam, c,
                        float(daylight.sun_azimuth_deg), "kd", ed, eu, res["Eo"][0], meta)


def angular_field(daylight: Daylight, water: Water, wavelength_nm, *, sky: str | SkyModel | None = None,
                  bottom: Bottom | None = None, photons: int | None = None, seed: int = 0,
                  n_theta: int = DEFAULT_N_THETA, n_phi: int = DEFAULT_N_PHI) -> AngularField:
    """The field of ``daylight.model`` (``"monte-carlo"`` or ``"kd"``); sky and photons default to the Daylight's."""
    sky = sky if sky is not None else getattr(daylight, "sky", "cie")
    if daylight.model == "monte-carlo":
        photons = photons if photons is not None else int(getattr(daylight, "photons", 20_000))
        return angular_field_monte_carlo(daylight, water, wavelength_nm, sky=sky, bottom=bottom, photons=photons,
                                         seed=seed, n_theta=n_theta, n_phi=n_phi)
    if daylight.model == "kd":
        return angular_field_kd(daylight, water, wavelength_nm, sky=sky, bottom=bottom, n_theta=n_theta,
                                n_phi=n_phi)
    raise ConfigError(f"unknown daylight model {daylight.model!r}", field="daylight.model", allowed="kd, monte-carlo")


def equilibrium_residual(fld: AngularField, water: Water, view_dirs, *, sub: int = 8) -> np.ndarray:
    """``b ∫ p L dω′ / (c L) − 1`` for (horizontal) viewing directions: 0 for a field in equilibrium.

    ``L`` is the field's radiance seen along each direction (its bin value), the
    in-scattering integral sums the diffuse bins (the phase function averaged over
    each bin by ``sub × 2sub`` sub-directions) and the beam.  Returns (…, n_wl).
    """
    v = np.asarray(view_dirs, float).reshape(-1, 3)
    v = v / np.linalg.norm(v, axis=1, keepdims=True)
    wl = fld.wavelength_nm
    b, c = water.b_per_m(wl), water.c_per_m(wl)
    dirs, dw = fld.bin_directions(sub)  # viewing directions u of the bins
    out = np.empty((v.shape[0], wl.size))
    for i, vi in enumerate(v):
        # light seen looking along u propagates along −u; scattered into −v: cos ψ = u·v
        cos_psi = np.clip(dirs @ vi, -1.0, 1.0)
        cos_b = float(np.clip(-(fld.sun.direction @ vi), -1.0, 1.0))  # beam (propagating s) into −v: cos ψ = −s·v
        for j, lam in enumerate(wl):
            p = np.asarray(water.phase.eval(cos_psi, float(lam)), float)
            w_bins = p.sum(axis=-1) * dw
            j_in = b[j] * (np.sum(fld.diffuse[j] * w_bins)
                           + float(np.asarray(water.phase.eval(np.array([cos_b]), float(lam))).ravel()[0])
                           * fld.sun.irradiance_normal[j])
            L = fld.radiance(vi[None, :])[0, j]
            out[i, j] = j_in / (c[j] * L) - 1.0
    return out.reshape(np.asarray(view_dirs).shape[:-1] + (wl.size,))

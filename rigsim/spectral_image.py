"""SpectralImage: spectral radiance at the entrance pupil, with ground truth and provenance.

The one interface between the image makers (:mod:`rigsim.render`,
:mod:`rigsim.preview`) and the image users (:mod:`rigsim.sensor`,
:mod:`rigsim.metrics`).  One SpectralImage serves every sensor.

Provenance is typed: :attr:`SpectralImage.scene` is the :class:`~rigsim.scene.types.Scene`
that made the image (camera, lens, port, water, lights, targets, daylight) and
:attr:`SpectralImage.render` how it was made (:class:`RenderInfo`: engine, seed, paths per
pixel).  Later stages read physics from these (the sensor takes the f-number, the port and
the medium from the scene), never from :attr:`SpectralImage.meta`, which is a free-form,
JSON-ready description for people and reports.  :meth:`SpectralImage.save` writes both to
``scene.json`` (:mod:`rigsim.scene.record`) and :meth:`SpectralImage.load` reads them back.
"""

from __future__ import annotations

import json
import zipfile
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from rigsim.errors import ConfigError
from rigsim.fileio import atomic_write_npz, atomic_write_text

#: Names of the optional ground-truth layers and their meaning.
LAYER_DOCS = {
    "range_m": "(rows, cols) distance from the entrance pupil to the first surface hit, m (inf: none)",
    "clear": "(rows, cols, bands) radiance of the same view and lighting without water, W/(m² sr nm)",
    "object_id": "(rows, cols) int32 id of the first surface hit (0: none; see meta['object_ids'])",
    "direct": "(rows, cols, bands) radiance of light that reached the camera without scattering in water",
    "backscatter": "(rows, cols, bands) radiance scattered by the water into the camera without "
                   "reaching a surface (the veiling light)",
    "flash": "(rows, cols, bands) radiance integrated over one flash of the strobes, J/(m² sr nm); "
             "``radiance`` then holds only continuous light (ambient, video lights)",
    "flash_clear": "``clear`` for the flash, J/(m² sr nm)",
    "flash_direct": "``direct`` for the flash, J/(m² sr nm)",
    "flash_backscatter": "``backscatter`` for the flash, J/(m² sr nm)",
    "particles": "(rows, cols, bands) what the water's discrete particles (marine snow) add to the radiance: "
                 "their light less the light they hide (the image without them is radiance − particles; the "
                 "direct and backscatter layers hold no light of theirs, only their shadow)",
    "flash_particles": "``particles`` for the flash, J/(m² sr nm)",
    "particle_id": "(rows, cols) int32 1-based index of the nearest particle whose image reaches into the pixel (0: none; "
                   "the instance mask; meta['particles'] describes the set)",
}

#: Spectral layers that have a continuous (W) part and a flash (J) part.
SPECTRAL_LAYERS = ("clear", "direct", "backscatter", "particles")
#: The image makers.
ENGINES = ("mitsuba", "preview")


@dataclass(frozen=True)
class RenderInfo:
    """How an image was made.

    Attributes
    ----------
    engine
        ``"mitsuba"`` (the Monte Carlo renderer, :func:`rigsim.render.render`) or ``"preview"``
        (the fast engine, :func:`rigsim.preview.render_preview`).
    seed
        Random seed (Monte Carlo; None for the deterministic fast engine).
    spp
        Paths per pixel of the ``full`` passes (Monte Carlo; None otherwise).
    integrator
        Mitsuba integrator (``"rigsim"``, ``"volpath"``), or None.
    """

    engine: str
    seed: int | None = None
    spp: int | None = None
    integrator: str | None = None

    def __post_init__(self):
        if self.engine not in ENGINES:
            raise ConfigError(f"unknown engine {self.engine!r}", field="engine", allowed=", ".join(ENGINES))


@dataclass(frozen=True, eq=False)
class SpectralImage:
    """Spectral radiance image with ground-truth layers.

    Attributes
    ----------
    radiance
        Array (rows, cols, bands) of spectral radiance in W·m⁻²·sr⁻¹·nm⁻¹.
    wavelength_nm
        Band centres (nm), shape (bands,).
    bandwidth_nm
        Band widths (nm), shape (bands,).
    layers
        Ground truth, keys from :data:`LAYER_DOCS`.
    meta
        JSON-serialisable description for people and reports (wall time, noise, the
        object-id legend ``meta["object_ids"]`` …); nothing downstream reads physics from it.
    scene
        The typed :class:`~rigsim.scene.types.Scene` that made the image, or None (an image
        of unknown origin: no port, no lens of its own).
    render
        :class:`RenderInfo`, or None.
    """

    radiance: np.ndarray
    wavelength_nm: np.ndarray
    bandwidth_nm: np.ndarray
    layers: dict[str, np.ndarray] = field(default_factory=dict)
    meta: dict = field(default_factory=dict)
    scene: object = None
    render: RenderInfo | None = None

    def __post_init__(self):
        r = np.asarray(self.radiance)
        if r.ndim != 3:
            raise ValueError(f"radiance must be (rows, cols, bands), got shape {r.shape}")
        if r.shape[2] != len(self.wavelength_nm) or len(self.bandwidth_nm) != len(self.wavelength_nm):
            raise ValueError("radiance bands, wavelength_nm and bandwidth_nm disagree")
        for k in self.layers:
            if k not in LAYER_DOCS:
                raise ValueError(f"unknown layer {k!r}; known: {', '.join(LAYER_DOCS)}")

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, cols)."""
        return self.radiance.shape[:2]

    @property
    def n_bands(self) -> int:
        return self.radiance.shape[2]

    def radiant_exposure(self, exposure_s: float, layer: str | None = None) -> np.ndarray:
        """Spectral radiance integrated over an exposure, J·m⁻²·sr⁻¹·nm⁻¹.

        Continuous light (``radiance``, or the continuous part of a spectral ground-
        truth ``layer`` such as ``"clear"``) times the exposure time, plus one flash
        (layer ``flash`` / ``flash_<layer>``) if the scene has strobes — a strobe's
        flash is shorter than any shutter time, so it does not scale with the shutter.
        """
        if layer is None:
            cont, flash = np.asarray(self.radiance, float), self.layers.get("flash")
        else:
            if layer not in SPECTRAL_LAYERS:
                raise ValueError(f"{layer!r} is not a spectral layer ({', '.join(SPECTRAL_LAYERS)})")
            cont, flash = self.layers.get(layer), self.layers.get(f"flash_{layer}")
            if cont is None and flash is None:
                raise KeyError(f"this image has no {layer!r} layer")
        if cont is None or not np.any(cont):  # no continuous light (a strobe-only scene): the flash alone
            return np.array(flash, float) if flash is not None else np.zeros(self.radiance.shape)
        h = np.asarray(cont, float) * float(exposure_s)
        if flash is not None:
            h += flash
        return h

    def save(self, directory: str | Path) -> Path:
        """Write ``spectral.npz`` (radiance + layers), ``meta.json`` and ``scene.json`` (the typed
        provenance, if any) into ``directory``, each atomically."""
        from dataclasses import asdict

        from rigsim.scene.record import scene_record

        from rigsim.fileio import ensure_folder

        d = ensure_folder(directory)
        arrays = {"radiance": np.asarray(self.radiance, np.float32),
                  "wavelength_nm": np.asarray(self.wavelength_nm, float),
                  "bandwidth_nm": np.asarray(self.bandwidth_nm, float)}
        for k, v in self.layers.items():
            arrays[f"layer_{k}"] = np.asarray(v)
        atomic_write_npz(d / "spectral.npz", arrays)
        atomic_write_text(d / "meta.json", json.dumps(self.meta, indent=2, default=_json_default))
        prov = {"scene": None if self.scene is None else scene_record(self.scene),
                "render": None if self.render is None else asdict(self.render)}
        atomic_write_text(d / "scene.json", json.dumps(prov, default=_json_default))
        return d

    @classmethod
    def load(cls, directory: str | Path) -> "SpectralImage":
        """Read a SpectralImage written by :meth:`save`.

        Raises
        ------
        ConfigError
            One line naming the file: no ``spectral.npz``, a truncated or corrupt file, arrays
            of the wrong shape, radiance that is not finite or negative, unreadable JSON.
        """
        d = Path(directory)
        f = d / "spectral.npz"
        allowed = "a directory written by `rigsim render`"
        if not f.is_file():
            raise ConfigError("no spectral.npz here (not a render directory)", file=d, allowed=allowed)
        try:
            with np.load(f, allow_pickle=False) as z:
                missing = [k for k in ("radiance", "wavelength_nm", "bandwidth_nm") if k not in z.files]
                if missing:
                    raise ConfigError(f"corrupt: no {', '.join(missing)} array", file=f, allowed=allowed)
                layers = {k[6:]: z[k] for k in z.files if k.startswith("layer_")}
                radiance, wl, bw = z["radiance"], z["wavelength_nm"], z["bandwidth_nm"]
        except ConfigError:
            raise
        except (OSError, ValueError, EOFError, KeyError, zipfile.BadZipFile, zlib.error,
                NotImplementedError) as exc:  # a damaged zip header claims a version zipfile lacks (soak)
            raise ConfigError(f"cannot read ({_reason(exc)}); truncated or not written by rigsim", file=f,
                              allowed=allowed) from None
        radiance = np.asarray(radiance)
        wl, bw = np.asarray(wl), np.asarray(bw)
        if (radiance.ndim != 3 or wl.ndim != 1 or bw.shape != wl.shape or radiance.shape[2] != wl.size
                or not np.issubdtype(radiance.dtype, np.floating) or not np.issubdtype(wl.dtype, np.number)):
            raise ConfigError(f"corrupt: radiance {radiance.shape} and {wl.size} wavelengths do not match", file=f,
                              allowed=allowed)
        for name, arr in (("radiance", radiance), *((f"layer {k}", v) for k, v in layers.items()
                                                     if k in SPECTRAL_LAYERS or k.startswith("flash"))):
            a = np.asarray(arr)
            if a.shape[:2] != radiance.shape[:2]:
                raise ConfigError(f"corrupt: {name} has shape {a.shape}, the image {radiance.shape[:2]}", file=f,
                                  allowed=allowed)
            # the particles' layers are signed (their light less the light they hide): finite is all they must be
            signed = name.endswith("particles")
            if not np.issubdtype(a.dtype, np.number) or not np.all(np.isfinite(a)) or (not signed and np.any(a < 0)):
                raise ConfigError(f"corrupt: {name} has values that are not finite or negative", file=f,
                                  allowed="radiance >= 0 everywhere (the particles' layers: finite)")
        if not (np.all(np.isfinite(wl)) and np.all(np.diff(wl) > 0) and np.all(bw > 0)):
            raise ConfigError("corrupt: wavelengths must increase and bandwidths be positive", file=f,
                              allowed=allowed)
        unknown = [k for k in layers if k not in LAYER_DOCS]
        if unknown:
            raise ConfigError(f"unknown layer {unknown[0]!r}", file=f, allowed=", ".join(LAYER_DOCS))
        meta = {}
        if (d / "meta.json").is_file():
            meta = _read_json(d / "meta.json")
            if not isinstance(meta, dict):
                raise ConfigError("must hold a JSON object", file=d / "meta.json")
        scene, render = None, None
        if (d / "scene.json").is_file():
            from rigsim.scene.record import scene_from_record

            prov = _read_json(d / "scene.json")
            if not isinstance(prov, dict):
                raise ConfigError("must hold a JSON object", file=d / "scene.json")
            try:
                if prov.get("scene") is not None:
                    scene = scene_from_record(prov["scene"])
                if prov.get("render") is not None:
                    render = RenderInfo(**prov["render"])
            except ConfigError as exc:
                raise ConfigError(f"corrupt: {exc}", file=d / "scene.json") from None
            except (TypeError, ValueError, KeyError, AttributeError, IndexError) as exc:
                raise ConfigError(f"corrupt: {_reason(exc)}", file=d / "scene.json") from None
        return cls(radiance=radiance, wavelength_nm=wl, bandwidth_nm=bw, layers=layers, meta=meta, scene=scene,
                   render=render)


def _reason(exc: BaseException) -> str:
    text = " ".join(str(exc).split())
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def _read_json(path: Path):
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError, UnicodeDecodeError) as exc:
        raise ConfigError(f"cannot read ({_reason(exc)})", file=path) from None


def _json_default(o):
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    if isinstance(o, Path):
        return str(o)
    raise TypeError(f"not JSON serialisable: {type(o)}")


def xyz_from_spectral(spectral: np.ndarray, wavelength_nm, bandwidth_nm) -> np.ndarray:
    """CIE 1931 2° tristimulus values ``∑ S_b ∫_band x̄ȳz̄ dλ`` of a spectral array (..., bands) → (..., 3).

    In the unit of the input times nm (e.g. W·m⁻²·sr⁻¹ for radiance); multiply Y by
    683 lm/W for luminance in cd/m².  See :func:`rigsim.colorimetry.XYZ_from_bands`.
    """
    from rigsim.colorimetry import XYZ_from_bands

    return XYZ_from_bands(spectral, wavelength_nm, bandwidth_nm)


def srgb_preview(image: SpectralImage, *, exposure_s: float = 1.0, layer: str | None = None,
                 percentile: float = 99.0, level: float = 0.8, scale: float | None = None
                 ) -> tuple[np.ndarray, dict]:
    """An 8-bit sRGB picture of a spectral image as a colorimeter would see it (no camera).

    The radiant exposure (continuous × ``exposure_s`` + flash) is converted to CIE XYZ,
    white-balanced to nothing (D65 display white), scaled so that the ``percentile`` of Y
    maps to ``level`` (or by the given ``scale``), and encoded as sRGB (IEC 61966-2-1).

    Returns the (rows, cols, 3) uint8 image and a dict stating the exposure used.
    """
    import colour

    h = image.radiant_exposure(exposure_s, layer)
    xyz = xyz_from_spectral(h, image.wavelength_nm, image.bandwidth_nm)
    if scale is None:
        y = xyz[..., 1]
        ref = float(np.percentile(y[np.isfinite(y)], percentile)) if np.isfinite(y).any() else 0.0
        scale = level / ref if ref > 0 else 1.0
    rgb = colour.XYZ_to_sRGB(xyz * scale, apply_cctf_encoding=False)
    enc = colour.cctf_encoding(np.clip(rgb, 0, 1), function="sRGB")
    out = np.rint(np.clip(enc, 0, 1) * 255).astype(np.uint8)
    return out, {"exposure_s": exposure_s, "percentile": percentile, "level": level, "xyz_scale": scale,
                 "observer": "CIE 1931 2 degree", "note": "Y (in units of the radiant exposure x nm) times "
                 "xyz_scale maps to display white 1.0"}

"""Derived tables of a study: visibility range per rig × sensor × water × target."""

from __future__ import annotations

from collections import defaultdict

import numpy as np

from rigsim.metrics.visibility import visibility_range, visibility_range_se

__all__ = ["visibility_table", "GROUP_KEYS"]

#: Columns that identify a distance sweep.
GROUP_KEYS = ("rig", "sensor", "water", "target")


def visibility_table(rows: list[dict], threshold: float) -> list[dict]:
    """For each rig × sensor × water × target, the distance where contrast falls below
    ``threshold``, from the scene radiance (noise-free, ``contrast_radiance``) and from the
    developed image (``contrast_image``).

    Rows beyond the sweep (``extension``, the fast engine's steps: :mod:`rigsim.study.runner`)
    count like the others; ``sweep_max_m`` is the sweep's largest distance, ``searched_to_m`` the
    largest distance rendered (inf visibility: still visible there).  ``visibility_m_radiance_se``
    is the radiance range's standard error from the fast engine's photon noise in the two contrasts
    it is interpolated between (``contrast_radiance_se``, :func:`rigsim.study.case.contrast_photon_noise`;
    :func:`~rigsim.metrics.visibility.visibility_range_se`): NaN where a bracketing case has none (a
    Monte Carlo case, or one rendered before it was measured), 0 where neither has photons.
    """
    groups: dict[tuple, list[dict]] = defaultdict(list)
    for r in rows:
        groups[tuple(r.get(k) for k in GROUP_KEYS)].append(r)
    out = []
    for key, rs in groups.items():
        rs = sorted(rs, key=lambda r: r["distance_m"])
        d = np.array([r["distance_m"] for r in rs], float)
        rec = dict(zip(GROUP_KEYS, key))
        rec["threshold"] = threshold
        rec["n_distances"] = len(d)
        for col in ("contrast_radiance", "contrast_image"):
            c = np.array([r.get(col, np.nan) for r in rs], float)
            ok = np.isfinite(c)
            rng = visibility_range(d[ok], c[ok], threshold=threshold) if ok.sum() >= 2 else float("nan")
            rec[f"visibility_m_{col.split('_')[1]}"] = rng
            if col == "contrast_radiance":
                se = np.array([_photon_se(r) for r in rs], float)
                rec["visibility_m_radiance_se"] = (visibility_range_se(d[ok], c[ok], se[ok], threshold=threshold)
                                                   if ok.sum() >= 2 else float("nan"))
        rec["sweep_max_m"] = float(max((r["distance_m"] for r in rs if not r.get("extension")), default=np.nan))
        far = rs[-1].get("contrast_radiance")
        rec["contrast_at_searched_end"] = float(far) if far is not None else np.nan
        rec["searched_to_m"] = float(d.max())
        rec["c_550_per_m"] = rs[0].get("c_550_per_m")
        out.append(rec)
    return out


def _photon_se(row: dict) -> float:
    """A row's contrast standard error from the fast engine's photons: its ``contrast_radiance_se``; 0 for
    a fast-engine case that traced no photons (no multiple scattering: nothing random); NaN otherwise."""
    se = row.get("contrast_radiance_se")
    if se is not None and se == se:
        return float(se)
    if row.get("engine") == "preview" and row.get("ms_photons") == 0:
        return 0.0
    return float("nan")

"""Image-quality metrics as plain array functions (reference first, options keyword-only).

* :mod:`rigsim.metrics.contrast` — Michelson and Weber contrast, SNR per patch,
  backscatter share.
* :mod:`rigsim.metrics.color` — ΔE2000 of the ColorChecker (colour-science).
* :mod:`rigsim.metrics.mtf` — ISO 12233 slanted-edge MTF and MTF50.
* :mod:`rigsim.metrics.visibility` — visibility range from a distance sweep and the
  black-disk sighting range.
"""

from rigsim.metrics.color import delta_e_2000, chart_delta_e
from rigsim.metrics.contrast import (
    backscatter_share,
    contrast_michelson,
    contrast_weber,
    luminance,
    patch_snr,
)
from rigsim.metrics.mtf import mtf50, mtf_slanted_edge
from rigsim.metrics.visibility import black_disk_range_ZaneveldPegau2003, visibility_range, visibility_range_se

__all__ = [
    "delta_e_2000", "chart_delta_e", "backscatter_share", "contrast_michelson", "contrast_weber",
    "luminance", "patch_snr", "mtf50", "mtf_slanted_edge", "black_disk_range_ZaneveldPegau2003",
    "visibility_range",
    "visibility_range_se",
]

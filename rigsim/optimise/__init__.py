"""Strobe placement: rig + water + distance → a better rig (search over the fast engine, verified by render).

* :mod:`rigsim.optimise.space` — what may change (arms, aims, beams) within the rig's ``[limits]``.
* :mod:`rigsim.optimise.objective` — a placement's numbers (backscatter share, unevenness of the light
  on the subject, sensor SNR, ΔE2000, lit specks) and their weighted score.
* :mod:`rigsim.optimise.search` — :func:`optimise`: a Sobol look and a bounded Nelder–Mead refinement.
* :mod:`rigsim.optimise.output` — the optimised rig file, pictures, sensitivities, Monte Carlo check.
* :mod:`rigsim.optimise.sweep` — the optimum versus distance and water.
* :mod:`rigsim.optimise.diagram` — top view and view from behind of a rig before and after.
"""

from rigsim.optimise.objective import DEFAULT_WEIGHTS, Setting, Weights
from rigsim.optimise.search import Optimum, optimise

__all__ = ["optimise", "Optimum", "Setting", "Weights", "DEFAULT_WEIGHTS"]

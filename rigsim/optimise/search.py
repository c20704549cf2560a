"""The search: where a rig's lights should go for a :class:`~rigsim.optimise.objective.Setting`.

Method (deterministic for a seed):

1. **Global look** — a scrambled Sobol sequence (:class:`scipy.stats.qmc.Sobol`, ``seed``) of
   ``2^k`` placements over the whole :class:`~rigsim.optimise.space.Space`, plus the rig's own
   placement, each imaged by the fast engine at :data:`~rigsim.optimise.objective.SEARCH` fidelity
   (about 0.1 s each) and scored.  A placement a diver cannot use (inside the housing, a strobe in
   the picture) is refused.
2. **Local refinement** — bounded Nelder–Mead (:func:`scipy.optimize.minimize`, Gao & Han's adaptive
   coefficients) in the unit cube from the best placement found, with the beam (diffuser) held at
   that placement's choice; then each other beam choice is tried at the refined placement and refined
   in turn if it wins.  Nelder–Mead needs no gradients (the score of a rendered image has none) and
   moves by whole simplex steps, which the images' pixel-level steps do not trap.
3. The start and the optimum are then measured again at the finer
   :data:`~rigsim.optimise.objective.REPORT` fidelity, with the multiply scattered light where the water
   needs it, so the reported improvement is not the search's own estimate.

:func:`optimise` returns an :class:`Optimum` (typed, JSON-serialisable by :meth:`Optimum.record`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from rigsim.config.rigdoc import RigDoc
from rigsim.errors import ConfigError
from rigsim.optimise.objective import (
    DEFAULT_WEIGHTS,
    REPORT,
    SEARCH,
    Evaluation,
    Fidelity,
    Setting,
    Weights,
    evaluate,
)
from rigsim.optimise.space import Space

__all__ = ["Optimum", "optimise", "search", "Evaluator", "GLOBAL_POINTS", "LOCAL_EVALUATIONS"]

#: Placements of the global look (a power of two, as Sobol sequences balance best).
GLOBAL_POINTS = 64
#: Evaluations of each local refinement.
LOCAL_EVALUATIONS = 160
#: Score of a placement a diver cannot use (higher than any real score).
REFUSED = 1e3

ProgressCallback = Callable[[float, str], None]


class Evaluator:
    """Scores placements of a :class:`Space` in a :class:`Setting`, once each (cached by the rig file's
    own rounded values), with the water and sensor loaded once."""

    def __init__(self, space: Space, setting: Setting, weights: Weights = DEFAULT_WEIGHTS,
                 fidelity: Fidelity = SEARCH, seed: int = 0):
        from rigsim.sensor import load_sensor

        self.space, self.setting, self.weights, self.fidelity, self.seed = space, setting, weights, fidelity, seed
        self.water = setting.load_water()
        self.sensor = load_sensor(setting.sensor)
        self.cache: dict[str, tuple[float, Evaluation]] = {}
        self.calls = 0

    def doc(self, x: np.ndarray) -> RigDoc:
        return self.space.apply(x)

    def evaluation(self, doc: RigDoc, fidelity: Fidelity | None = None) -> Evaluation:
        """The numbers of a rig document (refused placements get ``infeasible``)."""
        why = self.space.feasible(doc)
        if why is not None:
            return Evaluation(metrics={}, engine="", seconds=0.0, infeasible=why)
        return evaluate(doc.rig(), self.setting, fidelity or self.fidelity, water=self.water, sensor=self.sensor,
                        seed=self.seed)

    def __call__(self, x: np.ndarray) -> float:
        try:
            doc = self.doc(x)
        except ConfigError:
            return REFUSED
        key = doc.to_toml()  # the rig file's own rounding (mm, 0.01 deg)
        hit = self.cache.get(key)
        if hit is None:
            self.calls += 1
            ev = self.evaluation(doc)
            score = REFUSED if ev.infeasible else ev.score(self.weights)
            hit = self.cache[key] = (score, ev)
        return hit[0]


@dataclass(frozen=True, eq=False)
class Optimum:
    """The result of :func:`optimise`.

    Attributes
    ----------
    setting, weights
        What was optimised for.
    space
        The searched parameters and limits.
    start_x, best_x
        The rig's own placement and the optimum, as points of ``space``.
    start_doc, best_doc
        The rig documents (``best_doc.to_toml()`` is the optimised rig file).
    start, best
        Their numbers at :data:`~rigsim.optimise.objective.REPORT` fidelity.
    start_search_score, best_search_score
        Their scores at the search's fidelity.
    evaluations, seconds
        Placements imaged by the search, and the wall time of the whole call (s).
    history
        ``(evaluation number, best search score so far)`` after each stage.
    seed
        The seed.
    """

    setting: Setting
    weights: Weights
    space: Space
    start_x: np.ndarray
    best_x: np.ndarray
    start_doc: RigDoc
    best_doc: RigDoc
    start: Evaluation
    best: Evaluation
    start_search_score: float
    best_search_score: float
    evaluations: int
    seconds: float
    history: tuple[tuple[int, float], ...] = ()
    seed: int = 0
    notes: tuple[str, ...] = field(default_factory=tuple)

    @property
    def improvement(self) -> float:
        """Relative drop of the score from the start to the optimum (REPORT fidelity; 0.25 = 25 % lower)."""
        s0, s1 = self.start.score(self.weights), self.best.score(self.weights)
        if not math.isfinite(s0) or s0 <= 0:
            return float("nan")
        return 1.0 - s1 / s0

    def record(self) -> dict:
        """The optimum as JSON-ready numbers, with ``code``: the rigsim code that found it
        (:func:`rigsim.code_version.code_version`)."""
        from dataclasses import asdict

        from rigsim.code_version import code_version

        return {
            "setting": asdict(self.setting), "weights": asdict(self.weights), "seed": self.seed,
            "parameters": [{"key": p.key, "light": p.light, "lo": p.lo, "hi": p.hi, "options": list(p.options)}
                           for p in self.space.parameters],
            "mirrored_pair": list(self.space.pair) if self.space.pair else None,
            "start_placement": self.space.describe_doc(self.start_doc),
            "best_placement": self.space.describe_doc(self.best_doc),
            "start": self.start.record(self.weights), "best": self.best.record(self.weights),
            "start_search_score": self.start_search_score, "best_search_score": self.best_search_score,
            "improvement": self.improvement, "evaluations": self.evaluations, "seconds": self.seconds,
            "history": [list(h) for h in self.history], "notes": list(self.notes), "code": code_version(),
        }


def _nelder_mead(fun, u0: np.ndarray, fixed: np.ndarray, free: np.ndarray, maxfev: int, step: float = 0.15):
    """Bounded Nelder–Mead over the ``free`` coordinates of the unit cube, the others at ``fixed``."""
    from scipy.optimize import minimize

    if not free.size:
        return u0, fun(u0)

    def f(v):
        u = fixed.copy()
        u[free] = v
        return fun(u)

    v0 = u0[free]
    simplex = [v0]
    for j in range(free.size):  # steps into the box (away from the nearer bound)
        v = v0.copy()
        v[j] = v0[j] + step if v0[j] + step <= 1.0 else v0[j] - step
        simplex.append(v)
    res = minimize(f, v0, method="Nelder-Mead", bounds=[(0.0, 1.0)] * free.size,
                   options={"maxfev": maxfev, "initial_simplex": np.array(simplex), "xatol": 2e-3, "fatol": 1e-4,
                            "adaptive": True})
    u = fixed.copy()
    u[free] = np.clip(res.x, 0.0, 1.0)
    return u, float(res.fun)


def search(space: Space, fun: Callable[[np.ndarray], float], *, seed: int = 0, global_points: int = GLOBAL_POINTS,
           local_evaluations: int = LOCAL_EVALUATIONS, progress: ProgressCallback | None = None,
           calls: Callable[[], int] | None = None) -> tuple[np.ndarray, float, float, list[tuple[int, float]]]:
    """Minimise ``fun(x)`` (``x`` a point of ``space``, in its units) by the module's method.

    Returns ``(best x, its value, the value at space.start(), history)``; ``fun`` is only ever called at
    points within the space's limits (the beam as an option index).  ``calls`` counts evaluations for the
    progress messages (default: calls of ``fun``).
    """
    from scipy.stats import qmc

    tick = progress or (lambda f, m: None)
    n_calls = [0]

    def f(u):
        n_calls[0] += 1
        return fun(space.from_unit(u))

    count = calls or (lambda: n_calls[0])
    beam = space.beam
    budget = global_points + local_evaluations * (1 + (len(beam.options) - 1 if beam else 0))
    u_start = space.to_unit(space.start())
    s_start = f(u_start)
    pts = qmc.Sobol(d=space.dim, scramble=True, seed=seed).random(max(2, int(global_points)))
    best_u, best_s = u_start, s_start
    for i, u in enumerate(pts):
        s = f(u)
        if s < best_s:
            best_u, best_s = u, s
        if i % 8 == 7:
            tick(count() / budget, f"global look: {i + 1}/{len(pts)} placements, best score {best_s:.4g}")
    history = [(count(), best_s)]
    free = np.array([j for j, p in enumerate(space.parameters) if not p.options and p.hi > p.lo], int)
    tick(count() / budget, "local refinement")
    snapped = space.to_unit(space.from_unit(best_u))
    u_loc, s_loc = _nelder_mead(f, snapped, snapped, free, local_evaluations)
    if s_loc <= best_s:
        best_u, best_s = u_loc, s_loc
    history.append((count(), best_s))
    if beam is not None:
        j = space.dim - 1
        current = space.from_unit(best_u)[j]
        for k in range(len(beam.options)):
            if k == int(round(current)):
                continue
            u = best_u.copy()
            u[j] = space.to_unit(np.where(np.arange(space.dim) == j, k, space.from_unit(best_u)))[j]
            tick(min(1.0, count() / budget), f"beam {beam.options[k]:g} deg")
            if f(u) < best_s:
                u2, s2 = _nelder_mead(f, u, u, free, local_evaluations)
                if s2 < best_s:
                    best_u, best_s = u2, s2
        history.append((count(), best_s))
    tick(1.0, "search done")
    return space.from_unit(best_u), float(best_s), float(s_start), history


def optimise(doc: RigDoc, setting: Setting, *, weights: Weights = DEFAULT_WEIGHTS, limits: dict | None = None,
             symmetric: bool | None = None, seed: int = 0, global_points: int = GLOBAL_POINTS,
             local_evaluations: int = LOCAL_EVALUATIONS, progress: ProgressCallback | None = None) -> Optimum:
    """Find the placement of ``doc``'s lights that minimises the score of ``weights`` in ``setting``.

    Parameters
    ----------
    doc
        The starting rig (:meth:`RigDoc.load`).
    setting
        Water, subject distance, sensor, subject, marine snow.
    weights
        The score's weights (:class:`~rigsim.optimise.objective.Weights`).
    limits
        :func:`~rigsim.optimise.space.limits_for` of the rig with the user's overrides (None: the rig's own).
    symmetric
        Mirror a pair of lights (None: when the rig is a pair).
    seed
        Seeds the Sobol scrambling (and the photograph's noise); the same inputs and seed give the same rig.
    global_points, local_evaluations
        The search's budget (see the module docstring).
    progress
        Called as ``progress(fraction_done, message)``.

    Raises
    ------
    ConfigError
        A rig without lights, limits that leave nothing to search, an unknown water or sensor.
    """
    t0 = time.perf_counter()
    tick = progress or (lambda f, m: None)
    space = Space.of(doc, limits=limits, symmetric=symmetric)
    ev = Evaluator(space, setting, weights, SEARCH, seed)
    x_start = space.start()
    best_x, best_s, s_start, history = search(space, ev, seed=seed, global_points=global_points,
                                              local_evaluations=local_evaluations,
                                              progress=lambda f, m: tick(0.8 * f, m), calls=lambda: ev.calls)
    if best_s >= REFUSED:
        raise ConfigError("no placement within the limits is usable (every one puts a light inside the housing "
                          "or in the picture)", file=doc.source, field="limits", allowed="wider limits")
    best_doc = space.apply(best_x)
    tick(0.8, "measuring the start and the optimum with multiple scattering")
    start_eval = ev.evaluation(doc, REPORT)
    best_eval = ev.evaluation(best_doc, REPORT)
    notes = []
    if start_eval.infeasible:
        notes.append(f"the starting rig is not usable as it is: {start_eval.infeasible}")
    best_final_score = best_eval.score(weights)
    if not start_eval.infeasible and best_final_score > start_eval.score(weights):
        notes.append("with multiple scattering the starting rig scores better than the search's optimum "
                     f"({start_eval.score(weights):.4g} against {best_final_score:.4g}): the rig is kept")
        best_x, best_doc, best_eval, best_s = x_start, doc, start_eval, s_start
    tick(1.0, "done")
    return Optimum(setting=setting, weights=weights, space=space, start_x=x_start, best_x=best_x, start_doc=doc,
                   best_doc=best_doc, start=start_eval, best=best_eval, start_search_score=s_start,
                   best_search_score=best_s, evaluations=ev.calls, seconds=time.perf_counter() - t0,
                   history=tuple(history), seed=seed, notes=tuple(notes))

"""Statistical helpers for Monte Carlo tests (χ² goodness of fit)."""

from __future__ import annotations

import numpy as np
from scipy import stats


def chi2_gof(samples: np.ndarray, edges: np.ndarray, expected_prob: np.ndarray, *,
             min_expected: float = 5.0) -> tuple[float, float]:
    """χ² goodness-of-fit of ``samples`` binned on ``edges`` (ascending) against the
    expected probabilities per bin.  Bins with fewer than ``min_expected`` expected
    counts are pooled with their neighbours (as Mitsuba's chi2 test does).

    Returns (statistic, p-value).
    """
    n = samples.size
    counts, _ = np.histogram(samples, bins=edges)
    exp = np.asarray(expected_prob, float) * n
    if abs(exp.sum() - n) > 1e-6 * n + 1e-9 or np.any(exp < 0):
        raise ValueError(f"expected probabilities sum to {exp.sum() / n}, not 1")
    # pool small bins
    obs_p, exp_p = [], []
    o_acc = e_acc = 0.0
    for o, e in zip(counts, exp):
        o_acc += o
        e_acc += e
        if e_acc >= min_expected:
            obs_p.append(o_acc)
            exp_p.append(e_acc)
            o_acc = e_acc = 0.0
    if e_acc > 0 or o_acc > 0:
        if exp_p:
            obs_p[-1] += o_acc
            exp_p[-1] += e_acc
        else:
            obs_p.append(o_acc)
            exp_p.append(e_acc)
    obs_p, exp_p = np.array(obs_p), np.array(exp_p)
    exp_p *= obs_p.sum() / exp_p.sum()
    res = stats.chisquare(obs_p, exp_p)
    return float(res.statistic), float(res.pvalue)

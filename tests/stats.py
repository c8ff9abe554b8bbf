"""Statistical helpers shared by the tests: chi-square goodness of fit with pooling."""

from __future__ import annotations

import numpy as np
from scipy import stats

SIGNIFICANCE = 0.01


def sidak(alpha: float, tests: int) -> float:
    """Per-test level so that `tests` independent tests keep family-wise level alpha."""
    return 1.0 - (1.0 - alpha) ** (1.0 / tests)


def chi2_test(observed: np.ndarray, expected: np.ndarray, min_expected: float = 5.0):
    """Pearson chi-square with cells of low expected count pooled (Mitsuba's recipe).

    Returns (p_value, dof). Cells with expected < min_expected are merged into one.
    """
    obs = np.asarray(observed, float).ravel()
    exp = np.asarray(expected, float).ravel()
    order = np.argsort(exp)
    obs, exp = obs[order], exp[order]
    low = exp < min_expected
    pooled_o, pooled_e = obs[low].sum(), exp[low].sum()
    obs, exp = obs[~low], exp[~low]
    if pooled_e > 0:
        obs, exp = np.append(obs, pooled_o), np.append(exp, pooled_e)
    if np.any((exp == 0) & (obs > 0)):
        return 0.0, len(exp) - 1
    keep = exp > 0
    chi2 = float(np.sum((obs[keep] - exp[keep]) ** 2 / exp[keep]))
    dof = int(keep.sum()) - 1
    return float(stats.chi2.sf(chi2, dof)), dof


def histogram_2d(points: np.ndarray, lo, hi, res: int) -> np.ndarray:
    h, _, _ = np.histogram2d(points[:, 0], points[:, 1], bins=res,
                             range=[[lo[0], hi[0]], [lo[1], hi[1]]])
    return h


def expected_2d(pdf, lo, hi, res: int, n: int, sub: int = 16) -> np.ndarray:
    """Expected counts per cell: n x integral of pdf over each cell (midpoint rule on a
    sub x sub grid per cell)."""
    xs = np.linspace(lo[0], hi[0], res * sub + 1)
    ys = np.linspace(lo[1], hi[1], res * sub + 1)
    xm, ym = 0.5 * (xs[1:] + xs[:-1]), 0.5 * (ys[1:] + ys[:-1])
    X, Y = np.meshgrid(xm, ym, indexing="ij")
    dens = pdf(np.column_stack([X.ravel(), Y.ravel()])).reshape(X.shape)
    cell = (xs[1] - xs[0]) * (ys[1] - ys[0])
    return n * dens.reshape(res, sub, res, sub).sum(axis=(1, 3)) * cell

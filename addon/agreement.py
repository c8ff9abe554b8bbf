"""Do two renders of one scene agree? A block z-test with a Sidak-corrected threshold.

Specula gives one image S with an estimate of each pixel's variance of the mean (from the
spread of its R replicates). Cycles gives K >= 2 images C_1..C_K of the same scene with
independent seeds; their mean C has the variance s^2 / K per pixel, s^2 the sample variance
over the K runs (K - 1 degrees of freedom per pixel).

For every block of pixels, of several shapes (BLOCK_SHAPES), and every colour channel:

    D = sum_block(S) - sum_block(C)
    V = sum_block(var_S) + sum_block(s^2 / K)
    t = D / sqrt(V)

Pixels are independent in both renderers, so V is the variance of D. Cycles' part of V has
only (K - 1) x pixels degrees of freedom, so t is referred to Student's t with the
Welch-Satterthwaite degrees of freedom (Specula's variance comes from its R replicates,
R - 1 degrees of freedom per pixel). Small blocks find local, sign-changing differences (a
defocus edge, a bokeh outline); large blocks find small, widespread ones (a few % of
light). Every (scale, block, channel) is one test; the images agree when no test's
two-sided p-value falls below the Sidak level for the whole family at `alpha`.

Where both engines are noise-free, a per-pixel tolerance of REL_TOLERANCE x value (as a
standard deviation) stands in for the variance; see its comment.

Specula's variance is its replicate estimate, calibrated against its measured error
(tests/benchmarks/calibration.py). The test's power is checked by rendering deliberately
wrong images (tests/cycles/test_power.py).

Used by `python -m addon compare` (addon/compare.py) and by the agreement tests
(tests/cycles/compare.py re-exports it). Needs scipy (Student's t and the normal
distribution); the packaged add-on does not ship it, so only the command and the tests
import this module.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import stats

ALPHA = 1e-3
# Block shapes (rows, columns): squares at three scales, and one-pixel rows 16 long, which
# follow a long horizontal edge (a defocus profile alternates sign across the edge, so a
# square block straddling it would cancel). Column strips (16, 1) were tried too: they
# flagged caustic fireflies on the Cornell box ceiling (heavy tails that 16 pixels do not
# average out; max |z| 5.3-5.8 on mat_mirror, mat_glass_tinted, mat_principled_metal), so
# they are left out.
BLOCK_SHAPES = ((4, 4), (8, 8), (16, 16), (1, 16))
# Per-pixel differences this small relative to the pixel's value are not flagged even where
# both engines are noise-free (a convex object lit by a constant world; the background).
# Specula samples Cycles' own filter table now (film.cycles_filter_table; before, random
# scenes with bright silhouettes disagreed at |z| 5-16), yet with 1e-4 the default scenes
# still disagree (|z| 7.8, 13.4) at isolated background pixels beside the cube where both
# engines are noise-free and Cycles is lower by one sample's worth in both seeds
# (1/128 of the edge contrast); not explained yet. Added to the block variance as an
# independent per-pixel standard deviation.
REL_TOLERANCE = 0.005


@dataclass
class Comparison:
    """The outcome of `compare`.

    agree : no test rejected. p_min : smallest two-sided p-value. p_sidak : the per-test
    level. max_z : the normal-equivalent |z| of p_min (what a Gaussian z would be for the
    same p); z_threshold : the same for p_sidak. worst : (block size, row, column, channel)
    of p_min, in blocks of that size. tests : how many tests in the family.
    rel_rmse : RMS of (S - C) over RMS of C, a plain image difference for reports.
    per_scale : block size -> max normal-equivalent |z| at that scale.
    """

    agree: bool
    p_min: float
    p_sidak: float
    max_z: float
    z_threshold: float
    worst: tuple
    tests: int
    rel_rmse: float
    per_scale: dict = field(default_factory=dict)

    def worst_pixels(self, height: int, width: int) -> tuple[int, int, int, int]:
        """The worst block as pixels (x0, y0, x1, y1), x1 and y1 exclusive, with row 0 at
        the TOP (as image viewers count), clipped to the image."""
        (bh, bw), r, c, _ = self.worst
        # Blocks count rows from the bottom (renders are stored bottom-up).
        y0_bottom, x0 = r * bh, c * bw
        y1_bottom, x1 = min(y0_bottom + bh, height), min(x0 + bw, width)
        return x0, height - y1_bottom, x1, height - y0_bottom

    def describe(self) -> str:
        verdict = "agree" if self.agree else "DISAGREE"
        (bh, bw), r, c, ch = self.worst
        return (f"{verdict}: max |z| {self.max_z:.2f} (threshold {self.z_threshold:.2f}, "
                f"{self.tests} tests, worst {bh}x{bw} block ({r}, {c}) channel {'RGB'[ch]}); "
                f"per scale {', '.join(f'{k}:{v:.1f}' for k, v in self.per_scale.items())}; "
                f"relative RMSE {self.rel_rmse:.4f}")


def block_sums(image: np.ndarray, b) -> np.ndarray:
    """Sum (H, W, C) over blocks of b = (rows, columns) pixels (an int: square); the last
    row/column of blocks may be partial."""
    bh, bw = (b, b) if np.isscalar(b) else b
    h, w = image.shape[:2]
    rows = np.add.reduceat(image, np.arange(0, h, bh), axis=0)
    return np.add.reduceat(rows, np.arange(0, w, bw), axis=1)


def _normal_equivalent(p):
    """|z| of a two-sided normal test with p-value p (inf for p = 0)."""
    return float(stats.norm.isf(np.maximum(p, 1e-300) / 2.0)) if p > 0 else float("inf")


def compare(specula: np.ndarray, specula_var: np.ndarray, cycles_runs: np.ndarray,
            alpha: float = ALPHA, block_shapes=BLOCK_SHAPES,
            specula_dof: float = math.inf) -> Comparison:
    """Compare Specula's image with K independent Cycles images of the same scene.

    specula : (H, W, 3) mean image; specula_var : (H, W, 3) variance of each pixel's mean
    cycles_runs : (K, H, W, 3) images from K >= 2 seeds
    specula_dof : degrees of freedom of each pixel's variance (RenderResult.dof: its
        replicates - 1); inf treats Specula's variance as known
    """
    s = np.asarray(specula, np.float64)[..., :3]
    vs = np.asarray(specula_var, np.float64)[..., :3]
    runs = np.asarray(cycles_runs, np.float64)[..., :3]
    k = len(runs)
    if k < 2:
        raise ValueError(f"need at least two Cycles runs for their variance, got {k}")
    if runs.shape[1:] != s.shape or vs.shape != s.shape:
        raise ValueError(f"shape mismatch: Specula {s.shape}, variance {vs.shape}, "
                         f"Cycles {runs.shape}")
    c = runs.mean(axis=0)
    vc = runs.var(axis=0, ddof=1) / k
    dof_c_pixel = k - 1
    tol_var = (REL_TOLERANCE * 0.5 * (np.abs(s) + np.abs(c))) ** 2

    p_values, where, per_scale = [], [], {}
    for b in block_shapes:
        d = block_sums(s - c, b)
        v_s, v_c = block_sums(vs, b), block_sums(vc, b)
        n_pix = block_sums(np.ones(s.shape[:2] + (1,)), b)
        var = v_s + v_c + block_sums(tol_var, b)
        # Welch-Satterthwaite over both engines' variance estimates.
        specula_part = 0.0 if math.isinf(specula_dof) else v_s ** 2 / (specula_dof * n_pix)
        dof = var ** 2 / np.maximum(v_c ** 2 / (dof_c_pixel * n_pix) + specula_part, 1e-300)
        dof = np.clip(dof, 1.0, 1e6)
        t = np.abs(d) / np.sqrt(np.maximum(var, 1e-300))
        t = np.where(var > 0, t, np.where(d == 0, 0.0, np.inf))
        p = 2.0 * stats.t.sf(t, dof)
        p_values.append(p.ravel())
        idx = np.indices(p.shape).reshape(3, -1).T
        where.extend((b, int(r), int(q), int(ch)) for r, q, ch in idx)
        per_scale[f"{b[0]}x{b[1]}"] = _normal_equivalent(float(p.min()))
    p_all = np.concatenate(p_values)
    m = len(p_all)
    p_sidak = 1.0 - (1.0 - alpha) ** (1.0 / m)
    i = int(np.argmin(p_all))
    rms_c = np.sqrt(np.mean(c ** 2))
    rel = float(np.sqrt(np.mean((s - c) ** 2)) / rms_c) if rms_c > 0 else float("nan")
    return Comparison(agree=bool(p_all[i] >= p_sidak), p_min=float(p_all[i]),
                      p_sidak=float(p_sidak), max_z=_normal_equivalent(float(p_all[i])),
                      z_threshold=_normal_equivalent(p_sidak), worst=where[i], tests=m,
                      rel_rmse=rel, per_scale=per_scale)

"""Film: the pixel filter and the per-pixel running statistics.

Cycles importance-samples its pixel filter instead of splatting: a sample's raster
offset is drawn from the filter's density and the sample counts, with weight 1, in the
pixel it was generated for. The pixel value is the mean of its samples, so every pixel
carries a running mean and variance (Welford) from which the per-pixel standard error
and the image's estimated relative error follow.
"""

from __future__ import annotations

import math
from collections import namedtuple
from dataclasses import dataclass

import numpy as np

from .jit import INLINE, JIT, njit
from .sampling import guided_interp, interp_guide
from .scene import LUMINANCE

# Depth written where a camera ray escapes: finite, so no pass ever holds inf.
BACKGROUND_DEPTH = 1e10
_TABLE_SIZE = 1024


class PixelFilter:
    """A separable pixel filter sampled through Cycles' inverse-CDF table.

    kind : "BLACKMAN_HARRIS" (support +-width, Cycles doubles the width internally),
    "BOX" (support +-width/2) or "GAUSSIAN" (sigma width/4, truncated at +-1.5 width).
    `offset(u, table)` maps u in [0,1) to a raster offset from the pixel centre, through
    the same 1024-entry table as Cycles (`cycles_filter_table`), quirks included:
    the sampled density is the filter's to within a table step, except that 1/1023 of the
    samples lands between +radius and -0.5 px. `density` is the filter itself.
    """

    def __init__(self, kind: str = "BLACKMAN_HARRIS", width: float = 1.5):
        self.kind, self.width = kind, float(width)
        self.radius = {"BLACKMAN_HARRIS": self.width, "BOX": 0.5 * self.width,
                       "GAUSSIAN": 1.5 * self.width}[kind]
        # Cycles' own inverse-CDF table (film.cpp filter_table, util_cdf_inverted), read
        # by linear interpolation as its lookup_table_read: knots u = k / 1023.
        self._cdf = np.arange(_TABLE_SIZE) / (_TABLE_SIZE - 1.0)
        self._x = cycles_filter_table(self) - 0.5

    def density(self, d: np.ndarray) -> np.ndarray:
        """Unnormalised 1D filter density at offset d from the pixel centre."""
        d = np.asarray(d, np.float64)
        inside = np.abs(d) <= self.radius
        if self.kind == "BOX":
            return inside.astype(np.float64)
        if self.kind == "GAUSSIAN":
            return np.where(inside, np.exp(-8.0 * d * d / (self.width * self.width)), 0.0)
        phi = 2.0 * np.pi * (d / (2.0 * self.width) + 0.5)
        bh = 0.35875 - 0.48829 * np.cos(phi) + 0.14128 * np.cos(2 * phi) - 0.01168 * np.cos(3 * phi)
        return np.where(inside, np.maximum(bh, 0.0), 0.0)

    def table(self) -> "FilterTable":
        return FilterTable(self._cdf, self._x, interp_guide(self._cdf))


# The filter's inverse CDF as the kernel reads it: knots u (k,), offsets x (k,), and the
# guide of sampling.guided_interp.
FilterTable = namedtuple("FilterTable", "u x guide")


@njit(**INLINE)
def filter_offset(u, table):
    """A raster offset from the pixel centre, drawn from the filter's density by u."""
    return guided_interp(u, table.u, table.x, table.guide)


def cycles_filter_table(f: PixelFilter) -> np.ndarray:
    """Cycles' 1024-entry filter table for f: raster offsets + 0.5 at u = k / 1023.

    As film.cpp builds it: the filter evaluated on its positive half (Cycles' width is
    doubled for Blackman-Harris, tripled for Gaussian), a left Riemann sum for the CDF,
    inverted symmetrically about the centre with upper_bound and the next interval's
    slope, and the last entry never written (0), so u in the top 1/1023 maps between
    +radius and -0.5 px. Replicated because it decides how much of a bright neighbour a
    silhouette pixel picks up."""
    size = _TABLE_SIZE
    width = f.width * {"BLACKMAN_HARRIS": 2.0, "GAUSSIAN": 3.0, "BOX": 1.0}[f.kind]
    half = 0.5 * width
    x = half * np.arange(size - 1) / (size - 2.0)
    if f.kind == "BOX":
        y = np.ones_like(x)
    elif f.kind == "GAUSSIAN":
        v = x * (6.0 / width)
        y = np.exp(-2.0 * v * v)
    else:
        v = 2.0 * np.pi * (x / width + 0.5)
        y = 0.35875 - 0.48829 * np.cos(v) + 0.14128 * np.cos(2 * v) - 0.01168 * np.cos(3 * v)
    cdf = np.concatenate([[0.0], np.cumsum(np.abs(y))])
    cdf = cdf / cdf[-1]
    cdf[-1] = 1.0
    table = np.zeros(size)
    half_size = (size - 1) // 2
    for i in range(half_size + 1):
        u = i / half_size
        index = int(np.searchsorted(cdf, u, side="right"))
        if index < len(cdf) - 1:
            t = (u - cdf[index]) / (cdf[index + 1] - cdf[index])
        else:
            t, index = 0.0, len(cdf) - 1
        y_i = ((index + t) / (size - 1)) * width
        table[half_size + i] = 0.5 * (1.0 + y_i)
        table[half_size - i] = 0.5 * (1.0 - y_i)
    return table


@dataclass
class Pass:
    """What a caller sees after each pass of a render (and what `render` returns).

    combined : (H, W, 4) float32 linear RGBA, row 0 at the bottom (Blender's order)
    depth : (H, W) float32 mean camera z-depth of the first hit (BACKGROUND_DEPTH where
        nothing is hit)
    normal : (H, W, 3) float32 mean world-space shading normal of the first hit
    error : (H, W) float32 estimated standard error of each pixel's luminance
    variance : (H, W, 3) float32 estimated variance of each pixel's mean, per channel
    samples : samples per pixel so far; seconds : wall time since the render began
    relative_error : estimated relative RMS error of the image (see Film)
    progress : fraction of the sample budget done
    """

    combined: np.ndarray
    depth: np.ndarray
    normal: np.ndarray
    error: np.ndarray
    variance: np.ndarray
    samples: int
    seconds: float
    relative_error: float
    progress: float


class Film:
    """Per-pixel running mean and variance of radiance, plus Depth and Normal passes.

    Pixels are indexed row-major from the bottom row (Blender's order): index = y * W + x.
    `add` folds one sample per pixel of a chunk into the statistics.
    """

    def __init__(self, width: int, height: int):
        self.width, self.height = width, height
        n = width * height
        self.count = np.zeros(n, np.int32)
        self.mean = np.zeros((n, 3), np.float64)
        # Sums of squared deviations per channel (Welford); float32 keeps a 4K film small.
        self.m2 = np.zeros((n, 3), np.float32)
        self.m2_luminance = np.zeros(n, np.float64)
        self.depth = np.zeros(n, np.float32)
        self.normal = np.zeros((n, 3), np.float32)
        self.rejected: list[str] = []

    def add(self, pixels, radiance, depth, normal, rejected=None) -> None:
        """Fold one sample for each pixel in `pixels` (n,) into the running statistics
        (Welford): radiance (n, 3), first-hit depth (n,) and normal (n, 3). Updating per
        chunk keeps temporaries the size of a chunk, not of the image. Samples with a
        non-finite radiance, depth or normal are left out; the integrator names their stage
        in `rejected`."""
        if rejected:
            self.rejected.extend(rejected)
        _welford(pixels, radiance, depth, normal, self.count, self.mean, self.m2,
                 self.m2_luminance, self.depth, self.normal, LUMINANCE)

    def check_finite(self, sample: int) -> None:
        """Raise if any pass holds NaN or inf, naming the first bad pixel."""
        for name, arr in (("combined", self.mean), ("depth", self.depth),
                          ("normal", self.normal), ("error", self.m2),
                          ("error", self.m2_luminance)):
            # One compiled pass, no temporaries: this runs after every pass.
            i = _first_nonfinite_row(arr.reshape(len(self.count), -1))
            if i >= 0:
                raise FloatingPointError(
                    f"non-finite value in the {name} pass at pixel (x={i % self.width}, "
                    f"y={i // self.width}) after sample {sample}")

    def relative_error(self) -> float:
        """Estimated relative RMS error of the image: RMS standard error / mean luminance."""
        return self.statistics()[2]

    def statistics(self) -> tuple[np.ndarray, np.ndarray, float]:
        """Each pixel's estimated standard error of its mean luminance (n,) and variance of
        its mean per channel (n, 3), as float32, and the image's estimated relative RMS
        error: after every pass of a progressive render, so one compiled pass over the
        film (a 1920x1080 film: ~120 ms a pass in numpy)."""
        n = len(self.count)
        error, variance = np.empty(n, np.float32), np.empty((n, 3), np.float32)
        sum_e2, sum_y, most = _statistics(self.count, self.mean, self.m2, self.m2_luminance,
                                          LUMINANCE, error, variance)
        rel = float("inf") if most < 2 else _relative(sum_e2 / n, sum_y / n)
        return error, variance, rel

    def snapshot(self, samples: int, seconds: float, progress: float, stats=None):
        """The film as a Pass; `stats` from `statistics()` if the caller has them."""
        error, variance, rel = stats if stats is not None else self.statistics()
        h, w = self.height, self.width
        rgba = np.ones((h, w, 4), np.float32)
        rgba[..., :3] = self.mean.reshape(h, w, 3)
        return Pass(combined=rgba, depth=self.depth.reshape(h, w).copy(),
                    normal=self.normal.reshape(h, w, 3).copy(), error=error.reshape(h, w),
                    variance=variance.reshape(h, w, 3), samples=samples, seconds=seconds,
                    relative_error=rel if np.isfinite(rel) else -1.0, progress=min(progress, 1.0))


def _relative(mean_error2: float, mean_luminance: float) -> float:
    """RMS standard error over mean luminance (0 for a black image)."""
    if mean_luminance <= 0:
        return 0.0
    return float(np.sqrt(mean_error2) / mean_luminance)


@njit(**JIT)
def _welford(pixels, radiance, depth, normal, count, mean, m2, m2_luminance, depth_acc,
             normal_acc, lum):
    """Film.add: Welford's update per sample (float32 where the film stores float32);
    releases the GIL, so worker threads fold their own chunks."""
    f32 = np.float32
    for i in range(len(pixels)):
        r0, r1, r2, z = radiance[i, 0], radiance[i, 1], radiance[i, 2], depth[i]
        if not (np.isfinite(r0) and np.isfinite(r1) and np.isfinite(r2) and np.isfinite(z)
                and np.isfinite(normal[i, 0]) and np.isfinite(normal[i, 1])
                and np.isfinite(normal[i, 2])):
            continue
        p = pixels[i]
        n = count[p] + 1
        count[p] = n
        d0, d1, d2 = r0 - mean[p, 0], r1 - mean[p, 1], r2 - mean[p, 2]
        mean[p, 0] += d0 / n
        mean[p, 1] += d1 / n
        mean[p, 2] += d2 / n
        a0, a1, a2 = r0 - mean[p, 0], r1 - mean[p, 1], r2 - mean[p, 2]
        m2[p, 0] += f32(d0 * a0)
        m2[p, 1] += f32(d1 * a1)
        m2[p, 2] += f32(d2 * a2)
        m2_luminance[p] += ((d0 * lum[0] + d1 * lum[1] + d2 * lum[2])
                            * (a0 * lum[0] + a1 * lum[1] + a2 * lum[2]))
        w = f32(1.0 / n)
        depth_acc[p] += w * (f32(z) - depth_acc[p])
        for c in range(3):
            normal_acc[p, c] += w * (f32(normal[i, c]) - normal_acc[p, c])


@njit(**JIT)
def _statistics(count, mean, m2, m2_luminance, lum, error, variance):
    """Each pixel's standard error of its mean luminance into error (n,) and variance of its
    mean into variance (n, 3) float32 (0 below 2 samples); returns the sums of squared
    errors and of mean luminances and the largest sample count, for the relative error."""
    f32 = np.float32
    sum_e2 = 0.0
    sum_y = 0.0
    most = 0
    for i in range(len(count)):
        c = count[i]
        most = max(most, c)
        n = f32(c)
        if n > 1:
            d = max(n * (n - f32(1)), f32(1.0))
            for j in range(3):
                variance[i, j] = m2[i, j] / d
        else:
            for j in range(3):
                variance[i, j] = f32(0.0)
        v = 0.0
        n64 = float(c)
        if n64 > 1:
            v = m2_luminance[i] / max(n64 * (n64 - 1), 1.0)
        e = math.sqrt(max(v, 0.0))
        error[i] = f32(e)
        sum_e2 += e * e
        sum_y += mean[i, 0] * lum[0] + mean[i, 1] * lum[1] + mean[i, 2] * lum[2]
    return sum_e2, sum_y, most


@njit(**JIT)
def _first_nonfinite_row(rows):
    """Index of the first row of (n, k) `rows` holding NaN or inf, or -1."""
    for i in range(rows.shape[0]):
        for j in range(rows.shape[1]):
            if not np.isfinite(rows[i, j]):
                return i
    return -1

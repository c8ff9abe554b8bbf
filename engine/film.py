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

from .jit import ALLOCATING, INLINE, JIT, njit
from .sampling import guided_interp, interp_guide
from .scene import LUMINANCE

# Depth written where a camera ray escapes: finite, so no pass ever holds inf.
BACKGROUND_DEPTH = 1e10
_TABLE_SIZE = 1024
# The half-width in pixels of the neighbourhood a pixel's error is pooled over
# (_pool_variance); 0 leaves every pixel its own estimate.
POOL_RADIUS = 1
# How many times its neighbourhood's mean independent-sample variance a pixel's must be for
# the pixel to count as standing out (_pool_variance).
STANDS_OUT = 2.0


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


@njit(**INLINE)
def filter_density(d, table):
    """The density with which `filter_offset` draws raster offset d (one axis): exactly the
    table's, so a contribution splatted with it (light tracing) lands in each pixel as a
    camera sample would. The table is linear between knots u = k / (n - 1), so a segment
    between x_k and x_k+1 has density 1 / ((n - 1) (x_k+1 - x_k)); the last segment runs
    backwards (Cycles' unwritten last entry) over [x_n-1, x_n-2]."""
    xs = table.x
    n = len(xs)
    step = 1.0 / (n - 1)
    out = 0.0
    if xs[0] <= d < xs[n - 2]:
        lo, hi = 0, n - 2  # xs[lo] <= d < xs[hi]
        while hi - lo > 1:
            mid = (lo + hi) >> 1
            if xs[mid] <= d:
                lo = mid
            else:
                hi = mid
        out = step / (xs[hi] - xs[lo])
    a, b = min(xs[n - 2], xs[n - 1]), max(xs[n - 2], xs[n - 1])
    if a <= d <= b and b > a:
        out += step / (b - a)
    return out


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


# Two-sided 95% quantiles of Student's t for 1..30 degrees of freedom (t_{0.975, nu}).
_T95 = (12.7062, 4.3027, 3.1824, 2.7764, 2.5706, 2.4469, 2.3646, 2.3060, 2.2622, 2.2281,
        2.2010, 2.1788, 2.1604, 2.1448, 2.1314, 2.1199, 2.1098, 2.1009, 2.0930, 2.0860,
        2.0796, 2.0739, 2.0687, 2.0639, 2.0595, 2.0555, 2.0518, 2.0484, 2.0452, 2.0423)
_Z975 = 1.959963984540054


def t95(dof: int) -> float:
    """t_{0.975, dof}: the half-width of a 95% interval in standard errors, for a variance
    estimated with `dof` degrees of freedom (inf for none)."""
    if dof < 1:
        return float("inf")
    if dof <= len(_T95):
        return _T95[dof - 1]
    # Cornish-Fisher expansion of t around the normal quantile (Abramowitz & Stegun
    # 26.7.5); within 1e-4 of the exact value from 31 degrees of freedom on.
    z, v = _Z975, float(dof)
    return (z + (z ** 3 + z) / (4 * v) + (5 * z ** 5 + 16 * z ** 3 + 3 * z) / (96 * v * v)
            + (3 * z ** 7 + 19 * z ** 5 + 17 * z ** 3 - 15 * z) / (384 * v ** 3))


def _chi2_quantile(p_z: float, dof: float) -> float:
    """The chi-square quantile with `dof` degrees of freedom at the normal quantile p_z
    (Wilson-Hilferty: chi2/dof is nearly normal after a cube root)."""
    c = 2.0 / (9.0 * dof)
    return dof * max(1.0 - c + p_z * math.sqrt(c), 0.0) ** 3


@dataclass
class Estimate:
    """The film's image and how far it may be from the image it converges to.

    Samples come in R independent replicates (independently scrambled copies of the
    sample sequence, see `Film`), so the spread of a pixel's R replicate means is an
    unbiased estimate of the variance of their mean, with R - 1 degrees of freedom, whatever
    the sequence's own convergence rate.

    combined : (n, 3) float32 each pixel's value: the sample-count-weighted mean of its
        replicate means
    error : (n,) float32 estimated standard error of each pixel's luminance, pooled over
        the pixel's neighbourhood (see _pool_variance): its 95% interval is value +- t95 x
        error
    variance : (n, 3) float32 estimated variance of each pixel's value, per channel, pooled
        the same way
    dof : degrees of freedom of each pixel's own variance (replicates with samples - 1, at
        least in every pixel); t95 the 95% half-width in pooled standard errors
    relative_error : estimated relative RMS error of the image: RMS standard error of the
        luminance over the mean luminance (-1 until it can be estimated)
    interval : (low, high) 95% interval of relative_error (normal theory, Satterthwaite's
        degrees of freedom for the sum of the pixels' variances)
    independent_relative_error : the same from the samples' own spread as if they were
        independent, what Specula reported before replicates (it overstates the error of
        stratified samples); kept for comparison
    """

    combined: np.ndarray
    error: np.ndarray
    variance: np.ndarray
    dof: int
    t95: float
    relative_error: float
    interval: tuple
    independent_relative_error: float


@dataclass
class Pass:
    """What a caller sees after each pass of a render (and what `render` returns).

    combined : (H, W, 4) float32 linear RGBA, row 0 at the bottom (Blender's order)
    depth : (H, W) float32 mean camera z-depth of the first hit (BACKGROUND_DEPTH where
        nothing is hit)
    normal : (H, W, 3) float32 mean world-space shading normal of the first hit
    error : (H, W) float32 estimated standard error of each pixel's luminance; a pixel's
        95% interval is its value +- t95 x error
    variance : (H, W, 3) float32 estimated variance of each pixel's mean, per channel
    samples : samples per pixel so far; seconds : wall time since the render began
    relative_error : estimated relative RMS error of the image (see Estimate); -1 when
        it cannot be estimated yet (fewer than two replicates with samples)
    error_interval : its 95% interval (low, high)
    dof, t95 : degrees of freedom of the per-pixel variances, and the t quantile
    independent_relative_error : the estimate before replicates (see Estimate)
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
    error_interval: tuple = (-1.0, -1.0)
    dof: int = 0
    t95: float = float("inf")
    independent_relative_error: float = -1.0


class Film:
    """Per-pixel, per-replicate running means of radiance, plus Depth and Normal passes.

    replicates : the replicate ids this film holds (a render of replicates 4-7 of 8 holds
        (4, 5, 6, 7)); a sample is folded into the slot of its replicate. Each slot keeps
        its sample count, its mean (float32) and its samples' sums of squared deviations
        (Welford; R, G, B and luminance, float32). These are all the image and its error
        are made of, so films of disjoint replicate sets merge into exactly the film of
        their union (`estimate` over the gathered slots; addon/merge.py).
    With a transparent film (`transparent`), each slot also keeps the running mean of its
    samples' transparency (Cycles' film_write_transparent: the average throughput of a
    camera path that reaches the world straight or through transparent surfaces), from
    which the pixel's alpha follows (`alpha`); like the means, it merges exactly.
    Pixels are indexed row-major from the bottom row (Blender's order): index = y * W + x.
    """

    def __init__(self, width: int, height: int, replicates=(0,), transparent: bool = False):
        self.width, self.height = width, height
        self.replicates = tuple(int(r) for r in replicates)
        n, m = width * height, len(self.replicates)
        self.count = np.zeros(n, np.int32)
        self.replicate_count = np.zeros((n, m), np.int32)
        self.replicate_mean = np.zeros((n, m, 3), np.float32)
        self.replicate_m2 = np.zeros((n, m, 4), np.float32)
        self.transparent = bool(transparent)
        self.replicate_transparency = np.zeros((n, m) if transparent else (0, 0), np.float32)
        self.depth = np.zeros(n, np.float32)
        self.normal = np.zeros((n, 3), np.float32)
        self.rejected: list[str] = []

    def add(self, pixels, slot, radiance, depth, normal, rejected=None,
            transparency=None) -> None:
        """Fold one sample for each pixel in `pixels` (n,), all of replicate slot `slot`,
        into the running statistics: radiance (n, 3), first-hit depth (n,) and normal
        (n, 3), and with a transparent film the transparency (n,). Updating per chunk keeps
        temporaries the size of a chunk, not of the image. Samples with a non-finite value
        are left out; the integrator names their stage in `rejected`."""
        if rejected:
            self.rejected.extend(rejected)
        if not self.transparent or transparency is None:
            transparency = _NO_TRANSPARENCY
        _welford(pixels, slot, radiance, depth, normal, transparency, self.count,
                 self.replicate_count, self.replicate_mean, self.replicate_m2,
                 self.replicate_transparency, self.depth, self.normal, LUMINANCE)

    def check_finite(self, sample: int) -> None:
        """Raise if any pass holds NaN or inf, naming the first bad pixel."""
        n = len(self.count)
        for name, arr in (("combined", self.replicate_mean), ("depth", self.depth),
                          ("normal", self.normal), ("error", self.replicate_m2),
                          ("alpha", self.replicate_transparency)):
            # One compiled pass, no temporaries: this runs after every pass.
            if arr.size == 0:
                continue
            i = _first_nonfinite_row(arr.reshape(n, -1))
            if i >= 0:
                raise FloatingPointError(
                    f"non-finite value in the {name} pass at pixel (x={i % self.width}, "
                    f"y={i // self.width}) after sample {sample}")

    def estimate(self) -> Estimate:
        """The image, each pixel's standard error and variance, and the image's relative
        error with its interval: after every pass a caller reads, so compiled passes over
        the film."""
        return estimate(self.replicate_count, self.replicate_mean, self.replicate_m2,
                        (self.height, self.width))

    def snapshot(self, samples: int, seconds: float, progress: float, est=None) -> Pass:
        """The film as a Pass; `est` from `estimate()` if the caller has it."""
        est = est if est is not None else self.estimate()
        h, w = self.height, self.width
        rgba = np.ones((h, w, 4), np.float32)
        rgba[..., :3] = est.combined.reshape(h, w, 3)
        if self.transparent:
            rgba[..., 3] = alpha(self.replicate_count, self.replicate_transparency).reshape(h, w)
        return Pass(combined=rgba, depth=self.depth.reshape(h, w).copy(),
                    normal=self.normal.reshape(h, w, 3).copy(), error=est.error.reshape(h, w),
                    variance=est.variance.reshape(h, w, 3), samples=samples, seconds=seconds,
                    relative_error=est.relative_error, progress=min(progress, 1.0),
                    error_interval=est.interval, dof=est.dof, t95=est.t95,
                    independent_relative_error=est.independent_relative_error)


# What a film without transparency passes _welford in its place.
_NO_TRANSPARENCY = np.zeros(0)


def alpha(replicate_count, replicate_transparency) -> np.ndarray:
    """Each pixel's alpha (n,) float32 from its replicates' counts (n, m) and mean
    transparencies (n, m): one minus their count-weighted mean, within [0, 1] (Cycles'
    combined pass: alpha = 1 - transparent / samples, saturated). A function of those
    arrays alone, so a film and a merge of films give the same bits."""
    counts = replicate_count.astype(np.float64)
    total = counts.sum(axis=1)
    mean = (counts * replicate_transparency).sum(axis=1) / np.maximum(total, 1.0)
    return np.clip(1.0 - mean, 0.0, 1.0).astype(np.float32)


def estimate(replicate_count, replicate_mean, replicate_m2, shape,
             radius: int | None = None) -> Estimate:
    """An Estimate from per-replicate counts (n, m), float32 means (n, m, 3) and sums of
    squared deviations (n, m, 4) of an image of `shape` (H, W) (pixels row-major from the
    bottom row). A function of those arrays alone, so a film and a merge of films holding
    the same replicates give the same bits. `radius` overrides POOL_RADIUS (0: each
    pixel's own replicate variance, unbiased; for measurements)."""
    radius = POOL_RADIUS if radius is None else radius
    n = len(replicate_count)
    combined = np.empty((n, 3), np.float32)
    # Each pixel's variance of its value: from its replicates' spread ("own") and from its
    # samples' spread within the replicates as if they were independent ("independent");
    # one channel at a time (R, G, B, then luminance), so a 4K film's temporaries stay
    # a few hundred MB.
    own, independent, pooled = np.empty(n), np.empty(n), np.empty(n, np.float32)
    variance = np.empty((n, 3), np.float32)
    for k in range(4):
        s_var, s_var2, s_lum, fewest, s_ind = _statistics(
            replicate_count, replicate_mean, replicate_m2, LUMINANCE, k, combined, own,
            independent)
        _pool_variance(own.reshape(shape), independent.reshape(shape), radius,
                       pooled.reshape(shape))
        if k < 3:
            variance[:, k] = pooled
    dof = max(fewest - 1, 0)
    mean_lum = s_lum / max(n, 1)
    rel, interval = -1.0, (-1.0, -1.0)
    if fewest >= 2 and mean_lum > 0 and s_var > 0:
        rel = math.sqrt(s_var / n) / mean_lum
        # Satterthwaite: the sum of n variance estimates with dof_i each is nearly
        # sum x chi2(nu) / nu, nu = sum^2 / sum(v_i^2 / dof_i).
        nu = s_var * s_var / max(s_var2, 1e-300)
        lo = rel * math.sqrt(nu / _chi2_quantile(_Z975, nu))
        hi = rel * math.sqrt(nu / max(_chi2_quantile(-_Z975, nu), 1e-300))
        interval = (lo, hi)
    elif fewest >= 2:
        rel, interval = 0.0, (0.0, 0.0)
    ind = math.sqrt(s_ind / n) / mean_lum if mean_lum > 0 and s_ind >= 0 else -1.0
    window = (2 * radius + 1) ** 2
    return Estimate(combined=combined, error=np.sqrt(pooled), variance=variance, dof=dof,
                    t95=t95(dof * window), relative_error=rel, interval=interval,
                    independent_relative_error=ind)


def estimate_of(result, radius: int | None = None) -> Estimate:
    """`estimate` of a render's replicate arrays (a RenderResult's replicate_count,
    replicate_mean and replicate_m2, (H, W, m, ...)); radius 0 gives each pixel's own,
    unbiased replicate variance (for measurements against a reference)."""
    h, w, m = result.replicate_count.shape
    return estimate(result.replicate_count.reshape(h * w, m),
                    result.replicate_mean.reshape(h * w, m, 3),
                    result.replicate_m2.reshape(h * w, m, 4), (h, w), radius)


@njit(**JIT)
def _welford(pixels, slot, radiance, depth, normal, transparency, count, rcount, rmean, rm2,
             rtransparency, depth_acc, normal_acc, lum):
    """Film.add: each sample into its replicate's running mean and sums of squared
    deviations (Welford; float32, each rounded once per update), with a transparent film
    (transparency not empty) its replicate's mean transparency, and the depth and normal
    means; releases the GIL, so worker threads fold their own chunks."""
    f32 = np.float32
    transparent = len(transparency) > 0
    for i in range(len(pixels)):
        r0, r1, r2, z = radiance[i, 0], radiance[i, 1], radiance[i, 2], depth[i]
        if not (np.isfinite(r0) and np.isfinite(r1) and np.isfinite(r2) and np.isfinite(z)
                and np.isfinite(normal[i, 0]) and np.isfinite(normal[i, 1])
                and np.isfinite(normal[i, 2])
                and (not transparent or np.isfinite(transparency[i]))):
            continue
        p = pixels[i]
        k = rcount[p, slot] + 1
        rcount[p, slot] = k
        if transparent:
            old = rtransparency[p, slot]
            rtransparency[p, slot] = f32(old + (transparency[i] - old) / k)
        y_old = 0.0
        y_new = 0.0
        for c in range(3):
            x = radiance[i, c]
            old = rmean[p, slot, c]
            new = f32(old + (x - old) / k)
            rmean[p, slot, c] = new
            rm2[p, slot, c] = f32(rm2[p, slot, c] + (x - old) * (x - new))
            y_old += lum[c] * old
            y_new += lum[c] * new
        y = r0 * lum[0] + r1 * lum[1] + r2 * lum[2]
        rm2[p, slot, 3] = f32(rm2[p, slot, 3] + (y - y_old) * (y - y_new))
        n = count[p] + 1
        count[p] = n
        w = f32(1.0 / n)
        depth_acc[p] += w * (f32(z) - depth_acc[p])
        for c in range(3):
            normal_acc[p, c] += w * (f32(normal[i, c]) - normal_acc[p, c])


@njit(**JIT)
def _statistics(rcount, rmean, rm2, lum, k, combined, own, independent):
    """Per pixel, for channel k (0-2: R, G, B; 3: luminance): the count-weighted mean of
    the replicate means (R, G, B into combined (n, 3)); from their spread the variance of
    that mean into own (n,),

        V = sum_r c_r (m_r - m)^2 / ((R - 1) sum_r c_r)

    over the R replicates with samples (c_r samples, mean m_r; with equal counts the usual
    sum_r (m_r - m)^2 / (R (R - 1))), 0 where R < 2; and from the samples' spread within
    the replicates, as if independent, sum_r M2_r / ((N - R) N) into independent (n,)
    (0 where N <= R). Returns the sums over pixels of own, of its square over its degrees
    of freedom, of the luminance and of independent (-1 if some pixel has none), and the
    fewest replicates with samples in any pixel."""
    s_var, s_var2, s_lum, s_ind = 0.0, 0.0, 0.0, 0.0
    fewest = rcount.shape[1]
    for i in range(rcount.shape[0]):
        total, filled = 0.0, 0
        m0, m1, m2 = 0.0, 0.0, 0.0
        for r in range(rcount.shape[1]):
            c = float(rcount[i, r])
            if c > 0:
                filled += 1
                total += c
                m0 += c * rmean[i, r, 0]
                m1 += c * rmean[i, r, 1]
                m2 += c * rmean[i, r, 2]
        fewest = min(fewest, filled)
        if total > 0:
            m0, m1, m2 = m0 / total, m1 / total, m2 / total
        y = m0 * lum[0] + m1 * lum[1] + m2 * lum[2]
        s_lum += y
        # The channel's weights on R, G, B (luminance: its coefficients) and its mean.
        w0 = lum[0] if k == 3 else (1.0 if k == 0 else 0.0)
        w1 = lum[1] if k == 3 else (1.0 if k == 1 else 0.0)
        w2 = lum[2] if k == 3 else (1.0 if k == 2 else 0.0)
        mk = m0 * w0 + m1 * w1 + m2 * w2
        if k < 3:
            combined[i, k] = np.float32(mk)
        v = 0.0
        if filled >= 2:
            for r in range(rcount.shape[1]):
                c = float(rcount[i, r])
                if c > 0:
                    d = (rmean[i, r, 0] * w0 + rmean[i, r, 1] * w1 + rmean[i, r, 2] * w2) - mk
                    v += c * d * d
            v /= (filled - 1) * total
            s_var2 += v * v / (filled - 1)
        own[i] = v
        s_var += v
        independent[i] = 0.0
        if total > filled:
            m2_sum = 0.0
            for r in range(rcount.shape[1]):
                m2_sum += rm2[i, r, k]
            independent[i] = max(m2_sum, 0.0) / ((total - filled) * total)
            s_ind += independent[i]
        else:
            s_ind = -1.0e300
    return s_var, s_var2, s_lum, fewest, s_ind


@njit(**ALLOCATING)
def _pool_variance(own, independent, radius, out):
    """Each pixel's variance for its interval, into out (float32): the larger of

    * the mean of the own (replicate) variances over its (2 radius + 1)^2 neighbourhood
      (the part inside the image), and
    * its independent-sample variance times the neighbourhood's ratio of own to
      independent variance.

    Why pool: path-traced pixels are skewed. A pixel whose rare bright paths (a caustic, a
    light seen through glass) fell in none of its replicates has replicates that agree, so
    its own spread says its error is small exactly when its value is furthest below the
    truth; its 95% interval then misses far more often than 5 % (54-86 % coverage at 16
    samples, measured; README "Honest error"). Its neighbours see the same surfaces and
    rare paths, and some of them caught one: their mean variance stands for the pixel's,
    with many more degrees of freedom. Why the second term: a pixel can differ from its
    neighbours for real (a silhouette, a highlight, a shadow or defocus edge crossing it).
    Its samples' own spread sees that with N - R degrees of freedom, but overstates the
    error of stratified samples by a factor that changes slowly across the image; the
    neighbourhood's own/independent ratio measures that factor. The image's relative
    error uses neither: the plain per-pixel estimates are unbiased, and so is their mean."""
    h, w = own.shape
    # Separable window sums: along rows, then down columns (zero stays exactly zero).
    rows = np.empty((2, h, w))
    for y in range(h):
        for x in range(w):
            a, b = 0.0, 0.0
            for k in range(max(x - radius, 0), min(x + radius + 1, w)):
                a += own[y, k]
                b += independent[y, k]
            rows[0, y, x], rows[1, y, x] = a, b
    for y in range(h):
        y0, y1 = max(y - radius, 0), min(y + radius + 1, h)
        for x in range(w):
            a, b = 0.0, 0.0
            for k in range(y0, y1):
                a += rows[0, k, x]
                b += rows[1, k, x]
            count = (y1 - y0) * (min(x + radius + 1, w) - max(x - radius, 0))
            v = a / count
            if b > 0.0 and independent[y, x] > STANDS_OUT * b / count:
                v = max(v, independent[y, x] * (a / b))
            out[y, x] = v


@njit(**JIT)
def _first_nonfinite_row(rows):
    """Index of the first row of (n, k) `rows` holding NaN or inf, or -1."""
    for i in range(rows.shape[0]):
        for j in range(rows.shape[1]):
            if not np.isfinite(rows[i, j]):
                return i
    return -1

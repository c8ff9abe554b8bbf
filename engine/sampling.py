"""Sample sequences, warps and multiple importance sampling weights.

Sequences: every random number a path draws is a pure function of (seed, pixel, sample
index, dimension), so a render is the same whatever the thread timing. Each dimension pair
is an Owen-scrambled 2D Sobol (0,2)-sequence whose index is shuffled per pixel and per
dimension pair (Burley 2020, "Practical Hash-based Owen Scrambling", the scheme Cycles
uses): stratified within each pixel, decorrelated across pixels and across dimension pairs.

Every function here works on one sample (scalars in, scalars out) and is compiled by numba
into the per-bounce kernel (integrator.py), which inlines it; integers are uint64 holding
32 bits. Warps take u in [0, 1).
"""

from __future__ import annotations

import math

import numpy as np

from .jit import ALLOCATING, JIT, njit

ONE_MINUS_EPSILON = 1.0 - 2.0**-53  # largest double below 1

_M32 = np.uint64(0xFFFFFFFF)
_REVERSE_STEPS = tuple((np.uint64(s), np.uint64(m)) for s, m in (
    (1, 0x55555555), (2, 0x33333333), (4, 0x0F0F0F0F), (8, 0x00FF00FF), (16, 0x0000FFFF)))


def _sobol_dim1_tables() -> np.ndarray:
    """Byte tables for the second Sobol dimension (primitive polynomial x + 1), in the
    bit-reversed domain.

    Direction numbers m_k = m_{k-1} xor 2 m_{k-1}, m_1 = 1, v_k = m_k << (32 - k), and
    y = xor of v_k over the set bits k of the index. The tables take bytes of the
    *reversed* index and give the *reversed* y, so the whole generator-matrix product is
    four lookups and the Owen scramble that follows needs no extra bit reversal.
    """
    v = []
    m = 1
    for k in range(1, 33):
        if k > 1:
            m = m ^ (m << 1)
        v.append((m << (32 - k)) & 0xFFFFFFFF)
    rev_v = [int(f"{x:032b}"[::-1], 2) for x in v]
    tables = np.zeros((4, 256), np.uint64)
    for j in range(4):
        for b in range(256):
            acc = 0
            for bit in range(8):
                if b >> bit & 1:
                    # Bit (8j + bit) of the reversed index is bit 31 - (8j + bit) of the index.
                    acc ^= rev_v[31 - (8 * j + bit)]
            tables[j, b] = acc
    return tables


_SOBOL1_REV = _sobol_dim1_tables()


# -------------------------------------------------------------------- bit tricks
@njit(**JIT)
def hash_u32(x):
    """A well-mixing 32-bit integer hash (lowbias32 by Chris Wellons)."""
    x = x & _M32
    x ^= x >> np.uint64(16)
    x = (x * np.uint64(0x7FEB352D)) & _M32
    x ^= x >> np.uint64(15)
    x = (x * np.uint64(0x846CA68B)) & _M32
    x ^= x >> np.uint64(16)
    return x


@njit(**JIT)
def hash_combine(a, b):
    return hash_u32(a ^ ((hash_u32(b) + np.uint64(0x9E3779B9)) & _M32))


@njit(**JIT)
def reverse_bits(x):
    """Reverse the low 32 bits (swap halves, then bytes, nibbles, pairs, bits)."""
    x = np.uint64(x)
    for shift, mask in _REVERSE_STEPS:
        x = ((x >> shift) & mask) | ((x & mask) << shift)
    return x & _M32


@njit(**JIT)
def laine_karras(x, seed):
    """Laine-Karras permutation: an Owen scramble of bit-reversed integers."""
    x = (x + seed) & _M32
    x ^= (x * np.uint64(0x6C50B47C)) & _M32
    x ^= (x * np.uint64(0xB82F1E52)) & _M32
    x ^= (x * np.uint64(0xC7AFE638)) & _M32
    x ^= (x * np.uint64(0x8D22F6E6)) & _M32
    return x


@njit(**JIT)
def _to_unit(x):
    return min(float(x) * 2.0**-32, ONE_MINUS_EPSILON)


# -------------------------------------------------------------------- sequences
@njit(**JIT)
def pixel_seed(pixel, seed):
    """The sequence seed of one pixel id for the render seed."""
    return hash_combine(np.uint64(pixel) & _M32, (np.uint64(seed) & _M32) ^ np.uint64(0x5BD1E995))


def replicate_seed(seed, replicate):
    """The sequence seed of replicate `replicate` of a render with seed `seed`: an
    independent scramble of every pixel's sequence per replicate (replicate 0 keeps the
    render's seed, so a one-replicate render is the plain sequence)."""
    if replicate == 0:
        return int(seed) & 0xFFFFFFFF
    return int(hash_combine(np.uint64(int(seed) & 0xFFFFFFFF),
                            np.uint64(0x2545F491 + int(replicate))))


@njit(**JIT)
def sample_2d(pseed, rev_sample, dim):
    """A 2D point in [0, 1)^2 of dimension pair `dim` for a pixel's seed and the bit-reversed
    sample index: a shuffled, Owen-scrambled Sobol (0,2)-sequence. The shuffled index is
    i' = rev(LK(rev(i))); the Owen scramble of y is rev(LK(rev(y))), where dimension 0 has
    rev(y) = i' and dimension 1's tables return rev(y) from rev(i')."""
    dim_seed = hash_combine(pseed, np.uint64(dim))
    r = laine_karras(rev_sample, dim_seed)
    index = reverse_bits(r)
    x = reverse_bits(laine_karras(index, hash_combine(dim_seed, np.uint64(0xA511E9B3))))
    y_rev = (_SOBOL1_REV[0, r & np.uint64(0xFF)]
             ^ _SOBOL1_REV[1, (r >> np.uint64(8)) & np.uint64(0xFF)]
             ^ _SOBOL1_REV[2, (r >> np.uint64(16)) & np.uint64(0xFF)]
             ^ _SOBOL1_REV[3, r >> np.uint64(24)])
    y = reverse_bits(laine_karras(y_rev, hash_combine(dim_seed, np.uint64(0x63D83595))))
    return _to_unit(x), _to_unit(y)


@njit(**JIT)
def sample_1d(pseed, rev_sample, dim):
    """A scrambled van der Corput point of dimension `dim`."""
    dim_seed = hash_combine(pseed, np.uint64(dim))
    index = reverse_bits(laine_karras(rev_sample, dim_seed))
    return _to_unit(reverse_bits(laine_karras(index, hash_combine(dim_seed,
                                                                  np.uint64(0x1B873593)))))


@njit(**ALLOCATING)
def stream_2d(pixels, sample, seed, dim):
    """(n, 2) points of dimension pair `dim` for pixel ids (n,) at one sample index."""
    out = np.empty((len(pixels), 2))
    rev = reverse_bits(np.uint64(sample))
    for i in range(len(pixels)):
        out[i, 0], out[i, 1] = sample_2d(pixel_seed(pixels[i], seed), rev, dim)
    return out


@njit(**ALLOCATING)
def stream_1d(pixels, sample, seed, dim):
    """(n,) points of dimension `dim` for pixel ids (n,) at one sample index."""
    out = np.empty(len(pixels))
    rev = reverse_bits(np.uint64(sample))
    for i in range(len(pixels)):
        out[i] = sample_1d(pixel_seed(pixels[i], seed), rev, dim)
    return out


# Dimension-pair numbers: fixed ones for the camera, then a block per bounce with one
# slot per use (module constants: compiled code reads them as constants).
DIM_FILTER, DIM_LENS = 0, 1
DIMS_PER_BOUNCE = 6
LIGHT_SELECT, LIGHT_POINT, LOBE, BSDF, ROULETTE, CLOSURE = 0, 1, 2, 3, 4, 5


@njit(**JIT)
def bounce_dim(depth, which):
    """The dimension of slot `which` (LIGHT_SELECT, ...) at bounce `depth`."""
    return 2 + depth * DIMS_PER_BOUNCE + which


# -------------------------------------------------------------------- warps
@njit(**JIT)
def concentric_disk(ua, ub):
    """Shirley-Chiu concentric map of [0,1)^2 onto the unit disk."""
    a = 2.0 * ua - 1.0
    b = 2.0 * ub - 1.0
    if abs(a) > abs(b):
        r, theta = a, (np.pi / 4) * (b / a)
    else:
        r = b
        theta = (np.pi / 2) - (np.pi / 4) * (a / (b if b != 0 else 1.0))
    return r * math.cos(theta), r * math.sin(theta)


@njit(**JIT)
def cosine_hemisphere(ua, ub):
    """Cosine-weighted direction about +z (Malley's method): (x, y, z); pdf z / pi."""
    x, y = concentric_disk(ua, ub)
    return x, y, math.sqrt(max(0.0, 1.0 - (x * x + y * y)))


@njit(**JIT)
def regular_polygon(ua, ub, blades, rotation):
    """Uniform point in a regular `blades`-gon inscribed in the unit circle (Cycles' rule:
    vertices at angles rotation + (2k + 1) pi / blades)."""
    n = int(blades)
    corner = min(math.floor(ua * n), n - 1)
    s = math.sqrt(min(max(ua * n - corner, 0.0), 1.0))  # the fraction, reused
    # Uniform in the triangle (0,0), (cos a, sin a), (cos a, -sin a) with a = pi / n.
    a = np.pi / n
    x = s * math.cos(a)
    y = s * math.sin(a) * (2.0 * ub - 1.0)
    phi = rotation + corner * (2.0 * np.pi / n)
    c, sn = math.cos(phi), math.sin(phi)
    return c * x - sn * y, sn * x + c * y


def regular_polygon_area(blades: int) -> float:
    return 0.5 * blades * math.sin(2.0 * math.pi / blades)


@njit(**JIT)
def uniform_triangle(ua, ub):
    """Barycentrics (b0, b1, b2) uniform over a triangle (Heitz's low-distortion map)."""
    if ua < ub:
        b0, b1 = ua / 2, ub - ua / 2
    else:
        b0, b1 = ua - ub / 2, ub / 2
    return b0, b1, 1.0 - b0 - b1


@njit(**JIT)
def build_frame(nx, ny, nz):
    """Orthonormal tangents (s, t) of a unit normal (Duff et al. 2017)."""
    sign = 1.0 if nz >= 0.0 else -1.0
    a = -1.0 / (sign + nz)
    b = nx * ny * a
    return (1.0 + sign * nx * nx * a, sign * b, -sign * nx), (b, sign + ny * ny * a, -ny)


@njit(**JIT)
def uniform_cone(ax, ay, az, cos_max, ua, ub):
    """A direction uniform in the cone of half-angle acos(cos_max) about the unit axis a:
    (w, its cosine to a, solid-angle pdf)."""
    s, t = build_frame(ax, ay, az)
    cos = 1.0 - ua * (1.0 - cos_max)
    sin = math.sqrt(max(0.0, 1.0 - cos * cos))
    phi = 2.0 * np.pi * ub
    a, b = sin * math.cos(phi), sin * math.sin(phi)
    return (a * s[0] + b * t[0] + cos * ax, a * s[1] + b * t[1] + cos * ay,
            a * s[2] + b * t[2] + cos * az, cos, uniform_cone_pdf(cos_max))


@njit(**JIT)
def uniform_cone_pdf(cos_max):
    return 1.0 / (2.0 * np.pi * max(1.0 - cos_max, 1e-300))


# -------------------------------------------------------------------- MIS
# Below this solid angle a rectangle is sampled by area: the spherical excess is a
# difference of angles near 2 pi and loses its digits.
MIN_SOLID_ANGLE = 1e-5


@njit(**JIT)
def _rectangle_frame(ox, oy, oz, cx, cy, cz, ux, uy, uz, vx, vy, vz, len_u, len_v):
    """The rectangle (centre c, unit orthogonal axes u, v, side lengths) in the local frame
    of Urena et al. 2013 seen from o: (x0, x1, y0, y1, z0 <= 0, solid angle, the four
    constants the sampling reuses: b0, b1, k)."""
    dx = cx - 0.5 * (len_u * ux + len_v * vx) - ox
    dy = cy - 0.5 * (len_u * uy + len_v * vy) - oy
    dz = cz - 0.5 * (len_u * uz + len_v * vz) - oz
    nx, ny, nz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
    z0 = dx * nx + dy * ny + dz * nz
    if z0 > 0.0:
        z0 = -z0
    x0, y0 = dx * ux + dy * uy + dz * uz, dx * vx + dy * vy + dz * vz
    x1, y1 = x0 + len_u, y0 + len_v
    if not z0 < 0.0:  # o in the rectangle's plane: it subtends nothing
        return x0, x1, y0, y1, z0, 0.0, 0.0, 0.0, 0.0
    # The z parts of the unit normals of the spherical rectangle's four great-circle edges
    # (cross products of successive corners; the angles below need only these).
    n0z = -y0 / math.sqrt(z0 * z0 + y0 * y0)
    n1z = x1 / math.sqrt(z0 * z0 + x1 * x1)
    n2z = y1 / math.sqrt(z0 * z0 + y1 * y1)
    n3z = -x0 / math.sqrt(z0 * z0 + x0 * x0)
    # Internal angles between successive edges; the solid angle is their spherical excess.
    g0 = math.acos(min(max(-(n0z * n1z), -1.0), 1.0))
    g1 = math.acos(min(max(-(n1z * n2z), -1.0), 1.0))
    g2 = math.acos(min(max(-(n2z * n3z), -1.0), 1.0))
    g3 = math.acos(min(max(-(n3z * n0z), -1.0), 1.0))
    k = 2.0 * math.pi - g2 - g3
    return x0, x1, y0, y1, z0, max(g0 + g1 - k, 0.0), n0z, n2z, k


@njit(**JIT)
def spherical_rectangle_solid_angle(ox, oy, oz, cx, cy, cz, ux, uy, uz, vx, vy, vz, len_u,
                                    len_v):
    """The solid angle the rectangle subtends at o."""
    return _rectangle_frame(ox, oy, oz, cx, cy, cz, ux, uy, uz, vx, vy, vz, len_u, len_v)[5]


@njit(**JIT)
def spherical_rectangle(ox, oy, oz, cx, cy, cz, ux, uy, uz, vx, vy, vz, len_u, len_v, ua, ub):
    """A point on the rectangle uniform in the solid angle it subtends at o (Urena,
    Fajardo and King 2013): (point, solid angle; the density is 1 / solid angle)."""
    x0, x1, y0, y1, z0, solid, b0, b1, k = _rectangle_frame(
        ox, oy, oz, cx, cy, cz, ux, uy, uz, vx, vy, vz, len_u, len_v)
    au = ua * solid + k
    fu = (math.cos(au) * b0 - b1) / math.sin(au)
    cu = 1.0 / math.sqrt(fu * fu + b0 * b0)
    if fu <= 0.0:
        cu = -cu
    cu = min(max(cu, -1.0), 1.0)
    xu = -(cu * z0) / max(math.sqrt(max(1.0 - cu * cu, 0.0)), 1e-300)
    xu = min(max(xu, x0), x1)
    d = math.sqrt(xu * xu + z0 * z0)
    h0 = y0 / math.sqrt(d * d + y0 * y0)
    h1 = y1 / math.sqrt(d * d + y1 * y1)
    hv = h0 + ub * (h1 - h0)
    hv2 = hv * hv
    yv = hv * d / math.sqrt(1.0 - hv2) if hv2 < 1.0 - 1e-12 else y1
    yv = min(max(yv, y0), y1)
    # Back to world space from the corner.
    a, b = xu - x0 - 0.5 * len_u, yv - y0 - 0.5 * len_v
    return (cx + a * ux + b * vx, cy + a * uy + b * vy, cz + a * uz + b * vz, solid)


@njit(**JIT)
def power_heuristic(a, b):
    """MIS weight of strategy a against b (beta = 2), safe for zero and infinite pdfs (an
    infinite pdf is a delta strategy: it takes the whole weight)."""
    if math.isinf(a):
        return 1.0
    if math.isinf(b):
        return 0.0
    m = max(max(a, b), 1e-300)
    a2 = (a / m) ** 2
    b2 = (b / m) ** 2
    s = a2 + b2
    return a2 / max(s, 1e-300) if s > 0 else 0.0


# -------------------------------------------------------------------- tables
def interp_guide(xp: np.ndarray, cells: int = 16384) -> np.ndarray:
    """Index guide for `guided_interp` on xp in [0, 1]: guide[c] = the last j with
    xp[j] <= c / cells (-1 if none), for c = 0..cells."""
    return np.searchsorted(xp, np.arange(cells + 1) / cells, side="right") - 1


@njit(**JIT)
def guided_interp(x, xp, fp, guide):
    """np.interp for one x in [0, 1], bit-identical (the pixel filter's inverse CDF, the
    microfacet tables over mu). A binary search over a 16k-entry table mispredicts a branch
    per level (~150 ns a sample); the guide starts at x's cell, a step or two short."""
    cells = len(guide) - 1
    j = guide[min(int(x * cells), cells - 1)]
    n = len(xp)
    while j + 1 < n and xp[j + 1] <= x:  # the last j with xp[j] <= x
        j += 1
    if j < 0:
        return fp[0]
    if j >= n - 1:
        return fp[-1]
    slope = (fp[j + 1] - fp[j]) / (xp[j + 1] - xp[j])
    return slope * (x - xp[j]) + fp[j]


@njit(**JIT)
def sample_cdf(cdf, u):
    """The entry of a discrete distribution with this CDF (last entry 1) chosen by u."""
    return min(np.searchsorted(cdf, u, side="right"), len(cdf) - 1)


class Distribution1D:
    """Discrete distribution over weights: pmf and CDF (sampled by `sample_cdf`)."""

    def __init__(self, weights: np.ndarray):
        w = np.maximum(np.asarray(weights, np.float64), 0.0)
        self.total = float(w.sum())
        self.pmf = w / self.total if self.total > 0 else np.zeros_like(w)
        self.cdf = np.cumsum(self.pmf)
        if len(self.cdf):
            self.cdf[-1] = 1.0


def cross_rows(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise cross product of (n, 3) arrays, bit-identical to np.cross but written
    column by column: 5-16x faster for millions of rows (np.cross moves axes and copies).
    For building scene data (triangle normals and areas), not per sample."""
    out = np.empty_like(a)
    np.multiply(a[:, 1], b[:, 2], out=out[:, 0])
    out[:, 0] -= a[:, 2] * b[:, 1]
    np.multiply(a[:, 2], b[:, 0], out=out[:, 1])
    out[:, 1] -= a[:, 0] * b[:, 2]
    np.multiply(a[:, 0], b[:, 1], out=out[:, 2])
    out[:, 2] -= a[:, 1] * b[:, 0]
    return out

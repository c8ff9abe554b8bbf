"""Compiled bounce stages: the integrator's hot loop as numba kernels between embree calls.

The numpy integrator spends about 1 us of interpreter and temporary-array overhead per
ray segment against embree's 0.1 us, so numpy, not ray tracing, bounds its speed. These
kernels run the same stages with the same conventions, one loop over the batch per stage
and no temporaries, with the GIL released so both cores work:

    intersect (embree) -> surface_interaction -> sample_light -> shadow rays (embree)
    -> accumulate_unoccluded -> sample_bsdf -> intersect (embree) ...

`surface_interaction` handles light objects crossed on the way (lights are transparent),
escaped rays (world colour or environment map), emission, the bounce limit, Russian
roulette and absorbers, and compacts the survivors; `sample_light` does next-event
estimation on emissive triangles, light objects (point, spot, sun, area) and the
environment map, MIS-weighted; `sample_bsdf` samples diffuse, mirror, metal, glass and
the layered GGX lobes (Principled, rough Glossy) and writes the next rays straight into
embree's float32 buffers. Random numbers come from the same Owen-scrambled Sobol
sequences as `sampling.SampleStream`, and every formula keeps the numpy stages' order of
operations, so the two paths give the same image to the last bit on every scene tried
(tests/engine/test_kernel.py).

The kernels cover every material kind (`SUPPORTED`); a kind added to the numpy stages
first falls back to them through `unsupported` until it is ported here. numba is
optional: without it `AVAILABLE` is False and every render takes the numpy path.
"""

from __future__ import annotations

import math
import time

import numpy as np

from . import sampling
from .jit import NUMBA, cgutils, intrinsic, ir, njit, types
from .sampling import _SOBOL1_REV, ONE_MINUS_EPSILON, Dim
from .scene import DIFFUSE, GLASS, GLOSSY, METAL, MIRROR, NONE, PRINCIPLED
from .bsdf import valid_specular_normal
from .terminator import offset_amount, smooth_surface_offset

AVAILABLE = NUMBA  # the run-time switch (see jit.py)

# Material kinds the kernels implement (everything else uses the numpy integrator).
SUPPORTED = (NONE, DIFFUSE, MIRROR, METAL, GLASS, PRINCIPLED, GLOSSY)

# Same constants as the numpy integrator (see integrator.py).
RAY_EPSILON = 2.0**-18
ROULETTE_MIN_BOUNCE = 2
LOCAL_WEIGHT = 0.75
BACKGROUND_DEPTH = 1e10

_JIT = dict(cache=True, nogil=True, error_model="numpy")
_M32 = np.uint64(0xFFFFFFFF)
_SOBOL1 = _SOBOL1_REV.astype(np.uint64)
_REVERSE_STEPS = tuple((np.uint64(s), np.uint64(m)) for s, m in (
    (1, 0x55555555), (2, 0x33333333), (4, 0x0F0F0F0F), (8, 0x00FF00FF), (16, 0x0000FFFF)))


# -------------------------------------------------------------------- sample sequences
@njit(**_JIT)
def _hash(x):
    """lowbias32 (sampling.hash_u32) on a uint64 holding 32 bits."""
    x = x & _M32
    x ^= x >> np.uint64(16)
    x = (x * np.uint64(0x7FEB352D)) & _M32
    x ^= x >> np.uint64(15)
    x = (x * np.uint64(0x846CA68B)) & _M32
    x ^= x >> np.uint64(16)
    return x


@njit(**_JIT)
def _hash_combine(a, b):
    return _hash(a ^ ((_hash(b) + np.uint64(0x9E3779B9)) & _M32))


@njit(**_JIT)
def _reverse(x):
    """Reverse the low 32 bits (swap halves, then bytes, nibbles, pairs, bits)."""
    for shift, mask in _REVERSE_STEPS:
        x = ((x >> shift) & mask) | ((x & mask) << shift)
    return x & _M32


@njit(**_JIT)
def _laine_karras(x, seed):
    x = (x + seed) & _M32
    x ^= (x * np.uint64(0x6C50B47C)) & _M32
    x ^= (x * np.uint64(0xB82F1E52)) & _M32
    x ^= (x * np.uint64(0xC7AFE638)) & _M32
    x ^= (x * np.uint64(0x8D22F6E6)) & _M32
    return x


@njit(**_JIT)
def _to_unit(x):
    return min(float(x) * 2.0**-32, ONE_MINUS_EPSILON)


@njit(**_JIT)
def pixel_seed(pixel, seed):
    """SampleStream.pixel_seed for one pixel id."""
    return _hash_combine(np.uint64(pixel) & _M32, (np.uint64(seed) & _M32) ^ np.uint64(0x5BD1E995))


@njit(**_JIT)
def sample_2d(pseed, rev_sample, dim):
    """SampleStream.get_2d for one pixel: (u0, u1) in [0, 1)."""
    dim_seed = _hash_combine(pseed, np.uint64(dim))
    r = _laine_karras(rev_sample, dim_seed)
    index = _reverse(r)
    x = _reverse(_laine_karras(index, _hash_combine(dim_seed, np.uint64(0xA511E9B3))))
    y_rev = (_SOBOL1[0, r & np.uint64(0xFF)] ^ _SOBOL1[1, (r >> np.uint64(8)) & np.uint64(0xFF)]
             ^ _SOBOL1[2, (r >> np.uint64(16)) & np.uint64(0xFF)]
             ^ _SOBOL1[3, r >> np.uint64(24)])
    y = _reverse(_laine_karras(y_rev, _hash_combine(dim_seed, np.uint64(0x63D83595))))
    return _to_unit(x), _to_unit(y)


@njit(**_JIT)
def sample_1d(pseed, rev_sample, dim):
    """SampleStream.get_1d for one pixel."""
    dim_seed = _hash_combine(pseed, np.uint64(dim))
    index = _reverse(_laine_karras(rev_sample, dim_seed))
    return _to_unit(_reverse(_laine_karras(index, _hash_combine(dim_seed, np.uint64(0x1B873593)))))


@njit(**_JIT)
def stream_2d(pixels, sample, seed, dim):
    """(n, 2) samples of dimension pair `dim` for pixel ids (n,) (for tests)."""
    out = np.empty((len(pixels), 2))
    rev = _reverse(np.uint64(sample))
    for i in range(len(pixels)):
        out[i, 0], out[i, 1] = sample_2d(pixel_seed(pixels[i], seed), rev, dim)
    return out


@njit(**_JIT)
def stream_1d(pixels, sample, seed, dim):
    out = np.empty(len(pixels))
    rev = _reverse(np.uint64(sample))
    for i in range(len(pixels)):
        out[i] = sample_1d(pixel_seed(pixels[i], seed), rev, dim)
    return out


# -------------------------------------------------------------------- small vector helpers
@njit(**_JIT)
def _power_heuristic(a, b):
    """integrator.power_heuristic for scalars."""
    if math.isinf(a):
        return 1.0
    if math.isinf(b):
        return 0.0
    m = max(max(a, b), 1e-300)
    a2 = (a / m) ** 2
    b2 = (b / m) ** 2
    s = a2 + b2
    return a2 / max(s, 1e-300) if s > 0 else 0.0


_PER_BOUNCE = Dim.PER_BOUNCE
_LIGHT_SELECT, _LIGHT_POINT, _LOBE, _BSDF, _ROULETTE = (
    Dim.LIGHT_SELECT, Dim.LIGHT_POINT, Dim.LOBE, Dim.BSDF, Dim.ROULETTE)


@njit(**_JIT)
def _bounce_dim(depth, which):
    return 2 + depth * _PER_BOUNCE + which


# -------------------------------------------------------------------- light selection
# The emitters travel as one tuple (see `pack_lights`):
#   0 pmf (k,), 1 cdf (k,)               global choice by power
#   2 grid (int, voxels per axis; 0: none), 3 grid_lo (3,), 4 cell (3,)
#   5 local_pmf (g^3, k), 6 local_cdf_flat (g^3 k,), 7 has_mass (g^3,)
#   8 entry_of_triangle (t,), 9 area_by_triangle (t,)
#   10 v0, 11 e1, 12 e2, 13 normal (k, 3), 14 area (k,), 15 radiance (k, 3), 16 scale (k,)
@njit(**_JIT)
def _voxel(px, py, pz, lo, cell, grid):
    i = min(max(int((px - lo[0]) / cell[0]), 0), grid - 1)
    j = min(max(int((py - lo[1]) / cell[1]), 0), grid - 1)
    k = min(max(int((pz - lo[2]) / cell[2]), 0), grid - 1)
    return (i * grid + j) * grid + k


# Helpers take the tuple's arrays one by one: passing the tuple itself to a helper
# costs ~100 ns per call (measured), more than the rest of a light sample.
@njit(**_JIT)
def _entry_pmf(px, py, pz, entry, pmf, grid, lo, cell, local_pmf, has_mass):
    """LightSampler.pmf for one point and entry."""
    if grid == 0:
        return pmf[entry]
    vox = _voxel(px, py, pz, lo, cell, grid)
    a = LOCAL_WEIGHT if has_mass[vox] else 0.0
    return a * local_pmf[vox, entry] + (1.0 - a) * pmf[entry]


@njit(**_JIT)
def _choose(px, py, pz, u, pmf, cdf, grid, lo, cell, local_pmf, local_cdf_flat, has_mass):
    """LightSampler.choose for one point: (entry, probability)."""
    k_count = len(pmf)
    if grid == 0:
        k = min(np.searchsorted(cdf, u, side="right"), k_count - 1)
        return k, pmf[k]
    vox = _voxel(px, py, pz, lo, cell, grid)
    a = LOCAL_WEIGHT if has_mass[vox] else 0.0
    if u < a:
        ul = min(u / a, 1.0 - 1e-12)
        flat = np.searchsorted(local_cdf_flat, vox + ul, side="right")
        k = min(max(flat - vox * k_count, 0), k_count - 1)
    else:
        k = min(np.searchsorted(cdf, (u - a) / (1.0 - a), side="right"), k_count - 1)
    return k, a * local_pmf[vox, k] + (1.0 - a) * pmf[k]


# -------------------------------------------------------------------- the bounce kernel
@intrinsic
def _cycles(typingctx):
    """The CPU's cycle counter (llvm.readcyclecounter), for the per-stage profile."""
    def codegen(context, builder, signature, args):
        fnty = ir.FunctionType(ir.IntType(64), [])
        fn = cgutils.get_or_insert_function(builder.module, fnty, "llvm.readcyclecounter")
        return builder.call(fn, [])
    return types.uint64(), codegen


@njit(**_JIT)
def _concentric_disk(ua, ub):
    """sampling.sample_uniform_disk_concentric for one point (Shirley-Chiu)."""
    a = 2.0 * ua - 1.0
    b = 2.0 * ub - 1.0
    if abs(a) > abs(b):
        r, theta = a, (np.pi / 4) * (b / a)
    else:
        r = b
        theta = (np.pi / 2) - (np.pi / 4) * (a / (b if b != 0 else 1.0))
    return r * math.cos(theta), r * math.sin(theta)


@njit(**_JIT)
def _build_frame(nx, ny, nz):
    sign = 1.0 if nz >= 0.0 else -1.0
    a = -1.0 / (sign + nz)
    b = nx * ny * a
    return (1.0 + sign * nx * nx * a, sign * b, -sign * nx), (b, sign + ny * ny * a, -ny)


@njit(**_JIT)
def _fresnel_dielectric(cos_i, eta, exact):
    """(F, cos_t) as bsdf.fresnel_dielectric / fresnel_schlick_dielectric."""
    cos_i = min(max(abs(cos_i), 0.0), 1.0)
    disc = eta * eta - 1.0 + cos_i * cos_i
    if disc <= 0.0:
        return 1.0, 0.0
    cos_t = math.sqrt(disc) / eta
    if exact:
        d_par = eta * cos_i + cos_t
        d_perp = cos_i + eta * cos_t
        if not (d_par > 0 and d_perp > 0):
            return 1.0, cos_t
        r_par = (eta * cos_i - cos_t) / d_par
        r_perp = (cos_i - eta * cos_t) / d_perp
        f = 0.5 * (r_par * r_par + r_perp * r_perp)
    else:
        r0 = ((eta - 1.0) / (eta + 1.0)) ** 2
        c = cos_i if eta >= 1.0 else cos_t
        f = r0 + (1.0 - r0) * (1.0 - c) ** 5
    return min(max(f, 0.0), 1.0), cos_t



# -------------------------------------------------------------------- rough (GGX) lobes
# bsdf.py's layered lobe (Principled: GGX dielectric specular over a diffuse base; rough
# Glossy: the specular alone) for one vertex, in the same arithmetic order.
@njit(**_JIT)
def _ggx_lambda(cos_n, a2):
    c2 = max(cos_n * cos_n, 1e-300)
    return 0.5 * (math.sqrt(1.0 + a2 * max(1.0 / c2 - 1.0, 0.0)) - 1.0)


@njit(**_JIT)
def _eval_layered(wox, woy, woz, wix, wiy, wiz, sx, sy, sz, mx, my, mz, nx, ny, nz, dw0, dw1,
                  dw2, tint0, tint1, tint2, alpha, eta, fresnel_on, comp0, comp1, comp2, p_spec,
                  sampled):
    """bsdf.eval_layered: f * cos_i per channel and the lobe-mixture pdf, for shading
    normal s (the diffuse base's), specular normal m, geometric normal n (all on wo's
    side), the diffuse weight dw and the energy compensation per channel; `sampled` as in
    bsdf.eval_layered."""
    cos_o = mx * wox + my * woy + mz * woz
    cos_i = mx * wix + my * wiy + mz * wiz
    hx, hy, hz = wox + wix, woy + wiy, woz + wiz
    hl = max(math.sqrt(hx * hx + hy * hy + hz * hz), 1e-300)
    hx, hy, hz = hx / hl, hy / hl, hz / hl
    a2 = alpha * alpha
    spec = 0.0
    pdf_s = 0.0
    if cos_o > 0 and cos_i > 0:
        ch = mx * hx + my * hy + mz * hz
        c2 = min(ch * ch, 1.0)
        dd = 1.0 - c2 + a2 * c2
        d = a2 / (np.pi * (dd * dd))
        lo = _ggx_lambda(cos_o, a2)
        li = _ggx_lambda(cos_i, a2)
        f = 1.0
        if fresnel_on:
            f = _fresnel_dielectric(hx * wox + hy * woy + hz * woz, eta, True)[0]
        common = d / (4.0 * cos_o)
        spec = f * common / (1.0 + lo + li)
        pdf_s = common / (1.0 + lo)
    cos_d = max(sx * wix + sy * wiy + sz * wiz, 0.0)
    if not wix * nx + wiy * ny + wiz * nz > 0.0:
        spec = 0.0
        pdf_s = 0.0
        if sampled:
            cos_d = 0.0
    c = cos_d / np.pi
    return (dw0 * c + tint0 * (spec * comp0), dw1 * c + tint1 * (spec * comp1),
            dw2 * c + tint2 * (spec * comp2),
            p_spec * pdf_s + (1.0 - p_spec) * cos_d / np.pi)


@njit(**_JIT)
def _ggx_half_vector(v0, v1, v2, alpha, ua, ub):
    """bsdf.sample_ggx_vndf for one local view direction (Heitz 2018), z up."""
    a, b, c = alpha * v0, alpha * v1, v2
    norm = math.sqrt(a * a + b * b + c * c)
    a, b, c = a / norm, b / norm, c / norm
    lensq = a * a + b * b
    if lensq > 0:
        inv = 1.0 / math.sqrt(lensq)
        t1x, t1y, t1z = -b * inv, a * inv, 0.0
    else:
        t1x, t1y, t1z = 1.0, 0.0, 0.0
    t2x, t2y, t2z = b * t1z - c * t1y, c * t1x - a * t1z, a * t1y - b * t1x
    r = math.sqrt(ua)
    phi = 2.0 * np.pi * ub
    p1 = r * math.cos(phi)
    p2 = r * math.sin(phi)
    sv = 0.5 * (1.0 + c)
    p2 = (1.0 - sv) * math.sqrt(max(0.0, 1.0 - p1 * p1)) + sv * p2
    p3 = math.sqrt(max(0.0, 1.0 - p1 * p1 - p2 * p2))
    hx = alpha * (p1 * t1x + p2 * t2x + p3 * a)
    hy = alpha * (p1 * t1y + p2 * t2y + p3 * b)
    hz = max(p1 * t1z + p2 * t2z + p3 * c, 1e-12)
    norm = math.sqrt(hx * hx + hy * hy + hz * hz)
    return hx / norm, hy / norm, hz / norm



# -------------------------------------------------------------------- light objects
# Blender's light objects travel as one (j, _COLUMNS) float64 array (see `pack_objects`):
# lights.LightObjects' per-light values in the columns named below (booleans as 0/1),
# plus which lights camera rays and BSDF rays can hit and which sun discs they can see.
# One array, not a tuple of 25: an inlined helper reading a tuple of arrays paid their
# reference counts on every call (~380 ns a light sample, measured; ~40 ns now).
_POINT, _SPOT, _SUN, _AREA = 0, 1, 2, 3  # lights.POINT, SPOT, SUN, AREA
(_TYPE, _POWER, _CENTRE, _AXIS_U, _AXIS_V, _DIRECTION, _LOCAL, _RADIUS, _SOFT, _COS_SPOT,
 _SPOT_SMOOTH, _COS_ANGLE, _SUN_RADIANCE, _LEN_U, _LEN_V, _ELLIPTIC, _AREA_SIZE, _SPREAD_ON,
 _SPREAD_TAN, _SPREAD_NORM, _FACTOR, _HIT_CAMERA, _HIT_BSDF, _SUN_CAMERA, _SUN_BSDF,
 _COLUMNS) = (0, 1, 4, 7, 10, 13, 16, 25, 26, 27, 28, 29, 30, 31, 32, 33, 34, 35, 36, 37, 38,
              39, 40, 41, 42, 43)


@njit(**_JIT)
def _spread(cos_theta, on, tan_half, norm):
    """lights.spread_attenuation for one cosine, with the light's constants."""
    if not on:
        return 1.0
    c = min(max(cos_theta, 1e-12), 1.0)
    tan_a = math.sqrt(max(1.0 - c * c, 0.0)) / c
    return max((tan_half - tan_a) * norm, 0.0)


@njit(inline="always", **_JIT)
def _spot(j, vx, vy, vz, L):
    """LightObjects.spot_attenuation for light j at direction v from the light."""
    if L[j, _TYPE] != _SPOT:
        return 1.0
    a = L[j, _LOCAL] * vx + L[j, _LOCAL + 1] * vy + L[j, _LOCAL + 2] * vz
    b = L[j, _LOCAL + 3] * vx + L[j, _LOCAL + 4] * vy + L[j, _LOCAL + 5] * vz
    c = L[j, _LOCAL + 6] * vx + L[j, _LOCAL + 7] * vy + L[j, _LOCAL + 8] * vz
    n = math.sqrt(a * a + b * b + c * c)
    if n > 0:
        c = c / n
    f = (-c - L[j, _COS_SPOT]) * L[j, _SPOT_SMOOTH]
    if math.isnan(f):
        f = 0.0
    elif math.isinf(f):
        f = 1.0 if f > 0 else 0.0
    f = min(max(f, 0.0), 1.0)
    return f * f * (3.0 - 2.0 * f)


@njit(**_JIT)
def _sample_cone(ax, ay, az, cos_max, ua, ub):
    """A direction uniform in the cone of half-angle acos(cos_max) about the unit axis a
    (a sphere light's visible cone, a sun's disc): (w, its cosine to a, solid-angle pdf)."""
    s, t = _build_frame(ax, ay, az)
    cos = 1.0 - ua * (1.0 - cos_max)
    sin = math.sqrt(max(0.0, 1.0 - cos * cos))
    phi = 2.0 * np.pi * ub
    a, b = sin * math.cos(phi), sin * math.sin(phi)
    return (a * s[0] + b * t[0] + cos * ax, a * s[1] + b * t[1] + cos * ay,
            a * s[2] + b * t[2] + cos * az, cos, 1.0 / (2.0 * np.pi * max(1.0 - cos_max, 1e-300)))


@njit(inline="always", **_JIT)
def _sample_object(j, px, py, pz, ua, ub, L):
    """LightObjects.sample for light j from point p: (wi, distance (inf for a sun),
    radiance / solid-angle pdf per channel, pdf (inf for delta lights))."""
    typ = L[j, _TYPE]
    p0, p1, p2 = L[j, _POWER], L[j, _POWER + 1], L[j, _POWER + 2]
    v0 = v1 = v2 = 0.0
    if typ == _POINT or typ == _SPOT:
        cx0, cy0, cz0 = L[j, _CENTRE], L[j, _CENTRE + 1], L[j, _CENTRE + 2]
        tx, ty, tz = cx0 - px, cy0 - py, cz0 - pz
        d = math.sqrt(tx * tx + ty * ty + tz * tz)
        dn = d if d > 0 else 1.0
        cx, cy, cz = tx / dn, ty / dn, tz / dn
        r = L[j, _RADIUS]
        soft = L[j, _SOFT] != 0
        wx, wy, wz, dist, pdf = cx, cy, cz, d, np.inf
        valid = True
        if r <= 0:  # intensity P / (4 pi), a delta light
            g = 4.0 * np.pi * max(d, 1e-300) ** 2
            v0, v1, v2 = p0 / g, p1 / g, p2 / g
        elif not soft:  # a sphere: uniform in its visible cone, or everywhere from inside
            inside = d <= r
            cos_max = -1.0 if inside else math.sqrt(max(0.0, 1.0 - (r / d) ** 2))
            if d <= 0.0:
                cx, cy, cz = 0.0, 0.0, 1.0
            wx, wy, wz, cos, pdf = _sample_cone(cx, cy, cz, cos_max, ua, ub)
            root = math.sqrt(max(r ** 2 - d ** 2 * (1 - cos * cos), 0.0))
            dist = d * cos + root if inside else d * cos - root
            f = L[j, _FACTOR]
            v0, v1, v2 = p0 * f / pdf, p1 * f / pdf, p2 * f / pdf
        elif soft and d > 0:  # a disk of radius r facing the point
            nx, ny, nz = -cx, -cy, -cz
            s, t = _build_frame(nx, ny, nz)
            qa, qb = _concentric_disk(ua, ub)
            qa, qb = qa * r, qb * r
            yx = cx0 + qa * s[0] + qb * t[0]
            yy = cy0 + qa * s[1] + qb * t[1]
            yz = cz0 + qa * s[2] + qb * t[2]
            tx, ty, tz = yx - px, yy - py, yz - pz
            dist = math.sqrt(tx * tx + ty * ty + tz * tz)
            wx, wy, wz = tx / dist, ty / dist, tz / dist
            cos_l = -(wx * nx + wy * ny + wz * nz)
            pdf = dist * dist / (np.pi * r ** 2 * max(cos_l, 1e-300))
            f = L[j, _FACTOR]
            v0, v1, v2 = p0 * f / pdf, p1 * f / pdf, p2 * f / pdf
        else:
            valid = False
        if valid:  # the cone along the sampled ray, as LightObjects._sample_point
            att = 1.0 if (not soft and r > 0 and d <= r) else _spot(j, -wx, -wy, -wz, L)
            v0, v1, v2 = v0 * att, v1 * att, v2 * att
        else:
            v0 = v1 = v2 = 0.0
            pdf = 0.0
        return wx, wy, wz, dist, v0, v1, v2, pdf
    if typ == _SUN:
        ax, ay, az = -L[j, _DIRECTION], -L[j, _DIRECTION + 1], -L[j, _DIRECTION + 2]
        cos_max = L[j, _COS_ANGLE]
        if cos_max < 1.0:  # a disc: uniform in its cone
            wx, wy, wz, _, pdf = _sample_cone(ax, ay, az, cos_max, ua, ub)
            k = L[j, _SUN_RADIANCE] / pdf
            return wx, wy, wz, np.inf, p0 * k, p1 * k, p2 * k, pdf
        return ax, ay, az, np.inf, p0, p1, p2, np.inf
    # Area light: a uniform point on the rectangle or ellipse.
    if L[j, _ELLIPTIC] != 0:
        la, lb = _concentric_disk(ua, ub)
        la, lb = la * 0.5, lb * 0.5
    else:
        la, lb = ua - 0.5, ub - 0.5
    ka, kb = la * L[j, _LEN_U], lb * L[j, _LEN_V]
    yx = L[j, _CENTRE] + ka * L[j, _AXIS_U] + kb * L[j, _AXIS_V]
    yy = L[j, _CENTRE + 1] + ka * L[j, _AXIS_U + 1] + kb * L[j, _AXIS_V + 1]
    yz = L[j, _CENTRE + 2] + ka * L[j, _AXIS_U + 2] + kb * L[j, _AXIS_V + 2]
    tx, ty, tz = yx - px, yy - py, yz - pz
    d = math.sqrt(tx * tx + ty * ty + tz * tz)
    dn = d if d > 0 else 1.0
    wx, wy, wz = tx / dn, ty / dn, tz / dn
    cos_l = -(wx * L[j, _DIRECTION] + wy * L[j, _DIRECTION + 1] + wz * L[j, _DIRECTION + 2])
    pdf = 0.0
    area = L[j, _AREA_SIZE]
    if cos_l > 0 and d > 0 and area > 0:
        pdf = d * d / max(area * cos_l, 1e-300)
        f = L[j, _FACTOR] * _spread(cos_l, L[j, _SPREAD_ON] != 0, L[j, _SPREAD_TAN],
                                    L[j, _SPREAD_NORM])
        v0, v1, v2 = p0 * f / pdf, p1 * f / pdf, p2 * f / pdf
    return wx, wy, wz, d, v0, v1, v2, pdf


@njit(inline="always", **_JIT)
def _object_pdf(j, ox, oy, oz, dx, dy, dz, t, L):
    """LightObjects.pdf: the solid-angle density of sampling direction d from o toward
    intersectable light j, hit at distance t."""
    typ = L[j, _TYPE]
    if typ == _AREA:
        cos_a = -(dx * L[j, _DIRECTION] + dy * L[j, _DIRECTION + 1] + dz * L[j, _DIRECTION + 2])
        return t * t / max(L[j, _AREA_SIZE] * cos_a, 1e-300)
    tx, ty, tz = L[j, _CENTRE] - ox, L[j, _CENTRE + 1] - oy, L[j, _CENTRE + 2] - oz
    d = math.sqrt(tx * tx + ty * ty + tz * tz)
    r = L[j, _RADIUS]
    if (typ == _POINT or typ == _SPOT) and r > 0:
        dn = d if d > 0 else 1.0
        if L[j, _SOFT] != 0:
            cos_d = tx / dn * dx + ty / dn * dy + tz / dn * dz
            return t * t / (np.pi * max(r * r * cos_d, 1e-300))
        cos_max = math.sqrt(max(0.0, 1.0 - (r / dn) ** 2)) if d > r else -1.0
        return 1.0 / (2.0 * np.pi * max(1.0 - cos_max, 1e-300))
    return 0.0


@njit(inline="always", **_JIT)
def _intersect_object(j, ox, oy, oz, dx, dy, dz, tmax, L):
    """LightObjects.intersect for one ray: (distance (inf: missed), radiance)."""
    th = np.inf
    f = L[j, _FACTOR]
    p0, p1, p2 = L[j, _POWER], L[j, _POWER + 1], L[j, _POWER + 2]
    c0, c1, c2 = L[j, _CENTRE], L[j, _CENTRE + 1], L[j, _CENTRE + 2]
    if L[j, _TYPE] == _AREA:
        nx, ny, nz = L[j, _DIRECTION], L[j, _DIRECTION + 1], L[j, _DIRECTION + 2]
        denom = dx * nx + dy * ny + dz * nz
        front = denom < 0  # travelling against the emission direction
        t = ((c0 - ox) * nx + (c1 - oy) * ny + (c2 - oz) * nz) / (denom if front else -1.0)
        hx, hy, hz = ox + t * dx - c0, oy + t * dy - c1, oz + t * dz - c2
        lu = (hx * L[j, _AXIS_U] + hy * L[j, _AXIS_U + 1] + hz * L[j, _AXIS_U + 2]) / L[j, _LEN_U]
        lv = (hx * L[j, _AXIS_V] + hy * L[j, _AXIS_V + 1] + hz * L[j, _AXIS_V + 2]) / L[j, _LEN_V]
        if L[j, _ELLIPTIC] != 0:
            inside = lu * lu + lv * lv <= 0.25
        else:
            inside = abs(lu) <= 0.5 and abs(lv) <= 0.5
        if front and inside and t > 0 and t < tmax:
            th = t
        f = f * _spread(-denom, L[j, _SPREAD_ON] != 0, L[j, _SPREAD_TAN], L[j, _SPREAD_NORM])
    else:
        r = L[j, _RADIUS]
        ocx, ocy, ocz = ox - c0, oy - c1, oz - c2
        if L[j, _SOFT] != 0:  # a disk facing the ray's origin
            dc = math.sqrt(ocx * ocx + ocy * ocy + ocz * ocz)
            dn = dc if dc > 0 else 1.0
            nx, ny, nz = ocx / dn, ocy / dn, ocz / dn
            denom = dx * nx + dy * ny + dz * nz
            t = (-ocx * nx + -ocy * ny + -ocz * nz) / (denom if denom < 0 else -1.0)
            hx, hy, hz = ox + t * dx - c0, oy + t * dy - c1, oz + t * dz - c2
            ok = denom < 0 and hx * hx + hy * hy + hz * hz <= r * r and t > 0
        else:
            b = ocx * dx + ocy * dy + ocz * dz
            oc2 = ocx * ocx + ocy * ocy + ocz * ocz
            disc = b * b - (oc2 - r * r)
            # The near root from outside, the far one from inside.
            t = -b - (1.0 if oc2 > r * r else -1.0) * math.sqrt(max(disc, 0.0))
            ok = disc >= 0 and t > 0
        if L[j, _TYPE] == _SPOT:
            # One-sided: a spot is hit only by rays heading toward its centre's side;
            # from inside its sphere there is no cone (Cycles' spot.h).
            ok = ok and dx * ocx + dy * ocy + dz * ocz < 0.0
            if ok and t < tmax:
                th = t
            att = 1.0
            if L[j, _SOFT] != 0 or ocx * ocx + ocy * ocy + ocz * ocz > r * r:
                att = _spot(j, -dx, -dy, -dz, L)
            return th, p0 * f * att, p1 * f * att, p2 * f * att
        if ok and t < tmax:
            th = t
    return th, p0 * f, p1 * f, p2 * f


# -------------------------------------------------------------------- environment map
# The world's equirectangular map as one tuple (see `pack_environment`):
#   0 image (H, W, 3) float32, 1 texture_from_world, 2 world_from_texture (3, 3),
#   3 pmf, 4 cdf (H W,) of its pixel distribution, 5 its light entry (-1: no map)
@njit(**_JIT)
def _env_uv(dx, dy, dz, m):
    """EnvironmentMap.to_uv for one world direction."""
    x = dx * m[0, 0] + dy * m[0, 1] + dz * m[0, 2]
    y = dx * m[1, 0] + dy * m[1, 1] + dz * m[1, 2]
    z = dx * m[2, 0] + dy * m[2, 1] + dz * m[2, 2]
    u = 0.5 - math.atan2(y, x) / (2.0 * np.pi)
    v = 0.5 + math.atan2(z, math.hypot(x, y)) / np.pi
    return u % 1.0, min(max(v, 0.0), 1.0)


@njit(inline="always", **_JIT)
def _env_lookup(u, v, image):
    """EnvironmentMap.lookup at (u, v): bilinear, wrapping in u."""
    h, w = image.shape[0], image.shape[1]
    x = u * w - 0.5
    y = min(max(v * h - 0.5, 0.0), h - 1.0)
    x0 = int(math.floor(x))
    y0 = min(int(math.floor(y)), h - 1)
    fx, fy = x - x0, y - y0
    x0 %= w
    x1 = (x0 + 1) % w
    y1 = min(y0 + 1, h - 1)
    a, b = 1 - fx, 1 - fy
    r0 = ((np.float64(image[y0, x0, 0]) * a + np.float64(image[y0, x1, 0]) * fx) * b
          + (np.float64(image[y1, x0, 0]) * a + np.float64(image[y1, x1, 0]) * fx) * fy)
    r1 = ((np.float64(image[y0, x0, 1]) * a + np.float64(image[y0, x1, 1]) * fx) * b
          + (np.float64(image[y1, x0, 1]) * a + np.float64(image[y1, x1, 1]) * fx) * fy)
    r2 = ((np.float64(image[y0, x0, 2]) * a + np.float64(image[y0, x1, 2]) * fx) * b
          + (np.float64(image[y1, x0, 2]) * a + np.float64(image[y1, x1, 2]) * fx) * fy)
    return r0, r1, r2


@njit(**_JIT)
def _env_pdf(u, v, pk, w, h):
    """The solid-angle density of a pixel of probability pk at (u, v)."""
    cos_el = math.cos((v - 0.5) * np.pi)
    return pk * w * h / (2.0 * np.pi**2 * max(cos_el, 1e-12))


@njit(inline="always", **_JIT)
def _sample_environment(ua, ub, image, to_world, pmf, cdf):
    """EnvironmentMap.sample: a pixel by luminance x solid angle, a point in it; returns
    the world direction and its solid-angle pdf."""
    h, w = image.shape[0], image.shape[1]
    k = min(np.searchsorted(cdf, ua, side="right"), len(cdf) - 1)
    cdf_lo = cdf[k - 1] if k > 0 else 0.0
    pk = pmf[k]
    fx = min(max((ua - cdf_lo) / (pk if pk > 0 else 1.0), 0.0), 1.0 - 1e-12)
    row, col = k // w, k % w
    u = (col + fx) / w
    v = (row + ub) / h
    azimuth = (0.5 - u) * 2.0 * np.pi
    elevation = (v - 0.5) * np.pi
    ce = math.cos(elevation)
    x, y, z = ce * math.cos(azimuth), ce * math.sin(azimuth), math.sin(elevation)
    m = to_world
    return (x * m[0, 0] + y * m[0, 1] + z * m[0, 2], x * m[1, 0] + y * m[1, 1] + z * m[1, 2],
            x * m[2, 0] + y * m[2, 1] + z * m[2, 2], _env_pdf(u, v, pk, w, h))


@njit(**_JIT)
def shade(depth, rev_sample, flags, exact_fresnel, geometry, materials, lights, objects, env,
          world, camera, prim, tfar, bu, bv, m, live, pseed, o64, d64, throughput, prev_pdf,
          radiance, depth_pass, normal_pass, origin32, dir32, tmax32, srow, sorigin, sdir,
          stmax, scontrib, profile):
    """One bounce for the m live rays (pixel-batch rows live[:m]) after embree's closest
    hits (prim, tfar, bu, bv), in three stages per ray:

    surface interaction - light objects crossed before the hit add their radiance;
        escaped rays take the world (colour or map); hit point, normals (flipped to the
        incoming side), depth and normal passes at depth 0, emission (MIS-weighted), the
        bounce limit, Russian roulette, absorbers;
    sample light - next-event estimation at diffuse and rough vertices: an emitter
        (emissive triangle, light object or the environment) chosen by LightSampler's
        rule, a point or direction on it, MIS against BSDF sampling; the shadow ray goes
        to the s* buffers;
    sample BSDF - diffuse, mirror, metal, glass or the layered GGX lobe; the paths that go
        on are compacted to the front of live, d64, throughput, prev_pdf, their next rays
        (offset origin) in origin32, dir32, tmax32.

    One loop with the arrays unpacked once: per-ray helper functions taking the scene's
    arrays cost reference counting per call (measured 2-10x slower). profile (3,) uint64,
    if given (an empty array: no timing), receives cycle counts: [0] the whole loop,
    [1] sample light, [2] sample BSDF; the rest of the loop is surface interaction.
    Returns (paths that go on, shadow rays written).
    """
    (max_bounces, world_light, emitters, light_sampling, shading_normals, light_hits, sun_discs,
     environment, terminator) = flags
    (vertices, tri_normal, tri_scale, material_index, normals, smooth, object_index,
     terminator_offset) = geometry
    (kind, colour, ior, reflection_tint, transmission_tint, emission, layer_base, layer_tint,
     layer_alpha, layer_fresnel, mu_grid, mu_guide, layer_fms, missing_table,
     albedo_table) = materials
    (pmf, cdf, grid, lo, cell, local_pmf, local_cdf_flat, has_mass, entry_of_triangle,
     area_by_triangle, v0, e1, e2, lnormal, larea, lradiance, lscale) = lights
    cam_pos, forward = camera
    num_tri = len(v0)  # light entries 0..num_tri-1 are triangles, then the light objects
    L = objects
    n_obj = L.shape[0]
    hit_seen = _HIT_CAMERA if depth == 0 else _HIT_BSDF  # camera rays / BSDF rays
    sun_seen = _SUN_CAMERA if depth == 0 else _SUN_BSDF
    env_image, env_from_world, env_to_world, env_pmf, env_cdf, env_entry = env
    env_h, env_w = env_image.shape[0], env_image.shape[1]
    timing = len(profile) == 3
    if timing:
        c_loop = _cycles()
    out = 0
    shadow = 0
    for i in range(m):
        row = live[i]
        pseed_row = pseed[row]
        t0, t1, t2 = throughput[i, 0], throughput[i, 1], throughput[i, 2]
        dx, dy, dz = d64[i, 0], d64[i, 1], d64[i, 2]
        f = prim[i]
        if light_hits or sun_discs:
            # Light objects crossed before the surface (lights are transparent), then sun
            # discs for escaped rays, MIS-weighted after soft bounces
            # (Integrator.handle_light_hits).
            ox, oy, oz = o64[i, 0], o64[i, 1], o64[i, 2]
            mis = light_sampling and not math.isinf(prev_pdf[i])
            t_surface = np.float64(tfar[i]) if f >= 0 else np.float64(tmax32[i])
            for j in range(n_obj):
                if L[j, hit_seen] == 0:
                    continue
                th, l0, l1, l2 = _intersect_object(j, ox, oy, oz, dx, dy, dz, t_surface, L)
                if math.isinf(th):
                    continue
                w = 1.0
                if mis:
                    pdf_l = _entry_pmf(ox, oy, oz, num_tri + j, pmf, grid, lo, cell, local_pmf,
                                       has_mass) * _object_pdf(j, ox, oy, oz, dx, dy, dz, th, L)
                    w = _power_heuristic(prev_pdf[i], pdf_l)
                radiance[row, 0] += t0 * l0 * w
                radiance[row, 1] += t1 * l1 * w
                radiance[row, 2] += t2 * l2 * w
            if sun_discs and f < 0:
                for j in range(n_obj):
                    cos_half = L[j, _COS_ANGLE]
                    if L[j, sun_seen] == 0 or not (
                            dx * -L[j, _DIRECTION] + dy * -L[j, _DIRECTION + 1]
                            + dz * -L[j, _DIRECTION + 2] >= cos_half):
                        continue
                    w = 1.0
                    if mis:
                        pdf_l = _entry_pmf(ox, oy, oz, num_tri + j, pmf, grid, lo, cell,
                                           local_pmf, has_mass) / (
                            2.0 * np.pi * (1.0 - cos_half))
                        w = _power_heuristic(prev_pdf[i], pdf_l)
                    sr = L[j, _SUN_RADIANCE]
                    radiance[row, 0] += t0 * (L[j, _POWER] * sr) * w
                    radiance[row, 1] += t1 * (L[j, _POWER + 1] * sr) * w
                    radiance[row, 2] += t2 * (L[j, _POWER + 2] * sr) * w
        # ---- surface interaction
        if f < 0:
            if environment:
                # The map, MIS-weighted against its light sampling after soft bounces.
                u_e, v_e = _env_uv(dx, dy, dz, env_from_world)
                l0, l1, l2 = _env_lookup(u_e, v_e, env_image)
                w = 1.0
                if light_sampling and not math.isinf(prev_pdf[i]):
                    col = min(int(u_e * env_w), env_w - 1)
                    erow = min(int(v_e * env_h), env_h - 1)
                    pdf_l = _entry_pmf(o64[i, 0], o64[i, 1], o64[i, 2], env_entry, pmf, grid, lo,
                                       cell, local_pmf, has_mass) * _env_pdf(
                        u_e, v_e, env_pmf[erow * env_w + col], env_w, env_h)
                    w = _power_heuristic(prev_pdf[i], pdf_l)
                radiance[row, 0] += t0 * l0 * w
                radiance[row, 1] += t1 * l1 * w
                radiance[row, 2] += t2 * l2 * w
            elif world_light:
                radiance[row, 0] += t0 * world[0]
                radiance[row, 1] += t1 * world[1]
                radiance[row, 2] += t2 * world[2]
            continue
        # Hit point from the barycentrics in float64 (embree works in float32).
        u = np.float64(bu[i])
        v = np.float64(bv[i])
        w0 = 1.0 - u - v
        px = w0 * vertices[f, 0, 0] + u * vertices[f, 1, 0] + v * vertices[f, 2, 0]
        py = w0 * vertices[f, 0, 1] + u * vertices[f, 1, 1] + v * vertices[f, 2, 1]
        pz = w0 * vertices[f, 0, 2] + u * vertices[f, 1, 2] + v * vertices[f, 2, 2]
        nx, ny, nz = tri_normal[f, 0], tri_normal[f, 1], tri_normal[f, 2]
        front = dx * nx + dy * ny + dz * nz < 0.0
        sign = 1.0 if front else -1.0
        nx, ny, nz = nx * sign, ny * sign, nz * sign
        sx, sy, sz = nx, ny, nz
        if shading_normals and smooth[f]:
            ax = (w0 * normals[f, 0, 0] + u * normals[f, 1, 0] + v * normals[f, 2, 0]) * sign
            ay = (w0 * normals[f, 0, 1] + u * normals[f, 1, 1] + v * normals[f, 2, 1]) * sign
            az = (w0 * normals[f, 0, 2] + u * normals[f, 1, 2] + v * normals[f, 2, 2]) * sign
            length = math.sqrt(ax * ax + ay * ay + az * az)
            if length > 1e-12:
                sx, sy, sz = ax / length, ay / length, az / length
        if depth == 0:
            depth_pass[row] = ((px - cam_pos[0]) * forward[0] + (py - cam_pos[1]) * forward[1]
                               + (pz - cam_pos[2]) * forward[2])
            normal_pass[row, 0], normal_pass[row, 1], normal_pass[row, 2] = sx, sy, sz
        mat = material_index[f]
        # Emission: two-sided, MIS-weighted against light sampling after soft bounces.
        if emitters:
            le0, le1, le2 = emission[mat, 0], emission[mat, 1], emission[mat, 2]
            if max(le0, max(le1, le2)) > 0:
                w = 1.0
                if light_sampling and not math.isinf(prev_pdf[i]):
                    t = np.float64(tfar[i])
                    cos_l = abs(nx * dx + ny * dy + nz * dz)
                    ox, oy, oz = px - dx * t, py - dy * t, pz - dz * t
                    entry = entry_of_triangle[f]
                    pm = 0.0
                    if entry >= 0 and grid == 0:
                        pm = pmf[entry]
                    elif entry >= 0:
                        pm = _entry_pmf(ox, oy, oz, entry, pmf, grid, lo, cell, local_pmf,
                                        has_mass)
                    pdf_l = pm / area_by_triangle[f] * t * t / max(cos_l, 1e-300)
                    w = _power_heuristic(prev_pdf[i], pdf_l)
                radiance[row, 0] += t0 * le0 * w
                radiance[row, 1] += t1 * le1 * w
                radiance[row, 2] += t2 * le2 * w
        # Vertex max_bounces + 1 only adds emission; a pure emitter ends the path.
        k = kind[mat]
        if depth > max_bounces or k == NONE:
            continue
        if depth >= ROULETTE_MIN_BOUNCE:
            q = min(math.sqrt(max(t0, max(t1, t2))), 1.0)
            if not sample_1d(pseed_row, rev_sample, _bounce_dim(depth, _ROULETTE)) < q:
                continue
            t0, t1, t2 = t0 / q, t1 / q, t2 / q
        scale = max(tri_scale[f], max(abs(px), max(abs(py), abs(pz))))
        wox, woy, woz = -dx, -dy, -dz
        rough = k == PRINCIPLED or k == GLOSSY
        comp0 = comp1 = comp2 = albedo = alpha = eta_l = p_spec = 0.0
        dw0 = dw1 = dw2 = tint0 = tint1 = tint2 = 0.0
        fresnel_on = False
        # Specular lobes (delta and GGX) use the shading normal tilted so the mirror
        # direction stays above the surface (bsdf.valid_specular_normal); diffuse ones s.
        msx, msy, msz = sx, sy, sz
        if k != DIFFUSE:
            msx, msy, msz = valid_specular_normal(nx, ny, nz, wox, woy, woz, sx, sy, sz)
        if rough:
            # The layered lobe's parameters at this view direction (Integrator._layer).
            mu = min(max(msx * wox + msy * woy + msz * woz, 0.0), 1.0)
            missing = _interp(mu, mu_grid, missing_table[mat], mu_guide)
            comp0 = 1.0 + layer_fms[mat, 0] * missing
            comp1 = 1.0 + layer_fms[mat, 1] * missing
            comp2 = 1.0 + layer_fms[mat, 2] * missing
            albedo = _interp(mu, mu_grid, albedo_table[mat], mu_guide)
            dw0 = layer_base[mat, 0] * (1.0 - albedo)
            dw1 = layer_base[mat, 1] * (1.0 - albedo)
            dw2 = layer_base[mat, 2] * (1.0 - albedo)
            tint0, tint1, tint2 = layer_tint[mat, 0], layer_tint[mat, 1], layer_tint[mat, 2]
            sp = (tint0 + tint1 + tint2) / 3.0 * albedo
            sd = (dw0 + dw1 + dw2) / 3.0
            p_spec = sp / max(sp + sd, 1e-300) if sp + sd > 0 else 1.0
            alpha, eta_l, fresnel_on = layer_alpha[mat], ior[mat], layer_fresnel[mat]
        if timing:
            c_light = _cycles()
        # ---- sample light
        if light_sampling and (k == DIFFUSE or rough):
            u_sel = sample_1d(pseed_row, rev_sample, _bounce_dim(depth, _LIGHT_SELECT))
            ua, ub = sample_2d(pseed_row, rev_sample, _bounce_dim(depth, _LIGHT_POINT))
            if grid == 0:  # inline fast path: the general call costs ~35 ns a sample
                e = min(np.searchsorted(cdf, u_sel, side="right"), len(pmf) - 1)
                p_sel = pmf[e]
            else:
                e, p_sel = _choose(px, py, pz, u_sel, pmf, cdf, grid, lo, cell, local_pmf,
                                   local_cdf_flat, has_mass)
            # The emitter: direction, distance (inf: none), radiance / (selection x pdf)
            # and the combined pdf, as LightSampler.sample.
            if e < num_tri:
                # Uniform point on the triangle (Heitz's low-distortion map, as sampling.py).
                if ua < ub:
                    b0, b1 = ua / 2, ub - ua / 2
                else:
                    b0, b1 = ua - ub / 2, ub / 2
                b2 = 1.0 - b0 - b1
                tx = v0[e, 0] + b1 * e1[e, 0] + b2 * e2[e, 0] - px
                ty = v0[e, 1] + b1 * e1[e, 1] + b2 * e2[e, 1] - py
                tz = v0[e, 2] + b1 * e1[e, 2] + b2 * e2[e, 2] - pz
                dist = math.sqrt(tx * tx + ty * ty + tz * tz)
                dn = dist if dist > 0 else 1.0
                wx, wy, wz = tx / dn, ty / dn, tz / dn
                cos_l = abs(lnormal[e, 0] * wx + lnormal[e, 1] * wy + lnormal[e, 2] * wz)
                q0 = q1 = q2 = pdf_o = 0.0
                if cos_l > 0 and dist > 0:
                    pdf_o = dist * dist / max(larea[e] * cos_l, 1e-300)
                    inv = 1.0 / pdf_o
                    q0, q1, q2 = lradiance[e, 0] * inv, lradiance[e, 1] * inv, lradiance[e, 2] * inv
                light_scale = lscale[e]
            elif e == env_entry:  # the environment map: a direction, no distance
                wx, wy, wz, pdf_o = _sample_environment(ua, ub, env_image, env_to_world,
                                                        env_pmf, env_cdf)
                u_e, v_e = _env_uv(wx, wy, wz, env_from_world)
                q0, q1, q2 = _env_lookup(u_e, v_e, env_image)
                pd = max(pdf_o, 1e-300)
                q0, q1, q2, dist, light_scale = q0 / pd, q1 / pd, q2 / pd, np.inf, 0.0
            else:  # a light object
                wx, wy, wz, dist, q0, q1, q2, pdf_o = _sample_object(
                    e - num_tri, px, py, pz, ua, ub, L)
                light_scale = 0.0
                if not math.isinf(dist):
                    light_scale = max(abs(px + wx * dist), max(abs(py + wy * dist),
                                                               abs(pz + wz * dist)))
            ps = p_sel if p_sel > 0 else 1.0
            q0, q1, q2 = q0 / ps, q1 / ps, q2 / ps
            pdf_l = pdf_o * p_sel
            # The BSDF's f cos and pdf toward it (Integrator.eval_bsdf).
            g0 = g1 = g2 = pdf_b = 0.0
            if rough:
                g0, g1, g2, pdf_b = _eval_layered(
                    wox, woy, woz, wx, wy, wz, sx, sy, sz, msx, msy, msz, nx, ny, nz, dw0, dw1, dw2,
                    tint0, tint1, tint2, alpha, eta_l, fresnel_on, comp0, comp1, comp2,
                    p_spec, False)
            else:  # Lambert: the shading normal alone, as bsdf.eval_diffuse
                cos = wx * sx + wy * sy + wz * sz
                if cos > 0:
                    pdf_b = cos / np.pi
                    g0, g1, g2 = colour[mat, 0] * pdf_b, colour[mat, 1] * pdf_b, \
                        colour[mat, 2] * pdf_b
            if max(g0, max(g1, g2)) > 0 and max(q0, max(q1, q2)) > 0 and dist > 0:
                # MIS-weighted (delta lights take it all); the shadow ray starts at the
                # offset point and aims at the sampled point itself, stopping just short.
                w = 1.0 if math.isinf(pdf_l) else _power_heuristic(pdf_l, pdf_b)
                c0, c1, c2 = t0 * g0 * q0 * w, t1 * g1 * q1 * w, t2 * g2 * q2 * w
                if max(c0, max(c1, c2)) > 0:
                    eps = RAY_EPSILON * max(scale, 1e-30)
                    ox, oy, oz = px, py, pz
                    if terminator and smooth[f]:
                        # Lifted toward the smooth surface near the terminator (as
                        # Integrator.terminator_offsets).
                        cutoff = terminator_offset[object_index[f]]
                        if cutoff > 0.0:
                            amount, gx, gy, gz = offset_amount(cutoff, sx, sy, sz, nx, ny, nz,
                                                               wx, wy, wz)
                            if amount > 0.0:
                                lx, ly, lz = smooth_surface_offset(vertices[f], normals[f], w0,
                                                                   u, v, gx, gy, gz)
                                ox, oy, oz = ox + lx * amount, oy + ly * amount, oz + lz * amount
                    if wx * nx + wy * ny + wz * nz < 0.0:  # toward wi's side, as
                        eps = -eps  # integrator.offset_ray_origin
                    ox, oy, oz = ox + eps * nx, oy + eps * ny, oz + eps * nz
                    srow[shadow] = row
                    sorigin[shadow, 0], sorigin[shadow, 1], sorigin[shadow, 2] = ox, oy, oz
                    if math.isinf(dist):
                        sdir[shadow, 0], sdir[shadow, 1], sdir[shadow, 2] = wx, wy, wz
                        stmax[shadow] = 3e38
                    else:
                        gx = px + wx * dist - ox
                        gy = py + wy * dist - oy
                        gz = pz + wz * dist - oz
                        seg = math.sqrt(gx * gx + gy * gy + gz * gz)
                        sl = max(seg, 1e-300)
                        sdir[shadow, 0], sdir[shadow, 1], sdir[shadow, 2] = (gx / sl, gy / sl,
                                                                             gz / sl)
                        stmax[shadow] = seg - RAY_EPSILON * max(light_scale, 1e-30)
                    scontrib[shadow, 0], scontrib[shadow, 1], scontrib[shadow, 2] = c0, c1, c2
                    shadow += 1
        if timing:
            c_bsdf = _cycles()
            profile[1] += c_bsdf - c_light
        # ---- sample BSDF
        pdf = np.inf
        if rough:
            # Pick the specular or the diffuse layer, then evaluate the mixture (one-sample
            # MIS over the lobes), as bsdf.sample_layered.
            u_lobe = sample_1d(pseed_row, rev_sample, _bounce_dim(depth, _LOBE))
            ua, ub = sample_2d(pseed_row, rev_sample, _bounce_dim(depth, _BSDF))
            if u_lobe < p_spec:
                s, tt = _build_frame(msx, msy, msz)
                v0_ = wox * s[0] + woy * s[1] + woz * s[2]
                v1_ = wox * tt[0] + woy * tt[1] + woz * tt[2]
                v2_ = wox * msx + woy * msy + woz * msz
                hx, hy, hz = _ggx_half_vector(v0_, v1_, v2_, alpha, ua, ub)
                mx = hx * s[0] + hy * tt[0] + hz * msx
                my = hx * s[1] + hy * tt[1] + hz * msy
                mz = hx * s[2] + hy * tt[2] + hz * msz
                c = 2.0 * (mx * wox + my * woy + mz * woz)
                wx, wy, wz = c * mx - wox, c * my - woy, c * mz - woz
            else:
                s, tt = _build_frame(sx, sy, sz)
                lx, ly = _concentric_disk(ua, ub)
                lz = math.sqrt(max(0.0, 1.0 - (lx * lx + ly * ly)))
                wx = lx * s[0] + ly * tt[0] + lz * sx
                wy = lx * s[1] + ly * tt[1] + lz * sy
                wz = lx * s[2] + ly * tt[2] + lz * sz
            g0, g1, g2, pdf = _eval_layered(
                wox, woy, woz, wx, wy, wz, sx, sy, sz, msx, msy, msz, nx, ny, nz, dw0, dw1, dw2,
                tint0, tint1, tint2, alpha, eta_l, fresnel_on, comp0, comp1, comp2,
                    p_spec, True)
            ok = pdf > 0
            f0, f1, f2 = (g0 / pdf, g1 / pdf, g2 / pdf) if ok else (0.0, 0.0, 0.0)
        elif k == DIFFUSE:
            ua, ub = sample_2d(pseed_row, rev_sample, _bounce_dim(depth, _BSDF))
            # Concentric disk, then Malley's method about the shading normal.
            lx, ly = _concentric_disk(ua, ub)
            lz = math.sqrt(max(0.0, 1.0 - (lx * lx + ly * ly)))
            s, tt = _build_frame(sx, sy, sz)
            wx = lx * s[0] + ly * tt[0] + lz * sx
            wy = lx * s[1] + ly * tt[1] + lz * sy
            wz = lx * s[2] + ly * tt[2] + lz * sz
            ok = wx * nx + wy * ny + wz * nz > 0.0 and lz > 0.0
            f0, f1, f2 = colour[mat, 0], colour[mat, 1], colour[mat, 2]
            pdf = lz / np.pi
        else:
            sx, sy, sz = msx, msy, msz
            cos_o = sx * wox + sy * woy + sz * woz
            wx, wy, wz = 2.0 * cos_o * sx - wox, 2.0 * cos_o * sy - woy, 2.0 * cos_o * sz - woz
            ok = True
            if k == MIRROR:
                f0, f1, f2 = colour[mat, 0], colour[mat, 1], colour[mat, 2]
            elif k == METAL:
                c = (1.0 - min(max(abs(cos_o), 0.0), 1.0)) ** 5
                g0 = min(max(colour[mat, 0], 0.0), 1.0)
                g1 = min(max(colour[mat, 1], 0.0), 1.0)
                g2 = min(max(colour[mat, 2], 0.0), 1.0)
                f0 = min(max(g0 + (1.0 - g0) * c, 0.0), 1.0)
                f1 = min(max(g1 + (1.0 - g1) * c, 0.0), 1.0)
                f2 = min(max(g2 + (1.0 - g2) * c, 0.0), 1.0)
            else:  # GLASS
                eta = ior[mat] if front else 1.0 / ior[mat]
                fr, cos_t = _fresnel_dielectric(cos_o, eta, exact_fresnel)
                r0 = fr * reflection_tint[mat, 0]
                r1 = fr * reflection_tint[mat, 1]
                r2 = fr * reflection_tint[mat, 2]
                q0 = (1.0 - fr) * transmission_tint[mat, 0]
                q1 = (1.0 - fr) * transmission_tint[mat, 1]
                q2 = (1.0 - fr) * transmission_tint[mat, 2]
                r_avg = (r0 + r1 + r2) / 3.0
                t_avg = (q0 + q1 + q2) / 3.0
                total = r_avg + t_avg
                ok = total > 0
                p_reflect = r_avg / total if ok else 1.0
                if sample_1d(pseed_row, rev_sample, _bounce_dim(depth, _LOBE)) < p_reflect:
                    inv = 1.0 / max(p_reflect, 1e-300)
                    f0, f1, f2 = r0 * inv, r1 * inv, r2 * inv
                else:
                    inv = 1.0 / max(1.0 - p_reflect, 1e-300)
                    f0, f1, f2 = q0 * inv, q1 * inv, q2 * inv
                    c = cos_o / eta - cos_t
                    wx = -wox / eta + c * sx
                    wy = -woy / eta + c * sy
                    wz = -woz / eta + c * sz
                length = math.sqrt(wx * wx + wy * wy + wz * wz)
                wx, wy, wz = wx / length, wy / length, wz / length
        t0, t1, t2 = t0 * f0, t1 * f1, t2 * f2
        if ok and max(t0, max(t1, t2)) > 0:
            # Spawn: leave the surface toward the side of the new direction.
            side = 1.0 if wx * nx + wy * ny + wz * nz >= 0.0 else -1.0
            eps = side * RAY_EPSILON * max(scale, 1e-30)
            o64[out, 0] = px + eps * nx
            o64[out, 1] = py + eps * ny
            o64[out, 2] = pz + eps * nz
            origin32[out, 0], origin32[out, 1], origin32[out, 2] = (o64[out, 0], o64[out, 1],
                                                                    o64[out, 2])
            dir32[out, 0], dir32[out, 1], dir32[out, 2] = wx, wy, wz
            tmax32[out] = np.inf
            d64[out, 0], d64[out, 1], d64[out, 2] = wx, wy, wz
            throughput[out, 0], throughput[out, 1], throughput[out, 2] = t0, t1, t2
            prev_pdf[out] = pdf
            live[out] = row
            out += 1
        if timing:
            profile[2] += _cycles() - c_bsdf
    if timing:
        profile[0] += _cycles() - c_loop
    return out, shadow


@njit(**_JIT)
def all_finite(radiance, depth, normal):
    """Whether every sample of a chunk is finite in all the passes it feeds."""
    for i in range(len(depth)):
        if not (np.isfinite(radiance[i, 0]) and np.isfinite(radiance[i, 1])
                and np.isfinite(radiance[i, 2]) and np.isfinite(depth[i])
                and np.isfinite(normal[i, 0]) and np.isfinite(normal[i, 1])
                and np.isfinite(normal[i, 2])):
            return False
    return True


@njit(**_JIT)
def accumulate_unoccluded(radiance, srow, scontrib, occluded_prim, count):
    """Add the contributions of shadow rays that reached their light (embree's occlusion
    query leaves prim -1 on unblocked rays)."""
    for j in range(count):
        if occluded_prim[j] < 0:
            row = srow[j]
            radiance[row, 0] += scontrib[j, 0]
            radiance[row, 1] += scontrib[j, 1]
            radiance[row, 2] += scontrib[j, 2]


# -------------------------------------------------------------------- camera rays
def interp_guide(xp: np.ndarray, cells: int = 16384) -> np.ndarray:
    """Index guide for `_interp` on xp in [0, 1]: guide[c] = the last j with xp[j] <= c /
    cells (-1 if none), for c = 0..cells."""
    return np.searchsorted(xp, np.arange(cells + 1) / cells, side="right") - 1


@njit(**_JIT)
def _interp(x, xp, fp, guide):
    """np.interp for one x in [0, 1], bit-identical (the pixel filter's inverse CDF, the
    microfacet tables over mu). A binary search over the whole 16k-entry filter table
    mispredicts a branch per level (~150 ns a sample); the guide starts at x's cell, a
    step or two short of the answer."""
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


@njit(**_JIT)
def generate_camera_rays(pixels, sample, seed, width, filter_cdf, filter_x, filter_guide, view,
                         lens,
                         world_from_camera, position, pseed, origin32, dir32, tmax32, o64,
                         d64):
    """Camera rays for pixel ids (n,) as CameraModel.generate_rays, with the filter
    offsets and lens points of the numpy path; also fills each pixel's sequence seed.

    view = (width, height, half_x, half_y, fit_half, shift_x, shift_y, clip_start,
    clip_end, ortho); lens = (aperture, blades, rotation, ratio, focus) (aperture 0: pinhole).
    """
    rev_sample = _reverse(np.uint64(sample))
    w_img, h_img, half_x, half_y, fit_half, shift_x, shift_y, clip_start, clip_end, ortho = view
    aperture, blades, rotation, ratio, focus = lens
    m = world_from_camera
    for i in range(len(pixels)):
        ps = pixel_seed(pixels[i], seed)
        pseed[i] = ps
        fx, fy = sample_2d(ps, rev_sample, 0) if sample != 0 else (0.5, 0.5)
        rx = (pixels[i] % width) + 0.5 + _interp(fx, filter_cdf, filter_x, filter_guide)
        ry = (pixels[i] // width) + 0.5 + _interp(fy, filter_cdf, filter_x, filter_guide)
        x = (2.0 * rx / w_img - 1.0) * half_x + shift_x * 2 * fit_half
        y = (2.0 * ry / h_img - 1.0) * half_y + shift_y * 2 * fit_half
        lx = ly = 0.0
        if aperture > 0.0:
            ua, ub = sample_2d(ps, rev_sample, 1)
            if blades >= 3:
                nb = int(blades)
                corner = min(math.floor(ua * nb), nb - 1)
                sv = math.sqrt(min(max(ua * nb - corner, 0.0), 1.0))
                ang = np.pi / nb
                tx = sv * math.cos(ang)
                ty = sv * math.sin(ang) * (2.0 * ub - 1.0)
                phi = rotation + corner * (2.0 * np.pi / nb)
                c, sn = math.cos(phi), math.sin(phi)
                lx, ly = c * tx - sn * ty, sn * tx + c * ty
            else:
                lx, ly = _concentric_disk(ua, ub)
            lx, ly = lx * aperture / ratio, ly * aperture
        if ortho:
            px, py, pz = x, y, 0.0
            dx, dy, dz = 0.0, 0.0, 1.0
            if aperture > 0.0:
                px, py = px + lx, py + ly
                norm = math.sqrt(lx * lx + ly * ly + focus * focus)
                dx, dy, dz = -lx / norm, -ly / norm, focus / norm
            px, py, pz = px + clip_start * dx, py + clip_start * dy, pz + clip_start * dz
            tmax = clip_end - clip_start
        else:
            norm = math.sqrt(x * x + y * y + 1.0)
            dx, dy, dz = x / norm, y / norm, 1.0 / norm
            z_inv = 1.0 / dz
            px = py = pz = 0.0
            if aperture > 0.0:
                k = focus / dz
                fx_, fy_, fz_ = dx * k - lx, dy * k - ly, dz * k
                norm = math.sqrt(fx_ * fx_ + fy_ * fy_ + fz_ * fz_)
                dx, dy, dz = fx_ / norm, fy_ / norm, fz_ / norm
                px, py = lx, ly
            c = clip_start * z_inv
            px, py, pz = px + c * dx, py + c * dy, pz + c * dz
            tmax = (clip_end - clip_start) * z_inv
        for j in range(3):
            o64[i, j] = px * m[j, 0] + py * m[j, 1] + pz * m[j, 2] + position[j]
            origin32[i, j] = o64[i, j]
            dj = dx * m[j, 0] + dy * m[j, 1] + dz * m[j, 2]
            dir32[i, j] = dj
            d64[i, j] = dj
        tmax32[i] = min(tmax, 3e38)


# -------------------------------------------------------------------- the bounce loop
F32 = np.float32


def unsupported(scene, plan) -> str:
    """Why the kernels cannot render this scene ("" if they can)."""
    kinds = set(scene.materials.kind[np.unique(scene.material_index)].tolist())
    extra = sorted(kinds - set(SUPPORTED))
    if extra:
        from .scene import KIND_NAMES
        return "material kinds " + ", ".join(KIND_NAMES[k] for k in extra)
    return ""


def pack_layers(it) -> tuple:
    """The rough materials' layered-lobe parameters per material (Integrator._layer):
    base (k, 3), specular tint (k, 3), alpha (k,), dielectric Fresnel (k,) bool, the mu
    grid (m,) with its `_interp` guide, Fms per channel (k, 3) (bsdf.layer_fms), and the
    missing-energy and albedo tables (k, m); zeros for other kinds."""
    from .bsdf import ALBEDO_TABLE_SIZE, layer_fms
    k = len(it.kind)
    base, tint = np.zeros((k, 3)), np.zeros((k, 3))
    alpha, fresnel, fms = np.zeros(k), np.zeros(k, np.bool_), np.zeros((k, 3))
    mu = np.linspace(1e-3, 1.0, ALBEDO_TABLE_SIZE)
    missing, albedo = np.zeros((k, len(mu))), np.zeros((k, len(mu)))
    for j, tables in it.microfacet.items():
        principled = it.kind[j] == PRINCIPLED
        base[j] = it.colour[j] if principled else 0.0
        tint[j] = 1.0 if principled else it.colour[j]
        alpha[j], fresnel[j] = tables.alpha, principled
        fms[j] = layer_fms(tables, principled, it.colour[j])
        mu = tables.mu
        missing[j], albedo[j] = tables.missing_table, tables.albedo_table
    return base, tint, alpha, fresnel, mu, interp_guide(mu, 256), fms, missing, albedo


def pack_objects(sampler) -> np.ndarray:
    """The light objects as the kernels' (j, _COLUMNS) array (columns above)."""
    from .lights import SUN
    if sampler is None or sampler.objects.count == 0:
        return np.zeros((0, _COLUMNS))
    o = sampler.objects
    h = o.half_spread
    spread_on = h < 0.5 * np.pi - 1e-6
    # spread_attenuation's constants, computed as it does (numpy scalars).
    tan_half = np.array([np.tan(x) for x in h])
    norm = np.array([3.0 / x**3 if x <= 0.05 else 1.0 / (np.tan(x) - x) if on else 0.0
                     for x, on in zip(h, spread_on)])
    lit = o.power.max(axis=1) > 0
    hit = o.intersectable & lit
    sun = (o.type == SUN) & (o.cos_half_angle < 1.0) & lit
    columns = [(_TYPE, o.type), (_POWER, o.power), (_CENTRE, o.centre), (_AXIS_U, o.axis_u),
               (_AXIS_V, o.axis_v), (_DIRECTION, o.direction),
               (_LOCAL, o.local_from_world.reshape(-1, 9)), (_RADIUS, o.radius),
               (_SOFT, o.soft), (_COS_SPOT, o.cos_half_spot), (_SPOT_SMOOTH, o.spot_smooth),
               (_COS_ANGLE, o.cos_half_angle), (_SUN_RADIANCE, o.sun_radiance),
               (_LEN_U, o.len_u), (_LEN_V, o.len_v), (_ELLIPTIC, o.elliptic),
               (_AREA_SIZE, o.area), (_SPREAD_ON, spread_on), (_SPREAD_TAN, tan_half),
               (_SPREAD_NORM, norm), (_FACTOR, o.radiance_factor),
               (_HIT_CAMERA, hit & o.visible_camera), (_HIT_BSDF, hit & o.use_mis),
               (_SUN_CAMERA, sun & o.visible_camera), (_SUN_BSDF, sun & o.use_mis)]
    data = np.zeros((o.count, _COLUMNS))
    for col, values in columns:
        values = np.asarray(values, np.float64).reshape(o.count, -1)
        data[:, col:col + values.shape[1]] = values
    return data


def pack_environment(sampler) -> tuple:
    """The environment map as the kernels' tuple (layout above); a 1-pixel stand-in and
    entry -1 without one."""
    env = sampler.environment if sampler is not None else None
    if env is None:
        return (np.zeros((1, 1, 3), np.float32), np.eye(3), np.eye(3), np.ones(1), np.ones(1),
                -1)
    return (env.image, np.ascontiguousarray(env.texture_from_world, np.float64),
            np.ascontiguousarray(env.world_from_texture, np.float64), env.distribution.pmf,
            env.distribution.cdf, int(sampler.environment_index))


def pack_lights(sampler, num_triangles: int) -> tuple:
    """The emitters as the kernels' tuple (layout above); empty arrays without emitters."""
    if sampler is None:
        z3, z = np.zeros((0, 3)), np.zeros(0)
        return (z, z, 0, np.zeros(3), np.ones(3), np.zeros((1, 0)), z, np.zeros(1, np.bool_),
                np.full(num_triangles, -1, np.int64), np.ones(num_triangles), z3, z3, z3, z3,
                z, z3, z)
    s = sampler
    if hasattr(s, "local_pmf"):
        grid = (s.GRID, s.grid_lo, s.cell, s.local_pmf, s.local_cdf_flat, s.grid_has_mass)
    else:
        grid = (0, np.zeros(3), np.ones(3), np.zeros((1, s.num_entries)), np.zeros(0),
                np.zeros(1, np.bool_))
    return (s.distribution.pmf, s.distribution.cdf, *grid, s.entry_of_triangle,
            s.area_by_triangle, s.v0, s.e1, s.e2, s.normal, s.area, s.radiance, s.scale)


class CompiledTracer:
    """The bounce loop over the compiled stages; embree calls stay in Python (they release
    the GIL). Built by `Integrator` when the plan selects the compiled kernel.

    Each bounce is one `shade` call between the closest-hit and the shadow-ray queries.
    With `profile` on (the benchmark's profile) `shade` also counts cycles per stage, and
    its time is split into surface interaction, light sampling and BSDF sampling."""

    profile = False

    def __init__(self, integrator):
        it = self.it = integrator
        scene, plan = it.scene, it.plan
        normals = scene.normals if scene.normals is not None else np.zeros((1, 3, 3))
        self.geometry = (scene.vertices, it.tri_normal, it.tri_scale,
                         scene.material_index.astype(np.int64), normals,
                         scene.smooth.astype(np.bool_), scene.object_index.astype(np.int64),
                         np.asarray(scene.terminator_offset, np.float64))
        self.materials = (it.kind.astype(np.int64), it.colour, it.ior, it.reflection_tint,
                          it.transmission_tint, it.emission, *pack_layers(it))
        self.lights = pack_lights(it.emitters, scene.num_triangles)
        self.objects = pack_objects(it.emitters)
        self.environment = pack_environment(it.emitters)
        self.world = it.world
        self.camera = (it.camera.position, it.camera.forward)
        self.flags = (int(it.settings.max_bounces), bool(plan.world_light),
                      bool(plan.num_emitters), bool(plan.light_sampling),
                      bool(plan.shading_normals), bool(plan.light_hits),
                      bool(plan.sun_discs), bool(plan.environment), bool(plan.terminator))
        self.exact_fresnel = it.settings.fresnel == "exact"
        cm, cam = it.camera, it.camera.cam
        self.filter_cdf, self.filter_x = it.pixel_filter._cdf, it.pixel_filter._x
        self.filter_guide = interp_guide(self.filter_cdf)
        self.view = (float(cm.width), float(cm.height), cm.half_x, cm.half_y, cm.fit_half,
                     float(cam.shift_x), float(cam.shift_y), float(cam.clip_start),
                     float(cam.clip_end), cam.type == "ORTHO")
        self.lens = (float(cm.aperture) if it.plan.dof else 0.0, float(cm.blades),
                     float(cam.rotation), float(cam.ratio), float(cm.focus))
        self.world_from_camera = np.ascontiguousarray(cm.world_from_camera)
        self.position = np.asarray(cm.position, np.float64)

    def _count_shade(self, seconds: float, profile: np.ndarray) -> None:
        if len(profile) == 0 or profile[0] == 0:
            self.it._count("shade", seconds)
            return
        light, bsdf = profile[1] / profile[0], profile[2] / profile[0]
        self.it._count("surface interaction", seconds * (1.0 - light - bsdf))
        self.it._count("sample light", seconds * light)
        self.it._count("sample BSDF", seconds * bsdf)
        profile[:] = 0

    def trace_pixels(self, pixels: np.ndarray, sample: int):
        """As Integrator.trace_pixels: one sample for each pixel in `pixels` (n,)."""
        it = self.it
        n = len(pixels)
        seed = it.settings.seed
        radiance = np.zeros((n, 3))
        depth_pass = np.full(n, BACKGROUND_DEPTH)
        normal_pass = np.zeros((n, 3))
        rev_sample = np.uint64(sampling.reverse_bits(np.array([sample], np.uint32))[0])
        t0 = time.perf_counter()
        pseed = np.empty(n, np.uint64)
        origin32, dir32, tmax32 = np.empty((n, 3), F32), np.empty((n, 3), F32), np.empty(n, F32)
        o64, d64 = np.empty((n, 3)), np.empty((n, 3))
        generate_camera_rays(np.asarray(pixels, np.int64), sample, seed, it.width,
                             self.filter_cdf, self.filter_x, self.filter_guide, self.view,
                             self.lens,
                             self.world_from_camera, self.position, pseed, origin32, dir32,
                             tmax32, o64, d64)
        it._count("generate camera rays", time.perf_counter() - t0)
        live = np.arange(n, dtype=np.int64)
        throughput = np.ones((n, 3))
        prev_pdf = np.full(n, np.inf)
        # Shadow rays: at most one per path and bounce.
        srow, stmax, scontrib = np.empty(n, np.int64), np.empty(n, F32), np.empty((n, 3))
        sorigin, sdir = np.empty((n, 3), F32), np.empty((n, 3), F32)
        profile = np.zeros(3 if self.profile else 0, np.uint64)
        m = n
        for depth in range(it.settings.max_bounces + 2):
            if m == 0:
                break
            t0 = time.perf_counter()
            prim, tfar, bu, bv = it.accel.intersect_raw(origin32[:m], dir32[:m], tmax32[:m])
            it._count("intersect", time.perf_counter() - t0)
            t0 = time.perf_counter()
            m, count = shade(depth, rev_sample, self.flags, self.exact_fresnel, self.geometry,
                             self.materials, self.lights, self.objects, self.environment,
                             self.world, self.camera,
                             prim, tfar, bu, bv, m, live, pseed, o64, d64, throughput,
                             prev_pdf, radiance,
                             depth_pass, normal_pass, origin32, dir32, tmax32, srow, sorigin,
                             sdir, stmax, scontrib, profile)
            self._count_shade(time.perf_counter() - t0, profile)
            if count:
                t0 = time.perf_counter()
                blocked = it.accel.occluded_raw(sorigin[:count], sdir[:count], stmax[:count])
                accumulate_unoccluded(radiance, srow, scontrib, blocked, count)
                it._count("trace shadow rays", time.perf_counter() - t0)
        return radiance, depth_pass, normal_pass


def warm_up() -> None:
    """Load every kernel now (from numba's cache, or compile it on the first run ever) by
    rendering a 4x3 image of one emissive triangle. The add-on calls it in the background
    when it registers, so pressing Render does not wait for the kernels (~0.4 s)."""
    if not AVAILABLE:
        return
    from .renderer import render
    from .scene import Camera, Material, RenderSettings, SceneBuilder, World

    b = SceneBuilder()
    m = b.add_material(Material.diffuse("warm-up", (0.5, 0.5, 0.5), emission=(1, 1, 1)))
    b.add_mesh("warm-up", np.array([[-1.0, -1, -2], [1, -1, -2], [0, 1, -2]]),
               np.array([[0, 1, 2]]), m)
    camera = Camera(use_dof=True, fstop=1.0, focus_distance=2.0)
    render(b.build(camera, World((0.1, 0.1, 0.1))),
           RenderSettings(width=4, height=3, samples=2, threads=1))


"""The Voronoi Texture as Cycles computes it (kernel/svm/voronoi.h).

Space is cut into unit cells; each cell holds one feature point, placed at a hash of the
cell's integer coordinates times Randomness. F1 is the distance to the nearest point (and
that cell's colour and point), F2 to the second nearest, Smooth F1 a smooth minimum over
the 5^d cells around, Distance to Edge the distance to the nearest bisector between the
nearest point and another, N-Sphere Radius half the distance from the nearest point to
its own nearest. F1, F2 and Smooth F1 add octaves as fBM noise does (Detail, Roughness,
Lacunarity), with some sums replaced by blends; Normalize divides by the largest distance
the octaves can give.

The hashes are Cycles' exactly: 1D hashes the cell's float coordinate with lookup3
(noise._hash_floats, as hash_float_to_float), 2D-4D the integer coordinates with the PCG
hashes (Jarzynski and Olano 2020; hash_pcg2d_i .. hash_pcg4d_i), 32-bit signed
wrap-around done on int64. A point is (x, y, z, w) with d (1-4) coordinates read: 2D reads
x, y; 3D x, y, z; 4D all; 1D w alone (the W input). Unread coordinates stay 0, so one
function serves every dimension; its loops visit cells in Cycles' order (w outermost, x
innermost), which Smooth F1's running blend depends on.
"""

from __future__ import annotations

import math

import numpy as np

from .jit import JIT, njit
from .noise import _hash_floats, white_noise

FEATURES = ("F1", "F2", "SMOOTH_F1", "DISTANCE_TO_EDGE", "N_SPHERE_RADIUS")
METRICS = ("EUCLIDEAN", "MANHATTAN", "CHEBYCHEV", "MINKOWSKI")
F1, F2, SMOOTH_F1, DISTANCE_TO_EDGE, N_SPHERE_RADIUS = range(5)
EUCLIDEAN, MANHATTAN, CHEBYCHEV, MINKOWSKI = range(4)
FLT_MAX = 3.4028234663852886e38
PCG_A, PCG_C = 1664525, 1013904223
INT_TO_UNIT = 1.0 / 2147483648.0  # Cycles' 1.0f / (float)0x7FFFFFFF: (float) rounds up


# ----------------------------------------------------------------- PCG hashes (int32)
@njit(**JIT)
def _i32(x):
    """x wrapped to a signed 32-bit integer (C's int overflow as the hardware does it)."""
    return ((x + 0x80000000) & 0xFFFFFFFF) - 0x80000000


@njit(**JIT)
def _unit(h):
    """hash_int*_to_float*: a 31-bit hash as float32, times 1 / 2^31."""
    return float(np.float32(h & 0x7FFFFFFF)) * INT_TO_UNIT


@njit(**JIT)
def pcg_hash(d, x, y, z, w):
    """hash_int{d}_to_float{d} of integer keys (d = 2, 3, 4): each of the first d
    components in [0, 1] (the rest 0)."""
    x, y = _i32(x * PCG_A + PCG_C), _i32(y * PCG_A + PCG_C)
    if d == 2:
        for rnd in range(2):
            x = _i32(x + y * PCG_A)
            y = _i32(y + x * PCG_A)
            if rnd == 0:
                x, y = x ^ (x >> 16), y ^ (y >> 16)
        return _unit(x), _unit(y), 0.0, 0.0
    z, w = _i32(z * PCG_A + PCG_C), _i32(w * PCG_A + PCG_C)
    for rnd in range(2):
        if d == 3:
            x = _i32(x + y * z)
            y = _i32(y + z * x)
            z = _i32(z + x * y)
        else:
            x = _i32(x + y * w)
            y = _i32(y + z * x)
            z = _i32(z + x * y)
            w = _i32(w + y * z)
        if rnd == 0:
            x, y, z, w = x ^ (x >> 16), y ^ (y >> 16), z ^ (z >> 16), w ^ (w >> 16)
    return _unit(x), _unit(y), _unit(z), (_unit(w) if d == 4 else 0.0)


@njit(**JIT)
def cell_offset(d, cx, cy, cz, cw):
    """Where cell (cx, cy, cz, cw) (integral floats) holds its point, per read coordinate
    in [0, 1] before Randomness."""
    if d == 1:
        return 0.0, 0.0, 0.0, _hash_floats(np.int64(1), cw, 0.0, 0.0, 0.0)
    return pcg_hash(d, int(cx), int(cy), int(cz), int(cw))


@njit(**JIT)
def cell_colour(d, cx, cy, cz, cw):
    """A cell's Color: hash_float_to_float3 (1D), hash_int2_to_float3 (the 3D hash with
    z = 0), hash_int3_to_float3, or the first three of hash_int4_to_float4."""
    if d == 1:
        return white_noise(np.int64(1), 0.0, 0.0, 0.0, cw)
    r, g, b, _ = pcg_hash(3 if d == 2 else d, int(cx), int(cy), int(cz), int(cw))
    return r, g, b


# ----------------------------------------------------------------- distances
@njit(**JIT)
def distance(d, metric, exponent, dx, dy, dz, dw, bound):
    """voronoi_distance of a difference (unread coordinates 0); with `bound`, the cheaper
    voronoi_distance_bound that orders points alike (Euclidean squared, Minkowski
    unrooted). 1D is |dw| under every metric, as Cycles' float overload."""
    if d == 1:
        return abs(dw)
    if metric == EUCLIDEAN:
        s = dx * dx + dy * dy + dz * dz + dw * dw
        return s if bound else math.sqrt(s)
    if metric == MANHATTAN:
        return abs(dx) + abs(dy) + abs(dz) + abs(dw)
    if metric == CHEBYCHEV:
        return max(max(abs(dx), abs(dy)), max(abs(dz), abs(dw)))
    c = (dx, dy, dz, dw)
    s = 0.0
    for i in range(d):  # only the read coordinates (0 ** a negative exponent is inf)
        s += abs(c[i]) ** exponent
    return s if bound else s ** (1.0 / exponent)


@njit(**JIT)
def _reach(d, r):
    """The cell offsets each coordinate visits: -r..r where read, 0 elsewhere."""
    rxy = r if d >= 2 else 0
    return rxy, rxy, (r if d >= 3 else 0), (r if d == 1 or d == 4 else 0)


@njit(**JIT)
def _cells(rx, ry, rz, rw):
    """How many cells _reach's offsets visit."""
    return (2 * rx + 1) * (2 * ry + 1) * (2 * rz + 1) * (2 * rw + 1)


@njit(**JIT)
def _nth_cell(k, rx, ry, rz, rw):
    """The k-th cell offset in Cycles' order: x innermost, then y, z, and w outermost."""
    ox = k % (2 * rx + 1) - rx
    k //= 2 * rx + 1
    oy = k % (2 * ry + 1) - ry
    k //= 2 * ry + 1
    oz = k % (2 * rz + 1) - rz
    return ox, oy, oz, k // (2 * rz + 1) - rw


@njit(**JIT)
def _smoothstep(x):
    return 0.0 if x < 0.0 else (1.0 if x >= 1.0 else (3.0 - 2.0 * x) * x * x)


# ----------------------------------------------------------------- one octave
@njit(**JIT)
def octave(d, feature, metric, exponent, randomness, smoothness, x, y, z, w):
    """F1, F2 or Smooth F1 at (x, y, z, w): (distance, colour r, g, b, position x, y, z,
    w) as voronoi_f1 / voronoi_f2 / voronoi_smooth_f1."""
    fx, fy, fz, fw = math.floor(x), math.floor(y), math.floor(z), math.floor(w)
    lx, ly, lz, lw = x - fx, y - fy, z - fz, w - fw
    rx, ry, rz, rw = _reach(d, 2 if feature == SMOOTH_F1 else 1)
    # F1 orders by the bound (then measures its winner); F2 and Smooth F1 by the distance.
    bound = feature == F1
    d1 = d2 = FLT_MAX
    o1 = o2 = (0.0, 0.0, 0.0, 0.0)
    p1 = p2 = (0.0, 0.0, 0.0, 0.0)
    s_dist, s_r, s_g, s_b = 0.0, 0.0, 0.0, 0.0
    s_pos = (0.0, 0.0, 0.0, 0.0)
    h = -1.0
    for k in range(_cells(rx, ry, rz, rw)):
        ox, oy, oz, ow = _nth_cell(k, rx, ry, rz, rw)
        hx, hy, hz, hw = cell_offset(d, fx + ox, fy + oy, fz + oz, fw + ow)
        p = (ox + hx * randomness, oy + hy * randomness, oz + hz * randomness,
             ow + hw * randomness)
        dist = distance(d, metric, exponent, p[0] - lx, p[1] - ly, p[2] - lz,
                        p[3] - lw, bound)
        o = (float(ox), float(oy), float(oz), float(ow))
        if feature == SMOOTH_F1:
            h = 1.0 if h == -1.0 else _smoothstep(
                0.5 + 0.5 * (s_dist - dist) / smoothness)
            corr = smoothness * h * (1.0 - h)
            s_dist = s_dist + h * (dist - s_dist) - corr
            corr /= 1.0 + 3.0 * smoothness
            r, g, b = cell_colour(d, fx + ox, fy + oy, fz + oz, fw + ow)
            s_r, s_g, s_b = (s_r + h * (r - s_r) - corr, s_g + h * (g - s_g) - corr,
                             s_b + h * (b - s_b) - corr)
            s_pos = _blend_read(d, s_pos, p, h, corr)
        elif dist < d1:
            d2, o2, p2 = d1, o1, p1
            d1, o1, p1 = dist, o, p
        elif dist < d2:
            d2, o2, p2 = dist, o, p
    if feature == SMOOTH_F1:
        return (s_dist, s_r, s_g, s_b, s_pos[0] + fx, s_pos[1] + fy, s_pos[2] + fz,
                s_pos[3] + fw)
    dist, o, p = (d2, o2, p2) if feature == F2 else (d1, o1, p1)
    if bound:
        dist = distance(d, metric, exponent, p[0] - lx, p[1] - ly, p[2] - lz, p[3] - lw,
                        False)
    r, g, b = cell_colour(d, fx + o[0], fy + o[1], fz + o[2], fw + o[3])
    return dist, r, g, b, p[0] + fx, p[1] + fy, p[2] + fz, p[3] + fw


@njit(**JIT)
def _blend_read(d, a, b, h, corr):
    """mix(a, b, h) - corr on the read coordinates (Cycles' float2/3/4 smoothPosition);
    unread ones stay 0."""
    rx, ry, rz, rw = _reach(d, 1)
    return ((a[0] + h * (b[0] - a[0]) - corr) if rx else 0.0,
            (a[1] + h * (b[1] - a[1]) - corr) if ry else 0.0,
            (a[2] + h * (b[2] - a[2]) - corr) if rz else 0.0,
            (a[3] + h * (b[3] - a[3]) - corr) if rw else 0.0)


@njit(**JIT)
def _to_point(d, randomness, fx, fy, fz, fw, lx, ly, lz, lw, ox, oy, oz, ow):
    """The vector from the local point (lx..lw) to the feature point of the cell at offset
    (ox..ow) from cell (fx..fw)."""
    hx, hy, hz, hw = cell_offset(d, fx + ox, fy + oy, fz + oz, fw + ow)
    return (ox + hx * randomness - lx, oy + hy * randomness - ly, oz + hz * randomness - lz,
            ow + hw * randomness - lw)


@njit(**JIT)
def _nearest_vector(d, randomness, fx, fy, fz, fw, lx, ly, lz, lw):
    """The vector from the point to the nearest feature point (Euclidean), and its cell
    offset."""
    rx, ry, rz, rw = _reach(d, 1)
    best = FLT_MAX
    v = (0.0, 0.0, 0.0, 0.0)
    o = (0.0, 0.0, 0.0, 0.0)
    for k in range(_cells(rx, ry, rz, rw)):
        ox, oy, oz, ow = _nth_cell(k, rx, ry, rz, rw)
        t = _to_point(d, randomness, fx, fy, fz, fw, lx, ly, lz, lw, ox, oy, oz, ow)
        dd = t[0] * t[0] + t[1] * t[1] + t[2] * t[2] + t[3] * t[3]
        if dd < best:
            best, v = dd, t
            o = (float(ox), float(oy), float(oz), float(ow))
    return v, o


@njit(**JIT)
def distance_to_edge(d, randomness, x, y, z, w):
    """voronoi_distance_to_edge: the distance to the nearest bisector between the nearest
    feature point and one of its neighbours' (Euclidean in every metric)."""
    fx, fy, fz, fw = math.floor(x), math.floor(y), math.floor(z), math.floor(w)
    lx, ly, lz, lw = x - fx, y - fy, z - fz, w - fw
    if d == 1:
        mid = cell_offset(1, 0.0, 0.0, 0.0, fw)[3] * randomness
        left = -1.0 + cell_offset(1, 0.0, 0.0, 0.0, fw - 1.0)[3] * randomness
        right = 1.0 + cell_offset(1, 0.0, 0.0, 0.0, fw + 1.0)[3] * randomness
        return min(abs((mid + left) / 2.0 - lw), abs((mid + right) / 2.0 - lw))
    v, _ = _nearest_vector(d, randomness, fx, fy, fz, fw, lx, ly, lz, lw)
    rx, ry, rz, rw = _reach(d, 1)
    best = FLT_MAX
    for k in range(_cells(rx, ry, rz, rw)):
        ox, oy, oz, ow = _nth_cell(k, rx, ry, rz, rw)
        t = _to_point(d, randomness, fx, fy, fz, fw, lx, ly, lz, lw, ox, oy, oz, ow)
        e = (t[0] - v[0], t[1] - v[1], t[2] - v[2], t[3] - v[3])
        ee = e[0] * e[0] + e[1] * e[1] + e[2] * e[2] + e[3] * e[3]
        if ee > 0.0001:
            inv = 1.0 / math.sqrt(ee)
            best = min(best, ((v[0] + t[0]) * e[0] + (v[1] + t[1]) * e[1]
                              + (v[2] + t[2]) * e[2] + (v[3] + t[3]) * e[3])
                       * 0.5 * inv)
    return best


@njit(**JIT)
def n_sphere_radius(d, randomness, x, y, z, w):
    """voronoi_n_sphere_radius: half the distance from the nearest feature point to the
    nearest other one around it (Euclidean in every metric)."""
    fx, fy, fz, fw = math.floor(x), math.floor(y), math.floor(z), math.floor(w)
    lx, ly, lz, lw = x - fx, y - fy, z - fz, w - fw
    v, o = _nearest_vector(d, randomness, fx, fy, fz, fw, lx, ly, lz, lw)
    c = (v[0] + lx, v[1] + ly, v[2] + lz, v[3] + lw)  # the nearest point, in the cell
    rx, ry, rz, rw = _reach(d, 1)
    best = FLT_MAX
    q = c
    for k in range(_cells(rx, ry, rz, rw)):
        ox, oy, oz, ow = _nth_cell(k, rx, ry, rz, rw)
        if ox == 0 and oy == 0 and oz == 0 and ow == 0:
            continue
        n = (ox + o[0], oy + o[1], oz + o[2], ow + o[3])
        hx, hy, hz, hw = cell_offset(d, fx + n[0], fy + n[1], fz + n[2], fw + n[3])
        p = (n[0] + hx * randomness, n[1] + hy * randomness,
             n[2] + hz * randomness, n[3] + hw * randomness)
        dd = ((c[0] - p[0]) ** 2 + (c[1] - p[1]) ** 2 + (c[2] - p[2]) ** 2
              + (c[3] - p[3]) ** 2)
        if dd < best:
            best, q = dd, p
    return math.sqrt((q[0] - c[0]) ** 2 + (q[1] - c[1]) ** 2 + (q[2] - c[2]) ** 2
                     + (q[3] - c[3]) ** 2) / 2.0


# ----------------------------------------------------------------- the node
@njit(**JIT)
def voronoi(d, feature, metric, normalize, x, y, z, w, scale, detail, roughness, lacunarity,
            smoothness, exponent, randomness):
    """Cycles' svm_node_tex_voronoi at vector (x, y, z) and W: (Distance, Color r, g, b,
    Position x, y, z, W, Radius)."""
    detail = min(max(detail, 0.0), 15.0)
    roughness = min(max(roughness, 0.0), 1.0)
    randomness = min(max(randomness, 0.0), 1.0)
    smoothness = min(max(smoothness / 2.0, 0.0), 0.5)
    # The coordinates a dimension does not read are 0 (every loop and sum includes them).
    x, y = (x * scale, y * scale) if d >= 2 else (0.0, 0.0)
    z = z * scale if d >= 3 else 0.0
    w = w * scale if d == 1 or d == 4 else 0.0
    if feature == N_SPHERE_RADIUS:
        r = n_sphere_radius(d, randomness, x, y, z, w)
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, r
    cell = 0.5 + 0.5 * randomness
    zero_input = detail == 0.0 or roughness == 0.0
    remainder = detail - math.floor(detail)
    amplitude, octave_scale = 1.0, 1.0
    if feature == DISTANCE_TO_EDGE:
        largest, dist = cell, 8.0
        for i in range(int(math.ceil(detail)) + 1):
            o = distance_to_edge(d, randomness, x * octave_scale, y * octave_scale,
                                 z * octave_scale, w * octave_scale)
            if zero_input:
                dist = o
                break
            lerp_largest = largest + amplitude * (cell / octave_scale - largest)
            lerp_dist = dist + amplitude * (min(dist, o / octave_scale) - dist)
            if i <= detail:
                largest, dist = lerp_largest, lerp_dist
                octave_scale *= lacunarity
                amplitude *= roughness
            elif remainder != 0.0:
                largest += remainder * (lerp_largest - largest)
                dist += remainder * (min(dist, lerp_dist) - dist)
        if normalize:
            dist /= largest
        return dist, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    if feature == SMOOTH_F1 and smoothness == 0.0:
        feature = F1
    largest = cell if d == 1 else distance(d, metric, exponent, cell, cell,
                                           cell if d >= 3 else 0.0, cell if d == 4 else 0.0,
                                           False)
    if feature == F2:
        largest *= 2.0
    # The octaves' sum: distance and colour add, the position blends toward each octave's.
    total = dist = r = g = b = px = py = pz = pw = 0.0
    for i in range(int(math.ceil(detail)) + 1):
        s = octave_scale
        o = octave(d, feature, metric, exponent, randomness, smoothness, x * s, y * s, z * s,
                   w * s)
        if zero_input:
            total = 1.0
            dist, r, g, b, px, py, pz, pw = o
            break
        if i <= detail:
            k, octave_scale, amplitude = amplitude, octave_scale * lacunarity, \
                amplitude * roughness
        elif remainder != 0.0:
            k = remainder * amplitude
        else:
            break
        total += k
        dist, r, g, b = dist + k * o[0], r + k * o[1], g + k * o[2], b + k * o[3]
        px, py = px + k * (o[4] / s - px), py + k * (o[5] / s - py)
        pz, pw = pz + k * (o[6] / s - pz), pw + k * (o[7] / s - pw)
    if normalize:
        dist /= total * largest
        r, g, b = r / total, g / total, b / total
    if scale == 0.0:  # (safe_divide)
        return dist, r, g, b, 0.0, 0.0, 0.0, 0.0, 0.0
    return dist, r, g, b, px / scale, py / scale, pz / scale, pw / scale, 0.0

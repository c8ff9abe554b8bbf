"""Homogeneous media inside closed meshes: Cycles' volume stack, absorption, scattering
and emission.

A material's medium (scene.Material.absorption, scattering, anisotropy, volume_emission)
fills the inside of the meshes that wear it; `medium_table` packs each material's into a
row: extinction sigma_t = sigma_a + sigma_s, scattering sigma_s (per world unit), the
Henyey-Greenstein anisotropy g and the emission per unit length. A path carries a small
stack of the media it is in (material indices, -1 empty), as Cycles' volume stack does:
crossing a transmitting surface of such a material from its front pushes it, from its back
removes it, and the stack's coefficients add up (Cycles sums every closure of every stack
entry).

Along a segment of length t in media that only absorb, the throughput is multiplied by
the transmittance exp(-sigma_t t): exact, not an estimate (Cycles integrates a homogeneous
absorbing volume analytically too). Where they scatter, a distance is sampled
(`sample_distance`): the path scatters there (the phase function, `sample_phase`, picks its
new direction and next-event estimation weighs lights by `eval_phase`) or reaches the
surface; either way it is weighted so that the estimate is unbiased for all three colour
channels at once (the channel sampled is one of three strategies, combined by the balance
heuristic). Emission adds its integral along the segment, sigma_e (1 - T) / sigma_t
(Cycles' volume_emission_integrate).

A camera path starts in the media around the camera (`enclosing`, as Cycles'
volume_stack_init finds them) and in the world's volume, which fills all space.
"""

from __future__ import annotations

import math

import numpy as np

from .jit import INLINE, njit
from .sampling import build_frame

# Media a path can be inside at once (nested volumes: ice in water in a glass).
MEDIA_STACK = 4
# Columns of a medium row (medium_table).
SIGMA_T, SIGMA_S, ANISOTROPY, EMISSION = 0, 3, 6, 7
COLUMNS = 10
# Cycles clamps |g| below 1 - 1e-3 (a delta phase function otherwise) and treats
# |g| < 1e-3 as isotropic when sampling.
MAX_ANISOTROPY = 1.0 - 1e-3
ISOTROPIC_G = 1e-3
# Volume-only boundaries a path may cross (Cycles' VOLUME_BOUNDS_MAX): they count as no
# bounce, so this only stops a path caught re-hitting one surface.
VOLUME_BOUNDS_MAX = 1024


def medium_table(absorption, scattering, anisotropy, emission) -> np.ndarray:
    """Rows (k, COLUMNS) of the materials' media from sigma_a (k, 3), sigma_s (k, 3), g (k,)
    and emission (k, 3)."""
    a, s = np.asarray(absorption, np.float64), np.asarray(scattering, np.float64)
    g = np.clip(np.asarray(anisotropy, np.float64), -MAX_ANISOTROPY, MAX_ANISOTROPY)
    t = np.empty((len(a), COLUMNS))
    t[:, SIGMA_T:SIGMA_T + 3] = a + s
    t[:, SIGMA_S:SIGMA_S + 3] = s
    t[:, ANISOTROPY] = g
    t[:, EMISSION:EMISSION + 3] = np.asarray(emission, np.float64)
    return t


def enclosing(point, vertices, material_index, rows, world_row=-1) -> np.ndarray:
    """The volume stack (MEDIA_STACK material rows, -1 empty) of a path starting at
    `point`: the world's volume (`world_row`, -1 for none), then every medium of `rows`
    (materials whose medium a path can enter) whose mesh a ray from the point along +z
    leaves through a back face before entering it through a front one (Cycles'
    integrator_volume_stack_init, keyed by material rather than object). vertices (t, 3,
    3) and material_index (t,): the scene's triangles, in the point's frame."""
    stack = [int(world_row)] if world_row >= 0 else []
    chosen = np.isin(material_index, np.asarray(rows, np.int64))
    v = np.asarray(vertices, np.float64)[chosen]
    mats = np.asarray(material_index)[chosen]
    if len(v):
        p = np.asarray(point, np.float64)
        e1, e2 = v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]
        # Moller-Trumbore against the direction (0, 0, 1): d x e2 = (-e2y, e2x, 0).
        pv = np.stack([-e2[:, 1], e2[:, 0], np.zeros(len(v))], axis=1)
        det = np.einsum("ij,ij->i", e1, pv)
        safe = np.where(np.abs(det) > 1e-300, det, 1.0)
        s = p - v[:, 0]
        u = np.einsum("ij,ij->i", s, pv) / safe
        q = np.cross(s, e1)
        w, t = q[:, 2] / safe, np.einsum("ij,ij->i", e2, q) / safe
        hit = (np.abs(det) > 1e-300) & (u >= 0) & (w >= 0) & (u + w <= 1) & (t > 0)
        leaving = np.cross(e1, e2)[:, 2] > 0  # the face's front looks along the ray
        enclosed = set()
        for k in np.flatnonzero(hit)[np.argsort(t[hit], kind="stable")]:
            mat = int(mats[k])
            if not leaving[k]:
                enclosed.add(mat)
            elif mat not in enclosed and mat not in stack and len(stack) < MEDIA_STACK:
                stack.append(mat)
    return np.array(stack + [-1] * (MEDIA_STACK - len(stack)), np.int64)


def has_medium(rows: np.ndarray) -> np.ndarray:
    """Whether each medium row (n, COLUMNS) is anything: it attenuates or emits."""
    return (rows[:, SIGMA_T:SIGMA_T + 3].max(axis=1) > 0) | (
        rows[:, EMISSION:EMISSION + 3].max(axis=1) > 0)


@njit(**INLINE)
def transmittance(s0, s1, s2, t):
    """exp(-sigma t) per channel; 1 where sigma is 0, even along an infinite segment."""
    return (math.exp(-s0 * t) if s0 > 0.0 else 1.0, math.exp(-s1 * t) if s1 > 0.0 else 1.0,
            math.exp(-s2 * t) if s2 > 0.0 else 1.0)


@njit(**INLINE)
def extinction(media, row, table, mat, entering, crossed):
    """The summed extinction of path `row`'s stack (media (n, MEDIA_STACK)), after it
    crosses (if `crossed`) a surface of material `mat` from its front (`entering`)."""
    return _summed(media, row, table, SIGMA_T, mat, entering, crossed)


@njit(**INLINE)
def coefficients(media, row, table, column):
    """The stack's summed coefficient at `column` (SIGMA_T, SIGMA_S or EMISSION), (3)."""
    return _summed(media, row, table, column, -1, False, False)


@njit(**INLINE)
def _summed(media, row, table, column, mat, entering, crossed):
    """The coefficient at `column` (3) summed over path `row`'s stack as it is after the
    crossing (if `crossed`) of a surface of material `mat`."""
    s0 = s1 = s2 = 0.0
    for j in range(MEDIA_STACK):
        m = media[row, j]
        if _kept(m, mat, entering, crossed):
            s0 += table[m, column]
            s1 += table[m, column + 1]
            s2 += table[m, column + 2]
    if _pushed(media, row, table, mat, entering, crossed):
        s0 += table[mat, column]
        s1 += table[mat, column + 1]
        s2 += table[mat, column + 2]
    return s0, s1, s2


@njit(**INLINE)
def emission_along(e, sigma_t, t):
    """The integral of e exp(-sigma_t s) over s in [0, t] (one channel): e (1 - T) / sigma_t,
    e t where the optical depth is tiny (Cycles' second-order expansion there)."""
    depth = sigma_t * t
    if depth > 1e-5:
        return e * -math.expm1(-depth) / sigma_t
    return e * t * (1.0 - 0.5 * depth)


@njit(**INLINE)
def sample_distance(u_channel, u, t_max, st0, st1, st2, ss0, ss1, ss2, p0, p1, p2):
    """A free-flight distance along a segment of length t_max (inf: unbounded) through
    extinction st and scattering ss: a channel chosen with probability p (summing to 1),
    an exponential distance in it. Returns (t, w): t < t_max where the path scatters there,
    w = ss T(t) / pdf(t); else t = inf and the path reaches the segment's end with
    w = T(t_max) / P(reach); pdf and P are the three channels' mixture (balance
    heuristic)."""
    sigma = st0 if u_channel < p0 else (st1 if u_channel < p0 + p1 else st2)
    t = -math.log1p(-u) / sigma if sigma > 0.0 else math.inf
    if t < t_max:
        a0, a1, a2 = transmittance(st0, st1, st2, t)
        pdf = p0 * st0 * a0 + p1 * st1 * a1 + p2 * st2 * a2
        return t, ss0 * a0 / pdf, ss1 * a1 / pdf, ss2 * a2 / pdf
    a0, a1, a2 = transmittance(st0, st1, st2, t_max)
    reach = p0 * a0 + p1 * a1 + p2 * a2
    return math.inf, a0 / reach, a1 / reach, a2 / reach


@njit(**INLINE)
def henyey_greenstein(cos_theta, g):
    """The Henyey-Greenstein phase function at the angle theta between the propagation
    directions before and after scattering (g > 0 forward)."""
    d = 1.0 + g * g - 2.0 * g * cos_theta
    return (1.0 - g * g) / (4.0 * math.pi * d * math.sqrt(d))


@njit(**INLINE)
def sample_henyey_greenstein(dx, dy, dz, g, ua, ub):
    """A direction scattered from propagation direction d by Henyey-Greenstein g (inverse
    of its cosine's distribution, as Cycles' phase_henyey_greenstein_sample): (w, pdf)."""
    if abs(g) < ISOTROPIC_G:
        cos = 1.0 - 2.0 * ua
    else:
        k = (1.0 - g * g) / (1.0 - g + 2.0 * g * ua)
        cos = min(max((1.0 + g * g - k * k) / (2.0 * g), -1.0), 1.0)
    sin = math.sqrt(max(0.0, 1.0 - cos * cos))
    phi = 2.0 * math.pi * ub
    s, t = build_frame(dx, dy, dz)
    a, b = sin * math.cos(phi), sin * math.sin(phi)
    wx = a * s[0] + b * t[0] + cos * dx
    wy = a * s[1] + b * t[1] + cos * dy
    wz = a * s[2] + b * t[2] + cos * dz
    return wx, wy, wz, henyey_greenstein(cos, g)


@njit(**INLINE)
def eval_phase(media, row, table, dx, dy, dz, wx, wy, wz):
    """The phase function of path `row`'s stack from propagation direction d to w: each
    scattering medium's Henyey-Greenstein weighted by its share of sigma_s per channel
    (Cycles sums the phase closures so). Returns (f (3), pdf): pdf is the mixture that
    `sample_phase` samples (weights: each medium's mean sigma_s)."""
    cos = dx * wx + dy * wy + dz * wz
    f0 = f1 = f2 = pdf = s0 = s1 = s2 = 0.0
    for j in range(MEDIA_STACK):
        m = media[row, j]
        if m < 0:
            continue
        p = henyey_greenstein(cos, table[m, ANISOTROPY])
        f0 += table[m, SIGMA_S] * p
        f1 += table[m, SIGMA_S + 1] * p
        f2 += table[m, SIGMA_S + 2] * p
        pdf += (table[m, SIGMA_S] + table[m, SIGMA_S + 1] + table[m, SIGMA_S + 2]) * p
        s0 += table[m, SIGMA_S]
        s1 += table[m, SIGMA_S + 1]
        s2 += table[m, SIGMA_S + 2]
    total = s0 + s1 + s2
    return (f0 / s0 if s0 > 0.0 else 0.0, f1 / s1 if s1 > 0.0 else 0.0,
            f2 / s2 if s2 > 0.0 else 0.0, pdf / total if total > 0.0 else 0.0)


@njit(**INLINE)
def sample_phase(media, row, table, dx, dy, dz, u_lobe, ua, ub):
    """A scattered direction from the stack's phase function: one medium chosen by its mean
    sigma_s, its Henyey-Greenstein sampled. Returns (w, f / pdf (3), pdf): 1 for a single
    medium (sampled exactly)."""
    total = 0.0
    for j in range(MEDIA_STACK):
        m = media[row, j]
        if m >= 0:
            total += table[m, SIGMA_S] + table[m, SIGMA_S + 1] + table[m, SIGMA_S + 2]
    chosen = -1
    acc = 0.0
    for j in range(MEDIA_STACK):
        m = media[row, j]
        if m >= 0 and chosen < 0:
            acc += table[m, SIGMA_S] + table[m, SIGMA_S + 1] + table[m, SIGMA_S + 2]
            if u_lobe * total < acc:
                chosen = m
    if chosen < 0:
        return dx, dy, dz, 0.0, 0.0, 0.0, 0.0
    wx, wy, wz, _ = sample_henyey_greenstein(dx, dy, dz, table[chosen, ANISOTROPY], ua, ub)
    f0, f1, f2, pdf = eval_phase(media, row, table, dx, dy, dz, wx, wy, wz)
    if not pdf > 0.0:
        return wx, wy, wz, 0.0, 0.0, 0.0, 0.0
    return wx, wy, wz, f0 / pdf, f1 / pdf, f2 / pdf, pdf


@njit(**INLINE)
def carry(src_media, src, dst_media, dst, table, mat, entering, crossed):
    """Row src's stack (of src_media), updated for crossing (or not) a surface of material
    `mat`, becomes row dst of dst_media (the same array with dst <= src: a batch compacts
    in place). A full stack drops the medium entered (the path then ignores it, as Cycles'
    fixed-size stack does)."""
    push = _pushed(src_media, src, table, mat, entering, crossed)
    n = 0
    for j in range(MEDIA_STACK):
        m = src_media[src, j]
        if _kept(m, mat, entering, crossed):
            dst_media[dst, n] = m
            n += 1
    if push and n < MEDIA_STACK:
        dst_media[dst, n] = mat
        n += 1
    for j in range(n, MEDIA_STACK):
        dst_media[dst, j] = -1


@njit(**INLINE)
def _kept(m, mat, entering, crossed):
    """Whether stack entry m (-1: empty) stays after the crossing: all but the one left."""
    return m >= 0 and not (m == mat and crossed and not entering)


@njit(**INLINE)
def _pushed(media, row, table, mat, entering, crossed):
    """Whether the crossing adds mat's medium to path row's stack: entered, a medium that
    attenuates or emits, and not already there."""
    if not (crossed and entering and (
            table[mat, SIGMA_T] > 0.0 or table[mat, SIGMA_T + 1] > 0.0
            or table[mat, SIGMA_T + 2] > 0.0 or table[mat, EMISSION] > 0.0
            or table[mat, EMISSION + 1] > 0.0 or table[mat, EMISSION + 2] > 0.0)):
        return False
    for j in range(MEDIA_STACK):
        if media[row, j] == mat:
            return False
    return True

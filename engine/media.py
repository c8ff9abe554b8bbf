"""Homogeneous absorbing media inside closed meshes: Cycles' volume stack and Beer-Lambert.

A material's Volume Absorption (scene.Material.absorption, sigma_a per world unit) fills
the inside of the meshes that wear it. A path carries a small stack of the media it is in
(material indices, -1 empty), as Cycles' volume stack does: crossing a transmitting
surface of such a material from its front pushes it, from its back removes it, and the
stack's coefficients add up (Cycles sums every closure of every stack entry). Along a
segment of length t the throughput is multiplied by the transmittance exp(-sigma t);
absorption alone scatters nothing, so this is exact, not an estimate (Cycles integrates an
absorption-only homogeneous volume the same way, analytically).

A path starts outside every medium (Cycles traces the camera's own stack; a camera inside
a volume is not supported).
"""

from __future__ import annotations

import math

from .jit import INLINE, njit

# Media a path can be inside at once (nested volumes: ice in water in a glass).
MEDIA_STACK = 4


@njit(**INLINE)
def transmittance(s0, s1, s2, t):
    """exp(-sigma t) per channel; 1 where sigma is 0, even along an infinite segment."""
    return (math.exp(-s0 * t) if s0 > 0.0 else 1.0, math.exp(-s1 * t) if s1 > 0.0 else 1.0,
            math.exp(-s2 * t) if s2 > 0.0 else 1.0)


@njit(**INLINE)
def extinction(media, row, absorption, mat, entering, crossed):
    """The summed coefficient of path `row`'s stack (media (n, MEDIA_STACK)), after it
    crosses (if `crossed`) a surface of material `mat` from its front (`entering`) or back."""
    s0 = s1 = s2 = 0.0
    for j in range(MEDIA_STACK):
        m = media[row, j]
        if _kept(m, mat, entering, crossed):
            s0 += absorption[m, 0]
            s1 += absorption[m, 1]
            s2 += absorption[m, 2]
    if _pushed(media, row, absorption, mat, entering, crossed):
        s0 += absorption[mat, 0]
        s1 += absorption[mat, 1]
        s2 += absorption[mat, 2]
    return s0, s1, s2


@njit(**INLINE)
def carry(media, src, dst, absorption, mat, entering, crossed):
    """Path src's stack, updated for crossing (or not) a surface of material `mat`, becomes
    row dst's (dst <= src: the batch compacts in place). A full stack drops the medium
    entered (the path then ignores it, as Cycles' fixed-size stack does)."""
    push = _pushed(media, src, absorption, mat, entering, crossed)
    n = 0
    for j in range(MEDIA_STACK):
        m = media[src, j]
        if _kept(m, mat, entering, crossed):
            media[dst, n] = m
            n += 1
    if push and n < MEDIA_STACK:
        media[dst, n] = mat
        n += 1
    for j in range(n, MEDIA_STACK):
        media[dst, j] = -1


@njit(**INLINE)
def _kept(m, mat, entering, crossed):
    """Whether stack entry m (-1: empty) stays after the crossing: all but the one left."""
    return m >= 0 and not (m == mat and crossed and not entering)


@njit(**INLINE)
def _pushed(media, row, absorption, mat, entering, crossed):
    """Whether the crossing adds mat's medium to path row's stack: entered, absorbing, and
    not already there."""
    if not (crossed and entering and (absorption[mat, 0] > 0.0 or absorption[mat, 1] > 0.0
                                      or absorption[mat, 2] > 0.0)):
        return False
    for j in range(MEDIA_STACK):
        if media[row, j] == mat:
            return False
    return True

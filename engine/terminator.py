"""Cycles' shadow terminator geometry offset: where a smooth mesh's shadow rays start.

A smooth-shaded mesh is lit by its interpolated normals but shadowed by its flat
triangles, so near the terminator (light grazing the shading normal) a shadow ray from
the flat surface is blocked by the neighbouring triangles and the lit side ends in a
stair-stepped dark band. Cycles lifts the shadow ray's origin toward the smooth surface
the normals describe (Hanika, "Hacking the Shadow Terminator", Ray Tracing Gems II,
ch. 4): a parabola through the triangle's corners with their normals, capped by the
corners' tangent planes. It does so only for shadow rays of next-event estimation, only
on smooth triangles, and only by the amount set per object (Object > Shading > Shadow
Terminator > Geometry Offset, default 0.1: about the last 10-20 % of the lit side).
Specula does the same (intern/cycles/kernel/light/sample.h, shadow_ray_offset and
shadow_ray_smooth_surface_offset), so a smooth sphere's terminator band matches.

`offset_amount` and `smooth_surface_offset` are scalar functions that the compiled
kernel inlines (integrator.shadow_ray).
"""

from __future__ import annotations

import numpy as np

from .jit import JIT, njit


@njit(**JIT)
def offset_amount(cutoff, nsx, nsy, nsz, ngx, ngy, ngz, lx, ly, lz):
    """How much (0..1) of the smooth-surface offset a shadow ray toward unit direction l
    gets, with the shading normal ns and geometric normal ng on the incoming side, and
    the geometric normal it leaves along (flipped for transmission) written back.
    Returns (amount, ng_x, ng_y, ng_z)."""
    nl = nsx * lx + nsy * ly + nsz * lz
    if nl < 0.0:  # transmission: measure against the far side
        nl = -nl
        ngx, ngy, ngz = -ngx, -ngy, -ngz
    ngl = ngx * lx + ngy * ly + ngz * lz
    # A smooth transition from full offset at the terminator to none `cutoff` past it.
    if nl < cutoff:
        amount = 2.0 - (ngl + nl) / cutoff
    else:
        amount = 1.0 - ngl / cutoff
    return min(max(amount, 0.0), 1.0), ngx, ngy, ngz


@njit(**JIT)
def _dot(ax, ay, az, bx, by, bz):
    return ax * bx + ay * by + az * bz


@njit(**JIT)
def smooth_surface_offset(v, n, w0, w1, w2, ngx, ngy, ngz):
    """The displacement from the flat point with barycentric weights (w0, w1, w2) of the
    triangle with corners v (3, 3) and unit corner normals n (3, 3) to the smooth surface
    they describe, along the interpolated normal, on ng's side."""
    px = w0 * v[0, 0] + w1 * v[1, 0] + w2 * v[2, 0]
    py = w0 * v[0, 1] + w1 * v[1, 1] + w2 * v[2, 1]
    pz = w0 * v[0, 2] + w1 * v[1, 2] + w2 * v[2, 2]
    # The interpolated normal, not normalised (as Cycles: the offset scales with it).
    mx = w0 * n[0, 0] + w1 * n[1, 0] + w2 * n[2, 0]
    my = w0 * n[0, 1] + w1 * n[1, 1] + w2 * n[2, 1]
    mz = w0 * n[0, 2] + w1 * n[1, 2] + w2 * n[2, 2]
    # d[i][j] = (V_i - V_j) . N_k for the three corners k, as needed below.
    a = _dot(n[2, 0] - n[0, 0], n[2, 1] - n[0, 1], n[2, 2] - n[0, 2],
             v[0, 0] - v[2, 0], v[0, 1] - v[2, 1], v[0, 2] - v[2, 2])
    b = _dot(n[2, 0] - n[1, 0], n[2, 1] - n[1, 1], n[2, 2] - n[1, 2],
             v[1, 0] - v[2, 0], v[1, 1] - v[2, 1], v[1, 2] - v[2, 2])
    c = _dot(n[1, 0] - n[0, 0], n[1, 1] - n[0, 1], n[1, 2] - n[0, 2],
             v[1, 0] - v[0, 0], v[1, 1] - v[0, 1], v[1, 2] - v[0, 2])
    # The parabolic approximation of the height above the flat triangle.
    h = a * w0 * (w0 - 1.0) + (a + b + c) * w0 * w1 + b * w1 * (w1 - 1.0)
    # Capped by each corner's tangent plane (the local linear envelope); the sign follows
    # whether the mesh's normals face ng's side (a back-face hit) or not.
    side = 1.0 if _dot(mx, my, mz, ngx, ngy, ngz) > 0.0 else -1.0
    lowest = np.inf
    for k in range(3):
        i, j = (k + 1) % 3, (k + 2) % 3
        nk0, nk1, nk2 = n[k, 0], n[k, 1], n[k, 2]
        reach = max(side * _dot(v[i, 0] - v[k, 0], v[i, 1] - v[k, 1], v[i, 2] - v[k, 2],
                                nk0, nk1, nk2),
                    side * _dot(v[j, 0] - v[k, 0], v[j, 1] - v[k, 1], v[j, 2] - v[k, 2],
                                nk0, nk1, nk2), 0.0)
        hk = max(side * _dot(v[k, 0] - px, v[k, 1] - py, v[k, 2] - pz, nk0, nk1, nk2)
                 + reach, 0.0)
        lowest = min(lowest, hk)
    if side > 0.0:
        h = max(lowest, h * 0.5)
    else:
        h = min(-lowest, h * 0.5)
    return mx * h, my * h, mz * h

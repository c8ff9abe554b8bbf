"""The light tracer's stages: light paths from emissive triangles and light objects through
specular chains, connected to the camera at their first diffuse vertex (caustics.py says
why and how they are weighed against path tracing).

A wavefront like the camera's (kernels.Tracer.trace_light): `start_light_paths` draws a
point and a direction on an emitter, then per bounce embree's closest hits and
`light_bounce`, which follows mirror, metal and glass vertices with the path tracer's own
BSDF sampling (integrator.sample_bsdf: the same Fresnel choice and weights, which are
symmetric for smooth dielectrics) and queues the camera connection at the first Lambertian
vertex after at least one specular one, and goes on from it by the Lambertian BSDF (so
a light path can connect at several diffuse vertices). Paths whose first hit is not
specular, or that reach a rough surface, end: path tracing with next-event estimation
covers those. After
the connections' shadow rays, `splat` spreads each unblocked one over the pixels the
pixel filter reaches, with the density a camera sample has (film.filter_density).

Bounce limits are the path tracer's: a chain of k specular vertices is a camera path whose
emitter hit is vertex k + 1, allowed up to max_bounces + 1.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from . import camera, caustics, lights, shading
from .film import filter_density
from .integrator import (DIFFUSE, GLASS, METAL, MIRROR, ray_offset, russian_roulette,
                         sample_bsdf, surface_colour, surface_interaction)
from .jit import ALLOCATING, INLINE, JIT
from .bsdf import no_layer
from .sampling import (LIGHT_POINT, LIGHT_SELECT, bounce_dim, build_frame, concentric_disk,
                       cosine_hemisphere, hash_combine, pixel_seed, reverse_bits, sample_1d,
                       sample_2d, sample_cdf, uniform_triangle)

# Dimension pairs of a light path's start (its per-bounce blocks follow, as a camera path's).
DIM_EMITTER_POINT, DIM_EMISSION = 0, 1

def light_path_seed(seed):
    """The sequence seed of a replicate's light paths: apart from its pixels' (path ids
    and pixel ids share a numbering)."""
    return int(hash_combine(np.uint64(int(seed) & 0xFFFFFFFF), np.uint64(0x6C69676874)))


# One batch of light paths: live rows, sequence seeds, the ray (float64 and embree's
# float32), the weight beta (caustics.light_tracing_contribution), prev_pdf (unused, for
# integrator.spawn's sake), the chain's IOR product n_x / n_y so far, p_emit of the path's
# start (caustics.CausticData) over the shading_ratio of its Lambertian vertices so far, the
# largest channel of the starting weight (Russian roulette reads beta relative to it), the
# least distance of a first hit the path lights (lights.sphere_light_line; 0 but for Soft
# Falloff lights), and the shader programs' registers (integrator.Paths.svm).
LightPaths = namedtuple("LightPaths", "live pseed o64 d64 origin32 dir32 tmax32 throughput "
                                      "prev_pdf eta pdf_emit start near svm")
# Camera connections: shadow ray (float32), raster position (n, 2) and the contribution per
# unit raster area, MIS weight and 1 / N_L included.
Connections = namedtuple("Connections", "origin direction tmax raster contrib")


def start_light_paths(ids, sample, seed, sc, lp):
    """Light paths ids (n,) at index `sample` of the sequence of `seed`: a source by power;
    on an emissive triangle or an area light a uniform point and a cosine direction (on
    either side of a triangle, in front of an area light); suns, point and spot lights
    their own way (start_sun_path, start_sphere_light_path). Returns the number of paths
    started (0 without sources)."""
    em, ca = sc.emitters, sc.caustics
    if len(ca.cdf) == 0:
        return 0
    rev = reverse_bits(np.uint64(sample))
    for i in range(len(ids)):
        ps = pixel_seed(ids[i], seed)
        lp.pseed[i] = ps
        lp.live[i] = i
        e = sample_cdf(ca.cdf, sample_1d(ps, rev, bounce_dim(0, LIGHT_SELECT)))
        ua, ub = sample_2d(ps, rev, DIM_EMITTER_POINT)
        va, vb = sample_2d(ps, rev, DIM_EMISSION)
        j = ca.light[e]
        pe = ca.pdf_emit[e]
        if HAS_LIGHT_OBJECTS and HAS_SUN_DISCS and j >= 0 and lights.is_sun(j, em.objects):
            start_sun_path(i, e, j, ua, ub, va, vb, sc, lp)
            continue
        if HAS_LIGHT_OBJECTS and j >= 0 and not lights.is_area(j, em.objects):
            start_sphere_light_path(i, e, j, ua, ub, va, vb, sc, lp)
            continue
        b1 = b2 = 0.0
        if HAS_LIGHT_OBJECTS and j >= 0:
            L = em.objects
            px, py, pz = lights.area_light_point(j, ua, ub, L)
            nx, ny, nz = lights.emission_axis(j, L)
            scale = max(abs(px), max(abs(py), abs(pz)))
        else:
            b0, b1, b2 = uniform_triangle(ua, ub)
            px = em.v0[e, 0] + b1 * em.e1[e, 0] + b2 * em.e2[e, 0]
            py = em.v0[e, 1] + b1 * em.e1[e, 1] + b2 * em.e2[e, 1]
            pz = em.v0[e, 2] + b1 * em.e1[e, 2] + b2 * em.e2[e, 2]
            side = 1.0
            if va < 0.5:
                va = 2.0 * va
            else:
                va, side = 2.0 * va - 1.0, -1.0
            nx, ny, nz = side * em.normal[e, 0], side * em.normal[e, 1], side * em.normal[e, 2]
            scale = em.scale[e]
        lx, ly, lz = cosine_hemisphere(va, vb)
        s, t = build_frame(nx, ny, nz)
        dx = lx * s[0] + ly * t[0] + lz * nx
        dy = lx * s[1] + ly * t[1] + lz * ny
        dz = lx * s[2] + ly * t[2] + lz * nz
        if HAS_LIGHT_OBJECTS and j >= 0:
            r0, r1, r2 = lights.area_light_radiance(j, lz, em.objects)
        else:
            r0, r1, r2 = em.radiance[e, 0], em.radiance[e, 1], em.radiance[e, 2]
            if HAS_TEXTURES:
                f = em.triangle_of_entry[e]
                r0, r1, r2 = shading.emission_at(sc.geometry.material_index[f], f, b1, b2,
                                                 sc.materials.programs, sc.geometry.uv, lp.svm,
                                                 r0, r1, r2)
        eps = ray_offset(scale)
        lp.o64[i, 0], lp.o64[i, 1], lp.o64[i, 2] = px + eps * nx, py + eps * ny, pz + eps * nz
        lp.d64[i, 0], lp.d64[i, 1], lp.d64[i, 2] = dx, dy, dz
        for k in range(3):
            lp.origin32[i, k] = lp.o64[i, k]
            lp.dir32[i, k] = lp.d64[i, k]
        _set_start(i, r0, r1, r2, pe, 0.0, lp)
    return len(ids)


def _set_start(i, r0, r1, r2, pe, near, lp):
    """A light path's start weight: radiance over p_emit = p_sel p_A p_dir / |cos| (the
    cosine cancelled, caustics.py), and the least distance of a first hit it lights."""
    lp.throughput[i, 0], lp.throughput[i, 1], lp.throughput[i, 2] = r0 / pe, r1 / pe, r2 / pe
    lp.tmax32[i] = np.inf
    lp.prev_pdf[i] = np.inf
    lp.eta[i] = 1.0
    lp.pdf_emit[i] = pe
    lp.start[i] = max(max(r0, max(r1, r2)), 1e-300) / pe
    lp.near[i] = near


def start_sun_path(i, e, j, ua, ub, va, vb, sc, lp):
    """Light path i from sun j (source e): a direction in its cone, a uniform point on the
    source's disk across it (caustics.CausticData.disk)."""
    L, disk = sc.emitters.objects, sc.caustics.disk
    ax, ay, az = lights.emission_axis(j, L)
    dx, dy, dz, cos_y = lights.sun_direction(j, va, vb, L)
    s, t = build_frame(ax, ay, az)
    qa, qb = concentric_disk(ua, ub)
    qa, qb = qa * disk[e, 3], qb * disk[e, 3]
    lp.o64[i, 0] = disk[e, 0] + qa * s[0] + qb * t[0]
    lp.o64[i, 1] = disk[e, 1] + qa * s[1] + qb * t[1]
    lp.o64[i, 2] = disk[e, 2] + qa * s[2] + qb * t[2]
    lp.d64[i, 0], lp.d64[i, 1], lp.d64[i, 2] = dx, dy, dz
    for k in range(3):
        lp.origin32[i, k] = lp.o64[i, k]
        lp.dir32[i, k] = lp.d64[i, k]
    r0, r1, r2 = lights.sun_disc_radiance(j, L)
    _set_start(i, r0, r1, r2, sc.caustics.pdf_emit[e] / cos_y, 0.0, lp)


def start_sphere_light_path(i, e, j, ua, ub, va, vb, sc, lp):
    """Light path i from point or spot light j (source e): a line it emits
    (lights.sphere_light_line). Lights are not in the scene's geometry, so the ray needs
    no offset."""
    ox, oy, oz, dx, dy, dz, near, r0, r1, r2 = lights.sphere_light_line(
        j, sc.caustics.cos_cone[e], ua, ub, va, vb, sc.emitters.objects)
    lp.o64[i, 0], lp.o64[i, 1], lp.o64[i, 2] = ox, oy, oz
    lp.d64[i, 0], lp.d64[i, 1], lp.d64[i, 2] = dx, dy, dz
    for k in range(3):
        lp.origin32[i, k] = lp.o64[i, k]
        lp.dir32[i, k] = lp.d64[i, k]
    _set_start(i, r0, r1, r2, sc.caustics.pdf_emit[e], near, lp)


def connect_camera(i, row, depth, x, c, sc, lp, conn, n_conn, rev_sample):
    """Queue the connection of Lambertian vertex x of colour c to a lens point (drawn as a
    camera ray draws it), with its contribution and MIS weight, if the camera could see x.
    Returns the connections queued."""
    cam = sc.camera
    lx = ly = 0.0
    if HAS_DOF and cam.aperture > 0.0:
        ua, ub = sample_2d(lp.pseed[row], rev_sample, bounce_dim(depth, LIGHT_POINT))
        if HAS_POLYGON_APERTURE and cam.blades >= 3:
            lx, ly = camera.lens_polygon(ua, ub, cam)
        else:
            lx, ly = camera.lens_disk(ua, ub, cam)
    rx, ry, dz, dist, near, visible = camera.project(x.px, x.py, x.pz, lx, ly, cam)
    if not visible:
        return n_conn
    cx, cy, cz = camera.lens_to_world(lx, ly, cam)
    wx, wy, wz = (cx - x.px) / dist, (cy - x.py) / dist, (cz - x.pz) / dist
    # x's normals face the light's side; the camera must be on it too (Lambert reflects).
    cos_camera = x.nx * wx + x.ny * wy + x.nz * wz
    cos_chain = x.nx * x.wox + x.ny * x.woy + x.nz * x.woz
    cos_shading = x.sx * x.wox + x.sy * x.woy + x.sz * x.woz
    if not (cos_camera > 0.0 and cos_chain > 0.0 and cos_shading > 0.0):
        return n_conn
    raster_per_area = camera.raster_per_steradian(dz, cam) * cos_camera / (dist * dist)
    eta2 = lp.eta[i] * lp.eta[i]
    ca = sc.caustics
    w = caustics.light_tracing_weight(
        ca.n_light, lp.pdf_emit[i], eta2,
        caustics.camera_side_density(raster_per_area, cos_shading / math.pi, cos_chain))
    s = n_conn
    for j in range(3):
        conn.contrib[s, j] = caustics.light_tracing_contribution(
            lp.throughput[i, j], c[j], cos_shading, cos_chain, raster_per_area,
            eta2) * w / ca.n_light
    if not max(conn.contrib[s, 0], max(conn.contrib[s, 1], conn.contrib[s, 2])) > 0.0:
        return n_conn
    eps = ray_offset(x.scale)
    ox, oy, oz = x.px + eps * x.nx, x.py + eps * x.ny, x.pz + eps * x.nz
    conn.origin[s, 0], conn.origin[s, 1], conn.origin[s, 2] = ox, oy, oz
    conn.direction[s, 0], conn.direction[s, 1], conn.direction[s, 2] = wx, wy, wz
    # Up to where the camera ray would start (nothing before its clip start hides x).
    conn.tmax[s] = dist - near - eps
    conn.raster[s, 0], conn.raster[s, 1] = rx, ry
    return s + 1


def light_bounce(depth, rev_sample, max_bounces, sc, prim, tfar, bu, bv, m, lp, conn,
                 n_conn):
    """One bounce of the m live light paths after embree's closest hits: connect at a
    Lambertian vertex after a specular one, go on through specular vertices, end
    otherwise. Returns (paths that go on, connections queued)."""
    out = 0
    no_lobe = no_layer()
    for i in range(m):
        row = lp.live[i]
        f = prim[i]
        if f < 0 or (depth == 0 and tfar[i] < lp.near[i]):
            continue
        x = surface_interaction(i, f, sc.geometry.material_index[f], tfar[i], bu[i], bv[i], sc,
                                lp)
        k = sc.materials.kind[x.mat]
        if not (k == DIFFUSE or k == MIRROR or k == METAL or k == GLASS) or \
                (k == DIFFUSE and depth == 0):  # not a caustic path: NEE's
            continue
        c = surface_colour(x, sc, lp)
        if k == DIFFUSE:
            n_conn = connect_camera(i, row, depth, x, c, sc, lp, conn, n_conn, rev_sample)
        if depth + 1 > max_bounces:
            continue
        # beta carries the emitter's power (it scales with the scene's area): the roulette
        # reads it relative to the start, as a camera path's throughput starts at 1.
        b0 = lp.start[i]
        alive, t0, t1, t2 = russian_roulette(depth, depth, lp.throughput[i, 0] / b0,
                                             lp.throughput[i, 1] / b0,
                                             lp.throughput[i, 2] / b0, lp.pseed[row], rev_sample)
        if not alive:
            continue
        t0, t1, t2 = t0 * b0, t1 * b0, t2 * b0
        wx, wy, wz, f0, f1, f2, pdf, ok = sample_bsdf(row, depth, x, no_lobe, c, sc, lp,
                                                      rev_sample)
        t0, t1, t2 = t0 * f0, t1 * f1, t2 * f2
        if not (ok and max(t0, max(t1, t2)) > 0):
            continue
        eta = lp.eta[i]
        if k == GLASS and (wx * x.nx + wy * x.ny + wz * x.nz) < 0.0:  # refracted
            eta *= sc.materials.ior[x.mat] if x.front else 1.0 / sc.materials.ior[x.mat]
        # The adjoint of a shading (or tilted specular) normal, toward the camera's side,
        # which the path tracer reached first (caustics.shading_ratio).
        if k == DIFFUSE:
            ratio = caustics.shading_ratio(
                x.sx * x.wox + x.sy * x.woy + x.sz * x.woz,
                x.nx * x.wox + x.ny * x.woy + x.nz * x.woz, pdf * math.pi,
                abs(x.nx * wx + x.ny * wy + x.nz * wz))
        else:
            ratio = caustics.shading_ratio(
                abs(x.mx * x.wox + x.my * x.woy + x.mz * x.woz),
                abs(x.nx * x.wox + x.ny * x.woy + x.nz * x.woz),
                abs(x.mx * wx + x.my * wy + x.mz * wz), abs(x.nx * wx + x.ny * wy + x.nz * wz))
        if not ratio > 0.0:  # lit from below its shading horizon: the integrand is 0
            continue
        t0, t1, t2 = t0 * ratio, t1 * ratio, t2 * ratio
        pdf_emit = lp.pdf_emit[i] / ratio
        side = 1.0 if wx * x.nx + wy * x.ny + wz * x.nz >= 0.0 else -1.0
        e = side * ray_offset(x.scale)
        lp.o64[out, 0], lp.o64[out, 1], lp.o64[out, 2] = (x.px + e * x.nx, x.py + e * x.ny,
                                                          x.pz + e * x.nz)
        lp.d64[out, 0], lp.d64[out, 1], lp.d64[out, 2] = wx, wy, wz
        for j in range(3):
            lp.origin32[out, j] = lp.o64[out, j]
            lp.dir32[out, j] = lp.d64[out, j]
        lp.tmax32[out] = np.inf
        lp.throughput[out, 0], lp.throughput[out, 1], lp.throughput[out, 2] = t0, t1, t2
        lp.eta[out] = eta
        lp.pdf_emit[out] = pdf_emit
        lp.start[out] = b0
        lp.live[out] = row
        out += 1
    return out, n_conn


def splat(conn, occluded_prim, count, x0, y0, x1, y1, table, pixels, values):
    """Spread each unblocked connection over the pixels of window [x0, x1) x [y0, y1) that
    the filter reaches from its raster point, weighted by the density with which a camera
    sample of that pixel lands there. Writes window-local pixel ids and values; returns
    how many."""
    n = 0
    lo, hi = table.x[0], table.x[0]
    for k in range(len(table.x)):
        lo, hi = min(lo, table.x[k]), max(hi, table.x[k])
    fx = np.empty(int(math.ceil(hi - lo)) + 2)
    for j in range(count):
        if occluded_prim[j] >= 0:
            continue
        rx, ry = conn.raster[j, 0], conn.raster[j, 1]
        # Pixels whose centre c has rx - c within the filter's offsets [lo, hi].
        ax, bx = max(int(math.ceil(rx - 0.5 - hi)), x0), min(int(math.floor(rx - 0.5 - lo)),
                                                              x1 - 1)
        ay, by = max(int(math.ceil(ry - 0.5 - hi)), y0), min(int(math.floor(ry - 0.5 - lo)),
                                                              y1 - 1)
        # The filter is separable: each column's and row's density once.
        for px in range(ax, bx + 1):
            fx[px - ax] = filter_density(rx - (px + 0.5), table)
        for py in range(ay, by + 1):
            fy = filter_density(ry - (py + 0.5), table)
            if fy == 0.0:
                continue
            for px in range(ax, bx + 1):
                f = fy * fx[px - ax]
                if f == 0.0:
                    continue
                pixels[n] = (py - y0) * (x1 - x0) + (px - x0)
                values[n, 0] = conn.contrib[j, 0] * f
                values[n, 1] = conn.contrib[j, 1] * f
                values[n, 2] = conn.contrib[j, 2] * f
                n += 1
    return n


# name -> (function, numba options), compiled with integrator.STAGES (kernels.Kernel).
STAGES = {f.__name__: (f, INLINE) for f in (connect_camera, _set_start, start_sun_path,
                                             start_sphere_light_path)}
STAGES.update({f.__name__: (f, JIT) for f in (start_light_paths, light_bounce)})
STAGES["splat"] = (splat, ALLOCATING)  # one small scratch row per call
# The plan's values replace these (specialise.py).
HAS_DOF = HAS_POLYGON_APERTURE = HAS_LIGHT_OBJECTS = HAS_SUN_DISCS = HAS_TEXTURES = True

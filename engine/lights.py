"""Emitters: emissive triangles and Blender's light objects, in Cycles' units.

One power-proportional distribution chooses among all emitters for next-event
estimation; `sample` then draws a point (or direction) on the chosen one. Units follow
Cycles (see cycles_conventions.md, section 7), with P the light's colour x power:

- emissive triangle: two-sided radiance L = strength x colour.
- point, r = 0: intensity I = P / (4 pi). Spot: the same times the cone's smoothstep,
  measured in the light's (scaled) local frame, not renormalised to the cone.
- point or spot, r > 0: radiance L = P / (4 pi^2 r^2) on a sphere of radius r
  (soft falloff off) or on a disk of radius r facing the shading point (soft falloff on,
  Blender's default).
- sun: irradiance P on a surface facing it; with an angle, a disc of radiance
  P / (pi sin^2(angle / 2)) sampled uniformly in its cone.
- area: radiance P / (pi A) from the front side (local -Z) only, A including object
  scale (pi/4 x the box for disk and ellipse), times the spread attenuation.

`LightObjects` and `LightSampler` build the emitters' data once (`LightSampler.data()`, the
kernel's `Emitters`); the functions below sample, evaluate and intersect one light for one
point and are compiled into the kernel.

Light objects do not block rays. Camera and BSDF rays that pass through an area light, a
point or spot light of radius > 0 or a sun disc pick up its radiance and continue, as
Cycles treats lights as transparent surfaces.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from . import environment
from .environment import EnvironmentMap
from .jit import INLINE, JIT, njit
from .sampling import (MIN_SOLID_ANGLE, Distribution1D, build_frame, concentric_disk,
                       cross_rows, sample_cdf, spherical_rectangle,
                       spherical_rectangle_solid_angle, uniform_cone, uniform_cone_pdf,
                       uniform_triangle)
from .scene import GLASS, METAL, MIRROR, Scene

POINT, SPOT, SUN, AREA = 0, 1, 2, 3
SPECULAR_KINDS = (MIRROR, METAL, GLASS)
LIGHT_TYPES = {"POINT": POINT, "SPOT": SPOT, "SUN": SUN, "AREA": AREA}
ELLIPTIC_SHAPES = ("DISK", "ELLIPSE")


LOCAL_WEIGHT = 0.75  # the chance of the local distribution where a voxel has one
# With few emitters, the chance of choosing by each one's importance at the shading point
# itself (the rest by power: never 0 where the bound's heuristics are wrong).
IMPORTANCE_WEIGHT = 0.99

# Per-entry bounds for that choice (LightSampler.bounds): a bounding sphere (centre,
# radius), the importance weight (flux over 4 pi, or a distant light's irradiance), the
# emission axis, the emission kind, and a spot's cos(half cone).
(_B_CENTRE, _B_RADIUS, _B_WEIGHT, _B_AXIS, _B_KIND, _B_COS_SPOT, BOUND_COLUMNS) = (
    0, 3, 4, 5, 8, 9, 10)
OMNI, ONE_SIDED, TWO_SIDED, CONE, DISTANT = 0, 1, 2, 3, 4

# The emitters as the kernel reads them (LightSampler.data()):
#   pmf, cdf (k,): the global choice by power; grid (voxels per axis, 0: none), grid_lo (3,),
#   cell (3,), local_pmf (g^3, k), local_cdf_flat (g^3 k,), has_mass (g^3,): the local one;
#   entry_of_triangle, area_by_triangle (t,); per emissive triangle v0, e1, e2, normal (k, 3),
#   area (k,), radiance (k, 3), scale (k,); objects (j, COLUMNS); environment (None or
#   environment.Environment) and its entry (-1: none).
#   bounds (k, BOUND_COLUMNS) or (0, BOUND_COLUMNS): the choice by importance at the point;
#   triangle_of_entry (emissive triangles,): each one's triangle (its textured emission).
Emitters = namedtuple("Emitters", "pmf cdf grid lo cell local_pmf local_cdf_flat has_mass "
                                  "entry_of_triangle area_by_triangle v0 e1 e2 normal area "
                                  "radiance scale objects environment env_entry bounds "
                                  "triangle_of_entry")

(_TYPE, _POWER, _CENTRE, _AXIS_U, _AXIS_V, _DIRECTION, _LOCAL, _RADIUS, _SOFT, _COS_SPOT,
 _SPOT_SMOOTH, _COS_ANGLE, _SUN_RADIANCE, _LEN_U, _LEN_V, _ELLIPTIC, _AREA_SIZE, _SPREAD_ON,
 _SPREAD_TAN, _SPREAD_NORM, _FACTOR, _HIT_CAMERA, _HIT_BSDF, _SUN_CAMERA, _SUN_BSDF,
 COLUMNS) = (0, 1, 4, 7, 10, 13, 16, 25, 26, 27, 28, 29, 30, 31, 32, 33, 34, 35, 36, 37, 38,
              39, 40, 41, 42, 43)


class LightObjects:
    """Blender light objects as arrays (k lights).

    type : (k,) POINT/SPOT/SUN/AREA; power : (k, 3); centre : (k, 3) recentred
    axis_u, axis_v : (k, 3) unit local X and Y; direction : (k, 3) unit emission
    direction (local -Z); len_u, len_v : area size with scale; radius, soft : point/spot;
    local_from_world : (k, 3, 3) to the scaled local frame (spot cones); cos_half_spot,
    spot_smooth; cos_half_angle, sun_radiance; area, elliptic, half_spread, radiance.
    """

    def __init__(self, lights, origin: np.ndarray, scene_radius: float):
        k = len(lights)
        self.count = k
        self.names = [light.name for light in lights]
        self.type = np.array([LIGHT_TYPES[light.type] for light in lights], np.int32)
        self.power = np.array([light.power for light in lights], np.float64).reshape(k, 3)
        m = np.array([np.asarray(light.matrix, np.float64) for light in lights]).reshape(k, 4, 4)
        self.centre = m[:, :3, 3] - origin
        cols = m[:, :3, :3]
        lengths = np.linalg.norm(cols, axis=1)  # (k, 3) scale per local axis
        safe = np.where(lengths > 0, lengths, 1.0)
        self.axis_u = cols[:, :, 0] / safe[:, 0:1]
        self.axis_v = cols[:, :, 1] / safe[:, 1:2]
        self.direction = -cols[:, :, 2] / safe[:, 2:3]
        self.world_from_local = cols
        self.local_from_world = np.linalg.pinv(cols)
        self.radius = np.array([max(float(light.radius), 0.0) for light in lights])
        self.soft = np.array([bool(light.soft_falloff) for light in lights])
        half_spot = np.array([0.5 * float(light.spot_size) for light in lights])
        self.cos_half_spot = np.cos(np.clip(half_spot, 0.0, np.pi / 2))
        blend = np.array([float(light.spot_blend) for light in lights])
        with np.errstate(divide="ignore"):
            self.spot_smooth = 1.0 / np.maximum((1.0 - self.cos_half_spot) * blend, 0.0)
        half_angle = np.array([0.5 * min(float(light.angle), np.pi) for light in lights])
        self.cos_half_angle = np.cos(half_angle)
        sin2 = np.sin(half_angle) ** 2
        self.sun_radiance = np.where(sin2 > 0, 1.0 / (np.pi * np.where(sin2 > 0, sin2, 1.0)), 0.0)
        # Area size with the object's scale; SQUARE and DISK use size_x on both axes.
        size_y = np.array([float(light.size_x if light.shape in ("SQUARE", "DISK") else
                                 light.size_y) for light in lights])
        self.len_u = np.array([float(light.size_x) for light in lights]) * lengths[:, 0]
        self.len_v = size_y * lengths[:, 1]
        self.elliptic = np.array([light.shape in ELLIPTIC_SHAPES for light in lights])
        self.area = self.len_u * self.len_v * np.where(self.elliptic, np.pi / 4, 1.0)
        self.half_spread = np.array([0.5 * float(light.spread) for light in lights])
        normalize = np.array([bool(light.normalize) for light in lights])
        self.visible_camera = np.array([bool(light.visible_camera) for light in lights], bool)
        self.use_mis = np.array([bool(light.use_mis) for light in lights], bool)
        # Emitted radiance per unit power for the surface-like lights.
        sphere_area = 4.0 * np.pi * self.radius**2
        with np.errstate(divide="ignore", invalid="ignore"):
            radiance_factor = np.where(
                self.type == AREA,
                np.where(normalize, 1.0 / (np.pi * np.maximum(self.area, 1e-300)), 1.0 / np.pi),
                np.where(self.radius > 0, 1.0 / (np.pi * np.maximum(sphere_area, 1e-300)), 0.0))
        self.radiance_factor = radiance_factor
        self.scene_radius = max(scene_radius, 1e-12)

    def round_cone(self, j) -> bool:
        """Whether light j's frame is a rotation times a uniform scale, which keeps a
        spot's cone round and about its axis."""
        cols = self.world_from_local[j]
        gram = cols.T @ cols
        return bool(np.allclose(gram, gram[0, 0] * np.eye(3), rtol=1e-9, atol=0.0))

    def selection_power(self) -> np.ndarray:
        """Flux estimates used to pick lights (suns: irradiance x the scene's cross-section)."""
        p = self.power.mean(axis=1)
        zero_area = (self.type == AREA) & (self.area <= 0)
        return np.where(self.type == SUN, p * np.pi * self.scene_radius**2,
                        np.where(zero_area, 0.0, p))

    @property
    def intersectable(self) -> np.ndarray:
        """Lights camera and BSDF rays can hit: areas, spheres/disks of r > 0 (suns with
        an angle are handled on escape)."""
        return ((self.type == AREA) & (self.area > 0)) | (
            ((self.type == POINT) | (self.type == SPOT)) & (self.radius > 0))

    def table(self) -> np.ndarray:
        """The lights as the kernel's (k, COLUMNS) array (columns above)."""
        o = self
        if o.count == 0:
            return np.zeros((0, COLUMNS))
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
        data = np.zeros((o.count, COLUMNS))
        for col, values in columns:
            values = np.asarray(values, np.float64).reshape(o.count, -1)
            data[:, col:col + values.shape[1]] = values
        return data


def traces_light_paths(light) -> bool:
    """Whether light paths start on a light object (scene.Light): an area light of some
    size, a point or spot light of some radius or a sun of some angle, that BSDF rays can
    hit (Cycles' Multiple Importance; otherwise path tracing never finds its caustics, and
    neither does Cycles)."""
    if not (max(light.power) > 0 and bool(light.use_mis)):
        return False
    if light.type == "SUN":  # up to 90 degrees (wider, its start disk is unbounded)
        return 0 < light.angle <= math.pi / 2
    if light.type in ("POINT", "SPOT"):
        return light.radius > 0
    return (light.type == "AREA" and light.size_x > 0
            and (light.size_y > 0 or light.shape in ("SQUARE", "DISK")))


@njit(**JIT)
def spread_attenuation(cos_theta, on, tan_half, norm):
    """Cycles' soft-box grid attenuation of an area light at one cosine, normalised to keep
    power; `on`, tan(half spread) and the normalisation are the light's constants."""
    if not on:
        return 1.0
    c = min(max(cos_theta, 1e-12), 1.0)
    tan_a = math.sqrt(max(1.0 - c * c, 0.0)) / c
    return max((tan_half - tan_a) * norm, 0.0)


@njit(**INLINE)
def spot_attenuation(j, vx, vy, vz, L):
    """The smoothstep of spot light j's cone at direction v from the light, measured in its
    (scaled) local frame; 1 for other lights."""
    if L[j, _TYPE] != SPOT:
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


@njit(**INLINE)
def _sample_point_light(j, px, py, pz, ua, ub, L):
    """sample_object for a point or spot light: a delta light (radius 0), a sphere (soft
    falloff off: uniform in its visible cone, everywhere from inside) or a disk facing the
    point (soft falloff on)."""
    p0, p1, p2 = L[j, _POWER], L[j, _POWER + 1], L[j, _POWER + 2]
    v0 = v1 = v2 = 0.0
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
        wx, wy, wz, cos, pdf = uniform_cone(cx, cy, cz, cos_max, ua, ub)
        root = math.sqrt(max(r ** 2 - d ** 2 * (1 - cos * cos), 0.0))
        dist = d * cos + root if inside else d * cos - root
        f = L[j, _FACTOR]
        v0, v1, v2 = p0 * f / pdf, p1 * f / pdf, p2 * f / pdf
    elif soft and d > 0:  # a disk of radius r facing the point
        nx, ny, nz = -cx, -cy, -cz
        s, t = build_frame(nx, ny, nz)
        qa, qb = concentric_disk(ua, ub)
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
    if valid:
        # Spot cone along each sampled ray, from the sampled point on the light toward
        # the shading point (Cycles' spot_light_sample), as light hits evaluate it
        # along the ray that hit; inside a spot's sphere there is no cone.
        inside_sphere = not soft and r > 0 and d <= r
        att = 1.0 if inside_sphere else spot_attenuation(j, -wx, -wy, -wz, L)
        v0, v1, v2 = v0 * att, v1 * att, v2 * att
    else:
        v0 = v1 = v2 = 0.0
        pdf = 0.0
    return wx, wy, wz, dist, v0, v1, v2, pdf


@njit(**INLINE)
def sample_object(j, px, py, pz, ua, ub, L):
    """Next-event estimation of light j from point p: (wi, distance (inf for a sun),
    radiance / solid-angle pdf per channel, pdf (inf for delta lights))."""
    typ = L[j, _TYPE]
    p0, p1, p2 = L[j, _POWER], L[j, _POWER + 1], L[j, _POWER + 2]
    if typ == POINT or typ == SPOT:
        return _sample_point_light(j, px, py, pz, ua, ub, L)
    if typ == SUN:
        ax, ay, az = -L[j, _DIRECTION], -L[j, _DIRECTION + 1], -L[j, _DIRECTION + 2]
        cos_max = L[j, _COS_ANGLE]
        if cos_max < 1.0:  # a disc: uniform in its cone
            wx, wy, wz, _, pdf = uniform_cone(ax, ay, az, cos_max, ua, ub)
            k = L[j, _SUN_RADIANCE] / pdf
            return wx, wy, wz, np.inf, p0 * k, p1 * k, p2 * k, pdf
        return ax, ay, az, np.inf, p0, p1, p2, np.inf
    solid = _rectangle_solid_angle(j, px, py, pz, L)
    if solid > 0.0:
        # A rectangle seen from its front: uniform in the solid angle it subtends, as Cycles
        # samples it (the 1 / d^2 of area sampling is most of the noise near the light).
        yx, yy, yz, _ = spherical_rectangle(
            px, py, pz, L[j, _CENTRE], L[j, _CENTRE + 1], L[j, _CENTRE + 2], L[j, _AXIS_U],
            L[j, _AXIS_U + 1], L[j, _AXIS_U + 2], L[j, _AXIS_V], L[j, _AXIS_V + 1],
            L[j, _AXIS_V + 2], L[j, _LEN_U], L[j, _LEN_V], ua, ub)
        return _area_light_toward(j, px, py, pz, yx, yy, yz, 1.0 / solid, L)
    # Otherwise a uniform point on the rectangle or ellipse.
    yx, yy, yz = area_light_point(j, ua, ub, L)
    return _area_light_toward(j, px, py, pz, yx, yy, yz, -1.0, L)


@njit(**INLINE)
def area_light_point(j, ua, ub, L):
    """A uniform point on area light j (rectangle or ellipse)."""
    if L[j, _ELLIPTIC] != 0:
        la, lb = concentric_disk(ua, ub)
        la, lb = la * 0.5, lb * 0.5
    else:
        la, lb = ua - 0.5, ub - 0.5
    ka, kb = la * L[j, _LEN_U], lb * L[j, _LEN_V]
    return (L[j, _CENTRE] + ka * L[j, _AXIS_U] + kb * L[j, _AXIS_V],
            L[j, _CENTRE + 1] + ka * L[j, _AXIS_U + 1] + kb * L[j, _AXIS_V + 1],
            L[j, _CENTRE + 2] + ka * L[j, _AXIS_U + 2] + kb * L[j, _AXIS_V + 2])


@njit(**INLINE)
def emission_axis(j, L):
    """Light j's emission direction (an area light's front normal, the way a sun's light
    travels)."""
    return L[j, _DIRECTION], L[j, _DIRECTION + 1], L[j, _DIRECTION + 2]


@njit(**INLINE)
def is_sun(j, L):
    return L[j, _TYPE] == SUN


@njit(**INLINE)
def is_area(j, L):
    return L[j, _TYPE] == AREA


@njit(**INLINE)
def sun_direction(j, ua, ub, L):
    """A direction light from sun j travels, uniform in its cone: (w, cos to its axis)."""
    wx, wy, wz, cos, _ = uniform_cone(L[j, _DIRECTION], L[j, _DIRECTION + 1],
                                      L[j, _DIRECTION + 2], L[j, _COS_ANGLE], ua, ub)
    return wx, wy, wz, cos


@njit(**INLINE)
def sphere_light_line(j, cos_cone, ua, ub, va, vb, L):
    """A line light leaves point or spot light j (radius r > 0) along: a direction w
    uniform in the cone of cos_cone about its axis (-1: every direction), through a point
    uniform on the disk of radius r across w through the centre. Every line either kind
    of light emits is one of these, and they are drawn uniformly in the throughput
    measure dA_perp dw (which does not depend on where along a line it is measured), so
    p_emit = p_sel / (pi r^2 x the cone's solid angle) (caustics.CausticData).
    Returns (origin, w, near, radiance): a sphere's line starts where it leaves the
    sphere. A Soft Falloff light is a disk facing each point it lights (intersect_object);
    the line from the disk's point at offset b carries its radiance only to points at
    least `near` beyond the centre's foot, where the disk facing the point is wide enough:
    b^2 (d^2 + r^2) <= r^2 d^2 with d^2 = b^2 + s^2 at s along the line, so
    s >= b^2 / sqrt(r^2 - b^2). (Geometry within about r of the centre, behind the foot,
    does not shadow the line as it shadows path tracing's rays toward the disk.)"""
    wx, wy, wz, _, _ = uniform_cone(L[j, _DIRECTION], L[j, _DIRECTION + 1],
                                    L[j, _DIRECTION + 2], cos_cone, va, vb)
    s, t = build_frame(wx, wy, wz)
    r = L[j, _RADIUS]
    qa, qb = concentric_disk(ua, ub)
    qa, qb = qa * r, qb * r
    b2 = qa * qa + qb * qb
    if L[j, _SOFT] != 0:
        along = 0.0
        near = b2 / math.sqrt(r * r - b2) if b2 < r * r else np.inf
    else:
        along, near = math.sqrt(max(r * r - b2, 0.0)), 0.0
    ox = L[j, _CENTRE] + qa * s[0] + qb * t[0] + along * wx
    oy = L[j, _CENTRE + 1] + qa * s[1] + qb * t[1] + along * wy
    oz = L[j, _CENTRE + 2] + qa * s[2] + qb * t[2] + along * wz
    f = L[j, _FACTOR] * spot_attenuation(j, wx, wy, wz, L)
    return (ox, oy, oz, wx, wy, wz, near, L[j, _POWER] * f, L[j, _POWER + 1] * f,
            L[j, _POWER + 2] * f)


@njit(**INLINE)
def sun_disc_radiance(j, L):
    """Radiance of sun j's disc (per channel)."""
    k = L[j, _SUN_RADIANCE]
    return L[j, _POWER] * k, L[j, _POWER + 1] * k, L[j, _POWER + 2] * k


@njit(**INLINE)
def area_light_radiance(j, cos_theta, L):
    """Area light j's radiance (per channel) leaving at cos_theta to its emission
    direction: its factor times the spread's attenuation (0 behind it)."""
    if not cos_theta > 0.0:
        return 0.0, 0.0, 0.0
    f = L[j, _FACTOR] * spread_attenuation(cos_theta, L[j, _SPREAD_ON] != 0, L[j, _SPREAD_TAN],
                                           L[j, _SPREAD_NORM])
    return L[j, _POWER] * f, L[j, _POWER + 1] * f, L[j, _POWER + 2] * f


@njit(**INLINE)
def _area_light_toward(j, px, py, pz, yx, yy, yz, pdf_solid, L):
    """Area light j's sample at point y seen from p: (wi, distance, radiance / pdf, pdf),
    with the solid-angle pdf given, or (pdf_solid < 0) that of uniform area sampling."""
    tx, ty, tz = yx - px, yy - py, yz - pz
    d = math.sqrt(tx * tx + ty * ty + tz * tz)
    dn = d if d > 0 else 1.0
    wx, wy, wz = tx / dn, ty / dn, tz / dn
    cos_l = -(wx * L[j, _DIRECTION] + wy * L[j, _DIRECTION + 1] + wz * L[j, _DIRECTION + 2])
    v0 = v1 = v2 = pdf = 0.0
    area = L[j, _AREA_SIZE]
    if cos_l > 0 and d > 0 and area > 0:
        pdf = pdf_solid if pdf_solid >= 0.0 else d * d / max(area * cos_l, 1e-300)
        r0, r1, r2 = area_light_radiance(j, cos_l, L)
        v0, v1, v2 = r0 / pdf, r1 / pdf, r2 / pdf
    return wx, wy, wz, d, v0, v1, v2, pdf


@njit(**INLINE)
def _rectangle_solid_angle(j, ox, oy, oz, L):
    """The solid angle area light j subtends at o, when it is sampled that way (a
    rectangle with square axes, o in front of it, not too small); 0 otherwise."""
    if L[j, _ELLIPTIC] != 0:
        return 0.0
    if abs(L[j, _AXIS_U] * L[j, _AXIS_V] + L[j, _AXIS_U + 1] * L[j, _AXIS_V + 1]
           + L[j, _AXIS_U + 2] * L[j, _AXIS_V + 2]) > 1e-9:
        return 0.0  # sheared: not a rectangle
    front = ((ox - L[j, _CENTRE]) * L[j, _DIRECTION] + (oy - L[j, _CENTRE + 1])
             * L[j, _DIRECTION + 1] + (oz - L[j, _CENTRE + 2]) * L[j, _DIRECTION + 2])
    if not (front > 0.0 and L[j, _LEN_U] > 0.0 and L[j, _LEN_V] > 0.0):
        return 0.0
    solid = spherical_rectangle_solid_angle(
        ox, oy, oz, L[j, _CENTRE], L[j, _CENTRE + 1], L[j, _CENTRE + 2], L[j, _AXIS_U],
        L[j, _AXIS_U + 1], L[j, _AXIS_U + 2], L[j, _AXIS_V], L[j, _AXIS_V + 1],
        L[j, _AXIS_V + 2], L[j, _LEN_U], L[j, _LEN_V])
    return solid if solid > MIN_SOLID_ANGLE else 0.0


@njit(**INLINE)
def object_pdf(j, ox, oy, oz, dx, dy, dz, t, L):
    """The solid-angle density of sampling direction d from o toward
    intersectable light j, hit at distance t."""
    typ = L[j, _TYPE]
    if typ == AREA:
        solid = _rectangle_solid_angle(j, ox, oy, oz, L)
        if solid > 0.0:
            return 1.0 / solid
        cos_a = -(dx * L[j, _DIRECTION] + dy * L[j, _DIRECTION + 1] + dz * L[j, _DIRECTION + 2])
        return t * t / max(L[j, _AREA_SIZE] * cos_a, 1e-300)
    tx, ty, tz = L[j, _CENTRE] - ox, L[j, _CENTRE + 1] - oy, L[j, _CENTRE + 2] - oz
    d = math.sqrt(tx * tx + ty * ty + tz * tz)
    r = L[j, _RADIUS]
    if (typ == POINT or typ == SPOT) and r > 0:
        dn = d if d > 0 else 1.0
        if L[j, _SOFT] != 0:
            cos_d = tx / dn * dx + ty / dn * dy + tz / dn * dz
            return t * t / (np.pi * max(r * r * cos_d, 1e-300))
        cos_max = math.sqrt(max(0.0, 1.0 - (r / dn) ** 2)) if d > r else -1.0
        return uniform_cone_pdf(cos_max)
    return 0.0


@njit(**INLINE)
def intersect_object(j, ox, oy, oz, dx, dy, dz, tmax, L):
    """Where a ray (o, d) hits light j before tmax: (distance (inf: missed), radiance).
    Light objects are transparent: rays pick up their radiance and go on."""
    th = np.inf
    f = L[j, _FACTOR]
    p0, p1, p2 = L[j, _POWER], L[j, _POWER + 1], L[j, _POWER + 2]
    c0, c1, c2 = L[j, _CENTRE], L[j, _CENTRE + 1], L[j, _CENTRE + 2]
    if L[j, _TYPE] == AREA:
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
        r0, r1, r2 = area_light_radiance(j, -denom, L)
        return th, r0, r1, r2
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
        if L[j, _TYPE] == SPOT:
            # One-sided: a spot is hit only by rays heading toward its centre's side;
            # from inside its sphere there is no cone (Cycles' spot.h).
            ok = ok and dx * ocx + dy * ocy + dz * ocz < 0.0
            if ok and t < tmax:
                th = t
            att = 1.0
            if L[j, _SOFT] != 0 or ocx * ocx + ocy * ocy + ocz * ocz > r * r:
                att = spot_attenuation(j, -dx, -dy, -dz, L)
            return th, p0 * f * att, p1 * f * att, p2 * f * att
        if ok and t < tmax:
            th = t
    return th, p0 * f, p1 * f, p2 * f


class LightSampler:
    """All emitters of a scene, chosen by a mixture of two distributions.

    Entries 0..k-1 are emissive triangles, then light objects, then the environment.
    With few emitters (2 to MIN_ENTRIES - 1), each shading point weighs every one by its
    importance there (`importance`: intensity toward the point over d^2, bounded cosines
    at both ends, as the leaves of Cycles' light tree), with probability
    IMPORTANCE_WEIGHT, and by power otherwise. With many, a voxel grid over the scene
    holds, per voxel, a distribution by power / distance^2 from the voxel (so a point
    picks the lights that matter to it); a point samples that local distribution with
    probability LOCAL_WEIGHT and the global power distribution otherwise. Each choice's
    probability is known at any point (and normal), so MIS is exact.
    """

    LOCAL_WEIGHT = LOCAL_WEIGHT
    GRID = 8  # voxels per axis
    MIN_ENTRIES, MAX_ENTRIES = 8, 20_000  # the grid is (GRID^3, entries) floats
    IMPORTANCE = True  # fewer entries: chosen by their importance at each point (bounds)

    def __init__(self, scene: Scene):
        emission = scene.materials.emission[scene.material_index]
        v = scene.vertices
        area = 0.5 * np.linalg.norm(cross_rows(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]),
                                    axis=1)
        # Two-sided exitance pi L per side, times area: the triangle's flux.
        tri_power = 2.0 * np.pi * area * emission.mean(axis=1) if len(v) else np.zeros(0)
        self.index = np.nonzero(tri_power > 0)[0]
        self.radiance = emission[self.index]
        self.area = area[self.index]
        self.corners = v[self.index]
        # Per-emitter constants, gathered once rather than per sample.
        c = self.corners
        self.v0, self.e1, self.e2 = c[:, 0], c[:, 1] - c[:, 0], c[:, 2] - c[:, 0]
        nrm = cross_rows(self.e1, self.e2)
        self.normal = nrm / np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-300)
        self.scale = np.abs(c).max(axis=(1, 2)) if len(c) else np.zeros(0)
        radius = max(scene.extent, 1e-3) * 2.0
        self.objects = LightObjects(scene.lights, scene.origin, radius)
        env = scene.world.environment
        self.environment = None if env is None else EnvironmentMap(
            env, scene.world.texture_from_world, scene.world.ray_environments)
        # The world's flux through the scene's cross-section, to weigh it against lights.
        env_power = [] if self.environment is None else \
            [np.pi * self.environment.mean_radiance * np.pi * radius**2]
        weights = np.concatenate([tri_power[self.index], self.objects.selection_power(),
                                  env_power])
        self.distribution = Distribution1D(weights)
        self._caustic_sources(scene, tri_power[self.index])
        k = len(self.index)
        self.num_triangles = k
        self.num_entries = len(weights)
        self.entry_of_triangle = np.full(scene.num_triangles, -1, np.int64)
        self.entry_of_triangle[self.index] = np.arange(k)
        self.environment_index = len(weights) - 1 if env is not None else -1
        self.area_by_triangle = np.where(area > 0, area, 1.0)
        # Entry positions (suns and the environment have none: distance plays no part).
        centres = np.concatenate([self.corners.mean(axis=1), self.objects.centre,
                                  np.zeros((len(env_power), 3))])
        distant = np.concatenate([np.zeros(k, bool), self.objects.type == SUN,
                                  np.ones(len(env_power), bool)])
        self.scene_radius = radius
        if self.MIN_ENTRIES <= self.num_entries <= self.MAX_ENTRIES and len(v):
            self._build_grid(v.reshape(-1, 3), weights, centres, distant)
        elif self.IMPORTANCE and 2 <= self.num_entries < self.MIN_ENTRIES:
            self.bounds = self._bounds(weights, centres, distant)

    def _caustic_sources(self, scene, tri_power):
        """The light tracer's sources (caustics.py): the emissive triangles, then the
        light objects light paths start on (traces_light_paths), chosen by power. A sun's
        paths start on a disk across its direction, upstream of all the geometry (so
        whatever shades a sun ray shades its light path), just big enough to send every
        direction of its cone through the bounding sphere of the specular surfaces (only
        paths whose first hit is specular are light tracing's): caustic_disk holds its
        centre and radius (zeros for the others), caustic_area the sources' areas
        (a point or spot light's: its disk across each line, sphere_light_line), and
        caustic_cone the cosine of the cone their directions fill (suns, point and spot
        lights; a spot's own where its frame keeps cones round, else every direction)."""
        o = self.objects
        lit = [j for j, light in enumerate(scene.lights) if traces_light_paths(light)
               and (o.type[j] != AREA or o.area[j] > 0)]
        kinds = scene.materials.kind[scene.material_index]
        specular = np.isin(kinds, SPECULAR_KINDS)
        pts = scene.vertices[specular].reshape(-1, 3)
        centre = 0.5 * (pts.min(axis=0) + pts.max(axis=0)) if len(pts) else np.zeros(3)
        r_spec = float(np.linalg.norm(pts - centre, axis=1).max()) if len(pts) else 0.0
        disk = np.zeros((len(lit), 4))
        area = o.area[lit].astype(float)
        power = o.power.mean(axis=1)[lit]
        cone = np.zeros(len(lit))
        for k, j in enumerate(lit):
            if o.type[j] in (POINT, SPOT):
                cone[k] = o.cos_half_spot[j] if o.type[j] == SPOT and o.round_cone(j) else -1.0
                area[k] = math.pi * o.radius[j] ** 2
                power[k] *= 0.5 * (1.0 - cone[k])  # the share of the sphere the cone holds
            if o.type[j] == SUN:
                cone[k] = o.cos_half_angle[j]
                tan_half = math.tan(math.acos(min(max(o.cos_half_angle[j], -1.0), 1.0)))
                # Upstream of the geometry's bounding sphere (recentred: about the origin).
                up = float(np.linalg.norm(centre)) + math.sqrt(3.0) * scene.extent + r_spec
                up = 1.01 * up + 1e-9
                radius = (max(r_spec, 1e-12) + up * tan_half) * 1.001
                disk[k] = (*(centre - up * o.direction[j]), radius)
                area[k] = math.pi * radius * radius
                power[k] = power[k] * area[k]  # irradiance across the disk
        self.caustic_light = np.concatenate([np.full(len(self.index), -1),
                                             np.array(lit, np.int64)]).astype(np.int64)
        self.caustic_area = np.concatenate([self.area, area])
        self.caustic_disk = np.concatenate([np.zeros((len(self.index), 4)), disk])
        self.caustic_cone = np.concatenate([np.zeros(len(self.index)), cone])
        self.caustic_distribution = Distribution1D(np.concatenate([tri_power, power]))

    def _bounds(self, weights, centres, distant):
        """The few emitters' bounds for the choice by importance at each point (as a light
        tree's leaves weigh their lights, Cycles' kernel/light/tree.h): the intensity on
        the emitter's axis over d^2, d no less than the bound's radius, times its cosine
        toward the point bounded over its sphere (0 behind a one-sided area light, outside
        a spot's cone)."""
        k, o = self.num_triangles, self.objects
        b = np.zeros((self.num_entries, BOUND_COLUMNS))
        b[:, _B_CENTRE:_B_CENTRE + 3] = centres
        if k:
            b[:k, _B_RADIUS] = np.linalg.norm(self.corners - centres[:k, None], axis=2).max(1)
            b[:k, _B_AXIS:_B_AXIS + 3] = self.normal
            b[:k, _B_KIND] = TWO_SIDED
        j = slice(k, k + o.count)
        b[j, _B_AXIS:_B_AXIS + 3] = o.direction
        b[j, _B_COS_SPOT] = o.cos_half_spot
        b[j, _B_RADIUS] = np.where(o.type == AREA, 0.5 * np.hypot(o.len_u, o.len_v), o.radius)
        b[j, _B_KIND] = np.select([o.type == SUN, o.type == AREA, o.type == SPOT],
                                  [DISTANT, ONE_SIDED, CONE], OMNI)
        b[distant, _B_KIND] = DISTANT
        # The weight is the intensity toward the emitter's axis: flux / 4 pi for a point or
        # spot, / pi for a one-sided cosine emitter, / 2 pi for a two-sided one; distant
        # emitters weigh their irradiance.
        per_sr = np.select([b[:, _B_KIND] == ONE_SIDED, b[:, _B_KIND] == TWO_SIDED],
                           [np.pi, 2.0 * np.pi], 4.0 * np.pi)
        b[:, _B_WEIGHT] = weights / per_sr
        b[distant, _B_WEIGHT] = weights[distant] / (np.pi * self.scene_radius**2)
        return b

    def _build_grid(self, points, weights, centres, distant):
        lo, hi = points.min(axis=0), points.max(axis=0)
        pad = 1e-6 * max(float(np.max(hi - lo)), 1e-12)
        self.grid_lo, size = lo - pad, (hi - lo) + 2 * pad
        self.cell = np.maximum(size / self.GRID, 1e-30)
        g = self.GRID
        idx = np.stack(np.meshgrid(np.arange(g), np.arange(g), np.arange(g), indexing="ij"),
                       -1).reshape(-1, 3)
        voxel_centres = self.grid_lo + (idx + 0.5) * self.cell
        half_diag2 = float(np.sum((0.5 * self.cell) ** 2))
        d2 = np.sum((voxel_centres[:, None, :] - centres[None, :, :]) ** 2, axis=2)
        # Irradiance-like importance: flux / (4 pi d^2) for local emitters (distance floored
        # at the voxel's size), the irradiance itself for suns and the environment.
        importance = weights[None, :] / (4.0 * np.pi * np.maximum(d2, half_diag2))
        importance[:, distant] = weights[distant] / (np.pi * self.scene_radius**2)
        total = importance.sum(axis=1, keepdims=True)
        self.local_pmf = np.where(total > 0, importance / np.where(total > 0, total, 1), 0.0)
        cdf = np.cumsum(self.local_pmf, axis=1)
        cdf[:, -1] = 1.0
        # Row v's CDF shifted by v: one monotone array for a batched searchsorted.
        self.local_cdf_flat = (cdf + np.arange(len(cdf))[:, None]).ravel()
        self.grid_has_mass = total[:, 0] > 0

    def __len__(self):
        return self.num_entries

    def data(self) -> "Emitters":
        """The kernel's Emitters."""
        if hasattr(self, "local_pmf"):
            grid = (self.GRID, self.grid_lo, self.cell, self.local_pmf, self.local_cdf_flat,
                    self.grid_has_mass)
        else:
            grid = (0, np.zeros(3), np.ones(3), np.zeros((1, self.num_entries)), np.zeros(0),
                    np.zeros(1, np.bool_))
        env = self.environment.data() if self.environment is not None else None
        bounds = getattr(self, "bounds", np.zeros((0, BOUND_COLUMNS)))
        return Emitters(self.distribution.pmf, self.distribution.cdf, *grid,
                        self.entry_of_triangle, self.area_by_triangle, self.v0, self.e1, self.e2,
                        self.normal, self.area, self.radiance, self.scale,
                        self.objects.table(), env, int(self.environment_index), bounds,
                        self.index.astype(np.int64))


@njit(**INLINE)
def _cos_less(cos_t, cos_a, sin_a):
    """cos(max(theta - alpha, 0)) from cos theta and alpha's cosine and sine."""
    if cos_t >= cos_a:
        return 1.0
    return cos_t * cos_a + math.sqrt(max(1.0 - cos_t * cos_t, 0.0)) * sin_a


@njit(**INLINE)
def importance(px, py, pz, nx, ny, nz, e, bounds):
    """Entry e's importance at point p with shading normal n (zeros: no side; see
    LightSampler._bounds): an estimate of the irradiance it can bring, up to a common
    factor, 0 only where it brings none."""
    kind = bounds[e, _B_KIND]
    w = bounds[e, _B_WEIGHT]
    if kind == DISTANT:
        return w
    dx, dy, dz = px - bounds[e, 0], py - bounds[e, 1], pz - bounds[e, 2]
    r = bounds[e, _B_RADIUS]
    d2 = dx * dx + dy * dy + dz * dz
    if d2 <= r * r:  # inside the bound: every direction may matter
        return w / max(r * r, 1e-300)
    d = math.sqrt(d2)
    sin_a = r / d  # the bound's angular radius alpha, seen from p
    cos_a = math.sqrt(max(1.0 - sin_a * sin_a, 0.0))
    # The receiver's cosine toward the bound, at its most favourable point.
    if nx != 0.0 or ny != 0.0 or nz != 0.0:
        cos_i = _cos_less(-(dx * nx + dy * ny + dz * nz) / d, cos_a, sin_a)
        if cos_i <= 0.0:
            return 0.0
        w *= cos_i
    if kind != OMNI:
        # The emitter's: between its axis and p seen from the centre, less alpha.
        cos_t = (dx * bounds[e, 5] + dy * bounds[e, 6] + dz * bounds[e, 7]) / d
        if kind == TWO_SIDED:
            cos_t = abs(cos_t)
        cos_min = _cos_less(cos_t, cos_a, sin_a)
        if kind == CONE:
            if cos_min < bounds[e, _B_COS_SPOT]:
                return 0.0
        elif cos_min <= 0.0:
            return 0.0
        else:
            w *= cos_min
    return w / max(d2, 1e-300)


@njit(**JIT)
def importance_pmf(px, py, pz, nx, ny, nz, entry, pmf, bounds):
    """The probability of choosing `entry` from p (shading normal n) among few emitters:
    by importance at p with probability IMPORTANCE_WEIGHT, by power otherwise."""
    total = 0.0
    for e in range(len(pmf)):
        total += importance(px, py, pz, nx, ny, nz, e, bounds)
    if not total > 0.0:
        return pmf[entry]
    a = IMPORTANCE_WEIGHT
    return a * importance(px, py, pz, nx, ny, nz, entry, bounds) / total + (1.0 - a) * pmf[
        entry]


@njit(**JIT)
def choose_by_importance(px, py, pz, nx, ny, nz, u, pmf, cdf, bounds):
    """An emitter chosen with u among few from point p, shading normal n: (entry,
    probability)."""
    total = 0.0
    for e in range(len(pmf)):
        total += importance(px, py, pz, nx, ny, nz, e, bounds)
    a = IMPORTANCE_WEIGHT if total > 0.0 else 0.0
    if u < a:
        target = (u / a) * total
        acc, k = 0.0, len(pmf) - 1
        for e in range(len(pmf)):
            acc += importance(px, py, pz, nx, ny, nz, e, bounds)
            if target < acc:
                k = e
                break
        # The last entry with importance, if rounding ran past the total.
        while importance(px, py, pz, nx, ny, nz, k, bounds) <= 0.0 and k > 0:
            k -= 1
    else:
        k = sample_cdf(cdf, (u - a) / (1.0 - a) if a > 0.0 else u)
    p = pmf[k]
    if a > 0.0:
        p = a * importance(px, py, pz, nx, ny, nz, k, bounds) / total + (1.0 - a) * pmf[k]
    return k, p


@njit(**JIT)
def voxel(px, py, pz, lo, cell, grid):
    i = min(max(int((px - lo[0]) / cell[0]), 0), grid - 1)
    j = min(max(int((py - lo[1]) / cell[1]), 0), grid - 1)
    k = min(max(int((pz - lo[2]) / cell[2]), 0), grid - 1)
    return (i * grid + j) * grid + k


@njit(**JIT)
def entry_pmf(px, py, pz, entry, pmf, grid, lo, cell, local_pmf, has_mass):
    """The probability of choosing emitter `entry` from point p (the arrays of Emitters:
    a helper taking the structure itself would pay reference counts on every call)."""
    if grid == 0:
        return pmf[entry]
    vox = voxel(px, py, pz, lo, cell, grid)
    a = LOCAL_WEIGHT if has_mass[vox] else 0.0
    return a * local_pmf[vox, entry] + (1.0 - a) * pmf[entry]


@njit(**JIT)
def choose(px, py, pz, u, pmf, cdf, grid, lo, cell, local_pmf, local_cdf_flat, has_mass):
    """An emitter chosen from point p with u: (entry, probability). With a grid, the
    local distribution of p's voxel with probability LOCAL_WEIGHT, else the global one."""
    k_count = len(pmf)
    if grid == 0:
        k = sample_cdf(cdf, u)
        return k, pmf[k]
    vox = voxel(px, py, pz, lo, cell, grid)
    a = LOCAL_WEIGHT if has_mass[vox] else 0.0
    if u < a:
        ul = min(u / a, 1.0 - 1e-12)
        flat = np.searchsorted(local_cdf_flat, vox + ul, side="right")
        k = min(max(flat - vox * k_count, 0), k_count - 1)
    else:
        k = sample_cdf(cdf, (u - a) / (1.0 - a))
    return k, a * local_pmf[vox, k] + (1.0 - a) * pmf[k]


@njit(**INLINE)
def sample_triangle(e, px, py, pz, ua, ub, em):
    """A uniform point on emissive triangle entry e seen from p: (wi, distance, radiance /
    solid-angle pdf per channel, the solid-angle pdf). Two-sided emission."""
    b0, b1, b2 = uniform_triangle(ua, ub)
    tx = em.v0[e, 0] + b1 * em.e1[e, 0] + b2 * em.e2[e, 0] - px
    ty = em.v0[e, 1] + b1 * em.e1[e, 1] + b2 * em.e2[e, 1] - py
    tz = em.v0[e, 2] + b1 * em.e1[e, 2] + b2 * em.e2[e, 2] - pz
    dist = math.sqrt(tx * tx + ty * ty + tz * tz)
    dn = dist if dist > 0 else 1.0
    wx, wy, wz = tx / dn, ty / dn, tz / dn
    cos_l = abs(em.normal[e, 0] * wx + em.normal[e, 1] * wy + em.normal[e, 2] * wz)
    q0 = q1 = q2 = pdf = 0.0
    if cos_l > 0 and dist > 0:
        pdf = triangle_pdf(dist, cos_l, em.area[e])
        inv = 1.0 / pdf
        q0, q1, q2 = em.radiance[e, 0] * inv, em.radiance[e, 1] * inv, em.radiance[e, 2] * inv
    return wx, wy, wz, dist, q0, q1, q2, pdf


@njit(**JIT)
def triangle_pdf(dist, cos_l, area):
    """The solid-angle density of a uniform point on a triangle of this area."""
    return dist * dist / max(area * cos_l, 1e-300)


@njit(**INLINE)
def sample_environment(ua, ub, env):
    """A direction from the environment map: (wi, inf, radiance / pdf, pdf)."""
    wx, wy, wz, pdf = environment.sample(ua, ub, env)
    u_e, v_e = environment.to_uv(wx, wy, wz, env.texture_from_world)
    q0, q1, q2 = environment.lookup(u_e, v_e, env.image)
    pd = max(pdf, 1e-300)
    return wx, wy, wz, np.inf, q0 / pd, q1 / pd, q2 / pd, pdf

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

Light objects do not block rays. Camera and BSDF rays that pass through an area light, a
point or spot light of radius > 0 or a sun disc pick up its radiance and continue, as
Cycles treats lights as transparent surfaces.
"""

from __future__ import annotations

import numpy as np

from . import sampling
from .environment import EnvironmentMap
from .scene import Scene

POINT, SPOT, SUN, AREA = 0, 1, 2, 3
LIGHT_TYPES = {"POINT": POINT, "SPOT": SPOT, "SUN": SUN, "AREA": AREA}
ELLIPTIC_SHAPES = ("DISK", "ELLIPSE")


def _dot(a, b):
    return np.einsum("ij,ij->i", a, b)


def _normalize(v):
    n = np.linalg.norm(v, axis=1, keepdims=True)
    return v / np.where(n > 0, n, 1.0)


def smoothstep(f):
    f = np.clip(f, 0.0, 1.0)
    return f * f * (3.0 - 2.0 * f)


def spread_attenuation(cos_theta, half_spread):
    """Cycles' soft-box grid attenuation of an area light, normalised to keep power."""
    if half_spread >= 0.5 * np.pi - 1e-6:
        return np.ones_like(cos_theta)
    t = np.tan(half_spread)
    norm = 3.0 / half_spread**3 if half_spread <= 0.05 else 1.0 / (t - half_spread)
    c = np.clip(cos_theta, 1e-12, 1.0)
    tan_a = np.sqrt(np.maximum(1.0 - c * c, 0.0)) / c
    return np.maximum((t - tan_a) * norm, 0.0)


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

    # ------------------------------------------------------------------ helpers
    def spot_attenuation(self, j, w_from_light):
        """Smoothstep of the spot cone for lights j (n,) at directions from the light."""
        local = np.einsum("nij,nj->ni", self.local_from_world[j], w_from_light)
        local = _normalize(local)
        f = (-local[:, 2] - self.cos_half_spot[j]) * self.spot_smooth[j]
        att = smoothstep(np.nan_to_num(f, nan=0.0, posinf=1.0, neginf=0.0))
        return np.where(self.type[j] == SPOT, att, 1.0)

    def _frame(self, normal):
        s, t = sampling.build_frame(normal)
        return s, t

    # ------------------------------------------------------------------ sampling
    def sample(self, j, p, u):
        """Sample lights j (n,) from points p (n, 3) with u (n, 2).

        Returns wi (n, 3) toward the light, dist (n,) to the sampled point (inf for
        suns), value (n, 3) = emitted radiance / solid-angle pdf (intensity / d^2 for delta
        lights), pdf (n,) solid-angle density (inf for delta lights).
        """
        n = len(j)
        wi = np.zeros((n, 3))
        dist = np.full(n, np.inf)
        value = np.zeros((n, 3))
        pdf = np.full(n, np.inf)
        typ = self.type[j]
        power = self.power[j]

        # Point and spot lights.
        ps = np.nonzero((typ == POINT) | (typ == SPOT))[0]
        if len(ps):
            self._sample_point(j[ps], p[ps], u[ps], power[ps], ps, wi, dist, value, pdf)
        # Suns.
        su = np.nonzero(typ == SUN)[0]
        if len(su):
            js = j[su]
            axis = -self.direction[js]
            cos_max = self.cos_half_angle[js]
            disc = cos_max < 1.0
            s, t = self._frame(axis)
            cos = 1.0 - u[su, 0] * (1.0 - cos_max)
            sin = np.sqrt(np.maximum(0.0, 1.0 - cos * cos))
            phi = 2.0 * np.pi * u[su, 1]
            d_cone = (sin * np.cos(phi))[:, None] * s + (sin * np.sin(phi))[:, None] * t \
                + cos[:, None] * axis
            wi[su] = np.where(disc[:, None], d_cone, axis)
            pdf_cone = 1.0 / (2.0 * np.pi * np.maximum(1.0 - cos_max, 1e-300))
            pdf[su] = np.where(disc, pdf_cone, np.inf)
            value[su] = np.where(disc[:, None],
                                 power[su] * (self.sun_radiance[js] / pdf_cone)[:, None],
                                 power[su])
        # Area lights.
        ar = np.nonzero(typ == AREA)[0]
        if len(ar):
            ja = j[ar]
            uu = u[ar]
            ell = self.elliptic[ja]
            disk = sampling.sample_uniform_disk_concentric(uu) * 0.5
            rect = uu - 0.5
            local = np.where(ell[:, None], disk, rect)
            y = (self.centre[ja] + (local[:, 0] * self.len_u[ja])[:, None] * self.axis_u[ja]
                 + (local[:, 1] * self.len_v[ja])[:, None] * self.axis_v[ja])
            to = y - p[ar]
            d = np.linalg.norm(to, axis=1)
            w = to / np.where(d > 0, d, 1.0)[:, None]
            cos_l = -_dot(w, self.direction[ja])  # front side: light faces the point
            ok = (cos_l > 0) & (d > 0) & (self.area[ja] > 0)
            pdf_sa = np.where(ok, d * d / np.maximum(self.area[ja] * cos_l, 1e-300), np.inf)
            att = np.ones(len(ar))
            spread = self.half_spread[ja] < 0.5 * np.pi - 1e-6
            if spread.any():
                for h in np.unique(self.half_spread[ja][spread]):
                    sel = spread & (self.half_spread[ja] == h)
                    att[sel] = spread_attenuation(cos_l[sel], h)
            le = power[ar] * (self.radiance_factor[ja] * att)[:, None]
            wi[ar], dist[ar] = w, d
            value[ar] = np.where(ok[:, None], le / np.where(ok, pdf_sa, 1.0)[:, None], 0.0)
            pdf[ar] = np.where(ok, pdf_sa, 0.0)
        return wi, dist, value, pdf

    def _sample_point(self, j, p, u, power, rows, wi, dist, value, pdf):
        to_c = self.centre[j] - p
        d = np.linalg.norm(to_c, axis=1)
        w_c = to_c / np.where(d > 0, d, 1.0)[:, None]
        r = self.radius[j]
        out = np.zeros((len(j), 3))
        w_out, d_out = w_c.copy(), d.copy()
        pdf_out = np.full(len(j), np.inf)

        # r = 0: intensity P / (4 pi), a delta light.
        delta = r <= 0
        # r > 0, soft falloff off: a sphere, sampled uniformly in its visible cone; from
        # inside it (Cycles lights such points too) in every direction, the cone of
        # cosine -1, each ray reaching its far side.
        sphere = (r > 0) & ~self.soft[j]
        inside = d <= r
        # r > 0, soft falloff on: a disk of radius r facing the shading point.
        disk = (r > 0) & self.soft[j] & (d > 0)
        le = power * self.radiance_factor[j][:, None]
        if delta.any():
            out[delta] = power[delta] / (4.0 * np.pi * np.maximum(d[delta], 1e-300) ** 2)[:, None]
        if sphere.any():
            s_ = np.nonzero(sphere)[0]
            cos_max = np.where(inside[s_], -1.0, np.sqrt(np.maximum(
                0.0, 1.0 - (r[s_] / np.where(inside[s_], 1.0, d[s_])) ** 2)))
            axis = np.where((d[s_] > 0)[:, None], w_c[s_], np.array([0.0, 0.0, 1.0]))
            s, t = self._frame(axis)
            cos = 1.0 - u[s_, 0] * (1.0 - cos_max)
            sin = np.sqrt(np.maximum(0.0, 1.0 - cos * cos))
            phi = 2.0 * np.pi * u[s_, 1]
            w = (sin * np.cos(phi))[:, None] * s + (sin * np.sin(phi))[:, None] * t \
                + cos[:, None] * axis
            # Distance to the sphere along w (law of cosines: near root, far from inside).
            t_hit = d[s_] * cos - np.where(inside[s_], -1.0, 1.0) * np.sqrt(
                np.maximum(r[s_] ** 2 - d[s_] ** 2 * (1 - cos * cos), 0.0))
            pdf_sa = 1.0 / (2.0 * np.pi * np.maximum(1.0 - cos_max, 1e-300))
            w_out[s_], d_out[s_], pdf_out[s_] = w, t_hit, pdf_sa
            out[s_] = le[s_] / pdf_sa[:, None]
        if disk.any():
            k = np.nonzero(disk)[0]
            n_d = -w_c[k]  # disk normal, toward the shading point
            s, t = self._frame(n_d)
            q = sampling.sample_uniform_disk_concentric(u[k]) * r[k][:, None]
            y = self.centre[j[k]] + q[:, :1] * s + q[:, 1:] * t
            to = y - p[k]
            dd = np.linalg.norm(to, axis=1)
            w = to / dd[:, None]
            cos_l = -_dot(w, n_d)
            pdf_sa = dd * dd / (np.pi * r[k] ** 2 * np.maximum(cos_l, 1e-300))
            w_out[k], d_out[k], pdf_out[k] = w, dd, pdf_sa
            out[k] = le[k] / pdf_sa[:, None]
        # Spot cone along each sampled ray, from the sampled point on the light toward the
        # shading point (Cycles' spot_light_sample), as light hits evaluate it along the ray
        # that hit: toward the centre instead, a light of radius > 0 had a sharper cone edge
        # than Cycles and than its own hits.
        att = self.spot_attenuation(j, -w_out)
        # Inside a spot's sphere there is no cone (Cycles' spot_light_sample).
        att = np.where(sphere & inside, 1.0, att)
        valid = delta | sphere | disk
        wi[rows] = w_out
        dist[rows] = d_out
        value[rows] = np.where(valid[:, None], out * att[:, None], 0.0)
        pdf[rows] = np.where(valid, pdf_out, 0.0)

    # ------------------------------------------------------------------ ray hits
    def pdf(self, j, origin, direction, t):
        """Solid-angle density with which `sample` picks direction from origin, for
        intersectable lights j hit at distance t."""
        typ = self.type[j]
        to_c = self.centre[j] - origin
        d = np.linalg.norm(to_c, axis=1)
        r = self.radius[j]
        out = np.zeros(len(j))
        sphere = ((typ == POINT) | (typ == SPOT)) & (r > 0) & ~self.soft[j]
        cos_max = np.where(d > r, np.sqrt(np.maximum(
            0.0, 1.0 - (r / np.where(d > r, d, 1.0)) ** 2)), -1.0)
        out = np.where(sphere, 1.0 / (2.0 * np.pi * np.maximum(1.0 - cos_max, 1e-300)), out)
        disk = ((typ == POINT) | (typ == SPOT)) & (r > 0) & self.soft[j]
        cos_d = _dot(to_c / np.where(d > 0, d, 1)[:, None], direction)
        out = np.where(disk, t * t / (np.pi * np.maximum(r * r * cos_d, 1e-300)), out)
        area = typ == AREA
        cos_a = -_dot(direction, self.direction[j])
        out = np.where(area, t * t / np.maximum(self.area[j] * cos_a, 1e-300), out)
        return out

    def intersect(self, j: int, o, d, tmax):
        """Distances (n,) at which rays (o, d) hit light j before tmax (inf if not), and
        the radiance they pick up there (n, 3)."""
        n = len(o)
        t = np.full(n, np.inf)
        c = self.centre[j]
        typ = self.type[j]
        power = self.power[j]
        if typ == AREA:
            nrm = self.direction[j]
            denom = sampling.dot3(d, nrm)
            front = denom < 0  # travelling against the emission direction
            th = sampling.dot3(c - o, nrm) / np.where(front, denom, -1.0)
            hit_p = o + th[:, None] * d
            lu = sampling.dot3(hit_p - c, self.axis_u[j]) / self.len_u[j]
            lv = sampling.dot3(hit_p - c, self.axis_v[j]) / self.len_v[j]
            inside = (lu * lu + lv * lv <= 0.25) if self.elliptic[j] else \
                (np.abs(lu) <= 0.5) & (np.abs(lv) <= 0.5)
            ok = front & inside & (th > 0) & (th < tmax)
            t[ok] = th[ok]
            att = spread_attenuation(-denom, self.half_spread[j])
            le = power[None, :] * (self.radiance_factor[j] * att)[:, None]
            return t, le
        r = self.radius[j]
        oc = o - c
        if self.soft[j]:
            # A disk facing the ray's origin.
            dist_c = np.linalg.norm(oc, axis=1)
            nrm = oc / np.where(dist_c > 0, dist_c, 1.0)[:, None]
            denom = _dot(d, nrm)
            th = _dot(-oc, nrm) / np.where(denom < 0, denom, -1.0)
            hit_p = o + th[:, None] * d - c
            ok = (denom < 0) & (np.einsum("ij,ij->i", hit_p, hit_p) <= r * r) & (th > 0)
        else:
            b = _dot(oc, d)
            oc2 = _dot(oc, oc)
            disc = b * b - (oc2 - r * r)
            # The near root from outside, the far one from inside (the light is seen there).
            th = -b - np.where(oc2 > r * r, 1.0, -1.0) * np.sqrt(np.maximum(disc, 0.0))
            ok = (disc >= 0) & (th > 0)
        if typ == SPOT:
            # One-sided: a spot is hit only by rays heading toward its centre's side.
            ok &= _dot(d, oc) < 0.0
        ok &= th < tmax
        t[ok] = th[ok]
        le = np.tile(power * self.radiance_factor[j], (n, 1))
        if typ == SPOT:
            att = self.spot_attenuation(np.full(n, j), -d)
            # From inside its sphere there is no cone (Cycles' spot.h).
            if not self.soft[j]:
                att = np.where(_dot(oc, oc) > r * r, att, 1.0)
            le = le * att[:, None]
        return t, le


class LightSampler:
    """All emitters of a scene, chosen by a mixture of two distributions.

    Entries 0..k-1 are emissive triangles, then light objects, then the environment.
    With few emitters the choice is by power alone. With many, a voxel grid over the
    scene holds, per voxel, a distribution by power / distance^2 from the voxel (so a
    point picks the lights that matter to it); a point samples that local distribution
    with probability LOCAL_WEIGHT and the global power distribution otherwise. Both are
    known at any point, so `pmf(points, entries)` is exact for MIS.
    """

    LOCAL_WEIGHT = 0.75
    GRID = 8  # voxels per axis
    MIN_ENTRIES, MAX_ENTRIES = 8, 20_000  # the grid is (GRID^3, entries) floats

    def __init__(self, scene: Scene):
        emission = scene.materials.emission[scene.material_index]
        v = scene.vertices
        area = 0.5 * np.linalg.norm(sampling.cross_rows(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]),
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
        nrm = sampling.cross_rows(self.e1, self.e2)
        self.normal = nrm / np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-300)
        self.scale = np.abs(c).max(axis=(1, 2)) if len(c) else np.zeros(0)
        radius = max(scene.extent, 1e-3) * 2.0
        self.objects = LightObjects(scene.lights, scene.origin, radius)
        env = scene.world.environment
        self.environment = None if env is None else EnvironmentMap(env,
                                                                   scene.world.texture_from_world)
        # The world's flux through the scene's cross-section, to weigh it against lights.
        env_power = [] if self.environment is None else \
            [np.pi * self.environment.mean_radiance * np.pi * radius**2]
        weights = np.concatenate([tri_power[self.index], self.objects.selection_power(),
                                  env_power])
        self.distribution = sampling.Distribution1D(weights)
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

    def _voxel(self, p):
        ijk = np.clip(((p - self.grid_lo) / self.cell).astype(np.int64), 0, self.GRID - 1)
        return (ijk[:, 0] * self.GRID + ijk[:, 1]) * self.GRID + ijk[:, 2]

    def pmf(self, p, entries):
        """Probability (n,) of choosing `entries` (n,) from points p (n, 3)."""
        glob = self.distribution.pmf[entries]
        if not hasattr(self, "local_pmf"):
            return glob
        vox = self._voxel(p)
        local = self.local_pmf[vox, entries]
        a = np.where(self.grid_has_mass[vox], self.LOCAL_WEIGHT, 0.0)
        return a * local + (1.0 - a) * glob

    def choose(self, p, u):
        """Entries (n,) chosen from points p (n, 3) with u (n,) and their probability."""
        if not hasattr(self, "local_pmf"):
            k = self.distribution.sample(u)
            return k, self.distribution.pmf[k]
        vox = self._voxel(p)
        a = np.where(self.grid_has_mass[vox], self.LOCAL_WEIGHT, 0.0)
        use_local = u < a
        k = np.empty(len(p), np.int64)
        if (~use_local).any():
            ug = (u[~use_local] - a[~use_local]) / (1.0 - a[~use_local])
            k[~use_local] = self.distribution.sample(ug)
        if use_local.any():
            ul = np.minimum(u[use_local] / a[use_local], 1.0 - 1e-12)
            v = vox[use_local]
            flat = np.searchsorted(self.local_cdf_flat, v + ul, side="right")
            k[use_local] = np.clip(flat - v * self.num_entries, 0, self.num_entries - 1)
        return k, self.pmf(p, k)

    def __len__(self):
        return self.num_entries

    def sample(self, p, u_select, u_point):
        """Next-event estimation from points p (n, 3).

        Returns wi (n, 3), dist (n,) to the sampled point (inf toward a sun), value
        (n, 3) = radiance / (selection probability x solid-angle pdf), pdf (n,) the
        combined solid-angle density (inf for delta lights), light_scale (n,) a length
        scale at the sampled point for the shadow ray's offset.
        """
        n = len(p)
        k_all, p_sel = self.choose(p, u_select)
        is_tri = k_all < self.num_triangles
        wi = np.zeros((n, 3))
        dist = np.full(n, np.inf)
        value = np.zeros((n, 3))
        pdf = np.zeros(n)
        scale = np.zeros(n)
        tri = np.nonzero(is_tri)[0]
        if len(tri):
            k = k_all[tri]
            b = sampling.sample_uniform_triangle(u_point[tri])
            y = self.v0[k] + b[:, 1:2] * self.e1[k] + b[:, 2:3] * self.e2[k]
            to = y - p[tri]
            d = np.sqrt(np.einsum("ij,ij->i", to, to))
            w = to / np.where(d > 0, d, 1.0)[:, None]
            cos_l = np.abs(_dot(self.normal[k], w))
            ok = (cos_l > 0) & (d > 0)
            pdf_sa = np.where(ok, d * d / np.maximum(self.area[k] * cos_l, 1e-300), 0.0)
            wi[tri], dist[tri] = w, d
            value[tri] = self.radiance[k] * np.where(ok, 1.0 / np.where(ok, pdf_sa, 1.0),
                                                     0.0)[:, None]
            pdf[tri] = pdf_sa
            scale[tri] = self.scale[k]
        is_env = k_all == self.environment_index
        env = np.nonzero(is_env)[0]
        if len(env):
            w, pdf_sa = self.environment.sample(u_point[env])
            wi[env] = w
            value[env] = self.environment.lookup(w) / np.maximum(pdf_sa, 1e-300)[:, None]
            pdf[env] = pdf_sa
        obj = np.nonzero(~is_tri & ~is_env)[0]
        if len(obj):
            j = k_all[obj] - self.num_triangles
            w, d, val, pdf_sa = self.objects.sample(j, p[obj], u_point[obj])
            wi[obj], dist[obj], value[obj], pdf[obj] = w, d, val, pdf_sa
            finite = np.isfinite(d)
            scale[obj] = np.where(finite, np.abs(p[obj] + w * np.where(finite, d, 0)[:, None])
                                  .max(axis=1), 0.0)
        value /= np.where(p_sel > 0, p_sel, 1.0)[:, None]
        return wi, dist, value, pdf * p_sel, scale

    def pdf_triangle_area(self, p, triangle: np.ndarray) -> np.ndarray:
        """Area density of sampling points on emissive triangles from points p (n, 3),
        selection included."""
        entry = self.entry_of_triangle[triangle]
        pm = np.where(entry >= 0, self.pmf(p, np.maximum(entry, 0)), 0.0)
        return pm / self.area_by_triangle[triangle]

    def pmf_light(self, p, j: int) -> np.ndarray:
        """Probability (n,) of choosing light object j from points p (n, 3)."""
        return self.pmf(p, np.full(len(p), self.num_triangles + j))

    def pmf_environment(self, p) -> np.ndarray:
        return self.pmf(p, np.full(len(p), self.environment_index))

"""The wavefront path integrator.

One call of `trace_pixels` traces one sample for a batch of pixels. Rays live in
structure-of-arrays batches; the only Python loop is over bounce depth, and each bounce
is a sequence of named stages over the live rays:

    generate camera rays -> intersect -> handle escaped rays -> handle emission
    -> Russian roulette -> sample light + trace shadow rays -> sample BSDF -> spawn rays

Live rays are compacted by index after every stage that ends paths. Blender's bounce
counting: a camera ray hitting an emitter is depth 0; with max_bounces = N, light
sampling and scattering happen at vertices 0..N and vertex N+1 only adds emission and
background (Cycles' "terminate after transparent" at limit + 1). Emitters hit by BSDF
sampling after a non-delta bounce are weighted against next-event estimation with the
power heuristic; after delta bounces (mirror, metal, glass) and from the camera they
count fully. Russian roulette follows Cycles: none for the first two vertices, then
survival probability min(sqrt(max channel of throughput), 1).
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass

import numpy as np

from . import bsdf, kernel, sampling, terminator
from .film import BACKGROUND_DEPTH
from .sampling import Dim
from .scene import DIFFUSE, GLASS, GLOSSY, METAL, MIRROR, PRINCIPLED, RenderSettings, Scene

# Kinds with a non-delta lobe: they get next-event estimation and MIS.
SMOOTH_KINDS = (DIFFUSE, PRINCIPLED, GLOSSY)

# Spawned rays leave the surface by this fraction of the local coordinate magnitude:
# a few float32 ulps (embree intersects in float32), so the offset scales with the scene.
RAY_EPSILON = 2.0**-18
# Russian roulette starts after this many scatter events (Cycles: min_light_bounces + 1).
ROULETTE_MIN_BOUNCE = 2


@dataclass
class Hits:
    """Surface interactions for the live rays. All arrays have the live count n.

    p : (n, 3) hit points (float64, from barycentrics); ng, ns : (n, 3) geometric and
    shading normals flipped to the incoming side; wo : (n, 3) towards the ray origin;
    front : (n,) whether the ray hit the front face; prim, mat : (n,) ids; t : distances;
    scale : (n,) local coordinate magnitude for ray offsets; bu, bv : (n,) barycentrics of
    corners 1 and 2.
    """

    p: np.ndarray
    ng: np.ndarray
    ns: np.ndarray
    wo: np.ndarray
    front: np.ndarray
    prim: np.ndarray
    mat: np.ndarray
    t: np.ndarray
    scale: np.ndarray
    bu: np.ndarray
    bv: np.ndarray


class NonFiniteSample(FloatingPointError):
    pass


class Integrator:
    """Traces paths for batches of pixels; thread-safe (no shared mutable state except
    the stage counters, which are guarded by a lock)."""

    def __init__(self, scene: Scene, settings: RenderSettings, plan, accel, emitters, camera,
                 pixel_filter, debug: bool = False):
        self.scene, self.settings, self.plan = scene, settings, plan
        self.accel, self.emitters, self.camera = accel, emitters, camera
        self.pixel_filter = pixel_filter
        self.debug = debug
        v = scene.vertices
        n = sampling.cross_rows(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
        self.tri_normal = n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
        self.tri_scale = np.abs(v).max(axis=(1, 2)) if len(v) else np.zeros(0)
        m = scene.materials
        self.kind = m.kind
        self.colour = m.colour
        self.ior = m.ior
        self.reflection_tint = m.reflection_tint
        self.transmission_tint = m.transmission_tint
        self.emission = m.emission
        self.roughness = m.roughness if m.roughness is not None else np.zeros(len(m.kind))
        # Albedo and energy-compensation tables of every rough (GGX) material in use.
        self.microfacet = {}
        for k in np.unique(scene.material_index):
            if self.kind[k] in (PRINCIPLED, GLOSSY):
                alpha = max(float(self.roughness[k]) ** 2, bsdf.MIN_ALPHA)
                fresnel = "dielectric" if self.kind[k] == PRINCIPLED else "none"
                self.microfacet[int(k)] = bsdf.MicrofacetTables(alpha, fresnel, float(self.ior[k]))
        self.world = np.asarray(scene.world.colour, np.float64)
        self.width = settings.width
        self.stage_calls: dict[str, int] = {}
        self.stage_seconds: dict[str, float] = {}
        self._lock = threading.Lock()
        self.compiled = None
        if plan.kernel == "compiled" and not debug:
            from .kernel import CompiledTracer
            self.compiled = CompiledTracer(self)

    # ------------------------------------------------------------ bookkeeping
    def _count(self, stage: str, seconds: float) -> None:
        with self._lock:
            self.stage_calls[stage] = self.stage_calls.get(stage, 0) + 1
            self.stage_seconds[stage] = self.stage_seconds.get(stage, 0.0) + seconds

    def _check(self, stage: str, live: np.ndarray, pixels: np.ndarray, *arrays) -> None:
        """Debug mode: name the stage and pixel of the first NaN/inf."""
        if not self.debug:
            return
        for a in arrays:
            bad = ~np.isfinite(a.reshape(len(a), -1)).all(axis=1)
            if bad.any():
                px = int(pixels[live[np.argmax(bad)]])
                raise NonFiniteSample(f"stage '{stage}' produced a non-finite value at pixel "
                                      f"(x={px % self.width}, y={px // self.width})")

    # ------------------------------------------------------------ the bounce loop
    def trace_pixels(self, pixels: np.ndarray, sample: int):
        """Trace one sample for each pixel in `pixels` (n,) int64.

        Returns (pixels, radiance (n, 3), depth (n,), normal (n, 3), rejected) where
        rejected lists messages for samples that came out non-finite.
        """
        if self.compiled is not None:
            radiance, depth_pass, normal_pass = self.compiled.trace_pixels(pixels, sample)
            return pixels, radiance, depth_pass, normal_pass, self._rejected(
                pixels, sample, radiance, depth_pass, normal_pass)
        n = len(pixels)
        stream = sampling.SampleStream(pixels, sample, self.settings.seed)
        radiance = np.zeros((n, 3))
        depth_pass = np.full(n, BACKGROUND_DEPTH)
        normal_pass = np.zeros((n, 3))

        o, d, tmax = self.generate_camera_rays(pixels, stream)
        live = np.arange(n)
        throughput = np.ones((n, 3))
        prev_pdf = np.full(n, bsdf.DELTA_PDF)  # camera rays count emission fully

        for depth in range(self.settings.max_bounces + 2):
            if len(live) == 0:
                break
            prim, t, bu, bv = self.intersect(o, d, tmax)

            # Handle light objects the rays pass through (lights are transparent).
            if self.plan.light_hits or self.plan.sun_discs:
                self.handle_light_hits(radiance, live, throughput, o, d,
                                       np.where(prim < 0, tmax, t), prim < 0, prev_pdf,
                                       camera=depth == 0)

            # Handle escaped rays.
            miss = prim < 0
            if miss.any():
                self.handle_escaped(radiance, live[miss], throughput[miss], o[miss], d[miss],
                                    prev_pdf[miss])
            hit = ~miss
            live, throughput, prev_pdf = live[hit], throughput[hit], prev_pdf[hit]
            if len(live) == 0:
                break
            hits = self.surface_interaction(o[hit], d[hit], prim[hit], t[hit], bu[hit], bv[hit])
            if depth == 0:
                depth_pass[live] = self.camera.z_depth(hits.p)
                normal_pass[live] = hits.ns  # Cycles' N: the shading normal facing the viewer
                self._check("surface interaction (depth/normal pass)", live, pixels,
                            depth_pass[live], normal_pass[live])

            if self.plan.num_emitters:
                self.handle_emission(radiance, live, throughput, hits, prev_pdf)
                self._check("handle emission", live, pixels, radiance[live])

            # Terminate at Blender's bounce limit: vertex N+1 only adds emission.
            if depth > self.settings.max_bounces:
                break

            # Russian roulette (after emission, before light sampling, as in Cycles).
            keep = self.russian_roulette(throughput, stream, live, depth)
            if keep is not None:
                live, throughput, hits = live[keep], throughput[keep], _take(hits, keep)

            # Paths end on surfaces without a BSDF (a pure Emission shader).
            has_bsdf = self.kind[hits.mat] != 0
            if not has_bsdf.all():
                live, throughput, hits = live[has_bsdf], throughput[has_bsdf], _take(hits, has_bsdf)
            if len(live) == 0:
                break

            if self.plan.light_sampling:
                self.sample_light(radiance, live, throughput, hits, stream, depth)
                self._check("sample light", live, pixels, radiance[live])

            wi, weight, pdf = self.sample_bsdf(hits, stream, live, depth)
            self._check("sample BSDF", live, pixels, weight, wi)
            throughput = throughput * weight
            alive = max3(throughput) > 0
            live, throughput, prev_pdf = live[alive], throughput[alive], pdf[alive]
            o, d = self.spawn_rays(_take(hits, alive), wi[alive])
            tmax = np.full(len(live), np.inf)

        return pixels, radiance, depth_pass, normal_pass, self._rejected(
            pixels, sample, radiance, depth_pass, normal_pass)

    def _rejected(self, pixels, sample, radiance, depth_pass, normal_pass) -> list[str]:
        """A sample is bad if any pass it feeds (combined, depth, normal) is not finite."""
        if self.compiled is not None and kernel.all_finite(radiance, depth_pass, normal_pass):
            return []  # one compiled pass instead of five numpy ones over the chunk
        bad = ~(np.all(np.isfinite(radiance), axis=1) & np.isfinite(depth_pass)
                & np.all(np.isfinite(normal_pass), axis=1))
        return self._explain_nonfinite(pixels[bad], sample) if bad.any() else []

    def _explain_nonfinite(self, bad_pixels: np.ndarray, sample: int) -> list[str]:
        """Replay the bad samples in debug mode (sampling is deterministic) to name the
        stage that produced NaN/inf."""
        if self.debug:
            return [f"non-finite sample at pixel {int(p)}" for p in bad_pixels]
        tracer = Integrator.__new__(Integrator)
        tracer.__dict__.update(self.__dict__)
        tracer.debug, tracer.compiled = True, None  # the numpy stages name the culprit
        msgs = []
        for p in bad_pixels[:5]:
            try:
                tracer.trace_pixels(np.array([p]), sample)
                msgs.append(f"non-finite sample at pixel (x={p % self.width}, "
                            f"y={p // self.width}), stage unknown")
            except NonFiniteSample as e:
                msgs.append(str(e))
        return msgs

    # ------------------------------------------------------------ stages
    def generate_camera_rays(self, pixels: np.ndarray, stream: sampling.SampleStream):
        t0 = time.perf_counter()
        px = (pixels % self.width).astype(np.float64)
        py = (pixels // self.width).astype(np.float64)
        # Sample 0 looks through the middle of the filter table, as Cycles' first sample.
        u = stream.get_2d(Dim.FILTER) if stream.sample != 0 else np.full((len(pixels), 2), 0.5)
        offset = self.pixel_filter.sample(u)
        raster = np.column_stack([px + 0.5, py + 0.5]) + offset
        u_lens = stream.get_2d(Dim.LENS) if self.plan.dof else None
        o, d, tmax = self.camera.generate_rays(raster, u_lens)
        self._count("generate camera rays", time.perf_counter() - t0)
        return o, d, tmax

    def intersect(self, o, d, tmax):
        t0 = time.perf_counter()
        out = self.accel.intersect(o, d, tmax)
        self._count("intersect", time.perf_counter() - t0)
        return out

    def handle_escaped(self, radiance, idx, throughput, o, d, prev_pdf):
        """Escaped rays take the world: a constant colour (found by BSDF sampling only, as
        in Cycles) or the environment map, MIS-weighted against its light sampling."""
        if self.plan.environment:
            env = self.emitters.environment
            le = env.lookup(d)
            w = np.ones(len(idx))
            soft = np.isfinite(prev_pdf)
            if soft.any() and self.plan.light_sampling:
                w[soft] = power_heuristic(prev_pdf[soft], self.emitters.pmf_environment(o[soft])
                                          * env.pdf(d[soft]))
            radiance[idx] += throughput * le * w[:, None]
        elif self.plan.world_light:
            radiance[idx] += throughput * self.world

    def surface_interaction(self, o, d, prim, t, bu, bv) -> Hits:
        t0 = time.perf_counter()
        v = self.scene.vertices[prim]
        w0 = 1.0 - bu - bv
        p = w0[:, None] * v[:, 0] + bu[:, None] * v[:, 1] + bv[:, None] * v[:, 2]
        ng = self.tri_normal[prim]
        front = bsdf.dot(d, ng) < 0.0
        sign = np.where(front, 1.0, -1.0)[:, None]
        ng = ng * sign
        ns = ng
        if self.plan.shading_normals:
            ns = self.interpolate_normals(prim, w0, bu, bv, ng, sign)
        wo = -d
        scale = np.maximum(self.tri_scale[prim], max3(np.abs(p)))
        self._count("surface interaction", time.perf_counter() - t0)
        return Hits(p, ng, ns, wo, front, prim, self.scene.material_index[prim], t, scale,
                    bu, bv)

    def interpolate_normals(self, prim, w0, bu, bv, ng, sign):
        """Smooth shading normal, flipped with the geometric one; falls back to ng where
        the interpolated normal faces away from the incoming ray (no light leaks)."""
        nrm = self.scene.normals[prim]
        ns = w0[:, None] * nrm[:, 0] + bu[:, None] * nrm[:, 1] + bv[:, None] * nrm[:, 2]
        ns = ns * sign
        length = np.linalg.norm(ns, axis=1, keepdims=True)
        smooth = self.scene.smooth[prim] & (length[:, 0] > 1e-12)
        ns = np.where(smooth[:, None], ns / np.maximum(length, 1e-300), ng)
        # The incoming direction is -wo = d; ns must lie on wo's side for reflection.
        return ns

    def handle_emission(self, radiance, live, throughput, hits: Hits, prev_pdf):
        """Add emitted radiance (two-sided), MIS-weighted after non-delta bounces."""
        le = self.emission[hits.mat]
        emissive = max3(le) > 0
        if not emissive.any():
            return
        w = np.ones(len(live))
        soft = emissive & np.isfinite(prev_pdf)
        if soft.any() and self.plan.light_sampling:
            cos_l = np.abs(bsdf.dot(hits.ng[soft], hits.wo[soft]))
            origin = hits.p[soft] + hits.wo[soft] * hits.t[soft, None]
            pdf_l = (self.emitters.pdf_triangle_area(origin, hits.prim[soft]) * hits.t[soft] ** 2
                     / np.maximum(cos_l, 1e-300))
            pb = prev_pdf[soft]
            w[soft] = power_heuristic(pb, pdf_l)
        radiance[live[emissive]] += (throughput[emissive] * le[emissive]
                                     * w[emissive, None])

    def russian_roulette(self, throughput, stream, live, depth):
        if depth < ROULETTE_MIN_BOUNCE:
            return None
        q = np.minimum(np.sqrt(max3(throughput)), 1.0)
        u = stream.get_1d(Dim.bounce(depth, Dim.ROULETTE), rows=live)
        keep = u < q
        # Survivors are divided by q; since q >= sqrt(throughput), the result is at most
        # sqrt(throughput), so a small q never blows a path up.
        throughput[keep] /= q[keep, None]
        return keep

    def handle_light_hits(self, radiance, live, throughput, o, d, t_surface, escaped,
                          prev_pdf, camera):
        """Add the radiance of light objects crossed before the surface hit (and of sun
        discs for escaped rays), MIS-weighted after non-delta bounces. Camera rays see
        only lights visible to the camera; other rays only lights with MIS on (Cycles)."""
        t0 = time.perf_counter()
        objects = self.emitters.objects
        soft = np.isfinite(prev_pdf)
        mis = soft.any() and self.plan.light_sampling
        seen = (objects.visible_camera if camera else objects.use_mis) & \
            (objects.power.max(axis=1) > 0)
        for j in np.nonzero(objects.intersectable & seen)[0]:
            t, le = objects.intersect(j, o, d, t_surface)
            hit = np.isfinite(t)
            if not hit.any():
                continue
            w = np.ones(len(live))
            if mis:
                sel = hit & soft
                pdf_l = self.emitters.pmf_light(o[sel], j) * objects.pdf(
                    np.full(int(sel.sum()), j), o[sel], d[sel], t[sel])
                w[sel] = power_heuristic(prev_pdf[sel], pdf_l)
            radiance[live[hit]] += throughput[hit] * le[hit] * w[hit, None]
        if self.plan.sun_discs and escaped.any():
            for j in np.nonzero((objects.type == 2) & (objects.cos_half_angle < 1.0) & seen)[0]:
                inside = escaped & (sampling.dot3(d, -objects.direction[j])
                                    >= objects.cos_half_angle[j])
                if not inside.any():
                    continue
                w = np.ones(len(live))
                if mis:
                    sel = inside & soft
                    pdf_l = self.emitters.pmf_light(o[sel], j) / (
                        2.0 * np.pi * (1.0 - objects.cos_half_angle[j]))
                    w[sel] = power_heuristic(prev_pdf[sel], pdf_l)
                le = objects.power[j] * objects.sun_radiance[j]
                radiance[live[inside]] += throughput[inside] * le * w[inside, None]
        self._count("handle light hits", time.perf_counter() - t0)

    def sample_light(self, radiance, live, throughput, hits: Hits, stream, depth):
        """Next-event estimation at diffuse vertices: one emitter (triangle or light
        object) chosen by power, MIS-weighted against BSDF sampling."""
        t0 = time.perf_counter()
        diffuse = np.nonzero(np.isin(self.kind[hits.mat], SMOOTH_KINDS))[0]
        if len(diffuse) == 0:
            return
        rows = live[diffuse]
        u_sel = stream.get_1d(Dim.bounce(depth, Dim.LIGHT_SELECT), rows=rows)
        u_pt = stream.get_2d(Dim.bounce(depth, Dim.LIGHT_POINT), rows=rows)
        p, ng, ns = hits.p[diffuse], hits.ng[diffuse], hits.ns[diffuse]
        wi, dist, value, pdf_l, light_scale = self.emitters.sample(p, u_sel, u_pt)
        f_cos, pdf_bsdf = self.eval_bsdf(hits.wo[diffuse], wi, ns, ng, hits.mat[diffuse])
        ok = (max3(f_cos) > 0) & (max3(value) > 0) & (dist > 0)
        if not ok.any():
            return
        # Delta lights (pdf inf) cannot be hit by BSDF sampling: weight 1.
        w = np.where(np.isinf(pdf_l[ok]), 1.0, power_heuristic(pdf_l[ok], pdf_bsdf[ok]))
        contrib = throughput[diffuse[ok]] * f_cos[ok] * value[ok] * w[:, None]
        self._count("sample light", time.perf_counter() - t0)
        # Trace shadow rays: from the offset surface point to just short of the light.
        t1 = time.perf_counter()
        start = p[ok]
        if self.plan.terminator:
            start = start + self.terminator_offsets(_take(hits, diffuse[ok]), wi[ok])
        origin = offset_ray_origin(start, ng[ok], wi[ok], hits.scale[diffuse[ok]])
        finite = np.isfinite(dist[ok])
        # Aim from the offset origin at the sampled point itself: reusing wi from the
        # un-offset point would reach a grazing emitter's plane early and self-occlude.
        target = p[ok] + wi[ok] * np.where(finite, dist[ok], 0.0)[:, None]
        seg = target - origin
        seg_len = np.linalg.norm(seg, axis=1)
        direction = np.where(finite[:, None], seg / np.maximum(seg_len, 1e-300)[:, None], wi[ok])
        light_eps = RAY_EPSILON * np.maximum(light_scale[ok], 1e-30)
        blocked = self.accel.occluded(origin, direction,
                                      np.where(finite, seg_len - light_eps, 3e38))
        self._count("trace shadow rays", time.perf_counter() - t1)
        vis = ~blocked
        radiance[rows[ok][vis]] += contrib[vis]

    def terminator_offsets(self, hits: Hits, wi):
        """(n, 3) shadow-ray origin displacements by the objects' shadow terminator
        geometry offset (terminator.py), zero on flat triangles."""
        scene = self.scene
        cutoff = np.where(scene.smooth[hits.prim],
                          scene.terminator_offset[scene.object_index[hits.prim]], 0.0)
        out = np.empty((len(wi), 3))
        terminator.shadow_origin_offsets(scene.vertices, scene.normals, hits.prim.astype(np.int64),
                                         hits.bu, hits.bv, hits.ns, hits.ng, wi, cutoff, out)
        return out

    def _layer(self, k: int, wo, n):
        """Per-vertex parameters of rough material k's layered lobe at view directions wo,
        its specular normals n."""
        tables = self.microfacet[k]
        mu = np.clip(bsdf.dot(n, wo), 0.0, 1.0)
        m = len(wo)
        if self.kind[k] == PRINCIPLED:
            base, tint, fresnel = np.tile(self.colour[k], (m, 1)), np.ones((m, 3)), "dielectric"
        else:
            base, tint, fresnel = np.zeros((m, 3)), np.tile(self.colour[k], (m, 1)), "none"
        comp = tables.compensation(mu, bsdf.layer_fms(tables, self.kind[k] == PRINCIPLED,
                                                      self.colour[k]))
        return dict(base=base, alpha=np.full(m, tables.alpha), eta=np.full(m, self.ior[k]),
                    spec_tint=tint, fresnel=fresnel, comp=comp, albedo=tables.albedo(mu))

    def eval_bsdf(self, wo, wi, ns, ng, mat):
        """f * cos (n, 3) and sampling pdf (n,) of the non-delta BSDFs, for light sampling."""
        f_cos, pdf = np.zeros((len(wo), 3)), np.zeros(len(wo))
        kind = self.kind[mat]
        sel = np.nonzero(kind == DIFFUSE)[0]
        if len(sel):
            f_cos[sel], pdf[sel] = bsdf.eval_diffuse(wi[sel], ns[sel], self.colour[mat[sel]])
        for k in self.microfacet:
            sel = np.nonzero(mat == k)[0]
            if len(sel):
                n_spec = bsdf.valid_specular_normals(ng[sel], wo[sel], ns[sel])
                lobe = self._layer(k, wo[sel], n_spec)
                f_cos[sel], pdf[sel], _ = bsdf.eval_layered(wo[sel], wi[sel], ns[sel], ng[sel],
                                                            n_spec=n_spec,
                                                            **lobe)
        return f_cos, pdf

    def sample_bsdf(self, hits: Hits, stream, live, depth):
        """Sample each vertex's BSDF by material kind (only the kinds the plan lists)."""
        t0 = time.perf_counter()
        n = len(live)
        wi = np.zeros((n, 3))
        weight = np.zeros((n, 3))
        pdf = np.full(n, bsdf.DELTA_PDF)
        kind = self.kind[hits.mat]
        colour = self.colour[hits.mat]
        if self.plan.diffuse:
            sel = np.nonzero(kind == DIFFUSE)[0]
            if len(sel):
                u = stream.get_2d(Dim.bounce(depth, Dim.BSDF), rows=live[sel])
                wi[sel], weight[sel], pdf[sel] = bsdf.sample_diffuse(
                    hits.wo[sel], hits.ns[sel], hits.ng[sel], colour[sel], u)
        if self.plan.mirror:
            sel = np.nonzero(kind == MIRROR)[0]
            if len(sel):
                wi[sel], weight[sel], pdf[sel] = bsdf.sample_mirror(
                    hits.wo[sel], _specular_normal(hits, sel), colour[sel])
        if self.plan.metal:
            sel = np.nonzero(kind == METAL)[0]
            if len(sel):
                wi[sel], weight[sel], pdf[sel] = bsdf.sample_metal(
                    hits.wo[sel], _specular_normal(hits, sel), colour[sel])
        if self.microfacet:
            rough = np.nonzero(np.isin(kind, (PRINCIPLED, GLOSSY)))[0]
            if len(rough):
                u_lobe = stream.get_1d(Dim.bounce(depth, Dim.LOBE), rows=live[rough])
                u2 = stream.get_2d(Dim.bounce(depth, Dim.BSDF), rows=live[rough])
                mat = hits.mat[rough]
                for k in self.microfacet:
                    part = np.nonzero(mat == k)[0]
                    if len(part) == 0:
                        continue
                    sel = rough[part]
                    n_spec = _specular_normal(hits, sel)
                    lobe = self._layer(k, hits.wo[sel], n_spec)
                    wi[sel], weight[sel], pdf[sel] = bsdf.sample_layered(
                        hits.wo[sel], hits.ns[sel], hits.ng[sel], u_lobe=u_lobe[part],
                        n_spec=n_spec,
                        u=u2[part], **lobe)
        if self.plan.glass:
            sel = np.nonzero(kind == GLASS)[0]
            if len(sel):
                m = hits.mat[sel]
                eta = np.where(hits.front[sel], self.ior[m], 1.0 / self.ior[m])
                u = stream.get_1d(Dim.bounce(depth, Dim.LOBE), rows=live[sel])
                wi[sel], weight[sel], pdf[sel], _ = bsdf.sample_dielectric(
                    hits.wo[sel], _specular_normal(hits, sel), eta, self.reflection_tint[m],
                    self.transmission_tint[m], u, self.settings.fresnel)
        self._count("sample BSDF", time.perf_counter() - t0)
        return wi, weight, pdf

    def spawn_rays(self, hits: Hits, wi: np.ndarray):
        return offset_ray_origin(hits.p, hits.ng, wi, hits.scale), wi


def _specular_normal(hits: Hits, sel: np.ndarray) -> np.ndarray:
    """The normal of specular lobes (delta and GGX): the shading normal tilted so the
    mirror direction stays above the surface (bsdf.valid_specular_normal)."""
    return bsdf.valid_specular_normals(hits.ng[sel], hits.wo[sel], hits.ns[sel])


def offset_ray_origin(p: np.ndarray, ng: np.ndarray, wi: np.ndarray, scale: np.ndarray):
    """Move p off the surface toward the side of wi by a scale-aware epsilon."""
    side = np.where(bsdf.dot(wi, ng) >= 0.0, 1.0, -1.0)
    return p + (side * RAY_EPSILON * np.maximum(scale, 1e-30))[:, None] * ng


def power_heuristic(pdf_a: np.ndarray, pdf_b: np.ndarray) -> np.ndarray:
    """MIS weight of strategy a against b (beta = 2), safe for zero and infinite pdfs
    (an infinite pdf is a delta strategy: it takes the whole weight)."""
    a = np.asarray(pdf_a, np.float64)
    b = np.asarray(pdf_b, np.float64)
    m = np.maximum(np.maximum(a, b), 1e-300)
    m = np.where(np.isinf(m), 1.0, m)
    with np.errstate(invalid="ignore"):
        a2, b2 = (a / m) ** 2, (b / m) ** 2
        w = np.where(a2 + b2 > 0, a2 / np.maximum(a2 + b2, 1e-300), 0.0)
    return np.where(np.isinf(a), 1.0, np.where(np.isinf(b), 0.0, w))


def max3(a: np.ndarray) -> np.ndarray:
    """Per-row maximum of an (n, 3) array (faster than a reduction over a short axis)."""
    return np.maximum(np.maximum(a[:, 0], a[:, 1]), a[:, 2])


def _take(hits: Hits, sel) -> Hits:
    return Hits(*(getattr(hits, f)[sel] for f in Hits.__dataclass_fields__))

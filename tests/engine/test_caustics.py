"""Caustics by light tracing (engine/caustics.py, engine/light_tracing.py).

The light tracer and the path tracer's weight against it must leave the image what path
tracing alone converges to: the combined render is compared with independent plain
path-traced renders by the agreement test (addon/agreement.py). Power: the same test fails
when the light paths' contribution is dropped or their glass bends light with the wrong
IOR. Then the formulas the connection rests on: the camera projection and its raster
density, and the pixel filter's density.
"""

import math
from dataclasses import replace

import numpy as np
import pytest

from engine import caustics, render
from engine.camera import CameraModel, project, raster_per_steradian, raster_to_plane, \
    thin_lens_ray
from engine.film import PixelFilter, filter_density, filter_offset
from engine.plan import make_plan
from tests import scenes
from tests.cycles.compare import compare
from tests.patching import module_with, one_off_kernels

SIZE = dict(width=48, height=36)


@pytest.fixture(scope="module")
def box():
    # A 0.4 x 0.4 light: small enough that light paths carry the caustics, large enough
    # that 4 x 1024 path-traced samples have found them (with a 0.1 x 0.1 light they
    # have not: in a corner lit through the mirror sphere, path tracing reads 0.210 at
    # 1024 samples, 0.227-0.232 at 65536, and light tracing 0.236).
    return scenes.caustic_box(light_half=0.2)


def plain_runs(scene):
    """Four plain path-traced renders (light tracing off), independent seeds."""
    return np.stack([render(scene, scenes.settings(**SIZE, samples=1024, seed=100 + k,
                                                   light_tracing=False)).combined[..., :3]
                     for k in range(4)])


@pytest.fixture(scope="module")
def path_traced(box):
    return plain_runs(box)


def combined(box, seed=7):
    r = render(box, scenes.settings(**SIZE, samples=1024, seed=seed, replicates=4,
                                    light_tracing=True))
    assert r.plan.light_tracing
    return r


def agrees(result, runs):
    return compare(result.combined, result.variance, runs, specula_dof=result.dof)


def test_plan_traces_light_only_where_caustics_can_occur(box):
    st = scenes.settings(**SIZE, light_tracing=True)
    assert make_plan(box, st).light_tracing
    assert make_plan(box, scenes.settings(**SIZE)).light_tracing  # on by default
    assert not make_plan(box, scenes.settings(**SIZE, light_tracing=False)).light_tracing
    diffuse_only = scenes.cornell_box(spheres=False).build(scenes.cornell_camera(),
                                                           scenes.World((0, 0, 0)))
    assert not make_plan(diffuse_only, st).light_tracing
    assert not make_plan(box, scenes.settings(**SIZE, fresnel="schlick",
                                              light_tracing=True)).light_tracing
    assert "trace light paths" in make_plan(box, st).describe()
    # An area light is a source too, unless BSDF rays cannot hit it (then neither path
    # tracing nor Cycles finds its caustics).
    area = scenes.caustic_box_area_light()
    assert make_plan(area, st).light_tracing
    area.lights[0] = replace(area.lights[0], use_mis=False)
    assert not make_plan(area, st).light_tracing
    # So is a point or spot light of some radius; of radius 0 path tracing never hits it.
    bulb = scenes.caustic_box_sphere_light()
    assert make_plan(bulb, st).light_tracing
    bulb.lights[0] = replace(bulb.lights[0], radius=0.0)
    assert not make_plan(bulb, st).light_tracing


@pytest.mark.slow
def test_light_tracing_with_mis_agrees_with_path_tracing(box, path_traced):
    assert_agrees_and_converges_faster(box, path_traced)


def assert_agrees_and_converges_faster(scene, runs):
    r = combined(scene)
    c = agrees(r, runs)
    assert c.agree, c
    # And it is the better estimate of the two at equal samples: the light paths find the
    # caustics the camera paths hit by chance.
    assert r.relative_error < 0.75 * render(scene, scenes.settings(
        **SIZE, samples=512, seed=7, replicates=4, light_tracing=False)).relative_error


def assert_fails_without_light_paths(scene, runs, monkeypatch):
    one_off_kernels(monkeypatch, caustics=module_with(
        caustics, light_tracing_contribution=lambda beta, refl, cs, cc, rpa, eta2: 0.0))
    c = agrees(combined(scene), runs)
    assert not c.agree, c


@pytest.mark.slow
def test_dropping_the_light_paths_contribution_fails(box, path_traced, monkeypatch):
    assert_fails_without_light_paths(box, path_traced, monkeypatch)


# Light objects as sources: a Blender area light of the box's 0.4 quad (one-sided: its
# light paths start in front of it), and a glass and a mirror sphere on a floor under a
# 30-degree sun (light paths start on a disk across the sun's cone, upstream of the scene;
# under a 10-degree sun 4 x 1024 path-traced samples have not found the sunlight the
# mirror sphere spreads over the floor: in a corner block they read 0.4760, light tracing
# 0.4784 and path tracing at 65,536 samples 0.4782 +- 0.0003); a point light of radius 0.2
# with Soft Falloff (a disk facing each point it lights) and a 70-degree spot light of
# radius 0.15 without (a sphere), aimed at the glass sphere (light paths are lines
# uniform in the throughput measure, lights.sphere_light_line).
LIGHT_OBJECT_SCENES = {"area light": lambda: scenes.caustic_box_area_light(light_half=0.2),
                       "sun": scenes.sun_caustic_scene,
                       "point light": scenes.caustic_box_sphere_light,
                       "spot light": scenes.caustic_box_spot}


@pytest.fixture(scope="module", params=list(LIGHT_OBJECT_SCENES))
def lit_by_object(request):
    """(scene, four plain path-traced renders of it)."""
    scene = LIGHT_OBJECT_SCENES[request.param]()
    return scene, plain_runs(scene)


@pytest.mark.slow
def test_light_object_caustics_agree_with_path_tracing(lit_by_object):
    assert_agrees_and_converges_faster(*lit_by_object)


# The dropped contribution is the same formula for every source (one compiled kernel each,
# about 1.5 min): the spot light's sphere lines here, emissive triangles above; what is
# particular to each light object is tested line by line in test_lights.py.
@pytest.mark.slow
@pytest.mark.parametrize("lit_by_object", ["spot light"], indirect=True)
def test_light_object_paths_dropped_fail(lit_by_object, monkeypatch):
    assert_fails_without_light_paths(*lit_by_object, monkeypatch)


@pytest.mark.slow
def test_a_wrong_ior_on_light_paths_fails(box, path_traced, monkeypatch):
    from engine import bsdf, integrator
    from engine.bsdf import DELTA_PDF
    from engine.sampling import LOBE, bounce_dim, sample_1d

    def sample_bsdf(row, depth, x, lobe, c, sc, paths, rev_sample):
        """Light paths (told apart from camera paths by their field count) see glass of
        IOR x 1.15."""
        mt = sc.materials
        if len(paths) == LIGHT_FIELDS and mt.kind[x.mat] == integrator.GLASS:  # noqa: F821
            ior = mt.ior[x.mat] * 1.15
            eta = ior if x.front else 1.0 / ior
            u = sample_1d(paths.pseed[row], rev_sample, bounce_dim(depth, LOBE))
            wx, wy, wz, f0, f1, f2, ok = bsdf.sample_dielectric(
                x.wox, x.woy, x.woz, x.mx, x.my, x.mz, eta, mt.reflection_tint[x.mat],
                mt.transmission_tint[x.mat], mt.specular_tint[x.mat], u, True, True)
            return wx, wy, wz, f0, f1, f2, DELTA_PDF, ok
        return original_sample_bsdf(row, depth, x, lobe, c, sc, paths,  # noqa: F821
                                    rev_sample)

    from engine.light_tracing import LightPaths

    assert len(LightPaths._fields) != len(integrator.Paths._fields)
    one_off_kernels(monkeypatch, sample_bsdf=sample_bsdf,
                    original_sample_bsdf=integrator.sample_bsdf,
                    LIGHT_FIELDS=len(LightPaths._fields))
    c = agrees(combined(box), path_traced)
    assert not c.agree, c


def test_a_region_renders_the_whole_frames_pixels_with_light_paths(box):
    st = scenes.settings(width=16, height=12, samples=3, seed=2, light_tracing=True)
    full = render(box, st)
    part = render(box, replace(st, region=(4, 3, 12, 9)))
    assert full.plan.light_tracing and part.plan.light_tracing
    np.testing.assert_array_equal(part.combined, full.combined[3:9, 4:12])


def test_replicate_subsets_merge_into_the_whole_render_with_light_paths(box):
    st = scenes.settings(width=16, height=12, samples=4, seed=2, replicates=2,
                         light_tracing=True)
    whole = render(box, st)
    first = render(box, replace(st, samples=2, replicate_range=(0, 1)))
    second = render(box, replace(st, samples=2, replicate_range=(1, 2)))
    np.testing.assert_array_equal(whole.replicate_mean[:, :, :1], first.replicate_mean)
    np.testing.assert_array_equal(whole.replicate_mean[:, :, 1:], second.replicate_mean)
    np.testing.assert_array_equal(whole.replicate_m2[:, :, 1:], second.replicate_m2)


# ------------------------------------------------------------------ formulas
@pytest.mark.parametrize("dof", [False, True])
def test_project_inverts_the_camera_ray_and_its_raster_density(dof):
    model = CameraModel(scenes.cornell_camera(use_dof=dof, fstop=0.4, focus_distance=2.5),
                        64, 48, np.zeros(3))
    cam = model.data()
    aperture = cam.aperture
    rng = np.random.default_rng(3)
    m = cam.world_from_camera
    for _ in range(20):
        rx, ry = rng.uniform(0, 64), rng.uniform(0, 48)
        lx, ly = rng.uniform(-1, 1, 2) * aperture * 0.7
        x, y = raster_to_plane(rx, ry, cam)
        ox, oy, oz, dx, dy, dz, _ = thin_lens_ray(x, y, lx, ly, cam.focus, cam.clip_start,
                                                  cam.clip_end, False)
        t = rng.uniform(1.0, 4.0)
        p = m @ np.array([ox + t * dx, oy + t * dy, oz + t * dz]) + cam.position
        qx, qy, qdz, dist, near, visible = project(*p, lx, ly, cam)
        assert visible
        assert qx == pytest.approx(rx, abs=1e-7) and qy == pytest.approx(ry, abs=1e-7)
        assert qdz == pytest.approx(dz, rel=1e-9)
        assert dist == pytest.approx(t + near, rel=1e-9)
        # Raster area per steradian: push the direction by small angles, project again.
        h = 1e-6
        e1 = np.cross([dx, dy, dz], [0.0, 1.0, 0.0])
        e1 /= np.linalg.norm(e1)
        e2 = np.cross([dx, dy, dz], e1)
        pts = []
        for a, b in ((h, 0.0), (0.0, h)):
            d2 = np.array([dx, dy, dz]) + a * e1 + b * e2
            d2 /= np.linalg.norm(d2)
            q = m @ (np.array([lx, ly, 0.0]) + 3.0 * d2) + cam.position
            pts.append(np.array(project(*q, lx, ly, cam)[:2]))
        jac = abs(np.cross(pts[0] - [qx, qy], pts[1] - [qx, qy])) / (h * h)
        assert jac == pytest.approx(raster_per_steradian(dz, cam), rel=1e-4)


@pytest.mark.parametrize("kind,width", [("BLACKMAN_HARRIS", 1.5), ("BOX", 1.0),
                                        ("GAUSSIAN", 1.5)])
def test_filter_density_is_the_density_camera_samples_have(kind, width):
    table = PixelFilter(kind, width).table()
    d = np.linspace(-3.5, 3.5, 70001)
    dens = np.array([filter_density(v, table) for v in d])
    assert dens.sum() * (d[1] - d[0]) == pytest.approx(1.0, abs=1e-4)
    rng = np.random.default_rng(5)
    offsets = np.array([filter_offset(u, table) for u in rng.random(200_000)])
    hist, edges = np.histogram(offsets, bins=35, range=(-3.5, 3.5))
    mid = (np.arange(200) + 0.5) / 200  # midpoints: a bin edge on the support's edge is 0
    expected = np.array([np.mean([filter_density(a + (b - a) * t, table) for t in mid])
                         for a, b in zip(edges[:-1], edges[1:])]) * 0.2 * len(offsets)
    # Poisson counts: within 5 sigma in every bin.
    assert np.all(np.abs(hist - expected) <= 5 * np.sqrt(expected + 1.0))


def test_weights_sum_to_one_and_go_to_each_side_where_it_samples_better():
    for r_parts in [(1e4, 1e-3, 1.0, 0.5), (10.0, 2.0, 2.25, 1e-4), (0.0, 1.0, 1.0, 1.0)]:
        n_light, pdf_area, eta2, q = r_parts
        w_pt = caustics.path_tracing_weight(n_light, pdf_area, eta2, q)
        w_lt = caustics.light_tracing_weight(n_light, pdf_area, eta2, q) if n_light else 0.0
        assert w_pt + w_lt == pytest.approx(1.0)
    # A tiny emitter (large p_A) seen through glass: the light tracer takes nearly all.
    assert caustics.light_tracing_weight(1e4, 1e3, 1.0, 1.0) > 0.999
    assert math.isinf(caustics.light_tracing_ratio(1.0, 1.0, 1.0, 0.0))


def test_light_paths_connecting_at_several_vertices_stay_in_their_buffer(monkeypatch):
    """A light path connects to the camera at every Lambertian vertex after a specular one
    and goes on, so n paths can queue more than n connections over their bounces. Traced
    one path at a time (as a kernel's first compile does) by a kernel with bounds checking,
    none writes past the connection buffer: it holds one bounce's connections and is
    splatted after each (it once held n for all bounces; fuzz seed 52's compile overran it
    and crashed)."""
    from engine import integrator, kernels, light_tracing
    from engine.accel import Accel
    from engine.lights import LightSampler

    for module in (integrator, light_tracing):
        monkeypatch.setattr(module, "STAGES", {name: (f, dict(options, boundscheck=True))
                                               for name, (f, options) in module.STAGES.items()})
    box = scenes.caustic_box(light_half=0.2)
    st = scenes.settings(width=16, height=12, max_bounces=8, light_tracing=True)
    plan = make_plan(box, st)
    assert plan.light_tracing
    emitters = LightSampler(box)
    kernel = kernels.Kernel(plan.kernel_constants(hasattr(emitters, "local_pmf")), cache=False)
    data = kernels.scene_data(box, st, plan, emitters,
                              CameraModel(box.camera, st.width, st.height, box.origin), False)
    tracer = kernels.Tracer(kernel, data, Accel(box), st, lambda stage, seconds: None)
    splats = [len(tracer.trace_light(first, 1, 0)[0]) for first in range(400)]
    assert sum(splats) > 0

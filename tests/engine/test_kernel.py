"""Kernels per plan (engine/kernels.py): the generic kernel against the one made for the
scene's plan.

A specialised kernel only leaves out code its scene cannot reach, so on every scene both
must give the same image to the last bit, pass by pass: a render may start with the
generic kernel and switch at a pass boundary. All the statistical and known-answer tests
(furnace, invisible glass, the Cycles comparisons' power tests) then hold for both.
"""

import os
from dataclasses import replace

import numpy as np
import pytest

from engine import render, sampling
from engine.jit import NUMBA
from engine.scene import Camera, Light, Material, SceneBuilder, World
from tests import scenes


def both(scene, **kw):
    st = scenes.settings(width=40, height=30, samples=4, **kw)
    a = render(scene, replace(st, kernel="generic"))
    b = render(scene, replace(st, kernel="specialised"))
    assert a.plan.kernel == "generic" and b.plan.kernel == "specialised"
    return a, b


def assert_same_image(a, b):
    """Equal to the last bit in every pass (a wrong IOR or one bounce fewer changes pixels
    by percent; see test_a_wrong_renderer_is_told_apart)."""
    for name in ("combined", "depth", "normal", "variance"):
        np.testing.assert_array_equal(getattr(b, name), getattr(a, name), err_msg=name)
    assert a.samples == b.samples


# ----------------------------------------------------------------- sample sequences
def test_guided_interpolation_is_np_interp():
    from engine.film import PixelFilter

    f = PixelFilter("BLACKMAN_HARRIS", 1.5)
    guide = sampling.interp_guide(f._cdf)
    u = np.concatenate([np.random.default_rng(2).random(2000), [0.0, 0.5, 1.0 - 2**-53],
                        f._cdf[::997]])
    got = np.array([sampling.guided_interp(x, f._cdf, f._x, guide) for x in u])
    np.testing.assert_array_equal(got, np.interp(u, f._cdf, f._x))


# ----------------------------------------------------------------- whole images
@pytest.mark.parametrize("opts", [
    dict(),
    dict(fresnel="schlick"),
    dict(max_bounces=0),
    dict(max_bounces=1),
    dict(max_bounces=3),
    dict(region=(5, 4, 31, 22)),
    dict(filter_type="BOX", filter_width=1.0),
    dict(threads=1, chunk_pixels=97),
])
def test_cbspheres_same_in_both_kernels(opts):
    assert_same_image(*both(scenes.cbspheres(), **opts))


def test_the_fresnel_model_is_read_at_run_time():
    """One kernel serves both Fresnel models (a setting, not a feature): Schlick's changes
    the image in the generic and the specialised kernel alike (the glass sphere, and
    through its light every pixel whose paths chose another lobe at it)."""
    exact, schlick = both(scenes.cbspheres()), both(scenes.cbspheres(), fresnel="schlick")
    for a, b in zip(exact, schlick):
        assert a.plan.kernel == b.plan.kernel
        changed = np.abs(a.combined - b.combined).max(axis=-1) > 1e-6
        assert changed.mean() > 0.05, changed.mean()


@pytest.mark.parametrize("scene", [scenes.caustic_box_area_light,
                                   lambda: scenes.caustic_box_spot(soft_falloff=True)],
                         ids=["area light", "spot light"])
def test_light_object_caustics_same_in_both_kernels(scene):
    """Light paths from light objects (an area light and its solid-angle sampling, a
    Soft Falloff spot's lines): the same bits in both kernels."""
    a, b = both(scene(), light_tracing=True)
    assert a.plan.light_tracing
    assert_same_image(a, b)


@pytest.mark.parametrize("kind, light", [("diffuse", False), ("principled", True)])
def test_textured_colours_same_in_both_kernels(kind, light):
    """Image textures through shader programs (engine/shading.py), in the Lambert and the
    layered lobe, seen directly, in the mirror and through the glass (light paths too),
    and on an emitter (seen, sampled by next-event estimation, starting light paths)."""
    a, b = both(scenes.textured_box(interpolation="Cubic", scale=1.5, kind=kind,
                                    textured_light=light))
    assert a.plan.textures and a.plan.light_tracing
    assert_same_image(a, b)


@pytest.mark.parametrize("cam", [
    dict(use_dof=True, fstop=0.5, focus_distance=2.5),
    dict(use_dof=True, fstop=0.4, focus_distance=3.5, blades=5, rotation=0.3, ratio=1.6),
    dict(shift_x=0.1, shift_y=-0.05, clip_start=2.2, clip_end=3.4),
    dict(type="ORTHO", ortho_scale=2.5),
    dict(type="ORTHO", ortho_scale=2.5, use_dof=True, fstop=8.0, focus_distance=3.0),
    dict(sensor_fit="VERTICAL", sensor_height=20.0),
])
def test_cameras_same_in_both_kernels(cam):
    scene = scenes.cornell_box().build(scenes.cornell_camera(**cam), World((0, 0, 0)))
    assert_same_image(*both(scene))


def test_metal_tinted_glass_world_light_and_emissive_diffuse_same_in_both_kernels():
    b = SceneBuilder()
    floor = b.add_material(Material.diffuse("floor", (0.5, 0.6, 0.4), emission=(0.05, 0, 0)))
    metal = b.add_material(Material.metal("gold", (1.0, 0.75, 0.3)))
    glass = b.add_material(Material.glass("tinted", (0.9, 0.6, 0.8), 1.6))
    pglass = b.add_material(Material.principled_glass("pglass", (0.4, 0.9, 0.7), 1.33))
    b.add_mesh("floor", *scenes.quad((-3, -3, 0), (3, -3, 0), (3, 3, 0), (-3, 3, 0)), floor)
    for m, x in ((metal, -1.1), (glass, 0.0), (pglass, 1.1)):
        v, t, n = scenes.uv_sphere((x, 0, 0.5), 0.5)
        b.add_mesh(f"sphere {x}", v, t, m, corner_normals=n)
    cam = Camera(world_from_camera=scenes.look_at((0, -5, 2), (0, 0, 0.5)), lens_mm=40)
    scene = b.build(cam, World((0.3, 0.5, 0.8)))
    a, c = both(scene)
    assert a.combined[..., :3].mean() > 0.1
    assert_same_image(a, c)


@pytest.mark.parametrize("emitters", [1, 24])
def test_principled_and_rough_glossy_same_in_both_kernels(emitters):
    """The layered GGX lobes (light sampling with MIS on both lobes, energy compensation
    tables) under one ceiling light or 24 small ones (the light grid)."""
    b = scenes.cornell_box(spheres=False, emitter_radiance=10.0 if emitters == 1 else 0.0)
    rng = np.random.default_rng(8)
    for i in range(emitters if emitters > 1 else 0):
        m = b.add_material(Material.emission_only(f"lamp {i}", rng.random(3), 30.0))
        x, y = rng.uniform(-0.9, 0.8, 2)
        b.add_mesh(f"lamp {i}", *scenes.quad((x, y, 1.45), (x, y + 0.1, 1.45),
                                             (x + 0.1, y + 0.1, 1.45), (x + 0.1, y, 1.45)), m)
    mats = [b.add_material(Material.principled("plastic", (0.8, 0.2, 0.1), roughness=0.3)),
            b.add_material(Material.principled("rough", (0.2, 0.5, 0.9), roughness=0.8,
                                               ior=1.8)),
            b.add_material(Material.glossy("brushed", (0.9, 0.8, 0.5), roughness=0.15))]
    for m, x in zip(mats, (-0.55, 0.0, 0.55)):
        v, t, n = scenes.uv_sphere((x, 0.1, 0.3), 0.25)
        b.add_mesh(f"sphere {x}", v, t, m, corner_normals=n)
    scene = b.build(scenes.cornell_camera(), World((0, 0, 0)))
    a, c = both(scene)
    assert a.combined[..., :3].mean() > 0.05
    assert_same_image(a, c)


def test_rough_glass_and_metal_same_in_both_kernels():
    """Rough glass on both sides of its surface: light sampling through it (emitters
    chosen by their importance on both sides), compensation tables per side; rough metal."""
    b = scenes.cornell_box(spheres=False)
    mats = [b.add_material(Material.glass("frosted", (0.9, 0.6, 0.8), 1.6, roughness=0.4)),
            b.add_material(Material.principled_glass("pfrost", (0.4, 0.9, 0.7), 1.33,
                                                     roughness=0.8)),
            b.add_material(Material.glass("plain", (1, 1, 1), 1.45, roughness=0.2,
                                          multiscatter=False)),
            b.add_material(Material.metal("gold", (1.0, 0.75, 0.35), roughness=0.3))]
    for m, x in zip(mats, (-0.6, -0.2, 0.2, 0.6)):
        v, t, n = scenes.uv_sphere((x, 0.1, 0.3), 0.18)
        b.add_mesh(f"sphere {x}", v, t, m, corner_normals=n)
    scene = b.build(scenes.cornell_camera(), World((0, 0, 0)))
    a, c = both(scene)
    assert a.combined[..., :3].mean() > 0.05
    assert_same_image(a, c)


@pytest.mark.parametrize("kind", ["diffuse", "principled"])
def test_normal_maps_same_in_both_kernels(kind):
    a, c = both(scenes.normal_mapped_box(kind, strength=0.8))
    assert a.combined[..., :3].mean() > 0.05
    assert_same_image(a, c)


def test_mixes_media_and_transparency_same_in_both_kernels():
    """A mix with a textured factor (a checker image between a red diffuse and a rough
    glossy) on the floor, an absorbing glass ball and a checkered alpha cut-out (tinted
    transparent and diffuse) under the light: the generic kernel's run-time checks and the
    plan's kernel take the same choices, count the same bounces and give the same pixels."""
    b = scenes.cornell_box(spheres=False)
    mix = Material.mix("checker mix", Material.diffuse("red", (0.8, 0.2, 0.2)),
                       Material.glossy("shiny", (0.9, 0.9, 0.9), roughness=0.3), 0.5,
                       fac_program=scenes.image_program(scenes.checker_texels()))
    v, t = scenes.quad((-1, -1, 0.001), (1, -1, 0.001), (1, 1, 0.001), (-1, 1, 0.001))
    b.add_mesh("mixed floor", v, t, b.add_material(mix), uv_maps={"": scenes.quad_uvs()})
    amber = Material.glass("amber", (1, 1, 1), 1.5)
    amber = replace(amber, absorption=(0.5, 1.5, 3.0))
    v, t, n = scenes.uv_sphere((0.3, 0.0, 0.35), 0.35)
    b.add_mesh("amber ball", v, t, b.add_material(amber), corner_normals=n)
    cut_out = Material.mix("cut-out", Material.transparent("clear", (0.9, 0.8, 0.6)),
                           Material.diffuse("leaf", (0.3, 0.7, 0.2)), 0.5,
                           fac_program=scenes.image_program(scenes.checker_texels()))
    v, t = scenes.quad((-0.5, -0.5, 1.0), (0.5, -0.5, 1.0), (0.5, 0.5, 1.0), (-0.5, 0.5, 1.0))
    b.add_mesh("cut-out", v, t, b.add_material(cut_out), uv_maps={"": scenes.quad_uvs()})
    a, c = both(b.build(scenes.cornell_camera(), World((0, 0, 0))))
    assert a.plan.mixes and a.plan.volumes and a.plan.textures and a.plan.transparency
    assert a.combined[..., :3].mean() > 0.05
    assert_same_image(a, c)


@pytest.mark.parametrize("light", ["area", "point"])
def test_shadow_terminator_offset_same_in_both_kernels(light):
    """Coarse smooth spheres with terminator offsets 0, 0.1 and 1 lit from the side: the
    lifted shadow-ray origins (terminator.py) and the diffuse light evaluation without the
    geometric cut, in both paths; and the offset changes the image."""
    b = scenes.cornell_box(spheres=False, emitter_radiance=0.0)
    m = b.add_material(Material.diffuse("matte", (0.8, 0.8, 0.8)))
    for offset, x in zip((0.0, 0.1, 1.0), (-0.55, 0.0, 0.55)):
        v, t, n = scenes.uv_sphere((x, 0.1, 0.3), 0.25, segments=10, rings=5)
        b.add_mesh(f"ball {offset}", v, t, m, corner_normals=n, terminator_offset=offset)
    lamp = (Light("side", "AREA", (6, 6, 6), _at(-0.9, -0.5, 0.4, rx=np.pi / 2, rz=-1.0),
                  size_x=0.3) if light == "area" else
            Light("side", "POINT", (3, 3, 3), _at(-0.9, -0.5, 0.4)))
    b.add_light(lamp)
    scene = b.build(scenes.cornell_camera(), World((0, 0, 0)))
    a, c = both(scene)
    assert a.plan.terminator and a.combined[..., :3].mean() > 0.01
    assert_same_image(a, c)
    scene.terminator_offset[:] = 0.0
    flat = render(scene, scenes.settings(width=40, height=30, samples=4))
    assert not flat.plan.terminator
    assert np.abs(flat.combined - c.combined).max() > 1e-3  # same samples: no noise


def _at(x, y, z, rx=0.0, ry=0.0, rz=0.0, scale=(1.0, 1.0, 1.0)):
    """A light's matrix_world: rotations about X, Y, Z (Blender's XYZ Euler), then move."""
    def rot(axis, a):
        c, s_ = np.cos(a), np.sin(a)
        i, j = [(1, 2), (2, 0), (0, 1)][axis]
        m = np.eye(3)
        m[i, i], m[i, j], m[j, i], m[j, j] = c, -s_, s_, c
        return m
    m = np.eye(4)
    m[:3, :3] = rot(2, rz) @ rot(1, ry) @ rot(0, rx) @ np.diag(scale)
    m[:3, 3] = (x, y, z)
    return m


LIGHTS = {
    "point": [Light("bulb", "POINT", (3, 3, 2.5), _at(0.3, -0.2, 1.2))],
    "point_soft_visible": [Light("bulb", "POINT", (4, 3, 3), _at(0.3, -0.2, 1.0), radius=0.15,
                                 visible_camera=True)],
    "point_sphere": [Light("ball", "POINT", (4, 4, 4), _at(-0.3, 0.0, 1.1), radius=0.1,
                           soft_falloff=False, visible_camera=True)],
    "spot": [Light("spot", "SPOT", (20, 18, 15), _at(0.0, -0.3, 1.4, rx=0.3, scale=(1, 2, 1)),
                   radius=0.05, spot_size=0.9, spot_blend=0.3)],
    "spot_hard": [Light("spot", "SPOT", (20, 18, 15), _at(0.2, 0.0, 1.4), spot_size=0.7,
                        spot_blend=0.0)],
    # A sphere light through the ceiling: points inside it are lit from every direction.
    "point_sphere_through_ceiling": [Light("ball", "POINT", (4, 4, 4), _at(-0.3, 0.0, 1.4),
                                           radius=0.25, soft_falloff=False)],
    "sun": [Light("sun", "SUN", (2, 2, 1.8), _at(0, 0, 5, rx=0.5, ry=0.3))],
    "sun_disc": [Light("sun", "SUN", (2, 2, 1.8), _at(0, 0, 5, rx=0.4, ry=0.2), angle=0.3,
                       visible_camera=True)],
    "area": [Light("panel", "AREA", (8, 8, 8), _at(0, 0, 1.45), shape="RECTANGLE",
                   size_x=0.6, size_y=0.3, visible_camera=True)],
    "area_disk_spread": [Light("disk", "AREA", (8, 7, 6), _at(0.2, 0.1, 1.4, rx=0.2),
                               shape="ELLIPSE", size_x=0.5, size_y=0.3, spread=0.8)],
    "mixed_no_mis": [Light("panel", "AREA", (5, 5, 5), _at(0, 0, 1.45), use_mis=False),
                     Light("bulb", "POINT", (2, 1, 1), _at(0.5, 0, 0.8), radius=0.1),
                     Light("sun", "SUN", (0.5, 0.5, 0.5), _at(0, 0, 5, ry=0.4), angle=0.2)],
    # 2 emissive triangles + 9 lights: the spatial light grid picks among them.
    "grid": [Light(f"bulb {i}", "POINT", (1.0, 0.8, 0.6), _at(-0.8 + 0.2 * i, 0.6, 1.3),
                   radius=0.03 * (i % 3)) for i in range(9)],
}


def _sky(h=16, w=32):
    """A bright patch (a "sun") on a blue gradient, as an equirectangular map."""
    v = (np.arange(h) + 0.5)[:, None, None] / h
    img = np.concatenate([0.2 + 0.0 * v, 0.3 + 0.2 * v, 0.6 + 0.3 * v], axis=2)
    img = np.broadcast_to(img, (h, w, 3)).copy()
    img[11:13, 5:7] = (40.0, 35.0, 30.0)
    return img


@pytest.mark.parametrize("lights", [[], LIGHTS["area"]])
def test_environment_map_same_in_both_kernels(lights):
    """An open scene lit by a rotated environment map (importance-sampled, MIS), alone and
    beside an area light; diffuse, Principled and glass surfaces."""
    b = SceneBuilder()
    floor = b.add_material(Material.diffuse("floor", (0.6, 0.6, 0.5)))
    plastic = b.add_material(Material.principled("plastic", (0.2, 0.4, 0.8), roughness=0.35))
    glass = b.add_material(Material.glass("glass", (1, 1, 1), 1.5))
    b.add_mesh("floor", *scenes.quad((-3, -3, 0), (3, -3, 0), (3, 3, 0), (-3, 3, 0)), floor)
    for m, x in ((plastic, -0.6), (glass, 0.6)):
        v, t, n = scenes.uv_sphere((x, 0, 0.5), 0.5)
        b.add_mesh(f"sphere {x}", v, t, m, corner_normals=n)
    for light in lights:
        b.add_light(light)
    a = 0.7
    rot = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    cam = Camera(world_from_camera=scenes.look_at((0, -5, 2), (0, 0, 0.5)), lens_mm=35)
    scene = b.build(cam, World((0, 0, 0), environment=_sky(), texture_from_world=rot))
    x, y = both(scene)
    assert x.plan.environment and x.combined[..., :3].mean() > 0.1
    assert_same_image(x, y)


@pytest.mark.parametrize("name", list(LIGHTS))
def test_light_objects_same_in_both_kernels(name):
    """Every light type and option: next-event estimation on diffuse and Principled
    surfaces, lights and sun discs hit by camera and BSDF rays (MIS), a ceiling emitter
    beside them."""
    b = scenes.cornell_box(spheres=True, emitter_radiance=2.0)
    plastic = b.add_material(Material.principled("plastic", (0.8, 0.3, 0.2), roughness=0.4))
    v, t, n = scenes.uv_sphere((0.0, -0.3, 0.25), 0.2)
    b.add_mesh("plastic", v, t, plastic, corner_normals=n)
    for light in LIGHTS[name]:
        b.add_light(light)
    scene = b.build(scenes.cornell_camera(), World((0.02, 0.02, 0.03)))
    a, c = both(scene)
    assert a.combined[..., :3].mean() > 0.05
    if name == "grid":
        from engine.lights import LightSampler
        assert hasattr(LightSampler(scene), "local_pmf")
    assert_same_image(a, c)


def test_many_emitters_use_the_light_grid_and_same_in_both_kernels():
    """24 emissive quads: the spatial light grid (LightSampler.GRID) is in use."""
    b = scenes.cornell_box(spheres=True, emitter_radiance=0.0)
    rng = np.random.default_rng(5)
    for i in range(24):
        m = b.add_material(Material.emission_only(f"lamp {i}", rng.random(3), 30.0))
        x, y = rng.uniform(-0.9, 0.8, 2)
        b.add_mesh(f"lamp {i}", *scenes.quad((x, y, 1.45), (x, y + 0.1, 1.45),
                                             (x + 0.1, y + 0.1, 1.45), (x + 0.1, y, 1.45)), m)
    scene = b.build(scenes.cornell_camera(), World((0, 0, 0)))
    a, c = both(scene)
    from engine.lights import LightSampler
    assert hasattr(LightSampler(scene), "local_pmf")
    assert_same_image(a, c)


def test_a_wrong_renderer_is_told_apart():
    """Power of the comparison: IOR 1.45 -> 1.46 or one bounce fewer fails it."""
    ref = render(scenes.cbspheres(), scenes.settings(width=40, height=30, samples=4,
                                                     kernel="generic"))
    for scene, kw in ((scenes.cbspheres(glass_ior=1.46), {}),
                      (scenes.cbspheres(), dict(max_bounces=7))):
        other = render(scene, scenes.settings(width=40, height=30, samples=4,
                                              kernel="specialised", **kw))
        with pytest.raises(AssertionError):
            assert_same_image(ref, other)


def test_no_emitters_means_no_light_sampling_kernel(monkeypatch):
    """No emitters: the light-sampling stage of `shade` is off and no shadow ray is traced."""
    from engine.accel import Accel

    def boom(*a, **k):
        raise AssertionError("shadow rays traced without emitters")

    monkeypatch.setattr(Accel, "occluded_raw", boom)
    scene = scenes.cornell_box(emitter_radiance=0.0).build(scenes.cornell_camera(),
                                                          World((1, 1, 1)))
    r = render(scene, scenes.settings(width=16, height=12, samples=2, kernel="specialised"))
    assert r.plan.kernel == "specialised" and not r.plan.light_sampling
    assert r.combined[..., :3].mean() > 0


def test_profile_mode_renders_the_same_image(monkeypatch):
    """The per-stage cycle counting of the benchmark's profile changes no pixel (the plan's
    kernel: a profiled generic one would take five times as long to compile)."""
    st = scenes.settings(width=24, height=18, samples=2, kernel="specialised")
    plain = render(scenes.cbspheres(), st)
    from engine import renderer
    monkeypatch.setattr(renderer.Kernels, "profile", True)
    profiled = render(scenes.cbspheres(), st)
    assert_same_image(plain, profiled)


# ----------------------------------------------------------------- kernels per plan
def _built_kernel(scene, constants):
    """The kernel for `constants`, loaded from numba's cache where the suite compiled it
    before (the generic one always is), else compiled now on `scene`."""
    from engine import kernels
    from engine.accel import Accel
    from engine.camera import CameraModel
    from engine.lights import LightSampler
    from engine.plan import make_plan

    st = scenes.settings(width=8, height=6, samples=1)
    plan = make_plan(scene, st)
    return kernels.build_now(constants, lambda k: kernels.compile_on(
        k, scene, st, plan, LightSampler(scene) if plan.emitters else None,
        CameraModel(scene.camera, 8, 6, scene.origin), Accel(scene)))


# A formula only a feature uses (compiled on its own, so its name is in the kernel's IR).
MARKERS = {"HAS_GLASS": "sample_dielectric", "HAS_ROUGH": "ggx_visible_normal",
           "HAS_ROUGH_GLASS": "rough_dielectric", "HAS_ROUGH_METAL": "rough_conductor",
           "HAS_NORMAL_MAPS": "perturbed_normal",
           "HAS_METAL": "fresnel_f82", "HAS_DOF": "thin_lens_ray",
           "HAS_POLYGON_APERTURE": "regular_polygon", "HAS_LIGHT_OBJECTS": "spread_attenuation",
           "HAS_ENVIRONMENT": "to_uv", "HAS_TERMINATOR": "offset_amount",
           "HAS_LIGHT_GRID": "voxel", "HAS_LIGHT_IMPORTANCE": "importance_pmf",
           "HAS_LIGHT_TRACING": "path_tracing_weight", "HAS_TEXTURES": "image_channel",
           "HAS_VOLUMES": "transmittance", "HAS_SCATTERING": "scatter_in_medium",
           "HAS_MIXES": "choose_closure",
           "HAS_COATS": "coat_layering", "HAS_TRANSPARENCY": "pass_through",
           "HAS_SHEEN": "sheen_ltc", "HAS_LIGHT_PATH": "set_light_path",
           "HAS_OREN_NAYAR": "oren_nayar_ratio", "HAS_ANISOTROPY": "anisotropic_alphas",
           "HAS_TRANSPARENT_GLASS": "clear_glass", "HAS_THIN_FILM": "thin_film_f82"}


def _ir(kernel):
    """The optimised LLVM IR of the kernel's entry points. numba keeps it beside the object
    code, as bitcode to link into other functions, whether it compiled them now or loaded
    them from its cache (`inspect_llvm` has nothing for a cached function, so this test once
    compiled the generic kernel a second time, uncached: four minutes of the suite)."""
    return "\n".join(str(cres.library._get_module_for_linking())
                     for entry in (kernel.shade, kernel.generate_camera_rays)
                     for cres in entry.overloads.values())


@pytest.mark.skipif(not NUMBA, reason="numba is not installed")
def test_a_diffuse_only_kernel_has_no_code_for_absent_features():
    """The plan's kernel is compiled without the stages a scene cannot reach: a diffuse
    box's kernel holds no dielectric, GGX, metal, lens, light-object, environment,
    terminator, light-grid, light-importance or light-tracing code, while the generic
    kernel holds all of it."""
    from engine import kernels
    from engine.plan import make_plan

    box = scenes.cornell_box(spheres=False).build(scenes.cornell_camera(), World((0, 0, 0)))
    constants = make_plan(box, scenes.settings()).kernel_constants(False)
    own = _built_kernel(box, constants)
    generic = _built_kernel(box, kernels.generic_constants())
    assert not own.generic and generic.generic
    own_ir, generic_ir = _ir(own), _ir(generic)
    for name, marker in MARKERS.items():
        assert not constants[name]
        assert marker in generic_ir, f"{marker} missing from the generic kernel"
        assert marker not in own_ir, f"{name} off, but {marker} was compiled in"
    assert len(own_ir) < 0.3 * len(generic_ir), (len(own_ir), len(generic_ir))  # 14 %


def test_the_kernel_is_handed_c_contiguous_arrays():
    """numba compiles a kernel once per argument layout, so a strided view anywhere in the
    scene's data compiles the whole kernel again (it did: the emitters' first corners, a
    column of their corner array, cost the suite a second cold compile of every kernel)."""
    from engine import kernels
    from engine.camera import CameraModel
    from engine.lights import LightSampler
    from engine.plan import make_plan

    box, st = scenes.caustic_box(), scenes.settings(light_tracing=True)
    plan, emitters = make_plan(box, st), LightSampler(box)
    assert not emitters.data().v0.flags.c_contiguous  # what the test guards against
    camera = CameraModel(box.camera, st.width, st.height, box.origin)
    for generic in (True, False):
        strided = []

        def walk(x, name):
            if isinstance(x, np.ndarray):
                if not x.flags.c_contiguous:
                    strided.append(name)
            elif isinstance(x, tuple) and hasattr(x, "_fields"):
                for field, y in zip(x._fields, x):
                    walk(y, f"{name}.{field}")

        walk(kernels.scene_data(box, st, plan, emitters, camera, generic), "scene")
        assert strided == [], (generic, strided)


def test_a_kernel_without_glass_does_not_cover_a_glass_scene():
    from engine import kernels
    from engine.plan import make_plan

    box = scenes.cornell_box(spheres=False).build(scenes.cornell_camera(), World((0, 0, 0)))
    own = kernels.Kernel(make_plan(box, scenes.settings()).kernel_constants(False))
    glass = make_plan(scenes.cbspheres(), scenes.settings()).kernel_constants(False)
    assert glass["HAS_GLASS"] and not own.covers(glass)
    assert kernels.Kernel(kernels.generic_constants()).covers(glass)


def test_a_render_switches_to_its_own_kernel_at_a_pass_boundary(monkeypatch):
    """Started with the generic kernel (the plan's not loaded), a render switches to the
    plan's kernel once it has compiled, between passes, and its image is the same to the
    last bit as a render with either kernel throughout."""
    from engine import kernels

    monkeypatch.setenv("SPECULA_KERNEL", "auto")
    scene = scenes.cbspheres()
    st = scenes.settings(width=24, height=18, samples=6)
    generic = render(scene, replace(st, kernel="generic"))
    own = render(scene, replace(st, kernel="specialised"))
    from engine.lights import LightSampler

    em = LightSampler(scene)  # the renderer's flags: few emitters, chosen by importance
    constants = own.plan.kernel_constants(hasattr(em, "local_pmf"), hasattr(em, "bounds"))
    assert constants["HAS_LIGHT_IMPORTANCE"]
    monkeypatch.delitem(kernels._ready, kernels.key_of(constants))  # not loaded yet
    monkeypatch.setattr(kernels.Kernel, "on_disk", lambda self: False)  # nor cached

    def wait_for_the_kernel(p):
        if p.samples == 2:
            for thread in list(kernels._building.values()):
                thread.join()

    switched = render(scene, st, on_pass=wait_for_the_kernel)
    assert switched.plan.kernel == "generic, then specialised", switched.plan.kernel
    # Pass 3 was queued (ahead) while pass 2 ran: the kernel takes over from pass 4.
    assert switched.plan.kernel_note == "switched at pass 4"
    assert_same_image(generic, own)
    assert_same_image(generic, switched)


def test_without_numba_the_same_functions_run_as_python(tmp_path):
    """A platform without numba runs the very same stage functions as Python
    (NUMBA_DISABLE_JIT gives numba's decorators back the plain functions): the same image."""
    import json
    import os
    import subprocess
    import sys

    script = (
        "import json, sys; from engine import render; from tests import scenes\n"
        "r = render(scenes.cbspheres(), scenes.settings(width=6, height=4, samples=2,"
        " max_bounces=3, kernel=sys.argv[1]))\n"
        "print(json.dumps(r.combined[..., :3].ravel().tolist()))\n")
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    out = {}
    for jit in ("0", "1"):
        env = dict(os.environ, NUMBA_DISABLE_JIT=jit, PYTHONWARNINGS="ignore")
        run = subprocess.run([sys.executable, "-c", script, "specialised"], cwd=root, env=env,
                             capture_output=True, text=True, timeout=600)
        assert run.returncode == 0, run.stderr[-2000:]
        out[jit] = np.array(json.loads(run.stdout.strip().splitlines()[-1]))
    np.testing.assert_allclose(out["1"], out["0"], rtol=1e-12, atol=1e-15)
    assert out["0"].max() > 0


# ----------------------------------------------------------------- the kernels' cache
def test_a_copy_of_the_core_elsewhere_loads_the_same_kernels(tmp_path):
    """numba names its cache after the source folder, so the same core installed in two
    places (the extension in Blender 4.2 and in 5.0, a reinstall) compiled every kernel
    again: minutes for the generic one. The core's own locator (jit.EngineCacheLocator)
    finds them by the sources and the package name instead: a copy of engine/ elsewhere
    loads this checkout's kernels, compiling none; a copy imported under another package
    name has a cache of its own (numba's entries load only where their module imports
    by name: the extension's cache from a checkout's failed with "No module named
    'engine'")."""
    import shutil
    import subprocess
    import sys

    from engine import jit

    box = scenes.cornell_box(spheres=False).build(scenes.cornell_camera(), World((0, 0, 0)))
    st = scenes.settings(width=8, height=6, samples=1, kernel="specialised")
    render(box, st)  # this checkout's kernel for the box, compiled or loaded
    for folder in ("copy", "vendor"):
        shutil.copytree(jit.ENGINE_DIR, tmp_path / folder / "engine",
                        ignore=shutil.ignore_patterns("__pycache__"))
    (tmp_path / "vendor" / "__init__.py").write_text("")
    code = (
        "import sys; sys.path.insert(0, sys.argv[1]); sys.path.insert(0, sys.argv[2]); "
        "import engine, importlib; from tests import scenes; "
        "vendor = importlib.import_module('vendor.engine'); "
        "print(engine.jit.ENGINE_DIR); print(engine.jit.cache_root()); "
        "print(vendor.jit.cache_root()); "
        "box = scenes.cornell_box(spheres=False).build(scenes.cornell_camera(), "
        "engine.World((0, 0, 0))); "
        "r = engine.render(box, scenes.settings(width=8, height=6, samples=1, "
        "kernel='specialised')); "
        "(k,) = engine.kernels._ready.values(); "
        "print(sum(k.shade.stats.cache_hits.values()), "
        "sum(k.shade.stats.cache_misses.values()))")
    out = subprocess.run([sys.executable, "-c", code, str(tmp_path / "copy"), str(tmp_path)],
                         capture_output=True, text=True, timeout=600,
                         cwd=os.path.dirname(jit.ENGINE_DIR))
    assert out.returncode == 0, out.stderr[-3000:]
    lines = out.stdout.split("\n")
    assert lines[0] == str(tmp_path / "copy" / "engine")  # the copy ran, not this checkout
    assert lines[1] == jit.cache_root() != lines[2]
    hits, misses = map(int, lines[3].split())
    assert hits >= 1 and misses == 0, lines[3]


def test_old_cache_folders_are_pruned(tmp_path):
    """Cache folders of other sources beside this one's: the most recently used few stay,
    this one is marked used, the rest go; folders that are not the core's are left."""
    import os
    import time

    from engine import jit

    root = tmp_path / "specula-0000mine"
    root.mkdir()
    now = time.time()
    for i in range(jit.KEPT_CACHES + 3):
        old = tmp_path / f"specula-{i:08x}"
        old.mkdir()
        (old / "kernel.nbc").write_bytes(b"x")
        os.utime(old, (now - 1000 * (i + 1), now - 1000 * (i + 1)))
    (tmp_path / "numba-other").mkdir()
    os.utime(root, (now - 10 ** 6, now - 10 ** 6))
    removed = jit.prune_caches(str(root))
    left = sorted(p.name for p in tmp_path.iterdir())
    assert sorted(os.path.basename(p) for p in removed) == \
        [f"specula-{i:08x}" for i in range(jit.KEPT_CACHES, jit.KEPT_CACHES + 3)]
    assert left == sorted(["numba-other", "specula-0000mine"] +
                          [f"specula-{i:08x}" for i in range(jit.KEPT_CACHES)])
    assert root.stat().st_mtime > now - 60  # marked used

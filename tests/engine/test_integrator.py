"""Scenes with known answers: furnace, invisible glass, mirrors; Blender's bounce count."""

import numpy as np
import pytest

from engine import Camera, Material, RenderSettings, SceneBuilder, World, render
from tests.scenes import look_at, uv_sphere

pytestmark = pytest.mark.slow


def cube(b: SceneBuilder, name: str, material: int, half=1.0):
    """A closed axis-aligned cube of half-size `half` around the origin."""
    v = np.array([[x, y, z] for x in (-half, half) for y in (-half, half) for z in (-half, half)])
    faces = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    tris = [t for a, b_, c, d in faces for t in ((a, b_, c), (a, c, d))]
    b.add_mesh(name, v, np.array(tris), material)


def image_mean_and_error(result):
    """Mean luminance over the image and its standard error (pixels independent)."""
    lum = result.combined[..., :3] @ np.array([0.2126, 0.7152, 0.0722])
    return float(lum.mean()), float(np.sqrt(np.sum(result.error.astype(float) ** 2)) / lum.size)


def furnace(albedo: float, max_bounces: int, samples=32, seed=3):
    b = SceneBuilder()
    m = b.add_material(Material.diffuse("furnace", (albedo,) * 3, emission=(1.0, 1.0, 1.0)))
    cube(b, "enclosure", m)
    cam = Camera(world_from_camera=look_at((0, 0, 0), (0, 1, 0)), lens_mm=20)
    scene = b.build(cam, World((0, 0, 0)))
    return render(scene, RenderSettings(width=24, height=24, samples=samples,
                                        max_bounces=max_bounces, seed=seed))


@pytest.mark.parametrize("max_bounces", [0, 1, 2, 5])
def test_white_furnace_is_the_truncated_geometric_series(max_bounces):
    """Emission 1 and albedo a everywhere: L = sum_{k=0}^{N+1} a^k with max_bounces = N
    (camera hit, then direct light at N+1 vertices)."""
    a = 0.5
    r = furnace(a, max_bounces, samples=128 if max_bounces >= 5 else 32)
    mean, err = image_mean_and_error(r)
    expected = sum(a**k for k in range(max_bounces + 2))
    assert err < 0.004
    assert abs(mean - expected) < 5 * err + 1e-9, (mean, expected, err)
    # Power: one bounce fewer or more would be caught.
    for wrong in (max_bounces + 1, max_bounces + 3):
        assert abs(mean - sum(a**k for k in range(wrong))) > 5 * err


def test_furnace_with_many_bounces_converges_to_one_over_one_minus_a():
    a = 0.8
    r = furnace(a, 200, samples=64)
    mean, err = image_mean_and_error(r)
    assert abs(mean - 1 / (1 - a)) < 5 * err, (mean, err)


def sphere_in_environment(material: Material, world=(0.5, 0.7, 0.9), max_bounces=64, samples=8,
                          kernel="auto"):
    b = SceneBuilder()
    m = b.add_material(material)
    v, t, n = uv_sphere((0, 0, 0), 1.0, segments=64, rings=32)
    b.add_mesh("sphere", v, t, m, corner_normals=n)
    cam = Camera(world_from_camera=look_at((0, -4, 0), (0, 0, 0)), lens_mm=50)
    scene = b.build(cam, World(world))
    return render(scene, RenderSettings(width=40, height=30, samples=samples,
                                        max_bounces=max_bounces, seed=7, kernel=kernel))


@pytest.mark.parametrize("ior", [1.0, 1.33, 1.5, 2.4])
def test_glass_sphere_in_uniform_environment_is_invisible(ior):
    world = np.array([0.5, 0.7, 0.9])
    r = sphere_in_environment(Material.glass("glass", (1, 1, 1), ior), world)
    img = r.combined[..., :3]
    assert np.abs(img - world).max() < 1e-6


def test_a_specular_tint_leaves_white_glass_invisible_on_average():
    """Under a Specular Tint a Principled glass reflects F per channel (fresnel.
    tinted_fresnel) and transmits the rest, so white glass still passes all of a uniform
    world, channel by channel; each sample's weight is no longer 1 (the lobe is chosen
    by the channels' mean), only their mean is."""
    world = np.array([0.5, 0.7, 0.9])
    glass = Material.principled_glass("tinted", (1, 1, 1), 1.8, specular_tint=(0.1, 1.0, 4.0))
    r = sphere_in_environment(glass, world, samples=64)
    img = r.combined[..., :3]
    assert np.abs(img - world).max() > 0.05  # single pixels are noisy ...
    mean = img.reshape(-1, 3).mean(axis=0)
    se = np.sqrt(r.variance[..., :3].reshape(-1, 3).sum(axis=0)) / img[..., 0].size
    assert np.all(np.abs(mean - world) < 4 * se + 1e-6), (mean, world, se)  # ... not the mean


def test_a_refraction_sphere_passes_its_colour_twice():
    """The Refraction BSDF reflects nothing and refracts all but under total internal
    reflection, which a ray through a sphere does not meet: in a uniform environment the
    sphere's middle is colour^2 x the world (two crossings). The Glass BSDF of that colour
    (Fresnel-weighted) is not."""
    world, colour = np.array([0.5, 0.7, 0.9]), np.array([0.9, 0.6, 0.8])
    for kind in ("glass", "refraction"):
        r = sphere_in_environment(getattr(Material, kind)("r", tuple(colour), ior=1.5), world)
        middle = r.combined[10:20, 15:25, :3]  # within 8 px of the centre (radius 14.6 px)
        error = np.abs(middle - colour ** 2 * world).max()
        assert error < 1e-6 if kind == "refraction" else error > 0.01, (kind, error)


def eta_squared_dielectric(wox, woy, woz, nx, ny, nz, eta, r_tint, t_tint, st, u, exact,
                           fresnel_on, film_d=0.0, film_n=1.0):
    """bsdf.sample_dielectric with refracted radiance scaled by 1/eta^2."""
    wx, wy, wz, f0, f1, f2, ok = original_sample_dielectric(  # noqa: F821
        wox, woy, woz, nx, ny, nz, eta, r_tint, t_tint, st, u, exact, fresnel_on, film_d,
        film_n)
    if wx * nx + wy * ny + wz * nz < 0.0:  # transmitted
        k = 1.0 / (eta * eta)
        f0, f1, f2 = f0 * k, f1 * k, f2 * k
    return wx, wy, wz, f0, f1, f2, ok


def test_glass_sphere_with_eta_squared_scaling_would_be_visible(monkeypatch):
    """Power for the test above: a renderer that scaled refracted radiance by 1/eta^2
    (the course's convention) would not pass it."""
    from engine import bsdf
    from tests.patching import module_with, one_off_kernels

    one_off_kernels(monkeypatch, bsdf=module_with(
        bsdf, sample_dielectric=eta_squared_dielectric,
        original_sample_dielectric=bsdf.sample_dielectric))
    world = np.array([0.5, 0.7, 0.9])
    r = sphere_in_environment(Material.glass("glass", (1, 1, 1), 1.5), world)
    assert np.abs(r.combined[..., :3] - world).max() > 0.05


def test_mirror_of_colour_c_in_uniform_environment_returns_c():
    c = np.array([0.3, 0.6, 0.9])
    r = sphere_in_environment(Material.mirror("mirror", c), world=(1, 1, 1), max_bounces=4)
    centre = r.combined[12:18, 17:23, :3]
    assert np.allclose(centre, c, atol=1e-9)


def test_metal_reflects_base_colour_at_normal_incidence():
    base = np.array([1.0, 0.8, 0.4])
    r = sphere_in_environment(Material.metal("gold", base), world=(1, 1, 1), max_bounces=4)
    assert np.allclose(r.combined[15, 20, :3], base, atol=2e-3)


def test_emitter_is_two_sided_and_seen_at_depth_zero():
    """A camera sees L = strength x colour on both faces of an emitter, even with
    max_bounces = 0."""
    for eye in ((0, -3, 0), (0, 3, 0)):
        b = SceneBuilder()
        m = b.add_material(Material.emission_only("panel", (1.0, 0.5, 0.25), 4.0))
        b.add_mesh("panel", np.array([[-2, 0, -2], [2, 0, -2], [2, 0, 2], [-2, 0, 2.0]]),
                   np.array([[0, 1, 2], [0, 2, 3]]), m)
        scene = b.build(Camera(world_from_camera=look_at(eye, (0, 0, 0)), lens_mm=50), World())
        r = render(scene, RenderSettings(width=8, height=8, samples=2, max_bounces=0))
        assert np.allclose(r.combined[2:6, 2:6, :3], [4.0, 2.0, 1.0])


def test_escaped_rays_take_the_world_colour_and_alpha_is_one():
    b = SceneBuilder()
    scene = b.build(Camera(), World((0.2, 0.3, 0.4)))
    r = render(scene, RenderSettings(width=5, height=3, samples=2))
    assert np.allclose(r.combined[..., :3], [0.2, 0.3, 0.4]) and np.all(r.combined[..., 3] == 1)


def test_direct_light_on_a_diffuse_plane_matches_the_closed_form():
    """A small emitting square of radiance L and area A at height h above a Lambert plane
    of albedo rho: the point below sees E ~= L A / h^2, so L_out = rho E / pi."""
    L, side, h, rho = 50.0, 0.05, 1.0, 0.5
    b = SceneBuilder()
    lm = b.add_material(Material.emission_only("lamp", (1, 1, 1), L))
    pm = b.add_material(Material.diffuse("plane", (rho,) * 3))
    s = side / 2
    b.add_mesh("lamp", np.array([[-s, -s, h], [s, -s, h], [s, s, h], [-s, s, h]]),
               np.array([[0, 2, 1], [0, 3, 2]]), lm)
    b.add_mesh("plane", np.array([[-50, -50, 0], [50, -50, 0], [50, 50, 0], [-50, 50, 0.0]]),
               np.array([[0, 1, 2], [0, 2, 3]]), pm)
    cam = Camera(type="ORTHO", ortho_scale=0.002, world_from_camera=look_at((0, 0, 0.5), (0, 0, 0),
                                                                           up=(0, 1, 0)))
    scene = b.build(cam, World())
    r = render(scene, RenderSettings(width=8, height=8, samples=64, max_bounces=0, seed=5))
    mean, err = image_mean_and_error(r)
    # Exact irradiance below the centre of a square: solid-angle integral of cos.
    a = s / h
    e_exact = L * 4 * (a / np.sqrt(1 + a * a)) * np.arctan(a / np.sqrt(1 + a * a))
    assert abs(mean - rho * e_exact / np.pi) < 5 * err + 1e-6, (mean, rho * e_exact / np.pi, err)


def scaled_cbspheres(scale, offset=(0.0, 0.0, 0.0)):
    """CBspheres with every length (geometry, camera position, clip planes) scaled."""
    from tests import scenes

    b = scenes.cornell_box()
    for i, (name, v, tri, *rest) in enumerate(b._meshes):
        b._meshes[i] = (name, v * scale + np.asarray(offset), tri, *rest)
    cam = scenes.cornell_camera(clip_start=0.1 * scale, clip_end=100.0 * scale)
    m = np.array(cam.world_from_camera)
    m[:3, 3] = m[:3, 3] * scale + np.asarray(offset)
    return b.build(Camera(**{**cam.__dict__, "world_from_camera": m}), World((0, 0, 0)))


def max_block_z(ref, other, block=6):
    """Largest |z| of block sums of the luminance difference, and the Sidak-corrected
    two-sided critical value at family-wise level 1%."""
    from scipy import stats

    lum = np.array([0.2126, 0.7152, 0.0722])
    h, w = ref.error.shape

    def blocks(a):
        return a.reshape(h // block, block, w // block, block).sum(axis=(1, 3))

    d = blocks((ref.combined[..., :3] - other.combined[..., :3]) @ lum)
    v = blocks(ref.error.astype(float) ** 2 + other.error.astype(float) ** 2)
    z = np.abs(d) / np.sqrt(np.maximum(v, 1e-30))
    alpha = 1 - (1 - 0.01) ** (1 / z.size)
    return z.max(), stats.norm.isf(alpha / 2)


@pytest.mark.parametrize("scale,offset", [(1e-3, 0), (1e3, 0), (1.0, 1e5)])
def test_same_image_at_any_scale_and_position(scale, offset):
    """Scaled by 1e-3 or 1e3, or moved to (1e5, 1e5, 1e5), CBspheres renders the same
    image within noise (block-wise z-scores, Sidak-corrected)."""
    st = RenderSettings(width=48, height=36, samples=16, max_bounces=6, seed=11)
    ref = render(scaled_cbspheres(1.0), st)
    other = render(scaled_cbspheres(scale, (offset,) * 3), RenderSettings(**{**st.__dict__,
                                                                             "seed": 12}))
    z, critical = max_block_z(ref, other)
    assert z < critical, z
    assert np.isfinite(other.combined).all()


def fixed_ray_offset(scale):
    return 1e-6


def test_scale_comparison_rejects_a_fixed_epsilon(monkeypatch):
    """Power: with a fixed absolute ray offset (1e-6) the 1e3-scaled scene self-intersects
    and the comparison above fails."""
    from tests.patching import one_off_kernels

    st = RenderSettings(width=48, height=36, samples=16, max_bounces=6, seed=11)
    ref = render(scaled_cbspheres(1.0), st)
    one_off_kernels(monkeypatch, ray_offset=fixed_ray_offset)
    other = render(scaled_cbspheres(1e3), RenderSettings(**{**st.__dict__, "seed": 12}))
    z, critical = max_block_z(ref, other)
    assert z > critical


def test_grazing_shadow_rays_reach_the_emitter():
    """Regression: a small horizontal emitter seen at a grazing angle from the floor
    (shadow rays nearly parallel to its plane) lights the floor as the small-source
    formula says, E = L A cos_l cos / d^2, with no self-occlusion of the shadow rays."""
    L, side, h, x, rho = 50.0, 0.02, 0.2, 3.0, 0.5
    b = SceneBuilder()
    lm = b.add_material(Material.emission_only("lamp", (1, 1, 1), L))
    pm = b.add_material(Material.diffuse("plane", (rho,) * 3))
    s = side / 2
    b.add_mesh("lamp", np.array([[x - s, -s, h], [x + s, -s, h], [x + s, s, h], [x - s, s, h]]),
               np.array([[0, 1, 2], [0, 2, 3]]), lm)
    b.add_mesh("plane", np.array([[-50, -50, 0], [50, -50, 0], [50, 50, 0], [-50, 50, 0.0]]),
               np.array([[0, 1, 2], [0, 2, 3]]), pm)
    cam = Camera(type="ORTHO", ortho_scale=0.002,
                 world_from_camera=look_at((0, 0, 0.5), (0, 0, 0), up=(0, 1, 0)))
    r = render(b.build(cam, World()), RenderSettings(width=8, height=8, samples=64,
                                                     max_bounces=0, seed=5))
    mean, err = image_mean_and_error(r)
    d2 = x * x + h * h
    cos = h / np.sqrt(d2)  # both cosines equal: horizontal emitter, horizontal floor
    expected = rho * L * side * side * cos * cos / d2 / np.pi
    assert abs(mean - expected) < 5 * err + 2e-3 * expected, (mean, expected, err)

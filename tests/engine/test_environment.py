"""Environment-map world light: mapping, importance sampling, known answers."""

import numpy as np
import pytest

from engine import (Camera, Material, RenderSettings, SceneBuilder, World, environment, render,
                    shading)
from engine.environment import EnvironmentMap
from tests.scenes import look_at, uv_sphere
from tests.stats import SIGNIFICANCE, chi2_test


def test_equirectangular_mapping_follows_blender():
    m = EnvironmentMap(np.ones((8, 16, 3))).texture_from_world
    d = np.array([[1.0, 0, 0], [0, 1.0, 0], [-1.0, 0, 0], [0, 0, 1.0], [0, 0, -1.0]])
    u, v = np.array([environment.to_uv(*x, m) for x in d]).T
    assert np.allclose(u[:3], [0.5, 0.25, 0.0]) and np.allclose(v, [0.5, 0.5, 0.5, 1.0, 0.0])
    # The inverse mapping, as `sample` applies it: a one-pixel map puts (ua, ub) at (u, v).
    one = EnvironmentMap(np.ones((1, 1, 3))).data()
    back = np.array([environment.sample(a, b, one)[:3] for a, b in zip(u, v)])
    assert np.allclose(back, d, atol=1e-12)


def test_rotation_turns_the_lookup(rng):
    img = rng.random((9, 17, 3))
    rot = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # 90 deg about z
    d = rng.normal(size=(100, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    turned, plain = EnvironmentMap(img, rot).data(), EnvironmentMap(img).data()

    def lookup(env, x):
        return environment.lookup(*environment.to_uv(*x, env.texture_from_world), env.image)
    assert np.allclose([lookup(turned, x) for x in d], [lookup(plain, x) for x in d @ rot.T])
    # The sampled directions turn with the map: world_from_texture undoes texture_from_world.
    for ua, ub in rng.random((20, 2)):
        w = np.array(environment.sample(ua, ub, turned)[:3])
        assert np.allclose(w @ rot.T, environment.sample(ua, ub, plain)[:3])


def test_sampling_follows_luminance_and_pdf_is_consistent(rng):
    """Chi-square over the map's pixels: counts in proportion to luminance x cos(elev)."""
    h, w, n = 9, 17, 200_000
    img = rng.random((h, w, 3)) ** 3
    env_map = EnvironmentMap(img)
    env = env_map.data()
    m = env.texture_from_world
    samples = np.array([environment.sample(a, b, env) for a, b in rng.random((n, 2))])
    d, pdf = samples[:, :3], samples[:, 3]
    u, v = np.array([environment.to_uv(*x, m) for x in d]).T
    cells = np.minimum((v * h).astype(int), h - 1) * w + np.minimum((u * w).astype(int), w - 1)
    observed = np.bincount(cells, minlength=h * w)
    p, dof = chi2_test(observed, n * env_map.distribution.pmf)
    assert dof > 100 and p > SIGNIFICANCE / 10, p
    assert np.allclose([environment.pdf(a, b, env) for a, b in zip(u, v)], pdf, rtol=1e-6)
    # The density integrates to one over the sphere (Monte Carlo with uniform directions).
    z = rng.uniform(-1, 1, 400_000)
    phi = rng.uniform(0, 2 * np.pi, 400_000)
    s = np.sqrt(1 - z * z)
    dirs = np.column_stack([s * np.cos(phi), s * np.sin(phi), z])
    density = [environment.pdf(*environment.to_uv(*x, m), env) for x in dirs]
    assert np.mean(density) * 4 * np.pi == pytest.approx(1.0, rel=0.01)


def test_uniform_map_equals_a_constant_world():
    """A diffuse sphere lit by a uniform map of radiance L reflects albedo x L, like the
    constant world (here found through light sampling and MIS as well)."""
    L, a = 0.7, 0.5
    out = []
    for world in (World((L, L, L)), World((0, 0, 0), environment=np.full((16, 32, 3), L))):
        b = SceneBuilder()
        m = b.add_material(Material.diffuse("ball", (a, a, a)))
        v, t, n = uv_sphere((0, 0, 0), 1.0, 48, 24)
        b.add_mesh("ball", v, t, m, corner_normals=n)
        scene = b.build(Camera(world_from_camera=look_at((0, -4, 0), (0, 0, 0)), lens_mm=50),
                        world)
        r = render(scene, RenderSettings(width=24, height=18, samples=32, max_bounces=2, seed=3))
        out.append(r)
    const, env = out
    centre = env.combined[7:11, 10:14, :3]
    assert np.allclose(centre, a * L, atol=5 * np.sqrt(env.variance[7:11, 10:14].max()) + 1e-6)
    assert np.allclose(env.combined[0, 0, :3], L)  # background pixels see the map
    assert "handle escaped rays (environment map)" in env.plan.stages()


@pytest.mark.slow
def test_upper_hemisphere_sky_on_a_plane():
    """Sky of radiance 1 above the horizon, black below: a Lambert plane facing up gets
    E = pi, so it reflects albedo x 1, whatever mix of light and BSDF sampling finds it."""
    h, w = 32, 64
    img = np.zeros((h, w, 3))
    img[h // 2:] = 1.0
    b = SceneBuilder()
    m = b.add_material(Material.diffuse("ground", (0.5, 0.5, 0.5)))
    b.add_mesh("ground", np.array([[-1e3, -1e3, 0], [1e3, -1e3, 0], [1e3, 1e3, 0], [-1e3, 1e3, 0]]),
               np.array([[0, 1, 2], [0, 2, 3]]), m)
    cam = Camera(type="ORTHO", ortho_scale=0.01,
                 world_from_camera=look_at((0, 0, 1), (0, 0, 0), up=(0, 1, 0)))
    r = render(b.build(cam, World((0, 0, 0), environment=img)),
               RenderSettings(width=8, height=8, samples=64, max_bounces=0, seed=2))
    mean = r.combined[..., 0].mean()
    err = np.sqrt(r.variance[..., 0].astype(float).sum()) / 64
    assert abs(mean - 0.5) < 5 * err + 1e-6, (mean, err)


def test_invalid_environment_is_refused():
    with pytest.raises(ValueError, match="environment"):
        SceneBuilder().build(Camera(), World((0, 0, 0), environment=np.full((4, 8, 3), -1.0)))


def _direction_program(kind):
    """A program whose result is the world's coordinate map `kind` (shading's map names)."""
    p = shading.Program()
    p.out = p.uv(kind)
    return p


def test_a_baked_world_reads_each_texel_direction():
    """Each texel of a baked map holds the program run in the direction of its centre, the
    direction looked up where `to_uv` puts it: P and Generated are that direction, N its
    opposite (Cycles' shader_setup_from_background)."""
    w, h = 32, 16
    u, v = np.meshgrid((np.arange(w) + 0.5) / w, (np.arange(h) + 0.5) / h)
    d = np.array([shading.equirectangular_direction(a, b)
                  for a, b in zip(u.ravel(), v.ravel())]).reshape(h, w, 3)
    for kind, sign in ((shading.POSITION, 1.0), (shading.GENERATED, 1.0),
                       (shading.NORMAL, -1.0)):
        baked = environment.bake(_direction_program(kind), w, h)
        assert np.allclose(baked, np.maximum(sign * d, 0.0), atol=1e-6), kind
    m = np.eye(3)
    back = np.array([environment.to_uv(*x, m) for x in d.reshape(-1, 3)])
    assert np.allclose(back, np.stack([u.ravel(), v.ravel()], axis=1), atol=1e-12)


def test_a_baked_world_keeps_no_negative_or_non_finite_value():
    """Results beyond float32 (exp(100 z) above z = 0.89), which the map would hold as
    inf, and negative ones bake to 0: an output pixel is never NaN or inf."""
    p = shading.Program()
    z = p.uv(shading.GENERATED) + 2
    big, zero = p.const([100.0]), p.const([0.0])
    steep = p.emit(shading.OP_MATH, 1, a=z, b=big, c=big, d=shading.MATHS.index("MULTIPLY"))
    inf = p.emit(shading.OP_MATH, 1, a=steep, b=zero, c=zero,
                 d=shading.MATHS.index("EXPONENT"))
    p.out = p.emit(shading.OP_COMBINE, 3, a=inf, b=z, c=zero)
    baked = environment.bake(p, 16, 8)
    assert np.all(np.isfinite(baked)) and baked.min() >= 0.0
    assert np.all(baked[-1, :, 0] == 0.0) and np.all(baked[4:-1, :, 0] > 1e8)
    assert np.all(baked[:4, :, 1] == 0.0) and np.all(baked[4:, :, 1] > 0.0)


def test_a_baked_world_refuses_maps_a_world_does_not_have():
    with pytest.raises(ValueError, match="cannot read"):
        environment.bake(_direction_program(shading.CAMERA), 8, 4)


def test_environment_projections_follow_cycles(rng):
    """Equirectangular: the map's own convention, any length; Mirror Ball: Cycles'
    direction_to_mirrorball, whose +y (toward the ball's viewer) is the centre and -y the
    rim, on the direction normalised first."""
    for d in rng.normal(size=(50, 3)):
        unit = d / np.linalg.norm(d)
        assert np.allclose(shading.projection(2, *(3.0 * d)), shading.equirectangular(*unit))
        u, v = shading.projection(3, *(0.5 * d))
        x, y, z = unit[0], unit[1] - 1.0, unit[2]
        div = 2.0 * np.sqrt(max(-0.5 * y, 0.0))
        assert np.allclose((u, v), (0.5 * (x / div + 1.0), 0.5 * (z / div + 1.0)))
    assert shading.projection(3, 0.0, 1.0, 0.0) == (0.5, 0.5)
    assert shading.projection(2, 0.0, 0.0, 0.0) == (0.0, 0.0)


def test_the_maps_of_kinds_of_ray_need_a_map_and_are_checked_as_one():
    World(environment=np.ones((2, 4, 3)),
          ray_environments={shading.RAY_CAMERA: np.ones((2, 4, 3))}).validate()
    with pytest.raises(ValueError, match="need an environment"):
        World(ray_environments={shading.RAY_CAMERA: np.ones((2, 4, 3))}).validate()
    with pytest.raises(ValueError, match=r"ray_environments\[1\] must be finite"):
        World(environment=np.ones((2, 4, 3)),
              ray_environments={shading.RAY_CAMERA: np.full((2, 4, 3), np.nan)}).validate()
    with pytest.raises(ValueError, match="the environment's size"):
        World(environment=np.ones((2, 4, 3)),
              ray_environments={shading.RAY_CAMERA: np.ones((1, 2, 3))}).validate()
    with pytest.raises(ValueError, match="path flags must be an int"):
        World(environment=np.ones((2, 4, 3)), ray_environments={0: np.ones((2, 4, 3))}).validate()

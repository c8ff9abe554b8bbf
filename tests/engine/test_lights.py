"""Light objects against closed forms, in Cycles' units."""

import math

import numpy as np
import pytest

from engine import Camera, Light, Material, RenderSettings, SceneBuilder, World, render
from tests.scenes import look_at

pytestmark = pytest.mark.slow
RHO = 0.5


def at(position, target=None, up=(0, 1, 0)):
    """A light matrix at `position`, emitting (local -Z) toward `target` (default: down)."""
    position = np.asarray(position, float)
    target = position - np.array([0, 0, 1.0]) if target is None else np.asarray(target, float)
    return look_at(position, target, up=up)


def plane_scene(lights, world=(0, 0, 0), samples=64, ortho=0.002, max_bounces=0):
    """A Lambert plane (albedo RHO) at z = 0 seen from above by a tiny orthographic camera:
    the image is the radiance leaving the point below the camera, rho E / pi."""
    b = SceneBuilder()
    pm = b.add_material(Material.diffuse("plane", (RHO,) * 3))
    b.add_mesh("plane", np.array([[-50, -50, 0], [50, -50, 0], [50, 50, 0], [-50, 50, 0.0]]),
               np.array([[0, 1, 2], [0, 2, 3]]), pm)
    for light in lights:
        b.add_light(light)
    cam = Camera(type="ORTHO", ortho_scale=ortho, clip_start=0.01,
                 world_from_camera=look_at((0, 0, 0.05), (0, 0, 0), up=(0, 1, 0)))
    scene = b.build(cam, World(world))
    r = render(scene, RenderSettings(width=8, height=8, samples=samples, max_bounces=max_bounces,
                                     seed=5))
    img = r.combined[..., :3]
    err = np.sqrt(np.sum(r.variance.astype(float), axis=(0, 1))) / 64
    return img.mean(axis=(0, 1)), err, r


def assert_irradiance(lights, e_expected, **kw):
    mean, err, _ = plane_scene(lights, **kw)
    expected = RHO * np.asarray(e_expected) / np.pi
    assert np.all(np.abs(mean - expected) <= 5 * err + 1e-6 * expected), (mean, expected, err)
    return mean, err


def test_point_light_intensity_is_power_over_four_pi():
    p, h = 100.0, 2.0
    assert_irradiance([Light("lamp", "POINT", (p, p / 2, p / 4), at((0, 0, h)))],
                      np.array([1, 0.5, 0.25]) * p / (4 * np.pi * h * h))


def test_point_light_off_axis_has_cosine_and_inverse_square():
    p, h, x = 100.0, 2.0, 1.5
    d2 = h * h + x * x
    assert_irradiance([Light("lamp", "POINT", (p,) * 3, at((x, 0, h)))],
                      p / (4 * np.pi * d2) * (h / math.sqrt(d2)))


def test_sphere_light_matches_the_point_light_for_a_facing_point():
    """A uniform sphere of radiance P / (4 pi^2 r^2) gives E = pi L r^2 / h^2 = P / (4 pi h^2)."""
    p, h, r = 100.0, 2.0, 0.5
    assert_irradiance([Light("ball", "POINT", (p,) * 3, at((0, 0, h)), radius=r,
                             soft_falloff=False)], p / (4 * np.pi * h * h))


def test_soft_falloff_point_light_is_a_facing_disk():
    """Soft falloff: a disk of radius r facing the point: E = pi L r^2 / (h^2 + r^2)."""
    p, h, r = 100.0, 1.0, 0.5
    L = p / (4 * np.pi**2 * r * r)
    assert_irradiance([Light("disk", "POINT", (p,) * 3, at((0, 0, h)), radius=r,
                             soft_falloff=True)], np.pi * L * r * r / (h * h + r * r))


@pytest.mark.parametrize("x,expected_fraction", [(0.0, 1.0), (3.0, 0.0)])
def test_spot_cone_inside_and_outside(x, expected_fraction):
    p, h = 100.0, 2.0
    d2 = h * h + x * x
    lamp = Light("spot", "SPOT", (p,) * 3, at((x, 0, h)), spot_size=math.radians(60),
                 spot_blend=0.0)
    e = expected_fraction * p / (4 * np.pi * d2) * (h / math.sqrt(d2))
    assert_irradiance([lamp], e)


def test_spot_blend_is_the_smoothstep_of_the_cone():
    p, h = 100.0, 2.0
    size, blend = math.radians(90), 0.5
    x = h * math.tan(math.radians(40))  # 40 degrees off axis, inside the blend zone
    d2 = h * h + x * x
    cos_half = math.cos(size / 2)
    f = (h / math.sqrt(d2) - cos_half) / ((1 - cos_half) * blend)
    att = f * f * (3 - 2 * f)
    assert 0 < att < 1
    lamp = Light("spot", "SPOT", (p,) * 3, at((x, 0, h)), spot_size=size, spot_blend=blend)
    assert_irradiance([lamp], att * p / (4 * np.pi * d2) * (h / math.sqrt(d2)))


@pytest.mark.parametrize("angle", [0.0, math.radians(10)])
def test_sun_irradiance_is_its_strength_times_cosine(angle):
    s, tilt = 3.0, math.radians(30)
    m = at((0, 0, 5), (math.sin(tilt) * -5, 0, 5 - 5 * math.cos(tilt)))
    # A sun's position does not matter; it shines along its -Z.
    assert_irradiance([Light("sun", "SUN", (s,) * 3, m, angle=angle)], s * math.cos(tilt),
                      samples=128)


@pytest.mark.parametrize("shape", ["SQUARE", "RECTANGLE", "DISK"])
def test_area_light_radiance_is_power_over_pi_area(shape):
    p, h, side = 40.0, 1.0, 0.4
    size_y = side / 2 if shape == "RECTANGLE" else side
    area = side * size_y * (np.pi / 4 if shape == "DISK" else 1.0)
    L = p / (np.pi * area)
    if shape == "DISK":
        r = side / 2
        e = np.pi * L * r * r / (h * h + r * r)
    else:
        a, b = side / 2, size_y / 2

        def quadrant(x, y):  # irradiance below a corner of an x*y rectangle at height h
            return (x / math.sqrt(x * x + h * h) * math.atan(y / math.sqrt(x * x + h * h))
                    + y / math.sqrt(y * y + h * h) * math.atan(x / math.sqrt(y * y + h * h))) / 2
        e = L * 4 * quadrant(a, b)
    lamp = Light("panel", "AREA", (p,) * 3, at((0, 0, h)), shape=shape, size_x=side, size_y=size_y)
    assert_irradiance([lamp], e, samples=128)


def test_area_light_scale_enters_the_area():
    p, h = 40.0, 3.0
    m = at((0, 0, h))
    m[:3, :3] *= 2.0  # object scale 2: four times the area, a quarter of the radiance
    small = Light("panel", "AREA", (p,) * 3, m, size_x=0.1)
    mean, _, _ = plane_scene([small], samples=32)
    # Far away the panel acts like a point source of intensity P cos / pi.
    assert mean[0] == pytest.approx(RHO * p / (np.pi * h * h) / np.pi, rel=0.01)


def test_area_light_back_side_is_dark_and_lights_do_not_cast_shadows():
    p, h = 40.0, 1.0
    facing_up = Light("panel", "AREA", (p,) * 3, at((0, 0, h), (0, 0, h + 1)), size_x=0.4)
    mean, _, _ = plane_scene([facing_up], samples=8)
    assert np.all(mean == 0)
    # A point light sitting under an area light still reaches the plane.
    mean, _, _ = plane_scene([facing_up, Light("lamp", "POINT", (p,) * 3, at((0, 0, 2 * h)))],
                             samples=8)
    assert mean[0] > 0


def test_camera_sees_the_front_of_an_area_light_and_through_it():
    """Lights are transparent in Cycles: a camera ray adds L and continues to the world."""
    for eye, expected in (((0, 0, -3), 10.0 + 0.25), ((0, 0, 3), 0.25)):
        b = SceneBuilder()
        area = 4.0
        b.add_light(Light("panel", "AREA", (10.0 * np.pi * area,) * 3, at((0, 0, 0)), size_x=2.0,
                          visible_camera=True))
        scene = b.build(Camera(world_from_camera=look_at(eye, (0, 0, 0), up=(0, 1, 0)),
                               lens_mm=80), World((0.25, 0.25, 0.25)))
        r = render(scene, RenderSettings(width=8, height=8, samples=2, max_bounces=0))
        assert np.allclose(r.combined[3:5, 3:5, :3], expected), (eye, r.combined[4, 4])


def test_lights_are_invisible_to_the_camera_by_default():
    """Blender lights default to visible_camera off: the camera sees the world only."""
    b = SceneBuilder()
    b.add_light(Light("panel", "AREA", (100.0,) * 3, at((0, 0, 0)), size_x=2.0))
    scene = b.build(Camera(world_from_camera=look_at((0, 0, -3), (0, 0, 0), up=(0, 1, 0)),
                           lens_mm=80), World((0.25, 0.25, 0.25)))
    r = render(scene, RenderSettings(width=8, height=8, samples=2, max_bounces=0))
    assert np.allclose(r.combined[..., :3], 0.25)


def test_lights_share_one_power_distribution():
    """Two point lights chosen by power: the estimate is the sum of both."""
    p, h = 100.0, 2.0
    lamp = Light("lamp", "POINT", (p,) * 3, at((0, 0, h)))
    e_point = p / (4 * np.pi * h * h)
    mean_point, err_point, _ = plane_scene([lamp])
    assert abs(mean_point[0] - RHO * e_point / np.pi) < 5 * err_point[0] + 1e-6 * mean_point[0]
    b_mean, b_err, r = plane_scene([lamp, Light("lamp2", "POINT", (2 * p,) * 3, at((0, 0, h)))])
    assert abs(b_mean[0] - 3 * RHO * e_point / np.pi) < 5 * b_err[0] + 1e-6 * b_mean[0]
    assert r.plan.light_objects == 2 and "sample light" in r.plan.stages()


def test_invalid_light_raises_naming_it():
    with pytest.raises(ValueError, match="light 'Key'"):
        SceneBuilder().add_light(Light("Key", "POINT", (-1.0, 0, 0)))
    with pytest.raises(ValueError, match="light 'Key'.*type"):
        SceneBuilder().add_light(Light("Key", "LASER", (1.0, 1, 1)))


def many_lights_scene(n=30, seed=4):
    r = np.random.default_rng(seed)
    lights = [Light(f"L{i}", "POINT", tuple(r.uniform(5, 50, 3)),
                    at((r.uniform(-5, 5), r.uniform(-5, 5), r.uniform(0.5, 3))))
              for i in range(n)]
    return lights


def test_many_lights_use_the_spatial_grid_and_stay_unbiased():
    """With many emitters the choice is spatially aware; the estimate still equals the
    sum of each light's closed-form irradiance."""
    lights = many_lights_scene()
    e = np.zeros(3)
    for light in lights:
        pos = np.asarray(light.matrix)[:3, 3]
        d2 = float(pos @ pos)
        e += np.asarray(light.power) / (4 * np.pi * d2) * (pos[2] / math.sqrt(d2))
    mean, err, r = plane_scene(lights, samples=256)
    expected = RHO * e / np.pi
    assert np.all(np.abs(mean - expected) <= 5 * err + 1e-6 * expected), (mean, expected, err)


def test_spatial_choice_samples_its_own_pmf(rng):
    """choose() draws entries with exactly the probabilities entry_pmf() reports (used by
    MIS)."""
    from engine.lights import LightSampler, choose, entry_pmf

    b = SceneBuilder()
    pm = b.add_material(Material.diffuse("plane", (RHO,) * 3))
    b.add_mesh("plane", np.array([[-5, -5, 0], [5, -5, 0], [5, 5, 0], [-5, 5, 0.0]]),
               np.array([[0, 1, 2], [0, 2, 3]]), pm)
    for light in many_lights_scene(12):
        b.add_light(light)
    sampler = LightSampler(b.build(Camera(), World()))
    assert hasattr(sampler, "local_pmf")
    em = sampler.data()
    assert em.grid > 0
    n = 200_000
    p = (3.0, -4.0, 0.0)
    chosen = [choose(*p, u, em.pmf, em.cdf, em.grid, em.lo, em.cell, em.local_pmf,
                     em.local_cdf_flat, em.has_mass) for u in rng.random(n)]
    k = np.array([c[0] for c in chosen])
    pm_k = np.array([c[1] for c in chosen])
    probs = np.array([entry_pmf(*p, e, em.pmf, em.grid, em.lo, em.cell, em.local_pmf,
                                em.has_mass) for e in range(len(sampler))])
    assert probs.sum() == pytest.approx(1.0)
    counts = np.bincount(k, minlength=len(sampler))
    expected = probs * n
    assert np.allclose(pm_k, probs[k])  # p is the same for every draw
    from tests.stats import chi2_test
    pval, _ = chi2_test(counts, expected)
    assert pval > 1e-3
    # The local part favours the nearest light over the global power order.
    local_best = np.argmax(probs)
    pos = np.array([np.asarray(light.matrix)[:3, 3] for light in many_lights_scene(12)])
    d2 = np.sum((pos - [3.0, -4.0, 0.0]) ** 2, axis=1)
    power = np.array([np.mean(light.power) for light in many_lights_scene(12)])
    assert local_best == np.argmax(power / np.maximum(d2, 1e-3)) or \
        probs[local_best] > sampler.distribution.pmf[local_best]


def unequal_lights():
    """Issue 16's pair: a 1000 W point light far up and a 25 W area light low down."""
    return [Light("far point", "POINT", (1000.0,) * 3, at((-4.5, -1, 4)), radius=0.1),
            Light("low panel", "AREA", (25.0,) * 3, at((3.5, -0.5, 0.6)), size_x=0.5)]


def test_few_lights_are_chosen_by_their_importance_at_the_point(rng):
    """With few emitters each point weighs them by intensity / d^2 and both ends'
    cosines: under the low panel the panel is chosen most, far from it the point light,
    above the panel's plane (behind it) the panel only by the 1 % power share, and so is
    the point light for a surface facing away from it.
    choose_by_importance draws entries with the probabilities importance_pmf reports."""
    from engine.lights import (IMPORTANCE_WEIGHT, LightSampler, choose_by_importance,
                               importance_pmf)

    b = SceneBuilder()
    pm = b.add_material(Material.diffuse("plane", (RHO,) * 3))
    b.add_mesh("plane", np.array([[-5, -5, 0], [5, -5, 0], [5, 5, 0], [-5, 5, 0.0]]),
               np.array([[0, 1, 2], [0, 2, 3]]), pm)
    for light in unequal_lights():
        b.add_light(light)
    sampler = LightSampler(b.build(Camera(), World()))
    assert hasattr(sampler, "bounds") and not hasattr(sampler, "local_pmf")
    em = sampler.data()
    power = em.pmf

    def probs(p):
        return np.array([importance_pmf(*p, *up, e, em.pmf, em.bounds) for e in range(2)])

    up = (0.0, 0.0, 1.0)  # the plane's shading normal
    under, far, behind = (3.5, -0.5, 0.0), (-4.0, -1.0, 0.0), (3.5, -0.5, 1.5)
    assert probs(under)[1] > 0.8 > power[1]
    assert probs(far)[0] > 0.95
    assert probs(behind)[1] == pytest.approx((1 - IMPORTANCE_WEIGHT) * power[1])
    facing_away = probs(far)
    up = (1.0, 0.0, 0.0)  # a wall at x = -4 facing +x, away from the point light at -4.5
    assert probs(far)[0] == pytest.approx((1 - IMPORTANCE_WEIGHT) * power[0])
    up = (0.0, 0.0, 1.0)
    assert np.allclose(probs(far), facing_away)
    for p in (under, far, behind):
        assert probs(p).sum() == pytest.approx(1.0)
        n = 100_000
        draws = [choose_by_importance(*p, *up, u, em.pmf, em.cdf, em.bounds)
                 for u in rng.random(n)]
        k = np.array([d[0] for d in draws])
        assert np.allclose([d[1] for d in draws], probs(p)[k])
        expected = probs(p) * n
        z = (np.bincount(k, minlength=2) - expected) / np.sqrt(expected * (1 - probs(p)))
        assert np.all(np.abs(z) < 4.5), z


@pytest.mark.parametrize("x", [3.5, 0.0, -4.0])
def test_unequal_lights_stay_unbiased(x):
    """Chosen by importance, the two lights' irradiance is still the sum of their closed
    forms, under the panel, between and far from it."""
    from dataclasses import replace

    shift = np.eye(4)
    shift[0, 3] = -x  # move the lights, not the plane's camera
    point, panel = (replace(light, matrix=shift @ light.matrix) for light in unequal_lights())
    pos = np.asarray(point.matrix)[:3, 3]
    d2 = float(pos @ pos)
    e = 1000.0 / (4 * np.pi * d2) * (pos[2] / math.sqrt(d2))
    # The panel: four corner rectangles (signed) of the 0.5 m square at height 0.6.
    c, h, s = np.asarray(panel.matrix)[:3, 3], 0.6, 0.25
    L = 25.0 / (np.pi * 0.25)

    def corner(x_, y_):  # signed irradiance below a corner of an x_ * y_ rectangle
        sx, sy, x_, y_ = np.sign(x_), np.sign(y_), abs(x_), abs(y_)
        return sx * sy * (x_ / math.hypot(x_, h) * math.atan(y_ / math.hypot(x_, h))
                          + y_ / math.hypot(y_, h) * math.atan(x_ / math.hypot(y_, h))) / 2

    e += L * (corner(c[0] + s, c[1] + s) - corner(c[0] - s, c[1] + s)
              - corner(c[0] + s, c[1] - s) + corner(c[0] - s, c[1] - s))
    assert_irradiance([point, panel], e, samples=128)


@pytest.mark.parametrize("kind,soft", [("POINT", True), ("POINT", False), ("SPOT", True),
                                       ("SPOT", False)])
def test_light_path_lines_carry_what_path_tracing_sees(kind, soft, rng):
    """A point or spot light's light paths are lines (lights.sphere_light_line): at every
    point along one, a ray cast back along it hits the light (intersect_object, path
    tracing's view: a sphere, or with Soft Falloff a disk facing the point) exactly where
    the line is lit, from `near` on, with the radiance the line carries. And the lines are
    drawn uniformly in the throughput measure: radiance / p_emit is the light's power
    (within its cone)."""
    from engine.caustics import caustic_data
    from engine.lights import LightSampler, intersect_object, sphere_light_line

    r, power = 0.3, 7.0
    b = SceneBuilder()
    gm = b.add_material(Material.glass("glass", (1, 1, 1), 1.5))
    b.add_mesh("glass", np.array([[-5, -5, 0], [5, -5, 0], [5, 5, 0.0]]),
               np.array([[0, 1, 2]]), gm)
    b.add_light(Light("l", kind, (power,) * 3, look_at((0.2, 0.1, 2.0), (0.5, 0.0, 0.0)),
                      radius=r, soft_falloff=soft, spot_size=math.radians(60.0)))
    sampler = LightSampler(b.build(Camera(), World()))
    L, ca = sampler.data().objects, caustic_data(1.0, sampler)
    assert list(ca.light) == [0]
    lit = unlit = 0
    for u in rng.random((400, 4)):
        ox, oy, oz, wx, wy, wz, near, r0, r1, r2 = sphere_light_line(0, ca.cos_cone[0], *u, L)
        assert r0 == r1 == r2 >= 0.0
        if kind == "POINT":
            assert r0 / ca.pdf_emit[0] == pytest.approx(power, rel=1e-12)
        for s in rng.random(8) * 4.0 * r:
            if abs(s - near) < 1e-9:
                continue
            th, l0, _, _ = intersect_object(0, ox + s * wx, oy + s * wy, oz + s * wz, -wx, -wy,
                                            -wz, np.inf, L)
            assert math.isfinite(th) == (s > near), (s, near, th)
            if s > near:
                lit += 1
                assert l0 == pytest.approx(r0, rel=1e-9)
            else:
                unlit += 1
    assert lit > 1000 and (unlit > 100 if soft else unlit == 0)

"""Emitters and throughput: zero-area and zero-strength emitters, strength 1e6, and
Russian roulette with survival probabilities near zero."""

import warnings

import numpy as np
import pytest

from engine import Camera, Light, Material, RenderSettings, SceneBuilder, World, render
from tests.robustness.helpers import all_finite, image_mean_and_error, look_at

FLOOR = np.array([[-50, -50, 0], [50, -50, 0], [50, 50, 0], [-50, 50, 0.0]])
TWO = np.array([[0, 1, 2], [0, 2, 3]])


def lamp_over_floor(builder_hook, world=(0.0, 0.0, 0.0), samples=16, lamp_strength=50.0):
    """A small square lamp 1 above a Lambert floor (albedo 0.5), seen from above by a tiny
    orthographic camera; `builder_hook(b)` adds the emitters under test."""
    b = SceneBuilder()
    lm = b.add_material(Material.emission_only("lamp", (1, 1, 1), lamp_strength))
    pm = b.add_material(Material.diffuse("floor", (0.5,) * 3))
    s = 0.025
    b.add_mesh("lamp", np.array([[-s, -s, 1], [s, -s, 1], [s, s, 1], [-s, s, 1.0]]),
               np.array([[0, 2, 1], [0, 3, 2]]), lm)
    b.add_mesh("floor", FLOOR, TWO, pm)
    builder_hook(b)
    cam = Camera(type="ORTHO", ortho_scale=0.002,
                 world_from_camera=look_at((0, 0, 0.5), (0, 0, 0), up=(0, 1, 0)))
    return render(b.build(cam, World(world)),
                  RenderSettings(width=8, height=8, samples=samples, max_bounces=1, seed=5))


def expected_under_lamp(strength, rho=0.5, side=0.05, h=1.0):
    a = 0.5 * side / h
    e = strength * 4 * (a / np.sqrt(1 + a * a)) * np.arctan(a / np.sqrt(1 + a * a))
    return rho * e / np.pi


@pytest.mark.slow
def test_zero_area_and_zero_strength_emitters_change_nothing():
    """Add a degenerate emitting triangle (dropped with a warning), one of area 1e-22
    (kept: light sampling divides by its area), an emitter of strength 0, an area light of
    size 0, a point light of power 0 and a spot of radius 0 placed on the floor itself:
    finite, and the same mean as the lamp alone."""
    def hook(b):
        bright = b.add_material(Material.emission_only("bright", (1, 1, 1), 1e3))
        dark = b.add_material(Material.emission_only("dark", (1, 1, 1), 0.0))
        b.add_mesh("degenerate", np.array([[0, 0, 0.5], [1, 0, 0.5], [2, 0, 0.5]]),
                   [[0, 1, 2]], bright)
        b.add_mesh("speck", np.array([[3, 3, 0.5], [3 + 1e-11, 3, 0.5], [3, 3 + 1e-11, 0.5]]),
                   [[0, 1, 2]], bright)
        b.add_mesh("off", np.array([[-3, 3, 0.5], [-2, 3, 0.5], [-2, 4, 0.5]]), [[0, 1, 2]],
                   dark)
        b.add_light(Light("flat area", "AREA", (100.0, 100.0, 100.0),
                          matrix=np.eye(4), size_x=0.0,
                          size_y=0.0))
        b.add_light(Light("off point", "POINT", (0.0, 0.0, 0.0)))
        m = np.eye(4)
        m[:3, 3] = (0.001, 0.0, 0.0)  # on the floor, 1 mm from the shading points
        b.add_light(Light("spot on floor", "SPOT", (0.0, 0.0, 0.0), matrix=m))

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        r = lamp_over_floor(hook, samples=64)
    assert any("degenerate" in str(w.message) for w in caught)
    mean, err = image_mean_and_error(r)
    expected = expected_under_lamp(50.0)
    assert all_finite(r)
    # The speck adds radiance 1e3 x 1e-22 / 12.25 ~ 1e-20: nothing.
    assert abs(mean - expected) < 5 * err + 1e-6, (mean, expected, err)


@pytest.mark.slow
def test_strength_1e6_gives_finite_pixels_and_the_right_mean():
    """The closed form for a small lamp over a floor, at strength 1e6: finite pixels, the
    mean within 5 standard errors, and the lamp itself seen at exactly 1e6."""
    r = lamp_over_floor(lambda b: None, lamp_strength=1e6, samples=64)
    mean, err = image_mean_and_error(r)
    expected = expected_under_lamp(1e6)
    assert all_finite(r)
    assert abs(mean - expected) < 5 * err + 2e-3 * expected, (mean, expected, err)
    b = SceneBuilder()
    m = b.add_material(Material.emission_only("sun-like", (1, 1, 1), 1e6))
    b.add_mesh("panel", np.array([[-2, 0, -2], [2, 0, -2], [2, 0, 2], [-2, 0, 2.0]]), TWO, m)
    seen = render(b.build(Camera(world_from_camera=look_at((0, -3, 0), (0, 0, 0))), World()),
                  RenderSettings(width=8, height=8, samples=2, max_bounces=0))
    assert np.all(seen.combined[2:6, 2:6, :3] == 1e6) and all_finite(seen)


def test_russian_roulette_never_divides_by_a_tiny_survival_probability():
    """Throughputs down to the smallest subnormal, and 0: survivors are divided by
    q = min(sqrt(max channel), 1) >= their throughput, so the result is at most
    sqrt(throughput) <= 1 and finite; q = 0 never survives (no 0/0)."""
    from engine import integrator
    from engine.jit import INLINE, njit

    roulette = njit(**INLINE)(integrator.russian_roulette)
    pseed = np.uint64(12345)
    for t in (1.0, 0.5, 1e-8, 1e-300, 5e-324, 0.0):
        alive, t0, t1, t2 = roulette(5, 5, t, t * 0.5, 0.0, pseed, np.uint64(0))
        assert np.isfinite([t0, t1, t2]).all()
        if alive:
            assert t0 <= 1.0 and t0 <= np.sqrt(t) * (1 + 1e-12)
        if t == 0.0:
            assert not alive
    # Before the roulette bounce nothing is touched.
    assert roulette(1, 1, 1e-300, 0.0, 0.0, pseed, np.uint64(0)) == (True, 1e-300, 0.0, 0.0)

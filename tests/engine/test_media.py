"""Absorbing media (media.py): Cycles' volume stack and Beer-Lambert transmittance, through
glass into closed meshes, along camera paths and shadow rays."""

import math

import numpy as np
import pytest

from engine import Camera, Light, Material, RenderSettings, SceneBuilder, World, render
from engine.media import MEDIA_STACK, carry, extinction, transmittance
from tests import scenes

SIGMA = (0.3, 1.2, 2.5)


def _stack(*mats):
    media = np.full((2, MEDIA_STACK), -1, np.int64)
    media[0, :len(mats)] = mats
    return media


def test_the_stack_enters_and_leaves_as_cycles_volume_stack():
    """Crossing a front face pushes the material's medium, a back face removes it; a
    surface without a medium changes nothing; coefficients of nested media add up."""
    absorption = np.array([[0.0, 0.0, 0.0], [1.0, 2.0, 3.0], [0.5, 0.5, 0.5]])
    media = _stack(1)
    assert extinction(media, 0, absorption, 2, True, True) == (1.5, 2.5, 3.5)  # into 2
    assert extinction(media, 0, absorption, 1, False, True) == (0.0, 0.0, 0.0)  # out of 1
    assert extinction(media, 0, absorption, 1, True, False) == (1.0, 2.0, 3.0)  # reflected
    assert extinction(media, 0, absorption, 0, True, True) == (1.0, 2.0, 3.0)  # no medium
    carry(media, 0, 1, absorption, 2, True, True)
    assert list(media[1]) == [1, 2] + [-1] * (MEDIA_STACK - 2)
    carry(media, 1, 1, absorption, 1, False, True)  # in place: leaves 1, keeps 2
    assert list(media[1]) == [2] + [-1] * (MEDIA_STACK - 1)
    carry(media, 1, 0, absorption, 2, True, True)  # entering again what it is in: once
    assert list(media[0]) == [2] + [-1] * (MEDIA_STACK - 1)


def test_transmittance_is_one_where_nothing_absorbs_even_to_infinity():
    assert transmittance(0.0, 1.0, 0.0, math.inf) == (1.0, 0.0, 1.0)
    assert transmittance(2.0, 0.0, 0.5, 0.5) == pytest.approx((math.exp(-1), 1.0,
                                                                math.exp(-0.25)))


def _boundary(name, sigma):
    """A closed box's surface that bends and reflects nothing (glass of IOR 1) around a
    medium absorbing sigma per unit length: what a Volume-only material exports as."""
    return Material(name, "glass", (1, 1, 1), 1.0, absorption=tuple(sigma))


def _looking_down(b, world=(1.0, 1.0, 1.0), scale=0.5, **kw):
    cam = Camera(type="ORTHO", ortho_scale=scale,
                 world_from_camera=scenes.look_at((0, 0, 3), (0, 0, 0), up=(0, 1, 0)))
    return render(b.build(cam, World(world)), RenderSettings(
        width=4, height=4, samples=kw.pop("samples", 1), max_bounces=kw.pop("max_bounces", 4),
        seed=3, **kw))


def test_a_ray_through_an_absorbing_box_keeps_exp_minus_sigma_d():
    """Through a 1-unit box of absorbing medium behind an IOR-1 boundary, the world is seen
    attenuated by exactly exp(-sigma), per channel; nested inside a second box, the inner
    0.4 units absorb by both media (Cycles sums the stack). Tolerance: the float32 film and
    the rays' offsets off each surface (2^-18 of the coordinates' scale)."""
    b = SceneBuilder()
    v, t = scenes.closed_box((-1, -1, -0.5), (1, 1, 0.5))
    b.add_mesh("box", v, t, b.add_material(_boundary("medium", SIGMA)))
    out = _looking_down(b).combined[..., :3]
    np.testing.assert_allclose(out, np.broadcast_to(np.exp(-np.array(SIGMA)), out.shape),
                               rtol=1e-4)
    inner = (0.4, 0.0, 1.0)
    v, t = scenes.closed_box((-0.5, -0.5, -0.2), (0.5, 0.5, 0.2))
    b.add_mesh("inner", v, t, b.add_material(_boundary("inner medium", inner)))
    # Four crossings: Russian roulette (from the third vertex) makes the pixels random, with
    # the expected value; 16384 paths put it within 1% (5 standard errors: 3%).
    out = _looking_down(b, samples=1024).combined[..., :3].reshape(-1, 3).mean(axis=0)
    expected = np.exp(-np.array(SIGMA) - 0.4 * np.array(inner))
    np.testing.assert_allclose(out, expected, rtol=0.03)
    summed_not = np.exp(-0.6 * np.array(SIGMA) - 0.4 * np.array(inner))  # inner replaces outer
    assert not np.allclose(out, summed_not, rtol=0.03)


def test_shadow_rays_inside_a_medium_are_attenuated_over_their_length():
    """A floor and a point light inside an absorbing box, seen from above: the pixel is
    attenuated by the camera ray's way in (0.8) and the shadow ray's length, exactly."""
    def floor_pixel(sigma):
        b = SceneBuilder()
        v, t = scenes.closed_box((-1, -1, -0.5), (1, 1, 0.5))
        b.add_mesh("box", v, t, b.add_material(_boundary("medium", sigma)))
        v, t = scenes.quad((-0.9, -0.9, -0.3), (0.9, -0.9, -0.3), (0.9, 0.9, -0.3),
                           (-0.9, 0.9, -0.3))
        b.add_mesh("floor", v, t, b.add_material(Material.diffuse("floor", (0.5, 0.5, 0.5))))
        m = np.eye(4)
        m[:3, 3] = (0.2, 0.0, 0.1)
        b.add_light(Light("lamp", "POINT", (10.0, 10.0, 10.0), m, radius=0.0))
        return _looking_down(b, world=(0, 0, 0), scale=1e-4, max_bounces=1).combined[..., :3]

    r = math.hypot(0.2, 0.4)
    ratio = floor_pixel(SIGMA) / floor_pixel((0.0, 0.0, 0.0))
    expected = np.exp(-np.array(SIGMA) * (0.8 + r))
    np.testing.assert_allclose(ratio, np.broadcast_to(expected, ratio.shape), rtol=1e-3)


def test_a_scene_without_media_plans_none():
    from engine.plan import make_plan

    plain = make_plan(scenes.cbspheres(), scenes.settings())
    assert not plain.volumes and not plain.kernel_constants(False)["HAS_VOLUMES"]
    b = SceneBuilder()
    v, t = scenes.closed_box((-1, -1, -0.5), (1, 1, 0.5))
    b.add_mesh("box", v, t, b.add_material(_boundary("medium", SIGMA)))
    cam = Camera(type="ORTHO", world_from_camera=scenes.look_at((0, 0, 3), (0, 0, 0), (0, 1, 0)))
    plan = make_plan(b.build(cam, World((1, 1, 1))), scenes.settings())
    assert plan.volumes and "absorb in media" in plan.stages()
    # An opaque surface never lets a path into its medium: nothing to plan.
    b = SceneBuilder()
    b.add_mesh("box", v, t, b.add_material(Material("opaque", absorption=SIGMA)))
    assert not make_plan(b.build(cam, World((1, 1, 1))), scenes.settings()).volumes

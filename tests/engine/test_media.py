"""Absorbing media (media.py): Cycles' volume stack and Beer-Lambert transmittance, through
glass into closed meshes, along camera paths and shadow rays."""

import math

import numpy as np
import pytest

from engine import Camera, Light, Material, RenderSettings, SceneBuilder, World, render
from engine.media import MEDIA_STACK, carry, extinction, medium_table, transmittance
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
    absorption = medium_table(absorption, np.zeros((3, 3)), np.zeros(3), np.zeros((3, 3)))
    media = _stack(1)
    assert extinction(media, 0, absorption, 2, True, True) == (1.5, 2.5, 3.5)  # into 2
    assert extinction(media, 0, absorption, 1, False, True) == (0.0, 0.0, 0.0)  # out of 1
    assert extinction(media, 0, absorption, 1, True, False) == (1.0, 2.0, 3.0)  # reflected
    assert extinction(media, 0, absorption, 0, True, True) == (1.0, 2.0, 3.0)  # no medium
    carry(media, 0, media, 1, absorption, 2, True, True)
    assert list(media[1]) == [1, 2] + [-1] * (MEDIA_STACK - 2)
    carry(media, 1, media, 1, absorption, 1, False, True)  # in place: leaves 1, keeps 2
    assert list(media[1]) == [2] + [-1] * (MEDIA_STACK - 1)
    carry(media, 1, media, 0, absorption, 2, True, True)  # entering again what it is in: once
    assert list(media[0]) == [2] + [-1] * (MEDIA_STACK - 1)


def test_transmittance_is_one_where_nothing_absorbs_even_to_infinity():
    assert transmittance(0.0, 1.0, 0.0, math.inf) == (1.0, 0.0, 1.0)
    assert transmittance(2.0, 0.0, 0.5, 0.5) == pytest.approx((math.exp(-1), 1.0,
                                                                math.exp(-0.25)))


def _boundary(name, sigma):
    """A closed box's surface that is none around a medium absorbing sigma per unit
    length: what a Volume-only material exports as."""
    return Material.boundary(name, absorption=tuple(sigma))


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


# ---- scattering and emission -------------------------------------------------------------

def _fog_box(b, name="fog", **medium):
    v, t = scenes.closed_box((-1, -1, -0.5), (1, 1, 0.5))
    b.add_mesh("box", v, t, b.add_material(Material.boundary(name, **medium)))


def _mean(result):
    return result.combined[..., :3].reshape(-1, 3).mean(axis=0)


def test_a_scattering_medium_in_a_white_furnace_conserves_energy():
    """A Volume-only box that scatters without absorbing, in a uniform white world: every
    path leaves the box unattenuated, so every pixel is 1 in every channel, whatever the
    scattering's colour (each channel's coefficient differs: the distance sampled in one
    channel is weighted for all three) and anisotropy. 64 bounces: paths scattering more
    often in a box of optical depth <= 4 are negligible. A renderer that weighs each
    distance by the sampled channel's density alone (its weights then grow without bound
    where the channels' coefficients differ) read 0.945 in red here (measured)."""
    for g in (0.0, 0.7):
        b = SceneBuilder()
        _fog_box(b, scattering=(1.0, 2.0, 4.0), anisotropy=g)
        mean = _mean(_looking_down(b, scale=1.0, samples=64, max_bounces=64))
        # 4096 paths per channel; their spread measured below 1 % of the mean.
        np.testing.assert_allclose(mean, 1.0, atol=0.03)


def test_single_scattering_of_a_sun_matches_its_integral():
    """A sun straight above a slab (thickness 1) of scattering and absorbing medium, seen
    from above with max_bounces 0: each pixel is the single-scattered sunlight, E sigma_s
    HG(-1, g) (1 - exp(-2 sigma_t)) / (2 sigma_t) (the light goes down to depth t and back
    up: HG of the cosine -1 between the propagation directions). Forward scattering sends
    little back, backward much: the sign of g matters by a factor of 64."""
    sigma_s, sigma_a = np.array([0.5, 1.0, 2.0]), np.array([0.3, 0.0, 0.1])
    sigma_t = sigma_s + sigma_a
    for g in (0.6, -0.6):
        b = SceneBuilder()
        _fog_box(b, scattering=tuple(sigma_s), absorption=tuple(sigma_a), anisotropy=g)
        b.add_light(Light("sun", "SUN", (2.0, 2.0, 2.0)))
        got = _mean(_looking_down(b, world=(0, 0, 0), scale=1.0, samples=256, max_bounces=0))
        hg = (1 - g * g) / (4 * math.pi * (1 + g * g + 2 * g) ** 1.5)
        expected = 2.0 * sigma_s * hg * -np.expm1(-2 * sigma_t) / (2 * sigma_t)
        # The only noise is the distance's: measured within 0.2 %.
        np.testing.assert_allclose(got, expected, rtol=0.01)


def test_an_emitting_medium_adds_its_integral_along_the_ray():
    """A Volume-only slab (thickness 1) that emits e per unit length and absorbs sigma_a,
    over a black world: the camera sees e (1 - exp(-sigma_a)) / sigma_a, exactly (no
    sampling), and e where nothing absorbs."""
    e = np.array([1.0, 2.0, 0.5])
    sigma = np.array([0.0, 1.0, 3.0])
    b = SceneBuilder()
    _fog_box(b, absorption=tuple(sigma), volume_emission=tuple(e))
    got = _looking_down(b, world=(0, 0, 0)).combined[..., :3]
    expected = np.where(sigma > 0, e * -np.expm1(-sigma) / np.maximum(sigma, 1e-300), e)
    np.testing.assert_allclose(got, np.broadcast_to(expected, got.shape), rtol=1e-4)


def test_henyey_greenstein_sampling_matches_its_density():
    """Directions sampled from the phase function have the density it evaluates to: a
    histogram of their cosines to the propagation direction against the integral of HG
    over each bin (seeded; 200000 samples, bins' expected counts >= 1000)."""
    from engine.media import henyey_greenstein, sample_henyey_greenstein

    rng = np.random.default_rng(7)
    d = np.array([0.3, -0.5, 0.8])
    d /= np.linalg.norm(d)
    edges = np.linspace(-1.0, 1.0, 21)
    for g in (0.0, 0.5, -0.8):
        u = rng.random((200000, 2))
        cos = np.empty(len(u))
        for k, (ua, ub) in enumerate(u):
            wx, wy, wz, pdf = sample_henyey_greenstein(d[0], d[1], d[2], g, ua, ub)
            cos[k] = wx * d[0] + wy * d[1] + wz * d[2]
            if k < 100:
                assert pdf == pytest.approx(henyey_greenstein(cos[k], g), rel=1e-6)
        counts, _ = np.histogram(cos, edges)
        fine = np.linspace(-1.0, 1.0, 20001)
        density = np.array([2 * math.pi * henyey_greenstein(c, g) for c in fine])
        cdf = np.concatenate([[0.0], np.cumsum((density[1:] + density[:-1]) / 2 * np.diff(fine))])
        expected = np.diff(np.interp(edges, fine, cdf)) * len(u)
        assert cdf[-1] == pytest.approx(1.0, rel=1e-4)
        z = (counts - expected) / np.sqrt(expected)
        assert np.max(np.abs(z)) < 4.5, (g, z)


def test_volume_boundaries_are_not_transparent_bounces_for_paths():
    """Cycles counts a camera path's volume boundary crossings apart from its transparent
    bounces: with transparent_max_bounces 1 the world is still seen through two nested
    absorbing boxes (four crossings), attenuated by both."""
    b = SceneBuilder()
    _fog_box(b, absorption=SIGMA)
    v, t = scenes.closed_box((-0.5, -0.5, -0.2), (0.5, 0.5, 0.2))
    b.add_mesh("inner", v, t, b.add_material(_boundary("inner medium", (0.4, 0.0, 1.0))))
    out = _mean(_looking_down(b, transparent_max_bounces=1, max_bounces=1))
    np.testing.assert_allclose(out, np.exp(-np.array(SIGMA) - 0.4 * np.array((0.4, 0.0, 1.0))),
                               rtol=1e-3)


def test_a_scattering_medium_plans_its_stages():
    from engine.plan import make_plan

    b = SceneBuilder()
    _fog_box(b, scattering=(1.0, 1.0, 1.0))
    cam = Camera(type="ORTHO", world_from_camera=scenes.look_at((0, 0, 3), (0, 0, 0), (0, 1, 0)))
    b.add_light(Light("sun", "SUN", (1.0, 1.0, 1.0)))
    plan = make_plan(b.build(cam, World((0, 0, 0))), scenes.settings())
    constants = plan.kernel_constants(False)
    assert plan.volumes and plan.scattering and plan.transparency and plan.light_sampling
    assert constants["HAS_SCATTERING"] and constants["HAS_LIGHT_SAMPLING"]
    b = SceneBuilder()
    _fog_box(b, absorption=SIGMA)
    absorbing = make_plan(b.build(cam, World((1, 1, 1))), scenes.settings())
    assert absorbing.volumes and not absorbing.kernel_constants(False)["HAS_SCATTERING"]


def _box_triangles(lo, hi, flip=False):
    v, t = scenes.closed_box(lo, hi)
    tri = np.asarray(v, np.float64)[np.asarray(t)]
    return tri[:, ::-1] if flip else tri


def test_the_camera_starts_in_the_media_around_it():
    """media.enclosing, as Cycles' volume_stack_init: the world's volume first, then each
    medium whose mesh a ray along +z leaves before entering; nested boxes both, a box
    beside or above the camera (entered first along the ray) not, a box the ray misses
    not, and no medium twice."""
    from engine.media import enclosing

    outer = _box_triangles((-4, -4, -4), (4, 4, 4))
    inner = _box_triangles((-1, -1, -1), (1, 1, 1))
    above = _box_triangles((-1, -1, 2), (1, 1, 3))
    aside = _box_triangles((5, 5, -1), (6, 6, 1))
    tri = np.concatenate([outer, inner, above, aside])
    mats = np.repeat([3, 5, 7, 9], 12)
    empty = [-1] * MEDIA_STACK
    # (in the order the ray leaves them; the stack's order does not matter)
    assert list(enclosing((0, 0, 0), tri, mats, [3, 5, 7, 9])) == [5, 3] + empty[2:]
    assert list(enclosing((0, 0, 1.5), tri, mats, [3, 5, 7, 9])) == [3] + empty[1:]
    assert list(enclosing((0, 0, 0), tri, mats, [5], world_row=11)) == [11, 5] + empty[2:]
    assert list(enclosing((0, 0, 10), tri, mats, [3, 5, 7, 9])) == empty
    # Two boxes of one material around the camera: it is in that medium once.
    twice = np.concatenate([inner, _box_triangles((-2, -2, -2), (2, 2, 2))])
    assert list(enclosing((0, 0, 0), twice, np.full(24, 4), [4])) == [4] + empty[1:]
    # A box whose faces point inwards is entered along the ray, not left: not around it.
    assert list(enclosing((0, 0, 0), _box_triangles((-1, -1, -1), (1, 1, 1), flip=True),
                          np.full(12, 4), [4])) == empty

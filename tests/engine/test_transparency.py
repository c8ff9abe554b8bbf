"""Transparent surfaces (scene.Material.transparent, a Principled BSDF's alpha as a mix):
paths and shadow rays cross them straight, tinted, without counting a bounce, up to
Cycles' transparent bounce limit; MIS keeps the scattering vertex's state across them."""

from dataclasses import replace

import numpy as np
import pytest

from engine import Camera, Light, Material, RenderSettings, SceneBuilder, World, render
from engine.plan import make_plan
from tests import scenes
from tests.engine.test_integrator import max_block_z

SETTINGS = dict(width=48, height=36, samples=64, max_bounces=4, light_tracing=False)


def _box_with_filtered_light(pane, radiance):
    """The Cornell box whose light is sandwiched between two panes of `pane` a thousandth
    below and above it (same footprint): every path to the light crosses one pane."""
    b = SceneBuilder()
    scenes.cornell_box(b, emitter_radiance=radiance)
    if pane is not None:
        m = b.add_material(pane)
        for z in (1.489, 1.491):
            v, t = scenes.quad((-0.4, -0.3, z), (-0.4, 0.3, z), (0.4, 0.3, z),
                               (0.4, -0.3, z))
            b.add_mesh("pane", v, t, m)
    return b.build(scenes.cornell_camera(), World((0, 0, 0)))


@pytest.mark.slow
@pytest.mark.parametrize("pane", [
    Material.transparent("pane", (0.5, 0.5, 0.5)),
    Material.mix("alpha 0.5", Material.transparent("t"), Material.diffuse("black", (0, 0, 0)),
                 0.5)], ids=["transparent", "alpha"])
def test_a_light_behind_a_transparent_filter_is_the_light_dimmed(pane):
    """A light seen, sampled and hit only through a transparent pane of 0.5 (a Transparent
    BSDF, or alpha 0.5 over black: shadow rays pick among the mix) renders as the light at
    half its radiance, within noise (block z-scores, Sidak-corrected); the full light is
    told apart."""
    half = render(_box_with_filtered_light(None, 5.0), RenderSettings(seed=1, **SETTINGS))
    filtered = render(_box_with_filtered_light(pane, 10.0), RenderSettings(seed=2, **SETTINGS))
    z, critical = max_block_z(half, filtered)
    assert z < critical, z
    full = render(_box_with_filtered_light(None, 10.0), RenderSettings(seed=3, **SETTINGS))
    z, critical = max_block_z(full, filtered)
    assert z > critical, z


def _box_with_clear_ceiling(pane):
    """The box with a big, dim light and a pane across the room under it: BSDF-sampled
    rays reach the light across the pane, where MIS weighs them by the light's pdf from
    the scattering vertex (the pane's distance to the light is a seventh of it)."""
    b = SceneBuilder()
    scenes.cornell_box(b, emitter_radiance=2.0, light_half=(0.9, 0.9))
    if pane is not None:
        v, t = scenes.quad((-1, -1, 1.3), (-1, 1, 1.3), (1, 1, 1.3), (1, -1, 1.3))
        b.add_mesh("pane", v, t, b.add_material(pane))
    return b.build(scenes.cornell_camera(), World((0, 0, 0)))


@pytest.mark.slow
def test_a_clear_pane_changes_nothing_and_mis_measures_from_the_vertex():
    """A white transparent pane across the room leaves the image as it was, within noise.
    (Measuring the light's MIS distance from the pane instead of from the scattering
    vertex gives z 43 here.)"""
    ref = render(_box_with_clear_ceiling(None), RenderSettings(seed=1, **SETTINGS))
    clear = render(_box_with_clear_ceiling(Material.transparent("clear")),
                   RenderSettings(seed=2, **SETTINGS))
    z, critical = max_block_z(ref, clear)
    assert z < critical, z


def _panes(n, colour=(0.5, 0.8, 1.0), sun=False):
    """n transparent panes stacked under an orthographic camera looking down at a white
    world, or (sun) at a white floor lit by a sun straight through them."""
    b = SceneBuilder()
    m = b.add_material(Material.transparent("pane", colour))
    for k in range(n):
        z = 1.0 + 0.2 * k
        v, t = scenes.quad((-2, -2, z), (2, -2, z), (2, 2, z), (-2, 2, z))
        b.add_mesh(f"pane {k}", v, t, m)
    if sun:
        v, t = scenes.quad((-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0))
        b.add_mesh("floor", v, t, b.add_material(Material.diffuse("white", (1, 1, 1))))
        b.add_light(Light("sun", "SUN", (np.pi, np.pi, np.pi)))
    cam = Camera(type="ORTHO", ortho_scale=1.0,
                 world_from_camera=scenes.look_at((0, 0, 0.5) if sun else (0, 0, 3),
                                                  (0, 0, -1) if sun else (0, 0, 0),
                                                  up=(0, 1, 0)))
    return b.build(cam, World((0, 0, 0) if sun else (1, 1, 1)))


@pytest.mark.parametrize("limit", [0, 1, 2, 3, 4, 8])
def test_the_transparent_bounce_limit_is_cycles(limit):
    """Through three panes: the world is seen once three crossings are allowed (Cycles
    stops a path at the surface after its limit-th crossing, but still adds the world),
    and the panes' colour cubed tints it; a sun lights the floor through them once three
    crossings are allowed (Cycles blocks a shadow ray at the crossing past the limit,
    counting its path's). Exact: nothing is sampled."""
    st = RenderSettings(width=4, height=4, samples=2, max_bounces=2,
                        transparent_max_bounces=limit)
    c3 = np.array((0.5, 0.8, 1.0)) ** 3
    seen = render(_panes(3), st).combined[..., :3]
    np.testing.assert_allclose(seen, np.broadcast_to(c3 if limit >= 3 else 0.0, seen.shape),
                               rtol=1e-6, atol=1e-12)
    # The camera sits under the panes, so only the sun's shadow rays cross them: the
    # white floor's radiance is its irradiance pi x c^3 / pi.
    lit = render(_panes(3, sun=True), st).combined[..., :3]
    np.testing.assert_allclose(lit, np.broadcast_to(c3 if limit >= 3 else 0.0, lit.shape),
                               rtol=1e-6, atol=1e-12)


def test_a_camera_ray_keeps_its_clipping_through_a_transparent_surface():
    """Clip End between a pane and a black floor: the floor stays clipped behind the pane,
    so the white world shows through it, tinted (found by the random scenes: seed 35 saw
    the room behind an alpha cube past Clip End)."""
    scene = _panes(1)
    v, t = scenes.quad((-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0))
    b = SceneBuilder()
    b.add_mesh("pane", *scenes.quad((-2, -2, 1), (2, -2, 1), (2, 2, 1), (-2, 2, 1)),
               b.add_material(Material.transparent("pane", (0.5, 0.8, 1.0))))
    b.add_mesh("floor", v, t, b.add_material(Material.diffuse("black", (0, 0, 0))))
    cam = replace(scene.camera, clip_end=2.5)
    img = render(b.build(cam, World((1, 1, 1))),
                 RenderSettings(width=4, height=4, samples=2, max_bounces=2)).combined[..., :3]
    np.testing.assert_allclose(img, np.broadcast_to((0.5, 0.8, 1.0), img.shape), rtol=1e-6)


def test_transparency_is_planned_and_leaves_light_tracing_out():
    scene = _box_with_filtered_light(Material.transparent("pane"), 10.0)
    plan = make_plan(scene, scenes.settings())
    assert plan.transparency and not plan.light_tracing
    assert plan.kernel_constants(False)["HAS_TRANSPARENCY"]
    assert "pass through transparent surfaces" in plan.stages()
    assert not make_plan(scenes.cbspheres(), scenes.settings()).transparency
    with pytest.raises(ValueError, match="transparent_max_bounces"):
        RenderSettings(transparent_max_bounces=-1).validate()


@pytest.mark.parametrize("via, crossed, depth, expected", [
    (True, 1, 5, 1.0),     # after bounces, its first transparent crossing: Cycles goes on
    (True, 2, 0, 0.5),     # a camera ray past two crossings: the throughput's rule
    (True, 3, 5, 0.5),
    (False, 1, 1, 1.0),    # after a bounce, the first bounces go on
    (False, 1, 2, 0.5),    # the crossing was before the last bounce: the bounce rule
    (True, 1, 9, 0.0),     # past the bounce limit (8) nothing goes on
])
def test_a_ray_through_a_transparent_surface_goes_on_by_cycles_transparent_rule(
        via, crossed, depth, expected):
    """Cycles decides whether a path goes on as its ray arrives (the chance an emission
    under a coat or sheen is dimmed with, integrator.handle_emission): a ray that crossed a
    transparent surface since its last bounce goes on for certain while the path has
    crossed at most one, whatever its bounce count, else with min(sqrt(max throughput), 1)
    (path_state_continuation_probability). The bounce count's rule alone gets the first
    two rows wrong."""
    from engine import integrator
    from engine.kernels import Tracer
    paths = Tracer.new_paths(1)
    paths.throughput[0] = (0.25, 0.1, 0.2)
    paths.via_transparent[0] = via
    paths.transparent[0] = crossed
    assert integrator.continuation_probability(0, depth, 8, paths) == expected


def _frame_card(material):
    """A white world and, before the camera, `material` on a card covering the left half of
    the frame (x < 0) and nothing on the right."""
    b = SceneBuilder()
    m = b.add_material(material)
    v, t = scenes.quad((-5.0, -5.0, -3.0), (0.0, -5.0, -3.0), (0.0, 5.0, -3.0),
                       (-5.0, 5.0, -3.0))
    b.add_mesh("card", v, t, m)
    return b.build(Camera(), World((1.0, 1.0, 1.0)))


@pytest.mark.parametrize("card, alpha_left", [
    (Material.diffuse("matte", (0.5, 0.5, 0.5)), 1.0),
    (Material.transparent("tint", (0.2, 0.5, 0.8)), 0.5),
    (Material.holdout("hole"), 0.0)], ids=["opaque", "tinted", "holdout"])
@pytest.mark.parametrize("film_transparent", [True, False], ids=["transparent", "opaque"])
def test_alpha_is_one_minus_the_camera_paths_average_throughput_where_they_escape(
        card, alpha_left, film_transparent):
    """Film > Transparent: a camera ray reaching the world, straight or through a tinted
    Transparent BSDF (throughput (0.2, 0.5, 0.8): alpha 1 - 0.5), leaves the pixel that
    transparent and sees no world; a holdout leaves it wholly transparent and black, with
    the film opaque too (Cycles). Far from the card's edge the values are exact."""
    r = render(_frame_card(card), RenderSettings(width=16, height=8, samples=8,
                                                 film_transparent=film_transparent))
    rgba = r.combined
    left, right = rgba[:, :5], rgba[:, -5:]
    assert np.all(np.isfinite(rgba))
    holdout = card.kind == "holdout"
    want_left = alpha_left if (film_transparent or holdout) else 1.0
    np.testing.assert_allclose(left[..., 3], want_left, atol=1e-6)
    np.testing.assert_allclose(right[..., 3], 0.0 if film_transparent else 1.0, atol=1e-6)
    np.testing.assert_allclose(right[..., :3], 0.0 if film_transparent else 1.0, atol=1e-6)
    if holdout:
        np.testing.assert_allclose(left[..., :3], 0.0, atol=1e-6)
    elif card.kind == "transparent":  # the world through the tint, unless not seen
        want = 0.0 if film_transparent else np.array([0.2, 0.5, 0.8])
        np.testing.assert_allclose(left[..., :3], np.broadcast_to(want, left[..., :3].shape),
                                   atol=1e-6)
    assert (r.replicate_transparency is None) == (not film_transparent and not holdout)


def _glass_before(card, behind=None):
    """A white world and, before the camera, `card` over the left half of the frame, with
    `behind` (if any) on a second card behind it."""
    b = SceneBuilder()
    v, t = scenes.quad((-5.0, -5.0, -3.0), (0.0, -5.0, -3.0), (0.0, 5.0, -3.0),
                       (-5.0, 5.0, -3.0))
    b.add_mesh("glass", v, t, b.add_material(card))
    if behind is not None:
        v, t = scenes.quad((-50.0, -50.0, -6.0), (0.0, -50.0, -6.0), (0.0, 50.0, -6.0),
                           (-50.0, 50.0, -6.0))
        b.add_mesh("behind", v, t, b.add_material(behind))
    return b.build(Camera(), World((1.0, 1.0, 1.0)))


TINT = (0.2, 0.5, 0.8)  # a Refraction BSDF's throughput, no Fresnel: alpha 1 - 0.5


@pytest.mark.parametrize("roughness, threshold, glass_on, alpha_left", [
    (0.0, 0.1, True, 0.5),    # smooth: through it, the world's transparency
    (0.0, 0.0, True, 0.5),    # a threshold of 0 still lets smooth glass through
    (0.0, 0.1, False, 1.0),   # Transparent Glass off: the world is seen through the glass
    (0.2, 0.1, True, 1.0),    # rougher than the threshold: opaque
    (0.2, 0.25, True, None),  # within it: transparent by the rough lobe's throughput
], ids=["smooth", "threshold-0", "off", "too-rough", "rough-within"])
def test_transparent_glass_lets_camera_paths_see_the_transparent_film_through_clear_glass(
        roughness, threshold, glass_on, alpha_left):
    """Cycles' Film > Transparent Glass: a camera path that transmits through glass no
    rougher than the threshold (GGX alpha_x alpha_y <= threshold^4) stays a camera path
    for the film's transparency, so the world behind the glass is transparent by the
    path's throughput there and unseen; rougher glass, or the option off, shows the world
    through it with alpha 1. A Refraction BSDF card (no Fresnel) makes the smooth values
    exact."""
    card = Material.refraction("card", TINT, ior=1.45, roughness=roughness)
    st = RenderSettings(width=16, height=8, samples=16, film_transparent=True,
                        film_transparent_glass=glass_on, film_transparent_roughness=threshold)
    scene = _glass_before(card)
    assert make_plan(scene, st).transparent_glass == glass_on
    rgba = render(scene, st).combined
    left = rgba[:, :5]
    assert np.all(np.isfinite(rgba))
    if alpha_left is None:  # 1 - the rough lobe's average weight, the world unseen
        assert 0.4 < left[..., 3].min() and left[..., 3].max() < 0.8, left[..., 3]
        np.testing.assert_allclose(left[..., :3], 0.0, atol=1e-6)
        return
    np.testing.assert_allclose(left[..., 3], alpha_left, atol=1e-6)
    if alpha_left == 0.5:
        np.testing.assert_allclose(left[..., :3], 0.0, atol=1e-6)
    elif roughness == 0.0:  # the white world through the tint
        np.testing.assert_allclose(left[..., :3], np.broadcast_to(TINT, left[..., :3].shape),
                                   atol=1e-6)


@pytest.mark.parametrize("film_transparent", [True, False], ids=["transparent", "opaque"])
def test_a_holdout_behind_clear_glass_holds_out_under_transparent_glass_only(film_transparent):
    """A holdout seen through clear glass: with Transparent Glass (which needs the film
    transparent) the camera path is still one, and the holdout leaves the pixel transparent
    by the throughput through the glass (alpha 0.5); with the film opaque the glass ends
    the camera path, and the holdout is a surface without a BSDF to it (black, alpha 1)."""
    scene = _glass_before(Material.refraction("card", TINT, ior=1.45),
                          Material.holdout("hole"))
    st = RenderSettings(width=16, height=8, samples=8, film_transparent=film_transparent,
                        film_transparent_glass=True)
    rgba = render(scene, st).combined[:, :5]
    np.testing.assert_allclose(rgba[..., 3], 0.5 if film_transparent else 1.0, atol=1e-6)
    np.testing.assert_allclose(rgba[..., :3], 0.0, atol=1e-6)


def test_the_transparent_glass_threshold_is_checked():
    with pytest.raises(ValueError, match="film_transparent_roughness"):
        RenderSettings(film_transparent_roughness=1.5).validate()

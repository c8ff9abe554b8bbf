"""Cycles' Translucent BSDF (scene.Material.translucent): Lambertian transmission."""

import numpy as np

from engine import Camera, Material, RenderSettings, SceneBuilder, World, render
from engine.plan import make_plan
from tests import scenes


def _pane_under_a_glowing_ceiling(material, samples, seed):
    """scenes.pane_under_glowing_ceiling seen from below."""
    return render(scenes.pane_under_glowing_ceiling(material, -1.0),
                  RenderSettings(width=16, height=16, samples=samples, max_bounces=2,
                                 seed=seed))


def test_a_translucent_pane_passes_its_colour_through():
    """Seen from below, a translucent pane under a ceiling of radiance 1 has radiance
    colour x 1 (Lambertian transmission of the upper hemisphere; the ceiling covers all
    but 1e-6 of it). The image mean agrees within 4 standard errors and 0.1%; a diffuse
    pane is black from below."""
    colour = np.array([0.6, 0.3, 0.9])
    r = _pane_under_a_glowing_ceiling(Material.translucent("leaf", colour), 64, 1)
    img = r.combined[..., :3].reshape(-1, 3)
    se = np.sqrt((r.error.astype(float) ** 2).sum()) / img.shape[0]
    assert np.all(np.abs(img.mean(axis=0) - colour) < 4 * se + 1e-3 * colour), \
        (img.mean(axis=0), se)
    dark = _pane_under_a_glowing_ceiling(Material.diffuse("card", colour), 4, 1)
    assert dark.combined[..., :3].max() == 0.0
    plan = make_plan(_scene_of(Material.translucent("leaf", colour)), scenes.settings())
    assert plan.translucent and plan.light_sampling and not plan.light_tracing


def test_translucency_lights_only_the_far_side():
    """A closed box of a translucent material around a small emitter: light leaves it
    through its walls (the outside is lit); a diffuse box keeps it in (black outside)."""
    def lit_outside(material):
        b = SceneBuilder()
        v, t = scenes.closed_box((-1, -1, -1), (1, 1, 1))
        b.add_mesh("box", v, t, b.add_material(material))
        lv, lt = scenes.quad((-0.2, -0.2, 0), (0.2, -0.2, 0), (0.2, 0.2, 0), (-0.2, 0.2, 0))
        b.add_mesh("lamp", lv, lt, b.add_material(
            Material.emission_only("lamp", (1, 1, 1), 20.0)))
        cam = Camera(world_from_camera=scenes.look_at((0, -6, 0), (0, 0, 0), up=(0, 0, 1)))
        r = render(b.build(cam, World((0.0, 0.0, 0.0))),
                   RenderSettings(width=16, height=16, samples=16, max_bounces=4, seed=2))
        return r.combined[6:10, 6:10, :3].mean()
    assert lit_outside(Material.translucent("shade", (0.8, 0.8, 0.8))) > 0.05
    assert lit_outside(Material.diffuse("wall", (0.8, 0.8, 0.8))) == 0.0


def _scene_of(material):
    b = SceneBuilder()
    scenes.cornell_box(b, spheres=False)
    v, t, n = scenes.uv_sphere((0.0, 0.0, 0.4), 0.4)
    b.add_mesh("ball", v, t, b.add_material(material), corner_normals=n)
    return b.build(scenes.cornell_camera(), World((0, 0, 0)))

"""Mixed shaders (scene.Material.mix): a hit shades with one component, picked by the mix's
factor, carrying its scale; the image is the mixed BSDF's and the mixed emission's."""

import dataclasses

import numpy as np
import pytest

from engine import Material, RenderSettings, SceneBuilder, World, render
from engine.plan import make_plan
from engine.scene import Materials
from tests import scenes
from tests.engine.test_integrator import max_block_z

# Luminances 0.33 and 0.11: a wrong factor changes the luminance the comparison reads.
RED, BLUE = (0.8, 0.2, 0.2), (0.05, 0.1, 0.4)


def _box_with_ball(material):
    b = SceneBuilder()
    scenes.cornell_box(b, spheres=False)
    v, t, n = scenes.uv_sphere((0.0, 0.0, 0.4), 0.4)
    b.add_mesh("ball", v, t, b.add_material(material), corner_normals=n)
    return b.build(scenes.cornell_camera(), World((0, 0, 0)))


def _render(material, seed):
    return render(_box_with_ball(material), RenderSettings(width=48, height=36, samples=32,
                                                           max_bounces=4, seed=seed))


@pytest.mark.slow
@pytest.mark.parametrize("mixed, plain", [
    (Material.mix("mix", Material.diffuse("a", RED), Material.diffuse("b", BLUE), 0.3),
     Material.diffuse("same", tuple(0.7 * np.array(RED) + 0.3 * np.array(BLUE)))),
    (Material.mix("add", Material.diffuse("a", RED), Material.diffuse("b", BLUE), 0.5, 2.0),
     Material.diffuse("same", tuple(np.array(RED) + np.array(BLUE)))),
    (Material.mix("glow", Material.emission_only("e", (1.0, 0.8, 0.5), 2.0),
                  Material.mix("inner", Material.diffuse("a", RED), Material.diffuse("b", BLUE),
                               0.5), 0.6),
     Material.diffuse("same", tuple(0.3 * np.array(RED) + 0.3 * np.array(BLUE)),
                      emission=tuple(0.8 * np.array((1.0, 0.8, 0.5))))),
], ids=["mix", "add", "nested_with_emission"])
def test_a_mix_of_diffuse_shaders_is_the_diffuse_of_their_mix(mixed, plain):
    """Mix Shader, Add Shader and a nested mix with an emitter render as the one diffuse
    (and emission) they add up to, within noise (block z-scores, Sidak-corrected); the
    same comparison tells a mix with its factor reversed (the first input at fac) apart."""
    ref = _render(plain, 11)
    z, critical = max_block_z(ref, _render(mixed, 12))
    assert z < critical, z
    if mixed.name == "mix":
        wrong = Material.mix("mix", *mixed.components, 1.0 - mixed.fac)
        z, critical = max_block_z(ref, _render(wrong, 12))
        assert z > critical, z


def test_a_mix_plans_its_components_and_no_light_tracing():
    """The plan sees the kinds a mix reaches (here a mirror only inside a mix) and leaves
    light tracing out (light paths do not choose among components)."""
    scene = _box_with_ball(Material.mix("m", Material.diffuse("a", RED),
                                        Material.mirror("b"), 0.5))
    plan = make_plan(scene, scenes.settings())
    assert plan.mixes and plan.mirror and plan.diffuse and not plan.light_tracing
    assert plan.kernel_constants(False)["HAS_MIXES"]
    assert not make_plan(scenes.cbspheres(), scenes.settings()).mixes


def test_a_mix_is_validated_and_its_emission_lights_the_scene():
    with pytest.raises(ValueError, match="'bad'.*fac"):
        Material.mix("bad", Material.diffuse("a", RED), Material.diffuse("b", BLUE), 1.5)
    m = _box_with_ball(Material.mix("glow", Material.emission_only("e", (1, 1, 1), 4.0),
                                    Material.diffuse("a", RED), 0.25)).materials
    ball = m.names.index("glow")
    np.testing.assert_allclose(m.emission[ball], (3.0, 3.0, 3.0))  # an emitter for NEE
    for row in m.mix_components[ball]:
        np.testing.assert_allclose(m.emission[row], (3.0, 3.0, 3.0))


def test_a_textured_factor_picks_each_component_where_the_texture_says():
    """A Mix Shader whose factor is a 2 x 2 image of 0 and 1 (Closest): each texel's
    quarter of a quad under a white world is exactly one component's albedo (the factor's
    program is run at each hit, not replaced by its mean)."""
    from engine import Camera

    texels = np.zeros((2, 2, 4), np.float32)
    texels[0, 1, :3] = texels[1, 0, :3] = 1.0  # texel (x 1, y 0) and (x 0, y 1): fac 1
    texels[..., 3] = 1.0
    b = SceneBuilder()
    mix = Material.mix("checker", Material.diffuse("a", (0.2, 0.2, 0.2)),
                       Material.diffuse("b", (0.9, 0.6, 0.3)), 0.5,
                       fac_program=scenes.image_program(texels))
    v, t = scenes.quad((-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0))
    b.add_mesh("quad", v, t, b.add_material(mix), uv_maps={"": scenes.quad_uvs()})
    cam = Camera(type="ORTHO", ortho_scale=1.6,
                 world_from_camera=scenes.look_at((0, 0, 2), (0, 0, 0), up=(0, 1, 0)))
    r = render(b.build(cam, World((1.0, 1.0, 1.0))),
               RenderSettings(width=8, height=8, samples=4, max_bounces=1, seed=2))
    img = r.combined[..., :3]  # row 0 at the bottom (v = 0), as Blender's
    np.testing.assert_allclose(img[1, 1], (0.2, 0.2, 0.2), rtol=1e-5)  # texel (0, 0)
    np.testing.assert_allclose(img[1, 6], (0.9, 0.6, 0.3), rtol=1e-5)  # texel (1, 0)
    np.testing.assert_allclose(img[6, 1], (0.9, 0.6, 0.3), rtol=1e-5)  # texel (0, 1)
    np.testing.assert_allclose(img[6, 6], (0.2, 0.2, 0.2), rtol=1e-5)  # texel (1, 1)


def test_a_mix_of_its_own_textured_emission_shows_it_on_every_component():
    """A mix's own textured emission (a Principled BSDF's emission texture beside a textured
    Metallic) is seen, texel by texel, whichever component a hit picks; a textured emission
    inside a component cannot be mixed (the mix would have to scale a program)."""
    from engine import Camera

    emission = np.zeros((2, 2, 4), np.float32)
    emission[..., 3] = 1.0
    emission[0, 0, :3], emission[0, 1, :3] = (2.0, 0.5, 0.0), (0.0, 1.0, 3.0)
    emission[1, 0, :3], emission[1, 1, :3] = (0.2, 0.2, 0.2), (1.0, 1.0, 1.0)
    fac = np.zeros((2, 2, 4), np.float32)
    fac[0, 1, :3] = fac[1, 0, :3] = 1.0
    b = SceneBuilder()
    mix = Material.mix("glow", Material.diffuse("a", (0.2, 0.2, 0.2)),
                       Material.diffuse("b", (0.9, 0.6, 0.3)), 0.5,
                       fac_program=scenes.image_program(fac))
    mix = dataclasses.replace(mix, emission=tuple(emission[..., :3].mean(axis=(0, 1))),
                              emission_program=scenes.image_program(emission))
    v, t = scenes.quad((-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0))
    b.add_mesh("quad", v, t, b.add_material(mix), uv_maps={"": scenes.quad_uvs()})
    cam = Camera(type="ORTHO", ortho_scale=1.6,
                 world_from_camera=scenes.look_at((0, 0, 2), (0, 0, 0), up=(0, 1, 0)))
    r = render(b.build(cam, World((0.0, 0.0, 0.0))),
               RenderSettings(width=8, height=8, samples=4, max_bounces=1, seed=2))
    img = r.combined[..., :3]  # row 0 at the bottom (v = 0)
    for (iy, ix), (py, px) in {(0, 0): (1, 1), (0, 1): (1, 6), (1, 0): (6, 1),
                               (1, 1): (6, 6)}.items():
        np.testing.assert_allclose(img[py, px], emission[iy, ix, :3], rtol=1e-5)
    inner = Material.diffuse("c", (0.5, 0.5, 0.5), emission=(1.0, 1.0, 1.0),
                             emission_program=scenes.image_program(emission))
    with pytest.raises(ValueError, match="'bad'.*textured emission"):
        Materials.from_list([Material.mix("bad", inner, Material.diffuse("d", RED), 0.5)])

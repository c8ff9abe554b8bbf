"""Cycles' Principled coat (scene.Material.coated): an energy-compensated dielectric GGX
layer of weight w over the rest, which keeps 1 - w x A of the light at the view (A Cycles'
estimate of the coat's albedo: the smooth Fresnel F for a smooth coat) and the tint over
the path through the coat (bsdf.coat_layering)."""

import dataclasses

import numpy as np
import pytest

from engine import Camera, Material, RenderSettings, SceneBuilder, World, bsdf, render
from engine.fresnel import fresnel_dielectric
from engine.plan import make_plan
from tests import scenes

BASE = np.array([0.6, 0.3, 0.1])
TINT = np.array([0.9, 0.5, 0.7])


def _pane_under_a_glowing_ceiling(material, samples=16, seed=3):
    """scenes.pane_under_glowing_ceiling seen head-on from above (z = 0.5)."""
    return render(scenes.pane_under_glowing_ceiling(material, 0.5),
                  RenderSettings(width=16, height=16, samples=samples, max_bounces=2,
                                 seed=seed))


def _coated(weight, ior, roughness=0.0):
    return Material.coated("lacquer", Material.diffuse("paint", tuple(BASE)), weight,
                           roughness=roughness, ior=ior, tint=tuple(TINT))


def test_a_coat_that_reflects_nothing_dims_by_its_tint_alone():
    """At IOR 1 the coat reflects nothing, so head-on it only tints what is below by
    mix(1, tint, weight): the pane is the diffuse of that colour, sample for sample (the
    coat's choice takes a sampler dimension of its own)."""
    coated = _pane_under_a_glowing_ceiling(_coated(0.7, 1.0))
    plain = _pane_under_a_glowing_ceiling(
        Material.diffuse("same", tuple(BASE * (1.0 - 0.7 + 0.7 * TINT))))
    assert coated.plan.coats and not plain.plan.coats
    np.testing.assert_allclose(coated.combined[..., :3], plain.combined[..., :3], rtol=1e-9)


@pytest.mark.parametrize("weight", [1.0, 0.5])
def test_a_smooth_coat_reflects_its_fresnel_and_dims_what_is_below(weight):
    """A smooth coat (IOR 1.5, F = 0.04 head-on) over a diffuse pane under a ceiling of
    radiance 1: w F of the ceiling reflected plus (1 - w F) x mix(1, tint, w) x base.
    The mean agrees within 4 standard errors; a coat that does not dim what is below
    (w F more of it) is rejected."""
    img = _pane_under_a_glowing_ceiling(_coated(weight, 1.5), samples=64)
    f = fresnel_dielectric(1.0, 1.5, True)[0]
    below = BASE * (1.0 - weight + weight * TINT)
    expected = weight * f + (1.0 - weight * f) * below
    px = img.combined[..., :3].reshape(-1, 3)  # pixels: independent, alike estimates
    se = px.std(axis=0, ddof=1) / np.sqrt(px.shape[0])
    z = np.abs(px.mean(axis=0) - expected) / se
    assert np.all(z < 4.0), (px.mean(axis=0), expected, z)
    undimmed = weight * f + below
    assert np.max(np.abs(px.mean(axis=0) - undimmed) / se) > 8.0  # red, the brightest


def test_an_emission_under_a_coat_is_dimmed_by_it():
    """A Principled emission E under a smooth coat (IOR 1.5, F = 0.04 head-on, weight w),
    over a black base, under a ceiling of radiance 1, seen head-on: the coat reflects
    w F of the ceiling and lets out E (1 - w F) mix(1, tint, w), as Cycles dims it
    (integrator.under_layers); an emission dimmed by the tint alone is rejected."""
    emission, w = np.array([0.5, 1.0, 2.0]), 0.8
    base = Material.diffuse("black", (0.0, 0.0, 0.0))
    lacquer = Material.coated("glowing", base, w, roughness=0.0, ior=1.5, tint=tuple(TINT))
    img = _pane_under_a_glowing_ceiling(dataclasses.replace(lacquer, emission=tuple(emission)),
                                        samples=64)
    f = fresnel_dielectric(1.0, 1.5, True)[0]
    tinted = emission * (1.0 - w + w * TINT)
    expected = w * f + (1.0 - w * f) * tinted
    px = img.combined[..., :3].reshape(-1, 3)
    se = px.std(axis=0, ddof=1) / np.sqrt(px.shape[0])
    assert np.all(np.abs(px.mean(axis=0) - expected) < 4.0 * se + 1e-9), \
        (px.mean(axis=0), expected, se)
    assert np.max(np.abs(px.mean(axis=0) - (w * f + tinted)) / (se + 1e-12)) > 8.0


def test_a_coat_plans_as_a_mix_and_its_lobe_as_compensated_ggx():
    """A coat is a mix to the plan (no light tracing), with its own constant; its lobe is a
    Principled layer over black with energy compensation (Cycles 5 compensates the coat
    whatever the distribution), of the coat's IOR."""
    b = scenes.cornell_box(spheres=False)
    v, t, n = scenes.uv_sphere((0.0, 0.0, 0.4), 0.4)
    b.add_mesh("ball", v, t, b.add_material(_coated(0.8, 1.6, 0.2)), corner_normals=n)
    scene = b.build(scenes.cornell_camera(), World((0, 0, 0)))
    plan = make_plan(scene, scenes.settings())
    assert plan.coats and plan.mixes and plan.principled and not plan.light_tracing
    assert plan.kernel_constants(False)["HAS_COATS"]
    m = scene.materials
    top = m.names.index("lacquer")
    base, lobe = m.mix_components[top]
    assert m.coat_ior[top] == 1.6 and m.coat_ior[base] == 0.0
    np.testing.assert_allclose(m.coat_tint[top], TINT)
    assert m.ior[lobe] == 1.6 and m.multiscatter[lobe] and m.colour[lobe].max() == 0
    assert not make_plan(scenes.cbspheres(), scenes.settings()).coats


def test_a_coat_is_validated():
    with pytest.raises(ValueError, match="'bad'.*IOR"):
        Material.coated("bad", Material.diffuse("a", BASE), 0.5, ior=0.8)
    with pytest.raises(ValueError, match="'bad'.*fac"):
        Material.coated("bad", Material.diffuse("a", BASE), 1.5)
    with pytest.raises(ValueError, match="'bad'.*coat tint"):
        b = SceneBuilder()
        b.add_material(Material.coated("bad", Material.diffuse("a", BASE), 0.5,
                                       tint=(1.0, -0.1, 1.0)))
        v, t = scenes.quad((0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0))
        b.add_mesh("q", v, t, 0)
        b.build(scenes.cornell_camera(), World((0, 0, 0)))


def _coated_mirror_in_a_white_world(mu, roughness, samples):
    """A coat (weight 1, IOR 1.5) of `roughness` over smooth white metal, a wide floor in a
    world of radiance 1, seen at view cosine mu through a long lens (mu varies < 0.01)."""
    b = SceneBuilder()
    mirror = b.add_material(Material.coated("coat", Material.metal("m", (1.0, 1.0, 1.0)), 1.0,
                                            roughness=roughness, ior=1.5))
    v, t = scenes.quad((-100, -100, 0), (100, -100, 0), (100, 100, 0), (-100, 100, 0))
    b.add_mesh("floor", v, t, mirror)
    eye = (0.0, -5.0 * np.sqrt(1.0 - mu * mu), 5.0 * mu)
    scene = b.build(Camera(world_from_camera=scenes.look_at(eye, (0, 0, 0)), lens_mm=400.0),
                    World((1.0, 1.0, 1.0)))
    return render(scene, RenderSettings(width=8, height=8, samples=samples, max_bounces=1,
                                        seed=5))


@pytest.mark.parametrize("mu", [0.2, 0.5])
def test_a_rough_coat_dims_by_cycles_albedo_estimate(mu):
    """Over a white mirror in a white world the pixel is 1 - A(mu) + E(mu): what the coat
    leaves of the mirror plus the compensated coat lobe's albedo (MicrofacetTables
    layering_table and albedo_table). Within 4 standard errors; dimming by the smooth
    Fresnel instead (the coat before Cycles 5's estimate) is far off at grazing views.
    Against Cycles: the coat_rough agreement variant."""
    alpha = 0.7 ** 2
    t = bsdf.MicrofacetTables(alpha, "dielectric", 1.5)
    img = _coated_mirror_in_a_white_world(mu, 0.7, 256)
    px = img.combined[..., :3].mean(axis=-1).ravel()
    se = px.std(ddof=1) / np.sqrt(px.size)
    coat = np.interp(mu, t.mu, t.albedo_table)
    expected = 1.0 - np.interp(mu, t.mu, t.layering_table) + coat
    assert abs(px.mean() - expected) < 4.0 * se + 2e-4, (px.mean(), expected, se)
    smooth = 1.0 - fresnel_dielectric(mu, 1.5, True)[0] + coat
    assert abs(px.mean() - smooth) > 20.0 * se + 0.005

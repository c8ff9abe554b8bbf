"""Cycles' microfiber sheen (bsdf.eval_sheen, sample_sheen, sheen_ltc; scene.Material.sheen
and sheened): a linearly transformed cosine from Cycles' fitted table, and the Principled
sheen layer, which keeps 1 - weight x tint x albedo of what is below."""

import numpy as np
import pytest

from engine import Camera, Material, RenderSettings, SceneBuilder, World, bsdf, render
from engine.plan import make_plan
from tests import scenes

TABLE = bsdf.sheen_table()


def test_the_table_is_read_as_cycles_reads_it():
    """lookup_table_read_2D: rows over roughness, columns over the view cosine, exact at
    the grid points and bilinear between them; an invalid fit drops the lobe."""
    i, j = 20, 7  # roughness row, cosine column
    a, b, albedo = bsdf.sheen_ltc(TABLE, j / 31, i / 31)
    assert (a, b, albedo) == pytest.approx(tuple(TABLE[:, i, j]), abs=1e-12)
    half = bsdf.sheen_ltc(TABLE, (j + 0.5) / 31, i / 31)[2]
    assert half == pytest.approx(0.5 * (TABLE[2, i, j] + TABLE[2, i, j + 1]), abs=1e-12)
    assert bsdf.sheen_ltc(TABLE, 0.5, 0.0)[2] == 0.0  # roughness 0: no valid transform


@pytest.mark.parametrize("mu, roughness", [(0.9, 0.5), (0.3, 0.2), (0.1, 0.9)])
def test_the_lobe_is_a_distribution_its_samples_follow(mu, roughness):
    """The lobe integrates to 1 over the hemisphere (seeded Monte Carlo, uniform sphere)
    and a sample's pdf is the lobe's value toward it; the sampled directions' mean
    cosine agrees with the lobe's (its shape, not only its norm)."""
    rng = np.random.default_rng(11)
    a, b, _ = bsdf.sheen_ltc(TABLE, mu, roughness)
    wo = (np.sqrt(1 - mu * mu), 0.0, mu)
    n = 100_000
    z = rng.random(n)
    phi = rng.random(n) * 2 * np.pi
    s = np.sqrt(1 - z * z)
    f = np.array([bsdf.eval_sheen(*wo, s[k] * np.cos(phi[k]), s[k] * np.sin(phi[k]), z[k],
                                  0.0, 0.0, 1.0, a, b) for k in range(n)])
    assert f.mean() * 2 * np.pi == pytest.approx(1.0, abs=0.01)
    mean_cos = (f * z).mean() * 2 * np.pi
    cosines = []
    for _ in range(20_000):
        wx, wy, wz, pdf, ok = bsdf.sample_sheen(*wo, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, a, b,
                                                rng.random(), rng.random())
        assert ok and pdf == pytest.approx(bsdf.eval_sheen(*wo, wx, wy, wz, 0.0, 0.0, 1.0, a, b))
        cosines.append(wz)
    assert np.mean(cosines) == pytest.approx(mean_cos, abs=4 * np.std(cosines) / np.sqrt(2e4))


def _ball_in_a_white_world(material, samples):
    b = SceneBuilder()
    m = b.add_material(material)
    v, t, n = scenes.uv_sphere((0, 0, 0), 1.0, 64, 32)
    b.add_mesh("ball", v, t, m, corner_normals=n)
    scene = b.build(Camera(world_from_camera=scenes.look_at((0, -4, 0), (0, 0, 0)),
                           lens_mm=50), World((1.0, 1.0, 1.0)))
    return render(scene, RenderSettings(width=24, height=18, samples=samples, max_bounces=8,
                                        seed=9))


def test_a_white_sheen_over_white_diffuse_vanishes_in_a_white_furnace():
    """One bounce off a convex ball in a white world: the sheen returns its albedo A and
    leaves 1 - A of the white base, so the ball is the world's white everywhere (within
    noise). Without the layering's dimming it would be 1 + A at the rims."""
    r = _ball_in_a_white_world(Material.sheened("velvet", Material.diffuse("d", (1, 1, 1)),
                                                1.0, 0.3), 64)
    ball = np.hypot(*np.mgrid[-8.5:9.5, -11.5:12.5]) < 6.5  # inside the silhouette
    px = r.combined[..., 0][ball]
    err = np.sqrt(r.variance[..., 0][ball].astype(float))
    assert np.all(np.abs(px - 1.0) < 5 * err + 2e-3), (px.min(), px.max())
    assert r.plan.sheen and r.plan.mixes


def test_sheen_plans_only_where_used():
    box = scenes.cornell_box(spheres=False).build(scenes.cornell_camera(), World((0, 0, 0)))
    assert not make_plan(box, scenes.settings()).sheen
    b = scenes.cornell_box(spheres=False)
    v, t, n = scenes.uv_sphere((0.0, 0.0, 0.4), 0.4)
    b.add_mesh("ball", v, t, b.add_material(Material.sheen("dust", (0.9, 0.9, 0.9), 0.5)),
               corner_normals=n)
    plan = make_plan(b.build(scenes.cornell_camera(), World((0, 0, 0))), scenes.settings())
    assert plan.sheen and plan.kernel_constants(False)["HAS_SHEEN"]
    assert "sheen" in plan.stages()[-1] and not plan.mixes


def test_a_sheen_lobe_knows_its_layer_for_the_coat_normal():
    """A sheen over a coat mixes its normal with the coat's by the Coat Weight (Cycles'
    safe_normalize(mix(N, coat_normal, coat_weight))): each sheen lobe row names its layer
    (Materials.sheen_parent), a Sheen BSDF alone none."""
    from engine.scene import Materials

    coated = Material.coated("c", Material.diffuse("d", (0.5, 0.5, 0.5)), 0.7)
    m = Materials.from_list([Material.sheened("velvet", coated, 0.8, 0.4),
                             Material.sheen("dust", (0.9, 0.9, 0.9), 0.5)])
    top = m.names.index("velvet")
    lobe = m.mix_components[top, 1]
    assert m.sheen_layer[top] and m.sheen_parent[lobe] == top
    below = m.mix_components[top, 0]
    assert m.coat_ior[below] > 0 and m.mix_fac[below] == 0.7
    assert m.sheen_parent[m.names.index("dust")] == -1
    assert np.count_nonzero(m.sheen_parent >= 0) == 1

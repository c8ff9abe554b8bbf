"""Film > Transparent and holdouts as Cycles renders them: the world unseen by camera
paths that reach it straight or through transparent surfaces, the pixel's alpha one minus
their average throughput there (or at a holdout), and the world still lighting the scene.

Rendered live (a small scene, four Cycles seeds): an opaque block, a glass sphere (not
transparent: the world is seen through it, alpha 1), a tinted half-transparent card (a mix
of a Transparent BSDF of colour (1, 0.3, 0.3) and a diffuse), a Principled sphere of Alpha
0.3, a card mixing a Holdout (0.4) into a diffuse and a sphere of Alpha 0.5 whose object
is marked Holdout, and a frosted glass pane (roughness 0.15), under a blue world and a sun;
with the film transparent and opaque (holdouts make holes in both), and transparent with
Transparent Glass at a roughness threshold of 0.2 (the world behind the glass sphere and
the pane transparent too). Specula's RGB and alpha each agree with Cycles' by the
agreement test's block statistic. Deliberately wrong renders disagree: the card's tint
ignored in its transparency, the Holdout left out of its mix, Transparent Glass ignored,
its threshold below the pane's roughness.
"""

import math

import numpy as np
import pytest

from . import compare, renderers

pytestmark = pytest.mark.slow

RESOLUTION = (48, 36)
SAMPLES = 96  # Cycles, per seed
SPECULA_SAMPLES = 256
REPLICATES = 8  # the alpha's variance comes from the replicates' spread
SEEDS = (1, 2, 3, 4)
TINT = (1.0, 0.3, 0.3, 1.0)
FROSTED = 0.15  # the pane's roughness
THRESHOLD = 0.2  # Transparent Glass' roughness threshold: the pane is clear glass to it
FILMS = {"transparent": (True, False), "opaque": (False, False),
         "transparent_glass": (True, True)}  # (film transparent, Transparent Glass)


def over_diffuse(name, shader, inputs, colour, fac):
    """A material mixing `shader` (with `inputs`) into a diffuse of `colour`, the first by
    1 - fac."""
    import bpy
    mat = bpy.data.materials.new(name)
    tree = mat.node_tree
    tree.nodes.clear()
    mix = tree.nodes.new("ShaderNodeMixShader")
    first, matte = tree.nodes.new(shader), tree.nodes.new("ShaderNodeBsdfDiffuse")
    for key, value in inputs.items():
        first.inputs[key].default_value = value
    matte.inputs["Color"].default_value = colour
    mix.inputs["Fac"].default_value = fac
    tree.links.new(first.outputs[0], mix.inputs[1])
    tree.links.new(matte.outputs[0], mix.inputs[2])
    tree.links.new(mix.outputs[0],
                   tree.nodes.new("ShaderNodeOutputMaterial").inputs["Surface"])
    return mat


def build():
    from blend_scenes import build_scenes as bs
    scene = renderers.sky_and_sun_scene(RESOLUTION, 0.1)
    coll = scene.collection
    bs.quad("Block", [(-2.2, -0.5, -0.6), (-1.2, -0.5, -0.6), (-1.2, -0.5, 0.6),
                      (-2.2, -0.5, 0.6)], bs.diffuse("Clay", (0.8, 0.35, 0.2)), coll)
    bs.uv_sphere("Glass", (-0.2, 0.0, 0.1), 0.7,
                 bs.material("Glass", "ShaderNodeBsdfGlass", IOR=1.45, Roughness=0.0), coll)
    card = over_diffuse("Card", "ShaderNodeBsdfTransparent", {"Color": TINT},
                        (0.2, 0.8, 0.2, 1.0), 0.5)
    bs.quad("Card", [(1.0, -0.3, -0.7), (2.2, -0.3, -0.7), (2.2, -0.3, 0.7),
                     (1.0, -0.3, 0.7)], card, coll)
    bs.uv_sphere("Veil", (0.4, -1.2, 0.9), 0.35,
                 bs.material("Veil", "ShaderNodeBsdfPrincipled",
                             **{"Base Color": (0.9, 0.9, 0.2, 1.0), "Alpha": 0.3}), coll)
    hole = over_diffuse("Hole", "ShaderNodeHoldout", {}, (0.7, 0.7, 0.2, 1.0), 0.6)
    bs.quad("Hole", [(-1.6, -1.0, -1.2), (-0.6, -1.0, -1.2), (-0.6, -1.0, -0.3),
                     (-1.6, -1.0, -0.3)], hole, coll)
    # Held out, half transparent: the camera sees through half of it (Cycles keeps a
    # holdout object's transparency), every other ray sees its diffuse half too.
    bs.uv_sphere("Matte", (1.4, -1.5, -0.5), 0.3,
                 bs.material("Matte", "ShaderNodeBsdfPrincipled",
                             **{"Base Color": (0.9, 0.9, 0.9, 1.0), "Alpha": 0.5}),
                 coll).is_holdout = True
    bs.quad("Pane", [(0.9, -0.8, 0.9), (1.9, -0.8, 0.9), (1.9, -0.8, 1.6), (0.9, -0.8, 1.6)],
            bs.material("Frosted", "ShaderNodeBsdfGlass", IOR=1.45, Roughness=FROSTED), coll)
    scene.specula.film_transparent_roughness = THRESHOLD
    return scene


def node(material, kind):
    import bpy
    return next(n for n in bpy.data.materials[material].node_tree.nodes if n.bl_idname == kind)


def set_film(scene, film):
    scene.render.film_transparent, scene.specula.film_transparent_glass = FILMS[film]


def render_specula(scene, film, tint_ignored=False, holdout_left_out=False,
                   threshold=THRESHOLD):
    """Specula's RenderResult with the `film` of FILMS; `tint_ignored` renders the card's
    Transparent BSDF white, `holdout_left_out` the Hole's mix without its Holdout (an empty
    closure: black); `threshold`, Transparent Glass' roughness threshold."""
    s = scene.specula
    s.samples, s.max_bounces, s.seed, s.threads = SPECULA_SAMPLES, 8, 0, renderers.THREADS
    s.replicates, s.time_limit, s.target_error = REPLICATES, 0.0, 0.0
    set_film(scene, film)
    s.film_transparent_roughness = threshold
    clear = node("Card", "ShaderNodeBsdfTransparent")
    clear.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0) if tint_ignored else TINT
    tree = __import__("bpy").data.materials["Hole"].node_tree
    mix = node("Hole", "ShaderNodeMixShader")
    if holdout_left_out:
        tree.links.remove(mix.inputs[1].links[0])
    core_scene, settings, warnings = renderers.shared.export_specula(scene)
    s.film_transparent_roughness = THRESHOLD
    clear.inputs["Color"].default_value = TINT
    if holdout_left_out:
        tree.links.new(node("Hole", "ShaderNodeHoldout").outputs[0], mix.inputs[1])
    assert warnings == [], warnings
    return renderers.core().render(core_scene, settings)


def render_cycles(scene, film):
    """(K, H, W, 4) RGBA of Cycles at SEEDS with the `film` of FILMS."""
    runs = []
    set_film(scene, film)
    for seed in SEEDS:
        renderers.configure_cycles(scene, SAMPLES, seed, 8)
        rgba, _ = renderers.render_cycles_image(scene)
        runs.append(rgba)
    return np.stack(runs)


def alpha_variance(result):
    """Each pixel's alpha and the variance of it from its replicates' spread (R - 1 dof)."""
    c = result.replicate_count.astype(np.float64)
    t = result.replicate_transparency.astype(np.float64)
    total = c.sum(axis=2)
    mean = (c * t).sum(axis=2) / total
    var = (c * (t - mean[..., None]) ** 2).sum(axis=2) / ((c.shape[2] - 1) * total)
    return 1.0 - mean, var


def comparisons(result, runs):
    rgb = compare.compare(result.combined[..., :3], result.variance, runs[..., :3],
                          specula_dof=result.dof)
    alpha, var = alpha_variance(result)
    a = compare.compare(alpha[..., None], var[..., None], runs[..., 3:4],
                        specula_dof=REPLICATES - 1)
    return rgb, a


@pytest.fixture(scope="module")
def scene():
    return build()


@pytest.fixture(scope="module")
def cycles_transparent(scene):
    return render_cycles(scene, "transparent")


@pytest.fixture(scope="module")
def cycles_transparent_glass(scene):
    return render_cycles(scene, "transparent_glass")


@pytest.mark.parametrize("film", list(FILMS))
def test_film_and_holdouts_agree_with_cycles(scene, cycles_transparent,
                                             cycles_transparent_glass, film):
    runs = {"transparent": cycles_transparent, "transparent_glass": cycles_transparent_glass
            }.get(film)
    if runs is None:
        runs = render_cycles(scene, film)
    transparent = FILMS[film][0]
    result = render_specula(scene, film)
    assert np.all(np.isfinite(result.combined))
    alpha = result.combined[..., 3]
    # Holes: the holdouts' pixels, and with the film transparent the world's.
    assert alpha.max() == 1.0
    assert alpha.min() == 0.0 if transparent else alpha.min() < 0.7
    cycles_alpha = runs[..., 3].mean(axis=0)
    assert abs(alpha.mean() - cycles_alpha.mean()) < 0.01, (alpha.mean(), cycles_alpha.mean())
    if not transparent:  # the world shows where nothing is held out
        assert np.mean(alpha == 1.0) > 0.8
    rgb, a = comparisons(result, runs)
    print(f"RGB {rgb.describe()}\nalpha {a.describe()}\nmean alpha {alpha.mean():.4f}, "
          f"Cycles {cycles_alpha.mean():.4f}")
    assert rgb.agree, rgb.describe()
    assert a.agree, a.describe()


def test_transparency_that_ignores_the_tint_disagrees(scene, cycles_transparent):
    rgb, a = comparisons(render_specula(scene, "transparent", tint_ignored=True),
                         cycles_transparent)
    assert not a.agree and a.max_z > 2 * a.z_threshold, a.describe()
    assert math.isfinite(rgb.max_z)


def test_a_holdout_left_out_disagrees(scene, cycles_transparent):
    _, a = comparisons(render_specula(scene, "transparent", holdout_left_out=True),
                       cycles_transparent)
    assert not a.agree and a.max_z > 2 * a.z_threshold, a.describe()


def test_transparent_glass_ignored_disagrees(scene, cycles_transparent_glass):
    """The world behind the glass sphere and the pane seen, as without the option."""
    _, a = comparisons(render_specula(scene, "transparent"), cycles_transparent_glass)
    assert not a.agree and a.max_z > 2 * a.z_threshold, a.describe()


def test_a_threshold_below_the_panes_roughness_disagrees(scene, cycles_transparent_glass):
    """The frosted pane (roughness 0.15) opaque against the world at a threshold of 0.1:
    only Cycles' threshold^4 rule on alpha_x alpha_y tells 0.15 from 0.2 and 0.1."""
    _, a = comparisons(render_specula(scene, "transparent_glass", threshold=0.1),
                       cycles_transparent_glass)
    assert not a.agree and a.max_z > 2 * a.z_threshold, a.describe()

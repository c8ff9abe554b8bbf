"""IORs below 1 and at or below 0 as Cycles renders them.

Rendered live (a small scene, four Cycles seeds): a smooth and a rough (0.3) Glass BSDF, a
green Principled BSDF (roughness 0.3) and a smooth Principled of Transmission 1, all at
one IOR, on a diffuse floor under a sun and a blue world.

- IOR 0.5: each interface reflects with the real Fresnel of 0.5, total internal
  reflection beyond 30 degrees included; Cycles dims what lies below a Principled
  specular layer by its albedo estimate read from a table made for IORs >= 1 at 1 / 0.5's
  place (bsdf._lobe_row). With the estimate taken at 0.5 itself Specula disagreed at
  |z| inf.
- IOR 0 (and anything below 1e-5, NaN too): Cycles clamps it to 1e-5 (fmaxf in
  svm_node_closure_bsdf), which makes glass a mirror but at normal incidence; Specula
  clamps it the same, with a warning naming the node (it once rendered them at 1.5).

Deliberately wrong renders disagree: IOR 2 for 0.5 (the same F0, no total internal
reflection), 1.5 for 0.
"""

import numpy as np
import pytest

from . import harness, renderers

pytestmark = pytest.mark.slow

RESOLUTION = (48, 36)
SAMPLES = 256  # Cycles, per seed
SPECULA_SAMPLES = 1024
SEEDS = (1, 2, 3, 4)
SHADERS = {"Glass": ("ShaderNodeBsdfGlass", {"Roughness": 0.0}),
           "Frosted": ("ShaderNodeBsdfGlass", {"Roughness": 0.3}),
           "Green": ("ShaderNodeBsdfPrincipled", {"Roughness": 0.3,
                                                  "Base Color": (0.2, 0.6, 0.3, 1.0)}),
           "Clear": ("ShaderNodeBsdfPrincipled", {"Roughness": 0.0,
                                                  "Transmission Weight": 1.0})}


def build():
    from blend_scenes import build_scenes as bs
    scene = renderers.sky_and_sun_scene(RESOLUTION, 0.2)
    coll = scene.collection
    bs.quad("Floor", [(-4, -3, -0.7), (4, -3, -0.7), (4, 4, -0.7), (-4, 4, -0.7)],
            bs.diffuse("Clay", (0.8, 0.35, 0.2)), coll)
    for (name, (shader, inputs)), centre, radius in zip(
            SHADERS.items(), [(-1.5, 0, 0), (0, 0, 0), (1.5, 0, 0), (0.7, -1.3, 1.2)],
            (0.6, 0.6, 0.6, 0.35)):
        bs.uv_sphere(name, centre, radius, bs.material(name, shader, **inputs), coll)
    return scene


def set_ior(ior):
    import bpy
    for name, (shader, _) in SHADERS.items():
        node = next(n for n in bpy.data.materials[name].node_tree.nodes
                    if n.bl_idname == shader)
        node.inputs["IOR"].default_value = ior


def render_cycles(scene, ior):
    set_ior(ior)
    return harness.cycles_runs(scene, SAMPLES, SEEDS)


def render_specula(scene, ior):
    """Specula's RenderResult and the exporter's warnings."""
    set_ior(ior)
    return harness.specula_live(scene, SPECULA_SAMPLES)


agreement = harness.compare_live


@pytest.fixture(scope="module")
def scene():
    return build()


@pytest.mark.parametrize("ior, wrong", [(0.5, 2.0), (0.0, 1.5)], ids=["half", "zero"])
def test_iors_below_one_and_zero_agree_with_cycles(scene, ior, wrong):
    runs = render_cycles(scene, ior)
    result, warnings = render_specula(scene, ior)
    assert np.all(np.isfinite(result.combined))
    if ior < 1e-5:  # each material's node named, the clamp said
        assert sorted(w.split("'")[1] for w in warnings) == sorted(SHADERS), warnings
        assert all("IOR 0 is below 1e-05; using 1e-05" in w for w in warnings), warnings
    else:
        assert warnings == [], warnings
    c = agreement(result, runs)
    print(f"IOR {ior}: {c.describe()}")
    assert c.agree, c.describe()
    wrong_c = agreement(render_specula(scene, wrong)[0], runs)
    print(f"IOR {wrong} against Cycles at {ior}: {wrong_c.describe()}")
    assert not wrong_c.agree and wrong_c.max_z > 2 * wrong_c.z_threshold, wrong_c.describe()

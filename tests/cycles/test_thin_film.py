"""The Principled BSDF's Thin Film as Cycles renders it.

Rendered live (a small scene, four Cycles seeds) under a sun and a blue world over a grey
floor: a film on each lobe it changes (fresnel.thin_film_dielectric, thin_film_f82):

- "Oil": a dark dielectric, roughness 0.2 (the layered specular of bsdf.eval_layered),
  its film 150 or 900 nm thick in the squares of a Checker Texture (through Map Range: a
  program of the film, shading.pair_at);
- "Lacquer": the same smooth (Cycles' delta roughness) over red, a thicker film;
- "Anodised": metallic, roughness 0.15 (bsdf.eval_rough_conductor, the complex phase of
  the metal under the film);
- "Chrome": metallic, smooth (the smooth metal's F82 under the film);
- "Bubble": Transmission 1, smooth (bsdf.sample_dielectric; its back faces read the film
  relative to the glass, integrator.film_at);
- "Frost": Transmission 1, roughness 0.25, under a Specular Tint (fresnel.film_tinted).

Deliberately wrong renders disagree: the films left out (what Specula rendered before),
every film 20 % thicker (its colours shift), and Oil's film its mean thickness.
"""

import numpy as np
import pytest

from . import harness, renderers

pytestmark = pytest.mark.slow

RESOLUTION = (64, 48)
SAMPLES = 256  # Cycles, per seed
SPECULA_SAMPLES = 1024
SEEDS = (1, 2, 3, 4)
PRINCIPLED = "ShaderNodeBsdfPrincipled"
# name: (inputs, centre, radius)
SPHERES = {
    "Oil": ({"Base Color": (0.05, 0.05, 0.05, 1.0), "Roughness": 0.2,
             "Thin Film Thickness": 420.0, "Thin Film IOR": 2.2}, (-2.0, 0.4, 0.1), 0.6),
    "Lacquer": ({"Base Color": (0.5, 0.05, 0.05, 1.0), "Roughness": 0.0,
                 "Thin Film Thickness": 900.0, "Thin Film IOR": 1.8}, (-0.7, 0.4, 0.1), 0.6),
    "Anodised": ({"Base Color": (0.9, 0.6, 0.3, 1.0), "Metallic": 1.0, "Roughness": 0.15,
                  "Thin Film Thickness": 300.0, "Thin Film IOR": 1.5}, (0.6, 0.4, 0.1), 0.6),
    "Chrome": ({"Base Color": (0.8, 0.8, 0.85, 1.0), "Metallic": 1.0, "Roughness": 0.0,
                "Thin Film Thickness": 250.0, "Thin Film IOR": 2.0}, (1.9, 0.4, 0.1), 0.6),
    "Bubble": ({"Base Color": (1.0, 1.0, 1.0, 1.0), "Transmission Weight": 1.0,
                "Roughness": 0.0, "IOR": 1.33, "Thin Film Thickness": 500.0,
                "Thin Film IOR": 1.4}, (-0.6, -1.3, -0.2), 0.45),
    "Frost": ({"Base Color": (0.8, 0.9, 1.0, 1.0), "Transmission Weight": 1.0,
               "Roughness": 0.25, "IOR": 1.5, "Specular Tint": (1.0, 0.7, 0.9, 1.0),
               "Thin Film Thickness": 650.0, "Thin Film IOR": 1.3}, (0.7, -1.3, -0.2), 0.45),
}


def build():
    import bpy

    from blend_scenes import build_scenes as bs
    scene = renderers.sky_and_sun_scene(RESOLUTION, 0.2)
    coll = scene.collection
    bs.quad("Floor", [(-5, -4, -0.7), (5, -4, -0.7), (5, 5, -0.7), (-5, 5, -0.7)],
            bs.diffuse("Grey", (0.5, 0.5, 0.5)), coll)
    for name, (inputs, centre, radius) in SPHERES.items():
        bs.uv_sphere(name, centre, radius, bs.material(name, PRINCIPLED, **inputs), coll)
    tree = bpy.data.materials["Oil"].node_tree
    checker = tree.nodes.new("ShaderNodeTexChecker")
    checker.inputs["Scale"].default_value = 3.0
    ramp = tree.nodes.new("ShaderNodeMapRange")
    ramp.name = "Thickness"
    ramp.inputs["To Min"].default_value, ramp.inputs["To Max"].default_value = OIL
    tree.links.new(checker.outputs["Fac"], ramp.inputs["Value"])
    tree.links.new(ramp.outputs["Result"], _node("Oil").inputs["Thin Film Thickness"])
    return scene


# Oil's film thicknesses (nm), the checker's two.
OIL = (150.0, 900.0)


def _node(name, kind=PRINCIPLED):
    import bpy
    return next(n for n in bpy.data.materials[name].node_tree.nodes if n.bl_idname == kind)


def set_thickness(scale, oil_mean=False):
    """Every film's thickness times `scale` (0: no films); `oil_mean`: Oil's film its mean
    thickness, not its texture's."""
    import bpy
    for name, (inputs, _, _) in SPHERES.items():
        _node(name).inputs["Thin Film Thickness"].default_value = \
            inputs["Thin Film Thickness"] * scale
    tree = bpy.data.materials["Oil"].node_tree
    ramp = tree.nodes["Thickness"]
    ramp.inputs["To Min"].default_value = OIL[0] * scale
    ramp.inputs["To Max"].default_value = OIL[1] * scale
    socket = _node("Oil").inputs["Thin Film Thickness"]
    if oil_mean:
        for link in list(socket.links):
            tree.links.remove(link)
        socket.default_value = 0.5 * (OIL[0] + OIL[1]) * scale
    elif not socket.is_linked:
        tree.links.new(ramp.outputs["Result"], socket)


def render_cycles(scene):
    set_thickness(1.0)
    return harness.cycles_runs(scene, SAMPLES, SEEDS)


def render_specula(scene, scale=1.0, samples=SPECULA_SAMPLES, oil_mean=False):
    """Specula's RenderResult and the exporter's warnings, films `scale` times as thick."""
    set_thickness(scale, oil_mean)
    return harness.specula_live(scene, samples)


agreement = harness.compare_live


@pytest.fixture(scope="module")
def scene():
    return build()


def test_thin_films_agree_with_cycles(scene):
    runs = render_cycles(scene)
    result, warnings = render_specula(scene)
    assert warnings == [], warnings
    assert np.all(np.isfinite(result.combined))
    c = agreement(result, runs)
    print(f"thin films: {c.describe()}")
    harness.save_diagnostics("thin_film", result, runs, c)
    assert c.agree, c.describe()
    for scale, oil_mean, what in ((0.0, False, "left out"), (1.2, False, "20 % thicker"),
                                  (1.0, True, "textured as its mean")):
        wrong = agreement(render_specula(scene, scale, SPECULA_SAMPLES // 4, oil_mean)[0],
                          runs)
        print(f"films {what}: {wrong.describe()}")
        assert not wrong.agree and wrong.max_z > 2 * wrong.z_threshold, wrong.describe()

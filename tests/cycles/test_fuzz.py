"""The randomised comparison (fuzz.py): the generator covers what Specula supports, the
shrinker reduces a disagreement to its cause, a fixed set of random scenes agrees with
Cycles, and the same comparison catches a deliberately wrong renderer on a random scene."""

import json

import pytest

from . import fuzz, harness
from .test_power import _light_power_plus_5_percent, _one_bounce_fewer

# Seeds CI renders (a few seconds each at fuzz.SAMPLES on 2 cores): scenes that agreed in
# the first `make fuzz` run, chosen greedily to cover every material kind, light type and
# area shape, both camera types, shift, clipping, both apertures, a focus object and both
# world kinds (test_ci_seeds_cover_the_features); the other seeds are for `make fuzz`.
# Seeds 8 and 38 are regression scenes: they disagreed until specular lobes took Cycles'
# valid-reflection normal (a smooth metal monkey) and sphere lights lit points inside them
# (a point light poking through the ceiling). Seed 19 (a spot light through the ceiling)
# is fixed too, but at 128 samples its corner is noise-limited (|z| 5.8; 2.5 at 256, 3.2 at
# 1024): variants.spot_through_ceiling is its regression scene.
CI_SEEDS = (0, 2, 4, 6, 7, 8, 10, 13, 15, 22, 32, 37, 38)


def test_random_scene_is_pure_and_serialisable():
    for seed in range(20):
        a, b = fuzz.random_scene(seed), fuzz.random_scene(seed)
        assert a == b
        assert json.loads(json.dumps(a)) == a
    assert fuzz.random_scene(1) != fuzz.random_scene(2)


def _all_features(seeds, avoid_known=False):
    found = set()
    for seed in seeds:
        p = fuzz.random_scene(seed, avoid_known)
        found.update(o["material"]["kind"] for o in p["objects"])
        found.update(o["shape"] for o in p["objects"])
        found.update(light["type"] for light in p["lights"])
        found.update(light["shape"] for light in p["lights"] if light["type"] == "AREA")
        found.update(f"radius>0:{light['type']}" for light in p["lights"] if light.get("radius"))
        found.update(f"scaled:{light['type']}" for light in p["lights"]
                     if light["scale"] != [1.0, 1.0, 1.0])
        found.update("sun angle" for light in p["lights"] if light.get("angle"))
        found.update("spread" for light in p["lights"] if light.get("spread", 4) < 3.14)
        found.update("visible light" for light in p["lights"] if light["visible_camera"])
        found.update("hard falloff" for light in p["lights"] if light.get("soft_falloff") is False)
        found.update(f"world:{p['world']['kind']}" for _ in [0])
        found.update(f"sky:{p['world']['type']}" for _ in [0] if p["world"]["kind"] == "sky")
        found.update(f"world:{p['world']['light_path']['flag']}" for _ in [0]
                     if p["world"].get("light_path"))
        cam = p["camera"]
        found.update({cam["type"], cam["sensor_fit"], f"bounces:{p['max_bounces']}"})
        found.update({"shift"} if any(cam["shift"]) else set())
        found.update({"clip"} if cam["clip_start"] > 0.1 or cam["clip_end"] < 100 else set())
        if cam["dof"]:
            d = cam["dof"]
            found.add("dof blades" if d["blades"] else "dof disk")
            found.update({"dof ratio"} if d["ratio"] != 1.0 else set())
            found.update({"focus object"} if d["focus_object"] else set())
        found.update("principled emission" for o in p["objects"]
                     if o["material"].get("emission_strength"))
        found.update("rough glossy" for o in p["objects"]
                     if o["material"]["kind"] == "glossy" and o["material"]["roughness"] > 0)
        found.update("rough glass" for o in p["objects"]
                     if o["material"]["kind"] in ("glass", "principled_glass")
                     and o["material"]["roughness"] > 0)
        found.update("rough metal" for o in p["objects"]
                     if o["material"]["kind"] == "metal" and o["material"]["roughness"] > 0)
        found.update("absorbing glass" for o in p["objects"] if o["material"].get("volume"))
        found.update("mixed shader" for o in p["objects"] if o["material"].get("mix"))
        found.update("alpha" for o in p["objects"] if o["material"].get("alpha"))
        found.update("coat" for o in p["objects"] if o["material"].get("coat"))
        found.update("bump" for o in p["objects"] if o["material"].get("bump"))
        found.update("displacement" for o in p["objects"]
                     if o["material"].get("bump", {}).get("displacement"))
        found.update("sheen" for o in p["objects"] if o["material"].get("sheen"))
        found.update("specular tint" for o in p["objects"]
                     if o["material"].get("specular_tint"))
        found.update("refraction" for o in p["objects"] if o["material"].get("refraction"))
        found.update("textured roughness" for o in p["objects"]
                     if o["material"].get("roughness_checker"))
        found.update("textured specular" for o in p["objects"]
                     if o["material"].get("specular_checker"))
        found.update("thin film" for o in p["objects"] if o["material"].get("thin_film"))
        found.update("textured thin film" for o in p["objects"]
                     if o["material"].get("film_checker"))
        found.update(f"factor:{o['material']['mix']['factor']['kind']}" for o in p["objects"]
                     if o["material"].get("mix", {}).get("factor"))
        found.update("vector transform" for o in p["objects"]
                     if o["material"].get("colour_texture", {}).get("transform"))
        found.update("translucent mix" for o in p["objects"]
                     if o["material"].get("mix", {}).get("shader") == "translucent")
        found.update("smooth monkey" for o in p["objects"]
                     if o["shape"] == "monkey" and o["smooth"])
        found.update(f"known:{k}" for k in fuzz.known_issue_features(p))
    return found


EVERYTHING = {*fuzz.MATERIAL_KINDS, *fuzz.SHAPES, *fuzz.LIGHT_TYPES, "SQUARE", "RECTANGLE",
              "DISK", "ELLIPSE", "radius>0:POINT", "radius>0:SPOT", "scaled:SPOT", "scaled:AREA",
              "sun angle", "spread", "visible light", "hard falloff", "world:black",
              "world:colour", "world:map", "world:sky", "sky:MULTIPLE_SCATTERING",
              "sky:SINGLE_SCATTERING", "sky:PREETHAM",
              *(f"world:{flag}" for flag in fuzz.LIGHT_PATH_FLAGS),
              "PERSP", "ORTHO", "AUTO", "HORIZONTAL", "VERTICAL",
              "shift", "clip", "dof blades", "dof disk", "dof ratio", "focus object",
              "principled emission", "rough glossy", "rough glass", "rough metal", "smooth monkey",
              "absorbing glass", "mixed shader", "alpha", "textured roughness",
              "textured specular", "thin film", "textured thin film",
              "factor:fresnel", "factor:layer_fresnel", "factor:layer_facing", "translucent mix",
              "coat", "refraction", "bump", "specular tint", "sheen", "vector transform",
              "displacement",
              "bounces:0", "bounces:12", "known:a", "known:b", "known:c", "known:d",
              "known:e", "known:f"}


def test_generator_covers_every_supported_feature():
    missing = EVERYTHING - _all_features(range(300))
    assert not missing, f"300 seeds never draw {sorted(missing)}"


def test_avoid_known_leaves_out_the_known_differences():
    for seed in range(100):
        assert fuzz.known_issue_features(fuzz.random_scene(seed, avoid_known=True)) == []


def test_ci_seeds_cover_the_features():
    # What the fixed CI seeds exercise together; the rest is for `make fuzz`.
    found = _all_features(CI_SEEDS)
    wanted = {*fuzz.MATERIAL_KINDS, *fuzz.LIGHT_TYPES, "ORTHO", "PERSP", "world:map",
              "world:colour", "dof blades", "rough glass"}
    assert wanted <= found, f"CI seeds miss {sorted(wanted - found)}"


# ---------------------------------------------------------------------------------------
# The shrinker, against a fake 'disagrees' predicate (no rendering)


def _culprit_predicate(calls):
    """Disagrees while the scene has a glass object of IOR > 1.3 and a spot light with a
    blend > 0: the culprit is the pair."""
    def disagrees(p):
        calls.append(p)
        glass = any(o["material"]["kind"] == "glass" and o["material"]["ior"] > 1.3
                    for o in p["objects"])
        spot = any(light["type"] == "SPOT" and light["spot_blend"] > 0 for light in p["lights"])
        return glass and spot
    return disagrees


def _scene_with_culprits():
    """A random scene with a rich set of features, plus the culprit glass and spot."""
    p = fuzz.random_scene(2)
    p["objects"].append({"id": "Culprit", "shape": "cube", "location": [0.0, 0.0, 0.3],
                         "rotation": [0.3, 0.2, 0.1], "scale": [0.2, 0.2, 0.2], "smooth": False,
                         "terminator_offset": 0.1,
                         "material": {"kind": "glass", "colour": [0.9, 0.8, 0.7], "ior": 1.8}})
    p["lights"].append({"id": "CulpritSpot", "type": "SPOT", "colour": [1.0, 0.5, 0.5],
                        "visible_camera": True, "location": [0.0, 0.0, 1.3],
                        "rotation": [0.2, 0.1, 0.0], "scale": [1.2, 0.8, 1.0], "power": 80.0,
                        "radius": 0.1, "soft_falloff": False, "spot_size": 1.0,
                        "spot_blend": 0.5})
    p["camera"]["dof"] = {"fstop": 2.0, "blades": 5, "rotation": 0.3, "ratio": 1.5,
                          "focus_distance": 3.0, "focus_object": None}
    p["world"] = {"kind": "colour", "colour": [0.2, 0.3, 0.4], "strength": 1.0}
    return p


def test_shrinker_reduces_to_the_culprits():
    p = _scene_with_culprits()
    calls = []
    small, kept, n = fuzz.shrink(p, _culprit_predicate(calls), budget=1000, log=lambda s: None)
    assert n == len(calls)
    assert [o["id"] for o in small["objects"]] == ["Culprit"]
    assert [light["id"] for light in small["lights"]] == ["CulpritSpot"]
    assert small["camera"]["dof"] is None and small["world"] == {"kind": "black"}
    assert not small["ceiling_emitter"]
    assert _culprit_predicate([])(small)
    # Every simplification left would make it agree: the result is 1-minimal.
    assert all(not _culprit_predicate([])(q) for _, q in fuzz.simplifications(small))
    assert len(fuzz.features(small)) < len(fuzz.features(p))
    # The culprits' own inessential parameters went too.
    spot = small["lights"][0]
    assert spot["colour"] == [1.0, 1.0, 1.0] and spot["scale"] == [1.0, 1.0, 1.0]
    assert small["objects"][0]["material"]["colour"] == [0.8, 0.8, 0.8]


def test_shrinker_keeps_to_its_budget_and_never_loses_the_disagreement():
    p = _scene_with_culprits()
    calls = []
    small, kept, n = fuzz.shrink(p, _culprit_predicate(calls), budget=5, log=lambda s: None)
    assert n == len(calls) <= 5
    assert _culprit_predicate([])(small)


def test_shrinker_leaves_a_scene_alone_when_nothing_can_go():
    p = fuzz.random_scene(3)
    small, kept, n = fuzz.shrink(p, lambda q: q == p, budget=1000, log=lambda s: None)
    assert small == p and kept == [] and n == len(fuzz.simplifications(p))


# ---------------------------------------------------------------------------------------
# Rendered: the fixed seeds agree; a wrong renderer is caught


@pytest.mark.slow
@pytest.mark.parametrize("seed", CI_SEEDS)
def test_random_scene_agrees_with_cycles(seed):
    params = fuzz.random_scene(seed)
    c, result, runs, timing = fuzz.compare_scene(params)
    harness.RESULTS.append(("fuzz", f"seed {seed}", c, timing["specula"]))
    if not c.agree:
        harness.save_diagnostics(f"fuzz_seed_{seed}", result, runs, c)
    assert c.agree, f"seed {seed} {fuzz.features(params)}: {c.describe()}"


# error -> (seed whose random scene shows it, injection). Seed 92: a point light is its only
# light object (besides a glass and an emissive Principled glass cube); seed 15: one bounce
# in the box under its ceiling emitter, so one fewer loses all indirect light.
POWER = {"light_power_plus_5_percent": (92, _light_power_plus_5_percent),
         "one_bounce_fewer": (15, _one_bounce_fewer)}


@pytest.mark.slow
@pytest.mark.parametrize("error", list(POWER))
def test_fuzz_comparison_catches_injected_error(error):
    seed, inject = POWER[error]
    params = fuzz.random_scene(seed)
    correct = fuzz.compare_scene(params)[0]
    assert correct.agree, f"seed {seed} must agree first: {correct.describe()}"
    wrong, *_ = fuzz.compare_scene(params, inject=inject)
    harness.RESULTS.append(("fuzz power", f"{error} seed {seed}", wrong, 0.0))
    assert not wrong.agree, f"{error} on seed {seed} was not detected: {wrong.describe()}"

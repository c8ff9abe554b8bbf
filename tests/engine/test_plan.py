"""The plan leaves out what a scene does not need; absent stages never run."""

import numpy as np

from engine import RenderSettings, World, render
from engine.plan import make_plan
from tests import scenes


def boom(*args, **kwargs):
    raise AssertionError("a stage ran that the plan should have left out")


def diffuse_only_scene(**camera_kw):
    b = scenes.cornell_box(spheres=False)
    return b.build(scenes.cornell_camera(**camera_kw), World())


def test_plan_of_cbspheres_lists_every_stage():
    plan = make_plan(scenes.cbspheres(), RenderSettings())
    assert plan.diffuse and plan.mirror and plan.glass and plan.emitters
    assert plan.shading_normals and not plan.dof and not plan.metal
    text = plan.describe()
    for stage in ("sample light", "trace shadow rays", "interpolate shading normals", "glass"):
        assert stage in text
    assert "sample lens" not in text
    assert plan.as_dict()["stages"] == plan.stages()


def test_absent_features_are_not_in_the_kernel():
    """Flat diffuse Cornell box, no DOF: the plan's kernel is compiled without glass,
    mirror, metal, rough lobes, lens and normal interpolation (their code is absent from
    its IR: tests/engine/test_kernel.py)."""
    r = render(diffuse_only_scene(), scenes.settings(width=16, height=12, samples=2,
                                                     kernel="specialised"))
    assert r.plan.stages() == ["generate camera rays", "intersect",
                               "handle escaped rays (black)", "handle emission", "sample light",
                               "trace shadow rays", "sample BSDF (diffuse)"]
    c = r.plan.kernel_constants(False)
    for name in ("HAS_GLASS", "HAS_MIRROR", "HAS_METAL", "HAS_ROUGH", "HAS_DOF",
                 "HAS_SHADING_NORMALS", "HAS_LIGHT_OBJECTS", "HAS_ENVIRONMENT"):
        assert not c[name], name
    assert c["HAS_DIFFUSE"] and c["HAS_EMISSION"] and c["HAS_LIGHT_SAMPLING"]
    assert r.plan.kernel == "specialised"
    assert np.isfinite(r.combined).all() and r.combined[..., :3].mean() > 0


def test_no_emitters_means_no_light_sampling(monkeypatch):
    import engine.renderer
    monkeypatch.setattr(engine.renderer, "LightSampler", boom)
    b = scenes.cornell_box(spheres=False, emitter_radiance=0.0)
    scene = b.build(scenes.cornell_camera(), World((1, 1, 1)))
    r = render(scene, scenes.settings(width=16, height=12, samples=2, kernel="specialised"))
    assert not r.plan.emitters and r.combined[..., :3].mean() > 0
    c = r.plan.kernel_constants(False)
    assert not (c["HAS_LIGHT_SAMPLING"] or c["HAS_EMISSION"] or c["HAS_LIGHT_GRID"])


def test_dof_compiles_the_lens_only_when_on():
    on = render(diffuse_only_scene(use_dof=True, fstop=2.0, focus_distance=3.0),
                scenes.settings(width=16, height=12, samples=1, kernel="specialised"))
    off = render(diffuse_only_scene(), scenes.settings(width=16, height=12, samples=1,
                                                       kernel="specialised"))
    assert on.plan.kernel_constants(False)["HAS_DOF"]
    assert not off.plan.kernel_constants(False)["HAS_DOF"]
    assert "sample lens (disk)" in on.plan.stages() and "sample lens" not in str(off.plan.stages())


def test_plan_is_logged(caplog):
    import logging
    with caplog.at_level(logging.INFO, logger="specula"):
        render(diffuse_only_scene(), scenes.settings(width=8, height=6, samples=1))
    assert any("specula plan" in m and "sample BSDF (diffuse)" in m for m in caplog.messages)

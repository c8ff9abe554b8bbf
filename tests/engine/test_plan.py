"""The plan leaves out what a scene does not need; absent stages never run."""

import numpy as np

from engine import RenderSettings, World, bsdf, camera, render
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


def test_absent_features_do_not_run(monkeypatch):
    """Flat diffuse Cornell box, no DOF: glass, mirror, metal, lens and normal
    interpolation must not run."""
    monkeypatch.setattr(bsdf, "sample_dielectric", boom)
    monkeypatch.setattr(bsdf, "sample_mirror", boom)
    monkeypatch.setattr(bsdf, "sample_metal", boom)
    monkeypatch.setattr(camera.CameraModel, "sample_lens", boom)
    from engine import integrator
    monkeypatch.setattr(integrator.Integrator, "interpolate_normals", boom)
    r = render(diffuse_only_scene(), scenes.settings(width=16, height=12, samples=2,
                                                     kernel="numpy"))
    assert r.plan.stages() == ["numpy kernel", "generate camera rays", "intersect",
                               "handle escaped rays (black)", "handle emission", "sample light",
                               "trace shadow rays", "sample BSDF (diffuse)"]
    assert np.isfinite(r.combined).all() and r.combined[..., :3].mean() > 0


def test_no_emitters_means_no_light_sampling(monkeypatch):
    import engine.renderer
    from engine import integrator
    monkeypatch.setattr(integrator.Integrator, "sample_light", boom)
    monkeypatch.setattr(integrator.Integrator, "handle_emission", boom)
    monkeypatch.setattr(engine.renderer, "LightSampler", boom)
    b = scenes.cornell_box(spheres=False, emitter_radiance=0.0)
    scene = b.build(scenes.cornell_camera(), World((1, 1, 1)))
    r = render(scene, scenes.settings(width=16, height=12, samples=2, kernel="numpy"))
    assert not r.plan.emitters and r.combined[..., :3].mean() > 0


def test_dof_runs_the_lens_only_when_on(monkeypatch):
    calls = []
    original = camera.CameraModel.sample_lens
    monkeypatch.setattr(camera.CameraModel, "sample_lens",
                        lambda self, u: calls.append(len(u)) or original(self, u))
    render(diffuse_only_scene(use_dof=True, fstop=2.0, focus_distance=3.0),
           scenes.settings(width=16, height=12, samples=1, kernel="numpy"))
    assert sum(calls) == 16 * 12
    calls.clear()
    render(diffuse_only_scene(), scenes.settings(width=16, height=12, samples=1, kernel="numpy"))
    assert calls == []


def test_plan_is_logged(caplog):
    import logging
    with caplog.at_level(logging.INFO, logger="specula"):
        render(diffuse_only_scene(), scenes.settings(width=8, height=6, samples=1))
    assert any("specula plan" in m and "sample BSDF (diffuse)" in m for m in caplog.messages)

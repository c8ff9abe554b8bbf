"""Depth of field at its extremes: f-stop 1e-3 and 1e6, focus distance 1e-6 and 1e6,
3 and 64 blades, anamorphic ratio 0.01 and 100, rotation beyond 2 pi. Renders stay
finite and the lens sample distribution still passes its chi-square test.
(f-stop 1e6 against the pinhole image: tests/engine/test_camera.py::
test_fstop_to_infinity_converges_to_the_pinhole_image.)"""

import numpy as np
import pytest

from engine import World, camera, render
from engine.camera import CameraModel
from engine.scene import Camera
from tests import scenes
from tests.engine.test_sampling import polygon_contains
from tests.robustness.helpers import all_finite
from tests.stats import SIGNIFICANCE, chi2_test, expected_2d, histogram_2d, sidak

N, RES = 100_000, 21
LENSES = [
    dict(fstop=1e-3),
    dict(fstop=1e6),
    dict(blades=3, rotation=7.0),
    dict(blades=64, rotation=-20.0),
    dict(ratio=0.01),
    dict(ratio=100.0, blades=5, rotation=4 * np.pi + 0.3),
]
ALPHA = sidak(SIGNIFICANCE, len(LENSES))


@pytest.mark.slow
@pytest.mark.parametrize("lens", LENSES, ids=lambda d: "-".join(f"{k}{v:g}" for k, v in d.items()))
def test_lens_samples_pass_chi_square_at_extreme_settings(lens, rng):
    """Lens points mapped back to the unit aperture (ratio undone, radius divided out) are
    uniform over the disk (in (r^2, phi)) or over the polygon with Cycles' vertex angles."""
    cam = Camera(use_dof=True, **{"fstop": 2.8, **lens})
    model = CameraModel(cam, 8, 8, np.zeros(3))
    data = model.data()
    lens_point = camera.lens_polygon if model.blades else camera.lens_disk
    p = np.array([lens_point(ua, ub, data) for ua, ub in rng.random((N, 2))])
    assert np.isfinite(p).all()
    q = p / model.aperture * np.array([cam.ratio, 1.0])
    if cam.blades >= 3:
        assert polygon_contains(q, cam.blades, cam.rotation).mean() > 1 - 1e-9
        obs = histogram_2d(q, (-1, -1), (1, 1), RES)
        area = 0.5 * cam.blades * np.sin(2 * np.pi / cam.blades)
        exp = expected_2d(lambda x: polygon_contains(x, cam.blades, cam.rotation) / area,
                          (-1, -1), (1, 1), RES, N, sub=48)
    else:
        r2 = np.einsum("ij,ij->i", q, q)
        assert r2.max() <= 1 + 1e-9
        obs = histogram_2d(np.column_stack([r2, np.arctan2(q[:, 1], q[:, 0])]),
                           (0, -np.pi), (1, np.pi), RES)
        exp = np.full_like(obs, N / RES**2)
    pvalue, _ = chi2_test(obs, exp)
    assert pvalue > ALPHA, pvalue


CAMERAS = [
    dict(fstop=1e-3, focus_distance=3.0),
    dict(fstop=1e6, focus_distance=3.0),
    dict(fstop=1.0, focus_distance=1e-6),
    dict(fstop=1.0, focus_distance=1e6),
    dict(fstop=1e-3, focus_distance=1e-6),
    dict(fstop=2.0, focus_distance=3.0, blades=3, rotation=7.0),
    dict(fstop=2.0, focus_distance=3.0, blades=64, rotation=-20.0),
    dict(fstop=2.0, focus_distance=3.0, ratio=0.01),
    dict(fstop=2.0, focus_distance=3.0, ratio=100.0),
]


@pytest.mark.slow
@pytest.mark.parametrize("kw", CAMERAS, ids=lambda d: "-".join(f"{k}{v:g}" for k, v in d.items()))
def test_extreme_depth_of_field_renders_finite(kw):
    """CBspheres in a dim grey world (focus 1e-6 sends rays almost sideways past the
    focus point, as in Cycles, so they see the world rather than the box)."""
    sc = scenes.cornell_box().build(scenes.cornell_camera(use_dof=True, **kw),
                                    World((0.1, 0.1, 0.1)))
    r = render(sc, scenes.settings(width=24, height=18, samples=4, max_bounces=4))
    assert all_finite(r)
    assert r.plan.dof
    assert r.combined[..., :3].mean() > 0

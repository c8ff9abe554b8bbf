"""Every render checks itself: after each pass no pixel of any pass (combined, depth,
normal, error, variance) is NaN or inf; a non-finite sample is left out and reported with
its pixel and the stage that produced it, never written silently. (Radiance from a
poisoned stage: tests/engine/test_render.py::test_non_finite_samples_are_rejected_and_reported.)"""

import numpy as np
import pytest

from engine import integrator, render
from engine.film import Film
from tests import scenes
from tests.patching import one_off_kernels
from tests.robustness.helpers import all_finite

# The poisoned values raise numpy's "invalid value" warnings on their way; expected here.
pytestmark = [pytest.mark.slow, pytest.mark.filterwarnings("ignore::RuntimeWarning")]


@pytest.fixture(scope="module")
def cbspheres():
    return scenes.cbspheres()


def _poisoned_interaction(field, value):
    """surface_interaction with `value` in the hit point (whose z-depth fills the Depth
    pass) or the shading normal, for the first path of a batch on its camera hit only
    (depth pass not yet written), so no other pixel is hit by chance."""
    px = value if field == "depth" else 0.0
    sx = value if field == "normal" else 0.0

    def surface_interaction(i, f, mat, tfar, bu, bv, sc, paths):
        x = original_surface_interaction(i, f, mat, tfar, bu, bv, sc, paths)  # noqa: F821
        if i == 0 and paths.depth[paths.live[0]] == 1e10:
            return Vertex(x.px + px, x.py, x.pz, x.nx, x.ny, x.nz, x.sx + sx,  # noqa: F821
                          x.sy, x.sz, x.mx, x.my, x.mz, x.wox, x.woy, x.woz, x.front, x.f,
                          x.u, x.v, x.mat, x.t, x.scale, x.bx, x.by, x.bz)
        return x
    return surface_interaction


def poison_surface_interaction(monkeypatch, field, value):
    one_off_kernels(monkeypatch, surface_interaction=_poisoned_interaction(field, value),
                    original_surface_interaction=integrator.surface_interaction)


# Each case compiles a poisoned kernel (about 35 s): one infinity, one NaN (the check is
# the same isfinite for both), one in each pass.
@pytest.mark.parametrize("field,value", [("depth", np.inf), ("normal", np.nan)])
def test_non_finite_depth_or_normal_is_left_out_and_named(cbspheres, monkeypatch, field,
                                                          value):
    poison_surface_interaction(monkeypatch, field, value)
    # The plan's own kernel: each poisoned kernel (and its DEBUG twin) is compiled afresh,
    # and the scene's is several times quicker to compile than the generic one.
    r = render(cbspheres, scenes.settings(width=16, height=12, samples=2, threads=1,
                                          light_tracing=False, kernel="specialised"))
    assert all_finite(r)
    # The first camera hit of each chunk (pixel 0) was poisoned, once per sample.
    assert r.warnings == ["stage 'surface interaction (depth/normal pass)' produced a "
                          "non-finite value at pixel (x=0, y=0)"] * 2, r.warnings
    assert r.samples == 2


def test_debug_mode_names_the_stage_at_once(cbspheres, monkeypatch):
    poison_surface_interaction(monkeypatch, "normal", np.nan)
    with pytest.raises(FloatingPointError, match=r"stage 'surface interaction .*pixel \(x=0"):
        render(cbspheres, scenes.settings(width=16, height=12, samples=1, threads=1,
                                          light_tracing=False, kernel="specialised"),
               debug=True)


@pytest.mark.parametrize("name", ["depth", "normal", "combined", "error"])
def test_film_check_names_the_pass_and_pixel(name):
    """The last line of defence: a non-finite value that reached any film array stops the
    render with the pass and pixel named."""
    film = Film(16, 4)
    film.add(np.arange(64), 0, np.ones((64, 3)), np.ones(64), np.ones((64, 3)))
    target = {"depth": film.depth, "normal": film.normal,
              "combined": film.replicate_mean.reshape(64, 3),
              "error": film.replicate_m2.reshape(64, 4)}[name]
    target[2 * 16 + 5] = np.nan
    with pytest.raises(FloatingPointError, match=rf"{name} pass at pixel \(x=5, y=2\)"):
        film.check_finite(1)

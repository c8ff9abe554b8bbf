"""The comparison has power: deliberately wrong renders must disagree with Cycles.

Each injected error is applied to the exported core scene, the render settings or (for
one-sided emission) the integrator, on a variant where the error shows; the correct render
of the same variant must agree (test_agreement.py checks it too) and the wrong one must not.
"""

import dataclasses
import math
import time
from contextlib import contextmanager, nullcontext

import numpy as np
import pytest

from . import harness, renderers


def _ior_plus_3_percent(scene, settings):
    m = scene.materials
    glass = m.kind == renderers.core().scene.GLASS
    scene.materials = dataclasses.replace(m, ior=np.where(glass, m.ior * 1.03, m.ior))
    return scene, settings


def _schlick(scene, settings):
    return scene, dataclasses.replace(settings, fresnel="schlick")


def _fstop_plus_10_percent(scene, settings):
    scene.camera = dataclasses.replace(scene.camera, fstop=scene.camera.fstop * 1.1)
    return scene, settings


def _focus_plus_5_percent(scene, settings):
    cam = scene.camera
    scene.camera = dataclasses.replace(cam, focus_distance=cam.focus_distance * 1.05)
    return scene, settings


def _aperture_half_blade(scene, settings):
    cam = scene.camera
    assert cam.blades >= 3, "the variant must have a polygonal aperture"
    scene.camera = dataclasses.replace(cam, rotation=cam.rotation + math.pi / cam.blades)
    return scene, settings


def _light_power_plus_5_percent(scene, settings):
    scene.lights = [dataclasses.replace(light, power=tuple(1.05 * c for c in light.power))
                    for light in scene.lights]
    return scene, settings


def _one_bounce_fewer(scene, settings):
    return scene, dataclasses.replace(settings, max_bounces=settings.max_bounces - 1)


@contextmanager
def _one_sided_emission():
    """Emitters light only the side their geometric normal faces: camera and BSDF rays see
    no emission from a back face (wraps Integrator.handle_emission), and light samples on
    an emissive triangle seen from behind carry no radiance (wraps LightSampler.sample)."""
    core = renderers.core()
    Integrator, LightSampler = core.integrator.Integrator, core.lights.LightSampler
    handle, sample = Integrator.handle_emission, LightSampler.sample

    def front_only_emission(self, radiance, live, throughput, hits, *args, **kwargs):
        add = np.zeros_like(radiance)
        handle(self, add, live, throughput, hits, *args, **kwargs)
        rows = live[hits.front]
        radiance[rows] += add[rows]

    def front_only_sample(self, p, u_select, u_point, *args, **kwargs):
        wi, dist, value, *rest = sample(self, p, u_select, u_point, *args, **kwargs)
        # Redo the (deterministic) choice of emitter to find the triangles among them.
        k = self.distribution.sample(u_select)
        on_tri = np.nonzero(k < self.num_triangles)[0]
        c = self.corners[k[on_tri]]
        normal = np.cross(c[:, 1] - c[:, 0], c[:, 2] - c[:, 0])
        behind = np.einsum("ij,ij->i", normal, wi[on_tri]) > 0  # light faces away from p
        value = value.copy()
        value[on_tri[behind]] = 0.0
        return (wi, dist, value, *rest)

    Integrator.handle_emission = front_only_emission
    LightSampler.sample = front_only_sample
    # The patched stages are the numpy integrator's: render with it (the compiled kernels
    # reproduce it bit for bit, tests/engine/test_kernel.py).
    available, core.kernel.AVAILABLE = core.kernel.AVAILABLE, False
    try:
        yield
    finally:
        Integrator.handle_emission, LightSampler.sample = handle, sample
        core.kernel.AVAILABLE = available


# error name -> (variant where it shows, scene/settings injection, integrator patch)
INJECTIONS = {
    "ior_plus_3_percent": ("glass_chart_145", _ior_plus_3_percent, None),
    "schlick_fresnel": ("glass_sheet_fresnel", _schlick, None),
    "fstop_plus_10_percent": ("dof_blades", _fstop_plus_10_percent, None),
    "focus_distance_plus_5_percent": ("dof_blades", _focus_plus_5_percent, None),
    "aperture_rotated_half_blade": ("dof_blades", _aperture_half_blade, None),
    "one_bounce_fewer": ("cbspheres_bounces_3", _one_bounce_fewer, None),
    "one_sided_emission": ("emitter_direct", None, _one_sided_emission),
    "light_power_plus_5_percent": ("light_area_square", _light_power_plus_5_percent, None),
}


@pytest.mark.slow
@pytest.mark.parametrize("error", list(INJECTIONS))
def test_comparison_rejects_injected_error(error):
    name, inject, patch = INJECTIONS[error]
    correct = harness.agreement(name)
    assert correct.agree, f"correct render of {name} must agree first: {correct.describe()}"
    t0 = time.perf_counter()
    with patch() if patch else nullcontext():
        wrong = renderers.render_specula(harness.VARIANTS[name], inject)
    c = harness.compare_render(name, wrong, f"power: {error}", time.perf_counter() - t0)
    assert not c.agree, f"{error} on {name} was not detected: {c.describe()}"

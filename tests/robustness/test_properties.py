"""Property-based tests (hypothesis): the BSDF and camera functions, driven with random
and extreme inputs, return finite, bounded outputs."""

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from engine import Camera, bsdf, camera
from engine.camera import CameraModel
from tests.engine.test_camera import rays

SETTINGS = settings(max_examples=150, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])
N = 8

unit_float = st.floats(0.0, 1.0, allow_nan=False, width=64)
component = st.one_of(st.floats(-1.0, 1.0, allow_nan=False),
                      st.sampled_from([0.0, -0.0, 1e-8, -1e-8, 1e-300, 1.0, -1.0]))
etas = st.one_of(st.floats(1e-3, 1e3, allow_nan=False),
                 st.sampled_from([1.0, 1.0001, 1 / 1.0001, 100.0, 0.01, 1.5, 1 / 1.5]))


@st.composite
def unit_vectors(draw, n=N):
    v = draw(hnp.arrays(np.float64, (n, 3), elements=component))
    length = np.linalg.norm(v, axis=1, keepdims=True)
    v = np.where(length > 1e-150, v / np.where(length > 1e-150, length, 1.0), [0.0, 0.0, 1.0])
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def hemisphere_pair(wo, n):
    """Flip n to wo's side (the integrator's convention), keeping grazing cases."""
    return np.where((np.einsum("ij,ij->i", wo, n) < 0)[:, None], -n, n)


@SETTINGS
@given(wo=unit_vectors(), n=unit_vectors(), eta=etas,
       u=hnp.arrays(np.float64, (N,), elements=st.floats(0.0, 1.0 - 1e-16)),
       tints=hnp.arrays(np.float64, (2, 3), elements=unit_float),
       model=st.sampled_from(["exact", "schlick"]))
def test_dielectric_is_finite_and_bounded(wo, n, eta, u, tints, model):
    n = hemisphere_pair(wo, n)
    exact = model == "exact"
    for k in range(N):
        f, cos_t = bsdf.fresnel_dielectric(float(n[k] @ wo[k]), eta, exact)
        # cos_t = sqrt(eta^2 - 1 + cos_i^2) / eta loses ~eps / eta^2 for eta -> 0 (1.4e-11
        # above 1 at eta = 1e-3); harmless, as sampled directions are renormalised.
        assert 0 <= f <= 1 and 0 <= cos_t <= 1 + 1e-9
        for fresnel_on in (True, False):  # the Glass BSDF's, the Refraction BSDF's
            out = bsdf.sample_dielectric(*wo[k], *n[k], eta, tints[0], tints[1], np.ones(3),
                                         u[k], exact, fresnel_on)
            wi, w = np.array(out[:3]), np.array(out[3:6])
            assert np.isfinite(wi).all() and np.isfinite(w).all()
            assert np.isclose(np.linalg.norm(wi), 1.0)
            # Weight R/p or T/(1-p) with p the lobes' mean: at most 3x the largest tint.
            assert np.all(w >= 0) and np.all(w <= 3.0 * max(tints.max(), 0.0) + 1e-9)
        # White tints: the weight is exactly 1 (energy conserved, no eta^2 factor).
        out = bsdf.sample_dielectric(*wo[k], *n[k], eta, np.ones(3), np.ones(3), np.ones(3),
                                     u[k], exact, True)
        assert np.allclose(out[3:6], 1.0)


@SETTINGS
@given(wo=unit_vectors(), n=unit_vectors(), ng=unit_vectors(),
       u=hnp.arrays(np.float64, (N, 2), elements=st.floats(0.0, 1.0 - 1e-16)),
       colour=hnp.arrays(np.float64, (3,), elements=unit_float))
def test_lambert_mirror_metal_are_finite_and_bounded(wo, n, ng, u, colour):
    ng = hemisphere_pair(wo, ng)
    ns = hemisphere_pair(wo, n)
    for k in range(N):
        wx, wy, wz, pdf, ok = bsdf.sample_lambert(*n[k], *ng[k], *u[k])
        assert np.isfinite([wx, wy, wz, pdf]).all() and pdf >= 0
        p = bsdf.eval_lambert(wx, wy, wz, *n[k])
        assert np.isfinite(p) and 0 <= p <= 1 / np.pi + 1e-12
        wx, wy, wz, cos_o = bsdf.reflect(*wo[k], *ns[k])
        assert np.isclose(np.linalg.norm([wx, wy, wz]), 1.0)
        for c in colour:
            f = bsdf.fresnel_schlick_conductor(cos_o, c)
            assert np.isfinite(f) and 0 <= f <= 1.0 + 1e-12


cameras = st.builds(
    Camera,
    type=st.sampled_from(["PERSP", "ORTHO"]),
    lens_mm=st.one_of(st.floats(1.0, 5000.0), st.just(1e-3)),
    ortho_scale=st.floats(1e-4, 1e4),
    sensor_fit=st.sampled_from(["AUTO", "HORIZONTAL", "VERTICAL"]),
    shift_x=st.floats(-2, 2), shift_y=st.floats(-2, 2),
    clip_start=st.sampled_from([0.0, 1e-6, 0.1]),
    clip_end=st.sampled_from([1.0, 1e3, 1e6]),
    use_dof=st.booleans(),
    fstop=st.sampled_from([1e-3, 0.5, 2.8, 1e6]),
    focus_distance=st.sampled_from([0.0, 1e-6, 1.0, 1e6]),
    blades=st.sampled_from([0, 3, 5, 64]),
    rotation=st.floats(-100.0, 100.0),
    ratio=st.sampled_from([0.01, 1.0, 100.0]),
)


@SETTINGS
@given(cam=cameras, size=st.tuples(st.integers(1, 4000), st.integers(1, 4000)),
       raster=hnp.arrays(np.float64, (N, 2), elements=st.floats(-2.0, 1.0)),
       u=hnp.arrays(np.float64, (N, 2), elements=st.floats(0.0, 1.0 - 1e-16)))
def test_camera_rays_are_finite_unit_and_start_inside_the_clip_range(cam, size, raster, u):
    cam.validate()
    model = CameraModel(cam, size[0], size[1], np.zeros(3))
    o, d, tmax = rays(cam, raster * np.array(size) * 1.5, size[0], size[1], u)
    assert np.isfinite(o).all() and np.isfinite(d).all() and np.isfinite(tmax).all()
    assert np.allclose(np.linalg.norm(d, axis=1), 1.0)
    assert np.all(tmax > 0)
    if cam.use_dof:
        data = model.data()
        lens_point = camera.lens_polygon if model.blades else camera.lens_disk
        lens = np.array([lens_point(ua, ub, data) for ua, ub in u])
        assert np.isfinite(lens).all()
        r = model.aperture
        assert np.all(np.abs(lens[:, 1]) <= r * (1 + 1e-9))
        assert np.all(np.abs(lens[:, 0]) <= r / cam.ratio * (1 + 1e-9))

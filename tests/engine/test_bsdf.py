"""Delta lobes by exact values; Lambert by its closed forms."""

import numpy as np
import pytest

from engine import bsdf

Z = np.array([[0.0, 0.0, 1.0]])


def direction(theta, phi=0.3):
    return np.array([[np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)]])


@pytest.mark.parametrize("eta", [1.5, 1 / 1.5])
def test_normal_incidence_reflects_four_percent_from_both_sides(eta):
    f, cos_t = bsdf.fresnel_dielectric(np.array([1.0]), np.array([eta]))
    assert f[0] == pytest.approx(0.04, abs=1e-12)
    assert cos_t[0] == pytest.approx(1.0)
    fs, _ = bsdf.fresnel_schlick_dielectric(np.array([1.0]), np.array([eta]))
    assert fs[0] == pytest.approx(0.04, abs=1e-12)


def test_total_internal_reflection_past_the_critical_angle():
    ior = 1.5
    critical = np.arcsin(1 / ior)
    cos_i = np.cos(np.array([critical + 1e-6, critical + 0.1, np.pi / 2 - 1e-9]))
    for fn in (bsdf.fresnel_dielectric, bsdf.fresnel_schlick_dielectric):
        f, cos_t = fn(cos_i, np.full(3, 1 / ior))
        assert np.all(f == 1.0) and np.all(cos_t == 0.0)
    f, _ = bsdf.fresnel_dielectric(np.cos(np.array([critical - 1e-3])), np.array([1 / ior]))
    assert f[0] < 1.0
    # Sampling under TIR always reflects, with weight = reflection tint.
    wo = direction(critical + 0.2)
    wi, w, pdf, transmitted = bsdf.sample_dielectric(
        np.repeat(wo, 100, 0), np.repeat(Z, 100, 0), np.full(100, 1 / ior),
        np.ones((100, 3)) * 0.7, np.ones((100, 3)), np.linspace(0, 0.999, 100))
    assert not transmitted.any()
    assert np.allclose(w, 0.7) and np.all(np.isinf(pdf))
    assert np.allclose(wi, bsdf.reflect(np.repeat(wo, 100, 0), np.repeat(Z, 100, 0)))


@pytest.mark.parametrize("eta", [1.45, 2.4, 1 / 1.45, 1 / 1.2])
@pytest.mark.parametrize("theta", [0.0, 0.3, 0.7, 1.2])
def test_snells_law(eta, theta):
    wo = direction(theta)
    f, cos_t = bsdf.fresnel_dielectric(wo[:, 2], np.array([eta]))
    if f[0] == 1.0:
        pytest.skip("total internal reflection")
    wt = bsdf.refract(wo, Z, np.array([eta]), cos_t)
    assert np.linalg.norm(wt) == pytest.approx(1.0)
    assert wt[0, 2] < 0  # through the surface
    sin_i = np.linalg.norm(wo[0, :2])
    sin_t = np.linalg.norm(wt[0, :2])
    assert eta * sin_t == pytest.approx(sin_i, abs=1e-12)  # n_i sin_i = n_t sin_t
    # The refracted ray stays in the plane of incidence, on the other side of the normal.
    if sin_i > 0:
        assert np.allclose(wt[0, :2] / sin_t, -wo[0, :2] / sin_i)


def test_fresnel_matches_closed_forms():
    # Brewster's angle: the parallel component vanishes, F = r_perp^2 / 2.
    n = 1.5
    tb = np.arctan(n)
    f, cos_t = bsdf.fresnel_dielectric(np.array([np.cos(tb)]), np.array([n]))
    ci, ct = np.cos(tb), cos_t[0]
    assert f[0] == pytest.approx(0.5 * ((ci - n * ct) / (ci + n * ct)) ** 2, rel=1e-12)
    # Grazing incidence reflects everything; IOR 1 reflects nothing.
    assert bsdf.fresnel_dielectric(np.array([0.0]), np.array([1.5]))[0][0] == 1.0
    c = np.linspace(1e-6, 1, 50)
    assert np.all(bsdf.fresnel_dielectric(c, np.ones(50))[0] == 0.0)


@pytest.mark.parametrize("ior", [1.33, 1.45, 1.5, 1.6])
def test_schlick_within_its_known_bound_of_exact(ior):
    """Schlick's approximation (cosine in the thinner medium) stays within 0.06 of the
    exact unpolarised Fresnel reflectance for common glasses, from both sides.
    Measured maxima: 0.060 (1.33), 0.040 (1.45), 0.036 (1.5)."""
    c = np.linspace(0, 1, 20001)
    for eta in (ior, 1 / ior):
        exact, _ = bsdf.fresnel_dielectric(c, np.full_like(c, eta))
        approx, _ = bsdf.fresnel_schlick_dielectric(c, np.full_like(c, eta))
        assert np.abs(exact - approx).max() <= 0.061


def test_dielectric_lobe_selection_follows_fresnel_and_weights_are_the_colour(rng):
    n = 200_000
    wo = np.repeat(direction(1.0), n, 0)
    eta = np.full(n, 1.45)
    colour = np.tile([0.9, 0.5, 0.2], (n, 1))
    wi, w, _, transmitted = bsdf.sample_dielectric(wo, np.repeat(Z, n, 0), eta, colour, colour,
                                                   rng.random(n))
    f = bsdf.fresnel_dielectric(wo[:1, 2], eta[:1])[0][0]
    reflected = 1 - transmitted.mean()
    assert abs(reflected - f) < 4 * np.sqrt(f * (1 - f) / n)
    # Glass BSDF: weight = Color whichever lobe is chosen (Cycles' singular weight).
    assert np.allclose(w, colour)


def test_principled_transmission_tints_only_transmission():
    wo = direction(0.5)
    base = np.array([[0.25, 0.64, 1.0]])
    refl_tint, trans_tint = np.ones((1, 3)), np.sqrt(base)
    f = bsdf.fresnel_dielectric(wo[:, 2], np.array([1.5]))[0][0]
    pr = f / (f + (1 - f) * trans_tint.mean())
    _, w_r, _, t_r = bsdf.sample_dielectric(wo, Z, np.array([1.5]), refl_tint, trans_tint,
                                            np.array([0.0]))
    _, w_t, _, t_t = bsdf.sample_dielectric(wo, Z, np.array([1.5]), refl_tint, trans_tint,
                                            np.array([0.9999]))
    assert not t_r[0] and t_t[0]
    assert np.allclose(w_r * pr, f)  # untinted reflection, divided by its probability
    assert np.allclose(w_t * (1 - pr), (1 - f) * np.sqrt(base))


def test_mirror_reflects_colour_at_every_angle():
    for theta in (0.0, 0.5, 1.5):
        wo = direction(theta)
        wi, w, pdf = bsdf.sample_mirror(wo, Z, np.array([[0.3, 0.6, 0.9]]))
        assert np.allclose(w, [0.3, 0.6, 0.9]) and np.isinf(pdf[0])
        assert np.allclose(wi, [[-wo[0, 0], -wo[0, 1], wo[0, 2]]])


def test_metal_is_schlick_with_base_colour_at_normal_incidence():
    base = np.array([[1.0, 0.8, 0.4]])
    _, w0, _ = bsdf.sample_metal(Z, Z, base)
    assert np.allclose(w0, base)
    _, w1, _ = bsdf.sample_metal(direction(np.pi / 2 - 1e-9), Z, base)
    assert np.allclose(w1, 1.0, atol=1e-6)
    c = 0.4
    _, w2, _ = bsdf.sample_metal(direction(np.arccos(c)), Z, base)
    assert np.allclose(w2, base + (1 - base) * (1 - c) ** 5)


def test_lambert_weight_and_pdf(rng):
    n = 50_000
    wo = np.repeat(direction(0.4), n, 0)
    nz = np.repeat(Z, n, 0)
    colour = np.tile([0.5, 0.25, 1.0], (n, 1))
    wi, w, pdf = bsdf.sample_diffuse(wo, nz, nz, colour, rng.random((n, 2)))
    assert np.allclose(w, colour) and np.all(wi[:, 2] > 0)
    f_cos, pdf_eval = bsdf.eval_diffuse(wi, nz, colour)
    assert np.allclose(pdf, pdf_eval)
    assert np.allclose(f_cos / pdf_eval[:, None], colour)
    # A light below the geometric surface but above the shading horizon is evaluated by the
    # shading normal alone (Cycles' bsdf_diffuse_eval: the shadow ray decides), while
    # sampling never returns such a direction (above).
    below = np.array([[0.0, 0.6, -0.8]])
    f_cos, pdf_b = bsdf.eval_diffuse(below, np.array([[0.0, 1.0, 0.0]]), colour[:1])
    assert np.allclose(f_cos, colour[:1] * 0.6 / np.pi) and pdf_b[0] == pytest.approx(0.6 / np.pi)
    f_cos, pdf_b = bsdf.eval_diffuse(below, Z, colour[:1])
    assert np.all(f_cos == 0) and pdf_b[0] == 0

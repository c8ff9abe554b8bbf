"""Delta lobes by exact values; Lambert by its closed forms; Oren-Nayar by its energy."""

import math

import numpy as np
import pytest

from engine import bsdf

Z = np.array([0.0, 0.0, 1.0])
BELOW_ONE = 1.0 - 1e-12  # a lobe-choice u that picks transmission unless F is 1


def direction(theta, phi=0.3):
    return np.array([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)])


def fresnel(cos_i, eta, exact=True):
    """fresnel_dielectric over an array of cosines: (F, cos_t) arrays."""
    return np.vectorize(lambda c: bsdf.fresnel_dielectric(c, eta, exact))(cos_i)


def sample_dielectric(wo, eta, r_tint, t_tint, u, exact=True, st=(1.0, 1.0, 1.0)):
    """sample_dielectric about +z for one wo and an array of u: wi (m, 3), weight (m, 3),
    ok (m,)."""
    r_tint, t_tint = np.asarray(r_tint, np.float64), np.asarray(t_tint, np.float64)
    st = np.asarray(st, np.float64)
    out = np.vectorize(lambda uk: bsdf.sample_dielectric(*wo, *Z, eta, r_tint, t_tint, st, uk,
                                                          exact, True))(np.atleast_1d(u))
    return np.column_stack(out[:3]), np.column_stack(out[3:6]), out[6]


@pytest.mark.parametrize("eta", [1.5, 1 / 1.5])
def test_normal_incidence_reflects_four_percent_from_both_sides(eta):
    f, cos_t = bsdf.fresnel_dielectric(1.0, eta, True)
    assert f == pytest.approx(0.04, abs=1e-12)
    assert cos_t == pytest.approx(1.0)
    fs, _ = bsdf.fresnel_dielectric(1.0, eta, False)  # Schlick
    assert fs == pytest.approx(0.04, abs=1e-12)


def test_total_internal_reflection_past_the_critical_angle():
    ior = 1.5
    critical = np.arcsin(1 / ior)
    cos_i = np.cos(np.array([critical + 1e-6, critical + 0.1, np.pi / 2 - 1e-9]))
    for exact in (True, False):
        f, cos_t = fresnel(cos_i, 1 / ior, exact)
        assert np.all(f == 1.0) and np.all(cos_t == 0.0)
    f, _ = bsdf.fresnel_dielectric(np.cos(critical - 1e-3), 1 / ior, True)
    assert f < 1.0
    # Sampling under TIR always reflects, with weight = reflection tint.
    wo = direction(critical + 0.2)
    wi, w, ok = sample_dielectric(wo, 1 / ior, [0.7] * 3, [1.0] * 3, np.linspace(0, 0.999, 100))
    assert ok.all() and np.all(wi @ Z > 0)  # nothing transmitted
    assert np.allclose(w, 0.7)
    assert np.allclose(wi, bsdf.reflect(*wo, *Z)[:3])


@pytest.mark.parametrize("eta", [1.45, 2.4, 1 / 1.45, 1 / 1.2])
@pytest.mark.parametrize("theta", [0.0, 0.3, 0.7, 1.2])
def test_snells_law(eta, theta):
    wo = direction(theta)
    f, cos_t = bsdf.fresnel_dielectric(wo[2], eta, True)
    if f == 1.0:
        pytest.skip("total internal reflection")
    wt, w, ok = sample_dielectric(wo, eta, [1.0] * 3, [1.0] * 3, BELOW_ONE)
    wt = wt[0]
    assert ok[0] and np.allclose(w, 1.0)
    assert np.linalg.norm(wt) == pytest.approx(1.0)
    assert wt[2] < 0  # through the surface
    assert -wt[2] == pytest.approx(cos_t, abs=1e-12)  # the cosine the Fresnel term reports
    sin_i = np.linalg.norm(wo[:2])
    sin_t = np.linalg.norm(wt[:2])
    assert eta * sin_t == pytest.approx(sin_i, abs=1e-12)  # n_i sin_i = n_t sin_t
    # The refracted ray stays in the plane of incidence, on the other side of the normal.
    if sin_i > 0:
        assert np.allclose(wt[:2] / sin_t, -wo[:2] / sin_i)


def test_fresnel_matches_closed_forms():
    # Brewster's angle: the parallel component vanishes, F = r_perp^2 / 2.
    n = 1.5
    tb = np.arctan(n)
    f, cos_t = bsdf.fresnel_dielectric(np.cos(tb), n, True)
    ci, ct = np.cos(tb), cos_t
    assert f == pytest.approx(0.5 * ((ci - n * ct) / (ci + n * ct)) ** 2, rel=1e-12)
    # Grazing incidence reflects everything; IOR 1 reflects nothing.
    assert bsdf.fresnel_dielectric(0.0, 1.5, True)[0] == 1.0
    c = np.linspace(1e-6, 1, 50)
    assert np.all(fresnel(c, 1.0)[0] == 0.0)


@pytest.mark.parametrize("ior", [1.33, 1.45, 1.5, 1.6])
def test_schlick_within_its_known_bound_of_exact(ior):
    """Schlick's approximation (cosine in the thinner medium) stays within 0.06 of the
    exact unpolarised Fresnel reflectance for common glasses, from both sides.
    Measured maxima: 0.060 (1.33), 0.040 (1.45), 0.036 (1.5)."""
    c = np.linspace(0, 1, 20001)
    for eta in (ior, 1 / ior):
        exact, _ = fresnel(c, eta, True)
        approx, _ = fresnel(c, eta, False)
        assert np.abs(exact - approx).max() <= 0.061


def test_dielectric_lobe_selection_follows_fresnel_and_weights_are_the_colour(rng):
    n = 200_000
    wo = direction(1.0)
    colour = [0.9, 0.5, 0.2]
    wi, w, ok = sample_dielectric(wo, 1.45, colour, colour, rng.random(n))
    f = bsdf.fresnel_dielectric(wo[2], 1.45, True)[0]
    assert ok.all()
    reflected = np.mean(wi @ Z > 0)
    assert abs(reflected - f) < 4 * np.sqrt(f * (1 - f) / n)
    # Glass BSDF: weight = Color whichever lobe is chosen (Cycles' singular weight).
    assert np.allclose(w, colour)


def test_principled_transmission_tints_only_transmission():
    wo = direction(0.5)
    base = np.array([0.25, 0.64, 1.0])
    refl_tint, trans_tint = np.ones(3), np.sqrt(base)
    f = bsdf.fresnel_dielectric(wo[2], 1.5, True)[0]
    pr = f / (f + (1 - f) * trans_tint.mean())
    wi_r, w_r, _ = sample_dielectric(wo, 1.5, refl_tint, trans_tint, 0.0)
    wi_t, w_t, _ = sample_dielectric(wo, 1.5, refl_tint, trans_tint, 0.9999)
    assert wi_r[0] @ Z > 0 and wi_t[0] @ Z < 0  # reflected, then transmitted
    assert np.allclose(w_r * pr, f)  # untinted reflection, divided by its probability
    assert np.allclose(w_t * (1 - pr), (1 - f) * np.sqrt(base))


def test_mirror_reflects_about_the_normal_at_every_angle():
    # The mirror's weight is its colour (the integrator's sampling stage); its direction is
    # reflect's, which also returns the cosine the metal's Fresnel reads.
    for theta in (0.0, 0.5, 1.5):
        wo = direction(theta)
        *wi, cos_o = bsdf.reflect(*wo, *Z)
        assert np.allclose(wi, [-wo[0], -wo[1], wo[2]])
        assert cos_o == pytest.approx(np.cos(theta))


def test_metal_is_schlick_with_base_colour_at_normal_incidence():
    base = np.array([1.0, 0.8, 0.4])

    def metal_weight(wo):  # as the integrator: the Fresnel at reflect's cosine, per channel
        cos_o = bsdf.reflect(*wo, *Z)[3]
        return np.array([bsdf.fresnel_schlick_conductor(cos_o, f0) for f0 in base])

    assert np.allclose(metal_weight(Z), base)
    assert np.allclose(metal_weight(direction(np.pi / 2 - 1e-9)), 1.0, atol=1e-6)
    c = 0.4
    assert np.allclose(metal_weight(direction(np.arccos(c))), base + (1 - base) * (1 - c) ** 5)


# (A tint near 0 on a dark F0 drives the curve below 0 near grazing, where it is clamped;
# Cycles' Fss is the unclamped curve's average, as f82_fss.)
@pytest.mark.parametrize("f0, tint", [(0.9, 0.2), (0.5, 1.0), (0.95, 0.6), (0.1, 0.5)])
def test_f82_tint_scales_schlick_at_82_degrees_and_averages_as_cycles_says(f0, tint):
    """The F82-tint Fresnel (Cycles' metallic Principled): F0 head-on, Schlick's value times
    the Specular Tint at cos = 1/7, Schlick's itself with a white tint; its cosine-weighted
    average is f82_fss (the energy compensation's Fss), by quadrature."""
    b = bsdf.f82_tint_b(f0, tint)
    assert bsdf.fresnel_f82(1.0, f0, b) == pytest.approx(f0)
    schlick = bsdf.fresnel_schlick_conductor(1.0 / 7.0, f0)
    assert bsdf.fresnel_f82(1.0 / 7.0, f0, b) == pytest.approx(schlick * tint)
    mu = (np.arange(4000) + 0.5) / 4000  # midpoints
    average = np.mean([2.0 * m * bsdf.fresnel_f82(m, f0, b) for m in mu])
    assert bsdf.f82_fss(f0, b) == pytest.approx(average, abs=1e-6)
    assert bsdf.f82_tint_b(f0, 1.0) == 0.0


def test_lambert_weight_and_pdf(rng):
    n = 50_000
    u = rng.random((n, 2))
    wx, wy, wz, pdf, ok = np.vectorize(lambda ua, ub: bsdf.sample_lambert(*Z, *Z, ua, ub))(
        u[:, 0], u[:, 1])
    wi = np.column_stack([wx, wy, wz])
    assert ok.all() and np.all(wz > 0)
    assert np.allclose(np.linalg.norm(wi, axis=1), 1.0)
    assert np.allclose(pdf, wz / np.pi)
    # eval is f * cos / colour = cos / pi, the sampling pdf: the sampled weight
    # (colour x eval / pdf) is the colour.
    f_cos = np.vectorize(lambda x, y, z: bsdf.eval_lambert(x, y, z, *Z))(wx, wy, wz)
    assert np.allclose(f_cos, pdf)
    # A light below the geometric surface but above the shading horizon is evaluated by the
    # shading normal alone (Cycles' bsdf_diffuse_eval: the shadow ray decides), while
    # sampling never returns such a direction.
    below = (0.0, 0.6, -0.8)
    assert bsdf.eval_lambert(*below, 0.0, 1.0, 0.0) == pytest.approx(0.6 / np.pi)
    assert bsdf.eval_lambert(*below, *Z) == 0.0
    s = direction(0.6, 1.0)  # shading normal tilted off the geometric normal Z
    wx, wy, wz, _, ok = np.vectorize(lambda ua, ub: bsdf.sample_lambert(*s, *Z, ua, ub))(
        u[:, 0], u[:, 1])
    assert np.array_equal(ok, wz > 0) and 0 < ok.mean() < 1
    assert np.all(wx * s[0] + wy * s[1] + wz * s[2] > 0)


def test_bump_shadowing_follows_cycles():
    """Cycles' bump_shadowing_term (Conty Estevez et al.): 1 without a normal map; 0 where
    the light and the mapped normal lie on different sides of the smooth surface (any lobe
    evaluated, a diffuse one sampled too); a diffuse lobe's GGX masking G1 by the tilt."""
    b = (0.0, 0.0, 1.0)
    assert bsdf.bump_shadowing(*b, *b, 0.3, 0.1, 0.9, True, True) == 1.0
    s = (np.sin(0.5), 0.0, np.cos(0.5))  # tilted 0.5 rad toward +x
    w = (np.cos(1.3), 0.0, -np.sin(0.05))  # under the smooth surface, over s
    w = np.array(w) / np.linalg.norm(w)
    assert np.dot(s, w) > 0 and w[2] < 0
    assert bsdf.bump_shadowing(*b, *s, *w, True, False) == 0.0
    assert bsdf.bump_shadowing(*b, *s, *w, False, True) == 0.0
    assert bsdf.bump_shadowing(*b, *s, *w, False, False) == 1.0
    w = np.array((0.3, 0.0, 0.5)) / np.linalg.norm((0.3, 0.0, 0.5))
    alpha2 = 0.125 * (1 / np.cos(0.5) ** 2 - 1)
    g1 = 1 / (1 + 0.5 * (np.sqrt(1 + alpha2 * (1 / w[2] ** 2 - 1)) - 1))
    assert bsdf.bump_shadowing(*b, *s, *w, True, True) == pytest.approx(g1)
    assert bsdf.bump_shadowing(*b, *s, *w, False, True) == 1.0


def test_a_specular_tint_moves_f0_and_keeps_the_curve():
    """Cycles' generalized Schlick Fresnel under a Specular Tint: F0 x tint (at most 1) at
    normal incidence, 1 at grazing and under total internal reflection, the real curve's
    place between F0 and 1 in between; a white tint is the real Fresnel to the bit."""
    from engine.fresnel import fresnel_dielectric, tinted_fresnel
    for eta in (1.5, 1 / 1.5, 2.4):
        f0 = ((eta - 1) / (eta + 1)) ** 2
        for cos in np.linspace(0.0, 1.0, 41):
            f = fresnel_dielectric(cos, eta, True)[0]
            assert tinted_fresnel(f, eta, 1.0) == f
            lo, hi = tinted_fresnel(f, eta, 0.5), tinted_fresnel(f, eta, 3.0)
            assert 0.0 <= lo <= f <= hi <= 1.0
            s = (f - f0) / (1 - f0)
            assert lo == pytest.approx(0.5 * f0 + (1 - 0.5 * f0) * s, abs=1e-12)
        assert tinted_fresnel(fresnel_dielectric(1.0, eta, True)[0], eta, 0.5) == \
            pytest.approx(0.5 * f0)
        assert tinted_fresnel(f0, eta, 100.0) == 1.0
        assert tinted_fresnel(1.0, eta, 0.2) == 1.0  # grazing, total internal reflection


def _oren_nayar_albedo(roughness, cos_o, colour, n=16384, seed=7):
    """The directional albedo of Oren-Nayar (colour `colour`) at a view of cosine cos_o,
    estimated with cosine-weighted directions (the ratio over Lambert is the weight)."""
    rng = np.random.default_rng(seed)
    u = rng.random((n, 2))
    r, phi = np.sqrt(u[:, 0]), 2.0 * np.pi * u[:, 1]
    wi = np.stack([r * np.cos(phi), r * np.sin(phi), np.sqrt(1.0 - u[:, 0])], 1)
    wo = (math.sqrt(1.0 - cos_o ** 2), 0.0, cos_o)
    k = np.array([bsdf.oren_nayar_ratio(*wo, *w, 0.0, 0.0, 1.0, roughness, *colour)
                  for w in wi])
    return colour * k.mean(axis=0)


@pytest.mark.parametrize("roughness", [0.3, 1.0])
@pytest.mark.parametrize("cos_o", [1.0, 0.5, 0.1])
def test_oren_nayar_keeps_a_white_surfaces_energy(roughness, cos_o):
    """Cycles' Oren-Nayar with its multiple-scattering term reflects all the light a white
    surface gets, at every view (the single-scattering model alone loses up to 22 %), and
    a grey one less than white; at roughness 0 it is Lambert."""
    white = _oren_nayar_albedo(roughness, cos_o, np.ones(3))
    # (the OpenPBR term is a fit: within 1.5 % of 1, against 0.78 without it)
    assert white == pytest.approx(1.0, abs=0.015)
    grey = _oren_nayar_albedo(roughness, cos_o, np.full(3, 0.5))
    assert np.all(grey < 0.5 * white)
    assert bsdf.oren_nayar_ratio(0.0, 0.0, 1.0, 0.6, 0.0, 0.8, 0.0, 0.0, 1.0, 0.0,
                                 0.5, 0.5, 0.5) == pytest.approx((1.0, 1.0, 1.0))


def test_oren_nayar_brightens_toward_the_light_as_rough_surfaces_do():
    """Rough surfaces back-scatter: seen from beside the light (retro-reflection) a rough
    surface is brighter than Lambert, seen from the far side darker."""
    light = (0.6, 0.0, 0.8)
    back = bsdf.oren_nayar_ratio(0.6, 0.0, 0.8, *light, 0.0, 0.0, 1.0, 1.0, 0.5, 0.5, 0.5)
    away = bsdf.oren_nayar_ratio(-0.6, 0.0, 0.8, *light, 0.0, 0.0, 1.0, 1.0, 0.5, 0.5, 0.5)
    assert back[0] > 1.0 > away[0]

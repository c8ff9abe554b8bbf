"""Rough glass (bsdf.py): GGX reflection and refraction with Cycles' glass energy
compensation, sampled and evaluated consistently on both sides of the surface."""

import math

import numpy as np
import pytest

from engine import Material, World, bsdf, render
from engine.jit import njit
from engine.scene import Materials
from tests import scenes
from tests.stats import SIGNIFICANCE, chi2_test, expected_2d, histogram_2d, sidak

N = 200_000
RES = 24


def glass_lobe(alpha, eta, comp=1.0, r_tint=(1.0, 1.0, 1.0), t_tint=(1.0, 1.0, 1.0)):
    return bsdf.Layer(0.0, 0.0, 0.0, *r_tint, alpha, eta, True, comp, comp, comp, 1.0, *t_tint,
                      0.0, 0.0, 0.0, 1.0, 1.0, 1.0)


@njit(cache=True)
def sample_about_z(wo, lobe, u):
    """sample_rough_dielectric about +z (shading = geometric normal) for stratum points
    u (m, 3): wi (m, 3), weight (m, 3), pdf (m,), ok (m,)."""
    wi, w, pdf = np.empty((len(u), 3)), np.empty((len(u), 3)), np.empty(len(u))
    ok = np.empty(len(u), np.bool_)
    for k in range(len(u)):
        r = bsdf.sample_rough_dielectric(wo[0], wo[1], wo[2], 0.0, 0.0, 1.0, 0.0, 0.0, 1.0,
                                         lobe, u[k, 0], u[k, 1], u[k, 2])
        wi[k, 0], wi[k, 1], wi[k, 2] = r[0], r[1], r[2]
        w[k, 0], w[k, 1], w[k, 2], pdf[k], ok[k] = r[3], r[4], r[5], r[6], r[7]
    return wi, w, pdf, ok


@njit(cache=True)
def eval_about_z(wo, wi, lobe, physical_only):
    """eval_rough_dielectric about +z toward directions wi (m, 3): f cos (m,), pdf (m,).
    physical_only: zero where the microfacet that would join wo and wi faces away from
    either (a configuration sampling never produces, which Cycles still evaluates)."""
    f, pdf = np.empty(len(wi)), np.empty(len(wi))
    for k in range(len(wi)):
        g0, _, _, p = bsdf.eval_rough_dielectric(wo[0], wo[1], wo[2], wi[k, 0], wi[k, 1],
                                                 wi[k, 2], 0.0, 0.0, 1.0, lobe)
        if physical_only:
            transmit = wi[k, 2] < 0.0
            s = lobe.eta if transmit else 1.0
            hx, hy, hz = -(s * wi[k, 0] + wo[0]), -(s * wi[k, 1] + wo[1]), -(s * wi[k, 2] + wo[2])
            if hz < 0.0:
                hx, hy, hz = -hx, -hy, -hz
            ho = hx * wo[0] + hy * wo[1] + hz * wo[2]
            hi = hx * wi[k, 0] + hy * wi[k, 1] + hz * wi[k, 2]
            if not (ho > 0.0 and (hi < 0.0) == transmit):
                g0 = p = 0.0
        f[k], pdf[k] = g0, p
    return f, pdf


def _sphere_pdf(wo, lobe):
    def pdf(q):  # density in (cos theta, phi) = solid-angle pdf
        z, phi = q[:, 0], q[:, 1]
        s = np.sqrt(np.maximum(0, 1 - z * z))
        d = np.column_stack([s * np.cos(phi), s * np.sin(phi), z])
        return eval_about_z(wo, d, lobe, True)[1]
    return pdf


CASES = [(0.09, 0.6, 1.5), (0.3, 1.1, 1.5), (0.3, 1.1, 1 / 1.5), (0.6, 0.3, 1 / 1.5),
         (0.6, 1.3, 1.5)]


@pytest.mark.parametrize("alpha,theta,eta", CASES)
def test_rough_glass_sampling_matches_its_pdf(rng, alpha, theta, eta):
    """Chi-square over the whole sphere: reflected and refracted samples follow the pdf
    eval reports (where a microfacet joins the two directions), and each sample's own pdf
    and weight are eval's."""
    wo = np.array([np.sin(theta), 0.0, np.cos(theta)])
    lobe = glass_lobe(alpha, eta)
    wi, w, pdf_sampled, ok = sample_about_z(wo, lobe, rng.random((N, 3)))
    f, pdf = eval_about_z(wo, wi[ok], lobe, False)
    assert np.allclose(pdf_sampled[ok], pdf, rtol=1e-9)
    assert np.allclose(w[ok, 0], f / pdf, rtol=1e-9)
    pts = np.column_stack([wi[ok, 2], np.arctan2(wi[ok, 1], wi[ok, 0])])
    obs = histogram_2d(pts, (-1, -np.pi), (1, np.pi), RES)
    exp = expected_2d(_sphere_pdf(wo, lobe), (-1, -np.pi), (1, np.pi), RES, N, sub=32)
    p, dof = chi2_test(obs, exp)
    assert p > sidak(SIGNIFICANCE, len(CASES)), (p, dof)


def test_sampling_test_detects_a_wrong_refraction(rng):
    """Power: refracting with a 5 % larger IOR than the pdf assumes fails the test."""
    alpha, theta, eta = 0.3, 1.1, 1.5
    wo = np.array([np.sin(theta), 0.0, np.cos(theta)])
    wi, _, _, ok = sample_about_z(wo, glass_lobe(alpha, eta * 1.05), rng.random((N, 3)))
    pts = np.column_stack([wi[ok, 2], np.arctan2(wi[ok, 1], wi[ok, 0])])
    obs = histogram_2d(pts, (-1, -np.pi), (1, np.pi), RES)
    exp = expected_2d(_sphere_pdf(wo, glass_lobe(alpha, eta)), (-1, -np.pi), (1, np.pi), RES,
                      N, sub=32)
    assert chi2_test(obs, exp)[0] < 1e-6


def _albedo(rng, lobe, mu, n=100_000):
    wo = np.array([math.sqrt(1 - mu * mu), 0.0, mu])
    _, w, _, ok = sample_about_z(wo, lobe, rng.random((n, 3)))
    return np.where(ok, w[:, 0], 0.0).mean()


@pytest.mark.parametrize("roughness", [0.2, 0.5, 0.9])
def test_white_multiscatter_glass_keeps_all_the_energy(rng, roughness):
    """Cycles' Multiscatter GGX glass: with white tints, what the single-scatter lobe
    loses (up to a quarter at roughness 0.9 inside) is given back, on both sides."""
    m = Materials.from_list([Material.glass("g", (1, 1, 1), 1.45, roughness=roughness)])
    lt = bsdf.layer_tables(m, [0])
    for front, eta in ((True, 1.45), (False, 1 / 1.45)):
        missing = lt.missing[0] if front else lt.missing_back[0]
        for mu in (0.2, 0.6, 0.95):
            comp = 1.0 + np.interp(mu, lt.mu, missing)
            single = _albedo(rng, glass_lobe(lt.alpha[0], eta), mu)
            assert _albedo(rng, glass_lobe(lt.alpha[0], eta, comp), mu) == pytest.approx(
                1.0, abs=4e-3)
            assert single * comp == pytest.approx(1.0, abs=4e-3), (front, mu, single)


def test_plain_ggx_glass_loses_energy_and_tinted_glass_darkens():
    """Plain GGX keeps nothing of what single scattering misses; a tinted glass' transmission
    tint is the Fresnel average its compensation darkens by (Fms < tint < 1), the Glass
    BSDF's colour and the Principled's sqrt(base) alike; glass that transmits nothing
    darkens by the dielectric Fresnel's average."""
    plain = Material.glass("g", (1, 1, 1), 1.45, roughness=0.5, multiscatter=False)
    glass = Material.glass("t", (0.5, 0.9, 0.7), 1.45, roughness=0.5)
    pglass = Material.principled_glass("p", (0.25, 0.81, 1.0), 1.5, roughness=0.5)
    black = Material.principled_glass("b", (0.0, 0.0, 0.0), 1.5, roughness=0.5)
    lt = bsdf.layer_tables(Materials.from_list([plain, glass, pglass, black]), [0, 1, 2, 3])
    assert not lt.missing[0].any() and not lt.missing_back[0].any()
    assert lt.missing[1].max() > 0.01
    assert np.all(lt.fms[1] < [0.5, 0.9, 0.7]) and np.all(lt.fms[1] > [0.45, 0.85, 0.65])
    assert np.all(lt.fms[2] < np.sqrt([0.25, 0.81, 1.0]) + 1e-12)
    assert lt.fms[2][2] == pytest.approx(1.0) and lt.fms[2][0] < 0.5
    assert 0.0 < lt.fms[3][0] < 0.15 and lt.fms_back[3][0] > lt.fms[3][0]  # TIR inside


def test_rough_glass_kinds():
    assert Material.glass("g", roughness=0.3).kind == "rough_glass"
    assert Material.glass("g", roughness=0.001).kind == "glass"  # Cycles' delta threshold
    assert Material.glass("g", ior=1.0, roughness=0.3).kind == "glass"  # straight through
    assert Material.principled_glass("p", roughness=0.3).kind == "rough_glass"


@pytest.mark.parametrize("make, roughness", [
    ("glass", 0.0), ("glass", 0.4), ("principled_glass", 0.0), ("principled_glass", 0.4),
    ("refraction", 0.3)])
def test_a_textured_glass_colour_tints_as_the_constant_does(make, roughness):
    """A glass whose colour is a program (a 1 x 1 image of c, its constant standing for it
    grey) renders as the glass of colour c, sample for sample: the tints
    (scene.glass_tints: the Glass BSDF's c and c, the Principled BSDF's 1 and sqrt(c), the
    Refraction BSDF's 0 and c) and, rough, the energy compensation's Fss come from the
    colour at the hit, not from the constant."""
    c = (0.9, 0.5, 0.7)
    texel = np.array([[[*c, 1.0]]], np.float32)
    kwargs = {"roughness": roughness, "ior": 1.5}
    images = []
    for colour, program in ((c, None), ((0.5, 0.5, 0.5), scenes.image_program(texel))):
        b = scenes.cornell_box(spheres=False)
        ball = getattr(Material, make)("ball", colour, colour_program=program, **kwargs)
        v, t, n = scenes.uv_sphere((0.0, 0.0, 0.4), 0.4)
        b.add_mesh("ball", v, t, b.add_material(ball), corner_normals=n,
                   uv_maps={"": np.zeros((len(t), 3, 2))})
        r = render(b.build(scenes.cornell_camera(), World((0, 0, 0))),
                   scenes.settings(width=32, height=24, samples=4, light_tracing=False))
        assert r.plan.textures == (program is not None)
        images.append(r.combined[..., :3])
    np.testing.assert_allclose(images[1], images[0], rtol=1e-6, atol=1e-7)

"""Rough lobes: GGX visible-normal sampling, energy compensation, Principled layering."""

import numpy as np
import pytest

from engine import Camera, Material, RenderSettings, SceneBuilder, World, bsdf, render
from tests.scenes import look_at, uv_sphere
from tests.stats import SIGNIFICANCE, chi2_test, expected_2d, histogram_2d, sidak

N = 200_000
RES = 31


@pytest.mark.parametrize("alpha,theta", [(0.25, 0.5), (0.6, 1.2), (0.05, 0.9)])
def test_ggx_sampling_matches_its_pdf(rng, alpha, theta):
    """Chi-square: VNDF reflection samples follow the pdf eval_ggx reports."""
    wo = np.tile([np.sin(theta), 0.0, np.cos(theta)], (N, 1))
    n = np.tile([0.0, 0.0, 1.0], (N, 1))
    wi = bsdf.sample_ggx_reflection(wo, n, np.full(N, alpha), rng.random((N, 2)))
    up = wi[:, 2] > 0
    pts = np.column_stack([wi[up, 2], np.arctan2(wi[up, 1], wi[up, 0])])
    obs = histogram_2d(pts, (0, -np.pi), (1, np.pi), RES)

    def pdf(q):  # density in (cos theta, phi) = solid-angle pdf
        z, phi = q[:, 0], q[:, 1]
        s = np.sqrt(np.maximum(0, 1 - z * z))
        d = np.column_stack([s * np.cos(phi), s * np.sin(phi), z])
        m = len(d)
        return bsdf.eval_ggx(np.tile(wo[0], (m, 1)), d, np.tile(n[0], (m, 1)),
                             np.full(m, alpha), None, "none")[1]

    exp = expected_2d(pdf, (0, -np.pi), (1, np.pi), RES, N, sub=8)
    p, dof = chi2_test(obs, exp)
    assert p > sidak(SIGNIFICANCE, 3), (p, dof)


@pytest.mark.parametrize("alpha", [0.01, 0.25, 0.64, 1.0])
def test_compensated_ggx_with_unit_fresnel_conserves_energy(alpha):
    """Multiscatter GGX (Kulla-Conty) with F = 1 reflects everything at every angle."""
    t = bsdf.MicrofacetTables(alpha, "none")
    mu = np.linspace(0.05, 1, 20)
    e = np.interp(mu, t.mu, (t.compensation_table - 1))
    assert np.all(e >= 0) and np.allclose(t.albedo(mu), 1.0, atol=1e-9)


def test_single_scatter_albedo_agrees_with_brute_force(rng):
    alpha, mu = 0.25, 0.5
    t = bsdf.MicrofacetTables(alpha, "dielectric", 1.5)
    z = rng.random(1_000_000)
    phi = rng.random(1_000_000) * 2 * np.pi
    s = np.sqrt(1 - z * z)
    wi = np.column_stack([s * np.cos(phi), s * np.sin(phi), z])
    m = len(wi)
    wo = np.tile([np.sqrt(1 - mu * mu), 0, mu], (m, 1))
    f, _ = bsdf.eval_ggx(wo, wi, np.tile([0, 0, 1.0], (m, 1)), np.full(m, alpha),
                         np.full(m, 1.5), "dielectric")
    brute = np.mean(f) * 2 * np.pi * t.compensation(mu)
    assert t.albedo(mu) == pytest.approx(brute, rel=0.01)


def sphere_in_white_world(material, samples=16):
    b = SceneBuilder()
    m = b.add_material(material)
    v, t, n = uv_sphere((0, 0, 0), 1.0, 64, 32)
    b.add_mesh("ball", v, t, m, corner_normals=n)
    scene = b.build(Camera(world_from_camera=look_at((0, -4, 0), (0, 0, 0)), lens_mm=50),
                    World((1.0, 1.0, 1.0)))
    return render(scene, RenderSettings(width=24, height=18, samples=samples, max_bounces=8,
                                        seed=9))


@pytest.mark.slow
def test_white_rough_glossy_is_invisible_in_a_white_furnace():
    """Energy-compensated GGX with F = 1 in a uniform world: the sphere's centre returns
    the world radiance (within noise)."""
    r = sphere_in_white_world(Material.glossy("chrome", (1, 1, 1), roughness=0.6))
    centre = r.combined[6:12, 9:15, 0]
    err = np.sqrt(r.variance[6:12, 9:15, 0].astype(float))
    assert np.all(np.abs(centre - 1.0) < 5 * err + 2e-3), centre


@pytest.mark.slow
def test_principled_in_a_white_furnace_reflects_base_plus_specular():
    """Principled: L = albedo_spec(mu) + base (1 - albedo_spec(mu)) for one bounce off a
    convex object in a white world; with base 1 everything is returned."""
    r = sphere_in_white_world(Material.principled("white", (1, 1, 1), 0.5, 1.5))
    centre = r.combined[6:12, 9:15, 0]
    err = np.sqrt(r.variance[6:12, 9:15, 0].astype(float))
    assert np.all(np.abs(centre - 1.0) < 5 * err + 2e-3)
    r = sphere_in_white_world(Material.principled("black", (0, 0, 0), 0.5, 1.5), samples=64)
    t = bsdf.MicrofacetTables(0.25, "dielectric", 1.5)
    mean = r.combined[8:10, 11:13, 0].mean()  # near normal incidence
    err = np.sqrt(r.variance[8:10, 11:13, 0].astype(float).sum()) / 4
    assert abs(mean - t.albedo(0.99)) < 5 * err + 3e-3, (mean, t.albedo(0.99))


def test_principled_specular_ior_level_rescales_f0():
    m = Material.principled("p", ior=1.5, specular_ior_level=1.0)
    f0 = ((m.ior - 1) / (m.ior + 1)) ** 2
    assert f0 == pytest.approx(0.08)
    assert Material.principled("p", ior=1.5).ior == 1.5
    assert Material.glossy("g", roughness=0.001).kind == "mirror"

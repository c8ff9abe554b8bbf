"""Rough lobes: GGX visible-normal sampling, energy compensation, Principled layering."""

import dataclasses
import math

import numpy as np
import pytest

from engine import Camera, Material, RenderSettings, SceneBuilder, World, bsdf, render
from engine.scene import Materials
from engine.fresnel import fresnel_dielectric, specular_eta
from engine.jit import njit
from tests.scenes import look_at, uv_sphere
from tests.stats import SIGNIFICANCE, chi2_test, expected_2d, histogram_2d, sidak

N = 200_000
RES = 31


def specular_lobe(alpha):
    """A layered lobe that is GGX reflection alone: no base, white tint, no Fresnel and no
    compensation, chosen with probability 1."""
    return bsdf.Layer(0.0, 0.0, 0.0, 1.0, 1.0, 1.0, alpha, 1.5, False, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0,
                      0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0)


@njit(cache=True)
def sample_ggx_about_z(wo, lobe, u):
    """sample_layered about +z for one wo and stratum points u (m, 2): wi (m, 3), pdf (m,)."""
    wi, pdf = np.empty((len(u), 3)), np.empty(len(u))
    for k in range(len(u)):
        r = bsdf.sample_layered(wo[0], wo[1], wo[2], 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0,
                                1.0, lobe, 0.0, u[k, 0], u[k, 1], 0.0, 0.0, 1.0)
        wi[k, 0], wi[k, 1], wi[k, 2], pdf[k] = r[0], r[1], r[2], r[6]
    return wi, pdf


@njit(cache=True)
def eval_ggx_about_z(wo, wi, alpha, eta, fresnel_on):
    """eval_ggx about +z for one wo and directions wi (m, 3): f * cos_i (m,), pdf (m,)."""
    f, pdf = np.empty(len(wi)), np.empty(len(wi))
    for k in range(len(wi)):
        hx, hy, hz = wo[0] + wi[k, 0], wo[1] + wi[k, 1], wo[2] + wi[k, 2]
        hl = max(math.sqrt(hx * hx + hy * hy + hz * hz), 1e-300)
        hx, hy, hz = hx / hl, hy / hl, hz / hl
        f[k], pdf[k] = bsdf.eval_ggx(wo[2], wi[k, 2], hz, hx * wo[0] + hy * wo[1] + hz * wo[2],
                                     alpha * alpha, eta, fresnel_on)
    return f, pdf


@pytest.mark.parametrize("alpha,theta", [(0.25, 0.5), (0.6, 1.2), (0.05, 0.9)])
def test_ggx_sampling_matches_its_pdf(rng, alpha, theta):
    """Chi-square: VNDF reflection samples follow the pdf eval_ggx reports."""
    wo = np.array([np.sin(theta), 0.0, np.cos(theta)])
    wi, pdf_sampled = sample_ggx_about_z(wo, specular_lobe(alpha), rng.random((N, 2)))
    up = wi[:, 2] > 0
    assert np.allclose(pdf_sampled[up], eval_ggx_about_z(wo, wi[up], alpha, 1.5, False)[1])
    pts = np.column_stack([wi[up, 2], np.arctan2(wi[up, 1], wi[up, 0])])
    obs = histogram_2d(pts, (0, -np.pi), (1, np.pi), RES)

    def pdf(q):  # density in (cos theta, phi) = solid-angle pdf
        z, phi = q[:, 0], q[:, 1]
        s = np.sqrt(np.maximum(0, 1 - z * z))
        d = np.column_stack([s * np.cos(phi), s * np.sin(phi), z])
        return eval_ggx_about_z(wo, d, alpha, 1.5, False)[1]

    exp = expected_2d(pdf, (0, -np.pi), (1, np.pi), RES, N, sub=8)
    p, dof = chi2_test(obs, exp)
    assert p > sidak(SIGNIFICANCE, 3), (p, dof)


@pytest.mark.parametrize("alpha", [0.01, 0.25, 0.64, 1.0])
def test_compensated_ggx_with_unit_fresnel_conserves_energy(alpha):
    """Multiscatter GGX (Kulla-Conty) with F = 1 reflects everything at every angle."""
    t = bsdf.MicrofacetTables(alpha, "none")
    mu = np.linspace(0.05, 1, 20)
    e = np.interp(mu, t.mu, (t.compensation_table - 1))
    albedo = np.interp(mu, t.mu, t.albedo_table)
    assert np.all(e >= 0) and np.allclose(albedo, 1.0, atol=1e-9)


def test_single_scatter_albedo_agrees_with_brute_force(rng):
    alpha, mu = 0.25, 0.5
    t = bsdf.MicrofacetTables(alpha, "dielectric", 1.5)
    z = rng.random(1_000_000)
    phi = rng.random(1_000_000) * 2 * np.pi
    s = np.sqrt(1 - z * z)
    wi = np.column_stack([s * np.cos(phi), s * np.sin(phi), z])
    wo = np.array([np.sqrt(1 - mu * mu), 0, mu])
    f, _ = eval_ggx_about_z(wo, wi, alpha, 1.5, True)
    brute = np.mean(f) * 2 * np.pi * np.interp(mu, t.mu, t.compensation_table)
    assert np.interp(mu, t.mu, t.albedo_table) == pytest.approx(brute, rel=0.01)


def test_cycles_albedo_estimate_is_the_smooth_fresnel_for_a_smooth_lobe():
    """Cycles' estimate of a dielectric lobe's albedo (the ggx_gen_schlick_ior_s table:
    the mean over visible normals of the Fresnel's place between F0 and 1) tends to the
    smooth Fresnel as the lobe sharpens, and falls below it at grazing views as it
    roughens; compensated, it is darkened by (1 + Fms (1 - E) / E) E."""
    mu = np.linspace(0.05, 1.0, 20)
    smooth = np.array([fresnel_dielectric(m, 1.5, True)[0] for m in mu])
    sharp = bsdf.MicrofacetTables(1e-4, "dielectric", 1.5)
    np.testing.assert_allclose(np.interp(mu, sharp.mu, sharp.estimate_table), smooth,
                               atol=2e-3)
    rough = bsdf.MicrofacetTables(0.49, "dielectric", 1.5)
    estimate = np.interp(mu, rough.mu, rough.estimate_table)
    assert np.all(estimate[:4] < 0.5 * smooth[:4])
    e = 1.0 / (1.0 + rough.missing_table)
    np.testing.assert_allclose(rough.layering_table,
                               rough.estimate_table * (1.0 + rough.fms * rough.missing_table) * e)


# Cycles' ggx_gen_schlick_ior_s table (intern/cycles/scene/shader.tables) at grid points
# (its indices / 15 over z, roughness and view cosine; IOR from z as Cycles parametrises
# it, F0 = z^4): the interpolation factor s between F0 and 1.
CYCLES_SCHLICK_IOR_S = {(8, 6, 1): 0.269702, (8, 6, 6): 0.085747, (8, 14, 1): 0.054041,
                        (8, 14, 6): 0.021453, (12, 10, 3): 0.003612, (4, 14, 1): 0.028272}


@pytest.mark.parametrize("zi, ri, yi", list(CYCLES_SCHLICK_IOR_S))
def test_cycles_albedo_estimate_matches_its_table(zi, ri, yi):
    """estimate_table against values of Cycles' own table: within 1e-3 of its F0 + (1 -
    F0) s, where the smooth Fresnel (what the coat dimmed by before) is far off (0.70 for
    0.33 at IOR 1.8, roughness 0.4, cosine 1/15)."""
    f0 = (zi / 15) ** 4
    ior = (1 + math.sqrt(f0)) / (1 - math.sqrt(f0))
    rough, mu = ri / 15, yi / 15
    t = bsdf.MicrofacetTables(max(rough * rough, bsdf.MIN_ALPHA), "dielectric", ior)
    cycles = f0 + (1 - f0) * CYCLES_SCHLICK_IOR_S[(zi, ri, yi)]
    assert np.interp(mu, t.mu, t.estimate_table) == pytest.approx(cycles, abs=1e-3)


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
    albedo = np.interp(0.99, t.mu, t.albedo_table)
    assert abs(mean - albedo) < 5 * err + 3e-3, (mean, albedo)


def test_principled_specular_ior_level_rescales_f0():
    """Specular IOR Level scales F0 by 2 x level, and the IOR comes back from F0 clamped
    to 0.99 on the IOR's side of 1, as Cycles' ior_from_F0 (fresnel.specular_eta, which
    the kernel runs per point where they vary)."""
    m = Material.principled("p", ior=1.5, specular_ior_level=1.0)
    f0 = ((m.ior - 1) / (m.ior + 1)) ** 2
    assert f0 == pytest.approx(0.08)
    assert Material.principled("p", ior=1.5).ior == 1.5
    assert Material.glossy("g", roughness=0.001).kind == "mirror"
    assert specular_eta(1.5, 0.0) == 1.0 and specular_eta(0.7, 0.5) == 0.7
    below = specular_eta(0.7, 1.0)
    assert below < 1.0 and ((below - 1) / (below + 1)) ** 2 == \
        pytest.approx(2 * ((0.7 - 1) / 1.7) ** 2)
    assert specular_eta(1.5, 1e3) == pytest.approx((1 + math.sqrt(0.99)) / (1 - math.sqrt(0.99)))
    assert specular_eta(0.0, 0.5) == 1e-5  # Cycles' least IOR


def test_varying_ior_tables_match_the_exact_integrals():
    """The table a varying IOR reads (bsdf.varying_ior_tables: the spread over roughness,
    z and sqrt(mu)) against each (roughness, IOR)'s own MicrofacetTables at random points
    on both sides of 1: Cycles' albedo estimate F0 + (1 - F0) s within 0.015 everywhere
    (the worst is at grazing views, near IOR 1 or of a nearly smooth lobe) and 1.5e-3 on
    average, the
    Fresnel average within 0.1 %; and within 3e-3 of Cycles' own table values. Read on a
    uniform mu axis instead (a wrong lookup) it misses both bounds."""
    spread, fss = bsdf.varying_ior_tables()
    rng = np.random.default_rng(5)

    def table(roughness, eta, mu):
        return bsdf.ior_spread_at(spread, roughness, eta, mu)

    def uniform_mu(roughness, eta, mu):
        return bsdf.ior_spread_at(spread, roughness, eta, mu * mu)

    errors = {table: [], uniform_mu: []}
    for _ in range(40):
        roughness = rng.uniform(0.02, 1.0)
        eta = float(np.exp(rng.uniform(np.log(1.02), np.log(4.0))))
        eta = 1.0 / eta if rng.uniform() < 0.3 else eta
        exact = bsdf.MicrofacetTables(max(roughness ** 2, bsdf.MIN_ALPHA), "dielectric", eta)
        f0 = ((eta - 1) / (eta + 1)) ** 2
        for mu in (0.02, 0.1, 0.3, 0.6, 0.95):
            s = np.interp(mu, exact.mu, exact.spread)
            for read, errs in errors.items():
                errs.append(abs((1 - f0) * (read(roughness, eta, mu) - s)))
        assert bsdf.ior_fss_at(fss, eta) == pytest.approx(exact.fss, rel=1e-3)
    good, wrong = (np.array(e) for e in errors.values())
    assert good.max() < 0.015 and good.mean() < 1.5e-3, (good.max(), good.mean())
    assert wrong.max() > 0.015 and wrong.mean() > 1.5e-3, (wrong.max(), wrong.mean())
    for (zi, ri, yi), s in CYCLES_SCHLICK_IOR_S.items():
        f0 = (zi / 15) ** 4
        eta = (1 + math.sqrt(f0)) / (1 - math.sqrt(f0))
        ours = f0 + (1 - f0) * bsdf.ior_spread_at(spread, ri / 15, eta, yi / 15)
        assert ours == pytest.approx(f0 + (1 - f0) * s, abs=3e-3)


def test_a_varying_ior_layer_is_the_constant_ior_layer_at_the_hit():
    """A Principled layer whose IOR varies (a specular IOR program), read at a hit's
    relative IOR, is the layer of a material with that IOR as its constant, within the
    tables' interpolation: base weight, compensation and the chance of the specular lobe;
    at IOR 1 (Specular IOR Level 0) it has no specular at all."""
    from engine.shading import Program

    def layer(ior, program, eta, roughness=0.3):
        m = Materials.from_list([Material.principled("p", (0.6, 0.4, 0.2), roughness, ior,
                                                     specular_ior_program=program)])
        lt = bsdf.layer_tables(m, [0])
        return bsdf.layer_at(0, 0.4, eta, lt, False, 0.0, 0.0, 0.0, -1.0, (1.0, 1.0, 1.0))

    for eta in (1.2, 1.5, 1.9, 2.6, 1 / 1.4):
        varying, constant = layer(1.5, Program(), eta), layer(eta, None, eta)
        assert varying.eta == constant.eta == eta
        np.testing.assert_allclose(
            [varying.dw0, varying.dw2, varying.comp0, varying.p_spec],
            [constant.dw0, constant.dw2, constant.comp0, constant.p_spec], rtol=0.01, atol=2e-3)
    bare = layer(1.5, Program(), 1.0)
    assert bare.p_spec == 0.0 and bare.comp0 == 1.0 and bare.dw0 == pytest.approx(0.6)
    glossy = dataclasses.replace(Material.glossy("g", roughness=0.3),
                                 specular_ior_program=Program())
    with pytest.raises(ValueError, match="'g': only a Principled BSDF's dielectric layer"):
        Materials.from_list([glossy])


@njit(cache=True)
def sample_metal_about_z(wo, lobe, u):
    """sample_rough_conductor about +z for stratum points u (m, 2): wi (m, 3), weight
    (m, 3), pdf (m,), ok (m,)."""
    wi, w, pdf = np.empty((len(u), 3)), np.empty((len(u), 3)), np.empty(len(u))
    ok = np.empty(len(u), np.bool_)
    for k in range(len(u)):
        r = bsdf.sample_rough_conductor(wo[0], wo[1], wo[2], 0.0, 0.0, 1.0, 0.0, 0.0, 1.0,
                                        lobe, u[k, 0], u[k, 1])
        wi[k, 0], wi[k, 1], wi[k, 2] = r[0], r[1], r[2]
        w[k, 0], w[k, 1], w[k, 2], pdf[k], ok[k] = r[3], r[4], r[5], r[6], r[7]
    return wi, w, pdf, ok


def test_rough_metal_white_furnace_and_schlick_per_channel(rng):
    """Rough metal: with F0 = 1 the compensated lobe reflects everything; a channel's
    albedo grows with its F0 (Schlick at the microfacet), and its pdf is the GGX one."""
    lt = bsdf.layer_tables(Materials.from_list(
        [Material.metal("m", (1.0, 0.6, 0.1), roughness=0.5)]), [0])
    assert Material.metal("s", (1, 1, 1), roughness=0.001).kind == "metal"
    for mu in (0.3, 0.9):
        comp = 1.0 + lt.fms[0] * np.interp(mu, lt.mu, lt.missing[0])
        lobe = bsdf.Layer(0.0, 0.0, 0.0, 1.0, 0.6, 0.1, lt.alpha[0], 1.0, False, *comp, 1.0,
                          0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0)
        wo = np.array([np.sqrt(1 - mu * mu), 0.0, mu])
        wi, w, pdf, ok = sample_metal_about_z(wo, lobe, rng.random((100_000, 2)))
        albedo = np.where(ok[:, None], w, 0.0).mean(axis=0)
        assert albedo[0] == pytest.approx(1.0, abs=5e-3)
        assert albedo[0] > albedo[1] > albedo[2] > 0.05
        up = ok & (wi[:, 2] > 0)
        assert np.allclose(pdf[up], eval_ggx_about_z(wo, wi[up], lt.alpha[0], 1.0, False)[1])


# Textured roughness: the lobe tables on a roughness grid (bsdf.ROUGHNESS_GRID), read
# between its rows at each hit.

def _constant_program(value):
    from engine.shading import Program
    p = Program()
    p.out = p.const((value, value, value))
    return p


@pytest.mark.parametrize("kind", ["principled", "glossy", "metal", "glass", "principled_glass"])
def test_a_textured_roughness_reads_the_tables_a_constant_one_has(kind):
    """A roughness program's lobe at a hit matches the lobe of that roughness as a constant:
    alpha exactly, the compensation within 0.4% and the Principled base's weight within
    1.5% (the tables are interpolated between grid roughnesses, bsdf.ROUGHNESS_GRID), on
    both sides of glass; and the lobe follows the hit's roughness, not the material's
    constant (a lobe read at the mean is 10x further off)."""
    ctor = getattr(Material, kind)
    colour = {"base_colour": (0.9, 0.5, 0.2)} if kind != "glass" else {"colour": (0.9, 0.7, 1)}
    if kind == "glossy":
        colour = {"colour": (0.9, 0.5, 0.2)}
    for r in (0.07, 0.3, 0.55, 0.9):
        plain = ctor("plain", roughness=r, **colour)
        textured = ctor("textured", roughness=0.5, roughness_program=_constant_program(r),
                        **colour)
        m = Materials.from_list([plain, textured])
        assert m.kind[0] == m.kind[1] and m.roughness_programs[1] is not None
        lt = bsdf.layer_tables(m, [0, 1])
        assert lt.count[1] == bsdf.ROUGHNESS_GRID and lt.count[0] == 1
        for mu in (0.05, 0.4, 0.93):
            for front in (True, False):
                want, got, mean = (_lobe(m, lt, row, mu, front, rough)
                                   for row, rough in ((0, -1.0), (1, r), (1, 0.5)))
                assert got[0] == want[0]  # alpha
                np.testing.assert_allclose(got[1:4], want[1:4], rtol=4e-3)
                np.testing.assert_allclose(got[4:], want[4:], rtol=0.015, atol=1e-3)
                if abs(r - 0.5) > 0.2:
                    assert np.abs(np.subtract(mean[1:], want[1:])).max() > \
                        10 * np.abs(np.subtract(got[1:], want[1:])).max()


def _lobe(m, lt, row, mu, front, roughness):
    """alpha, compensation (3) and diffuse weight (3) of row's lobe at view cosine mu."""
    kind = m.kind[row]
    if kind == bsdf.ROUGH_GLASS:
        layer = bsdf.glass_layer_at(row, mu, front, m.ior[row], lt, m.reflection_tint[row],
                                    m.transmission_tint[row], roughness, True, False,
                                    m.specular_tint[row])
    elif kind == bsdf.ROUGH_METAL:
        layer = bsdf.metal_layer_at(row, mu, lt, False, 0.0, 0.0, 0.0, roughness,
                                    m.reflection_tint[row])
    else:
        layer = bsdf.layer_at(row, mu, m.ior[row], lt, False, 0.0, 0.0, 0.0, roughness,
                              m.specular_tint[row])
    return (layer.alpha, layer.comp0, layer.comp1, layer.comp2, layer.dw0, layer.dw1,
            layer.dw2)


# ----------------------------------------------------------------- anisotropic GGX
def anisotropic_lobe(ax, ay, tangent_angle=0.0):
    """specular_lobe made anisotropic: alpha_x ax along the tangent at `tangent_angle`
    about +z, alpha_y across it."""
    return specular_lobe(math.sqrt(ax * ay))._replace(
        ax=ax, ay=ay, tx=math.cos(tangent_angle), ty=math.sin(tangent_angle), tz=0.0)


@njit(cache=True)
def eval_layered_about_z(wo, wi, lobe):
    """eval_layered about +z for one wo and directions wi (m, 3): f * cos_i (m,), pdf (m,)."""
    f, pdf = np.empty(len(wi)), np.empty(len(wi))
    for k in range(len(wi)):
        r = bsdf.eval_layered(wo[0], wo[1], wo[2], wi[k, 0], wi[k, 1], wi[k, 2], 0.0, 0.0, 1.0,
                              0.0, 0.0, 1.0, 0.0, 0.0, 1.0, lobe, True, 0.0, 0.0, 1.0)
        f[k], pdf[k] = r[0], r[3]
    return f, pdf


def hemisphere_grid(n=64):
    """Directions (m, 3) over the upper hemisphere and their solid angles (m,)."""
    z = (np.arange(n) + 0.5) / n
    phi = (np.arange(4 * n) + 0.5) / (4 * n) * 2 * np.pi
    Z, P = np.meshgrid(z, phi, indexing="ij")
    s = np.sqrt(1 - Z * Z)
    d = np.stack([s * np.cos(P), s * np.sin(P), Z], -1).reshape(-1, 3)
    return d, np.full(len(d), 2 * np.pi / (4 * n * n))


@pytest.mark.parametrize("ax,ay,theta,phi_o,angle", [(0.1, 0.5, 0.6, 0.7, 0.4),
                                                      (0.6, 0.15, 1.1, -0.3, -1.0),
                                                      (0.3, 0.3, 0.8, 0.2, 0.9)])
def test_anisotropic_ggx_sampling_matches_its_pdf(rng, ax, ay, theta, phi_o, angle):
    """Chi-square: anisotropic VNDF samples follow the pdf eval_layered reports (Cycles'
    bsdf_aniso_D and bsdf_aniso_lambda about the tangent's frame)."""
    wo = np.array([np.sin(theta) * np.cos(phi_o), np.sin(theta) * np.sin(phi_o),
                   np.cos(theta)])
    lobe = anisotropic_lobe(ax, ay, angle)
    wi, pdf_sampled = sample_ggx_about_z(wo, lobe, rng.random((N, 2)))
    up = wi[:, 2] > 0
    assert np.allclose(pdf_sampled[up], eval_layered_about_z(wo, wi[up], lobe)[1])
    pts = np.column_stack([wi[up, 2], np.arctan2(wi[up, 1], wi[up, 0])])
    obs = histogram_2d(pts, (0, -np.pi), (1, np.pi), RES)

    def pdf(q):
        z, phi = q[:, 0], q[:, 1]
        s = np.sqrt(np.maximum(0, 1 - z * z))
        d = np.column_stack([s * np.cos(phi), s * np.sin(phi), z])
        return eval_layered_about_z(wo, d, lobe)[1]

    exp = expected_2d(pdf, (0, -np.pi), (1, np.pi), RES, N, sub=8)
    p, dof = chi2_test(obs, exp)
    assert p > sidak(SIGNIFICANCE, 3), (p, dof)


@pytest.mark.parametrize("ax,ay", [(0.3, 0.8), (0.5, 0.2), (0.9, 0.1)])
def test_anisotropic_ggx_distribution_is_normalised(ax, ay):
    """The projected microfacet area is the macro surface's: int D(h) cos_h dh = 1."""
    h, dw = hemisphere_grid(512)  # (the midpoint rule's error: 7e-4 at (0.9, 0.1))
    assert float(np.sum(aniso_d_at(h, ax, ay) * h[:, 2] * dw)) == pytest.approx(1.0, abs=1e-3)


@njit(cache=True)
def aniso_d_at(h, ax, ay):
    d = np.empty(len(h))
    for k in range(len(h)):
        d[k] = bsdf.ggx_aniso_d(h[k, 0], h[k, 1], h[k, 2], ax, ay)
    return d


def test_anisotropic_ggx_is_isotropic_at_equal_alphas_and_turns_with_its_tangent():
    """At alpha_x = alpha_y it is the isotropic lobe; swapping the alphas is turning the
    tangent a quarter turn; and it differs from the isotropic lobe of their geometric mean
    (Cycles' roughness for its tables) where they differ."""
    d, _ = hemisphere_grid(16)
    wo = np.array([0.5, 0.3, math.sqrt(1 - 0.34)])
    iso = eval_layered_about_z(wo, d, specular_lobe(0.4))
    np.testing.assert_allclose(eval_layered_about_z(wo, d, anisotropic_lobe(0.4, 0.4, 1.1)),
                               iso, rtol=1e-9, atol=1e-12)
    a = eval_layered_about_z(wo, d, anisotropic_lobe(0.2, 0.8, 0.3))
    b = eval_layered_about_z(wo, d, anisotropic_lobe(0.8, 0.2, 0.3 + math.pi / 2))
    np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-12)
    assert np.max(np.abs(a[0] - iso[0])) > 0.1 * np.max(iso[0])


def test_anisotropic_alphas_follow_cycles_conventions():
    """Principled: alpha_x = r^2 / sqrt(1 - 0.9 a); the Glossy BSDF: r^2 (1 - a) for a >= 0,
    r^2 / (1 + a) below; their product stays r^4; each at most 1."""
    ax, ay = bsdf.anisotropic_alphas(0.5, 0.8, True)
    assert ax == pytest.approx(0.25 / math.sqrt(1 - 0.72)) and ax * ay == pytest.approx(0.5**4)
    ax, ay = bsdf.anisotropic_alphas(0.5, 0.6, False)
    assert (ax, ay) == pytest.approx((0.25 * 0.4, 0.25 / 0.4))
    ax, ay = bsdf.anisotropic_alphas(0.5, -0.6, False)
    assert (ax, ay) == pytest.approx((0.25 / 0.4, 0.25 * 0.4))
    assert bsdf.anisotropic_alphas(1.0, 1.0, True) == pytest.approx((1.0, math.sqrt(0.1)))
    assert not bsdf.is_anisotropic(0.0, True) and not bsdf.is_anisotropic(-0.5, True)
    assert not bsdf.is_anisotropic(5e-5, False) and bsdf.is_anisotropic(-0.5, False)

"""Grazing and degenerate directions: Fresnel, refraction and reflection at cos(theta) =
1e-8, 0 and -0 from both sides, and shading normals facing away from the geometric one."""

import numpy as np
import pytest

from engine import Material, SceneBuilder, bsdf
from tests.robustness.helpers import all_finite, render_sphere_in_world

COSINES = np.array([1.0, 0.5, 1e-8, 0.0, -0.0, -1e-8, -0.5, -1.0])
ETAS = [1.5, 1 / 1.5, 1.0, 2.4, 1 / 2.4]


def _fresnel(exact, cosines, eta):
    out = np.array([bsdf.fresnel_dielectric(c, eta, exact) for c in cosines])
    return out[:, 0], out[:, 1]


@pytest.mark.parametrize("eta", ETAS)
@pytest.mark.parametrize("exact", [True, False], ids=["exact", "schlick"])
def test_fresnel_at_grazing_and_signed_zero(exact, eta):
    f, cos_t = _fresnel(exact, COSINES, eta)
    assert np.isfinite(f).all() and np.isfinite(cos_t).all()
    assert np.all((f >= 0) & (f <= 1)) and np.all((cos_t >= 0) & (cos_t <= 1 + 1e-15))
    # Even in cos(theta): the side is carried by eta, not by the sign of the cosine.
    assert np.array_equal(f, f[::-1]) and np.array_equal(cos_t, cos_t[::-1])
    # Exactly grazing reflects everything (for eta != 1 by the formula, for eta = 1 by the
    # guard against 0/0); 1e-8 from grazing is still almost total.
    assert np.all(f[3:5] == 1.0)
    if eta != 1.0:
        assert np.all(f[[2, 5]] > 0.999)


@pytest.mark.parametrize("eta", ETAS)
@pytest.mark.parametrize("side", [1.0, -1.0])
def test_reflect_refract_and_sample_at_grazing(eta, side):
    """Directions with cos(theta) = 1e-8, 0, -0 about a normal on either side: reflect and
    refract give unit vectors, sampling gives finite weights equal to the tint, so
    energy is conserved (R + T = 1 per sample, no eta^2 factor)."""
    ones = np.ones(3)
    for c in (1e-8, 0.0, -0.0, 1.0):
        s = np.sqrt(1 - c * c)
        wo = np.array([s, 0.0, abs(c) * side])
        n = np.array([0.0, 0.0, side])
        r = np.array(bsdf.reflect(*wo, *n)[:3])
        assert np.isclose(np.linalg.norm(r), 1.0)
        f, _ = bsdf.fresnel_dielectric(float(n @ wo), eta, True)
        for u in (0.0, 0.5, 1.0 - 1e-12):
            wx, wy, wz, f0, f1, f2, ok = bsdf.sample_dielectric(*wo, *n, eta, ones, ones,
                                                                ones, u, True, True)
            wi = np.array([wx, wy, wz])
            assert ok and np.isfinite(wi).all() and np.isclose(np.linalg.norm(wi), 1.0)
            assert np.allclose([f0, f1, f2], 1.0, rtol=0, atol=1e-12)
            if f < 1.0 and u > 0.99:  # transmitted: through to the other side
                assert wi @ n <= 0.0
        for colour in (0.9, 1.0):
            k = [bsdf.fresnel_schlick_conductor(float(n @ wo), colour)]
            assert np.isfinite(k).all() and 0.0 <= k[0] <= 1.0


def test_lambert_with_a_shading_normal_facing_away_from_the_geometric_one(rng):
    """A shading normal bent below the geometric surface: sampling fails cleanly (not ok)
    instead of sending light through the surface; evaluation is 0, never negative."""
    n = 2000
    ng = np.array([0.0, 0.0, 1.0])
    for ns in ([0.0, 0.0, -1.0], [1.0, 0.0, -1e-9], [0.0, 1.0, 0.0]):
        ns = np.array(ns) / np.linalg.norm(ns)
        for ua, ub in rng.random((n, 2)):
            wx, wy, wz, pdf, ok = bsdf.sample_lambert(*ns, *ng, ua, ub)
            assert np.isfinite([wx, wy, wz, pdf]).all()
            assert not ok or wz > 0
            p = bsdf.eval_lambert(wx, wy, wz, *ns)
            assert np.isfinite(p) and p >= 0


@pytest.mark.slow
@pytest.mark.parametrize("material", [Material.diffuse("white", (1, 1, 1)),
                                      Material.glass("glass", (1, 1, 1), 1.5),
                                      Material.mirror("mirror", (1, 1, 1))],
                         ids=["diffuse", "glass", "mirror"])
@pytest.mark.parametrize("bend", ["inverted", "tangent"])
def test_bent_shading_normals_render_finite_without_creating_energy(material, bend,
                                                                    monkeypatch):
    """A sphere whose shading normals are inverted (pointing inward) or tangent to the
    surface, in a white world of radiance 1 with white materials: every pixel finite and
    at most 1 (no energy from nowhere, no NaN from the fallback to the geometric normal)."""
    from tests.robustness import helpers

    def bent_sphere(b, name, m, centre=(0, 0, 0), radius=1.0, segments=64, rings=32):
        v, t, n = helpers.uv_sphere(centre, radius, segments=segments, rings=rings)
        if bend == "inverted":
            n = -n
        else:
            n = np.cross(n, [0.0, 0.0, 1.0]) + 1e-12
        b.add_mesh(name, v, t, m, corner_normals=n)

    monkeypatch.setattr(helpers, "sphere", bent_sphere)
    r = render_sphere_in_world(material, max_bounces=16, samples=8)
    img = r.combined[..., :3]
    assert all_finite(r)
    assert img.min() >= 0 and img.max() <= 1.0 + 1e-9, img.max()


@pytest.mark.parametrize("length,smooth", [(1e-150, True), (1e-200, False)])
def test_builder_keeps_tiny_normals_unit_or_falls_back_to_flat(rng, length, smooth):
    """A reversed shading normal of length 1e-150 is normalised; one of 1e-200 (whose
    length underflows to 0) falls back to the flat normal. Never a NaN."""
    from engine import Camera, World

    b = SceneBuilder()
    m = b.add_material(Material.diffuse("d", (0.5, 0.5, 0.5)))
    b.add_mesh("tri", rng.random((3, 3)), [[0, 1, 2]], m,
               corner_normals=-np.ones((1, 3, 3)) * length)
    sc = b.build(Camera(), World())
    assert bool(sc.smooth[0]) == smooth
    if smooth:
        assert np.allclose(np.linalg.norm(sc.normals, axis=2), 1.0)

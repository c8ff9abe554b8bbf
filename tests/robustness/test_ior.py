"""Index of refraction at its extremes: 1 (invisible), 1.0001, 10, 100, a bubble (< 1),
and invalid values (a clear error naming the material)."""

import numpy as np
import pytest

from engine import Camera, Material, RenderSettings, SceneBuilder, World, bsdf, render
from tests import scenes
from tests.engine.test_integrator import max_block_z
from tests.robustness.helpers import all_finite, look_at, quad, render_sphere_in_world, sphere


@pytest.mark.slow
def test_ior_one_glass_is_invisible_in_the_cornell_box():
    """A glass sphere of IOR exactly 1 in CBspheres renders the same image as the box
    without it (block z-scores, Sidak-corrected at 1 %). Rays cross it unbent with weight
    1; light sampling is blocked by it but BSDF sampling through it then counts fully."""
    st = RenderSettings(width=48, height=36, samples=24, max_bounces=24, seed=21)
    with_glass = scenes.cornell_box(mirror=False, glass_ior=1.0).build(scenes.cornell_camera(),
                                                                       World())
    without = scenes.cornell_box(spheres=False).build(scenes.cornell_camera(), World())
    a = render(with_glass, st)
    b = render(without, RenderSettings(**{**st.__dict__, "seed": 22}))
    z, critical = max_block_z(b, a)
    assert all_finite(a)
    assert z < critical, (z, critical)


def fresnel(cosines, eta):
    out = np.array([bsdf.fresnel_dielectric(c, eta, True) for c in cosines])
    return out[:, 0], out[:, 1]


def test_ior_one_is_exactly_transparent_at_every_angle():
    cos = np.array([1.0, 0.5, 1e-3, 1e-8, 0.0])
    f, cos_t = fresnel(cos, 1.0)
    assert np.all(f[:-1] == 0.0) and np.array_equal(cos_t, cos)


@pytest.mark.parametrize("ior", [1.0001, 10.0, 100.0])
def test_extreme_ior_is_finite_and_never_creates_energy(ior):
    """A white glass sphere in a white world (radiance 1): every pixel finite, in [0, 1]
    (paths trapped by total internal reflection until the bounce limit lose energy, none
    gains any). IOR 1.0001 is invisible to round-off."""
    r = render_sphere_in_world(Material.glass("g", (1, 1, 1), ior), max_bounces=32)
    img = r.combined[..., :3]
    assert all_finite(r)
    assert img.min() >= 0.0 and img.max() <= 1.0 + 1e-9, (img.min(), img.max())
    if ior < 1.001:
        assert np.abs(img - 1.0).max() < 1e-6


@pytest.mark.parametrize("ior", [1.0001, 10.0, 100.0, 0.5])
def test_dielectric_lobes_sum_to_one_for_extreme_ior(ior, rng):
    """Per sample the weight is the tint whichever lobe is chosen, and R + T = 1 (energy
    conserved exactly, no eta^2 scaling), from both sides."""
    n = 4000
    cos = np.concatenate([rng.random(n - 4), [1.0, 1e-8, 0.0, -0.0]])
    sin = np.sqrt(1 - cos**2)
    ones = np.ones(3)
    for eta in (ior, 1 / ior):
        f, _ = fresnel(cos, eta)
        assert np.all((f >= 0) & (f <= 1))
        out = np.array([bsdf.sample_dielectric(s, 0.0, c, 0.0, 0.0, 1.0, eta, ones, ones, ones,
                                               u, True, True)
                        for s, c, u in zip(sin, cos, rng.random(n))])
        wi, w = out[:, :3], out[:, 3:6]
        assert np.isfinite(wi).all() and np.isfinite(w).all()
        assert np.allclose(np.linalg.norm(wi, axis=1), 1.0)
        assert np.all(w <= 1.0 + 1e-12)


def test_bubble_reflects_totally_from_outside():
    """IOR 0.75 (air bubble in water): from outside, past the critical angle asin(0.75),
    F = 1 and sampling always reflects."""
    eta = 0.75
    theta = np.array([np.arcsin(eta) + 1e-4, 1.0, 1.4, np.pi / 2 - 1e-9])
    f, cos_t = fresnel(np.cos(theta), eta)
    assert np.all(f == 1.0) and np.all(cos_t == 0.0)
    f_below, _ = fresnel(np.cos([np.arcsin(eta) - 1e-3]), eta)
    assert f_below[0] < 1.0


@pytest.mark.slow
def test_bubble_rim_is_black_in_a_render():
    """An orthographic camera looks at a bubble (IOR 0.75) in front of an emitting disc of
    radius 0.7 (black world). Rays meeting the bubble beyond r = 0.75 R are totally
    reflected outward and can never reach the disc: that annulus is exactly black, while
    the centre transmits (F < 1 there)."""
    def image(ior):
        b = SceneBuilder()
        g = b.add_material(Material.glass("bubble", (1, 1, 1), ior))
        e = b.add_material(Material.emission_only("disc", (1, 1, 1), 1.0))
        sphere(b, "bubble", g, segments=96, rings=48)
        ang = np.linspace(0, 2 * np.pi, 65)[:-1]
        disc = np.column_stack([0.7 * np.cos(ang), np.full(64, 3.0), 0.7 * np.sin(ang)])
        v = np.vstack([[0, 3.0, 0], disc])
        tris = np.array([[0, 1 + (k + 1) % 64, 1 + k] for k in range(64)])
        b.add_mesh("disc", v, tris, e)
        cam = Camera(type="ORTHO", ortho_scale=2.2, world_from_camera=look_at((0, -3, 0),
                                                                              (0, 0, 0)))
        return render(b.build(cam, World()), RenderSettings(width=44, height=44, samples=4,
                                                            max_bounces=16, seed=3))
    ys, xs = np.mgrid[0:44, 0:44]
    r = np.hypot((xs + 0.5) / 44 * 2.2 - 1.1, (ys + 0.5) / 44 * 2.2 - 1.1)
    rim = (r > 0.80) & (r < 0.95)
    bubble = image(0.75)
    assert all_finite(bubble)
    assert bubble.combined[rim, :3].max() == 0.0
    assert bubble.combined[r < 0.3, :3].mean() > 0.5
    assert rim.sum() > 300


@pytest.mark.parametrize("ior", [0.0, -1.5, float("nan"), float("inf")])
def test_invalid_ior_is_an_error_naming_the_material(ior):
    """Also covered for 0, -1.5 and NaN in tests/engine/test_scene.py; here through a
    whole scene, before anything renders."""
    b = scenes.cornell_box(spheres=False)
    b.add_material(Material.glass("Cracked Glass", ior=ior))
    with pytest.raises(ValueError, match="IOR") as e:
        b.build(scenes.cornell_camera(), World())
    assert "Cracked Glass" in str(e.value)


def test_quad_helper_is_counter_clockwise():
    v, t = quad((0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0))
    n = np.cross(v[t[0, 1]] - v[t[0, 0]], v[t[0, 2]] - v[t[0, 0]])
    assert n[2] > 0


@pytest.mark.slow
def test_invalid_ior_through_blender(tmp_path):
    """Through the add-on: a Glass BSDF with IOR 0 renders with a warning naming the
    material (the add-on substitutes 1.5, as for other recoverable node input); IOR NaN
    (Blender's socket accepts it) ends the render with the core's error naming the
    material, and no image."""
    from tests.robustness.test_bad_input import bpy_case

    out = bpy_case("bad_ior", tmp_path)
    zero, nan = out["zero"], out["nan"]
    assert zero["error"] is None and zero["finite"]
    assert any("Bad IOR zero" in w and "IOR" in w for w in zero["export_warnings"])
    # NaN too is recoverable input now: substituted and warned, naming the material.
    assert nan["error"] is None and nan["finite"]
    assert any("Bad IOR nan" in w and "IOR" in w for w in nan["export_warnings"])

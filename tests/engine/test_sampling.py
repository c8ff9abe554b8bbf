"""Chi-square tests for every non-delta sampling routine, and the sample sequences."""

import numpy as np
import pytest

from engine import sampling
from engine.camera import CameraModel
from engine.film import PixelFilter
from engine.scene import Camera
from tests.stats import SIGNIFICANCE, chi2_test, expected_2d, histogram_2d, sidak

N = 200_000
RES = 31  # odd, so no cell boundary sits on a symmetry axis
# Family of chi-square tests in this module (each parametrisation counts once).
ALPHA = sidak(SIGNIFICANCE, 10)


def assert_chi2(observed, expected):
    p, dof = chi2_test(observed, expected)
    assert dof > 20, "too few cells to test"
    assert p > ALPHA, f"chi-square rejects the distribution: p = {p:.3g}, dof = {dof}"


def test_cosine_hemisphere(rng):
    w = sampling.sample_cosine_hemisphere(rng.random((N, 2)))
    assert np.allclose(np.linalg.norm(w, axis=1), 1.0)
    pts = np.column_stack([w[:, 2], np.arctan2(w[:, 1], w[:, 0])])
    obs = histogram_2d(pts, (0, -np.pi), (1, np.pi), RES)
    # Density in (cos theta, phi): solid angle d(omega) = d(cos) d(phi), pdf = cos / pi.
    exp = expected_2d(lambda p: p[:, 0] / np.pi, (0, -np.pi), (1, np.pi), RES, N)
    assert_chi2(obs, exp)
    assert np.allclose(sampling.cosine_hemisphere_pdf(w[:, 2]), w[:, 2] / np.pi)


def test_concentric_disk(rng):
    p = sampling.sample_uniform_disk_concentric(rng.random((N, 2)))
    r2 = np.einsum("ij,ij->i", p, p)
    assert r2.max() <= 1.0 + 1e-12
    # Uniform on the disk <=> (r^2, phi) uniform on [0, 1] x [-pi, pi].
    pts = np.column_stack([r2, np.arctan2(p[:, 1], p[:, 0])])
    obs = histogram_2d(pts, (0, -np.pi), (1, np.pi), RES)
    assert_chi2(obs, np.full_like(obs, N / RES**2))


def polygon_contains(p, blades, rotation):
    """Inside test for the regular polygon with vertices at rotation + (2k+1) pi / blades."""
    inside = np.ones(len(p), bool)
    for k in range(blades):
        a0 = rotation + (2 * k + 1) * np.pi / blades
        a1 = rotation + (2 * k + 3) * np.pi / blades
        e = np.array([np.cos(a1) - np.cos(a0), np.sin(a1) - np.sin(a0)])
        rel = p - np.array([np.cos(a0), np.sin(a0)])
        inside &= (e[0] * rel[:, 1] - e[1] * rel[:, 0]) >= 0
    return inside


@pytest.mark.parametrize("blades,rotation", [(3, 0.0), (5, 0.7), (8, -2.0)])
def test_polygon_aperture(rng, blades, rotation):
    p = sampling.sample_regular_polygon(rng.random((N, 2)), blades, rotation)
    assert polygon_contains(p, blades, rotation).mean() > 1 - 1e-9
    obs = histogram_2d(p, (-1, -1), (1, 1), RES)
    area = sampling.regular_polygon_area(blades)
    exp = expected_2d(lambda q: polygon_contains(q, blades, rotation) / area,
                      (-1, -1), (1, 1), RES, N, sub=48)
    assert_chi2(obs, exp)


def test_polygon_vertices_follow_cycles_convention():
    # u = (k/N + tiny, 1) reaches the triangle's far corner: vertex at rotation + (2k+1)pi/N.
    blades, rot = 6, 0.3
    u = np.array([[0.0, 1.0], [1.0 / blades, 1.0 - 1e-12]])
    u[:, 0] += 1.0 - 1e-12  # fractional part -> sqrt(v) = 1: the outer edge
    u[:, 0] = (np.arange(2) + 1.0 - 1e-12) / blades
    p = sampling.sample_regular_polygon(u, blades, rot)
    angles = np.arctan2(p[:, 1], p[:, 0])
    expected = rot + (2 * np.arange(2) + 1) * np.pi / blades
    assert np.allclose(np.angle(np.exp(1j * (angles - expected))), 0, atol=1e-5)
    assert np.allclose(np.linalg.norm(p, axis=1), 1.0, atol=1e-5)


def test_triangle_area(rng):
    b = sampling.sample_uniform_triangle(rng.random((N, 2)))
    assert np.all(b >= -1e-12) and np.allclose(b.sum(axis=1), 1.0)
    obs = histogram_2d(b[:, :2], (0, 0), (1, 1), RES)
    i, j = np.meshgrid(np.arange(RES), np.arange(RES), indexing="ij")
    # Cells below the diagonal are whole, cells on it exactly half (it passes corners).
    frac = np.where(i + j < RES - 1, 1.0, np.where(i + j == RES - 1, 0.5, 0.0))
    assert_chi2(obs, N * 2 * frac / RES**2)


def _table_mass(f, edges):
    """The probability f's table puts below each of `edges`: each of its 1023 intervals
    of u carries 1/1023, spread uniformly between its two knots' offsets."""
    lo, hi = np.minimum(f._x[:-1], f._x[1:]), np.maximum(f._x[:-1], f._x[1:])
    frac = np.clip((edges[:, None] - lo) / np.maximum(hi - lo, 1e-300), 0.0, 1.0)
    return frac.mean(axis=1)


@pytest.mark.parametrize("kind,width", [("BLACKMAN_HARRIS", 1.5), ("BOX", 1.0),
                                        ("GAUSSIAN", 1.5)])
def test_pixel_filter_samples_its_table(rng, kind, width):
    """Offsets follow the table (chi-square, 2D, separable)."""
    f = PixelFilter(kind, width)
    d = f.sample(rng.random((N, 2)))
    r = f.radius
    assert np.abs(d).max() <= r + 1e-9
    obs = histogram_2d(d, (-r, -r), (r, r), RES)
    m = np.diff(_table_mass(f, np.linspace(-r, r, RES + 1)))
    assert_chi2(obs, N * np.outer(m, m))


@pytest.mark.parametrize("kind,width", [("BLACKMAN_HARRIS", 1.5), ("BOX", 1.0),
                                        ("GAUSSIAN", 1.5), ("BLACKMAN_HARRIS", 3.0)])
def test_pixel_filter_table_is_cycles_inverse_cdf_of_the_filter(kind, width):
    """The table inverts the filter's CDF (within a table step) everywhere but Cycles'
    unwritten last entry, whose interval (1/1023 of the samples) runs from +radius back to
    -0.5 px; so a wrong filter shape or width fails."""
    f = PixelFilter(kind, width)
    r = f.radius
    x = np.linspace(-r, r, 2001)
    dens = f.density(x)
    exact = np.concatenate([[0.0], np.cumsum(0.5 * (dens[1:] + dens[:-1]) * np.diff(x))])
    exact /= exact[-1]
    table = _table_mass(f, x)
    # Without the last interval's mass the rest is the filter's CDF scaled by 1022/1023.
    last = np.clip((x - (-0.5)) / (r + 0.5), 0.0, 1.0) / 1023.0
    assert np.abs(table - last - exact * 1022 / 1023).max() < 3.0 / 1023
    assert f._x[-1] == pytest.approx(-0.5) and f._x[-2] == pytest.approx(r)
    wrong = PixelFilter(kind, width * 1.1)
    assert np.abs(_table_mass(wrong, x) - last - exact * 1022 / 1023).max() > 3.0 / 1023


def test_blackman_harris_support_is_twice_the_width_internally():
    f = PixelFilter("BLACKMAN_HARRIS", 1.5)
    assert f.radius == 1.5
    assert f.density(np.array([0.0]))[0] == pytest.approx(1.0, abs=1e-6)
    assert f.density(np.array([1.5]))[0] == pytest.approx(0.0, abs=1e-4)


def test_lens_samples_through_camera_model(rng):
    """The lens sample the camera uses (disk, polygon, ratio) covers its aperture uniformly."""
    cam = Camera(use_dof=True, fstop=2.0, lens_mm=50.0, blades=0, ratio=2.0)
    model = CameraModel(cam, 4, 4, np.zeros(3))
    p = model.sample_lens(rng.random((N, 2)))
    r = cam.aperture_radius
    q = p / r * np.array([cam.ratio, 1.0])  # undo the anamorphic squeeze: unit disk
    pts = np.column_stack([np.einsum("ij,ij->i", q, q), np.arctan2(q[:, 1], q[:, 0])])
    obs = histogram_2d(pts, (0, -np.pi), (1, np.pi), RES)
    assert_chi2(obs, np.full_like(obs, N / RES**2))


# ---------------------------------------------------------------- sequences
def test_sequence_is_stratified_per_pixel():
    """Every 2D dimension pair is a (0,2)-sequence per pixel: the first 2^k samples put
    exactly one point in each elementary interval of area 2^-k."""
    pts = np.array([sampling.SampleStream(np.arange(7), i, 3).get_2d(5) for i in range(64)])
    for p in range(7):
        for a in range(7):
            cx = np.floor(pts[:, p, 0] * 2**a)
            cy = np.floor(pts[:, p, 1] * 2 ** (6 - a))
            assert len(set(zip(cx, cy))) == 64


def test_sequence_1d_is_stratified():
    x = np.array([sampling.SampleStream(np.arange(7), i, 9).get_1d(3) for i in range(32)])
    for p in range(7):
        assert len(set(np.floor(x[:, p] * 32))) == 32


def test_sequence_is_uniform_across_pixels_and_decorrelated_across_dimensions():
    s = sampling.SampleStream(np.arange(N), 5, 11)
    a, b = s.get_2d(2), s.get_2d(3)
    obs = histogram_2d(a, (0, 0), (1, 1), RES)
    assert_chi2(obs, np.full_like(obs, N / RES**2))
    # Pairs taken from two different dimensions must be jointly uniform too.
    obs = histogram_2d(np.column_stack([a[:, 0], b[:, 1]]), (0, 0), (1, 1), RES)
    assert_chi2(obs, np.full_like(obs, N / RES**2))


def test_sequence_depends_on_seed_and_is_deterministic():
    a = sampling.SampleStream(np.arange(100), 3, 1).get_2d(4)
    assert np.array_equal(a, sampling.SampleStream(np.arange(100), 3, 1).get_2d(4))
    assert not np.allclose(a, sampling.SampleStream(np.arange(100), 3, 2).get_2d(4))
    # Subsets of rows give the same values as the full batch (thread-chunk independence).
    rows = np.array([5, 17, 63])
    assert np.array_equal(sampling.SampleStream(np.arange(100), 3, 1).get_2d(4, rows=rows),
                          a[rows])
    assert np.array_equal(sampling.SampleStream(np.arange(100)[rows], 3, 1).get_2d(4), a[rows])

"""Chi-square tests for every non-delta sampling routine, and the sample sequences."""

import numpy as np
import pytest

from engine import sampling
from engine.camera import CameraModel, lens_disk
from engine.film import PixelFilter, filter_offset
from engine.jit import njit
from engine.scene import Camera
from tests.stats import SIGNIFICANCE, chi2_test, expected_2d, histogram_2d, sidak

N = 200_000
RES = 31  # odd, so no cell boundary sits on a symmetry axis
# Family of chi-square tests in this module (each parametrisation counts once).
ALPHA = sidak(SIGNIFICANCE, 16)


def assert_chi2(observed, expected):
    p, dof = chi2_test(observed, expected)
    assert dof > 20, "too few cells to test"
    assert p > ALPHA, f"chi-square rejects the distribution: p = {p:.3g}, dof = {dof}"


def warp(fn, u, *args):
    """A scalar warp fn(ua, ub, *args) mapped over u (n, 2): its outputs as columns."""
    return np.column_stack(np.vectorize(lambda ua, ub: fn(ua, ub, *args))(u[:, 0], u[:, 1]))


@njit(cache=True)
def filter_offsets(u, table):
    """filter_offset for every entry of u, through the filter's table."""
    out = np.empty_like(u)
    for k in range(u.size):
        out.flat[k] = filter_offset(u.flat[k], table)
    return out


@njit(cache=True)
def lens_points(u, cam):
    """lens_disk for the rows of u (n, 2): lens points (n, 2) in scene units."""
    out = np.empty_like(u)
    for k in range(len(u)):
        out[k, 0], out[k, 1] = lens_disk(u[k, 0], u[k, 1], cam)
    return out


def test_cosine_hemisphere(rng):
    w = warp(sampling.cosine_hemisphere, rng.random((N, 2)))
    assert np.allclose(np.linalg.norm(w, axis=1), 1.0)
    pts = np.column_stack([w[:, 2], np.arctan2(w[:, 1], w[:, 0])])
    obs = histogram_2d(pts, (0, -np.pi), (1, np.pi), RES)
    # Density in (cos theta, phi): solid angle d(omega) = d(cos) d(phi), pdf = cos / pi.
    exp = expected_2d(lambda p: p[:, 0] / np.pi, (0, -np.pi), (1, np.pi), RES, N)
    assert_chi2(obs, exp)


def test_concentric_disk(rng):
    p = warp(sampling.concentric_disk, rng.random((N, 2)))
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
    p = warp(sampling.regular_polygon, rng.random((N, 2)), blades, rotation)
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
    p = warp(sampling.regular_polygon, u, blades, rot)
    angles = np.arctan2(p[:, 1], p[:, 0])
    expected = rot + (2 * np.arange(2) + 1) * np.pi / blades
    assert np.allclose(np.angle(np.exp(1j * (angles - expected))), 0, atol=1e-5)
    assert np.allclose(np.linalg.norm(p, axis=1), 1.0, atol=1e-5)


def test_triangle_area(rng):
    b = warp(sampling.uniform_triangle, rng.random((N, 2)))
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
    d = filter_offsets(rng.random((N, 2)), f.table())
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
    p = lens_points(rng.random((N, 2)), model.data())
    r = cam.aperture_radius
    q = p / r * np.array([cam.ratio, 1.0])  # undo the anamorphic squeeze: unit disk
    pts = np.column_stack([np.einsum("ij,ij->i", q, q), np.arctan2(q[:, 1], q[:, 0])])
    obs = histogram_2d(pts, (0, -np.pi), (1, np.pi), RES)
    assert_chi2(obs, np.full_like(obs, N / RES**2))


# ---------------------------------------------------------------- sequences
def test_sequence_is_stratified_per_pixel():
    """Every 2D dimension pair is a (0,2)-sequence per pixel: the first 2^k samples put
    exactly one point in each elementary interval of area 2^-k."""
    pts = np.array([sampling.stream_2d(np.arange(7), i, 3, 5) for i in range(64)])
    for p in range(7):
        for a in range(7):
            cx = np.floor(pts[:, p, 0] * 2**a)
            cy = np.floor(pts[:, p, 1] * 2 ** (6 - a))
            assert len(set(zip(cx, cy))) == 64


def test_sequence_1d_is_stratified():
    x = np.array([sampling.stream_1d(np.arange(7), i, 9, 3) for i in range(32)])
    for p in range(7):
        assert len(set(np.floor(x[:, p] * 32))) == 32


def test_sequence_is_uniform_across_pixels_and_decorrelated_across_dimensions():
    a, b = sampling.stream_2d(np.arange(N), 5, 11, 2), sampling.stream_2d(np.arange(N), 5, 11, 3)
    obs = histogram_2d(a, (0, 0), (1, 1), RES)
    assert_chi2(obs, np.full_like(obs, N / RES**2))
    # Pairs taken from two different dimensions must be jointly uniform too.
    obs = histogram_2d(np.column_stack([a[:, 0], b[:, 1]]), (0, 0), (1, 1), RES)
    assert_chi2(obs, np.full_like(obs, N / RES**2))


def test_sequence_depends_on_seed_and_is_deterministic():
    a = sampling.stream_2d(np.arange(100), 3, 1, 4)
    assert np.array_equal(a, sampling.stream_2d(np.arange(100), 3, 1, 4))
    assert not np.allclose(a, sampling.stream_2d(np.arange(100), 3, 2, 4))
    # Subsets of pixels give the same values as the full batch (thread-chunk independence),
    # and so does the kernel's per-sample path (pixel seed, bit-reversed sample index).
    rows = np.array([5, 17, 63])
    assert np.array_equal(sampling.stream_2d(np.arange(100)[rows], 3, 1, 4), a[rows])
    rev = sampling.reverse_bits(np.uint64(3))
    for r in rows:
        assert sampling.sample_2d(sampling.pixel_seed(r, 1), rev, 4) == tuple(a[r])
    x = sampling.stream_1d(np.arange(100), 3, 1, 4)
    assert not np.array_equal(x, sampling.stream_1d(np.arange(100), 3, 2, 4))
    assert all(sampling.sample_1d(sampling.pixel_seed(r, 1), rev, 4) == x[r] for r in rows)


RECTANGLES = {  # o, centre, u, v (unit, orthogonal), side lengths
    "near, off-centre": ((0.1, 0.4, -0.5), (0.3, -0.2, 1.0), (1, 0, 0), (0, 0.955336, 0.29552),
                         0.8, 0.5),
    "grazing": ((2.0, 0.0, 0.05), (0, 0, 0), (1, 0, 0), (0, 1, 0), 1.0, 2.0),
    "under a corner": ((0.5, 0.25, -0.01), (0, 0, 0), (1, 0, 0), (0, 1, 0), 1.0, 0.5),
    "far": ((0.0, 0.0, 40.0), (0, 0, 0), (0.6, 0.8, 0), (-0.8, 0.6, 0), 1.0, 1.0),
}


@pytest.mark.parametrize("name", RECTANGLES)
def test_spherical_rectangle_is_uniform_in_solid_angle(rng, name):
    """Points land on the rectangle with area density cos / (d^2 S), S the solid angle,
    which itself matches the integral of cos / d^2 over the rectangle (chi-square on the
    rectangle's (u, v) cells; a uniform-area or wrong-corner warp fails)."""
    o, c, u, v, lu, lv = (np.asarray(a, float) if isinstance(a, tuple) else a
                          for a in RECTANGLES[name])
    n_vec = np.cross(u, v)

    def density(uv):  # area density of uniform solid-angle sampling, per unit (s, t) area
        p = c + (uv[:, :1] * lu - lu / 2) * u + (uv[:, 1:] * lv - lv / 2) * v
        d = p - o
        dist = np.linalg.norm(d, axis=1)
        return np.abs(d @ n_vec) / dist**3 * lu * lv

    exact = expected_2d(density, (0, 0), (1, 1), 64, 1, sub=16).sum()
    solid = sampling.spherical_rectangle_solid_angle(*o, *c, *u, *v, lu, lv)
    assert solid == pytest.approx(exact, rel=1e-4)
    pts = np.array([sampling.spherical_rectangle(*o, *c, *u, *v, lu, lv, a, b)
                    for a, b in rng.random((N // 4, 2))])
    assert np.allclose(pts[:, 3], solid)
    st = np.column_stack([(pts[:, :3] - c) @ u / lu + 0.5, (pts[:, :3] - c) @ v / lv + 0.5])
    assert st.min() >= -1e-9 and st.max() <= 1 + 1e-9
    assert np.abs((pts[:, :3] - c) @ n_vec).max() < 1e-9
    obs = histogram_2d(st, (0, 0), (1, 1), RES)
    assert_chi2(obs, expected_2d(lambda uv: density(uv) / solid, (0, 0), (1, 1), RES, len(st)))

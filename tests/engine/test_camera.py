"""Cameras against Cycles' closed forms."""

import numpy as np
import pytest

from engine import Camera, camera
from engine.camera import CameraModel
from tests.scenes import look_at


def rays(cam, raster, width=400, height=300, u_lens=None):
    """World rays (origins (n, 3), directions (n, 3), tmax (n,)) for raster points (n, 2),
    made as the kernel makes them: the thin lens when u_lens (n, 2) is given and the camera
    has an aperture (a polygon with 3 or more blades), else the pinhole."""
    c = CameraModel(cam, width, height, np.zeros(3)).data()
    out = []
    for i, (rx, ry) in enumerate(np.atleast_2d(np.asarray(raster, float))):
        x, y = camera.raster_to_plane(rx, ry, c)
        if u_lens is not None and c.aperture > 0:
            lens = camera.lens_polygon if c.blades >= 3 else camera.lens_disk
            ray = camera.thin_lens_ray(x, y, *lens(*u_lens[i], c), c.focus, c.clip_start,
                                       c.clip_end, c.ortho)
        else:
            ray = camera.pinhole_ray(x, y, c)
        out.append(ray)
    r = np.array(out)
    m = c.world_from_camera
    return r[:, :3] @ m.T + c.position, r[:, 3:6] @ m.T, r[:, 6]


def to_camera(cam, d):
    """World direction -> Blender camera space (x right, y up, -z forward)."""
    m = np.asarray(cam.world_from_camera)[:3, :3]
    return d @ m


def test_pinhole_field_of_view_sensor_fits():
    lens, sw, sh = 35.0, 36.0, 24.0
    for fit, w, h, axis, sensor in [("AUTO", 400, 300, 0, sw), ("HORIZONTAL", 300, 400, 0, sw),
                                    ("VERTICAL", 400, 300, 1, sh), ("AUTO", 300, 400, 1, sw)]:
        cam = Camera(lens_mm=lens, sensor_width=sw, sensor_height=sh, sensor_fit=fit)
        # The right (or top) edge of the image along the fit axis.
        raster = np.array([[w, h / 2]]) if axis == 0 else np.array([[w / 2, h]])
        _, d, _ = rays(cam, raster, w, h)
        dc = to_camera(cam, d)[0]
        half = sensor / (2 * lens)
        assert dc[axis] / -dc[2] == pytest.approx(half, rel=1e-12), fit
        # The other axis follows the image aspect.
        raster2 = np.array([[w / 2, h]]) if axis == 0 else np.array([[w, h / 2]])
        dc2 = to_camera(cam, rays(cam, raster2, w, h)[1])[0]
        other = half * (h / w if axis == 0 else w / h)
        assert dc2[1 - axis] / -dc2[2] == pytest.approx(other, rel=1e-12), fit


def test_row_zero_is_the_bottom_and_shift_moves_by_fit_extent():
    cam = Camera(lens_mm=50, sensor_width=36, shift_x=0.1, shift_y=-0.2)
    _, d, _ = rays(cam, [[200, 150]])
    dc = to_camera(cam, d)[0]
    assert dc[0] / -dc[2] == pytest.approx(0.1 * 36 / 50)
    assert dc[1] / -dc[2] == pytest.approx(-0.2 * 36 / 50)
    _, d0, _ = rays(Camera(), [[0.5, 0.5]])
    dc0 = to_camera(Camera(), d0)[0]
    assert dc0[0] < 0 and dc0[1] < 0  # pixel (0, 0) looks down and left


def test_clipping_is_planar_along_the_view_axis():
    cam = Camera(clip_start=0.5, clip_end=20.0, world_from_camera=look_at((1, 2, 3), (4, 6, 3)))
    o, d, tmax = rays(cam, [[0, 0], [400, 300], [200, 150]])
    fwd = -np.asarray(cam.world_from_camera)[:3, 2]
    pos = np.asarray(cam.world_from_camera)[:3, 3]
    assert np.allclose((o - pos) @ fwd, 0.5)
    assert np.allclose((o + tmax[:, None] * d - pos) @ fwd, 20.0)


def test_camera_scale_is_ignored():
    m = look_at((0, -5, 1), (0, 0, 1))
    scaled = m.copy()
    scaled[:3, :3] *= np.array([2.0, 0.5, 3.0])
    a = rays(Camera(world_from_camera=m), [[10, 20]])
    b = rays(Camera(world_from_camera=scaled), [[10, 20]])
    assert all(np.allclose(x, y) for x, y in zip(a, b))


@pytest.mark.parametrize("blades,ratio", [(0, 1.0), (6, 1.0), (0, 2.0), (5, 0.5)])
def test_thin_lens_rays_meet_at_the_focus_plane(rng, blades, ratio):
    """Every lens sample for a raster point passes through the pinhole ray's point on
    the plane z = focus_distance (Cycles: a plane, not a sphere)."""
    focus = 3.7
    cam = Camera(use_dof=True, fstop=1.4, focus_distance=focus, blades=blades, rotation=0.4,
                 ratio=ratio, lens_mm=50, clip_start=0.1,
                 world_from_camera=look_at((0.5, -2, 1), (0, 3, 0)))
    raster = np.repeat([[37.0, 251.0]], 500, 0)
    o, d, _ = rays(cam, raster, u_lens=rng.random((500, 2)))
    pin_cam = Camera(**{**cam.__dict__, "use_dof": False})
    po, pd, _ = rays(pin_cam, raster[:1])
    fwd = -np.asarray(cam.world_from_camera)[:3, 2]
    pos = np.asarray(cam.world_from_camera)[:3, 3]
    t = (focus - (o - pos) @ fwd) / (d @ fwd)
    hit = o + t[:, None] * d
    tp = (focus - (po - pos) @ fwd) / (pd @ fwd)
    assert np.allclose(hit, po + tp[:, None] * pd, atol=1e-9)
    # Lens points (at the near clip plane, pulled back along each ray) fill the aperture.
    lens_pts = o - (0.1 / (pd @ fwd))[:, None] * d  # z_inv from the pinhole ray
    local = to_camera(cam, lens_pts - pos)
    r = cam.aperture_radius
    assert r == pytest.approx(50e-3 / (2 * 1.4))
    assert np.abs(local[:, 2]).max() < 1e-9
    assert np.abs(local[:, 0]).max() <= r / ratio * (1 + 1e-9)
    assert np.abs(local[:, 0]).max() > 0.8 * r / ratio


def test_orthographic_rays_are_parallel_and_span_ortho_scale():
    cam = Camera(type="ORTHO", ortho_scale=4.0, world_from_camera=look_at((0, -5, 0), (0, 0, 0)))
    o, d, _ = rays(cam, [[0, 150], [400, 150]])
    assert np.allclose(d[0], d[1]) and np.allclose(d[0], [0, 1, 0])
    assert np.linalg.norm(o[1] - o[0]) == pytest.approx(4.0)


def test_aperture_radius_mapping():
    assert Camera(use_dof=True, fstop=2.0, lens_mm=50).aperture_radius == pytest.approx(0.0125)
    assert Camera(use_dof=False, fstop=2.0).aperture_radius == 0.0
    assert Camera(type="ORTHO", use_dof=True, fstop=4.0).aperture_radius == pytest.approx(0.125)


def test_fstop_to_infinity_converges_to_the_pinhole_image():
    """As fstop grows the thin-lens image approaches the pinhole one: the mean absolute
    difference shrinks with the aperture, and at fstop 1e6 it is at round-off level
    (both use the same filter samples; the lens offset is ~1e-8 units)."""
    from engine import World, render
    from tests import scenes

    def image(**kw):
        sc = scenes.cornell_box().build(scenes.cornell_camera(**kw), World())
        return render(sc, scenes.settings(width=32, height=24, samples=4, seed=2)).combined

    pinhole = image()
    diffs = [np.abs(image(use_dof=True, fstop=f, focus_distance=3.0) - pinhole).mean()
             for f in (0.5, 8.0, 1e6)]
    assert diffs[0] > diffs[1] > diffs[2]
    assert diffs[2] < 1e-4 * pinhole.mean()


@pytest.mark.parametrize("kind", ["PERSP", "ORTHO"])
def test_view_maps_are_camera_space_and_the_frame_position(rng, kind):
    """Texture Coordinate's Camera and Window maps at random points in view: camera space
    is (+x right, +y up, +z ahead) of the camera, at the point's distance; Window's
    division is where `project` (pinhole) or the orthographic ray lands on the raster, over
    the frame size, shift and a non-square frame included."""
    cam = Camera(look_at((1.0, -4.0, 2.0), (0.2, 0.1, 0.5)), lens_mm=35.0, type=kind,
                 ortho_scale=3.0, shift_x=0.1, shift_y=-0.05)
    w, h = 160, 90
    origin = np.array([0.3, -0.2, 0.1])
    model = CameraModel(cam, w, h, origin)
    data = model.data()
    points = rng.uniform(-0.6, 0.6, (4, 3, 3)) + np.array([0.2, 0.1, 0.5]) - origin
    local, window = camera.view_maps(model, points)
    ndc = window[..., :2] / window[..., 2:]
    for p, c, q in zip(points.reshape(-1, 3), local.reshape(-1, 3), ndc.reshape(-1, 2)):
        assert np.linalg.norm(c) == pytest.approx(np.linalg.norm(p - model.position))
        assert c[2] > 0  # ahead
        if kind == "PERSP":
            rx, ry, *_ = camera.project(*p, 0.0, 0.0, data)
        else:  # the orthographic ray through (rx, ry) starts at the viewplane point
            x = (c[0] - cam.shift_x * 2 * model.fit_half) / model.half_x
            y = (c[1] - cam.shift_y * 2 * model.fit_half) / model.half_y
            rx, ry = (x + 1) * 0.5 * w, (y + 1) * 0.5 * h
            vx, vy = camera.raster_to_plane(rx, ry, data)
            assert (vx, vy) == pytest.approx((c[0], c[1]))
        assert q == pytest.approx((rx / w, ry / h))

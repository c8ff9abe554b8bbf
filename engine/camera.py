"""Cameras: Blender's perspective and orthographic cameras as Cycles maps them.

Camera space looks down +z with +y up (Cycles' convention); world_from_camera is the
camera object's matrix with its scale cleared and z flipped, since Blender cameras look
down their local -Z. The viewplane at z = 1 (perspective) spans the fit axis'
sensor / (2 lens) either side of the axis, the other axis scaled by the image aspect;
shift moves it by shift x the fit axis' full extent. Clipping is planar along the view
axis. With depth of field a lens point is drawn on a disk or a regular polygon of
radius `aperture_radius` (x divided by the anamorphic ratio) and the ray aims at the
point where the pinhole ray meets the focus plane z = focus_distance.

`CameraModel` derives the camera's constants once (`CameraData`); the functions below make
one ray and are compiled into the kernel, which picks the pinhole or the thin lens by plan.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from .jit import ALLOCATING, INLINE, JIT, njit
from .sampling import concentric_disk, regular_polygon
from .scene import Camera


def viewplane_half_extents(cam: Camera, width: int, height: int) -> tuple[float, float, float]:
    """(half_x, half_y, fit_half) of the viewplane at unit distance (perspective) or in
    scene units (orthographic); `fit_half` is the fit axis' half extent, the unit of shift."""
    xratio = width * cam.pixel_aspect_x
    yratio = height * cam.pixel_aspect_y
    fit = cam.sensor_fit
    if fit == "AUTO":
        horizontal, sensor = xratio > yratio, cam.sensor_width  # AUTO always uses the width
    elif fit == "HORIZONTAL":
        horizontal, sensor = True, cam.sensor_width
    else:
        horizontal, sensor = False, cam.sensor_height
    fit_half = (0.5 * cam.ortho_scale if cam.type == "ORTHO" else 0.5 * sensor / cam.lens_mm)
    if horizontal:
        return fit_half, fit_half * yratio / xratio, fit_half
    return fit_half * xratio / yratio, fit_half, fit_half


# The camera as the kernel reads it: image size, viewplane half extents (fit_half: the
# unit of shift), shift, clipping, orthographic or not, lens (aperture radius, blades (0: a
# disk), rotation, anamorphic ratio, focus distance), world_from_camera (3, 3) and position.
CameraData = namedtuple("CameraData", "width height half_x half_y fit_half shift_x shift_y "
                                      "clip_start clip_end ortho aperture blades rotation ratio "
                                      "focus world_from_camera position forward")


class CameraModel:
    """The camera's constants for a render of width x height pixels; origin is the scene's
    recentring offset."""

    def __init__(self, cam: Camera, width: int, height: int, origin: np.ndarray):
        self.cam, self.width, self.height = cam, width, height
        m = np.asarray(cam.world_from_camera, np.float64)
        rot = m[:3, :3] / np.maximum(np.linalg.norm(m[:3, :3], axis=0), 1e-300)  # clear scale
        # Flip z: Cycles' camera looks down +z, Blender's down -Z.
        self.world_from_camera = np.ascontiguousarray(rot * np.array([1.0, 1.0, -1.0]))
        self.position = m[:3, 3] - np.asarray(origin, np.float64)
        self.forward = np.ascontiguousarray(self.world_from_camera[:, 2])
        self.half_x, self.half_y, self.fit_half = viewplane_half_extents(cam, width, height)
        self.aperture = cam.aperture_radius
        self.blades = int(cam.blades) if cam.blades >= 3 else 0
        self.focus = max(float(cam.focus_distance), 1e-5)

    def data(self) -> CameraData:
        cam = self.cam
        return CameraData(float(self.width), float(self.height), self.half_x, self.half_y,
                          self.fit_half, float(cam.shift_x), float(cam.shift_y),
                          float(cam.clip_start), float(cam.clip_end), cam.type == "ORTHO",
                          float(self.aperture), float(self.blades), float(cam.rotation),
                          float(cam.ratio), float(self.focus), self.world_from_camera,
                          self.position, self.forward)


def view_maps(model: CameraModel, corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The per-corner values of Texture Coordinate's Camera and Window outputs
    (shading.CAMERA, WINDOW) at `corners` (t, 3, 3), recentred as the scene's vertices:
    the camera-space position, and homogeneous coordinates (X, Y, W) whose X / W, Y / W is
    the position in the frame (frame_position; Cycles' worldtondc: the whole frame, shift
    included, whatever region is rendered). W is the depth, or 1 for an orthographic
    camera, so that the shader interpolates X, Y and W over a triangle and divides."""
    local = (corners - model.position) @ model.world_from_camera
    return local, window_coordinates(local.reshape(-1, 3), model.data()).reshape(local.shape)


@njit(**ALLOCATING)
def window_coordinates(local, cam):
    """view_maps' homogeneous window coordinates of camera-space points (n, 3)."""
    out = np.empty_like(local)
    for i in range(len(local)):
        w = 1.0 if cam.ortho else local[i, 2]
        out[i, 0], out[i, 1] = frame_position(local[i, 0], local[i, 1], w, cam)
        out[i, 2] = w
    return out


@njit(**INLINE)
def frame_position(x, y, w, cam):
    """A viewplane point (x, y) (at z = 1, or in scene units for an orthographic camera)
    given homogeneously with weight w -> (X, Y) whose X / w, Y / w is its place in the
    frame, 0 at the bottom left, 1 at the top right: the inverse of raster_to_plane over
    the pixel counts."""
    shift_x, shift_y = cam.shift_x * 2 * cam.fit_half * w, cam.shift_y * 2 * cam.fit_half * w
    return ((x - shift_x) / cam.half_x + w) * 0.5, ((y - shift_y) / cam.half_y + w) * 0.5


@njit(**INLINE)
def raster_to_plane(rx, ry, cam):
    """Raster position in pixels (row 0 at the bottom) -> viewplane point at z = 1
    (perspective) or in scene units (orthographic)."""
    x = (2.0 * rx / cam.width - 1.0) * cam.half_x + cam.shift_x * 2 * cam.fit_half
    y = (2.0 * ry / cam.height - 1.0) * cam.half_y + cam.shift_y * 2 * cam.fit_half
    return x, y


@njit(**INLINE)
def lens_disk(ua, ub, cam):
    """A point on a round aperture, in scene units (x divided by the anamorphic ratio)."""
    lx, ly = concentric_disk(ua, ub)
    return lx * cam.aperture / cam.ratio, ly * cam.aperture


@njit(**INLINE)
def lens_polygon(ua, ub, cam):
    """A point on a polygonal aperture (the camera's blades and rotation), in scene units."""
    lx, ly = regular_polygon(ua, ub, cam.blades, cam.rotation)
    return lx * cam.aperture / cam.ratio, ly * cam.aperture


@njit(**INLINE)
def pinhole_ray(x, y, cam):
    """Camera-space origin, unit direction and far clip distance of the ray through
    viewplane point (x, y); clipping is planar along the view axis."""
    if cam.ortho:
        return x, y, cam.clip_start, 0.0, 0.0, 1.0, cam.clip_end - cam.clip_start
    norm = math.sqrt(x * x + y * y + 1.0)
    dx, dy, dz = x / norm, y / norm, 1.0 / norm
    z_inv = 1.0 / dz
    c = cam.clip_start * z_inv
    return c * dx, c * dy, c * dz, dx, dy, dz, (cam.clip_end - cam.clip_start) * z_inv


@njit(**JIT)
def thin_lens_ray(x, y, lx, ly, focus, clip_start, clip_end, ortho):
    """As pinhole_ray from lens point (lx, ly), aimed where the pinhole ray meets the focus
    plane at `focus`; the clip distances stay the pinhole ray's (Cycles)."""
    if ortho:
        norm = math.sqrt(lx * lx + ly * ly + focus * focus)
        dx, dy, dz = -lx / norm, -ly / norm, focus / norm
        return x + lx + clip_start * dx, y + ly + clip_start * dy, clip_start * dz, dx, dy, \
            dz, clip_end - clip_start
    norm = math.sqrt(x * x + y * y + 1.0)
    dx, dy, dz = x / norm, y / norm, 1.0 / norm
    z_inv = 1.0 / dz
    k = focus / dz
    fx, fy, fz = dx * k - lx, dy * k - ly, dz * k
    norm = math.sqrt(fx * fx + fy * fy + fz * fz)
    dx, dy, dz = fx / norm, fy / norm, fz / norm
    c = clip_start * z_inv
    return lx + c * dx, ly + c * dy, c * dz, dx, dy, dz, (clip_end - clip_start) * z_inv


@njit(**INLINE)
def raster_per_steradian(dz, cam):
    """Raster area (pixels^2) per steradian about a ray leaving a lens point with camera-space
    direction z component dz: the viewplane point moves as (d_x / d_z, d_y / d_z), whose
    Jacobian is 1 / d_z^3, and the raster scales it by width / (2 half_x) x height / (2 half_y).
    A light path connected to the camera turns this into the path tracer's density."""
    return cam.width * cam.height / (4.0 * cam.half_x * cam.half_y * dz * dz * dz)


@njit(**INLINE)
def project(px, py, pz, lx, ly, cam):
    """Where a world point reaches the raster through lens point (lx, ly) (0, 0 for a
    pinhole): the inverse of raster_to_plane and thin_lens_ray. Returns (rx, ry, dz, dist,
    near, visible): the raster position, the camera-space z of the unit direction from the
    lens point, the distance from the lens point, the distance at which the camera ray
    starts (its clip start), and whether a camera ray could reach the point (in front, and
    within the clip range the camera ray has). Perspective cameras only."""
    m = cam.world_from_camera
    wx, wy, wz = px - cam.position[0], py - cam.position[1], pz - cam.position[2]
    vx = wx * m[0, 0] + wy * m[1, 0] + wz * m[2, 0] - lx
    vy = wx * m[0, 1] + wy * m[1, 1] + wz * m[2, 1] - ly
    vz = wx * m[0, 2] + wy * m[1, 2] + wz * m[2, 2]
    if not vz > 0.0:
        return 0.0, 0.0, 0.0, 0.0, 0.0, False
    # The ray from the lens point meets the focus plane where the pinhole ray through
    # viewplane point (x, y) does: x = lx / focus + vx / vz (lx = 0 without a lens).
    x = lx / cam.focus + vx / vz
    y = ly / cam.focus + vy / vz
    fx, fy = frame_position(x, y, 1.0, cam)
    rx, ry = fx * cam.width, fy * cam.height
    dist = math.sqrt(vx * vx + vy * vy + vz * vz)
    z_inv = math.sqrt(x * x + y * y + 1.0)  # 1 / the pinhole ray's z (its clip distances)
    near = cam.clip_start * z_inv
    visible = near <= dist <= cam.clip_end * z_inv
    return rx, ry, vz / dist, dist, near, visible


@njit(**INLINE)
def lens_to_world(lx, ly, cam):
    """A lens point (camera space, z = 0) in world space."""
    m = cam.world_from_camera
    return (cam.position[0] + lx * m[0, 0] + ly * m[0, 1],
            cam.position[1] + lx * m[1, 0] + ly * m[1, 1],
            cam.position[2] + lx * m[2, 0] + ly * m[2, 1])


@njit(**INLINE)
def z_depth(px, py, pz, cam):
    """Distance of a world point from the camera along the view axis (the depth pass)."""
    return ((px - cam.position[0]) * cam.forward[0] + (py - cam.position[1]) * cam.forward[1]
            + (pz - cam.position[2]) * cam.forward[2])

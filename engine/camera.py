"""Cameras: Blender's perspective and orthographic cameras as Cycles maps them.

Camera space looks down +z with +y up (Cycles' convention); world_from_camera is the
camera object's matrix with its scale cleared and z flipped, since Blender cameras look
down their local -Z. The viewplane at z = 1 (perspective) spans the fit axis'
sensor / (2 lens) either side of the axis, the other axis scaled by the image aspect;
shift moves it by shift x the fit axis' full extent. Clipping is planar along the view
axis. With depth of field a lens point is drawn on a disk or a regular polygon of
radius `aperture_radius` (x divided by the anamorphic ratio) and the ray aims at the
point where the pinhole ray meets the focus plane z = focus_distance.
"""

from __future__ import annotations

import numpy as np

from . import sampling
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


class CameraModel:
    """Generates camera rays for pixels. origin is the scene's recentring offset."""

    def __init__(self, cam: Camera, width: int, height: int, origin: np.ndarray):
        self.cam, self.width, self.height = cam, width, height
        m = np.asarray(cam.world_from_camera, np.float64)
        rot = m[:3, :3] / np.maximum(np.linalg.norm(m[:3, :3], axis=0), 1e-300)  # clear scale
        # Flip z: Cycles' camera looks down +z, Blender's down -Z.
        self.world_from_camera = rot * np.array([1.0, 1.0, -1.0])
        self.position = m[:3, 3] - np.asarray(origin, np.float64)
        self.forward = self.world_from_camera[:, 2]
        self.half_x, self.half_y, self.fit_half = viewplane_half_extents(cam, width, height)
        self.aperture = cam.aperture_radius
        self.blades = int(cam.blades) if cam.blades >= 3 else 0
        self.focus = max(float(cam.focus_distance), 1e-5)

    @property
    def has_lens(self) -> bool:
        return self.aperture > 0.0

    def raster_to_camera(self, raster: np.ndarray) -> np.ndarray:
        """Raster (n, 2) in pixels, row 0 at the bottom -> viewplane (n, 2) at z = 1."""
        cam = self.cam
        x = (2.0 * raster[:, 0] / self.width - 1.0) * self.half_x + cam.shift_x * 2 * self.fit_half
        y = (2.0 * raster[:, 1] / self.height - 1.0) * self.half_y + cam.shift_y * 2 * self.fit_half
        return np.column_stack([x, y])

    def sample_lens(self, u: np.ndarray) -> np.ndarray:
        """Lens point (n, 2) in scene units: disk or polygon, x divided by the ratio."""
        if self.blades:
            p = sampling.sample_regular_polygon(u, self.blades, float(self.cam.rotation))
        else:
            p = sampling.sample_uniform_disk_concentric(u)
        p = p * self.aperture
        p[:, 0] /= self.cam.ratio
        return p

    def generate_rays(self, raster: np.ndarray, u_lens: np.ndarray | None):
        """Rays for raster positions (n, 2).

        Returns origins (n, 3), unit directions (n, 3) in the recentred world frame and
        tmax (n,) (the far clip). u_lens (n, 2) is used only when the lens is active.
        """
        cam = self.cam
        plane = self.raster_to_camera(raster)
        n = len(raster)
        if cam.type == "ORTHO":
            p = np.column_stack([plane, np.zeros(n)])
            d = np.tile([0.0, 0.0, 1.0], (n, 1))
            if self.has_lens and u_lens is not None:
                lens = self.sample_lens(u_lens)
                p[:, :2] += lens
                d = np.column_stack([-lens, np.full(n, self.focus)])
                d /= np.linalg.norm(d, axis=1, keepdims=True)
            p += cam.clip_start * d
            tmax = np.full(n, cam.clip_end - cam.clip_start)
        else:
            pin = np.column_stack([plane, np.ones(n)])
            pin /= np.linalg.norm(pin, axis=1, keepdims=True)
            z_inv = 1.0 / pin[:, 2]
            if self.has_lens and u_lens is not None:
                lens = self.sample_lens(u_lens)
                p_focus = pin * (self.focus / pin[:, 2])[:, None]
                p = np.column_stack([lens, np.zeros(n)])
                d = p_focus - p
                d /= np.linalg.norm(d, axis=1, keepdims=True)
            else:
                p = np.zeros((n, 3))
                d = pin
            # Planar near/far clip: z_inv comes from the pinhole ray even with DOF (Cycles).
            p += (cam.clip_start * z_inv)[:, None] * d
            tmax = (cam.clip_end - cam.clip_start) * z_inv
        origins = sampling.apply3(p, self.world_from_camera) + self.position
        directions = sampling.apply3(d, self.world_from_camera)
        return origins, directions, tmax

    def z_depth(self, points: np.ndarray) -> np.ndarray:
        """Distance of world points (n, 3) from the camera along the view axis."""
        return sampling.dot3(points - self.position, self.forward)

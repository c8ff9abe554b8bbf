"""World lighting from an equirectangular environment image, importance-sampled.

Blender's mapping (Cycles' `direction_to_equirectangular`): for a direction d in the
texture's frame, u = 0.5 - atan2(d.y, d.x) / (2 pi), v = 0.5 + elevation / pi, with image
row 0 at the bottom (v = 0 looks straight down). Radiance is looked up with bilinear
interpolation (the Environment Texture node's default "Linear"), wrapping in u.

Sampling picks a pixel in proportion to its luminance times cos(elevation) (the solid
angle it covers), then a uniform point inside it; the solid-angle density is
p_pixel x W x H / (2 pi^2 cos(elevation)).
"""

from __future__ import annotations

import numpy as np

from . import sampling

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


class EnvironmentMap:
    """image : (H, W, 3) radiance (strength applied), row 0 at the bottom.
    texture_from_world : (3, 3) rotation taking world directions into the texture's frame
    (a Mapping node's rotation)."""

    def __init__(self, image: np.ndarray, texture_from_world: np.ndarray | None = None):
        self.image = np.ascontiguousarray(image, np.float32)
        self.height, self.width = self.image.shape[:2]
        m = np.eye(3) if texture_from_world is None else np.asarray(texture_from_world, float)
        self.texture_from_world = m
        self.world_from_texture = np.linalg.inv(m)
        elevation = (np.arange(self.height) + 0.5) / self.height * np.pi - 0.5 * np.pi
        weight = (self.image.astype(np.float64) @ LUMINANCE) * np.cos(elevation)[:, None]
        weight = np.maximum(weight, 0.0)
        # A black map would leave nothing to sample: fall back to uniform over the sphere.
        if weight.sum() <= 0:
            weight = np.ones_like(weight) * np.cos(elevation)[:, None]
        self.distribution = sampling.Distribution1D(weight.ravel())
        self.mean_radiance = float(np.mean(self.image.astype(np.float64) @ LUMINANCE
                                           * np.cos(elevation)[:, None]) * np.pi / 2)

    def to_uv(self, d_world: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        d = sampling.apply3(d_world, self.texture_from_world)
        u = 0.5 - np.arctan2(d[:, 1], d[:, 0]) / (2.0 * np.pi)
        v = 0.5 + np.arctan2(d[:, 2], np.hypot(d[:, 0], d[:, 1])) / np.pi
        return np.mod(u, 1.0), np.clip(v, 0.0, 1.0)

    def from_uv(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        azimuth = (0.5 - u) * 2.0 * np.pi
        elevation = (v - 0.5) * np.pi
        ce = np.cos(elevation)
        d = np.column_stack([ce * np.cos(azimuth), ce * np.sin(azimuth), np.sin(elevation)])
        return sampling.apply3(d, self.world_from_texture)

    def lookup(self, d_world: np.ndarray) -> np.ndarray:
        """Bilinear radiance (n, 3) for world directions (n, 3)."""
        u, v = self.to_uv(d_world)
        x = u * self.width - 0.5
        y = np.clip(v * self.height - 0.5, 0.0, self.height - 1.0)
        x0 = np.floor(x).astype(np.int64)
        y0 = np.minimum(np.floor(y).astype(np.int64), self.height - 1)
        fx, fy = (x - x0)[:, None], (y - y0)[:, None]
        x0 %= self.width
        x1 = (x0 + 1) % self.width
        y1 = np.minimum(y0 + 1, self.height - 1)
        img = self.image
        top = img[y0, x0] * (1 - fx) + img[y0, x1] * fx
        bottom = img[y1, x0] * (1 - fx) + img[y1, x1] * fx
        return (top * (1 - fy) + bottom * fy).astype(np.float64)

    def pdf(self, d_world: np.ndarray) -> np.ndarray:
        """Solid-angle density of `sample` at world directions (n, 3)."""
        u, v = self.to_uv(d_world)
        col = np.minimum((u * self.width).astype(np.int64), self.width - 1)
        row = np.minimum((v * self.height).astype(np.int64), self.height - 1)
        p = self.distribution.pmf[row * self.width + col]
        cos_el = np.cos((v - 0.5) * np.pi)
        return p * self.width * self.height / (2.0 * np.pi**2 * np.maximum(cos_el, 1e-12))

    def sample(self, u2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Directions (n, 3) and their solid-angle pdf (n,) from u2 (n, 2): the pixel by
        the first coordinate (its remainder reused for x), the row position by the second."""
        k = self.distribution.sample(u2[:, 0])
        cdf_lo = np.where(k > 0, self.distribution.cdf[np.maximum(k - 1, 0)], 0.0)
        pk = self.distribution.pmf[k]
        fx = np.clip((u2[:, 0] - cdf_lo) / np.where(pk > 0, pk, 1.0), 0.0, 1.0 - 1e-12)
        row, col = np.divmod(k, self.width)
        u = (col + fx) / self.width
        v = (row + u2[:, 1]) / self.height
        d = self.from_uv(u, v)
        cos_el = np.cos((v - 0.5) * np.pi)
        pdf = pk * self.width * self.height / (2.0 * np.pi**2 * np.maximum(cos_el, 1e-12))
        return d, pdf

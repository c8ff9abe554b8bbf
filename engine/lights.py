"""Emitters: emissive triangles, chosen in proportion to power and sampled by area.

Emission is two-sided with radiance L = strength x colour (Cycles), so a triangle's
power is pi x area x mean(L) per side; the constant factor does not change the
selection probabilities, so weights are area x mean(L).
"""

from __future__ import annotations

import numpy as np

from . import sampling
from .scene import Scene


class EmitterSet:
    """Emissive triangles of a scene.

    index : (k,) triangle ids; radiance : (k, 3); area : (k,)
    pmf_by_triangle : (t,) selection probability of every scene triangle (0 if not an
        emitter), used to weight BSDF-sampled emitter hits by MIS.
    """

    def __init__(self, scene: Scene):
        emission = scene.materials.emission[scene.material_index]
        v = scene.vertices
        area = 0.5 * np.linalg.norm(np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]), axis=1)
        power = area * emission.mean(axis=1)
        self.index = np.nonzero(power > 0)[0]
        self.radiance = emission[self.index]
        self.area = area[self.index]
        self.corners = v[self.index]
        self.distribution = sampling.Distribution1D(power[self.index])
        self.pmf_by_triangle = np.zeros(scene.num_triangles)
        self.pmf_by_triangle[self.index] = self.distribution.pmf
        self.area_by_triangle = np.where(area > 0, area, 1.0)

    def __len__(self):
        return len(self.index)

    def sample(self, u_select: np.ndarray, u_point: np.ndarray):
        """Pick emitters by power and points on them uniformly.

        Returns triangle ids (n,), points (n, 3), pdf with respect to area (n,) and
        radiance (n, 3).
        """
        k = self.distribution.sample(u_select)
        b = sampling.sample_uniform_triangle(u_point)
        c = self.corners[k]
        p = b[:, 0:1] * c[:, 0] + b[:, 1:2] * c[:, 1] + b[:, 2:3] * c[:, 2]
        pdf_area = self.distribution.pmf[k] / self.area[k]
        return self.index[k], p, pdf_area, self.radiance[k]

    def pdf_area(self, triangle: np.ndarray) -> np.ndarray:
        """Area density with which `sample` picks a point on each triangle (n,)."""
        return self.pmf_by_triangle[triangle] / self.area_by_triangle[triangle]

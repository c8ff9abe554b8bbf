"""The acceleration structure: the only module that touches embreex.

Embree works in float32, so it gets the scene's recentred vertices; hit points are then
rebuilt in float64 from the barycentrics (see `Integrator`), which keeps them accurate
far from the world origin.
"""

from __future__ import annotations

import time

import numpy as np
from embreex import mesh_construction, rtcore_scene

from .scene import Scene

F32 = np.float32


class Accel:
    """Closest-hit and occlusion queries against the scene's triangles.

    `seconds` accumulates wall time spent inside embreex calls (for the benchmark);
    `rays` counts ray segments traced.
    """

    def __init__(self, scene: Scene):
        self.empty = scene.num_triangles == 0
        self.seconds = 0.0
        self.rays = 0
        if not self.empty:
            self._scene = rtcore_scene.EmbreeScene()
            if scene.shared_triangles is not None:
                # Indexed: each shared vertex copied once (embreex fills its buffers at
                # ~0.3 us a vertex: 1.2 s for a 1M-triangle soup, 0.5 s indexed).
                verts = np.ascontiguousarray(scene.shared_vertices, dtype=F32)
                tris = np.ascontiguousarray(scene.shared_triangles, dtype=np.int32)
            else:
                verts = np.ascontiguousarray(scene.vertices.reshape(-1, 3), dtype=F32)
                tris = np.arange(len(verts), dtype=np.int32).reshape(-1, 3)
            mesh_construction.TriangleMesh(self._scene, verts, tris)
            # Commit now (embreex commits lazily on the first query) so build time is
            # not charged to the first pass.
            self._scene.run(np.zeros((1, 3), F32), np.ones((1, 3), F32))

    def intersect(self, origins: np.ndarray, directions: np.ndarray, tmax: np.ndarray):
        """Closest hits. origins, directions (n, 3) float64, tmax (n,).

        Returns prim (n,) int32 (-1 for a miss), t (n,) float64, and barycentrics
        u, v (n,) float64 such that p = (1 - u - v) p0 + u p1 + v p2.
        """
        n = len(origins)
        if self.empty or n == 0:
            return (np.full(n, -1, np.int32), np.full(n, np.inf), np.zeros(n), np.zeros(n))
        t0 = time.perf_counter()
        hit = self._scene.run(np.ascontiguousarray(origins, F32),
                              np.ascontiguousarray(directions, F32),
                              dists=np.ascontiguousarray(np.minimum(tmax, 3e38), F32), output=1)
        self.seconds += time.perf_counter() - t0
        self.rays += n
        return (hit["primID"], hit["tfar"].astype(np.float64), hit["u"].astype(np.float64),
                hit["v"].astype(np.float64))

    def occluded(self, origins: np.ndarray, directions: np.ndarray, tmax: np.ndarray):
        """(n,) bool: is anything hit along each segment [0, tmax)?"""
        n = len(origins)
        if self.empty or n == 0:
            return np.zeros(n, bool)
        t0 = time.perf_counter()
        hit = self._scene.run(np.ascontiguousarray(origins, F32),
                              np.ascontiguousarray(directions, F32),
                              dists=np.ascontiguousarray(np.maximum(tmax, 0.0), F32),
                              query="OCCLUDED")
        self.seconds += time.perf_counter() - t0
        self.rays += n
        return hit >= 0

    def intersect_raw(self, origins: np.ndarray, directions: np.ndarray, tmax: np.ndarray):
        """Closest hits for contiguous float32 rays (the compiled kernels' buffers), in
        embree's own arrays: prim (n,) int32 (-1 for a miss), t, u, v (n,) float32. Embree
        writes each hit's t over `tmax` (pass a copy to keep it)."""
        n = len(origins)
        if self.empty or n == 0:
            z = np.zeros(n, F32)
            return np.full(n, -1, np.int32), np.full(n, np.inf, F32), z, z
        t0 = time.perf_counter()
        hit = self._scene.run(origins, directions, dists=tmax, output=1)
        self.seconds += time.perf_counter() - t0
        self.rays += n
        return hit["primID"], hit["tfar"], hit["u"], hit["v"]

    def occluded_raw(self, origins: np.ndarray, directions: np.ndarray, tmax: np.ndarray):
        """(n,) int32 for contiguous float32 segments: >= 0 where something blocks it."""
        n = len(origins)
        if self.empty or n == 0:
            return np.full(n, -1, np.int32)
        t0 = time.perf_counter()
        hit = self._scene.run(origins, directions, dists=tmax, query="OCCLUDED")
        self.seconds += time.perf_counter() - t0
        self.rays += n
        return hit

"""Cycles' mesh-derived attributes (engine.mesh_attributes): Random Per Island and
Pointiness, checked on meshes whose values are known by hand."""

import math

import numpy as np


def test_an_island_is_numbered_by_the_root_cycles_disjoint_set_gives_it():
    """Random Per Island hashes the root of each triangle's first vertex in Cycles'
    DisjointSet: joined by rank, so vertex 2 joining the set {0, 1} hangs under its root
    0 (joining without rank would root the island at 2); a tie keeps the first vertex's
    root; another island has its own number."""
    from engine.mesh_attributes import island_random
    from engine.noise import hash_uint
    edges = np.array([[0, 1], [2, 0], [4, 3], [5, 6]], np.int64)
    got = island_random(edges, 7, np.array([2, 3, 6], np.int64))
    expected = [np.float32(hash_uint(1, root, 0, 0, 0)) / np.float32(4294967296.0)
                for root in (0, 4, 5)]
    assert got.dtype == np.float32 and list(got) == expected


def _cube(split):
    """A unit cube's positions, vertex normals and edges: 8 shared corners (normals along
    the diagonals, as Blender's), or each face its own 4 corners with its own normal."""
    corners = np.array([(x, y, z) for x in (0, 1) for y in (0, 1) for z in (0, 1)],
                       np.float32)
    if not split:
        edges = [(a, b) for a in range(8) for b in range(a + 1, 8)
                 if np.abs(corners[a] - corners[b]).sum() == 1]
        normals = (corners - 0.5) / np.linalg.norm(corners - 0.5, axis=1)[:, None]
        return corners, normals.astype(np.float32), np.array(edges, np.int64)
    positions, normals, edges = [], [], []
    for axis in range(3):
        for side in (0, 1):
            face = [c for c in corners if c[axis] == side]
            face = [face[0], face[1], face[3], face[2]]  # around the square
            n = np.zeros(3, np.float32)
            n[axis] = 1.0 if side else -1.0
            first = len(positions)
            positions += face
            normals += [n] * 4
            edges += [(first + k, first + (k + 1) % 4) for k in range(4)]
    return (np.array(positions, np.float32), np.array(normals, np.float32),
            np.array(edges, np.int64))


def test_pointiness_is_a_half_where_flat_and_cycles_angle_at_a_cube_s_corners():
    """Pointiness is the angle between a vertex's normal and the mean of its edges'
    directions over pi, blurred once over the edges: 1/2 on a flat grid; at a cube's
    corners acos(-1/sqrt 3) / pi = 0.696, the same when every face has its own corners
    (Cycles welds exact duplicates first; unwelded, each would read 1/2)."""
    from engine.mesh_attributes import pointiness
    xs = np.array([(x, y, 0.0) for y in range(3) for x in range(3)], np.float32)
    grid_edges = np.array([(i, i + 1) for i in range(9) if i % 3 < 2]
                          + [(i, i + 3) for i in range(6)], np.int64)
    up = np.tile(np.array([0, 0, 1], np.float32), (9, 1))
    np.testing.assert_allclose(pointiness(xs, up, grid_edges), 0.5, atol=1e-6)
    corner = math.acos(-1.0 / math.sqrt(3.0)) / math.pi
    for split in (False, True):
        np.testing.assert_allclose(pointiness(*_cube(split)), corner, atol=1e-6)

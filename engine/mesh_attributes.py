"""Attributes Cycles derives from a mesh's topology for the Geometry node, as the exporter
asks for them: Pointiness (attr_create_pointiness) and Random Per Island
(attr_create_random_per_island), each the same arithmetic in float32."""

from __future__ import annotations

import math

import numpy as np

from .jit import ALLOCATING, JIT, njit
from .noise import MASK, hash_uint

# Cycles' FLT_EPSILON and M_1_PI_F, as float32.
_EPSILON = np.float32(1.1920928955078125e-07)
_INV_PI = np.float32(1.0 / math.pi)


@njit(**JIT)
def _island_root(parent, x):
    """The root of x's set, the path to it compressed (Cycles' DisjointSet::find)."""
    root = x
    while parent[root] != root:
        root = parent[root]
    while parent[x] != root:
        x, parent[x] = parent[x], root
    return root


@njit(**ALLOCATING)
def island_random(edges, n_verts, first_verts):
    """The Geometry node's Random Per Island of each triangle (float32): Cycles joins the
    mesh's vertices along its edges, in order, in its DisjointSet (union by rank, the
    first vertex's root winning a tie) and hashes the root of each triangle's first
    vertex, hash_uint_to_float (attr_create_random_per_island). edges : (e, 2) vertex
    indices; first_verts : (t,) each triangle's first vertex."""
    parent = np.arange(n_verts)
    rank = np.zeros(n_verts, np.int64)
    for e in range(edges.shape[0]):
        x = _island_root(parent, edges[e, 0])
        y = _island_root(parent, edges[e, 1])
        if x == y:
            continue
        if rank[x] < rank[y]:
            x, y = y, x
        parent[y] = x
        if rank[x] == rank[y]:
            rank[x] += 1
    out = np.empty(len(first_verts), np.float32)
    for t in range(len(first_verts)):
        h = hash_uint(1, _island_root(parent, first_verts[t]) & MASK, 0, 0, 0)
        out[t] = np.float32(h) / np.float32(4294967296.0)
    return out


@njit(**ALLOCATING)
def _welded(positions):
    """Each vertex's representative among its exact duplicates (Cycles' STEP 1: vertices
    sorted by the sum of their coordinates, equal positions by index downward, each
    pointing to the first later one within FLT_EPSILON squared, within 3 FLT_EPSILON of
    its sum, then chains followed to their end)."""
    n = positions.shape[0]
    total = np.empty(n, np.float32)
    for v in range(n):
        total[v] = positions[v, 0] + positions[v, 1] + positions[v, 2]
    # (reversed and stably sorted: equal sums keep the higher index first)
    order = n - 1 - np.argsort(total[::-1], kind="mergesort")
    orig = np.arange(n)
    for k in range(n):
        v = order[k]
        for m in range(k + 1, n):
            w = order[m]
            if total[w] - total[v] > np.float32(3.0) * _EPSILON:
                break
            dx = positions[w, 0] - positions[v, 0]
            dy = positions[w, 1] - positions[v, 1]
            dz = positions[w, 2] - positions[v, 2]
            if dx * dx + dy * dy + dz * dz < _EPSILON:
                orig[v] = w
                break
    for v in range(n):
        o = orig[v]
        while o != orig[o]:
            o = orig[o]
        orig[v] = o
    return orig


@njit(**ALLOCATING)
def _unique_edges(edges, orig):
    """The edges between representatives, each unordered pair once, in the mesh's order."""
    seen = set()
    out = np.empty((edges.shape[0], 2), np.int64)
    k = 0
    for e in range(edges.shape[0]):
        a, b = orig[edges[e, 0]], orig[edges[e, 1]]
        key = (min(a, b), max(a, b))
        if key in seen:
            continue
        seen.add(key)
        out[k, 0], out[k, 1] = a, b
        k += 1
    return out[:k]


@njit(**ALLOCATING)
def pointiness(positions, vertex_normals, edges):
    """The Geometry node's Pointiness per vertex (float32): with exact duplicates welded,
    the angle between a vertex's normal and the mean direction of its edges, over pi
    (1/2 flat, above convex), then averaged with its edge neighbours' once. positions,
    vertex_normals : (n, 3) float32, Blender's; edges : (e, 2) vertex indices."""
    n = positions.shape[0]
    orig = _welded(positions)
    normal = np.zeros((n, 3), np.float32)
    for v in range(n):
        for j in range(3):
            normal[orig[v], j] += vertex_normals[v, j]
    unique = _unique_edges(edges, orig)
    accum = np.zeros((n, 3), np.float32)
    count = np.zeros(n, np.int64)
    for e in range(unique.shape[0]):
        a, b = unique[e, 0], unique[e, 1]
        d = positions[b] - positions[a]
        length = np.float32(math.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]))
        if length > 0:
            d = d / length
        accum[a] += d
        accum[b] -= d
        count[a] += 1
        count[b] += 1
    raw = np.zeros(n, np.float32)
    for v in range(n):
        if orig[v] == v and count[v] > 0:
            nv = normal[v] / np.float32(math.sqrt(normal[v, 0] ** 2 + normal[v, 1] ** 2
                                                  + normal[v, 2] ** 2))
            mean = accum[v] / np.float32(count[v])
            c = min(max(nv[0] * mean[0] + nv[1] * mean[1] + nv[2] * mean[2], -1.0), 1.0)
            raw[v] = np.float32(math.acos(c)) * _INV_PI
    data = raw.copy()
    count[:] = 0
    for e in range(unique.shape[0]):
        a, b = unique[e, 0], unique[e, 1]
        data[a] += raw[b]
        data[b] += raw[a]
        count[a] += 1
        count[b] += 1
    for v in range(n):
        data[v] /= np.float32(count[v] + 1)
    out = np.empty(n, np.float32)
    for v in range(n):
        out[v] = data[orig[v]]
    return out

"""engine/voronoi.py against Blender's own Voronoi Texture, evaluated by geometry nodes at
random points: Blender's implementation (blenlib's noise) is the same algorithm as
Cycles' kernel/svm/voronoi.h, with the same hashes, so every output must match to float32
rounding. (The Cycles variant `voronoi` checks the node inside rendered materials.)"""

import bpy
import numpy as np
import pytest

from engine import voronoi as V

INPUTS = {"Scale": 2.3, "Detail": 1.6, "Roughness": 0.6, "Lacunarity": 2.2,
          "Smoothness": 0.7, "Exponent": 1.3, "Randomness": 0.85}
ORDER = ("Scale", "Detail", "Roughness", "Lacunarity", "Smoothness", "Exponent", "Randomness")
# Output name -> (width in Blender's attribute, columns of voronoi.voronoi's result).
OUTPUTS = {"Distance": (1, [0]), "Color": (4, [1, 2, 3]), "Position": (3, [4, 5, 6]),
           "W": (1, [7]), "Radius": (1, [8])}


def blender_voronoi(points, dims, feature, metric, normalize, inputs):
    """Blender's Voronoi Texture at `points` (n, 3) with W = x + y: output name -> values
    (None where the node has no such output for these settings)."""
    mesh = bpy.data.meshes.new("points")
    mesh.vertices.add(len(points))
    mesh.vertices.foreach_set("co", points.ravel())
    obj = bpy.data.objects.new("points", mesh)
    bpy.context.scene.collection.objects.link(obj)
    tree = bpy.data.node_groups.new("voronoi", "GeometryNodeTree")
    tree.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    tree.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    nodes, links = tree.nodes, tree.links
    position, split = nodes.new("GeometryNodeInputPosition"), nodes.new("ShaderNodeSeparateXYZ")
    w = nodes.new("ShaderNodeMath")  # ADD
    node = nodes.new("ShaderNodeTexVoronoi")
    node.voronoi_dimensions, node.feature, node.distance = dims, feature, metric
    node.normalize = normalize
    for name, value in inputs.items():
        if name in node.inputs:
            node.inputs[name].default_value = value
    links.new(position.outputs[0], split.inputs[0])
    links.new(split.outputs[0], w.inputs[0])
    links.new(split.outputs[1], w.inputs[1])
    if "Vector" in node.inputs:
        links.new(position.outputs[0], node.inputs["Vector"])
    if "W" in node.inputs:
        links.new(w.outputs[0], node.inputs["W"])
    geometry = nodes.new("NodeGroupInput").outputs[0]
    present = {}
    for name, (width, _) in OUTPUTS.items():
        out = next((o for o in node.outputs if o.name == name and o.enabled), None)
        present[name] = out is not None
        if out is None:
            continue
        store = nodes.new("GeometryNodeStoreNamedAttribute")
        store.data_type = {1: "FLOAT", 3: "FLOAT_VECTOR", 4: "FLOAT_COLOR"}[width]
        store.inputs["Name"].default_value = "out_" + name
        links.new(geometry, store.inputs["Geometry"])
        links.new(out, next(s for s in store.inputs if s.name == "Value" and s.enabled))
        geometry = store.outputs[0]
    links.new(geometry, nodes.new("NodeGroupOutput").inputs[0])
    obj.modifiers.new("voronoi", "NODES").node_group = tree
    evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
    result = {}
    for name, (width, _) in OUTPUTS.items():
        if not present[name]:
            result[name] = None
            continue
        values = np.zeros(len(points) * width, np.float32)
        key = {1: "value", 3: "vector", 4: "color"}[width]
        evaluated.attributes["out_" + name].data.foreach_get(key, values)
        result[name] = values.reshape(len(points), width)[:, :3] if width > 1 else values
    bpy.data.objects.remove(obj)
    bpy.data.meshes.remove(mesh)
    bpy.data.node_groups.remove(tree)
    return result


def ours(points, dims, feature, metric, normalize, inputs):
    d, f, m = np.int64(int(dims[0])), np.int64(V.FEATURES.index(feature)), \
        np.int64(V.METRICS.index(metric))
    return np.array([V.voronoi(d, f, m, normalize, float(p[0]), float(p[1]), float(p[2]),
                               float(np.float32(p[0] + p[1])), *(inputs[k] for k in ORDER))
                     for p in points])


CASES = [(dims, feature, metric)
         for dims in ("1D", "2D", "3D", "4D") for feature in V.FEATURES
         for metric in (V.METRICS if dims != "1D" and feature in ("F1", "F2", "SMOOTH_F1")
                        else ("EUCLIDEAN",))]


@pytest.mark.parametrize("dims, feature, metric", CASES)
def test_voronoi_is_blenders(dims, feature, metric):
    """Every dimension, feature and metric, fractal (Detail 1.6: a fractional octave),
    normalized or not: each output Blender has for the settings agrees to float32
    rounding at 99 % of 300 random points (the rest sit on a near-tie between two
    points, where float32 and float64 may pick differently)."""
    points = np.random.default_rng(7).uniform(-3.0, 3.0, (300, 3)).astype(np.float32)
    for normalize in (False, True):
        theirs = blender_voronoi(points, dims, feature, metric, normalize, INPUTS)
        mine = ours(points, dims, feature, metric, normalize, INPUTS)
        for name, (width, columns) in OUTPUTS.items():
            if theirs[name] is None:
                continue
            ref = theirs[name]
            got = mine[:, columns].reshape(ref.shape)
            assert np.std(ref) > 0.01, (name, "a constant output tells nothing")
            err = np.abs(got - ref).reshape(len(points), -1).max(axis=1)
            tolerance = 1e-4 * np.maximum(1.0, np.abs(ref).reshape(len(points), -1).max(axis=1))
            assert np.mean(err > tolerance) <= 0.01, (name, normalize, np.sort(err)[-5:])


def test_pcg_hash_is_cycles_integer_arithmetic():
    """hash_pcg2d_i wraps as 32-bit signed integers and shifts arithmetically: checked
    against numpy's int32 arithmetic (which wraps the same way) on extreme keys."""
    keys = np.array([[0, 0], [-1, 7], [2**31 - 1, -2**31], [123456, -98765]], np.int64)
    for kx, ky in keys:
        with np.errstate(over="ignore"):
            v = np.array([kx, ky]).astype(np.int32) * np.int32(1664525) + np.int32(1013904223)
            v[0] += v[1] * np.int32(1664525)
            v[1] += v[0] * np.int32(1664525)
            v = v ^ (v >> 16)
            v[0] += v[1] * np.int32(1664525)
            v[1] += v[0] * np.int32(1664525)
        expected = (v & 0x7FFFFFFF).astype(np.float32).astype(np.float64) / 2.0**31
        got = V.pcg_hash(np.int64(2), int(kx), int(ky), 0, 0)[:2]
        np.testing.assert_array_equal(got, expected)

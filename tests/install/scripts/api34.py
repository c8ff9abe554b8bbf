"""Run inside Debian's Blender 3.4 with the legacy add-on enabled: the exporter's API
differences (Principled input names before 4.0, normals before 4.1). Prints `RESULT {json}`."""

import json

import bmesh
import bpy
import numpy as np
from specula import exporter, materials

bpy.ops.wm.read_homefile(use_empty=True)
scene = bpy.context.scene


def principled(name, **inputs):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    node = mat.node_tree.nodes["Principled BSDF"]
    for key, value in inputs.items():
        node.inputs[key].default_value = value
    return mat


result = {"version": list(bpy.app.version)}
# Before 4.0 the emission colour input is "Emission" and transmission is "Transmission".
glass = principled("Glass", **{"Transmission": 1.0, "IOR": 1.33, "Emission": (1, 0.5, 0.25, 1),
                               "Emission Strength": 2.0, "Roughness": 0.0})
spec, warnings = materials.convert(glass)
result["glass"] = {"ctor": spec.ctor, "kwargs": {k: v for k, v in spec.kwargs.items()},
                   "warnings": warnings}
metal = principled("Metal", **{"Metallic": 1.0, "Roughness": 0.0,
                               "Base Color": (0.9, 0.6, 0.2, 1)})
spec, warnings = materials.convert(metal)
result["metal"] = {"ctor": spec.ctor, "warnings": warnings}

# Smooth sphere: interpolated normals from calc_normals_split (no corner_normals before 4.1).
mesh = bpy.data.meshes.new("Sphere")
bm = bmesh.new()
bmesh.ops.create_uvsphere(bm, u_segments=16, v_segments=8, radius=1.0)
for face in bm.faces:
    face.smooth = True
bm.to_mesh(mesh)
bm.free()
obj = bpy.data.objects.new("Sphere", mesh)
scene.collection.objects.link(obj)
cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
cam.location = (0, -5, 0)
cam.rotation_euler = (np.pi / 2, 0, 0)
scene.collection.objects.link(cam)
scene.camera = cam
depsgraph = bpy.context.evaluated_depsgraph_get()
exported = exporter.export(depsgraph)
(data,) = exported.meshes.values()
vertex_normals = data.vertices / np.linalg.norm(data.vertices, axis=1, keepdims=True)
corner_vertices = vertex_normals[data.triangles]
result["sphere"] = {"triangles": int(len(data.triangles)), "smooth": bool(data.smooth.all()),
                    "max_normal_error": float(np.abs(data.normals - corner_vertices).max())}
print("RESULT " + json.dumps(result))

"""Scene-building helpers for the add-on tests (bpy data only, no operators)."""

import bpy  # noqa: I001 - bpy must be imported before bmesh
import bmesh


def link(obj, scene=None):
    (scene or bpy.context.scene).collection.objects.link(obj)
    return obj


def cube_object(name="Cube", size=2.0, smooth=False, scene=None):
    mesh = bpy.data.meshes.new(name)
    bm = bmesh.new()
    bmesh.ops.create_cube(bm, size=size)
    for f in bm.faces:
        f.smooth = smooth
    bm.to_mesh(mesh)
    bm.free()
    return link(bpy.data.objects.new(name, mesh), scene)


def sphere_object(name="Sphere", radius=1.0, smooth=True, scene=None):
    mesh = bpy.data.meshes.new(name)
    bm = bmesh.new()
    bmesh.ops.create_uvsphere(bm, u_segments=16, v_segments=8, radius=radius)
    for f in bm.faces:
        f.smooth = smooth
    bm.to_mesh(mesh)
    bm.free()
    return link(bpy.data.objects.new(name, mesh), scene)


def node_material(name, shader, **inputs):
    mat = bpy.data.materials.new(name)
    if bpy.app.version < (5, 0):
        mat.use_nodes = True
    tree = mat.node_tree
    tree.nodes.clear()
    out = tree.nodes.new("ShaderNodeOutputMaterial")
    node = tree.nodes.new(shader)
    for key, value in inputs.items():
        node.inputs[key].default_value = value
    tree.links.new(node.outputs[0], out.inputs["Surface"])
    return mat, node


def camera_object(name="Camera", location=(0.0, 0.0, 0.0), rotation=(0.0, 0.0, 0.0),
                  scene=None):
    cam = bpy.data.cameras.new(name)
    obj = link(bpy.data.objects.new(name, cam), scene)
    obj.location = location
    obj.rotation_euler = rotation
    (scene or bpy.context.scene).camera = obj
    return obj


def depsgraph():
    dg = bpy.context.evaluated_depsgraph_get()
    dg.update()
    return dg

"""Bad-input cases that need Blender, each run in its own process by test_bad_input.py:
`python -m tests.robustness.bpy_cases CASE OUTDIR` prints one JSON line (the last) with
what happened, timings and the process's peak RSS. Not a test module itself."""

from __future__ import annotations  # noqa: I001 - bpy must be imported before bmesh

import json
import os
import sys
import time

import bpy
import bmesh
import numpy as np

import addon
from addon import core as core_loader
from addon import exporter, render_session
from tests.memory import peak_rss_mb


def fresh():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine = "SPECULA"
    return scene


def camera(scene, location=(0.0, -8.0, 0.0), rotation=(np.pi / 2, 0.0, 0.0)):
    obj = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(obj)
    obj.location, obj.rotation_euler = location, rotation
    scene.camera = obj
    return obj


def world(scene, colour):
    w = bpy.data.worlds.new("World")
    w.color = colour
    if bpy.app.version < (5, 0):
        w.use_nodes = True
    bg = next(n for n in w.node_tree.nodes if n.bl_idname == "ShaderNodeBackground")
    bg.inputs["Color"].default_value = (*colour, 1.0)
    scene.world = w
    return w


def render_to_exr(scene, path, size, samples=2):
    scene.specula.samples = samples
    scene.render.resolution_x, scene.render.resolution_y = size
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.image_settings.color_depth = "32"
    scene.render.filepath = path
    scene.render.use_file_extension = False
    render_session.last_summary = {}
    error = None
    try:
        bpy.ops.render.render(write_still=True)
    except RuntimeError as exc:
        error = str(exc).strip()
    out = {"summary": dict(render_session.last_summary), "error": error}
    if error is None and os.path.isfile(path):
        image = bpy.data.images.load(path)
        out["image_size"] = list(image.size)
        px = np.zeros(image.size[0] * image.size[1] * image.channels, np.float32)
        image.pixels.foreach_get(px)
        px = px.reshape(-1, image.channels)
        out["finite"] = bool(np.isfinite(px).all())
        out["mean_rgb"] = px[:, :3].mean(axis=0).tolist()
    return out


def core_scene(scene):
    exp = exporter.export(bpy.context.evaluated_depsgraph_get())
    sc, warnings = exporter.to_core(exp, core_loader.load())
    return exp, sc, warnings


# ------------------------------------------------------------------------------- cases
def case_messy_meshes(outdir):
    """An n-gon, loose edges and vertices, a mesh with no faces, an empty mesh and an
    object without material, rendered through Blender's pipeline."""
    scene = fresh()
    camera(scene)
    world(scene, (0.2, 0.3, 0.4))
    bm = bmesh.new()
    ring = [bm.verts.new((np.cos(a), 0.0, np.sin(a))) for a in np.linspace(0, 2 * np.pi, 9)[:-1]]
    bm.faces.new(ring)  # an octagon: 6 triangles
    a, b = bm.verts.new((2, 0, 0)), bm.verts.new((3, 0, 1))
    bm.edges.new((a, b))  # a loose edge
    bm.verts.new((-2, 0, -1))  # a loose vertex
    mesh = bpy.data.meshes.new("Messy")
    bm.to_mesh(mesh)
    bm.free()
    scene.collection.objects.link(bpy.data.objects.new("Messy", mesh))
    wire = bpy.data.meshes.new("Wire")
    wire.from_pydata([(0, 0, 2), (1, 0, 2), (1, 0, 3)], [(0, 1), (1, 2)], [])
    scene.collection.objects.link(bpy.data.objects.new("Wire", wire))
    scene.collection.objects.link(bpy.data.objects.new("Empty mesh", bpy.data.meshes.new("E")))
    exp, sc, warnings = core_scene(scene)
    res = render_to_exr(scene, os.path.join(outdir, "messy.exr"), (32, 24))
    return dict(triangles=int(sc.num_triangles), objects=sc.object_names,
                materials=[m.ctor for m in exp.materials], warnings=exp.warnings + warnings,
                **res)


def case_empty_scene(outdir):
    """Nothing but a camera and a world colour: the image is the world colour."""
    scene = fresh()
    camera(scene)
    world(scene, (0.2, 0.3, 0.4))
    return render_to_exr(scene, os.path.join(outdir, "empty.exr"), (8, 6))


def case_no_camera(outdir):
    scene = fresh()
    world(scene, (0.2, 0.3, 0.4))
    bpy.ops.mesh.primitive_cube_add()
    scene.camera = None
    return render_to_exr(scene, os.path.join(outdir, "nocam.exr"), (8, 6))


def case_one_pixel(outdir):
    scene = fresh()
    camera(scene)
    world(scene, (0.5, 0.5, 0.5))
    bpy.ops.mesh.primitive_cube_add()
    return render_to_exr(scene, os.path.join(outdir, "one.exr"), (1, 1), samples=4)


def case_instances(outdir, count=100_000):
    """A 12-triangle cube instanced `count` times by geometry nodes (a grid of points),
    exported, converted and rendered at 32x24, 1 sample."""
    scene = fresh()
    camera(scene, location=(0.0, -60.0, 40.0), rotation=(np.radians(55), 0.0, 0.0))
    world(scene, (0.5, 0.5, 0.5))
    src = bpy.data.objects.new("Src", bpy.data.meshes.new("SrcMesh"))
    bm = bmesh.new()
    bmesh.ops.create_cube(bm, size=0.1)
    bm.to_mesh(src.data)
    bm.free()
    scene.collection.objects.link(src)
    src.hide_render = True
    host = bpy.data.objects.new("Host", bpy.data.meshes.new("HostMesh"))
    scene.collection.objects.link(host)
    ng = bpy.data.node_groups.new("Scatter", "GeometryNodeTree")
    ng.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    ng.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    ng.nodes.new("NodeGroupInput")
    out = ng.nodes.new("NodeGroupOutput")
    grid = ng.nodes.new("GeometryNodeMeshGrid")
    grid.inputs["Vertices X"].default_value = 400
    grid.inputs["Vertices Y"].default_value = count // 400
    grid.inputs["Size X"].default_value = 50.0
    grid.inputs["Size Y"].default_value = 50.0
    iop = ng.nodes.new("GeometryNodeInstanceOnPoints")
    info = ng.nodes.new("GeometryNodeObjectInfo")
    info.inputs["Object"].default_value = src
    ng.links.new(grid.outputs[0], iop.inputs["Points"])
    ng.links.new(info.outputs["Geometry"], iop.inputs["Instance"])
    ng.links.new(iop.outputs[0], out.inputs[0])
    host.modifiers.new("GN", "NODES").node_group = ng
    t0 = time.perf_counter()
    exp = exporter.export(bpy.context.evaluated_depsgraph_get())
    t1 = time.perf_counter()
    core = core_loader.load()
    sc, warnings = exporter.to_core(exp, core)
    t2 = time.perf_counter()
    r = core.render(sc, core.RenderSettings(width=32, height=24, samples=1, max_bounces=1))
    t3 = time.perf_counter()
    return dict(instances=sum(i.is_instance for i in exp.instances), meshes=len(exp.meshes),
                triangles=int(sc.num_triangles), export_s=t1 - t0, to_core_s=t2 - t1,
                render_s=t3 - t2, finite=bool(np.isfinite(r.combined).all()),
                hit_fraction=float((r.depth < 1e9).mean()), warnings=warnings)


def case_bad_ior(outdir):
    """Glass BSDF with IOR 0 (the add-on warns naming the material and uses 1.5) and a
    Principled glass with IOR NaN (the core refuses it, naming the material)."""
    out = {}
    for label, value in (("zero", 0.0), ("nan", float("nan"))):
        scene = fresh()
        camera(scene)
        world(scene, (0.5, 0.5, 0.5))
        bpy.ops.mesh.primitive_cube_add()
        mat = bpy.data.materials.new(f"Bad IOR {label}")
        if bpy.app.version < (5, 0):
            mat.use_nodes = True
        tree = mat.node_tree
        tree.nodes.clear()
        shader = tree.nodes.new("ShaderNodeBsdfGlass")
        shader.inputs["IOR"].default_value = value
        output = tree.nodes.new("ShaderNodeOutputMaterial")
        tree.links.new(shader.outputs[0], output.inputs["Surface"])
        bpy.context.active_object.data.materials.append(mat)
        res = render_to_exr(scene, os.path.join(outdir, f"ior_{label}.exr"), (8, 6))
        exp = exporter.export(bpy.context.evaluated_depsgraph_get())
        res.update(socket_value=float(shader.inputs["IOR"].default_value),
                   export_warnings=exp.warnings)
        out[label] = res
    return out


CASES = {name[5:]: fn for name, fn in globals().items() if name.startswith("case_")}


def main(argv):
    name, outdir = argv[0], argv[1]
    addon.register()
    t0 = time.perf_counter()
    out = CASES[name](outdir)
    out.update(case=name, seconds=time.perf_counter() - t0, peak_rss_mb=peak_rss_mb())
    print(json.dumps(out, default=str))


if __name__ == "__main__":
    main(sys.argv[1:])

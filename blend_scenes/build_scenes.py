"""Rebuild the course project's scenes for Blender and save them next to this script.

Run: .venv/bin/python blend_scenes/build_scenes.py            (bpy 5.0.1: blend_scenes/*.blend)
     blender -b --python blend_scenes/build_scenes.py -- --out blend_scenes/v3.4
                                     (Debian's Blender 3.4.1: files every version 3.4 - 5.0 opens;
                                      files saved by 5.0 open only in 4.5 and later)

Frames: the course is y-up with the camera on +z; Blender is z-up, so a course point
(x, y, z) is Blender (x, -z, y) and the camera sits on -y looking along +y.

  cbspheres.blend  Cornell box (x in [-1, 1], y in [-1, 1], z in [0, 1.5], front (y = -1)
                   open), ceiling emitter, mirror sphere left, glass sphere right; 480x360.
  cbdragon.blend   The same box with a gold mirror stand-in for the dragon (Suzanne with
                   a level-4 Subdivision modifier, > 200k triangles once evaluated) and a
                   thin-lens camera; 480x270.
  default.blend    Blender's factory startup scene, engine set to Specula.
"""

import math
import os
import sys

import bpy  # noqa: I001 - bpy must be imported before bmesh
import bmesh

HERE = os.path.dirname(os.path.abspath(__file__))
# Where the .blend files go (`-- --out DIR` changes it).
HERE_OUT = HERE
sys.path.insert(0, os.path.dirname(HERE))

# Course CBspheres camera: horizontal field of view 49.13 degrees on a 36 mm sensor.
SENSOR_WIDTH = 36.0
CBSPHERES_HFOV = math.radians(49.13)
CBSPHERES_LENS = SENSOR_WIDTH / (2.0 * math.tan(CBSPHERES_HFOV / 2.0))

# Course CBdragon thin lens: radius 1.23 scene units, focal distance 4.56. Blender takes an
# f-stop: radius = lens_mm * 1e-3 / (2 * fstop), so fstop = lens_mm * 1e-3 / (2 * radius).
# The camera stands back so the subject's front is ~4.56 from it, and its lens makes the
# box's open front (2 wide, 4 from the camera) fill the frame: lens = 18 mm * 4 / 1.
CBDRAGON_CAMERA_Y = -5.0
CBDRAGON_LENS = (SENSOR_WIDTH / 2.0) * (-1.0 - CBDRAGON_CAMERA_Y) / 1.0
CBDRAGON_APERTURE_RADIUS = 1.23
CBDRAGON_FOCUS = 4.56
CBDRAGON_FSTOP = CBDRAGON_LENS * 1e-3 / (2.0 * CBDRAGON_APERTURE_RADIUS)


def register_addon():
    """Register Specula if it can be; the scenes are still built without it."""
    try:
        import addon
        addon.register()
        return True
    except Exception as exc:  # noqa: BLE001 - building scenes must not need the add-on
        print(f"Specula add-on not registered ({exc}); scenes keep the default engine")
        return False


def material(name, shader, **inputs):
    """A node material whose surface is one `shader` node with the given input values."""
    mat = bpy.data.materials.new(name)
    if bpy.app.version < (5, 0):
        mat.use_nodes = True
    tree = mat.node_tree
    tree.nodes.clear()
    out = tree.nodes.new("ShaderNodeOutputMaterial")
    node = tree.nodes.new(shader)
    node.location = (-300, 0)
    for key, value in inputs.items():
        node.inputs[key].default_value = value
    tree.links.new(node.outputs[0], out.inputs["Surface"])
    colour = inputs.get("Color", inputs.get("Base Color"))
    if colour is not None:
        mat.diffuse_color = colour  # what Solid mode and EEVEE fallbacks show
    return mat


def diffuse(name, rgb):
    return material(name, "ShaderNodeBsdfDiffuse", Color=(*rgb, 1.0), Roughness=0.0)


def mesh_object(name, verts, faces, mat, collection):
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(verts, [], faces)
    mesh.update()
    obj = bpy.data.objects.new(name, mesh)
    obj.data.materials.append(mat)
    collection.objects.link(obj)
    return obj


def quad(name, corners, mat, collection):
    return mesh_object(name, corners, [(0, 1, 2, 3)], mat, collection)


def cornell_box(collection):
    """Walls with inward-facing normals, plus the ceiling emitter at z = 1.49."""
    white = diffuse("White", (0.6, 0.6, 0.6))
    red = diffuse("Red", (0.6, 0.2, 0.2))
    blue = diffuse("Blue", (0.2, 0.2, 0.6))
    x0, x1, y0, y1, z0, z1 = -1.0, 1.0, -1.0, 1.0, 0.0, 1.5
    quad("Floor", [(x0, y0, z0), (x1, y0, z0), (x1, y1, z0), (x0, y1, z0)], white, collection)
    quad("Ceiling", [(x0, y0, z1), (x0, y1, z1), (x1, y1, z1), (x1, y0, z1)], white, collection)
    quad("Back", [(x0, y1, z0), (x1, y1, z0), (x1, y1, z1), (x0, y1, z1)], white, collection)
    quad("Left", [(x0, y0, z0), (x0, y1, z0), (x0, y1, z1), (x0, y0, z1)], red, collection)
    quad("Right", [(x1, y0, z0), (x1, y0, z1), (x1, y1, z1), (x1, y1, z0)], blue, collection)
    light = material("Light", "ShaderNodeEmission", Color=(1.0, 1.0, 1.0, 1.0), Strength=10.0)
    light.diffuse_color = (1.0, 1.0, 1.0, 1.0)
    # Facing down; Cycles' emission is two-sided anyway.
    quad("Emitter", [(-0.4, -0.3, 1.49), (-0.4, 0.3, 1.49), (0.4, 0.3, 1.49), (0.4, -0.3, 1.49)],
         light, collection)


def uv_sphere(name, centre, radius, mat, collection):
    mesh = bpy.data.meshes.new(name)
    bm = bmesh.new()
    bmesh.ops.create_uvsphere(bm, u_segments=64, v_segments=32, radius=radius)
    for face in bm.faces:
        face.smooth = True
    bm.to_mesh(mesh)
    bm.free()
    obj = bpy.data.objects.new(name, mesh)
    obj.location = centre
    obj.data.materials.append(mat)
    collection.objects.link(obj)
    return obj


def camera(scene, name, location, lens, res):
    cam = bpy.data.cameras.new(name)
    cam.sensor_fit = "HORIZONTAL"
    cam.sensor_width = SENSOR_WIDTH
    cam.lens = lens
    cam.clip_start, cam.clip_end = 0.1, 100.0
    obj = bpy.data.objects.new(name, cam)
    obj.location = location
    obj.rotation_euler = (math.pi / 2.0, 0.0, 0.0)  # look along +y, z up
    scene.collection.objects.link(obj)
    scene.camera = obj
    scene.render.resolution_x, scene.render.resolution_y = res
    scene.render.resolution_percentage = 100
    return obj


def black_world(scene):
    world = bpy.data.worlds.new("Black")
    if bpy.app.version < (5, 0):
        world.use_nodes = True
    bg = next(n for n in world.node_tree.nodes if n.bl_idname == "ShaderNodeBackground")
    bg.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    bg.inputs["Strength"].default_value = 1.0
    world.color = (0.0, 0.0, 0.0)
    scene.world = world


def finish(scene, path, use_specula):
    """Common render settings, then save compressed next to this script."""
    if use_specula:
        scene.render.engine = "SPECULA"
        scene.specula.samples = 64
        scene.specula.max_bounces = 12
    for layer in scene.view_layers:
        layer.use_pass_z = True
        layer.use_pass_normal = True
    # Linear output when saved as EXR; 'Standard' keeps PNGs comparable with the course.
    scene.view_settings.view_transform = "Standard"
    bpy.ops.wm.save_as_mainfile(filepath=path, compress=True)
    print(f"wrote {path} ({os.path.getsize(path) // 1024} KiB)")


def new_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return bpy.context.scene


def build_cbspheres(use_specula):
    scene = new_scene()
    coll = scene.collection
    cornell_box(coll)
    mirror = material("Mirror", "ShaderNodeBsdfGlossy", Color=(1.0, 1.0, 1.0, 1.0),
                      Roughness=0.0)
    glass = material("Glass", "ShaderNodeBsdfGlass", Color=(1.0, 1.0, 1.0, 1.0), Roughness=0.0,
                     IOR=1.45)
    uv_sphere("MirrorSphere", (-0.5, 0.25, 0.3), 0.3, mirror, coll)
    uv_sphere("GlassSphere", (0.5, -0.25, 0.3), 0.3, glass, coll)
    camera(scene, "Camera", (0.0, -3.0, 0.75), CBSPHERES_LENS, (480, 360))
    black_world(scene)
    finish(scene, os.path.join(HERE_OUT, "cbspheres.blend"), use_specula)


def build_cbdragon(use_specula):
    scene = new_scene()
    coll = scene.collection
    cornell_box(coll)
    gold = material("GoldMirror", "ShaderNodeBsdfGlossy", Color=(1.0, 0.8, 0.4, 1.0),
                    Roughness=0.0)
    mesh = bpy.data.meshes.new("Dragon")
    bm = bmesh.new()
    bmesh.ops.create_monkey(bm)
    for face in bm.faces:
        face.smooth = True
    bm.to_mesh(mesh)
    bm.free()
    dragon = bpy.data.objects.new("Dragon", mesh)
    dragon.data.materials.append(gold)
    # Suzanne faces -y, i.e. the camera; 0.5 scale keeps her inside the box on the floor.
    dragon.location = (0.0, 0.0, 0.5)
    dragon.scale = (0.5, 0.5, 0.5)
    # Level 4 gives ~250k triangles; left as a modifier so the .blend stays small.
    subsurf = dragon.modifiers.new("Subdivision", "SUBSURF")
    subsurf.levels = 4
    subsurf.render_levels = 4
    coll.objects.link(dragon)
    cam = camera(scene, "Camera", (0.0, CBDRAGON_CAMERA_Y, 0.75), CBDRAGON_LENS, (480, 270))
    dof = cam.data.dof
    dof.use_dof = True
    dof.focus_distance = CBDRAGON_FOCUS
    dof.aperture_fstop = CBDRAGON_FSTOP
    black_world(scene)
    finish(scene, os.path.join(HERE_OUT, "cbdragon.blend"), use_specula)


def build_default(use_specula):
    bpy.ops.wm.read_factory_settings(use_empty=False)
    scene = bpy.context.scene
    if use_specula:
        scene.render.engine = "SPECULA"
    for layer in scene.view_layers:  # Depth and Normal passes beside Combined
        layer.use_pass_z = True
        layer.use_pass_normal = True
    # Saved untouched otherwise: the point light is skipped with a warning (not supported
    # yet), so the cube is lit by the factory world colour only.
    bpy.ops.wm.save_as_mainfile(filepath=os.path.join(HERE_OUT, "default.blend"), compress=True)
    print(f"wrote {os.path.join(HERE_OUT, 'default.blend')}")


def main():
    global HERE_OUT
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    if argv[:1] == ["--out"] and len(argv) == 2:
        HERE_OUT = os.path.abspath(argv[1])
        os.makedirs(HERE_OUT, exist_ok=True)
    elif argv:
        raise SystemExit(f"usage: build_scenes.py [-- --out DIR], got {argv}")
    use_specula = register_addon()
    build_cbspheres(use_specula)
    build_cbdragon(use_specula)
    build_default(use_specula)


if __name__ == "__main__":
    main()

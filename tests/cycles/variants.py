"""The scenes Specula is compared with Cycles on: name -> a function that builds it in bpy.

Each variant's `setup()` leaves the scene to compare as `bpy.context.scene`: either a
committed .blend from blend_scenes/ (opened, then adjusted) or a small focused scene built
here from the helpers of blend_scenes/build_scenes.py (the course's Cornell box: diffuse
walls, ceiling emitter of radiance 10, camera 3 units in front). Resolution, sample counts
and the bounce limit are part of the variant; `renderers.prepare` applies them to both
engines.

A variant's `fingerprint()` hashes everything that defines its image (its own source, the
shared helpers it uses, build_scenes.py, the files it reads and its parameters), so a cached
Cycles reference is used only for the scene it was rendered from.
"""

from __future__ import annotations

import hashlib
import inspect
import json
import math
import os
import re
import sys
from dataclasses import dataclass, field

import bpy
import bmesh  # after bpy: the bpy module provides it
import mathutils
import numpy as np

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
if REPO not in sys.path:
    sys.path.insert(0, REPO)
SCENES_DIR = os.path.join(REPO, "blend_scenes")

from blend_scenes import build_scenes as bs  # noqa: E402 - needs REPO on sys.path

BUILD_SCENES = os.path.join(SCENES_DIR, "build_scenes.py")
GLTF_DIR = os.path.join(REPO, "tests", "assets", "gltf")


@dataclass(frozen=True)
class Variant:
    """One scene to compare.

    setup : callable() building the scene in bpy (it becomes bpy.context.scene)
    resolution : (width, height) in pixels, at 100 %
    max_bounces : the total bounce limit given to both engines (Cycles' per-type limits equal)
    samples : Specula's samples per pixel
    cycles_samples : Cycles' samples per pixel per seed; seeds : Cycles' independent seeds
    files : files the setup reads (hashed into the fingerprint)
    xfail : reason the comparison is expected to fail (a known missing feature), or None
    """

    name: str
    setup: object
    resolution: tuple = (64, 48)
    max_bounces: int = 8
    samples: int = 128
    cycles_samples: int = 256
    seeds: tuple = (1, 2)
    files: tuple = ()
    xfail: str | None = None
    notes: str = ""
    params: dict = field(default_factory=dict)

    def fingerprint(self) -> str:
        h = hashlib.sha256()
        h.update(inspect.getsource(self.setup).encode())
        for helper in _helpers_used(self.setup):
            h.update(inspect.getsource(helper).encode())
        for path in (BUILD_SCENES,) + tuple(self.files):
            with open(path, "rb") as f:
                h.update(hashlib.sha256(f.read()).digest())
        h.update(json.dumps(dict(resolution=list(self.resolution), max_bounces=self.max_bounces,
                                 cycles_samples=self.cycles_samples, seeds=list(self.seeds),
                                 params=self.params), sort_keys=True).encode())
        return h.hexdigest()[:16]


# ---------------------------------------------------------------------------------------
# Shared helpers (their source is part of every fingerprint)


def _open(name):
    bpy.ops.wm.open_mainfile(filepath=os.path.join(SCENES_DIR, name))
    return bpy.context.scene


def _box(emitter=True):
    """The course's Cornell box with its camera (4:3) and a black world."""
    scene = bs.new_scene()
    bs.cornell_box(scene.collection)
    if not emitter:
        bpy.data.objects.remove(bpy.data.objects["Emitter"])
    bs.camera(scene, "Camera", (0.0, -3.0, 0.75), bs.CBSPHERES_LENS, (64, 48))
    bs.black_world(scene)
    return scene


def _cube(name, location, scale, mat):
    """A unit cube (flat, outward normals) of material `mat`, moved and scaled."""
    mesh = bpy.data.meshes.new(name)
    bm = bmesh.new()
    bmesh.ops.create_cube(bm, size=1.0)
    bm.to_mesh(mesh)
    bm.free()
    obj = bpy.data.objects.new(name, mesh)
    obj.location, obj.scale = location, scale
    obj.data.materials.append(mat)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def _sphere(mat, centre=(0.0, 0.0, 0.4), radius=0.4, name="Subject"):
    return bs.uv_sphere(name, centre, radius, mat, bpy.context.scene.collection)


def _principled(name, **inputs):
    return bs.material(name, "ShaderNodeBsdfPrincipled", **inputs)


def _emitter_quad(name, centre, size, strength, rotation=(math.pi / 2, 0.0, 0.0)):
    """A square emitter of side `size`; the default rotation faces the camera (-y)."""
    mat = bs.material(name + "Mat", "ShaderNodeEmission", Color=(1.0, 1.0, 1.0, 1.0),
                      Strength=strength)
    h = size / 2.0
    obj = bs.quad(name, [(-h, -h, 0.0), (h, -h, 0.0), (h, h, 0.0), (-h, h, 0.0)], mat,
                  bpy.context.scene.collection)
    obj.location = centre
    obj.rotation_euler = rotation
    return obj


def _card(name, centre, size, mat, angle=0.0):
    """A flat w x h rectangle facing the camera (-y), turned by `angle` about the y axis."""
    w, h = size[0] / 2.0, size[1] / 2.0
    obj = bs.quad(name, [(-w, 0.0, -h), (-w, 0.0, h), (w, 0.0, h), (w, 0.0, -h)], mat,
                  bpy.context.scene.collection)
    obj.location = centre
    obj.rotation_euler = (0.0, angle, 0.0)
    return obj


def _chart(camera_res=(64, 48)):
    """Black world, the box camera at (0, -3, 0.75) looking along +y, and a uniform emitter
    of radiance 1 filling the view 6 units away: the backdrop for the charts below."""
    scene = bs.new_scene()
    bs.camera(scene, "Camera", (0.0, -3.0, 0.75), bs.CBSPHERES_LENS, camera_res)
    bs.black_world(scene)
    white = bs.material("Backdrop", "ShaderNodeEmission", Color=(1.0, 1.0, 1.0, 1.0),
                        Strength=1.0)
    _card("Backdrop", (0.0, 3.0, 0.75), (8.0, 6.0), white)
    return scene


def _dof_scene(**dof):
    """A lens chart: black cards (diffuse colour 0) against the emitting backdrop, in front
    of, at and behind the focus plane (2, 3 and ~6 units from the camera). Every pixel is
    the visible fraction of the backdrop over the lens and the pixel filter, with no
    lighting noise, so the blur of each card's edges shows the aperture's size and shape.
    Lens radius 0.3 (Blender's f-stop from it) unless `aperture_fstop` is given."""
    scene = _chart()
    black = bs.diffuse("Black", (0.0, 0.0, 0.0))
    for i, (x, z, a) in enumerate([(-0.45, 0.75, 0.0), (0.35, 1.05, 0.6), (0.05, 0.65, 0.0),
                                   (-0.35, 1.1, 0.3), (0.55, 0.8, 0.0)]):
        _card(f"Near{i}", (x, -1.0, z), (0.1, 0.1), black, a)
    # A long horizontal edge far out of focus: its blur profile is the aperture's height
    # profile, which tells a polygon from the same polygon turned by half a blade.
    _card("Shelf", (0.0, -1.0, 0.15), (2.2, 0.6), black)
    _card("FocusBarV", (-0.7, 0.0, 0.75), (0.06, 1.2), black)
    _card("FocusBarH", (0.4, 0.0, 1.35), (1.0, 0.06), black)
    for i, (x, z) in enumerate([(1.2, 0.0), (-1.5, 1.9), (1.6, 1.8), (-1.4, -0.4)]):
        _card(f"Far{i}", (x, 2.9, z), (0.5, 0.5), black, 0.4 * i)
    cam = scene.camera.data
    cam.dof.use_dof = True
    cam.dof.focus_distance = 3.0
    cam.dof.aperture_fstop = cam.lens * 1e-3 / (2.0 * 0.3)
    for key, value in dof.items():
        if key in ("sensor_fit", "shift_x", "shift_y"):
            setattr(cam, key, value)
        else:
            setattr(cam.dof, key, value)
    return scene


def _glass_chart(ior):
    """A glass sphere in front of the backdrop, with black vertical stripes on the backdrop
    (refraction shifts them with the IOR) and a second emitter behind the camera (its
    reflection on the sphere is F(theta) x 0.5): Fresnel and IOR seen almost noise-free."""
    _chart()
    black = bs.diffuse("Black", (0.0, 0.0, 0.0))
    for i in range(-6, 7):
        _card(f"Stripe{i}", (0.3 * i, 2.95, 0.75), (0.12, 6.0), black)
    back = bs.material("BackLight", "ShaderNodeEmission", Color=(1.0, 1.0, 1.0, 1.0),
                       Strength=0.5)
    card = _card("BackLight", (0.0, -4.0, 0.75), (8.0, 6.0), back)
    card.rotation_euler = (0.0, 0.0, math.pi)  # faces +y, toward the sphere
    _sphere(bs.material("Glass", "ShaderNodeBsdfGlass", Color=(1.0, 1.0, 1.0, 1.0),
                        Roughness=0.0, IOR=ior), (0.0, 0.0, 0.75), 0.6)


def _helpers() -> list:
    """Every helper of this module: its private functions, wherever they are defined."""
    return [f for name, f in globals().items() if name.startswith("_") and
            inspect.isfunction(f) and f.__module__ == __name__
            and name not in ("_helpers", "_helpers_used", "_add")]


def _helpers_used(fn) -> list:
    """The shared helpers `fn` calls, directly or through other helpers (for fingerprints:
    editing one helper invalidates only the references of the variants that use it)."""
    found, todo = [], [fn]
    while todo:
        source = inspect.getsource(todo.pop())
        for helper in _helpers():
            if helper not in found and re.search(rf"\b{helper.__name__}\(", source):
                found.append(helper)
                todo.append(helper)
    return sorted(found, key=lambda f: f.__name__)


# ---------------------------------------------------------------------------------------
# The committed scenes


def cbspheres():
    _open("cbspheres.blend")


def cbdragon():
    _open("cbdragon.blend")


def default_with_light():
    """The factory scene as committed: point light, and a cube whose default Principled BSDF
    has a rough (0.5) dielectric specular layer over its diffuse base."""
    _open("default.blend")


def default_light_no_specular():
    """The factory scene with its point light and its cube's Principled specular layer
    switched off (Specular IOR Level 0): the diffuse base alone."""
    _open("default.blend")
    node = bpy.data.materials["Material"].node_tree.nodes["Principled BSDF"]
    node.inputs["Specular IOR Level"].default_value = 0.0


def default_no_light():
    """The factory scene without its point light, lit by its grey world only, and its cube's
    Principled specular layer switched off."""
    _open("default.blend")
    bpy.data.objects.remove(bpy.data.objects["Light"])
    node = bpy.data.materials["Material"].node_tree.nodes["Principled BSDF"]
    node.inputs["Specular IOR Level"].default_value = 0.0


# ---------------------------------------------------------------------------------------
# One material kind at a time: a sphere in the Cornell box


def mat_diffuse():
    _box()
    _sphere(bs.diffuse("Diffuse", (0.8, 0.5, 0.2)))


def mat_mirror():
    _box()
    _sphere(bs.material("Mirror", "ShaderNodeBsdfGlossy", Color=(0.9, 0.9, 0.9, 1.0),
                        Roughness=0.0))


def mat_glass_145():
    _box()
    _sphere(bs.material("Glass", "ShaderNodeBsdfGlass", Color=(1.0, 1.0, 1.0, 1.0),
                        Roughness=0.0, IOR=1.45))


def mat_glass_24():
    _box()
    _sphere(bs.material("Glass", "ShaderNodeBsdfGlass", Color=(1.0, 1.0, 1.0, 1.0),
                        Roughness=0.0, IOR=2.4))


def mat_glass_tinted():
    _box()
    _sphere(bs.material("Glass", "ShaderNodeBsdfGlass", Color=(0.5, 0.9, 0.7, 1.0),
                        Roughness=0.0, IOR=1.45))


def mat_principled_metal():
    _box()
    _sphere(_principled("Gold", **{"Base Color": (1.0, 0.75, 0.35, 1.0), "Metallic": 1.0,
                                   "Roughness": 0.0}))


def mat_principled_glass():
    _box()
    _sphere(_principled("PGlass", **{"Base Color": (0.6, 0.8, 1.0, 1.0), "Roughness": 0.0,
                                     "IOR": 1.5, "Transmission Weight": 1.0}))


def glass_sheet_fresnel():
    """A single glass sheet (IOR 1.45) turned 60 degrees from the view, reflecting a uniform
    emitter (radiance 1) into the camera: each sheet pixel is about F(60 deg) = 0.081 (exact
    Fresnel) and Schlick's 0.064 would be 21 % darker. Black world; the refracted rays leave
    through the open sheet."""
    scene = bs.new_scene()
    bs.camera(scene, "Camera", (0.0, -3.0, 0.75), bs.CBSPHERES_LENS, (64, 48))
    bs.black_world(scene)
    glass = bs.material("Glass", "ShaderNodeBsdfGlass", Color=(1.0, 1.0, 1.0, 1.0),
                        Roughness=0.0, IOR=1.45)
    sheet = _card("Sheet", (-0.3, 0.0, 0.75), (1.4, 1.1), glass)
    # 240 = 60 + 180 degrees: the same plane with its normal toward the camera (a back
    # face would swap the IOR and totally reflect at 60 degrees).
    sheet.rotation_euler = (0.0, 0.0, math.radians(240.0))
    light = bs.material("Panel", "ShaderNodeEmission", Color=(1.0, 1.0, 1.0, 1.0),
                        Strength=1.0)
    panel = _card("Panel", (3.0, 2.0, 0.75), (8.0, 6.0), light)
    panel.rotation_euler = (0.0, 0.0, math.radians(90.0))


def glass_chart_145():
    _glass_chart(1.45)


def glass_chart_24():
    _glass_chart(2.4)


# ---------------------------------------------------------------------------------------
# Emitters


def emitter_direct():
    """Two emitters seen by the camera, one from the front and one from the back (tilted
    away, its back also lighting the floor), in the box without its ceiling light."""
    _box(emitter=False)
    _emitter_quad("FrontEmitter", (-0.45, 0.2, 0.6), 0.35, 4.0)
    _emitter_quad("BackEmitter", (0.45, 0.0, 0.5), 0.35, 4.0,
                  rotation=(math.radians(-60.0), 0.0, math.radians(15.0)))


def emitter_through_glass():
    """An emitter behind a glass sphere, seen through it; the ceiling light stays on."""
    _box()
    _sphere(bs.material("Glass", "ShaderNodeBsdfGlass", Color=(1.0, 1.0, 1.0, 1.0),
                        Roughness=0.0, IOR=1.45), (0.0, -0.2, 0.4), 0.35)
    _emitter_quad("Hidden", (0.0, 0.6, 0.4), 0.3, 5.0)


# ---------------------------------------------------------------------------------------
# Depth of field: every Blender DOF setting the exporter reads


def dof_disk():
    _dof_scene()


def dof_blades():
    """Three blades: turning the aperture by half a blade flips the triangle, the shape
    difference the power test must see (five blades: dof_blades_5)."""
    _dof_scene(aperture_blades=3, aperture_rotation=math.radians(20.0))


def dof_blades_5():
    _dof_scene(aperture_blades=5, aperture_rotation=math.radians(20.0))


def dof_anamorphic():
    _dof_scene(aperture_ratio=2.0)


def dof_vertical_fit():
    _dof_scene(sensor_fit="VERTICAL")


def dof_shift():
    _dof_scene(shift_x=0.12, shift_y=-0.08)


def dof_focus_object():
    """Focus on an off-axis empty: Cycles measures along the view axis (2.6), not the
    Euclidean distance (about 2.73)."""
    _dof_scene()
    target = bpy.data.objects.new("FocusTarget", None)
    target.location = (0.6, -0.4, 0.3)
    bpy.context.scene.collection.objects.link(target)
    bpy.context.scene.camera.data.dof.focus_object = target


# ---------------------------------------------------------------------------------------
# Light objects and world lighting (issue 6): the box without its ceiling emitter, a
# diffuse sphere and a rough Principled sphere, lit by one Blender light each


def _lit_box(kind, name="Lamp", location=(0.0, -0.1, 1.3), rotation=(0.0, 0.0, 0.0), **props):
    """The box without its ceiling emitter, two spheres (diffuse, rough Principled), and one
    light of `kind` with the given datablock properties."""
    _box(emitter=False)
    _sphere(bs.diffuse("Clay", (0.8, 0.6, 0.4)), (-0.45, 0.2, 0.3), 0.3, "Clay")
    _sphere(_principled("Plastic", **{"Base Color": (0.2, 0.4, 0.8, 1.0), "Roughness": 0.35}),
            (0.45, -0.1, 0.3), 0.3, "Plastic")
    light = bpy.data.lights.new(name, kind)
    for key, value in props.items():
        setattr(light, key, value)
    obj = bpy.data.objects.new(name, light)
    obj.location, obj.rotation_euler = location, rotation
    bpy.context.scene.collection.objects.link(obj)
    return obj


def light_point():
    _lit_box("POINT", energy=60.0, shadow_soft_size=0.0)


def light_point_sphere():
    _lit_box("POINT", energy=60.0, shadow_soft_size=0.15, use_soft_falloff=False)


def light_point_soft_coloured():
    _lit_box("POINT", energy=80.0, shadow_soft_size=0.25, use_soft_falloff=True,
             color=(1.0, 0.6, 0.3))


def light_spot():
    _lit_box("SPOT", energy=150.0, shadow_soft_size=0.05, spot_size=math.radians(70.0),
             spot_blend=0.4, rotation=(math.radians(20.0), 0.0, 0.0))


def light_sun():
    """A sun through the box's open front, its angle 0 (sharp shadows)."""
    _lit_box("SUN", energy=3.0, angle=0.0, location=(0.0, -3.0, 2.0),
             rotation=(math.radians(60.0), 0.0, math.radians(-20.0)))


def light_sun_angle():
    _lit_box("SUN", energy=3.0, angle=math.radians(15.0), location=(0.0, -3.0, 2.0),
             rotation=(math.radians(60.0), 0.0, math.radians(-20.0)))


def light_area_square():
    _lit_box("AREA", energy=40.0, shape="SQUARE", size=0.6)


def light_area_rectangle_scaled():
    obj = _lit_box("AREA", energy=40.0, shape="RECTANGLE", size=0.5, size_y=0.25)
    obj.scale = (1.5, 1.0, 1.0)


def light_area_disk_visible():
    """A disk light seen by the camera (object visibility on), tilted toward it."""
    obj = _lit_box("AREA", energy=40.0, shape="DISK", size=0.5,
                   rotation=(math.radians(-35.0), 0.0, 0.0))
    obj.visible_camera = True


def light_area_ellipse_spread():
    _lit_box("AREA", energy=40.0, shape="ELLIPSE", size=0.6, size_y=0.3,
             spread=math.radians(60.0))


def light_through_glass():
    """A point light and an area light seen through and focused by a glass sphere."""
    _lit_box("AREA", energy=30.0, shape="SQUARE", size=0.4)
    _sphere(bs.material("Glass", "ShaderNodeBsdfGlass", Color=(1.0, 1.0, 1.0, 1.0),
                        Roughness=0.0, IOR=1.45), (0.0, -0.45, 0.55), 0.25, "Lens")
    lamp = bpy.data.lights.new("Spark", "POINT")
    lamp.energy, lamp.shadow_soft_size = 10.0, 0.05
    obj = bpy.data.objects.new("Spark", lamp)
    obj.location = (0.0, 0.3, 0.6)
    bpy.context.scene.collection.objects.link(obj)


def _sky_image():
    """A packed 64 x 32 float image: a bright warm patch in a dim blue sky."""
    w, h = 64, 32
    u = (np.arange(w) + 0.5) / w
    v = (np.arange(h) + 0.5) / h
    sky = np.zeros((h, w, 4), np.float32)
    sky[..., 0], sky[..., 1], sky[..., 2], sky[..., 3] = 0.1, 0.15, 0.3 * v[:, None] + 0.05, 1
    patch = np.exp(-(((u[None, :] - 0.3) / 0.06) ** 2 + ((v[:, None] - 0.55) / 0.08) ** 2))
    sky[..., 0] += 20.0 * patch
    sky[..., 1] += 15.0 * patch
    sky[..., 2] += 8.0 * patch
    image = bpy.data.images.new("Sky", w, h, float_buffer=True)
    image.pixels.foreach_set(sky.ravel())
    image.pack()
    return image


def world_environment():
    """The spheres on the box's floor, lit through its open front by an environment map (a
    procedural image: a bright warm patch in a dim blue sky), rotated by a Mapping node."""
    _lit_box("POINT", energy=0.0)
    image = _sky_image()
    world = bpy.context.scene.world
    world.use_nodes = True
    nt = world.node_tree
    background = next(n for n in nt.nodes if n.bl_idname == "ShaderNodeBackground")
    tex = nt.nodes.new("ShaderNodeTexEnvironment")
    tex.image = image
    mapping = nt.nodes.new("ShaderNodeMapping")
    mapping.inputs["Rotation"].default_value = (0.0, 0.0, math.radians(100.0))
    coords = nt.nodes.new("ShaderNodeTexCoord")
    nt.links.new(coords.outputs["Generated"], mapping.inputs["Vector"])
    nt.links.new(mapping.outputs["Vector"], tex.inputs["Vector"])
    nt.links.new(tex.outputs["Color"], background.inputs["Color"])
    background.inputs["Strength"].default_value = 1.0


def _world_stage():
    """A diffuse ball, a mirror ball and a rough Principled ball on a floor, seen from above
    with the horizon in the top of the frame: the world is seen directly, in the mirror
    and as the only light. Returns the world's node tree, emptied but for its output."""
    scene = bs.new_scene()
    coll = scene.collection
    bs.quad("Floor", [(-3, -3, 0), (3, -3, 0), (3, 3, 0), (-3, 3, 0)],
            bs.diffuse("Floor", (0.5, 0.5, 0.5)), coll)
    bs.uv_sphere("Clay", (-0.55, 0.2, 0.3), 0.3, bs.diffuse("Clay", (0.8, 0.6, 0.4)), coll)
    bs.uv_sphere("Mirror", (0.1, 0.35, 0.3), 0.3,
                 bs.material("Mirror", "ShaderNodeBsdfGlossy", Color=(1, 1, 1, 1),
                             Roughness=0.0), coll)
    bs.uv_sphere("Plastic", (0.7, 0.0, 0.25), 0.25,
                 _principled("Plastic", **{"Base Color": (0.2, 0.4, 0.8, 1.0),
                                           "Roughness": 0.35}), coll)
    cam = bs.camera(scene, "Camera", (0.0, -2.6, 1.1), bs.CBSPHERES_LENS, (64, 48))
    look = mathutils.Vector((0.0, 0.0, 0.55)) - cam.location
    cam.rotation_euler = look.to_track_quat("-Z", "Y").to_euler()
    world = bpy.data.worlds.new("Nodes")
    scene.world = world
    world.use_nodes = True
    nt = world.node_tree
    for node in [n for n in nt.nodes if n.bl_idname != "ShaderNodeOutputWorld"]:
        nt.nodes.remove(node)
    return nt


def _sky_and_sun(nt):
    """A Mix Shader of a sky and a ground Background by a Map Range of the direction's
    height (Texture Coordinate Generated, Separate XYZ), plus, through an Add Shader, an
    Emission whose strength is a sharp power of the direction's cosine to a sun-like
    point, tinted by a Color Ramp of it. Returns the Add Shader's output."""
    coords = nt.nodes.new("ShaderNodeTexCoord")
    xyz = nt.nodes.new("ShaderNodeSeparateXYZ")
    nt.links.new(coords.outputs["Generated"], xyz.inputs["Vector"])
    horizon = nt.nodes.new("ShaderNodeMapRange")
    horizon.inputs["From Min"].default_value, horizon.inputs["From Max"].default_value = -0.05, 0.2
    nt.links.new(xyz.outputs["Z"], horizon.inputs["Value"])
    sky, ground = (nt.nodes.new("ShaderNodeBackground") for _ in range(2))
    sky.inputs["Color"].default_value = (0.25, 0.45, 0.9, 1.0)
    ground.inputs["Color"].default_value = (0.35, 0.25, 0.15, 1.0)
    ground.inputs["Strength"].default_value = 0.6
    mix = nt.nodes.new("ShaderNodeMixShader")
    nt.links.new(horizon.outputs["Result"], mix.inputs["Fac"])
    nt.links.new(ground.outputs["Background"], mix.inputs[1])
    nt.links.new(sky.outputs["Background"], mix.inputs[2])
    toward = nt.nodes.new("ShaderNodeVectorMath")
    toward.operation = "DOT_PRODUCT"
    toward.inputs[1].default_value = mathutils.Vector((-0.5, 0.6, 0.62)).normalized()
    nt.links.new(coords.outputs["Generated"], toward.inputs[0])
    sharp = nt.nodes.new("ShaderNodeMath")
    sharp.operation, sharp.use_clamp = "POWER", True
    sharp.inputs[1].default_value = 60.0
    nt.links.new(toward.outputs["Value"], sharp.inputs[0])
    strength = nt.nodes.new("ShaderNodeMath")
    strength.operation = "MULTIPLY"
    strength.inputs[1].default_value = 40.0
    nt.links.new(sharp.outputs["Value"], strength.inputs[0])
    ramp = nt.nodes.new("ShaderNodeValToRGB")
    ramp.color_ramp.elements[0].color = (1.0, 0.5, 0.2, 1.0)
    ramp.color_ramp.elements[1].color = (1.0, 0.95, 0.8, 1.0)
    nt.links.new(sharp.outputs["Value"], ramp.inputs["Fac"])
    sun = nt.nodes.new("ShaderNodeEmission")
    nt.links.new(ramp.outputs["Color"], sun.inputs["Color"])
    nt.links.new(strength.outputs["Value"], sun.inputs["Strength"])
    add = nt.nodes.new("ShaderNodeAddShader")
    nt.links.new(mix.outputs["Shader"], add.inputs[0])
    nt.links.new(sun.outputs["Emission"], add.inputs[1])
    return add.outputs["Shader"]


def world_nodes_sky():
    """A world node tree baked into a map (issue 14): _sky_and_sun."""
    nt = _world_stage()
    out = next(n for n in nt.nodes if n.bl_idname == "ShaderNodeOutputWorld")
    nt.links.new(_sky_and_sun(nt), out.inputs["Surface"])


def world_camera_backdrop():
    """The Light Path trick (issue 14): camera rays see a plain grey backdrop (a Mix Shader
    by Is Camera Ray), every other ray _sky_and_sun: it lights the balls, the mirror ball
    reflects it, the camera does not see it past them."""
    nt = _world_stage()
    out = next(n for n in nt.nodes if n.bl_idname == "ShaderNodeOutputWorld")
    backdrop = nt.nodes.new("ShaderNodeBackground")
    backdrop.inputs["Color"].default_value = (0.6, 0.6, 0.6, 1.0)
    path, mix = nt.nodes.new("ShaderNodeLightPath"), nt.nodes.new("ShaderNodeMixShader")
    nt.links.new(path.outputs["Is Camera Ray"], mix.inputs["Fac"])
    nt.links.new(_sky_and_sun(nt), mix.inputs[1])
    nt.links.new(backdrop.outputs["Background"], mix.inputs[2])
    nt.links.new(mix.outputs["Shader"], out.inputs["Surface"])


def _gradient(nt, horizon, sky_rgb, ground_rgb, strength=1.0):
    """A Mix Shader of a ground and a sky Background by `horizon` (a Map Range's Result, 0
    below the horizon): its Shader output."""
    sky, ground = (nt.nodes.new("ShaderNodeBackground") for _ in range(2))
    sky.inputs["Color"].default_value = tuple(sky_rgb) + (1.0,)
    ground.inputs["Color"].default_value = tuple(ground_rgb) + (1.0,)
    sky.inputs["Strength"].default_value = ground.inputs["Strength"].default_value = strength
    mix = nt.nodes.new("ShaderNodeMixShader")
    nt.links.new(horizon.outputs["Result"], mix.inputs["Fac"])
    nt.links.new(ground.outputs["Background"], mix.inputs[1])
    nt.links.new(sky.outputs["Background"], mix.inputs[2])
    return mix.outputs["Shader"]


def world_sky_texture():
    """Blender 5's default sky (issue 14): a Sky Texture of type Multiple Scattering, its
    sun 25 degrees up behind the camera to the right, lighting the stage alone at strength
    0.05. The sky (Cycles' precomputed texture, baked into the map) is seen above the
    horizon and in the metal ball; its sun disc (a sun light of the disc's power here, the
    disc itself in Cycles) casts the balls' shadows. The metal ball is slightly rough: a
    smooth one throws the 0.5-degree sun onto the floor as a caustic that Cycles' paths
    find only by chance (at 2 x 256 samples its floor there was 1-3 % darker than
    Specula's light tracing makes it)."""
    _sky_stage("MULTIPLE_SCATTERING")


def world_sky_single_scattering():
    """The Sky Texture's Single Scattering (Blender 2.90-4.5's Nishita sky, which older
    files open as): a low sun (12 degrees) seen from 500 m through a denser, hazier
    atmosphere, a larger (2 degrees), dimmer (0.7) disc, below the horizon the horizon's
    colour fading out; otherwise world_sky_texture's stage."""
    sky = _sky_stage("SINGLE_SCATTERING", elevation=12.0, rotation=150.0)
    sky.altitude, sky.air_density, sky.aerosol_density = 500.0, 1.5, 2.0
    sky.sun_size, sky.sun_intensity = math.radians(2.0), 0.7


def world_sky_preetham():
    """The Sky Texture's Preetham type (the analytic daylight of older files): turbidity 3,
    the sun 40 degrees up to the back left, at strength 1 (the sky is about 0.3 there); no
    disc."""
    sky = _sky_stage("PREETHAM", strength=1.0)
    sky.turbidity = 3.0
    sky.sun_direction = mathutils.Vector((-0.55, 0.45, 0.64)).normalized()


def _sky_stage(sky_type, elevation=25.0, rotation=120.0, strength=0.05):
    """_world_stage lit by a Sky Texture of `sky_type` alone at `strength`, its metal ball
    slightly rough (world_sky_texture). Returns the Sky Texture node."""
    nt = _world_stage()
    metal = next(n for n in bpy.data.objects["Mirror"].active_material.node_tree.nodes
                 if n.bl_idname in ("ShaderNodeBsdfGlossy", "ShaderNodeBsdfAnisotropic"))
    metal.inputs["Roughness"].default_value = 0.2
    out = next(n for n in nt.nodes if n.bl_idname == "ShaderNodeOutputWorld")
    sky, background = nt.nodes.new("ShaderNodeTexSky"), nt.nodes.new("ShaderNodeBackground")
    sky.sky_type = sky_type
    sky.sun_elevation, sky.sun_rotation = math.radians(elevation), math.radians(rotation)
    background.inputs["Strength"].default_value = strength
    nt.links.new(sky.outputs["Color"], background.inputs["Color"])
    nt.links.new(background.outputs["Background"], out.inputs["Surface"])
    return sky


def world_ray_kinds():
    """A world that tells kinds of ray apart by the Light Path's Is Glossy Ray and Is
    Diffuse Ray (issue 14): light samples and camera rays see a blue sky over a brown
    ground, glossy rays (the mirror ball's, a glass ball's, the plastic's highlights) a warm
    one, diffuse bounces a green one. Light samples and bounces are weighed by MIS in both
    engines, each by its own map's pdf, which differ little on a world this smooth (no
    sun)."""
    nt = _world_stage()
    bs.uv_sphere("Glass", (-0.15, -0.4, 0.18), 0.18,
                 bs.material("Glass", "ShaderNodeBsdfGlass", Color=(1, 1, 1, 1), Roughness=0.0,
                             IOR=1.45), bpy.context.scene.collection)
    out = next(n for n in nt.nodes if n.bl_idname == "ShaderNodeOutputWorld")
    coords, xyz = nt.nodes.new("ShaderNodeTexCoord"), nt.nodes.new("ShaderNodeSeparateXYZ")
    nt.links.new(coords.outputs["Generated"], xyz.inputs["Vector"])
    horizon = nt.nodes.new("ShaderNodeMapRange")
    horizon.inputs["From Min"].default_value, horizon.inputs["From Max"].default_value = -0.05, 0.4
    nt.links.new(xyz.outputs["Z"], horizon.inputs["Value"])
    path = nt.nodes.new("ShaderNodeLightPath")
    diffuse, glossy = nt.nodes.new("ShaderNodeMixShader"), nt.nodes.new("ShaderNodeMixShader")
    nt.links.new(path.outputs["Is Diffuse Ray"], diffuse.inputs["Fac"])
    nt.links.new(_gradient(nt, horizon, (0.25, 0.45, 0.9), (0.35, 0.25, 0.15)),
                 diffuse.inputs[1])
    nt.links.new(_gradient(nt, horizon, (0.2, 0.9, 0.3), (0.1, 0.3, 0.1), 1.5),
                 diffuse.inputs[2])
    nt.links.new(path.outputs["Is Glossy Ray"], glossy.inputs["Fac"])
    nt.links.new(diffuse.outputs["Shader"], glossy.inputs[1])
    nt.links.new(_gradient(nt, horizon, (1.0, 0.6, 0.2), (0.5, 0.1, 0.3), 2.0),
                 glossy.inputs[2])
    nt.links.new(glossy.outputs["Shader"], out.inputs["Surface"])


def world_environment_mapped():
    """An Environment Texture the core's map cannot look up directly, so baked (issue 14):
    world_environment's procedural sky through a Mapping that rotates, moves and scales
    the direction, its Strength from a Math node, its colour through a Hue/Saturation."""
    nt = _world_stage()
    out = next(n for n in nt.nodes if n.bl_idname == "ShaderNodeOutputWorld")
    image = _sky_image()
    tex = nt.nodes.new("ShaderNodeTexEnvironment")
    tex.image = image
    mapping = nt.nodes.new("ShaderNodeMapping")
    mapping.inputs["Location"].default_value = (0.0, 0.0, -0.15)
    mapping.inputs["Rotation"].default_value = (0.0, 0.0, math.radians(60.0))
    mapping.inputs["Scale"].default_value = (1.0, 1.0, 1.5)
    coords = nt.nodes.new("ShaderNodeTexCoord")
    nt.links.new(coords.outputs["Generated"], mapping.inputs["Vector"])
    nt.links.new(mapping.outputs["Vector"], tex.inputs["Vector"])
    hue = nt.nodes.new("ShaderNodeHueSaturation")
    hue.inputs["Hue"].default_value = 0.45
    nt.links.new(tex.outputs["Color"], hue.inputs["Color"])
    background = nt.nodes.new("ShaderNodeBackground")
    nt.links.new(hue.outputs["Color"], background.inputs["Color"])
    strength = nt.nodes.new("ShaderNodeMath")
    strength.operation = "MULTIPLY"
    strength.inputs[0].default_value, strength.inputs[1].default_value = 0.5, 3.0
    nt.links.new(strength.outputs["Value"], background.inputs["Strength"])
    nt.links.new(background.outputs["Background"], out.inputs["Surface"])


# ---------------------------------------------------------------------------------------
# The registry


# ---------------------------------------------------------------------------------------
# Issue 12's three mismatches, each swept over its parameters: spot lights of radius > 0
# (the cone's smoothstep along each sampled ray), rough Glossy colours (the multiscatter
# compensation with the colour as its Fresnel) and the shadow terminator geometry offset.


def _spot_room(location=(0.0, 0.0, 1.45), rotation=(0.0, 0.0, 0.0), **props):
    """Issue 12's user scene: the box without its ceiling emitter, diffuse walls and two
    diffuse balls, lit only by one spot light (pointing straight down by default)."""
    _box(emitter=False)
    _sphere(bs.diffuse("Clay", (0.8, 0.6, 0.4)), (-0.45, 0.2, 0.3), 0.3, "Clay")
    _sphere(bs.diffuse("Chalk", (0.7, 0.7, 0.7)), (0.45, -0.1, 0.3), 0.3, "Chalk")
    light = bpy.data.lights.new("Spot", "SPOT")
    for key, value in props.items():
        setattr(light, key, value)
    obj = bpy.data.objects.new("Spot", light)
    obj.location, obj.rotation_euler = location, rotation
    bpy.context.scene.collection.objects.link(obj)
    return obj


def spot_user():
    """Cone 50 degrees, blend 0.3, radius 0.05, soft falloff off, 150 W, straight down: the
    scene that disagreed with z 92 (the blend ring on the floor)."""
    _spot_room(energy=150.0, spot_size=math.radians(50.0), spot_blend=0.3,
               shadow_soft_size=0.05, use_soft_falloff=False)


def spot_small_cone_soft():
    """A narrow cone with a hard edge from a large soft-falloff disk."""
    _spot_room(energy=150.0, spot_size=math.radians(12.0), spot_blend=0.0,
               shadow_soft_size=0.2, use_soft_falloff=True,
               rotation=(math.radians(25.0), 0.0, 0.0))


def spot_wide_blend_one():
    """Cone 180 degrees with blend 1 and a big sphere."""
    _spot_room(energy=150.0, spot_size=math.radians(180.0), spot_blend=1.0,
               shadow_soft_size=0.3, use_soft_falloff=False, location=(0.0, 0.0, 1.2))


def spot_radius_zero():
    _spot_room(energy=150.0, spot_size=math.radians(80.0), spot_blend=0.6,
               shadow_soft_size=0.0, rotation=(math.radians(-20.0), 0.0, 0.0))


def spot_scaled():
    """Non-uniform object scale squashes the cone into an ellipse (Cycles' scaled axes)."""
    obj = _spot_room(energy=150.0, spot_size=math.radians(70.0), spot_blend=0.5,
                     shadow_soft_size=0.1, use_soft_falloff=True)
    obj.scale = (2.0, 0.6, 1.0)


def spot_seen_glass_mirror():
    """The spot lamp itself seen by the camera, through a glass ball and in a mirror ball;
    it points at the camera, tilted, so its cone edge crosses the view."""
    _box(emitter=False)
    _sphere(bs.material("Glass", "ShaderNodeBsdfGlass", Color=(1.0, 1.0, 1.0, 1.0),
                        Roughness=0.0, IOR=1.45), (-0.35, -0.5, 0.5), 0.22, "Lens")
    _sphere(bs.material("Mirror", "ShaderNodeBsdfGlossy", Color=(0.9, 0.9, 0.9, 1.0),
                        Roughness=0.0), (0.45, 0.1, 0.3), 0.3, "Mirror")
    light = bpy.data.lights.new("Spot", "SPOT")
    light.energy, light.spot_size, light.spot_blend = 300.0, math.radians(60.0), 0.5
    light.shadow_soft_size, light.use_soft_falloff = 0.15, False
    obj = bpy.data.objects.new("Spot", light)
    obj.location = (-0.2, 0.6, 0.8)
    obj.rotation_euler = (math.radians(-100.0), 0.0, math.radians(-15.0))
    obj.visible_camera = True
    bpy.context.scene.collection.objects.link(obj)


def spot_through_ceiling():
    """A spot light whose sphere pokes through the ceiling (fuzz seed 19, shrunk): ceiling
    points inside the sphere are lit with no cone, and hits are one-sided (Cycles' spot.h)."""
    obj = _spot_room(energy=198.0, spot_size=1.2672, spot_blend=0.626, shadow_soft_size=0.165,
                     use_soft_falloff=False, location=(-0.2, 0.3, 1.355))
    obj.scale = (1.265, 1.076, 0.956)


def _glossy_balls(balls):
    """Rough Glossy spheres of the given (colour, roughness) on the box's floor under its
    ceiling emitter."""
    _box()
    xs = np.linspace(-0.6, 0.6, len(balls))
    for i, ((r, g, b), rough) in enumerate(balls):
        mat = bs.material(f"Glossy{i}", "ShaderNodeBsdfGlossy", Color=(r, g, b, 1.0),
                          Roughness=rough)
        _sphere(mat, (float(xs[i]), 0.0, 0.27), 0.27, f"Ball{i}")


def glossy_colours():
    """Issue 12's sphere (0.74, 0.77, 0.62) at roughness 0.72, grey 0.5 at 0.8 and a
    saturated red at 0.45."""
    _glossy_balls((((0.74, 0.77, 0.62), 0.72), ((0.5, 0.5, 0.5), 0.8),
                   ((0.9, 0.15, 0.1), 0.45)))


def glossy_roughness():
    """One dark blue colour at roughness 0.2, 0.5 and 1.0."""
    _glossy_balls((((0.2, 0.3, 0.6), 0.2), ((0.2, 0.3, 0.6), 0.5), ((0.2, 0.3, 0.6), 1.0)))


def _balls(materials):
    """Spheres of the given materials on the floor of the box (built first, as it clears the
    file) under its ceiling emitter, seen against the red, grey and blue walls."""
    xs = np.linspace(-0.6, 0.6, len(materials))
    for i, mat in enumerate(materials):
        _sphere(mat, (float(xs[i]), 0.0, 0.27), 0.27, f"Ball{i}")


def _glass(name, colour, roughness, distribution="MULTI_GGX", ior=1.45):
    mat = bs.material(name, "ShaderNodeBsdfGlass", Color=colour + (1.0,), Roughness=roughness,
                      IOR=ior)
    next(n for n in mat.node_tree.nodes if n.bl_idname == "ShaderNodeBsdfGlass").distribution = \
        distribution
    return mat


def rough_glass_roughness():
    """Clear Glass BSDF (Multiscatter GGX, IOR 1.45) at roughness 0.15, 0.4 and 0.8."""
    _box()
    _balls([_glass(f"Frosted{i}", (1.0, 1.0, 1.0), r)
                        for i, r in enumerate((0.15, 0.4, 0.8))])


def rough_glass_tinted():
    """A tinted Multiscatter GGX glass, a plain GGX one (no energy compensation) and a
    very rough Principled glass (sqrt(base) transmission tint, which also darkens what
    the energy compensation gives back; IOR 1.5)."""
    _box()
    _balls([
        _glass("Tinted", (0.5, 0.9, 0.7), 0.5),
        _glass("PlainGGX", (1.0, 1.0, 1.0), 0.5, "GGX"),
        _principled("PFrosted", **{"Base Color": (0.3, 0.8, 1.0, 1.0), "Roughness": 0.8,
                                   "IOR": 1.5, "Transmission Weight": 1.0})])


def rough_metal():
    """Principled metallic spheres (F82 with a white tint: Schlick on the base colour):
    gold at roughness 0.2, copper at 0.5 and a plain-GGX grey at 0.9."""
    _box()
    grey = _principled("Grey", **{"Base Color": (0.6, 0.6, 0.6, 1.0), "Metallic": 1.0,
                                  "Roughness": 0.9})
    next(n for n in grey.node_tree.nodes
         if n.bl_idname == "ShaderNodeBsdfPrincipled").distribution = "GGX"
    _balls([
        _principled("Gold", **{"Base Color": (1.0, 0.75, 0.35, 1.0), "Metallic": 1.0,
                               "Roughness": 0.2}),
        _principled("Copper", **{"Base Color": (0.95, 0.64, 0.54, 1.0), "Metallic": 1.0,
                                 "Roughness": 0.5}), grey])


def specular_tint():
    """The Principled BSDF's Specular Tint on metal (Cycles' F82-tint Fresnel; issue 14,
    point 1): a smooth silver ball tinted blue toward grazing, a rough (0.3) gold tinted
    red and a rough (0.6) copper whose tint is above 1 in green (taken as 1)."""
    _box()
    _balls([
        _principled("TintedSilver", **{"Base Color": (0.9, 0.9, 0.9, 1.0), "Metallic": 1.0,
                                       "Roughness": 0.0, "Specular Tint": (0.2, 0.5, 1.0, 1.0)}),
        _principled("TintedGold", **{"Base Color": (1.0, 0.75, 0.35, 1.0), "Metallic": 1.0,
                                     "Roughness": 0.3, "Specular Tint": (1.0, 0.3, 0.2, 1.0)}),
        _principled("TintedCopper", **{"Base Color": (0.95, 0.64, 0.54, 1.0), "Metallic": 1.0,
                                       "Roughness": 0.6,
                                       "Specular Tint": (0.3, 1.5, 0.6, 1.0)})])


def specular_tint_dielectric():
    """The Principled BSDF's Specular Tint on its dielectric and glass Fresnel (Cycles'
    generalized Schlick: F0 x tint rising to 1; issue 14, point 1): a dark ball with an
    orange-tinted coat of reflection (roughness 0.15), a green one tinted blue past 1
    (roughness 0.4; F0 x tint is at most 1), smooth glass (IOR 1.8) tinted toward blue and
    rough (0.3) glass (IOR 1.6) tinted toward red, both strongly: their reflections are a
    small part of what the camera sees through them."""
    _box()
    balls = [
        _principled("OrangeSheen", **{"Base Color": (0.05, 0.05, 0.05, 1.0), "Roughness": 0.15,
                                      "Specular Tint": (1.0, 0.3, 0.1, 1.0)}),
        _principled("BlueSheen", **{"Base Color": (0.2, 0.5, 0.2, 1.0), "Roughness": 0.4,
                                    "Specular Tint": (0.2, 0.4, 1.8, 1.0)}),
        _principled("TintedGlass", **{"Base Color": (1.0, 1.0, 1.0, 1.0), "Roughness": 0.0,
                                      "Transmission Weight": 1.0, "IOR": 1.8,
                                      "Specular Tint": (0.1, 1.0, 4.0, 1.0)}),
        _principled("TintedFrost", **{"Base Color": (0.9, 0.9, 1.0, 1.0), "Roughness": 0.3,
                                      "Transmission Weight": 1.0, "IOR": 1.6,
                                      "Specular Tint": (5.0, 0.5, 0.1, 1.0)})]
    for i, mat in enumerate(balls):
        _sphere(mat, (-0.63 + 0.42 * i, 0.0, 0.2), 0.2, f"Ball{i}")


def _checker_on(mat, socket, colour1, colour2, scale=4.0):
    """`mat` whose shader's input `socket` is a Checker Texture on the UV map: colour1 and
    colour2 (RGBA) in squares."""
    tree = mat.node_tree
    node = next(n for n in tree.nodes if socket in n.inputs)
    checker = tree.nodes.new("ShaderNodeTexChecker")
    checker.inputs["Color1"].default_value = colour1
    checker.inputs["Color2"].default_value = colour2
    checker.inputs["Scale"].default_value = scale
    tree.links.new(tree.nodes.new("ShaderNodeTexCoord").outputs["UV"], checker.inputs["Vector"])
    tree.links.new(checker.outputs["Color"], node.inputs[socket])
    return mat


def textured_tints():
    """Tints and sheen that vary over the surface (issue 14, point 1: every Principled input
    linkable), each from a Checker on the UV map: a velvet whose Sheen Tint and Sheen
    Roughness vary, a Sheen BSDF whose Color and Roughness vary, a coat whose Coat Tint
    varies (red and green squares), and a partly metallic ball whose Specular Tint varies
    (its metal and dielectric lobes both; large squares: the tints' effect is small)."""
    _box()
    velvet = _principled("Velvet", **{"Base Color": (0.05, 0.02, 0.08, 1.0),
                                      "Roughness": 0.7, "Sheen Weight": 1.0})
    _checker_on(velvet, "Sheen Tint", (1.0, 0.6, 0.2, 1.0), (0.3, 0.6, 1.0, 1.0))
    _checker_on(velvet, "Sheen Roughness", (0.15, 0.15, 0.15, 1.0), (0.9, 0.9, 0.9, 1.0), 2.0)
    dust = bs.material("Dust", "ShaderNodeBsdfSheen")
    _checker_on(dust, "Color", (0.9, 0.9, 0.2, 1.0), (0.2, 0.9, 0.9, 1.0))
    _checker_on(dust, "Roughness", (0.2, 0.2, 0.2, 1.0), (0.8, 0.8, 0.8, 1.0), 2.0)
    lacquer = _principled("Lacquer", **{"Base Color": (0.8, 0.8, 0.8, 1.0), "Roughness": 0.5,
                                        "Coat Weight": 1.0, "Coat Roughness": 0.1})
    _checker_on(lacquer, "Coat Tint", (0.9, 0.2, 0.2, 1.0), (0.2, 0.9, 0.2, 1.0), 1.5)
    steel = _principled("Steel", **{"Base Color": (0.7, 0.7, 0.7, 1.0), "Roughness": 0.2,
                                    "Metallic": 0.6})
    _checker_on(steel, "Specular Tint", (1.0, 0.2, 0.1, 1.0), (0.1, 0.4, 3.0, 1.0), 1.5)
    for i, mat in enumerate((velvet, dust, lacquer, steel)):
        obj = bpy.data.objects.new(f"Ball{i}", _uv_sphere_mesh(f"Ball{i}", 0.2))
        obj.location = (-0.63 + 0.42 * i, 0.0, 0.2)
        obj.data.materials.append(mat)
        bpy.context.scene.collection.objects.link(obj)


def emission_under_layers():
    """A Principled BSDF's emission dimmed by its coat and sheen at the view (Cycles:
    "emission, attenuated by sheen and coat"; issue 14, point 1): glowing balls, the only
    lights of the box, under a tinted coat, under a sheen, and under both at Alpha 0.7:
    darker rims where the coat reflects more and the sheen takes more, seen by the camera
    and by next-event estimation from the floor and walls they light."""
    _box(emitter=False)
    glow = {"Base Color": (0.1, 0.1, 0.1, 1.0), "Emission Color": (1.0, 0.6, 0.3, 1.0),
            "Emission Strength": 6.0}
    balls = [
        _principled("Coated", **glow, **{"Coat Weight": 1.0, "Coat Roughness": 0.1,
                                         "Coat IOR": 1.8, "Coat Tint": (0.4, 0.8, 1.0, 1.0)}),
        _principled("Sheened", **glow, **{"Sheen Weight": 1.0, "Sheen Roughness": 0.3,
                                          "Sheen Tint": (0.8, 0.8, 1.0, 1.0)}),
        _principled("Both", **glow, **{"Coat Weight": 0.8, "Coat Roughness": 0.3,
                                       "Sheen Weight": 0.7, "Sheen Roughness": 0.6,
                                       "Alpha": 0.7})]
    _balls(balls)


def _checkered(mat, socket, scale, colour1, colour2):
    """`mat` with its Principled BSDF's input `socket` from a Checker Texture of `scale` on
    Generated coordinates."""
    tree = mat.node_tree
    checker = tree.nodes.new("ShaderNodeTexChecker")
    checker.inputs["Scale"].default_value = scale
    checker.inputs["Color1"].default_value = colour1
    checker.inputs["Color2"].default_value = colour2
    tree.links.new(tree.nodes.new("ShaderNodeTexCoord").outputs["Generated"],
                   checker.inputs["Vector"])
    tree.links.new(checker.outputs["Color"], next(
        n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled").inputs[socket])
    return mat


def emission_under_alpha():
    """A Principled BSDF's textured emission under its Alpha (issue 14, point 1; Cycles
    weighs every closure of the node by alpha, its emission too): glowing balls, the only
    lights of the box. A checkered glow at Alpha 0.6 under a tinted coat, over fractional
    Metallic and Transmission; a checkered glow under a checkered Alpha and a sheen; a
    plain glow under a checkered Alpha and a sheen; and a card on the back wall, a Mix
    Shader of a checkered glow under Alpha and a Transparent BSDF."""
    _box(emitter=False)
    orange, blue = (1.0, 0.5, 0.1, 1.0), (0.1, 0.3, 1.0, 1.0)
    base = {"Base Color": (0.2, 0.2, 0.2, 1.0), "Emission Strength": 1.2}
    veiled = _checkered(_principled("Veiled", **base, **{
        "Metallic": 0.3, "Transmission Weight": 0.5, "Alpha": 0.6, "Coat Weight": 0.8,
        "Coat Roughness": 0.2, "Coat IOR": 1.6, "Coat Tint": (0.6, 0.9, 1.0, 1.0)}),
        "Emission Color", 4.0, orange, blue)
    lace = _checkered(_principled("Lace", **base, **{"Sheen Weight": 0.7,
                                                     "Sheen Roughness": 0.4}),
                      "Emission Color", 4.0, orange, blue)
    lace = _checkered(lace, "Alpha", 3.0, (1.0, 1.0, 1.0, 1.0), (0.25, 0.25, 0.25, 1.0))
    # (Not coated: with a coat, the right wall beside it read 1.4 % bright at 4096
    # samples, |z| 5.3, though the ball alone agrees; see the README's known differences.)
    masked = _checkered(_principled("Masked", **base, **{
        "Emission Color": (1.0, 0.7, 0.4, 1.0), "Sheen Weight": 0.5}),
        "Alpha", 3.0, (1.0, 1.0, 1.0, 1.0), (0.3, 0.3, 0.3, 1.0))
    _balls([veiled, lace, masked])
    # On the back wall, a Mix Shader (0.35) of a Principled's checkered glow at Alpha 0.8
    # and a Transparent BSDF (an alpha cut-out the older way). (Not coated: a coated
    # glowing card renders 1-2 % dark at its edges at 4096 samples, with or without a
    # texture or a mix; see the README's known differences.)
    card = _checkered(_principled("GlowCard", **{**base, "Emission Strength": 2.0},
                                  Alpha=0.8), "Emission Color", 5.0, orange, blue)
    tree = card.node_tree
    out = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial")
    glow = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled")
    mix = tree.nodes.new("ShaderNodeMixShader")
    mix.inputs["Fac"].default_value = 0.35
    tree.links.new(glow.outputs[0], mix.inputs[1])
    tree.links.new(tree.nodes.new("ShaderNodeBsdfTransparent").outputs[0], mix.inputs[2])
    tree.links.new(mix.outputs[0], out.inputs["Surface"])
    _card("GlowCard", (0.0, 0.9, 0.95), (0.9, 0.5), card)


def _with_volume(mat, shader, **inputs):
    """`mat` with a `shader` volume node on its Material Output's Volume."""
    tree = mat.node_tree
    out = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial")
    vol = tree.nodes.new(shader)
    for key, value in inputs.items():
        vol.inputs[key].default_value = value
    tree.links.new(vol.outputs[0], out.inputs["Volume"])
    return mat


def coloured_glass():
    """Glass filled with absorbing media (issue 14, point 3): a Glass BSDF over Volume
    Absorption, a Principled glass over Volume Absorption (what the glTF importer makes of
    KHR_materials_volume) and a rough glass over an absorption-only Principled Volume."""
    _box()
    _balls([
        _with_volume(_glass("Amber", (1.0, 1.0, 1.0), 0.0), "ShaderNodeVolumeAbsorption",
                     Color=(0.8, 0.5, 0.2, 1.0), Density=2.0),
        _with_volume(_principled("Bottle", **{"Base Color": (1.0, 1.0, 1.0, 1.0),
                                              "Roughness": 0.0, "IOR": 1.5,
                                              "Transmission Weight": 1.0}),
                     "ShaderNodeVolumeAbsorption", Color=(0.3, 0.8, 0.5, 1.0), Density=3.0),
        _with_volume(_glass("Frosted", (1.0, 1.0, 1.0), 0.3), "ShaderNodeVolumePrincipled",
                     Color=(0.0, 0.0, 0.0, 1.0), Density=2.0,
                     **{"Absorption Color": (0.2, 0.4, 0.9, 1.0)})])


def _volume_only(mat):
    """`mat` with its Surface shader moved to the Material Output's Volume (nothing on
    Surface: a volume's invisible boundary)."""
    tree = mat.node_tree
    out = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial")
    link = out.inputs["Surface"].links[0]
    node = link.from_node
    tree.links.remove(link)
    tree.links.new(node.outputs[0], out.inputs["Volume"])
    return mat


def _fog(name, scatter, absorb):
    """A Volume-only material: Volume Scatter + Volume Absorption (the usual fog), each
    given as {input: value}."""
    mat = _volume_only(bs.material(name, "ShaderNodeAddShader"))
    tree = mat.node_tree
    add = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeAddShader")
    for sock, (kind, inputs) in zip(add.inputs, (("ShaderNodeVolumeScatter", scatter),
                                                 ("ShaderNodeVolumeAbsorption", absorb))):
        node = tree.nodes.new(kind)
        for key, value in inputs.items():
            node.inputs[key].default_value = value
        tree.links.new(node.outputs[0], sock)
    return mat


def scattering_media():
    """Scattering media (issue 14, point 3): milky glass (a Glass BSDF over a Principled
    Volume scattering forward), a Volume-only ball of orange fog scattering backward (Volume
    Scatter + Volume Absorption) and a Volume-only ball of thin glowing smoke (a Principled
    Volume's emission), under the ceiling emitter."""
    _box()
    _balls([
        _with_volume(_glass("Milky", (1.0, 1.0, 1.0), 0.0), "ShaderNodeVolumePrincipled",
                     Color=(0.9, 0.9, 0.9, 1.0), Density=3.0, Anisotropy=0.5),
        _fog("Orange", {"Color": (0.9, 0.5, 0.2, 1.0), "Density": 4.0, "Anisotropy": -0.3},
             {"Color": (0.5, 0.8, 0.9, 1.0), "Density": 1.0}),
        _volume_only(bs.material("Glow", "ShaderNodeVolumePrincipled",
                                 Color=(0.6, 0.6, 0.6, 1.0), Density=1.0,
                                 **{"Emission Strength": 3.0,
                                    "Emission Color": (1.0, 0.4, 0.1, 1.0)}))])


def fog_point_light():
    """A Volume-only cube of fog (Volume Scatter, forward) filling most of the box, with a
    point light of radius 0.1 and a clay ball inside it: light reaches the walls outside
    the fog through its boundary (shadow rays cross it), and scattered rays hit the
    light inside the fog."""
    scene = _box(emitter=False)
    _cube("Fog", (0.0, 0.0, 0.66), (1.6, 1.6, 1.28), _volume_only(bs.material(
        "Fog", "ShaderNodeVolumeScatter", Color=(0.8, 0.8, 0.8, 1.0), Density=0.6,
        Anisotropy=0.4)))
    _sphere(bs.diffuse("Clay", (0.8, 0.6, 0.4)), (-0.35, 0.1, 0.3), 0.3, "Clay")
    light = bpy.data.lights.new("Lamp", "POINT")
    light.energy, light.shadow_soft_size = 30.0, 0.1
    obj = bpy.data.objects.new("Lamp", light)
    obj.location = (0.25, 0.0, 0.9)
    scene.collection.objects.link(obj)


def camera_in_fog():
    """The camera inside a volume (issue 14, point 3; Cycles' volume_stack_init): a
    Volume-only cube of thin fog (Volume Scatter forward + Volume Absorption) enclosing the
    box, the camera and a clay ball, lit by the ceiling emitter. Camera paths start in the
    fog; leaving its cube they leave it."""
    _box()
    _cube("Fog", (0.0, -1.0, 0.75), (2.6, 4.4, 2.0), _fog(
        "Fog", {"Color": (0.8, 0.8, 0.8, 1.0), "Density": 0.25, "Anisotropy": 0.3},
        {"Color": (0.6, 0.7, 0.9, 1.0), "Density": 0.1}))
    _sphere(bs.diffuse("Clay", (0.8, 0.6, 0.4)), (0.2, 0.1, 0.3), 0.3, "Clay")


def world_fog():
    """A world Volume (issue 14, point 3): homogeneous fog filling all space (Volume Scatter
    backward + bluish Volume Absorption on the World Output's Volume), the box lit by its
    ceiling emitter and a point light; every path starts in the world's volume, the black
    background stays black and the light dims with distance."""
    scene = _box()
    tree = scene.world.node_tree
    out = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputWorld")
    add = tree.nodes.new("ShaderNodeAddShader")
    scatter = tree.nodes.new("ShaderNodeVolumeScatter")
    scatter.inputs["Density"].default_value, scatter.inputs["Anisotropy"].default_value = \
        0.3, -0.2
    absorb = tree.nodes.new("ShaderNodeVolumeAbsorption")
    absorb.inputs["Color"].default_value = (0.7, 0.8, 0.95, 1.0)
    absorb.inputs["Density"].default_value = 0.15
    tree.links.new(scatter.outputs[0], add.inputs[0])
    tree.links.new(absorb.outputs[0], add.inputs[1])
    tree.links.new(add.outputs[0], out.inputs["Volume"])
    _sphere(bs.diffuse("Clay", (0.8, 0.6, 0.4)), (-0.3, 0.1, 0.3), 0.3, "Clay")
    light = bpy.data.lights.new("Lamp", "POINT")
    light.energy, light.shadow_soft_size = 20.0, 0.1
    obj = bpy.data.objects.new("Lamp", light)
    obj.location = (0.4, -0.3, 0.8)
    scene.collection.objects.link(obj)


def _mix_of(name, node, first, second, fac=None):
    """A material whose surface is a `node` (Mix or Add Shader) of two shader nodes, each
    given as (bl_idname, {input: value})."""
    mat = bs.material(name, node)
    tree = mat.node_tree
    mix = next(n for n in tree.nodes if n.bl_idname == node)
    if fac is not None:
        mix.inputs["Fac"].default_value = fac
    shader_inputs = [s for s in mix.inputs if s.type == "SHADER"]
    for sock, (kind, inputs) in zip(shader_inputs, (first, second)):
        sub = tree.nodes.new(kind)
        for key, value in inputs.items():
            sub.inputs[key].default_value = value
        tree.links.new(sub.outputs[0], sock)
    return mat


def _view_factor(mat, kind, output, **inputs):
    """`mat`'s Mix Shader Fac driven by a `kind` node's `output` (Fresnel, Layer Weight)."""
    tree = mat.node_tree
    node = tree.nodes.new(kind)
    for key, value in inputs.items():
        node.inputs[key].default_value = value
    mix = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeMixShader")
    tree.links.new(node.outputs[output], mix.inputs["Fac"])
    return mat


def view_factors():
    """Mix factors that read the view at the hit (issue 14, point 1): a Diffuse and a rough
    Glossy mixed by a Fresnel node (IOR 1.5, the classic coated look), two Diffuse colours
    by Layer Weight's Facing (blend 0.3: red face-on, blue at the rim), and a clear glass
    and a blue Diffuse by Layer Weight's Fresnel (blend 0.2), seen from inside the glass
    too; and a card above them turned away from the camera, a red and a blue Diffuse mixed
    by a Fresnel node (IOR 1.5): on a back face the node inverts the IOR, so at the card's
    angle it reflects totally (blue), where a front face would be mostly red."""
    _box()
    card = _card("BackCard", (0.0, 0.6, 0.95), (0.8, 0.35), _view_factor(
        _mix_of("BackFresnel", "ShaderNodeMixShader",
                ("ShaderNodeBsdfDiffuse", {"Color": (0.8, 0.1, 0.1, 1.0)}),
                ("ShaderNodeBsdfDiffuse", {"Color": (0.1, 0.2, 0.9, 1.0)})),
        "ShaderNodeFresnel", "Fac", IOR=1.5))
    card.rotation_euler = (0.0, 0.0, 0.8)  # (bs.quad winds it toward +y)
    _balls([
        _view_factor(_mix_of("Coated", "ShaderNodeMixShader",
                             ("ShaderNodeBsdfDiffuse", {"Color": (0.7, 0.15, 0.1, 1.0)}),
                             ("ShaderNodeBsdfGlossy", {"Color": (1.0, 1.0, 1.0, 1.0),
                                                       "Roughness": 0.15})),
                     "ShaderNodeFresnel", "Fac", IOR=1.5),
        _view_factor(_mix_of("Facing", "ShaderNodeMixShader",
                             ("ShaderNodeBsdfDiffuse", {"Color": (0.8, 0.1, 0.1, 1.0)}),
                             ("ShaderNodeBsdfDiffuse", {"Color": (0.1, 0.2, 0.9, 1.0)})),
                     "ShaderNodeLayerWeight", "Facing", Blend=0.3),
        _view_factor(_mix_of("RimGlass", "ShaderNodeMixShader",
                             ("ShaderNodeBsdfGlass", {"Color": (1.0, 1.0, 1.0, 1.0),
                                                      "Roughness": 0.0, "IOR": 1.45}),
                             ("ShaderNodeBsdfDiffuse", {"Color": (0.1, 0.2, 0.9, 1.0)})),
                     "ShaderNodeLayerWeight", "Fresnel", Blend=0.2)])


def _checker_metallic(mat):
    """The Principled BSDF's Metallic from a Checker Texture on the UV map: 1 and 0.3 in
    squares."""
    tree = mat.node_tree
    node = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled")
    checker = tree.nodes.new("ShaderNodeTexChecker")
    checker.inputs["Color1"].default_value = (1.0, 1.0, 1.0, 1.0)
    checker.inputs["Color2"].default_value = (0.3, 0.3, 0.3, 1.0)
    checker.inputs["Scale"].default_value = 4.0
    coords = tree.nodes.new("ShaderNodeTexCoord")  # UV (Generated is not compiled yet)
    tree.links.new(coords.outputs["UV"], checker.inputs["Vector"])
    tree.links.new(checker.outputs["Color"], node.inputs["Metallic"])
    return mat


def _checker_roughness(mat, low, high, scale=4.0):
    """`mat` whose shader's Roughness is a Checker Texture on the UV map: low and high in
    squares."""
    tree = mat.node_tree
    node = next(n for n in tree.nodes if "Roughness" in n.inputs)
    checker = tree.nodes.new("ShaderNodeTexChecker")
    checker.inputs["Color1"].default_value = (low, low, low, 1.0)
    checker.inputs["Color2"].default_value = (high, high, high, 1.0)
    checker.inputs["Scale"].default_value = scale
    coords = tree.nodes.new("ShaderNodeTexCoord")
    tree.links.new(coords.outputs["UV"], checker.inputs["Vector"])
    tree.links.new(checker.outputs["Color"], node.inputs["Roughness"])
    return mat


def textured_roughness():
    """Roughness from a Checker Texture on the UV maps (issue 14, points 1 and 2): a
    Principled floor at 0.2 and 0.5 in squares (the light's reflection breaks up into
    them), a gold Principled metal ball at 0.3 and 0.6, a Glass BSDF ball at 0.3 and 0.6
    and a Glossy ball at 0.25 and 0.5, in large squares."""
    scene = _box()
    floor = bpy.data.objects["Floor"]
    floor.data.materials[0] = _checker_roughness(
        _principled("FloorRough", **{"Base Color": (0.5, 0.5, 0.5, 1.0)}), 0.2, 0.5)
    _quad_uvs(floor)
    balls = [_checker_roughness(_principled("Gold", **{"Base Color": (1.0, 0.75, 0.35, 1.0),
                                                       "Metallic": 1.0}), 0.3, 0.6, 2.0),
             _checker_roughness(_glass("Frosted", (1.0, 1.0, 1.0), 0.3), 0.3, 0.6, 2.0),
             _checker_roughness(bs.material("Sheen", "ShaderNodeBsdfGlossy",
                                            Color=(0.8, 0.8, 0.8, 1.0)), 0.25, 0.5, 2.0)]
    for i, (mat, x) in enumerate(zip(balls, (-0.6, 0.0, 0.6))):
        obj = bpy.data.objects.new(f"Ball{i}", _uv_sphere_mesh(f"Ball{i}", 0.27))
        obj.location = (x, 0.0, 0.27)
        obj.data.materials.append(mat)
        scene.collection.objects.link(obj)


def _shell_group():
    """A node group: a Principled BSDF whose Base Color and Roughness are the group's
    inputs, its Metallic a Value node inside."""
    g = bpy.data.node_groups.new("Shell", "ShaderNodeTree")
    g.interface.new_socket("Base", in_out="INPUT", socket_type="NodeSocketColor")
    g.interface.new_socket("Rough", in_out="INPUT", socket_type="NodeSocketFloat")
    g.interface.new_socket("BSDF", in_out="OUTPUT", socket_type="NodeSocketShader")
    gin, gout = g.nodes.new("NodeGroupInput"), g.nodes.new("NodeGroupOutput")
    p = g.nodes.new("ShaderNodeBsdfPrincipled")
    metallic = g.nodes.new("ShaderNodeValue")
    metallic.outputs[0].default_value = 0.0
    g.links.new(gin.outputs["Base"], p.inputs["Base Color"])
    g.links.new(gin.outputs["Rough"], p.inputs["Roughness"])
    g.links.new(metallic.outputs[0], p.inputs["Metallic"])
    g.links.new(p.outputs[0], gout.inputs["BSDF"])
    return g


def _grouped(name, group, base, rough):
    """A material whose Surface is an instance of `group` with inputs Base and Rough."""
    mat = bs.material(name, "ShaderNodeBsdfDiffuse")
    tree = mat.node_tree
    tree.nodes.remove(next(n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfDiffuse"))
    node = tree.nodes.new("ShaderNodeGroup")
    node.node_tree = group
    node.inputs["Base"].default_value = base + (1.0,)
    node.inputs["Rough"].default_value = rough
    out = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial")
    tree.links.new(node.outputs["BSDF"], out.inputs["Surface"])
    return mat, node


def node_groups():
    """Materials built from node groups (issue 14, point 1), read as if ungrouped: one group
    (a Principled BSDF on the group's Base and Roughness) used by three balls with their
    own inputs: a red one at 0.2, a green one at 0.6, and one whose Base is a Checker
    Texture outside the group; and the back wall inside a group within a group."""
    scene = _box()
    shell = _shell_group()
    red, _ = _grouped("Red", shell, (0.8, 0.1, 0.1), 0.2)
    green, _ = _grouped("Green", shell, (0.1, 0.7, 0.2), 0.6)
    checked, node = _grouped("Checked", shell, (0.5, 0.5, 0.5), 0.35)
    tree = checked.node_tree
    checker = tree.nodes.new("ShaderNodeTexChecker")
    checker.inputs["Color1"].default_value = (0.9, 0.6, 0.1, 1.0)
    checker.inputs["Color2"].default_value = (0.1, 0.3, 0.8, 1.0)
    checker.inputs["Scale"].default_value = 4.0
    tree.links.new(tree.nodes.new("ShaderNodeTexCoord").outputs["UV"], checker.inputs["Vector"])
    tree.links.new(checker.outputs["Color"], node.inputs["Base"])
    for i, (mat, x) in enumerate(zip((red, green, checked), (-0.6, 0.0, 0.6))):
        obj = bpy.data.objects.new(f"Ball{i}", _uv_sphere_mesh(f"Ball{i}", 0.27))
        obj.location = (x, 0.0, 0.27)
        obj.data.materials.append(mat)
        scene.collection.objects.link(obj)
    outer = bpy.data.node_groups.new("Outer", "ShaderNodeTree")
    outer.interface.new_socket("Tint", in_out="INPUT", socket_type="NodeSocketColor")
    outer.interface.new_socket("BSDF", in_out="OUTPUT", socket_type="NodeSocketShader")
    inner = outer.nodes.new("ShaderNodeGroup")
    inner.node_tree = shell
    inner.inputs["Rough"].default_value = 0.5
    outer.links.new(outer.nodes.new("NodeGroupInput").outputs["Tint"], inner.inputs["Base"])
    outer.links.new(inner.outputs["BSDF"], outer.nodes.new("NodeGroupOutput").inputs["BSDF"])
    wall = bpy.data.objects["Back"]
    mat = bs.material("Wall", "ShaderNodeBsdfDiffuse")
    tree = mat.node_tree
    tree.nodes.remove(next(n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfDiffuse"))
    node = tree.nodes.new("ShaderNodeGroup")
    node.node_tree = outer
    node.inputs["Tint"].default_value = (0.9, 0.8, 0.3, 1.0)
    out = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial")
    tree.links.new(node.outputs["BSDF"], out.inputs["Surface"])
    wall.data.materials[0] = mat


def _turned_30(tree):
    """A Mapping turning its vector 30 degrees about z."""
    mapping = tree.nodes.new("ShaderNodeMapping")
    mapping.inputs["Rotation"].default_value = (0.0, 0.0, math.radians(30.0))
    return mapping


def _procedural(name, coordinates=None, scale=3.0):
    """A Diffuse material coloured by a Checker Texture on Texture Coordinate's
    `coordinates` output (None: the Vector unlinked, Generated by default), via a Mapping
    rotating it 30 degrees about z."""
    return _coordinate_checker(name, coordinates, scale,
                               _turned_30 if coordinates is not None else None)


def texture_spaces():
    """Procedural texture coordinates (issue 14, point 1): Checker Textures on Generated
    coordinates (unlinked: the default) on a ball, on Generated through a Mapping on a
    scaled, rotated box (its texture space follows the mesh, not the object), and on
    Object coordinates on a ball whose object is moved and turned (they follow it)."""
    _box()
    _sphere(_procedural("Default"), (-0.6, 0.0, 0.27), 0.27, "Default")
    crate = _cube("Crate", (0.0, 0.1, 0.2), (0.35, 0.25, 0.4),
                  _procedural("Generated", "Generated"))
    crate.rotation_euler = (0.0, 0.0, 0.5)
    ball = _sphere(_procedural("Object", "Object", scale=2.0), (0.6, 0.0, 0.27), 0.27, "Obj")
    ball.rotation_euler = (0.4, 0.0, 0.9)


def _coordinate_checker(name, output, scale, mapping=None):
    """A Diffuse material coloured by a Checker Texture of `scale` on Texture Coordinate's
    `output` (None: its Vector unlinked), through the Mapping `mapping(tree)` makes (its
    Vector linked here) if given."""
    mat = bs.material(name, "ShaderNodeBsdfDiffuse")
    tree = mat.node_tree
    checker = tree.nodes.new("ShaderNodeTexChecker")
    checker.inputs["Color1"].default_value = (0.9, 0.6, 0.1, 1.0)
    checker.inputs["Color2"].default_value = (0.1, 0.3, 0.8, 1.0)
    checker.inputs["Scale"].default_value = scale
    if output is not None:
        vector = tree.nodes.new("ShaderNodeTexCoord").outputs[output]
        if mapping is not None:
            node = mapping(tree)
            tree.links.new(vector, node.inputs["Vector"])
            vector = node.outputs["Vector"]
        tree.links.new(vector, checker.inputs["Vector"])
    diffuse = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfDiffuse")
    tree.links.new(checker.outputs["Color"], diffuse.inputs["Color"])
    return mat


def _linked_mapping(kind, **links):
    """A Mapping of type `kind` whose inputs named in `links` are linked: a tuple is a
    Combine XYZ of those values, "noise" a Noise Texture's Color (on Generated coordinates)
    times 2."""
    def make(tree):
        node = tree.nodes.new("ShaderNodeMapping")
        node.vector_type = kind
        for name, value in links.items():
            if value == "noise":
                noise = tree.nodes.new("ShaderNodeTexNoise")
                noise.inputs["Scale"].default_value = 2.0
                scale = tree.nodes.new("ShaderNodeVectorMath")
                scale.operation = "SCALE"
                scale.inputs["Scale"].default_value = 2.0
                tree.links.new(noise.outputs["Color"], scale.inputs[0])
                source = scale.outputs["Vector"]
            else:
                combine = tree.nodes.new("ShaderNodeCombineXYZ")
                for axis, v in zip("XYZ", value):
                    combine.inputs[axis].default_value = v
                source = combine.outputs["Vector"]
            tree.links.new(source, node.inputs[name])
        return node
    return make


def texture_coordinates():
    """Texture Coordinate's view outputs and a Mapping with linked inputs (issue 14, point
    1): Checker Textures on the object-space Normal of a turned ball, through a Normal
    Mapping scaled and turned by linked vectors; on the Reflection, through a Texture
    Mapping whose linked scale is 0 on y; on Camera coordinates, through a Point Mapping
    turned by a Noise Texture; and on the Window (the camera shifted) on a card behind."""
    _box()
    bpy.context.scene.camera.data.shift_x = 0.06
    normal = _coordinate_checker("NormalChecker", "Normal", 2.0, _linked_mapping(
        "NORMAL", Rotation=(0.3, 0.0, 0.6), Scale=(1.0, 2.0, 0.5)))
    reflection = _coordinate_checker("ReflectionChecker", "Reflection", 2.5, _linked_mapping(
        "TEXTURE", Scale=(0.7, 0.0, 0.5)))
    camera = _coordinate_checker("CameraChecker", "Camera", 4.0, _linked_mapping(
        "POINT", Rotation="noise", Location=(0.1, 0.2, 0.0)))
    _balls([normal, reflection, camera])
    bpy.data.objects["Ball0"].rotation_euler = (0.4, 0.0, 0.9)
    _card("WindowCard", (0.0, 0.5, 0.75), (1.2, 0.5), _coordinate_checker(
        "WindowChecker", "Window", 6.0))


def _diffuse_fed(name, feed):
    """A Diffuse material whose Color is the socket `feed(tree)` returns."""
    mat = bs.material(name, "ShaderNodeBsdfDiffuse")
    tree = mat.node_tree
    diffuse = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfDiffuse")
    tree.links.new(feed(tree), diffuse.inputs["Color"])
    return mat


def _object_info_feed(tree):
    """Object Info: its Color mixed toward (Random, Alpha, Object Index / 4) by Alpha, times
    the Color of an Attribute node of type Object reading the property "tint"."""
    info = tree.nodes.new("ShaderNodeObjectInfo")
    combine = tree.nodes.new("ShaderNodeCombineColor")
    quarter = tree.nodes.new("ShaderNodeMath")
    quarter.operation = "DIVIDE"
    quarter.inputs[1].default_value = 4.0
    tree.links.new(info.outputs["Object Index"], quarter.inputs[0])
    for source, channel in ((info.outputs["Random"], "Red"), (info.outputs["Alpha"], "Green"),
                            (quarter.outputs[0], "Blue")):
        tree.links.new(source, combine.inputs[channel])
    mix = tree.nodes.new("ShaderNodeMix")
    mix.data_type = "RGBA"
    ins = {s.identifier: s for s in mix.inputs}
    tree.links.new(info.outputs["Alpha"], ins["Factor_Float"])
    tree.links.new(info.outputs["Color"], ins["A_Color"])
    tree.links.new(combine.outputs["Color"], ins["B_Color"])
    tint = tree.nodes.new("ShaderNodeAttribute")
    tint.attribute_type, tint.attribute_name = "OBJECT", "tint"
    times = tree.nodes.new("ShaderNodeMix")
    times.data_type, times.blend_type = "RGBA", "MULTIPLY"
    ins = {s.identifier: s for s in times.inputs}
    ins["Factor_Float"].default_value = 1.0
    tree.links.new(mix.outputs[2], ins["A_Color"])
    tree.links.new(tint.outputs["Color"], ins["B_Color"])
    return times.outputs[2]


def _position_feed(tree):
    """A Checker Texture (scale 5) on the Geometry node's Position (world space)."""
    checker = tree.nodes.new("ShaderNodeTexChecker")
    checker.inputs["Scale"].default_value = 5.0
    checker.inputs["Color1"].default_value = (0.9, 0.6, 0.1, 1.0)
    checker.inputs["Color2"].default_value = (0.1, 0.3, 0.8, 1.0)
    tree.links.new(tree.nodes.new("ShaderNodeNewGeometry").outputs["Position"],
                   checker.inputs["Vector"])
    return checker.outputs["Color"]


def _normals_feed(tree):
    """The Geometry node's |Normal| mixed with |True Normal| by Incoming . Normal."""
    geometry = tree.nodes.new("ShaderNodeNewGeometry")
    absolute = []
    for name in ("Normal", "True Normal"):
        node = tree.nodes.new("ShaderNodeVectorMath")
        node.operation = "ABSOLUTE"
        tree.links.new(geometry.outputs[name], node.inputs[0])
        absolute.append(node.outputs[0])
    dot = tree.nodes.new("ShaderNodeVectorMath")
    dot.operation = "DOT_PRODUCT"
    tree.links.new(geometry.outputs["Incoming"], dot.inputs[0])
    tree.links.new(geometry.outputs["Normal"], dot.inputs[1])
    mix = tree.nodes.new("ShaderNodeMix")
    mix.data_type = "VECTOR"
    ins = {s.identifier: s for s in mix.inputs}
    tree.links.new(dot.outputs["Value"], ins["Factor_Float"])
    tree.links.new(absolute[0], ins["A_Vector"])
    tree.links.new(absolute[1], ins["B_Vector"])
    return mix.outputs[1]


def _backfacing_feed(tree):
    """Orange on a front face, green on a back face (Geometry's Backfacing as the factor)."""
    mix = tree.nodes.new("ShaderNodeMix")
    mix.data_type = "RGBA"
    ins = {s.identifier: s for s in mix.inputs}
    ins["A_Color"].default_value = (0.9, 0.4, 0.1, 1.0)
    ins["B_Color"].default_value = (0.2, 0.8, 0.3, 1.0)
    tree.links.new(tree.nodes.new("ShaderNodeNewGeometry").outputs["Backfacing"],
                   ins["Factor_Float"])
    return mix.outputs[2]


def geometry_and_object_info():
    """The Geometry node (Position, Normal, True Normal, Incoming, Backfacing), Object
    Info (Color, Alpha, Random, Object Index) and the Attribute node of type Object (issue
    14, point 1): a ball and three cubes sharing one mesh, each with its own colour, alpha,
    pass index and "tint" (the ball's on its mesh; a vector, a number, four numbers) (Random
    differs by object); a ball chequered on world positions; a faceted ball (flat and smooth halves)
    coloured by its normals; and a card seen from behind whose back face is green."""
    _box()
    info = _diffuse_fed("Info", _object_info_feed)
    ball = _sphere(info, (-0.6, 0.0, 0.27), 0.27, "InfoBall")
    ball.color, ball.pass_index = (0.9, 0.5, 0.2, 0.3), 3
    ball.data["tint"] = (1.0, 0.6, 0.8)
    mesh = None
    for i, (colour, index, tint) in enumerate((
            ((0.2, 0.6, 0.9, 0.8), 1, (0.5, 1.0, 1.0)), ((0.8, 0.8, 0.2, 0.0), 2, 0.7),
            ((0.9, 0.2, 0.5, 0.5), 4, (0.9, 0.8, 0.6, 0.5)))):
        cube = _cube(f"InfoCube{i}", (-0.75 + 0.3 * i, 0.5, 0.8), (0.18, 0.18, 0.18), info)
        if mesh is None:
            mesh = cube.data
        else:  # linked duplicates: one mesh, three objects
            old, cube.data = cube.data, mesh
            bpy.data.meshes.remove(old)
        cube.color, cube.pass_index = colour, index
        cube["tint"] = tint
    _sphere(_diffuse_fed("Position", _position_feed), (0.0, 0.0, 0.27), 0.27, "PositionBall")
    faceted = _sphere(_diffuse_fed("Normals", _normals_feed), (0.6, 0.0, 0.27), 0.27,
                      "NormalsBall")
    for face in faceted.data.polygons:
        face.use_smooth = face.center[0] > 0.0
    faceted.rotation_euler = (0.3, 0.2, 0.4)
    _card("BackCard", (0.55, 0.5, 0.85), (0.5, 0.35), _diffuse_fed("Backfacing",
                                                                   _backfacing_feed))


def parametric():
    """The Geometry node's Parametric (issue 14, point 1), glowing as a colour on a card, a
    turned cube and a turned mirrored cube (negative x scale: its corners reorder with its
    winding, Cycles' values stay the mesh's)."""
    _box()

    def feed(tree):
        return tree.nodes.new("ShaderNodeNewGeometry").outputs["Parametric"]
    _glowing_card("ParametricCard", (0.0, 0.6, 1.05), (0.9, 0.45), feed)
    mat = _glow("ParametricGlow", feed)
    for name, x, sx in (("ParametricCube", -0.45, 0.25), ("MirroredCube", 0.45, -0.25)):
        cube = _cube(name, (x, 0.0, 0.4), (sx, 0.25, 0.25), mat)
        cube.rotation_euler = (0.5, 0.3, 0.7)


def _islands_mesh(name, count):
    """One mesh of `count` small cubes in a row (each an island), built in a fixed order."""
    from mathutils import Matrix
    mesh = bpy.data.meshes.new(name)
    bm = bmesh.new()
    for i in range(count):
        bmesh.ops.create_cube(bm, size=0.14, matrix=Matrix.Translation(
            (-0.45 + 0.9 * i / (count - 1), 0.0, 0.08 * (i % 2))))
    bm.to_mesh(mesh)
    bm.free()
    return mesh


def random_per_island():
    """The Geometry node's Random Per Island (issue 14, point 1): a mesh of eight cubes
    glowing grey in it, and the same mesh mirrored and turned glowing in a White Noise
    hash of it (which would scatter any difference in the number's last bit)."""
    _box()

    def glow(name, hashed):
        def feed(tree):
            value = tree.nodes.new("ShaderNodeNewGeometry").outputs["Random Per Island"]
            if not hashed:
                return value
            noise = tree.nodes.new("ShaderNodeTexWhiteNoise")
            noise.noise_dimensions = "1D"
            tree.links.new(value, noise.inputs["W"])
            return noise.outputs["Color"]
        return _glow(name, feed)

    mesh = _islands_mesh("Islands", 8)
    for name, z, scale, mat in (("Islands", 0.9, (1.0, 1.0, 1.0), glow("IslandGrey", False)),
                                ("HashedIslands", 0.35, (-1.0, 1.0, 1.0),
                                 glow("IslandHashed", True))):
        obj = bpy.data.objects.new(name, mesh if name == "Islands" else mesh.copy())
        obj.data.materials.clear()
        obj.data.materials.append(mat)
        obj.location, obj.scale, obj.rotation_euler = (0.0, 0.0, z), scale, (0.3, 0.0, 0.2)
        bpy.context.scene.collection.objects.link(obj)


def pointiness():
    """The Geometry node's Pointiness (issue 14, point 1) through a Color Ramp of a narrow
    range, glowing: a cube rounded by a Subdivision Surface modifier, a cube whose faces
    an Edge Split modifier parts (duplicate vertices, which Cycles welds first) and a
    turned card (flat: 1/2)."""
    _box()
    def feed(tree):
        ramp = tree.nodes.new("ShaderNodeValToRGB")
        low, high = ramp.color_ramp.elements
        low.position, high.position = 0.45, 0.75
        low.color, high.color = (0.1, 0.2, 1.0, 1.0), (1.0, 0.6, 0.1, 1.0)
        tree.links.new(tree.nodes.new("ShaderNodeNewGeometry").outputs["Pointiness"],
                       ramp.inputs["Fac"])
        return ramp.outputs["Color"]
    mat = _glow("Pointy", feed)
    rounded = _cube("RoundedCube", (-0.45, 0.0, 0.4), (0.25, 0.25, 0.25), mat)
    rounded.modifiers.new("Subdivision", "SUBSURF").levels = 2
    rounded.modifiers["Subdivision"].render_levels = 2
    parted = _cube("PartedCube", (0.45, 0.0, 0.4), (0.25, 0.25, 0.25), mat)
    parted.modifiers.new("EdgeSplit", "EDGE_SPLIT").split_angle = 0.5
    for obj in (rounded, parted):
        obj.rotation_euler = (0.5, 0.3, 0.7)
    _card("FlatCard", (0.0, 0.6, 1.05), (0.9, 0.45), mat, angle=0.3)


def _vector_transform(tree, kind, source, target, vector):
    """A Vector Transform node of `kind` from `source` to `target` space fed by `vector`."""
    node = tree.nodes.new("ShaderNodeVectorTransform")
    node.vector_type, node.convert_from, node.convert_to = kind, source, target
    tree.links.new(vector, node.inputs["Vector"])
    return node.outputs["Vector"]


def _transformed(name, kind, source, target, coordinate, checker=0.0):
    """A Diffuse material coloured by the Vector Transform of `coordinate` ("Position" or
    "Normal" of the Geometry node, else a Texture Coordinate output): through a Checker
    Texture of scale `checker` if given, else its absolute value."""
    def feed(tree):
        node = tree.nodes.new("ShaderNodeNewGeometry" if coordinate in ("Position", "Normal")
                              else "ShaderNodeTexCoord")
        vector = _vector_transform(tree, kind, source, target, node.outputs[coordinate])
        if checker:
            texture = tree.nodes.new("ShaderNodeTexChecker")
            texture.inputs["Scale"].default_value = checker
            texture.inputs["Color1"].default_value = (0.9, 0.6, 0.1, 1.0)
            texture.inputs["Color2"].default_value = (0.1, 0.3, 0.8, 1.0)
            tree.links.new(vector, texture.inputs["Vector"])
            return texture.outputs["Color"]
        absolute = tree.nodes.new("ShaderNodeVectorMath")
        absolute.operation = "ABSOLUTE"
        tree.links.new(vector, absolute.inputs[0])
        return absolute.outputs[0]
    return _diffuse_fed(name, feed)


def vector_transform():
    """The Vector Transform node (issue 14, point 1) between World, Object and Camera
    space, for points, vectors and normals, on turned and unevenly scaled objects, and
    Texture Coordinate's Object output of another object (a turned, scaled empty): two
    balls sharing a material chequered by world positions in their own space; a ball
    coloured by its camera-space normals; a ball chequered by camera coordinates in its own
    space; a ball coloured by its object-space normals in world space and a cube by its
    world normals in object space; a cube coloured by object coordinates as camera-space
    vectors, another chequered by them as world points; a card chequered in the empty's
    space."""
    _box()
    shared = _transformed("ObjectPoints", "POINT", "WORLD", "OBJECT", "Position", 4.0)
    balls = [(shared, (-0.7, 0.1, 0.2), (0.3, 0.0, 0.8), (1.0, 0.7, 1.3)),
             (shared, (-0.25, -0.1, 0.2), (0.0, 0.9, -0.4), (1.2, 1.0, 0.8)),
             (_transformed("CameraNormals", "NORMAL", "WORLD", "CAMERA", "Normal"),
              (0.2, 0.1, 0.2), (0.0, 0.0, 0.0), (1.0, 1.0, 1.0)),
             (_transformed("CameraToObject", "POINT", "CAMERA", "OBJECT", "Camera", 5.0),
              (0.65, -0.1, 0.2), (0.5, 0.2, 0.7), (0.8, 1.3, 1.0)),
             (_transformed("ObjectNormals", "NORMAL", "OBJECT", "WORLD", "Normal"),
              (-0.45, 0.45, 0.75), (0.7, 0.0, 0.3), (1.5, 0.6, 1.0))]
    for i, (mat, centre, turn, scale) in enumerate(balls):
        ball = _sphere(mat, centre, 0.2, f"Ball{i}")
        ball.rotation_euler, ball.scale = turn, scale
    cubes = [("NormalCube", _transformed("WorldNormals", "NORMAL", "WORLD", "OBJECT", "Normal"),
              (0.05, 0.5, 0.8)),
             ("VectorCube", _transformed("ObjectVectors", "VECTOR", "OBJECT", "CAMERA",
                                         "Object"), (0.45, 0.5, 0.8)),
             ("PointCube", _transformed("ObjectPointsInWorld", "POINT", "OBJECT", "WORLD",
                                        "Object", 6.0), (0.8, 0.3, 1.15))]
    for name, mat, location in cubes:
        cube = _cube(name, location, (0.25, 0.3, 0.18), mat)
        cube.rotation_euler = (0.4, 0.3, 0.6)
    projector = bpy.data.objects.new("Projector", None)
    projector.location, projector.rotation_euler = (0.3, 0.2, 1.0), (0.2, 0.5, 0.9)
    projector.scale = (0.5, 1.5, 1.0)
    bpy.context.scene.collection.objects.link(projector)
    mat = bs.material("Projected", "ShaderNodeBsdfDiffuse")
    tree = mat.node_tree
    coordinates = tree.nodes.new("ShaderNodeTexCoord")
    coordinates.object = projector
    texture = tree.nodes.new("ShaderNodeTexChecker")
    texture.inputs["Scale"].default_value = 3.0
    tree.links.new(coordinates.outputs["Object"], texture.inputs["Vector"])
    diffuse = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfDiffuse")
    tree.links.new(texture.outputs["Color"], diffuse.inputs["Color"])
    _card("ProjectedCard", (-0.1, 0.7, 1.2), (1.2, 0.45), mat)


def _orange_to_blue(tree, factor):
    """A colour Mix from orange to blue by the socket `factor`; returns its Result."""
    mix = tree.nodes.new("ShaderNodeMix")
    mix.data_type = "RGBA"
    ins = {sock.identifier: sock for sock in mix.inputs}
    ins["A_Color"].default_value = (0.9, 0.5, 0.1, 1.0)
    ins["B_Color"].default_value = (0.1, 0.3, 0.9, 1.0)
    tree.links.new(factor, ins["Factor_Float"])
    return mix.outputs["Result"]


def _painted_ball(name, centre, domain, data_type, attribute="Paint", alpha=False):
    """A smooth UV sphere of radius 0.27 whose colour attribute `attribute` (per `domain`)
    paints bands of colour from its vertices' positions, Diffuse-shaded by a Color
    Attribute node reading it by name ("" for the mesh's default). With `alpha` the bands
    are in its alpha too, and the Diffuse colour mixes orange and blue by it."""
    mesh = _uv_sphere_mesh(name, 0.27)
    attr = mesh.color_attributes.new(attribute, data_type, domain)
    co = np.array([v.co[:] for v in mesh.vertices])
    points = co if domain == "POINT" else co[[loop.vertex_index for loop in mesh.loops]]
    if domain == "CORNER":  # per face: a hard pattern only corners can hold
        # Keyed by where the face is, not its index: bmesh orders the sphere's faces
        # differently in each process, and the reference is rendered in another.
        middle = np.array([p.center[:] for p in mesh.polygons])
        key = np.floor(middle[:, 0] * 40.0) + np.floor(middle[:, 2] * 40.0)
        face = np.repeat(key, [len(p.vertices) for p in mesh.polygons])
        points = points + 0.05 * (face % 3)[:, None]
    rgba = np.ones((len(points), 4))
    rgba[:, 0] = 0.5 + 0.5 * np.sin(12.0 * points[:, 2])
    rgba[:, 1] = 0.5 + 0.5 * np.cos(9.0 * points[:, 0])
    rgba[:, 2] = np.clip(0.3 + 2.0 * points[:, 1], 0.0, 1.0)
    if alpha:
        rgba[:, 3] = 0.5 + 0.5 * np.cos(14.0 * points[:, 2] + 6.0 * points[:, 0])
    attr.data.foreach_set("color", rgba.astype(np.float32).ravel())
    mat = bs.material(name, "ShaderNodeBsdfDiffuse")
    tree = mat.node_tree
    node = tree.nodes.new("ShaderNodeVertexColor")
    node.layer_name = attribute if attribute != "Paint" else ""
    colour = node.outputs["Color"]
    if alpha:
        colour = _orange_to_blue(tree, node.outputs["Alpha"])
    tree.links.new(colour, next(
        n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfDiffuse").inputs["Color"])
    obj = bpy.data.objects.new(name, mesh)
    obj.location = centre
    obj.data.materials.append(mat)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def colour_attributes():
    """Color Attribute nodes (issue 14, point 1): a byte colour attribute per face corner
    read as the mesh's default (its layer name empty), a float one per point read by name
    beside another attribute, and a byte one's Alpha as a Mix factor."""
    _box()
    _painted_ball("Corners", (-0.55, 0.0, 0.27), "CORNER", "BYTE_COLOR")
    ball = _painted_ball("Points", (0.0, 0.0, 0.27), "POINT", "FLOAT_COLOR", "Tint")
    ball.data.color_attributes.new("Other", "FLOAT_COLOR", "POINT")
    _painted_ball("Alpha", (0.55, 0.0, 0.27), "CORNER", "BYTE_COLOR", alpha=True)


def _blend_card(name, centre, blend_type, odd, textured):
    """A card whose Emission colour is a Mix node in `blend_type`, its result clamped if
    `odd`. `textured`: A, B and the factor vary over the card's UV map, A a hue sweep
    through Combine Color (HSL if `odd`, else HSV), B the (h, s, v) (HSL: (h, s, l)) of a
    gradient through Separate Color, times 1.5 plus 0.2 (Dodge and Burn reach their limits,
    Divide stays finite where the hue is 0); else all constants, which both engines fold."""
    mat = bs.material(name, "ShaderNodeEmission", Strength=1.0)
    tree = mat.node_tree
    mix = tree.nodes.new("ShaderNodeMix")
    mix.data_type, mix.blend_type = "RGBA", blend_type
    mix.clamp_result = odd
    a, b_in, f = (next(s for s in mix.inputs if s.identifier == i)
                  for i in ("A_Color", "B_Color", "Factor_Float"))
    if textured:
        mode = "HSL" if odd else "HSV"
        uv = tree.nodes.new("ShaderNodeSeparateXYZ")
        tree.links.new(tree.nodes.new("ShaderNodeTexCoord").outputs["UV"], uv.inputs[0])
        hue = tree.nodes.new("ShaderNodeCombineColor")
        hue.mode = mode
        tree.links.new(uv.outputs["X"], hue.inputs[0])
        hue.inputs[1].default_value = 0.85
        tree.links.new(uv.outputs["Y"], hue.inputs[2])
        ramp = tree.nodes.new("ShaderNodeCombineColor")
        tree.links.new(uv.outputs["Y"], ramp.inputs[0])
        ramp.inputs[1].default_value = 0.4
        tree.links.new(uv.outputs["X"], ramp.inputs[2])
        split = tree.nodes.new("ShaderNodeSeparateColor")
        split.mode = "HSV" if odd else "HSL"
        tree.links.new(ramp.outputs[0], split.inputs[0])
        b = tree.nodes.new("ShaderNodeCombineColor")
        for i in range(3):
            tree.links.new(split.outputs[i], b.inputs[i])
        scale = tree.nodes.new("ShaderNodeVectorMath")
        scale.operation = "MULTIPLY_ADD"
        scale.inputs[1].default_value = (1.5, 1.5, 1.5)
        scale.inputs[2].default_value = (0.2, 0.2, 0.2)
        tree.links.new(b.outputs[0], scale.inputs[0])
        fac = tree.nodes.new("ShaderNodeMath")
        fac.operation = "MULTIPLY_ADD"
        tree.links.new(uv.outputs["Y"], fac.inputs[0])
        fac.inputs[1].default_value, fac.inputs[2].default_value = 0.8, 0.3
        tree.links.new(hue.outputs[0], a)
        tree.links.new(scale.outputs[0], b_in)
        tree.links.new(fac.outputs[0], f)
    else:
        a.default_value = (0.7, 0.35, 0.15, 1.0)
        b_in.default_value = (0.25, 0.9, 1.3, 1.0)
        f.default_value = 0.65
    emission = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeEmission")
    tree.links.new(mix.outputs["Result"], emission.inputs["Color"])
    obj = _card(name, centre, (0.17, 0.5), mat)
    _quad_uvs(obj)
    return obj


def blend_modes():
    """Every blend mode of the colour Mix node (issue 14, point 1) on emitting cards seen
    head-on by an orthographic camera, nothing else in the scene: each pixel is the mix
    itself, free of lighting noise. Top row: A, B and the factor vary over each card
    (shader programs, and Combine / Separate Color in HSV and HSL); bottom row: constants
    (folded to one colour by the exporter, as by Cycles). Every other card clamps its
    result, and Linear Light's: Cycles emits the negative colours it makes (negative
    light), which Specula renders as 0 (README_addon.md)."""
    modes = ("MIX", "DARKEN", "MULTIPLY", "BURN", "LIGHTEN", "SCREEN", "DODGE", "ADD",
             "OVERLAY", "SOFT_LIGHT", "LINEAR_LIGHT", "DIFFERENCE", "EXCLUSION", "SUBTRACT",
             "DIVIDE", "HUE", "SATURATION", "COLOR", "VALUE")
    scene = bs.new_scene()
    cam = bs.camera(scene, "Camera", (0.0, -3.0, 0.0), 50.0, (228, 72))
    cam.data.type, cam.data.ortho_scale = "ORTHO", 4.0
    bs.black_world(scene)
    for i, mode in enumerate(modes):
        x = -2.0 + (i + 0.5) * 4.0 / len(modes)
        odd = i % 2 == 1 or mode == "LINEAR_LIGHT"
        _blend_card(f"T{mode}", (x, 0.0, 0.3), mode, odd, True)
        _blend_card(f"C{mode}", (x, 0.0, -0.33), mode, odd, False)


def _glow(name, feed):
    """An Emission material (strength 1) whose colour is the socket `feed(tree)` returns."""
    mat = bs.material(name, "ShaderNodeEmission", Strength=1.0)
    tree = mat.node_tree
    emission = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeEmission")
    tree.links.new(feed(tree), emission.inputs["Color"])
    return mat


def _glowing_card(name, centre, size, feed):
    """An emitting card (strength 1, UV mapped) whose colour is the socket `feed(tree)`
    returns."""
    _quad_uvs(_card(name, centre, size, _glow(name, feed)))


def _noise_feed(dimensions, kind, output="Factor", **inputs):
    """A feed for _glowing_card: a Noise Texture (on Generated coordinates, unlinked) of
    `dimensions` and fractal `kind`, its W the card's Generated x, through Math Absolute
    where it is the Factor (some fractals go below 0, which would be negative light)."""
    def feed(tree):
        node = tree.nodes.new("ShaderNodeTexNoise")
        node.noise_dimensions, node.noise_type = dimensions, kind
        for key, value in inputs.items():
            if key == "normalize":
                node.normalize = value
            else:
                node.inputs[key].default_value = value
        if dimensions in ("1D", "4D"):
            split = tree.nodes.new("ShaderNodeSeparateXYZ")
            tree.links.new(tree.nodes.new("ShaderNodeTexCoord").outputs["Generated"],
                           split.inputs[0])
            tree.links.new(split.outputs["X"], node.inputs["W"])
        if output == "Color":
            return node.outputs["Color"]
        absolute = tree.nodes.new("ShaderNodeMath")
        absolute.operation = "ABSOLUTE"
        tree.links.new(node.outputs["Fac"], absolute.inputs[0])
        return absolute.outputs[0]
    return feed


def _gradient_feed(kind):
    def feed(tree):
        node = tree.nodes.new("ShaderNodeTexGradient")
        node.gradient_type = kind
        mapping = tree.nodes.new("ShaderNodeMapping")  # Generated [0, 1] -> [-1, 1]
        mapping.inputs["Location"].default_value = (-1.0, -1.0, -1.0)
        mapping.inputs["Scale"].default_value = (2.0, 2.0, 2.0)
        tree.links.new(tree.nodes.new("ShaderNodeTexCoord").outputs["Generated"],
                       mapping.inputs["Vector"])
        tree.links.new(mapping.outputs["Vector"], node.inputs["Vector"])
        return node.outputs["Color"]
    return feed


def _wave_feed(kind, direction, profile, output="Color", **inputs):
    def feed(tree):
        node = tree.nodes.new("ShaderNodeTexWave")
        node.wave_type, node.wave_profile = kind, profile
        if kind == "BANDS":
            node.bands_direction = direction
        else:
            node.rings_direction = direction
        for key, value in inputs.items():
            node.inputs[key].default_value = value
        return node.outputs[output]
    return feed


def _magic_feed(depth, output="Color", **inputs):
    def feed(tree):
        node = tree.nodes.new("ShaderNodeTexMagic")
        node.turbulence_depth = depth
        for key, value in inputs.items():
            node.inputs[key].default_value = value
        return node.outputs[output]
    return feed


def procedural_textures():
    """Procedural textures (issue 14, point 1: a new node is one new function): Noise
    Textures of every dimension and fractal type (fBM, normalized or not and with a
    fractional detail; multifractal, hybrid and ridged multifractal, hetero terrain;
    distortion; the Color output), every Gradient Texture type, and Wave (bands and rings,
    every profile, distortion) and Magic Textures, on emitting cards seen head-on by an
    orthographic camera: each pixel is the texture itself."""
    scene = bs.new_scene()
    cam = bs.camera(scene, "Camera", (0.0, -3.0, 0.0), 50.0, (224, 96))
    cam.data.type, cam.data.ortho_scale = "ORTHO", 4.0
    bs.black_world(scene)
    noises = [("3D", "FBM", "Factor", {}),
              ("3D", "FBM", "Color", {"Distortion": 0.6, "Detail": 4.5}),
              ("3D", "FBM", "Factor", {"normalize": False, "Detail": 3.5, "Roughness": 0.7}),
              ("2D", "MULTIFRACTAL", "Factor", {"Detail": 3.0, "Scale": 3.0}),
              ("4D", "RIDGED_MULTIFRACTAL", "Factor", {"Offset": 1.0, "Gain": 2.0,
                                                        "Detail": 4.0}),
              ("1D", "HYBRID_MULTIFRACTAL", "Factor", {"Offset": 0.5, "Gain": 1.5,
                                                        "Scale": 8.0}),
              ("3D", "HETERO_TERRAIN", "Factor", {"Offset": 0.7, "Detail": 2.5})]
    for i, (d, kind, output, inputs) in enumerate(noises):
        _glowing_card(f"N{i}", (-2.0 + (i + 0.5) * 4.0 / 7, 0.0, 0.55), (0.5, 0.5),
                      _noise_feed(d, kind, output, **inputs))
    kinds = ("LINEAR", "QUADRATIC", "EASING", "DIAGONAL", "SPHERICAL", "QUADRATIC_SPHERE",
             "RADIAL")
    for i, kind in enumerate(kinds):
        _glowing_card(f"G{kind}", (-2.0 + (i + 0.5) * 4.0 / 7, 0.0, 0.0), (0.5, 0.5),
                      _gradient_feed(kind))
    others = [_wave_feed("BANDS", "X", "SIN", Scale=1.5),
              _wave_feed("BANDS", "DIAGONAL", "SAW", Scale=1.0, Distortion=4.0, Detail=3.0),
              _wave_feed("RINGS", "SPHERICAL", "TRI", "Fac", Scale=1.2),
              _wave_feed("RINGS", "Z", "SIN", Scale=0.8, Distortion=6.0, Detail=2.5,
                         **{"Detail Scale": 2.0, "Detail Roughness": 0.7,
                            "Phase Offset": 1.0}),
              _magic_feed(2, Scale=3.0),
              _magic_feed(5, Scale=2.0, Distortion=2.5),
              _magic_feed(8, "Fac", Scale=4.0, Distortion=1.5)]
    for i, feed in enumerate(others):
        _glowing_card(f"W{i}", (-2.0 + (i + 0.5) * 4.0 / 7, 0.0, -0.55), (0.5, 0.5), feed)


def _white_noise_feed(dimensions, output="Color", cells=8.0, w=0.0):
    """A feed for _glowing_card: a White Noise Texture of `dimensions` on the card's
    Generated coordinates times `cells`, floored (a random colour per cell; None: the raw
    coordinates, noise per point; 0: the Vector unlinked), its W the floored x (1D) or
    `w` (4D)."""
    def feed(tree):
        node = tree.nodes.new("ShaderNodeTexWhiteNoise")
        node.noise_dimensions = dimensions
        if dimensions == "4D":
            node.inputs["W"].default_value = w
        if cells == 0:
            return node.outputs[output]
        vector = tree.nodes.new("ShaderNodeTexCoord").outputs["Generated"]
        if cells is not None:
            # Moved off the integers before the floor: the card's flat axis is Generated
            # 1/2 everywhere, x 8 an integer, which float rounding puts either side of.
            for operation in ("SCALE", "ADD", "FLOOR"):
                vmath = tree.nodes.new("ShaderNodeVectorMath")
                vmath.operation = operation
                vmath.inputs[3].default_value = cells  # Scale (unavailable to the others)
                vmath.inputs[1].default_value = (0.0123, 0.0123, 0.0123)
                tree.links.new(vector, vmath.inputs[0])
                vector = vmath.outputs["Vector"]
        if dimensions == "1D":
            split = tree.nodes.new("ShaderNodeSeparateXYZ")
            tree.links.new(vector, split.inputs[0])
            tree.links.new(split.outputs["X"], node.inputs["W"])
        else:
            tree.links.new(vector, node.inputs["Vector"])
        return node.outputs[output]
    return feed


def white_noise():
    """The White Noise Texture (issue 14, point 1): a random colour per cell of floored
    coordinates in 1D, 2D, 3D and 4D, its Value in 2D, noise per point on the raw
    coordinates and the Vector unlinked, on emitting cards seen head-on by an orthographic
    camera."""
    scene = bs.new_scene()
    cam = bs.camera(scene, "Camera", (0.0, -3.0, 0.0), 50.0, (224, 32))
    cam.data.type, cam.data.ortho_scale = "ORTHO", 4.0
    bs.black_world(scene)
    feeds = [_white_noise_feed("1D", cells=6.0), _white_noise_feed("2D", "Value", 5.0),
             _white_noise_feed("3D"), _white_noise_feed("4D", w=0.37, cells=4.0),
             _white_noise_feed("3D", cells=None), _white_noise_feed("3D", cells=0),
             _white_noise_feed("2D", cells=7.0)]
    for i, feed in enumerate(feeds):
        _glowing_card(f"WN{i}", (-2.0 + (i + 0.5) * 4.0 / 7, 0.0, 0.0), (0.5, 0.5), feed)


def _generated_axis(tree, axis="X"):
    """The card's Generated coordinate along `axis` (0 to 1 across it)."""
    split = tree.nodes.new("ShaderNodeSeparateXYZ")
    tree.links.new(tree.nodes.new("ShaderNodeTexCoord").outputs["Generated"], split.inputs[0])
    return split.outputs[axis]


def _map_range_feed(kind, clamp=True, steps=4.0, ends=(0.2, 0.7, 0.9, 0.1)):
    """A feed for _glowing_card: a float Map Range of `kind` of the card's x from
    ends[0]..ends[1] to ends[2]..ends[3] into a Combine Color's red, with its y as green."""
    def feed(tree):
        node = tree.nodes.new("ShaderNodeMapRange")
        node.interpolation_type, node.clamp = kind, clamp
        ins = {s.identifier: s for s in node.inputs}  # unavailable sockets too
        for name, v in zip(("From Min", "From Max", "To Min", "To Max", "Steps"),
                           ends + (steps,)):
            ins[name].default_value = v
        tree.links.new(_generated_axis(tree), ins["Value"])
        combine = tree.nodes.new("ShaderNodeCombineColor")
        tree.links.new(node.outputs["Result"], combine.inputs["Red"])
        tree.links.new(_generated_axis(tree, "Z"), combine.inputs["Green"])
        return combine.outputs["Color"]
    return feed


def _vector_map_range_feed(kind):
    """A feed: a vector Map Range of `kind` of the card's Generated coordinates, the source
    range linked (a Combine XYZ), clamped, steps per axis."""
    def feed(tree):
        node = tree.nodes.new("ShaderNodeMapRange")
        node.data_type, node.interpolation_type, node.clamp = "FLOAT_VECTOR", kind, True
        ins = {s.identifier: s for s in node.inputs}
        ins["To_Min_FLOAT3"].default_value = (0.9, 0.1, 0.3)
        ins["To_Max_FLOAT3"].default_value = (0.1, 0.8, 0.6)
        ins["Steps_FLOAT3"].default_value = (3.0, 5.0, 2.0)
        low = tree.nodes.new("ShaderNodeCombineXYZ")
        low.inputs["X"].default_value, low.inputs["Z"].default_value = 0.1, 0.3
        tree.links.new(low.outputs[0], ins["From_Min_FLOAT3"])
        # (y: the card's flat axis is Generated 1/2, which must not land on a step.)
        ins["From_Max_FLOAT3"].default_value = (0.8, 1.1, 0.9)
        tree.links.new(tree.nodes.new("ShaderNodeTexCoord").outputs["Generated"], ins["Vector"])
        return node.outputs["Vector"]
    return feed


def _clamp_feed(kind, low, high):
    """A feed: the card's x scaled to -0.5..1.5 clamped (Min Max or Range) as grey."""
    def feed(tree):
        scale = tree.nodes.new("ShaderNodeMath")
        scale.operation = "MULTIPLY_ADD"
        scale.inputs[1].default_value, scale.inputs[2].default_value = 2.0, -0.5
        tree.links.new(_generated_axis(tree), scale.inputs[0])
        node = tree.nodes.new("ShaderNodeClamp")
        node.clamp_type = kind
        node.inputs["Min"].default_value, node.inputs["Max"].default_value = low, high
        tree.links.new(scale.outputs[0], node.inputs["Value"])
        return node.outputs["Result"]
    return feed


def _curve_points(curve, points):
    """Set a curve map's points (its two defaults moved, more added)."""
    for p, (x, y) in zip(curve.points, points[:2]):
        p.location = (x, y)
    for x, y in points[2:]:
        curve.points.new(x, y)


def _curves_feed(kind, extend="EXTRAPOLATED"):
    """A feed: RGB Curves of a gradient (x, z, 1 - x: reaching past 1 on the card's x via a
    Multiply by 1.4) with a combined curve and per-channel curves, Vector Curves of the
    Generated coordinates times 2 minus 1, or a Float Curve of x as grey; extrapolated or
    horizontal beyond the curves' ends. Factor 0.85."""
    def feed(tree):
        node = tree.nodes.new({"RGB": "ShaderNodeRGBCurve", "VECTOR": "ShaderNodeVectorCurve",
                               "FLOAT": "ShaderNodeFloatCurve"}[kind])
        node.inputs[0].default_value = 0.85
        mapping = node.mapping
        mapping.extend = extend
        curves = list(mapping.curves)
        if kind == "RGB":
            _curve_points(curves[3], [(0.0, 0.1), (0.9, 1.0), (0.5, 0.7)])
            _curve_points(curves[0], [(0.0, 0.0), (1.0, 0.8), (0.3, 0.5)])
            _curve_points(curves[2], [(0.1, 0.3), (1.0, 0.6)])
            colour = tree.nodes.new("ShaderNodeCombineColor")
            stretch = tree.nodes.new("ShaderNodeMath")
            stretch.operation = "MULTIPLY"
            stretch.inputs[1].default_value = 1.4
            tree.links.new(_generated_axis(tree), stretch.inputs[0])
            tree.links.new(stretch.outputs[0], colour.inputs["Red"])
            tree.links.new(_generated_axis(tree, "Z"), colour.inputs["Green"])
            invert = tree.nodes.new("ShaderNodeMath")
            invert.operation = "SUBTRACT"
            invert.inputs[0].default_value = 1.0
            tree.links.new(_generated_axis(tree), invert.inputs[1])
            tree.links.new(invert.outputs[0], colour.inputs["Blue"])
            tree.links.new(colour.outputs[0], node.inputs["Color"])
            return node.outputs["Color"]
        if kind == "VECTOR":
            _curve_points(curves[0], [(-1.0, -0.5), (1.0, 0.9), (0.2, 0.6)])
            # (y, the card's flat axis, is 0: a curve through 0 there would leave rounding
            # crumbs of 1e-16 against Cycles' exact 0, which no noise estimate covers.)
            _curve_points(curves[1], [(-1.0, 0.2), (1.0, 0.7)])
            _curve_points(curves[2], [(-0.8, 1.0), (1.0, -0.2)])
            spread = tree.nodes.new("ShaderNodeVectorMath")
            spread.operation = "MULTIPLY_ADD"
            spread.inputs[1].default_value = (2.0, 2.0, 2.0)
            spread.inputs[2].default_value = (-1.0, -1.0, -1.0)
            tree.links.new(tree.nodes.new("ShaderNodeTexCoord").outputs["Generated"],
                           spread.inputs[0])
            tree.links.new(spread.outputs[0], node.inputs["Vector"])
            absolute = tree.nodes.new("ShaderNodeVectorMath")
            absolute.operation = "ABSOLUTE"
            tree.links.new(node.outputs["Vector"], absolute.inputs[0])
            return absolute.outputs[0]
        _curve_points(curves[0], [(0.1, 0.2), (0.8, 0.9), (0.4, 0.1)])
        tree.links.new(_generated_axis(tree), node.inputs["Value"])
        return node.outputs["Value"]
    return feed


def converter_nodes():
    """Map Range (float: every interpolation type, clamped or not, a reversed source range;
    vector: stepped and smoother step with a linked source range), Clamp (Min Max and a
    reversed Range), RGB Curves, Vector Curves and Float Curve (extrapolated, and
    horizontal past their ends) (issue 14, point 1), on emitting cards seen head-on by an
    orthographic camera."""
    scene = bs.new_scene()
    cam = bs.camera(scene, "Camera", (0.0, -3.0, 0.0), 50.0, (224, 64))
    cam.data.type, cam.data.ortho_scale = "ORTHO", 4.0
    bs.black_world(scene)
    # (Unclamped, the result stays positive: Cycles emits negative light, Specula none.)
    feeds = [_map_range_feed("LINEAR", clamp=False, ends=(0.3, 0.7, 0.3, 0.6)),
             _map_range_feed("LINEAR"),
             _map_range_feed("STEPPED", steps=3.0),
             _map_range_feed("SMOOTHSTEP", ends=(0.8, 0.3, 0.0, 1.0)),
             _map_range_feed("SMOOTHERSTEP"), _vector_map_range_feed("STEPPED"),
             _vector_map_range_feed("SMOOTHERSTEP"),
             _clamp_feed("MINMAX", 0.2, 0.8), _clamp_feed("RANGE", 0.9, 0.1),
             _curves_feed("RGB"), _curves_feed("RGB", "HORIZONTAL"), _curves_feed("VECTOR"),
             _curves_feed("FLOAT"), _curves_feed("FLOAT", "HORIZONTAL")]
    for i, feed in enumerate(feeds):
        row, col = divmod(i, 7)
        _glowing_card(f"C{i}", (-2.0 + (col + 0.5) * 4.0 / 7, 0.0, 0.28 - 0.56 * row),
                      (0.5, 0.5), feed)


def _brick_feed(output="Color", width_linked=False, **settings):
    """A feed for _glowing_card: a Brick Texture on the card's (x, z) as (x, y) (bricks lie
    in x and y) with `settings` (its properties and inputs by name); with `width_linked`,
    its Brick Width 0.3 + 0.4 x the card's x."""
    def feed(tree):
        node = tree.nodes.new("ShaderNodeTexBrick")
        plane = tree.nodes.new("ShaderNodeCombineXYZ")
        tree.links.new(_generated_axis(tree), plane.inputs["X"])
        tree.links.new(_generated_axis(tree, "Z"), plane.inputs["Y"])
        tree.links.new(plane.outputs[0], node.inputs["Vector"])
        node.inputs["Color1"].default_value = (0.8, 0.3, 0.1, 1.0)
        node.inputs["Color2"].default_value = (0.3, 0.6, 0.9, 1.0)
        node.inputs["Mortar"].default_value = (0.9, 0.9, 0.8, 1.0)
        node.inputs["Scale"].default_value = 3.0
        for key, value in settings.items():
            if key in node.inputs:
                node.inputs[key].default_value = value
            else:
                setattr(node, key, value)
        if width_linked:
            width = tree.nodes.new("ShaderNodeMath")
            width.operation = "MULTIPLY_ADD"
            width.inputs[1].default_value, width.inputs[2].default_value = 0.4, 0.3
            tree.links.new(_generated_axis(tree), width.inputs[0])
            tree.links.new(width.outputs[0], node.inputs["Brick Width"])
        return node.outputs[output]
    return feed


def _rotated_checker_feed(kind, invert=False, axis_linked=False):
    """A feed: a Checker Texture (scale 4) of the card's Generated coordinates less 1/2,
    turned by a Vector Rotate of `kind` about (0.1, 0, 0.1) (angle 0.6, Euler (0.3, 0.5,
    0.9)), inverted or not; with `axis_linked`, its Axis the coordinates themselves."""
    def feed(tree):
        centred = tree.nodes.new("ShaderNodeVectorMath")
        centred.operation = "SUBTRACT"
        centred.inputs[1].default_value = (0.5, 0.5, 0.5)
        tree.links.new(tree.nodes.new("ShaderNodeTexCoord").outputs["Generated"],
                       centred.inputs[0])
        node = tree.nodes.new("ShaderNodeVectorRotate")
        node.rotation_type, node.invert = kind, invert
        ins = {s.identifier: s for s in node.inputs}
        ins["Center"].default_value = (0.1, 0.0, 0.1)
        ins["Angle"].default_value = 0.6
        ins["Axis"].default_value = (0.3, 1.0, 0.2)
        ins["Rotation"].default_value = (0.3, 0.5, 0.9)
        tree.links.new(centred.outputs[0], ins["Vector"])
        if axis_linked:
            tree.links.new(centred.outputs[0], ins["Axis"])
        checker = tree.nodes.new("ShaderNodeTexChecker")
        checker.inputs["Scale"].default_value = 4.0
        checker.inputs["Color1"].default_value = (0.9, 0.6, 0.1, 1.0)
        checker.inputs["Color2"].default_value = (0.1, 0.3, 0.8, 1.0)
        tree.links.new(node.outputs["Vector"], checker.inputs["Vector"])
        return checker.outputs["Color"]
    return feed


def _grey_feed(tree):
    """A feed: RGB to BW of a colour gradient (the card's x, z and 1/2)."""
    combine = tree.nodes.new("ShaderNodeCombineColor")
    tree.links.new(_generated_axis(tree), combine.inputs["Red"])
    tree.links.new(_generated_axis(tree, "Z"), combine.inputs["Green"])
    combine.inputs["Blue"].default_value = 0.5
    grey = tree.nodes.new("ShaderNodeRGBToBW")
    tree.links.new(combine.outputs[0], grey.inputs["Color"])
    return grey.outputs["Val"]


def bricks_and_rotation():
    """Brick Textures (the default offset; squashed and offset rows with smoothed mortar
    and a bias; a linked brick width; the Fac output), Vector Rotate of every type
    (inverted or not, a linked axis) and RGB to BW (issue 14, point 1), on emitting cards
    seen head-on by an orthographic camera."""
    scene = bs.new_scene()
    cam = bs.camera(scene, "Camera", (0.0, -3.0, 0.0), 50.0, (224, 64))
    cam.data.type, cam.data.ortho_scale = "ORTHO", 4.0
    bs.black_world(scene)
    feeds = [_brick_feed(),
             _brick_feed(squash=0.6, squash_frequency=3, offset=0.25, offset_frequency=3,
                         **{"Mortar Smooth": 0.4, "Mortar Size": 0.04, "Bias": -0.3}),
             _brick_feed(width_linked=True, **{"Row Height": 0.2}),
             _brick_feed("Fac", **{"Mortar Smooth": 0.7, "Mortar Size": 0.05}),
             _grey_feed,
             _rotated_checker_feed("AXIS_ANGLE"),
             _rotated_checker_feed("AXIS_ANGLE", invert=True, axis_linked=True),
             _rotated_checker_feed("X_AXIS"), _rotated_checker_feed("Y_AXIS", invert=True),
             _rotated_checker_feed("Z_AXIS"), _rotated_checker_feed("EULER_XYZ"),
             _rotated_checker_feed("EULER_XYZ", invert=True)]
    for i, feed in enumerate(feeds):
        row, col = divmod(i, 7)
        _glowing_card(f"B{i}", (-2.0 + (col + 0.5) * 4.0 / 7, 0.0, 0.28 - 0.56 * row),
                      (0.5, 0.5), feed)


def _voronoi_feed(dimensions, feature="F1", metric="EUCLIDEAN", output="Color",
                  plane=False, w_linked=False, normalize=False, **inputs):
    """A feed for _glowing_card: a Voronoi Texture of `dimensions`, `feature` and distance
    `metric` (Scale 5 unless given) on the card's Generated coordinates (unlinked), or on
    its (x, z) with `plane`; its W 0.37, or the card's x with `w_linked`; `output` read,
    through Absolute where it is the Position (a point of a cell below 0) or Smooth F1's
    Distance (its smooth minimum dips below 0 near a point): negative light, which Cycles
    emits and Specula does not."""
    def feed(tree):
        node = tree.nodes.new("ShaderNodeTexVoronoi")
        node.voronoi_dimensions, node.feature, node.distance = dimensions, feature, metric
        node.normalize = normalize
        ins = {s.identifier: s for s in node.inputs}  # unavailable sockets too
        ins["Scale"].default_value, ins["W"].default_value = 5.0, 0.37
        for key, value in inputs.items():
            ins[key].default_value = value
        if plane:
            xz = tree.nodes.new("ShaderNodeCombineXYZ")
            tree.links.new(_generated_axis(tree), xz.inputs["X"])
            tree.links.new(_generated_axis(tree, "Z"), xz.inputs["Y"])
            tree.links.new(xz.outputs[0], ins["Vector"])
        if w_linked:
            tree.links.new(_generated_axis(tree), ins["W"])
        out = node.outputs[output]
        if output == "Position":
            absolute = tree.nodes.new("ShaderNodeVectorMath")
            absolute.operation = "ABSOLUTE"
            tree.links.new(out, absolute.inputs[0])
            out = absolute.outputs["Vector"]
        elif feature == "SMOOTH_F1" and output == "Distance":
            absolute = tree.nodes.new("ShaderNodeMath")
            absolute.operation = "ABSOLUTE"
            tree.links.new(out, absolute.inputs[0])
            out = absolute.outputs[0]
        return out
    return feed


def voronoi():
    """The Voronoi Texture (issue 14, point 1): F1, F2, Smooth F1, Distance to Edge and
    N-Sphere Radius in 1D to 4D, under every distance metric, with fractal octaves
    (whole and fractional Detail) and Normalize, each of its five outputs, on emitting
    cards seen head-on by an orthographic camera. (Generated y is 1/2 on a card: times
    Scale 5 it is 2.5, off the cells' edges.)"""
    scene = bs.new_scene()
    cam = bs.camera(scene, "Camera", (0.0, -3.0, 0.0), 50.0, (224, 64))
    cam.data.type, cam.data.ortho_scale = "ORTHO", 4.0
    bs.black_world(scene)
    feeds = [_voronoi_feed("3D"), _voronoi_feed("3D", output="Distance"),
             _voronoi_feed("2D", "F2", "MANHATTAN", "Distance", plane=True, normalize=True),
             _voronoi_feed("2D", "SMOOTH_F1", "CHEBYCHEV", plane=True, Smoothness=0.6),
             _voronoi_feed("3D", "F1", "MINKOWSKI", "Distance", Exponent=0.7, Detail=2.5,
                           Roughness=0.6),
             _voronoi_feed("3D", "DISTANCE_TO_EDGE", output="Distance", Detail=1.5),
             _voronoi_feed("3D", "N_SPHERE_RADIUS", output="Radius"),
             _voronoi_feed("1D", output="W", w_linked=True),
             _voronoi_feed("1D", "SMOOTH_F1", output="Distance", w_linked=True),
             _voronoi_feed("4D", "F2"),
             _voronoi_feed("4D", output="Position", Randomness=0.8),
             _voronoi_feed("2D", plane=True, normalize=True, Randomness=0.4, Detail=1.3),
             _voronoi_feed("2D", "DISTANCE_TO_EDGE", output="Distance", plane=True,
                           normalize=True, Randomness=0.7),
             _voronoi_feed("3D", "F2", "CHEBYCHEV", "Distance", normalize=True, Detail=1.0)]
    for i, feed in enumerate(feeds):
        row, col = divmod(i, 7)
        _glowing_card(f"V{i}", (-2.0 + (col + 0.5) * 4.0 / 7, 0.0, 0.28 - 0.56 * row),
                      (0.5, 0.5), feed)


def _ranged_feed(node_type, name, value, low, high):
    """A feed: the Color of a `node_type` node whose input `name` is `value`, or (None) the
    card's x mapped to low .. high."""
    def feed(tree):
        node = tree.nodes.new(node_type)
        if value is not None:
            node.inputs[name].default_value = value
            return node.outputs["Color"]
        ramp = tree.nodes.new("ShaderNodeMapRange")
        ramp.inputs["To Min"].default_value, ramp.inputs["To Max"].default_value = low, high
        tree.links.new(_generated_axis(tree), ramp.inputs["Value"])
        tree.links.new(ramp.outputs["Result"], node.inputs[name])
        return node.outputs["Color"]
    return feed


def _blackbody_feed(kelvin=None):
    """A feed: a Blackbody of `kelvin`, or of the card's x mapped to 500 .. 13000 K (below
    Cycles' 800 K floor, through each of its seven fitted bands, past its 12000 K end)."""
    return _ranged_feed("ShaderNodeBlackbody", "Temperature", kelvin, 500.0, 13000.0)


def _normal_node_feed(output="Dot", linked=True):
    """A feed: a Normal node of direction (0.3, -0.5, 0.8) (not of unit length); its Dot
    with the card's Object coordinates (or its own unlinked input) through Math Absolute,
    or its Normal output through Vector Math Absolute."""
    def feed(tree):
        node = tree.nodes.new("ShaderNodeNormal")
        node.outputs["Normal"].default_value = (0.3, -0.5, 0.8)
        node.inputs["Normal"].default_value = (0.6, 0.0, 0.8)
        if linked:
            tree.links.new(tree.nodes.new("ShaderNodeTexCoord").outputs["Object"],
                           node.inputs["Normal"])
        absolute = tree.nodes.new("ShaderNodeMath" if output == "Dot" else
                                  "ShaderNodeVectorMath")
        absolute.operation = "ABSOLUTE"
        tree.links.new(node.outputs[output], absolute.inputs[0])
        return absolute.outputs[0]
    return feed


def wavelength():
    """The Wavelength node (issue 14, point 1) over 350 .. 800 nm (black below 380 and from
    780 on in Cycles) and at 470, 550 and 610 nm, on emitting cards seen head-on by an
    orthographic camera."""
    scene = bs.new_scene()
    cam = bs.camera(scene, "Camera", (0.0, -3.0, 0.0), 50.0, (128, 32))
    cam.data.type, cam.data.ortho_scale = "ORTHO", 4.0
    bs.black_world(scene)
    feeds = [_ranged_feed("ShaderNodeWavelength", "Wavelength", nm, 350.0, 800.0)
             for nm in (None, 470.0, 550.0, 610.0)]
    for i, feed in enumerate(feeds):
        _glowing_card(f"L{i}", (-2.0 + (i + 0.5) * 4.0 / 4, 0.0, 0.0), (0.8, 0.8), feed)


def blackbody_and_normal():
    """The Blackbody node (issue 14, point 1) over 500 .. 13000 K and at 3200 K, and the
    Normal node's Dot (linked to the card's Object coordinates, and unlinked) and Normal
    outputs, on emitting cards seen head-on by an orthographic camera."""
    scene = bs.new_scene()
    cam = bs.camera(scene, "Camera", (0.0, -3.0, 0.0), 50.0, (224, 32))
    cam.data.type, cam.data.ortho_scale = "ORTHO", 4.0
    bs.black_world(scene)
    feeds = [_blackbody_feed(), _blackbody_feed(3200.0), _blackbody_feed(650.0),
             _normal_node_feed(), _normal_node_feed(linked=False),
             _normal_node_feed("Normal"), _blackbody_feed(20000.0)]
    for i, feed in enumerate(feeds):
        _glowing_card(f"K{i}", (-2.0 + (i + 0.5) * 4.0 / 7, 0.0, 0.0), (0.5, 0.5), feed)


# The attributes of the attribute cards' mesh: name -> (data type, domain, components).
CARD_ATTRIBUTES = {"height": ("FLOAT", "POINT", 1), "pair": ("FLOAT2", "CORNER", 2),
                   "facet": ("FLOAT_VECTOR", "FACE", 3), "paint": ("FLOAT_COLOR", "CORNER", 4),
                   "bytes": ("BYTE_COLOR", "POINT", 4), "ids": ("INT", "FACE", 1),
                   "flag": ("BOOLEAN", "POINT", 1)}


def _attribute_grid():
    """A 0.5 x 0.5 card of 4 x 4 quads (x, z) carrying CARD_ATTRIBUTES, seeded values in
    0.05 .. 1 (ids 0 .. 9, flags 0 or 1), and a UV map."""
    rng = np.random.default_rng(11)
    n = 4
    verts = [(-0.25 + 0.5 * i / n, 0.0, -0.25 + 0.5 * j / n)
             for j in range(n + 1) for i in range(n + 1)]
    faces = [(j * (n + 1) + i, j * (n + 1) + i + 1, (j + 1) * (n + 1) + i + 1,
              (j + 1) * (n + 1) + i) for j in range(n) for i in range(n)]
    mesh = bpy.data.meshes.new("AttributeGrid")
    mesh.from_pydata(verts, [], faces)
    mesh.uv_layers.new(name="UVMap")
    for name, (kind, domain, width) in CARD_ATTRIBUTES.items():
        attr = mesh.attributes.new(name, kind, domain)
        count = len(attr.data)
        if kind == "INT":
            attr.data.foreach_set("value", rng.integers(0, 10, count).astype(np.int32))
        elif kind == "BOOLEAN":
            attr.data.foreach_set("value", rng.integers(0, 2, count).astype(bool))
        else:
            key = {1: "value", 2: "vector", 3: "vector", 4: "color"}[width]
            attr.data.foreach_set(key, rng.uniform(0.05, 1.0, count * width).astype(
                np.float32))
    return mesh


def _attribute_card(name, centre, mesh, attribute, output, scale=1.0):
    """An emitting card of `mesh` (its own) whose colour is the Attribute node's `output` of
    `attribute` (times `scale`)."""
    mat = bs.material(name, "ShaderNodeEmission", Strength=1.0)
    tree = mat.node_tree
    node = tree.nodes.new("ShaderNodeAttribute")
    node.attribute_type, node.attribute_name = "GEOMETRY", attribute
    out = node.outputs[output]
    if scale != 1.0:
        times = tree.nodes.new("ShaderNodeMath")
        times.operation = "MULTIPLY"
        times.inputs[1].default_value = scale
        tree.links.new(out, times.inputs[0])
        out = times.outputs[0]
    emission = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeEmission")
    tree.links.new(out, emission.inputs["Color"])
    mesh.materials.append(mat)
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    obj.location = centre
    return obj


def attributes():
    """The Attribute node (issue 14, point 1) of type Geometry on a mesh with a float
    attribute on its points, a 2D one on corners, a vector per face, a float colour with
    alpha on corners, a byte colour on points, an integer per face and a boolean per point,
    and its UV map: Fac, Color, Vector and Alpha, each read as Cycles reads its type, on
    emitting cards seen head-on."""
    scene = bs.new_scene()
    cam = bs.camera(scene, "Camera", (0.0, -3.0, 0.0), 50.0, (224, 64))
    cam.data.type, cam.data.ortho_scale = "ORTHO", 4.0
    bs.black_world(scene)
    reads = [("height", "Fac", 1.0), ("pair", "Vector", 1.0), ("facet", "Color", 1.0),
             ("paint", "Color", 1.0), ("paint", "Alpha", 1.0), ("bytes", "Color", 1.0),
             ("ids", "Fac", 0.1), ("flag", "Fac", 1.0), ("facet", "Fac", 1.0),
             ("pair", "Fac", 1.0), ("UVMap", "Vector", 1.0), ("bytes", "Alpha", 1.0),
             ("height", "Color", 1.0), ("paint", "Fac", 1.0)]
    for i, (name, output, scale) in enumerate(reads):
        row, col = divmod(i, 7)
        mesh = _attribute_grid()
        _attribute_card(f"A{i}", (-2.0 + (col + 0.5) * 4.0 / 7, 0.0, 0.28 - 0.56 * row), mesh,
                        name, output, scale)


def _refraction(name, colour, roughness, ior=1.45):
    mat = bs.material(name, "ShaderNodeBsdfRefraction", Color=colour + (1.0,),
                      Roughness=roughness, IOR=ior)
    next(n for n in mat.node_tree.nodes
         if n.bl_idname == "ShaderNodeBsdfRefraction").distribution = "GGX"
    return mat


def refraction():
    """The Refraction BSDF (issue 14, points 1 and 2): no reflection, refraction without
    Fresnel; smooth and clear (IOR 1.45), rough (0.3) and tinted, and rough (0.6) at IOR
    1.3, on the box's floor under its light."""
    _box()
    _balls([_refraction("Clear", (1.0, 1.0, 1.0), 0.0),
            _refraction("Tinted", (0.6, 0.9, 0.8), 0.3),
            _refraction("Frosted", (1.0, 1.0, 1.0), 0.6, ior=1.3)])


def textured_glass():
    """Glass coloured by a Checker Texture (on Generated coordinates: warm and cool squares;
    issue 14, point 1): a smooth Glass BSDF, a rough (0.3) Principled glass (transmission
    tinted by the square root of its base colour) and a rough (0.2) Refraction BSDF."""
    _box()
    balls = [_glass("CheckerGlass", (1.0, 1.0, 1.0), 0.0),
             _principled("CheckerPrincipledGlass", **{"Roughness": 0.3, "IOR": 1.5,
                                                      "Transmission Weight": 1.0}),
             _refraction("CheckerRefraction", (1.0, 1.0, 1.0), 0.2)]
    for mat in balls:
        tree = mat.node_tree
        checker = tree.nodes.new("ShaderNodeTexChecker")
        checker.inputs["Color1"].default_value = (0.95, 0.55, 0.3, 1.0)
        checker.inputs["Color2"].default_value = (0.3, 0.6, 0.95, 1.0)
        checker.inputs["Scale"].default_value = 2.0
        node = next(n for n in tree.nodes if "Color" in n.inputs or "Base Color" in n.inputs)
        tree.links.new(checker.outputs["Color"],
                       node.inputs["Base Color" if "Base Color" in node.inputs else "Color"])
    _balls(balls)


def coat():
    """The Principled BSDF's coat (issue 14, point 1): a smooth clear coat over a red
    Principled, a tinted coat of IOR 1.8 and weight 0.7 over rough gold metal, and a coat
    of IOR 2.2 whose weight is a Checker Texture (1 and 0 on Generated coordinates) over
    a dark blue Principled without a specular layer (Specular IOR Level 0), on the box's
    floor under its light."""
    _box()
    red = _principled("Lacquer", **{"Base Color": (0.6, 0.05, 0.03, 1.0), "Roughness": 0.5,
                                    "Coat Weight": 1.0, "Coat Roughness": 0.03})
    gold = _principled("TintedCoat", **{
        "Base Color": (1.0, 0.75, 0.35, 1.0), "Metallic": 1.0, "Roughness": 0.4,
        "Coat Weight": 0.7, "Coat IOR": 1.8, "Coat Roughness": 0.1,
        "Coat Tint": (0.5, 0.8, 1.0, 1.0)})
    blue = _principled("PatchyCoat", **{"Base Color": (0.02, 0.03, 0.1, 1.0), "Roughness": 1.0,
                                        "Specular IOR Level": 0.0, "Coat Roughness": 0.1,
                                        "Coat IOR": 2.2})
    checker = blue.node_tree.nodes.new("ShaderNodeTexChecker")
    checker.inputs["Color1"].default_value = (1.0, 1.0, 1.0, 1.0)
    checker.inputs["Color2"].default_value = (0.0, 0.0, 0.0, 1.0)
    checker.inputs["Scale"].default_value = 3.0
    node = next(n for n in blue.node_tree.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled")
    blue.node_tree.links.new(checker.outputs["Color"], node.inputs["Coat Weight"])
    _balls([red, gold, blue])


def coat_rough():
    """Rough coats (issue 14, point 1), where Cycles 5 compensates the coat's energy and
    dims what is below by its estimate of the coat's albedo, not the smooth Fresnel: a
    clear coat of roughness 0.6 over smooth pale metal, a coat of roughness 0.8 (weight
    0.8, IOR 1.6) over a red Principled, and a tinted coat of roughness 0.45 (weight 0.7)
    over smooth gold."""
    _box()
    mirror = _principled("RoughCoatMirror", **{
        "Base Color": (0.95, 0.93, 0.88, 1.0), "Metallic": 1.0, "Roughness": 0.0,
        "Coat Weight": 1.0, "Coat Roughness": 0.6})
    red = _principled("SatinRed", **{"Base Color": (0.7, 0.08, 0.05, 1.0), "Roughness": 0.5,
                                     "Coat Weight": 0.8, "Coat Roughness": 0.8,
                                     "Coat IOR": 1.6})
    gold = _principled("TintedRoughCoatGold", **{
        "Base Color": (1.0, 0.75, 0.35, 1.0), "Metallic": 1.0, "Roughness": 0.0,
        "Coat Weight": 0.7, "Coat Roughness": 0.45, "Coat Tint": (0.6, 0.85, 1.0, 1.0)})
    _balls([mirror, red, gold])


def coat_furnace():
    """Rough coats in a white furnace (a world of radiance 1 and nothing else), quiet enough
    to show the coat lobe's energy compensation (Cycles 5 compensates coats; 1-3% of the
    lobe at these roughnesses): a coat of roughness 0.8 over a black Principled without a
    specular layer (all its light is the coat's) and a coat of roughness 0.6 over smooth
    white metal (what the coat leaves of the mirror, 1 - A, plus the coat's albedo)."""
    scene = bs.new_scene()
    bs.camera(scene, "Camera", (0.0, -3.0, 0.75), bs.CBSPHERES_LENS, (64, 48))
    bs.black_world(scene)
    background = next(n for n in scene.world.node_tree.nodes
                      if n.bl_idname == "ShaderNodeBackground")
    background.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    black = _principled("CoatOverBlack", **{
        "Base Color": (0.0, 0.0, 0.0, 1.0), "Specular IOR Level": 0.0, "Coat Weight": 1.0,
        "Coat Roughness": 0.8})
    mirror = _principled("CoatOverMirror", **{
        "Base Color": (1.0, 1.0, 1.0, 1.0), "Metallic": 1.0, "Roughness": 0.0,
        "Coat Weight": 1.0, "Coat Roughness": 0.6})
    _sphere(black, (-0.45, 0.0, 0.75), 0.4, "Ball0")
    _sphere(mirror, (0.45, 0.0, 0.75), 0.4, "Ball1")


def sheen():
    """Microfiber sheen (issue 14, point 1): a Principled sheen (roughness 0.3) over a dark
    red base, a tinted sheen (0.8 weight, roughness 0.8) over a coat over dark blue, and a
    Sheen BSDF alone (roughness 0.5), on the box's floor under its light: the velvet rims
    the sheen's grazing lobe makes."""
    _box()
    red = _principled("Velvet", **{"Base Color": (0.25, 0.02, 0.03, 1.0), "Roughness": 0.8,
                                   "Sheen Weight": 1.0, "Sheen Roughness": 0.3})
    blue = _principled("SheenOverCoat", **{
        "Base Color": (0.02, 0.03, 0.15, 1.0), "Roughness": 0.6, "Sheen Weight": 0.8,
        "Sheen Roughness": 0.8, "Sheen Tint": (1.0, 0.8, 0.6, 1.0), "Coat Weight": 0.5,
        "Coat Roughness": 0.2})
    dust = bs.material("Dust", "ShaderNodeBsdfSheen", Color=(0.9, 0.9, 0.9, 1.0),
                       Roughness=0.5)
    _balls([red, blue, dust])


def translucency():
    """The Translucent BSDF (issue 14, point 1): a greenish translucent card under the
    ceiling light, lighting the floor below it through itself and seen from below, and a
    leaf-like ball mixing a Diffuse and a Translucent BSDF (0.5)."""
    _box()
    col = bpy.context.scene.collection
    leaf = bs.material("Leaf", "ShaderNodeBsdfTranslucent", Color=(0.4, 0.8, 0.2, 1.0))
    card = bs.quad("Leaf", [(-0.4, -0.4, 0.0), (0.4, -0.4, 0.0), (0.4, 0.4, 0.0),
                            (-0.4, 0.4, 0.0)], leaf, col)
    card.location = (-0.3, 0.2, 1.05)
    _sphere(_mix_of("Foliage", "ShaderNodeMixShader",
                    ("ShaderNodeBsdfDiffuse", {"Color": (0.3, 0.6, 0.2, 1.0)}),
                    ("ShaderNodeBsdfTranslucent", {"Color": (0.8, 0.9, 0.3, 1.0)}), fac=0.5),
            (0.45, -0.1, 0.3), 0.3, "Foliage")


def _light_path_colour(mat):
    """`mat`'s Diffuse Color made of its ray's Light Path outputs: red, 0.3 x Ray Length
    for camera rays (0 for others); green, Is Glossy Ray (seen in a mirror or through
    glass); blue, 0.35 x Ray Depth; each clamped to [0, 1], plus 0.1 grey."""
    tree = mat.node_tree
    path = tree.nodes.new("ShaderNodeLightPath")
    diffuse = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfDiffuse")
    combine = tree.nodes.new("ShaderNodeCombineColor")

    def math(operation, a, b):
        node = tree.nodes.new("ShaderNodeMath")
        node.operation, node.use_clamp = operation, True
        for sock, value in zip(node.inputs, (a, b)):
            if isinstance(value, float):
                sock.default_value = value
            else:
                tree.links.new(value, sock)
        return node.outputs[0]

    length = math("MULTIPLY", path.outputs["Ray Length"], 0.3)
    channels = (math("MULTIPLY", length, path.outputs["Is Camera Ray"]),
                path.outputs["Is Glossy Ray"], math("MULTIPLY", path.outputs["Ray Depth"], 0.35))
    for channel, sock in zip(channels, combine.inputs):
        tree.links.new(math("ADD", channel, 0.1), sock)
    tree.links.new(combine.outputs[0], diffuse.inputs["Color"])
    return mat


def light_path():
    """The Light Path node (issue 14, point 1) as scenes use it: an orange emitter the
    camera sees through (a Mix Shader of Emission and Transparent by Is Camera Ray) lighting
    the box from the front left; a glass ball whose shadow rays pass (Is Shadow Ray mixes
    in a Transparent BSDF: the classic light-shadow trick); a mirror ball; and a cube
    whose colour is made of Is Camera Ray, Ray Length, Is Glossy Ray and Ray Depth, seen
    directly, in the mirror and through the glass."""
    _box()
    col = bpy.context.scene.collection
    hidden = _view_factor(_mix_of("Hidden", "ShaderNodeMixShader",
                                  ("ShaderNodeEmission", {"Color": (1.0, 0.5, 0.2, 1.0),
                                                          "Strength": 6.0}),
                                  ("ShaderNodeBsdfTransparent", {})),
                          "ShaderNodeLightPath", "Is Camera Ray")
    bs.quad("Hidden", [(-0.9, -0.4, 0.45), (-0.45, -0.4, 0.45), (-0.45, -0.4, 0.9),
                       (-0.9, -0.4, 0.9)], hidden, col)
    glass = _view_factor(_mix_of("ShadowlessGlass", "ShaderNodeMixShader",
                                 ("ShaderNodeBsdfGlass", {"IOR": 1.5, "Roughness": 0.0}),
                                 ("ShaderNodeBsdfTransparent", {})),
                         "ShaderNodeLightPath", "Is Shadow Ray")
    _sphere(glass, (-0.4, 0.25, 0.3), 0.3, "Glass")
    _sphere(bs.material("Mirror", "ShaderNodeBsdfGlossy", Roughness=0.0), (0.5, 0.4, 0.3), 0.3,
            "Mirror")
    _cube("Paths", (0.25, -0.35, 0.15), (0.3, 0.3, 0.3),
          _light_path_colour(bs.diffuse("PathColour", (0.5, 0.5, 0.5))))


def _unit_checker(tree, scale):
    """A Checker Texture of 1 and 0 at `scale` on Object coordinates: (its Fac output, the
    Texture Coordinate node)."""
    checker = tree.nodes.new("ShaderNodeTexChecker")
    checker.inputs["Scale"].default_value = scale
    checker.inputs["Color1"].default_value = (1.0, 1.0, 1.0, 1.0)
    checker.inputs["Color2"].default_value = (0.0, 0.0, 0.0, 1.0)
    coords = tree.nodes.new("ShaderNodeTexCoord")
    tree.links.new(coords.outputs["Object"], checker.inputs["Vector"])
    return checker.outputs["Fac"], coords


def oren_nayar():
    """The Diffuse BSDF's Roughness (Cycles' Oren-Nayar with its multiple-scattering term):
    balls of roughness 1 (white, lit by the ceiling and by an emitter high on the front
    left, toward which rough surfaces glow) and 0.5 (orange), and
    a grey cube whose roughness is a Checker Texture's (0 and 1); and the Principled
    BSDF's Diffuse Roughness on a blue ball (1, and a Checker's 0 and 1 on its lower
    half) under its rough specular layer."""
    _box()
    _emitter_quad("Front", (-0.7, -0.95, 1.25), 0.25, 16.0)
    white = bs.material("RoughWhite", "ShaderNodeBsdfDiffuse", Color=(0.9, 0.9, 0.9, 1.0),
                        Roughness=1.0)
    _sphere(white, (-0.45, 0.2, 0.35), 0.35, "RoughWhite")
    orange = bs.material("RoughOrange", "ShaderNodeBsdfDiffuse", Color=(0.9, 0.45, 0.1, 1.0),
                         Roughness=0.5)
    _sphere(orange, (0.5, 0.35, 0.3), 0.3, "RoughOrange")
    grey = bs.material("Checked", "ShaderNodeBsdfDiffuse", Color=(0.7, 0.7, 0.7, 1.0))
    tree = grey.node_tree
    diffuse = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfDiffuse")
    tree.links.new(_unit_checker(tree, 3.0)[0], diffuse.inputs["Roughness"])
    _cube("Checked", (0.2, -0.3, 0.2), (0.4, 0.4, 0.4), grey)
    blue = _principled("RoughBase", **{"Base Color": (0.2, 0.45, 0.9, 1.0), "Roughness": 0.4})
    tree = blue.node_tree
    fac, coords = _unit_checker(tree, 4.0)
    below = tree.nodes.new("ShaderNodeMath")  # 1 above the ball's equator, the checker below
    below.operation = "GREATER_THAN"
    separate = tree.nodes.new("ShaderNodeSeparateXYZ")
    tree.links.new(coords.outputs["Object"], separate.inputs[0])
    tree.links.new(separate.outputs["Z"], below.inputs[0])
    below.inputs[1].default_value = 0.0
    top = tree.nodes.new("ShaderNodeMath")
    top.operation, top.use_clamp = "ADD", True
    tree.links.new(below.outputs[0], top.inputs[0])
    tree.links.new(fac, top.inputs[1])
    principled = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled")
    tree.links.new(top.outputs[0], principled.inputs["Diffuse Roughness"])
    _sphere(blue, (-0.5, -0.45, 0.22), 0.22, "RoughBase")


def anisotropic():
    """Anisotropic GGX (issue 14, point 1: the Principled BSDF's Anisotropic, Anisotropic
    Rotation and Tangent; the Glossy BSDF's Anisotropy and Rotation): a gold Principled
    metal ball, Anisotropic 0.9 on the default tangent (radial about its own z, the ball
    tipped 0.5 rad about x); a Glossy ball of Anisotropy -0.7 (the other convention),
    Rotation 0.25, squashed along z (tangents turn as normals do); and a green Principled
    cube, turned about z, whose Anisotropic is a Checker's 0 and 1, turned by 0.125 about
    a Tangent node's radial x direction; and a silver Principled ball whose Tangent is its
    UV map's (a Tangent node; u runs along its meridians), tipped 0.8 rad about y. An
    emitter above the camera's view, in front of the box, draws the highlights out."""
    _box()
    _emitter_quad("Front", (-0.4, -1.6, 1.4), 0.4, 12.0, (-math.pi / 3, 0.0, 0.0))
    gold = _principled("BrushedGold", **{"Base Color": (0.9, 0.6, 0.2, 1.0), "Metallic": 1.0,
                                         "Roughness": 0.4, "Anisotropic": 0.9})
    ball = _sphere(gold, (-0.5, 0.25, 0.35), 0.35, "BrushedGold")
    ball.rotation_euler = (0.5, 0.0, 0.0)
    glossy = bs.material("Streaked", "ShaderNodeBsdfGlossy", Color=(0.8, 0.85, 0.9, 1.0),
                         Roughness=0.5, Anisotropy=-0.7, Rotation=0.25)
    squashed = _sphere(glossy, (0.55, 0.1, 0.3), 0.3, "Streaked")
    squashed.scale = (1.0, 1.0, 0.7)
    green = _principled("Checked", **{"Base Color": (0.15, 0.5, 0.25, 1.0), "Roughness": 0.3,
                                      "Anisotropic Rotation": 0.125})
    tree = green.node_tree
    principled = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled")
    tree.links.new(_unit_checker(tree, 3.0)[0], principled.inputs["Anisotropic"])
    tangent = tree.nodes.new("ShaderNodeTangent")
    tangent.direction_type, tangent.axis = "RADIAL", "X"
    tree.links.new(tangent.outputs["Tangent"], principled.inputs["Tangent"])
    cube = _cube("Checked", (-0.05, -0.45, 0.17), (0.34, 0.34, 0.34), green)
    cube.rotation_euler = (0.0, 0.0, 0.5)
    silver = _principled("Mapped", **{"Base Color": (0.8, 0.8, 0.85, 1.0), "Metallic": 1.0,
                                      "Roughness": 0.35, "Anisotropic": 0.8})
    tree = silver.node_tree
    tangent = tree.nodes.new("ShaderNodeTangent")
    tangent.direction_type, tangent.uv_map = "UV_MAP", "UVMap"
    tree.links.new(tangent.outputs["Tangent"], next(
        n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled").inputs["Tangent"])
    mesh = bpy.data.meshes.new("Mapped")
    bm = bmesh.new()
    bm.loops.layers.uv.new("UVMap")
    bmesh.ops.create_uvsphere(bm, u_segments=48, v_segments=24, radius=0.17, calc_uvs=True)
    uv = bm.loops.layers.uv["UVMap"]
    for face in bm.faces:  # u along the meridians: its tangents are not the radial ones
        face.smooth = True
        for loop in face.loops:
            loop[uv].uv = (loop[uv].uv[1], loop[uv].uv[0])
    bm.to_mesh(mesh)
    bm.free()
    mapped = bpy.data.objects.new("Mapped", mesh)
    mapped.location, mapped.rotation_euler = (0.55, -0.55, 0.17), (0.0, 0.8, 0.0)
    mapped.data.materials.append(silver)
    bpy.context.scene.collection.objects.link(mapped)


def metallic_bsdf():
    """The Metallic BSDF (issue 14, point 2: rough metal as Cycles renders it): a rough
    copper ball, anisotropic, whose Edge Tint is a Checker of green and white; a smooth
    pale ball of a strong blue Edge Tint (the delta metal); and a rough Physical Conductor
    of the node's default IOR and Extinction (rendered as Cycles' F82 fit of it). An
    emitter above the camera's view, in front of the box, lights their grazing rims."""
    _box()
    _emitter_quad("Front", (0.0, -1.6, 1.4), 0.5, 12.0, (-math.pi / 3, 0.0, 0.0))
    copper = bs.material("Copper", "ShaderNodeBsdfMetallic",
                         **{"Base Color": (0.95, 0.64, 0.54, 1.0), "Roughness": 0.25,
                            "Anisotropy": 0.6, "Rotation": 0.1})
    tree = copper.node_tree
    checker = tree.nodes.new("ShaderNodeTexChecker")
    checker.inputs["Scale"].default_value = 4.0
    checker.inputs["Color1"].default_value = (0.2, 0.9, 0.3, 1.0)
    checker.inputs["Color2"].default_value = (1.0, 1.0, 1.0, 1.0)
    metal = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfMetallic")
    tree.links.new(checker.outputs["Color"], metal.inputs["Edge Tint"])
    _sphere(copper, (-0.5, 0.2, 0.33), 0.33, "Copper")
    pale = bs.material("Pale", "ShaderNodeBsdfMetallic",
                       **{"Base Color": (0.9, 0.9, 0.85, 1.0), "Edge Tint": (0.1, 0.3, 1.0, 1.0),
                          "Roughness": 0.0})
    _sphere(pale, (0.5, 0.2, 0.3), 0.3, "Pale")
    conductor = bs.material("Conductor", "ShaderNodeBsdfMetallic", Roughness=0.3)
    next(n for n in conductor.node_tree.nodes
         if n.bl_idname == "ShaderNodeBsdfMetallic").fresnel_type = "PHYSICAL_CONDUCTOR"
    _sphere(conductor, (0.0, -0.45, 0.22), 0.22, "Conductor")


def falloff_and_camera_data():
    """Light Falloff and Camera Data (issue 14, point 1): an Emission card on the back wall
    whose Strength is a Light Falloff's Linear output (Strength 1.2, Smooth 0.5: brighter
    with the ray's length, the camera's and a light sample's alike); a Diffuse ball coloured
    by the Camera Data's View Vector (its absolute value) and a cube by its View Z Depth
    and by how much its View Distance exceeds it (scaled into colours)."""
    _box()
    card = bs.material("Fading", "ShaderNodeEmission", Color=(1.0, 0.9, 0.7, 1.0))
    tree = card.node_tree
    falloff = tree.nodes.new("ShaderNodeLightFalloff")
    falloff.inputs["Strength"].default_value = 1.2
    falloff.inputs["Smooth"].default_value = 0.5
    tree.links.new(falloff.outputs["Linear"], next(
        n for n in tree.nodes if n.bl_idname == "ShaderNodeEmission").inputs["Strength"])
    _card("Fading", (0.0, 0.95, 0.8), (0.8, 0.5), card)
    viewed = bs.material("Viewed", "ShaderNodeBsdfDiffuse")
    tree = viewed.node_tree
    view = tree.nodes.new("ShaderNodeCameraData")
    absolute = tree.nodes.new("ShaderNodeVectorMath")
    absolute.operation = "ABSOLUTE"
    tree.links.new(view.outputs["View Vector"], absolute.inputs[0])
    tree.links.new(absolute.outputs[0], next(
        n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfDiffuse").inputs["Color"])
    _sphere(viewed, (-0.45, 0.1, 0.3), 0.3, "Viewed")
    ranged = bs.material("Ranged", "ShaderNodeBsdfDiffuse")
    tree = ranged.node_tree
    view = tree.nodes.new("ShaderNodeCameraData")
    combine = tree.nodes.new("ShaderNodeCombineXYZ")
    off_axis = tree.nodes.new("ShaderNodeMath")  # distance less depth: 0 on the view axis
    off_axis.operation = "SUBTRACT"
    tree.links.new(view.outputs["View Distance"], off_axis.inputs[0])
    tree.links.new(view.outputs["View Z Depth"], off_axis.inputs[1])
    for socket, value, scale in ((0, off_axis.outputs[0], 4.0),
                                 (1, view.outputs["View Z Depth"], 0.25)):
        times = tree.nodes.new("ShaderNodeMath")
        times.operation = "MULTIPLY"
        times.inputs[1].default_value = scale
        tree.links.new(value, times.inputs[0])
        tree.links.new(times.outputs[0], combine.inputs[socket])
    combine.inputs[2].default_value = 0.3
    tree.links.new(combine.outputs[0], next(
        n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfDiffuse").inputs["Color"])
    cube = _cube("Ranged", (0.45, -0.1, 0.25), (0.3, 0.6, 0.5), ranged)
    cube.rotation_euler = (0.0, 0.0, 0.6)


def principled_ggx():
    """The Principled BSDF's GGX distribution (the default of files from before Blender
    4.0): no energy compensation on any lobe, the base under the dielectric taking what
    its single scattering leaves. Rough dielectric balls (roughness 0.7 on orange, 0.95 at
    IOR 2.2 on blue) and a rough metal half of Metallic 0.5."""
    _box()
    for name, centre, radius, inputs in (
            ("GGXOrange", (-0.45, 0.15, 0.35), 0.35,
             {"Base Color": (0.9, 0.45, 0.1, 1.0), "Roughness": 0.7}),
            ("GGXBlue", (0.45, 0.15, 0.35), 0.35,
             {"Base Color": (0.1, 0.25, 0.8, 1.0), "Roughness": 0.95, "IOR": 2.2}),
            ("GGXHalf", (0.0, -0.45, 0.22), 0.22,
             {"Base Color": (0.8, 0.8, 0.75, 1.0), "Roughness": 0.8, "Metallic": 0.5})):
        mat = _principled(name, **inputs)
        next(n for n in mat.node_tree.nodes
             if n.bl_idname == "ShaderNodeBsdfPrincipled").distribution = "GGX"
        _sphere(mat, centre, radius, name)


def specular_ior_textured():
    """A Principled BSDF's IOR and Specular IOR Level varying over the surface (issue 14,
    point 1: every input linkable; the glTF importer links KHR_materials_specular's texture
    to the level): a blue ball whose level is a Checker's 0.1 and 1 (F0 0.4 % and 8 %); a
    grey ball under an orange Specular Tint whose IOR is a Checker's 0.75 and 2.5 (both
    sides of 1); a white cube whose roughness is a Checker's 0.15 and 0.6 and whose level
    runs 0 to 2 along x (a Gradient Texture). An emitter in front of the box, above the
    camera's view, lights them at grazing angles, where the Fresnel turns."""
    _box()
    _emitter_quad("Front", (-0.4, -1.6, 1.4), 0.4, 12.0, (-math.pi / 3, 0.0, 0.0))

    def driven(name, inputs, socket, scale, offset, source=None):
        mat = _principled(name, **inputs)
        tree = mat.node_tree
        fac = source(tree) if source else _unit_checker(tree, 4.0)[0]
        affine = tree.nodes.new("ShaderNodeMath")
        affine.operation = "MULTIPLY_ADD"
        tree.links.new(fac, affine.inputs[0])
        affine.inputs[1].default_value, affine.inputs[2].default_value = scale, offset
        principled = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled")
        tree.links.new(affine.outputs[0], principled.inputs[socket])
        return mat, tree, principled

    blue, _, _ = driven("LevelChecked", {"Base Color": (0.2, 0.35, 0.7, 1.0),
                                         "Roughness": 0.25}, "Specular IOR Level", 0.9, 0.1)
    _sphere(blue, (-0.45, 0.2, 0.35), 0.35, "LevelChecked")
    grey, _, _ = driven("IorChecked", {"Base Color": (0.35, 0.35, 0.35, 1.0), "Roughness": 0.3,
                                       "Specular Tint": (1.0, 0.6, 0.3, 1.0)}, "IOR", 1.75, 0.75)
    _sphere(grey, (0.5, 0.3, 0.3), 0.3, "IorChecked")

    def gradient(tree):
        g = tree.nodes.new("ShaderNodeTexGradient")
        coords = tree.nodes.new("ShaderNodeTexCoord")
        tree.links.new(coords.outputs["Generated"], g.inputs["Vector"])
        return g.outputs["Fac"]

    white, tree, principled = driven("LevelRamp", {"Base Color": (0.8, 0.8, 0.8, 1.0)},
                                     "Specular IOR Level", 2.0, 0.0, gradient)
    rough = tree.nodes.new("ShaderNodeMath")
    rough.operation = "MULTIPLY_ADD"
    tree.links.new(_unit_checker(tree, 3.0)[0], rough.inputs[0])
    rough.inputs[1].default_value, rough.inputs[2].default_value = 0.45, 0.15
    tree.links.new(rough.outputs[0], principled.inputs["Roughness"])
    cube = _cube("LevelRamp", (0.0, -0.4, 0.17), (0.34, 0.34, 0.34), white)
    cube.rotation_euler = (0.0, 0.0, 0.5)


def emission_strength_texture():
    """Emission Strength from textures (issue 14, point 1): an Emission card on the back
    wall whose Strength is a Checker Texture's Fac (0 and 1, times 3 by a Math node), and a
    Principled ball whose Emission Strength is a Checker's colour (its luminance) under an
    orange Emission Color."""
    _box()
    card = bs.material("Sign", "ShaderNodeEmission", Color=(0.9, 0.9, 1.0, 1.0))
    tree = card.node_tree
    checker = tree.nodes.new("ShaderNodeTexChecker")
    checker.inputs["Scale"].default_value = 4.0
    tree.links.new(tree.nodes.new("ShaderNodeTexCoord").outputs["UV"], checker.inputs["Vector"])
    times = tree.nodes.new("ShaderNodeMath")
    times.operation = "MULTIPLY"
    times.inputs[1].default_value = 3.0
    tree.links.new(checker.outputs["Fac"], times.inputs[0])
    tree.links.new(times.outputs[0], next(
        n for n in tree.nodes if n.bl_idname == "ShaderNodeEmission").inputs["Strength"])
    sign = _card("Sign", (0.0, 0.95, 0.8), (0.8, 0.5), card)
    _quad_uvs(sign)
    ball = _principled("Lantern", **{"Base Color": (0.2, 0.2, 0.2, 1.0),
                                     "Emission Color": (1.0, 0.5, 0.1, 1.0)})
    tree = ball.node_tree
    checker = tree.nodes.new("ShaderNodeTexChecker")
    checker.inputs["Color1"].default_value = (2.0, 2.0, 2.0, 1.0)
    checker.inputs["Color2"].default_value = (0.2, 0.2, 0.2, 1.0)
    checker.inputs["Scale"].default_value = 3.0
    tree.links.new(tree.nodes.new("ShaderNodeTexCoord").outputs["UV"], checker.inputs["Vector"])
    tree.links.new(checker.outputs["Color"], next(
        n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled"
    ).inputs["Emission Strength"])
    obj = bpy.data.objects.new("Lantern", _uv_sphere_mesh("Lantern", 0.25))
    obj.location = (0.4, -0.1, 0.25)
    obj.data.materials.append(ball)
    bpy.context.scene.collection.objects.link(obj)


def mixed_shaders():
    """Mixed closures (issue 14, point 1): a Mix Shader of a red Diffuse and a rough Glossy,
    an Add Shader of a dark Diffuse and a faint Glossy, and Principled BSDFs with a
    Checker Texture's Metallic (1 and 0.3 in squares: a mix whose factor is evaluated at
    each hit) and at Transmission 0.5 (Cycles mixes the lobes linearly)."""
    _box()
    for i, mat in enumerate([
            _mix_of("MixDG", "ShaderNodeMixShader",
                    ("ShaderNodeBsdfDiffuse", {"Color": (0.8, 0.1, 0.1, 1.0)}),
                    ("ShaderNodeBsdfGlossy", {"Color": (1.0, 1.0, 1.0, 1.0), "Roughness": 0.3}),
                    fac=0.4),
            _mix_of("AddDG", "ShaderNodeAddShader",
                    ("ShaderNodeBsdfDiffuse", {"Color": (0.1, 0.3, 0.5, 1.0)}),
                    ("ShaderNodeBsdfGlossy", {"Color": (0.4, 0.4, 0.4, 1.0), "Roughness": 0.15})),
            _checker_metallic(_principled("HalfMetal", **{"Base Color": (0.9, 0.6, 0.3, 1.0),
                                                          "Roughness": 0.3})),
            _principled("HalfGlass", **{"Base Color": (0.8, 0.9, 1.0, 1.0), "Roughness": 0.0,
                                        "Transmission Weight": 0.5})]):
        # UV spheres: the checker reads the UV map (without one it would read (0, 0)).
        obj = bpy.data.objects.new(f"Ball{i}", _uv_sphere_mesh(f"Ball{i}", 0.2))
        obj.location = (-0.66 + 0.44 * i, 0.0, 0.2)
        obj.data.materials.append(mat)
        bpy.context.scene.collection.objects.link(obj)


def _low_poly_sphere(name, centre, radius, mat, segments=10):
    """A smooth-shaded UV sphere coarse enough that its terminator shows the facets."""
    import bmesh
    mesh = bpy.data.meshes.new(name)
    bm = bmesh.new()
    bmesh.ops.create_uvsphere(bm, u_segments=segments, v_segments=segments // 2,
                              radius=radius)
    for face in bm.faces:
        face.smooth = True
    bm.to_mesh(mesh)
    bm.free()
    obj = bpy.data.objects.new(name, mesh)
    obj.location = centre
    obj.data.materials.append(mat)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def _terminator_balls(offsets, light_kind, **props):
    """Two coarse smooth spheres lit from the side, with the given shadow terminator
    geometry offsets (None: Blender's default, 0.1, as the object has it)."""
    _box(emitter=False)
    mat = bs.diffuse("Matte", (0.8, 0.8, 0.8))
    for i, offset in enumerate(offsets):
        # 1 cm above the floor: where a coarse sphere's pole touches it, Cycles leaks a
        # little light into the contact (~0.003 in both seeds where Specula is exactly 0).
        obj = _low_poly_sphere(f"Ball{i}", (-0.42 + 0.84 * i, -0.1, 0.37), 0.36, mat)
        if offset is not None:
            obj.shadow_terminator_geometry_offset = offset
    light = bpy.data.lights.new("Side", light_kind)
    for key, value in props.items():
        setattr(light, key, value)
    # From the upper left, at right angles to the view, so the terminator runs across each
    # sphere's visible face.
    obj = bpy.data.objects.new("Side", light)
    obj.location = (-0.9, -0.1, 1.3)
    obj.rotation_euler = (0.0, math.radians(-45.0), 0.0)
    bpy.context.scene.collection.objects.link(obj)


def terminator_point():
    _terminator_balls((None, 1.0), "POINT", energy=40.0, shadow_soft_size=0.0)


def terminator_area():
    _terminator_balls((0.0, 0.5), "AREA", energy=40.0, shape="SQUARE", size=0.3)


def caustic_quad():
    """CBspheres lit by a 0.4 x 0.4 quad at height 1.2 instead of its ceiling light (the
    same power): the caustics under the glass sphere and from the mirror sphere are lit
    through specular chains from a light path tracing hits rarely; Specula traces light
    paths for them (engine/caustics.py). The quad is large enough for Cycles' unbiased
    path tracing to converge on them at the reference's samples."""
    _open("cbspheres.blend")
    bpy.data.objects.remove(bpy.data.objects["Emitter"])
    _emitter_quad("SmallEmitter", (0.0, 0.0, 1.2), 0.4, 10.0 * 0.48 / 0.16, rotation=(0, 0, 0))
    bpy.context.scene.specula.use_light_tracing = True


def caustic_area_light():
    """caustic_quad with a Blender area light of the same size facing down in place of the
    quad (the same power toward the floor): light paths start on light objects too."""
    _open("cbspheres.blend")
    bpy.data.objects.remove(bpy.data.objects["Emitter"])
    light = bpy.data.lights.new("Panel", "AREA")
    light.shape, light.size = "SQUARE", 0.4
    light.energy = 10.0 * 0.48 / 0.16 * math.pi * 0.16  # P = pi A L
    obj = bpy.data.objects.new("Panel", light)
    obj.location = (0.0, 0.0, 1.2)
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.scene.specula.use_light_tracing = True


def caustic_point_light():
    """caustic_quad with a point light of radius 0.2 (Soft Falloff on, Blender's default:
    a disk facing each point it lights) at the quad's place, about as bright."""
    _open("cbspheres.blend")
    bpy.data.objects.remove(bpy.data.objects["Emitter"])
    light = bpy.data.lights.new("Bulb", "POINT")
    light.energy, light.shadow_soft_size, light.use_soft_falloff = 30.0, 0.2, True
    obj = bpy.data.objects.new("Bulb", light)
    obj.location = (0.0, 0.0, 1.2)
    bpy.context.scene.collection.objects.link(obj)


def caustic_spot():
    """CBspheres lit by a 70-degree spot light of radius 0.15 with Soft Falloff off (a
    sphere), above the glass sphere and aimed at it."""
    _open("cbspheres.blend")
    bpy.data.objects.remove(bpy.data.objects["Emitter"])
    light = bpy.data.lights.new("Spot", "SPOT")
    light.energy, light.shadow_soft_size, light.use_soft_falloff = 60.0, 0.15, False
    light.spot_size, light.spot_blend = math.radians(70.0), 0.15
    obj = bpy.data.objects.new("Spot", light)
    obj.location = (0.3, -0.3, 1.3)
    look = mathutils.Vector((0.5, -0.25, 0.3)) - obj.location
    obj.rotation_euler = look.to_track_quat("-Z", "Y").to_euler()
    bpy.context.scene.collection.objects.link(obj)


def caustic_sun():
    """A glass and a mirror sphere on a floor under a 30-degree sun (tests/scenes.py
    sun_caustic_scene): light paths start on a disk across the sun's cone."""
    scene = bs.new_scene()
    coll = scene.collection
    bs.quad("Floor", [(-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0)],
            bs.diffuse("Floor", (0.6, 0.6, 0.6)), coll)
    bs.uv_sphere("Glass", (0.0, 0.0, 0.3), 0.3,
                 bs.material("Glass", "ShaderNodeBsdfGlass", Color=(1, 1, 1, 1), Roughness=0.0,
                             IOR=1.5), coll)
    bs.uv_sphere("Mirror", (0.75, 0.35, 0.2), 0.2,
                 bs.material("Mirror", "ShaderNodeBsdfGlossy", Color=(1, 1, 1, 1),
                             Roughness=0.0), coll)
    sun = bpy.data.lights.new("Sun", "SUN")
    sun.energy, sun.angle = 3.0, math.radians(30.0)
    obj = bpy.data.objects.new("Sun", sun)
    toward = mathutils.Vector((-math.sin(math.radians(30)), 0.3, math.cos(math.radians(30))))
    obj.rotation_euler = toward.to_track_quat("Z", "Y").to_euler()  # local +Z to the sun
    coll.objects.link(obj)
    cam = bs.camera(scene, "Camera", (0.3, -2.2, 2.0), bs.CBSPHERES_LENS, (64, 48))
    look = mathutils.Vector((0.3, 0.0, 0.15)) - cam.location
    cam.rotation_euler = look.to_track_quat("-Z", "Y").to_euler()
    bs.black_world(scene)
    scene.specula.use_light_tracing = True


def _checker_image(name, n=8, colourspace="sRGB"):
    """An n x n packed byte image of two colours in squares with a red texel at the bottom
    left and a green one at the top right (a flipped or transposed lookup shows)."""
    image = bpy.data.images.new(name, n, n, alpha=True)
    iy, ix = np.mgrid[0:n, 0:n]
    px = np.where(((ix + iy) % 2 == 0)[..., None], (0.9, 0.6, 0.1, 1.0), (0.1, 0.3, 0.8, 1.0))
    px[0, 0], px[n - 1, n - 1] = (1.0, 0.0, 0.0, 1.0), (0.0, 1.0, 0.0, 1.0)
    image.pixels.foreach_set(px.astype(np.float32).ravel())
    image.pack()
    image.colorspace_settings.name = colourspace
    return image


def _textured(name, image, shader="ShaderNodeBsdfDiffuse", socket="Color", scale=1.0,
              interpolation="Closest", extension="REPEAT", **inputs):
    """A material whose `socket` is an Image Texture of `image` on the UV map, through a
    Mapping node scaling it by `scale`."""
    mat = bs.material(name, shader, **inputs)
    tree = mat.node_tree
    shader_node = next(n for n in tree.nodes if n.bl_idname != "ShaderNodeOutputMaterial")
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image, tex.interpolation, tex.extension = image, interpolation, extension
    mapping = tree.nodes.new("ShaderNodeMapping")
    mapping.inputs["Scale"].default_value = (scale, scale, 1.0)
    coords = tree.nodes.new("ShaderNodeTexCoord")
    tree.links.new(coords.outputs["UV"], mapping.inputs["Vector"])
    tree.links.new(mapping.outputs["Vector"], tex.inputs["Vector"])
    tree.links.new(tex.outputs["Color"], shader_node.inputs[socket])
    return mat


def _projected(name, image, projection, coordinates, blend=0.0, linear=False, offset=None):
    """A Diffuse material coloured by an Image Texture of `image` in `projection` on
    Texture Coordinate's `coordinates` output (moved by `offset` through a Mapping if
    given; Box blended by `blend`)."""
    def feed(tree):
        tex = tree.nodes.new("ShaderNodeTexImage")
        tex.image, tex.projection, tex.projection_blend = image, projection, blend
        tex.interpolation = "Linear" if linear else "Closest"
        vector = tree.nodes.new("ShaderNodeTexCoord").outputs[coordinates]
        if offset is not None:
            mapping = tree.nodes.new("ShaderNodeMapping")
            mapping.inputs["Location"].default_value = offset
            tree.links.new(vector, mapping.inputs["Vector"])
            vector = mapping.outputs["Vector"]
        tree.links.new(vector, tex.inputs["Vector"])
        return tex.outputs["Color"]
    return _diffuse_fed(name, feed)


def image_projections():
    """Image Texture's Sphere, Tube and Box projections (issue 14, point 1): a ball in
    Sphere projection of its Generated coordinates, a turned cylinder in Tube projection
    (of Object coordinates centred on its axis: Generated ones would put its caps exactly
    on a texel edge, v = 1, where float rounding picks either side), a turned, unevenly
    scaled cube in Box projection of Object coordinates (blend 0) and a ball in Box
    projection blended 0.4 (the two- and three-face mixes between), each of a chequered
    image with a red and a green corner texel (a mirrored face shows)."""
    _box()
    image = _checker_image("Projected", n=8)
    _sphere(_projected("SphereMap", image, "SPHERE", "Generated"), (-0.6, 0.0, 0.27), 0.27,
            "SphereBall")
    bpy.ops.mesh.primitive_cylinder_add(radius=0.2, depth=0.55, location=(-0.05, 0.1, 0.3),
                                        rotation=(0.3, 0.0, 0.5))
    tube = bpy.context.active_object
    tube.data.materials.append(_projected("TubeMap", image, "TUBE", "Object",
                                          offset=(0.5, 0.5, 0.5)))
    cube = _cube("BoxCube", (0.5, 0.3, 0.3), (0.35, 0.3, 0.4),
                 _projected("BoxMap", image, "BOX", "Object"))
    cube.rotation_euler = (0.5, 0.3, 0.7)
    ball = _sphere(_projected("BlendedBox", image, "BOX", "Object", blend=0.4, linear=True),
                   (0.1, -0.35, 0.85), 0.25, "BlendedBall")
    ball.rotation_euler = (0.2, 0.6, 0.1)


def _wired(name, size, emission=0.0):
    """A Diffuse material orange on its faces' insides and blue within size / 2 of their
    edges (a Wireframe node of world-space `size` as the Mix factor); with `emission`, an
    Emission of that strength on the wires instead, added to the Diffuse."""
    mat = bs.material(name, "ShaderNodeBsdfDiffuse")
    tree = mat.node_tree
    wires = tree.nodes.new("ShaderNodeWireframe")
    wires.inputs["Size"].default_value = size
    diffuse = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfDiffuse")
    if emission:
        glow = tree.nodes.new("ShaderNodeEmission")
        glow.inputs["Color"].default_value = (0.3, 0.9, 0.4, 1.0)
        scale = tree.nodes.new("ShaderNodeMath")
        scale.operation = "MULTIPLY"
        scale.inputs[1].default_value = emission
        tree.links.new(wires.outputs["Fac"], scale.inputs[0])
        tree.links.new(scale.outputs[0], glow.inputs["Strength"])
        add = tree.nodes.new("ShaderNodeAddShader")
        out = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial")
        tree.links.new(diffuse.outputs[0], add.inputs[0])
        tree.links.new(glow.outputs[0], add.inputs[1])
        tree.links.new(add.outputs[0], out.inputs["Surface"])
        return mat
    tree.links.new(_orange_to_blue(tree, wires.outputs["Fac"]), diffuse.inputs["Color"])
    return mat


def wireframe():
    """The Wireframe node at world-space sizes (issue 14): a smooth UV sphere and a turned,
    unevenly scaled cube whose triangles' edges (the quads' diagonals too, as Cycles
    renders them) colour their surface, and a card whose wires glow green (an Emission of
    the Wireframe's Fac, added to its Diffuse)."""
    _box()
    _sphere(_wired("WiredBall", 0.005), (-0.45, 0.0, 0.3), 0.3, "WiredBall")
    cube = _cube("WiredCube", (0.4, 0.1, 0.3), (0.35, 0.3, 0.45), _wired("WiredCube", 0.03))
    cube.rotation_euler = (0.4, 0.2, 0.6)
    _card("WiredCard", (0.0, 0.6, 1.05), (0.9, 0.4), _wired("GlowingWires", 0.04, 4.0))


def _uv_sphere_mesh(name, radius):
    """A smooth 32 x 16 UV sphere mesh with its UV map (bmesh's calc_uvs)."""
    mesh = bpy.data.meshes.new(name)
    bm = bmesh.new()
    bm.loops.layers.uv.new("UVMap")  # calc_uvs fills an existing layer
    bmesh.ops.create_uvsphere(bm, u_segments=32, v_segments=16, radius=radius, calc_uvs=True)
    for face in bm.faces:
        face.smooth = True
    bm.to_mesh(mesh)
    bm.free()
    return mesh


def _quad_uvs(obj):
    layer = obj.data.uv_layers.new(name="UVMap")
    for loop, uv in zip(layer.data, ((0, 0), (1, 0), (1, 1), (0, 1))):
        loop.uv = uv


def _checker_alpha(mat, scale=4.0):
    """The Principled BSDF's Alpha from a Checker Texture on the UV map: 1 and 0 in
    squares (a cut-out)."""
    tree = mat.node_tree
    node = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled")
    checker = tree.nodes.new("ShaderNodeTexChecker")
    checker.inputs["Color1"].default_value = (1.0, 1.0, 1.0, 1.0)
    checker.inputs["Color2"].default_value = (0.0, 0.0, 0.0, 1.0)
    checker.inputs["Scale"].default_value = scale
    coords = tree.nodes.new("ShaderNodeTexCoord")
    tree.links.new(coords.outputs["UV"], checker.inputs["Vector"])
    tree.links.new(checker.outputs["Fac"], node.inputs["Alpha"])
    return mat


def alpha_cutouts():
    """Alpha and the Transparent BSDF (issue 14, points 1 and 4): a leaf-green card under the
    light whose Principled Alpha is a Checker Texture (a cut-out: seen from below, it casts
    a checkered shadow through transparent shadow rays), a tinted Transparent BSDF pane in
    front of a white ball (seen through, casting a coloured shadow), and a blue ball at
    Alpha 0.4."""
    _box()
    col = bpy.context.scene.collection
    leaf = _checker_alpha(_principled("Leaf", **{"Base Color": (0.2, 0.6, 0.1, 1.0),
                                                 "Roughness": 0.5}))
    card = bs.quad("Leaf", [(-0.45, -0.45, 0.0), (0.45, -0.45, 0.0), (0.45, 0.45, 0.0),
                            (-0.45, 0.45, 0.0)], leaf, col)
    _quad_uvs(card)
    card.location = (0.0, 0.1, 1.1)
    pane = bs.material("Tint", "ShaderNodeBsdfTransparent", Color=(0.9, 0.5, 0.2, 1.0))
    _card("Pane", (-0.45, -0.5, 0.4), (0.6, 0.8), pane)
    _sphere(bs.diffuse("Chalk", (0.8, 0.8, 0.8)), (-0.45, 0.0, 0.25), 0.25, "Chalk")
    ghost = _principled("Ghost", **{"Base Color": (0.1, 0.2, 0.8, 1.0), "Alpha": 0.4})
    _sphere(ghost, (0.5, -0.1, 0.3), 0.3, "Ghost")


def transparent_limit():
    """Cycles' transparent bounce limit (3 here): four overlapping tinted Transparent BSDF
    panes in front of the back wall and under the light. Where the camera looks through
    all four, the fourth is the surface after the limit (emission only: black); the
    shadow rays crossing three or more panes are blocked."""
    _box()
    bpy.context.scene.specula.transparent_max_bounces = 3
    pane = bs.material("Tint", "ShaderNodeBsdfTransparent", Color=(0.95, 0.8, 0.6, 1.0))
    for i in range(4):
        _card(f"Pane{i}", (-0.45 + 0.3 * i, -0.2 - 0.15 * i, 0.7), (0.9, 1.0), pane)


def textured_walls():
    """The Cornell box whose back wall (through a Hue/Saturation node) and floor carry an
    8 x 8 sRGB image texture (Closest, repeated twice by a Mapping node on the floor), a
    Principled sphere textured on its own UVs (Linear, Extend) and a Glossy sphere whose
    colour is the image Mixed (Multiply) with an RGB: the textured colour in Lambert,
    layered and specular lobes."""
    scene = _box()
    image = _checker_image("Checker")
    back = bpy.data.objects["Back"]
    back.data.materials[0] = _textured("BackTex", image, Roughness=0.0)
    tree = back.data.materials[0].node_tree  # image -> Hue/Saturation -> Color
    hsv = tree.nodes.new("ShaderNodeHueSaturation")
    for name, value in (("Hue", 0.62), ("Saturation", 1.4), ("Value", 0.9), ("Fac", 0.8)):
        hsv.inputs[name].default_value = value
    tex = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeTexImage")
    diffuse = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfDiffuse")
    tree.links.new(tex.outputs["Color"], hsv.inputs["Color"])
    tree.links.new(hsv.outputs["Color"], diffuse.inputs["Color"])
    floor = bpy.data.objects["Floor"]
    floor.data.materials[0] = _textured("FloorTex", image, scale=2.0, Roughness=0.0)
    for obj in (back, floor):
        _quad_uvs(obj)
    ball = _textured("BallTex", image, "ShaderNodeBsdfPrincipled", "Base Color",
                     interpolation="Linear", extension="EXTEND", Roughness=0.4)
    mesh = _uv_sphere_mesh("Ball", 0.3)
    obj = bpy.data.objects.new("Ball", mesh)
    obj.location = (-0.45, 0.2, 0.3)
    obj.data.materials.append(ball)
    scene.collection.objects.link(obj)
    glossy = _textured("GlossyTex", image, "ShaderNodeBsdfGlossy", Roughness=0.3)
    tree = glossy.node_tree
    tex = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeTexImage")
    mix = tree.nodes.new("ShaderNodeMix")
    mix.data_type, mix.blend_type = "RGBA", "MULTIPLY"
    mix.inputs["Factor"].default_value = 0.7
    mix.inputs[7].default_value = (0.9, 0.9, 0.5, 1.0)  # B_Color
    tree.links.new(tex.outputs["Color"], mix.inputs[6])  # A_Color
    glossy_node = next(n for n in tree.nodes if n.bl_idname in ("ShaderNodeBsdfGlossy",
                                                                "ShaderNodeBsdfAnisotropic"))
    tree.links.new(mix.outputs[2], glossy_node.inputs["Color"])  # Result_Color
    mesh2 = mesh.copy()
    obj2 = bpy.data.objects.new("GlossyBall", mesh2)
    obj2.location = (0.45, -0.2, 0.3)
    mesh2.materials[0] = glossy
    scene.collection.objects.link(obj2)


def _stripes_normal_image(name, n=8, tilt=0.6):
    """An n x n packed float Non-Color tangent-space normal map: vertical stripes whose
    normals lean alternately toward +u and -u by `tilt` (tests/scenes.normal_map_texels)."""
    image = bpy.data.images.new(name, n, n, alpha=True, float_buffer=True)
    ix = np.mgrid[0:n, 0:n][1]
    x = np.where(ix % 2 == 0, tilt, -tilt)
    z = math.sqrt(1.0 - tilt * tilt)
    px = np.stack([(x + 1) / 2, np.full_like(x, 0.5), np.full_like(x, (z + 1) / 2),
                   np.ones_like(x)], axis=-1)
    image.pixels.foreach_set(px.astype(np.float32).ravel())
    image.pack()
    image.colorspace_settings.name = "Non-Color"
    return image


def _normal_mapped(mat, image, strength=1.0):
    """Link a tangent-space Normal Map of `image` (Linear, on the UV map) into the Normal
    input of `mat`'s shader."""
    tree = mat.node_tree
    shader_node = next(n for n in tree.nodes if n.bl_idname != "ShaderNodeOutputMaterial")
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image, tex.interpolation = image, "Linear"
    normal_map = tree.nodes.new("ShaderNodeNormalMap")
    normal_map.inputs["Strength"].default_value = strength
    tree.links.new(tex.outputs["Color"], normal_map.inputs["Color"])
    tree.links.new(normal_map.outputs["Normal"], shader_node.inputs["Normal"])
    return mat


def normal_maps():
    """Issue 14's normal maps: the floor (Diffuse, strength 1) and a smooth UV sphere
    (rough Principled, strength 0.7) carry a striped tangent-space normal map, with
    Blender's own tangents; the stripes tilt the shading normal by 37 degrees."""
    scene = _box()
    image = _stripes_normal_image("Stripes")
    floor = bpy.data.objects["Floor"]
    floor.data.materials[0] = _normal_mapped(bs.diffuse("BumpyFloor", (0.7, 0.7, 0.7)),
                                             image)
    _quad_uvs(floor)
    obj = bpy.data.objects.new("Ball", _uv_sphere_mesh("Ball", 0.35))
    obj.location = (0.1, 0.1, 0.35)
    obj.data.materials.append(_normal_mapped(_principled("BumpyBall", **{
        "Base Color": (0.8, 0.5, 0.3, 1.0), "Roughness": 0.4}), image, 0.7))
    scene.collection.objects.link(obj)


def _bumped(mat, axis, frequency, distance, strength=1.0, invert=False):
    """Link a Bump node into the Normal input of `mat`'s shader: its Height the ripples
    sin(frequency x the Generated coordinate `axis`) (Math nodes), smooth at every scale a
    pixel sees, so Cycles' finite step (a tenth of the pixel footprint) is its gradient."""
    tree = mat.node_tree
    shader_node = next(n for n in tree.nodes if n.bl_idname != "ShaderNodeOutputMaterial")
    coords, xyz, times, sine, bump = (tree.nodes.new(t) for t in (
        "ShaderNodeTexCoord", "ShaderNodeSeparateXYZ", "ShaderNodeMath", "ShaderNodeMath",
        "ShaderNodeBump"))
    times.operation, sine.operation = "MULTIPLY", "SINE"
    times.inputs[1].default_value = frequency
    bump.inputs["Distance"].default_value = distance
    bump.inputs["Strength"].default_value = strength
    bump.invert = invert
    tree.links.new(coords.outputs["Generated"], xyz.inputs[0])
    tree.links.new(xyz.outputs[axis], times.inputs[0])
    tree.links.new(times.outputs[0], sine.inputs[0])
    tree.links.new(sine.outputs[0], bump.inputs["Height"])
    tree.links.new(bump.outputs["Normal"], shader_node.inputs["Normal"])
    return mat


def bump():
    """Bump nodes (issue 14, point 1) on ripples of Generated coordinates: the box's floor
    (Diffuse, ridges along y), a rough (0.3) Principled ball in horizontal bands, a
    Glossy (0.15) ball inverted, and a smooth Glass ball at strength 0.6."""
    _box()
    floor = bpy.data.objects["Floor"]
    floor.data.materials[0] = _bumped(bs.diffuse("RippledFloor", (0.7, 0.7, 0.7)), "X", 40.0,
                                      0.03)
    _balls([_bumped(_principled("BandedBall", **{"Base Color": (0.8, 0.3, 0.2, 1.0),
                                                "Roughness": 0.3}), "Z", 30.0, 0.01),
            _bumped(bs.material("RippledGlossy", "ShaderNodeBsdfGlossy",
                                Color=(0.9, 0.8, 0.5, 1.0), Roughness=0.15), "X", 30.0,
                    0.008, invert=True),
            _bumped(_glass("RippledGlass", (1.0, 1.0, 1.0), 0.0), "Y", 10.0, 0.012, 0.6)])


def _displaced(mat, axis, frequency, scale, space="WORLD", midlevel=0.5):
    """Link a Displacement node into `mat`'s Material Output (Displacement Method Bump Only,
    Blender's default): its Height the ripples sin(frequency x the Generated coordinate
    `axis`), as _bumped's."""
    tree = mat.node_tree
    out = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial")
    coords, xyz, times, sine, displacement = (tree.nodes.new(t) for t in (
        "ShaderNodeTexCoord", "ShaderNodeSeparateXYZ", "ShaderNodeMath", "ShaderNodeMath",
        "ShaderNodeDisplacement"))
    times.operation, sine.operation = "MULTIPLY", "SINE"
    times.inputs[1].default_value = frequency
    displacement.space = space
    displacement.inputs["Scale"].default_value = scale
    displacement.inputs["Midlevel"].default_value = midlevel
    tree.links.new(coords.outputs["Generated"], xyz.inputs[0])
    tree.links.new(xyz.outputs[axis], times.inputs[0])
    tree.links.new(times.outputs[0], sine.inputs[0])
    tree.links.new(sine.outputs[0], displacement.inputs["Height"])
    tree.links.new(displacement.outputs[0], out.inputs["Displacement"])
    assert mat.displacement_method == "BUMP"
    return mat


def _normal_coloured(mat):
    """`mat` with its last Diffuse BSDF's Color the Geometry node's Normal x 0.5 + 0.5."""
    tree = mat.node_tree
    diffuse = [n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfDiffuse"][-1]
    geometry, scaled = (tree.nodes.new(t) for t in ("ShaderNodeNewGeometry",
                                                    "ShaderNodeVectorMath"))
    scaled.operation = "MULTIPLY_ADD"
    scaled.inputs[1].default_value = scaled.inputs[2].default_value = (0.5, 0.5, 0.5)
    tree.links.new(geometry.outputs["Normal"], scaled.inputs[0])
    tree.links.new(scaled.outputs[0], diffuse.inputs["Color"])
    return mat


def displacement_bump():
    """A Material Output's Displacement rendered as Cycles renders Bump Only (issue 14,
    point 1): ripples on the box's floor (Diffuse, World space); a rough Principled ball
    under a coat (both its lobes bumped), World space; a ball mixing a red Diffuse and one
    coloured by the Geometry node's Normal by Layer Weight's Facing, where the mix factor
    and the colour read the displaced normal (Cycles' SetNormal runs before the shader's
    other nodes); a rough Glossy ball in Object space on an object scaled 1.5 (the
    ripples' depth grows with the scale, as Cycles' M normalize(M^T n) does)."""
    from mathutils import Matrix

    _box()
    floor = bpy.data.objects["Floor"]
    floor.data.materials[0] = _displaced(bs.diffuse("RippledFloor", (0.7, 0.7, 0.7)), "X",
                                         40.0, 0.03)
    _balls([_displaced(_principled("CoatedBands", **{
                "Base Color": (0.8, 0.3, 0.2, 1.0), "Roughness": 0.3, "Coat Weight": 0.6,
                "Coat Roughness": 0.05}), "Z", 30.0, 0.01),
            _displaced(_normal_coloured(_view_factor(_mix_of(
                "RippledFacing", "ShaderNodeMixShader",
                ("ShaderNodeBsdfDiffuse", {"Color": (0.8, 0.1, 0.1, 1.0)}),
                ("ShaderNodeBsdfDiffuse", {})), "ShaderNodeLayerWeight", "Facing",
                Blend=0.3)), "Z", 30.0, 0.015),
            _displaced(bs.material("ScaledGlossy", "ShaderNodeBsdfGlossy",
                                   Color=(0.9, 0.8, 0.5, 1.0), Roughness=0.15), "X", 30.0,
                       0.004, space="OBJECT")])
    ball = bpy.data.objects["Ball2"]
    ball.data.transform(Matrix.Scale(1.0 / 1.5, 4))  # (the mesh is centred on its origin)
    ball.scale = (1.5, 1.5, 1.5)


def sheen_bumped():
    """Sheen under Bump nodes: the microfiber lobe is a diffuse-type closure to Cycles, so its
    light is shadowed by the bumped normal's tilt off the surface (bump_shadowing_term), as a
    Diffuse BSDF's. A rippled Sheen BSDF floor, a banded Principled velvet (sheen 1.0,
    roughness 0.5), the same under a coat, and a rippled Sheen BSDF ball."""
    _box()
    floor = bpy.data.objects["Floor"]
    floor.data.materials[0] = _bumped(bs.material(
        "RippledSheen", "ShaderNodeBsdfSheen", Color=(0.8, 0.8, 0.8, 1.0), Roughness=0.4),
        "X", 30.0, 0.03)
    velvet = {"Base Color": (0.3, 0.03, 0.05, 1.0), "Roughness": 0.7, "Sheen Weight": 1.0,
              "Sheen Roughness": 0.5}
    _balls([_bumped(_principled("BandedVelvet", **velvet), "Z", 25.0, 0.015),
            _bumped(_principled("CoatedVelvet", **velvet, **{"Coat Weight": 0.7,
                                                             "Coat Roughness": 0.15}),
                    "X", 25.0, 0.015),
            _bumped(bs.material("SheenBall", "ShaderNodeBsdfSheen", Color=(0.9, 0.9, 0.6, 1.0),
                                Roughness=0.3), "Y", 20.0, 0.02)])


def textured_emitter():
    """The Cornell box lit by its ceiling quad whose Emission colour is the 8 x 8 image
    (Closest): a textured light seen directly, sampled by next-event estimation and starting
    light paths through the glass sphere (caustics on); a mirror and a glass sphere."""
    scene = _box(emitter=False)
    image = _checker_image("LightChecker")
    light = _textured("TexturedLight", image, "ShaderNodeEmission", Strength=12.0)
    obj = bs.quad("Emitter", [(-0.4, -0.3, 1.49), (-0.4, 0.3, 1.49), (0.4, 0.3, 1.49),
                              (0.4, -0.3, 1.49)], light, scene.collection)
    _quad_uvs(obj)
    _sphere(bs.material("Mirror", "ShaderNodeBsdfGlossy", Color=(0.9, 0.9, 0.9, 1.0),
                        Roughness=0.0), (-0.45, 0.2, 0.3), 0.3, "MirrorBall")
    _sphere(bs.material("Glass", "ShaderNodeBsdfGlass", Color=(1.0, 1.0, 1.0, 1.0),
                        Roughness=0.0, IOR=1.45), (0.45, -0.2, 0.3), 0.3, "GlassBall")
    scene.specula.use_light_tracing = True


def _gltf(name, direction=(0.6, -1.0, 0.5), distance=2.6, sun=True, ext=".glb"):
    """A Khronos glTF sample model (tests/assets/gltf/, licences beside them; `ext` .glb or
    .gltf) imported with Blender's own glTF importer, as a user would: framed by a camera
    from `direction`, `distance` bounding radii away, lit by a grey world and (`sun`) a
    sun."""
    scene = bs.new_scene()
    bpy.ops.import_scene.gltf(filepath=os.path.join(GLTF_DIR, name, name + ext))
    corners = [o.matrix_world @ mathutils.Vector(c) for o in scene.objects
               if o.type == "MESH" for c in o.bound_box]
    lo = mathutils.Vector([min(c[i] for c in corners) for i in range(3)])
    hi = mathutils.Vector([max(c[i] for c in corners) for i in range(3)])
    centre, radius = (lo + hi) / 2, (hi - lo).length / 2
    d = mathutils.Vector(direction).normalized()
    cam = bs.camera(scene, "Camera", centre + d * radius * distance, 50.0, (64, 48))
    cam.rotation_euler = (-d).to_track_quat("-Z", "Y").to_euler()
    cam.data.clip_start, cam.data.clip_end = radius * 0.05, radius * 20
    world = bpy.data.worlds.new("Grey")
    bg = next(n for n in world.node_tree.nodes if n.bl_idname == "ShaderNodeBackground")
    bg.inputs["Color"].default_value = (0.3, 0.3, 0.3, 1.0)
    world.color = (0.3, 0.3, 0.3)
    scene.world = world
    if not sun:
        return
    sun = bpy.data.lights.new("Sun", "SUN")
    sun.energy = 2.0
    obj = bpy.data.objects.new("Sun", sun)
    obj.rotation_euler = mathutils.Vector((0.4, -0.6, 1.0)).to_track_quat("Z", "Y").to_euler()
    scene.collection.objects.link(obj)


def gltf_box_textured():
    _gltf("BoxTextured")


def gltf_texture_settings():
    """Wrap modes (the importer's Math WRAP / PINGPONG chains), single- and double-sided."""
    _gltf("TextureSettingsTest", direction=(0.0, -1.0, 0.0))


def gltf_texture_coordinates():
    _gltf("TextureCoordinateTest", direction=(0.0, -1.0, 0.2))


def gltf_texture_linear_interpolation():
    """Emissive spheres (an emissive factor beside an emission read from a 2 x 1 sRGB
    texture) under emissive labels cut out by their texture's alpha (the importer's mask
    chain), whose constant reads 0 (the alpha's mean, 0.44, is under the cutoff 0.5): the
    labels' textured glow is weighed by the cut-out per point (it shone through the
    transparent parts, where the texture is white, when that constant was taken to mean no
    alpha program), and a positive constant stands in for light choice
    (scene._emission_stand_in; without it the export failed)."""
    _gltf("TextureLinearInterpolationTest", direction=(0.0, -1.0, 0.0))


def gltf_attenuation():
    """KHR_materials_volume through the importer: Principled glass over Volume Absorption
    (attenuation colour and distance), cubes of five sizes and node scales, seen face-on."""
    _gltf("AttenuationTest", direction=(0.0, -1.0, 0.0))


def gltf_glass_vase_flowers():
    """Glass two ways side by side (alpha 0.3 against transmission), and flowers cut out by
    their colour texture's alpha (the importer's alpha-mask Math chain) with normal and
    roughness maps."""
    _gltf("GlassVaseFlowers", direction=(0.0, -1.0, 0.25))


def gltf_transmission():
    """KHR_materials_transmission through the importer: Principled glass whose Transmission,
    Metallic, Roughness and Base Color come from textures, before a patterned backdrop,
    seen close. Lit by the world alone: a
    sun's caustics through the smooth balls are fireflies in both engines (issue 16)."""
    _gltf("TransmissionTest", direction=(0.0, -1.0, 0.3), distance=1.0, sun=False)


def gltf_damaged_helmet():
    """Khronos DamagedHelmet: every map of the metallic-roughness model at once, textured
    base colour, Metallic and Roughness (the importer's Separate Color of one texture),
    a normal map and a textured emission beside the textured Metallic."""
    _gltf("DamagedHelmet", direction=(0.3, -1.0, 0.2), distance=2.0, ext=".gltf")


def gltf_sheen_chair():
    """Khronos SheenChair (KHR_materials_sheen, through the importer): a fabric seat with a
    sheen of roughness 0.8 over a textured base colour and a normal map, on textured wood
    and metal legs, seen from the front and above."""
    _gltf("SheenChair", direction=(0.4, -1.0, 0.6), distance=3.2, ext=".gltf")


def gltf_specular():
    """Khronos SpecularTest (KHR_materials_specular, through the importer): rows of
    spheres whose specular factor (the Specular IOR Level) and specular colour (the
    Specular Tint) step from 0 to 1 and above, each row beside one whose value comes from
    a texture; seen face-on under the grey world alone (the sun's reflection in these
    smooth spheres is a highlight of about 1e-4 of a pixel, which 512 samples find by
    chance or not at all)."""
    _gltf("SpecularTest", direction=(0.0, -1.0, 0.0), distance=2.0, sun=False)


def gltf_clear_coat():
    """Khronos ClearCoatTest: each row a base, the base coated and the coat alone; a coat
    weight and a coat roughness from textures, and normal maps on the base, on the coat
    and on both."""
    _gltf("ClearCoatTest", direction=(0.0, -1.0, 0.0), distance=1.6)


def gltf_anisotropy_strength():
    """Khronos AnisotropyStrengthTest: a grid of metal balls, Roughness 0 to 1 across and
    Anisotropic 0 to 1 down (the importer's KHR_materials_anisotropy), on Cycles' default
    tangent; the roughest column's alpha_x is clamped to 1."""
    _gltf("AnisotropyStrengthTest", direction=(0.0, -1.0, 0.0), distance=2.3)


def _bounces(n):
    def cbspheres_bounces():
        _open("cbspheres.blend")
    return cbspheres_bounces


BLEND = {name: os.path.join(SCENES_DIR, name) for name in
         ("cbspheres.blend", "cbdragon.blend", "default.blend")}

VARIANTS: dict[str, Variant] = {}


def _add(v: Variant):
    VARIANTS[v.name] = v


_add(Variant("cbspheres", cbspheres, max_bounces=12, files=(BLEND["cbspheres.blend"],)))
_add(Variant("cbdragon", cbdragon, resolution=(64, 36), max_bounces=8,
             files=(BLEND["cbdragon.blend"],)))
_add(Variant("default_no_light", default_no_light, resolution=(64, 36), max_bounces=12,
             samples=64, cycles_samples=128, files=(BLEND["default.blend"],)))
_add(Variant("default_with_light", default_with_light, resolution=(64, 36), max_bounces=12,
             samples=64, cycles_samples=128, files=(BLEND["default.blend"],)))
_add(Variant("default_light_no_specular", default_light_no_specular, resolution=(64, 36),
             max_bounces=12, samples=64, cycles_samples=128, files=(BLEND["default.blend"],)))
for _setup in (mat_diffuse, mat_mirror, mat_glass_145, mat_glass_24, mat_glass_tinted,
               mat_principled_metal, mat_principled_glass, emitter_direct, emitter_through_glass):
    _add(Variant(_setup.__name__, _setup))
# Outside the sheet's outline a pixel's filter tail reaches the sheet in a few % of its
# samples, and a sampled Fresnel reflection carries weight 1: such pixels are rare 0/1
# events (about 1 hit in 200 samples). At 192 / 512 samples many held 0 or 1 hits, where a
# sample variance is meaningless (z = inf where Specula had none and both Cycles seeds one
# each); at these counts every outline pixel has tens of hits.
_add(Variant("glass_sheet_fresnel", glass_sheet_fresnel, max_bounces=8, samples=2048,
             cycles_samples=4096))
for _setup in (glass_chart_145, glass_chart_24):
    _add(Variant(_setup.__name__, _setup, max_bounces=8, samples=192, cycles_samples=512))
for _setup in (light_point, light_point_sphere, light_point_soft_coloured, light_spot, light_sun,
               light_sun_angle, light_area_square, light_area_rectangle_scaled,
               light_area_disk_visible, light_area_ellipse_spread, light_through_glass,
               world_environment, world_nodes_sky, world_environment_mapped,
               world_camera_backdrop, world_ray_kinds, world_sky_texture,
               world_sky_single_scattering, world_sky_preetham):
    _add(Variant(_setup.__name__, _setup, max_bounces=8))
for _setup in (dof_disk, dof_blades, dof_blades_5, dof_anamorphic, dof_vertical_fit, dof_shift,
               dof_focus_object):
    _add(Variant(_setup.__name__, _setup, max_bounces=1, samples=512, cycles_samples=2048))
# A 12-degree cone lights the room mostly indirectly: rare, bright paths; more samples.
_add(Variant("spot_small_cone_soft", spot_small_cone_soft, max_bounces=8, samples=1024,
             cycles_samples=1024))
for _setup in (spot_user, spot_wide_blend_one, spot_radius_zero,
               spot_scaled, spot_seen_glass_mirror, spot_through_ceiling, glossy_colours,
               glossy_roughness):
    _add(Variant(_setup.__name__, _setup, max_bounces=8))
# Rough glass and metal (issue 14): light reaches the floor and the camera through two rough
# interfaces, mostly by next-event estimation at the inner one.
for _setup in (rough_glass_roughness, rough_glass_tinted, rough_metal, coloured_glass,
               mixed_shaders, alpha_cutouts, transparent_limit, view_factors):
    _add(Variant(_setup.__name__, _setup, max_bounces=8, samples=512, cycles_samples=1024))
# Scattering media (issue 14, point 3): paths through fog are long and noisy in both.
for _setup in (scattering_media, fog_point_light, camera_in_fog, world_fog):
    _add(Variant(_setup.__name__, _setup, max_bounces=8, samples=512, cycles_samples=1024))
# Roughness varying in squares: 10% more roughness shows at |z| 10.6 at these samples,
# only 5.6 at rough glass' 512 / 1024 (measured): four times those, for a clear margin.
_add(Variant("textured_roughness", textured_roughness, max_bounces=8, samples=2048,
             cycles_samples=4096))
# Caustics from a small light: rare paths for path tracing, more samples for Cycles.
_add(Variant("caustic_quad", caustic_quad, max_bounces=8, samples=1024, cycles_samples=2048,
             files=(BLEND["cbspheres.blend"],)))
_add(Variant("caustic_area_light", caustic_area_light, max_bounces=8, samples=1024,
             cycles_samples=2048, files=(BLEND["cbspheres.blend"],)))
_add(Variant("caustic_sun", caustic_sun, max_bounces=8, samples=1024, cycles_samples=2048))
for _setup in (caustic_point_light, caustic_spot):
    _add(Variant(_setup.__name__, _setup, max_bounces=8, samples=1024, cycles_samples=2048,
                 files=(BLEND["cbspheres.blend"],)))
# Image textures through Blender's own nodes (issue 14).
_add(Variant("textured_walls", textured_walls, max_bounces=8))
_add(Variant("textured_emitter", textured_emitter, max_bounces=8, samples=256,
             cycles_samples=512))
_add(Variant("normal_maps", normal_maps, max_bounces=8))
# Distance +20% showed at |z| 3.6 at 512 / 1024 samples with slopes near 0.2 (measured):
# steeper ripples and four times the samples.
_add(Variant("bump", bump, max_bounces=8, samples=2048, cycles_samples=4096))
_add(Variant("specular_tint", specular_tint, max_bounces=8, samples=1024, cycles_samples=2048))
_add(Variant("specular_tint_dielectric", specular_tint_dielectric, max_bounces=8, samples=1024,
             cycles_samples=2048))
_add(Variant("textured_tints", textured_tints, max_bounces=8, samples=1024, cycles_samples=2048))
_add(Variant("emission_under_layers", emission_under_layers, max_bounces=8, samples=512,
             cycles_samples=1024))
_add(Variant("displacement_bump", displacement_bump, max_bounces=8, samples=2048,
             cycles_samples=4096))
_add(Variant("emission_under_alpha", emission_under_alpha, max_bounces=8, samples=512,
             cycles_samples=1024))
_add(Variant("node_groups", node_groups, max_bounces=8))
_add(Variant("texture_spaces", texture_spaces, max_bounces=8))
_add(Variant("colour_attributes", colour_attributes, max_bounces=8))
_add(Variant("texture_coordinates", texture_coordinates, resolution=(128, 96), max_bounces=8,
             samples=256, cycles_samples=512))
_add(Variant("geometry_and_object_info", geometry_and_object_info, resolution=(128, 96),
             max_bounces=8, samples=256, cycles_samples=512))
for _setup in (parametric, random_per_island, pointiness):  # the Geometry node's mesh data
    _add(Variant(_setup.__name__, _setup, resolution=(128, 96), max_bounces=0, samples=64,
                 cycles_samples=128))
_add(Variant("vector_transform", vector_transform, resolution=(128, 96), max_bounces=8,
             samples=256, cycles_samples=512))
_add(Variant("image_projections", image_projections, resolution=(128, 96), max_bounces=8,
             samples=256, cycles_samples=512))
_add(Variant("wireframe", wireframe, resolution=(128, 96), max_bounces=8, samples=256,
             cycles_samples=512))
_add(Variant("blend_modes", blend_modes, resolution=(228, 72), max_bounces=0, samples=64,
             cycles_samples=128))
_add(Variant("procedural_textures", procedural_textures, resolution=(224, 96), max_bounces=0,
             samples=64, cycles_samples=128))
_add(Variant("white_noise", white_noise, resolution=(224, 32), max_bounces=0, samples=64,
             cycles_samples=128))
_add(Variant("converter_nodes", converter_nodes, resolution=(224, 64), max_bounces=0,
             samples=64, cycles_samples=128))
_add(Variant("bricks_and_rotation", bricks_and_rotation, resolution=(224, 64), max_bounces=0,
             samples=64, cycles_samples=128))
_add(Variant("voronoi", voronoi, resolution=(224, 64), max_bounces=0, samples=64,
             cycles_samples=128))
_add(Variant("blackbody_and_normal", blackbody_and_normal, resolution=(224, 32),
             max_bounces=0, samples=64, cycles_samples=128))
_add(Variant("attributes", attributes, resolution=(224, 64), max_bounces=0, samples=64,
             cycles_samples=128))
_add(Variant("wavelength", wavelength, resolution=(128, 32), max_bounces=0, samples=64,
             cycles_samples=128))
_add(Variant("translucency", translucency, max_bounces=8))
_add(Variant("oren_nayar", oren_nayar, max_bounces=8, samples=1024, cycles_samples=2048))
_add(Variant("anisotropic", anisotropic, max_bounces=8, samples=1024, cycles_samples=2048))
_add(Variant("metallic_bsdf", metallic_bsdf, max_bounces=8, samples=512, cycles_samples=1024))
_add(Variant("principled_ggx", principled_ggx, max_bounces=8, samples=512, cycles_samples=1024))
_add(Variant("falloff_and_camera_data", falloff_and_camera_data, max_bounces=8, samples=256,
             cycles_samples=512))
_add(Variant("light_path", light_path, resolution=(96, 72), max_bounces=8, samples=1024,
             cycles_samples=2048))
_add(Variant("textured_glass", textured_glass, max_bounces=8, samples=512,
             cycles_samples=1024))
_add(Variant("refraction", refraction, max_bounces=8, samples=2048, cycles_samples=4096))
_add(Variant("coat", coat, max_bounces=8, samples=2048, cycles_samples=4096))
_add(Variant("coat_rough", coat_rough, max_bounces=8, samples=1024, cycles_samples=2048))
_add(Variant("coat_furnace", coat_furnace, max_bounces=8, samples=256, cycles_samples=512))
_add(Variant("sheen", sheen, max_bounces=8, samples=1024, cycles_samples=2048))
_add(Variant("sheen_bumped", sheen_bumped, max_bounces=8, samples=1024, cycles_samples=2048))
_add(Variant("emission_strength_texture", emission_strength_texture, max_bounces=8))
_add(Variant("specular_ior_textured", specular_ior_textured, max_bounces=8, samples=1024,
             cycles_samples=2048))
for _setup, _name in ((gltf_box_textured, "BoxTextured"),
                      (gltf_texture_settings, "TextureSettingsTest"),
                      (gltf_texture_coordinates, "TextureCoordinateTest"),
                      (gltf_attenuation, "AttenuationTest"),
                      (gltf_texture_linear_interpolation, "TextureLinearInterpolationTest"),
                      (gltf_glass_vase_flowers, "GlassVaseFlowers")):
    _add(Variant(_setup.__name__, _setup, max_bounces=8,
                 files=(os.path.join(GLTF_DIR, _name, _name + ".glb"),)))
# Glass balls through textured transmission and roughness: more samples, as rough glass.
_add(Variant("gltf_transmission", gltf_transmission, max_bounces=8, samples=512,
             cycles_samples=1024,
             files=(os.path.join(GLTF_DIR, "TransmissionTest", "TransmissionTest.glb"),)))
_add(Variant("gltf_clear_coat", gltf_clear_coat, resolution=(64, 96), max_bounces=8,
             samples=512, cycles_samples=1024,
             files=(os.path.join(GLTF_DIR, "ClearCoatTest", "ClearCoatTest.glb"),)))
_add(Variant("gltf_specular", gltf_specular, resolution=(112, 96), max_bounces=8,
             samples=512, cycles_samples=1024,
             files=(os.path.join(GLTF_DIR, "SpecularTest", "SpecularTest.glb"),)))
_add(Variant("gltf_anisotropy_strength", gltf_anisotropy_strength, resolution=(96, 72),
             max_bounces=8, samples=512, cycles_samples=1024,
             files=(os.path.join(GLTF_DIR, "AnisotropyStrengthTest",
                                 "AnisotropyStrengthTest.glb"),)))
_add(Variant("gltf_sheen_chair", gltf_sheen_chair, max_bounces=8,
             files=tuple(os.path.join(GLTF_DIR, "SheenChair", f) for f in (
                 "SheenChair.gltf", "SheenChair.bin", "chair_fabric_albedo.png",
                 "chair_fabric_normal.png", "chair_label.png", "chair_occlusion.png",
                 "chair_wood_albedo.png", "chair_woodblack_roughnessmetallic.png",
                 "chair_woodbrown_roughnessmetallic.png"))))
_add(Variant("gltf_damaged_helmet", gltf_damaged_helmet, max_bounces=8,
             files=tuple(os.path.join(GLTF_DIR, "DamagedHelmet", f) for f in (
                 "DamagedHelmet.gltf", "DamagedHelmet.bin", "Default_albedo.jpg",
                 "Default_metalRoughness.jpg", "Default_emissive.jpg", "Default_normal.jpg",
                 "Default_AO.jpg"))))
# Direct light only: the terminator band is a few pixels of each sphere, and without the
# room's indirect light its pixels are nearly noise-free (the power tests need that).
for _setup in (terminator_point, terminator_area):
    _add(Variant(_setup.__name__, _setup, max_bounces=0, samples=256, cycles_samples=256))
# The course's max ray depth experiment: Blender's max_bounces on CBspheres.
for _n in (0, 1, 2, 3, 4, 5, 100):
    _add(Variant(f"cbspheres_bounces_{_n}", _bounces(_n), max_bounces=_n,
                 files=(BLEND["cbspheres.blend"],), params={"max_bounces": _n}))


"""The exporter's arrays against Blender's own data: triangles, normals, materials,
instances, transforms, visibility, camera, world."""

import math

import bpy
import numpy as np
import pytest
from addon_helpers import camera_object, cube_object, depsgraph, link, node_material, sphere_object
from mathutils import Matrix, Vector

from addon import exporter, materials, shader_nodes


def export(scene):
    if scene.camera is None:
        camera_object(location=(0, -10, 0), rotation=(math.pi / 2, 0, 0))
    return exporter.export(depsgraph())


def world_triangles(exp, name):
    """(t, 3, 3) world corners and (t, 3, 3) normals of the instance called `name`."""
    inst = next(i for i in exp.instances if i.name == name)
    mesh = exp.meshes[inst.mesh_key]
    v, tri, n = exporter.to_world(mesh, inst.matrix_world)
    return v[tri], n, inst, mesh


def blender_triangles(obj):
    """Blender's own world-space triangle corners, the slow obvious way."""
    ev = obj.evaluated_get(depsgraph())
    me = ev.to_mesh()
    m = ev.matrix_world
    out = np.array([[tuple(m @ me.vertices[i].co) for i in t.vertices] for t in me.loop_triangles])
    ev.to_mesh_clear()
    return out


def test_triangles_match_blender_with_transform(fresh):
    obj = cube_object()
    obj.location = (1.0, -2.0, 0.5)
    obj.rotation_euler = (0.3, -0.7, 1.1)
    obj.scale = (1.0, 2.0, 0.5)
    exp = export(fresh)
    corners, _, inst, mesh = world_triangles(exp, "Cube")
    np.testing.assert_allclose(corners, blender_triangles(obj), atol=1e-5)
    assert len(mesh.triangles) == 12
    np.testing.assert_allclose(inst.matrix_world, np.array(obj.matrix_world), atol=1e-6)


def test_modifiers_are_applied(fresh):
    obj = cube_object()
    mod = obj.modifiers.new("Subdivision", "SUBSURF")
    mod.levels = 2
    exp = export(fresh)
    corners, _, _, _ = world_triangles(exp, "Cube")
    assert len(corners) == 12 * 16  # 6 quads -> 96 quads -> 192 triangles
    np.testing.assert_allclose(corners, blender_triangles(obj), atol=1e-5)


def test_smooth_normals_match_corner_normals(fresh):
    obj = sphere_object()
    obj.scale = (1.0, 1.0, 3.0)  # non-uniform: normals need the inverse transpose
    exp = export(fresh)
    _, normals, _, mesh = world_triangles(exp, "Sphere")
    assert mesh.smooth.all()
    ev = obj.evaluated_get(depsgraph())
    me = ev.data
    loops = np.array([tuple(t.loops) for t in me.loop_triangles])
    local = np.array([tuple(c.vector) for c in me.corner_normals])[loops]
    inv_t = np.array(ev.matrix_world.to_3x3().inverted().transposed())
    expected = local @ inv_t.T
    unit = normals / np.linalg.norm(normals, axis=2, keepdims=True)
    np.testing.assert_allclose(unit, expected / np.linalg.norm(expected, axis=2, keepdims=True),
                               atol=1e-5)


def test_flat_meshes_use_the_winding_normal_after_shear(fresh):
    """A flat mesh exports no corner normals (the core takes each triangle's geometric
    normal, perpendicular by construction); the winding keeps it pointing outward."""
    obj = cube_object(smooth=False)
    obj.matrix_world = Matrix(((1, 0.5, 0, 0), (0, 1, 0, 0), (0, 0.3, 2, 0), (0, 0, 0, 1)))
    exp = export(fresh)
    corners, normals, _, mesh = world_triangles(exp, "Cube")
    assert not mesh.smooth.any() and normals is None
    e1 = corners[:, 1] - corners[:, 0]
    e2 = corners[:, 2] - corners[:, 0]
    outward = corners.mean(axis=1)  # the sheared cube is centred on the origin
    assert (np.einsum("ij,ij->i", np.cross(e1, e2), outward) > 0).all()


def test_custom_normals_are_used(fresh):
    obj = cube_object(smooth=False)
    me = obj.data
    custom = [(0.0, 0.0, 1.0)] * len(me.loops)
    me.normals_split_custom_set(custom)
    exp = export(fresh)
    _, normals, _, mesh = world_triangles(exp, "Cube")
    assert mesh.smooth.all()
    np.testing.assert_allclose(normals.reshape(-1, 3), np.tile([0.0, 0.0, 1.0], (36, 1)),
                               atol=1e-3)  # custom normals are stored compressed


@pytest.mark.parametrize("smooth", [True, False])
def test_negative_scale_keeps_winding_consistent(fresh, smooth):
    obj = cube_object(smooth=smooth)
    obj.scale = (-1.0, 1.0, 1.0)
    exp = export(fresh)
    corners, normals, _, _ = world_triangles(exp, "Cube")
    geometric = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    # Flat meshes carry no corner normals: the winding alone must face outward.
    reference = normals[:, 0] if smooth else corners.mean(axis=1)
    assert (np.einsum("ij,ij->i", geometric, reference) > 0).all()


def test_material_indices_follow_slots(fresh):
    obj = cube_object()
    red, _ = node_material("Red", "ShaderNodeBsdfDiffuse", Color=(1, 0, 0, 1))
    blue, _ = node_material("Blue", "ShaderNodeBsdfDiffuse", Color=(0, 0, 1, 1))
    obj.data.materials.append(red)
    obj.data.materials.append(blue)
    for poly in obj.data.polygons:
        poly.material_index = 1 if poly.normal.z > 0.5 else 0
    exp = export(fresh)
    inst = exp.instances[0]
    mesh = exp.meshes[inst.mesh_key]
    names = [exp.materials[i].name for i in inst.material_lut[mesh.material_index]]
    ev = obj.evaluated_get(depsgraph()).data
    expected = [ev.materials[t.material_index].name for t in ev.loop_triangles]
    assert names == expected
    assert names.count("Blue") == 2
    assert exp.materials[inst.material_lut[1]].kwargs["colour"] == (0.0, 0.0, 1.0)


def test_object_without_material_is_default_grey(fresh):
    cube_object()
    exp = export(fresh)
    spec = exp.materials[exp.instances[0].material_lut[0]]
    assert (spec.ctor, spec.kwargs["colour"]) == ("diffuse", (0.8, 0.8, 0.8))
    assert not exp.warnings


def test_linked_duplicates_share_one_mesh(fresh):
    a = cube_object("A")
    b = link(bpy.data.objects.new("B", a.data))
    b.location = (3.0, 0.0, 0.0)
    exp = export(fresh)
    assert len(exp.instances) == 2
    assert len(exp.meshes) == 1
    ca, _, _, _ = world_triangles(exp, "A")
    cb, _, _, _ = world_triangles(exp, "B")
    np.testing.assert_allclose(cb - ca, np.broadcast_to([3.0, 0, 0], ca.shape), atol=1e-6)


def test_collection_instances(fresh):
    coll = bpy.data.collections.new("Props")
    src = cube_object("Prop", size=0.5)
    fresh.collection.objects.unlink(src)
    coll.objects.link(src)
    src.location = (0.0, 0.0, 1.0)
    matrices = []
    for k in range(3):
        empty = link(bpy.data.objects.new(f"Inst{k}", None))
        empty.instance_type = "COLLECTION"
        empty.instance_collection = coll
        empty.location = (2.0 * k, 1.0, 0.0)
        empty.rotation_euler = (0.0, 0.0, 0.4 * k)
        matrices.append(Matrix.LocRotScale(Vector((2.0 * k, 1.0, 0.0)),
                                           empty.rotation_euler.to_quaternion(), None))
    exp = export(fresh)
    instances = [i for i in exp.instances if i.is_instance]
    assert len(instances) == 3
    assert len({i.mesh_key for i in instances}) == 1
    got = sorted((tuple(np.round(i.matrix_world[:3, 3], 6)) for i in instances))
    want = sorted(tuple(np.round(np.array(m @ src.matrix_world)[:3, 3], 6)) for m in matrices)
    assert got == want


def test_geometry_node_instances(fresh):
    src = cube_object("Src", size=0.2)
    src.hide_render = True  # the source is hidden; its instances still render
    host = link(bpy.data.objects.new("Host", bpy.data.meshes.new("HostMesh")))
    ng = bpy.data.node_groups.new("Scatter", "GeometryNodeTree")
    ng.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    ng.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    ng.nodes.new("NodeGroupInput")
    out = ng.nodes.new("NodeGroupOutput")
    line = ng.nodes.new("GeometryNodeMeshLine")
    line.inputs["Count"].default_value = 4
    iop = ng.nodes.new("GeometryNodeInstanceOnPoints")
    info = ng.nodes.new("GeometryNodeObjectInfo")
    info.inputs["Object"].default_value = src
    ng.links.new(line.outputs[0], iop.inputs["Points"])
    ng.links.new(info.outputs["Geometry"], iop.inputs["Instance"])
    ng.links.new(iop.outputs[0], out.inputs[0])
    host.modifiers.new("GN", "NODES").node_group = ng
    exp = export(fresh)
    instances = [i for i in exp.instances if i.is_instance]
    assert len(instances) == 4
    assert len({i.mesh_key for i in instances}) == 1  # read once, shared
    zs = sorted(float(i.matrix_world[2, 3]) for i in instances)
    np.testing.assert_allclose(zs, [0.0, 1.0, 2.0, 3.0], atol=1e-6)  # Mesh Line: 1 m offsets
    assert "Src" not in [i.name for i in exp.instances]


def test_particle_instances(fresh):
    emitter = cube_object("Emitter")
    src = sphere_object("Pebble", radius=0.05)
    src.location = (0, 0, 10)
    emitter.modifiers.new("Particles", "PARTICLE_SYSTEM")
    psys = emitter.particle_systems[0].settings
    psys.type = "HAIR"
    psys.count = 5
    psys.render_type = "OBJECT"
    psys.instance_object = src
    exp = export(fresh)
    pebbles = [i for i in exp.instances if i.is_instance]
    assert len(pebbles) == 5
    assert len({i.mesh_key for i in pebbles}) == 1


def test_hidden_from_render_is_skipped(fresh):
    cube_object("Visible")
    cube_object("Hidden").hide_render = True
    exp = export(fresh)
    assert [i.name for i in exp.instances] == ["Visible"]


def test_lights_are_exported_with_cycles_strength(fresh):
    cube_object()
    point = bpy.data.lights.new("Key", "POINT")
    point.energy, point.color, point.shadow_soft_size = 250.0, (1.0, 0.5, 0.25), 0.2
    point.use_soft_falloff = False
    if hasattr(point, "exposure"):
        point.exposure = 1.0
    key = link(bpy.data.objects.new("Key", point))
    key.location = (1, 2, 3)
    spot = bpy.data.lights.new("Spot", "SPOT")
    spot.spot_size, spot.spot_blend = 0.7, 0.3
    link(bpy.data.objects.new("Spot", spot))
    sun = bpy.data.lights.new("Sun", "SUN")
    sun.energy, sun.angle = 3.0, 0.1
    link(bpy.data.objects.new("Sun", sun))
    area = bpy.data.lights.new("Panel", "AREA")
    area.shape, area.size, area.size_y, area.spread = "RECTANGLE", 2.0, 0.5, 1.0
    panel = link(bpy.data.objects.new("Panel", area))
    panel.scale = (2, 1, 1)
    hidden = link(bpy.data.objects.new("Hidden", bpy.data.lights.new("Hidden", "POINT")))
    hidden.hide_render = True
    exp = export(fresh)
    by_name = {spec["name"]: spec for spec in exp.lights}
    assert set(by_name) == {"Key", "Spot", "Sun", "Panel"}
    gain = 2.0 if hasattr(point, "exposure") else 1.0
    assert np.allclose(by_name["Key"]["power"], np.array([1.0, 0.5, 0.25]) * 250 * gain)
    assert by_name["Key"]["radius"] == pytest.approx(0.2)
    assert by_name["Key"]["soft_falloff"] is False
    assert np.allclose(by_name["Key"]["matrix"][:3, 3], (1, 2, 3))
    assert by_name["Spot"]["spot_size"] == pytest.approx(0.7)
    assert by_name["Spot"]["spot_blend"] == pytest.approx(0.3)
    assert by_name["Sun"]["angle"] == pytest.approx(0.1)
    assert by_name["Panel"]["shape"] == "RECTANGLE" and by_name["Panel"]["size_y"] == 0.5
    assert np.allclose(by_name["Panel"]["matrix"][:3, 0], (2, 0, 0))
    assert not any("not supported" in w for w in exp.warnings)


@pytest.mark.parametrize("kind, size, scale", [
    ("POINT", 0.3, 4 * np.pi * 0.09), ("POINT", 0.0, 4.0), ("SPOT", 0.5, np.pi),
    ("SUN", 0.4, np.pi * np.sin(0.2) ** 2), ("SUN", 0.0, 1.0)])
def test_normalize_off_scales_point_spot_and_sun_lights_as_cycles(fresh, kind, size, scale):
    """Normalize off: a point or spot light's power times its sphere's area (4 at radius
    0), a sun's times pi sin^2(angle / 2) (1 at angle 0), as unnormalized over normalized
    Cycles renders measure; Specula's renders of the three (radius 0.3, 0 and angle 0.4)
    then match Cycles' means to 4 digits. It was warned and rendered normalized (a sun
    silently)."""
    light = bpy.data.lights.new("Bare", kind)
    light.energy = 10.0
    if kind == "SUN":
        light.angle = size
    else:
        light.shadow_soft_size = size
    link(bpy.data.objects.new("Bare", light))
    normal = export(fresh)
    light.normalize = False
    bare = export(fresh)
    assert bare.warnings == normal.warnings == []
    assert np.allclose(np.array(bare.lights[0]["power"]),
                       np.array(normal.lights[0]["power"]) * scale)


def core_blackbody(kelvin):
    from engine import shading
    return shading.blackbody(kelvin)


def test_a_light_node_tree_scales_its_emission_as_in_cycles(fresh):
    """A light's node tree: its Emission's Color x Strength, each the constant its chain
    reduces to, multiplies the light's power (the tree Blender makes, white at 1, changes
    nothing and warns nothing; a Light Falloff's Quadratic output without Smooth is its
    Strength, a Blackbody its colour); nothing on the Light Output emits nothing (both as
    a Cycles render of the factory scene measured: 2 x red, 0.4 x green at Color (1, 0.2,
    0.2), Strength 2); a texture or a falloff varying with distance is warned and left
    out. It was always warned and left out."""
    point = bpy.data.lights.new("Key", "POINT")
    point.energy, point.color = 100.0, (1.0, 0.5, 0.25)
    link(bpy.data.objects.new("Key", point))
    point.use_nodes = True
    tree = point.node_tree
    emission = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeEmission")

    def exported():
        exp = export(fresh)
        return np.array(exp.lights[0]["power"]), exp.warnings
    power, warnings = exported()
    assert np.allclose(power, (100.0, 50.0, 25.0)) and warnings == []
    emission.inputs["Color"].default_value = (1.0, 0.2, 0.2, 1.0)
    emission.inputs["Strength"].default_value = 2.0
    power, warnings = exported()
    assert np.allclose(power, (200.0, 20.0, 10.0)) and warnings == []
    falloff = tree.nodes.new("ShaderNodeLightFalloff")  # (a 2.7x lamp's strength)
    falloff.inputs["Strength"].default_value = 3.0
    tree.links.new(falloff.outputs["Quadratic"], emission.inputs["Strength"])
    power, warnings = exported()
    assert np.allclose(power, (300.0, 30.0, 15.0)) and warnings == []
    blackbody = tree.nodes.new("ShaderNodeBlackbody")
    blackbody.inputs["Temperature"].default_value = 3000.0
    tree.links.new(blackbody.outputs["Color"], emission.inputs["Color"])
    power, warnings = exported()
    want = np.array(core_blackbody(3000.0)) * 3.0 * np.array([100.0, 50.0, 25.0])
    assert np.allclose(power, want) and warnings == []
    tree.links.new(falloff.outputs["Linear"], emission.inputs["Strength"])
    power, warnings = exported()  # varies with the distance: left out, warned
    assert np.allclose(power, (100.0, 50.0, 25.0))
    assert len(warnings) == 1 and "'Key'" in warnings[0] and "Linear" in warnings[0]
    checker = tree.nodes.new("ShaderNodeTexChecker")
    tree.links.new(checker.outputs["Color"], emission.inputs["Color"])
    emission.inputs["Strength"].default_value = 1.0
    tree.links.remove(emission.inputs["Strength"].links[0])
    power, warnings = exported()
    assert np.allclose(power, (100.0, 50.0, 25.0))
    assert len(warnings) == 1 and "'Key'" in warnings[0]
    for old in list(tree.links):
        tree.links.remove(old)
    power, warnings = exported()
    assert np.allclose(power, 0.0) and len(warnings) == 1 and "emits nothing" in warnings[0]


def test_lights_reach_the_core(fresh, core):
    cube_object()
    link(bpy.data.objects.new("Key", bpy.data.lights.new("Key", "POINT"))).location = (0, 0, 3)
    scene, _ = exporter.to_core(export(fresh), core)
    assert len(scene.lights) == 1 and scene.lights[0].type == "POINT"


def test_no_camera_is_an_export_error(fresh):
    cube_object()
    with pytest.raises(exporter.ExportError, match="no active camera"):
        exporter.export(depsgraph())


def test_camera_fields(fresh):
    cam = camera_object(location=(1, 2, 3), rotation=(1.0, 0.2, 0.3))
    data = cam.data
    data.lens, data.sensor_width, data.sensor_height = 35.0, 32.0, 18.0
    data.sensor_fit = "VERTICAL"
    data.shift_x, data.shift_y = 0.1, -0.2
    data.clip_start, data.clip_end = 0.5, 250.0
    dof = data.dof
    dof.use_dof = True
    dof.focus_distance = 7.5
    dof.aperture_fstop = 1.4
    dof.aperture_blades = 6
    dof.aperture_rotation = 0.25
    dof.aperture_ratio = 1.5
    fresh.render.pixel_aspect_x = 2.0
    c = export(fresh).camera
    np.testing.assert_allclose(c["world_from_camera"], np.array(cam.matrix_world), atol=1e-6)
    assert c["type"] == "PERSP"
    assert (c["lens_mm"], c["sensor_width"], c["sensor_height"], c["sensor_fit"]) == \
        (35.0, 32.0, 18.0, "VERTICAL")
    assert c["shift_x"] == pytest.approx(0.1) and c["shift_y"] == pytest.approx(-0.2)
    assert (c["clip_start"], c["clip_end"]) == (0.5, 250.0)
    assert c["use_dof"] and c["focus_distance"] == 7.5
    assert c["fstop"] == pytest.approx(1.4)
    assert (c["blades"], c["rotation"], c["ratio"]) == (6, pytest.approx(0.25), 1.5)
    assert c["pixel_aspect_x"] == 2.0


@pytest.mark.parametrize("rotation", [(0.0, 0.0, 0.0), (0.4, -0.3, 1.2)])
def test_focus_object_is_measured_along_the_view_axis(fresh, rotation):
    cam = camera_object(location=(0.5, -1.0, 2.0), rotation=rotation)
    cam.data.dof.use_dof = True
    cam.data.dof.focus_distance = 99.0  # ignored when there is a focus object
    bpy.context.view_layer.update()  # matrix_world is stale until the scene is evaluated
    m = cam.matrix_world
    forward = -(m.to_3x3() @ Vector((0, 0, 1))).normalized()
    side = (m.to_3x3() @ Vector((1, 0, 0))).normalized()
    target = link(bpy.data.objects.new("Target", None))
    target.location = m.translation + 5.0 * forward + 3.0 * side  # off-axis
    cam.data.dof.focus_object = target
    c = export(fresh).camera
    assert c["focus_distance"] == pytest.approx(5.0, abs=1e-5)  # not sqrt(34)


def test_orthographic_and_panoramic_cameras(fresh):
    cam = camera_object()
    cam.data.type = "ORTHO"
    cam.data.ortho_scale = 4.0
    c = export(fresh).camera
    assert (c["type"], c["ortho_scale"]) == ("ORTHO", 4.0)
    cam.data.type = "PANO"
    exp = export(fresh)
    assert exp.camera["type"] == "PERSP"
    assert any("PANO" in w for w in exp.warnings)


def test_world_background_colour_times_strength(fresh):
    world = bpy.data.worlds.new("W")
    if bpy.app.version < (5, 0):
        world.use_nodes = True
    bg = next(n for n in world.node_tree.nodes if n.bl_idname == "ShaderNodeBackground")
    bg.inputs["Color"].default_value = (0.2, 0.4, 0.5, 1.0)
    bg.inputs["Strength"].default_value = 2.0
    fresh.world = world
    np.testing.assert_allclose(export(fresh).world_colour, (0.4, 0.8, 1.0), atol=1e-6)
    fresh.world = None
    assert export(fresh).world_colour == (0.0, 0.0, 0.0)


def test_world_volume_is_read_as_a_materials_volume(fresh, core):
    """The World Output's Volume: a homogeneous medium in every path's stack (its
    coefficients as a material's Volume gives them); a node Specula cannot render is
    named with the world; no Volume, or one of nothing, is none."""
    world = bpy.data.worlds.new("Hazy")
    if bpy.app.version < (5, 0):
        world.use_nodes = True
    tree = world.node_tree
    out = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputWorld")
    fresh.world = world
    assert export(fresh).world_volume is None
    scatter = tree.nodes.new("ShaderNodeVolumeScatter")
    scatter.inputs["Color"].default_value = (0.5, 0.8, 1.0, 1.0)
    scatter.inputs["Density"].default_value = 0.2
    scatter.inputs["Anisotropy"].default_value = 0.4
    link = tree.links.new(scatter.outputs[0], out.inputs["Volume"])
    exp = export(fresh)
    assert exp.world_volume["scattering"] == pytest.approx((0.1, 0.16, 0.2))
    assert exp.world_volume["anisotropy"] == pytest.approx(0.4)
    cube_object()
    scene, _ = exporter.to_core(export(fresh), core)
    assert scene.world_medium >= 0
    assert scene.materials.medium[scene.world_medium, 3:6] == pytest.approx((0.1, 0.16, 0.2))
    tree.links.remove(link)
    odd = tree.nodes.new("ShaderNodeBsdfDiffuse")
    tree.links.new(odd.outputs[0], out.inputs["Volume"])
    exp = export(fresh)
    assert exp.world_volume is None
    assert any("world 'Hazy'" in w and odd.name in w for w in exp.warnings), exp.warnings


def test_resolution_percentage(fresh):
    fresh.render.resolution_x, fresh.render.resolution_y = 640, 480
    fresh.render.resolution_percentage = 50
    assert exporter.resolution(fresh) == (320, 240)


def test_to_core_builds_the_scene(fresh, core):
    obj = cube_object()
    glass, _ = node_material("Glass", "ShaderNodeBsdfGlass", Roughness=0.0, IOR=1.45)
    obj.data.materials.append(glass)
    b = link(bpy.data.objects.new("B", obj.data))
    b.location = (5, 0, 0)
    exp = export(fresh)
    scene, warnings = exporter.to_core(exp, core)
    assert scene.num_triangles == 24
    assert warnings == []
    assert list(scene.materials.names) == ["Glass"]
    assert scene.materials.ior[0] == pytest.approx(1.45)
    world = scene.vertices.reshape(-1, 3) + scene.origin
    assert world[:, 0].max() == pytest.approx(6.0)


@pytest.mark.parametrize("mirror", [False, True])
def test_batched_instances_match_one_by_one(rng, mirror):
    n, t, k = 10, 6, 5
    mesh = exporter.MeshData(rng.normal(size=(n, 3)), rng.integers(0, n, (t, 3)),
                             np.zeros(t, np.int32), rng.normal(size=(t, 3, 3)), np.ones(t, bool),
                             np.zeros(1, np.int32))
    mats = np.tile(np.eye(4), (k, 1, 1))
    mats[:, :3, :3] = rng.normal(size=(k, 3, 3))
    mats[:, :3, 3] = rng.normal(size=(k, 3))
    sign = -1.0 if mirror else 1.0
    mats[:, :3, :3] *= (sign * np.sign(np.linalg.det(mats[:, :3, :3])))[:, None, None]
    v, tri, nrm = exporter.to_world_batch(mesh, mats)
    for i in range(k):
        vi, ti, ni = exporter.to_world(mesh, mats[i])
        np.testing.assert_allclose(v[tri[i * t:(i + 1) * t]], vi[ti], atol=1e-9)
        np.testing.assert_allclose(nrm[i * t:(i + 1) * t], ni, atol=1e-9)


def test_to_core_groups_instances(fresh, core):
    test_geometry_node_instances(fresh)
    exp = export(fresh)
    scene, _ = exporter.to_core(exp, core)
    assert scene.num_triangles == 4 * 12
    assert any("(+3 instances)" in name for name in scene.object_names)


def _environment_world(image, rotation=None, strength=2.0):
    world = bpy.data.worlds.new("Sky")
    world.use_nodes = True
    nt = world.node_tree
    bg = nt.nodes["Background"]
    bg.inputs["Strength"].default_value = strength
    tex = nt.nodes.new("ShaderNodeTexEnvironment")
    tex.image = image
    nt.links.new(tex.outputs["Color"], bg.inputs["Color"])
    if rotation is not None:
        mapping = nt.nodes.new("ShaderNodeMapping")
        mapping.inputs["Rotation"].default_value = rotation
        coords = nt.nodes.new("ShaderNodeTexCoord")
        nt.links.new(coords.outputs["Generated"], mapping.inputs["Vector"])
        nt.links.new(mapping.outputs["Vector"], tex.inputs["Vector"])
    world.color = (0.1, 0.2, 0.3)
    return world


def test_environment_texture_is_exported_with_strength_and_rotation(fresh, tmp_path, rng):
    cube_object()
    pixels = rng.random((6, 10, 4)).astype(np.float32)
    image = bpy.data.images.new("sky", 10, 6, float_buffer=True)
    image.pixels.foreach_set(pixels.ravel())
    fresh.world = _environment_world(image, rotation=(0.0, 0.0, np.pi / 2))
    exp = export(fresh)
    env = exp.environment
    assert np.allclose(env["environment"], 2.0 * pixels[..., :3], atol=1e-6)
    assert np.allclose(env["texture_from_world"] @ [1, 0, 0], [0, 1, 0], atol=1e-6)
    assert not any("Sky" in w for w in exp.warnings)


def test_missing_environment_image_warns_and_uses_a_constant_world(fresh, tmp_path):
    cube_object()
    image = bpy.data.images.new("gone", 4, 4)
    image.source = "FILE"  # now backed by a file that does not exist
    image.filepath = str(tmp_path / "nowhere.hdr")
    fresh.world = _environment_world(image)
    exp = export(fresh)
    assert exp.environment is None
    assert any("world 'Sky'" in w and "cannot be read" in w for w in exp.warnings)
    assert np.allclose(exp.world_colour, (0.1, 0.2, 0.3))


def _node_world(name="Nodes"):
    """A world whose node tree holds only its output, and that output."""
    world = bpy.data.worlds.new(name)
    world.use_nodes = True
    nt = world.node_tree
    for node in [n for n in nt.nodes if n.bl_idname != "ShaderNodeOutputWorld"]:
        nt.nodes.remove(node)
    world.color = (0.1, 0.2, 0.3)
    return world, nt, nt.nodes["World Output"]


def test_a_world_node_tree_is_baked_into_a_map(fresh):
    """Background Strength from the direction's height (Texture Coordinate Generated,
    Separate XYZ): a map bright above the horizon and black below, each row the height of
    its centre, looked up in the world's own frame."""
    cube_object()
    world, nt, out = _node_world()
    coords, xyz, bg = (nt.nodes.new(k) for k in ("ShaderNodeTexCoord", "ShaderNodeSeparateXYZ",
                                                 "ShaderNodeBackground"))
    bg.inputs["Color"].default_value = (1.0, 0.5, 0.25, 1.0)
    nt.links.new(coords.outputs["Generated"], xyz.inputs["Vector"])
    nt.links.new(xyz.outputs["Z"], bg.inputs["Strength"])
    nt.links.new(bg.outputs["Background"], out.inputs["Surface"])
    fresh.world = world
    exp = export(fresh)
    assert not any("Nodes" in w for w in exp.warnings), exp.warnings
    image = exp.environment["environment"]
    h, w = image.shape[:2]
    assert (w, h) == (exporter.WORLD_BAKE_WIDTH, exporter.WORLD_BAKE_WIDTH // 2)
    height = np.sin(((np.arange(h) + 0.5) / h - 0.5) * np.pi)
    expected = np.maximum(height, 0.0)[:, None, None] * np.array([1.0, 0.5, 0.25])
    assert np.allclose(image, expected, atol=1e-6)
    assert np.array_equal(exp.environment["texture_from_world"], np.eye(3))


def test_a_world_tree_that_does_not_vary_is_its_constant(fresh):
    """An RGB node and a Math node into a Background: its colour x strength, no map."""
    cube_object()
    world, nt, out = _node_world()
    rgb, maths, bg = (nt.nodes.new(k) for k in ("ShaderNodeRGB", "ShaderNodeMath",
                                                "ShaderNodeBackground"))
    rgb.outputs[0].default_value = (0.2, 0.4, 0.6, 1.0)
    maths.operation = "MULTIPLY"
    maths.inputs[0].default_value, maths.inputs[1].default_value = 1.5, 2.0
    nt.links.new(rgb.outputs[0], bg.inputs["Color"])
    nt.links.new(maths.outputs[0], bg.inputs["Strength"])
    nt.links.new(bg.outputs["Background"], out.inputs["Surface"])
    fresh.world = world
    exp = export(fresh)
    assert exp.environment is None
    np.testing.assert_allclose(exp.world_colour, (0.6, 1.2, 1.8), rtol=1e-6)


def test_is_camera_ray_bakes_the_world_camera_rays_see(fresh, core):
    """A Mix Shader by Light Path's Is Camera Ray: camera rays see its second shader, every
    other ray its first (constant here: two small maps of one colour each)."""
    cube_object()
    world, nt, out = _node_world()
    path, mix = nt.nodes.new("ShaderNodeLightPath"), nt.nodes.new("ShaderNodeMixShader")
    lit, seen = nt.nodes.new("ShaderNodeBackground"), nt.nodes.new("ShaderNodeBackground")
    lit.inputs["Color"].default_value = (1.0, 0.8, 0.6, 1.0)
    seen.inputs["Color"].default_value = (0.1, 0.2, 0.3, 1.0)
    nt.links.new(path.outputs["Is Camera Ray"], mix.inputs["Fac"])
    nt.links.new(lit.outputs["Background"], mix.inputs[1])
    nt.links.new(seen.outputs["Background"], mix.inputs[2])
    nt.links.new(mix.outputs["Shader"], out.inputs["Surface"])
    fresh.world = world
    exp = export(fresh)
    assert not any("Nodes" in w for w in exp.warnings), exp.warnings
    assert np.allclose(exp.environment["environment"], (1.0, 0.8, 0.6))
    camera = core.shading.RAY_CAMERA
    assert list(exp.environment["ray_environments"]) == [camera]
    assert np.allclose(exp.environment["ray_environments"][camera], (0.1, 0.2, 0.3))


def test_is_glossy_or_diffuse_ray_bakes_a_map_for_each_kind_of_ray_they_tell_apart(fresh, core):
    """A world lit by one colour, reflected in glossy surfaces as another and seen by
    diffuse bounces as a third (Is Glossy Ray, Is Diffuse Ray): light samples see the
    first map; each escaping kind of ray the map its flags read, the glossy and singular
    reflections and transmissions sharing one; camera and volume rays read neither
    output, so they see the light samples' map (no entry)."""
    cube_object()
    world, nt, out = _node_world()
    path = nt.nodes.new("ShaderNodeLightPath")
    glossy, diffuse = nt.nodes.new("ShaderNodeMixShader"), nt.nodes.new("ShaderNodeMixShader")
    colours = {}
    for name, rgb in (("lit", (1.0, 0.8, 0.6)), ("mirrored", (0.1, 0.2, 0.3)),
                      ("bounced", (0.0, 0.5, 0.0))):
        colours[name] = nt.nodes.new("ShaderNodeBackground")
        colours[name].inputs["Color"].default_value = rgb + (1.0,)
    nt.links.new(path.outputs["Is Diffuse Ray"], diffuse.inputs["Fac"])
    nt.links.new(colours["lit"].outputs[0], diffuse.inputs[1])
    nt.links.new(colours["bounced"].outputs[0], diffuse.inputs[2])
    nt.links.new(path.outputs["Is Glossy Ray"], glossy.inputs["Fac"])
    nt.links.new(diffuse.outputs[0], glossy.inputs[1])
    nt.links.new(colours["mirrored"].outputs[0], glossy.inputs[2])
    nt.links.new(glossy.outputs["Shader"], out.inputs["Surface"])
    fresh.world = world
    exp = export(fresh)
    assert not any("Nodes" in w for w in exp.warnings), exp.warnings
    sh = core.shading
    maps = exp.environment["ray_environments"]
    assert np.allclose(exp.environment["environment"], (1.0, 0.8, 0.6))
    glossy_rays = [sh.RAY_GLOSSY | s | side for s in (0, sh.RAY_SINGULAR)
                   for side in (sh.RAY_REFLECT, sh.RAY_TRANSMIT)]
    diffuse_rays = [sh.RAY_DIFFUSE | side for side in (sh.RAY_REFLECT, sh.RAY_TRANSMIT)]
    assert sorted(maps) == sorted(glossy_rays + diffuse_rays)
    for flags in glossy_rays:
        assert np.allclose(maps[flags], (0.1, 0.2, 0.3)) and maps[flags] is maps[glossy_rays[0]]
    for flags in diffuse_rays:
        assert np.allclose(maps[flags], (0.0, 0.5, 0.0))


@pytest.mark.parametrize("node", ["ShaderNodeLightPath", "ShaderNodeTexSky"])
def test_a_world_tree_that_cannot_be_baked_warns_naming_its_node(fresh, node):
    """A Light Path node's Ray Depth (the maps tell kinds of ray apart, not depths) or a
    node without an instruction: a warning naming the world and the node, and the world's
    viewport colour."""
    cube_object()
    world, nt, out = _node_world()
    src, bg = nt.nodes.new(node), nt.nodes.new("ShaderNodeBackground")
    src.name = "Culprit"
    if node == "ShaderNodeTexSky":
        src.sky_type = "HOSEK_WILKIE"  # (the other types are baked)
    nt.links.new(src.outputs["Ray Depth"] if node == "ShaderNodeLightPath"
                 else src.outputs[0],
                 bg.inputs["Strength"] if node == "ShaderNodeLightPath" else bg.inputs["Color"])
    nt.links.new(bg.outputs["Background"], out.inputs["Surface"])
    fresh.world = world
    exp = export(fresh)
    assert exp.environment is None
    assert np.allclose(exp.world_colour, (0.1, 0.2, 0.3))
    said = [w for w in exp.warnings if "world 'Nodes'" in w]
    assert said and "'Culprit'" in said[0], exp.warnings


def _sky_world(sky_type, elevation=30.0, rotation=50.0, strength=0.1):
    world, nt, out = _node_world()
    sky, bg = nt.nodes.new("ShaderNodeTexSky"), nt.nodes.new("ShaderNodeBackground")
    sky.name = "Daylight"
    sky.sky_type = sky_type
    sky.sun_elevation, sky.sun_rotation = math.radians(elevation), math.radians(rotation)
    bg.inputs["Strength"].default_value = strength
    nt.links.new(sky.outputs["Color"], bg.inputs["Color"])
    nt.links.new(bg.outputs["Background"], out.inputs["Surface"])
    return world, sky


@pytest.mark.parametrize("sky_type", ["MULTIPLE_SCATTERING", "SINGLE_SCATTERING"])
def test_a_sky_texture_is_baked_and_its_sun_disc_becomes_a_sun_light(fresh, core, sky_type):
    """A Multiple or Single Scattering sky: a map of the sky without its sun (its brightest
    texel far below the disc's radiance), and one sun light toward the sun, of the disc's
    angle, whose irradiance is the disc's (environment.disc_irradiance) at the Background's
    strength; camera rays see it, as they see the world."""
    cube_object()
    fresh.world, node = _sky_world(sky_type)
    exp = export(fresh)
    assert exp.warnings == []
    env = exp.environment["environment"]
    assert env.shape[1] == exporter.WORLD_BAKE_WIDTH and np.all(np.isfinite(env))
    suns = [light for light in exp.lights if light["type"] == "SUN"]
    assert len(suns) == 1 and "'Daylight'" in suns[0]["name"]
    sun = suns[0]
    e, r = core.sky.sun_position(node.sun_elevation, node.sun_rotation)
    toward = np.asarray(sun["matrix"])[:3, 2]  # a sun shines along its local -Z
    assert np.allclose(toward, core.sky.sun_direction(e, r))
    assert toward[2] == pytest.approx(math.sin(math.radians(30.0)))
    assert sun["angle"] == pytest.approx(node.sun_size) and sun["visible_camera"]
    radiance = np.array(sun["power"]) / (math.pi * math.sin(node.sun_size / 2) ** 2)
    assert np.all(radiance > 1e3 * env.max())  # the disc is not in the map
    core.scene.Light(**sun).validate()
    # Twice the strength, twice the power; Sun Disc off, or the sun set, no light.
    fresh.world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.2
    assert np.allclose(next(li for li in export(fresh).lights if li["type"] == "SUN")["power"],
                       2 * np.array(sun["power"]))
    node.sun_disc = False
    assert not export(fresh).lights
    node.sun_disc, node.sun_elevation = True, math.radians(-5.0)
    assert not export(fresh).lights


def test_a_preetham_sky_is_baked_without_a_sun_light(fresh, core):
    """Preetham's analytic sky: baked (its zenith the zenith's luminance times the
    strength, in the scene's RGB), no disc and so no light; Hosek-Wilkie is warned."""
    cube_object()
    fresh.world, node = _sky_world("PREETHAM", strength=2.0)
    node.sun_direction, node.turbidity = (0.0, 0.6, 0.8), 3.0
    exp = export(fresh)
    assert exp.warnings == [] and not exp.lights
    env = exp.environment["environment"]
    params = core.sky.preetham_params(node.sun_direction, node.turbidity)
    xyz = np.array(core.sky.preetham_xyz(0.0, 0.0, 1.0, np.array(params), 0))
    m = np.array(shader_nodes.xyz_to_scene_linear()).reshape(3, 3)
    assert np.allclose(env[-1].mean(axis=0), 2.0 * m @ xyz, rtol=2e-3)
    node.sky_type = "HOSEK_WILKIE"
    exp = export(fresh)
    assert exp.environment is None and any("'Daylight'" in w for w in exp.warnings)


def test_a_sun_disc_some_rays_see_otherwise_warns(fresh):
    """A Light Path's Is Glossy Ray mixing the sky with a grey: Cycles' glossy bounces see
    no disc, Specula's one sun light is seen by every ray (warned, naming the node)."""
    cube_object()
    fresh.world, node = _sky_world("MULTIPLE_SCATTERING")
    nt = fresh.world.node_tree
    out = nt.nodes["World Output"]
    path, mix = nt.nodes.new("ShaderNodeLightPath"), nt.nodes.new("ShaderNodeMixShader")
    grey = nt.nodes.new("ShaderNodeBackground")
    nt.links.new(path.outputs["Is Glossy Ray"], mix.inputs["Fac"])
    nt.links.new(nt.nodes["Background"].outputs["Background"], mix.inputs[1])
    nt.links.new(grey.outputs["Background"], mix.inputs[2])
    nt.links.new(mix.outputs["Shader"], out.inputs["Surface"])
    exp = export(fresh)
    assert len(exp.lights) == 1
    assert any("'Daylight'" in w and "kinds of ray" in w for w in exp.warnings), exp.warnings
    nt.links.remove(path.outputs["Is Glossy Ray"].links[0])  # (Fac 0.5: all alike)
    nt.links.new(nt.nodes.new("ShaderNodeValue").outputs[0], mix.inputs["Fac"])
    assert not export(fresh).warnings


def test_a_mapping_that_moves_or_scales_the_environment_is_baked(fresh, rng):
    """Only a rotating Mapping is looked up exactly; one with a Scale is baked, and the map
    is the image where the scaled direction points (here: z scaled by 0, the horizon's
    row everywhere)."""
    cube_object()
    pixels = rng.random((8, 16, 4)).astype(np.float32)
    image = bpy.data.images.new("sky", 16, 8, float_buffer=True)
    image.pixels.foreach_set(pixels.ravel())
    world = _environment_world(image, rotation=(0.0, 0.0, 0.0), strength=1.0)
    mapping = next(n for n in world.node_tree.nodes if n.bl_idname == "ShaderNodeMapping")
    mapping.inputs["Scale"].default_value = (1.0, 1.0, 0.0)
    fresh.world = world
    exp = export(fresh)
    baked = exp.environment["environment"]
    assert baked.shape[1] == exporter.WORLD_BAKE_WIDTH  # twice 16 is less
    # Every row is the horizon's (v = 0.5: half way between image rows 3 and 4).
    horizon = 0.5 * (pixels[3, :, :3] + pixels[4, :, :3])
    row = baked[0]
    u = (np.arange(row.shape[0]) + 0.5) / row.shape[0]
    x = u * 16 - 0.5
    x0 = np.floor(x).astype(int)
    f = (x - x0)[:, None]
    expected = (1 - f) * horizon[x0 % 16] + f * horizon[(x0 + 1) % 16]
    assert np.allclose(row, expected, atol=1e-5)
    assert np.allclose(baked, row[None], atol=1e-6)


@pytest.mark.parametrize("mirror", [False, True])
def test_normal_map_tangents_are_blenders(fresh, core, mirror):
    """A normal-mapped material's triangles carry Blender's own tangents and bitangent signs
    (Mesh.calc_tangents) in world space; a mirroring object flips the sign with the
    winding, so the bitangent still follows the map's v in the world."""
    import bmesh
    from addon_helpers import node_material
    mesh = bpy.data.meshes.new("Ball")
    bm = bmesh.new()
    bm.loops.layers.uv.new("UVMap")
    bmesh.ops.create_uvsphere(bm, u_segments=16, v_segments=8, radius=1.0, calc_uvs=True)
    for f in bm.faces:
        f.smooth = True
    bm.to_mesh(mesh)
    bm.free()
    obj = link(bpy.data.objects.new("Ball", mesh))
    obj.rotation_euler = (0.3, 0.2, 0.1)
    obj.scale = (1.0, -1.0, 1.0) if mirror else (1.0, 1.0, 1.0)
    mat, node = node_material("Bumpy", "ShaderNodeBsdfDiffuse")
    nmap = mat.node_tree.nodes.new("ShaderNodeNormalMap")
    mat.node_tree.links.new(nmap.outputs[0], node.inputs["Normal"])
    obj.data.materials.append(mat)
    exp = export(fresh)
    scene, _ = exporter.to_core(exp, core)
    ev = obj.evaluated_get(depsgraph())
    me = ev.to_mesh()
    me.calc_tangents()
    linear = np.array(ev.matrix_world)[:3, :3]
    tangent = np.array([[tuple(me.loops[i].tangent) for i in t.loops] for t in me.loop_triangles])
    sign = np.array([[me.loops[i].bitangent_sign for i in t.loops] for t in me.loop_triangles])
    normal = np.array([[tuple(me.loops[i].normal) for i in t.loops] for t in me.loop_triangles])
    ev.to_mesh_clear()
    world_t = tangent @ linear.T
    world_b = sign[..., None] * np.cross(normal, tangent) @ linear.T  # Blender's bitangent
    got = scene.tangents
    order = [0, 2, 1] if mirror else [0, 1, 2]
    np.testing.assert_allclose(got[..., :3], world_t[:, order], atol=1e-5)
    # The core forms B = sign (n x t) from its world-space normal and tangent.
    n_world = scene.normals
    b = got[..., 3:] * np.cross(n_world, got[..., :3])
    cos = np.sum(b * world_b[:, order], axis=-1) / (
        np.linalg.norm(b, axis=-1) * np.linalg.norm(world_b[:, order], axis=-1))
    assert np.all(cos > 0.99), cos.min()


def test_a_textured_mix_factor_alone_exports_the_uv_maps(fresh, core):
    """Regression: a material whose only texture drives a mix factor (here a Checker on the
    UV map into the Principled BSDF's Metallic) reads UV maps, so the mesh exports them
    (without, every hit read the factor at UV (0, 0))."""
    import bmesh
    from addon_helpers import node_material
    mesh = bpy.data.meshes.new("Ball")
    bm = bmesh.new()
    bm.loops.layers.uv.new("UVMap")
    bmesh.ops.create_uvsphere(bm, u_segments=16, v_segments=8, radius=1.0, calc_uvs=True)
    bm.to_mesh(mesh)
    bm.free()
    obj = link(bpy.data.objects.new("Ball", mesh))
    mat, node = node_material("Checkered", "ShaderNodeBsdfPrincipled")
    tree = mat.node_tree
    checker = tree.nodes.new("ShaderNodeTexChecker")
    coords = tree.nodes.new("ShaderNodeTexCoord")
    tree.links.new(coords.outputs["UV"], checker.inputs["Vector"])
    tree.links.new(checker.outputs["Fac"], node.inputs["Metallic"])
    obj.data.materials.append(mat)
    exp = export(fresh)
    scene, warnings = exporter.to_core(exp, core)
    assert not any("no UV map" in w for w in warnings), warnings
    assert scene.uv is not None and np.ptp(scene.uv[0]) > 0.5
    assert scene.programs is not None and (scene.programs.fac[:, 0] >= 0).any()


def test_generated_and_object_coordinates_follow_the_mesh(fresh, core):
    """A Checker Texture with its Vector unlinked reads Generated coordinates, the mesh's
    texture space ((P - location) / (2 size) + 1/2: the default cube's corners at 0 and 1),
    and Texture Coordinate's Object output the vertex in the object's space, whatever the
    object's transform (meshes carry them only where a program reads them)."""
    obj = cube_object("Crate")
    obj.location, obj.scale = (3.0, 0.0, 0.0), (2.0, 1.0, 1.0)
    mat, node = node_material("Procedural", "ShaderNodeBsdfDiffuse")
    tree = mat.node_tree
    checker = tree.nodes.new("ShaderNodeTexChecker")
    tree.links.new(checker.outputs["Color"], node.inputs["Color"])
    obj.data.materials.append(mat)
    scene, warnings = exporter.to_core(export(fresh), core)
    assert warnings == [] and scene.uv.shape[0] == 1 and scene.programs.colour[0, 0] >= 0
    generated = scene.uv[0].copy()
    coords = tree.nodes.new("ShaderNodeTexCoord")
    tree.links.new(coords.outputs["Object"], checker.inputs["Vector"])
    scene, warnings = exporter.to_core(export(fresh), core)
    assert warnings == []
    local = scene.uv[0]  # the cube's own corners, unmoved and unscaled
    np.testing.assert_array_equal(np.abs(local), 1.0)
    assert len(np.unique(local.reshape(-1, 3), axis=0)) == 8
    np.testing.assert_allclose(generated, local * 0.5 + 0.5, atol=1e-6)


def test_colour_attributes_are_read_per_corner_and_named_when_missing(fresh, core):
    """A Color Attribute node reads the mesh's default colour attribute (layer name empty)
    in linear RGB, per corner, interpolated like a UV map; an object without the attribute
    it names reads 0 there, and the warning names the attribute and the object."""
    obj = cube_object("Painted")
    attr = obj.data.color_attributes.new("Paint", "BYTE_COLOR", "CORNER")
    rgba = np.random.default_rng(3).random((len(attr.data), 4)).astype(np.float32)
    attr.data.foreach_set("color", rgba.ravel())
    stored = np.zeros(len(attr.data) * 4, np.float32)
    attr.data.foreach_get("color", stored)  # bytes: the linear value of the stored byte
    mat, node = node_material("Vertex", "ShaderNodeBsdfDiffuse")
    tree = mat.node_tree
    colour = tree.nodes.new("ShaderNodeVertexColor")
    tree.links.new(colour.outputs["Color"], node.inputs["Color"])
    obj.data.materials.append(mat)
    scene, warnings = exporter.to_core(export(fresh), core)
    assert warnings == [] and scene.uv.shape[0] == 1
    corners = sorted(map(tuple, scene.uv[0].reshape(-1, 3).round(5)))
    want = sorted(map(tuple, stored.reshape(-1, 4)[:, :3].round(5)))
    assert len(corners) == 36 and set(corners) == set(want)
    colour.layer_name = "Wetness"
    scene, warnings = exporter.to_core(export(fresh), core)
    assert any("'Painted'" in w and "colour attribute 'Wetness'" in w for w in warnings)
    assert not scene.uv.any()


def test_attribute_node_reads_each_type_and_names_a_missing_one(fresh, core):
    """An Attribute node reads a face attribute per triangle (every corner of a face the
    face's value), its Fac from the attribute's type (a 2D value's x); an Object-type
    Attribute is unsupported and named; a missing attribute reads 0, its Alpha 1 (as a real
    Cycles render of one reads), and is named with its object."""
    obj = cube_object("Tagged")
    faces = obj.data.attributes.new("tag", "FLOAT", "FACE")
    values = np.arange(1, len(faces.data) + 1, dtype=np.float32)
    faces.data.foreach_set("value", values)
    mat, node = node_material("Tags", "ShaderNodeBsdfDiffuse")
    tree = mat.node_tree
    attr = tree.nodes.new("ShaderNodeAttribute")
    attr.attribute_name = "tag"
    tree.links.new(attr.outputs["Fac"], node.inputs["Color"])
    obj.data.materials.append(mat)
    scene, warnings = exporter.to_core(export(fresh), core)
    assert warnings == []
    (scalars,) = scene.uv  # (Fac, Alpha, 0) per corner: each triangle one face's value
    assert set(np.unique(scalars[:, :, 0])) == set(values)
    assert (scalars[:, :, 0] == scalars[:, :1, 0]).all() and (scalars[:, :, 1] == 1).all()
    attr.attribute_name = "missing"
    scene, warnings = exporter.to_core(export(fresh), core)
    assert any("'Tagged'" in w and "attribute 'missing'" in w and "Alpha 1" in w
               for w in warnings), warnings
    (scalars,) = scene.uv
    assert (scalars[:, :, 0] == 0).all() and (scalars[:, :, 1] == 1).all()
    attr.attribute_type = "INSTANCER"
    spec, warnings = materials.convert(mat)
    assert spec.ctor == "diffuse" and "colour_program" not in spec.kwargs
    assert any(attr.name in w and "INSTANCER" in w for w in warnings), warnings


# What a Cycles 5.0 render of an Emission fed by an Attribute node of type Object read, per
# property (one-off render, 1 spp, values rounded): (Color, Fac, Alpha).
CYCLES_OBJECT_ATTRIBUTES = {
    "f": ((0.25, 0.25, 0.25), 0.25, 1.0),            # a float (the object's, not the mesh's)
    "i": ((3.0, 3.0, 3.0), 3.0, 1.0),                # an integer
    "v2": ((0.1, 0.2, 0.0), 0.1, 1.0),               # two numbers: Fac is x
    "v4": ((0.1, 0.2, 0.3), 0.2, 0.4),               # four: Fac the mean of three, Alpha w
    "md": ((0.75, 0.75, 0.75), 0.75, 1.0),           # on the mesh only
    "color": ((0.6, 0.5, 0.4), 0.5, 0.7),            # the built-in viewport colour
    "location": ((0.05, 0.0, 0.0), 0.05 / 3, 1.0),   # an RNA path
    "s": ((0.0, 0.0, 0.0), 0.0, 0.0),                # a string: not a number
    "v5": ((0.0, 0.0, 0.0), 0.0, 0.0),               # five numbers
    "missing": ((0.0, 0.0, 0.0), 0.0, 0.0),
}


# What a Cycles 5.0 render read through an Attribute node of type View Layer, with "a" on
# the view layer (0.2), the scene (0.5) and the world (0.9), "b" on the scene (0.3) and the
# world (0.8), "c" on the world, "d" only on the object: (Color, Fac, Alpha).
CYCLES_VIEW_LAYER_ATTRIBUTES = {
    "a": ((0.2, 0.2, 0.2), 0.2, 1.0),
    "b": ((0.3, 0.3, 0.3), 0.3, 1.0),
    "c": ((0.1, 0.2, 0.3), 0.2, 1.0),
    "frame_current": ((7.0, 7.0, 7.0), 7.0, 1.0),      # the scene's RNA property
    "samples": ((0.0, 0.0, 0.0), 0.0, 1.0),            # the view layer's own (0)
    "color": ((0.05, 0.05, 0.05), 0.05, 1.0),          # the world's viewport colour
    "d": ((0.0, 0.0, 0.0), 0.0, 0.0),                  # an object's: not looked up
    "name": ((0.0, 0.0, 0.0), 0.0, 0.0),               # a string
}


def test_attribute_node_of_type_view_layer_is_a_constant_of_the_render(fresh, core):
    """An Attribute node of type View Layer reads the view layer's, else the scene's, else
    the world's custom property or RNA path, a constant of the render, as a Cycles render
    read (above); a property none of them holds reads 0 and is warned naming the node."""
    from engine import shading
    obj = cube_object("Lit")
    obj["d"] = 0.4
    world = bpy.data.worlds.new("World")
    world.color = (0.05, 0.05, 0.05)
    fresh.world = world
    fresh.frame_current = 7
    bpy.context.view_layer["a"], fresh["a"], world["a"] = 0.2, 0.5, 0.9
    fresh["b"], world["b"], world["c"] = 0.3, 0.8, [0.1, 0.2, 0.3]
    mat, node = node_material("VL", "ShaderNodeEmission")
    tree = mat.node_tree
    attr = tree.nodes.new("ShaderNodeAttribute")
    attr.attribute_type = "VIEW_LAYER"
    obj.data.materials.append(mat)

    def emitted(output, colour):
        for old in list(tree.links):
            if old.from_node == attr:
                tree.links.remove(old)
        tree.links.new(attr.outputs[output], node.inputs["Strength"])
        if colour:
            tree.links.new(attr.outputs["Color"], node.inputs["Color"])
        exported = export(fresh)
        spec = next(m for m in exported.materials if m.name == "VL")
        program = spec.kwargs.get("emission_program")
        value = (shading.evaluate(program)[program.out:program.out + 3] if program is not None
                 else np.asarray(spec.kwargs.get("colour", (0.0,) * 3)) *
                 spec.kwargs.get("strength", 0.0))
        return value, exported.warnings

    for name, (colour, fac, alpha) in CYCLES_VIEW_LAYER_ATTRIBUTES.items():
        attr.attribute_name = name
        value, warnings = emitted("Alpha", True)
        assert np.allclose(value, np.multiply(colour, alpha), atol=1e-6), (name, value)
        value, _ = emitted("Fac", False)
        assert np.allclose(value, fac, atol=1e-6), (name, value)
        warned = any(f"Attribute node '{attr.name}' reads '{name}'" in w for w in warnings)
        assert warned == (alpha == 0.0), (name, warnings)


def test_attribute_node_of_type_object_reads_each_objects_property(fresh, core):
    """An Attribute node of type Object reads, per object, a custom property or RNA path of
    the object, then of its mesh, as Cycles does (the values a Cycles render read, above);
    two objects sharing the material read their own values; a property an object lacks
    reads 0, Alpha included, and is warned naming the object and the material."""
    sh = core.shading
    a, b = cube_object("A"), cube_object("B")
    a.location.x, b.location.x = 0.05, 3.0
    a["f"], a.data["f"], a.data["md"] = 0.25, 0.9, 0.75
    a["i"], a["v2"], a["v4"], a["s"] = 3, [0.1, 0.2], [0.1, 0.2, 0.3, 0.4], "text"
    a["v5"], a.color = [1.0, 2, 3, 4, 5], (0.6, 0.5, 0.4, 0.7)
    b["f"] = 0.5
    mat, node = node_material("Props", "ShaderNodeEmission")
    tree = mat.node_tree
    attr = tree.nodes.new("ShaderNodeAttribute")
    attr.attribute_type = "OBJECT"
    tree.links.new(attr.outputs["Color"], node.inputs["Color"])
    tree.links.new(attr.outputs["Alpha"], node.inputs["Strength"])
    a.data.materials.append(mat)
    b.data.materials.append(mat)
    for name, (colour, fac, alpha) in CYCLES_OBJECT_ATTRIBUTES.items():
        attr.attribute_name = name
        exported = export(fresh)
        scene, _ = exporter.to_core(exported, core)
        by_name = dict(zip(scene.uv_names, scene.uv))
        vector = by_name[sh.OBJECT_ATTRIBUTE + name][:12]  # A's twelve triangles
        scalars = by_name[sh.OBJECT_ATTRIBUTE_SCALARS + name][:12]
        assert np.allclose(vector, colour, atol=1e-6), name
        assert np.allclose(scalars[..., :2], (fac, alpha), atol=1e-6), name
        warned = any("object 'A'" in w and f"property '{name}'" in w and "'Props'" in w
                     for w in exported.warnings)
        assert warned == (alpha == 0.0), (name, exported.warnings)
    attr.attribute_name = "f"
    scene, _ = exporter.to_core(export(fresh), core)
    values = dict(zip(scene.uv_names, scene.uv))[sh.OBJECT_ATTRIBUTE_SCALARS + "f"][:, 0, 0]
    assert sorted(set(values.tolist())) == [0.25, 0.5]

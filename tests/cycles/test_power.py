"""The comparison has power: deliberately wrong renders must disagree with Cycles.

Each injected error is applied to the exported core scene, the render settings or (one-sided
emission, the old spot cone) a one-off kernel (tests/patching.py), on a variant where the
error shows; the correct render of the same variant must agree (test_agreement.py checks it
too) and the wrong one must not.
"""

import copy
import dataclasses
import math
import time
from contextlib import contextmanager, nullcontext

import numpy as np
import pytest

from . import harness, renderers


def _ior_plus_3_percent(scene, settings):
    m = scene.materials
    glass = m.kind == renderers.core().scene.GLASS
    scene.materials = dataclasses.replace(m, ior=np.where(glass, m.ior * 1.03, m.ior))
    return scene, settings


def _schlick(scene, settings):
    return scene, dataclasses.replace(settings, fresnel="schlick")


@contextmanager
def _own_kernel():
    """Render with the plan's own kernel: Schlick's Fresnel is a second generic kernel
    (every feature on) to compile, about five times the plan's compile (the same pixels)."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("SPECULA_KERNEL", "specialised")
        yield


def _fstop_plus_10_percent(scene, settings):
    scene.camera = dataclasses.replace(scene.camera, fstop=scene.camera.fstop * 1.1)
    return scene, settings


def _focus_plus_5_percent(scene, settings):
    cam = scene.camera
    scene.camera = dataclasses.replace(cam, focus_distance=cam.focus_distance * 1.05)
    return scene, settings


def _aperture_half_blade(scene, settings):
    cam = scene.camera
    assert cam.blades >= 3, "the variant must have a polygonal aperture"
    scene.camera = dataclasses.replace(cam, rotation=cam.rotation + math.pi / cam.blades)
    return scene, settings


def _light_power_plus_5_percent(scene, settings):
    scene.lights = [dataclasses.replace(light, power=tuple(1.05 * c for c in light.power))
                    for light in scene.lights]
    return scene, settings


def _one_bounce_fewer(scene, settings):
    return scene, dataclasses.replace(settings, max_bounces=settings.max_bounces - 1)


def front_only_emission(i, row, depth, x, sc, paths, mis, max_bounces):
    """handle_emission for front faces only."""
    if x.front:
        original_handle_emission(i, row, depth, x, sc, paths, mis, max_bounces)  # noqa: F821


def front_only_triangle(e, px, py, pz, ua, ub, em):
    """lights.sample_triangle carrying no radiance to points behind the triangle."""
    wx, wy, wz, dist, q0, q1, q2, pdf = original_sample_triangle(  # noqa: F821
        e, px, py, pz, ua, ub, em)
    if em.normal[e, 0] * wx + em.normal[e, 1] * wy + em.normal[e, 2] * wz > 0.0:
        q0 = q1 = q2 = 0.0  # the light faces away from p
    return wx, wy, wz, dist, q0, q1, q2, pdf


@contextmanager
def _one_sided_emission():
    """Emitters light only the side their geometric normal faces: camera and BSDF rays see
    no emission from a back face, and light samples on an emissive triangle seen from
    behind carry no radiance (a one-off kernel with both stages swapped)."""
    from tests.patching import module_with, one_off_kernels

    core = renderers.core()
    with pytest.MonkeyPatch.context() as mp:
        one_off_kernels(mp, handle_emission=front_only_emission,
                        original_handle_emission=core.integrator.handle_emission,
                        lights=module_with(core.lights, sample_triangle=front_only_triangle,
                                           original_sample_triangle=core.lights.sample_triangle))
        yield


def _no_terminator_offset(scene, settings):
    scene.terminator_offset = np.zeros_like(scene.terminator_offset)
    return scene, settings


@contextmanager
def _glossy_compensation_white():
    """Issue 12's old Glossy: energy compensation with Fss = 1, the colour applied after
    (bsdf.layer_fms builds the kernel's tables, in Python)."""
    bsdf = renderers.core().bsdf
    layer_fms = bsdf.layer_fms

    def white(tables, principled, colour):
        return layer_fms(tables, principled, np.ones(3) if not principled else colour)

    bsdf.layer_fms = white
    try:
        yield
    finally:
        bsdf.layer_fms = layer_fms


def cone_toward_centre(j, px, py, pz, ua, ub, L):
    """lights._sample_point_light with the spot cone's smoothstep taken toward the light's
    centre instead of along the sampled ray."""
    wx, wy, wz, dist, v0, v1, v2, pdf = original_sample_point_light(  # noqa: F821
        j, px, py, pz, ua, ub, L)
    if L[j, _TYPE] == SPOT:  # noqa: F821
        tx, ty, tz = L[j, _CENTRE] - px, L[j, _CENTRE + 1] - py, L[j, _CENTRE + 2] - pz  # noqa
        n = max(math.sqrt(tx * tx + ty * ty + tz * tz), 1e-300)
        along = spot_attenuation(j, -wx, -wy, -wz, L)  # noqa: F821
        toward = spot_attenuation(j, -tx / n, -ty / n, -tz / n, L)  # noqa: F821
        k = toward / along if along > 0 else 0.0
        v0, v1, v2 = v0 * k, v1 * k, v2 * k
    return wx, wy, wz, dist, v0, v1, v2, pdf


@contextmanager
def _spot_cone_toward_centre():
    """Issue 12's old spot light: next-event estimation took the cone's smoothstep toward
    the light's centre instead of along the sampled ray (a one-off kernel)."""
    from tests.patching import module_with, one_off_kernels

    lights = renderers.core().lights
    with pytest.MonkeyPatch.context() as mp:
        one_off_kernels(mp, lights=module_with(
            lights, _sample_point_light=cone_toward_centre,
            original_sample_point_light=lights._sample_point_light))
        yield


def _texture_v_flipped(scene, settings):
    scene.uv = scene.uv.copy()
    scene.uv[..., 1] = 1.0 - scene.uv[..., 1]
    return scene, settings


def _srgb_not_decoded(scene, settings):
    textures = scene.programs.textures.copy()
    textures[:, 5] = 0
    scene.programs = scene.programs._replace(textures=textures)
    return scene, settings


def _textures_as_their_means(scene, settings):
    """The renderer before shader programs: every textured colour its image's mean."""
    scene.programs = scene.programs._replace(
        colour=np.full_like(scene.programs.colour, -1))
    return scene, settings


def untextured_emitter(e, ua, ub, pdf, q0, q1, q2, sc, paths):
    """integrator.textured_emitter that keeps the emitter's mean radiance."""
    return q0, q1, q2


@contextmanager
def _light_samples_untextured():
    """Next-event estimation reads a textured emitter's mean, not the texture at the point
    it sampled (camera and BSDF rays still see the texture; a one-off kernel)."""
    from tests.patching import one_off_kernels

    with pytest.MonkeyPatch.context() as mp:
        one_off_kernels(mp, textured_emitter=untextured_emitter)
        yield


def _emission_as_its_mean(scene, settings):
    scene.programs = scene.programs._replace(
        emission=np.full_like(scene.programs.emission, -1))
    return scene, settings


def _roughness_as_its_mean(scene, settings):
    """The renderer before roughness programs: every textured roughness its mean."""
    scene.programs = scene.programs._replace(
        roughness=np.full_like(scene.programs.roughness, -1))
    return scene, settings


def rougher_roughness_at(mat, f, u, v, pt, uv, reg, r):
    """shading.roughness_at 10% higher where a program gives it (at most 1)."""
    x = original_roughness_at(mat, f, u, v, pt, uv, reg, r)  # noqa: F821 - the copy's
    return min(1.1 * x, 1.0) if x >= 0.0 else x


@contextmanager
def _textured_roughness_plus_10_percent():
    """Every textured roughness 10% higher at each hit (a one-off kernel)."""
    from tests.patching import module_with, one_off_kernels

    shading = renderers.core().shading
    with pytest.MonkeyPatch.context() as mp:
        one_off_kernels(mp, shading=module_with(shading, roughness_at=rougher_roughness_at,
                                                original_roughness_at=shading.roughness_at))
        yield


@contextmanager
def _group_inputs_unread():
    """The exporter reads a socket linked to a Group Input as unlinked: its own value
    inside the group, not the group node's input."""
    from addon import shader_nodes

    source = shader_nodes._source

    def own_value_inside(out, path, to_socket):
        if out.node.bl_idname == "NodeGroupInput" and path:
            return None
        return source(out, path, to_socket)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(shader_nodes, "_source", own_value_inside)
        yield


def front_facing_geometry(reg, nx, ny, nz, ix, iy, iz, backfacing):
    """shading.set_geometry that never says the hit is on a back face."""
    original_set_geometry(reg, nx, ny, nz, ix, iy, iz, False)  # noqa: F821 - the copy's


@contextmanager
def _back_faces_unseen():
    """Fresnel and Layer Weight evaluated as if every hit were on a front face (a one-off
    kernel): the IOR inverted on the wrong side."""
    from tests.patching import module_with, one_off_kernels

    shading = renderers.core().shading
    with pytest.MonkeyPatch.context() as mp:
        one_off_kernels(mp, shading=module_with(shading, set_geometry=front_facing_geometry,
                                                original_set_geometry=shading.set_geometry))
        yield


@contextmanager
def _generated_as_object():
    """The exporter gives Generated coordinates the Object ones (no texture space)."""
    from addon import exporter

    spaces = exporter._texture_spaces

    def object_for_generated(mesh, co, tri_verts, names, tri_loops=None, normals=None):
        sh = renderers.core().shading
        out = spaces(mesh, co, tri_verts, names, tri_loops, normals)
        if sh.GENERATED in out:
            out[sh.GENERATED] = co[tri_verts]
        return out

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(exporter, "_texture_spaces", object_for_generated)
        yield


@contextmanager
def _view_maps_changed(change):
    """The renderer's Camera and Window maps as `change(model, corners, view_maps)` makes
    them."""
    kernels = renderers.core().kernels
    view_maps = kernels.view_maps
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(kernels, "view_maps", lambda model, corners: change(model, corners,
                                                                       view_maps))
        yield


def _camera_coordinates_looking_back():
    """Camera coordinates in Blender's camera space (looking down -z), not Cycles'."""
    def change(model, corners, view_maps):
        local, window = view_maps(model, corners)
        return local * np.array([1.0, 1.0, -1.0]), window
    return _view_maps_changed(change)


def _window_unshifted():
    """The Window output of the camera without its shift."""
    def change(model, corners, view_maps):
        unshifted = copy.copy(model)
        unshifted.cam = dataclasses.replace(model.cam, shift_x=0.0, shift_y=0.0)
        return view_maps(unshifted, corners)
    return _view_maps_changed(change)


@contextmanager
def _normal_coordinates_in_world_space():
    """Texture Coordinate's Normal turned with the object (world space), not its own."""
    from addon import exporter

    instance_uvs = exporter._instance_uvs

    def turned(mesh, insts, object_maps=()):
        maps = instance_uvs(mesh, insts, object_maps)
        sh = renderers.core().shading
        if sh.NORMAL in maps:
            linear = np.asarray(insts[0].matrix_world, np.float64)[:3, :3]
            maps[sh.NORMAL] = (maps[sh.NORMAL] @ np.linalg.inv(linear)).astype(np.float32)
        return maps

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(exporter, "_instance_uvs", turned)
        yield


@contextmanager
def _mapping_links_unread():
    """A Mapping's linked Location, Rotation and Scale read as their own values."""
    from addon import shader_nodes

    def unlinked(c, node, out):
        sh = c.sh
        # (Vector and Normal mappings have no Location.)
        regs = [c.program.const(list(sock.default_value) if sock is not None else [0.0] * 3)
                for sock in (shader_nodes.enabled_input(node, name)
                             for name in ("Location", "Rotation", "Scale"))]
        vec = c.input(node.inputs["Vector"], "VECTOR")
        return c.program.emit(sh.OP_VECTOR_MAPPING, 3, vec, *regs,
                              e=sh.MAPPINGS.index(node.vector_type)), "VECTOR"

    with pytest.MonkeyPatch.context() as mp:
        mp.setitem(shader_nodes.NODES, "ShaderNodeMapping", unlinked)
        yield


def _white_noise_dimensions_rotated():
    """Each White Noise Texture hashed in the next dimension (1D as 2D, ... 4D as 1D)."""
    def rotated(row, sh):
        assert row[0] == sh.OP_WHITE_NOISE
        return row[:5] + (row[5] % 4 + 1,) + row[6:]
    return _instruction_changed("ShaderNodeTexWhiteNoise", rotated)


@contextmanager
def _instruction_changed(node_type, change):
    """The last instruction each node of `node_type` compiles to, as `change(row, sh)`
    returns it."""
    from addon import shader_nodes

    compile_node = shader_nodes.NODES[node_type]

    def changed(c, node, out):
        result = compile_node(c, node, out)
        c.program.code[-1] = change(c.program.code[-1], c.sh)
        return result

    with pytest.MonkeyPatch.context() as mp:
        mp.setitem(shader_nodes.NODES, node_type, changed)
        yield


@contextmanager
def _map_range_types_rotated():
    """Each Map Range interpolated by the next type (Linear as Stepped, ...)."""
    shading = renderers.core().shading
    with pytest.MonkeyPatch.context() as mp:
        kinds = shading.MAP_RANGES
        mp.setattr(shading, "MAP_RANGES", kinds[1:] + kinds[:1])
        yield


def _curves_never_extrapolated():
    """Curves held horizontal past their ends whatever their Extend setting."""
    def flat(row, sh):
        assert row[0] == sh.OP_CURVES
        return row[:5] + (0,) + row[6:]
    return _instruction_changed("ShaderNodeRGBCurve", flat)


def _clamp_range_as_min_max():
    """The Clamp node's Range type clamped as Min Max (a reversed range not turned round)."""
    def min_max(row, sh):
        assert row[0] == sh.OP_CLAMP
        return row[:5] + (0,) + row[6:]
    return _instruction_changed("ShaderNodeClamp", min_max)


@contextmanager
def _object_random_zero():
    """Object Info's Random read as 0 for every object (the depsgraph's random_id, which
    is 0 for an object that is not an instance)."""
    noise = renderers.core().noise
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(noise, "object_random", lambda name, instance_random_id=None: 0.0)
        yield


@contextmanager
def _object_property_number_as_x():
    """An Attribute node of type Object reading a number as the vector (v, 0, 0) rather than
    (v, v, v), as a 2D value's z is 0."""
    from addon import shader_nodes
    channels = shader_nodes.attribute_channels

    def as_x(raw, scalars=False):
        out = channels(raw, scalars)
        if not scalars and np.asarray(raw).shape[1] == 1:
            out[:, 1:] = 0.0
        return out

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(shader_nodes, "attribute_channels", as_x)
        yield


@contextmanager
def _position_recentred():
    """The Geometry node's Position relative to the scene's recentring origin, not the
    world's."""
    kernels = renderers.core().kernels
    fill = kernels.fill_view_maps

    def recentred(scene, cam, tri_normal):
        origin = scene.origin
        scene.origin = np.zeros(3)
        try:
            fill(scene, cam, tri_normal)
        finally:
            scene.origin = origin

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(kernels, "fill_view_maps", recentred)
        yield


@contextmanager
def _backfacing_ignored():
    """The Geometry node's Backfacing read as 0: every face a front face."""
    from addon import shader_nodes

    compile_node = shader_nodes.NODES["ShaderNodeNewGeometry"]

    def front(c, node, out):
        if out.name == "Backfacing":
            return c.program.const([0.0]), "VALUE"
        return compile_node(c, node, out)

    with pytest.MonkeyPatch.context() as mp:
        mp.setitem(shader_nodes.NODES, "ShaderNodeNewGeometry", front)
        yield


@contextmanager
def _node_replaced(node_type, replace):
    """Every `node_type` node compiled by replace(its own compile function)."""
    from addon import shader_nodes

    with pytest.MonkeyPatch.context() as mp:
        mp.setitem(shader_nodes.NODES, node_type, replace(shader_nodes.NODES[node_type]))
        yield


@contextmanager
def _parametric_corners_swapped():
    """The Parametric map's first two corners swapped: (u, 1 - u - v, 0) for Cycles'
    (1 - u - v, u, 0)."""
    from addon import exporter

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(exporter, "PARAMETRIC_CORNERS", exporter.PARAMETRIC_CORNERS[[1, 0, 2]])
        yield


@contextmanager
def _islands_rooted_at_their_first_join():
    """Random Per Island with the islands joined without Cycles' union by rank (the
    first vertex's root always wins): the same islands, other roots, other numbers."""
    from addon import exporter
    from engine import noise

    def unranked(mesh, tri_verts):
        edges = np.zeros(len(mesh.edges) * 2, np.int64)
        mesh.edges.foreach_get("vertices", edges)
        parent = list(range(len(mesh.vertices)))

        def root(x):
            while parent[x] != x:
                x = parent[x]
            return x
        for a, b in edges.reshape(-1, 2):
            ra, rb = root(int(a)), root(int(b))
            if ra != rb:
                parent[rb] = ra
        return np.array([np.float32(noise.hash_uint(1, root(int(v)), 0, 0, 0))
                         / np.float32(4294967296.0) for v in tri_verts[:, 0]], np.float32)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(exporter, "_island_random", unranked)
        yield


@contextmanager
def _pointiness_unwelded():
    """Pointiness without Cycles' welding of duplicate vertices first: a face split from
    its neighbours reads flat along its own edges."""
    from addon import exporter

    def unwelded(mesh, co):
        normals = np.zeros(len(mesh.vertices) * 3, np.float32)
        mesh.vertices.foreach_get("normal", normals)
        normals = normals.reshape(-1, 3).astype(np.float64)
        edges = np.zeros(len(mesh.edges) * 2, np.int64)
        mesh.edges.foreach_get("vertices", edges)
        a, b = edges.reshape(-1, 2).T
        d = co[b].astype(np.float64) - co[a]
        d /= np.maximum(np.linalg.norm(d, axis=1), 1e-30)[:, None]
        accum = np.zeros_like(normals)
        np.add.at(accum, a, d)
        np.add.at(accum, b, -d)
        count = np.bincount(np.concatenate([a, b]), minlength=len(co))
        mean = accum / np.maximum(count, 1)[:, None]
        raw = np.where(count > 0, np.arccos(np.clip((normals * mean).sum(1), -1, 1)) / np.pi,
                       0.0)
        data = raw.copy()
        np.add.at(data, a, raw[b])
        np.add.at(data, b, raw[a])
        return (data / (count + 1)).astype(np.float32)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(exporter, "_pointiness", unwelded)
        yield


def _vector_transform_read_as(**changes):
    """Every Vector Transform node compiled as if its vector_type, convert_from or
    convert_to were `changes` (e.g. vector_type={"NORMAL": "VECTOR"}: normals transformed
    as directions)."""
    from types import SimpleNamespace

    def replace(compile_node):
        def changed(c, node, out):
            fields = {name: changes.get(name, {}).get(getattr(node, name), getattr(node, name))
                      for name in ("vector_type", "convert_from", "convert_to")}
            return compile_node(c, SimpleNamespace(inputs=node.inputs, **fields), out)
        return changed
    return _node_replaced("ShaderNodeVectorTransform", replace)


@contextmanager
def _object_space_unscaled():
    """Object space without the object's scale: world_to_object inverts the matrices with
    their axes normalised (Vector Transform into an object's space, and Texture Coordinate's
    Object of the empty)."""
    from addon import shader_nodes

    inverse = shader_nodes.world_to_object

    def unscaled(matrix_world):
        m = np.array(matrix_world, np.float64)  # (4, 4), or (k, 4, 4) instances
        m[..., :3, :3] /= np.linalg.norm(m[..., :3, :3], axis=-2, keepdims=True)
        return inverse(m)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(shader_nodes, "world_to_object", unscaled)
        yield


@contextmanager
def _camera_space_as_blender():
    """Vector Transform's camera space as Blender's (looking down -z), not Cycles'."""
    kernels = renderers.core().kernels
    sh = renderers.core().shading
    fill = kernels.fill_view_maps

    def flipped(scene, cam, tri_normal):
        fill(scene, cam, tri_normal)
        if sh.CAMERA_AXES[2] in scene.uv_names:
            scene.uv[scene.uv_names.index(sh.CAMERA_AXES[2])] *= -1.0

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(kernels, "fill_view_maps", flipped)
        yield


def _projector_ignored():
    """Texture Coordinate's Object output of another object read as the shaded object's."""
    from types import SimpleNamespace

    def replace(compile_node):
        def own(c, node, out):
            plain = SimpleNamespace(name=node.name, from_instancer=node.from_instancer,
                                    object=None)
            return compile_node(c, plain, out)
        return own
    return _node_replaced("ShaderNodeTexCoord", replace)


def _image_read_as(projection=None, blend=None):
    """Every Image Texture compiled as if its projection (a dict: from -> to) or its Box
    blend (`blend`) were other."""
    from types import SimpleNamespace

    def replace(compile_node):
        def changed(c, node, out):
            proxy = SimpleNamespace(**{name: getattr(node, name) for name in (
                "name", "image", "interpolation", "extension", "inputs", "outputs",
                "projection", "projection_blend")})
            proxy.projection = (projection or {}).get(node.projection, node.projection)
            proxy.projection_blend = node.projection_blend if blend is None else blend
            return compile_node(c, proxy, out)
        return changed
    return _node_replaced("ShaderNodeTexImage", replace)


@contextmanager
def _box_normal_in_world_space():
    """Box projection weighted by the world-space shading normal, not the object's."""
    from addon import shader_nodes

    through = shader_nodes._through

    def world(c, v, kind, axes, origin, into):
        if kind == "NORMAL" and axes == c.sh.OBJECT_AXES:
            return v
        return through(c, v, kind, axes, origin, into)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(shader_nodes, "_through", world)
        yield


@contextmanager
def _world_baked_at_1024():
    """A world's node tree baked at half the width: the map's interpolation error at a kink
    four times as large."""
    from addon import exporter

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(exporter, "WORLD_BAKE_WIDTH", 1024)
        yield


@contextmanager
def _world_mapping_only_rotates():
    """The Mappings of a world's node tree taken as their rotations alone, their Location
    and Scale dropped (what Specula did with a world's Mapping before world trees were
    baked): each set to 0 and 1 while the tree compiles."""
    from addon import exporter, shader_nodes

    compile_world = shader_nodes.compile_world

    def rotation_only(surface, texture_cache):
        mappings = [n for n in surface.id_data.nodes if n.bl_idname == "ShaderNodeMapping"]
        kept = [(tuple(n.inputs["Location"].default_value),
                 tuple(n.inputs["Scale"].default_value)) for n in mappings]
        try:
            for n in mappings:
                n.inputs["Location"].default_value, n.inputs["Scale"].default_value = \
                    (0.0, 0.0, 0.0), (1.0, 1.0, 1.0)
            return compile_world(surface, texture_cache)
        finally:
            for n, (location, scale) in zip(mappings, kept):
                n.inputs["Location"].default_value, n.inputs["Scale"].default_value = \
                    location, scale

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(exporter.shader_nodes, "compile_world", rotation_only)
        yield


def _camera_map_for_every_ray(scene, settings):
    """The backdrop camera rays see taken as the world every ray sees (no Light Path)."""
    from engine.shading import RAY_CAMERA
    world = scene.world
    scene.world = dataclasses.replace(world, environment=world.ray_environments[RAY_CAMERA],
                                      ray_environments=None)
    return scene, settings


def _light_map_for_every_ray(scene, settings):
    """Every kind of ray sees the light samples' world (what Specula rendered before it
    baked a map per kind of ray: a world with Is Glossy Ray was its viewport colour)."""
    scene.world = dataclasses.replace(scene.world, ray_environments=None)
    return scene, settings


@contextmanager
def _world_sampled_by_luminance():
    """The world's map sampled by luminance rather than Cycles' average of RGB: the MIS
    weights of light samples and bounces, which see different worlds, are then not
    Cycles'."""
    from engine import environment
    from engine.scene import LUMINANCE

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(environment, "pixel_weights",
                   lambda image: image.astype(np.float64) @ LUMINANCE)
        yield


@contextmanager
def _sky_rotation_not_reversed():
    """The Sky Texture's Sun Rotation taken as it is rather than reversed (Cycles turns
    it into 2 pi - rotation): the sun, its shadows and the sky's bright side turn the
    other way round."""
    from engine import sky

    position = sky.sun_position
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(sky, "sun_position", lambda elevation, rotation: (
            position(elevation, rotation)[0], 2.0 * math.pi - position(elevation, rotation)[1]))
        yield


@contextmanager
def _sky_black_below_the_horizon():
    """The Single Scattering sky black below the horizon (an older intern/sky's texture)
    rather than its horizon's colour fading out, as Blender 5.0 fills it."""
    from engine import sky

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(sky, "horizon_fade", lambda z: np.zeros(np.shape(z)))
        yield


@contextmanager
def _preetham_sun_azimuth_from_x():
    """The Preetham sky's sun azimuth taken as atan2(y, x), as directions are elsewhere,
    rather than Cycles' atan2(x, y) for its Sun Direction: the bright side turns."""
    from engine import sky

    params = sky.preetham_params
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(sky, "preetham_params", lambda d, t: params((d[1], d[0], d[2]), t))
        yield


def _wireframe_size_scaled(factor):
    """Every Wireframe node's Size (unlinked) times `factor`."""
    from types import SimpleNamespace

    def replace(compile_node):
        def scaled(c, node, out):
            size = SimpleNamespace(default_value=factor * node.inputs["Size"].default_value,
                                   is_linked=False, links=(), enabled=True, type="VALUE",
                                   name="Size", node=node)
            proxy = SimpleNamespace(name=node.name, use_pixel_size=node.use_pixel_size,
                                    inputs={"Size": size})
            return compile_node(c, proxy, out)
        return scaled
    return _node_replaced("ShaderNodeWireframe", replace)


@contextmanager
def _mixed_emission_as_mean():
    """A textured Emission inside an Add Shader rendered as its mean (the old fallback)."""
    from addon import materials

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(materials._Reader, "mixed_emission", lambda self, *args: {})
        yield


def _displacement_in_world_space():
    """Every Displacement node compiled as if its space were World (an Object-space one
    not stretched by the object's scale)."""
    from types import SimpleNamespace

    def replace(compile_node):
        def changed(c, node, out):
            return compile_node(c, SimpleNamespace(inputs=node.inputs, name=node.name,
                                                   space="WORLD"), out)
        return changed
    return _node_replaced("ShaderNodeDisplacement", replace)


@contextmanager
def _alpha_glow_unweighted():
    """A Principled BSDF's textured emission under its Alpha not weighted by it: its own
    program, or with a textured Alpha and a constant emission, that constant."""
    from addon import materials

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(materials._Reader, "alpha_glow", lambda self, node, spec, glow, *_: glow)
        yield


@contextmanager
def _input_offset(node_type, name, opcode, offset, params=lambda: ()):
    """A `node_type` node (one instruction of `opcode` on one input) reading its input
    `name` plus `offset`."""
    from addon import shader_nodes

    def shifted(c, node, out):
        sh = c.sh
        value = c.program.emit(sh.OP_MATH, 1, a=c.input(node.inputs[name], "VALUE"),
                               b=c.program.const([offset]), c=c.program.const([0.0]),
                               d=sh.MATHS.index("ADD"))
        return c.program.emit(getattr(sh, opcode), 3, a=value, params=params()), "RGBA"

    with pytest.MonkeyPatch.context() as mp:
        mp.setitem(shader_nodes.NODES, node_type, shifted)
        yield


def _blackbody_in_celsius():
    """The Blackbody's Temperature taken as degrees Celsius (273.15 K added)."""
    return _input_offset("ShaderNodeBlackbody", "Temperature", "OP_BLACKBODY", 273.15)


def _wavelength_5nm_longer():
    """The Wavelength node's input 5 nm longer (one entry of Cycles' table off)."""
    from addon import shader_nodes
    return _input_offset("ShaderNodeWavelength", "Wavelength", "OP_WAVELENGTH", 5.0,
                         shader_nodes.xyz_to_scene_linear)


@contextmanager
def _light_path_read(change):
    """Each Light Path output as `change(compiler, name, register)` makes it from the
    correct register."""
    from addon import shader_nodes

    compile_node = shader_nodes.NODES["ShaderNodeLightPath"]

    def changed(c, node, out):
        reg, kind = compile_node(c, node, out)
        return change(c, out.name, reg), kind

    with pytest.MonkeyPatch.context() as mp:
        mp.setitem(shader_nodes.NODES, "ShaderNodeLightPath", changed)
        yield


def _shadow_rays_unseen(c, name, reg):
    """Is Shadow Ray never 1 (shadow rays evaluated as the path's own ray)."""
    return c.program.const([0.0]) if name == "Is Shadow Ray" else reg


def _glossy_rays_as_diffuse(c, name, reg):
    """Is Glossy Ray reading the Is Diffuse Ray flag."""
    if name != "Is Glossy Ray":
        return reg
    sh = c.sh
    return c.program.emit(sh.OP_LIGHT_PATH, 1, d=sh.LIGHT_PATH_OUTPUTS.index("Is Diffuse Ray"))


def _ray_depth_one_less(c, name, reg):
    """Ray Depth counted from -1 (the camera ray's hit at depth -1)."""
    if name != "Ray Depth":
        return reg
    sh, p = c.sh, c.program
    return p.emit(sh.OP_MATH, 1, a=reg, b=p.const([-1.0]), c=reg, d=sh.MATHS.index("ADD"))


def _diffuse_roughness_scaled(factor):
    """Every Diffuse BSDF's roughness times `factor` (0: Lambert, the old fallback, its
    textured roughness dropped too)."""
    def inject(scene, settings):
        m = scene.materials
        diffuse = m.kind == renderers.core().scene.DIFFUSE
        scene.materials = dataclasses.replace(
            m, roughness=np.where(diffuse, m.roughness * factor, m.roughness))
        if factor == 0.0 and scene.programs is not None:
            rows = scene.programs.roughness.copy()
            rows[diffuse] = -1
            scene.programs = scene.programs._replace(roughness=rows)
        return scene, settings
    return inject


def _principled_base_lambert(scene, settings):
    """The Principled BSDF's Diffuse Roughness ignored (its base Lambert, as before)."""
    m = scene.materials
    scene.materials = dataclasses.replace(m, diffuse_roughness=np.zeros_like(m.roughness))
    if scene.programs is not None:
        scene.programs = scene.programs._replace(
            diffuse_roughness=np.full_like(scene.programs.diffuse_roughness, -1))
    return scene, settings


def _specular_ior_constant(scene, settings):
    """A Principled BSDF's varying IOR and Specular IOR Level read as their constants (the
    textures' means, the old fallback)."""
    if scene.programs is not None:
        scene.programs = scene.programs._replace(
            specular_ior=np.full_like(scene.programs.specular_ior, -1))
    return scene, settings


def _specular_ior_tables_at_mean(scene, settings):
    """The layer's Fresnel at each hit's IOR, but its spread and Fresnel average (what dims
    the base, and the compensation) at the material's mean IOR."""
    m = scene.materials
    scene.materials = dataclasses.replace(m, specular_ior_programs=[None] * len(m.kind))
    return scene, settings


def _anisotropy_changed(scale=1.0, turn=0.0):
    """Every constant anisotropy times `scale` (0: isotropic, the old fallback, its
    textured anisotropy and tangents dropped too) and every constant rotation `turn` more
    (a quarter: the lobe's axes swapped)."""
    def inject(scene, settings):
        m = scene.materials
        scene.materials = dataclasses.replace(
            m, specular_anisotropy=m.specular_anisotropy * scale,
            anisotropic_rotation=m.anisotropic_rotation + turn)
        if scale == 0.0 and scene.programs is not None:
            scene.programs = scene.programs._replace(
                anisotropy=np.full_like(scene.programs.anisotropy, -1),
                tangent=np.full_like(scene.programs.tangent, -1))
        return scene, settings
    return inject


def _all_multiscatter(scene, settings):
    """Every microfacet lobe Multiscatter GGX (energy compensated)."""
    m = scene.materials
    scene.materials = dataclasses.replace(m, multiscatter=np.ones_like(m.multiscatter))
    return scene, settings


def _falloff_unsmoothed():
    """Light Falloff compiled as if its Smooth were 0."""
    def replace(compile_node):
        def changed(c, node, out):
            read = c.input
            c.input = lambda s, kind: c.program.const([0.0]) if s.name == "Smooth" \
                else read(s, kind)
            try:
                return compile_node(c, node, out)
            finally:
                del c.input
        return changed
    return _node_replaced("ShaderNodeLightFalloff", replace)


def _depth_as_distance():
    """Camera Data's View Z Depth compiled as its View Distance."""
    def replace(compile_node):
        return lambda c, node, out: compile_node(
            c, node, node.outputs["View Distance"] if out.name == "View Z Depth" else out)
    return _node_replaced("ShaderNodeCameraData", replace)


def _edge_tint_white(scene, settings):
    """Every metal's F82 edge tint white (Schlick's Fresnel from its F0), its tint programs
    dropped."""
    m = scene.materials
    kinds = renderers.core().scene
    tint = m.reflection_tint.copy()
    tint[np.isin(m.kind, (kinds.METAL, kinds.ROUGH_METAL))] = 1.0
    scene.materials = dataclasses.replace(m, reflection_tint=tint)
    if scene.programs is not None:
        scene.programs = scene.programs._replace(tint=np.full_like(scene.programs.tint, -1))
    return scene, settings


def _conductor_without_extinction(scene, settings):
    """The Physical Conductor (the Metallic BSDF's defaults) fitted with Extinction 0."""
    m = scene.materials
    row = m.names.index("Conductor")
    f0, tint, _ = renderers.core().bsdf.conductor_as_f82(
        np.array([2.757, 2.513, 2.231]), np.zeros(3))
    colour, edge = m.colour.copy(), m.reflection_tint.copy()
    colour[row], edge[row] = f0, tint
    scene.materials = dataclasses.replace(m, colour=colour, reflection_tint=edge)
    return scene, settings


@contextmanager
def _tangents_in_object_space():
    """The radial tangents left in the object's own space (not turned into the world's)."""
    from addon import exporter
    saved = exporter._as_normals
    exporter._as_normals = lambda local, matrix_world: local.astype(np.float32)
    try:
        yield
    finally:
        exporter._as_normals = saved


@contextmanager
def _uv_tangents_as_radial():
    """A Tangent node's UV Map direction read as the default radial one (about Z)."""
    from addon import shader_nodes
    saved = shader_nodes.NODES["ShaderNodeTangent"]
    shader_nodes.NODES["ShaderNodeTangent"] = lambda c, node, out: shader_nodes._tangent(
        c, node, node.axis if node.direction_type == "RADIAL" else "Z")
    try:
        yield
    finally:
        shader_nodes.NODES["ShaderNodeTangent"] = saved


@contextmanager
def _normal_node_unnormalised():
    """The Normal node's direction used as it is set, not normalised."""
    from addon import shader_nodes

    compile_node = shader_nodes.NODES["ShaderNodeNormal"]

    def raw(c, node, out):
        length = sum(x * x for x in node.outputs["Normal"].default_value) ** 0.5
        first = len(c.program.code)
        result = compile_node(c, node, out)
        for row in c.program.code[first:]:  # the direction's constant, scaled back
            if row[0] == c.sh.OP_CONST and row[4] == 3:
                for j in range(3):
                    c.program.params[row[7] + j] *= length
                break
        return result

    with pytest.MonkeyPatch.context() as mp:
        mp.setitem(shader_nodes.NODES, "ShaderNodeNormal", raw)
        yield


@contextmanager
def _attribute_scalars_changed(change):
    """The exporter's Attribute scalars (Fac, Alpha) as `change(scalars, vector)` makes
    them."""
    from addon import exporter

    read = exporter._named_attribute

    def changed(mesh, name, tri_verts, tri_loops, scalars=False):
        out = read(mesh, name, tri_verts, tri_loops, scalars)
        if scalars and out is not None:
            change(out, read(mesh, name, tri_verts, tri_loops, False))
        return out

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(exporter, "_named_attribute", changed)
        yield


def _alpha_as_one(scalars, vector):
    scalars[..., 1] = 1.0


def _fac_as_mean(scalars, vector):
    scalars[..., 0] = vector.mean(axis=-1)


@contextmanager
def _parameter_changed(node_type, opcode, index, value):
    """Parameter `index` of each `node_type` node's instruction (of `opcode`, a
    shading.OP_* name) set to `value`."""
    from addon import shader_nodes

    compile_node = shader_nodes.NODES[node_type]

    def changed(c, node, out):
        result = compile_node(c, node, out)
        row = c.program.code[-1]
        assert row[0] == getattr(c.sh, opcode)
        c.program.params[row[7] + index] = float(value)
        return result

    with pytest.MonkeyPatch.context() as mp:
        mp.setitem(shader_nodes.NODES, node_type, changed)
        yield


@contextmanager
def _colour_attributes_read(change):
    """The exporter's colour attributes (RGB, or alpha in the first channel) as
    `change(values, alpha)` makes them."""
    from addon import exporter

    read = exporter._colour_attribute

    def patched(mesh, name, tri_verts, tri_loops, alpha=False):
        values = read(mesh, name, tri_verts, tri_loops, alpha)
        return None if values is None else change(values, alpha)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(exporter, "_colour_attribute", patched)
        yield


def _colour_attributes_encoded():
    """The exporter reads colour attributes as stored sRGB, not decoded to linear."""
    return _colour_attributes_read(
        lambda rgb, alpha: rgb if alpha else np.maximum(rgb, 0.0) ** (1.0 / 2.2))


def _colour_alpha_opaque():
    """The exporter reads every colour attribute's alpha as 1."""
    def opaque(values, alpha):
        if alpha:
            values[..., 0] = 1.0
        return values
    return _colour_attributes_read(opaque)


@contextmanager
def _colour_and_value_swapped():
    """The Mix node's Color and Value blend modes exchanged (a slip this variant caught:
    their indices after Hue were swapped in the kernel's first version)."""
    shading = renderers.core().shading
    modes = list(shading.BLENDS)
    i, j = modes.index("COLOR"), modes.index("VALUE")
    modes[i], modes[j] = modes[j], modes[i]
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(shading, "BLENDS", tuple(modes))
        yield


@contextmanager
def _texture_types_rotated():
    """Each Noise Texture rendered as the next fractal type, each Gradient Texture as the
    next gradient and each Wave Texture with the next profile."""
    nz = renderers.core().noise
    with pytest.MonkeyPatch.context() as mp:
        for name in ("NOISE_TYPES", "GRADIENT_TYPES", "WAVE_PROFILES"):
            kinds = getattr(nz, name)
            mp.setattr(nz, name, kinds[1:] + kinds[:1])
        yield


@contextmanager
def _hsv_read_as_hsl():
    """Separate and Combine Color's HSV mode converted as HSL."""
    shading = renderers.core().shading
    modes = [m.replace("HSV", "HSL") if "HSV" in m else m.replace("HSL", "HSV")
             for m in shading.CONVERSIONS]
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(shading, "CONVERSIONS", tuple(modes))
        yield


def _translucent_as_diffuse(scene, settings):
    """The Translucent BSDF rendered as a Diffuse one of its colour: reflecting, not
    transmitting."""
    m = scene.materials
    core_scene = renderers.core().scene
    kind = np.where(m.kind == core_scene.TRANSLUCENT, core_scene.DIFFUSE, m.kind)
    scene.materials = dataclasses.replace(m, kind=kind.astype(m.kind.dtype))
    return scene, settings


def _roughness_plus_10_percent(kind):
    def inject(scene, settings):
        m = scene.materials
        rough = m.kind == getattr(renderers.core().scene, kind)
        scene.materials = dataclasses.replace(
            m, roughness=np.where(rough, np.minimum(m.roughness * 1.1, 1.0), m.roughness))
        return scene, settings
    return inject


@contextmanager
def _glass_fss_white():
    """Rough glass compensated with Fss = 1 whatever its tints: a tinted glass' colour would
    not darken what multiple scattering gives back (bsdf.glass_fss builds the kernel's
    tables, in Python)."""
    bsdf = renderers.core().bsdf
    glass_fss = bsdf.glass_fss
    bsdf.glass_fss = lambda r, t, eta: np.ones(3)
    try:
        yield
    finally:
        bsdf.glass_fss = glass_fss


def physical_refraction(wox, woy, woz, wix, wiy, wiz, mx, my, mz, lobe):
    """bsdf.eval_rough_dielectric that is zero where the microfacet joining wo and wi faces
    away from either (the check Cycles' eval leaves as a TODO; its sampling never goes
    there)."""
    g0, g1, g2, pdf = original_eval(wox, woy, woz, wix, wiy, wiz, mx, my, mz, lobe)  # noqa
    transmit = mx * wix + my * wiy + mz * wiz < 0.0
    s = lobe.eta if transmit else 1.0
    hx, hy, hz = -(s * wix + wox), -(s * wiy + woy), -(s * wiz + woz)
    if hx * mx + hy * my + hz * mz < 0.0:
        hx, hy, hz = -hx, -hy, -hz
    if not (hx * wox + hy * woy + hz * woz > 0.0
            and (hx * wix + hy * wiy + hz * wiz < 0.0) == transmit):
        return 0.0, 0.0, 0.0, 0.0
    return g0, g1, g2, pdf


@contextmanager
def _refraction_validity_checked():
    """Rough glass evaluated only where a microfacet can join the two directions (a one-off
    kernel): next-event estimation at rough glass then misses what Cycles' eval adds."""
    from tests.patching import module_with, one_off_kernels

    bsdf = renderers.core().bsdf
    with pytest.MonkeyPatch.context() as mp:
        one_off_kernels(mp, bsdf=module_with(bsdf, eval_rough_dielectric=physical_refraction,
                                             original_eval=bsdf.eval_rough_dielectric))
        yield


def _normal_maps_ignored(scene, settings):
    pt = scene.programs
    scene.programs = pt._replace(normal=np.full_like(pt.normal, -1))
    return scene, settings


def _normal_map_strength_halved(scene, settings):
    m = scene.materials
    scene.materials = dataclasses.replace(m, normal_strength=m.normal_strength * 0.5)
    return scene, settings


def _media_scaled(field, factor):
    """An injection scaling every material's medium `field` (absorption, scattering,
    anisotropy) by `factor`."""
    def inject(scene, settings):
        m = scene.materials
        scene.materials = dataclasses.replace(m, **{field: getattr(m, field) * factor})
        return scene, settings
    return inject


_absorption_plus_10_percent = _media_scaled("absorption", 1.1)


def _mix_factor_reversed(scene, settings):
    m = scene.materials
    mixes = m.mix_components[:, 0] >= 0
    scene.materials = dataclasses.replace(m, mix_fac=np.where(mixes, 1.0 - m.mix_fac, m.mix_fac))
    return scene, settings


def _mix_factors_as_their_means(scene, settings):
    pt = scene.programs
    scene.programs = pt._replace(fac=np.full_like(pt.fac, -1))
    return scene, settings


def _transparent_tint_plus_10_percent(scene, settings):
    m = scene.materials
    clear = (m.kind == renderers.core().scene.TRANSPARENT)[:, None]
    scene.materials = dataclasses.replace(m, colour=np.where(clear, m.colour * 1.1, m.colour))
    return scene, settings


def _one_transparent_bounce_more(scene, settings):
    return scene, dataclasses.replace(
        settings, transparent_max_bounces=settings.transparent_max_bounces + 1)


def opaque_shadow_rays(rev_sample, transparent_max, sc, prim, tfar, bu, bv, count, shadow,
                       paths):
    """cross_transparent with every surface blocking: no transparent shadows."""
    for j in range(count):
        if prim[j] < 0:
            for c in range(3):
                paths.radiance[shadow.row[j], c] += shadow.contrib[j, c]
    return 0


@contextmanager
def _opaque_shadows():
    """Shadow rays stop at transparent surfaces (a one-off kernel)."""
    from tests.patching import one_off_kernels

    with pytest.MonkeyPatch.context() as mp:
        one_off_kernels(mp, cross_transparent=opaque_shadow_rays)
        yield


# error name -> (variant where it shows, scene/settings injection, integrator patch)
def _refraction_with_fresnel(scene, settings):
    """The Refraction BSDF's transmission weighted by 1 - F, as the Glass BSDF's (still
    reflecting nothing)."""
    m = scene.materials
    scene.materials = dataclasses.replace(m, fresnel=np.ones_like(m.fresnel))
    return scene, settings


def _glass_colour_as_its_mean(scene, settings):
    """The renderer before textured glass colours: a glass' textured colour its mean."""
    sc = renderers.core().scene
    glass = np.isin(scene.materials.kind, (sc.GLASS, sc.ROUGH_GLASS))
    colour = scene.programs.colour.copy()
    colour[glass] = -1
    scene.programs = scene.programs._replace(colour=colour)
    return scene, settings


def _coat_ior_plus_10_percent(scene, settings):
    """Every coat's IOR 10% higher, its lobe's with it."""
    m = scene.materials
    coats = np.flatnonzero(m.coat_ior > 0)
    ior = m.ior.copy()
    ior[m.mix_components[coats, 1]] *= 1.1
    scene.materials = dataclasses.replace(m, coat_ior=m.coat_ior * 1.1, ior=ior)
    return scene, settings


def _coat_tint_ignored(scene, settings):
    m = scene.materials
    scene.materials = dataclasses.replace(m, coat_tint=np.ones_like(m.coat_tint))
    return scene, settings


@contextmanager
def _coats_ignored():
    """The exporter before coats: a Principled BSDF's coat is left out."""
    from addon import materials

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(materials._Reader, "coat", lambda self, node, spec: spec)
        yield


@contextmanager
def _coat_normal_as_the_normal():
    """An unlinked Coat Normal read as the Principled's Normal (its normal map), not as
    the mesh's normal."""
    from addon import materials

    normal_map_of = materials._Reader.normal_map_of

    def shared(self, node, socket_name):
        own = normal_map_of(self, node, socket_name)
        return self.normal_map if own is None and socket_name == "Coat Normal" else own

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(materials._Reader, "normal_map_of", shared)
        yield


def _coat_uncompensated(scene, settings):
    """Coats' lobes plain GGX, as Cycles 4 made them (and Specula before Cycles 5)."""
    m = scene.materials
    multiscatter = m.multiscatter.copy()
    multiscatter[m.mix_components[m.coat_ior > 0, 1]] = False
    scene.materials = dataclasses.replace(m, multiscatter=multiscatter)
    return scene, settings


@contextmanager
def _coat_dims_by_the_smooth_fresnel():
    """What is below a coat dimmed by the smooth dielectric's Fresnel at the view, not by
    Cycles' estimate of the rough coat's albedo (bsdf._lobe_row builds the kernel's
    tables, in Python; a coat's lobe is the only Principled over black here)."""
    bsdf = renderers.core().bsdf
    lobe_row = bsdf._lobe_row

    def smooth(materials, j, roughness, rough=True):
        row = lobe_row(materials, j, roughness, rough)
        if not rough or materials.kind[j] != renderers.core().scene.PRINCIPLED or \
                materials.colour[j].any():
            return row
        mu = np.linspace(1e-3, 1.0, bsdf.ALBEDO_TABLE_SIZE)
        fresnel = [bsdf.fresnel_dielectric(x, float(materials.ior[j]), True)[0] for x in mu]
        return (*row[:3], np.array(fresnel), *row[4:])

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(bsdf, "_lobe_row", smooth)
        yield


@contextmanager
def _sheens_ignored():
    """The exporter before sheen: a Principled BSDF's sheen is left out."""
    from addon import materials

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(materials._Reader, "sheen", lambda self, node, spec: spec)
        yield


def _sheen_roughness_plus_20_percent(scene, settings):
    m = scene.materials
    roughness = m.roughness.copy()
    sheen = m.kind == renderers.core().scene.SHEEN
    roughness[sheen] = np.minimum(roughness[sheen] * 1.2, 1.0)
    scene.materials = dataclasses.replace(m, roughness=roughness)
    return scene, settings


def _specular_tint_white(scene, settings):
    """Metals' Specular Tint white (Schlick's Fresnel, as before the F82 tint)."""
    m = scene.materials
    kinds = renderers.core().scene
    metal = np.isin(m.kind, (kinds.METAL, kinds.ROUGH_METAL))
    tint = np.where(metal[:, None], 1.0, m.reflection_tint)
    scene.materials = dataclasses.replace(m, reflection_tint=tint)
    return scene, settings


def _dielectric_specular_tint_white(scene, settings):
    """The dielectric and glass Fresnel untinted (as before their Specular Tint)."""
    scene.materials = dataclasses.replace(
        scene.materials, specular_tint=np.ones_like(scene.materials.specular_tint))
    return scene, settings


def _tints_as_their_means(scene, settings):
    """Every textured Specular and Coat Tint its mean (before their programs)."""
    scene.programs = scene.programs._replace(tint=np.full_like(scene.programs.tint, -1))
    return scene, settings


def _sheen_as_its_means(scene, settings):
    """Textured sheen colours and roughness their means (textured_tints textures nothing
    else's colour or roughness)."""
    pt = scene.programs
    scene.programs = pt._replace(colour=np.full_like(pt.colour, -1),
                                 roughness=np.full_like(pt.roughness, -1))
    return scene, settings


@contextmanager
def _camera_outside_media():
    """Camera paths start outside every mesh's medium (before the camera's volume stack:
    only the world's volume)."""
    from engine import kernels

    enclosing = kernels.enclosing

    def outside(point, vertices, material_index, rows, world_row=-1):
        return enclosing(point, vertices, material_index, [], world_row)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(kernels, "enclosing", outside)
        yield


def _world_volume_ignored(scene, settings):
    scene.world_medium = -1
    return scene, settings


def _emission_undimmed(scene, settings):
    """Emission under a Principled sheen or coat undimmed by them (before under_layers)."""
    m = scene.materials
    scene.materials = dataclasses.replace(m, emission_share=np.zeros_like(m.emission_share))
    return scene, settings


def _displacement_shadowed_from_the_mesh(scene, settings):
    """A displacement's bump shadowed as a Bump node's: from the mesh's smooth normal."""
    m = scene.materials
    scene.materials = dataclasses.replace(m, sets_normal=np.zeros_like(m.sets_normal))
    return scene, settings


def _mix_reads_the_mesh_normal(scene, settings):
    """A displaced material's mix factor read on the mesh's normal, not the displaced one
    (no mix row sets the normal)."""
    m = scene.materials
    mix = m.kind == renderers.core().scene.MIX
    scene.materials = dataclasses.replace(m, sets_normal=m.sets_normal & ~mix)
    return scene, settings


def _bumps_ignored(scene, settings):
    pt = scene.programs
    scene.programs = pt._replace(height=np.full_like(pt.height, -1))
    return scene, settings


@contextmanager
def _bump_distance_plus_10_percent():
    """Every Bump node's Distance 10% larger (its program's first channel scaled)."""
    from addon import shader_nodes

    compile_bump = shader_nodes.compile_bump

    def farther(node, texture_cache):
        p, why = compile_bump(node, texture_cache)
        if p is not None:
            sh = renderers.core().shading
            k = p.const([1.1])
            dh = p.emit(sh.OP_MATH, 1, a=p.out, b=k, c=k, d=sh.MATHS.index("MULTIPLY"))
            p.out = p.emit(sh.OP_COMBINE, 3, a=dh, b=p.out + 1, c=p.out + 1)
        return p, why

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(shader_nodes, "compile_bump", farther)
        yield


def bump_on_the_turned_normal(f, u, v, sign, nx, ny, nz, mat, sc, paths):
    """integrator.bumped_normal taken about the normal as turned to the incoming side."""
    return original_bumped_normal(f, u, v, 1.0, nx, ny, nz, mat, sc, paths)  # noqa: F821


@contextmanager
def _bump_on_the_turned_normal():
    """The Bump node's formula read literally on a back face, about the normal turned to
    the incoming side: a bumped glass' inside tilts the other way (a one-off kernel)."""
    from tests.patching import one_off_kernels

    with pytest.MonkeyPatch.context() as mp:
        one_off_kernels(mp, bumped_normal=bump_on_the_turned_normal,
                        original_bumped_normal=renderers.core().integrator.bumped_normal)
        yield


INJECTIONS = {
    "ior_plus_3_percent": ("glass_chart_145", _ior_plus_3_percent, None),
    "schlick_fresnel": ("glass_sheet_fresnel", _schlick, _own_kernel),
    "fstop_plus_10_percent": ("dof_blades", _fstop_plus_10_percent, None),
    "focus_distance_plus_5_percent": ("dof_blades", _focus_plus_5_percent, None),
    "aperture_rotated_half_blade": ("dof_blades", _aperture_half_blade, None),
    "one_bounce_fewer": ("cbspheres_bounces_3", _one_bounce_fewer, None),
    "one_sided_emission": ("emitter_direct", None, _one_sided_emission),
    "light_power_plus_5_percent": ("light_area_square", _light_power_plus_5_percent, None),
    "spot_cone_toward_centre": ("spot_user", None, _spot_cone_toward_centre),
    "glossy_compensation_white": ("glossy_colours", None, _glossy_compensation_white),
    "no_terminator_offset": ("terminator_point", _no_terminator_offset, None),
    "no_terminator_offset_area_light": ("terminator_area", _no_terminator_offset, None),
    "texture_v_flipped": ("textured_walls", _texture_v_flipped, None),
    "srgb_texture_not_decoded": ("textured_walls", _srgb_not_decoded, None),
    "textures_as_their_means": ("textured_walls", _textures_as_their_means, None),
    "textured_emission_as_its_mean": ("textured_emitter", _emission_as_its_mean, None),
    "light_samples_untextured": ("textured_emitter", None, _light_samples_untextured),
    "rough_glass_roughness_plus_10_percent": ("rough_glass_roughness",
                                              _roughness_plus_10_percent("ROUGH_GLASS"), None),
    "rough_metal_roughness_plus_10_percent": ("rough_metal",
                                              _roughness_plus_10_percent("ROUGH_METAL"), None),
    "rough_glass_fss_white": ("rough_glass_tinted", None, _glass_fss_white),
    "refraction_validity_checked": ("rough_glass_roughness", None,
                                    _refraction_validity_checked),
    "normal_maps_ignored": ("normal_maps", _normal_maps_ignored, None),
    "normal_map_strength_halved": ("normal_maps", _normal_map_strength_halved, None),
    "absorption_plus_10_percent": ("coloured_glass", _absorption_plus_10_percent, None),
    "gltf_absorption_plus_10_percent": ("gltf_attenuation", _absorption_plus_10_percent, None),
    "scattering_plus_10_percent": ("fog_point_light", _media_scaled("scattering", 1.1), None),
    "phase_isotropic": ("fog_point_light", _media_scaled("anisotropy", 0.0), None),
    "anisotropy_negated": ("scattering_media", _media_scaled("anisotropy", -1.0), None),
    "camera_outside_media": ("camera_in_fog", None, _camera_outside_media),
    "world_volume_ignored": ("world_fog", _world_volume_ignored, None),
    "mix_factor_reversed": ("mixed_shaders", _mix_factor_reversed, None),
    "textured_mix_factor_as_its_mean": ("mixed_shaders", _mix_factors_as_their_means, None),
    "alpha_as_its_mean": ("alpha_cutouts", _mix_factors_as_their_means, None),
    "opaque_shadows": ("alpha_cutouts", None, _opaque_shadows),
    "transparent_tint_plus_10_percent": ("alpha_cutouts", _transparent_tint_plus_10_percent,
                                         None),
    "one_transparent_bounce_more": ("transparent_limit", _one_transparent_bounce_more, None),
    "gltf_alpha_as_its_mean": ("gltf_glass_vase_flowers", _mix_factors_as_their_means, None),
    "gltf_label_alpha_as_its_mean": ("gltf_texture_linear_interpolation",
                                     _mix_factors_as_their_means, None),
    "gltf_label_glow_unweighted": ("gltf_texture_linear_interpolation", None,
                                   _alpha_glow_unweighted),
    "gltf_roughness_as_its_mean": ("gltf_transmission", _roughness_as_its_mean, None),
    "group_inputs_unread": ("node_groups", None, _group_inputs_unread),
    "generated_as_object": ("texture_spaces", None, _generated_as_object),
    "colour_attributes_encoded": ("colour_attributes", None, _colour_attributes_encoded),
    "colour_alpha_opaque": ("colour_attributes", None, _colour_alpha_opaque),
    "colour_and_value_swapped": ("blend_modes", None, _colour_and_value_swapped),
    "hsv_read_as_hsl": ("blend_modes", None, _hsv_read_as_hsl),
    "texture_types_rotated": ("procedural_textures", None, _texture_types_rotated),
    "camera_coordinates_looking_back": ("texture_coordinates", None,
                                        _camera_coordinates_looking_back),
    "window_unshifted": ("texture_coordinates", None, _window_unshifted),
    "normal_coordinates_in_world_space": ("texture_coordinates", None,
                                          _normal_coordinates_in_world_space),
    "mapping_links_unread": ("texture_coordinates", None, _mapping_links_unread),
    "white_noise_dimensions_rotated": ("white_noise", None, _white_noise_dimensions_rotated),
    "object_random_zero": ("geometry_and_object_info", None, _object_random_zero),
    "object_property_number_as_x": ("geometry_and_object_info", None,
                                    _object_property_number_as_x),
    "position_recentred": ("geometry_and_object_info", None, _position_recentred),
    "backfacing_ignored": ("geometry_and_object_info", None, _backfacing_ignored),
    # Vector Transform: normals as directions; points as directions (origins dropped);
    # object space without its scale; Blender's camera space; the projector empty ignored.
    "normals_transformed_as_vectors": ("vector_transform", None, lambda:
                                       _vector_transform_read_as(
                                           vector_type={"NORMAL": "VECTOR"})),
    "points_transformed_as_vectors": ("vector_transform", None, lambda:
                                      _vector_transform_read_as(
                                          vector_type={"POINT": "VECTOR"})),
    "object_space_unscaled": ("vector_transform", None, _object_space_unscaled),
    "camera_space_as_blender": ("vector_transform", None, _camera_space_as_blender),
    "projector_ignored": ("vector_transform", None, _projector_ignored),
    # Image projections: Sphere read as Flat, Tube as Sphere, Box unblended, Box by the
    # world-space normal.
    "sphere_projection_flat": ("image_projections", None, lambda: _image_read_as(
        projection={"SPHERE": "FLAT"})),
    "tube_projection_as_sphere": ("image_projections", None, lambda: _image_read_as(
        projection={"TUBE": "SPHERE"})),
    "box_blend_ignored": ("image_projections", None, lambda: _image_read_as(blend=0.0)),
    "box_normal_in_world_space": ("image_projections", None, _box_normal_in_world_space),
    # Wireframe: its size doubled; the wires' glow (an Emission in an Add Shader) as its
    # mean, as before the mix had its own emission program.
    "wireframe_size_doubled": ("wireframe", None, lambda: _wireframe_size_scaled(2.0)),
    "mixed_emission_as_mean": ("wireframe", None, _mixed_emission_as_mean),
    # Bricks' offset frequency 0 (no offset or squash); Vector Rotate's Invert ignored.
    "brick_rows_unshifted": ("bricks_and_rotation", None, lambda: _parameter_changed(
        "ShaderNodeTexBrick", "OP_BRICK", 7, 0)),
    "rotation_never_inverted": ("bricks_and_rotation", None, lambda: _parameter_changed(
        "ShaderNodeVectorRotate", "OP_VECTOR_ROTATE", 0, 0)),
    # Every Voronoi feature read as F1; every distance metric as Euclidean.
    "voronoi_features_all_f1": ("voronoi", None, lambda: _parameter_changed(
        "ShaderNodeTexVoronoi", "OP_VORONOI", 8, 0)),
    "voronoi_metrics_all_euclidean": ("voronoi", None, lambda: _parameter_changed(
        "ShaderNodeTexVoronoi", "OP_VORONOI", 9, 0)),
    "blackbody_in_celsius": ("blackbody_and_normal", None, _blackbody_in_celsius),
    "normal_node_unnormalised": ("blackbody_and_normal", None, _normal_node_unnormalised),
    "wavelength_5nm_longer": ("wavelength", None, _wavelength_5nm_longer),
    # Oren-Nayar: rendered as Lambert (the old fallback); its constant roughness halved.
    "oren_nayar_as_lambert": ("oren_nayar", _diffuse_roughness_scaled(0.0), None),
    "oren_nayar_roughness_halved": ("oren_nayar", _diffuse_roughness_scaled(0.5), None),
    "principled_diffuse_roughness_ignored": ("oren_nayar", _principled_base_lambert, None),
    # A varying IOR and Specular IOR Level: their means (the old fallback); the layer's
    # tables read at the mean while its Fresnel follows the hit.
    "specular_ior_as_mean": ("specular_ior_textured", _specular_ior_constant, None),
    "specular_ior_tables_at_mean": ("specular_ior_textured", _specular_ior_tables_at_mean,
                                    None),
    "gltf_specular_texture_as_mean": ("gltf_specular", _specular_ior_constant, None),
    # Anisotropic GGX: rendered isotropic (the old fallback); anisotropy halved; every
    # lobe's tangent a quarter turn off (its axes swapped).
    "anisotropy_ignored": ("anisotropic", _anisotropy_changed(scale=0.0), None),
    "anisotropy_halved": ("anisotropic", _anisotropy_changed(scale=0.5), None),
    "anisotropy_quarter_turn": ("anisotropic", _anisotropy_changed(turn=0.25), None),
    "anisotropy_tangent_untransformed": ("anisotropic", None, _tangents_in_object_space),
    "anisotropy_uv_tangent_as_radial": ("anisotropic", None, _uv_tangents_as_radial),
    "gltf_anisotropy_ignored": ("gltf_anisotropy_strength", _anisotropy_changed(scale=0.0),
                                None),
    # The Principled BSDF's GGX rendered as Multiscatter GGX (the old fallback).
    "principled_ggx_as_multiscatter": ("principled_ggx", _all_multiscatter, None),
    # Light Falloff's Smooth ignored; Camera Data's View Z Depth read as its distance.
    "light_falloff_smooth_ignored": ("falloff_and_camera_data", None, _falloff_unsmoothed),
    "camera_data_depth_as_distance": ("falloff_and_camera_data", None, _depth_as_distance),
    # Metallic BSDF: the Edge Tint ignored (white: Schlick's metal); the Physical
    # Conductor's Extinction read as 0. (Its F82 fit without the tint, Schlick's from its
    # F0, differs on a thin rim only and passed: max |z| 3.45.)
    "metallic_edge_tint_ignored": ("metallic_bsdf", _edge_tint_white, None),
    "metallic_conductor_without_extinction": ("metallic_bsdf", _conductor_without_extinction,
                                              None),
    # Light Path: the shadow rays' flag never set; glossy rays read as diffuse ones; the
    # depth one less.
    "light_path_shadow_rays_unseen": ("light_path", None,
                                      lambda: _light_path_read(_shadow_rays_unseen)),
    "light_path_glossy_as_diffuse": ("light_path", None,
                                     lambda: _light_path_read(_glossy_rays_as_diffuse)),
    "light_path_depth_one_less": ("light_path", None,
                                  lambda: _light_path_read(_ray_depth_one_less)),
    # Attribute: a colour's Alpha read as 1; Fac as the mean of the vector (a 2D
    # attribute's Fac is its x in Cycles).
    "attribute_alpha_as_one": ("attributes", None,
                               lambda: _attribute_scalars_changed(_alpha_as_one)),
    "attribute_fac_as_mean": ("attributes", None,
                              lambda: _attribute_scalars_changed(_fac_as_mean)),
    "map_range_types_rotated": ("converter_nodes", None, _map_range_types_rotated),
    "curves_never_extrapolated": ("converter_nodes", None, _curves_never_extrapolated),
    "clamp_range_as_min_max": ("converter_nodes", None, _clamp_range_as_min_max),
    "translucent_as_diffuse": ("translucency", _translucent_as_diffuse, None),
    "emission_strength_as_its_mean": ("emission_strength_texture", _emission_as_its_mean,
                                      None),
    "view_factors_as_their_means": ("view_factors", _mix_factors_as_their_means, None),
    "back_faces_unseen": ("view_factors", None, _back_faces_unseen),
    "helmet_emission_as_its_mean": ("gltf_damaged_helmet", _emission_as_its_mean, None),
    "helmet_roughness_as_its_mean": ("gltf_damaged_helmet", _roughness_as_its_mean, None),
    "textured_roughness_plus_10_percent": ("textured_roughness", None,
                                           _textured_roughness_plus_10_percent),
    "refraction_with_fresnel": ("refraction", _refraction_with_fresnel, None),
    "glass_colour_as_its_mean": ("textured_glass", _glass_colour_as_its_mean, None),
    "refraction_roughness_plus_10_percent": ("refraction", _roughness_plus_10_percent(
        "ROUGH_GLASS"), None),
    "coat_ior_plus_10_percent": ("coat", _coat_ior_plus_10_percent, None),
    "coat_tint_ignored": ("coat", _coat_tint_ignored, None),
    "coat_weight_as_its_mean": ("coat", _mix_factors_as_their_means, None),
    "coat_uncompensated": ("coat_furnace", _coat_uncompensated, None),
    "coat_dims_by_the_smooth_fresnel": ("coat_rough", None, _coat_dims_by_the_smooth_fresnel),
    "sheens_ignored": ("sheen", None, _sheens_ignored),
    "sheen_roughness_plus_20_percent": ("sheen", _sheen_roughness_plus_20_percent, None),
    "coats_ignored": ("gltf_clear_coat", None, _coats_ignored),
    "coat_normal_as_the_normal": ("gltf_clear_coat", None, _coat_normal_as_the_normal),
    "bumps_ignored": ("bump", _bumps_ignored, None),
    "specular_tint_white": ("specular_tint", _specular_tint_white, None),
    "dielectric_specular_tint_white": ("specular_tint_dielectric",
                                       _dielectric_specular_tint_white, None),
    "tints_as_their_means": ("textured_tints", _tints_as_their_means, None),
    "emission_undimmed": ("emission_under_layers", _emission_undimmed, None),
    "displacement_ignored": ("displacement_bump", _bumps_ignored, None),
    "displacement_object_as_world": ("displacement_bump", None, _displacement_in_world_space),
    "displacement_shadowed_from_the_mesh": ("displacement_bump",
                                            _displacement_shadowed_from_the_mesh, None),
    "displacement_mix_on_the_mesh_normal": ("displacement_bump", _mix_reads_the_mesh_normal,
                                            None),
    "alpha_emission_undimmed": ("emission_under_alpha", _emission_undimmed, None),
    "alpha_glow_unweighted": ("emission_under_alpha", None, _alpha_glow_unweighted),
    "sheen_as_its_means": ("textured_tints", _sheen_as_its_means, None),
    "parametric_corners_swapped": ("parametric", None, _parametric_corners_swapped),
    "islands_rooted_at_their_first_join": ("random_per_island", None,
                                           _islands_rooted_at_their_first_join),
    "pointiness_unwelded": ("pointiness", None, _pointiness_unwelded),
    "bump_distance_plus_10_percent": ("bump", None, _bump_distance_plus_10_percent),
    "bump_on_the_turned_normal": ("bump", None, _bump_on_the_turned_normal),
    "world_baked_at_1024": ("world_nodes_sky", None, _world_baked_at_1024),
    "world_mapping_only_rotates": ("world_environment_mapped", None,
                                   _world_mapping_only_rotates),
    "world_camera_map_for_every_ray": ("world_camera_backdrop", _camera_map_for_every_ray,
                                       None),
    "world_light_map_for_every_ray": ("world_ray_kinds", _light_map_for_every_ray, None),
    "world_sampled_by_luminance": ("world_ray_kinds", None, _world_sampled_by_luminance),
    # The Sky Texture (issue 14): its sun disc's power, and Cycles' sense of its rotation.
    "sky_sun_power_plus_5_percent": ("world_sky_texture", _light_power_plus_5_percent, None),
    "sky_rotation_not_reversed": ("world_sky_texture", None, _sky_rotation_not_reversed),
    "sky_black_below_the_horizon": ("world_sky_single_scattering", None,
                                    _sky_black_below_the_horizon),
    "preetham_sun_azimuth_from_x": ("world_sky_preetham", None, _preetham_sun_azimuth_from_x),
}


@pytest.mark.slow
@pytest.mark.parametrize("error", list(INJECTIONS),
                         ids=[f"{variant}-{error}" for error, (variant, *_) in INJECTIONS.items()])
def test_comparison_rejects_injected_error(error):
    name, inject, patch = INJECTIONS[error]
    correct = harness.agreement(name)
    assert correct.agree, f"correct render of {name} must agree first: {correct.describe()}"
    t0 = time.perf_counter()
    with patch() if patch else nullcontext():
        wrong = renderers.render_specula(harness.VARIANTS[name], inject)
    c = harness.compare_render(name, wrong, f"power: {error}", time.perf_counter() - t0)
    assert not c.agree, f"{error} on {name} was not detected: {c.describe()}"

"""Blender scene -> Specula core arrays, in one pass over the depsgraph.

`export(depsgraph)` walks `depsgraph.object_instances` once. Each unique evaluated geometry
(modifiers and geometry nodes applied) is read once with `foreach_get` into numpy and
shared; every instance (the object itself, collection, particle and geometry-node
instances) only records a copy of its world matrix and its material slots. `to_core`
then applies each instance's matrix to the shared arrays in numpy and feeds the core's
`SceneBuilder`. The result of `export` holds no bpy references, so it outlives the
depsgraph and needs no core to inspect (the tests rely on that).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import bpy
import numpy as np

from . import core, materials, shader_nodes

# Object types `Object.to_mesh()` can turn into triangles.
GEOMETRY_TYPES = {"MESH", "CURVE", "SURFACE", "FONT", "META"}
# Types with geometry the core cannot render yet; each gets a warning, not silence.
UNSUPPORTED_TYPES = {"CURVES": "hair curves", "POINTCLOUD": "point cloud", "VOLUME": "volume",
                     "GREASEPENCIL": "grease pencil"}
# Cycles writes this depth where a camera ray hits nothing; so do we.
BACKGROUND_DEPTH = 1e10


@dataclass
class MeshData:
    """One unique evaluated geometry, in object space.

    vertices : (n, 3) float64
    triangles : (t, 3) int64 vertex indices
    material_index : (t,) int32 slot index
    normals : (t, 3, 3) float64 per-corner shading normals (smooth, flat or custom)
    smooth : (t,) bool, whether the triangle interpolates `normals`
    material_lut : (s,) int32 exported material per mesh material slot (used when the
        object has no slots, e.g. materials set by geometry nodes)
    uv_maps : UV map name -> (t, 3, 2) float32 per-corner coordinates, "" the render-active
        map; read only when some material has a texture
    tangents : UV map name -> (t, 3, 4) float32 per-corner tangent (xyz) and bitangent sign
        (Blender's own, mikktspace), for the maps normal-mapped materials read
    """

    vertices: np.ndarray
    triangles: np.ndarray
    material_index: np.ndarray
    normals: np.ndarray
    smooth: np.ndarray
    material_lut: np.ndarray
    uv_maps: dict = field(default_factory=dict)
    tangents: dict = field(default_factory=dict)


@dataclass
class Instance:
    """One placement of a MeshData: its name, key, world matrix (4, 4) and slot table."""

    name: str
    mesh_key: tuple
    matrix_world: np.ndarray
    material_lut: np.ndarray
    is_instance: bool = False
    # Object > Shading > Shadow Terminator > Geometry Offset (Cycles' default 0.1).
    terminator_offset: float = 0.1
    # What the Object Info node reads: the object's colour (RGBA), its random number
    # (noise.object_random) and pass index.
    colour: tuple = (1.0, 1.0, 1.0, 1.0)
    random: float = 0.0
    pass_index: int = 0
    # What Attribute nodes of type Object read: property name -> its 1-4 values (None:
    # the object has no such property).
    properties: dict = field(default_factory=dict)


@dataclass
class ExportedScene:
    meshes: dict = field(default_factory=dict)
    instances: list = field(default_factory=list)
    materials: list = field(default_factory=list)
    camera: dict = field(default_factory=dict)
    world_colour: tuple = (0.0, 0.0, 0.0)
    warnings: list = field(default_factory=list)
    lights: list = field(default_factory=list)  # keyword dicts for core.Light
    environment: dict | None = None  # keyword arguments for core.World's map, if any
    world_volume: dict | None = None  # the world's Volume (core.World.volume), if any
    object_maps: list = field(default_factory=list)  # the Object Info maps programs read

    @property
    def num_triangles(self):
        return sum(len(self.meshes[i.mesh_key].triangles) for i in self.instances)


class ExportError(RuntimeError):
    """The scene cannot be rendered at all (e.g. no camera); the message says why."""


# ---------------------------------------------------------------------------------------
# Meshes


def _corner_normals(mesh, n_loops):
    """(n_loops, 3) float32 corner normals, whichever API this Blender has."""
    cn = np.zeros(n_loops * 3, np.float32)
    if hasattr(mesh, "corner_normals"):  # 4.1+: always up to date, custom normals included
        mesh.corner_normals.foreach_get("vector", cn)
    else:  # 4.0 and older: split normals must be computed first
        if hasattr(mesh, "calc_normals_split"):
            mesh.calc_normals_split()
        mesh.loops.foreach_get("normal", cn)
    return cn.reshape(-1, 3)


def _uv_maps(mesh, tri_loops) -> dict:
    """Every UV map of `mesh` per triangle corner; "" names the render-active one (what an
    Image Texture without a Vector input reads in Cycles)."""
    maps = {}
    for layer in mesh.uv_layers:
        uv = np.zeros(len(mesh.loops) * 2, np.float32)
        layer.data.foreach_get("uv", uv)
        maps[layer.name] = uv.reshape(-1, 2)[tri_loops.reshape(-1, 3)]
        if layer.active_render:
            maps[""] = maps[layer.name]
    return maps


def _texture_spaces(mesh, co, tri_verts, spaces, tri_loops=None, normals=None) -> dict:
    """Per-corner (t, 3, 3) values of the maps named in `spaces`: Object, the vertex in the
    object's own space; Generated, the mesh's texture space as Cycles' mesh_texture_space
    maps it ((P - location) / (2 size) + 1/2; 1/2 along a flat axis); Normal, the corner
    normals (`normals`, object space; a flat face's are its own); colour attributes
    (shading.COLOUR_ATTRIBUTE), linear RGB, per corner or per point, and attributes of
    any kind (shading.ATTRIBUTE) (a mesh without the attribute has no map: it reads
    shading.absent_map_value there, warned, as Cycles' missing attribute)."""
    sh = core.load().shading
    out = {}
    # Attribute maps: (prefix, reader, whether the reader's flag is set for this prefix).
    readers = ((sh.ATTRIBUTE, _named_attribute, False),
               (sh.ATTRIBUTE_SCALARS, _named_attribute, True),
               (sh.COLOUR_ATTRIBUTE, _colour_attribute, False),
               (sh.COLOUR_ALPHA, _colour_attribute, True))
    for name in spaces:
        for prefix, read, flag in readers:
            if name.startswith(prefix):
                values = read(mesh, name[len(prefix):], tri_verts, tri_loops, flag)
                if values is not None:
                    out[name] = values
    if sh.OBJECT in spaces:
        out[sh.OBJECT] = co[tri_verts]
    if sh.NORMAL in spaces and normals is not None:
        out[sh.NORMAL] = normals.astype(np.float32)
    if sh.PARAMETRIC in spaces:
        out[sh.PARAMETRIC] = np.broadcast_to(PARAMETRIC_CORNERS, (len(tri_verts), 3, 3))
    if sh.ISLAND_RANDOM in spaces:
        out[sh.ISLAND_RANDOM] = np.broadcast_to(
            _island_random(mesh, tri_verts)[:, None, None], (len(tri_verts), 3, 3))
    if sh.POINTINESS in spaces:
        out[sh.POINTINESS] = np.repeat(_pointiness(mesh, co)[tri_verts][..., None], 3, axis=2)
    radial = [name for name in spaces if name.startswith(sh.RADIAL)]
    if sh.GENERATED in spaces or radial:
        loc = np.array(mesh.texspace_location, np.float32)
        size = np.array(mesh.texspace_size, np.float32)
        scale = np.divide(0.5, size, out=np.zeros(3, np.float32), where=size != 0)
        generated = co[tri_verts] * scale - (loc * scale - 0.5)
        if sh.GENERATED in spaces:
            out[sh.GENERATED] = generated
        for name in radial:  # object space here; _instance_uvs turns them into the world's
            out[name] = _radial(generated - 0.5, name[len(sh.RADIAL):])
    return out


def _island_random(mesh, tri_verts) -> np.ndarray:
    """(t,) the Random Per Island of each triangle of `mesh` (noise.island_random)."""
    edges = np.zeros(len(mesh.edges) * 2, np.int64)
    mesh.edges.foreach_get("vertices", edges)
    return core.load().mesh_attributes.island_random(edges.reshape(-1, 2), len(mesh.vertices),
                                           np.ascontiguousarray(tri_verts[:, 0], np.int64))


def _pointiness(mesh, co) -> np.ndarray:
    """(n,) the Pointiness of each vertex of `mesh` (mesh_attributes.pointiness)."""
    normals = np.zeros(len(mesh.vertices) * 3, np.float32)
    mesh.vertices.foreach_get("normal", normals)
    edges = np.zeros(len(mesh.edges) * 2, np.int64)
    mesh.edges.foreach_get("vertices", edges)
    return core.load().mesh_attributes.pointiness(
        np.ascontiguousarray(co, np.float32), normals.reshape(-1, 3), edges.reshape(-1, 2))


# The Parametric map's value at each corner of a triangle (shading.PARAMETRIC).
PARAMETRIC_CORNERS = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.0]], np.float32)


def _radial(g, axis):
    """(t, 3, 3) the direction around `axis` at centred texture-space points g (Cycles'
    svm_node_tangent: Z gives (-g_y, g_x, 0))."""
    x, y, z = g[..., 0], g[..., 1], g[..., 2]
    zero = np.zeros_like(x)
    v = {"X": (zero, -z, y), "Y": (-z, zero, x), "Z": (-y, x, zero)}[axis]
    return np.stack(v, axis=-1).astype(np.float32)


def _colour_attribute(mesh, name, tri_verts, tri_loops, alpha=False):
    """(t, 3, 3) linear RGB of colour attribute `name` ("": the default one) per triangle
    corner (with `alpha`, its alpha in the first channel), or None where the mesh has none
    by that name."""
    attributes = mesh.color_attributes
    attr = attributes.get(name or attributes.default_color_name or "")
    if attr is None or attr.domain not in ("POINT", "CORNER"):
        return None
    rgba = np.zeros(len(attr.data) * 4, np.float32)
    attr.data.foreach_get("color", rgba)  # linear, byte colours decoded from sRGB
    rgba = rgba.reshape(-1, 4)
    rgb = np.zeros_like(rgba[:, :3])
    if alpha:
        rgb[:, 0] = rgba[:, 3]
    else:
        rgb[:] = rgba[:, :3]
    index = tri_verts if attr.domain == "POINT" else tri_loops.reshape(-1, 3)
    return rgb[index]


# Attribute types as Cycles' Attribute node reads them: (foreach_get key, components).
ATTRIBUTE_TYPES = {"FLOAT": ("value", 1), "INT": ("value", 1), "INT8": ("value", 1),
                   "BOOLEAN": ("value", 1), "FLOAT2": ("vector", 2), "INT32_2D": ("vector", 2),
                   "FLOAT_VECTOR": ("vector", 3), "FLOAT_COLOR": ("color", 4),
                   "BYTE_COLOR": ("color", 4)}


def _named_attribute(mesh, name, tri_verts, tri_loops, scalars=False):
    """(t, 3, 3) per triangle corner of the mesh attribute `name` as the Attribute node
    reads it (shading.ATTRIBUTE): its vector, or with `scalars` (Fac, Alpha, 0); None
    where the mesh has no such attribute on its points, corners or faces, or one of a type
    Cycles does not read (a matrix)."""
    attr = mesh.attributes.get(name)
    if attr is None or attr.domain not in ("POINT", "CORNER", "FACE") or \
            attr.data_type not in ATTRIBUTE_TYPES:
        return None
    key, width = ATTRIBUTE_TYPES[attr.data_type]
    raw = np.zeros(len(attr.data) * width, np.float32)  # (colours linear, bytes decoded)
    attr.data.foreach_get(key, raw)
    out = shader_nodes.attribute_channels(raw.reshape(-1, width), scalars)
    if attr.domain == "FACE":
        faces = np.zeros(len(tri_verts), np.int32)
        mesh.loop_triangles.foreach_get("polygon_index", faces)
        return out[np.repeat(faces[:, None], 3, axis=1)]
    return out[tri_verts if attr.domain == "POINT" else tri_loops.reshape(-1, 3)]


def _tangents(mesh, tri_loops, names, warn) -> dict:
    """Blender's tangents (Mesh.calc_tangents) per triangle corner for the UV maps `names`
    ("" the render-active one): (t, 3, 4) float32, xyz and the bitangent sign."""
    out = {}
    for name in names:
        layer = next((u for u in mesh.uv_layers if (u.name == name if name else
                                                    u.active_render)), None)
        if layer is None:
            continue  # the missing map is warned where the texture reads it
        try:
            mesh.calc_tangents(uvmap=layer.name)
        except RuntimeError as exc:
            warn(f"mesh '{mesh.name}': no tangents for UV map '{layer.name}' ({exc}): "
                 f"normal maps and Tangent nodes reading it are not applied")
            continue
        n = len(mesh.loops)
        tangent, sign = np.zeros(n * 3, np.float32), np.zeros(n, np.float32)
        mesh.loops.foreach_get("tangent", tangent)
        mesh.loops.foreach_get("bitangent_sign", sign)
        corners = np.concatenate([tangent.reshape(-1, 3), sign[:, None]], axis=1)
        out[name] = corners[tri_loops.reshape(-1, 3)]
    if names:
        mesh.free_tangents()
    return out


def read_mesh(mesh, material_lut, uv=False, tangent_maps=(), warn=None, spaces=()) -> MeshData:
    """Read a bpy Mesh into numpy with foreach_get (no per-triangle Python); `uv`: its UV
    maps too, and the texture `spaces` (shading.GENERATED, OBJECT) programs read;
    `tangent_maps`: the UV maps whose tangents normal maps need."""
    n_vert, n_loops = len(mesh.vertices), len(mesh.loops)
    co = np.zeros(n_vert * 3, np.float32)
    mesh.vertices.foreach_get("co", co)
    tris = mesh.loop_triangles
    t = len(tris)
    tri_verts = np.zeros(t * 3, np.int32)
    tri_loops = np.zeros(t * 3, np.int32)
    mat_index = np.zeros(t, np.int32)
    smooth = np.zeros(t, bool)
    tris.foreach_get("vertices", tri_verts)
    tris.foreach_get("loops", tri_loops)
    tris.foreach_get("material_index", mat_index)
    tris.foreach_get("use_smooth", smooth)
    normals = _corner_normals(mesh, n_loops)[tri_loops.reshape(-1, 3)]
    # Custom normals apply to flat faces too (4.1+ keeps them regardless of sharp_face).
    if getattr(mesh, "has_custom_normals", False):
        smooth[:] = True
    sh = core.load().shading
    uv_tangents = [name[len(sh.UV_TANGENT):] for name in spaces
                   if name.startswith(sh.UV_TANGENT)] if uv else []
    tangents = _tangents(mesh, tri_loops, sorted(set(tangent_maps) | set(uv_tangents)),
                         warn or (lambda msg: None))
    maps = _uv_maps(mesh, tri_loops) if uv else {}
    maps.update({sh.UV_TANGENT + name: tangents[name][..., :3] for name in uv_tangents
                 if name in tangents})  # (object space; _instance_uvs turns them)
    tangents = {name: t for name, t in tangents.items() if name in tangent_maps}
    if uv:
        maps.update(_texture_spaces(mesh, co.reshape(-1, 3), tri_verts.reshape(-1, 3), spaces,
                                    tri_loops, normals))
    return MeshData(co.reshape(-1, 3).astype(np.float64), tri_verts.reshape(-1, 3).astype(np.int64),
                    mat_index, normals.astype(np.float64), smooth, material_lut, maps, tangents)


def to_world(mesh: MeshData, matrix_world):
    """World-space (vertices (n, 3), triangles (t, 3), normals (t, 3, 3)) of one instance.

    Normals use the inverse transpose; a mirroring matrix (det < 0) flips the winding so
    the geometric normal keeps agreeing with the shading normals, as Cycles does.
    """
    m = np.asarray(matrix_world, dtype=np.float64)
    linear = m[:3, :3]
    vertices = mesh.vertices @ linear.T + m[:3, 3]
    triangles = mesh.triangles
    mirrored = np.linalg.det(linear) < 0
    if mirrored:
        triangles = triangles[:, [0, 2, 1]]
    if not mesh.smooth.any():
        return vertices, triangles, None  # flat: the core uses geometric normals
    # Row vectors: (M^-T n)^T = n^T M^-1, as one (3t, 3) x (3, 3) product (a stacked
    # (t, 3, 3) @ (3, 3) matmul is several times slower for millions of triangles).
    t = len(mesh.normals)
    normals = (mesh.normals.reshape(-1, 3) @ np.linalg.pinv(linear)).reshape(t, 3, 3)
    if mirrored:
        normals = normals[:, [0, 2, 1]]
    return vertices, triangles, normals


# ---------------------------------------------------------------------------------------
# Exporter


class _Exporter:
    def __init__(self, depsgraph):
        self.depsgraph = depsgraph
        self.scene = depsgraph.scene
        self.out = ExportedScene()
        self._material_index = {}  # material pointer (or None) -> index in out.materials
        self._image_means = {}  # image means shared by this export's materials
        self._warned = set()
        self.textured = False
        self.spaces = []  # the texture spaces programs read (shading.GENERATED, OBJECT)
        self.properties = []  # the object properties Attribute nodes of type Object read

    def warn(self, text):
        if text not in self._warned:
            self._warned.add(text)
            self.out.warnings.append(text)

    def material(self, mat):
        key = None if mat is None else mat.original.as_pointer()
        index = self._material_index.get(key)
        if index is None:
            spec, warnings = materials.convert(mat, self._image_means)
            for w in warnings:
                self.warn(w)
            index = self._material_index[key] = len(self.out.materials)
            self.out.materials.append(spec)
        return index

    def holdout_lut(self, obj, lut):
        """The materials of an object marked Holdout (or in a Holdout collection of the view
        layer): each slot's material held out from camera rays (materials.camera_holdout),
        keeping its transparency as Cycles does."""
        out = []
        for k in lut.tolist():
            index = self._material_index.get(("holdout", k))
            if index is None:
                spec, warnings = materials.camera_holdout(self.out.materials[k], obj.name)
                for w in warnings:
                    self.warn(w)
                index = self._material_index[("holdout", k)] = len(self.out.materials)
                self.out.materials.append(spec)
            out.append(index)
        return np.array(out, np.int32)

    def slot_lut(self, slots):
        return np.array([self.material(s) for s in slots], np.int32)

    def run(self):
        layer = shader_nodes.RENDER_LAYER.set(tuple(
            owner for owner in (self.depsgraph.view_layer, self.scene, self.scene.world)
            if owner is not None))
        try:
            return self._run()
        finally:
            shader_nodes.RENDER_LAYER.reset(layer)

    def _run(self):
        # Materials first: whether any has a texture decides if meshes carry UV maps.
        for id_ in self.depsgraph.ids:
            if isinstance(id_, bpy.types.Material):
                self.material(id_)
        programs = [spec.kwargs[key] for m in self.out.materials for spec in m.parts()
                    for key in materials.PROGRAM_KEYS if spec.kwargs.get(key) is not None]
        self.textured = bool(programs)
        sh = core.load().shading
        self.spaces = sorted({name for p in programs for name in p.uv_maps
                              if name in (sh.GENERATED, sh.OBJECT, sh.NORMAL, sh.PARAMETRIC,
                                          sh.ISLAND_RANDOM, sh.POINTINESS)
                              or name.startswith((sh.COLOUR_ATTRIBUTE, sh.COLOUR_ALPHA,
                                                  sh.ATTRIBUTE, sh.ATTRIBUTE_SCALARS,
                                                  sh.RADIAL, sh.UV_TANGENT))})
        read = {n for p in programs for n in p.uv_maps}
        self.out.object_maps = [n for n in sh.OBJECT_MAPS if n in read] + sorted(
            n for n in read if n.startswith((sh.OBJECT_ATTRIBUTE, sh.OBJECT_ATTRIBUTE_SCALARS)))
        self.properties = sorted({n[len(prefix):] for n in self.out.object_maps
                                  for prefix in (sh.OBJECT_ATTRIBUTE,
                                                 sh.OBJECT_ATTRIBUTE_SCALARS)
                                  if n.startswith(prefix)})
        self.tangent_maps = sorted({m.normal_uv for m in self.out.materials
                                    if m.normal_uv is not None})
        for inst in self.depsgraph.object_instances:
            obj = inst.object
            if obj.type in GEOMETRY_TYPES:
                self.geometry(inst, obj)
            elif obj.type == "LIGHT":
                self.light(inst, obj)
            elif obj.type in UNSUPPORTED_TYPES:
                self.warn(f"object '{obj.name}' ({UNSUPPORTED_TYPES[obj.type]}) not supported "
                          f"yet, skipped")
        self.out.camera = camera_settings(self.scene, self.depsgraph, self.warn)
        self.out.world_colour, self.out.environment, suns = world_lighting(
            self.scene.world, self.warn, self._image_means)
        self.out.lights.extend(suns)
        volume, notes = materials.world_volume(self.scene.world, self._image_means)
        self.out.world_volume = volume
        for note in notes:
            self.warn(note)
        return self.out

    def geometry(self, inst, obj):
        # The render depsgraph already drops hide_render objects; a viewport depsgraph (the
        # tests, or a future viewport render) does not, so check the original object too.
        if not inst.is_instance and (obj.original.hide_render or not inst.show_self):
            return
        if inst.is_instance and not inst.show_self:
            return
        key = (obj.type, obj.data.as_pointer() if obj.data is not None else 0,
               0 if obj.type == "MESH" else obj.original.as_pointer())
        mesh_data = self.out.meshes.get(key)
        if mesh_data is None:
            mesh_data = self.read(obj, key)
            if mesh_data is None:
                return
        if len(mesh_data.triangles) == 0:
            return
        lut = self.slot_lut(s.material for s in obj.material_slots)
        if len(lut) == 0:
            lut = mesh_data.material_lut
        if len(lut) == 0:
            lut = np.array([self.material(None)], np.int32)
        if obj.original.holdout_get(view_layer=self.depsgraph.view_layer):
            lut = self.holdout_lut(obj, lut)
        name = obj.name if not inst.is_instance or inst.parent is None else \
            f"{inst.parent.name}/{obj.name}"
        self.out.instances.append(Instance(
            name, key, np.array(inst.matrix_world.copy()), lut, bool(inst.is_instance),
            self.terminator_offset(obj), tuple(obj.color),
            core.load().noise.object_random(obj.name, inst.random_id if inst.is_instance
                                            else None),
            int(obj.pass_index), self.object_properties(obj, lut)))

    def object_properties(self, obj, lut) -> dict:
        """The properties Attribute nodes of type Object read, on `obj`; one its materials
        read and it lacks is warned (it reads 0 there, Alpha included, as in Cycles)."""
        out = {name: shader_nodes.id_property((obj, obj.data), name)
               for name in self.properties}
        sh = core.load().shading
        for name, values in out.items():
            if values is not None:
                continue
            keys = (sh.OBJECT_ATTRIBUTE + name, sh.OBJECT_ATTRIBUTE_SCALARS + name)
            users = [m.name for m in (self.out.materials[k] for k in sorted(set(lut.tolist())))
                     if any(spec.kwargs.get(key) is not None
                            and any(n in spec.kwargs[key].uv_maps for n in keys)
                            for spec in m.parts() for key in materials.PROGRAM_KEYS)]
            if users:
                self.warn(f"object '{obj.name}' has no property '{name}' (a number or 1-4 "
                          f"numbers) that material '{users[0]}' reads with an Attribute "
                          f"node: it reads 0 there")
        return out

    def terminator_offset(self, obj) -> float:
        """The object's shadow terminator geometry offset (Blender 3.0+; Cycles' default
        0.1 where it is missing); its Shading Offset is not supported and is warned."""
        shading = float(getattr(obj, "shadow_terminator_shading_offset", 0.0))
        if shading > 0.0:
            self.warn(f"object '{obj.name}': Shadow Terminator Shading Offset {shading:.3g} is "
                      f"not supported; rendered as 0")
        return min(max(float(getattr(obj, "shadow_terminator_geometry_offset", 0.1)), 0.0), 1.0)

    def light(self, inst, obj):
        if not inst.is_instance and (obj.original.hide_render or not inst.show_self):
            return
        spec = light_settings(obj.data, np.array(inst.matrix_world.copy()), obj.name, self.warn)
        if spec is not None:
            spec["visible_camera"] = bool(getattr(obj, "visible_camera", False))
            self.out.lights.append(spec)

    def read(self, obj, key):
        try:
            mesh = obj.to_mesh()
        except RuntimeError as exc:
            self.warn(f"object '{obj.name}': could not be converted to a mesh ({exc}), skipped")
            return None
        try:
            if mesh is None:
                data = MeshData(np.zeros((0, 3)), np.zeros((0, 3), np.int64), np.zeros(0, np.int32),
                                np.zeros((0, 3, 3)), np.zeros(0, bool), np.zeros(0, np.int32))
            else:
                data = read_mesh(mesh, self.slot_lut(mesh.materials), self.textured,
                                 self.tangent_maps, self.warn, self.spaces)
        finally:
            obj.to_mesh_clear()
        self.out.meshes[key] = data
        return data


def light_settings(light, matrix_world, name, warn):
    """Keyword arguments for the core's `Light` from a Blender light datablock, with
    Cycles' strength: colour (x blackbody colour) x power x 2^exposure (4.5+)."""
    if getattr(getattr(light, "cycles", None), "is_portal", False):
        return None  # a portal guides sampling in Cycles; it emits nothing
    colour = np.array(light.color[:3], np.float64)
    if getattr(light, "use_temperature", False):
        colour = colour * np.array(light.temperature_color[:3])
    power = colour * float(light.energy) * 2.0 ** float(getattr(light, "exposure", 0.0))
    normalize = bool(getattr(light, "normalize", True))
    if not normalize and light.type != "AREA":  # (the core takes an area light's flag)
        power, normalize = power * unnormalized_scale(light), True
    spec = dict(name=name, type=light.type, power=tuple(power), matrix=matrix_world,
                normalize=normalize,
                use_mis=bool(getattr(getattr(light, "cycles", None),
                                     "use_multiple_importance_sampling", True)))
    if light.type in ("POINT", "SPOT"):
        spec.update(radius=float(light.shadow_soft_size),
                    soft_falloff=bool(getattr(light, "use_soft_falloff", True)))
    if light.type == "SPOT":
        spec.update(spot_size=float(light.spot_size), spot_blend=float(light.spot_blend))
        if getattr(light, "use_square", False):
            warn(f"light '{name}': square spot cones are not supported; rendered round")
    elif light.type == "SUN":
        spec.update(angle=float(light.angle))
    elif light.type == "AREA":
        spec.update(shape=light.shape, size_x=float(light.size), size_y=float(light.size_y),
                    spread=float(getattr(light, "spread", np.pi)))
    if getattr(light, "use_nodes", False) and getattr(light, "node_tree", None) is not None:
        spec["power"] = tuple(power * light_tree_emission(light.node_tree, name, warn))
    return spec


def unnormalized_scale(light) -> float:
    """What Normalize off multiplies a point, spot or sun light's power by in Cycles, as its
    renders measure it (the factory scene's mean, unnormalized over normalized): a point or
    spot light of radius r > 0 its sphere's area 4 pi r^2 (r 0.1: 0.1257; 0.5: 3.1416), of
    radius 0 4; a sun of angle a > 0 pi sin^2(a / 2) (0.2: 0.03131; 0.6: 0.2744), of angle
    0 1."""
    if light.type == "SUN":
        half = 0.5 * float(light.angle)
        return math.pi * math.sin(half) ** 2 if half > 0.0 else 1.0
    r = float(light.shadow_soft_size)
    return 4.0 * math.pi * r * r if r > 0.0 else 4.0


def light_tree_emission(tree, name, warn) -> np.ndarray:
    """What a light's node tree multiplies its emission by, as Cycles evaluates it: the
    Emission node on its Light Output, Color x Strength, each the constant its chain
    reduces to (a Blackbody colour, a Light Falloff's Quadratic output without Smooth: its
    Strength); white and 1 in the tree Blender makes: no change. Nothing there, or a group
    whose tree is missing, emits nothing (as in Cycles: checked on a render). Anything
    else (a texture, a falloff that varies with distance, another shader) is warned and
    left out (1)."""
    out = next((n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputLight"
                and n.is_active_output), None)
    link = None if out is None else shader_nodes.live_link(out.inputs["Surface"])
    node = None if link is None else link.from_node
    if node is None or node.bl_idname == "ShaderNodeGroup":
        what = "nothing" if node is None else f"group node '{node.name}' without its tree"
        warn(f"light '{name}': its node tree has {what} on its Light Output; it emits "
             f"nothing, as in Cycles")
        return np.zeros(3)
    if node.bl_idname == "ShaderNodeEmission":
        reduce = materials.constant_of
        (colour, c_notes), (strength, s_notes) = (reduce(node.inputs[s])
                                                  for s in ("Color", "Strength"))
        if colour is not None and strength is not None and not c_notes + s_notes:
            return np.array(colour[:3], np.float64) * float(strength)
        why = "; ".join(c_notes + s_notes) or "a chain Specula cannot reduce to a constant"
        warn(f"light '{name}': its node tree's Emission varies ({why}); using its colour and "
             f"power")
        return np.ones(3)
    warn(f"light '{name}': its node tree (node '{node.name}' ({node.bl_label or node.bl_idname})"
         f" on its Light Output) is not supported beyond an Emission; using its colour and "
         f"power")
    return np.ones(3)


def export(depsgraph) -> ExportedScene:
    """Read the evaluated scene into an `ExportedScene` (raises ExportError if unrenderable)."""
    return _Exporter(depsgraph).run()


# ---------------------------------------------------------------------------------------
# Camera and world


def focus_distance(cam_obj, dof, depsgraph=None):
    """Cycles' focal distance: along the view axis to the focus object, else the field."""
    target = dof.focus_object
    if target is None:
        return float(dof.focus_distance)
    if depsgraph is not None:
        target = target.evaluated_get(depsgraph)
    m = np.array(target.matrix_world)
    subtarget = getattr(dof, "focus_subtarget", "")
    if subtarget and target.type == "ARMATURE" and target.pose is not None:
        bone = target.pose.bones.get(subtarget)
        if bone is not None:
            m = m @ np.array(bone.matrix)
    cam_m = np.array(cam_obj.matrix_world)
    view_dir = cam_m[:3, 2] / max(np.linalg.norm(cam_m[:3, 2]), 1e-300)
    return float(abs(np.dot(view_dir, cam_m[:3, 3] - m[:3, 3])))


def camera_settings(scene, depsgraph, warn) -> dict:
    """Keyword arguments of the core's `Camera` for `scene.camera`."""
    cam_obj = scene.camera
    if cam_obj is None:
        raise ExportError(f"scene '{scene.name}' has no active camera")
    if cam_obj.type != "CAMERA":
        raise ExportError(f"the active camera '{cam_obj.name}' is a {cam_obj.type}, not a camera")
    cam_obj = cam_obj.evaluated_get(depsgraph)
    cam = cam_obj.data
    cam_type = cam.type
    if cam_type not in ("PERSP", "ORTHO"):
        warn(f"camera '{cam_obj.name}': {cam_type} cameras are not supported; rendered as "
             f"perspective")
        cam_type = "PERSP"
    dof = cam.dof
    render = scene.render
    return dict(
        world_from_camera=np.array(cam_obj.matrix_world), type=cam_type, lens_mm=float(cam.lens),
        ortho_scale=float(cam.ortho_scale), sensor_width=float(cam.sensor_width),
        sensor_height=float(cam.sensor_height), sensor_fit=cam.sensor_fit,
        shift_x=float(cam.shift_x), shift_y=float(cam.shift_y),
        clip_start=float(cam.clip_start), clip_end=float(cam.clip_end),
        use_dof=bool(dof.use_dof), fstop=float(dof.aperture_fstop),
        focus_distance=focus_distance(cam_obj, dof, depsgraph),
        blades=int(dof.aperture_blades), rotation=float(dof.aperture_rotation),
        ratio=float(dof.aperture_ratio), pixel_aspect_x=float(render.pixel_aspect_x),
        pixel_aspect_y=float(render.pixel_aspect_y))


def _uses_nodes(idblock):
    # 5.0 always uses the node tree (use_nodes is deprecated there).
    return idblock.node_tree is not None and (bpy.app.version >= (5, 0) or idblock.use_nodes)


# The width of a baked world map (height: half): Cycles runs the world's shader per ray, the
# map is looked up bilinearly between texel centres, which rounds off a kink (a Map Range's
# clamp at the horizon: 0.6 % too bright in that pixel row at 1024, 0.12 % at 2048, measured
# against Cycles on tests/cycles world_nodes_sky). A world with images is baked at twice its
# widest image's width, so the lookup adds little blur to the image it resamples, up to
# 4096 (at 2048: 25 MB of map and 34 MB of sampling tables; at 4096 four times that).
WORLD_BAKE_WIDTH = 2048


def world_lighting(world, warn, texture_cache):
    """(colour, environment, suns) of the core's World: the background radiance (colour x
    strength of a plain Background; black without a world, or with its Surface unlinked, as
    in Cycles), the keywords of an equirectangular map (core.World's environment and
    texture_from_world) where the world varies with direction, or None, and the core Light
    keywords of its Sky Textures' sun discs (`sky_suns`).

    A Background whose Color is an Environment Texture (Equirectangular, Linear), its Vector
    unlinked, a Texture Coordinate's Generated or a rotating Mapping, is the image itself,
    looked up exactly (`_plain_environment`). Any other node tree the shader programs can
    express (Background and Emission under Mix and Add Shaders; textures, Mapping, Math,
    Color Ramp, Gradient, Noise ... on the direction) is baked into a map
    (environment.bake) that the kernel looks up and importance-samples as such a map; a
    tree that does not vary is its constant. A Light Path node's Is ... Ray outputs bake a
    map for each kind of ray they tell from light samples (core.World's ray_environments,
    environment.bake_rays: Is Camera Ray, a camera background of its own). Trees that
    cannot be baked (the Light Path's Ray Length and depths, a Hosek-Wilkie Sky Texture
    ...) warn, naming the node, and render the viewport colour."""
    if world is None:
        return (0.0, 0.0, 0.0), None, []
    flat = tuple(float(c) for c in world.color[:3])
    if not _uses_nodes(world):
        return flat, None, []
    out = world.node_tree.get_output_node('CYCLES')
    if out is None:
        warn(f"world '{world.name}': no active World Output node for Cycles; using its "
             f"viewport colour")
        return flat, None, []
    surface = out.inputs.get("Surface")
    if surface is None or shader_nodes.live_link(surface) is None:
        return (0.0, 0.0, 0.0), None, []  # Cycles renders an unlinked world black too
    plain = _plain_environment(world, shader_nodes.live_link(surface).from_node, warn)
    if plain is not None:
        return flat, plain or None, []  # {}: the plain map could not be read (warned)
    program, why = shader_nodes.compile_world(surface, texture_cache)
    if program is None:
        warn(f"world '{world.name}' cannot be rendered from its node tree ({why}); rendering "
             f"its viewport colour instead")
        return flat, None, []
    sh, environment = core.load().shading, core.load().environment
    varies = program.uv_maps or program.textures or any(ins[0] in sh.GEOMETRY_OPS
                                                        for ins in program.code)
    reads_path = any(ins[0] == sh.OP_LIGHT_PATH for ins in program.code)
    if not varies and not reads_path:
        values = sh.evaluate(program)
        return tuple(max(float(v), 0.0) for v in values[program.out:program.out + 3]), None, []
    width = min(max([WORLD_BAKE_WIDTH] + [2 * t.texels.shape[1] for t in program.textures]),
                4096) if varies else 8
    env = dict(environment=environment.bake(program, width, width // 2),
               texture_from_world=np.eye(3))
    if reads_path:  # the light samples' map (flags 0), and those of the rays told apart
        env["ray_environments"] = environment.bake_rays(program, width, width // 2)
    return flat, env, sky_suns(world, program, reads_path, warn)


def sky_suns(world, program, reads_path, warn) -> list:
    """Core Light keywords of a world program's Sky Texture sun discs, which its map
    leaves out (a 2048-texel-wide map would hold the default 0.545-degree disc in about 7
    texels, its power off by tens of %): each a sun light of the disc's angle and
    irradiance (environment.disc_irradiance), seen by camera rays as the world is. A
    world that shows the disc to some kind of ray otherwise than to light samples (a Light
    Path node: Cycles' bounces then see it otherwise) is warned: every ray sees it as light
    samples do."""
    environment = core.load().environment
    lights = []
    for name, direction, diameter in program.suns:
        direction = np.asarray(direction, np.float64)
        irradiance = environment.disc_irradiance(program, direction, diameter)
        if reads_path and any(not np.allclose(environment.disc_irradiance(
                program, direction, diameter, flags), irradiance, rtol=1e-6, atol=0.0)
                for flags in environment.ESCAPING_RAYS):
            warn(f"world '{world.name}': the sun disc of node '{name}' is seen differently "
                 f"by some kinds of ray (a Light Path node); every ray sees it as light "
                 f"samples do")
        if not np.any(irradiance > 0.0):
            continue  # below the horizon, or of no intensity
        frame = np.eye(4)
        frame[:3, 0], frame[:3, 1] = core.load().sampling.build_frame(*direction)
        frame[:3, 2] = direction  # a sun shines along its local -Z
        lights.append(dict(name=f"{world.name}: sun of '{name}'", type="SUN",
                           power=tuple(float(v) for v in irradiance), matrix=frame,
                           angle=float(diameter), visible_camera=True, use_mis=True))
    return lights


def _plain_environment(world, node, warn):
    """A world whose Surface is `node`, when it is a Background lit by an Environment
    Texture that the core's map looks up exactly (Equirectangular, Linear; Strength
    unlinked; Vector unlinked, a Texture Coordinate's Generated or a Mapping that only
    rotates it): the core World's keywords, {} where its image cannot be read (warned), and
    None for any other tree."""
    if node.bl_idname != "ShaderNodeBackground" or node.inputs["Strength"].is_linked \
            or not node.inputs["Color"].is_linked:
        return None
    tex = shader_nodes.live_link(node.inputs["Color"]).from_node
    if tex.bl_idname != "ShaderNodeTexEnvironment" or tex.projection != "EQUIRECTANGULAR" \
            or tex.interpolation != "Linear" or tex.image is None:
        return None
    rotation = _rotation_only(tex.inputs.get("Vector"))
    if rotation is None:
        return None
    image, where = tex.image, f"world '{world.name}': node '{tex.name}'"
    try:
        w, h = (int(v) for v in image.size)
        if w * h == 0:
            raise RuntimeError("no pixels (file missing or not an image)")
        px = np.empty(w * h * image.channels, np.float32)
        image.pixels.foreach_get(px)
    except (RuntimeError, ValueError) as exc:
        warn(f"{where}: image '{image.name}' ({image.filepath}) cannot be read: {exc}; "
             f"rendering the world's viewport colour instead")
        return {}
    rgb = px.reshape(h, w, image.channels)[..., :3].astype(np.float64)
    if image.channels < 3:
        rgb = np.repeat(px.reshape(h, w, image.channels)[..., :1], 3, axis=2)
    if not image.is_float and image.colorspace_settings.name == "sRGB":
        rgb = shader_nodes.srgb_to_linear(rgb)
    if not np.all(np.isfinite(rgb)):
        warn(f"{where}: image '{image.name}' has NaN/inf pixels; they are rendered black")
        rgb = np.nan_to_num(rgb, nan=0.0, posinf=0.0, neginf=0.0)
    rgb = np.maximum(rgb, 0.0)
    strength = float(node.inputs["Strength"].default_value)
    return dict(environment=rgb * strength, texture_from_world=rotation)


def _rotation_only(vector):
    """The rotation (3, 3) taking world directions into an Environment Texture's frame when
    its Vector input only rotates the direction (unlinked; a Texture Coordinate's
    Generated; a Mapping of zero Location and unit Scale, its other inputs unlinked, over
    either), else None."""
    link = None if vector is None else shader_nodes.live_link(vector)
    if link is None:
        return np.eye(3)
    src = link.from_node
    if src.bl_idname == "ShaderNodeTexCoord":
        return np.eye(3) if link.from_socket.name == "Generated" else None
    # A Mapping's own Vector unlinked is 0, in Cycles too: not the direction.
    if src.bl_idname != "ShaderNodeMapping" or not src.inputs["Vector"].is_linked \
            or _rotation_only(src.inputs["Vector"]) is None:
        return None
    ins = {k: src.inputs.get(k) for k in ("Location", "Rotation", "Scale")}
    if any(sock is not None and sock.is_linked for sock in ins.values()):
        return None
    location = np.zeros(3) if ins["Location"] is None else np.array(ins["Location"].default_value)
    scale = np.ones(3) if ins["Scale"] is None else np.array(ins["Scale"].default_value)
    if src.vector_type not in ("POINT", "TEXTURE", "VECTOR") or np.any(scale != 1.0) \
            or (src.vector_type != "VECTOR" and np.any(location != 0.0)):
        return None
    r = np.array(core.load().shading.euler_rotation(
        *(float(a) for a in ins["Rotation"].default_value[:3])))
    inner = _rotation_only(src.inputs["Vector"])
    # POINT and VECTOR rotate the lookup vector; TEXTURE applies the inverse.
    return (r.T if src.vector_type == "TEXTURE" else r) @ inner


# ---------------------------------------------------------------------------------------
# Core objects


def render_settings_kwargs(scene, width, height, samples=None):
    """Keyword arguments of the core's `RenderSettings` from `scene.specula` (and Blender's
    own Film > Transparent)."""
    s = scene.specula
    return dict(width=int(width), height=int(height),
                samples=int(samples if samples is not None else s.samples),
                time_limit=float(s.time_limit), target_error=float(s.target_error),
                max_bounces=int(s.max_bounces),
                transparent_max_bounces=int(s.transparent_max_bounces), seed=int(s.seed),
                threads=int(s.threads),
                fresnel=s.fresnel.lower(), filter_type=s.filter_type,
                filter_width=float(s.filter_width), replicates=int(s.replicates),
                replicate_range=replicate_range(s),
                light_tracing=bool(s.use_light_tracing),
                film_transparent=bool(scene.render.film_transparent),
                film_transparent_glass=bool(s.film_transparent_glass),
                film_transparent_roughness=float(s.film_transparent_roughness))


def replicate_range(s):
    """(first, stop) of the scene's replicate subset, or None for all of them (checked
    against the replicate count by RenderSettings.validate)."""
    if not s.use_replicate_subset:
        return None
    return int(s.replicate_first), int(s.replicate_last) + 1


def resolution(scene):
    """Render size in pixels, resolution_percentage applied as Blender does."""
    r = scene.render
    pct = r.resolution_percentage / 100.0
    return max(1, int(r.resolution_x * pct)), max(1, int(r.resolution_y * pct))


def border_region(scene, width, height):
    """Blender's render border in full-frame pixels, (x0, y0, x1, y1) with x1, y1 exclusive
    and row 0 at the bottom, or None when the whole frame is rendered.

    Blender (render_init_from_main) truncates border fraction x size computed in float32;
    the same arithmetic here gives the same rectangle (3.4 - 5.0), whether or not the image
    is then cropped to the border.
    """
    r = scene.render
    if not r.use_border:
        return None
    f32 = np.float32
    x0, x1 = (int(f32(v) * f32(width)) for v in (r.border_min_x, r.border_max_x))
    y0, y1 = (int(f32(v) * f32(height)) for v in (r.border_min_y, r.border_max_y))
    x0, x1 = min(max(x0, 0), width), min(max(x1, 0), width)
    y0, y1 = min(max(y0, 0), height), min(max(y1, 0), height)
    if (x0, y0, x1, y1) == (0, 0, width, height) or x1 <= x0 or y1 <= y0:
        return None
    return x0, y0, x1, y1


# Instances of one mesh are transformed together, in groups of at most this many triangles
# (bounds the temporary arrays; particle systems can have millions of instances).
BATCH_TRIANGLES = 1 << 20


def to_world_batch(mesh: MeshData, matrices):
    """World-space arrays of k instances of `mesh` at once (all with the same det sign).

    matrices : (k, 4, 4). Returns vertices (k * n, 3), triangles (k * t, 3) into them and
    normals (k * t, 3, 3), instance-major.
    """
    m = np.asarray(matrices, dtype=np.float64)
    linear = m[:, :3, :3]
    vertices = np.einsum("kij,nj->kni", linear, mesh.vertices) + m[:, None, :3, 3]
    normals = np.einsum("tcj,kji->ktci", mesh.normals, np.linalg.pinv(linear))
    triangles = mesh.triangles
    if np.linalg.det(linear[0]) < 0:
        triangles = triangles[:, [0, 2, 1]]
        normals = normals[:, :, [0, 2, 1]]
    offsets = np.arange(len(m), dtype=np.int64)[:, None, None] * len(mesh.vertices)
    return (vertices.reshape(-1, 3), (triangles[None] + offsets).reshape(-1, 3),
            normals.reshape(-1, 3, 3))


def _group_instances(exported: ExportedScene):
    """Yield (name, mesh, lut, [instances]): objects alone, instances grouped by mesh."""
    groups = {}
    for inst in exported.instances:
        mesh = exported.meshes[inst.mesh_key]
        if not inst.is_instance:
            yield inst.name, mesh, inst.material_lut, [inst]
            continue
        mirrored = bool(np.linalg.det(inst.matrix_world[:3, :3]) < 0)
        key = (inst.mesh_key, inst.material_lut.tobytes(), mirrored, inst.terminator_offset)
        groups.setdefault(key, []).append(inst)
    for insts in groups.values():
        mesh = exported.meshes[insts[0].mesh_key]
        step = max(1, BATCH_TRIANGLES // max(1, len(mesh.triangles)))
        for start in range(0, len(insts), step):
            chunk = insts[start:start + step]
            name = chunk[0].name if len(chunk) == 1 else \
                f"{chunk[0].name} (+{len(chunk) - 1} instances)"
            yield name, mesh, chunk[0].material_lut, chunk


def _instance_uvs(mesh: MeshData, insts, object_maps=()) -> dict:
    """The UV maps of k instances of `mesh`, corners in the order to_world gives them (a
    mirroring matrix flips the winding), and the Object Info maps `object_maps` (each
    instance's values on all its corners)."""
    mirrored = np.linalg.det(insts[0].matrix_world[:3, :3]) < 0
    sh = core.load().shading
    maps = {name: np.tile(m[:, [0, 2, 1]] if mirrored else m, (len(insts), 1, 1))
            for name, m in mesh.uv_maps.items()
            if not name.startswith((sh.RADIAL, sh.UV_TANGENT))}
    for name, m in mesh.uv_maps.items():
        if name.startswith((sh.RADIAL, sh.UV_TANGENT)):
            local = m[:, [0, 2, 1]] if mirrored else m
            maps[name] = np.concatenate([_as_normals(local, i.matrix_world) for i in insts])
    # Each instance's values, (k, 3) per map; the inverses, when read, once for them all.
    matrices = np.array([np.asarray(i.matrix_world, np.float64) for i in insts])
    inverses = shader_nodes.world_to_object(matrices) if any(
        n in (*sh.OBJECT_INVERSE, sh.OBJECT_INVERSE_ORIGIN) for n in object_maps) else None
    per_instance = {
        sh.OBJECT_LOCATION: lambda: matrices[:, :3, 3],
        sh.OBJECT_COLOUR: lambda: [i.colour[:3] for i in insts],
        sh.OBJECT_NUMBERS: lambda: [(i.colour[3], i.random, i.pass_index) for i in insts],
        sh.OBJECT_INVERSE_ORIGIN: lambda: inverses[:, :3, 3],
        **{axis: (lambda j=j: matrices[:, :3, j]) for j, axis in enumerate(sh.OBJECT_AXES)},
        **{axis: (lambda j=j: inverses[:, :3, j]) for j, axis in enumerate(sh.OBJECT_INVERSE)}}
    for name in object_maps:
        for prefix, scalars in ((sh.OBJECT_ATTRIBUTE, False),
                                (sh.OBJECT_ATTRIBUTE_SCALARS, True)):
            if name.startswith(prefix):
                per_instance[name] = lambda n=name[len(prefix):], s=scalars: \
                    _property_channels(insts, n, s)
    t = len(mesh.triangles)
    for name in object_maps:
        values = np.asarray(per_instance[name](), np.float32)
        maps[name] = np.broadcast_to(np.repeat(values, t, axis=0)[:, None, :],
                                     (len(insts) * t, 3, 3))
    return maps


def _property_channels(insts, name, scalars) -> np.ndarray:
    """(k, 3) each instance's object property `name` as an Attribute node of type Object
    reads it (shader_nodes.attribute_channels; zeros where the object lacks it)."""
    return np.array([shader_nodes.attribute_channels([i.properties[name]], scalars)[0]
                     if i.properties.get(name) is not None else np.zeros(3) for i in insts])


def _as_normals(local, matrix_world) -> np.ndarray:
    """Object-space directions (t, 3, 3) turned into world space as normals turn (Cycles'
    object_normal_transform of the Tangent node's and primitive_tangent's directions):
    row vectors n^T M^-1, as to_world's normals."""
    linear = np.asarray(matrix_world, np.float64)[:3, :3]
    return (local @ np.linalg.pinv(linear)).astype(np.float32)


def _instance_tangents(mesh: MeshData, insts, mat_index, specs):
    """(k t, 3, 4) world-space tangents of k instances of `mesh`, each triangle's from the
    UV map its material's normal map reads (zeros where it has none), or None. Tangents
    turn with the object (M t); a mirroring matrix flips the bitangent sign along with the
    winding, so the bitangent keeps pointing along the map's v."""
    if not mesh.tangents:
        return None
    t = len(mesh.triangles)
    local = np.zeros((t, 3, 4), np.float32)
    for k, spec in enumerate(specs):
        name = spec.normal_uv
        if name in mesh.tangents:
            rows = mat_index == k
            local[rows] = mesh.tangents[name][rows]
    out = []
    for inst in insts:
        linear = np.asarray(inst.matrix_world, np.float64)[:3, :3]
        world = local.copy()
        world[..., :3] = local[..., :3] @ linear.T
        if np.linalg.det(linear) < 0:
            world = world[:, [0, 2, 1]]
            world[..., 3] *= -1.0
        out.append(world)
    return np.concatenate(out)


def to_core(exported: ExportedScene, core):
    """Build the core's `Scene`; returns (scene, builder warnings)."""
    builder = core.SceneBuilder()
    for spec in exported.materials:
        builder.add_material(spec.to_core(core))
    for name, mesh, lut, insts in _group_instances(exported):
        if len(insts) == 1:
            vertices, triangles, normals = to_world(mesh, insts[0].matrix_world)
        else:
            vertices, triangles, normals = to_world_batch(
                mesh, np.stack([i.matrix_world for i in insts]))
        # Blender clamps out-of-range material indices to the last slot.
        mat_index = lut[np.clip(mesh.material_index, 0, len(lut) - 1)]
        k = len(insts)
        builder.add_mesh(name, vertices, triangles, np.tile(mat_index, k),
                         corner_normals=normals,
                         smooth=np.tile(mesh.smooth, k) if normals is not None else False,
                         terminator_offset=insts[0].terminator_offset,
                         uv_maps=_instance_uvs(mesh, insts, exported.object_maps),
                         tangents=_instance_tangents(mesh, insts, mat_index,
                                                     exported.materials))
    for spec in exported.lights:
        builder.add_light(core.Light(**spec))
    world = core.World(exported.world_colour, **(exported.environment or {}),
                       volume=exported.world_volume)
    scene = builder.build(core.Camera(**exported.camera), world)
    return scene, list(builder.warnings)


classes = ()


def register():
    pass


def unregister():
    pass

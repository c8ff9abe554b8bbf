"""Node chains -> shader programs (engine/shading.py), for inputs that vary over a surface.

A material colour driven by an image texture (through Mapping, Mix, Math, Separate and
Combine nodes ...) compiles into a program the kernel runs at each hit, as Cycles' SVM
compiler emits one SVM node per shader node. One small function per node kind,
`f(c, node, out) -> (register, socket type)`, in `NODES`; a chain with a node not listed
there raises `Unsupported`, naming it, and the caller falls back to the chain's constant
(materials.py). A chain with nothing varying in it (an RGB into a Mix) is left to the
constant folding, which gives the same value.

Images are read once per export (keyed by image, interpolation and extension) into the
texels Cycles would sample: byte images in sRGB keep their encoded values and are decoded
after interpolation, others are decoded per texel to scene linear; alpha is associated
where Cycles associates it (see engine/shading.py).
"""

import contextvars

import mathutils
import numpy as np

from . import core

WIDTHS = {"VALUE": 1, "INT": 1, "BOOLEAN": 1, "RGBA": 3, "VECTOR": 3}
# Node kinds whose output varies over a surface: a chain with none of them is a constant.
VARYING = ("ShaderNodeTexImage", "ShaderNodeTexEnvironment", "ShaderNodeTexCoord",
           "ShaderNodeUVMap",
           "ShaderNodeTexChecker", "ShaderNodeFresnel", "ShaderNodeLayerWeight",
           "ShaderNodeVertexColor", "ShaderNodeTexNoise", "ShaderNodeTexGradient",
           "ShaderNodeTexWave", "ShaderNodeTexMagic", "ShaderNodeTexWhiteNoise",
           "ShaderNodeNewGeometry", "ShaderNodeObjectInfo", "ShaderNodeTexBrick",
           "ShaderNodeTexVoronoi", "ShaderNodeAttribute", "ShaderNodeLightPath",
           "ShaderNodeTangent", "ShaderNodeVectorTransform", "ShaderNodeWireframe",
           "ShaderNodeDisplacement", "ShaderNodeLightFalloff", "ShaderNodeCameraData")
# Nodes that read the hit's view direction and normal: an emission cannot use them (a
# light sampled from a shading point would need them from that point's side too).
VIEW_DEPENDENT = ("ShaderNodeFresnel", "ShaderNodeLayerWeight")


# The pass index of the material being read (materials.convert sets it): Object Info's
# Material Index, a constant of the material's programs (Cycles' shader_pass_id). A world
# reads 0.
MATERIAL_PASS_INDEX = contextvars.ContextVar("material_pass_index", default=0)
# What an Attribute node of type View Layer reads (the exporter sets it): the render's view
# layer, scene and world, searched in that order (id_property).
RENDER_LAYER = contextvars.ContextVar("render_layer", default=())


class Unsupported(Exception):
    """A node (or a setting of one) that has no program instruction yet."""


# ------------------------------------------------------------------ node groups
# Cycles compiles a material as if its node groups were ungrouped. Here the nodes inside a
# group are read in place, each seen through the group nodes that lead to it (`path`,
# outermost first): a link from a group node continues inside its group at the Group
# Output, a link from a Group Input continues outside at the group node's input. Every
# node and socket reached through `live_link` carries its path, so the readers below and
# materials.py walk through groups without knowing of them.

class _InGroups:
    """A bpy node or socket (`raw`) inside the groups on `path`; otherwise the bpy item."""

    __slots__ = ("raw", "path")

    def __init__(self, raw, path):
        self.raw, self.path = raw, path

    def __getattr__(self, name):
        return getattr(self.raw, name)

    def as_pointer(self):
        """Distinct per item and path: a group used twice is two sets of nodes."""
        return hash((self.raw.as_pointer(),) + tuple(g.as_pointer() for g in self.path))

    def __eq__(self, other):
        return type(other) is type(self) and self.raw == other.raw and self.path == other.path

    def __hash__(self):
        return self.as_pointer()


class GroupSocket(_InGroups):
    """A bpy node socket inside the groups on `path`."""

    __slots__ = ()

    @property
    def node(self):
        return GroupNode(self.raw.node, self.path)


class GroupNode(_InGroups):
    """A bpy node inside the groups on `path`: its sockets carry the path on."""

    __slots__ = ()

    @property
    def inputs(self):
        return _Sockets(self.raw.inputs, self.path)

    @property
    def outputs(self):
        return _Sockets(self.raw.outputs, self.path)

    @property
    def internal_links(self):
        return [Link(GroupSocket(k.from_socket, self.path), GroupSocket(k.to_socket, self.path))
                for k in self.raw.internal_links]


class _Sockets:
    """A node's inputs or outputs, each wrapped with the node's path."""

    def __init__(self, raw, path):
        self.raw, self.path = raw, path

    def _wrap(self, s):
        return None if s is None else GroupSocket(s, self.path)

    def __getitem__(self, key):
        if isinstance(key, slice):
            return [self._wrap(s) for s in list(self.raw)[key]]
        return self._wrap(self.raw[key])

    def get(self, key, default=None):
        s = self.raw.get(key)
        return default if s is None else self._wrap(s)

    def __iter__(self):
        return (self._wrap(s) for s in self.raw)

    def __len__(self):
        return len(self.raw)

    def __contains__(self, key):
        return key in self.raw


class Link:
    """A link as the readers see it: its source socket (and node) past any group boundary."""

    __slots__ = ("from_socket", "to_socket")

    def __init__(self, from_socket, to_socket=None):
        self.from_socket, self.to_socket = from_socket, to_socket

    @property
    def from_node(self):
        return self.from_socket.node


class GroupValue:
    """What an unlinked socket of a group boundary holds (a Group Output's input, a group
    node's input), seen as a Value or RGB node of that value."""

    def __init__(self, socket):
        self.bl_idname = "ShaderNodeRGB" if WIDTHS.get(socket.type) == 3 else "ShaderNodeValue"
        self.bl_label, self.name, self.mute = "Value", socket.node.name, False
        self.inputs, self.internal_links = [], []
        self.outputs = [_GroupValueOutput(self, socket)]

    def as_pointer(self):
        return id(self)


class _GroupValueOutput:
    def __init__(self, node, socket):
        self.node, self.name, self.identifier = node, socket.name, socket.identifier
        self.type, self.default_value = socket.type, socket.default_value
        self.is_linked, self.enabled = True, True


def live_link(socket):
    """The link that drives `socket` (a bpy socket or a GroupSocket), past group
    boundaries, or None: muted and invalid links do not count (Blender then evaluates the
    socket's own value)."""
    raw, path = (socket.raw, socket.path) if isinstance(socket, GroupSocket) else (socket, ())
    if not raw.is_linked:
        return None
    link = next((k for k in raw.links if not k.is_muted and k.is_valid), None)
    return None if link is None else _source(link.from_socket, path, socket)


def _source(out, path, to_socket):
    """The Link from output socket `out` (inside `path`) to `to_socket`, continued into a
    group (at its Group Output) or out of one (at the group node's input)."""
    node = out.node
    inner = None
    if node.bl_idname == "ShaderNodeGroup" and node.node_tree is not None and not node.mute:
        boundary = next((n for n in node.node_tree.nodes if n.bl_idname == "NodeGroupOutput"
                         and n.is_active_output), None)
        inner = None if boundary is None else \
            (next((s for s in boundary.inputs if s.identifier == out.identifier), None),
             path + (node,))
    elif node.bl_idname == "NodeGroupInput" and path:
        inner = (next((s for s in path[-1].inputs if s.identifier == out.identifier), None),
                 path[:-1])
    if inner is None:
        return Link(GroupSocket(out, path), to_socket)
    sock, inner_path = inner
    if sock is None:
        return None
    wrapped = GroupSocket(sock, inner_path)
    link = live_link(wrapped)
    if link is not None:
        return link
    if sock.type == "SHADER" or getattr(sock, "default_value", None) is None:
        return None
    return Link(GroupValue(sock).outputs[0], to_socket)


def enabled_input(node, name):
    """`node`'s input called `name` (or with that identifier); nodes like Mix have one per
    data type, only one enabled."""
    found = [s for s in node.inputs if s.name == name or s.identifier == name]
    return next((s for s in found if s.enabled), found[0] if found else None)


def varies(socket, seen=None) -> bool:
    """Whether the chain behind `socket` has a node whose output varies over a surface
    (each node looked at once: shared sub-chains are common in big trees)."""
    link = live_link(socket)
    seen = set() if seen is None else seen
    if link is None or link.from_node.as_pointer() in seen:
        return False
    node = link.from_node
    seen.add(node.as_pointer())
    if node.bl_idname in VARYING:
        return True
    return any(varies(s, seen) for s in node.inputs if s.enabled)


class Compiler:
    """Compiles the chain behind one socket into a `shading.Program`."""

    def __init__(self, texture_cache, view_dependent=True):
        self.sh = core.load().shading
        self.view_dependent = view_dependent
        self.program = self.sh.Program()
        self.textures = texture_cache
        self.done = {}  # (node pointer, output identifier) -> (register, type)
        self.world = False  # compiling a world's tree (compile_world)

    def compile(self, socket, to_type="RGBA"):
        """The program computing `socket`'s value as `to_type` (its result register set):
        converted to the socket's own type first, as Blender converts a link (an image's
        colour into a Roughness is its luminance, then repeated)."""
        own = socket.type if socket.type in WIDTHS else to_type
        self.program.out = self.convert(self.input(socket, own), own, to_type)
        return self.program

    def input(self, socket, to_type):
        """The register holding input `socket`'s value converted to `to_type`."""
        if socket is None:
            raise Unsupported("a missing input")
        link = live_link(socket)
        if link is None:
            value = getattr(socket, "default_value", None)
            if value is None or isinstance(value, str):
                raise Unsupported(f"input '{socket.name}' of node '{socket.node.name}'")
            values = [float(v) for v in (value[:3] if WIDTHS.get(socket.type, 1) == 3
                                         else [value])]
            return self.convert(self.program.const(values), socket.type, to_type)
        reg, kind = self.output(link.from_socket)
        return self.convert(reg, kind, to_type)

    def output(self, out):
        key = (out.node.as_pointer(), out.identifier)
        if key not in self.done:
            node = out.node
            if node.mute:
                through = next((k.from_socket for k in node.internal_links
                                if k.to_socket == out), None)
                if through is None:
                    raise Unsupported(f"muted node '{node.name}'")
                self.done[key] = (self.input(through, out.type), out.type)
            else:
                fn = NODES.get(node.bl_idname)
                if fn is None:
                    raise Unsupported(f"node '{node.name}' ({node.bl_label or node.bl_idname})")
                if node.bl_idname in VIEW_DEPENDENT and not self.view_dependent:
                    raise Unsupported(f"node '{node.name}' ({node.bl_label}) in an emission")
                self.done[key] = fn(self, node, out)
        return self.done[key]

    def convert(self, reg, from_type, to_type):
        """Blender's implicit conversions: colour -> float by luminance, vector -> float by
        the average, float -> colour or vector by repeating it."""
        wf, wt = WIDTHS.get(from_type), WIDTHS.get(to_type)
        if wf is None or wt is None:
            raise Unsupported(f"a {from_type} -> {to_type} link")
        if wf == wt:
            return reg
        if wt == 3:
            return self.program.emit(self.sh.OP_COMBINE, 3, a=reg, b=reg, c=reg)
        op = self.sh.OP_LUMINANCE if from_type == "RGBA" else self.sh.OP_AVERAGE
        return self.program.emit(op, 1, a=reg)

    def texture(self, node):
        """The shading.Texture of an Image Texture node's image, read once per export."""
        image = node.image
        if image is None:
            raise Unsupported(f"image texture '{node.name}' without an image")
        # An Environment Texture has no Extension: Cycles repeats its image.
        extension = getattr(node, "extension", "REPEAT")
        key = (image.as_pointer(), node.interpolation, extension)
        if key not in self.textures:
            pixels = ("texels", image.as_pointer())  # one read under every filter
            if pixels not in self.textures:
                self.textures[pixels] = image_texels(image)
            texels, srgb = self.textures[pixels]
            if texels is None:
                raise Unsupported(f"image '{image.name}' (no pixels: a missing file?)")
            self.textures[key] = self.sh.Texture(image.name, texels, node.interpolation,
                                                 extension, srgb)
        return self.textures[key]


# ------------------------------------------------------------------ images
# `Image.pixels` holds byte images as their stored 8-bit values / 255, still encoded in the
# image's colour space (an sRGB 128 reads 0.502, not 0.216), and float images as the
# scene-linear buffer Blender decoded on loading (a 16-bit sRGB PNG's 0.5 reads 0.214; as
# Non-Color, 0.5): read back in bpy 5.0.1.

def srgb_to_linear(c):
    """The sRGB transfer function, encoded -> linear, elementwise (the core's formula)."""
    c = np.asarray(c, np.float64)
    return core.load().shading.srgb_decode(c.ravel()).reshape(c.shape)


# Linear Display P3 (D65) -> CIE XYZ, to reach scene linear through mathutils' XYZ conversion.
_P3_TO_XYZ = np.array([[0.4865709, 0.2656677, 0.1982173],
                       [0.2289746, 0.6917385, 0.0792869],
                       [0.0000000, 0.0451134, 1.0439444]])


def _xyz_to_scene(rgb):
    return tuple(mathutils.Color(rgb).from_xyz_d65_to_scene_linear())


def _via(method):
    def to_scene(rgb):
        # Blender releases without this conversion work in linear Rec.709: keep the values.
        convert = getattr(mathutils.Color(rgb), method, None)
        return tuple(rgb) if convert is None else tuple(convert())
    return to_scene


# Byte image colour space -> (per-texel transfer function, linear primaries -> scene linear).
# Spaces not listed are decoded as sRGB, with a note in the warning.
COLOUR_SPACES = {
    "sRGB": (srgb_to_linear, _via("from_rec709_linear_to_scene_linear")),
    "Linear Rec.709": (None, _via("from_rec709_linear_to_scene_linear")),
    "Linear Rec.2020": (None, _via("from_rec2020_linear_to_scene_linear")),
    "ACEScg": (None, _via("from_acescg_to_scene_linear")),
    "ACES2065-1": (None, _via("from_aces_to_scene_linear")),
    "Linear CIE-XYZ D65": (None, _xyz_to_scene),
    "Display P3": (srgb_to_linear, lambda rgb: _xyz_to_scene(tuple(_P3_TO_XYZ @ rgb))),
}



def _space_matrix(to_scene):
    """The 3x3 matrix of a linear primaries conversion (materials.COLOUR_SPACES)."""
    return np.array([to_scene(tuple(e)) for e in np.eye(3)]).T


def image_texels(image):
    """(texels (h, w, 4) float32, srgb) as Cycles samples `image` (None when it has no
    pixels). `Image.pixels` holds byte images as stored (straight alpha, encoded) and float
    images as Blender's scene-linear, premultiplied buffer."""
    width, height = image.size
    count = len(image.pixels) if width * height else 0
    if count == 0:
        return None, False
    channels = count // (width * height)
    px = np.empty(count, np.float32)
    image.pixels.foreach_get(px)
    px = px.reshape(height, width, channels)
    texels = np.ones((height, width, 4), np.float32)
    texels[..., :3] = px[..., :3] if channels >= 3 else px[..., :1]
    if channels >= 4 or channels == 2:
        texels[..., 3] = px[..., -1]
    mode = image.alpha_mode
    if mode == "NONE":
        texels[..., 3] = 1.0
    space = image.colorspace_settings
    srgb = False
    if not image.is_float and not space.is_data:
        if mode in ("STRAIGHT", "PREMUL"):  # Cycles associates byte images on loading
            texels[..., :3] *= texels[..., 3:]
        known = space.name in COLOUR_SPACES
        transfer, to_scene = COLOUR_SPACES[space.name if known else "sRGB"]
        if space.name == "sRGB":
            srgb = True  # decoded after interpolation, as Cycles' compress_as_srgb
        else:
            if transfer is not None:
                texels[..., :3] = transfer(texels[..., :3].astype(np.float64))
            texels[..., :3] = texels[..., :3] @ _space_matrix(to_scene).T.astype(np.float32)
    return texels, srgb


# ------------------------------------------------------------------ node functions
def _n_image(c, node, out):
    """Image Texture, in each projection: Flat; Sphere and Tube (the coordinate mapped
    first); Box (three lookups weighted by the object-space shading normal, as Cycles'
    svm_node_tex_image_box, so not in an emission)."""
    sh, p = c.sh, c.program
    vec = enabled_input(node, "Vector")
    coord = c.input(vec, "VECTOR") if live_link(vec) is not None else p.uv("")
    unassociate = _unassociates(node)
    texture = c.texture(node)
    if node.projection in ("SPHERE", "TUBE"):
        coord = p.emit(sh.OP_PROJECTION, 3, a=coord, d=sh.PROJECTIONS.index(node.projection))
    if node.projection != "BOX":
        reg = p.image(texture, coord, unassociate)
    elif not c.view_dependent:
        raise Unsupported(f"image texture '{node.name}' box projection in an emission")
    else:
        normal = _through(c, p.emit(sh.OP_GEOMETRY, 3, d=0), "NORMAL", sh.OBJECT_AXES, None,
                          into=True)
        faces = p.emit(sh.OP_BOX, 9, a=normal, b=coord, d=0,
                       params=[node.projection_blend])
        first = p.image(texture, faces + 3, unassociate)
        for k in (5, 7):  # OP_BOX reads the three lookups as consecutive registers
            p.image(texture, faces + k, unassociate)
        reg = p.emit(sh.OP_BOX, 4, a=faces, b=first, d=1)
    return (reg + 3, "VALUE") if out.name == "Alpha" else (reg, "RGBA")


def _unassociates(node):
    """Whether an image node's colour is divided by its alpha where the Alpha output is
    used (Cycles unassociates a colour image's premultiplied alpha then; an Environment
    Texture has no Alpha output in 5.0)."""
    alpha = node.outputs.get("Alpha")
    return (alpha is not None and alpha.is_linked and node.image is not None
            and not node.image.colorspace_settings.is_data
            and node.image.alpha_mode not in ("CHANNEL_PACKED", "NONE"))


def _n_environment(c, node, out):
    """Environment Texture: its image in the Equirectangular or Mirror Ball projection of
    the direction at Vector, which unlinked is the position (Cycles' LINK_POSITION: in a
    world, the ray's direction) (svm_node_tex_environment)."""
    sh, p = c.sh, c.program
    vec = enabled_input(node, "Vector")
    coord = c.input(vec, "VECTOR") if live_link(vec) is not None else p.uv(sh.POSITION)
    coord = p.emit(sh.OP_PROJECTION, 3, a=coord, d=sh.PROJECTIONS.index(node.projection))
    reg = p.image(c.texture(node), coord, _unassociates(node))
    return (reg + 3, "VALUE") if out.name == "Alpha" else (reg, "RGBA")


def _n_sky(c, node, out):
    """Sky Texture of type Multiple or Single Scattering (engine/sky.py): the sky texture
    Cycles precomputes for the node, read at the Generated coordinate (in a world, the
    ray's direction), plus the sun's disc; in a world the disc becomes a sun light
    (Program.suns, exporter.sky_suns). Preetham: the analytic sky of its Sun Direction and
    Turbidity. Hosek-Wilkie is refused. Its Vector input is unavailable in Blender 5.0
    (greyed out, not read)."""
    sh, p, sky = c.sh, c.program, core.load().sky
    if node.sky_type == "PREETHAM":
        xyz = p.emit(sh.OP_SKY, 3, a=p.uv(sh.GENERATED), d=2, params=sky.preetham_params(
            node.sun_direction, node.turbidity))
        return p.emit(sh.OP_SKY, 3, a=xyz, b=p.const([0.0, 0.0, 0.0]), d=1,
                      params=xyz_to_scene_linear()), "RGBA"
    if node.sky_type not in sky.MODELS:
        raise Unsupported(f"Sky Texture '{node.name}' of type {node.sky_type} (only "
                          f"Multiple and Single Scattering and Preetham are supported)")
    elevation, rotation = sky.sun_position(node.sun_elevation, node.sun_rotation)
    atmosphere = (float(node.air_density), float(node.aerosol_density),
                  float(node.ozone_density))
    size = max(float(node.sun_size), sky.MIN_SUN_SIZE)
    if c.world and node.sun_disc:
        p.suns.append((node.name, sky.sun_direction(elevation, rotation), size))
    bottom, top = sky.sun_pixels(node.sky_type, elevation, size, node.altitude, *atmosphere)
    params = sky.disc_params(elevation, rotation, size if node.sun_disc else -1.0,
                             float(node.sun_intensity), float(node.altitude), bottom, top)
    key = ("sky", node.sky_type, elevation, float(node.altitude), atmosphere)
    if key not in c.textures:
        xyz = sky.texture(node.sky_type, elevation, node.altitude, *atmosphere)
        texels = np.concatenate([xyz, np.ones(xyz.shape[:2] + (1,))], axis=2)
        c.textures[key] = sh.Texture(f"sky of '{node.name}'", texels, "Linear", "EXTEND")
    lookup = p.emit(sh.OP_SKY, 6, a=p.uv(sh.GENERATED), d=0, params=params)
    xyz = p.image(c.textures[key], lookup, False)
    return p.emit(sh.OP_SKY, 3, a=xyz, b=lookup + 3, d=1,
                  params=xyz_to_scene_linear()), "RGBA"


def world_to_object(matrix_world) -> np.ndarray:
    """An object's world-to-object matrix (4, 4), or those of a stack (k, 4, 4): the
    pseudo-inverse, so that a flattened object's zero axis stays zero rather than NaN."""
    return np.linalg.pinv(np.asarray(matrix_world, np.float64))


def _n_tex_coord(c, node, out):
    """Texture Coordinate: UV, Generated, Object (of the shaded object, or of the node's
    own object: the world position in that object's space, Cycles' NODE_TEXCO_OBJECT with
    its inverse transform), Normal, Camera, Window and Reflection (svm_node_tex_coord)."""
    sh, p = c.sh, c.program
    name = out.name
    if node.from_instancer:
        raise Unsupported(f"texture coordinate '{node.name}' output {name} from the instancer")
    if c.world and name in ("UV", "Camera", "Window", "Reflection"):
        raise Unsupported(f"texture coordinate '{node.name}' output {name} in a world")
    if name == "Object" and node.object is not None:
        rows = world_to_object(node.object.matrix_world)[:3].ravel()
        return p.emit(sh.OP_MAPPING, 3, a=p.uv(sh.POSITION), params=rows), "VECTOR"
    if name in ("Normal", "Reflection") and not c.view_dependent:
        raise Unsupported(f"texture coordinate '{node.name}' output {name} in an emission")
    maps = {"UV": "", "Generated": sh.GENERATED, "Object": sh.OBJECT, "Camera": sh.CAMERA}
    if name in maps:
        return p.uv(maps[name]), "VECTOR"
    if name == "Normal":
        return p.emit(sh.OP_FACING, 3, a=p.uv(sh.NORMAL)), "VECTOR"
    if name == "Window":
        return p.emit(sh.OP_PROJECT, 3, a=p.uv(sh.WINDOW)), "VECTOR"
    if name == "Reflection":
        return p.emit(sh.OP_REFLECTION, 3), "VECTOR"
    raise Unsupported(f"texture coordinate '{node.name}' output {name}")


def _n_geometry(c, node, out):
    """Geometry: Position (world space), Normal (the shading normal), True Normal (the
    triangle's), Incoming (toward the viewer), Backfacing, Parametric (the barycentric
    weights of the triangle's first two corners), Random Per Island and Pointiness, as
    Cycles' svm_node_geometry reads sd->P, N, Ng, wi (N and Ng facing the viewer's side),
    u and v and the two mesh attributes."""
    sh, p, name = c.sh, c.program, out.name
    if name == "Position":
        return p.uv(sh.POSITION), "VECTOR"
    if name == "Parametric":
        return p.uv(sh.PARAMETRIC), "VECTOR"
    if name == "Random Per Island":
        return p.uv(sh.ISLAND_RANDOM), "VALUE"
    if name == "Pointiness":
        return p.uv(sh.POINTINESS), "VALUE"
    if name == "Tangent":  # Cycles' primitive_tangent: Radial Z of the texture space
        return _tangent(c, node, "Z")
    if name not in ("Normal", "True Normal", "Incoming", "Backfacing"):
        raise Unsupported(f"geometry '{node.name}' output {name}")
    if not c.view_dependent:
        raise Unsupported(f"geometry '{node.name}' output {name} in an emission")
    if name == "True Normal":
        return p.emit(sh.OP_FACING, 3, a=p.uv(sh.TRUE_NORMAL)), "VECTOR"
    if name == "Backfacing":
        return p.emit(sh.OP_GEOMETRY, 1, d=2), "VALUE"
    return p.emit(sh.OP_GEOMETRY, 3, d=0 if name == "Normal" else 1), "VECTOR"


def _tangent(c, node, axis, uv_map=None):
    """The radial tangent about the texture space's `axis`, or the tangent of `uv_map`,
    across the shading normal."""
    if not c.view_dependent:
        raise Unsupported(f"node '{node.name}' tangent in an emission")
    p = c.program
    direction = c.sh.RADIAL + axis if uv_map is None else c.sh.UV_TANGENT + uv_map
    return p.emit(c.sh.OP_GEOMETRY, 3, a=p.uv(direction), d=3), "VECTOR"


def _n_tangent(c, node, out):
    """Tangent: Radial about X, Y or Z, or a UV map's tangents (Cycles' svm_node_tangent)."""
    if node.direction_type == "UV_MAP":
        return _tangent(c, node, None, node.uv_map)
    return _tangent(c, node, node.axis)


def _n_object_info(c, node, out):
    """Object Info: the shaded object's Location, Color, Alpha, Random and Object Index
    (its pass index), from the maps the exporter fills per instance, and the material's
    Material Index (its pass index, MATERIAL_PASS_INDEX)."""
    sh, p, name = c.sh, c.program, out.name
    if name == "Material Index":
        return p.const([float(MATERIAL_PASS_INDEX.get())]), "VALUE"
    if name == "Location":
        return p.uv(sh.OBJECT_LOCATION), "VECTOR"
    if name == "Color":
        return p.uv(sh.OBJECT_COLOUR), "RGBA"
    numbers = ("Alpha", "Random", "Object Index")
    if name not in numbers:
        raise Unsupported(f"object info '{node.name}' output {name}")
    return p.uv(sh.OBJECT_NUMBERS) + numbers.index(name), "VALUE"


def _n_color_attribute(c, node, out):
    """Color Attribute: its Color, or its Alpha (the first channel of the alpha map)."""
    if out.name == "Alpha":
        return c.program.uv(c.sh.COLOUR_ALPHA + node.layer_name), "VALUE"
    if out.name != "Color":
        raise Unsupported(f"color attribute '{node.name}' output {out.name}")
    return c.program.uv(c.sh.COLOUR_ATTRIBUTE + node.layer_name), "RGBA"


def attribute_channels(raw, scalars=False) -> np.ndarray:
    """(n, 3) float32 of n values of 1-4 components (n, width) as the Attribute node's
    outputs read them (Cycles' svm_node_attr_store by the attribute's type): its vector (a
    scalar repeated, a 2D value with z = 0, the first three components), or with `scalars`
    (Fac, Alpha, 0): Fac a scalar, a 2D value's x or the mean of three components; Alpha
    the fourth component, else 1."""
    raw = np.asarray(raw, np.float32)
    width = raw.shape[1]
    out = np.zeros((len(raw), 3), np.float32)
    if scalars:
        out[:, 0] = raw[:, 0] if width <= 2 else raw[:, :3].mean(axis=1)
        out[:, 1] = raw[:, 3] if width == 4 else 1.0
    else:
        out[:, :min(width, 3)] = raw[:, :3]
        if width == 1:
            out[:, 1:] = raw
    return out


def id_property(owners, name):
    """The values (a tuple of 1-4 floats) of the property `name` an Attribute node of type
    Object or View Layer reads: on each of `owners` in turn (an object, then its data; the
    view layer, then the scene, then the world), a custom property, else an RNA path, as the
    Blender manual describes Cycles' lookup (measured against Cycles renders: a custom
    property on the object beats its mesh's, the view layer's the scene's, the scene's the
    world's). An integer, float or boolean, or an array of 1-4 of them; None otherwise (a
    string, five components, nothing of that name)."""
    for owner in owners:
        if owner is None:
            continue
        value = owner.get(name) if hasattr(owner, "get") else None
        if value is None:
            try:
                value = owner.path_resolve(name)
            except (ValueError, TypeError):
                value = None
        if value is None:
            continue
        if isinstance(value, (bool, int, float)):
            return (float(value),)
        try:
            values = tuple(float(v) for v in value)
        except (TypeError, ValueError):
            return None
        return values if 1 <= len(values) <= 4 else None
    return None


def view_layer_attribute(node, out):
    """An Attribute node of type View Layer: a constant of the render (RENDER_LAYER), its
    output `out` as the Geometry type reads a value of that width (0, Alpha included, for a
    property that is not there); a float, or (r, g, b) for Color and Vector."""
    values = id_property(RENDER_LAYER.get(), node.attribute_name)
    if values is None:
        return (0.0, 0.0, 0.0) if out.identifier in ("Color", "Vector") else 0.0
    if out.identifier in ("Color", "Vector"):
        return tuple(float(v) for v in attribute_channels([values])[0])
    return float(attribute_channels([values], True)[0, 1 if out.identifier == "Alpha" else 0])


def _n_attribute(c, node, out):
    """Attribute of type Geometry: the mesh's attribute of that name (generic, colour or a
    UV map) on points, corners or faces; of type Object: the shaded object's property of
    that name (filled per instance by the exporter); of type View Layer: a constant (see
    view_layer_attribute). Each output as Cycles reads the attribute's type."""
    sh, name = c.sh, node.attribute_name
    if node.attribute_type == "VIEW_LAYER":
        value = view_layer_attribute(node, out)
        if isinstance(value, tuple):
            return c.program.const(list(value)), "RGBA" if out.identifier == "Color" \
                else "VECTOR"
        return c.program.const([value]), "VALUE"
    if node.attribute_type == "GEOMETRY":
        vector, scalars = sh.ATTRIBUTE, sh.ATTRIBUTE_SCALARS
    elif node.attribute_type == "OBJECT":
        vector, scalars = sh.OBJECT_ATTRIBUTE, sh.OBJECT_ATTRIBUTE_SCALARS
    else:
        raise Unsupported(f"attribute '{node.name}' of type {node.attribute_type}")
    if out.identifier in ("Color", "Vector"):
        return c.program.uv(vector + name), "RGBA" if out.identifier == "Color" \
            else "VECTOR"
    reg = c.program.uv(scalars + name)
    return (reg + 1 if out.identifier == "Alpha" else reg), "VALUE"


def _n_uv_map(c, node, out):
    if node.from_instancer:
        raise Unsupported(f"UV map '{node.name}' from the instancer")
    return c.program.uv(node.uv_map), "VECTOR"


def _n_mapping(c, node, out):
    """Mapping: every type, every input linkable (Location is unused by Vector and Normal,
    as in Cycles)."""
    kind = node.vector_type
    if kind not in c.sh.MAPPINGS:
        raise Unsupported(f"mapping '{node.name}' type {kind}")
    vec, loc, rot, scale = (c.input(enabled_input(node, name), "VECTOR")
                            if enabled_input(node, name) is not None
                            else c.program.const([0.0, 0.0, 0.0])
                            for name in ("Vector", "Location", "Rotation", "Scale"))
    return c.program.emit(c.sh.OP_VECTOR_MAPPING, 3, a=vec, b=loc, c=rot, d=scale,
                          e=c.sh.MAPPINGS.index(kind)), "VECTOR"


def _n_value(c, node, out):
    v = node.outputs[0].default_value
    values = [float(x) for x in v[:3]] if WIDTHS.get(out.type) == 3 else [float(v)]
    return c.program.const(values), out.type


def _n_reroute(c, node, out):
    return c.input(node.inputs[0], out.type), out.type


def _n_mix(c, node, out):
    sh = c.sh
    data = node.data_type
    if data == "RGBA":
        return _blend(c, node, enabled_input(node, "Factor_Float"), "A_Color", "B_Color",
                      node.blend_type, node.clamp_factor, node.clamp_result)
    if data not in ("FLOAT", "VECTOR"):
        raise Unsupported(f"mix '{node.name}' of {data}")
    width = 1 if data == "FLOAT" else 3
    per_axis = data == "VECTOR" and node.factor_mode == "NON_UNIFORM"
    fac_socket = enabled_input(node, "Factor_Vector" if per_axis else "Factor_Float")
    fac = c.input(fac_socket, "VECTOR" if per_axis else "VALUE")
    if node.clamp_factor:
        fac = _clamped(c, fac, 3 if per_axis else 1)
    a = c.input(enabled_input(node, f"A_{'Float' if width == 1 else 'Vector'}"), data)
    b = c.input(enabled_input(node, f"B_{'Float' if width == 1 else 'Vector'}"), data)
    return c.program.emit(sh.OP_LERP, width, a=fac, b=a, c=b, d=width, e=int(per_axis)), data


def _n_mix_rgb(c, node, out):
    return _blend(c, node, node.inputs[0], node.inputs[1].identifier,
                  node.inputs[2].identifier, node.blend_type, True, node.use_clamp)


def _blend(c, node, fac_socket, a_name, b_name, blend_type, clamp_factor, clamp_result):
    if blend_type not in c.sh.BLENDS:
        raise Unsupported(f"mix '{node.name}' blend {blend_type}")
    fac = c.input(fac_socket, "VALUE")
    if clamp_factor:
        fac = _clamped(c, fac, 1)
    a = c.input(enabled_input(node, a_name), "RGBA")
    b = c.input(enabled_input(node, b_name), "RGBA")
    return c.program.emit(c.sh.OP_BLEND, 3, a=fac, b=a, c=b, d=c.sh.BLENDS.index(blend_type),
                          e=int(clamp_result)), "RGBA"


def _clamped(c, reg, width):
    """reg's `width` values clamped to [0, 1] (Math Add 0 with its clamp)."""
    zero = c.program.const([0.0])
    regs = [c.program.emit(c.sh.OP_MATH, 1, a=reg + j, b=zero, c=zero, d=0, e=1)
            for j in range(width)]
    if width == 1:
        return regs[0]
    return c.program.emit(c.sh.OP_COMBINE, 3, a=regs[0], b=regs[1], c=regs[2])


def _n_math(c, node, out):
    if node.operation not in c.sh.MATHS:
        raise Unsupported(f"math '{node.name}' operation {node.operation}")
    args = [c.input(s, "VALUE") for s in node.inputs if s.enabled]
    zero = None
    while len(args) < 3:
        zero = zero if zero is not None else c.program.const([0.0])
        args.append(zero)
    return c.program.emit(c.sh.OP_MATH, 1, a=args[0], b=args[1], c=args[2],
                          d=c.sh.MATHS.index(node.operation), e=int(node.use_clamp)), "VALUE"


def _n_separate(c, node, out):
    """Separate XYZ / Color (RGB, HSV, HSL): register addressing, after a conversion."""
    kind = "VECTOR" if node.bl_idname == "ShaderNodeSeparateXYZ" else "RGBA"
    reg = c.input(node.inputs[0], kind)
    mode = getattr(node, "mode", "RGB")
    if mode != "RGB":
        reg = c.program.emit(c.sh.OP_COLOUR_SPACE, 3, a=reg,
                             d=c.sh.CONVERSIONS.index(f"RGB_TO_{mode}"))
    index = [s.identifier for s in node.outputs].index(out.identifier)
    return reg + index, "VALUE"


def _n_combine(c, node, out):
    """Combine XYZ / Color (RGB, HSV, HSL)."""
    a, b, d = (c.input(s, "VALUE") for s in node.inputs[:3])
    reg = c.program.emit(c.sh.OP_COMBINE, 3, a=a, b=b, c=d)
    mode = getattr(node, "mode", "RGB")
    if mode != "RGB":
        reg = c.program.emit(c.sh.OP_COLOUR_SPACE, 3, a=reg,
                             d=c.sh.CONVERSIONS.index(f"{mode}_TO_RGB"))
    return reg, out.type


def _n_invert(c, node, out):
    fac, col = c.input(node.inputs[0], "VALUE"), c.input(node.inputs[1], "RGBA")
    return c.program.emit(c.sh.OP_INVERT, 3, a=fac, b=col), "RGBA"


def _n_gamma(c, node, out):
    col, g = c.input(node.inputs[0], "RGBA"), c.input(node.inputs[1], "VALUE")
    return c.program.emit(c.sh.OP_GAMMA, 3, a=col, b=g), "RGBA"


def _n_bright_contrast(c, node, out):
    col, bright, contrast = (c.input(s, t) for s, t in zip(node.inputs[:3],
                                                           ("RGBA", "VALUE", "VALUE")))
    return c.program.emit(c.sh.OP_BRIGHT_CONTRAST, 3, a=col, b=bright, c=contrast), "RGBA"


def _n_checker(c, node, out):
    vec = enabled_input(node, "Vector")
    # Unlinked, a procedural texture reads Generated coordinates (Cycles' default).
    co = c.input(vec, "VECTOR") if live_link(vec) is not None else c.program.uv(c.sh.GENERATED)
    c1, c2 = c.input(node.inputs["Color1"], "RGBA"), c.input(node.inputs["Color2"], "RGBA")
    scale = c.input(node.inputs["Scale"], "VALUE")
    reg = c.program.emit(c.sh.OP_CHECKER, 4, a=co, b=c1, c=c2, d=scale)
    return (reg + 3, "VALUE") if out.identifier == "Fac" else (reg, "RGBA")


def _texture_vector(c, node):
    """A procedural texture's Vector: its link, or unlinked the Generated coordinates
    (Cycles' default)."""
    vec = enabled_input(node, "Vector")
    if vec is not None and live_link(vec) is not None:
        return c.input(vec, "VECTOR")
    return c.program.uv(c.sh.GENERATED)


def _n_noise(c, node, out):
    """Noise Texture: every dimension and fractal type, Distortion and Normalize."""
    nz = core.load().noise
    d = int(node.noise_dimensions[0])
    co = _texture_vector(c, node) if d > 1 else c.program.const([0.0, 0.0, 0.0])
    w = enabled_input(node, "W")
    w = c.input(w, "VALUE") if w is not None else c.program.const([0.0])
    # (Offset and Gain are unavailable to some fractal types: found by iterating.)
    inputs = [c.input(enabled_input(node, name), "VALUE") for name in (
        "Scale", "Detail", "Roughness", "Lacunarity", "Offset", "Gain", "Distortion")]
    kind = nz.NOISE_TYPES.index(getattr(node, "noise_type", "FBM"))
    colour = out.identifier == "Color"
    reg = c.program.emit(c.sh.OP_NOISE, 4, a=co, b=w, c=int(colour), params=[
        *inputs, d, kind, int(getattr(node, "normalize", True))])
    return (reg, "RGBA") if colour else (reg + 3, "VALUE")


def _n_gradient(c, node, out):
    kind = core.load().noise.GRADIENT_TYPES.index(node.gradient_type)
    reg = c.program.emit(c.sh.OP_GRADIENT, 4, a=_texture_vector(c, node), d=kind)
    return (reg, "RGBA") if out.identifier == "Color" else (reg + 3, "VALUE")


def _n_wave(c, node, out):
    """Wave Texture: bands and rings in every direction, every profile, distortion."""
    nz = core.load().noise
    inputs = [c.input(enabled_input(node, name), "VALUE") for name in (
        "Scale", "Distortion", "Detail", "Detail Scale", "Detail Roughness", "Phase Offset")]
    reg = c.program.emit(c.sh.OP_WAVE, 4, a=_texture_vector(c, node), params=[
        *inputs, nz.WAVE_TYPES.index(node.wave_type), nz.WAVE_BANDS.index(node.bands_direction),
        nz.WAVE_RINGS.index(node.rings_direction), nz.WAVE_PROFILES.index(node.wave_profile)])
    return (reg, "RGBA") if out.identifier == "Color" else (reg + 3, "VALUE")


def _n_magic(c, node, out):
    reg = c.program.emit(c.sh.OP_MAGIC, 4, a=_texture_vector(c, node),
                         b=c.input(enabled_input(node, "Scale"), "VALUE"),
                         c=c.input(enabled_input(node, "Distortion"), "VALUE"),
                         d=int(node.turbulence_depth))
    return (reg, "RGBA") if out.identifier == "Color" else (reg + 3, "VALUE")


def _n_white_noise(c, node, out):
    """White Noise Texture: every dimension. Its Vector unlinked is the socket's own value
    (Cycles gives this node no default coordinates)."""
    d = int(node.noise_dimensions[0])
    w = enabled_input(node, "W")
    w = c.input(w, "VALUE") if w is not None else c.program.const([0.0])
    reg = c.program.emit(c.sh.OP_WHITE_NOISE, 4, a=c.input(enabled_input(node, "Vector"),
                                                          "VECTOR"), b=w, d=d)
    return (reg, "RGBA") if out.identifier == "Color" else (reg + 3, "VALUE")


def _n_voronoi(c, node, out):
    """Voronoi Texture: every dimension, feature and distance metric, fractal octaves and
    Normalize; all five outputs."""
    vo = core.load().voronoi
    d = int(node.voronoi_dimensions[0])
    co = _texture_vector(c, node) if d > 1 else c.program.const([0.0, 0.0, 0.0])
    w = enabled_input(node, "W")
    w = c.input(w, "VALUE") if w is not None else c.program.const([0.0])
    # (Inputs a feature does not use are absent or disabled: those read as 0.)
    inputs = [c.input(s, "VALUE") if s is not None else c.program.const([0.0])
              for s in (enabled_input(node, name) for name in (
                  "Scale", "Detail", "Roughness", "Lacunarity", "Smoothness", "Exponent",
                  "Randomness"))]
    reg = c.program.emit(c.sh.OP_VORONOI, 9, a=co, b=w, params=[
        *inputs, d, vo.FEATURES.index(node.feature), vo.METRICS.index(node.distance),
        int(node.normalize)])
    at, kind = {"Color": (0, "RGBA"), "Distance": (3, "VALUE"), "Position": (4, "VECTOR"),
                "W": (7, "VALUE"), "Radius": (8, "VALUE")}[out.identifier]
    return reg + at, kind


def _n_brick(c, node, out):
    """Brick Texture: every input linkable; Offset, Squash and their frequencies."""
    colours = [c.input(node.inputs[n], "RGBA") for n in ("Color1", "Color2", "Mortar")]
    values = [c.input(node.inputs[n], "VALUE") for n in (
        "Scale", "Mortar Size", "Mortar Smooth", "Bias", "Brick Width", "Row Height")]
    reg = c.program.emit(c.sh.OP_BRICK, 4, _texture_vector(c, node), *colours, params=[
        *values, node.offset, node.offset_frequency, node.squash, node.squash_frequency])
    return (reg, "RGBA") if out.identifier == "Color" else (reg + 3, "VALUE")


def _n_vector_rotate(c, node, out):
    """Vector Rotate: every type, inverted or not."""
    sh = c.sh
    vec, centre, axis = (c.input(enabled_input(node, n), "VECTOR")
                         for n in ("Vector", "Center", "Axis"))
    angle = c.input(enabled_input(node, "Angle"), "VALUE")
    rotation = c.input(enabled_input(node, "Rotation"), "VECTOR")
    return c.program.emit(sh.OP_VECTOR_ROTATE, 3, a=vec, b=centre, c=axis,
                          d=sh.ROTATIONS.index(node.rotation_type), e=angle,
                          params=[int(node.invert), rotation]), "VECTOR"


def _n_blackbody(c, node, out):
    """Blackbody: Cycles' fit of a black body's colour (in Rec.709, the scene's linear
    space here)."""
    return c.program.emit(c.sh.OP_BLACKBODY, 3, a=c.input(node.inputs["Temperature"],
                                                           "VALUE")), "RGBA"


def xyz_to_scene_linear() -> list:
    """Cycles' XYZ to scene-linear matrix for this Blender's colour configuration
    (row-major): Blender's own XYZ (D65) to scene-linear conversion, which Cycles 5's
    Wavelength colours match to 1e-5 (an ACES route through Cycles' older xyz_E_to_aces
    matrix was 8 % off in blue)."""
    columns = [mathutils.Color(e).from_xyz_d65_to_scene_linear() for e in np.eye(3)]
    return list(np.array([list(c) for c in columns]).T.ravel())


def _n_wavelength(c, node, out):
    """Wavelength: the CIE colour-matching functions in the scene's linear RGB, as Cycles."""
    return c.program.emit(c.sh.OP_WAVELENGTH, 3, a=c.input(node.inputs["Wavelength"],
                                                            "VALUE"),
                          params=xyz_to_scene_linear()), "RGBA"


def _n_normal(c, node, out):
    """Normal: its Normal output is its own direction, normalised; Dot that direction
    dotted with its input, normalised (Vector Math's safe normalise: 0 stays 0)."""
    sh = c.sh
    direction = np.array(node.outputs["Normal"].default_value, float)
    length = np.linalg.norm(direction)
    direction = c.program.const(list(direction / length if length > 0 else direction))
    if out.identifier == "Normal":
        return direction, "VECTOR"
    unit = c.program.emit(sh.OP_VECTOR_MATH, 4, a=c.input(node.inputs["Normal"], "VECTOR"),
                          b=direction, c=direction, d=sh.VECTOR_MATHS.index("NORMALIZE"),
                          e=c.program.const([1.0]))
    reg = c.program.emit(sh.OP_VECTOR_MATH, 4, a=unit, b=direction, c=direction,
                         d=sh.VECTOR_MATHS.index("DOT_PRODUCT"), e=c.program.const([1.0]))
    return reg + 3, "VALUE"


def _n_rgb_to_bw(c, node, out):
    """RGB to BW: the colour's luminance (Cycles' linear_rgb_to_gray)."""
    return c.convert(c.input(node.inputs["Color"], "RGBA"), "RGBA", "VALUE"), "VALUE"


def _n_color_ramp(c, node, out):
    """Color Ramp as Cycles bakes it: a table of RAMP_TABLE_SIZE entries from Blender's own
    ramp evaluation, looked up (linearly unless Constant) at the factor."""
    ramp = node.color_ramp
    n = c.sh.RAMP_TABLE_SIZE
    table = [x for i in range(n) for x in ramp.evaluate(i / (n - 1))]
    fac = c.input(node.inputs["Fac"], "VALUE")
    reg = c.program.emit(c.sh.OP_RAMP, 4, a=fac, b=n, c=int(ramp.interpolation != "CONSTANT"),
                         params=table)
    return (reg + 3, "VALUE") if out.name == "Alpha" else (reg, "RGBA")


def _n_map_range(c, node, out):
    """Map Range: float and vector, every interpolation type, Clamp."""
    vector = node.data_type == "FLOAT_VECTOR"
    if node.data_type not in ("FLOAT", "FLOAT_VECTOR"):
        raise Unsupported(f"map range '{node.name}' of {node.data_type}")
    kind, width = ("VECTOR", 3) if vector else ("VALUE", 1)
    suffix = "_FLOAT3" if vector else ""
    names = ["Vector" if vector else "Value"] + [
        n.replace(" ", "_") + suffix if vector else n
        for n in ("From Min", "From Max", "To Min", "To Max", "Steps")]
    sockets = {s.identifier: s for s in node.inputs}
    regs = [c.input(sockets[n], kind) for n in names]
    reg = c.program.emit(c.sh.OP_MAP_RANGE, width, *regs[:5], params=[
        regs[5], c.sh.MAP_RANGES.index(node.interpolation_type), int(node.clamp), width])
    return reg, kind


def _n_clamp(c, node, out):
    value, lo, hi = (c.input(node.inputs[n], "VALUE") for n in ("Value", "Min", "Max"))
    return c.program.emit(c.sh.OP_CLAMP, 1, a=value, b=lo, c=hi,
                          d=int(node.clamp_type == "RANGE")), "VALUE"


def _n_curves(c, node, out):
    """RGB Curves, Vector Curves and Float Curve as Cycles bakes them (its
    curvemapping_color_to_array / float_to_array): a table of RAMP_TABLE_SIZE + 1 entries
    over the range from the curves' first to last points (RGB: each channel's curve after
    the combined one), from Blender's own curve evaluation."""
    mapping = node.mapping
    mapping.update()
    rgb, single = node.bl_idname == "ShaderNodeRGBCurve", node.bl_idname == "ShaderNodeFloatCurve"
    curves = list(mapping.curves)[:1 if single else (4 if rgb else 3)]
    lo = min(cm.points[0].location[0] for cm in curves)
    hi = max(cm.points[-1].location[0] for cm in curves)
    n = c.sh.RAMP_TABLE_SIZE
    table = []
    for i in range(n + 1):
        t = lo + i / n * (hi - lo)
        if rgb:
            t = mapping.evaluate(curves[3], t)
        values = [mapping.evaluate(curves[0 if single else j], t) for j in range(3)]
        table.extend(values + [1.0])
    kind = "VALUE" if single else ("RGBA" if rgb else "VECTOR")
    width = 1 if single else 3
    value = c.input(enabled_input(node, "Value" if single else ("Color" if rgb else "Vector")),
                    kind)
    fac = c.input(node.inputs[0], "VALUE")
    return c.program.emit(c.sh.OP_CURVES, width, a=value, b=fac, c=n + 1,
                          d=int(mapping.extend == "EXTRAPOLATED"), e=width,
                          params=[lo, hi] + table), kind


def _n_hue_saturation(c, node, out):
    hue, sat, val, fac = (c.input(node.inputs[n], "VALUE")
                          for n in ("Hue", "Saturation", "Value", "Fac"))
    col = c.input(node.inputs["Color"], "RGBA")
    return c.program.emit(c.sh.OP_HSV, 3, a=col, b=hue, c=sat, d=val, e=fac), "RGBA"


def _n_vector_math(c, node, out):
    if node.operation not in c.sh.VECTOR_MATHS:
        raise Unsupported(f"vector math '{node.name}' operation {node.operation}")
    a, b, d = (c.input(s, "VECTOR") for s in node.inputs[:3])
    scale = c.input(node.inputs[3], "VALUE")
    reg = c.program.emit(c.sh.OP_VECTOR_MATH, 4, a=a, b=b, c=d,
                         d=c.sh.VECTOR_MATHS.index(node.operation), e=scale)
    return (reg + 3, "VALUE") if out.name == "Value" else (reg, "VECTOR")


def _n_vector_transform(c, node, out):
    """Vector Transform between World, Object and Camera space, step by step as Cycles'
    svm_node_vector_transform: a Point moves with the frame's origin, a Vector does not,
    and a Normal goes through the transposed inverse and is normalised after each step."""
    kind, source, target = node.vector_type, node.convert_from, node.convert_to
    v = c.input(node.inputs["Vector"], "VECTOR")
    if source == target:
        return v, "VECTOR"
    if source == "CAMERA":  # to world first
        v = _through(c, v, kind, c.sh.CAMERA_AXES, c.sh.CAMERA_ORIGIN, into=False)
    elif source == "OBJECT":
        v = (_through(c, v, kind, c.sh.OBJECT_INVERSE, None, into=True) if kind == "NORMAL"
             else _through(c, v, kind, c.sh.OBJECT_AXES, c.sh.OBJECT_LOCATION, into=False))
    if target == "CAMERA":
        return _through(c, v, kind, c.sh.CAMERA_AXES, c.sh.CAMERA_ORIGIN, into=True), "VECTOR"
    if target == "OBJECT":
        v = (_through(c, v, kind, c.sh.OBJECT_AXES, None, into=True) if kind == "NORMAL"
             else _through(c, v, kind, c.sh.OBJECT_INVERSE, c.sh.OBJECT_INVERSE_ORIGIN,
                           into=False))
    return v, "VECTOR"


def _through(c, v, kind, axes, origin, into):
    """One OP_TRANSFORM step of vector register v: with the frame of the maps `axes`, the
    components along them (`into`) or the sum of them it weights; a Point with `origin`
    (a map) taken off before, or added after; a Normal normalised."""
    p = c.program
    first = p.uv(axes[0])
    for axis in axes[1:]:  # OP_TRANSFORM reads the three as consecutive registers
        p.uv(axis)
    o = p.uv(origin) if kind == "POINT" and origin is not None else -1
    return p.emit(c.sh.OP_TRANSFORM, 3, a=v, b=first, c=o, d=int(into),
                  e=int(kind == "NORMAL"))


def _n_displacement(c, node, out):
    """Displacement (Cycles' svm_node_displacement): the normal (its Normal input, or the
    shading normal) times (Height - Midlevel) x Scale, in World space as it is; in Object
    space the normal is taken into the object's frame (M^T n, normalised), scaled there
    and carried back as a direction (M v), so the object's scale stretches it."""
    sh, p = c.sh, c.program
    maths = sh.MATHS
    height = p.emit(sh.OP_MATH, 1, a=c.input(node.inputs["Height"], "VALUE"),
                    b=c.input(node.inputs["Midlevel"], "VALUE"), c=p.const([0.0]),
                    d=maths.index("SUBTRACT"))
    scale = c.input(node.inputs["Scale"], "VALUE")
    height = p.emit(sh.OP_MATH, 1, a=height, b=scale, c=scale, d=maths.index("MULTIPLY"))
    normal = node.inputs["Normal"]
    if live_link(normal) is not None:
        n = c.input(normal, "VECTOR")
    elif c.view_dependent:
        n = p.emit(sh.OP_GEOMETRY, 3, d=0)
    else:
        raise Unsupported(f"displacement '{node.name}' along the normal in an emission")
    if node.space == "OBJECT":  # (normalised there, as object_inverse_normal_transform)
        n = _through(c, n, "NORMAL", sh.OBJECT_AXES, None, into=True)
    v = p.emit(sh.OP_VECTOR_MATH, 4, a=n, b=n, c=n, d=sh.VECTOR_MATHS.index("SCALE"),
               e=height)
    if node.space == "OBJECT":
        v = _through(c, v, "VECTOR", sh.OBJECT_AXES, None, into=False)
    return v, "VECTOR"


def _n_wireframe(c, node, out):
    """Wireframe at a world-space Size (Cycles' wireframe, on the triangles as rendered);
    Pixel Size needs the ray's footprint, which Specula does not carry."""
    if node.use_pixel_size:
        raise Unsupported(f"wireframe '{node.name}' in pixel size")
    p = c.program
    size = c.input(node.inputs["Size"], "VALUE")
    return p.emit(c.sh.OP_WIREFRAME, 1, a=p.map_index(c.sh.POSITION), b=size), "VALUE"


def _n_light_path(c, node, out):
    """Light Path: the state of the path being shaded (shading.set_light_path), as Cycles'
    svm_node_light_path reads it; Portal Depth is 0 (Specula has no light portals)."""
    sh = c.sh
    if out.name == "Portal Depth":
        return c.program.const([0.0]), "VALUE"
    if out.name not in sh.LIGHT_PATH_OUTPUTS:
        raise Unsupported(f"light path '{node.name}' output {out.name}")
    if c.world and sh.LIGHT_PATH_OUTPUTS.index(out.name) >= sh.RAY_FLAG_COUNT:
        raise Unsupported(f"light path '{node.name}' output {out.name} in a world (its maps "
                          f"tell kinds of ray apart, not lengths or depths)")
    return c.program.emit(sh.OP_LIGHT_PATH, 1,
                          d=sh.LIGHT_PATH_OUTPUTS.index(out.name)), "VALUE"


def _n_light_falloff(c, node, out):
    """Light Falloff: Strength times the ray's length to the power 0 (Quadratic), 1
    (Linear) or 2 (Constant), then times L^2 / (Smooth + L^2) where Smooth > 0, as
    Cycles' svm_node_light_falloff; L is the Light Path's Ray Length (for a light sample,
    the distance to the light point)."""
    sh, p = c.sh, c.program
    strength = c.input(node.inputs["Strength"], "VALUE")
    smooth = c.input(node.inputs["Smooth"], "VALUE")
    length = p.emit(sh.OP_LIGHT_PATH, 1, d=sh.LIGHT_PATH_OUTPUTS.index("Ray Length"))

    def maths(op, a, b, third=None):
        return p.emit(sh.OP_MATH, 1, a=a, b=b, c=b if third is None else third,
                      d=sh.MATHS.index(op))
    squared = maths("MULTIPLY", length, length)
    power = {"Quadratic": None, "Linear": length, "Constant": squared}[out.name]
    if power is not None:
        strength = maths("MULTIPLY", strength, power)
    if live_link(node.inputs["Smooth"]) is None and node.inputs["Smooth"].default_value <= 0:
        return strength, "VALUE"  # (the common case: no smoothing to run at every hit)
    zero, one = p.const([0.0]), p.const([1.0])
    smoothed = maths("DIVIDE", squared, maths("ADD", smooth, squared))  # (safe: 0 over 0 is 0)
    on = maths("GREATER_THAN", smooth, zero)  # only a positive Smooth applies
    factor = maths("MULTIPLY_ADD", maths("SUBTRACT", smoothed, one), on, one)
    return maths("MULTIPLY", strength, factor), "VALUE"


def _n_camera_data(c, node, out):
    """Camera Data: the shading point in the camera's space (Texture Coordinate's Camera:
    x right, y up, z along the view), as Cycles' svm_node_camera reads it: its direction
    (View Vector), its z (View Z Depth) and its length (View Distance)."""
    sh, p = c.sh, c.program
    if c.world:
        raise Unsupported(f"camera data '{node.name}' in a world")
    local = p.uv(sh.CAMERA)
    if out.name == "View Z Depth":
        return local + 2, "VALUE"
    op = "LENGTH" if out.name == "View Distance" else "NORMALIZE"
    reg = p.emit(sh.OP_VECTOR_MATH, 4, a=local, b=local, c=local, d=sh.VECTOR_MATHS.index(op),
                 e=p.const([1.0]))
    return (reg + 3, "VALUE") if op == "LENGTH" else (reg, "VECTOR")


def _normal(c, node):
    """The register of a Fresnel or Layer Weight node's Normal, -1 for the hit's own."""
    sock = node.inputs["Normal"]
    return c.input(sock, "VECTOR") if live_link(sock) is not None else -1


def _n_fresnel(c, node, out):
    return c.program.emit(c.sh.OP_FRESNEL, 1, a=c.input(node.inputs["IOR"], "VALUE"),
                          b=_normal(c, node)), "VALUE"


def _n_layer_weight(c, node, out):
    reg = c.program.emit(c.sh.OP_LAYER_WEIGHT, 2, a=c.input(node.inputs["Blend"], "VALUE"),
                         b=_normal(c, node))
    return (reg + 1 if out.name == "Facing" else reg), "VALUE"


NODES = {
    "ShaderNodeTexImage": _n_image,
    "ShaderNodeTexEnvironment": _n_environment,
    "ShaderNodeTexSky": _n_sky,
    "ShaderNodeTexCoord": _n_tex_coord,
    "ShaderNodeUVMap": _n_uv_map,
    "ShaderNodeVertexColor": _n_color_attribute,
    "ShaderNodeMapping": _n_mapping,
    "ShaderNodeRGB": _n_value,
    "ShaderNodeValue": _n_value,
    "NodeReroute": _n_reroute,
    "ShaderNodeMix": _n_mix,
    "ShaderNodeMixRGB": _n_mix_rgb,
    "ShaderNodeMath": _n_math,
    "ShaderNodeSeparateColor": _n_separate,
    "ShaderNodeSeparateRGB": _n_separate,
    "ShaderNodeSeparateXYZ": _n_separate,
    "ShaderNodeCombineColor": _n_combine,
    "ShaderNodeCombineRGB": _n_combine,
    "ShaderNodeCombineXYZ": _n_combine,
    "ShaderNodeInvert": _n_invert,
    "ShaderNodeGamma": _n_gamma,
    "ShaderNodeBrightContrast": _n_bright_contrast,
    "ShaderNodeTexChecker": _n_checker,
    "ShaderNodeTexNoise": _n_noise,
    "ShaderNodeTexGradient": _n_gradient,
    "ShaderNodeTexWave": _n_wave,
    "ShaderNodeTexMagic": _n_magic,
    "ShaderNodeTexWhiteNoise": _n_white_noise,
    "ShaderNodeTexVoronoi": _n_voronoi,
    "ShaderNodeBlackbody": _n_blackbody,
    "ShaderNodeAttribute": _n_attribute,
    "ShaderNodeWavelength": _n_wavelength,
    "ShaderNodeNormal": _n_normal,
    "ShaderNodeTexBrick": _n_brick,
    "ShaderNodeVectorRotate": _n_vector_rotate,
    "ShaderNodeVectorTransform": _n_vector_transform,
    "ShaderNodeWireframe": _n_wireframe,
    "ShaderNodeDisplacement": _n_displacement,
    "ShaderNodeRGBToBW": _n_rgb_to_bw,
    "ShaderNodeNewGeometry": _n_geometry,
    "ShaderNodeTangent": _n_tangent,
    "ShaderNodeObjectInfo": _n_object_info,
    "ShaderNodeMapRange": _n_map_range,
    "ShaderNodeClamp": _n_clamp,
    "ShaderNodeRGBCurve": _n_curves,
    "ShaderNodeVectorCurve": _n_curves,
    "ShaderNodeFloatCurve": _n_curves,
    "ShaderNodeValToRGB": _n_color_ramp,
    "ShaderNodeHueSaturation": _n_hue_saturation,
    "ShaderNodeVectorMath": _n_vector_math,
    "ShaderNodeFresnel": _n_fresnel,
    "ShaderNodeLayerWeight": _n_layer_weight,
    "ShaderNodeLightPath": _n_light_path,
    "ShaderNodeLightFalloff": _n_light_falloff,
    "ShaderNodeCameraData": _n_camera_data,
}


def scaled(program, strength):
    """`program` with its colour result multiplied by the constant `strength` (an emission's
    colour times its strength: a Multiply blend at factor 1)."""
    sh = core.load().shading
    fac, s = program.const([1.0]), program.const([float(strength)] * 3)
    program.out = program.emit(sh.OP_BLEND, 3, a=fac, b=program.out, c=s,
                               d=sh.BLENDS.index("MULTIPLY"))
    return program


def mixed_by(fac_program, first, second):
    """A program whose result is the constants `first` and `second` (3 values each) mixed
    per point by the first channel of `fac_program`, clamped to [0, 1] as a Mix Shader's
    factor is (two emissions mixed by a varying factor); None where the factor reads the
    hit's view or normal, which an emission cannot (a light sampled from elsewhere has
    neither)."""
    sh = core.load().shading
    viewed = (sh.OP_FRESNEL, sh.OP_LAYER_WEIGHT, *sh.GEOMETRY_OPS)
    if any(ins[0] in viewed for ins in fac_program.code):
        return None
    p = sh.Program(list(fac_program.code), list(fac_program.params),
                   list(fac_program.textures), list(fac_program.uv_maps),
                   fac_program.registers, fac_program.out)
    zero = p.const([0.0])
    fac = p.emit(sh.OP_MATH, 1, a=p.out, b=zero, c=zero, d=sh.MATHS.index("ADD"), e=1)
    p.out = p.emit(sh.OP_LERP, 3, a=fac, b=p.const(first), c=p.const(second), d=3)
    return p


def constant(colour):
    """A program whose result is the constant `colour` (a normal map of one colour)."""
    program = core.load().shading.Program()
    program.out = program.const([float(c) for c in colour])
    return program


def _attempt(build):
    """(build()'s program, "") or, where a node in its chain does not compile or a value
    does not fit, (None, why not)."""
    try:
        return build(), ""
    except Unsupported as exc:
        return None, str(exc)
    except (ValueError, ArithmeticError) as exc:  # a program too large, an odd value
        return None, f"{type(exc).__name__}: {exc}"


def compile_emission(source, texture_cache):
    """(program or None, why not): the emission `source` describes, per point, in one
    program (no view-dependent nodes). A source is the recipe of an emission:
      ("product", colour socket, strength socket): colour x strength (one Emission or a
          Principled BSDF's emission, either varying);
      ("constant", (r, g, b)): an emission that does not vary;
      ("mix", first, second, fac, scale): scale x ((1 - fac) first + fac second), a Mix
          Shader (fac a number or its Fac socket; an Add Shader: fac 0.5, scale 2) over
          two sources;
      ("weighted", source, weight): source x weight, a number or a socket clamped to
          [0, 1] (a Principled BSDF's Alpha weighs its emission)."""
    def build():
        c = Compiler(texture_cache, view_dependent=False)
        c.program.out = _emission_of(c, source)
        return c.program
    return _attempt(build)


def _emission_of(c, source):
    """The register of emission `source` (compile_emission), in compiler c's program."""
    p, kind = c.program, source[0]
    if kind == "constant":
        return p.const([float(x) for x in source[1]])
    if kind == "mix":
        _, first, second, fac, scale = source
        f = p.const([float(fac)]) if isinstance(fac, (int, float)) else \
            _clamped(c, c.input(fac, "VALUE"), 1)  # (a Mix Shader clamps its factor)
        mixed = p.emit(c.sh.OP_LERP, 3, a=f, b=_emission_of(c, first),
                       c=_emission_of(c, second), d=3)
        return _times(c, mixed, p.const([float(scale)] * 3))
    if kind == "weighted":
        _, inner, weight = source
        if isinstance(weight, (int, float)):
            w = p.const([float(weight)] * 3)
        else:  # (clamped, as a Principled BSDF clamps its Alpha)
            w = c.convert(_clamped(c, c.input(weight, "VALUE"), 1), "VALUE", "RGBA")
        return _times(c, _emission_of(c, inner), w)
    _, colour, strength = source  # "product"
    a = c.input(colour, "RGBA")
    b = c.convert(c.input(strength, "VALUE"), "VALUE", "RGBA")  # as compile()
    return _times(c, a, b)


def _times(c, a, b):
    """The register of colour registers a x b (a Multiply blend at factor 1)."""
    return c.program.emit(c.sh.OP_BLEND, 3, a=c.program.const([1.0]), b=a, c=b,
                          d=c.sh.BLENDS.index("MULTIPLY"))


def compile_world(surface, texture_cache):
    """(program or None, why not): the radiance a World Output's Surface input gives each
    direction (engine.environment.bake runs it over the sphere): Background and Emission
    (Color x Strength), Mix Shader (any factor, clamped) and Add Shader of them. A Light
    Path node's Is ... Ray outputs are read (the world is then baked once per kind of ray
    they tell apart, environment.bake_rays); its lengths and depths, and the camera's or a
    UV map's coordinates, have no meaning in maps that serve many rays alike, and are
    refused."""
    def build():
        c = Compiler(texture_cache)
        c.world = True
        c.program.out = _world_radiance(c, surface)
        # (The Camera, Window, Reflection and UV outputs refuse themselves in a world.)
        allowed = core.load().environment.WORLD_MAPS
        for name in c.program.uv_maps:
            if name not in allowed:
                raise Unsupported(f"{c.sh.map_label(name)}, which a world does not have")
        return c.program
    return _attempt(build)


def _world_radiance(c, socket):
    """The register of the radiance behind a world's shader socket (compile_world)."""
    p = c.program
    link = live_link(socket)
    if link is None:
        return p.const([0.0, 0.0, 0.0])  # an unlinked shader is black, in Cycles too
    node = link.from_node
    kind = node.bl_idname
    if kind in ("ShaderNodeBackground", "ShaderNodeEmission"):
        colour = c.input(enabled_input(node, "Color"), "RGBA")
        strength = c.convert(c.input(enabled_input(node, "Strength"), "VALUE"), "VALUE", "RGBA")
        return _times(c, colour, strength)
    shaders = [s for s in node.inputs if s.enabled and s.type == "SHADER"]
    if kind == "ShaderNodeMixShader":
        fac = _clamped(c, c.input(enabled_input(node, "Fac"), "VALUE"), 1)
        return p.emit(c.sh.OP_LERP, 3, a=fac, b=_world_radiance(c, shaders[0]),
                      c=_world_radiance(c, shaders[1]), d=3)
    if kind == "ShaderNodeAddShader":
        return p.emit(c.sh.OP_BLEND, 3, a=p.const([1.0]), b=_world_radiance(c, shaders[0]),
                      c=_world_radiance(c, shaders[1]), d=c.sh.BLENDS.index("ADD"))
    raise Unsupported(f"node '{node.name}' ({node.bl_idname}) in a world")


def compile_bump(node, texture_cache):
    """(program or None, why not): a Bump node's program, whose result is (Distance x
    Height, negated by Invert; Strength) at a point (the kernel differentiates its first
    channel over the surface, shading.bump_normal); (None, "") when its Height does not
    vary (a constant height tilts nothing). A chain through a node without an instruction
    is refused even where it might be constant: a Noise Texture varies."""
    height = enabled_input(node, "Height")
    if height is None or live_link(height) is None:
        return None, ""

    def build():
        c = Compiler(texture_cache)
        p, multiply = c.program, c.sh.MATHS.index("MULTIPLY")
        distance = c.input(enabled_input(node, "Distance"), "VALUE")
        if node.invert:
            negative = p.const([-1.0])
            distance = p.emit(c.sh.OP_MATH, 1, a=distance, b=negative, c=negative, d=multiply)
        dh = p.emit(c.sh.OP_MATH, 1, a=c.input(height, "VALUE"), b=distance, c=distance,
                    d=multiply)
        strength = c.input(enabled_input(node, "Strength"), "VALUE")
        p.out = p.emit(c.sh.OP_COMBINE, 3, a=dh, b=strength, c=strength)
        return p
    program, why = _attempt(build)
    return (program, why) if program is None or varies(height) else (None, "")


def compile_displacement(socket, texture_cache):
    """(program or None, why not): a Material Output's Displacement as Cycles renders it in
    Bump Only (ShaderGraph::bump_from_displacement): a Bump node of Distance 1 and Strength
    1 whose height is the displacement vector's component along the shading normal (the
    same result layout as compile_bump); (None, "") where the displacement does not vary
    (a Displacement node of constant inputs moves every point along its normal alike)."""
    src = live_link(socket).from_node
    inputs = [s for s in src.inputs if s.enabled] \
        if src.bl_idname == "ShaderNodeDisplacement" else [socket]
    if not any(varies(s) for s in inputs):
        return None, ""

    def build():
        c = Compiler(texture_cache)
        p = c.program
        v = c.input(socket, "VECTOR")
        n = p.emit(c.sh.OP_GEOMETRY, 3, d=0)
        dot = p.emit(c.sh.OP_VECTOR_MATH, 4, a=v, b=n, c=n,
                     d=c.sh.VECTOR_MATHS.index("DOT_PRODUCT"), e=p.const([1.0]))
        one = p.const([1.0])
        p.out = p.emit(c.sh.OP_COMBINE, 3, a=dot + 3, b=one, c=one)
        return p
    return _attempt(build)


def compile_pair(first, second, second_default, texture_cache):
    """(program or None, why not): where either of two value inputs varies (sockets; the
    second may be None, then `second_default`), the program of both (its first two
    channels): a GGX node's anisotropy and rotation, a Principled BSDF's IOR and Specular
    IOR Level."""
    if not (varies(first) or (second is not None and varies(second))):
        return None, ""

    def build():
        c = Compiler(texture_cache)
        a = c.input(first, "VALUE")
        b = c.input(second, "VALUE") if second is not None else \
            c.program.const([second_default])
        c.program.out = c.program.emit(c.sh.OP_COMBINE, 3, a=a, b=b, c=b)
        return c.program
    return _attempt(build)


def compile_tangent(socket, texture_cache):
    """(program, why not): a GGX node's Tangent input: its chain's program where linked,
    else Cycles' default, the Geometry node's Tangent (Radial Z); that default too, with
    the reason, where the chain does not compile."""
    default = core.load().shading.radial_tangent("Z")
    if socket is None or live_link(socket) is None:
        return default, ""
    program, why = _attempt(lambda: Compiler(texture_cache).compile(socket, "VECTOR"))
    return program or default, why


def compile_colour(socket, texture_cache, view_dependent=True):
    """(program or None, why not): the program for colour input `socket` when its chain
    varies over the surface and every node in it compiles (with `view_dependent`, nodes
    reading the view too); (None, "") for a chain that does not vary (the constant folding
    handles it exactly)."""
    if not varies(socket):
        return None, ""
    return _attempt(lambda: Compiler(texture_cache, view_dependent).compile(socket, "RGBA"))

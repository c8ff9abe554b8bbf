"""Shader programs: a material input that varies over a surface, evaluated at each hit.

Cycles compiles a material's node tree into a linear program of SVM nodes that its kernel
interprets per shading point (intern/cycles/kernel/svm/). Specula does the same for the
inputs it can vary: a program is a list of instructions over a small file of float
registers, one instruction per node, each a function of its own below; a new node is one
new function and one opcode. A colour occupies three consecutive registers, a vector
three, a float one; Separate XYZ/RGB is register addressing and needs no instruction.

An instruction is a row of int64: (op, out, a, b, c, d, e, p): `out` and `a`..`e` are
register indices or small integer arguments (the opcode says which), `p` an offset into
the program's float parameters. Programs of all materials are packed into one table
(`ProgramTable`), their images into one texel array, so the kernel gets a few arrays.

Images are stored as Cycles stores them: byte images in sRGB keep their encoded values
and are decoded after interpolation (Cycles' NODE_IMAGE_COMPRESS_AS_SRGB), every other
image holds scene-linear values; alpha is associated (premultiplied) unless the image's
alpha is channel-packed or ignored, and an Image node whose Alpha output is used
un-associates its colour again (NODE_IMAGE_ALPHA_UNASSOCIATE).
"""

from __future__ import annotations

import math
from collections import namedtuple
from dataclasses import dataclass, field

import numpy as np

from . import noise, sky, voronoi
from .fresnel import fresnel_dielectric
from .jit import ALLOCATING, INLINE, JIT, njit
from .spectrum import CIE_COLOUR_MATCH

# ------------------------------------------------------------------ opcodes
OP_CONST = 0        # reg[out:out+c] = params[p:p+c]
OP_UV = 1           # reg[out:out+3] = (u, v, 0) of UV map a at the hit, or its Generated or
#                     Object coordinates (the maps named GENERATED, OBJECT)
OP_MAPPING = 2      # reg[out:out+3] = M (params[p:p+12], 3x4 row-major) (reg[a:a+3], 1)
OP_IMAGE = 3        # reg[out:out+3] colour, reg[out+3] alpha of image b at reg[a:a+2];
#                     c: un-associate alpha
OP_BLEND = 4        # colour Mix: reg[out:out+3] = blend d of fac reg[a], reg[b:b+3], reg[c:c+3];
#                     e: clamp the result
OP_LERP = 5         # reg[out:out+d] = lerp(reg[b:], reg[c:], fac reg[a] (e=0) or reg[a:a+d] (e=1))
OP_MATH = 6         # reg[out] = math d (reg[a], reg[b], reg[c]); e: clamp to [0, 1]
OP_LUMINANCE = 7    # reg[out] = Rec.709 luminance of reg[a:a+3] (colour -> float)
OP_AVERAGE = 8      # reg[out] = mean of reg[a:a+3] (vector -> float)
OP_COMBINE = 9      # reg[out:out+3] = (reg[a], reg[b], reg[c]) (also float -> colour)
OP_INVERT = 10      # reg[out:out+3] = lerp(reg[b:b+3], 1 - reg[b:b+3], fac reg[a])
OP_GAMMA = 11       # reg[out:out+3] = reg[a:a+3] ** reg[b] where positive
OP_BRIGHT_CONTRAST = 12  # reg[out:out+3] from colour reg[a:a+3], bright reg[b], contrast reg[c]
OP_CHECKER = 13     # reg[out:out+3] colour, reg[out+3] fac of Cycles' checker at reg[a:a+3],
#                     colours reg[b:b+3], reg[c:c+3], scale reg[d]
OP_RAMP = 14        # reg[out:out+4] RGBA of the ramp table params[p:p+4b] (b entries) at fac
#                     reg[a]; c: interpolate between entries (Color Ramp)
OP_HSV = 15         # reg[out:out+3] Hue/Saturation/Value of colour reg[a:a+3]: hue reg[b],
#                     saturation reg[c], value reg[d], factor reg[e]
OP_VECTOR_MATH = 16  # reg[out:out+3] vector, reg[out+3] value of vector math d on vectors
#                     reg[a:a+3], reg[b:b+3], reg[c:c+3] and scale reg[e]
OP_FRESNEL = 17     # reg[out] = Fresnel node of IOR reg[a], normal reg[b:b+3] (b < 0: the hit's)
OP_LAYER_WEIGHT = 18  # reg[out] Fresnel, reg[out+1] Facing of Layer Weight: blend reg[a],
#                     normal reg[b:b+3] (b < 0: the hit's)
OP_COLOUR_SPACE = 19  # reg[out:out+3] = conversion d (CONVERSIONS) of reg[a:a+3]
OP_NOISE = 20       # reg[out:out+3] Color, reg[out+3] Fac of Cycles' Noise Texture at vector
#                     reg[a:a+3] and W reg[b]; params[p:p+7] the registers of Scale, Detail,
#                     Roughness, Lacunarity, Offset, Gain and Distortion, then its
#                     dimensions, type (noise.NOISE_TYPES) and normalize; c: Color is read
OP_GRADIENT = 21    # reg[out:out+3] Color, reg[out+3] Fac of the Gradient Texture of type d
#                     (noise.GRADIENT_TYPES) at reg[a:a+3]
OP_WAVE = 22        # reg[out:out+3] Color, reg[out+3] Fac of the Wave Texture at reg[a:a+3];
#                     params[p:p+6] the registers of Scale, Distortion, Detail, Detail Scale,
#                     Detail Roughness and Phase Offset, then its type, bands and rings
#                     directions and profile (noise.WAVE_*)
OP_MAGIC = 23       # reg[out:out+3] Color, reg[out+3] Fac of the Magic Texture at reg[a:a+3],
#                     scale reg[b], distortion reg[c], depth d
OP_VECTOR_MAPPING = 24  # reg[out:out+3] = Mapping node of type e (MAPPINGS) of vector reg[a:a+3]
#                     by location reg[b:b+3], Euler XYZ rotation reg[c:c+3], scale reg[d:d+3]
OP_REFLECTION = 25  # reg[out:out+3] = Texture Coordinate's Reflection: the view direction
#                     mirrored about the shading normal (world space)
OP_FACING = 26      # reg[out:out+3] = reg[a:a+3] normalised, negated on a back face (the
#                     Normal output, from the map NORMAL)
OP_PROJECT = 27     # reg[out:out+3] = (reg[a] / reg[a+2], reg[a+1] / reg[a+2], 0) (the Window
#                     output, from the homogeneous map WINDOW; 0 where reg[a+2] is 0)
OP_WHITE_NOISE = 28  # reg[out:out+3] Color, reg[out+3] Value of Cycles' White Noise Texture
#                     of dimension d at vector reg[a:a+3] and W reg[b]
OP_CURVES = 29      # reg[out:out+e] = RGB / Vector Curves (e = 3), Float Curve (e = 1) of
#                     reg[a:a+e] by factor reg[b]: c table entries at params[p+2:] over the
#                     range params[p:p+2]; d: extrapolate
OP_MAP_RANGE = 30   # reg[out:out+w] = Map Range of reg[a:], from reg[b:] .. reg[c:] to
#                     reg[d:] .. reg[e:]; params[p:p+4]: the Steps register, type
#                     (MAP_RANGES), clamp, w
OP_CLAMP = 31       # reg[out] = Clamp of reg[a] to reg[b] .. reg[c]; d: Range (else Min Max)
OP_GEOMETRY = 32    # the hit's geometry (Geometry node): d = 0, reg[out:out+3] = the shading
#                     normal; 1, the direction toward the viewer; 2, reg[out] = back face;
#                     3, the tangent along reg[a:a+3] across the shading normal (Tangent)
OP_BRICK = 33       # reg[out:out+3] Color, reg[out+3] Fac of Cycles' Brick Texture at
#                     reg[a:a+3]: colours reg[b:], reg[c:], mortar reg[d:]; params[p:p+6] the
#                     registers of Scale, Mortar Size, Mortar Smooth, Bias, Brick Width and Row
#                     Height, then offset, its frequency, squash and its frequency
OP_VORONOI = 35     # reg[out:out+3] Color, reg[out+3] Distance, reg[out+4:out+7] Position,
#                     reg[out+7] W, reg[out+8] Radius of Cycles' Voronoi Texture at vector
#                     reg[a:a+3] and W reg[b]; params[p:p+7] the registers of Scale, Detail,
#                     Roughness, Lacunarity, Smoothness, Exponent and Randomness, then its
#                     dimensions, feature (voronoi.FEATURES), metric (voronoi.METRICS) and
#                     normalize
OP_BLACKBODY = 36   # reg[out:out+3] = the Blackbody node's colour of temperature reg[a] (K)
OP_WAVELENGTH = 37  # reg[out:out+3] = the Wavelength node's colour of reg[a] nm; params[p:p+9]
#                     the CIE XYZ to scene-linear matrix (row-major)
OP_LIGHT_PATH = 38  # reg[out] = the Light Path node's output d (LIGHT_PATH_OUTPUTS): a register
#                     of the path state block set_light_path fills
OP_TRANSFORM = 39   # reg[out:out+3] = the vector reg[a:a+3] through the frame of columns
#                     reg[b:b+9] (three world-space axes): d = 0, sum_j v_j axis_j, plus
#                     reg[c:c+3] where c >= 0 (a point's origin); d = 1, the components
#                     (v - reg[c:c+3] where c >= 0) . axis_j; e: normalised (a normal)
OP_BOX = 40         # Image Texture's Box projection (Cycles' svm_node_tex_image_box): d = 0,
#                     reg[out:out+3] the three faces' weights and reg[out+3:out+9] their (u, v)
#                     for the object-space normal reg[a:a+3] at coordinate reg[b:b+3], blend
#                     params[p]; d = 1, reg[out:out+4] = sum_j reg[a+j] reg[b+4j:b+4j+4]
OP_PROJECTION = 41  # reg[out:out+3] = (u, v, 0) of reg[a:a+3] in projection d (PROJECTIONS):
#                     an Image Texture's Sphere or Tube, an Environment Texture's
#                     Equirectangular or Mirror Ball
OP_WIREFRAME = 42   # reg[out] = the Wireframe node's Fac: 1 where the hit lies within reg[b] / 2
#                     of an edge of its triangle, whose corners map a holds (POSITION)
OP_SKY = 43         # the Sky Texture (engine/sky.py): d = 0, reg[out:out+3] = (u, v, 0) of
#                     direction reg[a:a+3] in the sky's texture, reg[out+3:out+6] the XYZ of
#                     its sun's disc there (params[p:p+sky.DISC_PARAMS]; 0 while
#                     reg[SKY_WITHOUT_SUN] is set); d = 1, reg[out:out+3] = the XYZ
#                     reg[a:a+3] + reg[b:b+3] in the scene's linear RGB (params[p:p+9],
#                     row-major), negative channels 0 (Cycles' xyz_to_rgb_clamped); d = 2,
#                     reg[out:out+3] = the XYZ of the Preetham sky at direction reg[a:a+3]
#                     (params[p:p+sky.PREETHAM_PARAMS])
OP_VECTOR_ROTATE = 34  # reg[out:out+3] = Vector Rotate of reg[a:a+3] about centre reg[b:b+3]:
#                     type d (ROTATIONS) by axis reg[c:c+3] and angle reg[e], or Euler
#                     angles reg[params[p+1]:]; params[p]: invert

# The names of the per-corner coordinate maps beside a mesh's UV maps for Texture
# Coordinate's Generated output (the mesh's texture space: (P - location) / (2 size) + 1/2,
# as Cycles' mesh_texture_space) and its Object output (P in the object's own space).
GENERATED, OBJECT = "\x00generated", "\x00object"
# A Color Attribute node's colours (linear RGB per corner) are the map of this prefix and
# the attribute's name ("": the mesh's default colour attribute, as Cycles reads it).
COLOUR_ATTRIBUTE = "\x00colour:"
# ... and its alpha, the map of this prefix and the name (alpha in the first channel).
COLOUR_ALPHA = "\x00alpha:"
# Texture Coordinate's Normal reads the map NORMAL: the corners' shading normals in the
# object's own space (OP_FACING normalises and orients them). Its Camera and Window outputs
# read maps the renderer fills from the camera (camera.view_maps), since they depend on the
# render's camera and frame: CAMERA, the corner in camera space (+z ahead, +y up), and
# WINDOW, homogeneous coordinates whose division (OP_PROJECT) is the frame's normalised
# position (0..1 from the bottom left). Interpolating either over a triangle is exact: both
# are linear in the position.
NORMAL, CAMERA, WINDOW = "\x00normal", "\x00camera", "\x00window"
# The Geometry node's Position (world space) and True Normal (the triangle's, as its
# winding gives it; OP_FACING orients it) are maps the renderer fills from the scene too.
POSITION, TRUE_NORMAL = "\x00position", "\x00true_normal"
# The Geometry node's Parametric: the hit's barycentric weights of its triangle's first two
# corners and 0, (1 - u - v, u, 0) (Cycles' svm_node_geometry; its u and v weigh corners 1
# and 2, as embree's). Per corner (1, 0, 0), (0, 1, 0) and 0, which interpolate to exactly
# that; the exporter's mesh map, so a mirrored instance's reordered corners keep it.
PARAMETRIC = "\x00parametric"
# The Geometry node's Random Per Island: each triangle's island's number
# (noise.island_random) on all three corners, so it interpolates to itself.
ISLAND_RANDOM = "\x00island_random"
# ... and its Pointiness: each vertex's (mesh_attributes.pointiness) on the corners, which
# Cycles interpolates as a vertex attribute.
POINTINESS = "\x00pointiness"
# The Vector Transform node's camera space: the render camera's axes (Cycles' camera
# space: +z ahead, +y up, scale cleared) and position, maps of world-space vectors
# OP_TRANSFORM reads as a frame (three consecutive registers).
CAMERA_AXES = ("\x00camera_axis:x", "\x00camera_axis:y", "\x00camera_axis:z")
CAMERA_ORIGIN = "\x00camera_origin"
VIEW_MAPS = (CAMERA, WINDOW, POSITION, TRUE_NORMAL, *CAMERA_AXES, CAMERA_ORIGIN)
# The Attribute node (of type Geometry) reads the mesh's attribute of its name (a generic
# attribute, a colour attribute or a UV map) as two maps: ATTRIBUTE + name, its vector (the
# Color and Vector outputs: a scalar repeated, a 2D value with z = 0, a colour's RGB), and
# ATTRIBUTE_SCALARS + name, its Fac (a scalar, a 2D value's x, the mean of three
# components) and Alpha (a colour's alpha, else 1) in the first two channels, as Cycles'
# svm_node_attr_store reads each type.
ATTRIBUTE, ATTRIBUTE_SCALARS = "\x00attribute:", "\x00attribute_scalars:"
# The Object Info node's outputs, per object (each corner of an object holds its values;
# the exporter fills them per instance): its location; its colour; its alpha, Random
# (Cycles' object random number) and pass index.
OBJECT_LOCATION, OBJECT_COLOUR = "\x00object_location", "\x00object_colour"
OBJECT_NUMBERS = "\x00object_numbers"
# ... and its object space: the columns of the object's matrix M (its origin is
# OBJECT_LOCATION), and of M^-1 with its origin -M^-1 t.
OBJECT_AXES = ("\x00object_axis:x", "\x00object_axis:y", "\x00object_axis:z")
OBJECT_INVERSE = ("\x00object_inverse:x", "\x00object_inverse:y", "\x00object_inverse:z")
OBJECT_INVERSE_ORIGIN = "\x00object_inverse:t"
OBJECT_MAPS = (OBJECT_LOCATION, OBJECT_COLOUR, OBJECT_NUMBERS, *OBJECT_AXES, *OBJECT_INVERSE,
               OBJECT_INVERSE_ORIGIN)
# The Attribute node of type Object reads a property of the shaded object (a custom
# property or an RNA path, on the object, then on its data) as two per-object maps laid out
# as ATTRIBUTE's and ATTRIBUTE_SCALARS' (Cycles stores it as an object attribute read by
# the same svm_node_attr); a property the object lacks reads 0, Alpha included.
OBJECT_ATTRIBUTE = "\x00object_attribute:"
OBJECT_ATTRIBUTE_SCALARS = "\x00object_attribute_scalars:"
# The Tangent node's Radial directions (and the Geometry node's Tangent, Radial Z): the map
# of this prefix and the axis ("X", "Y", "Z") holds, per corner, the direction around that
# axis of the texture space, (-(g_y - 1/2), g_x - 1/2, 0) for Z from Generated g, turned
# into world space as a normal turns (Cycles' svm_node_tangent and primitive_tangent with
# object_normal_transform); both steps are linear, so interpolating it is exact.
RADIAL = "\x00radial:"
# ... and the Tangent node's UV Map direction: the map of this prefix and the UV map's name
# ("": the render-active one) holds Blender's tangents of that map (as normal maps read
# them), turned into world space as a normal turns, as svm_node_tangent turns them.
UV_TANGENT = "\x00uv_tangent:"


# How a warning names the maps of fixed names.
_MAP_LABELS = {GENERATED: "Generated coordinates", OBJECT: "Object coordinates",
               NORMAL: "normals", PARAMETRIC: "parametric coordinates",
               ISLAND_RANDOM: "random per island", POINTINESS: "pointiness"}


def map_label(name: str) -> str:
    """How a warning names a per-corner map."""
    if name in _MAP_LABELS:
        return _MAP_LABELS[name]
    if name in OBJECT_AXES + OBJECT_INVERSE + (OBJECT_INVERSE_ORIGIN,):
        return "object transform"
    if name in OBJECT_MAPS:
        return "object info"
    for prefix in (OBJECT_ATTRIBUTE, OBJECT_ATTRIBUTE_SCALARS):
        if name.startswith(prefix):
            return f"object property '{name[len(prefix):]}'"
    if name.startswith(RADIAL):
        return "Generated coordinates"
    if name.startswith(UV_TANGENT):
        uv_map = name[len(UV_TANGENT):]
        return f"tangents of UV map '{uv_map}'" if uv_map else "UV map tangents"
    for prefix in (COLOUR_ATTRIBUTE, COLOUR_ALPHA):
        if name.startswith(prefix):
            attribute = name[len(prefix):]
            return f"colour attribute '{attribute}'" if attribute else "colour attribute"
    for prefix in (ATTRIBUTE, ATTRIBUTE_SCALARS):
        if name.startswith(prefix):
            return f"attribute '{name[len(prefix):]}'"
    return f"UV map '{name}'" if name else "UV map"


def absent_map_value(name: str) -> tuple:
    """What a program reads from a map the mesh does not have: 0, except a missing
    attribute's Alpha, which is 1 (Cycles' svm_node_attr reads a missing attribute as a
    zero vector and stores Alpha 1 for any type without a fourth channel; the Color
    Attribute node's missing Alpha stays 0, svm_node_vertex_color)."""
    return (0.0, 1.0, 0.0) if name.startswith(ATTRIBUTE_SCALARS) else (0.0, 0.0, 0.0)

# Blend modes of OP_BLEND (Cycles' svm_mix, kernel/svm/color_util.h): per channel up to
# HUE, then the four that work in HSV on the whole colour.
BLENDS = ("MIX", "ADD", "MULTIPLY", "SUBTRACT", "SCREEN", "DIVIDE", "DIFFERENCE", "DARKEN",
          "LIGHTEN", "EXCLUSION", "OVERLAY", "DODGE", "BURN", "SOFT_LIGHT", "LINEAR_LIGHT",
          "HUE", "SATURATION", "COLOR", "VALUE")
HUE = BLENDS.index("HUE")
# Types of OP_VECTOR_MAPPING (the Mapping node's, svm_mapping in kernel/svm/mapping_util.h).
MAPPINGS = ("POINT", "TEXTURE", "VECTOR", "NORMAL")
# OP_PROJECTION's kinds: the Image Texture's and the Environment Texture's projections.
PROJECTIONS = ("SPHERE", "TUBE", "EQUIRECTANGULAR", "MIRROR_BALL")
# Types of OP_VECTOR_ROTATE (the Vector Rotate node's).
ROTATIONS = ("AXIS_ANGLE", "X_AXIS", "Y_AXIS", "Z_AXIS", "EULER_XYZ")
# Types of OP_MAP_RANGE (the Map Range node's interpolation types).
MAP_RANGES = ("LINEAR", "STEPPED", "SMOOTHSTEP", "SMOOTHERSTEP")
# Conversions of OP_COLOUR_SPACE (Separate and Combine Color's modes; util/color.h).
CONVERSIONS = ("RGB_TO_HSV", "RGB_TO_HSL", "HSV_TO_RGB", "HSL_TO_RGB")
# Operations of OP_MATH (Cycles' svm_math, kernel/svm/math_util.h).
MATHS = ("ADD", "SUBTRACT", "MULTIPLY", "DIVIDE", "MULTIPLY_ADD", "POWER", "MINIMUM", "MAXIMUM",
         "LESS_THAN", "GREATER_THAN", "ABSOLUTE", "SQRT", "FLOOR", "CEIL", "FRACT", "MODULO",
         "SINE", "COSINE", "WRAP", "PINGPONG", "ROUND", "TRUNC", "SIGN", "EXPONENT",
         "LOGARITHM", "SNAP", "COMPARE", "FLOORED_MODULO", "INVERSE_SQRT", "RADIANS",
         "DEGREES", "TANGENT", "SINH", "COSH", "TANH", "ARCSINE", "ARCCOSINE", "ARCTANGENT",
         "ARCTAN2", "SMOOTH_MIN", "SMOOTH_MAX")
# Operations of OP_VECTOR_MATH (Cycles' svm_vector_math, kernel/svm/vector_math.h), and for
# those done per component the Math operation that does it (-1: its own formula).
VECTOR_MATHS = ("ADD", "SUBTRACT", "MULTIPLY", "DIVIDE", "MULTIPLY_ADD", "CROSS_PRODUCT",
                "PROJECT", "REFLECT", "REFRACT", "FACEFORWARD", "DOT_PRODUCT", "DISTANCE",
                "LENGTH", "SCALE", "NORMALIZE", "SNAP", "FLOOR", "CEIL", "MODULO", "WRAP",
                "FRACTION", "ABSOLUTE", "POWER", "SIGN", "MINIMUM", "MAXIMUM", "SINE",
                "COSINE", "TANGENT")
# POWER is the Math node's safe one too: Cycles' powf per channel makes NaN where that
# gives 0 (a negative base, a fractional exponent), and a NaN must never reach a pixel.
PER_COMPONENT = tuple(MATHS.index({"FRACTION": "FRACT"}.get(op, op))
                      if {"FRACTION": "FRACT"}.get(op, op) in MATHS else -1
                      for op in VECTOR_MATHS)
INTERPOLATIONS = ("Closest", "Linear", "Cubic", "Smart")  # Smart is Cubic on the CPU
EXTENSIONS = ("REPEAT", "EXTEND", "CLIP", "MIRROR")
LUMINANCE = (0.2126, 0.7152, 0.0722)
# Cycles' fit of a black body's Rec.709 colour (kernel/tables.h, the blackbody_table_*
# coefficients; svm_math_blackbody_color_rec709): per temperature band (lower edges
# BLACKBODY_BANDS K), red and green a / T + b T + c, blue a cubic in T. Below 800 K and
# from 12000 K on, the colours at the ends.
BLACKBODY_BANDS = np.array([965.0, 1167.0, 1449.0, 1902.0, 3315.0, 6365.0])
BLACKBODY_R = np.array([[1.61919106e+03, -2.05010916e-03, 5.02995757e+00],
                        [2.48845471e+03, -1.11330907e-03, 3.22621544e+00],
                        [3.34143193e+03, -4.86551192e-04, 1.76486769e+00],
                        [4.09461742e+03, -1.27446582e-04, 7.25731635e-01],
                        [4.67028036e+03, 2.91258199e-05, 1.26703442e-01],
                        [4.59509185e+03, 2.87495649e-05, 1.50345020e-01],
                        [3.78717450e+03, 9.35907826e-06, 3.99075871e-01]])
BLACKBODY_G = np.array([[-4.88999748e+02, 6.04330754e-04, -7.55807526e-02],
                        [-7.55994277e+02, 3.16730098e-04, 4.78306139e-01],
                        [-1.02363977e+03, 1.20223470e-04, 9.36662319e-01],
                        [-1.26571316e+03, 4.87340896e-06, 1.27054498e+00],
                        [-1.42529332e+03, -4.01150431e-05, 1.43972784e+00],
                        [-1.17554822e+03, -2.16378048e-05, 1.30408023e+00],
                        [-5.00799571e+02, -4.59832026e-06, 1.09098763e+00]])
BLACKBODY_B = np.array([[5.96945309e-11, -4.85742887e-08, -9.70622247e-05, -4.07936148e-03],
                        [2.40430366e-11, 5.55021075e-08, -1.98503712e-04, 2.89312858e-02],
                        [-1.40949732e-11, 1.89878968e-07, -3.56632824e-04, 9.10767778e-02],
                        [-3.61460868e-11, 2.84822009e-07, -4.93211319e-04, 1.56723440e-01],
                        [-1.97075738e-11, 1.75359352e-07, -2.50542825e-04, -2.22783266e-02],
                        [-1.61997957e-13, -1.64216008e-08, 3.86216271e-04, -7.38077418e-01],
                        [6.72650283e-13, -2.73078809e-08, 4.24098264e-04, -7.52335691e-01]])
# Entries of a Color Ramp's table (Cycles' RAMP_TABLE_SIZE).
RAMP_TABLE_SIZE = 256
# The registers one program may use (the kernel's scratch per path batch); the last
# seven hold the hit's geometry for the nodes that read it (set_geometry): the shading
# normal, facing the incoming side (3), the direction toward the viewer (3) and whether
# the surface is seen from its back (1), Cycles' sd->N, sd->wi and SD_BACKFACING.
MAX_REGISTERS = 256
GEOMETRY = MAX_REGISTERS - 7
# Before them, the state of the path being shaded for the Light Path node
# (set_light_path), one register per output in this order: Cycles' path flags (the type
# of the ray that arrived: PATH_RAY_CAMERA ... PATH_RAY_VOLUME_SCATTER, as 0 or 1), the
# ray's length and the bounce counters (svm_node_light_path). Portal Depth is always 0:
# Specula has no light portals.
LIGHT_PATH_OUTPUTS = ("Is Camera Ray", "Is Shadow Ray", "Is Diffuse Ray", "Is Glossy Ray",
                      "Is Singular Ray", "Is Reflection Ray", "Is Transmission Ray",
                      "Is Volume Scatter Ray", "Ray Length", "Ray Depth", "Diffuse Depth",
                      "Glossy Depth", "Transparent Depth", "Transmission Depth")
LIGHT_PATH = GEOMETRY - len(LIGHT_PATH_OUTPUTS)
# Before them, 1 while a world's map is baked: Sky Textures leave their sun's disc out of
# it (the exporter makes the disc a sun light of its own, which a map would blur), else 0.
SKY_WITHOUT_SUN = LIGHT_PATH - 1
# The path flags (bit j: output j), as the integrator keeps them per path.
RAY_CAMERA, RAY_SHADOW, RAY_DIFFUSE, RAY_GLOSSY, RAY_SINGULAR, RAY_REFLECT, RAY_TRANSMIT, \
    RAY_VOLUME_SCATTER = (1 << j for j in range(8))
RAY_FLAG_COUNT = 8
WIDTH = 8  # int64 columns of an instruction


@dataclass
class Texture:
    """One image as the kernel samples it: texels (h, w, 4) float32, bottom row first
    (Blender's and Cycles' order), already associated and, unless `srgb`, scene linear."""

    name: str
    texels: np.ndarray
    interpolation: str = "Linear"
    extension: str = "REPEAT"
    srgb: bool = False  # encoded sRGB values, decoded after interpolation

    def __post_init__(self):
        t = np.asarray(self.texels, np.float32)
        if t.ndim != 3 or t.shape[2] != 4 or t.shape[0] < 1 or t.shape[1] < 1:
            raise ValueError(f"image '{self.name}': texels must be (h, w, 4), got {t.shape}")
        if self.interpolation not in INTERPOLATIONS:
            raise ValueError(f"image '{self.name}': interpolation {self.interpolation!r} not one "
                             f"of {INTERPOLATIONS}")
        if self.extension not in EXTENSIONS:
            raise ValueError(f"image '{self.name}': extension {self.extension!r} not one of "
                             f"{EXTENSIONS}")
        # A NaN or inf texel would put one in a pixel: Cycles reads them as 0 too. Finite
        # texels stay the array given, which other Textures of the image share (pack).
        self.texels = t if np.isfinite(t).all() else np.nan_to_num(t, nan=0.0, posinf=0.0,
                                                                   neginf=0.0)


@dataclass
class Program:
    """One input's program under construction: instructions, float parameters, the
    registers it uses, its textures and UV maps (by name; "" the render-active map), and
    the register holding the result."""

    code: list = field(default_factory=list)
    params: list = field(default_factory=list)
    textures: list = field(default_factory=list)
    uv_maps: list = field(default_factory=list)
    registers: int = 0
    out: int = -1
    # A world's Sky Texture sun discs (which its map leaves out): (node name, the unit
    # direction toward the sun, its angular diameter).
    suns: list = field(default_factory=list)

    def register(self, width: int) -> int:
        r = self.registers
        self.registers += width
        if self.registers > SKY_WITHOUT_SUN:
            raise ValueError(f"the node chain needs more than {SKY_WITHOUT_SUN} registers")
        return r

    def emit(self, op, width, a=0, b=0, c=0, d=0, e=0, params=()) -> int:
        """Append one instruction writing `width` new registers; returns the first."""
        out = self.register(width)
        p = len(self.params)
        self.params.extend(float(x) for x in params)
        self.code.append((op, out, a, b, c, d, e, p))
        return out

    def const(self, values) -> int:
        values = [float(v) for v in np.atleast_1d(values)]
        return self.emit(OP_CONST, len(values), c=len(values), params=values)

    def map_index(self, name: str) -> int:
        """The program's index of per-corner map `name` (pack makes it the scene's)."""
        if name not in self.uv_maps:
            self.uv_maps.append(name)
        return self.uv_maps.index(name)

    def uv(self, name: str) -> int:
        return self.emit(OP_UV, 3, a=self.map_index(name))

    def image(self, texture: Texture, coordinate: int, unassociate: bool) -> int:
        """A lookup of `texture`; one the program already reads (a Box projection's three
        faces, the same image on two nodes) keeps its one copy of the texels."""
        index = next((k for k, t in enumerate(self.textures) if t is texture), None)
        if index is None:
            self.textures.append(texture)
            index = len(self.textures) - 1
        return self.emit(OP_IMAGE, 4, a=coordinate, b=index, c=int(unassociate))


def radial_tangent(axis: str = "Z") -> Program:
    """The program of the Tangent node's Radial direction about `axis` ("X", "Y", "Z"), and
    of the Geometry node's Tangent (Z): Cycles' default for a Tangent input left unlinked."""
    p = Program()
    p.out = p.emit(OP_GEOMETRY, 3, a=p.uv(RADIAL + axis), d=3)
    return p


# The kernel's view of every program of a scene:
#   code (n, WIDTH) int64, params (p,) float64, texels (N, 4) float32,
#   textures (i, 6) int64 rows (first texel, width, height, interpolation, extension, srgb),
#   colour, emission, normal, fac, roughness, height, tint (k, 3) int64 per material: that
#   input's program as first instruction (-1: none), end, result register. tint: the
#   Principled BSDF's Specular Tint, or on a coat's mix its Coat Tint; diffuse_roughness:
#   the Principled BSDF's Diffuse Roughness; anisotropy: a GGX lobe's anisotropy and its
#   rotation (two registers); tangent: its Tangent input (a vector); specular_ior: the
#   Principled BSDF's IOR and Specular IOR Level (two registers); thin_film: its Thin Film
#   Thickness and IOR (two registers).
SLOTS = ("colour", "emission", "normal", "fac", "roughness", "height", "tint",
         "diffuse_roughness", "anisotropy", "tangent", "specular_ior", "thin_film")
ProgramTable = namedtuple("ProgramTable", "code params texels textures " + " ".join(SLOTS))


def pack(colour_programs: list, emission_programs: list | None, uv_index,
         normal_programs: list | None = None, fac_programs: list | None = None,
         roughness_programs: list | None = None, height_programs: list | None = None,
         tint_programs: list | None = None,
         diffuse_roughness_programs: list | None = None,
         anisotropy_programs: list | None = None,
         tangent_programs: list | None = None,
         specular_ior_programs: list | None = None,
         thin_film_programs: list | None = None) -> ProgramTable:
    """Pack the materials' colour, emission, normal-map, mix-factor, roughness, bump
    height, tint, diffuse roughness, anisotropy, tangent, specular IOR and thin film
    programs (one per material, or None) into a ProgramTable; each program's UV map names
    become scene-wide map indices through `uv_index(name)`."""
    k = len(colour_programs)
    slots = [p or [None] * k for p in (colour_programs, emission_programs, normal_programs,
                                       fac_programs, roughness_programs, height_programs,
                                       tint_programs, diffuse_roughness_programs,
                                       anisotropy_programs, tangent_programs,
                                       specular_ior_programs, thin_film_programs)]
    code, params, texels, tex_rows = [], [], [], []
    rows = np.full((len(SLOTS), k, 3), -1, np.int64)
    n_code = n_params = n_texels = 0
    # An image read by several programs (a base colour and its alpha, one texture under
    # two materials) or under two filters keeps one copy of its texels: keyed by identity,
    # for the exporter hands every reader of an image the same Texture and texel array.
    first_texel, row_of = {}, {}
    for slot, mat, prog in [(j, m, p) for j, progs in enumerate(slots)
                            for m, p in enumerate(progs)]:
        if prog is None:
            continue
        table_rows = []
        for t in prog.textures:
            if id(t.texels) not in first_texel:
                first_texel[id(t.texels)] = n_texels
                texels.append(t.texels.reshape(-1, 4))
                n_texels += t.texels.shape[0] * t.texels.shape[1]
            h, w = t.texels.shape[:2]
            row = (first_texel[id(t.texels)], w, h, INTERPOLATIONS.index(t.interpolation),
                   EXTENSIONS.index(t.extension), int(t.srgb))
            if row not in row_of:
                row_of[row] = len(tex_rows)
                tex_rows.append(row)
            table_rows.append(row_of[row])
        for op, out, a, b, c, d, e, p in prog.code:
            if op in (OP_UV, OP_WIREFRAME):
                a = uv_index(prog.uv_maps[a])
            elif op == OP_IMAGE:
                b = table_rows[b]
            code.append((op, out, a, b, c, d, e, p + n_params))
        rows[slot, mat] = (n_code, n_code + len(prog.code), prog.out)
        n_code += len(prog.code)
        params.extend(prog.params)
        n_params += len(prog.params)
    return ProgramTable(np.array(code, np.int64).reshape(-1, WIDTH),
                        np.array(params + [0.0], np.float64),
                        (np.concatenate(texels) if texels else np.zeros((1, 4), np.float32)),
                        np.array(tex_rows, np.int64).reshape(-1, 6), *rows)


# ------------------------------------------------------------------ node functions
@njit(**JIT)
def srgb_to_linear(c):
    """The sRGB transfer function, encoded -> linear (Cycles' color_srgb_to_linear)."""
    if c < 0.04045:
        return 0.0 if c < 0.0 else c * (1.0 / 12.92)
    return ((c + 0.055) * (1.0 / 1.055)) ** 2.4


@njit(**ALLOCATING)
def srgb_decode(c):
    """srgb_to_linear over a 1-d array (images, outside the kernel)."""
    out = np.empty(len(c))
    for i in range(len(c)):
        out[i] = srgb_to_linear(c[i])
    return out


@njit(**JIT)
def blend(mode, t, a, b):
    """One channel of Cycles' colour Mix of a and b at factor t, for the modes that work
    per channel (mode: BLENDS index; kernel/svm/color_util.h, svm_mix_*)."""
    tm = 1.0 - t
    if mode == 1:  # ADD
        return a + t * b
    if mode == 2:  # MULTIPLY
        return a * (tm + t * b)
    if mode == 3:  # SUBTRACT
        return a - t * b
    if mode == 4:  # SCREEN
        return 1.0 - (tm + t * (1.0 - b)) * (1.0 - a)
    if mode == 5:  # DIVIDE
        return tm * a + t * a / b if b != 0.0 else a
    if mode == 6:  # DIFFERENCE
        return tm * a + t * abs(a - b)
    if mode == 7:  # DARKEN
        return tm * a + t * min(a, b)
    if mode == 8:  # LIGHTEN (Cycles 5; before 4.x it was max(a, t b))
        return tm * a + t * max(a, b)
    if mode == 9:  # EXCLUSION
        return max(tm * a + t * (a + b - 2.0 * a * b), 0.0)
    if mode == 10:  # OVERLAY
        if a < 0.5:
            return a * (tm + 2.0 * t * b)
        return 1.0 - (tm + 2.0 * t * (1.0 - b)) * (1.0 - a)
    if mode == 11:  # DODGE
        if a == 0.0:
            return a
        d = 1.0 - t * b
        return 1.0 if d <= 0.0 else min(a / d, 1.0)
    if mode == 12:  # BURN
        d = tm + t * b
        if d <= 0.0:
            return 0.0
        return min(max(1.0 - (1.0 - a) / d, 0.0), 1.0)
    if mode == 13:  # SOFT_LIGHT
        screen = 1.0 - (1.0 - b) * (1.0 - a)
        return tm * a + t * ((1.0 - a) * b * a + a * screen)
    if mode == 14:  # LINEAR_LIGHT
        return a + t * (2.0 * b - 1.0)
    return tm * a + t * b


@njit(**JIT)
def blend_colour(mode, t, a0, a1, a2, b0, b1, b2):
    """Cycles' colour Mix of colours a and b at factor t (mode: BLENDS index): the modes
    of HSV (Hue, Saturation, Value, Color) on the whole colour, the rest per channel."""
    if mode < HUE:
        return blend(mode, t, a0, b0), blend(mode, t, a1, b1), blend(mode, t, a2, b2)
    h, s, v = rgb_to_hsv(a0, a1, a2)
    h2, s2, v2 = rgb_to_hsv(b0, b1, b2)
    if mode == HUE or mode == HUE + 2:  # HUE, COLOR: only where b has a hue
        if s2 == 0.0:
            return a0, a1, a2
        r, g, b = hsv_to_rgb(h2, s2 if mode == HUE + 2 else s, v)
        return (1.0 - t) * a0 + t * r, (1.0 - t) * a1 + t * g, (1.0 - t) * a2 + t * b
    if mode == HUE + 1:  # SATURATION: only where a has one
        if s == 0.0:
            return a0, a1, a2
        return hsv_to_rgb(h, (1.0 - t) * s + t * s2, v)
    return hsv_to_rgb(h, s, (1.0 - t) * v + t * v2)  # VALUE


@njit(**JIT)
def math_op(op, a, b, c):
    """Cycles' Math node (op: MATHS index), with its safe division, power and root."""
    if op == 0:
        return a + b
    if op == 1:
        return a - b
    if op == 2:
        return a * b
    if op == 3:
        return a / b if b != 0.0 else 0.0
    if op == 4:
        return a * b + c
    if op == 5:  # safe_powf: a negative base needs an integer exponent
        if a < 0.0 and b != math.floor(b):
            return 0.0
        return a ** b if (a != 0.0 or b > 0.0) else (1.0 if b == 0.0 else 0.0)
    if op == 6:
        return min(a, b)
    if op == 7:
        return max(a, b)
    if op == 8:
        return 1.0 if a < b else 0.0
    if op == 9:
        return 1.0 if a > b else 0.0
    if op == 10:
        return abs(a)
    if op == 11:
        return math.sqrt(a) if a > 0.0 else 0.0
    if op == 12:
        return math.floor(a)
    if op == 13:
        return math.ceil(a)
    if op == 14:
        return a - math.floor(a)
    if op == 15:  # safe_modulo: fmod, 0 for b = 0
        return np.fmod(a, b) if b != 0.0 else 0.0
    if op == 16:
        return math.sin(a)
    if op == 17:
        return math.cos(a)
    return _math_more(op, a, b, c)


@njit(**JIT)
def _math_more(op, a, b, c):
    """The Math node's operations from WRAP on (math_op's second half)."""
    if op == 18:  # wrapf(a, max b, min c)
        r = b - c
        return a - r * math.floor((a - c) / r) if r != 0.0 else c
    if op == 19:  # pingpongf
        if b == 0.0:
            return 0.0
        q = (a - b) / (b * 2.0)
        return abs((q - math.floor(q)) * b * 2.0 - b)
    if op == 20:
        return math.floor(a + 0.5)
    if op == 21:
        return math.floor(a) if a >= 0.0 else math.ceil(a)
    if op == 22:
        return 1.0 if a > 0.0 else (-1.0 if a < 0.0 else 0.0)
    if op == 23:
        return math.exp(min(a, 700.0))
    if op == 24:  # safe_logf
        return math.log(a) / math.log(b) if a > 0.0 and b > 0.0 and b != 1.0 else 0.0
    if op == 25:
        return math.floor(a / b) * b if b != 0.0 else 0.0
    if op == 26:
        return 1.0 if abs(a - b) <= max(c, 1e-5) else 0.0
    if op == 27:
        return a - math.floor(a / b) * b if b != 0.0 else 0.0
    return _math_trigonometry(op, a, b, c)


@njit(**JIT)
def _math_trigonometry(op, a, b, c):
    """The Math node's operations from INVERSE_SQRT on: conversions of angles, the
    trigonometric and hyperbolic functions (Cycles' safe ones: arcsine and arccosine of
    the clamped value, atan2 of the origin 0) and the smooth minimum and maximum
    (smoothminf: a cubic blend over the distance c)."""
    if op == 28:
        return 1.0 / math.sqrt(a) if a > 0.0 else 0.0
    if op == 29:
        return a * (math.pi / 180.0)
    if op == 30:
        return a * (180.0 / math.pi)
    if op == 31:
        return math.tan(a)
    if op == 32:  # (sinh and cosh overflow past |a| 710; Cycles' floats give inf earlier)
        return math.sinh(min(max(a, -700.0), 700.0))
    if op == 33:
        return math.cosh(min(max(a, -700.0), 700.0))
    if op == 34:
        return math.tanh(a)
    if op == 35:
        return math.asin(min(max(a, -1.0), 1.0))
    if op == 36:
        return math.acos(min(max(a, -1.0), 1.0))
    if op == 37:
        return math.atan(a)
    if op == 38:
        return math.atan2(a, b) if a != 0.0 or b != 0.0 else 0.0
    sign = 1.0 if op == 39 else -1.0  # SMOOTH_MAX is -smoothmin(-a, -b, c)
    a, b = sign * a, sign * b
    if c != 0.0:
        h = max(c - abs(a - b), 0.0) / c
        return sign * (min(a, b) - h * h * h * c * (1.0 / 6.0))
    return sign * min(a, b)


@njit(**JIT)
def node_vector_math(ins, reg):
    """Cycles' Vector Math node (its safe division, projection and normalisation): the
    vector and the value outputs, the one an operation does not make 0."""
    op, a, b, c = ins[5], ins[2], ins[3], ins[4]
    out, scale = ins[1], reg[ins[6]]
    ax, ay, az = reg[a], reg[a + 1], reg[a + 2]
    bx, by, bz = reg[b], reg[b + 1], reg[b + 2]
    x = y = z = value = 0.0
    k = PER_COMPONENT[op]
    if k >= 0:
        x, y, z = (math_op(k, ax, bx, reg[c]), math_op(k, ay, by, reg[c + 1]),
                   math_op(k, az, bz, reg[c + 2]))
    elif op == 5:  # CROSS_PRODUCT
        x, y, z = ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx
    elif op == 6:  # PROJECT
        ll = bx * bx + by * by + bz * bz
        t = (ax * bx + ay * by + az * bz) / ll if ll != 0.0 else 0.0
        x, y, z = t * bx, t * by, t * bz
    elif op == 7 or op == 8:  # REFLECT, REFRACT about the normalised b
        nx, ny, nz = _safe_normalize(bx, by, bz)
        d = nx * ax + ny * ay + nz * az
        if op == 7:
            x, y, z = ax - 2.0 * d * nx, ay - 2.0 * d * ny, az - 2.0 * d * nz
        else:  # refract(a, n, eta = scale)
            k2 = 1.0 - scale * scale * (1.0 - d * d)
            if k2 >= 0.0:
                m = scale * d + math.sqrt(k2)
                x, y, z = scale * ax - m * nx, scale * ay - m * ny, scale * az - m * nz
    elif op == 9:  # FACEFORWARD: a if dot(c, b) < 0, else -a
        sign = 1.0 if reg[c] * bx + reg[c + 1] * by + reg[c + 2] * bz < 0.0 else -1.0
        x, y, z = sign * ax, sign * ay, sign * az
    elif op == 10:
        value = ax * bx + ay * by + az * bz
    elif op == 11:
        value = math.sqrt((ax - bx) ** 2 + (ay - by) ** 2 + (az - bz) ** 2)
    elif op == 12:
        value = math.sqrt(ax * ax + ay * ay + az * az)
    elif op == 13:
        x, y, z = ax * scale, ay * scale, az * scale
    else:  # NORMALIZE (the others are per component)
        x, y, z = _safe_normalize(ax, ay, az)
    reg[out], reg[out + 1], reg[out + 2], reg[out + 3] = x, y, z, value


@njit(**JIT)
def set_geometry(reg, nx, ny, nz, ix, iy, iz, backfacing):
    """The hit's geometry into the registers the Fresnel and Layer Weight nodes read."""
    reg[GEOMETRY], reg[GEOMETRY + 1], reg[GEOMETRY + 2] = nx, ny, nz
    reg[GEOMETRY + 3], reg[GEOMETRY + 4], reg[GEOMETRY + 5] = ix, iy, iz
    reg[GEOMETRY + 6] = 1.0 if backfacing else 0.0


@njit(**JIT)
def set_light_path(reg, flags, length, depth, diffuse, glossy, transparent, transmission):
    """The state of the path being shaded into the registers the Light Path node reads:
    its flags (RAY_*), the arriving ray's length and its bounce counters (Ray Depth as
    Cycles reports it in this context: one more for a shadow ray or a light's emission)."""
    for j in range(RAY_FLAG_COUNT):
        reg[LIGHT_PATH + j] = 1.0 if flags & (1 << j) else 0.0
    reg[LIGHT_PATH + 8] = length
    reg[LIGHT_PATH + 9] = depth
    reg[LIGHT_PATH + 10] = diffuse
    reg[LIGHT_PATH + 11] = glossy
    reg[LIGHT_PATH + 12] = transparent
    reg[LIGHT_PATH + 13] = transmission


@njit(**JIT)
def set_ray_length(reg, length):
    """The Light Path node's Ray Length alone (a light's emission: the distance to it)."""
    reg[LIGHT_PATH + 8] = length


@njit(**JIT)
def _facing_cosine(normal, reg):
    """The cosine between the view and the normal in reg[normal:normal+3] (normalised), or
    the hit's shading normal where normal < 0."""
    g = GEOMETRY
    if normal < 0:
        nx, ny, nz = reg[g], reg[g + 1], reg[g + 2]
    else:
        nx, ny, nz = _safe_normalize(reg[normal], reg[normal + 1], reg[normal + 2])
    return nx * reg[g + 3] + ny * reg[g + 4] + nz * reg[g + 5]


@njit(**JIT)
def node_fresnel(ins, reg):
    """Cycles' Fresnel node (svm_node_fresnel): the dielectric Fresnel at the view's angle
    to the normal, of IOR max(ior, 1e-5), inverted on a back face."""
    eta = max(reg[ins[2]], 1e-5)
    if reg[GEOMETRY + 6] != 0.0:
        eta = 1.0 / eta
    reg[ins[1]] = fresnel_dielectric(_facing_cosine(ins[3], reg), eta, True)[0]


@njit(**JIT)
def node_layer_weight(ins, reg):
    """Cycles' Layer Weight node (svm_node_layer_weight): Fresnel, the dielectric Fresnel
    of eta = 1 / max(1 - blend, 1e-5) (not inverted on a back face); Facing, 1 - |cos|
    raised to the blend's power curve."""
    blend = reg[ins[2]]
    cos = _facing_cosine(ins[3], reg)
    eta = max(1.0 - blend, 1e-5)
    if reg[GEOMETRY + 6] == 0.0:
        eta = 1.0 / eta
    reg[ins[1]] = fresnel_dielectric(cos, eta, True)[0]
    facing = abs(cos)
    if blend != 0.5:
        b = min(max(blend, 0.0), 1.0 - 1e-5)
        facing = facing ** (2.0 * b if b < 0.5 else 0.5 / (1.0 - b))
    reg[ins[1] + 1] = 1.0 - facing


@njit(**JIT)
def _safe_normalize(x, y, z):
    """(x, y, z) normalised, or 0 (Cycles' safe_normalize)."""
    ll = math.sqrt(x * x + y * y + z * z)
    return (x / ll, y / ll, z / ll) if ll != 0.0 else (0.0, 0.0, 0.0)


@njit(**JIT)
def _wrap(i, n, extension):
    """Texel index i of a row or column of n under an extension (EXTENSIONS index);
    -1 for Clip outside the image."""
    if extension == 0:  # REPEAT
        i %= n
        return i + n if i < 0 else i
    if extension == 1:  # EXTEND
        return min(max(i, 0), n - 1)
    if extension == 3:  # MIRROR
        m = abs(i + (1 if i < 0 else 0)) % (2 * n)
        return 2 * n - m - 1 if m >= n else m
    return i if 0 <= i < n else -1


@njit(**JIT)
def _texel(texels, first, w, h, ix, iy, ch):
    if ix < 0 or iy < 0 or ix >= w or iy >= h:
        return 0.0
    return np.float64(texels[first + iy * w + ix, ch])


@njit(**JIT)
def _cubic_weight(k, t):
    """Cycles' uniform cubic B-spline weight k (0..3) at t (SET_CUBIC_SPLINE_WEIGHTS)."""
    if k == 0:
        return (((-1.0 / 6.0) * t + 0.5) * t - 0.5) * t + (1.0 / 6.0)
    if k == 1:
        return ((0.5 * t - 1.0) * t) * t + (2.0 / 3.0)
    if k == 2:
        return ((-0.5 * t + 0.5) * t + 0.5) * t + (1.0 / 6.0)
    return (1.0 / 6.0) * t * t * t


@njit(**JIT)
def image_channel(x, y, ch, texels, tex):
    """Channel ch of the image row `tex` at texture coordinates (x, y), interpolated and
    extended as Cycles' CPU kernel does (kernel/device/cpu/image.h)."""
    first, w, h, interp, ext = tex[0], tex[1], tex[2], tex[3], tex[4]
    if interp == 0:  # Closest
        ix = _wrap(int(math.floor(x * w)), w, ext)
        iy = _wrap(int(math.floor(y * h)), h, ext)
        return _texel(texels, first, w, h, ix, iy, ch)
    fx, fy = x * w - 0.5, y * h - 0.5
    ix0, iy0 = int(math.floor(fx)), int(math.floor(fy))
    tx, ty = fx - ix0, fy - iy0
    if interp == 1:  # Linear
        r = 0.0
        for j in range(2):
            wy = ty if j else 1.0 - ty
            iy = _wrap(iy0 + j, h, ext)
            for i in range(2):
                wx = tx if i else 1.0 - tx
                r += wx * wy * _texel(texels, first, w, h, _wrap(ix0 + i, w, ext), iy, ch)
        return r
    r = 0.0  # Cubic (and Smart)
    for j in range(4):
        iy = _wrap(iy0 + j - 1, h, ext)
        row = 0.0
        for i in range(4):
            row += _cubic_weight(i, tx) * _texel(texels, first, w, h,
                                                 _wrap(ix0 + i - 1, w, ext), iy, ch)
        r += _cubic_weight(j, ty) * row
    return r


@njit(**INLINE)
def node_image(ins, reg, pt):
    """Image Texture: colour and alpha at the coordinate in reg[a], reg[a + 1]."""
    tex = pt.textures[ins[3]]
    x, y = reg[ins[2]], reg[ins[2] + 1]
    out = ins[1]
    alpha = image_channel(x, y, np.int64(3), pt.texels, tex)  # (not a literal: one compile)
    for ch in range(3):
        c = image_channel(x, y, ch, pt.texels, tex)
        if ins[4] != 0 and alpha != 1.0 and alpha != 0.0:
            c /= alpha
        reg[out + ch] = srgb_to_linear(c) if tex[5] != 0 else c
    reg[out + 3] = alpha


@njit(**JIT)
def box_weights(nx, ny, nz, blend):
    """The weights of the three faces of Cycles' box projection for the object-space
    normal n and the blend: one face near an axis, two or three mixed in between."""
    x, y, z = abs(nx), abs(ny), abs(nz)
    total = x + y + z
    if not total > 0.0:
        return 1.0, 0.0, 0.0
    x, y, z = x / total, y / total, z / total
    limit = 0.5 * (1.0 + blend)
    if x > limit * (x + y) and x > limit * (x + z):
        return 1.0, 0.0, 0.0
    if y > limit * (x + y) and y > limit * (y + z):
        return 0.0, 1.0, 0.0
    if z > limit * (x + z) and z > limit * (y + z):
        return 0.0, 0.0, 1.0
    if not blend > 0.0:
        return 1.0, 0.0, 0.0  # (Cycles' fallback to one side)
    if z < (1.0 - limit) * (x + y):
        w = min(max((x / (x + y) - 0.5 * (1.0 - blend)) / blend, 0.0), 1.0)
        return w, 1.0 - w, 0.0
    if x < (1.0 - limit) * (y + z):
        w = min(max((y / (y + z) - 0.5 * (1.0 - blend)) / blend, 0.0), 1.0)
        return 0.0, w, 1.0 - w
    if y < (1.0 - limit) * (x + z):
        w = min(max((x / (x + z) - 0.5 * (1.0 - blend)) / blend, 0.0), 1.0)
        return w, 0.0, 1.0 - w
    k = 2.0 * limit - 1.0
    return (((2.0 - limit) * x + (limit - 1.0)) / k, ((2.0 - limit) * y + (limit - 1.0)) / k,
            ((2.0 - limit) * z + (limit - 1.0)) / k)


@njit(**INLINE)
def node_box(ins, reg, params):
    """OP_BOX: the faces' weights and coordinates (d = 0), mapped so that no face's image
    is mirrored, as Cycles maps them; or the lookups' weighted sum (d = 1)."""
    a, b, out = ins[2], ins[3], ins[1]
    if ins[5] == 0:
        nx, ny, nz = reg[a], reg[a + 1], reg[a + 2]
        x, y, z = reg[b], reg[b + 1], reg[b + 2]
        reg[out], reg[out + 1], reg[out + 2] = box_weights(nx, ny, nz, params[ins[7]])
        reg[out + 3], reg[out + 4] = (1.0 - y if nx < 0.0 else y), z
        reg[out + 5], reg[out + 6] = (1.0 - x if ny > 0.0 else x), z
        reg[out + 7], reg[out + 8] = (1.0 - y if nz > 0.0 else y), x
        return
    for ch in range(4):
        reg[out + ch] = (reg[a] * reg[b + ch] + reg[a + 1] * reg[b + 4 + ch]
                         + reg[a + 2] * reg[b + 8 + ch])


@njit(**JIT)
def sphere_tube(kind, x, y, z):
    """(u, v) of the Sphere (kind 0) or Tube (1) projection of a coordinate in the 0..1
    box, remapped to -1..1 first (Cycles' texco_remap_square, map_to_sphere, map_to_tube)."""
    x, y, z = 2.0 * x - 1.0, 2.0 * y - 1.0, 2.0 * z - 1.0
    if kind == 0:
        length2 = x * x + y * y + z * z
        if not length2 > 0.0:
            return 0.0, 0.0
        u = 0.0 if x == 0.0 and y == 0.0 else 0.5 - math.atan2(x, y) / (2.0 * math.pi)
        return u, 1.0 - math.acos(min(max(z / math.sqrt(length2), -1.0), 1.0)) / math.pi
    length = math.sqrt(x * x + y * y)
    if not length > 0.0:
        return 0.0, 0.0
    return (1.0 - math.atan2(x / length, y / length) / math.pi) * 0.5, (z + 1.0) * 0.5


@njit(**JIT)
def equirectangular(x, y, z):
    """(u, v) of direction (x, y, z) on an equirectangular map (Cycles'
    direction_to_equirectangular): u = 0.5 - azimuth / 2 pi, v = 0.5 + elevation / pi (v = 0
    looks straight down); (0, 0) for the zero vector, as in Cycles."""
    if x == 0.0 and y == 0.0 and z == 0.0:
        return 0.0, 0.0
    return (0.5 - math.atan2(y, x) / (2.0 * np.pi),
            0.5 + math.atan2(z, math.hypot(x, y)) / np.pi)


@njit(**JIT)
def equirectangular_direction(u, v):
    """The unit direction at (u, v) of an equirectangular map (the inverse of
    `equirectangular`)."""
    azimuth = (0.5 - u) * 2.0 * np.pi
    elevation = (v - 0.5) * np.pi
    ce = math.cos(elevation)
    return ce * math.cos(azimuth), ce * math.sin(azimuth), math.sin(elevation)


@njit(**JIT)
def projection(kind, x, y, z):
    """(u, v) of a coordinate in projection `kind` (PROJECTIONS): Sphere and Tube of a
    point in the 0..1 box (sphere_tube); Equirectangular and Mirror Ball of a direction,
    normalised first (Cycles' svm_node_tex_environment, direction_to_mirrorball)."""
    if kind < 2:
        return sphere_tube(kind, x, y, z)
    length = math.sqrt(x * x + y * y + z * z)
    if length > 0.0:
        x, y, z = x / length, y / length, z / length
    if kind == 2:
        return equirectangular(x, y, z)
    y -= 1.0
    div = 2.0 * math.sqrt(max(-0.5 * y, 0.0))
    if div > 0.0:
        x, z = x / div, z / div
    return 0.5 * (x + 1.0), 0.5 * (z + 1.0)


@njit(**INLINE)
def node_uv(ins, reg, uv, f, u, v):
    """The hit's coordinates on map a (a UV map, w = 0, or a texture space), interpolated
    from the triangle's corners."""
    m = ins[2]
    w0 = 1.0 - u - v
    out = ins[1]
    for j in range(3):
        reg[out + j] = (w0 * np.float64(uv[m, f, 0, j]) + u * np.float64(uv[m, f, 1, j])
                        + v * np.float64(uv[m, f, 2, j]))


@njit(**JIT)
def node_wireframe(ins, reg, uv, f, u, v):
    """The Wireframe node at world-space size reg[b] (Cycles' wireframe: the squared
    distance to each edge, |edge x (P - corner)|^2 / |edge|^2, against (size / 2)^2)."""
    m, w0 = ins[2], 1.0 - u - v
    c = uv[m, f]
    px = w0 * np.float64(c[0, 0]) + u * np.float64(c[1, 0]) + v * np.float64(c[2, 0])
    py = w0 * np.float64(c[0, 1]) + u * np.float64(c[1, 1]) + v * np.float64(c[2, 1])
    pz = w0 * np.float64(c[0, 2]) + u * np.float64(c[1, 2]) + v * np.float64(c[2, 2])
    half = 0.5 * reg[ins[3]]
    reg[ins[1]] = 0.0
    for i in range(3):
        k = i - 1 if i > 0 else 2
        dx, dy, dz = px - c[i, 0], py - c[i, 1], pz - c[i, 2]
        ex, ey, ez = (np.float64(c[i, 0]) - c[k, 0], np.float64(c[i, 1]) - c[k, 1],
                      np.float64(c[i, 2]) - c[k, 2])
        cx, cy, cz = ey * dz - ez * dy, ez * dx - ex * dz, ex * dy - ey * dx
        if cx * cx + cy * cy + cz * cz < (ex * ex + ey * ey + ez * ez) * half * half:
            reg[ins[1]] = 1.0
            return


@njit(**INLINE)
def node_mapping(ins, reg, params):
    a, out, p = ins[2], ins[1], ins[7]
    x, y, z = reg[a], reg[a + 1], reg[a + 2]
    for j in range(3):
        q = p + 4 * j
        reg[out + j] = params[q] * x + params[q + 1] * y + params[q + 2] * z + params[q + 3]


@njit(**INLINE)
def node_transform(ins, reg):
    """One step of the Vector Transform node (OP_TRANSFORM): a vector through a frame,
    as Cycles' transform_point, transform_direction and, for a normal, the transposed
    transform normalised. A zero normal stays zero (Cycles' normalize would make NaN)."""
    a, b, c, out = ins[2], ins[3], ins[4], ins[1]
    x, y, z = reg[a], reg[a + 1], reg[a + 2]
    if ins[5] == 0:
        rx = x * reg[b] + y * reg[b + 3] + z * reg[b + 6]
        ry = x * reg[b + 1] + y * reg[b + 4] + z * reg[b + 7]
        rz = x * reg[b + 2] + y * reg[b + 5] + z * reg[b + 8]
        if c >= 0:
            rx, ry, rz = rx + reg[c], ry + reg[c + 1], rz + reg[c + 2]
    else:
        if c >= 0:
            x, y, z = x - reg[c], y - reg[c + 1], z - reg[c + 2]
        rx = x * reg[b] + y * reg[b + 1] + z * reg[b + 2]
        ry = x * reg[b + 3] + y * reg[b + 4] + z * reg[b + 5]
        rz = x * reg[b + 6] + y * reg[b + 7] + z * reg[b + 8]
    if ins[6] != 0:
        length = math.sqrt(rx * rx + ry * ry + rz * rz)
        if length > 0.0:
            rx, ry, rz = rx / length, ry / length, rz / length
    reg[out], reg[out + 1], reg[out + 2] = rx, ry, rz


@njit(**JIT)
def euler_rotation(x, y, z):
    """The rotation matrix (rows) of Euler angles x, y, z applied in XYZ order (Blender's
    default rotation mode; Cycles' euler_to_transform)."""
    cx, cy, cz = math.cos(x), math.cos(y), math.cos(z)
    sx, sy, sz = math.sin(x), math.sin(y), math.sin(z)
    return ((cy * cz, sy * sx * cz - cx * sz, sy * cx * cz + sx * sz),
            (cy * sz, sy * sx * sz + cx * cz, sy * cx * sz - sx * cz),
            (-sy, cy * sx, cy * cx))


@njit(**JIT)
def _safe_divide(a, b):
    return a / b if b != 0.0 else 0.0


@njit(**JIT)
def node_vector_mapping(ins, reg):
    """Cycles' Mapping node (svm_mapping) with every input a register: Point, rotate the
    scaled vector and move it; Texture, the inverse (a zero scale gives 0 on its axis);
    Vector, rotate the scaled vector; Normal, rotate the vector divided by the scale and
    normalise."""
    a, b, c, d, kind, out = ins[2], ins[3], ins[4], ins[5], ins[6], ins[1]
    m = euler_rotation(reg[c], reg[c + 1], reg[c + 2])
    if kind == 1:  # TEXTURE: R^T (v - location) / scale
        wx, wy, wz = reg[a] - reg[b], reg[a + 1] - reg[b + 1], reg[a + 2] - reg[b + 2]
        for j in range(3):
            reg[out + j] = _safe_divide(m[0][j] * wx + m[1][j] * wy + m[2][j] * wz,
                                        reg[d + j])
        return
    if kind == 3:  # NORMAL
        wx, wy, wz = (_safe_divide(reg[a], reg[d]), _safe_divide(reg[a + 1], reg[d + 1]),
                      _safe_divide(reg[a + 2], reg[d + 2]))
    else:
        wx, wy, wz = reg[a] * reg[d], reg[a + 1] * reg[d + 1], reg[a + 2] * reg[d + 2]
    x, y, z = (m[0][0] * wx + m[0][1] * wy + m[0][2] * wz,
               m[1][0] * wx + m[1][1] * wy + m[1][2] * wz,
               m[2][0] * wx + m[2][1] * wy + m[2][2] * wz)
    if kind == 0:  # POINT
        x, y, z = x + reg[b], y + reg[b + 1], z + reg[b + 2]
    elif kind == 3:
        x, y, z = _safe_normalize(x, y, z)
    reg[out], reg[out + 1], reg[out + 2] = x, y, z


@njit(**JIT)
def axis_rotation(x, y, z, ax, ay, az, angle):
    """(x, y, z) turned by `angle` about the unit axis a (Rodrigues; Cycles'
    rotate_around_axis)."""
    c, s = math.cos(angle), math.sin(angle)
    t = 1.0 - c
    return ((c + t * ax * ax) * x + (t * ax * ay - az * s) * y + (t * ax * az + ay * s) * z,
            (t * ax * ay + az * s) * x + (c + t * ay * ay) * y + (t * ay * az - ax * s) * z,
            (t * ax * az - ay * s) * x + (t * ay * az + ax * s) * y + (c + t * az * az) * z)


@njit(**JIT)
def node_vector_rotate(ins, reg, params):
    """Cycles' Vector Rotate (svm_node_vector_rotate): about the centre, by Euler XYZ angles
    (inverted: the transposed rotation) or by an angle about an axis (X, Y, Z or the Axis
    input normalised; inverted: the negated angle; a zero axis leaves the vector)."""
    a, b, kind, out, p = ins[2], ins[3], ins[5], ins[1], ins[7]
    invert = params[p] != 0.0
    x, y, z = reg[a] - reg[b], reg[a + 1] - reg[b + 1], reg[a + 2] - reg[b + 2]
    if kind == 4:  # EULER_XYZ
        e = int(params[p + 1])
        m = euler_rotation(reg[e], reg[e + 1], reg[e + 2])
        if invert:
            rx, ry, rz = (m[0][0] * x + m[1][0] * y + m[2][0] * z,
                          m[0][1] * x + m[1][1] * y + m[2][1] * z,
                          m[0][2] * x + m[1][2] * y + m[2][2] * z)
        else:
            rx, ry, rz = (m[0][0] * x + m[0][1] * y + m[0][2] * z,
                          m[1][0] * x + m[1][1] * y + m[1][2] * z,
                          m[2][0] * x + m[2][1] * y + m[2][2] * z)
    else:
        if kind == 0:
            ax, ay, az = reg[ins[4]], reg[ins[4] + 1], reg[ins[4] + 2]
        else:
            ax, ay, az = (1.0 if kind == 1 else 0.0, 1.0 if kind == 2 else 0.0,
                          1.0 if kind == 3 else 0.0)
        length = math.sqrt(ax * ax + ay * ay + az * az)
        if length == 0.0:
            reg[out], reg[out + 1], reg[out + 2] = reg[a], reg[a + 1], reg[a + 2]
            return
        angle = -reg[ins[6]] if invert else reg[ins[6]]
        rx, ry, rz = axis_rotation(x, y, z, ax / length, ay / length, az / length, angle)
    reg[out], reg[out + 1], reg[out + 2] = rx + reg[b], ry + reg[b + 1], rz + reg[b + 2]


@njit(**JIT)
def node_voronoi(ins, reg, params):
    """Cycles' Voronoi Texture (voronoi.voronoi): its five outputs side by side."""
    a, p, out = ins[2], ins[7], ins[1]
    dist, r, g, b, px, py, pz, pw, radius = voronoi.voronoi(
        np.int64(params[p + 7]), np.int64(params[p + 8]), np.int64(params[p + 9]),
        params[p + 10] != 0.0, reg[a], reg[a + 1], reg[a + 2], reg[ins[3]],
        reg[int(params[p])], reg[int(params[p + 1])], reg[int(params[p + 2])],
        reg[int(params[p + 3])], reg[int(params[p + 4])], reg[int(params[p + 5])],
        reg[int(params[p + 6])])
    reg[out], reg[out + 1], reg[out + 2], reg[out + 3] = r, g, b, dist
    reg[out + 4], reg[out + 5], reg[out + 6] = px, py, pz
    reg[out + 7], reg[out + 8] = pw, radius


@njit(**JIT)
def node_brick(ins, reg, params):
    """Cycles' Brick Texture (svm_node_tex_brick): the bricks' two colours mixed by each
    brick's tint, the mortar colour over them by the mortar factor."""
    a, p, out = ins[2], ins[7], ins[1]
    scale = reg[int(params[p])]
    tint, f = noise.brick(reg[a] * scale, reg[a + 1] * scale, reg[int(params[p + 1])],
                          reg[int(params[p + 2])], reg[int(params[p + 3])],
                          reg[int(params[p + 4])], reg[int(params[p + 5])], params[p + 6],
                          int(params[p + 7]), params[p + 8], int(params[p + 9]))
    for j in range(3):
        c = reg[ins[3] + j]
        if f != 1.0:
            c = (1.0 - tint) * c + tint * reg[ins[4] + j]
        reg[out + j] = c * (1.0 - f) + reg[ins[5] + j] * f
    reg[out + 3] = f


@njit(**JIT)
def node_view_coordinates(ins, reg):
    """The Geometry node's Normal, Incoming and Backfacing, and Texture Coordinate's
    outputs made from the hit's geometry or a view map's value: Reflection (Cycles'
    svm_texco_reflection: -reflect(wi, N) = 2 (N.wi) N - wi), Normal (the interpolated
    object-space normal normalised, negated on a back face as sd->N is) and Window (the
    homogeneous map divided through; Cycles' transform_perspective)."""
    op, a, out, g = ins[0], ins[2], ins[1], GEOMETRY
    if op == OP_GEOMETRY and ins[5] == 3:  # Cycles: cross(N, normalize(cross(t, N)))
        nx, ny, nz = reg[g], reg[g + 1], reg[g + 2]
        tx, ty, tz = reg[a], reg[a + 1], reg[a + 2]
        cx, cy, cz = _safe_normalize(ty * nz - tz * ny, tz * nx - tx * nz, tx * ny - ty * nx)
        reg[out], reg[out + 1], reg[out + 2] = ny * cz - nz * cy, nz * cx - nx * cz, \
            nx * cy - ny * cx
    elif op == OP_GEOMETRY:  # the normal, the view (3 registers) or the side (1)
        for j in range(3 if ins[5] < 2 else 1):
            reg[out + j] = reg[g + 3 * ins[5] + j]
    elif op == OP_REFLECTION:
        nx, ny, nz = reg[g], reg[g + 1], reg[g + 2]
        ix, iy, iz = reg[g + 3], reg[g + 4], reg[g + 5]
        d = 2.0 * (nx * ix + ny * iy + nz * iz)
        reg[out], reg[out + 1], reg[out + 2] = d * nx - ix, d * ny - iy, d * nz - iz
    elif op == OP_FACING:
        sign = -1.0 if reg[g + 6] != 0.0 else 1.0
        x, y, z = _safe_normalize(reg[a], reg[a + 1], reg[a + 2])
        reg[out], reg[out + 1], reg[out + 2] = sign * x, sign * y, sign * z
    else:  # OP_PROJECT
        w = reg[a + 2]
        reg[out] = reg[a] / w if w != 0.0 else 0.0
        reg[out + 1] = reg[a + 1] / w if w != 0.0 else 0.0
        reg[out + 2] = 0.0


@njit(**INLINE)
def node_checker(ins, reg):
    """Cycles' Checker Texture (kernel/svm/checker.h) at reg[a:a+3] with scale reg[d]."""
    a, s = ins[2], reg[ins[5]]
    # The nudge keeps faces at integer coordinates off a square's edge, as in Cycles.
    x = abs(int(math.floor((reg[a] * s + 0.000001) * 0.999999)))
    y = abs(int(math.floor((reg[a + 1] * s + 0.000001) * 0.999999)))
    z = abs(int(math.floor((reg[a + 2] * s + 0.000001) * 0.999999)))
    first = (1 if x % 2 == y % 2 else 0) == z % 2
    src = ins[3] if first else ins[4]
    out = ins[1]
    for j in range(3):
        reg[out + j] = reg[src + j]
    reg[out + 3] = 1.0 if first else 0.0


@njit(**JIT)
def node_noise(ins, reg, params):
    """Cycles' Noise Texture (noise.noise_texture) at the scaled vector and W."""
    a, p, out = ins[2], ins[7], ins[1]
    scale = reg[int(params[p])]
    value, g, b = noise.noise_texture(
        int(params[p + 7]), int(params[p + 8]), params[p + 9] != 0.0, reg[a] * scale,
        reg[a + 1] * scale, reg[a + 2] * scale, reg[ins[3]] * scale, reg[int(params[p + 1])],
        reg[int(params[p + 2])], reg[int(params[p + 3])], reg[int(params[p + 4])],
        reg[int(params[p + 5])], reg[int(params[p + 6])], ins[4] != 0)
    reg[out], reg[out + 1], reg[out + 2], reg[out + 3] = value, g, b, value


@njit(**JIT)
def node_wave(ins, reg, params):
    """Cycles' Wave Texture (noise.wave) at the vector times Scale."""
    a, p, out = ins[2], ins[7], ins[1]
    scale = reg[int(params[p])]
    f = noise.wave(int(params[p + 6]), int(params[p + 7]), int(params[p + 8]),
                   int(params[p + 9]), reg[a] * scale, reg[a + 1] * scale, reg[a + 2] * scale,
                   reg[int(params[p + 1])], reg[int(params[p + 2])], reg[int(params[p + 3])],
                   reg[int(params[p + 4])], reg[int(params[p + 5])])
    reg[out], reg[out + 1], reg[out + 2], reg[out + 3] = f, f, f, f


@njit(**JIT)
def ramp_lookup(params, p, n, f, j, interpolate, extrapolate):
    """Channel j of Cycles' rgb_ramp_lookup in the table of n RGBA entries at params[p:]
    at f: clamped to [0, 1] (NaN reads the first entry), linear between entries when
    `interpolate`; with `extrapolate`, outside [0, 1] the end entries' slope continues."""
    if extrapolate and (f < 0.0 or f > 1.0):
        if f < 0.0:
            t0, t1, f = params[p + j], params[p + 4 + j], -f
        else:
            t0, t1, f = params[p + 4 * (n - 1) + j], params[p + 4 * (n - 2) + j], f - 1.0
        return t0 + (t0 - t1) * f * (n - 1)
    f = min(max(f, 0.0), 1.0) * (n - 1) if math.isfinite(f) else 0.0
    i = min(max(int(f), 0), n - 1)
    t = f - i
    r = params[p + 4 * i + j]
    if interpolate and t > 0.0:
        r = (1.0 - t) * r + t * params[p + 4 * (i + 1) + j]
    return r


@njit(**INLINE)
def node_ramp(ins, reg, params):
    """Cycles' Color Ramp (svm_node_rgb_ramp): the table at the factor, linear between
    entries unless the ramp is Constant."""
    for j in range(4):
        reg[ins[1] + j] = ramp_lookup(params, ins[7], ins[3], reg[ins[2]], j, ins[4] != 0,
                                      np.bool_(False))


@njit(**JIT)
def node_curves(ins, reg, params):
    """Cycles' RGB Curves, Vector Curves (svm_node_curves: channel j of the table at the
    input's channel j) and Float Curve (svm_node_curve, one channel): the input's position
    in the curves' range [params[p], params[p+1]] looked up (extrapolated if the curves
    are), mixed with the input by the factor."""
    a, fac, n, out, p = ins[2], reg[ins[3]], ins[4], ins[1], ins[7]
    lo, hi = params[p], params[p + 1]
    for j in range(ins[6]):
        x = reg[a + j]
        y = ramp_lookup(params, p + 2, n, (x - lo) / (hi - lo) if hi != lo else 0.0, j,
                        np.bool_(True),
                        ins[5] != 0)
        reg[out + j] = (1.0 - fac) * x + fac * y


@njit(**JIT)
def clamp_range(x, lo, hi, swap):
    """x clamped to [lo, hi] (Cycles' clamp: min(max(x, lo), hi)); with `swap`, a range
    given high to low is turned round first (the Clamp node's Range type)."""
    if swap and lo > hi:
        lo, hi = hi, lo
    return min(max(x, lo), hi)


@njit(**JIT)
def node_map_range(ins, reg, params):
    """Cycles' Map Range (svm_node_map_range, svm_node_vector_map_range) per component:
    Linear, Stepped, Smooth Step and Smoother Step, the result clamped to the target range
    (Linear and Stepped, when asked). A float's empty source range gives 0, a vector's the
    target minimum (its safe division)."""
    p, out = ins[7], ins[1]
    steps_reg, kind, clamp, width = (int(params[p]), int(params[p + 1]), params[p + 2] != 0.0,
                                     int(params[p + 3]))
    for j in range(width):
        x, lo, hi = reg[ins[2] + j], reg[ins[3] + j], reg[ins[4] + j]
        to_lo, to_hi = reg[ins[5] + j], reg[ins[6] + j]
        t = (x - lo) / (hi - lo) if hi != lo else 0.0
        if kind == 1:  # STEPPED
            steps = reg[steps_reg + j]
            t = math.floor(t * (steps + 1.0)) / steps if steps > 0.0 else 0.0
        elif kind >= 2:
            t = min(max(t, 0.0), 1.0)
            t = t * t * (3.0 - 2.0 * t) if kind == 2 else t * t * t * (t * (t * 6.0 - 15.0)
                                                                       + 10.0)
        r = to_lo + t * (to_hi - to_lo) if hi != lo or width == 3 else 0.0
        # A float's clamp is a Clamp node after it (Cycles' MapRangeNode::expand), whatever
        # the type; a vector's applies to Linear and Stepped only.
        if clamp and (width == 1 or kind < 2):
            r = clamp_range(r, to_lo, to_hi, np.bool_(True))
        reg[out + j] = r


@njit(**JIT)
def rgb_to_hsv(r, g, b):
    """Cycles' rgb_to_hsv (util/color.h): hue in [0, 1)."""
    cmax = max(r, max(g, b))
    cdelta = cmax - min(r, min(g, b))
    s = cdelta / cmax if cmax != 0.0 else 0.0
    h = 0.0
    if s != 0.0:
        cr, cg, cb = (cmax - r) / cdelta, (cmax - g) / cdelta, (cmax - b) / cdelta
        if r == cmax:
            h = cb - cg
        elif g == cmax:
            h = 2.0 + cr - cb
        else:
            h = 4.0 + cg - cr
        h /= 6.0
        if h < 0.0:
            h += 1.0
    return h, s, cmax


@njit(**JIT)
def wavelength(nm, to_rgb):
    """The Wavelength node (svm_node_wavelength): the colour-matching functions at nm
    (linear between Cycles' 5 nm entries; black outside 380 .. 775), to the scene's linear
    RGB by `to_rgb` (9 floats, row-major: xyz_to_rgb), scaled by 1 / 2.52 so that no channel
    exceeds 1, negative channels 0."""
    ii = (nm - 380.0) / 5.0
    i = int(ii)  # (float_to_int truncates toward 0: -0.5 is entry 0, as in Cycles)
    if i < 0 or i >= 80:
        return 0.0, 0.0, 0.0
    t = ii - i
    lo, hi = CIE_COLOUR_MATCH[i], CIE_COLOUR_MATCH[i + 1]
    x, y, z = lo[0] + t * (hi[0] - lo[0]), lo[1] + t * (hi[1] - lo[1]), lo[2] + t * (hi[2] - lo[2])
    r, g, b = xyz_to_rgb(to_rgb, 0, x, y, z)
    return max(r / 2.52, 0.0), max(g / 2.52, 0.0), max(b / 2.52, 0.0)


@njit(**JIT)
def xyz_to_rgb(m, p, x, y, z):
    """CIE XYZ (x, y, z) in the scene's linear RGB by the matrix m[p:p+9] (row-major)."""
    return (m[p] * x + m[p + 1] * y + m[p + 2] * z, m[p + 3] * x + m[p + 4] * y + m[p + 5] * z,
            m[p + 6] * x + m[p + 7] * y + m[p + 8] * z)


@njit(**JIT)
def blackbody(t):
    """The Blackbody node's colour of temperature t (K) in linear Rec.709, negative
    channels 0 (Cycles' svm_node_blackbody; the fit leaves Rec.709's gamut at the ends)."""
    if t >= 12000.0:
        return 0.8262954810464208, 0.9945080501520986, 1.566307710274283
    if t < 800.0:
        return 5.413294490189271, 0.0, 0.0
    i = np.searchsorted(BLACKBODY_BANDS, t, side="right")
    r, g, b = BLACKBODY_R[i], BLACKBODY_G[i], BLACKBODY_B[i]
    return (max(r[0] / t + r[1] * t + r[2], 0.0), max(g[0] / t + g[1] * t + g[2], 0.0),
            max(((b[0] * t + b[1]) * t + b[2]) * t + b[3], 0.0))


@njit(**JIT)
def hsv_to_rgb(h, s, v):
    """Cycles' hsv_to_rgb (util/color.h)."""
    if s == 0.0:
        return v, v, v
    if h == 1.0:
        h = 0.0
    h *= 6.0
    i = math.floor(h)
    f = h - i
    p, q, t = v * (1.0 - s), v * (1.0 - s * f), v * (1.0 - s * (1.0 - f))
    if i == 0.0:
        return v, t, p
    if i == 1.0:
        return q, v, p
    if i == 2.0:
        return p, v, t
    if i == 3.0:
        return p, q, v
    if i == 4.0:
        return t, p, v
    return v, p, q


@njit(**JIT)
def rgb_to_hsl(r, g, b):
    """Cycles' rgb_to_hsl (util/color.h): hue in [0, 1), lightness at most 1."""
    cmax, cmin = max(r, max(g, b)), min(r, min(g, b))
    lum = min(1.0, (cmax + cmin) / 2.0)
    if cmax == cmin:
        return 0.0, 0.0, lum
    d = cmax - cmin
    s = d / (2.0 - cmax - cmin) if lum > 0.5 else d / (cmax + cmin)
    if cmax == r:
        h = (g - b) / d + (6.0 if g < b else 0.0)
    elif cmax == g:
        h = (b - r) / d + 2.0
    else:
        h = (r - g) / d + 4.0
    return h / 6.0, s, lum


@njit(**JIT)
def hsl_to_rgb(h, s, lum):
    """Cycles' hsl_to_rgb (util/color.h)."""
    nr = min(max(abs(h * 6.0 - 3.0) - 1.0, 0.0), 1.0)
    ng = min(max(2.0 - abs(h * 6.0 - 2.0), 0.0), 1.0)
    nb = min(max(2.0 - abs(h * 6.0 - 4.0), 0.0), 1.0)
    chroma = (1.0 - abs(2.0 * lum - 1.0)) * s
    return (nr - 0.5) * chroma + lum, (ng - 0.5) * chroma + lum, (nb - 0.5) * chroma + lum


@njit(**JIT)
def convert_colour(conversion, x, y, z):
    """Separate and Combine Color's modes (conversion: CONVERSIONS index)."""
    if conversion == 0:
        return rgb_to_hsv(x, y, z)
    if conversion == 1:
        return rgb_to_hsl(x, y, z)
    if conversion == 2:
        return hsv_to_rgb(x, y, z)
    return hsl_to_rgb(x, y, z)


@njit(**INLINE)
def node_hsv(ins, reg):
    """Cycles' Hue/Saturation/Value node (svm/hsv.h): hue shifted (0.5 keeps it),
    saturation scaled and clamped, value scaled, mixed with the input by the factor, and
    negative channels clamped."""
    a, out = ins[2], ins[1]
    r, g, b = reg[a], reg[a + 1], reg[a + 2]
    h, s, v = rgb_to_hsv(r, g, b)
    h += reg[ins[3]] + 0.5
    h -= math.floor(h)
    s = min(max(s * reg[ins[4]], 0.0), 1.0)
    nr, ng, nb = hsv_to_rgb(h, s, v * reg[ins[5]])
    fac = reg[ins[6]]
    reg[out] = max(fac * nr + (1.0 - fac) * r, 0.0)
    reg[out + 1] = max(fac * ng + (1.0 - fac) * g, 0.0)
    reg[out + 2] = max(fac * nb + (1.0 - fac) * b, 0.0)


@njit(**INLINE)
def node_colour_ops(ins, reg):
    """The colour adjustments: Mix (blend modes), Invert, Gamma, Bright/Contrast."""
    op, out, a, b, c = ins[0], ins[1], ins[2], ins[3], ins[4]
    if op == OP_BLEND:
        v0, v1, v2 = blend_colour(ins[5], reg[a], reg[b], reg[b + 1], reg[b + 2], reg[c],
                                  reg[c + 1], reg[c + 2])
        if ins[6] != 0:
            v0, v1, v2 = min(max(v0, 0.0), 1.0), min(max(v1, 0.0), 1.0), min(max(v2, 0.0), 1.0)
        reg[out], reg[out + 1], reg[out + 2] = v0, v1, v2
        return
    for j in range(3):
        if op == OP_INVERT:
            x = reg[b + j]
            reg[out + j] = (1.0 - reg[a]) * x + reg[a] * (1.0 - x)
        elif op == OP_GAMMA:
            x = reg[a + j]
            reg[out + j] = x ** reg[b] if x > 0.0 else x
        else:  # OP_BRIGHT_CONTRAST
            contrast = reg[c]
            reg[out + j] = max((1.0 + contrast) * reg[a + j] + reg[b] - contrast * 0.5, 0.0)


@njit(**JIT)
def node_sky(ins, reg, params):
    """The Sky Texture's steps (OP_SKY): the texture's coordinates and the sun's disc at
    the direction, then XYZ to RGB (the texture is read by OP_IMAGE between them); or the
    Preetham sky's XYZ."""
    out, a, p = ins[1], ins[2], ins[7]
    if ins[5] == 2:
        reg[out], reg[out + 1], reg[out + 2] = sky.preetham_xyz(reg[a], reg[a + 1],
                                                                reg[a + 2], params, p)
        return
    if ins[5] == 0:
        x, y, z = reg[a], reg[a + 1], reg[a + 2]
        reg[out], reg[out + 1] = sky.texture_coordinates(x, y, z, params[p + 1])
        reg[out + 2] = 0.0
        disc = (0.0, 0.0, 0.0) if reg[SKY_WITHOUT_SUN] != 0.0 else sky.sun_disc(
            x, y, z, params, p)
        reg[out + 3], reg[out + 4], reg[out + 5] = disc
        return
    b = ins[3]
    r, g, bl = xyz_to_rgb(params, p, reg[a] + reg[b], reg[a + 1] + reg[b + 1],
                          reg[a + 2] + reg[b + 2])
    reg[out], reg[out + 1], reg[out + 2] = max(r, 0.0), max(g, 0.0), max(bl, 0.0)


# The opcodes of the procedural textures, of the converters and of the nodes reading the
# hit's geometry: each group one function of its own (node_texture, node_converter,
# node_view_coordinates), keeping the interpreter short.
TEXTURE_OPS = (OP_CHECKER, OP_NOISE, OP_GRADIENT, OP_WAVE, OP_MAGIC, OP_WHITE_NOISE, OP_BRICK,
               OP_VORONOI, OP_SKY)
CONVERTER_OPS = (OP_VECTOR_MAPPING, OP_VECTOR_ROTATE, OP_CURVES, OP_MAP_RANGE, OP_CLAMP,
                 OP_BLACKBODY, OP_WAVELENGTH, OP_TRANSFORM, OP_BOX, OP_PROJECTION)
GEOMETRY_OPS = (OP_GEOMETRY, OP_REFLECTION, OP_FACING, OP_PROJECT)
# The opcodes reading the hit's normal (set_geometry's registers): a program without them
# reads the same value on the mesh's normal as on a displaced one.
NORMAL_OPS = (OP_GEOMETRY, OP_REFLECTION, OP_FRESNEL, OP_LAYER_WEIGHT)


def reads_normal(program: Program | None) -> bool:
    """Whether a program reads the hit's normal (NORMAL_OPS)."""
    return program is not None and any(ins[0] in NORMAL_OPS for ins in program.code)


@njit(**JIT)
def node_texture(ins, reg, params):
    """The procedural textures: Color in reg[out:out+3], Fac in reg[out+3]."""
    op, out, a = ins[0], ins[1], ins[2]
    if op == OP_CHECKER:
        node_checker(ins, reg)
    elif op == OP_NOISE:
        node_noise(ins, reg, params)
    elif op == OP_GRADIENT:
        g = noise.gradient(ins[5], reg[a], reg[a + 1], reg[a + 2])
        reg[out], reg[out + 1], reg[out + 2], reg[out + 3] = g, g, g, g
    elif op == OP_WAVE:
        node_wave(ins, reg, params)
    elif op == OP_MAGIC:
        r, g, b = noise.magic(reg[a], reg[a + 1], reg[a + 2], reg[ins[3]], ins[5], reg[ins[4]])
        reg[out], reg[out + 1], reg[out + 2] = r, g, b
        reg[out + 3] = (r + g + b) / 3.0
    elif op == OP_WHITE_NOISE:
        r, g, b = noise.white_noise(ins[5], reg[a], reg[a + 1], reg[a + 2], reg[ins[3]])
        reg[out], reg[out + 1], reg[out + 2], reg[out + 3] = r, g, b, r
    elif op == OP_VORONOI:
        node_voronoi(ins, reg, params)
    elif op == OP_SKY:
        node_sky(ins, reg, params)
    else:
        node_brick(ins, reg, params)


@njit(**JIT)
def node_converter(ins, reg, params):
    """Mapping, Vector Rotate, the Curves, Map Range, Clamp, Blackbody, Wavelength,
    Vector Transform and the Image Texture's projections."""
    op = ins[0]
    if op == OP_VECTOR_MAPPING:
        node_vector_mapping(ins, reg)
    elif op == OP_VECTOR_ROTATE:
        node_vector_rotate(ins, reg, params)
    elif op == OP_CURVES:
        node_curves(ins, reg, params)
    elif op == OP_MAP_RANGE:
        node_map_range(ins, reg, params)
    elif op == OP_BLACKBODY:
        reg[ins[1]], reg[ins[1] + 1], reg[ins[1] + 2] = blackbody(reg[ins[2]])
    elif op == OP_WAVELENGTH:
        reg[ins[1]], reg[ins[1] + 1], reg[ins[1] + 2] = wavelength(
            reg[ins[2]], params[ins[7]:ins[7] + 9])
    elif op == OP_TRANSFORM:
        node_transform(ins, reg)
    elif op == OP_BOX:
        node_box(ins, reg, params)
    elif op == OP_PROJECTION:
        reg[ins[1]], reg[ins[1] + 1] = projection(ins[5], reg[ins[2]], reg[ins[2] + 1],
                                                  reg[ins[2] + 2])
        reg[ins[1] + 2] = 0.0
    else:
        reg[ins[1]] = clamp_range(reg[ins[2]], reg[ins[3]], reg[ins[4]], ins[5] != 0)


@njit(**JIT)
def run(first, end, pt, uv, f, u, v, reg):
    """Execute instructions first..end-1 of the ProgramTable pt at the hit (triangle f,
    barycentrics u, v) in the register file reg. Called, not inlined: a kernel evaluates
    programs in five places, and five inlined copies of the interpreter cost minutes of
    compile time."""
    for k in range(first, end):
        ins = pt.code[k]
        op, out = ins[0], ins[1]
        if op == OP_CONST:
            for j in range(ins[4]):
                reg[out + j] = pt.params[ins[7] + j]
        elif op == OP_UV:
            node_uv(ins, reg, uv, f, u, v)
        elif op == OP_WIREFRAME:
            node_wireframe(ins, reg, uv, f, u, v)
        elif op == OP_MAPPING:
            node_mapping(ins, reg, pt.params)
        elif op == OP_IMAGE:
            node_image(ins, reg, pt)
        elif op == OP_LERP:
            for j in range(ins[5]):
                t = reg[ins[2] + j] if ins[6] != 0 else reg[ins[2]]
                reg[out + j] = (1.0 - t) * reg[ins[3] + j] + t * reg[ins[4] + j]
        elif op == OP_MATH:
            r = math_op(ins[5], reg[ins[2]], reg[ins[3]], reg[ins[4]])
            reg[out] = min(max(r, 0.0), 1.0) if ins[6] != 0 else r
        elif op == OP_LUMINANCE:
            reg[out] = (LUMINANCE[0] * reg[ins[2]] + LUMINANCE[1] * reg[ins[2] + 1]
                        + LUMINANCE[2] * reg[ins[2] + 2])
        elif op == OP_AVERAGE:
            reg[out] = (reg[ins[2]] + reg[ins[2] + 1] + reg[ins[2] + 2]) / 3.0
        elif op == OP_COMBINE:
            reg[out], reg[out + 1], reg[out + 2] = reg[ins[2]], reg[ins[3]], reg[ins[4]]
        elif op == OP_RAMP:
            node_ramp(ins, reg, pt.params)
        elif op == OP_HSV:
            node_hsv(ins, reg)
        elif op == OP_VECTOR_MATH:
            node_vector_math(ins, reg)
        elif op == OP_FRESNEL:
            node_fresnel(ins, reg)
        elif op == OP_LAYER_WEIGHT:
            node_layer_weight(ins, reg)
        elif op in TEXTURE_OPS:
            node_texture(ins, reg, pt.params)
        elif op in CONVERTER_OPS:
            node_converter(ins, reg, pt.params)
        elif op in GEOMETRY_OPS:
            node_view_coordinates(ins, reg)
        elif op == OP_LIGHT_PATH:
            reg[out] = reg[LIGHT_PATH + ins[5]]
        elif op == OP_COLOUR_SPACE:
            a = ins[2]
            reg[out], reg[out + 1], reg[out + 2] = convert_colour(ins[5], reg[a], reg[a + 1],
                                                                  reg[a + 2])
        else:
            node_colour_ops(ins, reg)


@njit(**INLINE)
def colour_at(mat, f, u, v, pt, uv, reg, c0, c1, c2):
    """Material mat's colour at the hit: its colour program's result or the constant c."""
    return result_at(pt.colour, mat, f, u, v, pt, uv, reg, c0, c1, c2)


@njit(**INLINE)
def emission_at(mat, f, u, v, pt, uv, reg, c0, c1, c2):
    """Material mat's emitted radiance at the hit: its emission program's result or c."""
    return result_at(pt.emission, mat, f, u, v, pt, uv, reg, c0, c1, c2)


@njit(**INLINE)
def normal_at(mat, f, u, v, pt, uv, reg, c0, c1, c2):
    """The colour feeding material mat's Normal Map node at the hit, or c without one."""
    return result_at(pt.normal, mat, f, u, v, pt, uv, reg, c0, c1, c2)


@njit(**INLINE)
def tint_at(mat, f, u, v, pt, uv, reg, c0, c1, c2):
    """Material mat's Specular Tint (a coat's mix: its Coat Tint) at the hit: its tint
    program's result (negative channels 0) or the constant c."""
    return result_at(pt.tint, mat, f, u, v, pt, uv, reg, c0, c1, c2)


@njit(**INLINE)
def fac_at(mat, f, u, v, pt, uv, reg, fac):
    """Mix mat's factor at the hit: its factor program's first channel in [0, 1], or fac."""
    r, _, _ = result_at(pt.fac, mat, f, u, v, pt, uv, reg, fac, fac, fac)
    return min(r, 1.0)


@njit(**INLINE)
def roughness_at(mat, f, u, v, pt, uv, reg, r):
    """Material mat's roughness at the hit: its roughness program's first channel in
    [0, 1] (Cycles clamps it), or r where the roughness is constant."""
    x, _, _ = result_at(pt.roughness, mat, f, u, v, pt, uv, reg, r, r, r)
    return min(x, 1.0)


@njit(**INLINE)
def diffuse_roughness_at(mat, f, u, v, pt, uv, reg, r):
    """Material mat's Diffuse Roughness at the hit: its program's first channel in [0, 1],
    or r where it is constant."""
    x, _, _ = result_at(pt.diffuse_roughness, mat, f, u, v, pt, uv, reg, r, r, r)
    return min(x, 1.0)


@njit(**INLINE)
def pair_at(slot, mat, f, u, v, pt, uv, reg, a, b):
    """A pair of material mat's inputs at the hit, e.g. its IOR and Specular IOR Level, its
    Thin Film Thickness and IOR, its anisotropy and rotation: the first two channels of its
    program in slot (one of pt's, e.g. pt.thin_film; negative values kept), or the
    constants (a, b) where it has none."""
    if slot[mat, 0] < 0:
        return a, b
    x, y, _ = raw_result_at(slot, mat, f, u, v, pt, uv, reg)
    return x, y


@njit(**INLINE)
def tangent_at(mat, f, u, v, pt, uv, reg):
    """Material mat's tangent at the hit (its tangent program's result, a vector), or 0."""
    if pt.tangent[mat, 0] < 0:
        return 0.0, 0.0, 0.0
    return raw_result_at(pt.tangent, mat, f, u, v, pt, uv, reg)


@njit(**JIT)
def normal_map(cx, cy, cz, tx, ty, tz, sign, nx, ny, nz):
    """Cycles' tangent-space Normal Map node (svm_node_normal_map): colour c in [0, 1]
    read as 2c - 1 on the frame of the interpolated tangent t, B = sign (n x t) and the
    mesh's front-side normal n (all unnormalised, as interpolated). Returns the unit
    normal, or n itself where the result degenerates."""
    ax, ay, az = 2.0 * cx - 1.0, 2.0 * cy - 1.0, 2.0 * cz - 1.0
    bx, by, bz = (sign * (ny * tz - nz * ty), sign * (nz * tx - nx * tz),
                  sign * (nx * ty - ny * tx))
    x = ax * tx + ay * bx + az * nx
    y = ax * ty + ay * by + az * ny
    z = ax * tz + ay * bz + az * nz
    length = math.sqrt(x * x + y * y + z * z)
    if not (length > 0.0 and math.isfinite(length)):
        length = math.sqrt(nx * nx + ny * ny + nz * nz)
        return nx / length, ny / length, nz / length
    return x / length, y / length, z / length


@njit(**INLINE)
def perturbs_normal(pt, mat):
    """Whether material mat tilts its shading normal: a Normal Map node's colour or a Bump
    node's height program."""
    return pt.normal[mat, 0] >= 0 or pt.height[mat, 0] >= 0


# The barycentric step over which a Bump node's height is differentiated. Cycles steps a
# tenth of the pixel footprint (the node's Filter Width); in the limit both are the height's
# surface gradient, which a step this small reaches for any smooth height (1e-5 of an edge
# is a hundredth of a texel of a 1024-texel image on a two-triangle plane) while float64
# keeps the difference quotient's rounding near 1e-11.
BUMP_STEP = 1e-5


@njit(**INLINE)
def height_at(mat, f, u, v, pt, uv, reg):
    """Material mat's bump program at barycentrics (u, v) of triangle f: (Distance x
    Height, Strength), unclamped (a height may be negative); non-finite values are 0."""
    h, strength, _ = raw_result_at(pt.height, mat, f, u, v, pt, uv, reg)
    return h, strength


@njit(**JIT)
def bump_normal(nx, ny, nz, ex, ey, ez, fx, fy, fz, dh_e, dh_f, strength):
    """Cycles' Bump node (svm_node_set_bump; Mikkelsen 2010, "Bump Mapping Unparameterized
    Surfaces on the GPU"): the unit normal n tilted by the surface gradient of a height
    whose derivatives along the surface vectors e and f are dh_e and dh_f (Distance
    included, negated by Invert), blended toward n by the strength (>= 0); n itself where
    the tilted normal degenerates. The result does not depend on which e, f span the
    surface: surfgrad / det is the gradient."""
    rx, ry, rz = fy * nz - fz * ny, fz * nx - fx * nz, fx * ny - fy * nx  # f x n
    qx, qy, qz = ny * ez - nz * ey, nz * ex - nx * ez, nx * ey - ny * ex  # n x e
    det = ex * rx + ey * ry + ez * rz
    s = 1.0 if det > 0.0 else (-1.0 if det < 0.0 else 0.0)
    ax = abs(det) * nx - s * (dh_e * rx + dh_f * qx)
    ay = abs(det) * ny - s * (dh_e * ry + dh_f * qy)
    az = abs(det) * nz - s * (dh_e * rz + dh_f * qz)
    length = math.sqrt(ax * ax + ay * ay + az * az)
    if not (length > 0.0 and math.isfinite(length)):
        return nx, ny, nz
    strength = max(strength, 0.0)
    ax = strength * ax / length + (1.0 - strength) * nx
    ay = strength * ay / length + (1.0 - strength) * ny
    az = strength * az / length + (1.0 - strength) * nz
    length = math.sqrt(ax * ax + ay * ay + az * az)
    if not (length > 0.0 and math.isfinite(length)):
        return nx, ny, nz
    return ax / length, ay / length, az / length


@njit(**INLINE)
def raw_result_at(rows, mat, f, u, v, pt, uv, reg):
    """The three result registers of program rows[mat] (which must exist) run at the hit
    (triangle f, barycentrics u, v); non-finite channels are 0, negative ones kept."""
    # f as int64 whatever array it came from: an int32 triangle index compiled the whole
    # interpreter a second time.
    run(rows[mat, 0], rows[mat, 1], pt, uv, np.int64(f), u, v, reg)
    o = rows[mat, 2]
    r0, r1, r2 = reg[o], reg[o + 1], reg[o + 2]
    return (r0 if math.isfinite(r0) else 0.0, r1 if math.isfinite(r1) else 0.0,
            r2 if math.isfinite(r2) else 0.0)


@njit(**INLINE)
def result_at(rows, mat, f, u, v, pt, uv, reg, c0, c1, c2):
    """The result of program rows[mat] (pt.colour, .emission or .normal) at the hit (triangle f,
    barycentrics u, v; negative or non-finite channels are 0, as Cycles clamps closure
    weights), or the constant c0, c1, c2 where the material has no such program."""
    if rows[mat, 0] < 0:
        return c0, c1, c2
    r0, r1, r2 = raw_result_at(rows, mat, f, u, v, pt, uv, reg)
    return (r0 if r0 > 0.0 else 0.0, r1 if r1 > 0.0 else 0.0, r2 if r2 > 0.0 else 0.0)


def evaluate(program: Program, uv=(0.0, 0.0), normal=(0.0, 0.0, 1.0), incoming=(0.0, 0.0, 1.0),
             backfacing=False, light_path=(0, 0.0, 0, 0, 0, 0, 0)):
    """Run a program outside the kernel (tests, constant folding): the registers after it
    ran at coordinates `uv` (u, v or u, v, w) on every map, at a hit of that shading
    normal, direction toward the viewer and side, by a path of that state (flags, ray
    length, depth, diffuse, glossy, transparent and transmission depth)."""
    pt = pack([program], None, lambda name: 0)
    w = uv[2] if len(uv) > 2 else 0.0
    corners = np.broadcast_to(np.asarray([[uv[0], uv[1], w]] * 3, np.float32),
                              (max(len(program.uv_maps), 1), 1, 3, 3)).copy()
    reg = np.zeros(MAX_REGISTERS)
    set_geometry(reg, *normal, *incoming, backfacing)
    set_light_path(reg, *light_path)
    run(0, len(pt.code), pt, corners, 0, 0.0, 0.0, reg)
    return reg

"""Blender materials -> Specula material descriptions.

The core understands Lambert diffuse, perfect mirror, smooth metal, smooth and rough glass,
rough Glossy, the dielectric Principled BSDF, Transparent, emission and mixes of these (see
engine/scene.py `Material`). This module reads a material's Cycles output and maps the
nodes it knows onto those; anything else becomes a documented fallback with a warning that names the
material, the node and the input, so nothing renders silently black and no fallback
changes what kind of thing an object is (a surface never becomes a light, a volume never
becomes an opaque wall).

Fallbacks:
  * no node tree (before 5.0): diffuse of the material's viewport colour (`diffuse_color`),
    as Cycles; no Cycles output / nothing linked to Surface: black, no light passing (Cycles'
    empty closure), warned; but nothing on Surface and something on Volume: an invisible
    boundary (crossed by paths and shadow rays, counted as Cycles
    counts volume bounds) around the volume's medium.
  * Volume: its medium fills the mesh (absorption, Henyey-Greenstein scattering and
    emission of Volume Absorption, Volume Scatter, Principled Volume, Volume
    Coefficients and Emission, added and mixed); other volume shaders warned, ignored.
  * Displacement linked beside a Surface: a bump (the material's Displacement Method Bump
    Only, Cycles' default); Displacement Only and Both would move the mesh: warned.
  * Diffuse BSDF: Lambert, or Oren-Nayar (Cycles' improved model) at Roughness > 0.
  * Beckmann (and Ashikhmin-Shirley) distributions: GGX.
  * Principled BSDF: metal (x Metallic), glass (x (1 - Metallic) x Transmission Weight)
    and a Lambert base under a GGX dielectric layer (the rest), mixed as Cycles mixes them
    (a mix of shaders where two or more weigh > 0), and Alpha < 1 (or textured) mixes in
    transparent white; a Coat Weight > 0 (or textured) lays Cycles' coat over the lobes,
    and a Sheen Weight > 0 (or textured) Cycles' microfiber sheen over that.
    Specular Tint bends the metal's F82 Fresnel and scales the dielectric and glass
    Fresnel's F0 (Cycles' generalized Schlick); Thin Film puts Cycles' thin-film
    interference on the Fresnel of the dielectric, glass and metal lobes. Inputs Specula
    does not render (Subsurface) warn when used; Diffuse Roughness makes the base
    Oren-Nayar.
  * Sheen BSDF: Cycles' microfiber sheen (Ashikhmin rendered as microfiber, warned).
  * Metallic BSDF: the Principled BSDF's F82 metal (Base Color, Edge Tint, Thin Film); a
    Physical Conductor as Cycles' F82 fit of its IOR and Extinction (warned with its
    deviation; its Thin Film warned and left out).
  * Mix Shader (Fac constant or textured) and Add Shader: a mix of their two shaders.
  * Refraction BSDF: refraction only, without Fresnel (Beckmann rendered as GGX, warned).
  * any other shader node (Toon, Hair, ...): diffuse of its 'Color' / 'Base Color'
    input, or grey 0.8.
  * an input driven by other nodes (textures): the constant the chain reduces to (see
    `_Constants`: an image's mean colour in scene-linear space, RGB / Value / Math / Mix /
    Separate Color ... applied to such constants), warned when approximate. A chain that cannot
    be reduced uses the input's own value, except the Principled BSDF's emission, which is
    then off: a hidden white default must not turn a textured surface into a light.
"""

import dataclasses
import math
import os
from dataclasses import dataclass, field

import bpy
import numpy as np

from . import core, shader_nodes
from .shader_nodes import COLOUR_SPACES, enabled_input, live_link

DEFAULT_GREY = (0.8, 0.8, 0.8)
# Cycles treats roughness below this as a perfect delta lobe (alpha = r^2 <= 2e-10 there).
ROUGHNESS_EPSILON = 1e-5
# Cycles clamps a BSDF's IOR to at least this (svm_node_closure_bsdf's fmaxf(ior, 1e-5f)):
# near 0 a glass is a mirror but for rays at normal incidence, not another material.
MIN_IOR = 1e-5
GLOSSY_NODES = ("ShaderNodeBsdfGlossy", "ShaderNodeBsdfAnisotropic")
# Colour -> float socket conversion: luminance with the Rec.709 coefficients of Blender's
# default configuration (what Cycles' `linear_rgb_to_gray` uses there).
LUMINANCE = (0.2126, 0.7152, 0.0722)
# Image means are taken over at most about this many texels per side (a strided subsample):
# a 4k texture's mean does not need all 16M texels.
MEAN_SIDE = 512
# The Principled BSDF's inputs Specula does not render yet: (input, the value at which it has
# no effect, what is rendered instead). Used (linked, or unlinked at another value) -> warning.
PRINCIPLED_IGNORED = (
    ("Subsurface Weight", 0.0, "rendered without subsurface scattering"),
)
# Material Output inputs beside Surface that Specula ignores, with what that means.
OUTPUT_IGNORED = (("Thickness", "thickness is not used"),)
# Leaves whose look does not depend on the shading normal.
UNSHADED = ("transparent", "emission_only", "boundary", "holdout")


def _layered(spec) -> bool:
    """Whether a sheen or coat lies over part of `spec` (it dims the emission below it)."""
    return any(p.ctor == "mix" and ("coat_ior" in p.kwargs or p.kwargs.get("sheen_layer"))
               for p in spec.parts())


def _leaf_emission(spec) -> np.ndarray:
    """The constant emission (3,) of a spec that is not a mix."""
    if spec.ctor == "emission_only":
        return spec.kwargs.get("strength", 1.0) * np.asarray(spec.kwargs.get("colour", (1,) * 3),
                                                             np.float64)
    return np.asarray(spec.kwargs.get("emission", (0.0,) * 3), np.float64)


@dataclass(frozen=True)
class MaterialSpec:
    """A core `Material` constructor call: `getattr(Material, ctor)(name, **kwargs)`."""

    ctor: str
    name: str
    kwargs: dict = field(default_factory=dict)

    def parts(self):
        """This spec and, for a mix, every spec below it."""
        yield self
        if self.ctor == "mix":
            for part in (self.kwargs["first"], self.kwargs["second"]):
                yield from part.parts()

    def leaves(self):
        """This spec, or a mix's component specs, recursively."""
        return (part for part in self.parts() if part.ctor != "mix")

    @property
    def normal_uv(self):
        """The UV map of the normal maps below this spec (one per material), or None."""
        return next((leaf.kwargs["normal_uv"] for leaf in self.leaves()
                     if leaf.kwargs.get("normal_program") is not None), None)

    def to_core(self, core):
        if self.ctor == "mix":
            k = self.kwargs
            m = core.Material.mix(self.name, k["first"].to_core(core),
                                  k["second"].to_core(core), k["fac"], k["scale"],
                                  k.get("fac_program"))
            extra = {key: tuple(k[key]) for key in ("emission", "coat_tint") if key in k}
            extra.update({key: k[key] for key in MEDIUM_KEYS if key in k})
            if "coat_ior" in k:
                extra["coat_ior"] = float(k["coat_ior"])
            if k.get("sheen_layer"):
                extra["sheen_layer"] = True
            for key in ("emission_program", "tint_program", "height_program", "sets_normal"):
                if key in k:
                    extra[key] = k[key]
            return dataclasses.replace(m, **extra) if extra else m
        kwargs = dict(self.kwargs)
        kwargs.pop("normal_uv", None)
        normal = {k: kwargs.pop(k) for k in ("normal_program", "normal_strength",
                                             "height_program", "sets_normal", *MEDIUM_KEYS)
                  if k in kwargs}
        anisotropy = {k: kwargs.pop(k) for k in ANISOTROPY_KEYS if k in kwargs}
        m = getattr(core.Material, self.ctor)(self.name, **kwargs)
        if anisotropy:  # (a Glossy BSDF at zero roughness is a mirror: it ignores them)
            m = m.with_anisotropy(**anisotropy)
        return dataclasses.replace(m, **normal) if normal else m


def _factors_read_normal(spec):
    """Whether a mix's factor or one below it reads the hit's normal: only then does its
    choice need the displaced normal (a bump costs three height evaluations per hit), for
    the kernel reads every factor below a mix on the normal set for it."""
    return any(core.load().shading.reads_normal(part.kwargs.get("fac_program"))
               for part in spec.parts() if part.ctor == "mix")


# The MaterialSpec keywords of a material's medium (its Volume: scene.Material's fields).
MEDIUM_KEYS = ("absorption", "scattering", "anisotropy", "volume_emission")
NO_MEDIUM = {"absorption": (0.0, 0.0, 0.0), "scattering": (0.0, 0.0, 0.0), "anisotropy": 0.0,
             "volume_emission": (0.0, 0.0, 0.0)}


def _is_medium(medium):
    """Whether medium keywords (MEDIUM_KEYS) describe anything: absorption, scattering or
    emission."""
    return medium is not None and any(max(medium[k]) > 0 for k in ("absorption", "scattering",
                                                                     "volume_emission"))


# The MaterialSpec keywords holding shader programs (a mix's factor among them): a material
# with one reads UV maps.
PROGRAM_KEYS = ("colour_program", "emission_program", "normal_program", "fac_program",
                "roughness_program", "height_program", "tint_program",
                "diffuse_roughness_program", "anisotropy_program", "tangent_program",
                "specular_ior_program", "thin_film_program")
# The MaterialSpec keywords of an anisotropic GGX lobe (scene.Material.with_anisotropy).
ANISOTROPY_KEYS = ("specular_anisotropy", "anisotropic_rotation", "tangent_program",
                   "anisotropy_program")


# The volume shaders: on a Surface they make no closure (Cycles' svm_node_closure_volume
# returns outside a volume).
VOLUME_SHADERS = ("ShaderNodeVolumeAbsorption", "ShaderNodeVolumeScatter",
                  "ShaderNodeVolumePrincipled", "ShaderNodeVolumeCoefficients")


def no_shader(name):
    """Cycles' empty closure: black, and no light passes (an unlinked shader input)."""
    return MaterialSpec("emission_only", name, {"colour": (0.0, 0.0, 0.0), "strength": 0.0})


def _is_no_shader(spec):
    """Whether `spec` adds nothing: an emission of nothing (an Add Shader leaves it out)."""
    return spec.ctor == "emission_only" and "emission_program" not in spec.kwargs and (
        spec.kwargs["strength"] <= 0.0 or max(spec.kwargs["colour"]) <= 0.0)


def holdout(name):
    """Cycles' Holdout: a hole in the image (alpha 0) where the camera sees it."""
    return MaterialSpec("holdout", name, {})


def _held_out(spec):
    """What a camera ray sees of `spec` on a holdout object: Cycles keeps its transparent
    closures and makes the rest one holdout (surface_shader_apply_holdout). A part with no
    Transparent BSDF below it is a holdout; a mix keeps its factor over its parts held out.
    None where a coat or sheen layer lies over transparency (not a plain mix)."""
    if not any(p.ctor == "transparent" for p in spec.parts()):
        return holdout(spec.name)
    if spec.ctor != "mix":
        return spec
    k = spec.kwargs
    if "coat_ior" in k or k.get("sheen_layer"):
        return None
    first, second = _held_out(k["first"]), _held_out(k["second"])
    if first is None or second is None:
        return None
    kept = {key: k[key] for key in ("fac", "scale", "fac_program") if key in k}
    return MaterialSpec("mix", spec.name, {"first": first, "second": second, **kept})


def camera_holdout(spec, obj_name):
    """(The spec of `spec` on the object `obj_name` marked Holdout, [warnings]): held out
    (_held_out) to camera rays and `spec` to every other ray, as Cycles'
    SD_OBJECT_HOLDOUT_MASK acts on camera paths only (integrate_surface_holdout), so the
    object still shadows, reflects and lights the rest. A mix of the two by the Light
    Path's Is Camera Ray; an emission is the mix's own, by the same factor (none to the
    camera)."""
    sh = core.load().shading
    fac = sh.Program()
    camera = fac.emit(sh.OP_LIGHT_PATH, 1, d=sh.LIGHT_PATH_OUTPUTS.index("Is Camera Ray"))
    fac.out = fac.emit(sh.OP_COMBINE, 3, a=camera, b=camera, c=camera)
    warnings = []
    held = _held_out(spec)
    if held is None:
        warnings.append(f"object '{obj_name}' is a holdout: the transparency under the coat "
                        f"or sheen of its material '{spec.name}' is not kept (Cycles keeps "
                        f"it)")
        held = holdout(spec.name)
    kwargs = {"first": spec, "second": held, "fac": 0.0, "scale": 1.0, "fac_program": fac,
              # The medium inside is the triangle's material's, the mix's as a whole.
              **{key: spec.kwargs[key] for key in MEDIUM_KEYS if key in spec.kwargs}}
    emission = _leaf_emission(spec) if spec.ctor != "mix" else np.zeros(3)
    if spec.ctor == "mix" and any(max(_leaf_emission(leaf)) > 0 or
                                  leaf.kwargs.get("emission_program") is not None
                                  for leaf in spec.parts()) \
            or spec.kwargs.get("emission_program") is not None:
        warnings.append(f"object '{obj_name}' is a holdout: the emission of its material "
                        f"'{spec.name}' is not held out from the camera (a mixed or "
                        f"textured emission)")
    elif max(emission) > 0:
        spec = MaterialSpec(spec.ctor, spec.name, {k: v for k, v in spec.kwargs.items()
                                                   if k not in ("emission", "strength")})
        if spec.ctor == "emission_only":
            spec.kwargs["strength"] = 0.0
        kwargs["first"] = spec
        kwargs["emission"] = tuple(float(e) for e in emission)
        kwargs["emission_program"] = shader_nodes.mixed_by(fac, emission, (0.0, 0.0, 0.0))
    return MaterialSpec("mix", spec.name, kwargs), warnings


def default_material():
    return MaterialSpec("diffuse", "Specula default", {"colour": DEFAULT_GREY})


def _with(program, key="colour_program"):
    """The keyword of an input's shader program (a colour's, by default), when it has one."""
    return {} if program is None else {key: program}


def _give_normal_map(spec, normal_map):
    """A shader's normal map (MaterialSpec keywords, or None) on every leaf of its spec
    without one of its own (a coat's lobe has its Coat Normal's, or none: normal_program
    None)."""
    if normal_map is None:
        return
    for leaf in spec.leaves():
        if "normal_program" not in leaf.kwargs:
            leaf.kwargs.update(normal_map)


def invisible_boundary(name, medium=None):
    """What a Volume-only material renders as: no surface (paths and shadow rays cross it
    as Cycles crosses a volume's boundary) around its medium (MEDIUM_KEYS keywords)."""
    return MaterialSpec("boundary", name, dict(NO_MEDIUM if medium is None else medium))


def transparent(name, colour=(1.0, 1.0, 1.0)):
    """Cycles' Transparent BSDF: what passes straight through, tinted."""
    return MaterialSpec("transparent", name, {"colour": tuple(colour)})


def _past_reroutes(link):
    """The link that reaches a node other than a reroute through `link`, or None where the
    reroutes lead nowhere (or `link` is None)."""
    while link is not None and link.from_node.bl_idname == "NodeReroute":
        link = live_link(link.from_node.inputs[0])
    return link


def _rgb(value):
    return tuple(float(c) for c in tuple(value)[:3])


def _fmt(value):
    if isinstance(value, tuple):
        return "(" + ", ".join(f"{c:.3g}" for c in value) + ")"
    return f"{value:.3g}"


def _label(node):
    return node.bl_label or node.bl_idname


def _own_value(socket):
    """The socket's unlinked value: float for scalars, (r, g, b) / (x, y, z) otherwise."""
    v = getattr(socket, "default_value", None)
    if v is None:
        return None
    try:
        return _rgb(v) if socket.type in ("RGBA", "VECTOR") else float(v)
    except (TypeError, ValueError):  # strings, menus, rotations: nothing Specula reduces
        return None


def _convert(value, from_type, to_type):
    """Blender's implicit socket conversions: float <-> colour / vector, colour -> float by
    luminance, vector -> float by the component average."""
    scalar = to_type in ("VALUE", "INT", "BOOLEAN")
    if not isinstance(value, tuple):
        return float(value) if scalar else (float(value),) * 3
    if not scalar:
        return value
    if from_type == "RGBA":
        return sum(w * c for w, c in zip(LUMINANCE, value))
    return sum(value) / 3.0


# ---- Image means -----------------------------------------------------------------------------
# `Image.pixels` holds byte images as their stored 8-bit values / 255, still encoded in the
# image's colour space (an sRGB 128 reads 0.502, not 0.216), and float images as the
# scene-linear buffer Blender decoded on loading (a 16-bit sRGB PNG's 0.5 reads 0.214; as
# Non-Color, 0.5): read back in bpy 5.0.1. Byte texels are decoded one by one, since the
# transfer function is not linear; the primaries are, so they convert the mean.

def image_mean(image, alpha_weighted):
    """Mean of what an Image Texture node outputs for `image`, in scene-linear space.

    Returns ((r, g, b), alpha, notes), or None when the image has no pixels (a missing
    file). The colour follows Cycles' Image Texture: with its Alpha output linked the Color
    output is straight (unassociated) colour, and since that alpha usually cuts the surface
    away where it is 0, the mean is weighted by alpha (the colour of what is seen); with
    Alpha unlinked the Color output is premultiplied by alpha (images whose alpha mode is
    Straight or Premultiplied) or the plain colour (Channel Packed, None, Non-Color data).
    """
    width, height = image.size
    count = len(image.pixels) if width * height else 0  # reading the length loads the image
    if count == 0:
        return None
    channels = count // (width * height)
    px = np.empty(count, np.float32)
    image.pixels.foreach_get(px)
    step = max(1, -(-max(width, height) // MEAN_SIDE))
    px = px.reshape(height, width, channels)[::step, ::step].reshape(-1, channels)
    px = px.astype(np.float64)
    rgb = px[:, :3] if channels >= 3 else np.repeat(px[:, :1], 3, axis=1)
    mode = image.alpha_mode
    alpha = px[:, 3] if channels >= 4 and mode != "NONE" else np.ones(len(px))
    # Blender keeps float buffers premultiplied, byte buffers as the file stores them.
    if mode in ("STRAIGHT", "PREMUL") and (image.is_float or mode == "PREMUL"):
        rgb = np.divide(rgb, alpha[:, None], out=np.zeros_like(rgb), where=alpha[:, None] > 0)
    notes = [f"the mean of image '{image.name}'"]
    space = image.colorspace_settings
    to_scene = None
    if not image.is_float and not space.is_data:
        known = space.name in COLOUR_SPACES
        transfer, to_scene = COLOUR_SPACES[space.name if known else "sRGB"]
        if not known:
            notes.append(f"its colour space '{space.name}' decoded as sRGB")
        if transfer is not None:
            rgb = transfer(rgb)
    associated = mode in ("STRAIGHT", "PREMUL") and not space.is_data
    if alpha_weighted and alpha.sum() > 0:
        mean = (rgb * alpha[:, None]).sum(axis=0) / alpha.sum()
    elif associated:
        mean = (rgb * alpha[:, None]).mean(axis=0)
    else:
        mean = rgb.mean(axis=0)
    mean = tuple(float(c) for c in mean)
    if to_scene is not None:
        mean = tuple(max(float(c), 0.0) for c in to_scene(mean))
    return mean, float(alpha.mean()), notes


# ---- Constant folding of node chains ----------------------------------------------------------
# Until Specula has textures, a linked input is reduced to one constant. One small function per
# node kind (as Cycles' SVM has one per node), each `f(k, node, out)` -> the value of output
# socket `out` (float, or an (r, g, b) / (x, y, z) tuple) or None when it cannot be reduced;
# `k` is the `_Constants` evaluating the chain. A later issue with real textures replaces this
# table. Linear nodes (Mix, Multiply, Separate Color ...) applied to means give exact means;
# non-linear ones (Power, Color Ramp ...) applied to means are approximations.

def _c_value(k, node, out):
    return _own_value(node.outputs[0])


def _c_reroute(k, node, out):
    return k.input(node.inputs[0])


def _c_light_falloff(k, node, out):
    """Light Falloff's Quadratic output without Smooth is its Strength whatever the ray's
    length (a light's node tree sets its strength so); the rest vary with it."""
    smooth = k.input(node.inputs["Smooth"])
    if out.name == "Quadratic" and smooth is not None and float(_convert(
            smooth, "VALUE", "VALUE")) <= 0.0:
        return k.input(node.inputs["Strength"])
    k.notes.append(f"node '{node.name}' ({_label(node)}) output {out.name} varies with the "
                   f"ray's length")
    return None


def _c_object_info(k, node, out):
    """Object Info's Material Index, the material's pass index; its other outputs vary."""
    return float(shader_nodes.MATERIAL_PASS_INDEX.get()) if out.name == "Material Index" \
        else None


def _c_attribute(k, node, out):
    """An Attribute node of type View Layer, a constant of the render; other types vary."""
    return shader_nodes.view_layer_attribute(node, out) \
        if node.attribute_type == "VIEW_LAYER" else None


def _c_image(k, node, out):
    image = node.image
    if image is None:
        k.notes.append(f"node '{node.name}' has no image")
        return None
    weighted = out.name == "Color" and node.outputs["Alpha"].is_linked
    stats = k.image_stats(image, weighted)
    if stats is None:
        k.notes.append(f"image '{image.name}' has no pixels")
        return None
    colour, alpha, notes = stats
    k.notes.extend(notes)
    return alpha if out.name == "Alpha" else colour


def _c_checker(k, node, out):
    # The checker's two colours cover equal areas: its means are their mean and Fac 0.5.
    c1, c2 = k.input(enabled_input(node, "Color1")), k.input(enabled_input(node, "Color2"))
    if out.name != "Fac" and (c1 is None or c2 is None):
        return None
    k.notes.append(f"the mean of checker '{node.name}'")
    return 0.5 if out.name == "Fac" else tuple(0.5 * (a + b) for a, b in zip(c1, c2))


def _blend(blend_type, t, c1, c2):
    """Cycles' colour Mix of two constant colours (the core's formula, shading.blend)."""
    sh = core.load().shading
    return sh.blend_colour(sh.BLENDS.index(blend_type), t, *c1, *c2)


def _mix(k, node, t, a, b, blend_type, clamp):
    """Shared by Mix and the legacy MixRGB: an operand that cannot be reduced (a Color
    Attribute, say) is left out, keeping the other one, the best constant at hand."""
    if a is None or b is None:
        if a is None and b is None:
            return None
        k.notes.append(f"node '{node.name}' ({_label(node)}) reduced to its one constant input")
        return a if b is None else b
    if t is None:
        t = 0.5
        k.notes.append(f"node '{node.name}' factor taken as 0.5")
    if not isinstance(a, tuple):
        return (1 - t) * a + t * b
    if blend_type not in core.load().shading.BLENDS:
        k.notes.append(f"node '{node.name}' blend {blend_type} taken as Mix")
        blend_type = "MIX"
    if isinstance(t, tuple):  # non-uniform vector factor
        out = tuple((1 - f) * x + f * y for f, x, y in zip(t, a, b))
    else:
        out = _blend(blend_type, t, a, b)
    return tuple(min(max(c, 0.0), 1.0) for c in out) if clamp else out


def _c_mix(k, node, out):
    t = k.input(enabled_input(node, "Factor"))
    if t is not None and node.clamp_factor:
        t = tuple(min(max(f, 0.0), 1.0) for f in t) if isinstance(t, tuple) \
            else min(max(t, 0.0), 1.0)
    colour = node.data_type == "RGBA"
    return _mix(k, node, t, k.input(enabled_input(node, "A")),
                k.input(enabled_input(node, "B")), node.blend_type if colour else "MIX",
                colour and node.clamp_result)


def _c_mix_rgb(k, node, out):
    t = k.input(node.inputs[0])
    t = None if t is None else min(max(t, 0.0), 1.0)
    return _mix(k, node, t, k.input(node.inputs[1]), k.input(node.inputs[2]),
                node.blend_type, node.use_clamp)


def _c_separate(k, node, out):
    """Separate Color / RGB / XYZ: one channel of the mean is the mean of that channel
    (after Cycles' conversion to HSV or HSL, which is not linear: approximate)."""
    c = k.input(node.inputs[0])
    if c is None:
        return None
    mode = getattr(node, "mode", "RGB")
    if mode != "RGB":
        sh = core.load().shading
        c = sh.convert_colour(sh.CONVERSIONS.index(f"RGB_TO_{mode}"), *c)
    return c[[s.identifier for s in node.outputs].index(out.identifier) % 3]


def _c_combine(k, node, out):
    c = [k.input(s) for s in node.inputs[:3]]
    if any(v is None for v in c):
        return None
    mode = getattr(node, "mode", "RGB")
    if mode != "RGB":
        sh = core.load().shading
        return tuple(sh.convert_colour(sh.CONVERSIONS.index(f"{mode}_TO_RGB"), *c))
    return tuple(c)


def _c_invert(k, node, out):
    t, c = k.input(node.inputs[0]), k.input(node.inputs[1])
    if t is None or c is None:
        return None
    return tuple((1 - t) * x + t * (1 - x) for x in c)


def _c_gamma(k, node, out):
    c, g = k.input(node.inputs[0]), k.input(node.inputs[1])
    if c is None or g is None:
        return None
    return tuple(x ** g if x > 0 else x for x in c)


def _c_bright_contrast(k, node, out):
    c, bright, contrast = (k.input(s) for s in node.inputs[:3])
    if c is None or bright is None or contrast is None:
        return None
    a, b = 1 + contrast, bright - contrast * 0.5
    return tuple(max(a * x + b, 0.0) for x in c)


def _c_color_ramp(k, node, out):
    t = k.input(node.inputs[0])
    if t is None:
        return None
    rgba = tuple(node.color_ramp.evaluate(min(max(t, 0.0), 1.0)))
    return rgba[3] if out.name == "Alpha" else rgba[:3]


def _c_math(k, node, out):
    sh = core.load().shading
    args = [k.input(s) for s in node.inputs if s.enabled]
    if node.operation not in sh.MATHS or any(v is None for v in args):
        return None
    v = sh.math_op(sh.MATHS.index(node.operation), *(args + [0.0, 0.0])[:3])
    return min(max(v, 0.0), 1.0) if node.use_clamp else v


def _c_vector_math(k, node, out):
    """Vector Math on constants, by the kernel's own node function."""
    sh = core.load().shading
    a, b, c, scale = (k.input(s) for s in node.inputs[:4])
    if node.operation not in sh.VECTOR_MATHS or any(v is None for v in (a, b, c, scale)):
        return None
    reg = np.zeros(14)
    reg[0:3], reg[3:6], reg[6:9], reg[9] = a, b, c, scale
    sh.node_vector_math(np.array([sh.OP_VECTOR_MATH, 10, 0, 3, 6,
                                  sh.VECTOR_MATHS.index(node.operation), 9, 0], np.int64), reg)
    return float(reg[13]) if out.name == "Value" else tuple(float(x) for x in reg[10:13])


NODE_CONSTANTS = {
    "NodeReroute": _c_reroute,
    "ShaderNodeLightFalloff": _c_light_falloff,
    "ShaderNodeObjectInfo": _c_object_info,
    "ShaderNodeAttribute": _c_attribute,
    "ShaderNodeRGB": _c_value,
    "ShaderNodeValue": _c_value,
    "ShaderNodeTexImage": _c_image,
    "ShaderNodeTexChecker": _c_checker,
    "ShaderNodeMix": _c_mix,
    "ShaderNodeMixRGB": _c_mix_rgb,
    "ShaderNodeSeparateColor": _c_separate,
    "ShaderNodeSeparateRGB": _c_separate,
    "ShaderNodeSeparateXYZ": _c_separate,
    "ShaderNodeCombineColor": _c_combine,
    "ShaderNodeCombineRGB": _c_combine,
    "ShaderNodeCombineXYZ": _c_combine,
    "ShaderNodeInvert": _c_invert,
    "ShaderNodeGamma": _c_gamma,
    "ShaderNodeBrightContrast": _c_bright_contrast,
    "ShaderNodeValToRGB": _c_color_ramp,
    "ShaderNodeMath": _c_math,
    "ShaderNodeVectorMath": _c_vector_math,
}
# Node trees are acyclic, but a chain this deep is not worth folding.
MAX_CHAIN_DEPTH = 64


class _Constants:
    """Reduces the node chain behind a socket to one constant; `notes` lists the
    approximations made (empty: the constant is exact, e.g. an RGB node)."""

    def __init__(self, image_cache):
        self.image_cache = image_cache
        self.notes = []
        self.depth = 0

    def image_stats(self, image, alpha_weighted):
        key = (image.as_pointer(), alpha_weighted)
        if key not in self.image_cache:
            self.image_cache[key] = image_mean(image, alpha_weighted)
        return self.image_cache[key]

    def input(self, socket):
        """Value of an input socket: its own, or its chain's constant converted to its type."""
        if socket is None:
            return None
        link = live_link(socket)
        if link is None:
            return _own_value(socket)
        v = self.output(link.from_socket)
        return None if v is None else _convert(v, link.from_socket.type, socket.type)

    def output(self, out):
        node = out.node
        if self.depth > MAX_CHAIN_DEPTH:
            return None
        self.depth += 1
        try:
            if node.mute:
                # A muted node passes its matching input through (Blender's internal links).
                through = next((k.from_socket for k in node.internal_links
                                if k.to_socket == out), None)
                return None if through is None else self.input(through)
            fn = NODE_CONSTANTS.get(node.bl_idname)
            if fn is not None:
                return fn(self, node, out)
            v = self.folded(node, out)
            return v if v is not None else self.pass_through(node, out)
        except (ArithmeticError, ValueError):  # e.g. Power overflowing: not a usable constant
            self.notes.append(f"node '{node.name}' ({_label(node)}) has no finite value")
            return None
        finally:
            self.depth -= 1

    def folded(self, node, out):
        """A node the kernel evaluates (Map Range, Curves ...) on inputs that do not vary:
        its program run once, so the constant is exact and the kernel's own functions make
        it. None for a node that reads the surface, or one no program can hold."""
        if node.bl_idname not in shader_nodes.NODES or node.bl_idname in shader_nodes.VARYING \
                or any(shader_nodes.varies(s) for s in node.inputs if s.enabled):
            return None
        compiler = shader_nodes.Compiler({})
        try:
            reg, kind = compiler.output(out)
        except shader_nodes.Unsupported:
            return None
        compiler.program.out = reg
        values = core.load().shading.evaluate(compiler.program)
        if shader_nodes.WIDTHS.get(kind) == 3:
            return tuple(float(x) for x in values[reg:reg + 3])
        return float(values[reg])

    def pass_through(self, node, out):
        """An unknown node that adjusts a linked input of its output's type (Hue/Saturation,
        RGB Curves, a node group ...) is approximated by that input: the best constant
        at hand. Nodes without such an input (Color Attribute, Noise, Fresnel ...) give None."""
        for s in node.inputs:
            if s.enabled and s.type == out.type and live_link(s) is not None:
                v = self.input(s)
                if v is not None:
                    self.notes.append(f"node '{node.name}' ({_label(node)}) taken as its input "
                                      f"'{s.name}'")
                    return v
        return None


class _Reader:
    """Reads one material (or a world's volume: `label` "world"), collecting warnings that
    name it."""

    def __init__(self, material, image_cache=None, label="material"):
        self.material = material
        self.label = label
        self.warnings = []
        self.constants = _Constants({} if image_cache is None else image_cache)
        self.normal_map = None  # set by normal(): the shader's tangent-space normal map
        # id(emission program) -> its recipe (shader_nodes.compile_emission), so that a mix
        # or an Alpha over it can compile it again, within its own
        self.emission_sources = {}

    def note_view_layer_attributes(self, tree, seen=None):
        """Warn of each linked Attribute node of type View Layer (in the tree or its groups)
        whose property the render's view layer, scene and world lack: it reads 0, as in
        Cycles, which says nothing."""
        owners = shader_nodes.RENDER_LAYER.get()
        seen = set() if seen is None else seen
        if not owners or tree is None or tree.as_pointer() in seen:
            return
        seen.add(tree.as_pointer())
        for node in tree.nodes:
            if node.bl_idname == "ShaderNodeGroup":
                self.note_view_layer_attributes(node.node_tree, seen)
            elif node.bl_idname == "ShaderNodeAttribute" and \
                    node.attribute_type == "VIEW_LAYER" and \
                    any(o.is_linked for o in node.outputs) and \
                    shader_nodes.id_property(owners, node.attribute_name) is None:
                self.warn(f"Attribute node '{node.name}' reads '{node.attribute_name}', "
                          f"which the view layer, scene and world do not hold as a number "
                          f"or 1-4 numbers: it reads 0")

    def warn(self, text):
        """Record a warning once (a Principled BSDF's lobes read the same inputs)."""
        text = f"{self.label} '{self.material.name}': {text}"
        if text not in self.warnings:
            self.warnings.append(text)

    def value(self, node, socket_name, default=None, unknown=None):
        """Value of `node`'s input `socket_name`: its own when unlinked, else the constant its
        node chain reduces to (warned when approximate). A chain that cannot be reduced
        gives `unknown`, or the input's own value when `unknown` is None (warned)."""
        sock = enabled_input(node, socket_name)
        if sock is None:
            return default
        link = live_link(sock)
        if link is None:
            return _own_value(sock)
        src = link.from_node
        where = (f"node '{node.name}' input '{socket_name}' is driven by node '{src.name}' "
                 f"({_label(src)})")
        self.constants.notes = []
        v = self.constants.input(sock)
        notes = self.constants.notes
        if v is None:
            used = _own_value(sock) if unknown is None else unknown
            why = "the input's own value" if unknown is None else "instead of the input's own " \
                f"value {_fmt(_own_value(sock))}"
            detail = f" ({'; '.join(notes)})" if notes else ""
            self.warn(f"{where}, which Specula cannot reduce to a constant{detail}; using "
                      f"{_fmt(used)}, {why}")
            return used
        if notes:
            self.warn(f"{where}, which Specula approximates by the constant {_fmt(v)}: "
                      f"{', '.join(notes)}")
        return v

    def colour(self, node, socket_name, default=DEFAULT_GREY, unknown=None):
        """A colour input; a chain's negative or non-finite components are 0 (the core takes
        no negative colours; Cycles clamps closure colours at 0 too)."""
        v = self.value(node, socket_name, None, unknown)
        if v is None:
            return default
        return tuple(c if math.isfinite(c) and c > 0 else 0.0
                     for c in _rgb(_convert(v, "VALUE", "RGBA")))

    def textured_colour(self, node, socket_name, default=DEFAULT_GREY, unknown=None,
                        emission=False):
        """A colour input that may vary over the surface: (the constant standing for it where
        one is needed, e.g. its image's mean; its shader program, or None when it is one
        constant or its chain does not compile, which is warned). An `emission` cannot
        depend on the view (Fresnel, Layer Weight)."""
        sock = enabled_input(node, socket_name)
        program, why = (None, "") if sock is None else \
            shader_nodes.compile_colour(sock, self.constants.image_cache, not emission)
        if program is None:
            warned = len(self.warnings)
            colour = self.colour(node, socket_name, default, unknown)
            if why and len(self.warnings) > warned:  # say why the constant stands in
                self.warnings[-1] += f"; it cannot be evaluated per point: {why} is not " \
                    "supported yet"
            elif why:
                self.warn(f"node '{node.name}' input '{socket_name}' varies over the surface "
                          f"through {why}, which Specula does not evaluate per point yet")
            return colour, None
        warned = len(self.warnings)
        colour = self.colour(node, socket_name, default, unknown)
        del self.warnings[warned:]  # the constant only stands in; the program is exact
        return colour, program

    def emission(self, node, colour_socket, strength_socket, default_strength, unknown_colour,
                 unknown_strength):
        """An emission's colour and strength: (the colour's and the strength's constants,
        e.g. their means; the program of their product where either varies, or None). A
        chain that cannot be reduced takes `unknown_*` (None: the socket's own value)."""
        strength, strength_program = self.textured_colour(
            node, strength_socket, (default_strength,) * 3,
            unknown=None if unknown_strength is None else (unknown_strength,) * 3,
            emission=True)
        strength = strength[0]
        if not strength > 0:
            return (0.0, 0.0, 0.0), 0.0, None
        colour, colour_program = self.textured_colour(node, colour_socket, (1.0, 1.0, 1.0),
                                                      unknown=unknown_colour, emission=True)
        if (colour_program is None and strength_program is None) or not max(colour) > 0:
            return colour, strength, None
        source = ("product", enabled_input(node, colour_socket),
                  enabled_input(node, strength_socket))
        if strength_program is None:
            program = shader_nodes.scaled(colour_program, strength)
        else:
            program, why = shader_nodes.compile_emission(source, self.constants.image_cache)
            if program is None:
                self.warn(f"node '{node.name}': its emission cannot be evaluated per point "
                          f"({why}); rendered as its constant")
                return colour, strength, None
        self.emission_sources[id(program)] = source
        return colour, strength, program

    def number(self, node, socket_name, default=0.0, unknown=None):
        v = self.value(node, socket_name, None, unknown)
        v = None if v is None else float(_convert(v, "RGBA", "VALUE"))
        return default if v is None or not math.isfinite(v) else v

    def unit(self, node, socket_name, default=0.0):
        """A weight or roughness, clamped to [0, 1] as Cycles clamps them."""
        return min(max(self.number(node, socket_name, default), 0.0), 1.0)

    def ignored(self, node, socket_name, neutral, rendered):
        """Warn when an input Specula does not render is used: linked, or set away from the
        value at which it has no effect."""
        sock = enabled_input(node, socket_name)
        if sock is None:
            return
        link = live_link(sock)
        own = _own_value(sock)
        if link is not None and isinstance(link.from_node, shader_nodes.GroupValue):
            link, own = None, _own_value(link.from_socket)  # a group's input left unlinked
        if link is not None:
            self.warn(f"node '{node.name}' input '{socket_name}' is driven by node "
                      f"'{link.from_node.name}' ({_label(link.from_node)}), which Specula does "
                      f"not support; {rendered}")
            return
        if neutral is not None and own is not None and \
                np.max(np.abs(np.subtract(own, neutral))) > 1e-6:
            self.warn(f"node '{node.name}' input '{socket_name}' {_fmt(own)} is not supported; "
                      f"{rendered}")

    def normal(self, node):
        """The shader's Normal input into self.normal_map (normal_map_of)."""
        normal_map = self.normal_map_of(node, "Normal")
        if normal_map is not None:
            self.normal_map = normal_map

    def normal_map_of(self, node, socket_name):
        """A normal input (Normal, Coat Normal): a tangent-space Normal Map node is compiled
        (its colour as a program, its strength and UV map, as MaterialSpec keywords), a
        Bump node too (bump_of); anything else there is warned and the mesh's normals are
        used (None)."""
        sock = enabled_input(node, socket_name)
        link = None if sock is None else live_link(sock)
        src = None if link is None else link.from_node
        if src is not None and src.bl_idname == "ShaderNodeBump":
            return self.bump_of(src)
        if src is not None and src.bl_idname == "ShaderNodeNormalMap" and \
                src.space == "TANGENT":
            colour, program = self.textured_colour(src, "Color", (0.5, 0.5, 1.0))
            if program is None:
                program = shader_nodes.constant(colour)
            strength = self.number(src, "Strength", 1.0)
            if not strength >= 0.0:
                self.warn(f"node '{src.name}' strength {strength:.3g} is negative; using 0")
                strength = 0.0
            return {"normal_program": program, "normal_strength": strength,
                    "normal_uv": src.uv_map}
        if src is not None and src.bl_idname == "ShaderNodeNormalMap":
            self.warn(f"node '{src.name}' space {src.space} is not supported (only Tangent "
                      f"Space); rendered with the mesh's normals")
            return None
        self.ignored(node, socket_name, None, "rendered with the mesh's normals")
        return None

    def bump_of(self, node):
        """A Bump node as MaterialSpec keywords: its height program (shader_nodes.
        compile_bump) over its Normal input's normal map, or over the mesh's normals. A
        height that does not vary leaves the normal as it is, as in Cycles; one that does
        not compile is warned and left out, as is a Bump under this one."""
        below = self.normal_map_of(node, "Normal") or {"normal_program": None}
        if below.pop("height_program", None) is not None:
            inner = live_link(enabled_input(node, "Normal")).from_node
            self.warn(f"node '{inner.name}' (Bump) on the Normal of node '{node.name}' (Bump) "
                      f"is not supported; only '{node.name}' is rendered")
        program, why = shader_nodes.compile_bump(node, self.constants.image_cache)
        if program is None and why:
            self.warn(f"node '{node.name}' (Bump) input 'Height' varies through {why}, which "
                      f"Specula does not evaluate per point yet; rendered without the bump")
        return below if program is None else {**below, "height_program": program}

    def no_surface(self, why):
        """A node tree giving the surface no shader renders black, and no light passes, as
        Cycles renders it (measured: an unlinked Surface, no Material Output)."""
        self.warn(f"{why}; rendered black, as Cycles renders it (no shader)")
        return no_shader(self.material.name)

    def read(self):
        mat = self.material
        tree = mat.node_tree
        # Specular lobes always tilt smooth normals to keep reflections above the surface
        # (bsdf.valid_specular_normal), Cycles' default for a material.
        if not getattr(getattr(mat, "cycles", None), "use_bump_map_correction", True):
            self.warn("Settings > Bump Map Correction off is not supported; rendered on")
        # Before 5.0 a material could keep a node tree while use_nodes is off.
        uses_nodes = tree is not None and (bpy.app.version >= (5, 0) or mat.use_nodes)
        if not uses_nodes:
            return MaterialSpec("diffuse", mat.name, {"colour": _rgb(mat.diffuse_color)})
        self.note_view_layer_attributes(tree)
        out = tree.get_output_node('CYCLES')
        if out is None:
            return self.no_surface("no active Material Output node for Cycles")
        surface = out.inputs.get("Surface")
        link = None if surface is None else live_link(surface)
        volume = out.inputs.get("Volume")
        volume_link = None if volume is None else live_link(volume)
        medium = None if volume_link is None else self.volume(volume_link)
        if link is None and volume_link is not None:
            # A Volume-only material (smoke, fog, an absorbing liquid) has no surface: a
            # boundary light and shadow rays cross unchanged, around the medium (Cycles).
            return invisible_boundary(mat.name, medium)
        if link is None:
            return self.no_surface(f"nothing is linked to '{out.name}' Surface")
        for socket_name, meaning in OUTPUT_IGNORED:
            sock = out.inputs.get(socket_name)
            ignored = None if sock is None else live_link(sock)
            if ignored is not None:
                src = ignored.from_node
                self.warn(f"'{out.name}' input '{socket_name}' is driven by node '{src.name}' "
                          f"({_label(src)}), which Specula ignores: {meaning}")
        source = _past_reroutes(link)
        if source is None:
            return self.no_surface(f"a reroute before '{out.name}' Surface leads nowhere")
        spec = self.shader(source.from_node)
        _give_normal_map(spec, self.normal_map)
        self.displacement(out, spec)
        if _is_medium(medium):
            spec.kwargs.update(medium)
        return spec

    def displacement(self, out, spec):
        """The Material Output's Displacement, as Cycles renders the material's Displacement
        Method Bump Only (its default): a bump (shader_nodes.compile_displacement) that
        sets the normal every closure without a normal of its own starts from; a closure's
        tangent-space Normal Map does not read it (Cycles' neither). The bumped normal is
        the surface's own (sets_normal): bump shadowing is measured from it (Cycles'
        SetNormal; beside a normal-mapped closure Specula measures from the mesh's).
        Displacement Only and Displacement and Bump move the mesh, which Specula does not
        (warned)."""
        sock = out.inputs.get("Displacement")
        link = None if sock is None else live_link(sock)
        if link is None:
            return
        method = getattr(self.material, "displacement_method", "BUMP")
        where = f"'{out.name}' input 'Displacement' (node '{link.from_node.name}')"
        if method != "BUMP":
            self.warn(f"{where}: displacement method {method} moves the mesh, which Specula "
                      f"does not; rendered " + ("without it" if method == "DISPLACEMENT" else
                                                "as Bump Only"))
            if method == "DISPLACEMENT":
                return
        program, why = shader_nodes.compile_displacement(sock, self.constants.image_cache)
        if program is None:
            if why:
                self.warn(f"{where} varies through {why}, which Specula does not evaluate "
                          f"per point yet; rendered without it")
            return
        for part in spec.parts():  # a mix's factor reads the displaced normal too
            if part.ctor == "mix" and _factors_read_normal(part):
                part.kwargs.update(height_program=program, sets_normal=True)
        self.warn_mesh_normal_coordinates(spec, where)
        for leaf in spec.leaves():
            if leaf.kwargs.get("normal_program") is not None or leaf.ctor in UNSHADED:
                continue  # a normal map's frame is the mesh's
            if leaf.kwargs.get("height_program") is not None:
                self.warn(f"{where}: a Bump node over the displaced normal is not supported; "
                          f"the Bump node's shader is rendered without the displacement")
                continue
            leaf.kwargs.update(height_program=program, sets_normal=True)
            leaf.kwargs.setdefault("normal_program", None)

    def warn_mesh_normal_coordinates(self, spec, where):
        """Warn where a displaced material's programs read the Texture Coordinate node's
        Normal: Specula's is the mesh's normal in object space, Cycles' the displaced one
        (its object-space normal of the shading normal SetNormal leaves)."""
        normal = core.load().shading.NORMAL
        if not any(normal in program.uv_maps for part in spec.parts()
                   for program in (part.kwargs.get(k) for k in PROGRAM_KEYS)
                   if program is not None):
            return
        nodes = sorted(n.name for n in self.material.node_tree.nodes
                       if n.bl_idname == "ShaderNodeTexCoord" and n.outputs["Normal"].is_linked)
        named = f" (node {', '.join(repr(n) for n in nodes)})" if nodes else ""
        self.warn(f"{where}: the Texture Coordinate's Normal{named} reads the mesh's normal "
                  f"under the displacement, not the displaced one; rendered so")

    def volume(self, link):
        """The medium of the Material Output's Volume (MEDIUM_KEYS keywords: coefficients
        per world unit), as Cycles' closures sum them: Volume Absorption (density x
        (1 - colour)), Volume Scatter (density x colour, Henyey-Greenstein), Principled
        Volume (scattering density x colour, absorption density x (1 - colour) x (1 -
        sqrt(absorption colour)), emission strength x colour), Volume Coefficients,
        Emission (strength x colour per unit length), and Add and Mix Shader (constant
        factor) of them; anything else is warned and adds nothing."""
        source = _past_reroutes(link)
        if source is None:
            return dict(NO_MEDIUM)
        node = source.from_node
        kind = node.bl_idname
        if kind in ("ShaderNodeAddShader", "ShaderNodeMixShader"):
            fac = 0.5 if kind == "ShaderNodeAddShader" else self.unit(node, "Fac", 0.5)
            weights = (1.0, 1.0) if kind == "ShaderNodeAddShader" else (1.0 - fac, fac)
            parts = [self.volume(sock_link) if sock_link is not None else dict(NO_MEDIUM)
                     for sock_link in (live_link(sock) for sock in
                                       [x for x in node.inputs if x.type == "SHADER"][:2])]
            return self._summed_media(node, parts, weights)
        medium = dict(NO_MEDIUM)
        if kind == "ShaderNodeVolumeAbsorption":
            colour = self.colour(node, "Color", (0.8, 0.8, 0.8))
            density = max(self.number(node, "Density", 1.0), 0.0)
            medium["absorption"] = tuple(density * max(1.0 - c, 0.0) for c in colour)
        elif kind == "ShaderNodeVolumeScatter":
            colour = self.colour(node, "Color", (0.8, 0.8, 0.8))
            density = max(self.number(node, "Density", 1.0), 0.0)
            medium["scattering"] = tuple(density * c for c in colour)
            medium["anisotropy"] = self._anisotropy(node)
        elif kind == "ShaderNodeVolumePrincipled":
            medium.update(self._principled_volume(node))
        elif kind == "ShaderNodeVolumeCoefficients":
            medium["absorption"] = self.colour(node, "Absorption Coefficients", (0.0,) * 3)
            medium["scattering"] = self.colour(node, "Scatter Coefficients", (0.0,) * 3)
            medium["anisotropy"] = self._anisotropy(node)
            medium["volume_emission"] = self.colour(node, "Emission Coefficients", (0.0,) * 3)
        elif kind == "ShaderNodeEmission":
            colour = self.colour(node, "Color", (1.0, 1.0, 1.0))
            strength = max(self.number(node, "Strength", 1.0), 0.0)
            medium["volume_emission"] = tuple(strength * c for c in colour)
        else:
            self.warn(f"Volume from node '{node.name}' ({_label(node)}) is not rendered "
                      f"(Specula renders Volume Absorption, Volume Scatter, Principled Volume, "
                      f"Volume Coefficients and Emission, added and mixed)")
        return medium

    def _principled_volume(self, node):
        """A Principled Volume's medium keywords (Cycles' svm_node_principled_volume)."""
        colour = self.colour(node, "Color", (0.5, 0.5, 0.5))
        density = max(self.number(node, "Density", 1.0), 0.0)
        tint = self.colour(node, "Absorption Color", (0.0, 0.0, 0.0))
        strength = max(self.number(node, "Emission Strength", 0.0), 0.0)
        emission = self.colour(node, "Emission Color", (1.0, 1.0, 1.0))
        self.ignored(node, "Blackbody Intensity", 0.0, "blackbody emission is not rendered")
        return {"scattering": tuple(density * c for c in colour),
                "absorption": tuple(density * max(1.0 - c, 0.0) * max(1.0 - math.sqrt(a), 0.0)
                                    for c, a in zip(colour, tint)),
                "anisotropy": self._anisotropy(node),
                "volume_emission": tuple(strength * c for c in emission)}

    def _anisotropy(self, node):
        """A scattering node's Henyey-Greenstein g in [-1, 1]; other phase functions (Volume
        Scatter's Fournier-Forand, Draine, Rayleigh, Mie) are warned and rendered as
        Henyey-Greenstein of its Anisotropy (isotropic for Rayleigh, whose mean cosine is
        0)."""
        g = min(max(self.number(node, "Anisotropy", 0.0), -1.0), 1.0)
        phase = getattr(node, "phase", "HENYEY_GREENSTEIN")
        if phase != "HENYEY_GREENSTEIN":
            g = 0.0 if phase == "RAYLEIGH" else g
            self.warn(f"node '{node.name}' phase function {phase.replace('_', ' ').title()} "
                      f"is not supported; rendered as Henyey-Greenstein with anisotropy "
                      f"{g:.3g}")
        return g

    def _summed_media(self, node, parts, weights):
        """Two media weighted and added (Add Shader: 1 and 1; Mix Shader: 1 - fac and fac);
        where both scatter with different anisotropy, one Henyey-Greenstein of their
        scattering-weighted mean g (warned: Cycles keeps both lobes)."""
        out = {key: tuple(sum(w * p[key][c] for p, w in zip(parts, weights)) for c in range(3))
               for key in ("absorption", "scattering", "volume_emission")}
        scatter = [w * sum(p["scattering"]) for p, w in zip(parts, weights)]
        g = [p["anisotropy"] for p in parts]
        out["anisotropy"] = (sum(s * x for s, x in zip(scatter, g)) / sum(scatter)
                             if sum(scatter) > 0 else 0.0)
        if min(scatter) > 0 and abs(g[0] - g[1]) > 1e-6:
            self.warn(f"node '{node.name}' ({_label(node)}) mixes volumes scattering with "
                      f"anisotropy {g[0]:.3g} and {g[1]:.3g}; rendered as one phase function "
                      f"of anisotropy {out['anisotropy']:.3g}")
        return out

    def shader(self, node):
        name, kind = self.material.name, node.bl_idname
        if kind in ("ShaderNodeMixShader", "ShaderNodeAddShader"):
            return self.mix(node)
        if kind in ("ShaderNodeBsdfDiffuse", "ShaderNodeBsdfGlass",
                    "ShaderNodeBsdfRefraction") or kind in GLOSSY_NODES:
            self.normal(node)
        if kind == "ShaderNodeBsdfDiffuse":  # Oren-Nayar where its Roughness is above 0
            colour, program = self.textured_colour(node, "Color")
            roughness, rough_program = self.textured_unit(node, "Roughness", 0.0)
            return MaterialSpec("diffuse", name, {"colour": colour, **_with(program),
                                                  "roughness": roughness,
                                                  **_with(rough_program, "roughness_program")})
        if kind in GLOSSY_NODES:
            # Rough Glossy is GGX; at Cycles' delta threshold it is a perfect mirror.
            colour, program = self.textured_colour(node, "Color")
            return MaterialSpec("glossy", name, {"colour": colour, **_with(program),
                                                 **self.roughness(node),
                                                 "multiscatter": self.multiscatter(node),
                                                 **self.anisotropy(node, "Anisotropy",
                                                                   "Rotation")})
        if kind == "ShaderNodeBsdfGlass":
            colour, program = self.textured_colour(node, "Color")
            return MaterialSpec("glass", name, {"colour": colour, **_with(program),
                                                "ior": self.ior(node), **self.roughness(node),
                                                "multiscatter": self.multiscatter(node)})
        if kind == "ShaderNodeBsdfRefraction":
            self.multiscatter(node)  # Beckmann (its default) is rendered as GGX, warned
            colour, program = self.textured_colour(node, "Color")
            return MaterialSpec("refraction", name, {"colour": colour, **_with(program),
                                                     "ior": self.ior(node),
                                                     **self.roughness(node)})
        if kind == "ShaderNodeEmission":
            # An Emission shader is a light whatever its colour: an unreducible chain keeps
            # the socket's own colour.
            colour, strength, program = self.emission(node, "Color", "Strength", 1.0, None,
                                                      None)
            return MaterialSpec("emission_only", name, {
                "colour": colour, "strength": strength,
                **({"emission_program": program} if program is not None else {})})
        if kind == "ShaderNodeBsdfPrincipled":
            return self.with_alpha(node, self.principled(node))
        if kind == "ShaderNodeBsdfMetallic":
            return self.metallic(node)
        if kind == "ShaderNodeGroup":  # (a group with its Group Output is looked through)
            return self.empty_group(node)
        if kind in VOLUME_SHADERS:
            self.warn(f"node '{node.name}' ({_label(node)}) is a volume shader on the Surface, "
                      f"where it adds nothing, as in Cycles (a medium goes on the Material "
                      f"Output's Volume)")
            return no_shader(name)
        if kind == "ShaderNodeBsdfTransparent":
            return transparent(name, self.colour(node, "Color", (1.0, 1.0, 1.0)))
        if kind == "ShaderNodeHoldout":
            return holdout(name)
        if kind == "ShaderNodeBsdfSheen":
            if getattr(node, "distribution", "MICROFIBER") != "MICROFIBER":
                self.warn(f"node '{node.name}' distribution {node.distribution} is not "
                          f"supported; rendered as Microfiber")
            self.normal(node)
            colour, program = self.textured_colour(node, "Color")
            roughness, roughness_program = self.textured_unit(node, "Roughness", 0.5)
            return MaterialSpec("sheen", name, {
                "colour": colour, **_with(program), "roughness": roughness,
                **_with(roughness_program, "roughness_program")})
        if kind == "ShaderNodeBsdfTranslucent":
            self.normal(node)
            colour, program = self.textured_colour(node, "Color")
            return MaterialSpec("translucent", name, {"colour": colour, **_with(program)})
        colour_socket = next((s for s in ("Color", "Base Color") if s in node.inputs), None)
        colour = DEFAULT_GREY if colour_socket is None else self.colour(node, colour_socket)
        self.warn(f"node '{node.name}' ({node.bl_label or kind}) is not supported; rendered as "
                  f"diffuse {'grey 0.8' if colour_socket is None else 'of its ' + colour_socket}")
        return MaterialSpec("diffuse", name, {"colour": colour})

    def mix(self, node):
        """Mix Shader (Fac, reduced to a constant) and Add Shader: a mix of the two shaders
        linked in, each with its own normal map; an unlinked input is no shader (Cycles'
        empty closure: black, no light passes)."""
        add = node.bl_idname == "ShaderNodeAddShader"
        fac, program = (0.5, None) if add else self.textured_unit(node, "Fac", 0.5)
        parts = []
        for sock in [s for s in node.inputs if s.type == "SHADER"][:2]:
            link = _past_reroutes(live_link(sock))
            self.normal_map = None
            part = self.shader(link.from_node) if link is not None else \
                no_shader(self.material.name)
            _give_normal_map(part, self.normal_map)
            self.normal_map = None
            parts.append(part)
        if not add and program is None and fac in (0.0, 1.0):
            return parts[int(fac)]
        if add and any(_is_no_shader(p) for p in parts):  # adding nothing is the other
            return parts[1] if _is_no_shader(parts[0]) else parts[0]
        return self.mixed(parts[0], parts[1], fac, 2.0 if add else 1.0, program,
                          fac_socket=None if add else enabled_input(node, "Fac"))

    def textured_unit(self, node, socket_name, default):
        """A factor in [0, 1] that may vary over the surface: (its constant, e.g. the image's
        mean; its shader program (first channel), or None)."""
        c, program = self.textured_colour(node, socket_name, (default,) * 3)
        return min(max(c[0], 0.0), 1.0), program

    def mixed(self, first, second, fac, scale=1.0, fac_program=None, emission_program=None,
              fac_socket=None):
        """The mix spec of two specs; their normal maps must read one UV map (a triangle has
        one set of tangents), else the second's is dropped, warned. A textured factor
        (`fac_socket`, a Mix Shader's Fac) mixes the components' emission per point, each
        textured or not (mixed_emission; a glTF unlit material: a textured Emission and a
        Transparent BSDF mixed by Light Path's Is Camera Ray), else by its constant
        (warned). `emission_program`: the mix's whole emission per point, given
        (with_alpha), its parts' constants its mean."""
        a, b = first.normal_uv, second.normal_uv
        if a is not None and b is not None and a != b:
            self.warn(f"mixed shaders' normal maps read UV maps '{a}' and '{b}'; only one per "
                      f"material is supported: the second's normal map is not rendered")
            for leaf in second.leaves():
                for key in ("normal_program", "normal_strength", "normal_uv"):
                    leaf.kwargs.pop(key, None)
        kwargs = {"first": first, "second": second, "fac": fac, "scale": scale}
        if emission_program is not None:
            kwargs["emission_program"] = emission_program
        elif fac_program is None or fac_socket is not None:
            kwargs.update(self.mixed_emission(first, second, fac, scale, fac_socket))
        for part in (*first.parts(), *second.parts()):
            if part.kwargs.pop("emission_program", None) is not None:
                self.warn("a textured emission inside a mixed shader is not supported; "
                          "rendered as its constant (the texture's mean)")
        if fac_program is not None and "emission_program" not in kwargs and any(
                max(_leaf_emission(leaf)) > 0 for leaf in (*first.leaves(), *second.leaves())):
            program = None
            if first.ctor != "mix" and second.ctor != "mix":
                a, b = (scale * _leaf_emission(part) for part in (first, second))
                program = shader_nodes.mixed_by(fac_program, a, b)
            if program is None:
                self.warn(f"an emission mixed by a textured factor is mixed by its mean, "
                          f"{fac:.3g}")
            else:  # the mix's own, per point (the Light Path node's invisible emitters)
                for part in (first, second):
                    part.kwargs.pop("emission", None)
                    if part.ctor == "emission_only":
                        part.kwargs["strength"] = 0.0
                kwargs["emission"] = tuple(np.maximum(a, b))  # (stands in for light choice)
                kwargs["emission_program"] = program
        if fac_program is not None:
            kwargs["fac_program"] = fac_program
        return MaterialSpec("mix", self.material.name, kwargs)

    def mixed_emission(self, first, second, fac, scale, fac_socket=None):
        """The emission of a Mix Shader (its factor constant, `fac`, or varying, the
        `fac_socket` it reads, `fac` its constant) or an Add Shader over parts of which
        one or both emit from a texture, as the mix's own program: their emissions
        mixed per point (shader_nodes.compile_emission), which the kernel evaluates where
        the mix is hit or sampled as a light. A part may be an Emission shader, a
        Principled BSDF (its emission under its Alpha, coat and sheen) or a mix with a
        program of its own; a part that emits nothing counts as 0. Emission shaders' parts
        become the mix's; the others keep their constants, for which the mix's program
        stands (scene._flatten_mixes), so a Principled BSDF's coat and sheen still dim
        its share. {} where that share would not be exact (the other part emits too) or a
        part's recipe is unknown: the texture's mean then (warned by the caller)."""
        parts = (first, second)
        programs = [p.kwargs.get("emission_program") for p in parts]
        if all(p is None for p in programs):
            return {}
        emits = [prog is not None or max(_leaf_emission(p)) > 0
                 for p, prog in zip(parts, programs)]
        if any(p.ctor != "emission_only" and _layered(p) for p in parts) and all(emits):
            return {}
        sources = [("constant", tuple(_leaf_emission(p))) if prog is None
                   else self.emission_sources.get(id(prog)) for p, prog in zip(parts, programs)]
        if any(source is None for source in sources):
            return {}
        source = ("mix", sources[0], sources[1], fac if fac_socket is None else fac_socket,
                  scale)
        program, why = shader_nodes.compile_emission(source, self.constants.image_cache)
        if program is None:
            self.warn(f"a mixed textured emission cannot be evaluated per point ({why})")
            return {}
        self.emission_sources[id(program)] = source
        weights = (scale * (1.0 - fac), scale * fac)
        own = sum(w * _leaf_emission(p) for w, p in zip(weights, parts)
                  if p.ctor == "emission_only")
        for p in parts:
            p.kwargs.pop("emission_program", None)
            if p.ctor == "emission_only":  # (now the mix's)
                p.kwargs["strength"] = 0.0
        kwargs = {"emission_program": program}
        if np.max(own) > 0:
            kwargs["emission"] = tuple(float(x) for x in own)
        elif not any(max(_leaf_emission(p)) > 0 for p in parts):
            # (the kernel skips a surface whose constants emit nothing: one stands in)
            kwargs["emission"] = tuple(float(x) for x in scale * np.maximum(
                _leaf_emission(first), _leaf_emission(second)))
        return kwargs

    def roughness(self, node):
        """A GGX node's Roughness as keywords: its constant in [0, 1] (the texture's mean
        where it varies) and, where it varies, its program (first channel, clamped)."""
        roughness, program = self.textured_unit(node, "Roughness", 0.5)
        return {"roughness": roughness, **_with(program, "roughness_program")}

    def rough(self, node):
        """Whether a GGX node's Roughness is above Cycles' delta threshold or varies."""
        r = self.roughness(node)
        return "roughness_program" in r or r["roughness"] > ROUGHNESS_EPSILON

    def multiscatter(self, node):
        """Whether a microfacet node is Multiscatter GGX (energy compensated) or plain GGX;
        other distributions render as GGX, with a warning."""
        distribution = getattr(node, "distribution", "MULTI_GGX")
        if distribution not in ("GGX", "MULTI_GGX") and self.rough(node):
            self.warn(f"node '{node.name}' distribution {distribution} is not supported; "
                      f"rendered as GGX")
        return distribution == "MULTI_GGX"

    def ior(self, node):
        ior = self.number(node, "IOR", 1.5)
        sock = node.inputs.get("IOR")
        if sock is not None and not sock.is_linked and sock.default_value != sock.default_value:
            ior = float("nan")  # Blender's socket accepts NaN; number() would hide it
        if not ior >= MIN_IOR:  # also NaN, which fmaxf drops too
            self.warn(f"node '{node.name}' IOR {ior:.3g} is below {MIN_IOR:g}; using "
                      f"{MIN_IOR:g} (as Cycles)")
            ior = MIN_IOR
        return ior

    def specular_ior(self, node):
        """A Principled BSDF's IOR and Specular IOR Level for its dielectric layer: (their
        constants, e.g. their textures' means; the program of both where either varies
        over the surface, or None)."""
        def constants():
            level = 0.5 if enabled_input(node, "Specular IOR Level") is None else \
                max(self.number(node, "Specular IOR Level", 0.5), 0.0)
            return self.ior(node), level
        return self.textured_pair(node, "IOR", "Specular IOR Level", 0.5, constants)

    def textured_pair(self, node, first, second, second_default, constants):
        """Two value inputs that may vary over the surface, as one program of both (its
        first two channels) where either does: (their constants, from `constants()`,
        whose warnings are dropped where the program stands for them; the program, or None,
        warned where its chain does not compile). A missing second input is
        `second_default`."""
        program, why = shader_nodes.compile_pair(
            enabled_input(node, first), enabled_input(node, second), second_default,
            self.constants.image_cache)
        warned = len(self.warnings)
        a, b = constants()
        if program is not None:
            del self.warnings[warned:]  # the constants only stand in; the program is exact
        elif why:
            self.warn(f"node '{node.name}' {first} or {second} cannot be evaluated per point "
                      f"({why} is not supported); rendered with their constants {a:.3g}, "
                      f"{b:.3g}")
        return a, b, program

    def anisotropy(self, node, socket_name, rotation_name):
        """A GGX node's anisotropy, its rotation and its Tangent as keywords (none where
        the node is isotropic): constants, or a program of both where either varies (the
        constants then stand for their means), and the tangent's program (Cycles' default,
        radial about Z, where the Tangent is unlinked or its chain does not compile,
        warned)."""
        if enabled_input(node, socket_name) is None:
            return {}
        a, r, program = self.textured_pair(node, socket_name, rotation_name, 0.0, lambda: (
            self.number(node, socket_name, 0.0),
            self.number(node, rotation_name, 0.0)
            if enabled_input(node, rotation_name) is not None else 0.0))
        if program is None and a == 0.0:
            return {}
        tangent_socket = enabled_input(node, "Tangent")
        tangent, why = shader_nodes.compile_tangent(tangent_socket,
                                                    self.constants.image_cache)
        if why:
            self.warn(f"node '{node.name}' Tangent cannot be evaluated ({why} is not "
                      f"supported); rendered with the default tangent (radial about Z)")
        return {"specular_anisotropy": a, "anisotropic_rotation": r, "tangent_program": tangent,
                **_with(program, "anisotropy_program")}

    def empty_group(self, node):
        """A group node giving no shader: its node tree missing (linked from a library
        that could not be read: Blender keeps an empty placeholder) or without a Group
        Output. Cycles renders it as no shader: black, and no light passes."""
        tree = getattr(node.node_tree, "original", node.node_tree)  # (not the depsgraph's copy)
        library = getattr(tree, "library", None)
        if tree is None:
            why = "has no node group"
        elif library is not None and getattr(tree, "is_missing", False):
            why = (f"uses node group '{tree.name}' from library '{library.filepath}', which "
                   f"could not be read")
        else:
            why = f"uses node group '{tree.name}', which has no Group Output"
        self.warn(f"node '{node.name}' {why}; rendered black, as Cycles renders it (no shader)")
        return no_shader(self.material.name)

    def metallic(self, node):
        """The Metallic BSDF: Cycles' F82 conductor of the Principled BSDF's metal (Base
        Color its F0, Edge Tint its F82 tint, either may vary) with its roughness,
        anisotropy and normal; a Physical Conductor (IOR and Extinction, constants) as the
        F82 metal fitted to it (bsdf.conductor_as_f82), warned with the fit's deviation."""
        self.normal(node)
        kwargs = {**self.roughness(node), "multiscatter": self.multiscatter(node),
                  **self.anisotropy(node, "Anisotropy", "Rotation")}
        if getattr(node, "fresnel_type", "F82") == "F82":
            base, program = self.textured_colour(node, "Base Color")
            tint, tint_program = self.textured_colour(node, "Edge Tint", (1.0, 1.0, 1.0))
            return MaterialSpec("metal", self.material.name, {
                "base_colour": base, **_with(program), "specular_tint": tint,
                **_with(tint_program, "tint_program"), **kwargs, **self.thin_film(node)})
        # (Cycles puts a film on the exact conductor, not on its F82 fit rendered here.)
        self.ignored(node, "Thin Film Thickness", 0.0, "rendered without thin film")
        n, k = (np.array(self.colour(node, name, default))  # (negative or NaN: 0)
                for name, default in (("IOR", (1.5,) * 3), ("Extinction", (0.0,) * 3)))
        f0, tint, deviation = core.load().bsdf.conductor_as_f82(n, k)
        self.warn(f"node '{node.name}' Physical Conductor (IOR {_fmt(tuple(n))}, Extinction "
                  f"{_fmt(tuple(k))}) is rendered as Cycles' F82 fit of it (F0 {_fmt(tuple(f0))},"
                  f" edge tint {_fmt(tuple(tint))}): exact at normal incidence and near 82 "
                  f"degrees, within {deviation:.3f} of the exact reflectance between")
        return MaterialSpec("metal", self.material.name, {
            "base_colour": tuple(float(x) for x in f0),
            "specular_tint": tuple(float(x) for x in tint), **kwargs})

    def thin_film(self, node):
        """A Principled or Metallic BSDF's Thin Film as keywords of its lobes: thickness
        (nm) and IOR, constants, or a program of both where either varies over the surface
        (the constants then stand for their means); none at thickness 0."""
        if "Thin Film Thickness" not in node.inputs:
            return {}
        d, n, program = self.textured_pair(
            node, "Thin Film Thickness", "Thin Film IOR", 1.33,
            lambda: (self.number(node, "Thin Film Thickness", 0.0),
                     self.number(node, "Thin Film IOR", 1.33)))
        if program is None and d <= 0.0:
            return {}
        rec709 = core.load().spectrum.XYZ_TO_REC709
        if not np.allclose(shader_nodes.xyz_to_scene_linear(), rec709.ravel(), atol=1e-3):
            self.warn(f"node '{node.name}' Thin Film: its colours are computed for linear "
                      f"Rec.709, not this file's working space")
        return {"thin_film": (d, n), **_with(program, "thin_film_program")}

    def principled_ignored(self, node):
        self.normal(node)
        for socket_name, neutral, rendered in PRINCIPLED_IGNORED:
            self.ignored(node, socket_name, neutral, rendered)

    def specular_tint(self, node):
        """The Principled BSDF's Specular Tint, the metal's F82 edge tint and the F0 tint of
        its dielectric and glass Fresnel, as keywords: its constant (the mean where it
        varies) and its program where it varies. White before 4.0, where it was a float."""
        sock = enabled_input(node, "Specular Tint")
        if sock is None or sock.type != "RGBA":
            return {"specular_tint": (1.0, 1.0, 1.0)}
        tint, program = self.textured_colour(node, "Specular Tint", (1.0, 1.0, 1.0))
        return {"specular_tint": tuple(max(t, 0.0) for t in tint),
                **_with(program, "tint_program")}

    def principled(self, node):
        """Cycles mixes the Principled BSDF's lobes linearly: metal x Metallic, glass x
        (1 - Metallic) x Transmission, the dielectric x the rest; here as a mix of the metal
        and a mix of the dielectric and the glass, each factor a program where it varies
        (the glTF importer's metallic and transmission channels)."""
        name = self.material.name
        self.principled_ignored(node)
        metallic, metal_program = self.textured_unit(node, "Metallic", 0.0)
        transmission, glass_program = self.textured_unit(
            node, "Transmission Weight" if "Transmission Weight" in node.inputs
            else "Transmission", 0.0)
        roughness = self.roughness(node)
        # A linked emission that cannot be reduced is off, not the sockets' own values:
        # Emission Color's is white, and a textured surface must not become a white light.
        # The colour input is "Emission Color" since 4.0 and "Emission" before.
        emission_socket = "Emission Color" if "Emission Color" in node.inputs else "Emission"
        colour, strength, program = self.emission(node, emission_socket, "Emission Strength",
                                                  0.0, (0.0, 0.0, 0.0), 0.0)
        emission = tuple(strength * c for c in colour)
        kwargs = {"emission": emission} if max(emission) > 0 else {}
        if kwargs and program is not None:
            kwargs["emission_program"] = program
        multiscatter = self.multiscatter(node)
        tint = {**self.specular_tint(node), **self.thin_film(node)}

        def metal():
            base, program = self.textured_colour(node, "Base Color")
            return MaterialSpec("metal", name, {"base_colour": base, **_with(program),
                                                **roughness, "multiscatter": multiscatter,
                                                **tint})

        def glass():
            base, program = self.textured_colour(node, "Base Color")
            return MaterialSpec("principled_glass", name, {
                "base_colour": base, **_with(program), "ior": self.ior(node), **roughness,
                "multiscatter": multiscatter, **tint})

        def either(first, second, fac, program):
            """first (1 - fac) and second (fac), or one alone where fac is 0 or 1."""
            if program is None and fac <= 0.0:
                return first()
            if program is None and fac >= 1.0:
                return second()
            return self.mixed(first(), second(), fac, 1.0, program)

        def non_metal():
            return either(lambda: self.dielectric(node, tint), glass, transmission,
                          glass_program)

        spec = either(non_metal, metal, metallic, metal_program)
        anisotropy = self.anisotropy(node, "Anisotropic", "Anisotropic Rotation")
        for leaf in spec.leaves():  # its metal and specular lobes (not the glass, as Cycles)
            if leaf.ctor in ("metal", "principled"):
                leaf.kwargs.update(anisotropy)
        spec = self.sheen(node, self.coat(node, spec))
        if spec.ctor != "mix":
            spec.kwargs.update(kwargs)
            return spec
        return self.with_emission(node, spec, kwargs)

    def coat(self, node, spec):
        """The Principled BSDF's coat over `spec` (Cycles: over every lobe but the sheen):
        Coat Weight, Coat Roughness and Coat Tint (any may vary), Coat IOR (at least 1, as
        Cycles clamps it) and the Coat Normal's
        normal map (the Normal's where unlinked, as in Cycles). Emission below a coat is
        not dimmed by it (warned)."""
        if "Coat Weight" not in node.inputs:
            return spec
        weight, weight_program = self.textured_unit(node, "Coat Weight", 0.0)
        if weight_program is None and weight <= 0.0:
            return spec
        roughness, roughness_program = self.textured_unit(node, "Coat Roughness", 0.03)
        ior = self.number(node, "Coat IOR", 1.5)
        if ior < 1.0:
            self.warn(f"node '{node.name}' Coat IOR {ior:.3g} is below 1; using 1 (as Cycles)")
            ior = 1.0
        tint, tint_program = self.textured_colour(node, "Coat Tint", (1.0, 1.0, 1.0))
        lobe = MaterialSpec("coat_lobe", self.material.name, {
            "roughness": roughness, "ior": ior,
            **_with(roughness_program, "roughness_program")})
        # Unlinked, the Coat Normal is the mesh's own (Cycles links it to the geometry's
        # normal), not the Normal: a smooth coat over a normal-mapped base.
        lobe.kwargs.update(self.normal_map_of(node, "Coat Normal") or {"normal_program": None})
        coat_uv, shared = lobe.normal_uv, self.normal_map
        if coat_uv is not None and shared is not None and coat_uv != shared["normal_uv"]:
            self.warn(f"node '{node.name}' Coat Normal and Normal read UV maps '{coat_uv}' and "
                      f"'{shared['normal_uv']}'; only one per material is supported: the "
                      f"coat's normal map is not rendered")
            lobe.kwargs.update(normal_program=None, normal_strength=1.0)
            lobe.kwargs.pop("normal_uv")
        mix = self.mixed(spec, lobe, weight, 1.0, weight_program)
        mix.kwargs.update(coat_ior=ior, coat_tint=tint, **_with(tint_program, "tint_program"))
        return mix

    def sheen(self, node, spec):
        """The Principled BSDF's sheen over `spec` (Cycles' first layer: over the coat):
        Sheen Weight (which may vary; above 1 it scales the tint, the same closure), Sheen
        Roughness and Sheen Tint (either may vary too)."""
        if "Sheen Weight" not in node.inputs:
            return spec
        weight, weight_program = self.textured_colour(node, "Sheen Weight", (0.0,) * 3)
        weight = max(weight[0], 0.0)
        if weight_program is None and weight <= 0.0:
            return spec
        tint, tint_program = self.textured_colour(node, "Sheen Tint", (1.0, 1.0, 1.0))
        roughness, roughness_program = self.textured_unit(node, "Sheen Roughness", 0.5)
        if weight_program is not None:
            weight = min(weight, 1.0)
        elif weight > 1.0:
            if tint_program is not None:
                tint_program = shader_nodes.scaled(tint_program, weight)
            tint, weight = tuple(c * weight for c in tint), 1.0
        lobe = MaterialSpec("sheen", self.material.name, {
            "colour": tint, **_with(tint_program), "roughness": roughness,
            **_with(roughness_program, "roughness_program")})
        mix = self.mixed(spec, lobe, weight, 1.0, weight_program)
        mix.kwargs.update(sheen_layer=True)
        return mix

    def with_alpha(self, node, spec):
        """A Principled BSDF's Alpha (which may vary, e.g. a texture's alpha channel): the
        mix of transparent white (1 - alpha) and the rest (Cycles' Principled: alpha
        scales every closure, its emission too, and adds a transparent one)."""
        alpha, program = self.textured_unit(node, "Alpha", 1.0)
        if program is None and alpha >= 1.0:
            return spec
        glow = spec.kwargs.pop("emission_program", None)
        if program is None and alpha <= 0.0:
            glow = None  # (Cycles weighs the emission by alpha: none of it glows)
        elif glow is not None or program is not None and \
                max(spec.kwargs.get("emission", (0.0,))) > 0:
            # Weighed per point by the alpha, whatever its constant (a cut-out's reads 0
            # where its mask's step is taken of the mean): unweighted, a textured glow shone
            # through the cut-out's transparent parts.
            glow = self.alpha_glow(node, spec, glow, alpha, program)
        return self.mixed(transparent(self.material.name), spec, alpha, 1.0, program, glow)

    def alpha_glow(self, node, spec, glow, alpha, alpha_program):
        """The emission of a Principled BSDF under its Alpha, per point: alpha x its
        emission (`glow`, its program, or its constant), as Cycles weighs every closure of
        the node by alpha. Its sheen and coat still dim it (scene: the mix's program stands
        for its parts' emission, which lies under them). None where it cannot be evaluated
        per point (warned: the texture's mean)."""
        inner = ("constant", tuple(spec.kwargs["emission"])) if glow is None \
            else self.emission_sources.get(id(glow))
        weight = alpha if alpha_program is None else enabled_input(node, "Alpha")
        program, why = (None, "its recipe is unknown") if inner is None else \
            shader_nodes.compile_emission(("weighted", inner, weight),
                                          self.constants.image_cache)
        if program is None:
            self.warn(f"node '{node.name}': its emission cannot be weighted by its Alpha per "
                      f"point ({why}); rendered as its mean")
            return None
        self.emission_sources[id(program)] = ("weighted", inner, weight)
        return program

    def with_emission(self, node, mix, kwargs):
        """A Principled BSDF's mix of lobes with its emission (textured or not) added once,
        on the mix."""
        mix.kwargs.update(kwargs)
        return mix

    def dielectric(self, node, specular_tint=None):
        """The Principled BSDF's dielectric part: a Lambert base under a GGX specular layer
        (Cycles' Principled v2; Multiscatter GGX compensated, GGX not, the base then taking
        what the lobe's single scattering leaves), its Fresnel under the Specular Tint
        (specular_tint's keywords)."""
        base, program = self.textured_colour(node, "Base Color")
        ior, level, specular_ior = self.specular_ior(node)
        diffuse = {}
        if "Diffuse Roughness" in node.inputs:  # (since 4.3) Oren-Nayar on the base
            sigma, sigma_program = self.textured_unit(node, "Diffuse Roughness", 0.0)
            diffuse = {"diffuse_roughness": sigma,
                       **_with(sigma_program, "diffuse_roughness_program")}
        return MaterialSpec("principled", self.material.name, {
            "base_colour": base, **_with(program), **self.roughness(node),
            "ior": ior, "specular_ior_level": level, **_with(specular_ior, "specular_ior_program"),
            "multiscatter": self.multiscatter(node),
            **(specular_tint or {"specular_tint": (1.0, 1.0, 1.0)}), **diffuse})


def world_volume(world, image_cache=None):
    """(the world's Volume as MEDIUM_KEYS keywords, or None; warnings naming the world):
    read as a material's Volume is, from the World Output's Volume input."""
    tree = None if world is None else world.node_tree
    if tree is None or not (bpy.app.version >= (5, 0) or world.use_nodes):
        return None, []
    out = tree.get_output_node('CYCLES')
    sock = None if out is None else out.inputs.get("Volume")
    link = None if sock is None else live_link(sock)
    if link is None:
        return None, []
    reader = _Reader(world, image_cache, label="world")
    medium = reader.volume(link)
    return (medium if _is_medium(medium) else None), reader.warnings


def constant_of(socket):
    """(the constant the chain behind an input reduces to, or None; the notes on what it
    approximates, empty where it is exact): the material reader's reduction, for node
    trees outside materials (a light's)."""
    k = _Constants({})
    return k.input(socket), k.notes


def convert(material, image_cache=None):
    """Map a bpy Material (or None) to (MaterialSpec, [warning, ...]). Never raises.

    image_cache : dict shared by the materials of one export, so an image used by several
        materials is averaged once (keyed by image pointer; not to be kept across exports,
        since the image may be edited in between)."""
    if material is None:
        return default_material(), []
    reader = _Reader(material, image_cache)
    pass_index = shader_nodes.MATERIAL_PASS_INDEX.set(int(material.pass_index))
    try:
        return reader.read(), reader.warnings
    except Exception as exc:  # noqa: BLE001 - a bad node tree must not stop the render
        if os.environ.get("SPECULA_STRICT_MATERIALS") == "1":
            raise  # the test suite: what lands here is a bug in the reader, not a bad tree
        reader.warn(f"could not be read ({type(exc).__name__}: {exc}); rendered as grey 0.8")
        return MaterialSpec("diffuse", material.name, {"colour": DEFAULT_GREY}), reader.warnings
    finally:
        shader_nodes.MATERIAL_PASS_INDEX.reset(pass_index)


classes = ()


def register():
    pass


def unregister():
    pass

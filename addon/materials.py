"""Blender materials -> Specula material descriptions.

The core understands Lambert diffuse, perfect mirror, smooth metal, smooth glass and
emission (see engine/scene.py `Material`). This module reads a material's Cycles output
and maps the nodes it knows onto those; anything else becomes a documented fallback with
a warning that names the material and the node, so nothing renders silently black.

Fallbacks:
  * no node tree / no Cycles output / nothing linked to Surface: diffuse of the
    material's viewport colour (`diffuse_color`).
  * Diffuse BSDF with roughness > 0 (Oren-Nayar): Lambert.
  * Glossy BSDF with roughness > 0: mirror. Glass BSDF with roughness > 0: smooth glass.
  * Principled BSDF: Transmission Weight >= 0.5 -> glass (IOR), else Metallic >= 0.5 ->
    metal, else diffuse of Base Color; roughness ignored for metal and glass (warned),
    the dielectric specular layer of the diffuse case is dropped (documented, not warned).
  * any other shader node (Mix, Add, Toon, ...): diffuse of its 'Color' / 'Base Color'
    input, or grey 0.8.
  * a linked input (texture): the socket's unlinked default value.
"""

from dataclasses import dataclass, field

import bpy

DEFAULT_GREY = (0.8, 0.8, 0.8)
# Cycles treats roughness below this as a perfect delta lobe (alpha = r^2 <= 2e-10 there).
ROUGHNESS_EPSILON = 1e-5
GLOSSY_NODES = ("ShaderNodeBsdfGlossy", "ShaderNodeBsdfAnisotropic")


@dataclass(frozen=True)
class MaterialSpec:
    """A core `Material` constructor call: `getattr(Material, ctor)(name, **kwargs)`."""

    ctor: str
    name: str
    kwargs: dict = field(default_factory=dict)

    def to_core(self, core):
        return getattr(core.Material, self.ctor)(self.name, **self.kwargs)


def default_material():
    return MaterialSpec("diffuse", "Specula default", {"colour": DEFAULT_GREY})


def _rgb(value):
    return tuple(float(c) for c in tuple(value)[:3])


class _Reader:
    """Reads one material, collecting warnings that name it."""

    def __init__(self, material):
        self.material = material
        self.warnings = []

    def warn(self, text):
        self.warnings.append(f"material '{self.material.name}': {text}")

    def value(self, node, socket_name, default=None):
        """Unlinked value of `node`'s input `socket_name` (warning when it is linked)."""
        sock = node.inputs.get(socket_name)
        if sock is None:
            return default
        if sock.is_linked:
            src = sock.links[0].from_node.name if sock.links else "?"
            self.warn(f"node '{node.name}' input '{socket_name}' is driven by node '{src}', "
                      f"which is not supported; using the input's own value")
        return sock.default_value

    def colour(self, node, socket_name, default=DEFAULT_GREY):
        v = self.value(node, socket_name, None)
        return default if v is None else _rgb(v)

    def number(self, node, socket_name, default=0.0):
        v = self.value(node, socket_name, None)
        return default if v is None else float(v)

    def viewport_fallback(self, why):
        self.warn(f"{why}; rendered as diffuse of its viewport colour")
        return MaterialSpec("diffuse", self.material.name,
                            {"colour": _rgb(self.material.diffuse_color)})

    def read(self):
        mat = self.material
        tree = mat.node_tree
        # Before 5.0 a material could keep a node tree while use_nodes is off.
        uses_nodes = tree is not None and (bpy.app.version >= (5, 0) or mat.use_nodes)
        if not uses_nodes:
            return MaterialSpec("diffuse", mat.name, {"colour": _rgb(mat.diffuse_color)})
        out = tree.get_output_node('CYCLES')
        if out is None:
            return self.viewport_fallback("no active Material Output node for Cycles")
        surface = out.inputs.get("Surface")
        if surface is None or not surface.is_linked or not surface.links:
            return self.viewport_fallback(f"nothing is linked to '{out.name}' Surface")
        node = surface.links[0].from_node
        while node.bl_idname == "NodeReroute":
            if not node.inputs[0].is_linked:
                return self.viewport_fallback(f"reroute '{node.name}' leads nowhere")
            node = node.inputs[0].links[0].from_node
        return self.shader(node)

    def shader(self, node):
        name, kind = self.material.name, node.bl_idname
        if kind == "ShaderNodeBsdfDiffuse":
            if self.number(node, "Roughness") > ROUGHNESS_EPSILON:
                self.warn(f"node '{node.name}' roughness > 0 (Oren-Nayar) is not supported; "
                          f"rendered as Lambert (roughness 0)")
            return MaterialSpec("diffuse", name, {"colour": self.colour(node, "Color")})
        if kind in GLOSSY_NODES:
            # Rough Glossy is Multiscatter GGX (Cycles' default for the node); at Cycles'
            # delta threshold it is a perfect mirror.
            return MaterialSpec("glossy", name, {"colour": self.colour(node, "Color"),
                                                 "roughness": self.number(node, "Roughness")})
        if kind == "ShaderNodeBsdfGlass":
            r = self.number(node, "Roughness")
            if r > ROUGHNESS_EPSILON:
                self.warn(f"node '{node.name}' roughness {r:.3g} is not supported; rendered as "
                          f"smooth glass (roughness 0)")
            return MaterialSpec("glass", name, {"colour": self.colour(node, "Color"),
                                                "ior": self.ior(node)})
        if kind == "ShaderNodeEmission":
            return MaterialSpec("emission_only", name, {
                "colour": self.colour(node, "Color", (1.0, 1.0, 1.0)),
                "strength": self.number(node, "Strength", 1.0)})
        if kind == "ShaderNodeBsdfPrincipled":
            return self.principled(node)
        colour_socket = next((s for s in ("Color", "Base Color") if s in node.inputs), None)
        colour = DEFAULT_GREY if colour_socket is None else self.colour(node, colour_socket)
        self.warn(f"node '{node.name}' ({node.bl_label or kind}) is not supported; rendered as "
                  f"diffuse {'grey 0.8' if colour_socket is None else 'of its ' + colour_socket}")
        return MaterialSpec("diffuse", name, {"colour": colour})

    def ior(self, node):
        ior = self.number(node, "IOR", 1.5)
        if ior <= 0:
            self.warn(f"node '{node.name}' IOR {ior:.3g} is not positive; using 1.5")
            ior = 1.5
        return ior

    def principled(self, node):
        name = self.material.name
        base = self.colour(node, "Base Color")
        metallic = self.number(node, "Metallic")
        transmission = self.number(node, "Transmission Weight",
                                   self.number(node, "Transmission"))
        roughness = self.number(node, "Roughness")
        strength = self.number(node, "Emission Strength", 0.0)
        # The colour input is "Emission Color" since 4.0 and "Emission" before.
        emission_socket = "Emission Color" if "Emission Color" in node.inputs else "Emission"
        emission = tuple(strength * c for c in self.colour(node, emission_socket,
                                                           (1.0, 1.0, 1.0)))
        kwargs = {"emission": emission} if strength > 0 else {}
        for label, w in (("Metallic", metallic), ("Transmission Weight", transmission)):
            if 0.0 < w < 1.0:
                self.warn(f"node '{node.name}' {label} {w:.3g} is not supported (only 0 or 1); "
                          f"treated as {1 if w >= 0.5 else 0}")
        if transmission >= 0.5:
            ctor, kwargs = "principled_glass", {"base_colour": base, "ior": self.ior(node),
                                                **kwargs}
        elif metallic >= 0.5:
            ctor, kwargs = "metal", {"base_colour": base, **kwargs}
        else:
            # Dielectric: Lambert base under a GGX specular layer (Cycles' Principled v2).
            level = self.number(node, "Specular IOR Level", 0.5) \
                if "Specular IOR Level" in node.inputs else 0.5
            tint = self.colour(node, "Specular Tint", (1.0, 1.0, 1.0)) \
                if "Specular Tint" in node.inputs and node.inputs["Specular Tint"].type == "RGBA" \
                else (1.0, 1.0, 1.0)
            if any(abs(c - 1.0) > 1e-6 for c in tint):
                self.warn(f"node '{node.name}' Specular Tint is not supported; rendered white")
            return MaterialSpec("principled", name, {
                "base_colour": base, "roughness": roughness, "ior": self.ior(node),
                "specular_ior_level": level, **kwargs})
        if roughness > ROUGHNESS_EPSILON:
            self.warn(f"node '{node.name}' roughness {roughness:.3g} is not supported; "
                      f"rendered smooth (roughness 0)")
        return MaterialSpec(ctor, name, kwargs)


def convert(material):
    """Map a bpy Material (or None) to (MaterialSpec, [warning, ...]). Never raises."""
    if material is None:
        return default_material(), []
    reader = _Reader(material)
    try:
        return reader.read(), reader.warnings
    except Exception as exc:  # noqa: BLE001 - a bad node tree must not stop the render
        reader.warn(f"could not be read ({type(exc).__name__}: {exc}); rendered as grey 0.8")
        return MaterialSpec("diffuse", material.name, {"colour": DEFAULT_GREY}), reader.warnings


classes = ()


def register():
    pass


def unregister():
    pass

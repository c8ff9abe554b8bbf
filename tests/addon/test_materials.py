"""Node trees -> core materials: supported nodes map exactly, the rest warn and fall back."""

import bpy
import pytest
from addon_helpers import node_material

from addon import materials

WHITE = (1.0, 1.0, 1.0, 1.0)


def convert(mat):
    spec, warnings = materials.convert(mat)
    return spec, warnings


@pytest.mark.parametrize("shader, inputs, ctor, kwargs", [
    ("ShaderNodeBsdfDiffuse", {"Color": (0.6, 0.2, 0.2, 1), "Roughness": 0.0}, "diffuse",
     {"colour": (0.6, 0.2, 0.2)}),
    ("ShaderNodeBsdfGlossy", {"Color": (1.0, 0.8, 0.4, 1), "Roughness": 0.0}, "glossy",
     {"colour": (1.0, 0.8, 0.4), "roughness": 0.0}),
    ("ShaderNodeBsdfGlossy", {"Color": (1.0, 0.8, 0.4, 1), "Roughness": 0.3}, "glossy",
     {"colour": (1.0, 0.8, 0.4), "roughness": 0.3}),
    ("ShaderNodeBsdfGlass", {"Color": WHITE, "Roughness": 0.0, "IOR": 1.45}, "glass",
     {"colour": (1.0, 1.0, 1.0), "ior": 1.45}),
    ("ShaderNodeEmission", {"Color": WHITE, "Strength": 10.0}, "emission_only",
     {"colour": (1.0, 1.0, 1.0), "strength": 10.0}),
    ("ShaderNodeBsdfPrincipled", {"Base Color": (0.5, 0.25, 0.125, 1), "Roughness": 0.3,
                                  "IOR": 1.45}, "principled",
     {"base_colour": (0.5, 0.25, 0.125), "roughness": 0.3, "ior": 1.45,
      "specular_ior_level": 0.5}),
    ("ShaderNodeBsdfPrincipled", {"Base Color": (0.9, 0.6, 0.2, 1), "Metallic": 1.0,
                                  "Roughness": 0.0}, "metal", {"base_colour": (0.9, 0.6, 0.2)}),
    ("ShaderNodeBsdfPrincipled", {"Base Color": WHITE, "Transmission Weight": 1.0,
                                  "Roughness": 0.0, "IOR": 1.33}, "principled_glass",
     {"base_colour": (1.0, 1.0, 1.0), "ior": 1.33}),
    ("ShaderNodeBsdfPrincipled", {"Base Color": (0.1, 0.1, 0.1, 1), "Emission Color":
                                  (1.0, 0.5, 0.0, 1), "Emission Strength": 4.0}, "principled",
     {"base_colour": (0.1, 0.1, 0.1), "roughness": 0.5, "ior": 1.5, "specular_ior_level": 0.5,
      "emission": (4.0, 2.0, 0.0)}),
])
def test_supported_nodes(fresh, shader, inputs, ctor, kwargs):
    mat, _ = node_material("M", shader, **inputs)
    spec, warnings = convert(mat)
    assert warnings == []
    assert (spec.ctor, spec.name) == (ctor, "M")
    assert spec.kwargs.keys() == kwargs.keys()
    for key, value in kwargs.items():
        assert spec.kwargs[key] == pytest.approx(value, abs=1e-6), key


def test_specs_build_core_materials(fresh, core):
    for shader in ("ShaderNodeBsdfDiffuse", "ShaderNodeBsdfGlass", "ShaderNodeEmission",
                   "ShaderNodeBsdfPrincipled"):
        mat, _ = node_material(shader, shader)
        spec, _ = convert(mat)
        assert isinstance(spec.to_core(core), core.Material)


def test_no_material_is_default_grey():
    spec, warnings = convert(None)
    assert (spec.ctor, spec.kwargs["colour"], warnings) == ("diffuse", (0.8, 0.8, 0.8), [])


@pytest.mark.parametrize("shader, expect_ctor", [
    ("ShaderNodeBsdfToon", "diffuse"),
    ("ShaderNodeBsdfTranslucent", "diffuse"),
    ("ShaderNodeMixShader", "diffuse"),
])
def test_unsupported_node_warns_and_falls_back(fresh, shader, expect_ctor):
    mat, node = node_material("Odd", shader)
    if "Color" in node.inputs:
        node.inputs["Color"].default_value = (0.1, 0.7, 0.3, 1.0)
    spec, warnings = convert(mat)
    assert spec.ctor == expect_ctor
    assert len(warnings) == 1
    assert "material 'Odd'" in warnings[0] and f"node '{node.name}'" in warnings[0]
    expected = (0.1, 0.7, 0.3) if "Color" in node.inputs else (0.8, 0.8, 0.8)
    assert spec.kwargs["colour"] == pytest.approx(expected, abs=1e-6)


@pytest.mark.parametrize("shader, ctor", [("ShaderNodeBsdfGlass", "glass"),
                                          ("ShaderNodeBsdfDiffuse", "diffuse")])
def test_rough_nodes_warn_and_render_smooth(fresh, shader, ctor):
    mat, node = node_material("Rough", shader, Roughness=0.4)
    spec, warnings = convert(mat)
    assert spec.ctor == ctor
    assert len(warnings) == 1 and "roughness" in warnings[0] and "'Rough'" in warnings[0]


def test_linked_input_warns_and_uses_default(fresh):
    mat, node = node_material("Tex", "ShaderNodeBsdfDiffuse", Color=(0.3, 0.3, 0.9, 1))
    tex = mat.node_tree.nodes.new("ShaderNodeTexChecker")
    mat.node_tree.links.new(tex.outputs["Color"], node.inputs["Color"])
    spec, warnings = convert(mat)
    assert spec.kwargs["colour"] == pytest.approx((0.3, 0.3, 0.9), abs=1e-6)
    assert len(warnings) == 1 and tex.name in warnings[0]


def test_unlinked_surface_uses_viewport_colour(fresh):
    mat, node = node_material("Bare", "ShaderNodeBsdfDiffuse")
    mat.node_tree.nodes.remove(node)
    mat.diffuse_color = (0.2, 0.5, 0.7, 1.0)
    spec, warnings = convert(mat)
    assert spec.kwargs["colour"] == pytest.approx((0.2, 0.5, 0.7), abs=1e-6)
    assert len(warnings) == 1 and "viewport colour" in warnings[0]


def test_no_cycles_output_uses_viewport_colour(fresh):
    mat, _ = node_material("EeveeOnly", "ShaderNodeBsdfDiffuse")
    out = next(n for n in mat.node_tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial")
    out.target = "EEVEE"
    spec, warnings = convert(mat)
    assert spec.ctor == "diffuse" and len(warnings) == 1


def test_reroute_is_followed(fresh):
    mat, node = node_material("Routed", "ShaderNodeBsdfGlossy", Roughness=0.0)
    tree = mat.node_tree
    out = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial")
    reroute = tree.nodes.new("NodeReroute")
    tree.links.new(node.outputs[0], reroute.inputs[0])
    tree.links.new(reroute.outputs[0], out.inputs["Surface"])
    spec, warnings = convert(mat)
    assert (spec.ctor, warnings) == ("glossy", [])


def test_fractional_principled_weights_warn(fresh):
    mat, _ = node_material("Half", "ShaderNodeBsdfPrincipled", Metallic=0.3, Roughness=0.0)
    spec, warnings = convert(mat)
    assert spec.ctor == "principled"
    assert any("Metallic" in w for w in warnings)


def test_materials_without_nodes_use_viewport_colour(fresh):
    if bpy.app.version >= (5, 0):
        pytest.skip("5.0 materials always use their node tree")
    mat = bpy.data.materials.new("Flat")
    mat.use_nodes = False
    mat.diffuse_color = (0.1, 0.2, 0.3, 1.0)
    spec, warnings = convert(mat)
    assert spec.kwargs["colour"] == pytest.approx((0.1, 0.2, 0.3)) and warnings == []

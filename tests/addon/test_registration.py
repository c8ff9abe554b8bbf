"""Registration: the engine's flags, settings with descriptions and ranges, Blender panels."""

import bpy
import pytest

import addon
from addon import properties, ui
from addon.engine import SpeculaRenderEngine


def test_engine_flags(fresh):
    assert (SpeculaRenderEngine.bl_idname, SpeculaRenderEngine.bl_label) == ("SPECULA", "Specula")
    assert SpeculaRenderEngine.bl_use_shading_nodes_custom is False
    assert SpeculaRenderEngine.bl_use_eevee_viewport is True
    fresh.render.engine = "CYCLES"
    fresh.render.engine = "SPECULA"  # an unknown engine would raise TypeError
    assert fresh.render.engine == "SPECULA"


@pytest.mark.parametrize("group", properties.classes)
def test_every_property_has_description_default_and_range(group):
    for prop in group.bl_rna.properties:
        if prop.identifier in ("rna_type", "name"):
            continue
        assert prop.description, prop.identifier
        if prop.type in ("INT", "FLOAT"):
            assert prop.hard_min < prop.hard_max, prop.identifier
            assert prop.hard_min <= prop.default <= prop.hard_max, prop.identifier


def test_scene_settings_defaults(fresh):
    s = fresh.specula
    assert (s.samples, s.time_limit, s.target_error, s.max_bounces, s.seed, s.threads) == \
        (64, 0.0, 0.0, 12, 0, 0)
    assert (s.fresnel, s.filter_type, s.filter_width) == ("EXACT", "BLACKMAN_HARRIS", 1.5)


@pytest.mark.parametrize("name", ["DATA_PT_camera_dof", "DATA_PT_camera_dof_aperture",
                                  "EEVEE_MATERIAL_PT_surface", "EEVEE_WORLD_PT_surface",
                                  "DATA_PT_EEVEE_light", "RENDER_PT_format"])
def test_blender_panels_show_for_specula(name):
    panel = getattr(bpy.types, name, None)
    if panel is None:
        pytest.skip(f"{name} does not exist in Blender {bpy.app.version_string}")
    assert "SPECULA" in panel.COMPAT_ENGINES


def test_unregister_restores_panels_and_reregisters():
    addon.unregister()
    try:
        assert "SPECULA" not in bpy.types.DATA_PT_camera_dof.COMPAT_ENGINES
        assert not hasattr(bpy.types.Scene, "specula")
    finally:
        addon.register()
    assert "SPECULA" in bpy.types.DATA_PT_camera_dof.COMPAT_ENGINES
    assert ui.SPECULA_RENDER_PT_sampling.is_registered

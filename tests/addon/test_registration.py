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


class RecordingLayout:
    """A stand-in for a panel's UILayout (there is no window in a headless bpy): it records
    what each prop() names, checking the property exists, and whether it is drawn active
    (a layout is only as active as the one it is in, as in Blender)."""

    def __init__(self, drawn, parent=None):
        self.drawn, self.parent = drawn, parent
        self.active, self.use_property_split = True, False

    def column(self, **_):
        return RecordingLayout(self.drawn, self)

    row = column

    def effective(self):
        return self.active and (self.parent is None or self.parent.effective())

    def prop(self, data, name, **_):
        assert name in data.bl_rna.properties, f"{data!r} has no property {name!r}"
        self.drawn[name] = self.effective()

    def label(self, **_):
        pass


def draw_panels(scene):
    """{property: whether it is drawn active} over Specula's panels."""
    import types
    drawn = {}
    context = types.SimpleNamespace(scene=scene, view_layer=scene.view_layers[0])
    for panel in ui.classes:
        panel.draw(types.SimpleNamespace(layout=RecordingLayout(drawn)), context)
    return drawn


def test_specula_panels_draw_existing_properties_with_film_options_active_as_in_cycles(fresh):
    """Every prop a Specula panel draws exists; Transparent Glass is active only with the
    film transparent, and its threshold only with Transparent Glass on (Cycles' Film
    panel)."""
    fresh.render.film_transparent, fresh.specula.film_transparent_glass = False, False
    drawn = draw_panels(fresh)
    assert {"samples", "max_bounces", "film_transparent", "film_transparent_glass",
            "use_pass_error"} <= set(drawn)
    assert not drawn["film_transparent_glass"] and not drawn["film_transparent_roughness"]
    fresh.render.film_transparent = True
    drawn = draw_panels(fresh)
    assert drawn["film_transparent_glass"] and not drawn["film_transparent_roughness"]
    fresh.specula.film_transparent_glass = True
    assert draw_panels(fresh)["film_transparent_roughness"]


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


def _warm_up_calls(monkeypatch, interactive, cached):
    """What the add-on asks the core's warm_up at registration and after a render."""
    import threading

    from addon import core

    asked = []

    class Core:
        def warm_up(self, compile_cold=True):
            asked.append(compile_cold)
            return cached or compile_cold

    def join():
        for thread in threading.enumerate():
            if thread.name == "specula-warm-up":
                thread.join(10)

    monkeypatch.setattr(core, "load", lambda: Core())
    monkeypatch.setattr(core, "_interactive", lambda: interactive)
    monkeypatch.setattr(core, "_generic_after_render", False)
    core.warm_up_in_background()
    join()
    core.after_render()
    join()
    core.after_render()  # once only
    join()
    return asked


@pytest.mark.parametrize("interactive, cached, calls", [
    (False, False, [False]), (False, True, [False]),
    (True, True, [False]), (True, False, [False, True])])
def test_generic_kernel_compiles_cold_only_after_a_render_in_the_interface(
        monkeypatch, interactive, cached, calls):
    """Registration only loads a cached generic kernel (compile_cold=False), so a first
    render is not kept waiting on numba's compiler; in the interface an uncached one
    compiles after the first render, once; a background session never compiles it cold."""
    assert _warm_up_calls(monkeypatch, interactive, cached) == calls

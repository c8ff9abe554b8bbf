"""Specula's panels, and Blender's own panels made visible when Specula is the engine."""

import bpy

ENGINE = "SPECULA"

# Blender's panels a Cycles-like engine needs but that are tagged EEVEE-only (names differ
# across versions; missing ones are skipped).
BLENDER_PANELS = (
    "EEVEE_MATERIAL_PT_context_material", "EEVEE_MATERIAL_PT_surface", "MATERIAL_PT_preview",
    "DATA_PT_camera_dof", "DATA_PT_camera_dof_aperture", "DATA_PT_EEVEE_light",
    "DATA_PT_light", "EEVEE_WORLD_PT_surface", "WORLD_PT_world",
    "VIEWLAYER_PT_layer_passes", "VIEWLAYER_PT_eevee_layer_passes_data",
    "VIEWLAYER_PT_eevee_next_layer_passes_data",
)
# Panels generic to every engine list the built-in renderers; they need Specula too.
GENERIC_ENGINE = "BLENDER_RENDER"

_added = []  # panel classes we added SPECULA to, so unregister removes only ours


def compatible_panels():
    """Blender panel classes that should show for Specula."""
    found = []
    for name in BLENDER_PANELS:
        cls = getattr(bpy.types, name, None)
        if cls is not None and hasattr(cls, "COMPAT_ENGINES"):
            found.append(cls)
    for name in dir(bpy.types):
        cls = getattr(bpy.types, name, None)
        engines = getattr(cls, "COMPAT_ENGINES", None)
        if engines is not None and GENERIC_ENGINE in engines and cls not in found:
            found.append(cls)
    return found


class SpeculaPanel:
    bl_space_type = 'PROPERTIES'
    bl_region_type = 'WINDOW'
    bl_context = "render"
    COMPAT_ENGINES = {ENGINE}

    @classmethod
    def poll(cls, context):
        return context.engine in cls.COMPAT_ENGINES


class SPECULA_RENDER_PT_sampling(SpeculaPanel, bpy.types.Panel):
    bl_label = "Sampling"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        s = context.scene.specula
        col = layout.column()
        col.prop(s, "samples")
        col.prop(s, "time_limit")
        col.prop(s, "target_error")
        col.prop(s, "seed")
        col.prop(s, "threads")
        col = layout.column(heading="Error Estimate")
        col.prop(s, "replicates")
        col.prop(s, "use_replicate_subset")
        sub = col.column(align=True)
        sub.active = s.use_replicate_subset
        sub.prop(s, "replicate_first")
        sub.prop(s, "replicate_last")


class SPECULA_RENDER_PT_light_paths(SpeculaPanel, bpy.types.Panel):
    bl_label = "Light Paths"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        s = context.scene.specula
        layout.prop(s, "max_bounces")
        layout.prop(s, "transparent_max_bounces")
        layout.prop(s, "fresnel")
        layout.prop(s, "use_light_tracing")


class SPECULA_RENDER_PT_film(SpeculaPanel, bpy.types.Panel):
    bl_label = "Film"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        s = context.scene.specula
        layout.prop(s, "filter_type")
        layout.prop(s, "filter_width")
        layout.prop(context.scene.render, "film_transparent", text="Transparent")
        # As Cycles' Film panel: Transparent Glass only matters with the film transparent.
        sub = layout.column()
        sub.active = context.scene.render.film_transparent
        sub.prop(s, "film_transparent_glass")
        glass = sub.column()
        glass.active = s.film_transparent_glass
        glass.prop(s, "film_transparent_roughness")


class SPECULA_VIEWLAYER_PT_passes(SpeculaPanel, bpy.types.Panel):
    bl_label = "Specula Passes"
    bl_context = "view_layer"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        view_layer = context.view_layer
        col = layout.column(heading="Include")
        col.prop(view_layer, "use_pass_z")
        col.prop(view_layer, "use_pass_normal")
        col.prop(view_layer.specula, "use_pass_error")
        col.prop(view_layer.specula, "use_pass_replicates")


classes = (SPECULA_RENDER_PT_sampling, SPECULA_RENDER_PT_light_paths, SPECULA_RENDER_PT_film,
           SPECULA_VIEWLAYER_PT_passes)


def register():
    for cls in classes:
        bpy.utils.register_class(cls)
    for panel in compatible_panels():
        if ENGINE not in panel.COMPAT_ENGINES:
            panel.COMPAT_ENGINES.add(ENGINE)
            _added.append(panel)


def unregister():
    for panel in _added:
        panel.COMPAT_ENGINES.discard(ENGINE)
    _added.clear()
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)

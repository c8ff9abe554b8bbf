"""The RenderEngine Blender sees; every callback is one line into RenderSession."""

import bpy

from . import core
from .render_session import RenderSession


class SpeculaRenderEngine(bpy.types.RenderEngine):
    bl_idname = "SPECULA"
    bl_label = "Specula"
    # Material/world previews would need a fast path; until then Blender draws them.
    bl_use_preview = False
    # Run the compositor on our passes (Depth, Normal, Specula Error).
    bl_use_postprocess = True
    # We have no real-time viewport: EEVEE draws Material Preview.
    bl_use_eevee_viewport = True
    # False keeps Cycles' and EEVEE's shader nodes visible and editable.
    bl_use_shading_nodes_custom = False

    def __init__(self, *args, **kwargs):
        # Blender 4.4+ passes arguments to RenderEngine subclasses' __init__.
        super().__init__(*args, **kwargs)
        self.session = RenderSession(self)

    def render(self, depsgraph):
        try:
            self.session.render(depsgraph)
        finally:
            core.after_render()  # the interface's generic kernel, if it was left for now

    def update_render_passes(self, scene=None, renderlayer=None):
        self.session.update_render_passes(scene, renderlayer)


classes = (SpeculaRenderEngine,)


def register():
    for cls in classes:
        bpy.utils.register_class(cls)


def unregister():
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)

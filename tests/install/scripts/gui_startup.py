"""Blender startup script for the F12 test: Specula selected, a short render, and a marker
file written by a render_complete handler (the test waits for it)."""

import os

import bpy

scene = bpy.context.scene
scene.render.engine = "SPECULA"
scene.specula.samples = int(os.environ.get("SPECULA_GUI_SAMPLES", "12"))
scene.render.resolution_percentage = 100
# The render opens in its own window (the default), which the test screenshots.
bpy.context.preferences.view.render_display_type = "WINDOW"


def _done(scene, *args):
    with open(os.environ["SPECULA_GUI_MARKER"], "w", encoding="utf-8") as f:
        f.write("rendered")


bpy.app.handlers.render_complete.append(_done)
print("SPECULA_GUI_READY", flush=True)

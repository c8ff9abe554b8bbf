"""Scale a glTF model's JPEG or PNG textures down in place, with Blender's own image code,
so that a sample model fits the repository (DamagedHelmet's five 2048 px maps are 3.2 MB).

Usage: .venv/bin/python tests/assets/gltf/shrink_textures.py SIZE IMAGE [IMAGE ...]

Each image becomes SIZE x SIZE (Blender's Image.scale: box-filtered) in its own format
(JPEG at quality 90), keeping its colour values as stored: the model's material reads them
as before, only coarser.
"""

import os
import sys

import bpy


def shrink(path: str, size: int) -> None:
    path = os.path.abspath(path)
    image = bpy.data.images.load(path)
    image.colorspace_settings.name = "Non-Color"  # scale the stored values, not decoded
    image.scale(size, size)
    fmt = "JPEG" if path.lower().endswith((".jpg", ".jpeg")) else "PNG"
    scene = bpy.context.scene
    scene.render.image_settings.file_format = fmt
    scene.render.image_settings.quality = 90
    scene.render.image_settings.color_management = "OVERRIDE"
    scene.render.image_settings.view_settings.view_transform = "Standard"
    image.save_render(path, scene=scene)
    bpy.data.images.remove(image)


if __name__ == "__main__":
    size = int(sys.argv[1])
    for p in sys.argv[2:]:
        shrink(p, size)
        print(p, "->", size)

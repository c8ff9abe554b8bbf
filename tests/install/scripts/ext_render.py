"""Run by a bpy module (4.2+) in a subprocess, in a fresh BLENDER_USER_RESOURCES:

    python ext_render.py EXTENSION_ZIP OUT_DIR SCENE.blend [SCENE.blend ...]

Installs the extension with the code behind `blender --command extension install-file -r
user_default -e ZIP`, then opens each scene, selects Specula, renders 2 samples at 25 %
(export + render: the smoke test) and saves an EXR. embreex is hidden from the venv so
that only the extension's bundled wheel can provide it. Prints one `RESULT {json}` line.
"""

import importlib.machinery
import json
import os
import sys

SITE = [p for p in sys.path if p.endswith("site-packages")]


# The extension's wheels: embreex, and numba with llvmlite for the compiled kernels.
BUNDLED = ("embreex", "numba", "llvmlite")


class HideVenvEmbreex:
    """Find the BUNDLED packages anywhere but the venv's site-packages (i.e. in the
    extension's)."""

    def find_spec(self, name, path=None, target=None):
        if name not in BUNDLED:
            return None
        spec = importlib.machinery.PathFinder.find_spec(
            name, [p for p in sys.path if p not in SITE])
        if spec is None:
            raise ModuleNotFoundError(f"{name} is hidden outside Blender's extension folders")
        return spec


sys.meta_path.insert(0, HideVenvEmbreex())

import bpy  # noqa: E402
from bl_pkg import bl_extension_cli  # noqa: E402

zip_path, out_dir, scenes = sys.argv[1], sys.argv[2], sys.argv[3:]
path_before = list(sys.path)
code = bl_extension_cli.cli_extension_handler(["install-file", "-r", "user_default", "-e",
                                               zip_path])
result = {"install_code": code, "blender": list(bpy.app.version), "renders": {}}
result["addons"] = sorted(a.module for a in bpy.context.preferences.addons
                          if "specula" in a.module)
for scene_path in scenes:
    name = os.path.relpath(scene_path, os.path.dirname(os.path.dirname(scene_path)))
    name = os.path.splitext(name)[0].replace(os.sep, "_")
    bpy.ops.wm.open_mainfile(filepath=scene_path)
    scene = bpy.context.scene
    scene.render.engine = "SPECULA"
    scene.specula.samples = 2
    scene.render.resolution_percentage = 25
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.filepath = os.path.join(out_dir, f"{name}.exr")
    session = next(m for n, m in sys.modules.items() if n.endswith("specula.render_session"))
    session.last_summary = {}
    bpy.ops.render.render(write_still=True)
    image = bpy.data.images.load(scene.render.filepath)
    pixels = list(image.pixels[:])
    result["renders"][name] = {
        "summary": {k: session.last_summary.get(k) for k in ("error", "samples", "triangles")},
        "kernel": (session.last_summary.get("plan") or {}).get("kernel"),
        "size": list(image.size), "mean": sum(pixels) / max(len(pixels), 1)}
import embreex  # noqa: E402

result["embreex"] = embreex.__file__
import numba  # noqa: E402

result["numba"] = numba.__file__
result["core"] = sorted(m for m in sys.modules if m.endswith("bundled.engine"))
result["added_to_sys_path"] = [p for p in sys.path if p not in path_before]
print("RESULT " + json.dumps(result))

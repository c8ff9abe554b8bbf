"""Shared helpers for the installation tests: Debian's Blender, fresh user folders, zips.

These tests run real Blender binaries and the bpy modules of several versions in
subprocesses, each with its own empty user folder (BLENDER_USER_SCRIPTS / _CONFIG for
Blender 3.4, BLENDER_USER_RESOURCES for 4.2+), so nothing leaks from one test into another
or from the machine's own Blender setup.
"""

from __future__ import annotations

import glob
import json
import os
import shutil
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
DIST = os.path.join(ROOT, "dist")
ARTIFACTS = os.path.join(ROOT, "out", "artifacts")
SCENES_34 = os.path.join(ROOT, "blend_scenes", "v3.4")
SCENE_NAMES = ("cbspheres", "cbdragon", "default")
# What the legacy add-on needs in Blender's Python (Debian's Blender 3.4 has no numpy).
LEGACY_MODULES = ("numpy==1.26.4", "embreex==4.4.0.post1", "numba==0.68.1",
                  "llvmlite==0.50.0")
# bpy module versions of the smoke test: venv folder -> the LTS release it holds.
COMPAT_VENVS = {"4.2": ".venv-bpy42", "4.5": ".venv-bpy45"}
BLENDER = shutil.which("blender")


def blender_version():
    """(major, minor) of the `blender` on PATH, or None."""
    if BLENDER is None:
        return None
    out = subprocess.run([BLENDER, "--version"], capture_output=True, text=True, timeout=60)
    for line in out.stdout.splitlines():
        if line.startswith("Blender "):
            major, minor = line.split()[1].split(".")[:2]
            return int(major), int(minor)
    return None


def version():
    """The add-on's "x.y.z" (the zips' names)."""
    sys.path.insert(0, os.path.join(ROOT, "tools"))
    try:
        import build_extension
        return build_extension.addon_version()
    finally:
        sys.path.pop(0)


def build_dist():
    """Run `make dist`'s script; returns {platform or 'legacy': zip path}."""
    subprocess.run([sys.executable, os.path.join(ROOT, "tools", "build_extension.py")],
                   check=True, capture_output=True, text=True, timeout=600)
    zips = {}
    for path in glob.glob(os.path.join(DIST, f"specula-{version()}-*.zip")):
        zips[os.path.basename(path)[:-4].rsplit("-", 1)[1]] = path
    return zips


def run(cmd, env=None, cwd=None, timeout=600, check=True):
    """Run a command; on failure the assertion shows its output."""
    full_env = dict(os.environ, **(env or {}))
    proc = subprocess.run(cmd, env=full_env, cwd=cwd, capture_output=True, text=True,
                          timeout=timeout)
    if check:
        assert proc.returncode == 0, (f"{cmd} exited {proc.returncode}\n--- stdout\n"
                                      f"{proc.stdout[-4000:]}\n--- stderr\n{proc.stderr[-4000:]}")
    return proc


def legacy_env(user):
    """Environment for Blender < 4.2 with its user folders inside `user`."""
    return {"BLENDER_USER_SCRIPTS": os.path.join(user, "scripts"),
            "BLENDER_USER_CONFIG": os.path.join(user, "config")}


def install_legacy(user, legacy_zip):
    """Install as docs/INSTALL.md tells a Blender 3.4 - 4.1 user: numpy, embreex and numba into the
    user scripts' `modules` folder (on Blender's sys.path), then Preferences > Add-ons >
    Install... with the zip, enable, save preferences."""
    env = legacy_env(user)
    modules = os.path.join(env["BLENDER_USER_SCRIPTS"], "modules")
    os.makedirs(modules, exist_ok=True)
    os.makedirs(env["BLENDER_USER_CONFIG"], exist_ok=True)
    run([sys.executable, "-m", "pip", "install", "--quiet", "--target", modules,
         "--only-binary=:all:", "--python-version", "3.11", *LEGACY_MODULES])
    script = (
        "import bpy, addon_utils\n"
        f"bpy.ops.preferences.addon_install(filepath={legacy_zip!r})\n"
        "bpy.ops.preferences.addon_enable(module='specula')\n"
        "bpy.ops.wm.save_userpref()\n"
        "import specula\n"
        "print('SPECULA_AT', specula.__file__)\n")
    out = run([BLENDER, "-b", "--python-exit-code", "1", "--python-expr", script], env=env)
    assert "SPECULA_AT " + env["BLENDER_USER_SCRIPTS"] in out.stdout, out.stdout
    return env


def json_line(stdout, tag):
    """The JSON printed after `tag` by a Blender-side script."""
    for line in stdout.splitlines():
        if line.startswith(tag + " "):
            return json.loads(line[len(tag) + 1:])
    raise AssertionError(f"no {tag} line in output:\n{stdout[-4000:]}")


def read_images(paths):
    """Load image files (EXR/PNG) with the bpy module in a subprocess: {path: (H, W, 4)
    float32, row 0 at the bottom} as Blender stores them."""
    import numpy as np
    code = (
        "import sys, bpy, numpy as np\n"
        "out = {}\n"
        "for i, p in enumerate(sys.argv[2:]):\n"
        "    img = bpy.data.images.load(p)\n"
        "    w, h = img.size\n"
        "    a = np.zeros(w * h * 4, np.float32)\n"
        "    img.pixels.foreach_get(a)\n"
        "    out[f'i{i}'] = a.reshape(h, w, 4)\n"
        "np.savez(sys.argv[1], **out)\n")
    dest = os.path.join(os.path.dirname(paths[0]), "_images.npz")
    run([os.path.join(ROOT, ".venv", "bin", "python"), "-c", code, dest, *paths])
    data = np.load(dest)
    return {p: data[f"i{i}"] for i, p in enumerate(paths)}


def compat_python(release):
    """The python of the bpy `release` venv (`make compat`), or None."""
    path = os.path.join(ROOT, COMPAT_VENVS[release], "bin", "python")
    return path if os.path.isfile(path) else None

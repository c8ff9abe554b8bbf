"""Build Specula's installable zips into dist/: an extension per platform and a legacy add-on.

Run: .venv/bin/python tools/build_extension.py [--dist DIR] [--wheels-cache DIR] [--offline]
(`make dist`).

What goes in each package (a folder named `specula`, the add-on's import name):

  *.py                  addon/*.py, the Blender glue, unchanged
  bundled/engine/*.py   the rendering core, a subpackage: `addon/core.py` imports it as
                        `.bundled.engine` (the core uses only relative imports inside itself),
                        so nothing is installed as a global top-level module and nothing
                        touches sys.path
  blender_manifest.toml (extensions only) id `specula`, Blender 4.2.0+, the platform's wheel
  wheels/*.whl          (extensions only) embreex for Blender's Python 3.11, and numba with
                        llvmlite (the compiled kernels, engine/integrator.py) where PyPI has them
                        for the platform, unmodified from PyPI; Blender installs them on
                        enable. numpy comes with Blender. Without numba (macOS x64: llvmlite
                        0.50 has no wheel for it) the same kernel runs as plain Python (slow).

Outputs:
  dist/specula-<version>-<platform>.zip   Blender 4.2 - 5.0 extensions, built and validated by
                                          Blender's own `blender_ext.py` (the code behind
                                          `blender --command extension build --split-platforms`),
                                          taken from the bpy module in .venv
  dist/specula-<version>-legacy.zip       the legacy add-on (Blender 3.4 - 4.1): the same sources
                                          without manifest or wheels; embreex is installed into
                                          Blender's scripts/modules folder (docs/INSTALL.md)

embreex's only dependency is numpy (its metadata: `Requires-Dist: numpy`); numba's are
llvmlite and numpy (>= 1.22, < 2.6).
"""

from __future__ import annotations

import argparse
import ast
import glob
import os
import shutil
import subprocess
import sys
import zipfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PACKAGE = "specula"
EMBREEX = "embreex==4.4.0.post1"
# The compiled kernels' wheels (same pins as requirements.txt).
COMPILED = ("numba==0.68.1", "llvmlite==0.50.0")
# Blender 4.2 - 5.0 run Python 3.11.
BLENDER_PYTHON = "3.11"
# Every platform PyPI has an embreex cp311 wheel for, as pip platform tag -> Blender platform.
# (embreex 4.4.0.post1 publishes no linux-arm64 or windows-arm64 wheels.)
WHEEL_PLATFORMS = {
    "manylinux_2_28_x86_64": "linux-x64",
    "win_amd64": "windows-x64",
    "macosx_13_0_arm64": "macos-arm64",
    "macosx_13_0_x86_64": "macos-x64",
}
# numba and llvmlite 0.50 publish cp311 wheels for these (not macOS x86_64).
COMPILED_PLATFORMS = ("manylinux_2_28_x86_64", "win_amd64", "macosx_13_0_arm64")
BLENDER_VERSION_MIN = "4.2.0"
LICENSE = "SPDX:GPL-3.0-or-later"


def addon_version():
    """`bl_info["version"]` of addon/__init__.py as "x.y.z" (read, not imported)."""
    with open(os.path.join(ROOT, "addon", "__init__.py"), encoding="utf-8") as f:
        tree = ast.parse(f.read())
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(getattr(t, "id", "") == "bl_info"
                                                for t in node.targets):
            info = ast.literal_eval(node.value)
            return ".".join(str(v) for v in info["version"])
    raise SystemExit("addon/__init__.py has no bl_info")


def blender_ext_script():
    """Blender's extension tool, from the bpy module of the running interpreter."""
    try:
        import importlib.util
        spec = importlib.util.find_spec("bpy")
    except ImportError:
        spec = None
    if spec is None or not spec.submodule_search_locations:
        raise SystemExit("the bpy module is needed for Blender's blender_ext.py: run `make setup`")
    base = list(spec.submodule_search_locations)[0]
    found = sorted(glob.glob(os.path.join(base, "*", "scripts", "addons_core", "bl_pkg", "cli",
                                          "blender_ext.py")))
    if not found:
        raise SystemExit(f"blender_ext.py not found under {base}")
    return found[-1]


def download_wheels(cache, offline):
    """Download the wheels of every platform (once; kept in `cache`): a list of paths."""
    os.makedirs(cache, exist_ok=True)
    wheels = []
    for tag, platform in WHEEL_PLATFORMS.items():
        specs = [EMBREEX] + (list(COMPILED) if tag in COMPILED_PLATFORMS else [])
        for spec in specs:
            wheels.append(_wheel(cache, spec, tag, platform, offline))
    return wheels


def _wheel(cache, spec, tag, platform, offline):
    """The cached cp311 wheel of `spec` for pip platform `tag`, downloaded if missing."""
    name, version = spec.split("==")
    pattern = os.path.join(cache, f"{name}-{version}-cp311-cp311-*.whl")

    def found():
        return [w for w in glob.glob(pattern) if _matches(w, tag)]

    have = found()
    if not have:
        if offline:
            raise SystemExit(f"no cached {name} wheel for {platform} in {cache}")
        subprocess.run([sys.executable, "-m", "pip", "download", spec, "--no-deps",
                        "--only-binary=:all:", "--python-version", BLENDER_PYTHON,
                        "--platform", tag, "--dest", cache, "--quiet"], check=True)
        have = found()
    if len(have) != 1:
        raise SystemExit(f"expected one {name} wheel for {platform}, found {have}")
    return have[0]


def _platform_tags(path):
    """A wheel file's platform tags: 'a.b' in `name-ver-py-abi-a.b.whl` -> {'a', 'b'}."""
    return set(os.path.basename(path)[:-len(".whl")].split("-")[-1].split("."))


def _matches(path, tag):
    """Whether a wheel fits pip platform `tag`: the same tag, or for macOS the same
    architecture (a wheel for an older macOS runs on a newer one)."""
    tags = _platform_tags(path)
    if tag in tags:
        return True
    if tag.startswith("macosx_"):
        arch = tag.split("_", 3)[3]
        return any(t.startswith("macosx_") and t.split("_", 3)[3] == arch for t in tags)
    return False


def stage_sources(dest):
    """Copy the add-on and the core (as bundled/engine) into `dest`."""
    if os.path.exists(dest):
        shutil.rmtree(dest)
    os.makedirs(os.path.join(dest, "bundled", "engine"))
    for path in sorted(glob.glob(os.path.join(ROOT, "addon", "*.py"))):
        shutil.copy2(path, dest)
    for path in sorted(glob.glob(os.path.join(ROOT, "engine", "*.py"))):
        shutil.copy2(path, os.path.join(dest, "bundled", "engine"))
    with open(os.path.join(dest, "bundled", "__init__.py"), "w", encoding="utf-8") as f:
        f.write('"""Specula\'s rendering core, packaged with the add-on (see core.py)."""\n')


def manifest(version, wheel_names):
    wheels = ",\n".join(f'  "./wheels/{name}"' for name in sorted(wheel_names))
    platforms = ", ".join(f'"{p}"' for p in sorted(WHEEL_PLATFORMS.values()))
    return f"""\
schema_version = "1.0.0"

id = "{PACKAGE}"
version = "{version}"
name = "Specula"
tagline = "Numpy and Embree path tracer with Cycles-matching materials"
maintainer = "Specula developers"
type = "add-on"
tags = ["Render"]

blender_version_min = "{BLENDER_VERSION_MIN}"

license = ["{LICENSE}"]

# embreex wheels exist on PyPI for these platforms only (Python {BLENDER_PYTHON}).
platforms = [{platforms}]

# Unmodified from PyPI: embreex, and numba + llvmlite (the compiled kernels) where PyPI
# has them; their other dependency, numpy, ships with Blender.
wheels = [
{wheels},
]
"""


def build_extensions(stage, dist, version, wheels):
    os.makedirs(os.path.join(stage, "wheels"))
    for path in wheels:
        shutil.copy2(path, os.path.join(stage, "wheels"))
    with open(os.path.join(stage, "blender_manifest.toml"), "w", encoding="utf-8") as f:
        f.write(manifest(version, [os.path.basename(p) for p in wheels]))
    tool = blender_ext_script()
    for old in glob.glob(os.path.join(dist, f"{PACKAGE}-{version}-*.zip")):
        if not old.endswith("-legacy.zip"):
            os.remove(old)
    subprocess.run([sys.executable, tool, "build", "--source-dir", stage, "--output-dir", dist,
                    "--split-platforms"], check=True)
    built = sorted(glob.glob(os.path.join(dist, f"{PACKAGE}-{version}-*.zip")))
    built = [b for b in built if not b.endswith("-legacy.zip")]
    for path in built:
        subprocess.run([sys.executable, tool, "validate", path], check=True,
                       stdout=subprocess.DEVNULL)
    return built


def build_legacy(stage, dist, version):
    """A zip whose single top folder `specula/` is the add-on, for Edit > Preferences >
    Add-ons > Install... (Blender 3.4 - 4.1)."""
    path = os.path.join(dist, f"{PACKAGE}-{version}-legacy.zip")
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
        for folder, dirs, files in os.walk(stage):
            dirs[:] = sorted(d for d in dirs if d not in ("wheels", "__pycache__"))
            for name in sorted(files):
                if name == "blender_manifest.toml" or not name.endswith(".py"):
                    continue
                full = os.path.join(folder, name)
                z.write(full, os.path.join(PACKAGE, os.path.relpath(full, stage)))
    return path


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dist", default=os.path.join(ROOT, "dist"))
    parser.add_argument("--wheels-cache", default=os.path.join(ROOT, "build", "wheels"))
    parser.add_argument("--offline", action="store_true",
                        help="use only wheels already in the cache")
    args = parser.parse_args(argv)
    version = addon_version()
    os.makedirs(args.dist, exist_ok=True)
    stage = os.path.join(ROOT, "build", "stage", PACKAGE)
    stage_sources(stage)
    legacy = build_legacy(stage, args.dist, version)
    wheels = download_wheels(args.wheels_cache, args.offline)
    built = build_extensions(stage, args.dist, version, wheels)
    for path in built + [legacy]:
        print(f"{os.path.relpath(path, ROOT)} ({os.path.getsize(path) // 1024} KiB)")


if __name__ == "__main__":
    main()

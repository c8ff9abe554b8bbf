"""`make dist`: one extension zip per platform PyPI has embreex wheels for, and a legacy zip."""

import ast
import glob
import os
import sys
import tomllib
import zipfile

import pytest

from . import helpers

PLATFORMS = {"linux_x64": "linux-x64", "windows_x64": "windows-x64",
             "macos_arm64": "macos-arm64", "macos_x64": "macos-x64"}
# Wheel platform tags that run on each Blender platform.
WHEEL_TAGS = {"linux-x64": "manylinux_2_28_x86_64", "windows-x64": "win_amd64",
              "macos-arm64": "macosx_13_0_arm64", "macos-x64": "macosx_13_0_x86_64"}
# llvmlite 0.50 has no macOS x86_64 wheel: that zip renders with the numpy stages.
COMPILED = {"linux_x64", "windows_x64", "macos_arm64"}
CORE_MODULES = sorted(os.path.basename(p) for p in glob.glob(os.path.join(helpers.ROOT,
                                                                        "engine", "*.py")))


def _arch(tag):
    """The part of a platform tag every wheel for it carries (macOS wheels may name an
    older minimum macOS: macosx_12_0_arm64 runs where macosx_13_0_arm64 does)."""
    return tag.split("_", 3)[3] if tag.startswith("macosx_") else tag


def test_one_zip_per_platform_and_a_legacy_zip(dist):
    assert set(dist) == set(PLATFORMS) | {"legacy"}


@pytest.mark.parametrize("platform", sorted(PLATFORMS))
def test_extension_zip(dist, platform):
    with zipfile.ZipFile(dist[platform]) as z:
        names = set(z.namelist())
        manifest = tomllib.loads(z.read("blender_manifest.toml").decode())
    assert manifest["schema_version"] == "1.0.0"
    assert manifest["id"] == "specula"
    assert manifest["type"] == "add-on"
    assert manifest["version"] == helpers.version()
    assert manifest["blender_version_min"] == "4.2.0"
    # Split per platform: only this platform, only its wheel, under wheels/. Blender's
    # builder keeps the source lists and overrides them in [build.generated].
    generated = manifest["build"]["generated"]
    assert generated["platforms"] == [PLATFORMS[platform]]
    # embreex everywhere; numba and llvmlite (the compiled kernels) where PyPI has them.
    expected = ["embreex-4.4.0.post1"] + (["llvmlite-0.50.0", "numba-0.68.1"]
                                         if platform in COMPILED else [])
    wheels = sorted(generated["wheels"])
    assert [w[len("./wheels/"):].split("-cp311")[0] for w in wheels] == expected
    assert sum(n.endswith(".whl") for n in names) == len(expected)
    for wheel in wheels:
        assert _arch(WHEEL_TAGS[PLATFORMS[platform]]) in wheel
        assert wheel[2:] in names
    assert not any(n.startswith("wheels/numpy") for n in names)  # Blender ships numpy
    # The add-on and the core as its subpackage; no top-level `engine` package.
    assert {"__init__.py", "engine.py", "core.py", "exporter.py", "bundled/__init__.py"} <= names
    assert {f"bundled/engine/{m}" for m in CORE_MODULES} <= names
    assert not any(n.startswith("engine/") for n in names)


def test_legacy_zip(dist):
    with zipfile.ZipFile(dist["legacy"]) as z:
        names = set(z.namelist())
    assert all(n.startswith("specula/") for n in names)
    assert {"specula/__init__.py", "specula/bundled/__init__.py"} <= names
    assert {f"specula/bundled/engine/{m}" for m in CORE_MODULES} <= names
    assert not any(n.endswith((".whl", ".toml")) for n in names)


def test_bl_info_covers_blender_34():
    with open(os.path.join(helpers.ROOT, "addon", "__init__.py"), encoding="utf-8") as f:
        tree = ast.parse(f.read())
    info = next(ast.literal_eval(n.value) for n in tree.body if isinstance(n, ast.Assign)
                and getattr(n.targets[0], "id", "") == "bl_info")
    assert info["blender"] <= (3, 4, 0)


def test_core_imports_only_relative_stdlib_numpy_embreex_numba():
    """So the core works as `specula.bundled.engine` without sys.path changes (numba and
    its llvmlite through engine/jit.py, which runs the same functions as Python without them)."""
    allowed = set(sys.stdlib_module_names) | {"numpy", "embreex", "numba", "llvmlite"}
    for path in glob.glob(os.path.join(helpers.ROOT, "engine", "*.py")):
        with open(path, encoding="utf-8") as f:
            tree = ast.parse(f.read())
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                tops = [a.name.split(".")[0] for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0:
                tops = [node.module.split(".")[0]]
            else:
                continue
            assert set(tops) <= allowed, f"{path}: imports {tops}"

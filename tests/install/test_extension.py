"""The extension as a Blender 4.2+ user installs it, in bpy 5.0.1, 4.2 LTS and 4.5 LTS.

Each run starts from an empty user folder, installs `dist/specula-<v>-linux_x64.zip` with
the code behind `blender --command extension install-file -r user_default -e ZIP` (the bpy
module has no command line), then opens every scene in blend_scenes/ that the version can
read, selects Specula and renders 2 samples at 25 % (the version-range smoke test).
embreex, numba and llvmlite are hidden from the venv, so the extension's own wheels must
provide them, and the scenes the compiled kernels cover render with them.
"""

import glob
import os
import sys

import pytest

from . import helpers

pytestmark = pytest.mark.slow

RELEASES = {"5.0": os.path.join(helpers.ROOT, ".venv", "bin", "python"),
            **{r: helpers.compat_python(r) for r in helpers.COMPAT_VENVS}}


def scenes_for(release):
    """blend_scenes/v3.4/* open everywhere; files saved by 5.0 open in 4.5 and later."""
    scenes = sorted(glob.glob(os.path.join(helpers.SCENES_34, "*.blend")))
    if tuple(int(v) for v in release.split(".")) >= (4, 5):
        scenes += sorted(glob.glob(os.path.join(helpers.ROOT, "blend_scenes", "*.blend")))
    return scenes


@pytest.mark.parametrize("release", sorted(RELEASES))
def test_install_file_enable_render(release, dist, tmp_path):
    python = RELEASES[release]
    if python is None:
        pytest.skip(f"no bpy {release} venv: run `make compat`")
    scenes = scenes_for(release)
    assert len(scenes) >= 3
    out = helpers.run([python, os.path.join(os.path.dirname(__file__), "scripts",
                                            "ext_render.py"), dist["linux_x64"],
                       str(tmp_path), *scenes],
                      env={"BLENDER_USER_RESOURCES": str(tmp_path / "user")}, timeout=900)
    result = helpers.json_line(out.stdout, "RESULT")
    assert result["blender"][:2] == [int(v) for v in release.split(".")]
    assert result["install_code"] == 0
    assert result["addons"] == ["bl_ext.user_default.specula"]
    ext_site = str(tmp_path / "user" / "extensions" / ".local")
    assert result["embreex"].startswith(ext_site), result["embreex"]
    assert result["numba"].startswith(ext_site), result["numba"]
    assert result["core"] == ["bl_ext.user_default.specula.bundled.engine"]
    # Only Blender's own wheel folder joins sys.path; the add-on adds nothing.
    assert all(p.startswith(ext_site) for p in result["added_to_sys_path"])
    assert len(result["renders"]) == len(scenes)
    for name, r in result["renders"].items():
        assert r["summary"]["error"] is None, (name, r)
        assert r["summary"]["samples"] == 2, (name, r)
        assert r["mean"] > 0.01, (name, r)  # not a black image
    # The extension's numba compiles the kernels, and every scene renders with them
    # (default.blend: Principled and a point light).
    kernels = {name: r["kernel"] for name, r in result["renders"].items()}
    assert set(kernels.values()) <= {"generic", "specialised", "generic, then specialised"}, \
        kernels
    print(sys.version, result["renders"])

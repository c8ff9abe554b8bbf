"""Debian's Blender 3.4.1 (`apt-get install blender`) with the legacy add-on installed from
dist/specula-<v>-legacy.zip into a fresh user folder (see conftest.blender34)."""

import glob
import os
import shutil

import pytest

from . import helpers

pytestmark = pytest.mark.slow


def test_farm_command_writes_the_frame(blender34, tmp_path, artifacts):
    """`blender -b SCENE -E SPECULA -o out/frame_#### -f 1`, as a render farm runs it.

    (Blender handles arguments in order, so `-o` must come before `-f`.) The scene is the
    3.4 build of cbspheres (files saved by 5.0 do not open in 3.4) at its own settings."""
    scene = os.path.join(helpers.SCENES_34, "cbspheres.blend")
    helpers.run([helpers.BLENDER, "-b", scene, "-E", "SPECULA", "-o", "out/frame_####",
                 "-f", "1"], env=blender34, cwd=tmp_path, timeout=900)
    frame = tmp_path / "out" / "frame_0001.png"
    assert frame.is_file()
    shutil.copy(frame, os.path.join(artifacts, "blender34_cbspheres_frame_0001.png"))
    (image,) = helpers.read_images([str(frame)]).values()
    assert image.shape == (360, 480, 4)
    assert image[..., :3].mean() > 0.1


def test_frame_range(blender34, tmp_path):
    """`-s 2 -e 3 -a` renders exactly frames 2 and 3 (farm managers split ranges this way)."""
    scene = os.path.join(helpers.SCENES_34, "cbspheres.blend")
    setup = ("import bpy; s = bpy.context.scene; s.specula.samples = 1; "
             "s.render.resolution_percentage = 10")
    helpers.run([helpers.BLENDER, "-b", scene, "-E", "SPECULA", "--python-expr", setup,
                 "-o", str(tmp_path / "f_####"), "-s", "2", "-e", "3", "-a"], env=blender34)
    assert sorted(os.listdir(tmp_path)) == ["f_0002.png", "f_0003.png"]


@pytest.mark.parametrize("name", helpers.SCENE_NAMES)
def test_scene_renders(blender34, tmp_path, name):
    """Every scene's 3.4 build exports and renders in 3.4 (2 samples, 25 %)."""
    scene = os.path.join(helpers.SCENES_34, f"{name}.blend")
    setup = ("import bpy; s = bpy.context.scene; s.specula.samples = 2; "
             "s.render.resolution_percentage = 25")
    out = helpers.run([helpers.BLENDER, "-b", scene, "-E", "SPECULA", "--python-expr", setup,
                       "-o", str(tmp_path / "f_####"), "-F", "OPEN_EXR", "-f", "1"],
                      env=blender34)
    assert "Specula | Sample 2/2" in out.stdout
    (image,) = helpers.read_images(glob.glob(str(tmp_path / "f_0001.exr"))).values()
    assert image[..., :3].mean() > 0.01


def test_api_differences_before_4(blender34, tmp_path):
    out = helpers.run([helpers.BLENDER, "-b", "--python-exit-code", "1", "--python",
                       os.path.join(os.path.dirname(__file__), "scripts", "api34.py")],
                      env=blender34)
    r = helpers.json_line(out.stdout, "RESULT")
    assert r["version"][:2] == [3, 4]
    assert r["glass"]["ctor"] == "principled_glass"
    assert r["glass"]["kwargs"]["ior"] == pytest.approx(1.33)
    assert r["glass"]["kwargs"]["emission"] == pytest.approx([2.0, 1.0, 0.5])
    assert r["glass"]["warnings"] == []
    assert r["metal"]["ctor"] == "metal"
    assert r["sphere"]["smooth"]
    # Smooth: vertex normals, within 0.05 of the radial ones (flat faces would be ~0.2 off).
    assert r["sphere"]["max_normal_error"] < 0.05

"""`python -m addon render ...` as a user runs it: subprocesses, exit codes, JSON line."""

import json
import os
import subprocess
import sys

import bpy
import numpy as np
import pytest
from conftest import REPO, SCENES_DIR

from addon import cli

DEFAULT = os.path.join(SCENES_DIR, "default.blend")
CBSPHERES = os.path.join(SCENES_DIR, "cbspheres.blend")


def run(*args, timeout=1200):
    return subprocess.run([sys.executable, "-m", "addon", *map(str, args)], cwd=REPO,
                          capture_output=True, text=True, timeout=timeout)


def last_json(stdout):
    return json.loads(stdout.strip().splitlines()[-1])


@pytest.mark.slow
def test_render_exr_is_linear_float(tmp_path):
    out = tmp_path / "default.exr"
    proc = run("render", DEFAULT, "--samples", 2, "--resolution", "64x36", "--seed", 3,
               "--max-bounces", 2, "--output", out)
    assert proc.returncode == 0, proc.stderr
    summary = last_json(proc.stdout)
    assert summary["engine"] == "SPECULA" and summary["samples"] == 2
    assert {"seconds", "relative_error", "plan"} <= summary.keys()
    assert summary["plan"]["max_bounces"] == 2
    assert summary["plan"]["light_objects"] == 1  # the factory scene's point light
    image = bpy.data.images.load(str(out))
    assert image.is_float and tuple(image.size) == (64, 36)
    px = np.zeros(64 * 36 * 4, np.float32)
    image.pixels.foreach_get(px)
    assert np.isfinite(px).all() and px.max() > 0


@pytest.mark.slow
def test_render_png_and_time_limit(tmp_path):
    out = tmp_path / "cb.png"
    proc = run("render", CBSPHERES, "--samples", 1000, "--time-limit", 0.5,
               "--resolution", "40x30", "--output", out)
    assert proc.returncode == 0, proc.stderr
    summary = last_json(proc.stdout)
    assert summary["stop_reason"] == "time limit" and summary["samples"] < 1000
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.slow
def test_one_render_saved_as_exr_and_png(tmp_path):
    exr, png = tmp_path / "a.exr", tmp_path / "a.png"
    proc = run("render", CBSPHERES, "--samples", 2, "--resolution", "40x30", "--output", exr,
               "--output", png)
    assert proc.returncode == 0, proc.stderr
    assert last_json(proc.stdout)["output"] == [str(exr), str(png)]
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    image = bpy.data.images.load(str(exr))
    assert image.is_float and tuple(image.size) == (40, 30)


@pytest.mark.slow
def test_render_with_cycles(tmp_path):
    out = tmp_path / "cycles.exr"
    proc = run("render", CBSPHERES, "--engine", "CYCLES", "--samples", 1, "--resolution",
               "32x24", "--output", out)
    assert proc.returncode == 0, proc.stderr
    assert last_json(proc.stdout)["engine"] == "CYCLES"
    assert out.is_file()


def test_cycles_is_configured_unbiased(fresh):
    args = cli.build_parser().parse_args(["render", "x.blend", "--engine", "cycles",
                                          "--samples", "7", "--max-bounces", "5"])
    fresh.specula.filter_type = "GAUSSIAN"
    fresh.specula.filter_width = 2.0
    cli._configure_cycles(fresh, args)
    c = fresh.cycles
    assert (c.samples, c.device, c.use_denoising, c.use_adaptive_sampling) == \
        (7, "CPU", False, False)
    assert (c.sample_clamp_direct, c.sample_clamp_indirect, c.blur_glossy,
            c.light_sampling_threshold) == (0, 0, 0, 0)
    assert [c.max_bounces, c.diffuse_bounces, c.glossy_bounces, c.transmission_bounces,
            c.volume_bounces] == [5] * 5
    assert (c.pixel_filter_type, c.filter_width) == ("GAUSSIAN", 2.0)


def test_missing_file_fails_cleanly(tmp_path):
    proc = run("render", tmp_path / "nope.blend")
    assert proc.returncode == 1
    assert "not found" in proc.stderr and "Traceback" not in proc.stderr


def test_unreadable_file_fails_cleanly(tmp_path):
    bad = tmp_path / "bad.blend"
    bad.write_text("this is not a blend file")
    proc = run("render", bad, "--output", tmp_path / "x.exr")
    assert proc.returncode == 1
    assert "cannot read" in proc.stderr and "Traceback" not in proc.stderr


@pytest.mark.parametrize("args", [
    ["render", DEFAULT, "--samples", "0"],
    ["render", DEFAULT, "--samples", "many"],
    ["render", DEFAULT, "--resolution", "64by36"],
    ["render", DEFAULT, "--engine", "EEVEE"],
    ["render", DEFAULT, "--output", "out.jpg"],
    ["render", DEFAULT, "--time-limit", "-1"],
    ["render"],
    [],
])
def test_bad_arguments_exit_2(args):
    proc = run(*args)
    assert proc.returncode == 2
    assert "usage:" in proc.stderr and "Traceback" not in proc.stderr


@pytest.mark.slow
def test_enables_as_an_installed_addon(tmp_path):
    """Linked into scripts/addons as 'specula' and enabled the way Blender does it."""
    addons = tmp_path / "scripts" / "addons"
    addons.mkdir(parents=True)
    (addons / "specula").symlink_to(os.path.join(REPO, "addon"), target_is_directory=True)
    out = tmp_path / "installed.exr"
    code = (
        "import bpy\nimport addon_utils, json\n"
        "addon_utils.enable('specula', default_set=True, handle_error=None)\n"
        f"bpy.ops.wm.open_mainfile(filepath={CBSPHERES!r})\n"
        "s = bpy.context.scene\n"
        "s.render.resolution_percentage = 10\n"
        "s.specula.samples = 2\n"
        "s.render.image_settings.file_format = 'OPEN_EXR'\n"
        f"s.render.filepath = {str(out)!r}\n"
        "bpy.ops.render.render(write_still=True)\n"
        "import specula.render_session as rs\n"
        "print(json.dumps(rs.last_summary, default=str))\n")
    env = dict(os.environ, BLENDER_USER_SCRIPTS=str(tmp_path / "scripts"))
    proc = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=1200)
    assert proc.returncode == 0, proc.stderr
    assert last_json(proc.stdout)["samples"] == 2
    assert out.is_file()


# ---------------------------------------------------------------------------------------
# Real files: a renamed Render Result, warnings, the JSON line


def saved_scene(tmp_path, name, edit):
    """cbspheres.blend changed by `edit(scene)` (in this process), saved as tmp_path/name."""
    bpy.ops.wm.open_mainfile(filepath=CBSPHERES)
    edit(bpy.context.scene)
    path = tmp_path / name
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    return path


@pytest.mark.slow
@pytest.mark.parametrize("engine", ["SPECULA", "CYCLES"])
def test_renamed_render_result_is_found_by_type(tmp_path, engine):
    def rename_render_result(scene):
        scene.render.resolution_percentage = 5
        scene.specula.samples = 1
        bpy.ops.render.render()
        image = next(i for i in bpy.data.images if i.type == "RENDER_RESULT")
        image.name = "My Render"  # saved with the file, and reused by the next render
        image.use_fake_user = True
    scene = saved_scene(tmp_path, "renamed.blend", rename_render_result)
    out = tmp_path / "r.exr"
    proc = run("render", scene, "--engine", engine, "--samples", 1, "--resolution", "24x18",
               "--output", out)
    assert proc.returncode == 0, proc.stderr
    assert out.is_file()


@pytest.mark.slow
def test_json_file_and_last_line(tmp_path):
    js = tmp_path / "sub" / "summary.json"
    proc = run("render", CBSPHERES, "--samples", 2, "--resolution", "24x18", "--output",
               tmp_path / "a.exr", "--json", js)
    assert proc.returncode == 0, proc.stderr
    assert json.loads(js.read_text()) == last_json(proc.stdout)
    # Blender's own lines ("Read blend: ...") go to stderr: stdout is the JSON alone.
    assert len(proc.stdout.strip().splitlines()) == 1


@pytest.mark.slow
def test_json_stays_last_when_blender_prints_at_exit(tmp_path):
    """Blender prints at exit ("Not freed memory blocks", with C stdio, for files saved by
    newer versions); after the JSON line that text must not reach stdout."""
    code = (
        "import atexit, ctypes, sys\n"
        "from addon import cli\n"
        "libc = ctypes.CDLL(None)\n"
        "def chatter():\n"
        "    libc.printf(b'Error: Not freed memory blocks: 3, total unfreed memory 0.1 MB\\n')\n"
        "    libc.fflush(None)\n"
        "    print('Python at exit')\n"
        "atexit.register(chatter)\n"
        f"sys.argv = ['addon', 'render', {CBSPHERES!r}, '--samples', '1', '--resolution',"
        f" '16x12', '--output', {str(tmp_path / 'x.exr')!r}]\n"
        "sys.exit(cli.main())\n")
    proc = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True,
                          text=True, timeout=1200, check=False)
    assert proc.returncode == 0, proc.stderr
    assert last_json(proc.stdout)["samples"] == 1
    assert "Not freed memory blocks" in proc.stderr and "Python at exit" in proc.stderr


@pytest.mark.slow
def test_warnings_are_one_line_each_and_grouped(tmp_path):
    def degenerate_objects(scene):
        for i in range(4):
            mesh = bpy.data.meshes.new(f"Flat{i}")
            # The second triangle has three collinear corners: zero area, dropped.
            mesh.from_pydata([(0, 0, 0.5), (0.1, 0, 0.5), (0.2, 0, 0.5), (0, 0.1, 0.5)], [],
                             [(0, 1, 3), (0, 1, 2)])
            scene.collection.objects.link(bpy.data.objects.new(f"Flat{i}", mesh))
    scene = saved_scene(tmp_path, "degenerate.blend", degenerate_objects)
    proc = run("render", scene, "--samples", 1, "--resolution", "16x12", "--output",
               tmp_path / "x.exr")
    assert proc.returncode == 0, proc.stderr
    lines = proc.stderr.splitlines()
    dropped = [ln for ln in lines if "dropped" in ln]
    expected = ("warning: object 'Flat0': dropped 1 of 2 triangles (0 with NaN/inf "
                "vertices, 1 degenerate) (and 3 more like it: 'Flat1', 'Flat2', 'Flat3')")
    assert dropped == [expected], proc.stderr
    assert "UserWarning" not in proc.stderr and "warnings.warn" not in proc.stderr
    assert "Traceback" not in proc.stderr
    assert last_json(proc.stdout)["warnings"] == [dropped[0][len("warning: "):]]


def test_python_warning_is_one_line():
    code = ("from addon import console\nimport warnings\nconsole.install_warning_format()\n"
            "warnings.warn('something odd about 3 objects')\n")
    proc = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True,
                          text=True, timeout=60, check=False)
    assert proc.stderr == "warning: something odd about 3 objects\n"


def test_warning_groups():
    from addon import console
    log = console.Warnings()
    for name in "abcde":
        log.add(f"Specula: object '{name}': dropped 1 of {len(name) + 9} triangles")
    log.add("object 'a': dropped 1 of 10 triangles")  # the same text again: once
    log.add("material 'M': node 'Mix' is not supported")
    assert log.lines() == [
        "object 'a': dropped 1 of 10 triangles (and 4 more like it: 'b', 'c', 'd', ...)",
        "material 'M': node 'Mix' is not supported"]

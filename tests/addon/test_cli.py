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


def run(*args, timeout=300):
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
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert last_json(proc.stdout)["samples"] == 2
    assert out.is_file()

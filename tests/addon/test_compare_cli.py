"""`python -m addon compare SCENE.blend`: a scene against Cycles, as a user runs it.

Subprocesses for exit codes and output; in-process (monkeypatched) for failures that no
committed scene produces: Cycles failing, scipy missing.
"""

import json
import sys

import bpy
import numpy as np
import pytest
from test_cli import CBSPHERES, last_json, run, saved_scene

import addon
from addon import agreement, cli, compare, renderers

# Tiny and quick (a few seconds per compare), yet enough samples for a variance per pixel.
SMALL = ("--samples", 32, "--resolution", "48x36")


def panoramic(scene):
    # Specula renders a panoramic camera as perspective (with a warning); Cycles does not.
    cam = scene.camera.data
    cam.type = "PANO"
    cam.panorama_type = "EQUIRECTANGULAR"


def png_size(path):
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    return int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")


@pytest.mark.slow
def test_agreeing_scene_exits_0_with_png_and_json(tmp_path):
    out, js = tmp_path / "cb.png", tmp_path / "cb.json"
    proc = run("compare", CBSPHERES, *SMALL, "--output", out, "--json", js)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "Traceback" not in proc.stderr
    summary = last_json(proc.stdout)
    assert json.loads(js.read_text()) == summary
    assert summary["verdict"] == "agree" and summary["agree"]
    assert summary["max_z"] < summary["z_threshold"]
    assert summary["resolution"] == [48, 36] and summary["specula"]["samples"] == 32
    assert summary["cycles"]["samples"] == [32, 32]
    errors = summary["error_against_time"]
    assert errors["specula_error"] > 0 and errors["cycles_error"] > 0
    assert errors["mse_ratio_at_equal_time"] > 0
    assert summary["warnings"] == [] and summary["output"] == str(out)
    assert "agree on cbspheres.blend" in proc.stdout
    w, h = png_size(out)
    assert w > 4 * 48 and h > 36  # four panels side by side and the plot below


@pytest.mark.slow
def test_unsupported_feature_differs_exits_1_and_says_why(tmp_path):
    scene = saved_scene(tmp_path, "pano.blend", panoramic)
    out = tmp_path / "pano.png"
    proc = run("compare", scene, "--samples", 16, "--resolution", "32x24", "--output", out)
    assert proc.returncode == 1, proc.stdout + proc.stderr
    assert "Traceback" not in proc.stderr
    summary = last_json(proc.stdout)
    assert summary["verdict"] == "differ" and not summary["agree"]
    assert any("not supported" in w for w in summary["warnings"])
    assert summary["differences_may_come_from_warnings"]
    assert "the differences may come from them" in proc.stdout
    assert "warning: camera 'Camera'" in proc.stderr
    assert png_size(out)[0] > 4 * 32


@pytest.mark.slow
def test_equal_time(tmp_path):
    proc = run("compare", CBSPHERES, "--time", 0.3, "--resolution", "32x24", "--output",
               tmp_path / "t.png")
    assert proc.returncode in (0, 1), proc.stderr
    summary = last_json(proc.stdout)
    assert summary["budget"] == {"samples": None, "seconds": 0.3}
    assert summary["specula"]["stop_reason"] == "time limit"
    # Cycles' samples come from its status line when its time limit stopped it.
    assert all(n > 0 for n in summary["cycles"]["samples"])


def test_missing_file_exits_3(tmp_path):
    proc = run("compare", tmp_path / "nope.blend")
    assert proc.returncode == 3
    assert "not found" in proc.stderr and str(tmp_path / "nope.blend") in proc.stderr
    assert "Traceback" not in proc.stderr


def test_unreadable_file_exits_3(tmp_path):
    bad = tmp_path / "bad.blend"
    bad.write_text("this is not a blend file")
    proc = run("compare", bad, "--output", tmp_path / "x.png")
    assert proc.returncode == 3
    assert f"cannot compare {bad}: Blender cannot read it" in proc.stderr
    assert "Traceback" not in proc.stderr


def test_scene_without_camera_exits_3(tmp_path):
    def no_camera(scene):
        bpy.data.objects.remove(scene.camera)
    scene = saved_scene(tmp_path, "nocam.blend", no_camera)
    proc = run("compare", scene, "--samples", 2, "--resolution", "16x12", "--output",
               tmp_path / "x.png")
    assert proc.returncode == 3
    assert "Specula cannot render it" in proc.stderr and "camera" in proc.stderr
    assert "Traceback" not in proc.stderr


@pytest.mark.parametrize("args", [
    ["compare", CBSPHERES, "--time", "0"],
    ["compare", CBSPHERES, "--output", "x.exr"],
    ["compare", CBSPHERES, "--samples", "-3"],
    ["compare"],
])
def test_bad_arguments_exit_2(args):
    proc = run(*args)
    assert proc.returncode == 2
    assert "usage:" in proc.stderr and "Traceback" not in proc.stderr


def test_cycles_failure_is_a_message(tmp_path, monkeypatch, capfd):
    def fail(scene):
        raise RuntimeError("Error: Cycles could not allocate the image\n")
    monkeypatch.setattr(renderers, "render_cycles_image", fail)
    code = cli.main(["compare", CBSPHERES, "--samples", "2", "--resolution", "16x12",
                     "--output", str(tmp_path / "x.png")])
    err = capfd.readouterr().err
    assert code == 3
    assert "Cycles cannot render it: Error: Cycles could not allocate the image" in err
    assert "Traceback" not in err


def test_without_scipy_compare_says_so(monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "scipy", None)  # makes `import scipy` fail
    monkeypatch.delitem(sys.modules, "addon.agreement")
    monkeypatch.delattr(addon, "agreement")
    code = cli.main(["compare", CBSPHERES])
    assert code == 2
    assert "compare needs scipy" in capsys.readouterr().err


# ---------------------------------------------------------------------------------------
# The pieces


def test_worst_block_in_top_left_pixels():
    c = agreement.Comparison(agree=False, p_min=0.0, p_sidak=1e-6, max_z=9.0, z_threshold=4.0,
                             worst=((4, 4), 0, 2, 1), tests=10, rel_rmse=0.1)
    # Block row 0 is the bottom of a 10-row image: pixel rows 6..9 from the top.
    assert c.worst_pixels(10, 12) == (8, 6, 12, 10)
    c.worst = ((1, 16), 9, 0, 0)  # a strip in the top row, clipped at the right edge
    assert c.worst_pixels(10, 12) == (0, 0, 12, 1)


def test_two_run_error_estimates_one_runs_noise(rng):
    truth = rng.uniform(0.2, 1.0, (64, 64, 3))
    sigma = 0.05
    runs = truth + rng.normal(0, sigma, (2,) + truth.shape)
    lum = truth @ compare.LUMINANCE
    expected = np.sqrt((sigma ** 2) * np.sum(compare.LUMINANCE ** 2)) / lum.mean()
    assert compare.two_run_relative_error(runs) == pytest.approx(expected, rel=0.05)


def test_equal_time_ratio_scales_mse_by_time(rng):
    runs = 0.5 + rng.normal(0, 0.05, (2, 32, 32, 3))
    # The same noise in half the time: half the MSE at equal time.
    e = compare.error_against_time([(0.1, 0.3)], runs, [1.0, 1.0], runs, [2.0, 2.0])
    assert e["mse_ratio_at_equal_time"] == pytest.approx(0.5)
    assert "scaled as MSE ~ 1/time" in e["text"]

"""Replicates merge exactly: renders of disjoint replicate sets, merged with
`python -m addon merge`, are one render of all of them, to the last bit."""

import json
import os
import subprocess
import sys

import numpy as np
import pytest
from conftest import REPO, SCENES_DIR

OpenEXR = pytest.importorskip("OpenEXR")
CBSPHERES = os.path.join(SCENES_DIR, "cbspheres.blend")
pytestmark = pytest.mark.slow


def run(*args, timeout=300):
    proc = subprocess.run([sys.executable, "-m", "addon", *map(str, args)], cwd=REPO,
                          capture_output=True, text=True, timeout=timeout)
    return proc


def render(out, replicates, samples, seed=5):
    proc = run("render", CBSPHERES, "--resolution", "40x30", "--samples", samples, "--seed",
               seed, "--max-bounces", 4, "--replicates", replicates, "--output", out)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout.strip().splitlines()[-1])


def passes(path):
    f = OpenEXR.File(str(path))
    px = {name: np.asarray(ch.pixels) for part in f.parts for name, ch in part.channels.items()}
    return px, f.parts[0].header


@pytest.fixture(scope="module")
def renders(tmp_path_factory):
    d = tmp_path_factory.mktemp("merge")
    a = render(d / "a.exr", "0-3/8", 12)
    b = render(d / "b.exr", "4-7/8", 12)
    whole = render(d / "whole.exr", "8", 24)
    return d, a, b, whole


def test_merged_halves_are_the_whole_render_to_the_last_bit(renders):
    d, a, b, whole = renders
    proc = run("merge", d / "a.exr", d / "b.exr", "-o", d / "merged.exr")
    assert proc.returncode == 0, proc.stderr
    summary = json.loads(proc.stdout.strip().splitlines()[-1])
    merged, header = passes(d / "merged.exr")
    one, one_header = passes(d / "whole.exr")
    for name in ("ViewLayer.Combined", "ViewLayer.Specula Error.X"):
        assert merged[name].dtype == np.float32
        np.testing.assert_array_equal(merged[name], one[name])
    for r in range(8):
        for name in (f"ViewLayer.Specula Replicate {r}", f"ViewLayer.Specula Replicate {r} Spread"):
            np.testing.assert_array_equal(merged[name], one[name])
    assert summary["relative_error"] == whole["relative_error"]
    assert summary["error_interval"] == whole["error_interval"]
    assert summary["samples"] == 24 and summary["replicates"] == "0-7/8"
    for key in ("Specula Relative Error", "Specula Error Interval", "Specula Replicates"):
        assert header[key] == one_header[key], key
    # Each half alone is a coarser estimate of the same image (not the same bits).
    half, _ = passes(d / "a.exr")
    assert not np.array_equal(half["ViewLayer.Combined"], one["ViewLayer.Combined"])


def test_overlapping_or_foreign_renders_are_refused(renders, tmp_path):
    d, *_ = renders
    proc = run("merge", d / "a.exr", d / "whole.exr", "-o", tmp_path / "x.exr")
    assert proc.returncode == 1 and "replicate 0 is also in" in proc.stderr
    render(tmp_path / "other_seed.exr", "4-7/8", 12, seed=6)
    proc = run("merge", d / "a.exr", tmp_path / "other_seed.exr", "-o", tmp_path / "x.exr")
    assert proc.returncode == 1 and "seed 6" in proc.stderr
    proc = run("merge", d / "a.exr", tmp_path / "missing.exr", "-o", tmp_path / "x.exr")
    assert proc.returncode == 1 and "no such file" in proc.stderr
    assert not (tmp_path / "x.exr").exists()


def test_render_json_exr_metadata_and_plot_carry_the_error_series(renders, tmp_path):
    d, a, b, whole = renders
    series = whole["series"]
    assert [p["samples"] for p in series][-1] == 24
    assert all(p["seconds"] > 0 for p in series)
    known = [p for p in series if p["relative_error"] > 0]
    assert known and all(lo <= p["relative_error"] <= hi
                         for p in known for lo, hi in [p["interval"]])
    assert whole["error_interval"][0] < whole["relative_error"] < whole["error_interval"][1]
    _, header = passes(d / "whole.exr")
    assert json.loads(header["Specula Error Series"]) == series
    assert float(header["Specula Relative Error"]) == pytest.approx(whole["relative_error"],
                                                                    rel=1e-5)
    plot = tmp_path / "curve.png"
    proc = run("render", CBSPHERES, "--resolution", "24x18", "--samples", 16, "--plot", plot,
               "--output", tmp_path / "x.exr")
    assert proc.returncode == 0, proc.stderr
    assert plot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_merged_alpha_of_a_holdout_under_a_transparent_film_is_the_whole_renders(tmp_path):
    """A transparent film with a holdout keeps each replicate's transparency as a pass of
    its own; the merged alpha is the whole render's, to the last bit, and has holes (the
    sphere held out, through the glass sphere too)."""
    import bpy
    bpy.ops.wm.open_mainfile(filepath=CBSPHERES)
    bpy.data.objects["MirrorSphere"].is_holdout = True
    bpy.context.scene.render.film_transparent = True
    held = tmp_path / "held.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(held), copy=True)
    out = {}
    for name, replicates, samples in (("a", "0-1/4", 8), ("b", "2-3/4", 8),
                                      ("whole", "4", 16)):
        proc = run("render", held, "--resolution", "32x24", "--samples", samples, "--seed", 3,
                   "--max-bounces", 3, "--replicates", replicates, "--output",
                   tmp_path / f"{name}.exr")
        assert proc.returncode == 0, proc.stderr
        out[name], _ = passes(tmp_path / f"{name}.exr")
    proc = run("merge", tmp_path / "a.exr", tmp_path / "b.exr", "-o", tmp_path / "m.exr")
    assert proc.returncode == 0, proc.stderr
    merged, _ = passes(tmp_path / "m.exr")
    combined = out["whole"]["ViewLayer.Combined"]
    np.testing.assert_array_equal(merged["ViewLayer.Combined"], combined)
    alpha = combined[..., 3]
    assert alpha.min() == 0.0 and alpha.max() == 1.0 and 0.8 < alpha.mean() < 0.99
    assert "ViewLayer.Specula Replicate 3 Transparency.X" in merged

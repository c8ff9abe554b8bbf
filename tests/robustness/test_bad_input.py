"""Bad and extreme input: an empty scene, no camera, messy meshes, 100,000 instances,
a 1x1 image, a 5-million-triangle mesh, unreadable .blend files, and cancelling.

Covered elsewhere (not repeated): an empty core scene renders the world colour
(tests/engine/test_integrator.py::test_escaped_rays_take_the_world_colour_and_alpha_is_one),
no camera is an ExportError (tests/addon/test_exporter.py::test_no_camera_is_an_export_error),
objects without materials get the default grey (test_exporter.py::
test_object_without_material_is_default_grey), 3840x2160 at 1 sample under 2 GB
(tests/engine/test_render.py::test_4k_render_peak_memory_under_2gb), a missing or
non-.blend file and bad CLI arguments (tests/addon/test_cli.py).
"""

import json
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from engine import Camera, Material, RenderSettings, SceneBuilder, World, render
from tests import scenes
from tests.robustness.helpers import all_finite, look_at

REPO = Path(__file__).resolve().parents[2]


def run_python(args, timeout=600):
    return subprocess.run([sys.executable, *args], cwd=REPO, capture_output=True, text=True,
                          timeout=timeout)


def bpy_case(name, tmp_path):
    proc = run_python(["-m", "tests.robustness.bpy_cases", name, str(tmp_path)])
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "Traceback" not in proc.stderr, proc.stderr[-3000:]
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    print(json.dumps({k: v for k, v in out.items() if k != "summary"}))
    return out


# ------------------------------------------------------------------ through Blender
@pytest.mark.slow
def test_ngons_loose_edges_and_faceless_meshes_render(tmp_path):
    """An octagon (6 triangles), a loose edge and vertex in the same mesh, a wire-only mesh
    and an empty mesh: only the octagon's triangles reach the core, the object without a
    material gets the default diffuse, the render finishes finite."""
    out = bpy_case("messy_meshes", tmp_path)
    assert out["error"] is None and "error" not in out["summary"]
    assert out["triangles"] == 6 and out["objects"] == ["Messy"]
    assert out["materials"] == ["diffuse"]
    assert out["finite"]


@pytest.mark.slow
def test_empty_scene_renders_the_world_colour_through_blender(tmp_path):
    out = bpy_case("empty_scene", tmp_path)
    assert out["error"] is None and out["finite"]
    assert np.allclose(out["mean_rgb"], [0.2, 0.3, 0.4], atol=1e-5)


@pytest.mark.slow
def test_no_camera_is_a_clear_error_through_blender(tmp_path):
    """Blender refuses first ("Cannot render, no camera"); the exporter's own ExportError
    ("has no active camera") covers callers that bypass that check."""
    out = bpy_case("no_camera", tmp_path)
    assert out["error"] and "camera" in out["error"].lower()


@pytest.mark.slow
def test_one_pixel_image(tmp_path):
    out = bpy_case("one_pixel", tmp_path)
    assert out["error"] is None and out["finite"] and out["summary"]["samples"] == 4
    sc = scenes.cbspheres()
    r = render(sc, RenderSettings(width=1, height=1, samples=8, max_bounces=4))
    assert r.combined.shape == (1, 1, 4) and all_finite(r) and r.combined[0, 0, :3].max() > 0


@pytest.mark.slow
def test_100k_instances_export_and_render_in_bounded_memory(tmp_path):
    """A 12-triangle cube instanced 100,000 times by geometry nodes: read once, placed
    100,000 times (1.2 M triangles), rendered; the whole process stays under 2 GB."""
    out = bpy_case("instances", tmp_path)
    assert out["instances"] == 100_000 and out["triangles"] == 1_200_000
    assert out["finite"] and out["hit_fraction"] > 0.3
    assert out["peak_rss_mb"] < 2048, out["peak_rss_mb"]


# ------------------------------------------------------------------ the core
FIVE_MILLION = r"""
import json, sys, time
import numpy as np
from engine import Camera, Material, RenderSettings, SceneBuilder, World, render
from tests.memory import peak_rss_mb
from tests.scenes import look_at
k = 1581  # 2 * 1581^2 = 4,999,122 triangles: a bumpy height field
xs = np.linspace(-1, 1, k + 1)
X, Y = np.meshgrid(xs, xs, indexing="ij")
v = np.column_stack([X.ravel(), Y.ravel(), 0.05 * np.sin(7 * X.ravel()) * np.cos(5 * Y.ravel())])
idx = np.arange((k + 1) ** 2).reshape(k + 1, k + 1)
a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
tris = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
del X, Y, a, b, c, d, idx
t0 = time.perf_counter()
builder = SceneBuilder()
m = builder.add_material(Material.diffuse("grey", (0.5, 0.5, 0.5)))
kept = builder.add_mesh("height field", v, tris, m)
t1 = time.perf_counter()
scene = builder.build(Camera(world_from_camera=look_at((0, -3, 2), (0, 0, 0))), World((1, 1, 1)))
t2 = time.perf_counter()
r = render(scene, RenderSettings(width=16, height=12, samples=1, max_bounces=1))
t3 = time.perf_counter()
print(json.dumps(dict(triangles=int(scene.num_triangles), kept=kept, add_mesh_s=t1 - t0,
                      build_s=t2 - t1, render_s=t3 - t2,
                      finite=bool(np.isfinite(r.combined).all()),
                      hit_fraction=float((r.depth < 1e9).mean()),
                      peak_rss_mb=peak_rss_mb())))
"""


@pytest.mark.slow
def test_five_million_triangles_in_bounded_memory():
    """A 5-million-triangle mesh through SceneBuilder, build() and a 1-sample render, in
    its own process: correct output and peak RSS under 3 GB (float64 corners are 360 MB,
    embree's float32 copy 180 MB plus its BVH). Times are printed, not asserted."""
    proc = run_python(["-c", FIVE_MILLION], timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    print(out)
    assert out["triangles"] == out["kept"] == 4_999_122
    assert out["finite"] and out["hit_fraction"] > 0.3
    assert out["peak_rss_mb"] < 3072, out["peak_rss_mb"]


@pytest.mark.slow
def test_cancelling_mid_render_keeps_the_image_and_leaves_no_thread():
    """Cancel from another thread while passes run (as Blender's Esc does): render returns
    the finished passes, marked cancelled, and its thread pool is gone."""
    baseline = threading.active_count()
    stop = threading.Event()
    passes = []

    def on_pass(p):
        passes.append(p.samples)
        if p.samples == 2:
            threading.Timer(0.01, stop.set).start()

    r = render(scenes.cbspheres(), scenes.settings(width=48, height=36, samples=10_000,
                                                   threads=2),
               on_pass=on_pass, should_stop=stop.is_set)
    assert r.cancelled and r.stop_reason == "cancelled"
    assert 2 <= r.samples < 10_000 and r.samples == passes[-1]
    assert all_finite(r) and r.combined[..., :3].mean() > 0
    deadline = time.monotonic() + 5
    while threading.active_count() > baseline and time.monotonic() < deadline:
        time.sleep(0.01)  # the Timer thread ends right after setting the event
    assert threading.active_count() == baseline, threading.enumerate()
    assert not [t for t in threading.enumerate() if t.name.startswith("ThreadPoolExecutor")]


def test_a_failed_render_leaves_no_thread(monkeypatch):
    """An exception in a worker (here a poisoned stage) propagates and still shuts the
    pool down."""
    from engine.accel import Accel

    def boom(self, *a, **k):
        raise RuntimeError("stage failed")

    monkeypatch.setattr(Accel, "intersect_raw", boom)
    baseline = threading.active_count()
    with pytest.raises(RuntimeError, match="stage failed"):
        render(scenes.cbspheres(), scenes.settings(width=8, height=8, samples=2, threads=2))
    assert threading.active_count() == baseline


def test_scene_with_only_a_light_object_and_no_geometry():
    """No triangles at all but a light: the world colour, nothing divides by an empty
    scene's size."""
    from engine import Light

    b = SceneBuilder()
    b.add_light(Light("lamp", "POINT", (100.0, 100.0, 100.0), radius=0.1))
    b.add_light(Light("sun", "SUN", (3.0, 3.0, 3.0), angle=0.1))
    r = render(b.build(Camera(), World((0.1, 0.2, 0.3))),
               RenderSettings(width=6, height=4, samples=2))
    assert all_finite(r)
    assert np.allclose(r.combined[..., :3], [0.1, 0.2, 0.3], atol=1e-6)


# ------------------------------------------------------------------ the command line
@pytest.mark.slow
@pytest.mark.parametrize("content", [b"", b"BLENDER-v500" + b"\0" * 64, "truncated"],
                         ids=["empty", "header-only", "truncated"])
def test_broken_blend_files_fail_with_a_message_and_exit_1(tmp_path, content):
    if content == "truncated":
        content = (REPO / "blend_scenes" / "default.blend").read_bytes()[:4096]
    bad = tmp_path / "broken.blend"
    bad.write_bytes(content)
    proc = run_python(["-m", "addon", "render", str(bad), "--output", str(tmp_path / "x.exr")],
                      timeout=300)
    assert proc.returncode == 1, (proc.returncode, proc.stderr[-2000:])
    assert "error:" in proc.stderr and "Traceback" not in proc.stderr


@pytest.mark.slow
def test_directory_instead_of_a_blend_file(tmp_path):
    proc = run_python(["-m", "addon", "render", str(tmp_path)], timeout=300)
    assert proc.returncode == 1 and "error:" in proc.stderr and "Traceback" not in proc.stderr


def test_orphan_geometry_without_camera_in_the_core():
    b = SceneBuilder()
    m = b.add_material(Material.diffuse("d", (0.5, 0.5, 0.5)))
    b.add_mesh("tri", np.eye(3), [[0, 1, 2]], m)
    with pytest.raises(ValueError, match="camera"):
        b.build(Camera(world_from_camera=np.full((4, 4), np.nan)), World())
    with pytest.raises(ValueError, match="camera"):
        b.build(Camera(world_from_camera=look_at((0, 0, 0), (0, 1, 0)), lens_mm=0.0), World())

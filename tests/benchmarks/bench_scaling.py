"""Scaling with scene size, and time to first pixels (a benchmark: it reports, never asserts).

* Export + acceleration-structure build: a Blender mesh of N triangles (a UV sphere in the
  CBspheres box, N from 10 thousand to 4 million) through the add-on's exporter
  (`exporter.export` + `to_core`) and the core's embree build (`Accel`).
* Time per sample at 160x120 with the same sphere: its silhouette is the same at every N,
  so only the triangle count changes; ray tracing should grow like log N.
* Memory: resident-set growth per triangle with the exported scene and its BVH alive.
* Time to first pixels: `bpy.ops.render.render()` on blend_scenes/cbspheres.blend (480x360)
  until the add-on first writes pixels into Blender's render result, in a process that has
  not rendered yet (cold: the core, numba and the compiled kernels load now) and again.

Writes out/bench/scaling.json, out/bench/scaling_time_per_sample.png,
out/bench/scaling_export_build.png and out/bench/scaling_memory.png.

    .venv/bin/python -m tests.benchmarks.bench_scaling      # part of `make bench`
"""

from __future__ import annotations

import argparse
import gc
import json
import math
import os
import sys
import time

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
if REPO not in sys.path:
    sys.path.insert(0, REPO)

import bpy  # noqa: E402
import numpy as np  # noqa: E402

from tests import scenes  # noqa: E402
from addon import imaging  # noqa: E402
from tests.cycles import renderers  # noqa: E402

OUT = os.path.join(REPO, "out", "bench")
COUNTS = (10_000, 40_000, 160_000, 640_000, 1_000_000, 2_560_000, 4_000_000)


def rss_bytes() -> int:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def time_to_first_pixels() -> dict:
    """Seconds from bpy.ops.render.render() to the first pixels written, cold and warm."""
    from addon import render_session

    renderers.open_blend_scene("cbspheres", (480, 360))
    scene = bpy.context.scene
    scene.render.engine = "SPECULA"
    scene.specula.samples = 4
    marks = []
    original = render_session.RenderSession._write

    def write(self, layer, p):
        marks.append(time.perf_counter())
        return original(self, layer, p)

    render_session.RenderSession._write = write
    out = {}
    try:
        for label in ("cold", "warm"):
            marks.clear()
            t0 = time.perf_counter()
            bpy.ops.render.render()
            out[label] = marks[0] - t0
    finally:
        render_session.RenderSession._write = original
    return out


def sphere_scene(triangles: int):
    """CBspheres with its two spheres replaced by one smooth UV sphere of ~`triangles`."""
    renderers.open_blend_scene("cbspheres", (160, 120))
    for name in ("MirrorSphere", "GlassSphere"):
        bpy.data.objects.remove(bpy.data.objects[name])
    # A UV sphere of s segments and s / 2 rings has about s^2 triangles. Built with
    # foreach_set (bmesh's create_uvsphere takes minutes at millions of faces).
    s = max(8, int(round(math.sqrt(triangles))))
    verts, tris, _ = scenes.uv_sphere((0.0, 0.0, 0.0), 0.45, segments=s, rings=s // 2)
    mesh = bpy.data.meshes.new("Sphere")
    mesh.vertices.add(len(verts))
    mesh.vertices.foreach_set("co", np.ascontiguousarray(verts, np.float32).ravel())
    mesh.loops.add(3 * len(tris))
    mesh.loops.foreach_set("vertex_index", np.ascontiguousarray(tris, np.int32).ravel())
    mesh.polygons.add(len(tris))
    mesh.polygons.foreach_set("loop_start", np.arange(0, 3 * len(tris), 3, dtype=np.int32))
    mesh.update()
    mesh.shade_smooth()
    mesh.materials.append(bpy.data.materials[0])
    obj = bpy.data.objects.new("Sphere", mesh)
    obj.location = (0.0, 0.0, 0.5)
    bpy.context.scene.collection.objects.link(obj)
    return bpy.context.scene


def measure(triangles: int, samples: int) -> dict:
    from addon import exporter

    core = renderers.core()
    scene = sphere_scene(triangles)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    gc.collect()
    rss0 = rss_bytes()
    t0 = time.perf_counter()
    exported = exporter.export(depsgraph)
    core_scene, _ = exporter.to_core(exported, core)
    t1 = time.perf_counter()
    accel = core.accel.Accel(core_scene)
    t2 = time.perf_counter()
    rss1 = rss_bytes()
    kw = exporter.render_settings_kwargs(scene, 160, 120)
    kw.update(samples=samples, time_limit=0.0, target_error=0.0)
    settings = core.RenderSettings(**kw)
    # Time per sample from the passes after the first (setup - plan, light tables, the
    # BVH the render builds for itself - is the export + build measured above).
    core.render(core_scene, core.RenderSettings(**{**kw, "samples": 2}))  # caches, page-ins
    per_sample = []
    for _ in range(3):  # the least of three: other jobs on the machine only add time
        stamps = []
        result = core.render(core_scene, settings,
                             on_pass=lambda p: stamps.append(time.perf_counter()))
        per_sample.append((stamps[-1] - stamps[0]) / (len(stamps) - 1))
    per_sample = min(per_sample)
    n = int(core_scene.num_triangles)
    del accel, exported
    return dict(triangles=n, export_seconds=t1 - t0, build_seconds=t2 - t1,
                export_build_seconds=t2 - t0, bytes_per_triangle=(rss1 - rss0) / n,
                seconds_per_sample=per_sample, kernel=result.plan.kernel)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--counts", default=",".join(str(c) for c in COUNTS))
    parser.add_argument("--samples", type=int, default=17)
    args = parser.parse_args(argv)
    os.makedirs(OUT, exist_ok=True)
    renderers.ensure_registered()
    first = time_to_first_pixels()
    print(f"time to first pixels on CBspheres 480x360: cold {first['cold']:.2f} s, "
          f"warm {first['warm']:.2f} s", flush=True)
    rows = []
    for count in (int(c) for c in args.counts.split(",")):
        row = measure(count, args.samples)
        rows.append(row)
        print(json.dumps(row), flush=True)
    base = rows[0]
    for r in rows:
        # Logarithmic growth from the smallest mesh: t(N) / t(N0) <= log N / log N0.
        r["time_ratio"] = r["seconds_per_sample"] / base["seconds_per_sample"]
        r["log_ratio"] = math.log(r["triangles"]) / math.log(base["triangles"])
    with open(os.path.join(OUT, "scaling.json"), "w") as f:
        json.dump(dict(first_pixels=first, rows=rows), f, indent=1)
    tris = [r["triangles"] for r in rows]
    t0 = base["seconds_per_sample"]
    plots = {
        "scaling_time_per_sample.png": (
            {"SECONDS PER SAMPLE": (tris, [r["seconds_per_sample"] for r in rows]),
             "LOG GROWTH BOUND": (tris, [t0 * r["log_ratio"] for r in rows])},
            "time per sample, 160x120", "triangles", "seconds", {"LOG GROWTH BOUND"}),
        "scaling_export_build.png": (
            {"EXPORT + BUILD": (tris, [r["export_build_seconds"] for r in rows]),
             "EXPORT": (tris, [r["export_seconds"] for r in rows]),
             "BVH BUILD": (tris, [r["build_seconds"] for r in rows])},
            "export and BVH build", "triangles", "seconds", set()),
        "scaling_memory.png": (
            {"BYTES PER TRIANGLE": (tris, [r["bytes_per_triangle"] for r in rows])},
            "resident memory per triangle", "triangles", "bytes", set()),
    }
    for name, (series, title, xl, yl, dashed) in plots.items():
        imaging.write_png(os.path.join(OUT, name),
                          imaging.loglog_plot(series, title, xl, yl, dashed=dashed))
    print("| triangles | export s | BVH s | export + BVH s | s / sample | t / t(10k) | "
          "log N / log 10k | bytes / triangle |")
    print("|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['triangles']:,} | {r['export_seconds']:.2f} | {r['build_seconds']:.2f} | "
              f"{r['export_build_seconds']:.2f} | {r['seconds_per_sample']:.4f} | "
              f"{r['time_ratio']:.2f} | {r['log_ratio']:.2f} | {r['bytes_per_triangle']:.0f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Error against run time, Specula beside Cycles (a benchmark: it reports, never asserts).

For each scene, both engines render on the CPU with the same thread count, resolution,
bounce limit and pixel filter (Cycles set up unbiased, as `python -m addon render --engine
CYCLES` does) at a series of time budgets. Each image is measured against a high-sample
Cycles reference (two seeds, cached in out/bench/):

* RMSE over pixels and RGB channels, and relative MSE (mean of (x - ref)^2 / (ref^2 + 0.01));
  both have the reference's own noise (estimated from its two seeds) subtracted;
* Specula's *estimated* relative error (the core's `relative_error`: RMS standard error of
  luminance / mean luminance) beside the same quantity *measured* against the reference;
* the time to first pixels: export + first pass for Specula, a 1-sample render for Cycles.

Writes out/bench/report.md, out/bench/results.json and out/bench/<scene>_error.png
(log-log error against wall seconds, both engines).

    make bench-cycles
    .venv/bin/python -m tests.benchmarks.bench_cycles --scenes cbspheres --budgets 1,2,4 \
        --resolution 160x120
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
if REPO not in sys.path:
    sys.path.insert(0, REPO)

import bpy  # noqa: E402

from addon import imaging  # noqa: E402
from tests.benchmarks import bench_core  # noqa: E402
from tests.cycles import renderers, variants  # noqa: E402

OUT = os.path.join(REPO, "out", "bench")
# Set by --guiding and --without-light-tracing: rows for Cycles with path guiding and for
# Specula with light tracing off, beside the usual two.
GUIDING = False
WITHOUT_LIGHT_TRACING = False
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])
RELMSE_EPS = 0.01


# "<scene>_dof": the committed scene with a thin lens focused this far along the view axis
# (CBspheres: on the glass sphere) and this lens radius (scene units).
DOF = {"cbspheres_dof": (2.75, 0.1)}
# "<scene>_small_quad[_ceiling]": the committed scene with its ceiling emitter replaced by a
# 0.1 x 0.1 quad of the same power at height 1.2 (or where the emitter was, 1 cm under the
# ceiling): caustics lit through specular chains from a light paths hit rarely.
SMALL_QUAD = {"cbspheres_small_quad": 1.2, "cbspheres_small_quad_ceiling": 1.49}
# "<scene>_small_sphere": the ceiling emitter replaced by a point light of radius 2 cm
# (Soft Falloff, Blender's default) of the quad's power (30 W), at height 1.2.
SMALL_SPHERE = {"cbspheres_small_sphere": 1.2}


def _small_quad(height):
    bpy.data.objects.remove(bpy.data.objects["Emitter"])
    variants._emitter_quad("SmallEmitter", (0.0, 0.0, height), 0.1, 10.0 * 0.48 / 0.01,
                           rotation=(0.0, 0.0, 0.0))
    bpy.context.scene.specula.use_light_tracing = True


def _small_sphere(height):
    bpy.data.objects.remove(bpy.data.objects["Emitter"])
    light = bpy.data.lights.new("Bulb", "POINT")
    light.energy, light.shadow_soft_size, light.use_soft_falloff = 30.0, 0.02, True
    obj = bpy.data.objects.new("Bulb", light)
    obj.location = (0.0, 0.0, height)
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.scene.specula.use_light_tracing = True


def open_scene(name, resolution, max_bounces):
    base = name.removesuffix("_dof").removesuffix("_small_quad_ceiling").removesuffix(
        "_small_quad").removesuffix("_small_sphere")
    scene = renderers.open_blend_scene(base, resolution)
    if name in SMALL_QUAD:
        _small_quad(SMALL_QUAD[name])
    if name in SMALL_SPHERE:
        _small_sphere(SMALL_SPHERE[name])
    if name in DOF:
        focus, radius = DOF[name]
        cam = scene.camera.data
        cam.dof.use_dof = True
        cam.dof.focus_object = None
        cam.dof.focus_distance = focus
        cam.dof.aperture_fstop = cam.lens * 1e-3 / (2.0 * radius)
        cam.dof.aperture_blades = 0
    if max_bounces is not None:
        scene.specula.max_bounces = max_bounces
    return scene


def render_specula(scene, samples=1 << 20, time_limit=0.0):
    """Export and render through the add-on's exporter; returns (result, wall seconds,
    seconds to the first pass including the export)."""
    from addon import exporter
    core = renderers.core()
    t0 = time.perf_counter()
    depsgraph = bpy.context.evaluated_depsgraph_get()
    exported = exporter.export(depsgraph)
    core_scene, _ = exporter.to_core(exported, core)
    w, h = scene.render.resolution_x, scene.render.resolution_y
    kw = exporter.render_settings_kwargs(scene, w, h)
    kw.update(samples=samples, time_limit=time_limit, target_error=0.0)
    first = []

    def on_pass(p):
        if not first:
            first.append(time.perf_counter() - t0)

    t_render = time.perf_counter()
    with bench_core.profiled_render() as seen:
        seen["result"] = result = core.render(core_scene, core.RenderSettings(**kw),
                                              on_pass=on_pass)
    wall = time.perf_counter() - t_render
    result.profile = bench_core.shares(seen, wall, renderers.THREADS)
    return result, time.perf_counter() - t0, first[0]


def render_cycles(scene, samples, seed=0, time_limit=0.0, guiding=False):
    """(image (H, W, 3), wall seconds); guiding: with Cycles' path guiding (surface and
    volume, its defaults otherwise), the setting Cycles offers for hard indirect light."""
    renderers.configure_cycles(scene, samples, seed, scene.specula.max_bounces, time_limit)
    scene.cycles.use_guiding = guiding
    rgba, seconds = renderers.render_cycles_image(scene)
    scene.render.engine = "SPECULA"
    return rgba[..., :3].astype(np.float64), seconds


def reference(name, scene, samples):
    """High-sample Cycles reference (mean of two seeds) and its per-pixel noise variance."""
    w, h = scene.render.resolution_x, scene.render.resolution_y
    path = os.path.join(OUT, f"reference_{name}_{w}x{h}_b{scene.specula.max_bounces}"
                             f"_s{samples}_blender{bpy.app.version_string}.npz")
    if os.path.isfile(path):
        with np.load(path) as data:
            print(f"{name}: cached reference {os.path.relpath(path, REPO)}", flush=True)
            return data["mean"], data["noise_var"]
    print(f"{name}: rendering the Cycles reference ({samples} samples x 2 seeds)...", flush=True)
    a, ta = render_cycles(scene, samples // 2, seed=101)
    b, tb = render_cycles(scene, samples // 2, seed=202)
    mean, noise_var = 0.5 * (a + b), 0.25 * (a - b) ** 2
    os.makedirs(OUT, exist_ok=True)
    np.savez_compressed(path, mean=mean.astype(np.float32), noise_var=noise_var.astype(np.float32))
    print(f"{name}: reference took {ta + tb:.0f} s", flush=True)
    return mean, noise_var


def errors(image, ref, noise_var):
    """RMSE, relative MSE and measured relative RMS luminance error, reference noise removed."""
    d2 = (image - ref) ** 2
    mse = max(float(np.mean(d2 - noise_var)), 0.0)
    rel = max(float(np.mean((d2 - noise_var) / (ref ** 2 + RELMSE_EPS))), 0.0)
    dy2 = ((image - ref) @ LUMINANCE) ** 2 - noise_var @ LUMINANCE ** 2
    rel_lum = float(np.sqrt(max(float(np.mean(dy2)), 0.0)) / max(float(np.mean(ref @ LUMINANCE)),
                                                                1e-12))
    return float(np.sqrt(mse)), rel, rel_lum


def bench_scene(name, budgets, resolution, ref_samples, max_bounces):
    scene = open_scene(name, resolution, max_bounces)
    ref, noise = reference(name, scene, ref_samples)
    rows = []
    # Time to first pixels: Specula's export + first pass; Cycles' 1-sample render.
    res, _, first_s = render_specula(scene, samples=1)
    _, first_c = render_cycles(scene, 1)
    for budget in budgets:
        res, wall_s, _ = render_specula(scene, time_limit=budget)
        img_s = res.combined[..., :3].astype(np.float64)
        rmse_s, rel_s, lum_s = errors(img_s, ref, noise)
        img_c, wall_c = render_cycles(scene, 1 << 24, seed=7, time_limit=budget)
        rmse_c, rel_c, _ = errors(img_c, ref, noise)
        extra = {}
        if GUIDING:
            img_g, wall_g = render_cycles(scene, 1 << 24, seed=7, time_limit=budget,
                                          guiding=True)
            extra.update(cycles_guided_seconds=wall_g,
                         cycles_guided_rmse=errors(img_g, ref, noise)[0])
        if WITHOUT_LIGHT_TRACING and scene.specula.use_light_tracing:
            scene.specula.use_light_tracing = False
            res_p, wall_p, _ = render_specula(scene, time_limit=budget)
            scene.specula.use_light_tracing = True
            extra.update(specula_plain_seconds=wall_p, specula_plain_samples=res_p.samples,
                         specula_plain_rmse=errors(res_p.combined[..., :3].astype(np.float64),
                                                   ref, noise)[0])
        row = dict(scene=name, budget=budget, specula_seconds=wall_s, specula_samples=res.samples,
                   specula_rmse=rmse_s, specula_relmse=rel_s, specula_rel_measured=lum_s,
                   specula_rel_estimated=float(res.relative_error),
                   specula_rmse_estimated=float(np.sqrt(np.mean(res.variance))),
                   specula_fraction_in_embree=res.profile[0],
                   specula_share_per_stage=res.profile[1],
                   cycles_seconds=wall_c, cycles_rmse=rmse_c, cycles_relmse=rel_c,
                   equal_time_mse_ratio=(rmse_s / rmse_c) ** 2 if rmse_c > 0 else float("nan"),
                   **extra)
        rows.append(row)
        print(json.dumps(row), flush=True)
    return rows, dict(scene=name, specula_first_pixels=first_s, cycles_first_pixels=first_c,
                      resolution=list(resolution), max_bounces=scene.specula.max_bounces,
                      reference_samples=ref_samples)


def plot(name, rows, path):
    series = {
        "SPECULA RMSE": ([r["specula_seconds"] for r in rows], [r["specula_rmse"] for r in rows]),
        "CYCLES RMSE": ([r["cycles_seconds"] for r in rows], [r["cycles_rmse"] for r in rows]),
        "SPECULA EST. RMSE": ([r["specula_seconds"] for r in rows],
                              [r["specula_rmse_estimated"] for r in rows]),
    }
    img = imaging.loglog_plot(series, f"{name}: error against time", "wall seconds",
                              "RMSE", dashed={"SPECULA EST. RMSE"})
    imaging.write_png(path, img)


def report(all_rows, info, args):
    lines = ["# Error against run time: Specula and Cycles", "",
             f"Command: `.venv/bin/python -m tests.benchmarks.bench_cycles {' '.join(args)}`",
             f"Blender {bpy.app.version_string}, {renderers.THREADS} threads for both engines, "
             f"CPU; Cycles unbiased (no denoising, adaptive sampling or clamping, Filter Glossy 0, "
             f"equal bounce limits, Blackman-Harris 1.5 px). Errors are against a Cycles "
             f"reference (two seeds; its own noise, estimated from the seeds, is subtracted). "
             f"Seconds are wall time including export / scene sync. Relative MSE uses "
             f"(x - ref)^2 / (ref^2 + {RELMSE_EPS}). Equal-time ratio = Specula MSE / Cycles MSE "
             f"(> 1: Specula is noisier for the same time). Rel. error est./meas.: Specula's own "
             f"estimate of its relative RMS luminance error beside the measured one.", "",
             "| scene | budget s | Specula s (spp) | Cycles s | Specula RMSE | Cycles RMSE | "
             "Specula relMSE | Cycles relMSE | equal-time MSE ratio | rel. error est. / meas. |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in all_rows:
        lines.append(f"| {r['scene']} | {r['budget']:g} | {r['specula_seconds']:.1f} "
                     f"({r['specula_samples']}) | {r['cycles_seconds']:.1f} | "
                     f"{r['specula_rmse']:.4f} | {r['cycles_rmse']:.4f} | "
                     f"{r['specula_relmse']:.5f} | {r['cycles_relmse']:.5f} | "
                     f"{r['equal_time_mse_ratio']:.1f} | {r['specula_rel_estimated']:.4f} / "
                     f"{r['specula_rel_measured']:.4f} |")
    extra = [r for r in all_rows if "cycles_guided_rmse" in r or "specula_plain_rmse" in r]
    if extra:
        lines += ["", "RMSE at each budget beside Specula without light tracing and Cycles with "
                  "path guiding (--without-light-tracing, --guiding; '-' where not run):", "",
                  "| scene | budget s | Specula | Specula, light tracing off (spp) | Cycles | "
                  "Cycles, path guiding | best Cycles / Specula |", "|---|---|---|---|---|---|---|"]
        for r in extra:
            plain = (f"{r['specula_plain_rmse']:.4f} ({r['specula_plain_samples']})"
                     if "specula_plain_rmse" in r else "-")
            guided = f"{r['cycles_guided_rmse']:.4f}" if "cycles_guided_rmse" in r else "-"
            best = min(r["cycles_rmse"], r.get("cycles_guided_rmse", float("inf")))
            lines.append(f"| {r['scene']} | {r['budget']:g} | {r['specula_rmse']:.4f} | {plain} "
                         f"| {r['cycles_rmse']:.4f} | {guided} | "
                         f"{best / max(r['specula_rmse'], 1e-12):.2f} |")
    lines += ["", "Specula's share of the two threads' time inside embreex, and per stage "
              "(from the core's stage timers; 'intersect' and 'trace shadow rays' include their "
              "embreex calls, 'other' is the bounce loop's glue and waiting at pass ends):", "",
              "| scene | budget s | in embreex | stages |", "|---|---|---|---|"]
    for r in all_rows:
        split = ", ".join(f"{k} {v:.0%}" for k, v in r["specula_share_per_stage"].items())
        lines.append(f"| {r['scene']} | {r['budget']:g} | "
                     f"{r['specula_fraction_in_embree']:.0%} | {split} |")
    lines += ["", "Time to first pixels (Specula: export + first pass; Cycles: a 1-sample "
              "render including sync):", "", "| scene | resolution | Specula s | Cycles s |",
              "|---|---|---|---|"]
    for i in info:
        lines.append(f"| {i['scene']} | {i['resolution'][0]}x{i['resolution'][1]} | "
                     f"{i['specula_first_pixels']:.2f} | {i['cycles_first_pixels']:.2f} |")
    lines += ["", "Plots: " + ", ".join(f"`{i['scene']}_error.png`" for i in info), ""]
    return "\n".join(lines)


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    parser = argparse.ArgumentParser(prog="python -m tests.benchmarks.bench_cycles",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenes", default="cbspheres,cbdragon,cbspheres_dof",
                        help="comma-separated names in blend_scenes/, or cbspheres_dof (the "
                             "first with a thin lens); default all three")
    parser.add_argument("--budgets", default="10,60", help="seconds, comma-separated")
    parser.add_argument("--resolution", default="160x120", help="WIDTHxHEIGHT (default 160x120)")
    parser.add_argument("--reference-samples", type=int, default=16384,
                        help="Cycles reference samples, split over two seeds (default 16384)")
    parser.add_argument("--max-bounces", type=int, default=None,
                        help="bounce limit for both engines (default: the scene's)")
    parser.add_argument("--guiding", action="store_true",
                        help="also render Cycles with path guiding at each budget")
    parser.add_argument("--without-light-tracing", action="store_true",
                        help="also render Specula with light tracing (caustics) off")
    parser.add_argument("--out-name", default="report",
                        help="report file stem in out/bench/ (default report)")
    args = parser.parse_args(argv)
    global GUIDING, WITHOUT_LIGHT_TRACING
    GUIDING, WITHOUT_LIGHT_TRACING = args.guiding, args.without_light_tracing
    budgets = [float(b) for b in args.budgets.split(",")]
    w, h = (int(v) for v in args.resolution.lower().split("x"))
    os.makedirs(OUT, exist_ok=True)
    all_rows, info = [], []
    for name in args.scenes.split(","):
        # 16:9 scenes keep their aspect at the requested width.
        res = (w, h) if name != "cbdragon" else (w, round(w * 9 / 16))
        rows, meta = bench_scene(name, budgets, res, args.reference_samples, args.max_bounces)
        all_rows += rows
        info.append(meta)
        plot(name, rows, os.path.join(OUT, f"{name}_error.png"))
    stem = args.out_name
    with open(os.path.join(OUT, "results.json" if stem == "report" else f"{stem}.json"),
              "w") as f:
        json.dump(dict(rows=all_rows, first_pixels=info), f, indent=1)
    text = report(all_rows, info, argv)
    with open(os.path.join(OUT, f"{stem}.md"), "w") as f:
        f.write(text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())

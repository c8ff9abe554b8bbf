"""The course project's experiments rendered by Specula and by Cycles, side by side.

    make figures        # or: .venv/bin/python -m tests.benchmarks.course_figures [--quick]

1. CBspheres at the course's max ray depths 0, 1, 2, 3, 4, 5 and 100.
2. The CBdragon stand-in's focus stacks: aperture sweep at focal distance 4.56 (lens radius
   0.02, 0.25, 0.75, 1.23, 2) and focal-distance sweep at radius 1.23 (1, 2, 3, 4.56, 5).

**Course ray depth -> Blender bounces.** The course counts the bounces a path may take and
shows at depth 0 only the emitters seen directly, at depth 1 direct lighting. Blender's
`max_bounces = 0` already *is* direct lighting (next-event estimation at the first hit), so
course depth d >= 1 is `max_bounces = d - 1`. Course depth 0 has no bounce count in Blender:
it is rendered at `max_bounces = 0` with every non-emitting surface's colour set to black,
which leaves exactly the emitters the camera sees (in both engines).

**Thin lens.** The course's lens radius r becomes Blender's f-stop
`lens_mm * 1e-3 / (2 r)`; its focal distance is Blender's focus distance (both measure to a
plane along the view axis).

Writes out/figures/cbspheres_depths.png, cbdragon_aperture.png, cbdragon_focus.png (rows:
Specula, Cycles, signed difference), and out/figures/differences.md / .json with, per image,
the relative RMS difference between the engines beside what noise alone would give, the
statistical comparison of tests/cycles/compare.py (max |z| against its Sidak threshold), and
Specula's samples, seconds and estimated relative error with its 95 % interval.
`--seconds S` gives each Specula image a time budget instead of a sample count,
`--without-light-tracing` turns its caustic light paths off (to compare at equal time), and
`--prefix P` names the outputs P<name>.
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

from blend_scenes import build_scenes  # noqa: E402
from addon import imaging  # noqa: E402
from tests.cycles import compare, renderers  # noqa: E402

OUT = os.path.join(REPO, "out", "figures")
COURSE_DEPTHS = (0, 1, 2, 3, 4, 5, 100)
APERTURE_RADII = (0.02, 0.25, 0.75, 1.23, 2.0)
FOCUS_DISTANCES = (1.0, 2.0, 3.0, 4.56, 5.0)


def blender_bounces(course_depth: int) -> int:
    """Blender's max_bounces for a course ray depth >= 1 (depth 0: see the module doc)."""
    return max(course_depth - 1, 0)


# Set by main: Specula's time budget per image (0: `samples`) and light tracing.
SPECULA_SECONDS, LIGHT_TRACING = 0.0, True


def open_scene(name, resolution, samples):
    scene = renderers.open_blend_scene(name, resolution)
    s = scene.specula
    s.samples, s.seed, s.time_limit, s.target_error = samples, 0, 0, 0
    if SPECULA_SECONDS:
        s.samples, s.time_limit = 1 << 20, SPECULA_SECONDS
    s.use_light_tracing = LIGHT_TRACING
    return scene


def blacken_non_emitters():
    """Course depth 0: every surface that does not emit renders black."""
    for mat in bpy.data.materials:
        if mat.node_tree is None:
            continue
        for node in mat.node_tree.nodes:
            if node.bl_idname == "ShaderNodeEmission":
                continue
            for socket in ("Color", "Base Color"):
                if socket in node.inputs:
                    node.inputs[socket].default_value = (0.0, 0.0, 0.0, 1.0)


class Specula:
    """Exports a scene once; renders it with a camera re-read from Blender each time."""

    def __init__(self, scene):
        from addon import exporter
        self.exporter, self.core, self.scene = exporter, renderers.core(), scene
        self.depsgraph = bpy.context.evaluated_depsgraph_get()
        exported = exporter.export(self.depsgraph)
        self.core_scene, _ = exporter.to_core(exported, self.core)

    def render(self, max_bounces):
        self.depsgraph.update()
        cam = self.exporter.camera_settings(self.scene, self.depsgraph, lambda _: None)
        self.core_scene.camera = self.core.Camera(**cam)
        w, h = self.scene.render.resolution_x, self.scene.render.resolution_y
        kw = self.exporter.render_settings_kwargs(self.scene, w, h)
        kw.update(max_bounces=max_bounces)
        return self.core.render(self.core_scene, self.core.RenderSettings(**kw))


def cycles_runs(scene, samples, max_bounces, seeds=(1, 2)):
    runs = []
    for seed in seeds:
        renderers.configure_cycles(scene, samples, seed, max_bounces)
        rgba, _ = renderers.render_cycles_image(scene)
        runs.append(rgba[..., :3].astype(np.float64))
    scene.render.engine = "SPECULA"
    return np.stack(runs)


def measure(label, result, runs):
    """One image's difference figures (and the images for the sheet)."""
    s = result.combined[..., :3].astype(np.float64)
    c = runs.mean(axis=0)
    rms_c = float(np.sqrt(np.mean(c ** 2)))
    noise = float(np.sqrt(np.mean(result.variance + runs.var(axis=0, ddof=1) / len(runs))))
    cmp = compare.compare(s, result.variance, runs, specula_dof=result.dof)
    return dict(label=label, specula=s, cycles=c,
                rel_rms_difference=float(np.sqrt(np.mean((s - c) ** 2))) / max(rms_c, 1e-12),
                rel_rms_noise=noise / max(rms_c, 1e-12), max_z=cmp.max_z,
                z_threshold=cmp.z_threshold, agree=cmp.agree, specula_samples=result.samples,
                specula_seconds=result.seconds,
                specula_relative_error=float(result.relative_error),
                specula_error_interval=[float(v) for v in result.error_interval])


def sheet(title, items, path, exposure=1.0):
    rows = [[imaging.flip(imaging.srgb(it["specula"], exposure)) for it in items],
            [imaging.flip(imaging.srgb(it["cycles"], exposure)) for it in items],
            [imaging.flip(imaging.diff_image(it["specula"], it["cycles"], 0.1)) for it in items]]
    captions = [[f"{it['specula_samples']} SPP {it['specula_seconds']:.0f} S"
                 f" E {100 * it['specula_relative_error']:.1f}%" for it in items],
                ["" for _ in items],
                [f"D {100 * it['rel_rms_difference']:.1f}% N {100 * it['rel_rms_noise']:.1f}%"
                 f" Z {it['max_z']:.1f}" for it in items]]
    img = imaging.contact_sheet(rows, ["SPECULA", "CYCLES", "S-C X10"],
                                [it["label"] for it in items], captions=captions, title=title)
    imaging.write_png(path, img)
    print(f"wrote {os.path.relpath(path, REPO)}", flush=True)


def depth_experiment(resolution, samples):
    items = []
    for depth in COURSE_DEPTHS:
        scene = open_scene("cbspheres", resolution, samples)
        if depth == 0:
            blacken_non_emitters()
        bounces = blender_bounces(depth)
        result = Specula(scene).render(bounces)
        runs = cycles_runs(scene, samples, bounces)
        label = f"DEPTH {depth} (B{bounces}{', BLACK' if depth == 0 else ''})"
        items.append(measure(label, result, runs))
        print(f"depth {depth}: max_bounces {bounces}, relative difference "
              f"{items[-1]['rel_rms_difference']:.4f} (noise {items[-1]['rel_rms_noise']:.4f}), "
              f"max |z| {items[-1]['max_z']:.2f}", flush=True)
    return items


def focus_experiments(resolution, samples, max_bounces):
    scene = open_scene("cbdragon", resolution, samples)
    specula = Specula(scene)
    cam = scene.camera.data
    lens = cam.lens
    done = {}

    def one(radius, focus):
        key = (radius, focus)
        if key not in done:
            cam.dof.use_dof = True
            cam.dof.aperture_fstop = lens * 1e-3 / (2.0 * radius)
            cam.dof.focus_distance = focus
            result = specula.render(max_bounces)
            runs = cycles_runs(scene, samples, max_bounces)
            done[key] = measure(f"R {radius:g} D {focus:g}", result, runs)
            print(f"radius {radius:g}, focus {focus:g}: relative difference "
                  f"{done[key]['rel_rms_difference']:.4f} (noise {done[key]['rel_rms_noise']:.4f})"
                  f", max |z| {done[key]['max_z']:.2f}", flush=True)
        return done[key]

    aperture = [one(r, build_scenes.CBDRAGON_FOCUS) for r in APERTURE_RADII]
    focus = [one(build_scenes.CBDRAGON_APERTURE_RADIUS, d) for d in FOCUS_DISTANCES]
    return aperture, focus


def write_table(groups, path_md, path_json, args):
    lines = ["# Course figures: Specula beside Cycles", "",
             f"Command: `.venv/bin/python -m tests.benchmarks.course_figures {' '.join(args)}` "
             f"(Blender {bpy.app.version_string}). Per image: relative RMS difference between the "
             f"engines (D), what the two images' estimated noise alone gives (N; D close to N "
             f"means the difference is noise), and the block z-test of tests/cycles/compare.py "
             f"(max |z| and its Sidak threshold at family level 0.1 %).", ""]
    table = {}
    for title, items in groups:
        lines += [f"## {title}", "", "| image | D | N | max abs z | threshold | agree | "
                  "Specula samples | s | estimated error (95 % interval) |",
                  "|---|---|---|---|---|---|---|---|---|"]
        for it in items:
            lo, hi = it["specula_error_interval"]
            lines.append(f"| {it['label']} | {100 * it['rel_rms_difference']:.2f} % | "
                         f"{100 * it['rel_rms_noise']:.2f} % | {it['max_z']:.2f} | "
                         f"{it['z_threshold']:.2f} | {'yes' if it['agree'] else 'NO'} | "
                         f"{it['specula_samples']} | {it['specula_seconds']:.1f} | "
                         f"{100 * it['specula_relative_error']:.2f} % "
                         f"({100 * lo:.2f}-{100 * hi:.2f} %) |")
        lines.append("")
        table[title] = [{k: v for k, v in it.items() if k not in ("specula", "cycles")}
                        for it in items]
    with open(path_md, "w") as f:
        f.write("\n".join(lines))
    with open(path_json, "w") as f:
        json.dump(table, f, indent=1)
    print("\n".join(lines))


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    parser = argparse.ArgumentParser(prog="python -m tests.benchmarks.course_figures",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("--width", type=int, default=160, help="image width (default 160)")
    parser.add_argument("--samples", type=int, default=64,
                        help="Specula samples; Cycles renders two seeds of as many (default 64)")
    parser.add_argument("--dragon-bounces", type=int, default=8,
                        help="max_bounces for the CBdragon stacks (default 8)")
    parser.add_argument("--quick", action="store_true", help="80 px wide, 16 samples")
    parser.add_argument("--only", choices=("depths", "focus"), help="one experiment only")
    parser.add_argument("--seconds", type=float, default=0.0,
                        help="Specula's time budget per image instead of --samples")
    parser.add_argument("--without-light-tracing", action="store_true",
                        help="Specula without its caustic light paths")
    parser.add_argument("--prefix", default="", help="prefix of the output files' names")
    args = parser.parse_args(argv)
    global SPECULA_SECONDS, LIGHT_TRACING
    SPECULA_SECONDS, LIGHT_TRACING = args.seconds, not args.without_light_tracing
    width, samples = (80, 16) if args.quick else (args.width, args.samples)
    os.makedirs(OUT, exist_ok=True)
    t0 = time.perf_counter()
    groups = []
    if args.only in (None, "depths"):
        depths = depth_experiment((width, width * 3 // 4), samples)
        sheet("CBSPHERES: COURSE MAX RAY DEPTH (BLENDER MAX_BOUNCES = DEPTH - 1)", depths,
              os.path.join(OUT, args.prefix + "cbspheres_depths.png"))
        groups.append(("CBspheres: course ray depth (Blender max_bounces)", depths))
    if args.only in (None, "focus"):
        aperture, focus = focus_experiments((width, width * 9 // 16), samples,
                                            args.dragon_bounces)
        sheet("CBDRAGON: APERTURE SWEEP AT FOCAL DISTANCE 4.56 (R = LENS RADIUS)", aperture,
              os.path.join(OUT, args.prefix + "cbdragon_aperture.png"))
        sheet("CBDRAGON: FOCAL DISTANCE SWEEP AT LENS RADIUS 1.23", focus,
              os.path.join(OUT, args.prefix + "cbdragon_focus.png"))
        groups += [("CBdragon: aperture sweep at focal distance 4.56", aperture),
                   ("CBdragon: focal distance sweep at lens radius 1.23", focus)]
    write_table(groups, os.path.join(OUT, args.prefix + "differences.md"),
                os.path.join(OUT, args.prefix + "differences.json"), argv)
    print(f"done in {time.perf_counter() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Kernels per plan (a benchmark: it reports, never asserts).

For five scenes (diffuse-only box, CBspheres, CBspheres with a polygonal thin lens, a box
lit by light objects, Principled and rough Glossy spheres): the compile time of the scene's
own kernel and of the generic kernel from nothing (uncached), and the render time of each
(best of several rounds, the kernels alternating; same image). With `--before PATH` (a
checkout of an older commit, e.g. `git worktree add /tmp/before 37c615f`) the same renders
run in that checkout too, with its default kernel, in turns with this one's.

    .venv/bin/python -m tests.benchmarks.bench_kernels [--rounds 3] [--samples 24]
        [--before /tmp/before]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from dataclasses import replace

import numpy as np

from engine import Light, Material, World, render
from tests import scenes

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def _spheres(materials):
    b = scenes.cornell_box(spheres=False)
    for k, (material, centre) in enumerate(zip(materials, ((-0.4, 0.2, 0.35),
                                                            (0.4, -0.1, 0.35)))):
        v, t, n = scenes.uv_sphere(centre, 0.35)
        b.add_mesh(f"sphere{k}", v, t, b.add_material(material), corner_normals=n)
    return b.build(scenes.cornell_camera(), World((0, 0, 0)))


def _light_objects():
    b = scenes.cornell_box(spheres=True, emitter_radiance=0.0)
    m = np.eye(4)
    m[:3, 3] = (0.3, 0.0, 1.3)
    b.add_light(Light("point", "POINT", (60.0, 60.0, 60.0), matrix=m, radius=0.05))
    m2 = np.eye(4)
    m2[:3, 3] = (-0.3, 0.2, 1.45)
    b.add_light(Light("area", "AREA", (30.0, 30.0, 30.0), matrix=m2, size_x=0.3,
                      size_y=0.2, shape="RECTANGLE"))
    return b.build(scenes.cornell_camera(), World((0, 0, 0)))


def scenes_to_bench():
    dof = scenes.cornell_camera(use_dof=True, fstop=0.5, focus_distance=2.5, blades=6)
    return {
        "diffuse box": scenes.cornell_box(spheres=False).build(scenes.cornell_camera(),
                                                               World((0, 0, 0))),
        "CBspheres": scenes.cbspheres(),
        "CBspheres + DOF (6 blades)": scenes.cornell_box().build(dof, World((0, 0, 0))),
        "light objects (point, area)": _light_objects(),
        "Principled + rough Glossy": _spheres([
            Material.principled("principled", (0.7, 0.3, 0.2), roughness=0.4),
            Material.glossy("glossy", (0.9, 0.6, 0.2), roughness=0.3)]),
    }


def compile_seconds(scene, settings, constants) -> float:
    """Seconds from nothing to a kernel for `constants` that has traced one pixel (uncached:
    numba's disk cache is not read or written)."""
    from engine import kernels
    from engine.accel import Accel
    from engine.camera import CameraModel
    from engine.lights import LightSampler
    from engine.plan import make_plan

    plan = make_plan(scene, settings)
    emitters = LightSampler(scene) if plan.emitters else None
    camera = CameraModel(scene.camera, settings.width, settings.height, scene.origin)
    accel = Accel(scene)
    t0 = time.perf_counter()
    k = kernels.Kernel(constants, cache=False)
    kernels.compile_on(k, scene, settings, plan, emitters, camera, accel)
    return time.perf_counter() - t0


def render_seconds(scene, settings, kinds, rounds):
    """Best wall seconds of a render with each kernel setting in `kinds` (alternating), and
    the last image of each."""
    for kind in kinds:  # load (or compile) first
        render(scene, replace(settings, kernel=kind, samples=1, width=16, height=12))
    times, images = {k: [] for k in kinds}, {}
    for _ in range(rounds):
        for kind in kinds:
            t0 = time.perf_counter()
            images[kind] = render(scene, replace(settings, kernel=kind)).combined
            times[kind].append(time.perf_counter() - t0)
    return {k: min(t) for k, t in times.items()}, images


def time_all(samples, rounds, kinds):
    """{scene: {kind: best seconds}} at 160x120 (also run inside an older checkout)."""
    out = {}
    for name, scene in scenes_to_bench().items():
        st = scenes.settings(width=160, height=120, samples=samples, threads=0)
        out[name] = {k: round(v, 3) for k, v in render_seconds(scene, st, kinds, rounds)[0].items()}
    return out


def time_before(path, samples, rounds):
    """time_all in the checkout at `path` (its own engine, its default kernel)."""
    code = ("import json, sys; sys.path.insert(0, sys.argv[1]); import importlib.util as u; "
            "s = u.spec_from_file_location('bk', sys.argv[2]); m = u.module_from_spec(s); "
            "s.loader.exec_module(m); "
            "print(json.dumps(m.time_all(int(sys.argv[3]), int(sys.argv[4]), ['auto'])))")
    run = subprocess.run([sys.executable, "-c", code, path, os.path.abspath(__file__),
                          str(samples), str(rounds)], cwd=path, capture_output=True, text=True,
                         check=True)
    return json.loads(run.stdout.strip().splitlines()[-1])


def bench_scene(name, scene, samples, rounds, compile_too):
    from engine.lights import LightSampler
    from engine.plan import make_plan

    settings = scenes.settings(width=160, height=120, samples=samples, threads=0)
    plan = make_plan(scene, settings)
    grid = plan.emitters and hasattr(LightSampler(scene), "local_pmf")
    row = {"scene": name, "plan": plan.describe()}
    if compile_too:
        row["compile_specialised_s"] = round(compile_seconds(
            scene, settings, plan.kernel_constants(grid)), 2)
    best, images = render_seconds(scene, settings, ("generic", "specialised"), rounds)
    for kind, t in best.items():
        row[f"{kind}_s"] = round(t, 3)
        row[f"{kind}_samples_per_s"] = round(160 * 120 * samples / t)
    row["speedup"] = round(best["generic"] / best["specialised"], 3)
    row["same_image"] = bool(np.array_equal(images["generic"], images["specialised"]))
    return row


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=24)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--no-compile", action="store_true", help="skip the compile timings")
    ap.add_argument("--out", default="out/bench")
    ap.add_argument("--before", default=None, help="an older checkout to time beside this")
    args = ap.parse_args()
    from engine import kernels

    rows = []
    if not args.no_compile:
        t = compile_seconds(scenes.cbspheres(), scenes.settings(width=16, height=12),
                            kernels.generic_constants())
        rows.append({"scene": "(generic kernel)", "compile_generic_s": round(t, 2)})
        print(rows[-1], flush=True)
    for name, scene in scenes_to_bench().items():
        rows.append(bench_scene(name, scene, args.samples, args.rounds, not args.no_compile))
        print(rows[-1], flush=True)
    before = time_before(args.before, args.samples, args.rounds) if args.before else None
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "kernels.json"), "w") as f:
        json.dump(dict(rows=rows, before=before), f, indent=1)
    print("| scene | compile s | generic samples/s | specialised samples/s | speed-up | "
          "same image |")
    print("|---|---|---|---|---|---|")
    for r in rows[1:] if not args.no_compile else rows:
        print(f"| {r['scene']} | {r.get('compile_specialised_s', '')} | "
              f"{r['generic_samples_per_s']} | {r['specialised_samples_per_s']} | "
              f"{r['speedup']} | {r['same_image']} |")
    if before:
        print("\n| scene | before s | generic s | specialised s |\n|---|---|---|---|")
        for r in rows:
            if r["scene"] in before:
                print(f"| {r['scene']} | {before[r['scene']]['auto']} | {r['generic_s']} | "
                      f"{r['specialised_s']} |")


if __name__ == "__main__":
    main()

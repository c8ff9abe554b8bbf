"""Kernels per plan (a benchmark: it reports, never asserts).

For five scenes (diffuse-only box, CBspheres, CBspheres with a polygonal thin lens, a box
lit by light objects, Principled and rough Glossy spheres): the compile time of the scene's
own kernel and of the generic kernel from nothing (uncached), and the render speed of each
(path samples per second, same image), alternating the two kernels over several rounds.

    .venv/bin/python -m tests.benchmarks.bench_kernels [--rounds 3] [--samples 24]
"""

from __future__ import annotations

import argparse
import json
import os
import time
from dataclasses import replace

import numpy as np

from engine import Light, Material, World, kernels, render
from engine.accel import Accel
from engine.camera import CameraModel
from engine.lights import LightSampler
from engine.plan import make_plan
from tests import scenes


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
    plan = make_plan(scene, settings)
    emitters = LightSampler(scene) if plan.emitters else None
    camera = CameraModel(scene.camera, settings.width, settings.height, scene.origin)
    accel = Accel(scene)
    t0 = time.perf_counter()
    k = kernels.Kernel(constants, cache=False)
    kernels.compile_on(k, scene, settings, plan, emitters, camera, accel)
    return time.perf_counter() - t0


def bench_scene(name, scene, samples, rounds, compile_too):
    settings = scenes.settings(width=160, height=120, samples=samples, threads=0)
    plan = make_plan(scene, settings)
    grid = plan.emitters and hasattr(LightSampler(scene), "local_pmf")
    row = {"scene": name, "plan": plan.describe()}
    if compile_too:
        row["compile_specialised_s"] = round(compile_seconds(
            scene, settings, plan.kernel_constants(grid)), 2)
    for kind in ("generic", "specialised"):  # load both (and compile once if need be)
        render(scene, replace(settings, kernel=kind, samples=1, width=16, height=12))
    times = {"generic": [], "specialised": []}
    images = {}
    for _ in range(rounds):
        for kind in ("generic", "specialised"):
            t0 = time.perf_counter()
            r = render(scene, replace(settings, kernel=kind))
            times[kind].append(time.perf_counter() - t0)
            images[kind] = r.combined
    for kind, t in times.items():
        row[f"{kind}_s"] = round(min(t), 3)
        row[f"{kind}_samples_per_s"] = round(160 * 120 * samples / min(t))
    row["speedup"] = round(min(times["generic"]) / min(times["specialised"]), 3)
    row["same_image"] = bool(np.array_equal(images["generic"], images["specialised"]))
    return row


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=24)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--no-compile", action="store_true", help="skip the compile timings")
    ap.add_argument("--out", default="out/bench")
    args = ap.parse_args()
    rows = []
    if not args.no_compile:
        t = compile_seconds(scenes.cbspheres(), scenes.settings(width=16, height=12),
                            kernels.generic_constants())
        rows.append({"scene": "(generic kernel)", "compile_generic_s": round(t, 2)})
        print(rows[-1], flush=True)
    for name, scene in scenes_to_bench().items():
        rows.append(bench_scene(name, scene, args.samples, args.rounds, not args.no_compile))
        print(rows[-1], flush=True)
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "kernels.json"), "w") as f:
        json.dump(rows, f, indent=1)
    print("| scene | compile s | generic samples/s | specialised samples/s | speed-up | "
          "same image |")
    print("|---|---|---|---|---|---|")
    for r in rows[1:] if not args.no_compile else rows:
        print(f"| {r['scene']} | {r.get('compile_specialised_s', '')} | "
              f"{r['generic_samples_per_s']} | {r['specialised_samples_per_s']} | "
              f"{r['speedup']} | {r['same_image']} |")


if __name__ == "__main__":
    main()

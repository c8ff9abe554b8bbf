"""Core throughput benchmark (a benchmark, not a test: it reports, never asserts).

CBspheres (Cornell box, mirror and glass sphere) at 480x360: ray segments per second,
path samples per second and the fraction of wall time inside embreex calls, beside the
raw embreex throughput on the very same rays (recorded during one pass, replayed alone).

    make bench            # or: .venv/bin/python -m tests.benchmarks.bench_core
"""

from __future__ import annotations

import argparse
import json
import os
import time
from contextlib import contextmanager
from dataclasses import replace

import numpy as np

from engine import render
from engine.accel import Accel
from tests import scenes


class RecordingAccel(Accel):
    """Accel that keeps a copy of every batch it traces, for the raw replay."""

    def __init__(self, scene):
        super().__init__(scene)
        self.batches = []

    def intersect(self, o, d, tmax):
        self.batches.append(("intersect", o.copy(), d.copy(), np.asarray(tmax).copy()))
        return super().intersect(o, d, tmax)

    def occluded(self, o, d, tmax):
        self.batches.append(("occluded", o.copy(), d.copy(), np.asarray(tmax).copy()))
        return super().occluded(o, d, tmax)

    def intersect_raw(self, o, d, tmax):
        self.batches.append(("intersect_raw", o.copy(), d.copy(), tmax.copy()))
        return super().intersect_raw(o, d, tmax)

    def occluded_raw(self, o, d, tmax):
        self.batches.append(("occluded_raw", o.copy(), d.copy(), tmax.copy()))
        return super().occluded_raw(o, d, tmax)


@contextmanager
def profiled_render():
    """Keep the Accel of the renders inside the block (the last one in `seen`), for
    embree's share; the render's own stage timers give the per-stage split."""
    import engine.renderer as renderer

    seen = {}
    original_accel = renderer.Accel

    def accel(scene):
        seen["accel"] = a = original_accel(scene)
        return a

    renderer.Accel = accel
    try:
        yield seen
    finally:
        renderer.Accel = original_accel


def shares(seen, wall, threads):
    """(fraction of the threads' time inside embreex, share per named stage). The stages
    'intersect' and 'trace shadow rays' include their embreex calls; 'other' is what no
    stage covers: the bounce loop's Python glue and threads waiting at pass ends."""
    busy = wall * threads
    stages = {k: round(v / busy, 3) for k, v in sorted(seen["result"].stage_seconds.items(),
                                                         key=lambda kv: -kv[1])}
    stages["other"] = round(1.0 - sum(stages.values()), 3)
    return round(seen["accel"].seconds / busy, 3), stages


def run(width=480, height=360, samples=8, threads=0, max_bounces=8, kernel="auto"):
    import engine.renderer as renderer

    scene = scenes.cbspheres()
    settings = replace(scenes.settings(width=width, height=height, samples=samples,
                                       threads=threads, max_bounces=max_bounces), kernel=kernel)
    render(scene, replace(settings, width=16, height=12, samples=1))  # load compiled code
    with profiled_render() as seen:
        t0 = time.perf_counter()
        seen["result"] = result = render(scene, settings)
        wall = time.perf_counter() - t0
    accel = seen["accel"]
    threads_used = settings.threads or os.cpu_count()

    # Replay one pass's rays through embreex alone, single-threaded.
    rec = RecordingAccel(scene)
    original = renderer.Accel
    renderer.Accel = lambda s: rec
    try:
        render(scene, replace(settings, samples=1, threads=1))
    finally:
        renderer.Accel = original
    raw = Accel(scene)
    t0 = time.perf_counter()
    for kind, o, d, tmax in rec.batches:
        getattr(raw, kind)(o, d, tmax)
    raw_seconds = time.perf_counter() - t0
    fraction, stages = shares(seen, wall, threads_used)
    profiled = None
    if True:
        # Profile: the same render with `shade` counting cycles per stage, so its time
        # splits into surface interaction, light sampling and BSDF sampling.
        renderer.Kernels.profile = True
        try:
            render(scene, replace(settings, width=16, height=12, samples=1))
            with profiled_render() as seen_p:
                t0 = time.perf_counter()
                seen_p["result"] = render(scene, settings)
                profiled = shares(seen_p, time.perf_counter() - t0, threads_used)[1]
        finally:
            renderer.Kernels.profile = False
    return {
        "scene": "CBspheres", "kernel": result.plan.kernel, "resolution": f"{width}x{height}",
        "samples": result.samples,
        "threads": threads_used, "wall_seconds": round(wall, 3),
        "ray_segments": accel.rays,
        "ray_segments_per_second": round(accel.rays / wall),
        "path_samples_per_second": round(width * height * result.samples / wall),
        # Summed over threads, divided by threads: the share of the cores' time in embree.
        "fraction_in_embree": fraction,
        "raw_embree_rays_per_second_1_thread": round(raw.rays / raw_seconds),
        "time_to_first_pass": round(result.time_to_first_pass, 3),
        "share_of_time_per_stage": stages,
        **({"share_of_time_per_stage_profiled": profiled} if profiled else {}),
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=8)
    ap.add_argument("--threads", type=int, default=0)
    ap.add_argument("--out", default="out/bench")
    ap.add_argument("--kernel", choices=("both", "generic", "specialised"), default="both",
                    help="both: the generic kernel, then the scene's own, in one run")
    args = ap.parse_args()
    kernels = ("generic", "specialised") if args.kernel == "both" else (args.kernel,)
    reports = [run(samples=args.samples, threads=args.threads, kernel=k) for k in kernels]
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "core.json"), "w") as f:
        json.dump(reports, f, indent=2)
    for report in reports:
        for k, v in report.items():
            print(f"{k:40s} {v}")
        print()


if __name__ == "__main__":
    main()

"""Stopping at a target error: the replicate estimate against the one before it.

    .venv/bin/python -m tests.benchmarks.bench_target [--scenes cbspheres cbdragon]
        [--target 0.01] [--resolution 64x48] [--reference-factor 8]

For each committed scene, as the add-on exports it:

* "replicates": Specula as it is, 2 replicates, stopping when its estimated relative error
  falls to the target (RenderSettings.target_error);
* "independent": the plain sequence (1 replicate) stopped as Specula did before replicates,
  when the independent-sample estimate (the samples' own spread over N) falls to the
  target; emulated by cancelling at the first pass where it does (`should_stop`), which is
  the same rule checked at the same passes.

Each stopped image is measured against a reference render (`--reference-factor` times the
samples the replicate render needed, its own seed) with the reference's estimated variance
subtracted. Reports seconds, samples, the estimate at the stop and the measured error, and
the time saved. Writes out/bench/target.json. A benchmark: it reports, never asserts.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from dataclasses import replace

import numpy as np

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
if REPO not in sys.path:
    sys.path.insert(0, REPO)

from addon import core  # noqa: E402
from addon.renderers import export_specula, render_specula  # noqa: E402
from tests.benchmarks.calibration import own_variance  # noqa: E402
from tests.cycles import renderers  # noqa: E402

OUT = os.path.join(REPO, "out", "bench")
LUM = np.array([0.2126, 0.7152, 0.0722])


def measured(result, ref) -> float:
    """Relative RMS error of the luminance against the reference, the reference's own
    estimated variance taken out."""
    y_ref = ref.combined[..., :3].astype(np.float64) @ LUM
    d = result.combined[..., :3].astype(np.float64) @ LUM - y_ref
    mse = float(np.mean(d * d)) - float(np.mean(own_variance(ref)))
    return math.sqrt(max(mse, 0.0)) / float(y_ref.mean())


def run_scene(name, target, resolution, factor, seed=11):
    renderers.open_blend_scene(name, resolution)
    core_scene, settings, _ = export_specula(__import__("bpy").context.scene)
    settings = replace(settings, time_limit=0.0, samples=1 << 20, seed=seed)
    # Compile (or load) the scene's kernel first, so neither timed render pays for it.
    render_specula(core_scene, replace(settings, samples=4, kernel="specialised"))
    t0 = time.perf_counter()
    new = render_specula(core_scene, replace(settings, target_error=target, replicates=2,
                                             kernel="specialised"))
    new_seconds = time.perf_counter() - t0

    def today(p):
        return 0 <= p.independent_relative_error <= target and p.samples >= 2

    # should_stop is checked right after on_pass, at the pass where the rule first holds.
    state = {"done": False}
    t0 = time.perf_counter()
    old = core.load().render(core_scene, replace(settings, replicates=1, kernel="specialised"),
                             on_pass=lambda p: state.update(done=today(p)),
                             should_stop=lambda: state["done"])
    old_seconds = time.perf_counter() - t0
    ref = render_specula(core_scene, replace(settings, samples=factor * new.samples,
                                             seed=1_000_003, replicates=8))
    rec = {"scene": name, "resolution": list(resolution), "target": target,
           "replicates": {"seconds": new_seconds, "samples": new.samples,
                          "estimated": new.relative_error,
                          "interval": list(new.error_interval), "measured": measured(new, ref)},
           "independent": {"seconds": old_seconds, "samples": old.samples,
                           "estimated": old.independent_relative_error,
                           "measured": measured(old, ref)},
           "reference_samples": ref.samples, "reference_error": ref.relative_error}
    rec["time_saved"] = 1.0 - new_seconds / old_seconds
    return rec


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scenes", nargs="*", default=["cbspheres", "cbdragon"])
    ap.add_argument("--target", type=float, default=0.01)
    ap.add_argument("--resolution", default="64x48")
    ap.add_argument("--reference-factor", type=int, default=8)
    args = ap.parse_args(argv)
    resolution = tuple(int(v) for v in args.resolution.split("x"))
    results = []
    for name in args.scenes:
        rec = run_scene(name, args.target, resolution, args.reference_factor)
        results.append(rec)
        n, o = rec["replicates"], rec["independent"]
        print(f"{name}: target {args.target:.2%}\n"
              f"  replicates : {n['seconds']:7.1f} s {n['samples']:6d} spp, estimated "
              f"{n['estimated']:.4f}, measured {n['measured']:.4f}\n"
              f"  independent: {o['seconds']:7.1f} s {o['samples']:6d} spp, estimated "
              f"{o['estimated']:.4f}, measured {o['measured']:.4f}\n"
              f"  time saved {rec['time_saved']:.0%}", flush=True)
    os.makedirs(OUT, exist_ok=True)
    with open(os.path.join(OUT, "target.json"), "w") as f:
        json.dump(results, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())

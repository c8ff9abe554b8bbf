"""Is the estimated error the real error? Calibration of the replicate estimate.

    .venv/bin/python -m tests.benchmarks.calibration [--only NAME ...] [--replicates 4,8]
        [--seeds 2] [--levels 16,64,256,1024] [--reference-samples 8192] [--json PATH]

For every variant of the Cycles agreement set (tests/cycles/variants.py), exported once
through the add-on: a reference rendered by Specula with `--reference-samples` samples and
its own seed, then `--seeds` renders per replicate count, each read at every level of
`--levels` samples (the passes a render could stop at). At each level:

* measured relative RMS error: RMS over pixels of the luminance difference from the
  reference, over the reference's mean luminance (the film's definition of the estimate),
  with the reference's own estimated mean square error taken out (`measured_raw` keeps it);
* estimated: the render's `relative_error`, and what the independent-sample estimate
  (before replicates) says (`independent_relative_error`);
* coverage: the share of pixels whose 95% interval (value +- t95 x error) holds the
  reference's value, pooled over seeds; pixels exact in both renders (zero difference,
  zero estimated error: a flat background) are left out and counted (`exact_share`).

The reference is Specula's own, not Cycles': the question is whether Specula's estimate
describes Specula's own noise (agreement with Cycles is tests/cycles' job), and a Cycles
reference converged enough for 1024 samples would cost hours. The reference has noise of
its own, `--reference-samples` / level times less in variance; `reference_share` reports
it (its estimated mean squared error over the measured one), the measured error has it
taken out, and the coverage is also given with the reference's variance added to each
interval (`coverage_with_reference`, the figure to read).

Also the efficiency of each pattern: measured error at equal samples for 1 replicate (the
plain sequence, no estimate) and for each replicate count.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from dataclasses import replace

import numpy as np

LUM = np.array([0.2126, 0.7152, 0.0722])
REFERENCE_SEED = 1_000_003


def _luminance(image):
    return np.asarray(image, np.float64)[..., :3] @ LUM


def own_variance(result):
    """Each pixel's own (unpooled, unbiased) replicate variance of its luminance."""
    from engine.film import estimate_of
    h, w = result.replicate_count.shape[:2]
    return estimate_of(result, radius=0).error.reshape(h, w).astype(np.float64) ** 2


def measure(core_scene, settings, render, levels, replicate_counts, seeds, ref_samples):
    """{replicates: {level: record}} for one exported scene."""
    ref = render(core_scene, replace(settings, samples=ref_samples, seed=REFERENCE_SEED,
                                     replicates=8, target_error=0.0, time_limit=0.0))
    y_ref = _luminance(ref.combined)
    ref_var = own_variance(ref)
    mean_ref = float(y_ref.mean())
    out = {}
    for reps in replicate_counts:
        acc = {lv: dict(measured2=[], estimated2=[], independent2=[], covered=0, covered_ref=0,
                        pixels=0, exact=0, ref_mse=float(ref_var.mean())) for lv in levels}
        for seed in range(1, seeds + 1):
            seen = {}

            def on_pass(p, seen=seen):
                if p.samples in acc:
                    seen[p.samples] = p

            render(core_scene, replace(settings, samples=max(levels), seed=seed,
                                       replicates=reps, target_error=0.0, time_limit=0.0),
                   on_pass=on_pass)
            for lv, p in seen.items():
                a = acc[lv]
                d = _luminance(p.combined) - y_ref
                a["measured2"].append(float(np.mean(d * d)))
                a["estimated2"].append(max(p.relative_error, 0.0) ** 2 * mean_ref ** 2)
                a["independent2"].append(max(p.independent_relative_error, 0.0) ** 2
                                         * mean_ref ** 2)
                if reps > 1:
                    se = p.error.astype(np.float64)
                    # Pixels exact in both renders (a flat background, an emitter seen
                    # directly) are covered by a zero-width interval; they say nothing
                    # about the estimate, so they are counted apart.
                    noisy = ~((d == 0) & (se == 0) & (ref_var == 0))
                    a["covered"] += int(np.sum((np.abs(d) <= p.t95 * se)[noisy]))
                    half_ref = p.t95 * np.sqrt(se ** 2 + ref_var)
                    a["covered_ref"] += int(np.sum((np.abs(d) <= half_ref)[noisy]))
                    a["pixels"] += int(noisy.sum())
                    a["exact"] += int((~noisy).sum())
        out[reps] = {lv: _summary(a, mean_ref) for lv, a in acc.items()}
    return out


def _summary(a, mean_ref):
    # The reference's own estimated variance taken out of the measured mean square error.
    mse = max(float(np.mean(a["measured2"])) - a["ref_mse"], 0.0)
    measured = math.sqrt(mse) / mean_ref if mean_ref > 0 else 0.0
    estimated = math.sqrt(np.mean(a["estimated2"])) / mean_ref if mean_ref > 0 else 0.0
    independent = math.sqrt(np.mean(a["independent2"])) / mean_ref if mean_ref > 0 else 0.0
    rec = {"measured": measured, "estimated": estimated, "independent": independent,
           "ratio": estimated / measured if measured > 0 else float("nan"),
           "independent_ratio": independent / measured if measured > 0 else float("nan"),
           "reference_share": a["ref_mse"] / max(np.mean(a["measured2"]), 1e-300),
           "measured_raw": math.sqrt(np.mean(a["measured2"])) / mean_ref if mean_ref > 0 else 0}
    if a["pixels"]:
        rec["coverage"] = a["covered"] / a["pixels"]
        rec["coverage_with_reference"] = a["covered_ref"] / a["pixels"]
        rec["exact_share"] = a["exact"] / (a["pixels"] + a["exact"])
    return rec


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--only", nargs="*")
    ap.add_argument("--replicates", default="1,4,8")
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--levels", default="16,64,256,1024")
    ap.add_argument("--reference-samples", type=int, default=8192)
    ap.add_argument("--json", default="out/calibration.json")
    ap.add_argument("--pool-radius", type=int, help="override film.POOL_RADIUS (experiments)")
    args = ap.parse_args(argv)
    if args.pool_radius is not None:
        from engine import film
        film.POOL_RADIUS = args.pool_radius
    from addon.renderers import render_specula
    from tests.cycles import renderers
    from tests.cycles.variants import VARIANTS

    levels = [int(v) for v in args.levels.split(",")]
    reps = [int(v) for v in args.replicates.split(",")]
    names = args.only or list(VARIANTS)
    results = {}
    try:
        with open(args.json) as f:
            results = json.load(f)
    except (OSError, ValueError):
        pass
    for name in names:
        t0 = time.perf_counter()
        core_scene, settings, _ = renderers.specula_scene(VARIANTS[name])
        res = measure(core_scene, settings, render_specula, levels, reps, args.seeds,
                      args.reference_samples)
        results[name] = {str(r): {str(lv): v for lv, v in d.items()} for r, d in res.items()}
        print(f"{name} ({time.perf_counter() - t0:.0f} s)")
        for r, d in res.items():
            for lv, v in d.items():
                cov = (f" coverage {100 * v['coverage']:.1f}% "
                       f"(+ref {100 * v['coverage_with_reference']:.1f}%)"
                       if "coverage" in v else "")
                print(f"  R={r:<2} {lv:>5} spp  measured {v['measured']:.4f}  estimated "
                      f"{v['estimated']:.4f} ratio {v['ratio']:.3f}  independent ratio "
                      f"{v['independent_ratio']:.3f}  ref share {v['reference_share']:.3f}"
                      f"{cov}", flush=True)
        with open(args.json, "w") as f:
            json.dump(results, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())

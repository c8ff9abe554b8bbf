"""Caustics: error against time with and without light tracing.

    .venv/bin/python -m tests.benchmarks.bench_caustics [--budgets 10 60]
        [--resolution 80x60] [--reference-seconds 240] [--scenes quad quad_ceiling cbspheres]

Scenes (tests/scenes.py `caustic_box`): CBspheres lit by a 0.1 x 0.1 emissive quad of the
usual light's power, at height 1.2 ("quad") and 1 cm under the ceiling ("quad_ceiling",
where the quad's back face makes a hot spot on the ceiling that lights the room as a second
small source), and CBspheres as committed in tests/scenes.py (its usual large light: the
scene where light tracing has least to do). For each: a reference (light tracing on,
`--reference-seconds`, its own seed), then renders stopped by the time limit at each
budget with path tracing alone and with light tracing, each measured against the
reference (relative RMS luminance error, the reference's own estimated variance taken
out) beside its own estimate. The scene's kernels are compiled before timing. Writes
out/bench/caustics.json (or --out). A benchmark: it reports, never asserts.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys

import numpy as np

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
if REPO not in sys.path:
    sys.path.insert(0, REPO)

from engine import render  # noqa: E402
from tests import scenes  # noqa: E402

OUT = os.path.join(REPO, "out", "bench")
LUM = np.array([0.2126, 0.7152, 0.0722])
SCENES = {"quad": lambda: scenes.caustic_box(light_z=1.2),
          "quad_ceiling": lambda: scenes.caustic_box(light_z=1.49),
          "cbspheres": scenes.cbspheres}


def measured(result, ref) -> float:
    y_ref = ref.combined[..., :3].astype(np.float64) @ LUM
    d = result.combined[..., :3].astype(np.float64) @ LUM - y_ref
    mse = float(np.mean(d * d)) - float(np.mean(ref.variance[..., :3] @ (LUM * LUM)))
    return math.sqrt(max(mse, 0.0)) / float(y_ref.mean())


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scenes", nargs="*", default=list(SCENES))
    ap.add_argument("--out", default="caustics.json")
    ap.add_argument("--budgets", nargs="*", type=float, default=[10.0, 60.0])
    ap.add_argument("--resolution", default="80x60")
    ap.add_argument("--reference-seconds", type=float, default=240.0)
    args = ap.parse_args(argv)
    w, h = (int(v) for v in args.resolution.split("x"))
    report = {}
    for name in args.scenes:
        box = SCENES[name]()

        def settings(**kw):
            return scenes.settings(width=w, height=h, samples=1 << 20, max_bounces=12,
                                   kernel="specialised", **kw)
        for lt in (False, True):  # compile (or load) both kernels first
            render(box, scenes.settings(width=w, height=h, samples=2, light_tracing=lt,
                                        kernel="specialised"))
        ref = render(box, settings(seed=99, time_limit=args.reference_seconds,
                                   light_tracing=True))
        rows = {"reference": {"samples": int(ref.samples), "seconds": ref.seconds,
                              "estimated": ref.relative_error}}
        for budget in args.budgets:
            for lt in (False, True):
                r = render(box, settings(seed=1, time_limit=budget, light_tracing=lt))
                key = f"{'light tracing' if lt else 'path tracing'} {budget:g} s"
                rows[key] = {"samples": int(r.samples), "seconds": round(r.seconds, 2),
                             "estimated": r.relative_error, "measured": measured(r, ref)}
                print(name, key, rows[key], flush=True)
        report[name] = rows
    os.makedirs(OUT, exist_ok=True)
    with open(os.path.join(OUT, args.out), "w") as f:
        json.dump(report, f, indent=1)
    print(json.dumps(report, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Light choice among unequal lights: equal-sample variance against Cycles' light tree.

    .venv/bin/python -m tests.benchmarks.bench_light_choice [--scenes unequal many]
        [--samples 16] [--seeds 4] [--reference-samples 2048] [--resolution 64x48]
    [--replicates R]

Scenes, built through Blender (the same .blend state for both engines;
tests/addon/test_many_lights.py):
- "unequal": a floor, a wall and two blocks, a 1000 W point light 4 m up at one end and
  a 25 W 0.5 m square area light 0.6 m above the floor at the other, where it outshines
  the point light (issue 16, point 5);
- "unequal_area": the same without the point light (each light alone, for scale);
- "unequal_point": the same without the area light;
- "many": tests/addon/test_many_lights.py's 1,000 emissive triangles and 100 point lights.

For each: a high-sample Cycles reference (its own seed), then Cycles and Specula at
`--samples`, `--seeds` seeds each; the mean squared error against the reference, minus the
reference's own variance (estimated from two half-sample references), per engine, and the
ratio Specula / Cycles ("variance per sample" ratio: equal samples). Writes
out/bench/light_choice.json, and per scene out/bench/light_choice_<scene>.png: the
reference beside each engine's per-pixel RMS error. A benchmark: it reports, never asserts.
"""

from __future__ import annotations

import argparse
import json
import os
import sys

import numpy as np

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
for p in (REPO, os.path.join(REPO, "tests", "addon")):
    if p not in sys.path:
        sys.path.insert(0, p)

OUT = os.path.join(REPO, "out", "bench")

from tests.imageio import write_png  # noqa: E402


def build_unequal(point=True, area=True):
    from test_many_lights import build_unequal_scene

    return build_unequal_scene(point, area)


def build_many():
    from test_many_lights import build_scene

    return build_scene()


SCENES = {"unequal": build_unequal,
          "unequal_area": lambda: build_unequal(point=False),
          "unequal_point": lambda: build_unequal(area=False),
          "many": build_many}


def main(argv=None) -> int:
    import pathlib
    import tempfile

    import bpy  # noqa: F401 - before the add-on

    import addon

    addon.register()
    from test_many_lights import render
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scenes", nargs="*", default=list(SCENES))
    ap.add_argument("--samples", type=int, default=16)
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--reference-samples", type=int, default=2048)
    ap.add_argument("--resolution", default="64x48")
    ap.add_argument("--out", default="light_choice.json")
    ap.add_argument("--replicates", type=int, default=0,
                    help="Specula's replicates (0: the scene's default)")
    args = ap.parse_args(argv)
    res = tuple(int(v) for v in args.resolution.split("x"))
    tmp = pathlib.Path(tempfile.mkdtemp(prefix="light_choice_"))
    report = {}
    for name in args.scenes:
        build = SCENES[name]
        half = args.reference_samples // 2
        r1 = render("CYCLES", half, 1001, tmp, build, res).astype(np.float64)
        r2 = render("CYCLES", half, 1002, tmp, build, res).astype(np.float64)
        ref = 0.5 * (r1 + r2)
        # Each half's error variance is twice the mean's: the mean's own variance per pixel
        # is mean((r1 - r2)^2) / 4.
        ref_var = float(np.mean((r1 - r2) ** 2)) / 4.0
        row, maps = {}, [ref]
        for engine in ("CYCLES", "SPECULA"):
            sq = np.mean([(render(engine, args.samples, s + 1, tmp, build, res,
                                  args.replicates) - ref) ** 2
                          for s in range(args.seeds)], axis=0)
            row[engine.lower()] = float(np.mean(sq)) - ref_var
            maps.append(np.sqrt(sq.mean(axis=2, keepdims=True)).repeat(3, 2))
        os.makedirs(OUT, exist_ok=True)
        # Reference, then each engine's RMS error per pixel, on one scale.
        write_png(os.path.join(OUT, f"light_choice_{name}.png"),
                  np.concatenate(maps, axis=1).repeat(4, 0).repeat(4, 1))
        row["ratio"] = row["specula"] / row["cycles"]
        row["reference_variance"] = ref_var
        report[name] = row
        print(f"{name:14s} {args.samples} spp  MSE Specula {row['specula']:.4g}  "
              f"Cycles {row['cycles']:.4g}  ratio {row['ratio']:.2f}  "
              f"(reference's own {ref_var:.2g})", flush=True)
    os.makedirs(OUT, exist_ok=True)
    with open(os.path.join(OUT, args.out), "w") as f:
        json.dump(dict(args=vars(args), scenes=report), f, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

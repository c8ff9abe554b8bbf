"""Cycles reference images for the agreement tests, rendered once and cached.

    .venv/bin/python -m tests.cycles.references [--only NAME ...] [--force]   (make references)

renders every variant of tests/cycles/variants.py with Cycles (unbiased, CPU, one image
per seed) and stores each as tests/cycles/references/<variant>.npz: the runs (K, H, W, 3)
float32 and a JSON metadata record (Blender version and build hash, the variant's
fingerprint, samples, seeds, resolution and the Cycles settings used).

The tests call `get(variant)`: a cached file is used only when its metadata matches the
installed Blender and the variant's current fingerprint; otherwise the reference is rendered
(and stored, so the next run is fast). Every lookup is recorded in `LOG`, which the
conftest prints at the end of the run (cached / rendered and why).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
REF_DIR = os.path.join(HERE, "references")

# (variant name, "cached" | "rendered", reason) for every lookup in this process
LOG: list[tuple[str, str, str]] = []


def blender_version() -> dict:
    import bpy
    build = bpy.app.build_hash
    return {"version": bpy.app.version_string,
            "build_hash": build.decode() if isinstance(build, bytes) else str(build)}


def path_for(variant) -> str:
    return os.path.join(REF_DIR, f"{variant.name}.npz")


def expected_metadata(variant) -> dict:
    return {"variant": variant.name, "fingerprint": variant.fingerprint(),
            "blender": blender_version(), "resolution": list(variant.resolution),
            "samples_per_seed": variant.cycles_samples, "seeds": list(variant.seeds),
            "max_bounces": variant.max_bounces}


def load(variant):
    """(runs, metadata) from the cache, or (None, reason it cannot be used)."""
    path = path_for(variant)
    if not os.path.isfile(path):
        return None, "no cached reference"
    with np.load(path) as data:
        meta = json.loads(str(data["meta"]))
        runs = data["runs"].astype(np.float32)
    want = expected_metadata(variant)
    for key in ("fingerprint", "blender", "resolution", "samples_per_seed", "seeds",
                "max_bounces"):
        if meta.get(key) != want[key]:
            return None, f"cached {key} {meta.get(key)!r} != {want[key]!r}"
    return runs, meta


def render(variant):
    """Render and store the reference; returns (runs, metadata)."""
    from . import renderers
    runs, settings, seconds = [], None, 0.0
    for seed in variant.seeds:
        t0 = time.perf_counter()
        image, settings = renderers.render_cycles(variant, seed)
        seconds += time.perf_counter() - t0
        runs.append(image)
    runs = np.stack(runs).astype(np.float32)
    meta = expected_metadata(variant)
    meta.update(cycles_settings=settings, seconds=round(seconds, 2),
                rendered=time.strftime("%Y-%m-%d %H:%M:%S"))
    os.makedirs(REF_DIR, exist_ok=True)
    np.savez_compressed(path_for(variant), runs=runs, meta=json.dumps(meta, default=str))
    return runs, meta


def get(variant, allow_render=True):
    """The variant's Cycles runs (K, H, W, 3), cached when valid, else rendered and stored."""
    runs, meta = load(variant)
    if runs is not None:
        LOG.append((variant.name, "cached", f"Blender {meta['blender']['version']}"))
        return runs
    reason = meta
    if not allow_render:
        raise LookupError(f"{variant.name}: {reason}")
    runs, meta = render(variant)
    LOG.append((variant.name, "rendered", f"{reason}; {meta['seconds']} s"))
    return runs


def summary_lines() -> list[str]:
    if not LOG:
        return []
    version = blender_version()
    cached = [n for n, how, _ in LOG if how == "cached"]
    rendered = [(n, why) for n, how, why in LOG if how == "rendered"]
    lines = [f"Cycles references (Blender {version['version']}, build {version['build_hash']}): "
             f"{len(cached)} cached, {len(rendered)} rendered now"]
    lines += [f"  rendered {n}: {why}" for n, why in rendered]
    return lines


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python -m tests.cycles.references",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("--only", nargs="*", help="variant names (default: all)")
    parser.add_argument("--force", action="store_true", help="render even if the cache is valid")
    args = parser.parse_args(argv)
    from . import renderers
    from .variants import VARIANTS
    renderers.ensure_registered()
    names = args.only or list(VARIANTS)
    unknown = [n for n in names if n not in VARIANTS]
    if unknown:
        parser.error(f"unknown variants {unknown}; known: {', '.join(VARIANTS)}")
    total = time.perf_counter()
    for name in names:
        variant = VARIANTS[name]
        runs, why = (None, "--force") if args.force else load(variant)
        if runs is not None:
            print(f"{name}: cached reference is current (Blender {why['blender']['version']})")
            continue
        runs, meta = render(variant)
        size = os.path.getsize(path_for(variant)) // 1024
        print(f"{name}: rendered in {meta['seconds']} s ({size} KiB; {why})", flush=True)
    print(f"done in {time.perf_counter() - total:.0f} s; references in {REF_DIR}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

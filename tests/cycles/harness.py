"""Shared state of one test run: Specula renders and comparisons, computed once per variant.

The agreement test and the power tests compare the same correct Specula render of a
variant; whichever runs first renders it. `RESULTS` feeds the terminal summary.
"""

from __future__ import annotations

import os
import re
import time

import numpy as np

from . import compare, references, renderers
from .variants import VARIANTS

_SPECULA: dict = {}
_AGREEMENT: dict = {}
# (kind, name, Comparison, seconds) per comparison made in this process, in order
RESULTS: list = []


def specula(name):
    """The correct Specula render of a variant (cached for the session)."""
    if name not in _SPECULA:
        _SPECULA[name] = renderers.render_specula(VARIANTS[name])
    return _SPECULA[name]


# Where a disagreeing comparison leaves its images for a look (Specula | Cycles | z map).
DIAGNOSTICS = os.path.join(references.HERE, "..", "..", "out", "cycles")


def compare_render(name, result, kind="agreement", seconds=0.0) -> compare.Comparison:
    """Compare a Specula render with the variant's Cycles runs."""
    runs = references.get(VARIANTS[name])
    c = compare.compare(result.combined[..., :3], result.variance, runs,
                        specula_dof=result.dof)
    RESULTS.append((kind, name, c, seconds))
    if not c.agree and kind == "agreement" or os.environ.get("SPECULA_CYCLES_DIAGNOSTICS"):
        save_diagnostics(f"{re.sub('[^a-z0-9_]+', '_', kind.lower())}_{name}", result, runs, c)
    return c


def save_diagnostics(stem, result, runs, c, directory=DIAGNOSTICS):
    """<directory>/<stem>.png (default out/cycles/): Specula, Cycles (mean of the seeds) and
    the per-pixel z map (red: Specula brighter), 4x enlarged; and the arrays as .npz."""
    from addon import imaging
    os.makedirs(directory, exist_ok=True)
    s = result.combined[..., :3].astype(np.float64)
    cm = runs.mean(axis=0)
    var = result.variance + runs.var(axis=0, ddof=1) / len(runs)
    z = ((s - cm) / np.sqrt(np.maximum(var, 1e-12))).mean(axis=-1)
    zimg = np.zeros(z.shape + (3,))
    zimg[..., 0], zimg[..., 2] = np.clip(z / 4, 0, 1), np.clip(-z / 4, 0, 1)
    k = max(1, 256 // s.shape[1])
    row = [imaging.upscale(imaging.flip(imaging.srgb(s)), k),
           imaging.upscale(imaging.flip(imaging.srgb(cm)), k),
           imaging.upscale(imaging.flip(np.round(zimg * 255).astype(np.uint8)), k)]
    sheet = imaging.contact_sheet([row], [""], ["SPECULA", "CYCLES", "Z (RED: SPECULA HIGHER)"],
                                  title=f"{stem}: max z {c.max_z:.1f} / {c.z_threshold:.1f}")
    imaging.write_png(os.path.join(directory, stem + ".png"), sheet)
    np.savez_compressed(os.path.join(directory, stem + ".npz"), specula=s,
                        variance=result.variance, cycles=runs)


def cycles_runs(scene, samples, seeds, max_bounces=8):
    """Cycles renders (seeds, H, W, 3) of a scene a test built itself (the live tests)."""
    runs = []
    for seed in seeds:
        renderers.configure_cycles(scene, samples, seed, max_bounces)
        runs.append(renderers.render_cycles_image(scene)[0][..., :3])
    return np.stack(runs)


def specula_live(scene, samples, max_bounces=8, replicates=8):
    """Specula's RenderResult of a scene a test built itself, and the exporter's warnings."""
    s = scene.specula
    s.samples, s.max_bounces, s.seed, s.threads = samples, max_bounces, 0, renderers.THREADS
    s.replicates, s.time_limit, s.target_error = replicates, 0.0, 0.0
    core_scene, settings, warnings = renderers.shared.export_specula(scene)
    return renderers.core().render(core_scene, settings), warnings


def compare_live(result, runs) -> compare.Comparison:
    """A live test's Specula render against its Cycles runs."""
    return compare.compare(result.combined[..., :3], result.variance, runs,
                           specula_dof=result.dof)


def agreement(name) -> compare.Comparison:
    """The correct render's comparison (made once per session)."""
    if name not in _AGREEMENT:
        t0 = time.perf_counter()
        result = specula(name)
        _AGREEMENT[name] = compare_render(name, result, "agreement", time.perf_counter() - t0)
    return _AGREEMENT[name]


def summary_lines() -> list[str]:
    lines = []
    for kind, name, c, seconds in RESULTS:
        lines.append(f"{kind:>28} {name:<24} {'agree   ' if c.agree else 'DISAGREE'} "
                     f"max|z| {c.max_z:6.2f} / {c.z_threshold:.2f}  rel.RMSE {c.rel_rmse:.3f}"
                     f"  Specula {seconds:.1f} s")
    return lines

"""`python -m addon compare SCENE.blend`: the scene rendered by Specula and by Cycles and
compared as the agreement tests compare them (tests/cycles).

* Both engines get the same resolution, bounce limit, pixel filter, threads and either the
  same samples per pixel (`--samples`, default the scene's Specula samples) or the same
  seconds (`--time`). Cycles is set up unbiased (renderers.configure_cycles_for_comparison)
  and renders twice, with seeds 1 and 2 above Specula's, because the test needs its
  variance; the test takes Specula's first run with its own per-pixel variance. Film >
  Transparent and the render border are turned off for both.
* The verdict is the block z-test of agreement.py at family level 0.1 %: agree or differ,
  the worst block's normal-equivalent |z| and where it is.
* Error against time, measured the same way for both engines: each renders twice with
  different seeds (Specula's second run serves only this), and per pixel (Y1 - Y2)^2 / 2 is
  an unbiased estimate of one run's variance of luminance, without a reference image. The
  relative RMS error of one run (RMS standard error over mean luminance, the definition of
  Film.relative_error) is plotted against the seconds of its render call (Specula: export
  plus core; Cycles: Blender's whole render call, sync and writing the image included), and
  the ratio of the MSEs at equal time is given, scaling as MSE ~ 1/time when the runs took
  different times. Specula's own per-pass estimate (its per-pixel sample variance) is
  plotted too, dashed: with Owen-scrambled Sobol samples it overestimates the error (about
  2x in RMS on cbspheres), so it is not what the engines are compared by. Neither number
  sees bias; the z-test does.
* A PNG: Specula | Cycles (mean of the two runs) | signed difference | per-pixel z, the
  worst block outlined, and the error-against-time plot below.

Exit codes: 0 agree, 1 differ, 2 bad arguments or scipy missing, 3 no comparison could be
made (missing or unreadable file, a scene one of the engines cannot render).
"""

from __future__ import annotations

import dataclasses
import math
import os
import sys
import time

import numpy as np

from . import console, imaging

EXIT_AGREE, EXIT_DIFFER, EXIT_USAGE, EXIT_FAILED = 0, 1, 2, 3
# Samples per pixel when only a time budget is given: the time limit stops both first.
TIME_MODE_SAMPLES = 1 << 20
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])  # Rec. 709, as the core's film
# Report panels are about this wide (small renders enlarged, large ones averaged down).
PANEL_WIDTH = 320
# The per-pixel z map saturates at this |z|.
Z_FULL = 4.0


class CompareError(RuntimeError):
    """The comparison cannot be made; the message says why (exit 3)."""


def default_output(scene_path):
    stem = os.path.splitext(os.path.basename(scene_path))[0]
    return os.path.join("out", "compare", f"{stem}.png")


def run(args) -> int:
    """The `compare` command; returns the exit code."""
    if not os.path.isfile(args.scene):
        return _fail(f"scene file not found: {args.scene}")
    if not os.access(args.scene, os.R_OK):
        return _fail(f"scene file is not readable: {args.scene}")
    try:
        from . import agreement
    except ImportError as exc:
        if getattr(exc, "name", "") == "scipy" or "scipy" in str(exc):
            return _fail("compare needs scipy for its statistics (Student's t and normal "
                         f"distributions); install it into this Python ({sys.executable} -m "
                         "pip install scipy)", EXIT_USAGE)
        raise
    log = console.Warnings()
    try:
        # Cycles' images pass through temporary files; Blender's "Saved: ..." lines about
        # them say nothing to the user.
        with console.captured_output(log, drop=("specula_cycles_",)):
            report = _compare(args, agreement, log)
    except CompareError as exc:
        log.print()
        return _fail(f"cannot compare {args.scene}: {exc}")
    except Exception as exc:  # noqa: BLE001 - a bug: still one message, not a traceback
        log.print()
        return _fail(f"cannot compare {args.scene}: internal error, please report it: "
                     f"{type(exc).__name__}: {exc}")
    log.print()
    for line in report.text:
        print(line)
    console.emit_json(report.summary, args.json)
    return EXIT_AGREE if report.comparison.agree else EXIT_DIFFER


def _fail(message, code=EXIT_FAILED):
    print(f"error: {message}", file=sys.stderr)
    return code


class _Report:
    def __init__(self, comparison, summary, text):
        self.comparison, self.summary, self.text = comparison, summary, text


def _open(args):
    import bpy

    from . import register
    if not hasattr(bpy.types.Scene, "specula"):
        register()
    try:
        bpy.ops.wm.open_mainfile(filepath=os.path.abspath(args.scene))
    except RuntimeError as exc:
        raise CompareError(f"Blender cannot read it: {str(exc).strip()}") from None
    scene = bpy.context.scene
    r = scene.render
    if args.resolution is not None:
        r.resolution_x, r.resolution_y = args.resolution
        r.resolution_percentage = 100
    # The comparison is of RGB over whole frames: with the film opaque, the world the
    # camera sees is compared too.
    r.film_transparent = False
    r.use_border = False
    s = scene.specula
    s.samples = args.samples or (TIME_MODE_SAMPLES if args.time else s.samples)
    s.time_limit = args.time or 0.0
    s.target_error = 0.0  # Cycles has no such stop; both run the same budget
    if args.max_bounces is not None:
        s.max_bounces = args.max_bounces
    if args.seed is not None:
        s.seed = args.seed
    return scene


def _render_specula(scene, log):
    from . import core, exporter, renderers
    try:
        # Importing the core and loading its compiled functions is paid once per process,
        # not per scene: not part of the timed export.
        core.load().warm_up()
        t0 = time.perf_counter()
        core_scene, settings, warnings = renderers.export_specula(scene)
    except (exporter.ExportError, ValueError, ImportError) as exc:
        raise CompareError(f"Specula cannot render it: {exc}") from None
    export_seconds = time.perf_counter() - t0
    log.extend(warnings)
    curve = []

    def on_pass(p):
        if p.relative_error >= 0 and math.isfinite(p.relative_error):
            curve.append((export_seconds + p.seconds, float(p.relative_error)))

    try:
        # One sample of an 8x8 image first: it loads (or compiles) the kernels this scene's
        # plan needs, which is not what the error against time should measure.
        renderers.render_specula(core_scene, dataclasses.replace(
            settings, width=8, height=8, samples=1, time_limit=0.0))
        result = renderers.render_specula(core_scene, settings, on_pass=on_pass)
        # A second, independent run measures Specula's error as Cycles' is measured.
        second = renderers.render_specula(core_scene, dataclasses.replace(
            settings, seed=settings.seed + 1))
    except Exception as exc:  # noqa: BLE001 - a message, never a traceback
        raise CompareError(f"Specula failed to render it: {type(exc).__name__}: {exc}"
                           ) from None
    log.extend(result.warnings or [])
    runs = np.stack([result.combined[..., :3], second.combined[..., :3]])
    seconds = [export_seconds + result.seconds, export_seconds + second.seconds]
    return result, runs, seconds, curve


def _render_cycles(scene, seeds, samples, time_limit, max_bounces, threads):
    """Cycles once per seed: (runs (K, H, W, 3), seconds per run, samples per run)."""
    import bpy

    from . import renderers
    if not hasattr(scene, "cycles"):
        raise CompareError("Cycles is not available in this Blender")
    done = []

    def on_stats(text):
        # "Sample 225/16777216": what Cycles did when a time limit stopped it.
        for part in str(text).split("|"):
            part = part.strip()
            if part.startswith("Sample ") and "/" in part:
                try:
                    done[-1] = max(done[-1], int(part[7:].split("/")[0]))
                except ValueError:
                    pass

    runs, seconds = [], []
    bpy.app.handlers.render_stats.append(on_stats)
    try:
        for seed in seeds:
            renderers.configure_cycles_for_comparison(scene, samples, seed, max_bounces,
                                                      time_limit=time_limit, threads=threads)
            done.append(0)
            try:
                rgba, sec = renderers.render_cycles_image(scene)
            except RuntimeError as exc:
                raise CompareError(f"Cycles cannot render it: {str(exc).strip()}") from None
            runs.append(rgba[..., :3])
            seconds.append(sec)
    finally:
        bpy.app.handlers.render_stats.remove(on_stats)
    counts = [n if time_limit else samples for n in done]
    return np.stack(runs), seconds, counts


def _compare(args, agreement, log) -> _Report:
    scene = _open(args)
    s = scene.specula
    name = os.path.basename(args.scene)
    result, specula_runs, specula_seconds, curve = _render_specula(scene, log)
    seeds = (s.seed + 1, s.seed + 2)
    runs, cycles_seconds, cycles_samples = _render_cycles(
        scene, seeds, s.samples, s.time_limit, s.max_bounces, s.threads)
    image = result.combined[..., :3].astype(np.float64)
    if runs.shape[1:] != image.shape:
        raise CompareError(f"the engines rendered different sizes: Specula "
                           f"{image.shape[1]}x{image.shape[0]}, Cycles "
                           f"{runs.shape[2]}x{runs.shape[1]}")
    cmp = agreement.compare(image, result.variance, runs, specula_dof=result.dof)
    errors = error_against_time(curve, specula_runs, specula_seconds, runs, cycles_seconds)
    output = os.path.abspath(args.output or default_output(args.scene))
    os.makedirs(os.path.dirname(output), exist_ok=True)
    h, w = image.shape[:2]
    budget = f"{args.time:g} s each" if args.time else f"{s.samples} samples each"
    verdict = "agree" if cmp.agree else "differ"
    x0, y0, x1, y1 = cmp.worst_pixels(h, w)
    (bh, bw), _, _, ch = cmp.worst
    warned = log.lines()
    title = (f"{name}: {verdict.upper()}, max z {cmp.max_z:.1f} (threshold "
             f"{cmp.z_threshold:.1f}), {w}x{h}, {budget}")
    imaging.write_png(output, figure(image, result.variance, runs, cmp, title, errors))

    where = (f"{bh}x{bw} block at x {x0}-{x1 - 1}, y {y0}-{y1 - 1} (pixels from the top left), "
             f"channel {'RGB'[ch]}")
    text = [(f"Specula and Cycles {verdict} on {name} ({w}x{h}, {budget}; Cycles twice, "
             f"seeds {seeds[0]} and {seeds[1]}, for its variance)"),
            (f"  worst block: {where}: |z| {_z(cmp.max_z)} (threshold "
             f"{cmp.z_threshold:.2f} for {cmp.tests} tests at family level "
             f"{agreement.ALPHA:.1%})")]
    text.append("  error against time: " + errors["text"])
    if warned:
        text.append(f"  {len(warned)} warning(s) above: Specula does not render everything in "
                    f"this scene as Cycles does" + ("" if cmp.agree else
                                                     "; the differences may come from them"))
    text.append(f"  image: {output}")
    summary = {
        "command": "compare", "scene": os.path.abspath(args.scene), "verdict": verdict,
        "agree": bool(cmp.agree), "max_z": _json_float(cmp.max_z),
        "z_threshold": cmp.z_threshold, "p_min": cmp.p_min, "p_sidak": cmp.p_sidak,
        "tests": cmp.tests,
        "worst_block": {"x0": x0, "y0": y0, "x1": x1, "y1": y1, "rows": bh, "columns": bw,
                        "channel": "RGB"[ch], "origin": "top left"},
        "per_scale": {k: _json_float(v) for k, v in cmp.per_scale.items()},
        "relative_rmse": _json_float(cmp.rel_rmse),
        "resolution": [w, h], "max_bounces": int(s.max_bounces),
        "budget": {"samples": None if args.time and not args.samples else int(s.samples),
                   "seconds": args.time},
        "specula": {"seeds": [int(s.seed), int(s.seed) + 1], "samples": int(result.samples),
                    "seconds": specula_seconds, "relative_error": errors["specula_error"],
                    "own_estimate": errors["specula_own_estimate"],
                    "stop_reason": result.stop_reason,
                    "triangles": _plan(result).get("triangles")},
        "cycles": {"seeds": list(seeds), "samples": cycles_samples, "seconds": cycles_seconds,
                   "relative_error": errors["cycles_error"]},
        "error_against_time": {k: v for k, v in errors.items() if k != "text"},
        "warnings": warned,
        "differences_may_come_from_warnings": bool(warned) and not cmp.agree,
        "output": output,
    }
    return _Report(cmp, summary, text)


def _plan(result):
    plan = result.plan
    return plan.as_dict() if hasattr(plan, "as_dict") else {}


def _z(z):
    return "inf (p below 1e-300)" if math.isinf(z) else f"{z:.2f}"


def _json_float(x):
    """JSON has no infinity; a p-value below 1e-300 is reported as z = null with a note."""
    return float(x) if math.isfinite(x) else None


# ---------------------------------------------------------------------------------------
# Error against time


def two_run_relative_error(runs):
    """The relative RMS error of ONE run, from two independent ones: per pixel,
    (Y1 - Y2)^2 / 2 estimates a run's variance of luminance without a reference image."""
    y = np.asarray(runs[:2], np.float64) @ LUMINANCE
    mean = float(np.mean(y))
    if mean <= 0:
        return None
    return float(np.sqrt(np.mean((y[0] - y[1]) ** 2 / 2.0)) / mean)


def error_against_time(curve, specula_runs, specula_seconds, cycles_runs, cycles_seconds):
    """Both engines' relative error against seconds (see the module docstring): one point
    each from their two runs, and Specula's own estimate after every pass."""
    t_s, t_c = float(np.mean(specula_seconds)), float(np.mean(cycles_seconds))
    e_s, e_c = two_run_relative_error(specula_runs), two_run_relative_error(cycles_runs)
    out = {"specula_own_estimate_curve": _thin(curve),
           "specula_own_estimate": curve[-1][1] if curve else None,
           "specula_seconds": t_s, "specula_error": e_s,
           "cycles_seconds": t_c, "cycles_error": e_c}
    if not e_s or not e_c:
        out["text"] = "no estimate (an image is black, or equal in both runs)"
        return out
    # Unbiased Monte Carlo: MSE ~ 1 / time, which puts the two points at equal time. (QMC
    # converges a little faster, so this slightly favours the engine that ran shorter.)
    ratio = (e_s / e_c) ** 2 * (t_s / t_c)
    out["mse_ratio_at_equal_time"] = ratio
    scaled = "" if abs(t_s / t_c - 1) < 0.05 else ", scaled as MSE ~ 1/time"
    out["text"] = (f"relative RMS error of one run, from two runs of each engine: Specula "
                   f"{e_s:.4f} after {t_s:.2f} s, Cycles {e_c:.4f} after {t_c:.2f} s; Specula's "
                   f"MSE is {ratio:.2f}x Cycles' at equal time{scaled}")
    return out


def _thin(curve, points=40):
    """At most about `points` of the curve, spaced evenly in log time (the last kept)."""
    if len(curve) <= points:
        return [list(c) for c in curve]
    logt = np.log([c[0] for c in curve])
    marks = np.linspace(logt[0], logt[-1], points)
    keep = sorted(set(np.searchsorted(logt, marks).clip(0, len(curve) - 1)) | {len(curve) - 1})
    return [list(curve[i]) for i in keep]


# ---------------------------------------------------------------------------------------
# The report image


def _fit(img, factor):
    """Enlarge by an integer factor (> 0) or average down by one (< 0), for display."""
    if factor > 0:
        return imaging.upscale(img, factor)
    d = -factor
    h, w = (img.shape[0] // d) * d, (img.shape[1] // d) * d
    return img[:h, :w].reshape(h // d, d, w // d, d, -1).mean(axis=(1, 3))


def _outline(panel, box, colour=(255, 220, 0)):
    x0, y0, x1, y1 = box
    h, w = panel.shape[:2]
    x1, y1 = min(max(x1, x0 + 1), w), min(max(y1, y0 + 1), h)
    for t in (0, 1):  # two pixels wide, just outside the block where there is room
        xa, ya, xb, yb = max(x0 - 1 - t, 0), max(y0 - 1 - t, 0), min(x1 + t, w - 1), \
            min(y1 + t, h - 1)
        panel[ya, xa:xb + 1] = colour
        panel[yb, xa:xb + 1] = colour
        panel[ya:yb + 1, xa] = colour
        panel[ya:yb + 1, xb] = colour


def figure(image, variance, runs, cmp, title, errors):
    """Specula | Cycles | Specula - Cycles | per-pixel z (rows top first), the worst block
    outlined in each; below, the error-against-time plot. 8-bit (H, W, 3)."""
    h, w = image.shape[:2]
    factor = max(1, PANEL_WIDTH // w) if w <= PANEL_WIDTH else -math.ceil(w / PANEL_WIDTH)
    cyc = runs.mean(axis=0)
    var = variance + runs.var(axis=0, ddof=1) / len(runs)
    z = ((image - cyc) / np.sqrt(np.maximum(var, 1e-12))).mean(axis=-1)
    zimg = np.zeros(z.shape + (3,))
    zimg[..., 0], zimg[..., 2] = np.clip(z / Z_FULL, 0, 1), np.clip(-z / Z_FULL, 0, 1)
    diff = (image - cyc) @ LUMINANCE
    scale = float(np.percentile(np.abs(diff), 99)) or 1e-6
    dimg = np.zeros(diff.shape + (3,))
    dimg[..., 0], dimg[..., 2] = np.clip(diff / scale, 0, 1), np.clip(-diff / scale, 0, 1)
    panels = [imaging.srgb(_fit(imaging.flip(image), factor)),
              imaging.srgb(_fit(imaging.flip(cyc), factor)),
              np.round(_fit(imaging.flip(dimg), factor) * 255).astype(np.uint8),
              np.round(_fit(imaging.flip(zimg), factor) * 255).astype(np.uint8)]
    x0, y0, x1, y1 = cmp.worst_pixels(h, w)
    f = float(factor) if factor > 0 else 1.0 / -factor
    box = (int(x0 * f), int(y0 * f), math.ceil(x1 * f), math.ceil(y1 * f))
    for p in panels:
        _outline(p, box)
    sheet = imaging.contact_sheet(
        [panels], [""], ["SPECULA", "CYCLES (2 SEEDS)", "SPECULA - CYCLES", "Z PER PIXEL"],
        captions=[["SRGB, STANDARD VIEW", "SRGB, STANDARD VIEW",
                   f"RED: SPECULA BRIGHTER, FULL AT {scale:.3g}",
                   f"RED: SPECULA HIGHER, FULL AT {Z_FULL:g}"]],
        title=title)
    series = {}
    for name, key in (("SPECULA, 2 RUNS", "specula"), ("CYCLES, 2 RUNS", "cycles")):
        if errors[f"{key}_error"]:
            series[name] = ((errors[f"{key}_seconds"],), (errors[f"{key}_error"],))
    if errors["specula_own_estimate_curve"]:
        series["SPECULA, OWN ESTIMATE"] = tuple(zip(*errors["specula_own_estimate_curve"]))
    plot = imaging.loglog_plot(series, "RELATIVE RMS ERROR OF ONE RUN AGAINST SECONDS",
                               "SECONDS", "", size=(min(sheet.shape[1], 640), 300),
                               dashed={"SPECULA, OWN ESTIMATE"})
    out = np.full((sheet.shape[0] + plot.shape[0] + 6, sheet.shape[1], 3), 32, np.uint8)
    out[:sheet.shape[0]] = sheet
    out[sheet.shape[0] + 6:, :plot.shape[1]] = plot
    return out

"""One render in Blender: export, run the core progressively, write passes back.

`RenderSession` does the work behind `SpeculaRenderEngine`'s callbacks. Errors never
escape into Blender's UI as a traceback: they end the render with `report({'ERROR'})` and
`error_set`, keeping whatever passes were already written.
"""

from __future__ import annotations

import json
import time
import traceback

import numpy as np

from . import core, exporter

ERROR_PASS = "Specula Error"
REPLICATE_PASS = "Specula Replicate {}"
SPREAD_PASS = "Specula Replicate {} Spread"
# The replicate's mean transparency (film.alpha; a transparent film or a holdout).
TRANSPARENCY_PASS = "Specula Replicate {} Transparency"
# The summary of the most recent render, for the command line's JSON line.
last_summary: dict = {}


def _unknown(rel):
    # The core reports a negative error before it has two samples to estimate it from.
    return rel is None or not np.isfinite(rel) or rel < 0


def _stats(samples, total, seconds, rel, interval=None):
    err = "-" if _unknown(rel) else f"{100.0 * rel:.2f}%"
    if not _unknown(rel) and interval is not None and interval[0] >= 0:
        err += f" (95%: {100.0 * interval[0]:.2f}-{100.0 * interval[1]:.2f}%)"
    return f"Sample {samples}/{total} | Time {seconds:.1f} s | Est. error {err}"


def replicate_ids(scene):
    """The replicates a render of `scene` traces (its Specula settings), read the way the
    exporter hands them to the core."""
    first, stop = exporter.replicate_range(scene.specula) or (0, scene.specula.replicates)
    return tuple(range(first, max(first + 1, stop)))


def error_metadata(out, settings) -> dict:
    """What a render says about its error, as text fields (EXR header, JSON): the
    estimate and its interval, the replicates and the error-against-time series."""
    ids = out.replicate_ids
    return {"Specula Relative Error": f"{out.relative_error:.6g}",
            "Specula Error Interval": f"{out.error_interval[0]:.6g} {out.error_interval[1]:.6g}",
            "Specula Replicates": f"{ids[0]}-{ids[-1]}/{settings.replicates}",
            "Specula Seed": str(settings.seed), "Specula Samples": str(out.samples),
            "Specula t95": f"{out.t95:.6g}",
            "Specula Error Series": json.dumps(out.series, separators=(",", ":"))}


# At most this share of a render's wall time goes to showing intermediate images.
DISPLAY_SHARE = 0.1


def _set_rect(render_pass, image):
    """Write an (H, W[, C]) image into a RenderPass with one foreach_set.

    Blender 4.x+ takes the flat float array; 3.x wants one row per pixel, (H * W, C).
    """
    flat = np.ascontiguousarray(image, np.float32).reshape(-1)
    try:
        render_pass.rect.foreach_set(flat)
    except TypeError:  # "expected sequence size H*W, got H*W*C" (before 4.x)
        render_pass.rect.foreach_set(flat.reshape(image.shape[0] * image.shape[1], -1))


class RenderSession:
    def __init__(self, engine):
        self.engine = engine

    # -- Passes --------------------------------------------------------------------------

    def update_render_passes(self, scene, view_layer):
        """Tell Blender (and the compositor) which passes a render will produce."""
        if scene is None or view_layer is None:
            return
        engine = self.engine
        engine.register_pass(scene, view_layer, "Combined", 4, "RGBA", 'COLOR')
        if view_layer.use_pass_z:
            engine.register_pass(scene, view_layer, "Depth", 1, "Z", 'VALUE')
        if view_layer.use_pass_normal:
            engine.register_pass(scene, view_layer, "Normal", 3, "XYZ", 'VECTOR')
        settings = getattr(view_layer, "specula", None)
        if settings is None or settings.use_pass_error:
            engine.register_pass(scene, view_layer, ERROR_PASS, 1, "X", 'VALUE')
        if settings is not None and settings.use_pass_replicates:
            for r in replicate_ids(scene):
                engine.register_pass(scene, view_layer, REPLICATE_PASS.format(r), 4, "RGBA",
                                     'COLOR')
                engine.register_pass(scene, view_layer, SPREAD_PASS.format(r), 4, "RGBA",
                                     'COLOR')
                # (Zero where the render keeps no transparency: alpha 1, so merges of any
                # renders read it alike.)
                engine.register_pass(scene, view_layer, TRANSPARENCY_PASS.format(r), 1, "X",
                                     'VALUE')

    def _write(self, layer, p):
        """Copy one core Pass into the result layer's passes (foreach_set, no lists)."""
        passes = layer.passes
        _set_rect(passes["Combined"], p.combined)
        depth = passes.get("Depth")
        if depth is not None:
            _set_rect(depth, np.where(np.isfinite(p.depth), p.depth, exporter.BACKGROUND_DEPTH))
        normal = passes.get("Normal")
        if normal is not None:
            _set_rect(normal, np.nan_to_num(p.normal))
        err = passes.get(ERROR_PASS)
        if err is not None:
            _set_rect(err, np.nan_to_num(p.error))
        # The final result only: each replicate's mean and, in A, its sample counts; its
        # samples' sums of squared deviations (R, G, B, luminance).
        for j, r in enumerate(getattr(p, "replicate_ids", ())):
            rep = passes.get(REPLICATE_PASS.format(r))
            if rep is not None:
                rgba = np.empty(p.replicate_mean.shape[:2] + (4,), np.float32)
                rgba[..., :3] = p.replicate_mean[:, :, j]
                rgba[..., 3] = p.replicate_count[:, :, j]
                _set_rect(rep, rgba)
            spread = passes.get(SPREAD_PASS.format(r))
            if spread is not None:
                _set_rect(spread, p.replicate_m2[:, :, j])
            transparency = passes.get(TRANSPARENCY_PASS.format(r))
            if transparency is not None and p.replicate_transparency is not None:
                _set_rect(transparency, p.replicate_transparency[:, :, j])

    def should_stop(self):
        """Esc in Blender (checked by the core between passes)."""
        return self.engine.test_break()

    # -- Render --------------------------------------------------------------------------

    def fail(self, message):
        global last_summary
        last_summary = {"engine": "SPECULA", "error": message}
        self.engine.report({'ERROR'}, message)
        self.engine.error_set(message)

    def render(self, depsgraph):
        global last_summary
        engine = self.engine
        scene = depsgraph.scene
        width, height = engine.resolution_x, engine.resolution_y
        engine.update_stats("", "Specula | Exporting scene")
        try:
            specula = core.load()
            exported = exporter.export(depsgraph)
            core_scene, builder_warnings = exporter.to_core(exported, specula)
            settings_kwargs = exporter.render_settings_kwargs(scene, width, height)
            # Render border: Blender gives the full frame's size; the core traces only the
            # border's pixels, sampled as in a whole-frame render, so regions stitch.
            region = exporter.border_region(scene, width, height)
            if region is not None:
                settings_kwargs["region"] = region
            settings = specula.RenderSettings(**settings_kwargs)
            settings.validate()
        except (ImportError, exporter.ExportError, ValueError) as exc:
            self.fail(f"Specula: {exc}")
            return
        except Exception as exc:  # noqa: BLE001 - never a traceback dialog
            traceback.print_exc()
            self.fail(f"Specula: export failed: {type(exc).__name__}: {exc}")
            return
        for warning in exported.warnings + builder_warnings:
            engine.report({'WARNING'}, f"Specula: {warning}")

        # Blender calls render() once per view layer; write into that layer's result. With a
        # border, the result is the border's rectangle and (0, 0) is its bottom-left pixel;
        # Blender places it in the frame, or crops the image to it (use_crop_to_border).
        x0, y0, x1, y1 = region if region is not None else (0, 0, width, height)
        result = engine.begin_result(0, 0, x1 - x0, y1 - y0, layer=depsgraph.view_layer.name)
        layer = result.layers[0]
        total = settings.samples

        display = {"seconds": 0.0}

        def on_pass(p):
            # Show the image after the first pass and then whenever showing it has cost at
            # most a tenth of the render so far: copying a 1920x1080 result into Blender
            # takes ~60 ms, as long as a whole pass of a simple scene. Progress and stats
            # update every pass; the final image is written below in any case.
            if p.samples == 1 or display["seconds"] <= DISPLAY_SHARE * p.seconds:
                t = time.perf_counter()
                self._write(layer, p)
                engine.update_result(result)
                display["seconds"] += time.perf_counter() - t
            engine.update_progress(float(min(p.progress, 1.0)))
            stats = _stats(p.samples, total, p.seconds, p.relative_error, p.error_interval)
            engine.update_stats("", f"Specula | {stats}")

        t0 = time.perf_counter()
        try:
            # Before the first pass: what it waits for (a first render of a kind of scene
            # compiles its kernel for a minute or more), not a frozen "Exporting scene".
            out = specula.render(core_scene, settings, on_pass=on_pass,
                                 should_stop=self.should_stop,
                                 on_status=lambda text: engine.update_stats(
                                     "", f"Specula | {text}"))
        except Exception as exc:  # noqa: BLE001 - keep the partial image, report, no dialog
            traceback.print_exc()
            engine.end_result(result)
            self.fail(f"Specula: render failed: {type(exc).__name__}: {exc}")
            return
        self._write(layer, out)
        engine.end_result(result)
        # Into the render's own result (what is saved), as Cycles stamps its metadata.
        metadata = error_metadata(out, settings)
        final = engine.get_result()
        for key, value in metadata.items():
            final.stamp_data_add_field(key, value)
        for warning in out.warnings or []:
            if warning not in builder_warnings:
                engine.report({'WARNING'}, f"Specula: {warning}")
        plan = out.plan
        last_summary = {
            "engine": "SPECULA", "samples": int(out.samples), "seconds": float(out.seconds),
            "relative_error": None if _unknown(out.relative_error) else float(out.relative_error),
            "error_interval": None if _unknown(out.relative_error)
            else [float(v) for v in out.error_interval],
            "replicates": metadata["Specula Replicates"],
            "t95": float(out.t95) if np.isfinite(out.t95) else None,
            "series": out.series,
            "stop_reason": out.stop_reason, "cancelled": bool(out.cancelled),
            "plan": plan.as_dict() if hasattr(plan, "as_dict") else str(plan),
            "triangles": int(core_scene.num_triangles),
            "wall_seconds": time.perf_counter() - t0,
        }
        stats = _stats(out.samples, total, out.seconds, out.relative_error, out.error_interval)
        engine.update_stats("", f"Specula | {stats} | {out.stop_reason}")


classes = ()


def register():
    pass


def unregister():
    pass

"""Progressive rendering: passes over the whole image, callbacks, stopping rules.

`render(scene, settings)` runs passes of one sample per pixel until the sample count,
the time limit or the target estimated error is reached, or `should_stop()` says so
(checked between passes, so a cancelled render keeps every finished pass). Each pass
is split into chunks of `settings.chunk_pixels` pixels, spread over a thread pool
(embreex and large numpy operations release the GIL), which bounds memory whatever
the resolution. Sample values depend only on (seed, pixel, sample index), never on
thread timing, so a render is deterministic for a given seed.
"""

from __future__ import annotations

import logging
import os
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from .accel import Accel
from .camera import CameraModel
from .film import Film, PixelFilter
from .integrator import Integrator
from .lights import LightSampler
from .plan import Plan, make_plan
from .scene import RenderSettings, Scene

log = logging.getLogger("specula")


@dataclass
class Pass:
    """What a caller sees after each pass (and what `render` returns).

    combined : (H, W, 4) float32 linear RGBA, row 0 at the bottom (Blender's order)
    depth : (H, W) float32 mean camera z-depth of the first hit (inf where nothing is hit)
    normal : (H, W, 3) float32 mean world-space shading normal of the first hit
    error : (H, W) float32 estimated standard error of each pixel's luminance
    variance : (H, W, 3) float32 estimated variance of each pixel's mean, per channel
    samples : samples per pixel so far; seconds : wall time since the render began
    relative_error : estimated relative RMS error of the image (see Film)
    progress : fraction of the sample budget done
    """

    combined: np.ndarray
    depth: np.ndarray
    normal: np.ndarray
    error: np.ndarray
    variance: np.ndarray
    samples: int
    seconds: float
    relative_error: float
    progress: float


@dataclass
class RenderResult(Pass):
    """The final image plus how the render went."""

    plan: Plan | None = None
    stop_reason: str = ""
    cancelled: bool = False
    warnings: list | None = None
    time_to_first_pass: float = 0.0


class NonFiniteError(RuntimeError):
    """A pass produced NaN or inf; the message names the pixel and stage."""


def _thread_count(settings: RenderSettings) -> int:
    return settings.threads or os.cpu_count() or 1


def render(scene: Scene, settings: RenderSettings, on_pass=None, should_stop=None,
           debug: bool = False) -> RenderResult:
    """Render `scene` progressively.

    on_pass : optional callable(Pass) run after every pass (for display and progress).
    should_stop : optional callable() -> bool checked between passes; True cancels,
        keeping the passes done.
    debug : trace NaN/inf to the stage that produced it (slower).
    """
    settings.validate()
    t0 = time.perf_counter()
    plan = make_plan(scene, settings)
    log.info("specula plan: %s", plan.describe())
    accel = Accel(scene)
    emitters = LightSampler(scene) if plan.emitters else None
    camera = CameraModel(scene.camera, settings.width, settings.height, scene.origin)
    pixel_filter = PixelFilter(settings.filter_type, settings.filter_width)
    x0, y0, x1, y1 = settings.window
    film = Film(x1 - x0, y1 - y0)
    integrator = Integrator(scene, settings, plan, accel, emitters, camera, pixel_filter,
                            debug=debug)
    n_pixels = (x1 - x0) * (y1 - y0)

    def frame_ids(local: np.ndarray) -> np.ndarray:
        """Full-frame ids of window pixels: sampling and camera rays use the full frame's
        numbering, so a region renders exactly the pixels a whole-frame render would."""
        ly, lx = np.divmod(local, x1 - x0)
        return (ly + y0) * settings.width + lx + x0

    def trace_and_fold(local: np.ndarray, sample: int) -> None:
        """One chunk's sample, folded into the film by the worker itself: chunks of a pass
        hold distinct pixels and passes run one after another, so each pixel still gets
        its samples in order (the film does not depend on thread timing)."""
        _, radiance, depth, normal, rejected = integrator.trace_pixels(frame_ids(local), sample)
        film.add(local, radiance, depth, normal, rejected)

    threads = _thread_count(settings)
    # Equal chunks, a multiple of the thread count, none above chunk_pixels (memory bound).
    n_chunks = threads * max(1, -(-n_pixels // (threads * int(settings.chunk_pixels))))
    chunk = -(-n_pixels // n_chunks)
    starts = list(range(0, n_pixels, chunk))
    stop_reason, cancelled, first = "samples", False, 0.0
    sample = 0
    with ThreadPoolExecutor(max_workers=threads) as pool:
        while sample < settings.samples:
            # Trace one sample per pixel, chunk by chunk, chunks spread over the pool.
            chunks = [np.arange(s, min(s + chunk, n_pixels)) for s in starts]
            jobs = [pool.submit(trace_and_fold, c, sample) for c in chunks]
            for job in jobs:
                job.result()
            sample += 1
            film.check_finite(sample)
            elapsed = time.perf_counter() - t0
            if sample == 1:
                first = elapsed
            # The image-wide error costs a pass over the film: only when someone reads it.
            needed = on_pass is not None or settings.target_error
            rel = film.relative_error() if needed else float("nan")
            if on_pass is not None:
                on_pass(film.snapshot(sample, elapsed, rel, sample / settings.samples))
            if sample >= settings.samples:
                break
            if settings.time_limit and elapsed >= settings.time_limit:
                stop_reason = "time limit"
                break
            if settings.target_error and sample >= 2 and rel <= settings.target_error:
                stop_reason = "target error"
                break
            if should_stop is not None and should_stop():
                stop_reason, cancelled = "cancelled", True
                break
    elapsed = time.perf_counter() - t0
    snap = film.snapshot(sample, elapsed, film.relative_error(), sample / settings.samples)
    return RenderResult(**snap.__dict__, plan=plan, stop_reason=stop_reason, cancelled=cancelled,
                        warnings=list(scene.warnings) + film.rejected,
                        time_to_first_pass=first)

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
import threading
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


class _Gate:
    """Opens when a pass may be folded into the film; `discard` drops it instead."""

    def __init__(self):
        self.opened = threading.Event()
        self.discard = False


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

    def trace_and_fold(local: np.ndarray, sample: int, gate: _Gate) -> None:
        """One chunk's sample, folded into the film by the worker itself once the gate of
        its pass opens: the main thread opens it after it has finished with the previous
        pass, so each pixel gets its samples in order (the film does not depend on thread
        timing) and a pass is folded whole or, if the render stopped, not at all."""
        if gate.discard:
            return
        _, radiance, depth, normal, rejected = integrator.trace_pixels(frame_ids(local), sample)
        gate.opened.wait()
        if gate.discard:
            return
        t1 = time.perf_counter()
        film.add(local, radiance, depth, normal, rejected)
        integrator._count("film", time.perf_counter() - t1)

    threads = _thread_count(settings)
    # Equal chunks, a multiple of the thread count, none above chunk_pixels (memory bound).
    n_chunks = threads * max(1, -(-n_pixels // (threads * int(settings.chunk_pixels))))
    chunk = -(-n_pixels // n_chunks)
    starts = list(range(0, n_pixels, chunk))
    stop_reason, cancelled, first = "samples", False, 0.0
    sample = 0
    snap = None  # the last pass handed to on_pass
    chunks = [np.arange(s, min(s + chunk, n_pixels)) for s in starts]
    with ThreadPoolExecutor(max_workers=threads) as pool:

        def launch(index):
            """Queue pass `index`: one sample per pixel, chunk by chunk over the pool."""
            gate = _Gate()
            return gate, [pool.submit(trace_and_fold, c, index, gate) for c in chunks]

        gate, jobs = launch(0)
        gate.opened.set()
        ahead = None
        try:
            while sample < settings.samples:
                # Queue the next pass before waiting for this one, so the workers go on
                # tracing while this thread folds statistics and calls back.
                ahead = launch(sample + 1) if sample + 1 < settings.samples else None
                for job in jobs:
                    job.result()
                sample += 1
                film.check_finite(sample)
                elapsed = time.perf_counter() - t0
                if sample == 1:
                    first = elapsed
                # The image-wide error costs a pass over the film: only when someone reads it.
                needed = on_pass is not None or settings.target_error
                stats = film.statistics() if needed else None
                rel = stats[2] if needed else float("nan")
                if on_pass is not None:
                    snap = film.snapshot(sample, elapsed, sample / settings.samples, stats)
                    on_pass(snap)
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
                if ahead is not None:
                    gate, jobs = ahead
                    ahead = None
                    gate.opened.set()
        finally:
            # Stopped (or failed): the pass queued ahead is traced but never folded.
            if ahead is not None:
                ahead[0].discard = True
                ahead[0].opened.set()
                for job in ahead[1]:
                    job.cancel()
    elapsed = time.perf_counter() - t0
    # The film is final now; the last pass's snapshot already shows it, if there was one.
    if snap is None or snap.samples != sample:
        snap = film.snapshot(sample, elapsed, sample / settings.samples)
    return RenderResult(**{**snap.__dict__, "seconds": elapsed}, plan=plan,
                        stop_reason=stop_reason, cancelled=cancelled,
                        warnings=list(scene.warnings) + film.rejected, time_to_first_pass=first)

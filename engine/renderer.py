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
import math
import os
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, replace

import numpy as np

from . import kernels
from .accel import Accel
from .camera import CameraModel
from .film import Film, Pass
from .jit import NUMBA, prune_caches
from .lights import LightSampler
from .plan import Plan, make_plan
from .scene import Camera, Material, RenderSettings, Scene, SceneBuilder, World

log = logging.getLogger("specula")


@dataclass
class RenderResult(Pass):
    """The final image plus how the render went."""

    plan: Plan | None = None
    stop_reason: str = ""
    cancelled: bool = False
    warnings: list | None = None
    time_to_first_pass: float = 0.0
    # Seconds the render's threads spent per stage (intersect, shade, ...), summed.
    stage_seconds: dict | None = None
    # Error against time: one record per series point (SeriesPoints), each
    # {"seconds", "samples", "relative_error", "interval": [low, high]}.
    series: list | None = None
    # The film itself, for merging renders of disjoint replicates (film.estimate): the
    # replicate ids, their sample counts (H, W, m), means (H, W, m, 3) and sums of squared
    # deviations (H, W, m, 4: R, G, B, luminance), float32.
    replicate_ids: tuple = ()
    replicate_count: np.ndarray | None = None
    replicate_mean: np.ndarray | None = None
    replicate_m2: np.ndarray | None = None
    # With a transparent film, each replicate's mean transparency (H, W, m) float32
    # (film.alpha); None otherwise.
    replicate_transparency: np.ndarray | None = None


class _Gate:
    """Opens when a pass may be folded into the film; `discard` drops it instead. `light`:
    the pass's light paths (_LightPass), if the plan traces them."""

    def __init__(self):
        self.opened = threading.Event()
        self.discard = False
        self.light = None


class _LightPass:
    """One pass's light paths (caustics.py): jobs that each trace a share of them and add
    their splats, in job order (so the sums do not depend on thread timing), into per-pixel
    sums the chunks of the pass add to their own samples. Each job's splats are folded as
    it ends, so memory holds one (pixels, 3) array per pass in flight, not every splat."""

    def __init__(self, n_pixels: int):
        self.n_pixels = n_pixels
        self.jobs = []
        self.rejected: list[str] = []
        self._sums = None
        self._turn = 0
        self._discarded = False
        self._cond = threading.Condition()

    def _wait_turn(self, k: int) -> bool:
        self._cond.wait_for(lambda: self._turn == k or self._discarded)
        return not self._discarded

    def add(self, k: int, pixels: np.ndarray, values: np.ndarray) -> None:
        """Job k's splats (window pixel ids, values), after those of jobs 0..k-1."""
        finite = np.all(np.isfinite(values), axis=1)
        pixels, values = pixels[finite], values[finite]
        ids, inverse = np.unique(pixels, return_inverse=True)
        sums = np.stack([np.bincount(inverse, weights=values[:, c], minlength=len(ids))
                         for c in range(3)], axis=1)
        with self._cond:
            if not self._wait_turn(k):
                return
            if not finite.all():
                self.rejected.append(f"{int((~finite).sum())} light-path splats were not "
                                     "finite and were left out")
            if self._sums is None:  # float32: a 4K frame's sums are 100 MB
                self._sums = np.zeros((self.n_pixels, 3), np.float32)
            self._sums[ids] += sums
            self._turn += 1
            self._cond.notify_all()

    def skip(self, k: int) -> None:
        """Job k failed: let the jobs after it go on (the failure is raised by its future)."""
        with self._cond:
            if self._wait_turn(k):
                self._turn += 1
                self._cond.notify_all()

    def for_chunk(self, start: int, stop: int) -> np.ndarray:
        """(stop - start, 3) sums of the splats on window pixels start..stop-1."""
        for job in self.jobs:
            job.result()
        if self._sums is None:
            return np.zeros((stop - start, 3))
        return self._sums[start:stop]

    def cancel(self):
        with self._cond:
            self._discarded = True
            self._cond.notify_all()
        for job in self.jobs:
            job.cancel()


class StageTimers:
    """Seconds and calls per stage, summed over the render's threads."""

    def __init__(self):
        self.seconds: dict[str, float] = {}
        self.calls: dict[str, int] = {}
        self._lock = threading.Lock()

    def __call__(self, stage: str, seconds: float) -> None:
        with self._lock:
            self.calls[stage] = self.calls.get(stage, 0) + 1
            self.seconds[stage] = self.seconds.get(stage, 0.0) + seconds


class Kernels:
    """The kernels of one render: the one in use, the plan's own compiling in the
    background if the render started with the generic one, and a DEBUG kernel made on
    demand to name the stage of a non-finite sample."""

    profile = False  # the benchmark's per-stage profile (PROFILE kernels)

    def __init__(self, scene, settings, plan, accel, emitters, camera, timers, on_status=None):
        self.on_status = on_status
        self.scene, self.settings, self.plan = scene, settings, plan
        self.accel, self.emitters, self.camera, self.timers = accel, emitters, camera, timers
        grid = emitters is not None and hasattr(emitters, "local_pmf")
        self.constants = plan.kernel_constants(grid, emitters is not None
                                               and hasattr(emitters, "bounds"))
        self.constants["PROFILE"] = self.profile
        generic = kernels.generic_constants()
        generic["PROFILE"] = self.profile
        self.pending = None
        self.switched_at = 0
        # SPECULA_KERNEL=generic makes "auto" mean "generic" (the test suite: one compile
        # instead of one per plan; tests/engine/test_kernel.py checks the plans' kernels).
        mode = settings.kernel if settings.kernel != "auto" else \
            os.environ.get("SPECULA_KERNEL", "auto")
        own = kernels.ready_kernel(self.constants)
        if own is None and mode != "generic":
            # The plan's kernel now if it only needs loading (or is asked for); else the
            # generic one, loaded, while the plan's compiles, unless neither was ever
            # compiled (then the plan's, which compiles in a third of the time).
            if kernels.Kernel(self.constants).on_disk() or mode == "specialised" or \
                    not kernels.compiled_before(generic):
                own = self._build(self.constants)
        if own is not None and mode != "generic":
            self.tracer = self.tracer_for(own)
            return
        self.tracer = self.tracer_for(self._build(generic))
        if mode == "auto":
            self.pending = kernels.build_in_background(self.constants, self._compile)

    def _build(self, constants) -> kernels.Kernel:
        """kernels.build_now, saying first what the render waits for (on_status)."""
        status = kernels.build_status(constants)
        if status and self.on_status is not None:
            self.on_status(status)
        return kernels.build_now(constants, self._compile)

    def tracer_for(self, kernel) -> kernels.Tracer:
        data = kernels.scene_data(self.scene, self.settings, self.plan, self.emitters,
                                  self.camera, kernel.generic)
        return kernels.Tracer(kernel, data, self.accel, self.settings, self.timers,
                              transparency=self.plan.transparency,
                              volumes=self.plan.volumes)

    def _compile(self, kernel) -> None:
        kernels.compile_on(kernel, self.scene, self.settings, self.plan, self.emitters,
                           self.camera, self.accel)

    def switch_if_ready(self, sample: int) -> None:
        """At a pass boundary: take the plan's own kernel once it has compiled."""
        if self.pending is None or self.pending.is_alive():
            return
        self.pending = None
        own = kernels.ready_kernel(self.constants)
        if own is not None:
            self.tracer = self.tracer_for(own)
            self.switched_at = sample

    def describe(self) -> tuple[str, str]:
        """(kernel, note) for the plan."""
        if not NUMBA:
            return "generic" if self.tracer.kernel.generic else "specialised", \
                "run as Python: numba is not installed"
        k = self.tracer.kernel
        if self.switched_at:
            return "generic, then specialised", f"switched at pass {self.switched_at + 1}"
        return ("generic" if k.generic else "specialised"), \
            (f"compiled in {k.compile_seconds:.1f} s" if k.compile_seconds > 1.0 else "")

    def use_debug_kernel(self) -> None:
        self.pending = None
        self.tracer = self.tracer_for(kernels.build_now(
            dict(self.tracer.kernel.constants, DEBUG=True, PROFILE=False), self._compile))

    def explain_nonfinite(self, pixels, sample, replicate) -> list[str]:
        debug = kernels.build_now(dict(self.tracer.kernel.constants, DEBUG=True, PROFILE=False),
                                  self._compile)
        return self.tracer.explain_nonfinite(pixels, sample, replicate, self.settings.width,
                                             self.tracer_for(debug))


class NonFiniteError(FloatingPointError):
    """A pass produced NaN or inf; the message names the pixel and stage."""


def _thread_count(settings: RenderSettings) -> int:
    return settings.threads or os.cpu_count() or 1


class _Worker:
    """What a worker thread does with one chunk of a pass."""

    def __init__(self, settings, kernel, film, timers, debug):
        self.settings, self.kernel, self.film, self.timers = settings, kernel, film, timers
        self.debug = debug
        self.replicates = settings.replicate_ids

    def frame_ids(self, local: np.ndarray) -> np.ndarray:
        """Full-frame ids of window pixels: sampling and camera rays use the full frame's
        numbering, so a region renders exactly the pixels a whole-frame render would."""
        x0, y0, x1, _ = self.settings.window
        ly, lx = np.divmod(local, x1 - x0)
        return (ly + y0) * self.settings.width + lx + x0

    def slot(self, index: int) -> tuple[int, int, int]:
        """(film slot, replicate, sample index within it) of pass `index`: passes cycle
        through the render's replicates, so every pass boundary leaves them within one
        sample of each other."""
        slot, sample = index % len(self.replicates), index // len(self.replicates)
        return slot, self.replicates[slot], sample

    def trace(self, pixels: np.ndarray, index: int, tracer):
        """Pass `index` for each pixel, with messages for samples that came out non-finite
        in any pass they feed (traced again by the DEBUG kernel to name the stage)."""
        _, replicate, sample = self.slot(index)
        radiance, depth, normal, stage, transparency = tracer.trace_pixels(pixels, sample,
                                                                           replicate)
        if tracer.kernel.all_finite(radiance, depth, normal):
            return radiance, depth, normal, transparency, []
        if self.debug:
            raise NonFiniteError(tracer.explain_nonfinite(pixels[stage > 0][:1], sample,
                                                          replicate, self.settings.width,
                                                          tracer)[0])
        bad = ~(np.all(np.isfinite(radiance), axis=1) & np.isfinite(depth)
                & np.all(np.isfinite(normal), axis=1))
        return radiance, depth, normal, transparency, self.kernel.explain_nonfinite(
            pixels[bad], sample, replicate)

    def trace_light(self, light: _LightPass, k: int, first: int, count: int, index: int,
                    tracer) -> None:
        """Light paths first..first+count-1 of pass `index`, job k of `light`."""
        _, replicate, sample = self.slot(index)
        try:
            pixels, values = tracer.trace_light(first, count, sample, replicate)
        except BaseException:
            light.skip(k)
            raise
        light.add(k, pixels, values)

    def trace_and_fold(self, local: np.ndarray, index: int, gate: _Gate, tracer) -> None:
        """One chunk's sample, folded into the film by the worker itself once the gate of
        its pass opens: the main thread opens it after it has finished with the previous
        pass, so each pixel gets its samples in order (the film does not depend on thread
        timing) and a pass is folded whole or, if the render stopped, not at all."""
        if gate.discard:
            return
        radiance, depth, normal, transparency, rejected = self.trace(self.frame_ids(local),
                                                                     index, tracer)
        gate.opened.wait()
        if gate.discard:
            return
        t1 = time.perf_counter()
        if gate.light is not None:
            radiance = radiance + gate.light.for_chunk(int(local[0]), int(local[-1]) + 1)
            if local[0] == 0:  # said once per pass
                rejected = rejected + gate.light.rejected
        self.film.add(local, self.slot(index)[0], radiance, depth, normal, rejected,
                      transparency)
        self.timers("film", time.perf_counter() - t1)


class SeriesPoints:
    """The passes whose error is recorded: about 10 % more samples each time (and the
    last), so a curve over thousands of passes stays a few dozen points."""

    def __init__(self):
        self.next = 1

    def due(self, sample: int) -> bool:
        if sample < self.next:
            return False
        self.next = max(sample + 1, int(math.ceil(sample * 1.1)))
        return True


def _series_point(p: Pass) -> dict:
    return {"seconds": round(p.seconds, 4), "samples": int(p.samples),
            "relative_error": p.relative_error, "interval": list(p.error_interval)}


def _stop_reason(settings, sample, elapsed, rel, should_stop) -> str:
    """Why a render stops after this pass before its sample count ("" if it goes on). The
    error is trusted once every replicate of the render has a sample."""
    if settings.time_limit and elapsed >= settings.time_limit:
        return "time limit"
    if (settings.target_error and sample >= len(settings.replicate_ids)
            and 0 <= rel <= settings.target_error):
        return "target error"
    if should_stop is not None and should_stop():
        return "cancelled"
    return ""


def _prepare(scene, settings, debug, on_status=None):
    """The plan, the film, the stage timers and the kernels of a render; `on_status(text)`
    hears what it is doing where that may take a while."""
    plan = make_plan(scene, settings)
    log.info("specula plan: %s", plan.describe())
    if on_status is not None:
        on_status(f"Building the ray acceleration structure ({scene.num_triangles:,} "
                  f"triangles)")
    accel = Accel(scene)
    emitters = LightSampler(scene) if plan.emitters else None
    camera = CameraModel(scene.camera, settings.width, settings.height, scene.origin)
    x0, y0, x1, y1 = settings.window
    timers = StageTimers()
    kernel = Kernels(scene, settings, plan, accel, emitters, camera, timers, on_status)
    if debug:
        kernel.use_debug_kernel()
    # The film keeps transparency where a pixel can have some: a transparent film or a
    # holdout (which makes holes with the film opaque too, as in Cycles).
    film = Film(x1 - x0, y1 - y0, settings.replicate_ids,
                settings.film_transparent or plan.holdout)
    return plan, film, timers, kernel


# Light paths per job. Fixed, not the chunks' size: the jobs' sums are added in job order,
# so the same partition for any thread count, chunk size or region keeps the image's bits.
LIGHT_PATHS_PER_JOB = 1 << 14


def _light_path_jobs(settings, plan) -> list[tuple[int, int]]:
    """(first, count) of each light-path job of a pass: one path per pixel of the whole
    frame, even for a region (kernels.scene_data)."""
    if not plan.light_tracing:
        return []
    frame, size = settings.width * settings.height, LIGHT_PATHS_PER_JOB
    return [(s, min(size, frame - s)) for s in range(0, frame, size)]


def _launch(pool, worker, tracer, index, chunks, light_paths):
    """Queue pass `index`: its light paths first (`light_paths`, (first, count) per job),
    then one sample per pixel, chunk by chunk over the pool. The chunks wait for the light
    paths, which are queued ahead of them, so never behind a waiting chunk."""
    gate = _Gate()
    if light_paths:
        gate.light = light = _LightPass(worker.film.width * worker.film.height)
        light.jobs = [pool.submit(worker.trace_light, light, k, first, count, index, tracer)
                      for k, (first, count) in enumerate(light_paths)]
    return gate, [pool.submit(worker.trace_and_fold, c, index, gate, tracer) for c in chunks]


def render(scene: Scene, settings: RenderSettings, on_pass=None, should_stop=None,
           debug: bool = False, on_status=None) -> RenderResult:
    """Render `scene` progressively. on_pass : optional callable(Pass) run after every
    pass (display, progress). should_stop : optional callable() -> bool checked between
    passes; True cancels, keeping the passes done. debug : the DEBUG kernel, which names
    the stage of a NaN/inf (slower). on_status : optional callable(str) told, before the
    first pass, what may take a while (the BVH; loading or compiling the kernel)."""
    settings.validate()
    t0 = time.perf_counter()
    plan, film, timers, kernel = _prepare(scene, settings, debug, on_status)
    n_pixels = film.width * film.height

    worker = _Worker(settings, kernel, film, timers, debug)
    threads = _thread_count(settings)
    # Equal chunks, a multiple of the thread count, none above chunk_pixels (memory bound).
    n_chunks = threads * max(1, -(-n_pixels // (threads * int(settings.chunk_pixels))))
    chunk = -(-n_pixels // n_chunks)
    starts = list(range(0, n_pixels, chunk))
    stop_reason, cancelled, first = "", False, 0.0
    sample = 0
    snap = None  # the last pass handed to on_pass or recorded in the series
    series, points = [], SeriesPoints()
    chunks = [np.arange(s, min(s + chunk, n_pixels)) for s in starts]
    light_paths = _light_path_jobs(settings, plan)
    with ThreadPoolExecutor(max_workers=threads) as pool:

        def launch(index):
            return _launch(pool, worker, kernel.tracer, index, chunks, light_paths)

        gate, jobs = launch(0)
        gate.opened.set()
        ahead = None
        try:
            while sample < settings.samples:
                # Queue the next pass before waiting for this one, so the workers go on
                # tracing while this thread folds statistics and calls back; the plan's own
                # kernel takes over from the pass after it has compiled.
                kernel.switch_if_ready(sample + 1)
                ahead = launch(sample + 1) if sample + 1 < settings.samples else None
                for job in jobs:
                    job.result()
                gate.light = None  # the light paths' sums are folded: free them
                sample += 1
                film.check_finite(sample)
                elapsed = time.perf_counter() - t0
                if sample == 1:
                    first = elapsed
                # The estimate costs a pass over the film: only when someone reads it.
                due = points.due(sample)
                rel, snap = float("nan"), None  # free the last pass before this one
                if due or on_pass is not None or settings.target_error:
                    snap = film.snapshot(sample, elapsed, sample / settings.samples)
                    rel = snap.relative_error
                    if due:
                        series.append(_series_point(snap))
                if on_pass is not None:
                    on_pass(snap)
                if sample >= settings.samples:
                    break
                stop_reason = _stop_reason(settings, sample, elapsed, rel, should_stop)
                if stop_reason:
                    cancelled = stop_reason == "cancelled"
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
                if ahead[0].light is not None:
                    ahead[0].light.cancel()
    return _result(scene, settings, plan, film, timers, kernel, series, sample,
                   time.perf_counter() - t0, stop_reason or "samples", cancelled, first, snap)


def _result(scene, settings, plan, film, timers, kernel, series, sample, elapsed, stop_reason,
            cancelled, first, snap) -> RenderResult:
    # The loop's last pass is the final one when it was made at this sample: reuse it
    # rather than hold two full-frame copies (the 4K render's peak memory).
    if snap is None or snap.samples != sample:
        snap = film.snapshot(sample, elapsed, sample / settings.samples)
    else:
        snap = replace(snap, seconds=elapsed)
    if not series or series[-1]["samples"] != sample:
        series.append(_series_point(snap))
    name, note = kernel.describe()
    return RenderResult(**snap.__dict__,
                        plan=replace(plan, kernel=name, kernel_note=note),
                        stop_reason=stop_reason, cancelled=cancelled,
                        warnings=list(scene.warnings) + film.rejected, time_to_first_pass=first,
                        stage_seconds=dict(timers.seconds), series=series,
                        replicate_ids=film.replicates,
                        replicate_count=film.replicate_count.reshape(film.height, film.width, -1),
                        replicate_mean=film.replicate_mean.reshape(film.height, film.width, -1, 3),
                        replicate_m2=film.replicate_m2.reshape(film.height, film.width, -1, 4),
                        replicate_transparency=film.replicate_transparency.reshape(
                            film.height, film.width, -1) if film.transparent else None)


def warm_up(compile_cold: bool = True) -> bool:
    """Load the generic kernel now (from numba's cache, or compile it on the first run
    ever) by rendering a 4x3 image of one emissive triangle with it. The add-on calls it in
    the background when it registers, so a render can start with it while the kernel made
    for its scene loads or compiles. Then the cache folders of other core sources are
    pruned (jit.prune_caches).

    compile_cold=False (the add-on's registration) loads it only where numba's cache has
    it: numba compiles one function at a time per process, so a cold generic compile begun
    at registration made the first render wait for it before even its own plan's kernel
    (Blender 3.4's farm render on a fresh cache: 335 s, the plan's kernel alone 91 s).
    Returns whether the generic kernel is loaded."""
    prune_caches()
    if not compile_cold and not kernels.compiled_before(kernels.generic_constants()):
        return False
    b = SceneBuilder()
    m = b.add_material(Material.diffuse("warm-up", (0.5, 0.5, 0.5), emission=(1, 1, 1)))
    b.add_mesh("warm-up", np.array([[-1.0, -1, -2], [1, -1, -2], [0, 1, -2]]),
               np.array([[0, 1, 2]]), m)
    camera = Camera(use_dof=True, fstop=1.0, focus_distance=2.0)
    render(b.build(camera, World((0.1, 0.1, 0.1))),
           RenderSettings(width=4, height=3, samples=2, threads=1, kernel="generic"))
    return True

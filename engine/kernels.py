"""Kernels per plan: compiling, caching, and the bounce loop between embree and `shade`.

`Kernel(constants)` compiles integrator.py's stages for one plan (specialise.py); numba
caches each on disk, so a plan seen before loads in well under a second. `kernel_for`
hands a render a kernel that is ready now and, when that is not the plan's own, compiles
the plan's kernel on a background thread for the renderer to switch to at a pass
boundary. Both give the same pixels: a specialised kernel only leaves out code the scene
cannot reach.

`Tracer` traces one sample for a batch of pixels with one kernel: camera rays, then per
bounce embree's closest hits, `shade`, and the shadow rays.
"""

from __future__ import annotations

import os
import threading
import time
import types

import numpy as np

from . import integrator, light_tracing, specialise
from .bsdf import layer_tables, sheen_table
from .caustics import caustic_data, no_caustic_data
from .camera import CameraModel, view_maps
from .film import BACKGROUND_DEPTH, PixelFilter
from .integrator import (PLAN_CONSTANTS, STAGE_NAMES, Geometry, MaterialTable, Paths,
                         SceneData, ShadowRays)
from .jit import INLINE
from .lights import BOUND_COLUMNS, COLUMNS, Emitters
from .media import MEDIA_STACK, VOLUME_BOUNDS_MAX, enclosing
from .plan import entered_media
from .environment import RAY_FLAGS, Environment
from .sampling import cross_rows, replicate_seed, reverse_bits
from .shading import (CAMERA, CAMERA_AXES, CAMERA_ORIGIN, MAX_REGISTERS, POSITION, SLOTS,
                      TRUE_NORMAL, VIEW_MAPS, WINDOW, ProgramTable)

F32 = np.float32
GENERIC = {name: True for name in PLAN_CONSTANTS}
GENERIC.update(PROFILE=False, DEBUG=False)


def key_of(constants: dict) -> tuple:
    return tuple(bool(constants[name]) for name in PLAN_CONSTANTS)


def tag_of(constants: dict) -> str:
    bits = "".join("1" if b else "0" for b in key_of(constants))
    return f"p{int(bits, 2):x}_{specialise.SOURCE_HASH}"


class Kernel:
    """integrator.py's stages compiled for one set of plan constants.

    cache=False and `overrides` (global name -> replacement) compile a one-off kernel with
    some formula swapped, for tests that put a wrong formula in on purpose."""

    def __init__(self, constants: dict, cache: bool = True, overrides: dict | None = None):
        self.constants = dict(constants)
        self.key = key_of(self.constants)
        self.generic = all(self.constants[n] for n in PLAN_CONSTANTS
                           if n not in ("PROFILE", "DEBUG"))
        self.tag = tag_of(self.constants) + ("" if cache else f"_once{id(self):x}")
        namespace = dict(vars(integrator))
        namespace.update(vars(light_tracing))
        stages = dict(integrator.STAGES)
        stages.update(light_tracing.STAGES)
        for name, replacement in (overrides or {}).items():
            if name in stages:  # a stage swapped for another
                stages[name] = (replacement, stages[name][1])
            elif isinstance(replacement, types.FunctionType):  # a new stage it may call
                stages[name] = (replacement, INLINE)
            else:
                namespace[name] = replacement
        f = specialise.specialise(stages, namespace, self.constants, self.tag, cache=cache)
        self.generate_camera_rays = f["generate_camera_rays"]
        self.shade = f["shade"]
        self.accumulate_unoccluded = f["accumulate_unoccluded"]
        self.cross_transparent = f["cross_transparent"]
        self.all_finite = f["all_finite"]
        self.start_light_paths = f["start_light_paths"]
        self.light_bounce = f["light_bounce"]
        self.splat = f["splat"]
        self.compile_seconds = 0.0

    def covers(self, constants: dict) -> bool:
        """Whether this kernel has every feature `constants` asks for: a kernel built
        without glass cannot be handed a glass scene."""
        return all(self.constants[n] or not constants[n] for n in PLAN_CONSTANTS
                   if n not in ("PROFILE", "DEBUG"))

    def _marker(self) -> str | None:
        """A file beside numba's cache saying this plan's kernel compiled before."""
        cache = getattr(self.shade, "_cache", None)
        path = getattr(cache, "_cache_path", None)
        return os.path.join(path, f"specula-{self.tag}.ready") if path else None

    def on_disk(self) -> bool:
        marker = self._marker()
        return bool(marker and os.path.exists(marker))

    def mark_ready(self) -> None:
        marker = self._marker()
        if marker:
            try:
                with open(marker, "w"):
                    pass
            except OSError:  # a read-only cache: the kernel still works, it just reloads
                pass


def compile_on(kernel: Kernel, scene, settings, plan, emitters, camera, accel) -> None:
    """Compile every entry point of `kernel` by tracing one pixel of the scene with it
    (numba compiles for the argument types it is called with)."""
    data = scene_data(scene, settings, plan, emitters, camera, kernel.generic)
    tracer = Tracer(kernel, data, accel, settings, lambda stage, seconds: None,
                    transparency=plan.transparency, volumes=plan.volumes)
    tracer.trace_pixels(np.zeros(1, np.int64), 0)
    if tracer.segmented_shadows:  # (one pixel need not have queued a shadow ray)
        tracer.trace_shadow_rays(tracer.shadow_rays(1), 0, tracer.new_paths(1),
                                 reverse_bits(np.uint64(0)))
    if kernel.constants["HAS_LIGHT_TRACING"]:
        tracer.trace_light(0, 1, 0)
    kernel.all_finite(np.zeros((1, 3)), np.zeros(1), np.zeros((1, 3)))


# ------------------------------------------------------------------ the kernel store
_lock = threading.Lock()
_ready: dict[tuple, Kernel] = {}
_building: dict[tuple, threading.Thread] = {}
_compiling: set = set()  # keys being compiled (not loaded from numba's cache) right now


def ready_kernel(constants: dict) -> Kernel | None:
    """The kernel for these constants if it is loaded in this process."""
    with _lock:
        return _ready.get(key_of(constants))


def compiled_before(constants: dict) -> bool:
    """Whether the kernel for these constants is loaded in this process or in numba's
    cache (it loads in seconds rather than compiling for minutes)."""
    return ready_kernel(constants) is not None or Kernel(constants).on_disk()


def build_status(constants: dict) -> str:
    """What a render about to wait for the kernel of `constants` tells its user ("" where
    it is loaded already). numba compiles one function at a time per process, so a compile
    under way on another thread (the add-on's warm-up, a plan's kernel in the background)
    delays even a load from the cache: said too."""
    if ready_kernel(constants) is not None:
        return ""
    what = "Loading the render kernel" if Kernel(constants).on_disk() else \
        "Compiling the render kernel for this kind of scene (once; a minute or more)"
    with _lock:
        busy = bool(_compiling - {key_of(constants)})
    return what + (", after another compiling in the background" if busy else "")


def build_now(constants: dict, compile_with) -> Kernel:
    """Load (from numba's cache) or compile the kernel for `constants` now; `compile_with`
    (Kernel) runs it once on real data so every entry point compiles with real types."""
    k = ready_kernel(constants)
    if k is not None:
        return k
    k = Kernel(constants)
    cold = not k.on_disk()
    if cold:
        with _lock:
            _compiling.add(k.key)
    t0 = time.perf_counter()
    try:
        compile_with(k)
    finally:
        if cold:
            with _lock:
                _compiling.discard(k.key)
    k.compile_seconds = time.perf_counter() - t0
    k.mark_ready()
    with _lock:
        _ready.setdefault(k.key, k)
        return _ready[k.key]


def build_in_background(constants: dict, compile_with) -> threading.Thread:
    """Start (or join) compiling the kernel for `constants` on a daemon thread."""
    key = key_of(constants)
    with _lock:
        thread = _building.get(key)
        if thread is not None:
            return thread

        def run():
            try:
                build_now(constants, compile_with)
            finally:
                with _lock:
                    _building.pop(key, None)

        thread = threading.Thread(target=run, name="specula-kernel", daemon=True)
        _building[key] = thread
    thread.start()
    return thread


def generic_constants() -> dict:
    return dict(GENERIC)


# ------------------------------------------------------------------ scene data
def scene_data(scene, settings, plan, emitters, cam: CameraModel, generic: bool) -> SceneData:
    """The scene as a kernel reads it. A specialised kernel gets None for the parts its plan
    does not use; the generic one gets harmless stand-ins (no emitters, flat normals, no
    environment) that its run-time checks skip."""
    v = scene.vertices
    t = len(v)
    n = cross_rows(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
    tri_normal = n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    tri_scale = np.abs(v).max(axis=(1, 2)) if t else np.zeros(0)
    smooth_needed = generic or plan.shading_normals or plan.terminator
    normals = smooth = obj = offset = None
    if smooth_needed:
        normals = scene.normals if scene.normals is not None else np.zeros((1, 3, 3))
        smooth = scene.smooth.astype(np.bool_) if scene.normals is not None else \
            np.zeros(t, np.bool_)
    if generic or plan.terminator:
        obj = scene.object_index.astype(np.int64)
        offset = np.asarray(scene.terminator_offset, np.float64)
        if len(offset) == 0:
            offset = np.zeros(1)
    uv = programs = None
    if scene.programs is not None and (plan.textures or generic):
        uv, programs = scene.uv, scene.programs
        fill_view_maps(scene, cam, tri_normal)
    elif generic:  # no material has a program
        uv = np.zeros((1, 1, 3, 3), np.float32)
        none = np.full((len(scene.materials), 3), -1, np.int64)
        programs = ProgramTable(np.zeros((0, 8), np.int64), np.zeros(1), np.zeros((1, 4), F32),
                                np.zeros((0, 6), np.int64), *[none] * len(SLOTS))
    tangents = None
    if scene.tangents is not None and (plan.normal_maps or generic):
        tangents = scene.tangents
    elif generic or plan.normal_maps:  # bump maps alone: no Normal Map reads tangents
        tangents = np.zeros((1, 3, 4), F32)
    geometry = Geometry(v, tri_normal, tri_scale, scene.material_index.astype(np.int64),
                        normals, smooth, obj, offset, uv, tangents)
    materials = material_table(scene, plan, programs, generic)
    em = emitters.data() if emitters is not None else None
    if generic:
        em = _generic_emitters(em, t)
    caustics = None
    if plan.light_tracing:
        # As many light paths as the whole frame has pixels, even for a region: a region's
        # pixels are then the whole frame's, bit for bit (RenderSettings.region).
        caustics = caustic_data(settings.width * settings.height, emitters)
    elif generic:
        caustics = no_caustic_data()
    camera = cam.data()
    camera_media = np.full(MEDIA_STACK, -1, np.int64)
    if plan.volumes:
        camera_media = enclosing(camera.position, scene.vertices, scene.material_index,
                                 entered_media(scene), scene.world_medium)
    return c_contiguous(SceneData(
        geometry, materials, em, np.asarray(scene.world.colour, np.float64), camera,
        PixelFilter(settings.filter_type, settings.filter_width).table(), caustics,
        camera_media, np.bool_(settings.fresnel == "exact"),
        np.bool_(settings.film_transparent), np.float64(settings.clear_glass_threshold)))


def material_table(scene, plan, programs, generic: bool) -> MaterialTable:
    """The materials as a kernel reads them (integrator.MaterialTable): as scene_data, None
    for the parts the plan does not use."""
    m = scene.materials
    rough = plan.principled or plan.glossy or plan.rough_glass or plan.rough_metal
    used = m.reachable(np.unique(scene.material_index))
    layers = layer_tables(m, used) if (rough or generic) else None
    strength = m.normal_strength if m.normal_strength is not None else np.ones(len(m.kind))
    # Materials.from_list always fills the media and mix arrays; a kernel without media or
    # mixes is not passed them.
    needs_mixes = plan.mixes or generic
    return MaterialTable(m.kind.astype(np.int64), m.colour, m.ior, m.reflection_tint,
                         m.transmission_tint, m.emission, layers, programs,
                         np.asarray(strength, np.float64),
                         m.medium if plan.volumes or generic else None,
                         m.mix_components if needs_mixes else None,
                         m.mix_fac if needs_mixes else None,
                         m.mix_scale if needs_mixes else None,
                         m.coat_ior if plan.coats or generic else None,
                         m.coat_tint if plan.coats or generic else None,
                         m.fresnel, m.glass_tints, m.roughness,
                         m.sheen_layer if plan.sheen or generic else None,
                         m.sheen_parent if plan.sheen or generic else None,
                         sheen_table() if plan.sheen or generic else None,
                         m.specular_tint, m.emission_root, m.emission_share,
                         *_anisotropy_columns(m, plan.anisotropy or generic),
                         _sets_normal(m) if plan.normal_maps or generic else None,
                         _thin_film(m) if plan.thin_film or generic else None)


def _thin_film(m) -> np.ndarray:
    """Each row's thin film (k, 2) (scene.Materials.thin_film; none where not given)."""
    if m.thin_film is None:
        return np.tile([0.0, 1.0], (len(m.kind), 1))
    return np.asarray(m.thin_film, np.float64)


def fill_view_maps(scene, cam: CameraModel, tri_normal) -> None:
    """Write the maps the renderer makes into the scene's maps: the camera's (Texture
    Coordinate's Camera and Window, Vector Transform's camera axes and position) for this
    render's camera and frame (a render at another size or with another camera writes them
    again), and the Geometry node's Position (world space) and True Normal (`tri_normal`,
    per triangle)."""
    names = [n for n in VIEW_MAPS if n in scene.uv_names]
    if not names or scene.view_maps_camera is cam:  # (the generic kernel's, then its own)
        return
    scene.view_maps_camera = cam
    local, window = view_maps(cam, scene.vertices) if {CAMERA, WINDOW} & set(names) else \
        (None, None)
    values = {CAMERA: local, WINDOW: window, POSITION: scene.vertices + scene.origin,
              TRUE_NORMAL: tri_normal[:, None, :],
              CAMERA_ORIGIN: (cam.position + scene.origin)[None, None, :],
              **{axis: cam.world_from_camera[:, j][None, None, :]
                 for j, axis in enumerate(CAMERA_AXES)}}
    for name in names:
        scene.uv[scene.uv_names.index(name)] = values[name]


def c_contiguous(data):
    """`data` (nested named tuples of arrays) with every array C-contiguous. numba compiles
    a kernel per argument layout: one strided view (the emitters' first corners are a column
    of their corner array) compiled the whole kernel a second time (~150 s cold)."""
    if isinstance(data, np.ndarray):
        return data if data.flags.c_contiguous else np.ascontiguousarray(data)
    if isinstance(data, tuple) and hasattr(data, "_fields"):
        return type(data)(*(c_contiguous(x) for x in data))
    return data


def _anisotropy_columns(m, needed) -> tuple:
    """The MaterialTable's anisotropy and rotation columns (None where not needed)."""
    if not needed:
        return None, None
    k = len(m.kind)
    return (m.specular_anisotropy if m.specular_anisotropy is not None else np.zeros(k),
            m.anisotropic_rotation if m.anisotropic_rotation is not None else np.zeros(k))


def _sets_normal(m) -> np.ndarray:
    """The MaterialTable's sets_normal column (False where the materials do not say)."""
    return m.sets_normal if m.sets_normal is not None else np.zeros(len(m.kind), np.bool_)


def _generic_emitters(em, num_triangles: int) -> Emitters:
    """Emitters with every part present, as the generic kernel is compiled for."""
    z3, z = np.zeros((0, 3)), np.zeros(0)
    stand_in_image = np.zeros((1, 1, 3), F32)
    stand_in_env = Environment(stand_in_image, np.eye(3), np.eye(3), np.ones(1), np.ones(1),
                               np.zeros((0, 1, 1, 3), F32),
                               np.full(RAY_FLAGS, -1, np.int64))
    if em is None:
        return Emitters(z, z, 0, np.zeros(3), np.ones(3), np.zeros((1, 0)), z,
                        np.zeros(1, np.bool_), np.full(num_triangles, -1, np.int64),
                        np.ones(num_triangles), z3, z3, z3, z3, z, z3, z,
                        np.zeros((0, COLUMNS)), stand_in_env, -1,
                        np.zeros((0, BOUND_COLUMNS)), np.zeros(0, np.int64))
    if em.environment is None:
        em = em._replace(environment=stand_in_env)
    return em


# ------------------------------------------------------------------ tracing
class Tracer:
    """Traces one sample for batches of pixels with one kernel; thread-safe.

    profile : `shade` reads the CPU's cycle counter around its stages (a PROFILE kernel),
    and the stage timers split its time into surface interaction, light sampling and BSDF
    sampling."""

    def __init__(self, kernel: Kernel, data: SceneData, accel, settings, count,
                 transparency: bool = False, volumes: bool = False):
        self.kernel, self.data, self.accel, self.settings = kernel, data, accel, settings
        self._count = count  # callable(stage, seconds)
        self.profile = bool(kernel.constants["PROFILE"])
        # The plan has transparent surfaces: paths and shadow rays cross them.
        self.transparency = bool(transparency)
        if transparency and not kernel.constants["HAS_TRANSPARENCY"]:
            raise ValueError("transparent shadows need a kernel with HAS_TRANSPARENCY")
        # Shadow rays are traced a segment at a time through transparent surfaces, and
        # through the plan's media where the kernel has transparency (its shadow rays
        # carry their media to be attenuated per segment, integrator.queue_shadow).
        self.segmented_shadows = self.transparency or bool(
            volumes and kernel.constants["HAS_TRANSPARENCY"] and kernel.constants["HAS_VOLUMES"])

    @staticmethod
    def new_paths(n: int) -> Paths:
        return Paths(np.arange(n, dtype=np.int64), np.empty(n, np.uint64), np.empty((n, 3)),
                     np.empty((n, 3)), np.empty((n, 3), F32), np.empty((n, 3), F32),
                     np.empty(n, F32), np.ones((n, 3)), np.full(n, np.inf), np.zeros((n, 3)),
                     np.full(n, BACKGROUND_DEPTH), np.zeros((n, 3)), np.zeros(n, np.int32),
                     np.zeros(n), np.ones(n), np.zeros(n), np.zeros((n, 3)),
                     np.zeros(MAX_REGISTERS), np.full((n, MEDIA_STACK), -1, np.int64),
                     np.zeros(n, np.int64), np.zeros(n, np.int64), np.zeros(n),
                     np.zeros(n, np.int64), np.zeros(n, np.bool_), np.zeros(n, np.int64),
                     np.zeros((n, 3), np.int64), np.zeros(n), np.zeros(n, np.bool_))

    @staticmethod
    def shadow_rays(n: int) -> ShadowRays:
        """Room for n shadow rays: at most one per path and bounce."""
        return ShadowRays(np.empty(n, np.int64), np.empty((n, 3), F32), np.empty((n, 3), F32),
                          np.empty(n, F32), np.empty((n, 3)), np.empty(n, np.int64),
                          np.empty(n, np.int64), np.full((n, MEDIA_STACK), -1, np.int64),
                          np.zeros((n, 4), np.int64))

    def trace_pixels(self, pixels: np.ndarray, sample: int, replicate: int = 0):
        """Sample `sample` of replicate `replicate` for each pixel id in `pixels` (n,):
        radiance (n, 3), depth (n,), normal (n, 3), with a DEBUG kernel the stage that
        first went non-finite (n,), and the transparency the film keeps (n,; a transparent
        film, holdouts). Replicate 0's first sample goes through the pixels' middles, as
        Cycles' first sample."""
        k, s = self.kernel, self.settings
        n = len(pixels)
        paths = self.new_paths(n)
        t0 = time.perf_counter()
        k.generate_camera_rays(np.asarray(pixels, np.int64), sample,
                               replicate_seed(s.seed, replicate), sample == 0 and replicate == 0,
                               self.data, paths)
        self._count("generate camera rays", time.perf_counter() - t0)
        rev_sample = reverse_bits(np.uint64(sample))
        shadow = self.shadow_rays(n)
        profile = np.zeros(3 if self.profile else 0, np.uint64)
        m = n
        # Each step is a bounce; transparent and volume boundary crossings take steps of
        # their own (every path ends within this: each step counts one of them).
        steps = s.max_bounces + 2 + (max(s.transparent_max_bounces, 1) + VOLUME_BOUNDS_MAX
                                     if self.transparency else 0)
        for step in range(steps):
            if m == 0:
                break
            prim, tfar, bu, bv = self._closest_hits(paths, m)
            t0 = time.perf_counter()
            m, count = k.shade(step, rev_sample, s.max_bounces, s.transparent_max_bounces,
                               self.data, prim, tfar, bu, bv, m, paths, shadow, profile)
            self._count_shade(time.perf_counter() - t0, profile)
            if count:
                self.trace_shadow_rays(shadow, count, paths, rev_sample)
        return paths.radiance, paths.depth, paths.normal, paths.nonfinite, paths.transparency

    def trace_shadow_rays(self, shadow: ShadowRays, count: int, paths: Paths, rev_sample):
        """Add the contributions of the first `count` queued shadow rays that reach their
        lights: one occlusion query, or closest hits in turn through transparent surfaces."""
        k = self.kernel
        t0 = time.perf_counter()
        if not self.segmented_shadows:
            blocked = self.accel.occluded_raw(shadow.origin[:count], shadow.direction[:count],
                                              shadow.tmax[:count])
            k.accumulate_unoccluded(paths.radiance, shadow, blocked, count)
        else:
            limit = self.settings.transparent_max_bounces
            for _ in range(limit + 1):
                # (embree writes each hit's distance over the tmax it is given)
                prim, tfar, bu, bv = self.accel.intersect_raw(
                    shadow.origin[:count], shadow.direction[:count], shadow.tmax[:count].copy())
                count = k.cross_transparent(rev_sample, limit, self.data, prim, tfar, bu, bv,
                                            count, shadow, paths)
                if count == 0:
                    break
        self._count("trace shadow rays", time.perf_counter() - t0)

    def _closest_hits(self, rays, m: int):
        """Embree's closest hits of the first m rays of a wavefront (camera or light
        paths: their float32 origin32, dir32, tmax32)."""
        t0 = time.perf_counter()
        # Embree writes hit distances over tmax; a ray crossing a transparent surface keeps
        # its end (a camera ray's clipping), so with transparency it gets a copy.
        tmax = rays.tmax32[:m]
        hits = self.accel.intersect_raw(rays.origin32[:m], rays.dir32[:m],
                                        tmax.copy() if self.transparency else tmax)
        self._count("intersect", time.perf_counter() - t0)
        return hits

    def trace_light(self, first: int, count: int, sample: int, replicate: int = 0):
        """Light paths first..first+count-1 of sample `sample` of replicate `replicate`
        (light_tracing.py), connected to the camera: (window-local pixel ids (k,), values
        (k, 3)) to add to the pass, each already divided by the paths per pass."""
        k, s = self.kernel, self.settings
        n = count
        lp = light_tracing.LightPaths(
            np.empty(n, np.int64), np.empty(n, np.uint64), np.empty((n, 3)), np.empty((n, 3)),
            np.empty((n, 3), F32), np.empty((n, 3), F32), np.empty(n, F32), np.empty((n, 3)),
            np.empty(n), np.empty(n), np.empty(n), np.empty(n), np.empty(n),
            np.zeros(MAX_REGISTERS))
        conn = light_tracing.Connections(np.empty((n, 3), F32), np.empty((n, 3), F32),
                                         np.empty(n, F32), np.empty((n, 2)), np.empty((n, 3)))
        t0 = time.perf_counter()
        seed = light_tracing.light_path_seed(replicate_seed(s.seed, replicate))
        m = k.start_light_paths(np.arange(first, first + count, dtype=np.int64), sample, seed,
                                self.data, lp)
        rev_sample = reverse_bits(np.uint64(sample))
        self._count("light paths", time.perf_counter() - t0)
        parts = []
        for depth in range(s.max_bounces + 1):
            if m == 0:
                break
            prim, tfar, bu, bv = self._closest_hits(lp, m)
            t0 = time.perf_counter()
            m, n_conn = k.light_bounce(depth, rev_sample, s.max_bounces, self.data, prim, tfar,
                                       bu, bv, m, lp, conn, 0)
            self._count("light paths", time.perf_counter() - t0)
            # A path connects at most once per bounce (a Lambertian vertex), so the buffer
            # holds one bounce's connections: splat them before the next bounce refills it.
            if n_conn:
                parts.append(self._splat(conn, n_conn))
        if not parts:
            return np.zeros(0, np.int64), np.zeros((0, 3))
        return (np.concatenate([p for p, _ in parts]),
                np.concatenate([v for _, v in parts]))

    def _splat(self, conn, n_conn: int):
        """The first n_conn camera connections, occlusion-tested and splatted through the
        pixel filter: (window-local pixel ids (k,), values (k, 3))."""
        k, s = self.kernel, self.settings
        t0 = time.perf_counter()
        blocked = self.accel.occluded_raw(conn.origin[:n_conn], conn.direction[:n_conn],
                                          conn.tmax[:n_conn])
        table = self.data.film_filter
        span = int(np.ceil(table.x.max() - table.x.min())) + 1  # pixels a splat reaches, per axis
        pixels = np.empty(n_conn * span * span, np.int64)
        values = np.empty((n_conn * span * span, 3))
        x0, y0, x1, y1 = s.window
        n_splat = k.splat(conn, blocked, n_conn, x0, y0, x1, y1, table, pixels, values)
        self._count("splat", time.perf_counter() - t0)
        return pixels[:n_splat], values[:n_splat]

    def _count_shade(self, seconds: float, profile: np.ndarray) -> None:
        if len(profile) == 0 or profile[0] == 0:
            self._count("shade", seconds)
            return
        light, bsdf = profile[1] / profile[0], profile[2] / profile[0]
        self._count("surface interaction", seconds * (1.0 - light - bsdf))
        self._count("sample light", seconds * light)
        self._count("sample BSDF", seconds * bsdf)
        profile[:] = 0

    def explain_nonfinite(self, pixels: np.ndarray, sample: int, replicate: int, width: int,
                          debug_tracer: "Tracer") -> list[str]:
        """Messages naming the stage and pixel of non-finite samples: the bad samples are
        traced again (sampling is deterministic) by a DEBUG kernel that marks the stage."""
        msgs = []
        for p in pixels[:5]:
            stage = int(debug_tracer.trace_pixels(np.array([p]), sample, replicate)[3][0])
            where = f"pixel (x={p % width}, y={p // width})"
            msgs.append(f"stage '{STAGE_NAMES[stage]}' produced a non-finite value at {where}"
                        if stage else f"non-finite sample at {where}, stage unknown")
        return msgs

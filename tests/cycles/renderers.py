"""Render a variant with Specula (in-process, through the add-on's exporter and the core)
and with Cycles (through Blender, set up unbiased), as linear float images.

Both return (H, W, 3) float arrays with row 0 at the bottom. Specula also returns its
per-pixel variance of the mean. Needs bpy with the add-on registered (`ensure_registered`).
"""

from __future__ import annotations

import os
import tempfile
import time
from types import SimpleNamespace

import bpy
import numpy as np

from .variants import SCENES_DIR, Variant

THREADS = 2  # the CI machine's cores; both engines get the same


def ensure_registered():
    """Register the add-on once per process (tests/addon's conftest may have done it)."""
    import addon
    if not hasattr(bpy.types.Scene, "specula"):
        addon.register()


def open_blend_scene(name, resolution):
    """Open blend_scenes/<name>.blend at `resolution` (100 %) with Specula registered;
    shared by the benchmarks."""
    ensure_registered()
    bpy.ops.wm.open_mainfile(filepath=os.path.join(SCENES_DIR, f"{name}.blend"))
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = resolution
    scene.render.resolution_percentage = 100
    scene.specula.threads = THREADS
    return scene


def core():
    from addon import core as core_loader
    return core_loader.load()


def prepare(variant: Variant):
    """Build the variant's scene and apply its resolution and bounce limit."""
    ensure_registered()
    variant.setup()
    scene = bpy.context.scene
    w, h = variant.resolution
    scene.render.resolution_x, scene.render.resolution_y = w, h
    scene.render.resolution_percentage = 100
    scene.render.film_transparent = False
    s = scene.specula
    s.samples = variant.samples
    s.max_bounces = variant.max_bounces
    s.time_limit = 0.0
    s.target_error = 0.0
    s.seed = 0
    s.threads = THREADS
    s.fresnel = "EXACT"
    s.filter_type = "BLACKMAN_HARRIS"
    s.filter_width = 1.5
    return scene


def specula_scene(variant: Variant):
    """(core scene, core RenderSettings, warnings) of the variant, as the add-on exports it."""
    from addon import exporter
    specula = core()
    scene = prepare(variant)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    depsgraph.update()
    exported = exporter.export(depsgraph)
    core_scene, warnings = exporter.to_core(exported, specula)
    w, h = variant.resolution
    settings = specula.RenderSettings(**exporter.render_settings_kwargs(scene, w, h))
    return core_scene, settings, exported.warnings + warnings


def render_specula(variant: Variant, inject=None):
    """Render with Specula; `inject(core_scene, settings) -> (core_scene, settings)` may
    alter the exported scene first. Returns the core's RenderResult."""
    core_scene, settings, _ = specula_scene(variant)
    if inject is not None:
        core_scene, settings = inject(core_scene, settings)
    return core().render(core_scene, settings)


def configure_cycles(scene, samples, seed, max_bounces, time_limit=0.0):
    """Cycles unbiased (the CLI's settings) on the CPU with THREADS threads."""
    from addon.cli import _configure_cycles
    scene.render.engine = "CYCLES"
    _configure_cycles(scene, SimpleNamespace(samples=samples, time_limit=time_limit, seed=seed,
                                             max_bounces=max_bounces))
    c = scene.cycles
    c.film_exposure = 1.0
    c.sampling_pattern = "TABULATED_SOBOL"  # independent pixels (no blue-noise dithering)
    c.use_animated_seed = False
    c.min_light_bounces = 0
    scene.render.threads_mode = "FIXED"
    scene.render.threads = THREADS
    return c


def cycles_settings_record(scene) -> dict:
    """The Cycles settings a reference depends on (stored beside it)."""
    c = scene.cycles
    keys = ("device", "use_denoising", "use_adaptive_sampling", "sample_clamp_direct",
            "sample_clamp_indirect", "blur_glossy", "light_sampling_threshold", "max_bounces",
            "diffuse_bounces", "glossy_bounces", "transmission_bounces", "volume_bounces",
            "transparent_max_bounces", "pixel_filter_type", "filter_width", "film_exposure",
            "sampling_pattern", "caustics_reflective", "caustics_refractive", "use_light_tree")
    return {k: (getattr(c, k) if not isinstance(getattr(c, k), float)
                else round(getattr(c, k), 6)) for k in keys}


def render_cycles_image(scene):
    """Render the current scene with its current engine settings; (H, W, 4) float32 from a
    32-bit EXR (linear, rows bottom to top), and the seconds the render took."""
    image = scene.render.image_settings
    image.file_format = "OPEN_EXR"
    image.color_depth = "32"
    image.color_mode = "RGBA"
    fd, path = tempfile.mkstemp(suffix=".exr", prefix="specula_cycles_")
    os.close(fd)
    scene.render.filepath = path
    scene.render.use_file_extension = False
    try:
        t0 = time.perf_counter()
        bpy.ops.render.render(write_still=True)
        seconds = time.perf_counter() - t0
        img = bpy.data.images.load(path)
        try:
            w, h = img.size
            buf = np.zeros(w * h * 4, np.float32)
            img.pixels.foreach_get(buf)
        finally:
            bpy.data.images.remove(img)
    finally:
        os.unlink(path)
    return buf.reshape(h, w, 4), seconds


def render_cycles(variant: Variant, seed: int, samples: int | None = None):
    """One Cycles render of the variant: (H, W, 3) float32 and the settings record."""
    scene = prepare(variant)
    configure_cycles(scene, samples or variant.cycles_samples, seed, variant.max_bounces)
    rgba, _ = render_cycles_image(scene)
    expected = (variant.resolution[1], variant.resolution[0])
    if rgba.shape[:2] != expected:
        raise RuntimeError(f"Cycles wrote {rgba.shape[:2]}, expected {expected}")
    return rgba[..., :3], cycles_settings_record(scene)

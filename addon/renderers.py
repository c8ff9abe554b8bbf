"""One Blender scene rendered by both engines in-process, as linear float images to compare.

Specula runs through the add-on's exporter and the core directly (not Blender's render
pipeline) because the comparison needs what only the core returns: each pixel's variance of
the mean and the estimated error after every pass. Cycles runs through Blender, set up
unbiased. Both images are (H, W, ...) float32 with row 0 at the bottom.

Used by `python -m addon compare` (compare.py) and by the agreement tests (tests/cycles).
"""

from __future__ import annotations

import os
import tempfile
import time

import bpy

from . import core, exporter

# Cycles' images pass through temporary EXR files named with this prefix.
TEMP_PREFIX = "specula_cycles_"

def configure_cycles_unbiased(scene, samples, time_limit, seed, max_bounces):
    """Cycles without its biased defaults, so it can be compared with Specula: CPU, no
    denoising, adaptive sampling or clamping, Filter Glossy 0, light threshold 0, every
    per-type bounce limit equal to the total, Specula's pixel filter and Transparent Glass."""
    c = scene.cycles
    s = scene.specula
    c.device = "CPU"
    c.samples = samples
    c.time_limit = time_limit
    c.seed = seed
    c.use_denoising = False
    c.use_adaptive_sampling = False
    c.sample_clamp_direct = 0.0
    c.sample_clamp_indirect = 0.0
    c.blur_glossy = 0.0
    c.light_sampling_threshold = 0.0
    # Every per-type limit equals the total, so only the total limits a path, as in Specula;
    # transparent bounces have their own limit, Specula's.
    for name in ("max_bounces", "diffuse_bounces", "glossy_bounces", "transmission_bounces",
                 "volume_bounces"):
        setattr(c, name, max_bounces)
    c.transparent_max_bounces = s.transparent_max_bounces
    c.pixel_filter_type = s.filter_type
    c.filter_width = s.filter_width  # Film > Pixel Filter width
    c.film_transparent_glass = s.film_transparent_glass
    c.film_transparent_roughness = s.film_transparent_roughness
    for layer in scene.view_layers:
        layer.cycles.use_denoising = False
    return c


def configure_cycles_for_comparison(scene, samples, seed, max_bounces, time_limit=0.0,
                                    threads=0):
    """Cycles unbiased, plus what the block test needs: independent pixels (the tabulated
    Sobol pattern; the default blue-noise pattern correlates neighbours, and the test sums
    pixel variances), no film exposure (Specula has none), the same threads as Specula
    (0: all cores)."""
    scene.render.engine = "CYCLES"
    c = configure_cycles_unbiased(scene, samples, time_limit, seed, max_bounces)
    c.film_exposure = 1.0
    c.sampling_pattern = "TABULATED_SOBOL"
    c.use_animated_seed = False
    c.min_light_bounces = 0
    scene.render.threads_mode = "FIXED" if threads else "AUTO"
    if threads:
        scene.render.threads = threads
    return c


def render_cycles_image(scene):
    """Render the scene with its current engine settings: (H, W, 4) float32 read back from a
    32-bit EXR (linear, rows bottom to top) and the seconds the render took (Blender's whole
    render call: sync, BVH, sampling and writing the EXR). Raises RuntimeError when Blender
    cannot render the scene."""
    import numpy as np
    image = scene.render.image_settings
    image.file_format = "OPEN_EXR"
    image.color_depth = "32"
    image.color_mode = "RGBA"
    fd, path = tempfile.mkstemp(suffix=".exr", prefix=TEMP_PREFIX)
    os.close(fd)
    os.unlink(path)  # so that a render that writes nothing is noticed
    scene.render.filepath = path
    scene.render.use_file_extension = False
    try:
        t0 = time.perf_counter()
        bpy.ops.render.render(write_still=True)
        seconds = time.perf_counter() - t0
        if not os.path.isfile(path):
            raise RuntimeError(f"{scene.render.engine} wrote no image")
        img = bpy.data.images.load(path)
        try:
            w, h = img.size
            buf = np.zeros(w * h * 4, np.float32)
            img.pixels.foreach_get(buf)
        finally:
            bpy.data.images.remove(img)
    finally:
        if os.path.exists(path):
            os.unlink(path)
    return buf.reshape(h, w, 4), seconds


def export_specula(scene):
    """(core scene, core RenderSettings, warnings) of `scene` as the add-on exports it, at
    its output resolution. Raises exporter.ExportError or ValueError when it cannot."""
    specula = core.load()
    depsgraph = bpy.context.evaluated_depsgraph_get()
    depsgraph.update()
    exported = exporter.export(depsgraph)
    core_scene, warnings = exporter.to_core(exported, specula)
    w, h = exporter.resolution(scene)
    settings = specula.RenderSettings(**exporter.render_settings_kwargs(scene, w, h))
    settings.validate()
    return core_scene, settings, exported.warnings + warnings


def render_specula(core_scene, settings, on_pass=None):
    """The core's RenderResult (image, variance of each pixel's mean, passes' errors)."""
    return core.load().render(core_scene, settings, on_pass=on_pass)

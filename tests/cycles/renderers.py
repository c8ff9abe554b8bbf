"""Render a variant with Specula (in-process, through the add-on's exporter and the core)
and with Cycles (through Blender, set up unbiased), as linear float images. The rendering
itself is the add-on's (`addon/renderers.py`, shared with `python -m addon compare`); this
module applies a variant's settings.

Both return (H, W, 3) float arrays with row 0 at the bottom. Specula also returns its
per-pixel variance of the mean. Needs bpy with the add-on registered (`ensure_registered`).
"""

from __future__ import annotations

import os

import bpy

from addon import renderers as shared
from addon.renderers import render_cycles_image

from .variants import SCENES_DIR, Variant

THREADS = 2  # the CI machine's cores; both engines get the same


def ensure_registered():
    """Register the add-on once per process (tests/addon's conftest may have done it)."""
    import addon
    if not hasattr(bpy.types.Scene, "specula"):
        addon.register()


def sky_and_sun_scene(resolution, sun_angle):
    """A new empty scene for the live tests that build their own: a blue world (0.3, 0.5,
    0.9), a sun of 3 W/m^2 and `sun_angle` (radians) from above and behind the camera,
    and the camera at (0, -6, 0.8) looking along +y (lens 40 mm) at `resolution`."""
    from blend_scenes import build_scenes as bs
    ensure_registered()
    scene = bs.new_scene()
    world = bpy.data.worlds.new("Sky")
    bg = next(n for n in world.node_tree.nodes if n.bl_idname == "ShaderNodeBackground")
    bg.inputs["Color"].default_value = (0.3, 0.5, 0.9, 1.0)
    bg.inputs["Strength"].default_value = 1.0
    scene.world = world
    sun = bpy.data.lights.new("Sun", "SUN")
    sun.energy, sun.angle = 3.0, sun_angle
    sun_obj = bpy.data.objects.new("Sun", sun)
    sun_obj.rotation_euler = (0.6, 0.3, 0.0)
    scene.collection.objects.link(sun_obj)
    bs.camera(scene, "Camera", (0.0, -6.0, 0.8), 40.0, resolution)
    return scene


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
    prepare(variant)
    return shared.export_specula(bpy.context.scene)


def render_specula(variant: Variant, inject=None):
    """Render with Specula; `inject(core_scene, settings) -> (core_scene, settings)` may
    alter the exported scene first. Returns the core's RenderResult."""
    core_scene, settings, _ = specula_scene(variant)
    if inject is not None:
        core_scene, settings = inject(core_scene, settings)
    return shared.render_specula(core_scene, settings)


def configure_cycles(scene, samples, seed, max_bounces, time_limit=0.0):
    """Cycles unbiased (the CLI's settings) on the CPU with THREADS threads, pixels
    independent (the add-on's comparison settings)."""
    return shared.configure_cycles_for_comparison(scene, samples, seed, max_bounces,
                                                  time_limit=time_limit, threads=THREADS)


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


def render_cycles(variant: Variant, seed: int, samples: int | None = None):
    """One Cycles render of the variant: (H, W, 3) float32 and the settings record."""
    scene = prepare(variant)
    configure_cycles(scene, samples or variant.cycles_samples, seed, variant.max_bounces)
    rgba, _ = render_cycles_image(scene)
    expected = (variant.resolution[1], variant.resolution[0])
    if rgba.shape[:2] != expected:
        raise RuntimeError(f"Cycles wrote {rgba.shape[:2]}, expected {expected}")
    return rgba[..., :3], cycles_settings_record(scene)

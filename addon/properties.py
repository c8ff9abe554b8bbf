"""Specula's settings: one PropertyGroup per data type, stored in the .blend file."""

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty, PointerProperty

FRESNEL_ITEMS = (
    ("EXACT", "Exact", "Exact unpolarised dielectric Fresnel, as Cycles' Glass BSDF uses"),
    ("SCHLICK", "Schlick", "Schlick's approximation, as the course project used"),
)

FILTER_ITEMS = (
    ("BLACKMAN_HARRIS", "Blackman-Harris", "Blackman-Harris window (Cycles' default)"),
    ("BOX", "Box", "Box filter: each pixel averages its own square"),
    ("GAUSSIAN", "Gaussian", "Gaussian filter, truncated at 1.5 x width"),
)


class SpeculaSceneSettings(bpy.types.PropertyGroup):
    """Per-scene render settings, `scene.specula`."""

    samples: IntProperty(
        name="Samples", description="Samples per pixel to render (an upper bound when a time "
        "limit or target error stops the render first)", default=64, min=1, max=1 << 20,
        soft_max=4096)
    time_limit: FloatProperty(
        name="Time Limit", description="Stop after this many seconds (0 for no limit)",
        default=0.0, min=0.0, max=86400.0 * 7, soft_max=3600.0, subtype='TIME_ABSOLUTE',
        unit='TIME_ABSOLUTE')
    target_error: FloatProperty(
        name="Target Error", description="Stop once the estimated relative RMS error of the "
        "image falls below this (0 to always render every sample)", default=0.0, min=0.0,
        max=1.0, soft_max=0.2, precision=3, subtype='FACTOR')
    max_bounces: IntProperty(
        name="Max Bounces", description="Total bounces a path may take, counted as Cycles "
        "does (0 shows direct lighting only)", default=12, min=0, max=1024, soft_max=128)
    transparent_max_bounces: IntProperty(
        name="Transparent Bounces", description="Transparent surfaces (Transparent BSDF, "
        "alpha) a path or a shadow ray may cross, as Cycles' Light Paths > Max Bounces > "
        "Transparent; they do not count as bounces", default=8, min=0, max=1024,
        soft_max=128)
    seed: IntProperty(
        name="Seed", description="Seed of the sample sequence; the same seed renders the "
        "same image", default=0, min=0, max=(1 << 31) - 1)
    threads: IntProperty(
        name="Threads", description="Worker threads (0 uses every core)", default=0, min=0,
        max=1024, soft_max=64)
    use_light_tracing: BoolProperty(
        name="Caustics", description="Trace paths from emissive meshes through glass, mirrors "
        "and metal to the diffuse surfaces they light, and weigh them against path tracing: "
        "caustics from small lights converge instead of sparkling (only where the scene can "
        "have them; same image, less noise)", default=True)
    fresnel: EnumProperty(
        name="Fresnel", description="Fresnel model for glass", items=FRESNEL_ITEMS,
        default="EXACT")
    filter_type: EnumProperty(
        name="Pixel Filter", description="Pixel reconstruction filter, importance-sampled as "
        "Cycles does", items=FILTER_ITEMS, default="BLACKMAN_HARRIS")
    filter_width: FloatProperty(
        name="Filter Width", description="Pixel filter width in pixels", default=1.5,
        min=0.01, max=10.0, soft_max=3.0, subtype='PIXEL')
    film_transparent_glass: BoolProperty(
        name="Transparent Glass", description="With the film transparent, render the world "
        "behind glass transparent too (its reflections stay), as Cycles' Film > Transparent "
        "Glass: for compositing glass over another background", default=False)
    film_transparent_roughness: FloatProperty(
        name="Roughness Threshold", description="Glass rougher than this is rendered opaque "
        "against the transparent world (Cycles' Transparent Glass Roughness Threshold)",
        default=0.1, min=0.0, max=1.0)
    replicates: IntProperty(
        name="Replicates", description="Independent replicates of the sample sequence: the "
        "estimated error comes from how far they differ (more replicates: more to split "
        "across machines, but each keeps less of the sequence's stratification, so more "
        "noise at equal samples; 1: no estimate)", default=2, min=1, max=64)
    use_replicate_subset: BoolProperty(
        name="Replicate Subset", description="Render replicates First to Last only, to merge "
        "with renders of the others (python -m addon merge): a still split across machines",
        default=False)
    replicate_first: IntProperty(
        name="First", description="First replicate rendered", default=0, min=0, max=63)
    replicate_last: IntProperty(
        name="Last", description="Last replicate rendered", default=0, min=0, max=63)


class SpeculaViewLayerSettings(bpy.types.PropertyGroup):
    """Per-view-layer pass settings, `view_layer.specula`."""

    use_pass_error: BoolProperty(
        name="Estimated Error", description="Write the 'Specula Error' pass: each pixel's "
        "estimated standard error of luminance", default=True)
    use_pass_replicates: BoolProperty(
        name="Replicates", description="Write each replicate's mean (RGB) and sample count "
        "(A) as 'Specula Replicate N' passes, so that renders of disjoint replicates merge "
        "exactly (python -m addon merge)", default=False)


classes = (SpeculaSceneSettings, SpeculaViewLayerSettings)


def register():
    for cls in classes:
        bpy.utils.register_class(cls)
    bpy.types.Scene.specula = PointerProperty(
        type=SpeculaSceneSettings, name="Specula", description="Specula render settings")
    bpy.types.ViewLayer.specula = PointerProperty(
        type=SpeculaViewLayerSettings, name="Specula", description="Specula pass settings")


def unregister():
    del bpy.types.ViewLayer.specula
    del bpy.types.Scene.specula
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)

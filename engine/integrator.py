"""The path integrator: named bounce stages, compiled into one kernel made for each plan.

A wavefront of rays alternates between embree (closest hits, shadow rays) and `shade`, the
compiled bounce, which runs these stages per ray:

    handle_light_hits -> traverse_medium [-> scatter_in_medium: a vertex in a medium]
    -> handle_escaped | choose_closure -> surface_interaction -> handle_emission
    -> pass_through (transparent, volume boundary) | surface_ends (limit, holdout)
    -> russian_roulette
    -> sample_light (shadow ray queued) -> sample_bsdf -> spawn

and, where the plan has transparent surfaces, shadow rays take closest hits in turn and
`cross_transparent` carries them through the transparent ones.

Each stage is a function of its own that holds no formulas: those live once in the module
of their concept (sampling, media, bsdf, lights, environment, camera, terminator) and numba
inlines them. The stages read the scene's plan as the module constants below; `Kernel` compiles a
copy of the stages with one plan's values (specialise.py), so code for features a scene
lacks is not in its kernel at all. The generic kernel (every constant on) renders any scene
and is what a render starts with while its own kernel compiles in the background.

Blender's bounce counting: a camera ray hitting an emitter is depth 0; with max_bounces =
N, light sampling and scattering happen at vertices 0..N and vertex N+1 only adds emission
and background (Cycles' "terminate after transparent" at limit + 1). Emitters hit by BSDF
sampling after a non-delta bounce are weighted against next-event estimation with the
power heuristic; after delta bounces (mirror, metal, glass) and from the camera they count
fully. Russian roulette follows Cycles: none for the first two vertices, then survival
probability min(sqrt(max channel of throughput), 1).

Transparent surfaces (Cycles' Transparent BSDF, a Principled BSDF's alpha) are not bounces:
a path crosses them keeping its bounce count, its MIS state (the last scattering vertex's
origin, pdf and normal; Paths.mis_t is the distance from it) and its flags, and counts them
apart, against transparent_max_bounces; each crossing takes the sampler's next bounce
dimensions, as in Cycles. So with transparency each path carries its own bounce count.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from . import (bsdf, camera, caustics, environment, fresnel, lights, media, sampling, shading,
               terminator)
from .bsdf import DELTA_PDF
from .film import filter_offset
from .fresnel import specular_eta
from .jit import INLINE, JIT, cgutils, intrinsic, ir, types
from .lights import (_COS_ANGLE, _DIRECTION, _HIT_BSDF, _HIT_CAMERA, _POWER, _SUN_BSDF,
                     _SUN_CAMERA, _SUN_RADIANCE)
from .sampling import (BSDF, CLOSURE, DIM_FILTER, DIM_LENS, LIGHT_POINT, LIGHT_SELECT, LOBE,
                       ROULETTE,
                       bounce_dim, hash_combine, pixel_seed, power_heuristic, reverse_bits,
                       sample_1d, sample_2d)
from .scene import (BOUNDARY, DIFFUSE, GLASS, GLOSSY, HOLDOUT, METAL, MIRROR, MIX, NONE,
                    PRINCIPLED, ROUGH_GLASS, ROUGH_METAL, SHEEN, TRANSLUCENT, TRANSPARENT,
                    glass_tints)

# Shadow rays crossing transparent surfaces choose among a mix's shaders with the sampler
# scrambled by this (and the crossing's number), apart from the path's own choices.
SHADOW_CLOSURE_SALT = 0x5AD0C105
# A segment through a scattering medium samples its distance (and the channel it samples
# it in) from the sampler scrambled by this, apart from the dimensions of the vertex it
# ends at (a scattering vertex or the surface).
FREE_FLIGHT_SALT = 0xF1EE7F11
# A shadow ray moves past a transparent surface along itself by the ray offset / cos: the
# cosine is taken as at least this (a grazing ray moves at most 1000 offsets).
GRAZING_COS = 1e-3
# Spawned rays leave the surface by this fraction of the local coordinate magnitude:
# a few float32 ulps (embree intersects in float32), so the offset scales with the scene.
RAY_EPSILON = 2.0**-18
# Russian roulette starts after this many scatter events (Cycles: min_light_bounces + 1).
ROULETTE_MIN_BOUNCE = 2
# A GGX lobe this smooth (alpha_x alpha_y at most this) is a singular one to the Light Path
# node (Cycles' BSDF_ROUGHNESS_SQ_THRESH: bsdf_microfacet_sample's label).
SINGULAR_ALPHA_SQ = 2e-10

# ------------------------------------------------------------------ the plan's constants
# What a kernel compiles in (Plan.kernel_key): the generic kernel's values, all on.
PLAN_CONSTANTS = ("HAS_DIFFUSE", "HAS_MIRROR", "HAS_METAL", "HAS_GLASS", "HAS_ROUGH",
                  "HAS_ROUGH_GLASS", "HAS_ROUGH_METAL",
                  "HAS_DOF", "HAS_POLYGON_APERTURE", "HAS_SHADING_NORMALS", "HAS_EMISSION",
                  "HAS_LIGHT_SAMPLING", "HAS_LIGHT_OBJECTS", "HAS_LIGHT_HITS", "HAS_SUN_DISCS",
                  "HAS_ENVIRONMENT", "HAS_WORLD_COLOUR", "HAS_TERMINATOR", "HAS_LIGHT_GRID",
                  "HAS_LIGHT_IMPORTANCE", "HAS_LIGHT_TRACING", "HAS_TEXTURES", "HAS_NORMAL_MAPS",
                  "HAS_VOLUMES", "HAS_SCATTERING", "HAS_MIXES", "HAS_COATS", "HAS_TRANSPARENCY",
                  "HAS_TRANSLUCENT", "HAS_SHEEN", "HAS_LIGHT_PATH", "HAS_OREN_NAYAR",
                  "HAS_ANISOTROPY", "HAS_TRANSPARENT_GLASS", "HAS_THIN_FILM", "PROFILE",
                  "DEBUG")
HAS_DIFFUSE = HAS_MIRROR = HAS_METAL = HAS_GLASS = HAS_ROUGH = HAS_ROUGH_GLASS = True
HAS_ROUGH_METAL = True
HAS_DOF = HAS_POLYGON_APERTURE = HAS_SHADING_NORMALS = HAS_EMISSION = True
HAS_LIGHT_SAMPLING = HAS_LIGHT_OBJECTS = HAS_LIGHT_HITS = HAS_SUN_DISCS = True
HAS_ENVIRONMENT = HAS_WORLD_COLOUR = HAS_TERMINATOR = HAS_LIGHT_GRID = True
HAS_LIGHT_IMPORTANCE = True
HAS_LIGHT_TRACING = True  # caustics.py: light paths, and the path tracer's weight against them
HAS_TEXTURES = True  # shading.py: colours from shader programs (image textures)
HAS_NORMAL_MAPS = True  # shading.normal_map: tangent-space normal maps
HAS_VOLUMES = True  # media.py: media inside closed meshes (absorbing, emitting)
HAS_SCATTERING = True  # media.py: media that scatter (free-flight distances, phase functions)
HAS_MIXES = True  # mixed shaders (scene.Material.mix): each hit picks one component
HAS_COATS = True  # Principled coats (scene.Material.coated): layers over mixed components
HAS_TRANSPARENCY = True  # transparent surfaces: per-path bounce counts, shadow rays cross them
HAS_TRANSLUCENT = True  # Lambertian transmission (the Translucent BSDF)
HAS_SHEEN = True  # microfiber sheen lobes (the Sheen BSDF, Principled sheen layers)
HAS_LIGHT_PATH = True  # programs read the path's state (the Light Path node): paths keep it
HAS_OREN_NAYAR = True  # Diffuse BSDFs with roughness (bsdf.oren_nayar_ratio)
HAS_ANISOTROPY = True  # anisotropic GGX lobes (bsdf.anisotropic_layer)
# Film > Transparent Glass: camera paths stay camera paths through clear glass (clear_glass)
HAS_TRANSPARENT_GLASS = True
HAS_THIN_FILM = True  # Principled Thin Film (fresnel.thin_film_dielectric, thin_film_f82)
PROFILE = DEBUG = False  # cycle counts per stage; naming the stage of a NaN

# The stage DEBUG kernels name when a value goes non-finite (Tracer.explain_nonfinite).
STAGE_NAMES = ("", "generate camera rays", "handle light hits", "handle escaped rays",
               "surface interaction (depth/normal pass)", "handle emission", "sample light",
               "sample BSDF")

# ------------------------------------------------------------------ named structures
# The scene as the kernel reads it. Parts a plan does not use are None (not passed).
#   vertices (t, 3, 3), tri_normal (t, 3), tri_scale (t,), material_index (t,);
#   normals (t, 3, 3) and smooth (t,) with shading normals; object_index (t,) and
#   terminator_offset (objects,) with the terminator offset; uv (maps, t, 3, 3) float32
#   with textures; tangents (t, 3, 4) float32 (xyz, bitangent sign) with normal maps.
Geometry = namedtuple("Geometry", "vertices tri_normal tri_scale material_index normals "
                                  "smooth object_index terminator_offset uv tangents")
# kind, colour (k, 3), ior (k,), reflection_tint, transmission_tint, emission (k, 3), the
# rough materials' bsdf.LayerTables (None without rough materials) and the colour and
# emission programs' shading.ProgramTable (None without textures), and each normal map's
# strength (k,), its medium (k, media.COLUMNS: media.medium_table) and, for mixes, the two
# component rows (k, 2), fac and scale (k,), coats' IOR (k,) and tint (k, 3), and
# whether a glass has a Fresnel (k,) bool (not the Refraction BSDF) and how its colour
# tints it (k,) int (scene.Materials); with sheen, which mixes are sheen layers (k,) bool,
# each sheen lobe's layer (k,) int (-1: a Sheen BSDF) and bsdf.sheen_table (3, 32, 32);
# the Principled BSDF's Specular Tint on its dielectric Fresnel (k, 3; white elsewhere);
# each row's layer dimming its emission's share under a sheen or coat (k,) and that share
# (k, 3) (scene.Materials.emission_root, emission_share); with anisotropy, each row's
# anisotropy and rotation (k,) (scene.Materials.specular_anisotropy, anisotropic_rotation);
# with normal maps, whether a row's bump is its displacement's (k,) bool
# (scene.Materials.sets_normal); with thin films, each row's film (thickness in nm, IOR)
# (k, 2) (scene.Materials.thin_film).
MaterialTable = namedtuple("MaterialTable", "kind colour ior reflection_tint "
                                            "transmission_tint emission layers programs "
                                            "normal_strength medium mix_components "
                                            "mix_fac mix_scale coat_ior coat_tint fresnel "
                                            "glass_tints roughness sheen_layer sheen_parent "
                                            "sheen_ltc specular_tint emission_root "
                                            "emission_share anisotropy rotation "
                                            "sets_normal thin_film")
# caustics: caustics.CausticData (n_light 0 without light tracing); camera_media: the
# volume stack camera paths start with (media.MEDIA_STACK material rows, -1 empty);
# exact_fresnel: the render's Fresnel model for smooth glass (False: Schlick's);
# film_transparent: Blender's Film > Transparent (camera paths that reach the world leave
# the pixel transparent instead of seeing it); clear_glass: the largest GGX alpha_x alpha_y
# of a glass transmission camera paths see that transparency through (Cycles' Transparent
# Glass; -1: none, RenderSettings.clear_glass_threshold). Settings, not features, so they
# are read at run time: one kernel serves every value.
SceneData = namedtuple("SceneData", "geometry materials emitters world camera film_filter "
                                    "caustics camera_media exact_fresnel film_transparent "
                                    "clear_glass")
# One batch of paths (rows of the batch): the live rows, each pixel's sequence seed, the
# current ray in float64 and in embree's float32 buffers, throughput and the pdf of the
# last BSDF sample (inf: delta or camera), the passes, and, for the weight against light
# tracing (caustics.py): the camera ray's raster area per steradian until the first hit,
# then camera_side_density at the path's diffuse first vertex while every vertex after it
# is specular (0 otherwise), the chain's product of relative IORs, and the distance from
# the lens point to where the camera ray starts (per row); svm: the shader programs'
# registers (shading.MAX_REGISTERS floats, reused by every path of the batch); the media
# each path is inside (media.MEDIA_STACK material indices, -1 empty); with transparency
# (HAS_TRANSPARENCY), each path's bounce count, its transparent crossings, the distance
# from its last scattering vertex (o64, where its MIS state was set) to the ray's start,
# the volume boundaries it crossed (counted apart, as Cycles does) and whether it crossed
# a transparent surface since that vertex (Cycles' PATH_RAY_TRANSPARENT); with the Light Path
# node (HAS_LIGHT_PATH), the flags of the ray that arrives (shading.RAY_*, Cycles'
# PATH_RAY_*) and its diffuse, glossy and transmission bounces (n, 3); per row the
# transparency a transparent film keeps (handle_escaped); with Transparent Glass
# (HAS_TRANSPARENT_GLASS), whether each path has bounced only through clear glass
# (clear_glass).
Paths = namedtuple("Paths", "live pseed o64 d64 origin32 dir32 tmax32 throughput prev_pdf "
                            "radiance depth normal nonfinite caustic_q caustic_eta "
                            "camera_near prev_normal svm media bounce transparent mis_t "
                            "bounds via_transparent flags kind_bounces transparency "
                            "through_glass")
# Shadow rays (float32 for embree) and what each adds if it arrives; with transparency, its
# path's transparent crossings plus its own, the sampler bounce of its vertex and the media
# it is in (traced a segment at a time, media.MEDIA_STACK entries); with the Light Path
# node, its path's bounce and diffuse, glossy and transmission bounces at its vertex (n, 4).
ShadowRays = namedtuple("ShadowRays", "row origin direction tmax contrib transparent vertex "
                                      "media bounces")
# One surface vertex: hit point, geometric normal n and shading normal s (both on the
# incoming side; s after the material's normal map), the specular lobes' normal m, wo,
# front face, triangle, barycentrics, material, distance, the offset scale and the mesh's
# own shading normal b (s without the normal map).
Vertex = namedtuple("Vertex", "px py pz nx ny nz sx sy sz mx my mz wox woy woz front f u v "
                              "mat t scale bx by bz")


@intrinsic
def _cycles(typingctx):
    """The CPU's cycle counter (llvm.readcyclecounter), for the per-stage profile."""
    def codegen(context, builder, signature, args):
        fnty = ir.FunctionType(ir.IntType(64), [])
        fn = cgutils.get_or_insert_function(builder.module, fnty, "llvm.readcyclecounter")
        return builder.call(fn, [])
    return types.uint64(), codegen


# ------------------------------------------------------------------ stages
def _debug_mark(paths, row, stage, a, b, c):
    """DEBUG kernels: remember the first stage that left a non-finite value in a path."""
    if paths.nonfinite[row] == 0 and not (math.isfinite(a) and math.isfinite(b)
                                          and math.isfinite(c)):
        paths.nonfinite[row] = stage


def ray_offset(scale):
    """How far a spawned or shadow ray starts off its surface (or stops short of the
    light), for a local coordinate magnitude `scale`."""
    return RAY_EPSILON * max(scale, 1e-30)


def offset_scale(g, f, px, py, pz):
    """The magnitude ray offsets at point p of triangle f scale with: the triangle's size or
    p's coordinates, whichever is larger (float32 ulps grow with both)."""
    return max(g.tri_scale[f], max(abs(px), max(abs(py), abs(pz))))


def _add(paths, row, t0, t1, t2, l0, l1, l2, w):
    """Radiance l reaching the camera through throughput t with MIS weight w."""
    paths.radiance[row, 0] += t0 * l0 * w
    paths.radiance[row, 1] += t1 * l1 * w
    paths.radiance[row, 2] += t2 * l2 * w


def generate_camera_rays(pixels, sample, seed, centred, sc, paths):
    """Camera rays for pixel ids (n,) at index `sample` of the sequence of `seed`: a filter
    offset by Cycles' table (through the pixel's middle if `centred`, as Cycles' first
    sample), a lens point with depth of field, the ray in world space."""
    rev_sample = reverse_bits(np.uint64(sample))
    cam = sc.camera
    m = cam.world_from_camera
    for i in range(len(pixels)):
        ps = pixel_seed(pixels[i], seed)
        paths.pseed[i] = ps
        fx, fy = (0.5, 0.5) if centred else sample_2d(ps, rev_sample, DIM_FILTER)
        rx = (pixels[i] % cam.width) + 0.5 + filter_offset(fx, sc.film_filter)
        ry = (pixels[i] // cam.width) + 0.5 + filter_offset(fy, sc.film_filter)
        x, y = camera.raster_to_plane(rx, ry, cam)
        # (The generic kernel has the lens code and checks the camera at run time.)
        if HAS_DOF and cam.aperture > 0.0:
            ua, ub = sample_2d(ps, rev_sample, DIM_LENS)
            if HAS_POLYGON_APERTURE and cam.blades >= 3:
                lx, ly = camera.lens_polygon(ua, ub, cam)
            else:
                lx, ly = camera.lens_disk(ua, ub, cam)
            px, py, pz, dx, dy, dz, tmax = camera.thin_lens_ray(
                x, y, lx, ly, cam.focus, cam.clip_start, cam.clip_end, cam.ortho)
        else:
            lx = ly = 0.0
            px, py, pz, dx, dy, dz, tmax = camera.pinhole_ray(x, y, cam)
        if HAS_LIGHT_TRACING:
            paths.caustic_q[i] = camera.raster_per_steradian(dz, cam)
            paths.camera_near[i] = math.sqrt((px - lx) ** 2 + (py - ly) ** 2 + pz * pz)
        for j in range(3):
            paths.o64[i, j] = px * m[j, 0] + py * m[j, 1] + pz * m[j, 2] + cam.position[j]
            paths.origin32[i, j] = paths.o64[i, j]
            dj = dx * m[j, 0] + dy * m[j, 1] + dz * m[j, 2]
            paths.dir32[i, j] = dj
            paths.d64[i, j] = dj
        paths.tmax32[i] = min(tmax, 3e38)
        if HAS_VOLUMES:  # in the media around the camera (media.enclosing)
            for j in range(media.MEDIA_STACK):
                paths.media[i, j] = sc.camera_media[j]
        if HAS_LIGHT_PATH:
            paths.flags[i] = shading.RAY_CAMERA
            for j in range(3):
                paths.kind_bounces[i, j] = 0
        if DEBUG:
            _debug_mark(paths, i, 1, paths.d64[i, 0], paths.d64[i, 1], paths.d64[i, 2])


def handle_light_hits(i, row, depth, f, tfar, sc, paths, mis):
    """Light objects crossed before the surface (lights are transparent), then sun discs
    for escaped rays, MIS-weighted after soft bounces, each seen through the media of the
    segment up to it (whether or not the path scatters before: its light is a term of its
    own along the ray). Camera rays see the lights visible to the camera; other rays the
    lights with MIS on (Cycles)."""
    em = sc.emitters
    L = em.objects
    t0, t1, t2 = paths.throughput[i, 0], paths.throughput[i, 1], paths.throughput[i, 2]
    ox, oy, oz = paths.o64[i, 0], paths.o64[i, 1], paths.o64[i, 2]
    dx, dy, dz = paths.d64[i, 0], paths.d64[i, 1], paths.d64[i, 2]
    num_tri = len(em.v0)  # light entries 0..num_tri-1 are triangles, then the light objects
    if HAS_LIGHT_HITS:
        hit_seen = _HIT_CAMERA if depth == 0 else _HIT_BSDF
        t_surface = np.float64(tfar) if f >= 0 else np.float64(paths.tmax32[i])
        t_start = 0.0  # o64 is the scattering vertex, before any transparent crossings
        if HAS_TRANSPARENCY:
            t_start = paths.mis_t[i]
            t_surface += t_start
        for j in range(L.shape[0]):
            if L[j, hit_seen] == 0:
                continue
            th, l0, l1, l2 = lights.intersect_object(j, ox, oy, oz, dx, dy, dz, t_surface, L)
            if math.isinf(th) or th <= t_start:  # (found on an earlier segment)
                continue
            w = 1.0
            if mis:
                pdf_l = emitter_pmf(ox, oy, oz, paths.prev_normal[i], num_tri + j,
                                    em) * lights.object_pdf(
                    j, ox, oy, oz, dx, dy, dz, th, L)
                w = power_heuristic(paths.prev_pdf[i], pdf_l)
            elif HAS_LIGHT_TRACING and depth >= 2 and paths.caustic_q[i] > 0.0:
                w = caustic_weight(i, sc.caustics.source_of_light[j], 1.0, sc, paths)
            a0 = a1 = a2 = 1.0
            if HAS_VOLUMES:
                a0, a1, a2 = medium_transmittance(i, -1, False, False, th - t_start, sc, paths)
            _add(paths, row, t0 * a0, t1 * a1, t2 * a2, l0, l1, l2, w)
    if HAS_SUN_DISCS and f < 0:
        sun_seen = _SUN_CAMERA if depth == 0 else _SUN_BSDF
        for j in range(L.shape[0]):
            cos_half = L[j, _COS_ANGLE]
            if L[j, sun_seen] == 0 or not (dx * -L[j, _DIRECTION] + dy * -L[j, _DIRECTION + 1]
                                           + dz * -L[j, _DIRECTION + 2] >= cos_half):
                continue
            w = 1.0
            if mis:
                pdf_l = emitter_pmf(ox, oy, oz, paths.prev_normal[i], num_tri + j, em) / (
                    2.0 * np.pi * (1.0 - cos_half))
                w = power_heuristic(paths.prev_pdf[i], pdf_l)
            elif HAS_LIGHT_TRACING and depth >= 2 and paths.caustic_q[i] > 0.0:
                # The light path's cosine at its start disk: to the sun's axis.
                cos_y = -(dx * L[j, _DIRECTION] + dy * L[j, _DIRECTION + 1]
                          + dz * L[j, _DIRECTION + 2])
                w = caustic_weight(i, sc.caustics.source_of_light[j], cos_y, sc, paths)
            sr = L[j, _SUN_RADIANCE]
            a0 = a1 = a2 = 1.0
            if HAS_VOLUMES:
                a0, a1, a2 = medium_transmittance(i, -1, False, False, np.inf, sc, paths)
            _add(paths, row, t0 * a0, t1 * a1, t2 * a2, L[j, _POWER] * sr,
                 L[j, _POWER + 1] * sr, L[j, _POWER + 2] * sr, w)
    if DEBUG:
        _debug_mark(paths, row, 2, paths.radiance[row, 0], paths.radiance[row, 1],
                    paths.radiance[row, 2])


def leave_transparent(i, row, paths):
    """Camera path i ends leaving its pixel (row) transparent by the average of its
    throughput (Cycles' film_write_transparent and film_write_holdout)."""
    paths.transparency[row] += (paths.throughput[i, 0] + paths.throughput[i, 1]
                                + paths.throughput[i, 2]) / 3.0


def transparent_background(i, depth, paths):
    """Whether path i is still what Cycles calls PATH_RAY_TRANSPARENT_BACKGROUND: a camera
    path straight from the lens or on through transparent surfaces (depth 0), or with
    Transparent Glass one whose every bounce was a clear glass transmission."""
    return depth == 0 or (HAS_TRANSPARENT_GLASS and paths.through_glass[i])


def clear_glass(k, alpha, cos_n, threshold):
    """Whether a bounce off a surface of kind k (its rough lobe's GGX alpha) toward a
    direction at cos_n to its normal on the incoming side keeps a camera path seeing the
    film's transparency (Cycles' LABEL_TRANSMIT_TRANSPARENT, bsdf_sample): a transmission
    (cos_n < 0) through glass whose alpha_x alpha_y (0 for smooth glass) is at most the
    Transparent Glass threshold (negative: none is)."""
    if threshold < 0.0 or cos_n >= 0.0:
        return False
    return k == GLASS or (k == ROUGH_GLASS and alpha * alpha <= threshold)


def handle_escaped(i, row, depth, sc, paths, mis):
    """Escaped rays take the world: the environment map (the one of their kind of ray,
    world_image), MIS-weighted against its light sampling, or a constant colour (found by
    BSDF sampling only, as in Cycles). With a transparent film a camera ray (depth 0:
    straight from the lens or on through transparent surfaces, which keep it one; and one
    through clear glass, transparent_background) sees no world: it leaves the pixel
    transparent by its throughput's average (Cycles' integrate_background; the world
    still lights the scene)."""
    t0, t1, t2 = paths.throughput[i, 0], paths.throughput[i, 1], paths.throughput[i, 2]
    if sc.film_transparent and transparent_background(i, depth, paths):
        leave_transparent(i, row, paths)
        return
    if HAS_ENVIRONMENT and sc.emitters.env_entry >= 0:
        env = sc.emitters.environment
        dx, dy, dz = paths.d64[i, 0], paths.d64[i, 1], paths.d64[i, 2]
        u_e, v_e = environment.to_uv(dx, dy, dz, env.texture_from_world)
        l0, l1, l2 = environment.lookup(u_e, v_e, world_image(i, depth, env, paths))
        w = 1.0
        if mis:
            pdf_l = emitter_pmf(paths.o64[i, 0], paths.o64[i, 1], paths.o64[i, 2],
                                paths.prev_normal[i], sc.emitters.env_entry,
                                sc.emitters) * environment.pdf(u_e, v_e, env)
            w = power_heuristic(paths.prev_pdf[i], pdf_l)
        _add(paths, row, t0, t1, t2, l0, l1, l2, w)
    elif HAS_WORLD_COLOUR:
        _add(paths, row, t0, t1, t2, sc.world[0], sc.world[1], sc.world[2], 1.0)
    if DEBUG:
        _debug_mark(paths, row, 3, paths.radiance[row, 0], paths.radiance[row, 1],
                    paths.radiance[row, 2])


def world_image(i, depth, env, paths):
    """The map escaping path i sees: the one of its path flags where the world tells rays
    apart (a camera ray's at depth 0, which transparent surfaces keep; the others' flags
    are kept where the plan has the Light Path), else the one light samples see."""
    flags = shading.RAY_CAMERA if depth == 0 else (paths.flags[i] if HAS_LIGHT_PATH else 0)
    j = env.image_of_flags[flags]
    return env.image if j < 0 else env.ray_images[j]


def choose_closure(u, f, bu, bv, dx, dy, dz, mat, sc, paths):
    """Down a mix of shaders to one component, the second with probability fac (its
    program's value at the hit of a ray along d where it is textured; a coat's lobe with
    probability its weight x its albedo, coat_layer; one sample u in [0, 1) serves every
    level: its remainder is reused): (material, the weight (3,) the choices carry: the
    mixes' scales, a coat's)."""
    mt = sc.materials
    w0 = w1 = w2 = 1.0
    if HAS_TEXTURES and mt.kind[mat] == MIX:  # a factor may read the hit's geometry
        g = sc.geometry
        front = dx * g.tri_normal[f, 0] + dy * g.tri_normal[f, 1] + dz * g.tri_normal[f, 2] < 0
        sx, sy, sz = surface_normal(f, np.float64(bu), np.float64(bv),
                                    1.0 if front else -1.0, mat, sc, paths)
        shading.set_geometry(paths.svm, sx, sy, sz, -dx, -dy, -dz, not front)
    while mt.kind[mat] == MIX:
        fac = mt.mix_fac[mat]
        if HAS_TEXTURES:
            fac = shading.fac_at(mat, f, np.float64(bu), np.float64(bv), mt.programs,
                                 sc.geometry.uv, paths.svm, fac)
        if HAS_COATS and mt.coat_ior[mat] > 0.0:
            mat, u, c0, c1, c2 = coat_layer(u, f, bu, bv, dx, dy, dz, mat, fac, sc, paths)
            w0, w1, w2 = w0 * c0, w1 * c1, w2 * c2
            continue
        if HAS_SHEEN and mt.sheen_layer[mat]:
            mat, u, c = sheen_layer(u, f, bu, bv, dx, dy, dz, mat, fac, sc, paths)
            w0, w1, w2 = w0 * c, w1 * c, w2 * c
            continue
        s = mt.mix_scale[mat]
        w0, w1, w2 = w0 * s, w1 * s, w2 * s
        if u < fac:
            u = u / fac
            mat = mt.mix_components[mat, 1]
        else:
            u = (u - fac) / (1.0 - fac)
            mat = mt.mix_components[mat, 0]
    return mat, (w0, w1, w2)


def coat_layer(u, f, bu, bv, dx, dy, dz, mat, weight, sc, paths):
    """Cycles' Principled coat `mat` of Coat Weight `weight` at a hit along d. Its lobe
    (the mix's second component) weighs `weight`; what is below (the first) weighs
    1 - weight x A, A the coat lobe's albedo at the view about its normal as Cycles
    estimates it (closure_layering_weight), times the tint's (coat_weights). The lobe is
    chosen with probability weight x A, which leaves what is below the tint's weight
    alone. Returns (component, u's remainder, its weight (3))."""
    mt = sc.materials
    albedo, a0, a1, a2 = coat_weights(f, bu, bv, dx, dy, dz, mat, weight, sc, paths)
    p = weight * albedo
    if u < p:
        return mt.mix_components[mat, 1], u / p, 1.0 / albedo, 1.0 / albedo, 1.0 / albedo
    return mt.mix_components[mat, 0], (u - p) / (1.0 - p), a0, a1, a2


def coat_weights(f, bu, bv, dx, dy, dz, mat, weight, sc, paths):
    """The coat `mat` (Coat Weight `weight`) at a hit along d: (A, the coat lobe's albedo
    at the view about its normal (its Coat Normal's) as Cycles estimates it; the tint's
    attenuation of what is below, 3 values: bsdf.coat_layering)."""
    mt = sc.materials
    g = sc.geometry
    coat = mt.mix_components[mat, 1]
    u_b, v_b = np.float64(bu), np.float64(bv)
    nx, ny, nz = g.tri_normal[f, 0], g.tri_normal[f, 1], g.tri_normal[f, 2]
    sign = 1.0 if dx * nx + dy * ny + dz * nz < 0.0 else -1.0
    sx, sy, sz = shading_normal(f, u_b, v_b, sign, sc)
    if HAS_NORMAL_MAPS and shading.perturbs_normal(mt.programs, coat):  # the Coat Normal
        sx, sy, sz = perturbed_normal(f, u_b, v_b, sign, sx, sy, sz, coat, sc, paths)
    mx, my, mz = bsdf.valid_specular_normal(nx * sign, ny * sign, nz * sign, -dx, -dy, -dz,
                                            sx, sy, sz)
    roughness = -1.0  # the table's own
    if HAS_TEXTURES:
        roughness = shading.roughness_at(coat, f, u_b, v_b, mt.programs, g.uv, paths.svm,
                                         roughness)
    tint = mt.coat_tint[mat, 0], mt.coat_tint[mat, 1], mt.coat_tint[mat, 2]
    if HAS_TEXTURES:  # the Coat Tint may vary
        tint = shading.tint_at(mat, f, u_b, v_b, mt.programs, g.uv, paths.svm, tint[0],
                               tint[1], tint[2])
    return bsdf.coat_layering(-(dx * mx + dy * my + dz * mz), coat, mt.layers, roughness,
                              mt.coat_ior[mat], weight, tint)


def sheen_layer(u, f, bu, bv, dx, dy, dz, mat, weight, sc, paths):
    """Cycles' Principled sheen `mat` of Sheen Weight `weight` at a hit along d: its lobe
    (the mix's second component, bsdf.eval_sheen, which carries its tint and albedo)
    weighs `weight`; what is below keeps 1 - A (sheen_weight). The lobe is chosen with
    probability A, which leaves what is below its weight. Returns (component, u's
    remainder, the choice's weight)."""
    mt = sc.materials
    p = sheen_weight(f, bu, bv, dx, dy, dz, mat, weight, sc, paths)
    if u < p:
        return mt.mix_components[mat, 1], u / p, weight / p
    return mt.mix_components[mat, 0], (u - p) / (1.0 - p), 1.0


def sheen_weight(f, bu, bv, dx, dy, dz, mat, weight, sc, paths):
    """A, what the sheen `mat` (Sheen Weight `weight`) takes at a hit along d: weight x
    the largest channel of tint x albedo at the view (closure_layering_weight), at most
    1."""
    mt = sc.materials
    g = sc.geometry
    lobe = mt.mix_components[mat, 1]
    nx, ny, nz = g.tri_normal[f, 0], g.tri_normal[f, 1], g.tri_normal[f, 2]
    sign = 1.0 if dx * nx + dy * ny + dz * nz < 0.0 else -1.0
    u_b, v_b = np.float64(bu), np.float64(bv)
    sx, sy, sz = shading_normal(f, u_b, v_b, sign, sc)
    sx, sy, sz = sheen_normal(f, u_b, v_b, sign, sx, sy, sz, lobe, sc, paths)
    roughness = mt.roughness[lobe]
    t0, t1, t2 = mt.colour[lobe, 0], mt.colour[lobe, 1], mt.colour[lobe, 2]
    if HAS_TEXTURES:  # the Sheen Tint and Roughness may vary
        roughness = shading.roughness_at(lobe, f, u_b, v_b, mt.programs, g.uv, paths.svm,
                                         roughness)
        t0, t1, t2 = shading.colour_at(lobe, f, u_b, v_b, mt.programs, g.uv, paths.svm, t0,
                                       t1, t2)
    _, _, albedo = bsdf.sheen_ltc(mt.sheen_ltc, -(dx * sx + dy * sy + dz * sz), roughness)
    return min(weight * max(t0, max(t1, t2)) * albedo, 1.0)


def under_layers(mat, f, u, v, dx, dy, dz, l0, l1, l2, full, sc, paths):
    """Emission l of material row `mat` at a hit along d (or the light point a shadow ray
    along d reaches) with its share under a Principled BSDF's sheen and coat dimmed by
    them there: Cycles' "emission (attenuated by sheen and coat)". A coat's tint dims it
    always; the layers' albedo (each layer leaving what is below it its layering weight:
    sheen_weight, coat_weights) only with probability `full`: Cycles evaluates the
    emission of a light sample and of a path ending at the hit (its bounce limit, or
    Russian roulette deciding before the surface is shaded) with no room for closures,
    so no sheen or coat lobe is made and nothing is layered under them; the tint is
    applied all the same."""
    mt = sc.materials
    layer = mt.emission_root[mat]
    if layer < 0:
        return l0, l1, l2
    g = sc.geometry
    if HAS_TEXTURES:  # a layer's weight may read the geometry (as choose_closure)
        front = dx * g.tri_normal[f, 0] + dy * g.tri_normal[f, 1] + dz * g.tri_normal[f, 2] < 0
        sx, sy, sz = surface_normal(f, u, v, 1.0 if front else -1.0, layer, sc, paths)
        shading.set_geometry(paths.svm, sx, sy, sz, -dx, -dy, -dz, not front)
    d0 = d1 = d2 = kept = 1.0  # the tint's (per channel) and the albedo's
    while mt.kind[layer] == MIX:
        fac = mt.mix_fac[layer]
        if HAS_TEXTURES:
            fac = shading.fac_at(layer, f, u, v, mt.programs, g.uv, paths.svm, fac)
        if HAS_COATS and mt.coat_ior[layer] > 0.0:
            albedo, a0, a1, a2 = coat_weights(f, u, v, dx, dy, dz, layer, fac, sc, paths)
            kept *= 1.0 - fac * albedo
            d0, d1, d2 = d0 * a0, d1 * a1, d2 * a2
        elif HAS_SHEEN and mt.sheen_layer[layer]:
            if full > 0.0:
                kept *= 1.0 - sheen_weight(f, u, v, dx, dy, dz, layer, fac, sc, paths)
        else:
            break
        layer = mt.mix_components[layer, 0]
    k = 1.0 - full + full * kept
    d0, d1, d2 = d0 * k, d1 * k, d2 * k
    s = mt.emission_share
    return (l0 * (1.0 - s[mat, 0] + s[mat, 0] * d0), l1 * (1.0 - s[mat, 1] + s[mat, 1] * d1),
            l2 * (1.0 - s[mat, 2] + s[mat, 2] * d2))


def sheen_normal(f, u, v, sign, sx, sy, sz, lobe, sc, paths):
    """The normal of sheen lobe `lobe` at a hit whose mesh normal is s: its own (the
    Principled's Normal) mixed with the coat's by the Coat Weight where its layer lies over
    a coat (Cycles: safe_normalize(mix(N, coat_normal, coat_weight)))."""
    mt = sc.materials
    nx, ny, nz = sx, sy, sz
    if HAS_NORMAL_MAPS and shading.perturbs_normal(mt.programs, lobe):
        nx, ny, nz = perturbed_normal(f, u, v, sign, sx, sy, sz, lobe, sc, paths)
    if not HAS_COATS or mt.sheen_parent[lobe] < 0:
        return nx, ny, nz
    below = mt.mix_components[mt.sheen_parent[lobe], 0]
    if mt.kind[below] != MIX or not mt.coat_ior[below] > 0.0:
        return nx, ny, nz
    weight = mt.mix_fac[below]
    if HAS_TEXTURES:
        weight = shading.fac_at(below, f, u, v, mt.programs, sc.geometry.uv, paths.svm,
                                weight)
    coat = mt.mix_components[below, 1]
    cx, cy, cz = sx, sy, sz
    if HAS_NORMAL_MAPS and shading.perturbs_normal(mt.programs, coat):
        cx, cy, cz = perturbed_normal(f, u, v, sign, sx, sy, sz, coat, sc, paths)
    mx, my, mz = nx + weight * (cx - nx), ny + weight * (cy - ny), nz + weight * (cz - nz)
    length = math.sqrt(mx * mx + my * my + mz * mz)
    if not length > 1e-12:
        return nx, ny, nz
    return mx / length, my / length, mz / length


def surface_interaction(i, f, mat, tfar, bu, bv, sc, paths):
    """The hit point from the barycentrics in float64 (embree works in float32), the
    geometric normal and the shading normal flipped to the incoming side (the shading
    normal falls back to the geometric one where it degenerates), the specular lobes'
    normal (bsdf.valid_specular_normal) and the ray-offset scale; mat: the material
    shading it (the triangle's, or the component a mix chose)."""
    g = sc.geometry
    vt = g.vertices
    dx, dy, dz = paths.d64[i, 0], paths.d64[i, 1], paths.d64[i, 2]
    u = np.float64(bu)
    v = np.float64(bv)
    w0 = 1.0 - u - v
    px = w0 * vt[f, 0, 0] + u * vt[f, 1, 0] + v * vt[f, 2, 0]
    py = w0 * vt[f, 0, 1] + u * vt[f, 1, 1] + v * vt[f, 2, 1]
    pz = w0 * vt[f, 0, 2] + u * vt[f, 1, 2] + v * vt[f, 2, 2]
    nx, ny, nz = g.tri_normal[f, 0], g.tri_normal[f, 1], g.tri_normal[f, 2]
    front = dx * nx + dy * ny + dz * nz < 0.0
    sign = 1.0 if front else -1.0
    nx, ny, nz = nx * sign, ny * sign, nz * sign
    sx, sy, sz = shading_normal(f, u, v, sign, sc)
    bx, by, bz = sx, sy, sz
    if HAS_TEXTURES:
        shading.set_geometry(paths.svm, sx, sy, sz, -dx, -dy, -dz, not front)
    k = sc.materials.kind[mat]
    if HAS_SHEEN and k == SHEEN:
        sx, sy, sz = sheen_normal(f, u, v, sign, sx, sy, sz, mat, sc, paths)
    elif HAS_NORMAL_MAPS and shading.perturbs_normal(sc.materials.programs, mat):
        sx, sy, sz = perturbed_normal(f, u, v, sign, sx, sy, sz, mat, sc, paths)
    if HAS_NORMAL_MAPS and sc.materials.sets_normal[mat]:  # the displaced surface's own
        bx, by, bz = sx, sy, sz
        if HAS_TEXTURES:  # and the normal its nodes read (Cycles' SetNormal runs first)
            shading.set_geometry(paths.svm, sx, sy, sz, -dx, -dy, -dz, not front)
    mx, my, mz = sx, sy, sz
    if k != DIFFUSE and k != TRANSLUCENT and k != SHEEN:
        mx, my, mz = bsdf.valid_specular_normal(nx, ny, nz, -dx, -dy, -dz, sx, sy, sz)
    scale = offset_scale(g, f, px, py, pz)
    return Vertex(px, py, pz, nx, ny, nz, sx, sy, sz, mx, my, mz, -dx, -dy, -dz, front, f, u,
                  v, mat, np.float64(tfar), scale, bx, by, bz)


def surface_normal(f, u, v, sign, mat, sc, paths):
    """The normal the nodes of material row `mat` read as the surface's (Geometry's Normal,
    Fresnel, Layer Weight, a mix's factor among them) at barycentrics (u, v), on the side
    `sign`: the mesh's smooth normal, or the displaced one where the material has a
    displacement (Bump Only): Cycles' SetNormal runs before the shader's other nodes."""
    sx, sy, sz = shading_normal(f, u, v, sign, sc)
    if HAS_NORMAL_MAPS and sc.materials.sets_normal[mat] and \
            sc.materials.programs.height[mat, 0] >= 0:
        sx, sy, sz = bumped_normal(f, u, v, sign, sx, sy, sz, mat, sc, paths)
    return sx, sy, sz


def shading_normal(f, u, v, sign, sc):
    """The mesh's smooth normal at barycentrics (u, v) of triangle f, turned to the side
    `sign` of its geometric normal; the geometric normal on flat triangles or where the
    interpolation degenerates."""
    g = sc.geometry
    nx, ny, nz = g.tri_normal[f, 0] * sign, g.tri_normal[f, 1] * sign, g.tri_normal[f, 2] * sign
    if HAS_SHADING_NORMALS and g.smooth[f]:
        nm = g.normals
        w0 = 1.0 - u - v
        ax = (w0 * nm[f, 0, 0] + u * nm[f, 1, 0] + v * nm[f, 2, 0]) * sign
        ay = (w0 * nm[f, 0, 1] + u * nm[f, 1, 1] + v * nm[f, 2, 1]) * sign
        az = (w0 * nm[f, 0, 2] + u * nm[f, 1, 2] + v * nm[f, 2, 2]) * sign
        length = math.sqrt(ax * ax + ay * ay + az * az)
        if length > 1e-12:
            return ax / length, ay / length, az / length
    return nx, ny, nz


def perturbed_normal(f, u, v, sign, sx, sy, sz, mat, sc, paths):
    """The shading normal s after material mat's Normal Map node, then its Bump node
    (whose Normal input is the map's result, or s), each where it has one."""
    pt = sc.materials.programs
    if pt.normal[mat, 0] >= 0:
        sx, sy, sz = mapped_normal(f, u, v, sign, sx, sy, sz, mat, sc, paths)
    if pt.height[mat, 0] >= 0:
        sx, sy, sz = bumped_normal(f, u, v, sign, sx, sy, sz, mat, sc, paths)
    return sx, sy, sz


def bumped_normal(f, u, v, sign, nx, ny, nz, mat, sc, paths):
    """The normal n (on the incoming side `sign`) after material mat's Bump node at the
    hit: its height program run at the hit and a small step along each of the triangle's
    edges from corner 0 (shading.BUMP_STEP), as Cycles runs the height's nodes at the hit
    and at offsets along the ray differentials: every coordinate a program reads is
    interpolated over the triangle, so a step in barycentrics is a step in position and
    in every coordinate. The bump is taken on the front side and turned to the incoming
    one: seen from inside, a bumped glass is the same surface (Cycles renders it so; the
    node's formula on the turned normal would tilt it the other way, and a bumped glass
    ball's caustic disagreed with Cycles' by |z| 28 that way)."""
    g = sc.geometry
    pt = sc.materials.programs
    vt = g.vertices
    h, strength = shading.height_at(mat, f, u, v, pt, g.uv, paths.svm)
    step = shading.BUMP_STEP
    h_e, _ = shading.height_at(mat, f, u + step, v, pt, g.uv, paths.svm)
    h_f, _ = shading.height_at(mat, f, u, v + step, pt, g.uv, paths.svm)
    bx, by, bz = shading.bump_normal(
        nx * sign, ny * sign, nz * sign, vt[f, 1, 0] - vt[f, 0, 0], vt[f, 1, 1] - vt[f, 0, 1],
        vt[f, 1, 2] - vt[f, 0, 2], vt[f, 2, 0] - vt[f, 0, 0], vt[f, 2, 1] - vt[f, 0, 1],
        vt[f, 2, 2] - vt[f, 0, 2], (h_e - h) / step, (h_f - h) / step, strength)
    return bx * sign, by * sign, bz * sign


def mapped_normal(f, u, v, sign, sx, sy, sz, mat, sc, paths):
    """The shading normal after material mat's tangent-space normal map at the hit (Cycles'
    svm_node_normal_map): the map's colour on the interpolated tangent frame around the
    mesh's front-side normal (unnormalised, the geometric one on flat triangles), turned
    to the incoming side (sign) and blended toward s by the node's strength; s itself
    where that degenerates."""
    g = sc.geometry
    w0 = 1.0 - u - v
    c0, c1, c2 = shading.normal_at(mat, f, u, v, sc.materials.programs, g.uv, paths.svm,
                                   0.5, 0.5, 1.0)
    tg = g.tangents
    tx = w0 * tg[f, 0, 0] + u * tg[f, 1, 0] + v * tg[f, 2, 0]
    ty = w0 * tg[f, 0, 1] + u * tg[f, 1, 1] + v * tg[f, 2, 1]
    tz = w0 * tg[f, 0, 2] + u * tg[f, 1, 2] + v * tg[f, 2, 2]
    bitangent_sign = w0 * tg[f, 0, 3] + u * tg[f, 1, 3] + v * tg[f, 2, 3]
    nx, ny, nz = g.tri_normal[f, 0], g.tri_normal[f, 1], g.tri_normal[f, 2]
    if HAS_SHADING_NORMALS and g.smooth[f]:
        nm = g.normals
        nx = w0 * nm[f, 0, 0] + u * nm[f, 1, 0] + v * nm[f, 2, 0]
        ny = w0 * nm[f, 0, 1] + u * nm[f, 1, 1] + v * nm[f, 2, 1]
        nz = w0 * nm[f, 0, 2] + u * nm[f, 1, 2] + v * nm[f, 2, 2]
    ax, ay, az = shading.normal_map(c0, c1, c2, tx, ty, tz, bitangent_sign, nx, ny, nz)
    ax, ay, az = ax * sign, ay * sign, az * sign
    strength = sc.materials.normal_strength[mat]
    if strength != 1.0:
        ax, ay, az = sx + (ax - sx) * strength, sy + (ay - sy) * strength, \
            sz + (az - sz) * strength
    length = math.sqrt(ax * ax + ay * ay + az * az)
    if not (length > 1e-12 and math.isfinite(length)):
        return sx, sy, sz
    return ax / length, ay / length, az / length


def surface_colour(x, sc, paths):
    """The material's colour at vertex x (diffuse, base, glossy or metal colour): its shader
    program's result where it has one (shading.py: image textures), else the table's."""
    mt = sc.materials
    c0, c1, c2 = mt.colour[x.mat, 0], mt.colour[x.mat, 1], mt.colour[x.mat, 2]
    if HAS_TEXTURES:
        c0, c1, c2 = shading.colour_at(x.mat, x.f, x.u, x.v, mt.programs, sc.geometry.uv,
                                       paths.svm, c0, c1, c2)
    return c0, c1, c2


def rough_lobe(x, k, c, sc, paths):
    """The rough lobe (bsdf.Layer) of vertex x of kind k with surface colour c: the
    Principled or Glossy layer, rough metal, or rough glass on the side wo sees, at the
    roughness its program gives here where it has one (anisotropic where it is), under its
    thin film where it has one; empty for others."""
    film_d = film_n = 0.0
    if HAS_THIN_FILM:
        film_d, film_n = film_at(x, k, sc, paths)
    lobe = lobe_at(x, k, c, sc, paths, film_d, film_n)
    if film_d > 0.0 and k != PRINCIPLED:  # (the Principled layer's estimate reads its film)
        return bsdf.filmed_layer(lobe, film_d, film_n)
    return lobe


def film_at(x, k, sc, paths):
    """Vertex x's thin film: its thickness (nm; 0: none, below fresnel.THIN_FILM_MIN) and
    IOR relative to the side wo sees, its program's where it varies. On a glass's back
    face the IOR is over the glass's (Cycles' adjust_thin_film_ior_at_backface: the stack
    glass | film | air reflects as air | film / glass | 1 / glass does)."""
    mt = sc.materials
    d, n = mt.thin_film[x.mat, 0], mt.thin_film[x.mat, 1]
    if HAS_TEXTURES and mt.programs.thin_film[x.mat, 0] >= 0:
        d, n = shading.pair_at(mt.programs.thin_film, x.mat, x.f, x.u, x.v, mt.programs,
                               sc.geometry.uv, paths.svm, d, n)
        n = max(n, fresnel.MIN_IOR)
    if not d > fresnel.THIN_FILM_MIN:
        return 0.0, 1.0
    if (k == GLASS or k == ROUGH_GLASS) and not x.front:
        return d, n / mt.ior[x.mat]
    return d, n


def lobe_at(x, k, c, sc, paths, film_d, film_n):
    """rough_lobe; a Principled layer under the film given (film_d > 0: its thickness)."""
    mt = sc.materials
    mu = min(max(x.mx * x.wox + x.my * x.woy + x.mz * x.woz, 0.0), 1.0)
    textured = tinted = False
    roughness = -1.0  # the table's own
    if HAS_TEXTURES and (k == PRINCIPLED or k == GLOSSY or k == ROUGH_METAL
                         or k == ROUGH_GLASS):
        textured = mt.programs.colour[x.mat, 0] >= 0
        tinted = mt.programs.tint[x.mat, 0] >= 0
        roughness = shading.roughness_at(x.mat, x.f, x.u, x.v, mt.programs, sc.geometry.uv,
                                         paths.svm, roughness)
    ax = ay = tx = ty = tz = 0.0
    if HAS_ANISOTROPY and (k == PRINCIPLED or k == GLOSSY or k == ROUGH_METAL):
        ax, ay, tx, ty, tz = anisotropy_at(x, k, roughness, sc, paths)
        if ax > 0.0:  # the tables at Cycles' roughness for them, (alpha_x alpha_y)^(1/4)
            roughness = math.sqrt(math.sqrt(ax * ay))
    if HAS_ROUGH and (k == PRINCIPLED or k == GLOSSY):
        sigma = -1.0  # the table's Diffuse Roughness
        if HAS_OREN_NAYAR and HAS_TEXTURES:
            sigma = shading.diffuse_roughness_at(x.mat, x.f, x.u, x.v, mt.programs,
                                                 sc.geometry.uv, paths.svm, sigma)
        eta = specular_eta_at(x, sc, paths) if k == PRINCIPLED else mt.ior[x.mat]
        lobe = bsdf.layer_at(x.mat, mu, eta, mt.layers, textured, c[0], c[1], c[2],
                             roughness, specular_tint_at(x, sc, paths), sigma, film_d, film_n)
        if HAS_ANISOTROPY and ax > 0.0:
            return bsdf.anisotropic_layer(lobe, ax, ay, tx, ty, tz)
        return lobe
    if HAS_ROUGH_METAL and k == ROUGH_METAL:  # (a varying tint needs its own Fss too)
        lobe = bsdf.metal_layer_at(x.mat, mu, mt.layers, textured or tinted, c[0], c[1],
                                   c[2], roughness, metal_edge_at(x, sc, paths))
        if HAS_ANISOTROPY and ax > 0.0:
            return bsdf.anisotropic_layer(lobe, ax, ay, tx, ty, tz)
        return lobe
    if HAS_ROUGH_GLASS and k == ROUGH_GLASS:
        tints = glass_tints_at(x, c, textured, sc)
        return bsdf.glass_layer_at(x.mat, mu, x.front, mt.ior[x.mat], mt.layers, tints[:3],
                                   tints[3:], roughness, mt.fresnel[x.mat], textured,
                                   specular_tint_at(x, sc, paths))
    return bsdf.no_layer()


def anisotropy_at(x, k, roughness, sc, paths):
    """Vertex x's anisotropic GGX: (alpha_x, alpha_y, tangent (3)) from its anisotropy,
    rotation and tangent here (their programs' results where they vary) and its roughness
    (< 0: the material's constant), as Cycles' svm_node_closure_bsdf makes them: the
    tangent turned by the rotation about the Principled BSDF's normal (its shading
    normal) or the Glossy BSDF's (the valid specular one); alpha_x 0 where the lobe is
    isotropic, or its tangent lies along the normal."""
    mt = sc.materials
    if mt.programs.tangent[x.mat, 0] < 0:
        return 0.0, 0.0, 0.0, 0.0, 0.0
    principled = k != GLOSSY
    a, rotation = shading.pair_at(mt.programs.anisotropy, x.mat, x.f, x.u, x.v, mt.programs,
                                  sc.geometry.uv, paths.svm, mt.anisotropy[x.mat],
                                  mt.rotation[x.mat])
    if not bsdf.is_anisotropic(a, principled):
        return 0.0, 0.0, 0.0, 0.0, 0.0
    r = roughness if roughness >= 0.0 else mt.roughness[x.mat]
    ax, ay = bsdf.anisotropic_alphas(r, a, principled)
    tx, ty, tz = shading.tangent_at(x.mat, x.f, x.u, x.v, mt.programs, sc.geometry.uv,
                                    paths.svm)
    if rotation != 0.0:
        nx, ny, nz = (x.sx, x.sy, x.sz) if principled else (x.mx, x.my, x.mz)
        tx, ty, tz = shading.axis_rotation(tx, ty, tz, nx, ny, nz, rotation * 2.0 * np.pi)
    if not bsdf.tangent_frame(x.mx, x.my, x.mz, tx, ty, tz)[6]:
        return 0.0, 0.0, 0.0, 0.0, 0.0
    return ax, ay, tx, ty, tz


def specular_eta_at(x, sc, paths):
    """The relative IOR of Principled vertex x's dielectric layer: fresnel.specular_eta of
    its IOR and Specular IOR Level here where either varies (their program), else its
    material's constant."""
    mt = sc.materials
    if HAS_TEXTURES and mt.programs.specular_ior[x.mat, 0] >= 0:
        ior, level = shading.pair_at(mt.programs.specular_ior, x.mat, x.f, x.u, x.v,
                                     mt.programs, sc.geometry.uv, paths.svm, 1.5, 0.5)
        return specular_eta(ior, level)
    return mt.ior[x.mat]


def specular_tint_at(x, sc, paths):
    """The Principled BSDF's Specular Tint on vertex x's dielectric Fresnel (3 values; its
    program's result where it varies; white for every other material)."""
    mt = sc.materials
    st = mt.specular_tint
    s0, s1, s2 = st[x.mat, 0], st[x.mat, 1], st[x.mat, 2]
    if HAS_TEXTURES:
        s0, s1, s2 = shading.tint_at(x.mat, x.f, x.u, x.v, mt.programs, sc.geometry.uv,
                                     paths.svm, s0, s1, s2)
    return s0, s1, s2


def metal_edge_at(x, sc, paths):
    """A metal vertex's Specular Tint, the edge its F82 Fresnel bends toward (3 values, at
    most 1 as Cycles takes it; its program's result where it varies)."""
    mt = sc.materials
    e = mt.reflection_tint
    e0, e1, e2 = e[x.mat, 0], e[x.mat, 1], e[x.mat, 2]
    if HAS_TEXTURES and mt.programs.tint[x.mat, 0] >= 0:
        e0, e1, e2 = shading.tint_at(x.mat, x.f, x.u, x.v, mt.programs, sc.geometry.uv,
                                     paths.svm, e0, e1, e2)
        e0, e1, e2 = min(e0, 1.0), min(e1, 1.0), min(e2, 1.0)
    return e0, e1, e2


def glass_tints_at(x, c, textured, sc):
    """The reflection and transmission tints (3 values each) of glass vertex x: from its
    colour c here where that is textured (scene.glass_tints), else the table's."""
    mt = sc.materials
    if textured:
        return glass_tints(mt.glass_tints[x.mat], c[0], c[1], c[2])
    r, t = mt.reflection_tint[x.mat], mt.transmission_tint[x.mat]
    return r[0], r[1], r[2], t[0], t[1], t[2]


def handle_emission(i, row, depth, x, sc, paths, mis, max_bounces):
    """Emission of the hit triangle (two-sided), MIS-weighted against light sampling after
    soft bounces, and against light tracing at the end of a diffuse -> specular chain
    from the camera (caustics.py). Under a Principled sheen or coat it is dimmed as Cycles
    dims it (under_layers) for a path that goes on, with the chance that Cycles' would
    (its Russian roulette's, before this surface's own weights; none past the bounce
    limit)."""
    e = sc.materials.emission
    le0, le1, le2 = e[x.mat, 0], e[x.mat, 1], e[x.mat, 2]
    if not max(le0, max(le1, le2)) > 0:  # (a textured emission's constant is > 0 too)
        return
    if HAS_TEXTURES:
        le0, le1, le2 = shading.emission_at(x.mat, x.f, x.u, x.v, sc.materials.programs,
                                            sc.geometry.uv, paths.svm, le0, le1, le2)
    if HAS_COATS or HAS_SHEEN:
        if sc.materials.emission_root[x.mat] >= 0:
            full = continuation_probability(i, depth, max_bounces, paths)
            le0, le1, le2 = under_layers(np.int64(x.mat), np.int64(x.f), x.u, x.v, -x.wox,
                                         -x.woy, -x.woz, le0, le1, le2, full, sc, paths)
    w = 1.0
    if mis:
        em = sc.emitters
        cos_l = abs(x.nx * x.wox + x.ny * x.woy + x.nz * x.woz)
        entry = em.entry_of_triangle[x.f]
        pm = 0.0
        if entry >= 0:
            pm = emitter_pmf(x.px + x.wox * x.t, x.py + x.woy * x.t, x.pz + x.woz * x.t,
                             paths.prev_normal[i], entry, em)
        pdf_l = pm / em.area_by_triangle[x.f] * x.t * x.t / max(cos_l, 1e-300)
        w = power_heuristic(paths.prev_pdf[i], pdf_l)
    elif HAS_LIGHT_TRACING and depth >= 2 and paths.caustic_q[i] > 0.0:
        # Emissive triangles are the light tracer's first sources, in entry order.
        w = caustic_weight(i, sc.emitters.entry_of_triangle[x.f], 1.0, sc, paths)
    _add(paths, row, paths.throughput[i, 0], paths.throughput[i, 1], paths.throughput[i, 2],
         le0, le1, le2, w)
    if DEBUG:
        _debug_mark(paths, row, 5, paths.radiance[row, 0], paths.radiance[row, 1],
                    paths.radiance[row, 2])


def caustic_weight(i, source, cos_y, sc, paths):
    """w_PT of path i, which reached light-tracer source `source` (-1: not one) at the end
    of a camera -> Lambertian -> ... -> specular chain (caustics.py); cos_y divides p_emit
    (a sun's: the cosine at its start disk; 1 for the others)."""
    ca = sc.caustics
    if source < 0 or source >= len(ca.pdf_emit) or not cos_y > 0.0:
        return 1.0
    eta = paths.caustic_eta[i]
    return caustics.path_tracing_weight(ca.n_light, ca.pdf_emit[source] / cos_y,
                                        1.0 / (eta * eta), paths.caustic_q[i])


def continuation_probability(i, depth, max_bounces, paths):
    """Cycles' chance that path i goes on from the surface it arrives at
    (path_state_continuation_probability, decided as the ray arrives): none past the bounce
    limit; certain for the first bounces or, for a ray that crossed a transparent surface
    since its last scattering vertex, while the path has crossed at most one (Cycles'
    min_bounce and transparent_min_bounce, each its setting 0 plus one); else
    min(sqrt(max channel of the throughput), 1)."""
    if depth > max_bounces:
        return 0.0
    if HAS_TRANSPARENCY and paths.via_transparent[i]:
        if paths.transparent[i] <= 1:
            return 1.0
    elif depth < ROULETTE_MIN_BOUNCE:
        return 1.0
    t = paths.throughput
    return min(math.sqrt(max(t[i, 0], max(t[i, 1], t[i, 2]))), 1.0)


def russian_roulette(depth, vertex, t0, t1, t2, pseed, rev_sample):
    """Cycles' rule: none for the first bounces, then survival with probability
    q = min(sqrt(max channel), 1) and the survivor divided by q (so at most sqrt(t): a small
    q never blows a path up); vertex: the sampler's bounce. Returns (survives,
    throughput)."""
    if depth < ROULETTE_MIN_BOUNCE:
        return True, t0, t1, t2
    q = min(math.sqrt(max(t0, max(t1, t2))), 1.0)
    if not sample_1d(pseed, rev_sample, bounce_dim(vertex, ROULETTE)) < q:
        return False, t0, t1, t2
    return True, t0 / q, t1 / q, t2 / q


def emitter_pmf(px, py, pz, normal, entry, em):
    """The probability of choosing emitter `entry` from point p whose shading normal (on
    the side it reflects to; zeros: any side) is `normal`: the many-lights grid's, the few
    lights' importance, or the global distribution alone."""
    if HAS_LIGHT_GRID and em.grid > 0:
        return lights.entry_pmf(px, py, pz, entry, em.pmf, em.grid, em.lo, em.cell,
                                em.local_pmf, em.has_mass)
    if HAS_LIGHT_IMPORTANCE and len(em.bounds) > 0:
        return lights.importance_pmf(px, py, pz, normal[0], normal[1], normal[2], entry,
                                     em.pmf, em.bounds)
    return em.pmf[entry]


def lit_side(x, sc):
    """The normal whose side light reaches vertex x from, for choosing emitters by their
    importance there: the shading normal, its opposite for Lambertian transmission, or
    zeros (both sides) where the BSDF both reflects and transmits."""
    if HAS_ROUGH_GLASS and sc.materials.kind[x.mat] == ROUGH_GLASS:
        return 0.0, 0.0, 0.0
    if HAS_TRANSLUCENT and sc.materials.kind[x.mat] == TRANSLUCENT:
        return -x.sx, -x.sy, -x.sz
    return x.sx, x.sy, x.sz


def sample_emitter(x, u_sel, ua, ub, sc, paths):
    """An emitter chosen from the vertex (by power, or by the grid's local distribution)
    and a point or direction on it: (wi, distance (inf: none), radiance / (selection x
    pdf), combined pdf, length scale at the light for the shadow ray's offset)."""
    em = sc.emitters
    if len(em.pmf) == 0:  # the generic kernel on a scene without emitters
        return 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    if HAS_LIGHT_GRID and em.grid > 0:
        e, p_sel = lights.choose(x.px, x.py, x.pz, u_sel, em.pmf, em.cdf, em.grid, em.lo,
                                 em.cell, em.local_pmf, em.local_cdf_flat, em.has_mass)
    elif HAS_LIGHT_IMPORTANCE and len(em.bounds) > 0:
        nx, ny, nz = lit_side(x, sc)
        e, p_sel = lights.choose_by_importance(x.px, x.py, x.pz, nx, ny, nz, u_sel, em.pmf,
                                               em.cdf, em.bounds)
    else:
        e = lights.sample_cdf(em.cdf, u_sel)
        p_sel = em.pmf[e]
    num_tri = len(em.v0)
    light_scale = 0.0
    if HAS_EMISSION and e < num_tri:
        wx, wy, wz, dist, q0, q1, q2, pdf = lights.sample_triangle(e, x.px, x.py, x.pz, ua, ub,
                                                                   em)
        light_scale = em.scale[e]
        if HAS_TEXTURES and pdf > 0.0:
            if HAS_LIGHT_PATH:
                shading.set_ray_length(paths.svm, dist)
            q0, q1, q2 = textured_emitter(e, ua, ub, pdf, q0, q1, q2, sc, paths)
        if HAS_COATS or HAS_SHEEN:
            f = em.triangle_of_entry[e]
            if pdf > 0.0 and sc.materials.emission_root[sc.geometry.material_index[f]] >= 0:
                _, b1, b2 = sampling.uniform_triangle(ua, ub)
                q0, q1, q2 = under_layers(np.int64(sc.geometry.material_index[f]),
                                          np.int64(f), b1, b2, wx, wy, wz, q0, q1, q2, 0.0,
                                          sc, paths)
    elif HAS_ENVIRONMENT and e == em.env_entry and e >= 0:
        wx, wy, wz, dist, q0, q1, q2, pdf = lights.sample_environment(ua, ub, em.environment)
    elif HAS_LIGHT_OBJECTS:
        wx, wy, wz, dist, q0, q1, q2, pdf = lights.sample_object(e - num_tri, x.px, x.py, x.pz,
                                                                 ua, ub, em.objects)
        if not math.isinf(dist):
            light_scale = max(abs(x.px + wx * dist), max(abs(x.py + wy * dist),
                                                         abs(x.pz + wz * dist)))
    else:
        return 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    ps = p_sel if p_sel > 0 else 1.0
    return wx, wy, wz, dist, q0 / ps, q1 / ps, q2 / ps, pdf * p_sel, light_scale


def textured_emitter(e, ua, ub, pdf, q0, q1, q2, sc, paths):
    """Radiance / pdf of the point (ua, ub) on emissive triangle entry e
    (lights.sample_triangle's point) where its material's emission is textured; else q."""
    f = sc.emitters.triangle_of_entry[e]
    mat = sc.geometry.material_index[f]
    if sc.materials.programs.emission[mat, 0] < 0:
        return q0, q1, q2
    _, b1, b2 = sampling.uniform_triangle(ua, ub)
    l0, l1, l2 = shading.emission_at(mat, f, b1, b2, sc.materials.programs, sc.geometry.uv,
                                     paths.svm, 0.0, 0.0, 0.0)
    return l0 / pdf, l1 / pdf, l2 / pdf


def shadow_origin(x, wx, wy, wz, sc):
    """Where the shadow ray toward w starts: lifted toward the smooth surface near the
    terminator (terminator.py), then offset to w's side of the surface."""
    ox, oy, oz = x.px, x.py, x.pz
    if HAS_TERMINATOR:
        g = sc.geometry
        if g.smooth[x.f]:
            cutoff = g.terminator_offset[g.object_index[x.f]]
            if cutoff > 0.0:
                amount, gx, gy, gz = terminator.offset_amount(cutoff, x.sx, x.sy, x.sz, x.nx,
                                                              x.ny, x.nz, wx, wy, wz)
                if amount > 0.0:
                    lx, ly, lz = terminator.smooth_surface_offset(
                        g.vertices[x.f], g.normals[x.f], 1.0 - x.u - x.v, x.u, x.v, gx, gy, gz)
                    ox, oy, oz = ox + lx * amount, oy + ly * amount, oz + lz * amount
    eps = ray_offset(x.scale)
    if wx * x.nx + wy * x.ny + wz * x.nz < 0.0:
        eps = -eps
    return ox + eps * x.nx, oy + eps * x.ny, oz + eps * x.nz


def sample_light(i, row, depth, x, lobe, c, sc, paths, shadow, n_shadow, rev_sample):
    """Next-event estimation at a diffuse or rough vertex: an emitter, the BSDF toward it,
    MIS against BSDF sampling (delta lights take it all); the shadow ray, from the offset
    origin to just short of the sampled point, is queued. Returns the shadow rays queued."""
    ps = paths.pseed[row]
    u_sel = sample_1d(ps, rev_sample, bounce_dim(depth, LIGHT_SELECT))
    ua, ub = sample_2d(ps, rev_sample, bounce_dim(depth, LIGHT_POINT))
    if HAS_LIGHT_PATH:  # a light's emission: no flags, one bounce on (PATH_RAY_EMISSION)
        bounce = paths.bounce[i] if HAS_TRANSPARENCY else depth
        length = paths.svm[shading.LIGHT_PATH + 8]  # the surface's, put back below
        light_path_registers(i, 0, 0.0, bounce + 1, paths)
    wx, wy, wz, dist, q0, q1, q2, pdf_l, light_scale = sample_emitter(x, u_sel, ua, ub, sc,
                                                                      paths)
    if HAS_LIGHT_PATH:  # the surface's own state again, for its BSDF's programs
        light_path_registers(i, paths.flags[i], length, bounce, paths)
    g0 = g1 = g2 = pdf_b = 0.0
    k = sc.materials.kind[x.mat]
    if HAS_ROUGH and (k == PRINCIPLED or k == GLOSSY):
        g0, g1, g2, pdf_b = bsdf.eval_layered(x.wox, x.woy, x.woz, wx, wy, wz, x.sx, x.sy, x.sz,
                                              x.mx, x.my, x.mz, x.nx, x.ny, x.nz, lobe, False,
                                              x.bx, x.by, x.bz)
    elif HAS_ROUGH_METAL and k == ROUGH_METAL:
        g0, g1, g2, pdf_b = bsdf.eval_rough_conductor(x.wox, x.woy, x.woz, wx, wy, wz, x.mx,
                                                      x.my, x.mz, x.nx, x.ny, x.nz, lobe)
    elif HAS_ROUGH_GLASS and k == ROUGH_GLASS:
        g0, g1, g2, pdf_b = bsdf.eval_rough_dielectric(x.wox, x.woy, x.woz, wx, wy, wz, x.mx,
                                                       x.my, x.mz, lobe)
    elif HAS_TRANSLUCENT and k == TRANSLUCENT:  # Lambert about the other side's normal
        pdf_b = bsdf.eval_lambert(wx, wy, wz, -x.sx, -x.sy, -x.sz)
        shadowing = pdf_b * diffuse_shadowing(x, -1.0, wx, wy, wz, True)
        g0, g1, g2 = c[0] * shadowing, c[1] * shadowing, c[2] * shadowing
    elif HAS_SHEEN and k == SHEEN:
        a, b, albedo = sheen_at(x, sc, paths)
        pdf_b = bsdf.eval_sheen(x.wox, x.woy, x.woz, wx, wy, wz, x.sx, x.sy, x.sz, a, b)
        shadowing = albedo * pdf_b * diffuse_shadowing(x, 1.0, wx, wy, wz, True)
        g0, g1, g2 = c[0] * shadowing, c[1] * shadowing, c[2] * shadowing
    elif HAS_DIFFUSE:
        pdf_b = bsdf.eval_lambert(wx, wy, wz, x.sx, x.sy, x.sz)
        shadowing = pdf_b * diffuse_shadowing(x, 1.0, wx, wy, wz, True)
        g0, g1, g2 = c[0] * shadowing, c[1] * shadowing, c[2] * shadowing
        if HAS_OREN_NAYAR and k == DIFFUSE:
            r0, r1, r2 = oren_nayar_at(x, wx, wy, wz, c, sc, paths)
            g0, g1, g2 = g0 * r0, g1 * r1, g2 * r2
    if HAS_NORMAL_MAPS and (k == ROUGH_GLASS or k == ROUGH_METAL):
        shadowing = bsdf.bump_shadowing(x.bx, x.by, x.bz, x.sx, x.sy, x.sz, wx, wy, wz, False,
                                        True)
        g0, g1, g2 = g0 * shadowing, g1 * shadowing, g2 * shadowing
    if not (max(g0, max(g1, g2)) > 0 and max(q0, max(q1, q2)) > 0 and dist > 0):
        return n_shadow
    w = 1.0 if math.isinf(pdf_l) else power_heuristic(pdf_l, pdf_b)
    ox, oy, oz = shadow_origin(x, wx, wy, wz, sc)
    # The shadow ray crosses the media on the light's side of the surface.
    return queue_shadow(i, row, depth, x, ox, oy, oz, wx, wy, wz, dist, light_scale,
                        g0 * q0 * w, g1 * q1 * w, g2 * q2 * w,
                        sc.geometry.material_index[x.f] if HAS_VOLUMES else 0,
                        wx * x.nx + wy * x.ny + wz * x.nz < 0.0, sc, paths, shadow, n_shadow)


def queue_shadow(i, row, depth, x, ox, oy, oz, wx, wy, wz, dist, light_scale, f0, f1, f2,
                 mat, crossed, sc, paths, shadow, n_shadow):
    """Queue the shadow ray of path i's vertex x (from o, toward w; dist: to the sampled
    point, inf for a distant light) carrying throughput x f. With media it starts in the
    path's after crossing (if `crossed`) the surface of material `mat` from x's side:
    traced a segment at a time with transparency (cross_transparent attenuates each), else
    attenuated over its whole length here (it meets no surface before its light). Returns
    the shadow rays queued."""
    t = paths.throughput
    c0, c1, c2 = t[i, 0] * f0, t[i, 1] * f1, t[i, 2] * f2
    if DEBUG:
        _debug_mark(paths, row, 6, c0, c1, c2)
    if HAS_VOLUMES and not HAS_TRANSPARENCY:
        a0, a1, a2 = medium_transmittance(i, mat, x.front, crossed, dist, sc, paths)
        c0, c1, c2 = c0 * a0, c1 * a1, c2 * a2
    if not max(c0, max(c1, c2)) > 0:
        return n_shadow
    s = n_shadow
    if HAS_VOLUMES and HAS_TRANSPARENCY:
        media.carry(paths.media, i, shadow.media, s, sc.materials.medium, mat, x.front,
                    crossed)
    shadow.row[s] = row
    shadow.origin[s, 0], shadow.origin[s, 1], shadow.origin[s, 2] = ox, oy, oz
    if math.isinf(dist):
        shadow.direction[s, 0], shadow.direction[s, 1], shadow.direction[s, 2] = wx, wy, wz
        shadow.tmax[s] = 3e38
    else:
        # Aim at the sampled point itself: reusing w from the un-offset point would reach a
        # grazing emitter's plane early and self-occlude.
        gx, gy, gz = x.px + wx * dist - ox, x.py + wy * dist - oy, x.pz + wz * dist - oz
        seg = math.sqrt(gx * gx + gy * gy + gz * gz)
        sl = max(seg, 1e-300)
        shadow.direction[s, 0], shadow.direction[s, 1], shadow.direction[s, 2] = (
            gx / sl, gy / sl, gz / sl)
        shadow.tmax[s] = seg - ray_offset(light_scale)
    shadow.contrib[s, 0], shadow.contrib[s, 1], shadow.contrib[s, 2] = c0, c1, c2
    if HAS_TRANSPARENCY:
        shadow.transparent[s] = paths.transparent[i]
        shadow.vertex[s] = depth
    if HAS_LIGHT_PATH:
        shadow.bounces[s, 0] = paths.bounce[i] if HAS_TRANSPARENCY else depth
        for j in range(3):
            shadow.bounces[s, j + 1] = paths.kind_bounces[i, j]
    return s + 1


def sample_bsdf(row, depth, x, lobe, c, sc, paths, rev_sample):
    """A direction from the vertex's BSDF (only the kinds the plan has; c: the surface's
    colour there): (w, weight, pdf, ok); the pdf is DELTA_PDF for delta lobes."""
    ps = paths.pseed[row]
    mt = sc.materials
    k = mt.kind[x.mat]
    if HAS_ROUGH and (k == PRINCIPLED or k == GLOSSY):
        u_lobe = sample_1d(ps, rev_sample, bounce_dim(depth, LOBE))
        ua, ub = sample_2d(ps, rev_sample, bounce_dim(depth, BSDF))
        return bsdf.sample_layered(x.wox, x.woy, x.woz, x.sx, x.sy, x.sz, x.mx, x.my, x.mz,
                                   x.nx, x.ny, x.nz, lobe, u_lobe, ua, ub, x.bx, x.by, x.bz)
    if HAS_ROUGH_METAL and k == ROUGH_METAL:
        ua, ub = sample_2d(ps, rev_sample, bounce_dim(depth, BSDF))
        return bsdf.sample_rough_conductor(x.wox, x.woy, x.woz, x.mx, x.my, x.mz, x.nx, x.ny,
                                           x.nz, lobe, ua, ub)
    if HAS_ROUGH_GLASS and k == ROUGH_GLASS:
        u_lobe = sample_1d(ps, rev_sample, bounce_dim(depth, LOBE))
        ua, ub = sample_2d(ps, rev_sample, bounce_dim(depth, BSDF))
        return bsdf.sample_rough_dielectric(x.wox, x.woy, x.woz, x.mx, x.my, x.mz, x.nx, x.ny,
                                            x.nz, lobe, u_lobe, ua, ub)
    if HAS_DIFFUSE and k == DIFFUSE:
        ua, ub = sample_2d(ps, rev_sample, bounce_dim(depth, BSDF))
        wx, wy, wz, pdf, ok = bsdf.sample_lambert(x.sx, x.sy, x.sz, x.nx, x.ny, x.nz, ua, ub)
        shadowing = diffuse_shadowing(x, 1.0, wx, wy, wz, False)
        k0 = k1 = k2 = shadowing
        if HAS_OREN_NAYAR:
            r0, r1, r2 = oren_nayar_at(x, wx, wy, wz, c, sc, paths)
            k0, k1, k2 = k0 * r0, k1 * r1, k2 * r2
        return wx, wy, wz, c[0] * k0, c[1] * k1, c[2] * k2, pdf, ok
    if HAS_SHEEN and k == SHEEN:
        ua, ub = sample_2d(ps, rev_sample, bounce_dim(depth, BSDF))
        a, b, albedo = sheen_at(x, sc, paths)
        wx, wy, wz, pdf, ok = bsdf.sample_sheen(x.wox, x.woy, x.woz, x.sx, x.sy, x.sz, x.nx,
                                                x.ny, x.nz, a, b, ua, ub)
        albedo *= diffuse_shadowing(x, 1.0, wx, wy, wz, False)
        return wx, wy, wz, c[0] * albedo, c[1] * albedo, c[2] * albedo, pdf, ok
    if HAS_TRANSLUCENT and k == TRANSLUCENT:  # Lambert about the other side's normals
        ua, ub = sample_2d(ps, rev_sample, bounce_dim(depth, BSDF))
        wx, wy, wz, pdf, ok = bsdf.sample_lambert(-x.sx, -x.sy, -x.sz, -x.nx, -x.ny, -x.nz,
                                                  ua, ub)
        shadowing = diffuse_shadowing(x, -1.0, wx, wy, wz, False)
        return wx, wy, wz, c[0] * shadowing, c[1] * shadowing, c[2] * shadowing, pdf, ok
    if HAS_GLASS and k == GLASS:
        eta = mt.ior[x.mat] if x.front else 1.0 / mt.ior[x.mat]
        u = sample_1d(ps, rev_sample, bounce_dim(depth, LOBE))
        tints = glass_tints_at(x, c, HAS_TEXTURES and mt.programs.colour[x.mat, 0] >= 0, sc)
        film_d = film_n = 0.0
        if HAS_THIN_FILM:
            film_d, film_n = film_at(x, k, sc, paths)
        wx, wy, wz, f0, f1, f2, ok = bsdf.sample_dielectric(
            x.wox, x.woy, x.woz, x.mx, x.my, x.mz, eta, tints[:3], tints[3:],
            specular_tint_at(x, sc, paths), u, sc.exact_fresnel, mt.fresnel[x.mat], film_d,
            film_n)
        # A tilted normal (smooth, mapped or bumped) can refract a direction back above the
        # geometric surface: Cycles' bsdf_microfacet_sample drops it (as the rough lobe).
        below_m = wx * x.mx + wy * x.my + wz * x.mz < 0.0
        ok = ok and below_m == (wx * x.nx + wy * x.ny + wz * x.nz < 0.0)
        return wx, wy, wz, f0, f1, f2, DELTA_PDF, ok
    wx, wy, wz, cos_o = bsdf.reflect(x.wox, x.woy, x.woz, x.mx, x.my, x.mz)
    if HAS_METAL and k == METAL:  # the reflection tint is its Specular Tint (F82)
        edge = metal_edge_at(x, sc, paths)
        d, n = film_at(x, k, sc, paths) if HAS_THIN_FILM else (0.0, 1.0)
        if d > 0.0:
            return (wx, wy, wz,
                    fresnel.thin_film_f82(cos_o, c[0], bsdf.f82_tint_b(c[0], edge[0]), n, d, 0),
                    fresnel.thin_film_f82(cos_o, c[1], bsdf.f82_tint_b(c[1], edge[1]), n, d, 1),
                    fresnel.thin_film_f82(cos_o, c[2], bsdf.f82_tint_b(c[2], edge[2]), n, d, 2),
                    DELTA_PDF, True)
        return (wx, wy, wz, bsdf.fresnel_f82(cos_o, c[0], bsdf.f82_tint_b(c[0], edge[0])),
                bsdf.fresnel_f82(cos_o, c[1], bsdf.f82_tint_b(c[1], edge[1])),
                bsdf.fresnel_f82(cos_o, c[2], bsdf.f82_tint_b(c[2], edge[2])), DELTA_PDF, True)
    if HAS_MIRROR and k == MIRROR:
        return wx, wy, wz, c[0], c[1], c[2], DELTA_PDF, True
    return wx, wy, wz, 0.0, 0.0, 0.0, DELTA_PDF, False


def oren_nayar_at(x, wx, wy, wz, c, sc, paths):
    """A Diffuse BSDF's f * cos toward w over Lambert's at vertex x of colour c (3 values):
    Oren-Nayar's at its roughness there (its program's where it varies), 1 where that is
    below Cycles' Lambert threshold."""
    mt = sc.materials
    r = mt.roughness[x.mat]
    if HAS_TEXTURES:
        r = shading.roughness_at(x.mat, x.f, x.u, x.v, mt.programs, sc.geometry.uv, paths.svm,
                                 r)
    if not r >= bsdf.OREN_NAYAR_MIN:
        return 1.0, 1.0, 1.0
    return bsdf.oren_nayar_ratio(x.wox, x.woy, x.woz, wx, wy, wz, x.sx, x.sy, x.sz, r, c[0],
                                 c[1], c[2])


def diffuse_shadowing(x, side, wx, wy, wz, evaluated):
    """Cycles' bump shadowing (bsdf.bump_shadowing) of a diffuse-type closure at vertex x
    toward w: the Diffuse, Sheen and Translucent BSDFs (CLOSURE_IS_BSDF_DIFFUSE), about the
    shading normal turned by `side` (-1: the Translucent's closure normal is the other
    side's). 1 where nothing tilts the normal."""
    if not HAS_NORMAL_MAPS:
        return 1.0
    return bsdf.bump_shadowing(x.bx, x.by, x.bz, side * x.sx, side * x.sy, side * x.sz, wx, wy,
                               wz, True, evaluated)


def sheen_at(x, sc, paths):
    """The sheen lobe of vertex x: (A, B, albedo) at its view (bsdf.sheen_ltc), at its
    roughness there."""
    mt = sc.materials
    cos_o = x.sx * x.wox + x.sy * x.woy + x.sz * x.woz
    roughness = mt.roughness[x.mat]
    if HAS_TEXTURES:
        roughness = shading.roughness_at(x.mat, x.f, x.u, x.v, mt.programs, sc.geometry.uv,
                                         paths.svm, roughness)
    return bsdf.sheen_ltc(mt.sheen_ltc, cos_o, roughness)


def caustic_state(i, row, depth, x, k, wx, wy, wz, pdf, sc, paths):
    """The light-tracing weight's state for the continuing path (Paths.caustic_q,
    caustic_eta): begun at a Lambertian first vertex with the camera's and the BSDF's
    densities, kept through specular vertices (the IOR product through refractions) and
    Lambertian ones (their shading_ratio), ended (0) at any other."""
    if depth == 0 and k == DIFFUSE:
        cos_camera = abs(x.nx * x.wox + x.ny * x.woy + x.nz * x.woz)
        dist = paths.camera_near[row] + x.t
        raster_per_area = paths.caustic_q[i] * cos_camera / (dist * dist)
        cos_chain = abs(x.nx * wx + x.ny * wy + x.nz * wz)
        return caustics.camera_side_density(raster_per_area, pdf, cos_chain), 1.0
    q = paths.caustic_q[i]
    eta = paths.caustic_eta[i]
    if depth == 0 or not q > 0.0:
        return 0.0, 1.0
    if k == DIFFUSE:  # a Lambertian vertex inside the path
        cos_s_camera = x.sx * x.wox + x.sy * x.woy + x.sz * x.woz
        if not cos_s_camera > 0.0:  # no light path samples this direction
            return 0.0, 1.0
        return q * caustics.shading_ratio(
            pdf * math.pi, abs(x.nx * wx + x.ny * wy + x.nz * wz), cos_s_camera,
            abs(x.nx * x.wox + x.ny * x.woy + x.nz * x.woz)), eta
    if not (k == MIRROR or k == METAL or k == GLASS):
        return 0.0, 1.0
    if k == GLASS and (wx * x.nx + wy * x.ny + wz * x.nz) < 0.0:  # refracted
        eta *= sc.materials.ior[x.mat] if x.front else 1.0 / sc.materials.ior[x.mat]
    # The lobe's normal m need not be the geometric one (a smooth mesh): the chain's
    # Jacobians then differ by the same ratio as a Lambertian vertex's (caustics.py).
    return q * caustics.shading_ratio(
        abs(x.mx * wx + x.my * wy + x.mz * wz), abs(x.nx * wx + x.ny * wy + x.nz * wz),
        abs(x.mx * x.wox + x.my * x.woy + x.mz * x.woz),
        abs(x.nx * x.wox + x.ny * x.woy + x.nz * x.woz)), eta


def medium_transmittance(i, mat, entering, crossed, t, sc, paths):
    """Beer-Lambert over length t (inf: to infinity) in the media path i is inside, after it
    crosses (if `crossed`) a surface of material `mat` from its front (`entering`)."""
    s0, s1, s2 = media.extinction(paths.media, i, sc.materials.medium, mat, entering,
                                  crossed)
    return media.transmittance(s0, s1, s2, t)


def traverse_medium(i, row, vertex, scatters, f, tfar, sc, paths, rev_sample):
    """The segment just traced (to the hit tfar away, or to infinity) lay in the path's
    media: their emission along it is added; where they scatter and the path may still
    bounce (`scatters`), a free-flight distance is sampled (media.sample_distance, in a
    channel chosen by throughput), else the throughput takes the transmittance up to the
    hit, exactly. Returns the distance along the segment where the path scatters (inf: it
    reaches the hit, its throughput weighted for that)."""
    mt = sc.materials.medium
    t = np.float64(tfar) if f >= 0 else np.inf
    t0, t1, t2 = paths.throughput[i, 0], paths.throughput[i, 1], paths.throughput[i, 2]
    st0, st1, st2 = media.coefficients(paths.media, i, mt, media.SIGMA_T)
    e0, e1, e2 = media.coefficients(paths.media, i, mt, media.EMISSION)
    if max(e0, max(e1, e2)) > 0.0:
        _add(paths, row, t0, t1, t2, media.emission_along(e0, st0, t),
             media.emission_along(e1, st1, t), media.emission_along(e2, st2, t), 1.0)
    ss0 = ss1 = ss2 = 0.0
    if HAS_SCATTERING and scatters:
        ss0, ss1, ss2 = media.coefficients(paths.media, i, mt, media.SIGMA_S)
    if not max(ss0, max(ss1, ss2)) > 0.0:
        a0, a1, a2 = media.transmittance(st0, st1, st2, t)
        paths.throughput[i, 0], paths.throughput[i, 1], paths.throughput[i, 2] = (
            t0 * a0, t1 * a1, t2 * a2)
        return np.inf
    total = t0 + t1 + t2
    p0, p1 = (t0 / total, t1 / total) if total > 0.0 else (1.0 / 3.0, 1.0 / 3.0)
    seed = hash_combine(paths.pseed[row], np.uint64(FREE_FLIGHT_SALT))
    u_channel, u = sample_2d(seed, rev_sample, bounce_dim(vertex, LOBE))
    ts, w0, w1, w2 = media.sample_distance(u_channel, u, t, st0, st1, st2, ss0, ss1, ss2, p0,
                                           p1, 1.0 - p0 - p1)
    paths.throughput[i, 0], paths.throughput[i, 1], paths.throughput[i, 2] = (
        t0 * w0, t1 * w1, t2 * w2)
    return ts


def scatter_in_medium(i, out, row, depth, vertex, ts, sc, paths, shadow, n_shadow,
                      rev_sample):
    """Path i scatters in its media ts along its segment: a vertex without a surface. As at
    a surface: Russian roulette, a light sampled and weighed by the phase function (MIS
    against phase sampling), then a direction from the phase function; the bounce counts
    (Cycles: a volume bounce is a bounce). Returns (rows going on, shadow rays queued)."""
    t_start = paths.mis_t[i] if HAS_TRANSPARENCY else 0.0
    dx, dy, dz = paths.d64[i, 0], paths.d64[i, 1], paths.d64[i, 2]
    t = t_start + ts
    px, py, pz = paths.o64[i, 0] + dx * t, paths.o64[i, 1] + dy * t, paths.o64[i, 2] + dz * t
    alive, t0, t1, t2 = russian_roulette(depth, vertex, paths.throughput[i, 0],
                                         paths.throughput[i, 1], paths.throughput[i, 2],
                                         paths.pseed[row], rev_sample)
    if not alive:
        return out, n_shadow
    paths.throughput[i, 0], paths.throughput[i, 1], paths.throughput[i, 2] = t0, t1, t2
    mt = sc.materials.medium
    # A vertex with no normal (zeros: lights are chosen from every side) and no surface to
    # offset rays from; `mat` is only read for the kind of surface it is not.
    x = Vertex(px, py, pz, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -dx, -dy, -dz, True,
               -1, 0.0, 0.0, max(paths.media[i, 0], 0), t, max(abs(px), max(abs(py), abs(pz))),
               0.0, 0.0, 0.0)
    ps = paths.pseed[row]
    if HAS_LIGHT_SAMPLING:
        u_sel = sample_1d(ps, rev_sample, bounce_dim(vertex, LIGHT_SELECT))
        ua, ub = sample_2d(ps, rev_sample, bounce_dim(vertex, LIGHT_POINT))
        if HAS_LIGHT_PATH:  # as at a surface (sample_light)
            light_path_registers(i, 0, 0.0, depth + 1, paths)
        wx, wy, wz, dist, q0, q1, q2, pdf_l, light_scale = sample_emitter(x, u_sel, ua, ub, sc,
                                                                          paths)
        f0, f1, f2, pdf_p = media.eval_phase(paths.media, i, mt, dx, dy, dz, wx, wy, wz)
        if max(f0, max(f1, f2)) > 0 and max(q0, max(q1, q2)) > 0 and dist > 0:
            w = 1.0 if math.isinf(pdf_l) else power_heuristic(pdf_l, pdf_p)
            n_shadow = queue_shadow(i, row, vertex, x, px, py, pz, wx, wy, wz, dist,
                                    light_scale, f0 * q0 * w, f1 * q1 * w, f2 * q2 * w, 0,
                                    False, sc, paths, shadow, n_shadow)
    u_lobe = sample_1d(ps, rev_sample, bounce_dim(vertex, LOBE))
    ua, ub = sample_2d(ps, rev_sample, bounce_dim(vertex, BSDF))
    wx, wy, wz, f0, f1, f2, pdf = media.sample_phase(paths.media, i, mt, dx, dy, dz, u_lobe,
                                                     ua, ub)
    t0, t1, t2 = t0 * f0, t1 * f1, t2 * f2
    if not (pdf > 0.0 and max(t0, max(t1, t2)) > 0):
        return out, n_shadow
    spawn_in_medium(i, out, row, depth, px, py, pz, wx, wy, wz, t0, t1, t2, pdf, sc, paths)
    return out + 1, n_shadow


def spawn_in_medium(i, out, row, depth, px, py, pz, wx, wy, wz, t0, t1, t2, pdf, sc, paths):
    """Continue path i from its scattering point p in a medium as row `out`: no surface to
    leave (no offset), its media unchanged, no normal for the next MIS weight."""
    media.carry(paths.media, i, paths.media, out, sc.materials.medium, 0, False, False)
    if HAS_LIGHT_PATH:
        count_bounce(i, out, shading.RAY_VOLUME_SCATTER, paths)
    if HAS_LIGHT_TRACING:  # (light paths never end in a medium)
        paths.caustic_q[out], paths.caustic_eta[out] = 0.0, 1.0
    if HAS_TRANSPARENCY:
        paths.bounce[out] = depth + 1
        paths.transparent[out] = paths.transparent[i]
        paths.bounds[out] = paths.bounds[i]
        paths.mis_t[out] = 0.0
        paths.via_transparent[out] = False
    if HAS_TRANSPARENT_GLASS:  # (a volume scatter ends it)
        paths.through_glass[out] = False
    paths.o64[out, 0], paths.o64[out, 1], paths.o64[out, 2] = px, py, pz
    paths.d64[out, 0], paths.d64[out, 1], paths.d64[out, 2] = wx, wy, wz
    for j in range(3):
        paths.origin32[out, j] = paths.o64[out, j]
        paths.dir32[out, j] = paths.d64[out, j]
        paths.prev_normal[out, j] = 0.0
    paths.tmax32[out] = np.inf
    paths.throughput[out, 0], paths.throughput[out, 1], paths.throughput[out, 2] = t0, t1, t2
    paths.prev_pdf[out] = pdf
    paths.live[out] = row


def path_counts(i, step, tfar, paths):
    """Path i at this step: (depth, the bounce: Blender's count; vertex, the sampler's
    bounce: transparent and volume boundary crossings count too; the hit's distance from
    the last scattering vertex). Without transparency every path's is the step's."""
    if HAS_TRANSPARENCY:
        depth = paths.bounce[i]
        return (depth, depth + paths.transparent[i] + paths.bounds[i],
                np.float64(tfar) + paths.mis_t[i])
    return step, step, np.float64(tfar)


def light_path_registers(i, flags, length, depth, paths):
    """The Light Path node's view of path i (svm_node_light_path): `flags` of this
    evaluation (the path's own at a surface it reaches, none for a light's emission sampled
    from its vertex), the ray's length, the depth Cycles reports there and the path's
    bounce counters."""
    kb = paths.kind_bounces
    crossed = paths.transparent[i] if HAS_TRANSPARENCY else 0
    shading.set_light_path(paths.svm, flags, np.float64(length), np.float64(depth), kb[i, 0],
                           kb[i, 1], crossed, kb[i, 2])


def bounce_flags(row, vertex, x, k, lobe, wx, wy, wz, rev_sample, paths):
    """Cycles' path flags of the ray a bounce off vertex x (kind k) starts toward w
    (path_state_next of the sampled label): reflection or transmission by w's side;
    diffuse, glossy or singular (a delta lobe, or GGX of alpha^2 <= SINGULAR_ALPHA_SQ) by
    the lobe sampled, for the Principled and Glossy layers the choice sample_bsdf made."""
    side = shading.RAY_TRANSMIT if wx * x.nx + wy * x.ny + wz * x.nz < 0.0 else \
        shading.RAY_REFLECT
    if k == DIFFUSE or k == SHEEN or k == TRANSLUCENT:
        return shading.RAY_DIFFUSE | side
    if k == PRINCIPLED or k == GLOSSY or k == ROUGH_GLASS or k == ROUGH_METAL:
        glossy = shading.RAY_GLOSSY
        if lobe.alpha * lobe.alpha <= SINGULAR_ALPHA_SQ:
            glossy |= shading.RAY_SINGULAR
        if k == PRINCIPLED or k == GLOSSY:
            u_lobe = sample_1d(paths.pseed[row], rev_sample, bounce_dim(vertex, LOBE))
            if u_lobe >= lobe.p_spec:
                return shading.RAY_DIFFUSE | side
        return glossy | side
    return shading.RAY_GLOSSY | shading.RAY_SINGULAR | side


def surface_ends(i, row, depth, k, max_bounces, paths):
    """Whether path i ends at a surface of kind k: past the bounce limit (vertex
    max_bounces + 1 only adds emission), without a BSDF, or held out. A holdout leaves a
    camera path's pixel (transparent_background) transparent by the path's average
    throughput, the film transparent or not (Cycles' integrate_surface_holdout: camera
    paths carry PATH_RAY_TRANSPARENT_BACKGROUND whatever the film); to any other path it is
    a surface without a BSDF."""
    if k == HOLDOUT and transparent_background(i, depth, paths):
        leave_transparent(i, row, paths)
    return depth > max_bounces or k == NONE or k == HOLDOUT


def count_bounce(i, out, flags, paths):
    """Path i's flags and bounce counters as row `out` after a bounce of `flags`: a
    transmission counts as one, a diffuse or glossy reflection as one of its kind
    (Cycles' path_state_next); a volume scatter counts none of them."""
    paths.flags[out] = flags
    for j in range(3):
        paths.kind_bounces[out, j] = paths.kind_bounces[i, j]
    if flags & shading.RAY_TRANSMIT:
        paths.kind_bounces[out, 2] += 1
    elif flags & shading.RAY_DIFFUSE:
        paths.kind_bounces[out, 0] += 1
    elif flags & shading.RAY_REFLECT:
        paths.kind_bounces[out, 1] += 1


def write_passes(row, depth, x, k, sc, paths):
    """The Depth and Normal passes from the camera ray's (depth 0) first surface that is
    not crossed (Cycles: the first one opaque enough) nor held out."""
    if depth != 0 or k == HOLDOUT or (HAS_TRANSPARENCY and (k == TRANSPARENT or
                                                            k == BOUNDARY)):
        return
    paths.depth[row] = camera.z_depth(x.px, x.py, x.pz, sc.camera)
    paths.normal[row, 0], paths.normal[row, 1], paths.normal[row, 2] = x.sx, x.sy, x.sz
    if DEBUG:
        _debug_mark(paths, row, 4, paths.depth[row], x.sx, x.sy + x.sz)


def pass_through(i, out, row, x, tfar, boundary, sc, paths):
    """Continue path i as row `out` straight through a transparent surface (tfar away), its
    throughput tinted by the surface's colour: only embree's ray start moves (behind the
    surface) and its end stays (a camera ray's clipping); o64, the MIS pdf and normal stay
    the scattering vertex's, mis_t grows to here. A volume `boundary` counts as a boundary
    crossed, not a transparent bounce (Cycles). Returns the rows going on."""
    eps = ray_offset(x.scale)  # n faces the incoming ray: behind is -n
    for j in range(3):
        paths.o64[out, j] = paths.o64[i, j]
        paths.d64[out, j] = paths.d64[i, j]
        paths.dir32[out, j] = paths.dir32[i, j]
        paths.prev_normal[out, j] = paths.prev_normal[i, j]
        paths.throughput[out, j] = paths.throughput[i, j] * sc.materials.colour[x.mat, j]
    paths.origin32[out, 0] = x.px - eps * x.nx
    paths.origin32[out, 1] = x.py - eps * x.ny
    paths.origin32[out, 2] = x.pz - eps * x.nz
    paths.tmax32[out] = paths.tmax32[i] - tfar
    paths.prev_pdf[out] = paths.prev_pdf[i]
    paths.mis_t[out] = x.t
    paths.bounce[out] = paths.bounce[i]
    paths.transparent[out] = paths.transparent[i] + (0 if boundary else 1)
    paths.bounds[out] = paths.bounds[i] + (1 if boundary else 0)
    # (A boundary leaves the flags as they were: Cycles' volume-only bounce skips
    # path_state_next.)
    paths.via_transparent[out] = paths.via_transparent[i] or not boundary
    if HAS_TRANSPARENT_GLASS:
        paths.through_glass[out] = paths.through_glass[i]
    paths.caustic_q[out], paths.caustic_eta[out] = paths.caustic_q[i], paths.caustic_eta[i]
    if HAS_LIGHT_PATH:  # the ray goes on as the same kind of ray (a camera ray stays one)
        paths.flags[out] = paths.flags[i]
        for j in range(3):
            paths.kind_bounces[out, j] = paths.kind_bounces[i, j]
    if HAS_VOLUMES:  # a transparent surface lets the path into its medium as glass does
        media.carry(paths.media, i, paths.media, out, sc.materials.medium,
                    sc.geometry.material_index[x.f], x.front, True)
    paths.live[out] = row
    return out + 1


def cross_surface(i, out, row, x, k, tfar, transparent_max, sc, paths):
    """Past the transparent limit a surface only adds emission (Cycles: terminate on the
    next surface); before it a transparent surface or a volume boundary (k) is crossed
    (pass_through), even past the bounce limit. Returns (whether path i is done with this
    surface, the rows going on)."""
    if paths.transparent[i] >= max(transparent_max, 1):
        return True, out
    if k == TRANSPARENT or (k == BOUNDARY and paths.bounds[i] < media.VOLUME_BOUNDS_MAX):
        return True, pass_through(i, out, row, x, tfar, k == BOUNDARY, sc, paths)
    return k == BOUNDARY, out


def spawn(i, out, row, depth, vertex, x, k, lobe, wx, wy, wz, t0, t1, t2, pdf, rev_sample, sc,
          paths):
    """Continue path i (at bounce depth, sampler vertex `vertex`, on a surface of kind k
    whose rough lobe is `lobe`) as row `out` of the compacted batch: leave the surface
    toward the side of the new direction, into embree's buffers, with the path's
    light-tracing weight state, media and counters (and, for the Light Path node, the
    bounce's flags; for Transparent Glass, whether it is still a camera path through clear
    glass: read before row `out`, which may be i, is written)."""
    if HAS_TRANSPARENT_GLASS:
        paths.through_glass[out] = (transparent_background(i, depth, paths) and clear_glass(
            k, lobe.alpha, wx * x.nx + wy * x.ny + wz * x.nz, sc.clear_glass))
    if HAS_LIGHT_TRACING:
        cq, ce = caustic_state(i, row, depth, x, k, wx, wy, wz, pdf, sc, paths)
        paths.caustic_q[out], paths.caustic_eta[out] = cq, ce
    if HAS_VOLUMES:  # the medium is the triangle's material's, a mix's as a whole
        media.carry(paths.media, i, paths.media, out, sc.materials.medium,
                    sc.geometry.material_index[x.f], x.front,
                    wx * x.nx + wy * x.ny + wz * x.nz < 0.0)
    if HAS_TRANSPARENCY:
        paths.bounce[out] = depth + 1
        paths.transparent[out] = paths.transparent[i]
        paths.bounds[out] = paths.bounds[i]
        paths.mis_t[out] = 0.0
        paths.via_transparent[out] = False
    if HAS_LIGHT_PATH:
        count_bounce(i, out, bounce_flags(row, vertex, x, k, lobe, wx, wy, wz, rev_sample, paths),
                     paths)
    side = 1.0 if wx * x.nx + wy * x.ny + wz * x.nz >= 0.0 else -1.0
    eps = side * ray_offset(x.scale)
    paths.o64[out, 0] = x.px + eps * x.nx
    paths.o64[out, 1] = x.py + eps * x.ny
    paths.o64[out, 2] = x.pz + eps * x.nz
    for j in range(3):
        paths.origin32[out, j] = paths.o64[out, j]
    paths.dir32[out, 0], paths.dir32[out, 1], paths.dir32[out, 2] = wx, wy, wz
    paths.tmax32[out] = np.inf
    paths.d64[out, 0], paths.d64[out, 1], paths.d64[out, 2] = wx, wy, wz
    paths.throughput[out, 0], paths.throughput[out, 1], paths.throughput[out, 2] = t0, t1, t2
    paths.prev_pdf[out] = pdf
    # Light choice by importance weighs emitters by the cosine at this vertex's normal
    # (lit_side); MIS at the next hit re-weighs.
    paths.prev_normal[out, 0], paths.prev_normal[out, 1], paths.prev_normal[out, 2] = (
        lit_side(x, sc))
    paths.live[out] = row


def shade(step, rev_sample, max_bounces, transparent_max, sc, prim, tfar, bu, bv, m, paths,
          shadow, profile):
    """One step (a bounce, or with transparency a segment) for the m live paths (batch rows
    paths.live[:m]) after embree's closest hits (prim, tfar, bu, bv): the stages above, per
    path. The paths that go on are compacted to the front of the batch; shadow rays are
    queued in `shadow`. profile (3,) uint64 (PROFILE kernels) receives cycle counts: the
    loop, sample light, sample BSDF. Returns (paths that go on, shadow rays queued)."""
    if PROFILE:
        c_loop = _cycles()
    out = n_shadow = np.int64(0)  # a literal 0 would compile scatter_in_medium twice
    for i in range(m):
        row = paths.live[i]
        f = prim[i]
        depth, vertex, t_hit = path_counts(i, step, tfar[i], paths)
        if HAS_LIGHT_PATH:  # the surface this ray reached sees the path's own state
            light_path_registers(i, paths.flags[i], tfar[i], depth, paths)
        mis = HAS_LIGHT_SAMPLING and not math.isinf(paths.prev_pdf[i])
        if HAS_LIGHT_HITS or HAS_SUN_DISCS:
            handle_light_hits(i, row, depth, f, tfar[i], sc, paths, mis)
        if HAS_VOLUMES:
            ts = traverse_medium(i, row, vertex, depth <= max_bounces, f, tfar[i], sc, paths,
                                 rev_sample)
            if HAS_SCATTERING and ts < np.inf:  # (a vertex of its own: no surface shading)
                out, n_shadow = scatter_in_medium(i, out, row, depth, vertex, ts, sc, paths,
                                                  shadow, n_shadow, rev_sample)
                continue
        if f < 0:
            handle_escaped(i, row, depth, sc, paths, mis)
            continue
        mat = sc.geometry.material_index[f]
        weight = (1.0, 1.0, 1.0)
        if HAS_MIXES:
            u = sample_1d(paths.pseed[row], rev_sample, bounce_dim(vertex, CLOSURE))
            mat, weight = choose_closure(u, f, bu[i], bv[i], paths.d64[i, 0], paths.d64[i, 1],
                                         paths.d64[i, 2], mat, sc, paths)
        x = surface_interaction(i, f, mat, t_hit, bu[i], bv[i], sc, paths)
        k = sc.materials.kind[x.mat]
        write_passes(row, depth, x, k, sc, paths)
        if HAS_EMISSION:
            handle_emission(i, row, depth, x, sc, paths, mis, max_bounces)
        if HAS_MIXES:  # after the emission, which is the whole mix's
            for j in range(3):
                paths.throughput[i, j] *= weight[j]
        if HAS_TRANSPARENCY:
            ended, out = cross_surface(i, out, row, x, k, tfar[i], transparent_max, sc, paths)
            if ended:
                continue
        if surface_ends(i, row, depth, k, max_bounces, paths):
            continue
        alive, t0, t1, t2 = russian_roulette(depth, vertex, paths.throughput[i, 0],
                                             paths.throughput[i, 1], paths.throughput[i, 2],
                                             paths.pseed[row], rev_sample)
        if not alive:
            continue
        paths.throughput[i, 0], paths.throughput[i, 1], paths.throughput[i, 2] = t0, t1, t2
        c = surface_colour(x, sc, paths)
        lobe = rough_lobe(x, k, c, sc, paths)
        if PROFILE:
            c_light = _cycles()
        if HAS_LIGHT_SAMPLING and not bsdf.is_delta_kind(k):
            n_shadow = sample_light(i, row, vertex, x, lobe, c, sc, paths, shadow, n_shadow,
                                    rev_sample)
        if PROFILE:
            c_bsdf = _cycles()
            profile[1] += c_bsdf - c_light
        wx, wy, wz, f0, f1, f2, pdf, ok = sample_bsdf(row, vertex, x, lobe, c, sc, paths,
                                                      rev_sample)
        t0, t1, t2 = t0 * f0, t1 * f1, t2 * f2
        if DEBUG:
            _debug_mark(paths, row, 7, t0 + wx, t1 + wy, t2 + wz)
        if ok and max(t0, max(t1, t2)) > 0:
            spawn(i, out, row, depth, vertex, x, k, lobe, wx, wy, wz, t0, t1, t2, pdf,
                  rev_sample, sc, paths)
            out += 1
        if PROFILE:
            profile[2] += _cycles() - c_bsdf
    if PROFILE:
        profile[0] += _cycles() - c_loop
    return out, n_shadow


def accumulate_unoccluded(radiance, shadow, occluded_prim, count):
    """Add the contributions of shadow rays that reached their light (embree's occlusion
    query leaves prim -1 on unblocked rays)."""
    for j in range(count):
        if occluded_prim[j] < 0:
            row = shadow.row[j]
            radiance[row, 0] += shadow.contrib[j, 0]
            radiance[row, 1] += shadow.contrib[j, 1]
            radiance[row, 2] += shadow.contrib[j, 2]


def cross_transparent(rev_sample, transparent_max, sc, prim, tfar, bu, bv, count, shadow,
                      paths):
    """Shadow rays after their closest hits (Cycles' transparent shadows): each segment is
    attenuated by the media it lies in; one that hits nothing adds its contribution; one
    that hits a transparent surface (a mix's: the component a sample picks, which
    estimates its transparency) or a volume boundary goes on behind it, tinted by its
    colour, into or out of its medium, compacted to the front, while its path's
    transparent crossings and its own (boundaries count here, as in Cycles) stay within
    the limit; any other surface blocks it. Returns the rays going on."""
    out = 0
    for j in range(count):
        row = shadow.row[j]
        f = prim[j]
        if HAS_VOLUMES:
            s0, s1, s2 = media.coefficients(shadow.media, j, sc.materials.medium,
                                            media.SIGMA_T)
            if max(s0, max(s1, s2)) > 0.0:
                a0, a1, a2 = media.transmittance(
                    s0, s1, s2, np.float64(tfar[j]) if f >= 0 else np.float64(shadow.tmax[j]))
                shadow.contrib[j, 0] *= a0
                shadow.contrib[j, 1] *= a1
                shadow.contrib[j, 2] *= a2
        if f < 0:
            for c in range(3):
                paths.radiance[row, c] += shadow.contrib[j, c]
            continue
        crossed = shadow.transparent[j] + 1
        if crossed > transparent_max:  # (Cycles: the path's crossings count too)
            continue
        mat = sc.geometry.material_index[f]
        weight = (1.0, 1.0, 1.0)
        if HAS_LIGHT_PATH:  # a shadow ray: only its flag, one bounce on (svm_node_light_path)
            b = shadow.bounces[j]
            shading.set_light_path(paths.svm, shading.RAY_SHADOW, np.float64(tfar[j]),
                                   np.float64(b[0] + 1), b[1], b[2], crossed - 1, b[3])
        if HAS_MIXES:
            seed = hash_combine(paths.pseed[row], np.uint64(SHADOW_CLOSURE_SALT + crossed))
            u = sample_1d(seed, rev_sample, bounce_dim(shadow.vertex[j], CLOSURE))
            d = shadow.direction[j]
            mat, weight = choose_closure(u, f, bu[j], bv[j], np.float64(d[0]), np.float64(d[1]),
                                         np.float64(d[2]), mat, sc, paths)
        if sc.materials.kind[mat] != TRANSPARENT and sc.materials.kind[mat] != BOUNDARY:
            continue
        # Go on along the ray itself, past the surface by the usual offset measured along
        # its normal: the ray still ends where it did, just short of the light.
        o, d = shadow.origin[j], shadow.direction[j]
        n = sc.geometry.tri_normal[f]
        cos_in = d[0] * n[0] + d[1] * n[1] + d[2] * n[2]
        cos_n = max(abs(cos_in), GRAZING_COS)
        t = np.float64(tfar[j])
        px, py, pz = o[0] + d[0] * t, o[1] + d[1] * t, o[2] + d[2] * t
        t += ray_offset(offset_scale(sc.geometry, f, px, py, pz)) / cos_n
        for c in range(3):
            shadow.origin[out, c] = o[c] + d[c] * t
            shadow.direction[out, c] = d[c]
            shadow.contrib[out, c] = shadow.contrib[j, c] * weight[c] * sc.materials.colour[mat, c]
        shadow.tmax[out] = shadow.tmax[j] - t
        shadow.row[out] = row
        shadow.transparent[out] = crossed
        shadow.vertex[out] = shadow.vertex[j]
        if HAS_LIGHT_PATH:
            for c in range(4):
                shadow.bounces[out, c] = shadow.bounces[j, c]
        if HAS_VOLUMES:
            media.carry(shadow.media, j, shadow.media, out, sc.materials.medium,
                        sc.geometry.material_index[f], cos_in < 0.0, True)
        out += 1
    return out


def all_finite(radiance, depth, normal):
    """Whether every sample of a chunk is finite in all the passes it feeds."""
    for i in range(len(depth)):
        if not (np.isfinite(radiance[i, 0]) and np.isfinite(radiance[i, 1])
                and np.isfinite(radiance[i, 2]) and np.isfinite(depth[i])
                and np.isfinite(normal[i, 0]) and np.isfinite(normal[i, 1])
                and np.isfinite(normal[i, 2])):
            return False
    return True


# name -> (function, numba options): what a kernel compiles. Stages taking the scene's
# structures are inlined into `shade` by numba; the entry points are compiled on their own
# (without reference counting: jit.JIT).
STAGES = {f.__name__: (f, INLINE) for f in (
    ray_offset, offset_scale, _debug_mark, _add, handle_light_hits, leave_transparent,
    transparent_background, handle_escaped, world_image, choose_closure, surface_ends,
    coat_layer, coat_weights, sheen_layer, sheen_weight, sheen_normal,
    surface_interaction, surface_normal, shading_normal,
    mapped_normal, bumped_normal,
    surface_colour, rough_lobe, anisotropy_at, glass_tints_at, specular_eta_at,
    specular_tint_at, metal_edge_at, lobe_at, film_at,
    handle_emission, caustic_weight,
    continuation_probability, russian_roulette, emitter_pmf,
    lit_side, textured_emitter,
    shadow_origin, sample_light, sample_bsdf, oren_nayar_at, diffuse_shadowing, sheen_at,
    caustic_state,
    medium_transmittance, queue_shadow, traverse_medium, spawn_in_medium,
    path_counts, light_path_registers, bounce_flags, count_bounce, write_passes, pass_through,
    cross_surface, spawn)}
# perturbed_normal runs programs (a bump's height three times): compiled once and called
# from its sites rather than inlined into each, which cut compiling the generic and a
# diffuse plan's kernels from 171 s to 109 s (test_kernel's diffuse-only test, no cache).
# scatter_in_medium (it runs only where a path scatters in a medium) and sample_emitter,
# which it shares with sample_light, are compiled once too: with both inlined, the medium's
# scattering vertex held a second copy of light sampling and compiling the generic kernel
# grew by a third.
# under_layers (only emissions under a Principled sheen or coat) likewise; clear_glass, a
# formula of scalars (no arrays to count references to), is a call of its own so that a
# kernel without Transparent Glass is seen to leave it out.
STAGES.update({f.__name__: (f, JIT) for f in (
    clear_glass, perturbed_normal, scatter_in_medium, sample_emitter, under_layers,
    generate_camera_rays, shade,
    accumulate_unoccluded, cross_transparent, all_finite)})

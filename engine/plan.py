"""The render plan: which stages a scene needs, derived before rendering.

The plan decides what the scene's kernel is compiled with (`kernel_constants`,
integrator.py): no lens sampling without depth of field, no glass code without glass, no
light sampling without emitters, no normal interpolation for flat meshes, and so on.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from .bsdf import OREN_NAYAR_MIN
from .lights import traces_light_paths
from .media import SIGMA_S, has_medium
from .scene import (
    BOUNDARY,
    DIFFUSE,
    GLASS,
    GLOSSY,
    HOLDOUT,
    KIND_NAMES,
    METAL,
    MIRROR,
    MIX,
    NONE,
    PRINCIPLED,
    ROUGH_GLASS,
    ROUGH_METAL,
    SHEEN,
    TRANSLUCENT,
    TRANSPARENT,
    RenderSettings,
    Scene,
)
from .shading import OP_LIGHT_PATH, RAY_CAMERA, SLOTS


@dataclass(frozen=True)
class Plan:
    """Features present in a scene; each flag gates a stage of the integrator."""

    diffuse: bool
    mirror: bool
    metal: bool
    glass: bool
    principled: bool
    glossy: bool
    absorber: bool
    emitters: bool
    num_emitters: int
    light_objects: int
    light_hits: bool
    sun_discs: bool
    dof: bool
    polygon_aperture: bool
    shading_normals: bool
    world_light: bool
    environment: bool
    fresnel: str
    max_bounces: int
    triangles: int
    # Which kernel rendered: "specialised" (made for this plan), "generic", or both in turn
    # ("generic, then specialised from pass N"); set by the renderer.
    kernel: str = ""
    kernel_note: str = ""
    # Some smooth triangle's object has a shadow terminator geometry offset > 0.
    terminator: bool = False
    # Light paths from emissive triangles through specular chains to the camera (caustics.py).
    light_tracing: bool = False
    # Some material used has an input from a shader program (shading.py): a colour, an
    # emission, a normal map, a mix factor or a roughness.
    textures: bool = False
    # Glass with roughness > 0 (GGX reflection and refraction).
    rough_glass: bool = False
    # Principled metallic with roughness > 0 (GGX reflection, per-channel Schlick Fresnel).
    rough_metal: bool = False
    # Some material used has a tangent-space normal map (shading.normal_map).
    normal_maps: bool = False
    # Some transmitting material used encloses a medium (media.py): it absorbs or emits.
    volumes: bool = False
    # ... and some such medium scatters.
    scattering: bool = False
    # Some material used is a mix of two (Mix / Add Shader): each hit picks one.
    mixes: bool = False
    # Some mix used is a Principled coat (scene.Material.coated): a layer over the rest.
    coats: bool = False
    # Some material used is (or mixes in) a Transparent BSDF: paths and shadow rays cross it.
    transparency: bool = False
    # Some material used is (or mixes in) a Translucent BSDF (Lambertian transmission).
    translucent: bool = False
    # Some material used is (or mixes in) a microfiber sheen (Sheen BSDF, Principled sheen).
    sheen: bool = False
    # Some shader program reads the path's state (the Light Path node).
    light_path: bool = False
    # Some Diffuse BSDF or Principled base used has a roughness (Oren-Nayar).
    oren_nayar: bool = False
    # Some GGX lobe used is anisotropic (bsdf.anisotropic_layer).
    anisotropy: bool = False
    # Some material used is (or mixes in) a holdout: the film keeps each pixel's
    # transparency, as it does for a transparent film.
    holdout: bool = False
    # Film > Transparent Glass with some glass used: camera paths see the film's
    # transparency through clear glass too (integrator.clear_glass).
    transparent_glass: bool = False
    # Some material used has a Principled Thin Film (fresnel.thin_film_dielectric).
    thin_film: bool = False

    @property
    def light_sampling(self) -> bool:
        """Next-event estimation runs only where a non-delta surface or a scattering medium
        can see an emitter."""
        return self.emitters and (self.diffuse or self.principled or self.glossy
                                  or self.rough_glass or self.rough_metal or self.translucent
                                  or self.sheen or self.scattering)

    def stages(self) -> list[str]:
        s = ["generate camera rays"]
        if self.dof:
            s.append("sample lens (%s)" % ("polygon" if self.polygon_aperture else "disk"))
        s.append("intersect")
        s.append("handle escaped rays" + (" (environment map)" if self.environment else
                                          " (world colour)" if self.world_light else " (black)"))
        if self.shading_normals:
            s.append("interpolate shading normals")
        if self.textures:
            s.append("evaluate shader programs (textures)")
        if self.normal_maps:
            s.append("apply normal maps")
        if self.volumes:
            s.append("absorb in media" + (", scatter (phase functions)" if self.scattering
                                          else ""))
        if self.light_path:
            s.append("keep the path's state (Light Path)")
        if self.mixes:
            s.append("choose one of mixed shaders" + (" (coats)" if self.coats else ""))
        if self.transparency:
            s.append("pass through transparent surfaces")
        if self.transparent_glass:
            s.append("see the transparent film through clear glass")
        if self.light_hits or self.sun_discs:
            s.append("handle light hits")
        if self.num_emitters:
            s.append("handle emission")
        if self.light_sampling:
            s += ["sample light", "trace shadow rays"
                  + (" (shadow terminator offset)" if self.terminator else "")
                  + (" through transparent surfaces" if self.transparency else "")]
        kinds = [n for n, f in (("diffuse" + (", Oren-Nayar" if self.oren_nayar else ""),
                                 self.diffuse), ("principled", self.principled),
                                ("rough glossy", self.glossy), ("mirror", self.mirror),
                                ("metal", self.metal), ("glass", self.glass),
                                ("rough glass", self.rough_glass),
                                ("rough metal", self.rough_metal),
                                ("translucent", self.translucent),
                                ("sheen", self.sheen), ("anisotropic GGX", self.anisotropy),
                                ("thin film", self.thin_film))
                 if f]
        if kinds:
            s.append("sample BSDF (%s)" % ", ".join(kinds))
        if self.light_tracing:
            s.append("trace light paths through specular chains to the camera")
        return s

    def kernel_constants(self, light_grid: bool, light_importance: bool = False) -> dict:
        """The compile-time constants of this plan's kernel (integrator.PLAN_CONSTANTS;
        light_grid: the emitters have a many-lights grid; light_importance: few emitters,
        chosen by their importance at each point)."""
        return dict(
            HAS_DIFFUSE=self.diffuse, HAS_MIRROR=self.mirror, HAS_METAL=self.metal,
            HAS_GLASS=self.glass, HAS_ROUGH=self.principled or self.glossy,
            HAS_ROUGH_GLASS=self.rough_glass, HAS_ROUGH_METAL=self.rough_metal,
            HAS_DOF=self.dof,
            HAS_POLYGON_APERTURE=self.polygon_aperture,
            HAS_SHADING_NORMALS=self.shading_normals, HAS_EMISSION=self.num_emitters > 0,
            HAS_LIGHT_SAMPLING=self.light_sampling, HAS_LIGHT_OBJECTS=self.light_objects > 0,
            HAS_LIGHT_HITS=self.light_hits, HAS_SUN_DISCS=self.sun_discs,
            HAS_ENVIRONMENT=self.environment,
            HAS_WORLD_COLOUR=self.world_light and not self.environment,
            HAS_TERMINATOR=self.terminator, HAS_LIGHT_GRID=bool(light_grid) and self.emitters,
            HAS_LIGHT_IMPORTANCE=bool(light_importance) and self.emitters,
            HAS_LIGHT_TRACING=self.light_tracing, HAS_TEXTURES=self.textures,
            HAS_NORMAL_MAPS=self.normal_maps, HAS_VOLUMES=self.volumes,
            HAS_SCATTERING=self.scattering, HAS_MIXES=self.mixes,
            HAS_COATS=self.coats,
            HAS_TRANSPARENCY=self.transparency, HAS_TRANSLUCENT=self.translucent,
            HAS_SHEEN=self.sheen, HAS_LIGHT_PATH=self.light_path,
            HAS_OREN_NAYAR=self.oren_nayar, HAS_ANISOTROPY=self.anisotropy,
            HAS_TRANSPARENT_GLASS=self.transparent_glass, HAS_THIN_FILM=self.thin_film,
            PROFILE=False, DEBUG=False)

    def describe(self) -> str:
        return (f"{self.triangles} triangles, {self.num_emitters} emissive, "
                f"{self.light_objects} lights, max_bounces {self.max_bounces}, "
                f"fresnel {self.fresnel}"
                + (f", {self.kernel} kernel" if self.kernel else "")
                + (f" ({self.kernel_note})" if self.kernel_note else "")
                + "; stages: " + " -> ".join(self.stages()))

    def as_dict(self) -> dict:
        d = asdict(self)
        d["stages"] = self.stages()
        return d


def entered_media(scene: Scene, medium=None) -> list:
    """The materials (top rows) on the scene's triangles whose medium a path can enter:
    only a transmitting surface lets a path into its medium (Cycles: the same); a mix's
    medium is its own row's, entered through any transmitting component."""
    m = scene.materials
    medium = m.medium if medium is None else medium
    if medium is None:
        return []
    return [int(top) for top in np.unique(scene.material_index)
            if has_medium(medium[top:top + 1])[0]
            and bool(np.any(np.isin(m.kind[m.reachable([top])],
                                    (GLASS, ROUGH_GLASS, TRANSPARENT, BOUNDARY))))]


def _light_path(scene: Scene, used) -> bool:
    """Whether a program of a material used reads the path's state (Light Path), or the
    world has a map for rays of some kind but camera rays (which depth 0 tells apart:
    integrator.world_image)."""
    if any(flags != RAY_CAMERA for flags in (scene.world.ray_environments or {})):
        return True
    programs = scene.programs
    return programs is not None and any(
        (programs.code[first:end, 0] == OP_LIGHT_PATH).any()
        for slot in SLOTS for first, end, _ in getattr(programs, slot)[used] if first >= 0)


def _oren_nayar(scene: Scene, used) -> bool:
    """Whether a Diffuse BSDF or a Principled base used is rough (Oren-Nayar), or may be
    (a roughness program)."""
    m, programs = scene.materials, scene.programs
    diffuse, principled = used[m.kind[used] == DIFFUSE], used[m.kind[used] == PRINCIPLED]
    sigma = m.diffuse_roughness if m.diffuse_roughness is not None else np.zeros(len(m.kind))
    textured = programs is not None and bool(
        np.any(programs.roughness[diffuse, 0] >= 0)
        or np.any(programs.diffuse_roughness[principled, 0] >= 0))
    return textured or bool(np.any(m.roughness[diffuse] >= OREN_NAYAR_MIN)
                            or np.any(sigma[principled] >= OREN_NAYAR_MIN))


def make_plan(scene: Scene, settings: RenderSettings) -> Plan:
    used = scene.materials.reachable(np.unique(scene.material_index))
    kinds = set(scene.materials.kind[used].tolist())
    mixes = MIX in kinds
    # A volume boundary is crossed as a transparent surface is (counted apart).
    transparency = TRANSPARENT in kinds or BOUNDARY in kinds
    kinds -= {MIX, TRANSPARENT, BOUNDARY}
    # Only emissive triangles need an area: per-material test first (millions of triangles).
    emissive = (scene.materials.emission.max(axis=1) > 0)[scene.material_index]
    v = scene.vertices[emissive]
    area = 0.5 * np.linalg.norm(np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]), axis=1)
    num_emitters = int(np.count_nonzero(area > 0))
    lights = [light for light in scene.lights if max(light.power) > 0]
    light_hits = any((light.type == "AREA" and light.size_x > 0) or
                     (light.type in ("POINT", "SPOT") and light.radius > 0) for light in lights)
    environment = scene.world.environment is not None
    sun_discs = any(light.type == "SUN" and light.angle > 0 for light in lights)
    cam = scene.camera
    dof = cam.aperture_radius > 0
    specular = bool(kinds & {MIRROR, METAL, GLASS})
    normal_maps = scene.programs is not None and bool(np.any(
        (scene.programs.normal[used, 0] >= 0) | (scene.programs.height[used, 0] >= 0)))
    m = scene.materials
    medium = m.medium  # (built from the materials' fields: once)
    entered = entered_media(scene, medium)
    if scene.world_medium >= 0:  # every path starts in the world's volume
        entered.append(scene.world_medium)
    volumes = bool(entered)
    scattering = any(medium[top, SIGMA_S:SIGMA_S + 3].max() > 0 for top in entered)
    assert all(k in KIND_NAMES for k in kinds)
    light_path, oren_nayar = _light_path(scene, used), _oren_nayar(scene, used)
    thin_film = (m.thin_film is not None and bool(np.any(m.thin_film[used, 0] > 0))) or (
        scene.programs is not None and bool(np.any(scene.programs.thin_film[used, 0] >= 0)))
    plan = Plan(
        diffuse=DIFFUSE in kinds, mirror=MIRROR in kinds, metal=METAL in kinds,
        glass=GLASS in kinds, principled=PRINCIPLED in kinds, glossy=GLOSSY in kinds,
        rough_glass=ROUGH_GLASS in kinds, rough_metal=ROUGH_METAL in kinds,
        absorber=NONE in kinds, holdout=HOLDOUT in kinds,
        transparent_glass=settings.clear_glass_threshold >= 0 and bool(
            kinds & {GLASS, ROUGH_GLASS}),
        emitters=num_emitters + len(lights) > 0 or environment,
        num_emitters=num_emitters, light_objects=len(lights), light_hits=light_hits,
        sun_discs=sun_discs, dof=dof, polygon_aperture=dof and cam.blades >= 3,
        shading_normals=scene.normals is not None and bool(scene.smooth.any()),
        world_light=bool(np.max(scene.world.colour) > 0) or environment,
        environment=environment, fresnel=settings.fresnel,
        terminator=bool(scene.normals is not None and np.any(
            scene.smooth & (scene.terminator_offset[scene.object_index] > 0))),
        max_bounces=int(settings.max_bounces), triangles=scene.num_triangles,
        textures=scene.programs is not None and any(
            bool(np.any(getattr(scene.programs, slot)[used, 0] >= 0)) for slot in SLOTS),
        normal_maps=normal_maps, volumes=volumes, scattering=scattering, mixes=mixes,
        transparency=transparency,
        coats=m.coat_ior is not None and bool(np.any(m.coat_ior[used] > 0)),
        translucent=TRANSLUCENT in kinds, sheen=SHEEN in kinds, light_path=light_path,
        oren_nayar=oren_nayar, anisotropy=bool(np.any(m.anisotropic()[used])),
        thin_film=thin_film,
        # Caustic paths need an emissive triangle or an area light BSDF rays can hit
        # (lights.traces_light_paths), a specular surface to reach a Lambertian
        # one and a perspective camera to see it; the light tracer's specular chains must
        # be the path tracer's read backwards, which exact Fresnel is (Schlick is not), and
        # a normal map's shadowing term is not (light paths are not weighted by it), nor
        # are paths through media (light paths carry no volume stack), mixed shaders
        # (light paths do not choose among them), transparent and translucent surfaces
        # (nor cross them), programs reading the path's state (light paths have none) or
        # Oren-Nayar diffuse (light paths connect to the camera from Lambertian vertices),
        # nor thin films (not written for light paths, whose refractions through a film
        # would need Cycles' back-face film read backwards).
        light_tracing=bool(settings.light_tracing and specular
                           and (num_emitters > 0 or any(traces_light_paths(light)
                                                        for light in lights))
                           and DIFFUSE in kinds and cam.type != "ORTHO" and not normal_maps
                           and not volumes and not mixes and not transparency
                           and TRANSLUCENT not in kinds and SHEEN not in kinds
                           and not light_path and not oren_nayar and not thin_film
                           and settings.fresnel == "exact" and settings.max_bounces >= 1))
    return plan

"""Scene model: the plain arrays the core renders, and validation at this boundary.

Everything the core needs arrives here as numpy arrays and small dataclasses; nothing
in `engine/` knows about Blender. The add-on (or a test) fills a `SceneBuilder` object by
object and calls `build()`, which validates, drops bad triangles with a warning that
names the object, recentres the geometry and returns an immutable `Scene`.

Conventions (Blender's): right-handed, z up, lengths in scene units, colours linear
Rec.709 RGB, radiance in W/(sr m^2) per unit of Blender's "strength".
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from dataclasses import dataclass, field

import numpy as np

from .fresnel import MIN_IOR, THIN_FILM_MIN, specular_eta
from .jit import ALLOCATING, JIT, njit
from .media import medium_table
from .shading import SLOTS, VIEW_MAPS, Program, ProgramTable, absent_map_value, map_label, pack

# BSDF kinds of the materials table (`Materials.kind`).
(NONE, DIFFUSE, MIRROR, METAL, GLASS, PRINCIPLED, GLOSSY, ROUGH_GLASS, ROUGH_METAL, MIX,
 TRANSPARENT, TRANSLUCENT, SHEEN, BOUNDARY, HOLDOUT) = range(15)
KIND_NAMES = {NONE: "none", DIFFUSE: "diffuse", MIRROR: "mirror", METAL: "metal", GLASS: "glass",
              PRINCIPLED: "principled", GLOSSY: "glossy", ROUGH_GLASS: "rough_glass",
              ROUGH_METAL: "rough_metal", MIX: "mix", TRANSPARENT: "transparent",
              TRANSLUCENT: "translucent", SHEEN: "sheen", BOUNDARY: "boundary",
              HOLDOUT: "holdout"}
# Cycles treats a microfacet lobe as a perfect delta once alpha^2 = roughness^4 <= 2e-10.
DELTA_ROUGHNESS = 2e-10 ** 0.25
# Cycles refracts straight through (a delta) where the IOR is this close to 1, however rough.
DELTA_IOR = 1e-4

# The kinds whose colour may come from a shader program (Material.colour_program).
TEXTURED_KINDS = ("diffuse", "principled", "glossy", "mirror", "metal", "rough_metal", "glass",
                  "rough_glass", "translucent", "sheen")
# The kinds whose roughness may come from one (Material.roughness_program): the GGX lobes,
# the sheen and Oren-Nayar diffuse.
ROUGH_KINDS = ("principled", "glossy", "rough_metal", "rough_glass", "sheen", "diffuse")
# The kinds whose GGX lobe may be anisotropic (Material.with_anisotropy).
ANISOTROPIC_KINDS = ("principled", "glossy", "rough_metal")
# The kinds with a Specular Tint that may vary (Material.tint_program); a coat's mix has its
# Coat Tint there.
TINTED_KINDS = ("principled", "metal", "rough_metal", "glass", "rough_glass")
# The kinds a Principled BSDF's Thin Film lies on (Material.thin_film, thin_film_program).
FILMED_KINDS = TINTED_KINDS
FRESNEL_MODELS = ("exact", "schlick")
FILTER_TYPES = ("BLACKMAN_HARRIS", "BOX", "GAUSSIAN")
# Rec.709 luminance of linear RGB (the error estimate, the world's share among the lights).
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])
KERNELS = ("auto", "generic", "specialised")
# Independent replicates of the sample sequence per render (RenderSettings.replicates): the
# error estimate's degrees of freedom against the stratification each replicate keeps; see
# the README's "Honest error" for the measurements behind the default.
DEFAULT_REPLICATES = 2
MAX_REPLICATES = 64
SENSOR_FITS = ("AUTO", "HORIZONTAL", "VERTICAL")
CAMERA_TYPES = ("PERSP", "ORTHO")


# How a glass' colour tints its reflection and transmission (Material.glass_tints).
GLASS_TINTS = ("colour", "principled", "refraction")


@njit(**JIT)
def glass_tints(model, c0, c1, c2):
    """A glass' (reflection, transmission) tints, 3 values each, from its colour c by its
    model (GLASS_TINTS' index): the Glass BSDF tints both by c; the Principled BSDF leaves
    reflection untinted and tints transmission by sqrt(c) per interface (c clamped to
    [0, 1], as Cycles' sqrt(clamped base colour)); the Refraction BSDF reflects nothing."""
    if model == 1:
        return (1.0, 1.0, 1.0, math.sqrt(min(max(c0, 0.0), 1.0)),
                math.sqrt(min(max(c1, 0.0), 1.0)), math.sqrt(min(max(c2, 0.0), 1.0)))
    if model == 2:
        return 0.0, 0.0, 0.0, c0, c1, c2
    return c0, c1, c2, c0, c1, c2


def _colour(value, what: str) -> np.ndarray:
    """Return `value` as a (3,) float64 RGB colour, raising ValueError when invalid."""
    c = np.asarray(value, dtype=np.float64).reshape(-1)
    if c.shape != (3,):
        raise ValueError(f"{what} must be an RGB triple, got {value!r}")
    if not np.all(np.isfinite(c)):
        raise ValueError(f"{what} must be finite, got {tuple(c)}")
    if np.any(c < 0):
        raise ValueError(f"{what} must not be negative, got {tuple(c)}")
    return c


def _thin_film(name, film) -> tuple:
    """A Thin Film (thickness in nm, IOR) checked: thickness finite and not negative, 0
    below fresnel.THIN_FILM_MIN (no film, as Cycles); the IOR finite, at least
    fresnel.MIN_IOR (Cycles' clamp)."""
    thickness, ior = (float(v) for v in film)
    if not (math.isfinite(thickness) and thickness >= 0.0 and math.isfinite(ior)):
        raise ValueError(f"material '{name}': a thin film needs a finite thickness >= 0 nm and "
                         f"a finite IOR, got {tuple(film)!r}")
    return (thickness if thickness > THIN_FILM_MIN else 0.0, max(ior, MIN_IOR))


def _specular_tint(m) -> np.ndarray:
    """m's Specular Tint (3,), negative channels 0 (Cycles' max(tint, 0)); white on kinds
    without a dielectric Fresnel it could tint."""
    tint = np.maximum(_colour(m.specular_tint, f"material '{m.name}' specular tint"), 0.0)
    if m.kind not in ("principled", "glass", "rough_glass") and np.any(tint != 1.0):
        raise ValueError(f"material '{m.name}': a {m.kind} material has no dielectric Fresnel "
                         f"for a specular tint")
    return tint


def _anisotropy(m) -> float:
    """A material's Henyey-Greenstein g, which must lie in [-1, 1]."""
    g = float(m.anisotropy)
    if not -1.0 <= g <= 1.0:
        raise ValueError(f"material '{m.name}': volume anisotropy must be in [-1, 1], got "
                         f"{m.anisotropy!r}")
    return g


def _positive(value, what: str) -> float:
    v = float(value)
    if not math.isfinite(v) or v <= 0:
        raise ValueError(f"{what} must be a positive finite number, got {value!r}")
    return v


@dataclass(frozen=True)
class Material:
    """One row of the materials table, with Cycles' semantics (roughness 0 throughout).

    kind : one of KIND_NAMES' values.
        - diffuse: Lambert, f = colour / pi (per-bounce weight = colour).
        - mirror: Glossy BSDF at roughness 0: reflectance = colour at every angle.
        - metal: Principled metallic at roughness 0: Cycles' F82-tint reflectance with
          F0 = colour and the Specular Tint `reflection_tint` (bsdf.fresnel_f82; white:
          Schlick's). rough_metal: the same Fresnel on a GGX lobe.
        - glass: smooth dielectric of index `ior` (outside medium 1, flipped on back
          faces); reflection weighted by `reflection_tint` x F, transmission by
          `transmission_tint` x (1 - F). Glass BSDF: both tints = colour. Principled
          transmission: reflection untinted, transmission sqrt(base colour) per interface.
          Without `fresnel`, Cycles' Refraction BSDF: no reflection, and transmission of
          `colour` whole except under total internal reflection, where nothing is
          (fresnel.glass_fresnel); rough, it is plain GGX (no energy compensation).
        - principled: Principled BSDF, dielectric: a Lambert base of `colour` under a GGX
          specular layer of index `ior` and `roughness` (alpha = roughness^2, Multiscatter
          GGX energy compensation); the base keeps 1 - the layer's albedo.
        - glossy: Glossy BSDF with roughness > 0: Multiscatter GGX reflection tinted by
          `colour`, no Fresnel.
        - rough_metal: Principled metallic with roughness > 0: GGX reflection with the
          metal's Schlick (F82, white tint) Fresnel per channel, Multiscatter GGX energy
          compensation with Fss its hemispherical average.
        - rough_glass: glass with roughness > 0: GGX reflection and refraction (Walter et
          al. 2007) with the tints and the dielectric Fresnel of glass, Multiscatter GGX
          energy compensation from the glass' own albedo tables (bsdf.py).
        - translucent: Cycles' Translucent BSDF: Lambert transmission, f = colour / pi
          toward the other side of the surface (diffuse light through a leaf or a lamp
          shade). It does not enter a medium inside the mesh (Cycles would).
        - none: no BSDF (a pure Emission shader): paths end here.
        - holdout: Cycles' Holdout: a camera path (straight or through transparent
          surfaces) ends here leaving the pixel transparent by its throughput's average,
          whether or not the film is (integrate_surface_holdout); any other path ends
          here as on `none`. Its Depth and Normal are not written.
        - transparent: Cycles' Transparent BSDF: light passes straight through, weighted by
          `colour`, as if the surface were not there (no bounce counted, only a transparent
          one); shadow rays cross it the same way (Cycles' transparent shadows). A
          Principled BSDF's Alpha a is a mix of transparent white (1 - a) and the rest (a).
        - mix: scale x ((1 - fac) x components[0] + fac x components[1]) (Cycles' Mix
          Shader: scale 1; Add Shader: fac 1/2, scale 2). A path picks one component per
          hit, the second with probability fac, and carries the scale (an unbiased
          estimate of the sum: the components are sampled and evaluated alone). Emission
          is the components' emission mixed the same way (plus the mix's own).
          A mix with coat_ior > 0 is instead Cycles' Principled coat layer
          (Material.coated): components[1] is the coat's lobe (GGX with a dielectric
          Fresnel of index coat_ior, energy compensated) of weight fac (the Coat Weight),
          and components[0] what lies below, dimmed by the coat's albedo at the view as
          Cycles estimates it, 1 - fac x A(cos_o) (bsdf.coat_layering), and by its tint,
          mix(1, coat_tint^(1 / cos_t), fac), cos_t the view's cosine refracted into the
          coat. Emission below a coat (the mix's own: a Principled BSDF's) is dimmed the
          same way at the view (Materials.emission_root). A mix with sheen_layer is
          Cycles' Principled sheen (Material.sheened): components[1] is a sheen lobe of
          weight fac (the Sheen Weight) and what lies below keeps 1 - max(fac x colour x
          albedo(cos_o)) of it.
        - sheen: Cycles' microfiber sheen (the Sheen BSDF, and the Principled BSDF's sheen
          lobe): `colour` x its albedo at the view x a linearly transformed cosine of
          `roughness` (bsdf.eval_sheen, Zeltner et al. 2022).
    emission : (3,) radiance L = strength x colour, two-sided, no division by pi.
    colour_program : a shading.Program whose result replaces `colour` at each hit (an image
        texture on the colour), or None. `colour` is then what the program's result is
        approximated by where a constant is needed (its mean).
    normal_program, normal_strength : a tangent-space normal map (Cycles' Normal Map node)
        over the shading normal, for any kind.
    height_program : a Bump node over that normal: a Program whose result's first channel
        is Distance x Height (negated by Invert) and second the node's Strength; the kernel
        takes its gradient over the surface (shading.bump_normal), for any kind.
    roughness_program : a Program whose first channel replaces `roughness` at each hit
        (clamped to [0, 1]) for the GGX kinds; `roughness` then stands for its mean, and the
        kind stays rough (a microfacet lobe) even where that mean is 0.
    emission_program : a Program whose result replaces `emission` at each point (a textured
        emission colour, strength included); `emission` then stands for it where a constant
        is needed (choosing lights by power), so it must be > 0.
    absorption : (3,) sigma_a per world unit of the homogeneous medium inside the meshes
        wearing the material (Cycles' Volume Absorption: density x (1 - colour)); paths
        reach it through a transmitting surface (glass, a volume boundary), media.py.
    scattering, anisotropy : (3,) sigma_s per world unit of that medium and its
        Henyey-Greenstein g (Cycles' Volume Scatter: density x colour).
    volume_emission : (3,) the medium's emitted radiance per world unit (Cycles' volume
        Emission: strength x colour).
    A "boundary" material is a Volume-only material's surface: none (paths and shadow rays
    cross it as Cycles crosses one, counted apart) around its medium.
    """

    name: str
    kind: str = "diffuse"
    colour: tuple = (0.8, 0.8, 0.8)
    ior: float = 1.5
    reflection_tint: tuple = (1.0, 1.0, 1.0)
    transmission_tint: tuple = (1.0, 1.0, 1.0)
    emission: tuple = (0.0, 0.0, 0.0)
    roughness: float = 0.0
    # Multiscatter GGX (Cycles' default distribution): the energy single scattering misses
    # is given back (Kulla-Conty); False is Cycles' plain GGX.
    multiscatter: bool = True
    colour_program: Program | None = field(default=None, compare=False)
    emission_program: Program | None = field(default=None, compare=False)
    # A tangent-space normal map: the program of the colour feeding the Normal Map node
    # (shading.normal_map) and the node's strength; its tangents come with the mesh
    # (SceneBuilder.add_mesh).
    normal_program: Program | None = field(default=None, compare=False)
    normal_strength: float = 1.0
    height_program: Program | None = field(default=None, compare=False)  # a Bump node
    # The height program is the Material Output's Displacement (Bump Only): its tilted
    # normal becomes the surface's own (Cycles' SetNormal), so bump shadowing
    # (bsdf.bump_shadowing) is measured from it, not from the mesh's smooth normal.
    sets_normal: bool = False
    absorption: tuple = (0.0, 0.0, 0.0)
    scattering: tuple = (0.0, 0.0, 0.0)
    anisotropy: float = 0.0
    volume_emission: tuple = (0.0, 0.0, 0.0)
    components: tuple = ()  # mix: the two Materials mixed
    fac: float = 0.0  # mix: the weight of components[1] (a constant standing for fac_program)
    # mix: a Program whose result's first channel is the factor at each hit (a textured Mix
    # Shader Fac, a Principled BSDF's textured Metallic), clamped to [0, 1] as Cycles does.
    fac_program: Program | None = field(default=None, compare=False)
    scale: float = 1.0  # mix: the factor of the whole sum
    roughness_program: Program | None = field(default=None, compare=False)
    # A Program whose result replaces the Specular Tint (principled, glass kinds:
    # `specular_tint`; metal kinds: `reflection_tint`, at most 1) or a coat's `coat_tint`.
    tint_program: Program | None = field(default=None, compare=False)
    # The Principled BSDF's Diffuse Roughness: its base is Oren-Nayar of this roughness
    # (bsdf.oren_nayar_ratio, Lambert at 0), which may vary (a program).
    diffuse_roughness: float = 0.0
    diffuse_roughness_program: Program | None = field(default=None, compare=False)
    # The Principled BSDF's IOR and Specular IOR Level where either varies: a Program whose
    # result's first two channels are them at each hit; its dielectric layer's relative IOR
    # is then fresnel.specular_eta of them (`ior`, the constant, stands for their means).
    specular_ior_program: Program | None = field(default=None, compare=False)
    # An anisotropic GGX lobe (principled, rough_metal: the Principled BSDF's Anisotropic;
    # glossy: the Glossy BSDF's Anisotropy, each in Cycles' own convention,
    # bsdf.anisotropic_alphas), turned by `anisotropic_rotation` (of a full turn) about the
    # normal from the tangent the `tangent_program` gives (a vector; the Tangent input, by
    # default shading.radial_tangent("Z")); `anisotropy_program` may give both per point
    # (its first two channels). See Material.with_anisotropy.
    specular_anisotropy: float = 0.0
    anisotropic_rotation: float = 0.0
    anisotropy_program: Program | None = field(default=None, compare=False)
    tangent_program: Program | None = field(default=None, compare=False)
    coat_ior: float = 0.0  # mix: > 0 makes it a coat layer of this IOR (see above)
    coat_tint: tuple = (1.0, 1.0, 1.0)  # coat: the colour light keeps through it head-on
    sheen_layer: bool = False  # mix: Cycles' Principled sheen over components[0] (see above)
    fresnel: bool = True  # glass kinds: False is the Refraction BSDF (no Fresnel)
    # Glass kinds: how the colour (or its program's result) tints reflection and
    # transmission, one of GLASS_TINTS (glass_tints).
    glass_tints: str = "colour"
    # The Principled BSDF's Specular Tint on its dielectric and glass Fresnel (Cycles: F0 x
    # tint rising to 1 as the real Fresnel does; fresnel.tinted_fresnel); white elsewhere.
    specular_tint: tuple = (1.0, 1.0, 1.0)
    # The Principled BSDF's Thin Film on its dielectric, glass and metal lobes (principled,
    # glass and metal kinds): (thickness in nm, the film's IOR); no film below
    # fresnel.THIN_FILM_MIN nm (fresnel.thin_film_dielectric, thin_film_f82).
    thin_film: tuple = (0.0, 1.33)
    # Where either varies: a Program whose result's first two channels are the film's
    # thickness and IOR at each hit (`thin_film` then stands for their means).
    thin_film_program: Program | None = field(default=None, compare=False)

    @classmethod
    def mix(cls, name, first, second, fac, scale=1.0, fac_program=None):
        """Cycles' Mix Shader (scale 1) or Add Shader (fac 1/2, scale 2) of two Materials."""
        fac, scale = float(fac), float(scale)
        if not (0.0 <= fac <= 1.0 and math.isfinite(scale) and scale >= 0.0):
            raise ValueError(f"material '{name}': a mix needs 0 <= fac <= 1 and a finite scale "
                             f">= 0, got fac {fac!r}, scale {scale!r}")
        return cls(name, "mix", (0.0, 0.0, 0.0), components=(first, second), fac=fac,
                   scale=scale, fac_program=fac_program)

    @classmethod
    def coated(cls, name, base, weight, roughness=0.03, ior=1.5, tint=(1.0, 1.0, 1.0),
               weight_program=None, roughness_program=None, tint_program=None):
        """Cycles' Principled coat (Coat Weight, Roughness, IOR, Tint) over `base`: a mix
        whose second component is the coat's own lobe, a Principled specular layer over
        black, energy compensated (Cycles' bsdf_microfacet_setup_fresnel_dielectric
        compensates it with the dielectric's Fss, whichever the Principled's
        distribution)."""
        ior = float(ior)
        if not (math.isfinite(ior) and ior >= 1.0):
            raise ValueError(f"material '{name}': a coat's IOR must be >= 1, got {ior!r}")
        m = cls.mix(name, base, cls.coat_lobe(name, roughness, ior, roughness_program), weight,
                    1.0, weight_program)
        return dataclasses.replace(m, coat_ior=ior, coat_tint=tuple(tint),
                                   tint_program=tint_program)

    @classmethod
    def coat_lobe(cls, name, roughness=0.03, ior=1.5, roughness_program=None):
        """The lobe of Cycles' Principled coat: GGX reflection with the dielectric Fresnel of
        `ior`, energy compensated, i.e. a Principled specular layer over black."""
        return cls.principled(name, (0.0, 0.0, 0.0), roughness, ior,
                              roughness_program=roughness_program, multiscatter=True)

    @classmethod
    def sheened(cls, name, base, weight, roughness=0.5, tint=(1.0, 1.0, 1.0),
                weight_program=None, tint_program=None, roughness_program=None):
        """Cycles' Principled sheen (Sheen Weight, Roughness, Tint) over `base`: a mix whose
        second component is the sheen lobe (Material.sheen of colour `tint`)."""
        lobe = cls.sheen(name, tint, roughness, tint_program, roughness_program)
        m = cls.mix(name, base, lobe, weight, 1.0, weight_program)
        return dataclasses.replace(m, sheen_layer=True)

    @classmethod
    def sheen(cls, name, colour=(1.0, 1.0, 1.0), roughness=0.5, colour_program=None,
              roughness_program=None):
        """Cycles' microfiber sheen (the Sheen BSDF, the Principled BSDF's sheen lobe):
        reflection by the linearly transformed cosine of roughness `roughness`, weighted by
        its albedo at the view and `colour` (bsdf.eval_sheen); either may vary (programs)."""
        return cls(name, "sheen", tuple(colour), roughness=float(roughness),
                   colour_program=colour_program, roughness_program=roughness_program)

    @classmethod
    def diffuse(cls, name, colour, emission=(0, 0, 0), colour_program=None,
                emission_program=None, roughness=0.0, roughness_program=None):
        """Cycles' Diffuse BSDF: Lambert, or at Roughness > 0 Oren-Nayar
        (bsdf.oren_nayar_ratio); the roughness may vary (a program)."""
        return cls(name, "diffuse", tuple(colour), emission=tuple(emission),
                   colour_program=colour_program, emission_program=emission_program,
                   roughness=float(roughness), roughness_program=roughness_program)

    @classmethod
    def mirror(cls, name, colour=(1, 1, 1), emission=(0, 0, 0), colour_program=None,
               emission_program=None):
        return cls(name, "mirror", tuple(colour), emission=tuple(emission),
                   colour_program=colour_program, emission_program=emission_program)

    @classmethod
    def metal(cls, name, base_colour, emission=(0, 0, 0), colour_program=None,
              emission_program=None, roughness=0.0, multiscatter=True, roughness_program=None,
              specular_tint=(1.0, 1.0, 1.0), tint_program=None, thin_film=(0.0, 1.33),
              thin_film_program=None):
        """Principled metallic: smooth at Cycles' delta roughness, else rough; its Specular
        Tint (or its program's result) above 1 is 1, as Cycles takes it."""
        rough = roughness > DELTA_ROUGHNESS or roughness_program is not None
        edge = tuple(min(float(t), 1.0) for t in specular_tint)
        return cls(name, "rough_metal" if rough else "metal", tuple(base_colour),
                   reflection_tint=edge, emission=tuple(emission), roughness=float(roughness),
                   multiscatter=bool(multiscatter), colour_program=colour_program,
                   emission_program=emission_program, roughness_program=roughness_program,
                   tint_program=tint_program, thin_film=_thin_film(name, thin_film),
                   thin_film_program=thin_film_program)

    @classmethod
    def glass(cls, name, colour=(1, 1, 1), ior=1.45, emission=(0, 0, 0),
              emission_program=None, roughness=0.0, multiscatter=True, roughness_program=None,
              colour_program=None):
        """Cycles' Glass BSDF: colour tints reflection and transmission alike."""
        return cls._glass(name, "colour", colour, ior, roughness, roughness_program,
                          emission=tuple(emission), emission_program=emission_program,
                          multiscatter=bool(multiscatter), colour_program=colour_program)

    @classmethod
    def _glass(cls, name, tints, colour, ior, roughness, roughness_program, **kwargs):
        """A glass kind whose tints its colour gives by the model `tints` (glass_tints)."""
        c = np.asarray(colour, np.float64)
        t = glass_tints(GLASS_TINTS.index(tints), c[0], c[1], c[2])
        kind = _glass_kind(roughness, ior, roughness_program)
        return cls(name, kind, tuple(colour), ior, t[:3], t[3:], roughness=float(roughness),
                   roughness_program=roughness_program if kind == "rough_glass" else None,
                   glass_tints=tints, **kwargs)

    @classmethod
    def refraction(cls, name, colour=(1, 1, 1), ior=1.45, roughness=0.0,
                   roughness_program=None, colour_program=None):
        """Cycles' Refraction BSDF: refraction only, tinted by colour, without Fresnel."""
        return cls._glass(name, "refraction", colour, ior, roughness, roughness_program,
                          multiscatter=False, fresnel=False, colour_program=colour_program)

    @classmethod
    def principled_glass(cls, name, base_colour=(1, 1, 1), ior=1.5, emission=(0, 0, 0),
                         emission_program=None, roughness=0.0, multiscatter=True,
                         roughness_program=None, colour_program=None,
                         specular_tint=(1.0, 1.0, 1.0), tint_program=None,
                         thin_film=(0.0, 1.33), thin_film_program=None):
        """Principled BSDF at Transmission 1: untinted reflection, sqrt(base) transmission,
        its Fresnel under the Specular Tint and its Thin Film."""
        return cls._glass(name, "principled", base_colour, ior, roughness, roughness_program,
                          emission=tuple(emission), emission_program=emission_program,
                          multiscatter=bool(multiscatter), colour_program=colour_program,
                          specular_tint=tuple(specular_tint), tint_program=tint_program,
                          thin_film=_thin_film(name, thin_film),
                          thin_film_program=thin_film_program)

    @classmethod
    def principled(cls, name, base_colour=(0.8, 0.8, 0.8), roughness=0.5, ior=1.5,
                   specular_ior_level=0.5, emission=(0, 0, 0), colour_program=None,
                   emission_program=None, roughness_program=None, multiscatter=True,
                   specular_tint=(1.0, 1.0, 1.0), tint_program=None, diffuse_roughness=0.0,
                   diffuse_roughness_program=None, specular_ior_program=None,
                   thin_film=(0.0, 1.33), thin_film_program=None):
        """Principled BSDF (metallic 0, transmission 0): a Lambert base (Oren-Nayar at a
        Diffuse Roughness > 0, clamped to 1 as Cycles does) under a GGX dielectric
        specular layer. Specular IOR Level rescales F0 as Cycles does (0.5 keeps the IOR);
        the Specular Tint scales F0 too (tinted_fresnel). `specular_ior_program` gives
        the IOR and the level per point where either varies (Material.specular_ior_program)."""
        ior = float(ior)
        if ior > 0:
            ior = float(specular_eta(ior, float(specular_ior_level)))
        return cls(name, "principled", tuple(base_colour), ior, emission=tuple(emission),
                   roughness=float(roughness), colour_program=colour_program,
                   emission_program=emission_program, roughness_program=roughness_program,
                   multiscatter=bool(multiscatter), specular_tint=tuple(specular_tint),
                   tint_program=tint_program,
                   diffuse_roughness=min(max(float(diffuse_roughness), 0.0), 1.0),
                   diffuse_roughness_program=diffuse_roughness_program,
                   specular_ior_program=specular_ior_program,
                   thin_film=_thin_film(name, thin_film), thin_film_program=thin_film_program)

    @classmethod
    def glossy(cls, name, colour=(1, 1, 1), roughness=0.0, emission=(0, 0, 0),
               colour_program=None, emission_program=None, multiscatter=True,
               roughness_program=None):
        """Glossy BSDF: a mirror at (Cycles-)zero roughness, else rough GGX reflection."""
        if roughness <= DELTA_ROUGHNESS and roughness_program is None:
            return cls.mirror(name, colour, emission, colour_program, emission_program)
        return cls(name, "glossy", tuple(colour), emission=tuple(emission),
                   roughness=float(roughness), multiscatter=bool(multiscatter),
                   colour_program=colour_program, emission_program=emission_program,
                   roughness_program=roughness_program)

    def with_anisotropy(self, specular_anisotropy, anisotropic_rotation=0.0,
                        tangent_program=None, anisotropy_program=None) -> "Material":
        """This material with an anisotropic GGX lobe: for a Principled BSDF (its metal and
        dielectric lobes: a mix's components of those kinds) or a rough Glossy BSDF; delta
        and other lobes stay as they are, as in Cycles (its glass and coat are isotropic).
        `tangent_program` is required (shading.radial_tangent("Z") is Cycles' default)."""
        anisotropy, rotation = specular_anisotropy, anisotropic_rotation
        if self.kind == "mix":  # a coat's own lobe (components[1]) stays isotropic
            parts = tuple(c if j == 1 and self.coat_ior > 0 else
                          c.with_anisotropy(anisotropy, rotation, tangent_program,
                                            anisotropy_program)
                          for j, c in enumerate(self.components))
            return dataclasses.replace(self, components=parts)
        if self.kind not in ANISOTROPIC_KINDS:
            return self
        if tangent_program is None:
            raise ValueError(f"material '{self.name}': an anisotropic lobe needs a tangent "
                             f"program (shading.radial_tangent)")
        a, r = float(anisotropy), float(rotation)
        if not (math.isfinite(a) and math.isfinite(r)):
            raise ValueError(f"material '{self.name}': anisotropy and rotation must be finite, "
                             f"got {anisotropy!r}, {rotation!r}")
        return dataclasses.replace(self, specular_anisotropy=a, anisotropic_rotation=r,
                                   tangent_program=tangent_program,
                                   anisotropy_program=anisotropy_program)

    @classmethod
    def translucent(cls, name, colour, colour_program=None):
        """Cycles' Translucent BSDF: Lambertian transmission tinted by colour."""
        return cls(name, "translucent", tuple(colour), colour_program=colour_program)

    @classmethod
    def boundary(cls, name, **medium):
        """A Volume-only material's surface: none, around its medium (absorption,
        scattering, anisotropy, volume_emission keywords)."""
        return cls(name, "boundary", (1.0, 1.0, 1.0), **medium)

    @classmethod
    def transparent(cls, name, colour=(1, 1, 1)):
        """Cycles' Transparent BSDF: straight through, tinted by colour."""
        return cls(name, "transparent", tuple(colour))

    @classmethod
    def holdout(cls, name):
        """Cycles' Holdout shader (and an object marked Holdout): a hole in the image."""
        return cls(name, "holdout", (0.0, 0.0, 0.0))

    @classmethod
    def emission_only(cls, name, colour=(1, 1, 1), strength=1.0, emission_program=None):
        """Cycles' Emission shader alone: radiance = strength x colour, no BSDF."""
        return cls(name, "none", (0, 0, 0), emission=tuple(float(strength) * np.asarray(colour)),
                   emission_program=emission_program)


def _flatten_mixes(materials: list[Material]) -> tuple[list[Material], list]:
    """The materials with every mix's components appended as rows of their own, and per row
    its component rows ((-1, -1) if not a mix). A mix's emission (its own plus its
    components', mixed as their BSDFs are) moves onto every component row below it: the
    path shades with one of them, and must see the emission of the whole."""
    out, components = list(materials), []
    given = len(out)
    i = 0
    while i < len(out):
        m = out[i]
        if m.kind != "mix":
            components.append((-1, -1))
            i += 1
            continue
        if len(m.components) != 2:
            raise ValueError(f"material '{m.name}': a mix needs two components")
        # A component row already carries the emission (and program) of the mix above it.
        if i < given and any(_emits(c, textured_only=True) for c in m.components):
            raise ValueError(f"material '{m.name}': a textured emission can only be a mix's "
                             f"own, not its components'")
        # A mix's own textured emission stands for its whole emission, the constants of its
        # components' included (a Principled BSDF's under its Alpha: alpha x E per point);
        # their mixed constants are its mean.
        total = _mixed_emission(m) if i < given else np.asarray(m.emission, np.float64)
        if i < given and m.emission_program is not None and not total.max() > 0:
            total = _emission_stand_in(m)
        out[i] = _with_emission(m, total, m.emission_program)
        rows = []
        for c in m.components:
            out.append(_with_emission(c, total, m.emission_program))
            rows.append(len(out) - 1)
        components.append(tuple(rows))
        i += 1
    return out, components


def _mixed_emission(m: Material) -> np.ndarray:
    own = np.asarray(m.emission, np.float64)
    if m.kind != "mix":
        return own
    a, b = (_mixed_emission(c) for c in m.components)
    if m.coat_ior > 0 or m.sheen_layer:  # the layer's lobe emits nothing; what is below
        return own + a  # (dimmed at each hit: _emission_parts)
    return own + m.scale * ((1.0 - m.fac) * a + m.fac * b)


def _emission_stand_in(m: Material) -> np.ndarray:
    """A positive constant to stand for mix m's textured emission where its components'
    constants mix to nothing, though its program emits (a glTF cut-out's Alpha, a step of
    its texture, whose constant reads 0): the kernel leaves out a surface whose constants
    emit nothing, and light choice weighs emitters by them. Any positive value keeps the
    render unbiased (the program gives the emission); the largest of its components'
    emissions, unweighted by the mixes, else 1."""
    def largest(x):
        own = np.asarray(x.emission, np.float64)
        if x.kind != "mix":
            return own
        return own + x.scale * np.maximum(largest(x.components[0]), largest(x.components[1]))
    e = largest(m)
    return e if e.max() > 0 else np.ones(3)


def _emission_parts(m: Material) -> tuple:
    """m's emission as (the part no layer dims (3,), the part under a sheen or coat (3,),
    the path of component choices from m down to the top layer mix over it, or None):
    what lies under a layer (a Principled BSDF's emission, its own on the layer mix) is
    dimmed by it and every layer under it. Where a plain mix holds two layered emissions,
    the second is taken undimmed."""
    own = np.asarray(m.emission, np.float64)
    zero = np.zeros(3)
    if m.kind != "mix":
        return own, zero, None
    a = _emission_parts(m.components[0])
    if m.coat_ior > 0 or m.sheen_layer:  # the layer's lobe emits nothing
        return zero, own + a[0] + a[1], ()
    b = _emission_parts(m.components[1])
    f, s = m.fac, m.scale
    rest = own + s * ((1.0 - f) * a[0] + f * b[0])
    layered = s * ((1.0 - f) * a[1] + f * b[1])
    if a[2] is not None and b[2] is not None:
        return rest + s * f * b[1], s * (1.0 - f) * a[1], (0,) + a[2]
    if a[2] is not None:
        return rest, layered, (0,) + a[2]
    if b[2] is not None:
        return rest, layered, (1,) + b[2]
    return rest, zero, None


def _emits(m: Material, textured_only=False) -> bool:
    """Whether m or anything mixed into it emits (has a textured emission)."""
    own = m.emission_program is not None or not textured_only and max(m.emission) > 0
    return own or any(_emits(c, textured_only) for c in m.components)


def _with_emission(m: Material, emission, program=None) -> Material:
    """m (and, for a mix, its components, recursively) emitting `emission` in total, or
    its textured `program` (a mix's own textured emission, `emission` its constant)."""
    e = tuple(float(x) for x in emission)
    if m.kind != "mix":
        return dataclasses.replace(m, emission=e, emission_program=program)
    return dataclasses.replace(m, emission=e, emission_program=program,
                               components=tuple(_with_emission(c, emission, program)
                                                for c in m.components))


def _glass_kind(roughness, ior, roughness_program=None) -> str:
    """Smooth glass at Cycles' delta roughness (unless textured), or at an IOR refracting
    straight through."""
    rough = (roughness > DELTA_ROUGHNESS or roughness_program is not None) and \
        abs(float(ior) - 1.0) >= DELTA_IOR
    return "rough_glass" if rough else "glass"


@dataclass(frozen=True)
class Materials:
    """The materials table as arrays; row i describes material index i.

    kind : (k,) int32, one of the kinds above (KIND_NAMES)
    colour, reflection_tint, transmission_tint, emission : (k, 3) float64
    ior : (k,) float64
    names : list of k str
    roughness : (k,) float64; multiscatter : (k,) bool (Material.multiscatter)
    """

    kind: np.ndarray
    colour: np.ndarray
    ior: np.ndarray
    reflection_tint: np.ndarray
    transmission_tint: np.ndarray
    emission: np.ndarray
    names: list
    roughness: np.ndarray | None = None
    multiscatter: np.ndarray | None = None
    # Per material its colour's and its emission's shading.Program or None (textures).
    colour_programs: list | None = None
    emission_programs: list | None = None
    normal_programs: list | None = None
    normal_strength: np.ndarray | None = None
    absorption: np.ndarray | None = None  # (k, 3), Material.absorption
    scattering: np.ndarray | None = None  # (k, 3), Material.scattering
    anisotropy: np.ndarray | None = None  # (k,), Material.anisotropy
    volume_emission: np.ndarray | None = None  # (k, 3), Material.volume_emission
    # Mixes: per row its two component rows (-1, -1 if not a mix), fac and scale; the
    # components are rows after the materials given (from_list flattens them).
    mix_components: np.ndarray | None = None
    mix_fac: np.ndarray | None = None
    mix_scale: np.ndarray | None = None
    # Coats (mixes with Material.coat_ior > 0): per row the coat's IOR (0: a plain mix) and
    # its tint (k, 3).
    coat_ior: np.ndarray | None = None
    coat_tint: np.ndarray | None = None
    sheen_layer: np.ndarray | None = None  # (k,) bool, Material.sheen_layer
    sheen_parent: np.ndarray | None = None  # (k,) int: a sheen lobe's layer row, else -1
    # An emission under a Principled BSDF's sheen or coat is dimmed by them at the view, as
    # Cycles dims it: per row the top layer (a sheen or coat mix row) whose layers dim the
    # share (k, 3) of its emission that lies under them (-1 and 0: none).
    emission_root: np.ndarray | None = None
    emission_share: np.ndarray | None = None
    fresnel: np.ndarray | None = None  # (k,) bool, Material.fresnel
    sets_normal: np.ndarray | None = None  # (k,) bool, Material.sets_normal
    glass_tints: np.ndarray | None = None  # (k,) int, GLASS_TINTS.index(Material.glass_tints)
    specular_tint: np.ndarray | None = None  # (k, 3), Material.specular_tint
    thin_film: np.ndarray | None = None  # (k, 2), Material.thin_film
    fac_programs: list | None = None  # per row a mix's factor Program or None (textures)
    roughness_programs: list | None = None  # per row a GGX lobe's roughness Program or None
    height_programs: list | None = None  # per row a Bump node's height Program or None
    tint_programs: list | None = None  # per row a Specular or Coat Tint Program or None
    diffuse_roughness: np.ndarray | None = None  # (k,), Material.diffuse_roughness
    diffuse_roughness_programs: list | None = None  # per row its Program or None
    specular_ior_programs: list | None = None  # per row Material.specular_ior_program or None
    thin_film_programs: list | None = None  # per row Material.thin_film_program or None
    # (k,) Material.specular_anisotropy and .anisotropic_rotation, and per row the
    # anisotropy and tangent Programs or None.
    specular_anisotropy: np.ndarray | None = None
    anisotropic_rotation: np.ndarray | None = None
    anisotropy_programs: list | None = None
    tangent_programs: list | None = None

    @classmethod
    def from_list(cls, materials: list[Material]) -> "Materials":
        given = list(materials)
        materials, components = _flatten_mixes(given)
        m = cls._rows(materials)
        fac = np.array([float(x.fac) if x.kind == "mix" else 0.0 for x in materials])
        scale = np.array([float(x.scale) if x.kind == "mix" else 1.0 for x in materials])
        coat_ior = np.array([float(x.coat_ior) if x.kind == "mix" else 0.0 for x in materials])
        if not np.all((coat_ior == 0.0) | (coat_ior >= 1.0)):  # also NaN
            bad = next(x for x, c in zip(materials, coat_ior) if not (c == 0 or c >= 1))
            raise ValueError(f"material '{bad.name}': a coat's IOR must be >= 1, got "
                             f"{bad.coat_ior!r}")
        tint = np.array([_colour(x.coat_tint, f"material '{x.name}' coat tint")
                         for x in materials]).reshape(-1, 3)
        sheen = np.array([x.kind == "mix" and bool(x.sheen_layer) for x in materials], bool)
        components = np.array(components, np.int64).reshape(-1, 2)
        parent = np.full(len(materials), -1, np.int64)
        parent[components[sheen, 1]] = np.flatnonzero(sheen)
        m = dataclasses.replace(m, mix_components=components, mix_fac=fac, mix_scale=scale,
                                coat_ior=coat_ior, coat_tint=tint, sheen_layer=sheen,
                                sheen_parent=parent)
        root, share = np.full(len(materials), -1, np.int64), np.zeros((len(materials), 3))
        for i, top in enumerate(given):
            rest, layered, path = _emission_parts(top)
            if path is None:
                continue
            r = i
            for step in path:
                r = int(components[r, step])
            total = rest + layered
            rows = m.reachable([i])
            root[rows] = r
            share[rows] = np.divide(layered, total, out=np.zeros(3), where=total > 0)
        return dataclasses.replace(m, emission_root=root, emission_share=share)

    def reachable(self, rows) -> np.ndarray:
        """`rows` and every mix component below them (the materials a hit can shade with)."""
        seen = set(int(r) for r in rows)
        todo = list(seen)
        while todo:
            for c in self.mix_components[todo.pop()] if self.mix_components is not None else ():
                if c >= 0 and int(c) not in seen:
                    seen.add(int(c))
                    todo.append(int(c))
        return np.array(sorted(seen), np.int64)

    @classmethod
    def _rows(cls, materials: list[Material]) -> "Materials":
        kinds = {v: k for k, v in KIND_NAMES.items()}
        rows = []
        for m in materials:
            if m.kind not in kinds:
                raise ValueError(f"material '{m.name}': unknown kind {m.kind!r}")
            ior = float(m.ior)
            if not math.isfinite(ior) or ior <= 0:
                raise ValueError(f"material '{m.name}': IOR must be > 0 and finite, got {m.ior!r}")
            r = float(m.roughness)
            if not (0.0 <= r <= 1.0):
                raise ValueError(f"material '{m.name}': roughness must be in [0, 1], got "
                                 f"{m.roughness!r}")
            rows.append((kinds[m.kind], _colour(m.colour, f"material '{m.name}' colour"), ior,
                         _colour(m.reflection_tint, f"material '{m.name}' reflection tint"),
                         _colour(m.transmission_tint, f"material '{m.name}' transmission tint"),
                         _colour(m.emission, f"material '{m.name}' emission")))
        if not rows:
            rows.append((DIFFUSE, np.full(3, 0.8), 1.5, np.ones(3), np.ones(3), np.zeros(3)))
            materials = [Material("default")]
        k, c, i, rt, tt, e = zip(*rows)
        programs = [m.colour_program for m in materials]
        emission_programs = [m.emission_program for m in materials]
        for m in materials:
            if m.colour_program is not None and m.kind not in TEXTURED_KINDS:
                raise ValueError(f"material '{m.name}': a {m.kind} material's colour cannot "
                                 f"vary (textured colours: {', '.join(TEXTURED_KINDS)})")
            if m.emission_program is not None and not max(m.emission) > 0:
                raise ValueError(f"material '{m.name}': a textured emission needs a positive "
                                 f"constant emission standing for it, got {m.emission!r}")
        normal_programs = [m.normal_program for m in materials]
        for m in materials:
            if not (math.isfinite(float(m.normal_strength)) and m.normal_strength >= 0):
                raise ValueError(f"material '{m.name}': normal map strength must be >= 0, "
                                 f"got {m.normal_strength!r}")
        absorption = np.array([_colour(m.absorption, f"material '{m.name}' absorption")
                               for m in materials])
        medium = (absorption,
                  np.array([_colour(m.scattering, f"material '{m.name}' scattering")
                            for m in materials]),
                  np.array([_anisotropy(m) for m in materials]),
                  np.array([_colour(m.volume_emission, f"material '{m.name}' volume emission")
                            for m in materials]))
        for m in materials:
            _check_varying(m)
        lists = (programs, emission_programs, normal_programs,  # then Material.<slot>_program
                 *([getattr(m, f"{slot}_program") for m in materials] for slot in SLOTS[3:]))
        textured = any(p is not None for progs in lists for p in progs)
        (programs, emission_programs, normal_programs, fac_programs, roughness_programs,
         height_programs, tint_programs, diffuse_roughness_programs, anisotropy_programs,
         tangent_programs, specular_ior_programs, thin_film_programs) = \
            lists if textured else (None,) * len(lists)
        return cls(np.array(k, np.int32), np.array(c), np.array(i), np.array(rt), np.array(tt),
                   np.array(e), [m.name for m in materials],
                   np.array([float(m.roughness) for m in materials]),
                   np.array([bool(m.multiscatter) for m in materials]),
                   programs, emission_programs, normal_programs,
                   np.array([float(m.normal_strength) for m in materials]), *medium,
                   fac_programs=fac_programs, roughness_programs=roughness_programs,
                   height_programs=height_programs, tint_programs=tint_programs,
                   diffuse_roughness_programs=diffuse_roughness_programs,
                   diffuse_roughness=np.array([float(m.diffuse_roughness) for m in materials]),
                   anisotropy_programs=anisotropy_programs, tangent_programs=tangent_programs,
                   specular_ior_programs=specular_ior_programs,
                   specular_anisotropy=np.array([float(m.specular_anisotropy)
                                                 for m in materials]),
                   anisotropic_rotation=np.array([float(m.anisotropic_rotation)
                                                  for m in materials]),
                   fresnel=np.array([bool(m.fresnel) for m in materials]),
                   sets_normal=np.array([bool(m.sets_normal) for m in materials]),
                   glass_tints=np.array([GLASS_TINTS.index(m.glass_tints) for m in materials],
                                        np.int64),
                   specular_tint=np.array([_specular_tint(m) for m in materials]),
                   thin_film=np.array([m.thin_film for m in materials], np.float64),
                   thin_film_programs=thin_film_programs)

    @property
    def medium(self) -> np.ndarray | None:
        """Each material's medium as the kernel reads it (k, media.COLUMNS)."""
        if self.absorption is None:
            return None
        k = len(self.absorption)
        zeros = np.zeros((k, 3))
        return medium_table(self.absorption,
                            zeros if self.scattering is None else self.scattering,
                            np.zeros(k) if self.anisotropy is None else self.anisotropy,
                            zeros if self.volume_emission is None else self.volume_emission)

    def program_lists(self) -> tuple:
        """The materials' programs per shading.SLOTS (colour, emission, normal, fac,
        roughness, height, tint, diffuse roughness, anisotropy, tangent, specular IOR, thin
        film), each a list with one Program or None per row."""
        return (self.colour_programs, self.emission_programs, self.normal_programs,
                self.fac_programs, self.roughness_programs, self.height_programs,
                self.tint_programs, self.diffuse_roughness_programs,
                self.anisotropy_programs, self.tangent_programs, self.specular_ior_programs,
                self.thin_film_programs)

    def varying_ior(self) -> np.ndarray:
        """(k,) bool: the rows whose dielectric layer's IOR varies over the surface (a
        Principled BSDF's specular IOR program)."""
        return np.array([p is not None for p in
                         (self.specular_ior_programs or [None] * len(self.kind))], bool)

    def anisotropic(self) -> np.ndarray:
        """(k,) bool: the rows whose GGX lobe may be anisotropic."""
        k = len(self.kind)
        a = self.specular_anisotropy if self.specular_anisotropy is not None else np.zeros(k)
        varying = np.array([p is not None for p in (self.anisotropy_programs or [None] * k)],
                           bool)
        return (a != 0.0) | varying

    def __len__(self):
        return len(self.kind)


@dataclass(frozen=True)
class Camera:
    """A Blender camera as Cycles maps it (see cycles_conventions.md, section 1).

    world_from_camera : (4, 4) float64, the camera object's matrix_world; its scale is
        ignored and the camera looks down its local -Z with +Y up.
    type : "PERSP" or "ORTHO".
    lens_mm : focal length in mm (perspective). ortho_scale : view width (orthographic).
    sensor_width, sensor_height : mm. sensor_fit : "AUTO", "HORIZONTAL" or "VERTICAL".
    shift_x, shift_y : in units of the fit axis' full extent.
    clip_start, clip_end : planar clip distances along the view axis.
    use_dof, fstop, focus_distance : thin lens; radius = lens_mm * 1e-3 / (2 * fstop)
        (1 / (2 * fstop) for orthographic), focus plane at focus_distance along the axis.
    blades (< 3 means a round aperture), rotation (radians), ratio (anamorphic; lens x
        is divided by it).
    pixel_aspect_x, pixel_aspect_y : Blender's pixel aspect.
    """

    world_from_camera: np.ndarray = field(default_factory=lambda: np.eye(4))
    type: str = "PERSP"
    lens_mm: float = 50.0
    ortho_scale: float = 6.0
    sensor_width: float = 36.0
    sensor_height: float = 24.0
    sensor_fit: str = "AUTO"
    shift_x: float = 0.0
    shift_y: float = 0.0
    clip_start: float = 0.1
    clip_end: float = 1000.0
    use_dof: bool = False
    fstop: float = 2.8
    focus_distance: float = 10.0
    blades: int = 0
    rotation: float = 0.0
    ratio: float = 1.0
    pixel_aspect_x: float = 1.0
    pixel_aspect_y: float = 1.0

    def validate(self) -> None:
        m = np.asarray(self.world_from_camera, dtype=np.float64)
        if m.shape != (4, 4) or not np.all(np.isfinite(m)):
            raise ValueError(f"camera matrix must be a finite 4x4 matrix, got {m!r}")
        if self.type not in CAMERA_TYPES:
            raise ValueError(f"camera type must be one of {CAMERA_TYPES}, got {self.type!r}")
        if self.sensor_fit not in SENSOR_FITS:
            raise ValueError(f"sensor fit must be one of {SENSOR_FITS}, got {self.sensor_fit!r}")
        for name in ("lens_mm", "ortho_scale", "sensor_width", "sensor_height", "ratio",
                     "pixel_aspect_x", "pixel_aspect_y"):
            _positive(getattr(self, name), f"camera {name}")
        if self.use_dof:
            _positive(self.fstop, "camera fstop")
            if not math.isfinite(float(self.focus_distance)) or self.focus_distance < 0:
                raise ValueError(f"camera focus_distance must be >= 0, got {self.focus_distance!r}")
            if not math.isfinite(float(self.rotation)):
                raise ValueError(f"camera aperture rotation must be finite, got {self.rotation!r}")
        for name in ("shift_x", "shift_y", "clip_start", "clip_end"):
            if not math.isfinite(float(getattr(self, name))):
                raise ValueError(f"camera {name} must be finite, got {getattr(self, name)!r}")
        if self.clip_start < 0 or self.clip_end <= self.clip_start:
            raise ValueError(f"camera clip range must satisfy 0 <= start < end, got "
                             f"{self.clip_start!r}..{self.clip_end!r}")

    @property
    def aperture_radius(self) -> float:
        """Lens radius in scene units, Cycles' `aperturesize` (0 without DOF)."""
        if not self.use_dof:
            return 0.0
        fstop = max(float(self.fstop), 1e-5)
        if self.type == "ORTHO":
            return 1.0 / (2.0 * fstop)
        return self.lens_mm * 1e-3 / (2.0 * fstop)


LIGHT_TYPES = ("POINT", "SPOT", "SUN", "AREA")
AREA_SHAPES = ("SQUARE", "RECTANGLE", "DISK", "ELLIPSE")


@dataclass(frozen=True)
class Light:
    """A Blender light object, in Cycles' units (see engine/lights.py for the radiometry).

    type : "POINT", "SPOT", "SUN" or "AREA".
    power : (3,) colour x power in W (Cycles' strength); for a sun, irradiance in W/m^2.
    matrix : (4, 4) the object's matrix_world (the light emits along local -Z; area size
        and spot cone follow the object's scale).
    radius : point/spot radius (Blender's shadow_soft_size); soft_falloff : Blender 4.1+'s
        "Soft Falloff" (on: a disk facing the shading point; off: a sphere).
    spot_size, spot_blend : full cone angle (radians) and blend of a spot.
    angle : a sun's angular diameter (radians).
    shape, size_x, size_y, spread, normalize : area light shape, size, spread (radians)
        and whether power is normalised by area (Blender 4.5+; default on).
    visible_camera : camera rays see the light (Blender's object ray visibility; off by
        default for lights). use_mis : BSDF rays can hit it (Cycles' "Multiple Importance"
        light option, on by default); off, it is reached by light sampling only.
    """

    name: str
    type: str
    power: tuple
    matrix: np.ndarray = field(default_factory=lambda: np.eye(4))
    radius: float = 0.0
    soft_falloff: bool = True
    spot_size: float = math.pi / 4
    spot_blend: float = 0.15
    angle: float = 0.0
    shape: str = "SQUARE"
    size_x: float = 1.0
    size_y: float = 1.0
    spread: float = math.pi
    normalize: bool = True
    visible_camera: bool = False
    use_mis: bool = True

    def validate(self) -> None:
        who = f"light '{self.name}'"
        if self.type not in LIGHT_TYPES:
            raise ValueError(f"{who}: type must be one of {LIGHT_TYPES}, got {self.type!r}")
        _colour(self.power, f"{who} power")
        m = np.asarray(self.matrix, dtype=np.float64)
        if m.shape != (4, 4) or not np.all(np.isfinite(m)):
            raise ValueError(f"{who}: matrix must be a finite 4x4 matrix")
        for name in ("radius", "spot_size", "spot_blend", "angle", "size_x", "size_y", "spread"):
            v = float(getattr(self, name))
            if not math.isfinite(v) or v < 0:
                raise ValueError(f"{who}: {name} must be a finite number >= 0, got {v!r}")
        if self.type == "AREA" and self.shape not in AREA_SHAPES:
            raise ValueError(f"{who}: shape must be one of {AREA_SHAPES}, got {self.shape!r}")


@dataclass(frozen=True)
class World:
    """Background: escaped rays take radiance `colour` (colour x strength in Blender), or,
    with `environment` (H, W, 3) float radiance (strength applied, row 0 at the bottom),
    an equirectangular map looked up in the frame `texture_from_world` (3, 3), which is
    importance-sampled as a light; `ray_environments`, {path flags (shading.RAY_*): an
    image of the same size} the maps rays leaving the scene with those flags see instead
    (a world that tells them apart with a Light Path node, environment.bake_rays), or
    None: the same map for every ray.
    `volume`: the world's Volume, a homogeneous medium
    filling all space (Material.boundary's medium keywords: absorption, scattering,
    anisotropy, volume_emission), or None; every path starts in it, as in Cycles, where it
    also dims distant light to nothing and the background to black unless it scatters."""

    colour: tuple = (0.0, 0.0, 0.0)
    environment: np.ndarray | None = None
    texture_from_world: np.ndarray | None = None
    volume: dict | None = None
    ray_environments: dict | None = None

    def medium(self) -> Material | None:
        """The world's volume as a material row (none around it), or None."""
        if not self.volume:
            return None
        m = Material.boundary("world volume", **self.volume)
        if not (max(m.absorption) > 0 or max(m.scattering) > 0 or max(m.volume_emission) > 0):
            return None
        return m

    def validate(self) -> None:
        _colour(self.colour, "world colour")
        if self.volume:
            Materials.from_list([self.medium() or Material("world")])  # its values
        rays = self.ray_environments or {}
        if rays and self.environment is None:
            raise ValueError("world ray_environments need an environment")
        images = [("environment", self.environment)] + [
            (f"ray_environments[{flags!r}]", env) for flags, env in rays.items()]
        for name, env in images:
            if env is None:
                continue
            env = np.asarray(env)
            if env.ndim != 3 or env.shape[2] != 3 or env.shape[0] < 1 or env.shape[1] < 1:
                raise ValueError(f"world {name} must be an (H, W, 3) image, got {env.shape}")
            if env.shape != np.shape(self.environment):
                raise ValueError(f"world {name} must be the environment's size "
                                 f"{np.shape(self.environment)}, got {env.shape}")
            if not np.all(np.isfinite(env)) or env.min() < 0:
                raise ValueError(f"world {name} must be finite and non-negative")
        for flags in rays:
            if not (isinstance(flags, (int, np.integer)) and 0 < flags < 256):
                raise ValueError(f"world ray_environments: path flags must be an int in "
                                 f"1..255, got {flags!r}")
        if self.texture_from_world is not None:
            m = np.asarray(self.texture_from_world, np.float64)
            if m.shape != (3, 3) or not np.all(np.isfinite(m)) or abs(np.linalg.det(m)) < 1e-12:
                raise ValueError("world texture_from_world must be an invertible 3x3 matrix")


@dataclass(frozen=True)
class RenderSettings:
    """How to render.

    width, height : pixels. samples : samples per pixel (upper bound).
    time_limit : seconds, 0 for none. target_error : stop when the estimated relative
        error falls below it, 0 for none. max_bounces : Blender's count (0 = direct light).
    transparent_max_bounces : Cycles' Transparent bounce limit: the transparent surfaces
        (Transparent BSDF, alpha) a path or a shadow ray may cross; they do not count
        toward max_bounces.
    seed : sample-sequence seed. threads : worker threads (0 = all cores).
    fresnel : "exact" or "schlick". filter_type, filter_width : pixel filter (px).
    chunk_pixels : pixels traced at once per thread, bounding memory.
    kernel : "auto" (the kernel made for the scene's plan, starting with the generic kernel
        while it compiles if the generic one is loaded and the plan's is not), "generic"
        (the kernel with every feature, throughout) or "specialised" (the plan's kernel
        from the first pass, compiling it first if need be).
    region : optional (x0, y0, x1, y1) in full-frame pixels (row 0 at the bottom, x1 and
        y1 exclusive): render only that rectangle (Blender's render border). Pixels are
        sampled exactly as in a whole-frame render, so regions stitch into the same image.
    replicates : R, the number of independent replicates of the sample sequence (see
        film.Film): the error estimate has R - 1 degrees of freedom per pixel; 1 gives the
        plain sequence and no error estimate.
    replicate_range : optional (first, stop): render only replicates first..stop-1 of the
        R, with `samples` spread over them; renders of disjoint ranges merge exactly into
        the render of their union (`python -m addon merge`).
    light_tracing : trace light paths for caustics where the plan finds they can occur
        (caustics.py); False leaves path tracing alone.
    film_transparent : Blender's Film > Transparent: camera rays that reach the world,
        straight or through transparent surfaces, leave the pixel transparent (alpha) and
        do not see the world, which still lights the scene (Cycles).
    film_transparent_glass, film_transparent_roughness : Cycles' Film > Transparent Glass
        and its Roughness Threshold: with the film transparent, camera rays keep seeing
        through glass transmissions whose roughness is at most the threshold (GGX
        alpha_x alpha_y <= threshold^4, Cycles' transparent_roughness_squared_threshold),
        so the world behind glass is transparent too.
    """

    width: int = 480
    height: int = 360
    samples: int = 16
    time_limit: float = 0.0
    target_error: float = 0.0
    max_bounces: int = 12
    transparent_max_bounces: int = 8
    seed: int = 0
    threads: int = 0
    fresnel: str = "exact"
    filter_type: str = "BLACKMAN_HARRIS"
    filter_width: float = 1.5
    chunk_pixels: int = 1 << 16
    kernel: str = "auto"
    region: tuple | None = None
    replicates: int = DEFAULT_REPLICATES
    replicate_range: tuple | None = None
    light_tracing: bool = True
    film_transparent: bool = False
    film_transparent_glass: bool = False
    film_transparent_roughness: float = 0.1

    @property
    def clear_glass_threshold(self) -> float:
        """The largest GGX alpha_x alpha_y of a glass transmission a camera ray keeps seeing
        the film's transparency through (Cycles squares the Roughness Threshold twice), or
        -1 where none does: Transparent Glass off, or the film opaque."""
        if self.film_transparent and self.film_transparent_glass:
            return float(self.film_transparent_roughness) ** 4
        return -1.0

    @property
    def replicate_ids(self) -> tuple[int, ...]:
        """The replicates this render traces, in the order its passes cycle through them."""
        first, stop = self.replicate_range or (0, self.replicates)
        return tuple(range(int(first), int(stop)))

    def validate(self) -> None:
        for name in ("width", "height", "samples", "chunk_pixels"):
            v = getattr(self, name)
            if int(v) != v or v < 1:
                raise ValueError(f"render {name} must be a positive integer, got {v!r}")
        if int(self.max_bounces) != self.max_bounces or self.max_bounces < 0:
            raise ValueError(f"max_bounces must be an integer >= 0, got {self.max_bounces!r}")
        if int(self.transparent_max_bounces) != self.transparent_max_bounces or \
                self.transparent_max_bounces < 0:
            raise ValueError(f"transparent_max_bounces must be an integer >= 0, got "
                             f"{self.transparent_max_bounces!r}")
        if not (self.time_limit >= 0) or not (self.target_error >= 0):
            raise ValueError(f"time_limit and target_error must be >= 0, got "
                             f"{self.time_limit!r}, {self.target_error!r}")
        if self.threads < 0:
            raise ValueError(f"threads must be >= 0, got {self.threads!r}")
        if self.fresnel not in FRESNEL_MODELS:
            raise ValueError(f"fresnel must be one of {FRESNEL_MODELS}, got {self.fresnel!r}")
        if self.filter_type not in FILTER_TYPES:
            raise ValueError(f"filter_type must be one of {FILTER_TYPES}, got {self.filter_type!r}")
        _positive(self.filter_width, "filter_width")
        if not 0.0 <= self.film_transparent_roughness <= 1.0:
            raise ValueError(f"film_transparent_roughness must be in [0, 1], got "
                             f"{self.film_transparent_roughness!r}")
        if self.kernel not in KERNELS:
            raise ValueError(f"kernel must be one of {KERNELS}, got {self.kernel!r}")
        if int(self.replicates) != self.replicates or not 1 <= self.replicates <= MAX_REPLICATES:
            raise ValueError(f"replicates must be an integer from 1 to {MAX_REPLICATES}, got "
                             f"{self.replicates!r}")
        if self.replicate_range is not None:
            first, stop = self.replicate_range
            if not (int(first) == first and int(stop) == stop
                    and 0 <= first < stop <= self.replicates):
                raise ValueError(f"replicate_range must be (first, stop) with 0 <= first < "
                                 f"stop <= replicates ({self.replicates}), got "
                                 f"{self.replicate_range!r}")
        if self.target_error and len(self.replicate_ids) < 2:
            raise ValueError("target_error needs at least two replicates to estimate the error")
        if self.region is not None:
            x0, y0, x1, y1 = (int(v) for v in self.region)
            if not (0 <= x0 < x1 <= self.width and 0 <= y0 < y1 <= self.height):
                raise ValueError(f"region must satisfy 0 <= x0 < x1 <= width and "
                                 f"0 <= y0 < y1 <= height, got {self.region!r} for "
                                 f"{self.width}x{self.height}")

    @property
    def window(self) -> tuple[int, int, int, int]:
        """The rendered rectangle (x0, y0, x1, y1): the region, or the whole frame."""
        if self.region is None:
            return 0, 0, int(self.width), int(self.height)
        return tuple(int(v) for v in self.region)


@dataclass
class Scene:
    """A validated scene, geometry recentred.

    vertices : (t, 3, 3) float64, triangle corners relative to `origin` (world = origin + v)
    origin : (3,) float64, the recentring offset; embree gets float32(vertices)
    normals : (t, 3, 3) float64 unit per-corner shading normals, or None (flat everywhere)
    smooth : (t,) bool, whether triangle t interpolates `normals`
    material_index : (t,) int32 into `materials`
    object_index : (t,) int32 into `object_names`
    terminator_offset : (objects,) float64, each object's shadow terminator geometry
        offset (Cycles' Object > Shading setting; 0: none; see terminator.py)
    shared_vertices, shared_triangles : the same triangles as an indexed mesh, (m, 3) float64
        relative to `origin` and (t, 3) int32 (shared_vertices[shared_triangles] equals
        `vertices`): what the acceleration structure is built from, since embree's buffers
        fill several times faster with a vertex shared by its triangles copied once
    uv : (maps, t, 3, 3) float32 per-corner texture coordinates of the UV maps (w = 0) and
        the Generated and Object coordinates (shading.GENERATED, OBJECT) the colour
        programs read, or None without programs; the camera's maps (shading.VIEW_MAPS)
        are zeros until a render fills them (kernels.scene_data)
    uv_names : the names of `uv`'s maps, in order
    programs : the materials' shading.ProgramTable, or None without textured materials
    tangents : (t, 3, 4) float32 per-corner world-space tangents and bitangent signs for
        normal maps (zeros where a mesh has none), or None without normal maps
    """

    vertices: np.ndarray
    origin: np.ndarray
    normals: np.ndarray | None
    smooth: np.ndarray
    material_index: np.ndarray
    object_index: np.ndarray
    object_names: list
    materials: Materials
    camera: Camera
    world: World
    warnings: list = field(default_factory=list)
    lights: list = field(default_factory=list)
    shared_vertices: np.ndarray | None = None
    shared_triangles: np.ndarray | None = None
    terminator_offset: np.ndarray | None = None
    uv: np.ndarray | None = None
    programs: ProgramTable | None = None
    tangents: np.ndarray | None = None
    uv_names: list = field(default_factory=list)
    # The world volume's row of `materials` (World.volume; on no triangle), or -1.
    world_medium: int = -1
    # The camera (camera.CameraModel) whose view maps `uv` holds (kernels.fill_view_maps).
    view_maps_camera: object = field(default=None, compare=False, repr=False)

    def __post_init__(self):
        if self.terminator_offset is None:
            self.terminator_offset = np.zeros(len(self.object_names))

    @property
    def num_triangles(self) -> int:
        return len(self.vertices)

    @property
    def extent(self) -> float:
        """Largest coordinate magnitude of the recentred geometry (0 for an empty scene)."""
        return float(np.abs(self.vertices).max()) if len(self.vertices) else 0.0


class SceneBuilder:
    """Collects objects and materials, then validates and builds a `Scene`.

    >>> b = SceneBuilder()
    >>> m = b.add_material(Material.diffuse("grey", (0.5, 0.5, 0.5)))
    >>> b.add_mesh("floor", verts, tris, m)        # verts (n, 3), tris (t, 3)
    >>> scene = b.build(Camera(...), World((0.1, 0.1, 0.1)))
    """

    def __init__(self):
        self._lights: list[Light] = []
        self._materials: list[Material] = []
        self._meshes: list[tuple] = []
        self._uv_maps: list[dict] = []
        self._tangents: list = []
        self.warnings: list[str] = []

    def add_material(self, material: Material) -> int:
        self._materials.append(material)
        return len(self._materials) - 1

    def add_light(self, light: Light) -> None:
        """Add a light object; invalid parameters raise ValueError naming the light."""
        light.validate()
        self._lights.append(light)

    def add_mesh(self, name: str, vertices, triangles, material_index=0,
                 corner_normals=None, smooth=None, terminator_offset=0.0,
                 uv_maps=None, tangents=None) -> int:
        """Add one object's triangles in world space; returns how many were kept.

        vertices : (n, 3) float, world-space positions
        triangles : (t, 3) int indices into vertices
        material_index : int or (t,) int into the materials added so far
        corner_normals : optional (t, 3, 3) per-corner shading normals (world space)
        smooth : optional (t,) bool; triangles not smooth use their geometric normal
        terminator_offset : the object's shadow terminator geometry offset, 0..1 (Cycles'
            default for a Blender object is 0.1; 0 starts shadow rays on the flat triangles)
        uv_maps : optional dict, UV map name -> (t, 3, 2) or (t, 3, 3) per-corner
            coordinates (shading.GENERATED and OBJECT name the texture spaces); the name ""
            is the map an Image Texture without a Vector input reads (Blender's render-active
            map)
        tangents : optional (t, 3, 4) per-corner world-space tangent (xyz, unnormalised as
            Blender's) and bitangent sign of the UV map the triangle's normal map reads

        Only the checks run here; `build` gathers the corners of every mesh straight into
        the scene's arrays (a million-triangle mesh is 72 MB per copy of its corners).
        """
        v = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
        tri = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
        t = len(tri)
        if t and (tri.min() < 0 or tri.max() >= len(v)):
            raise ValueError(f"object '{name}': triangle indices out of range 0..{len(v) - 1}")
        mi = np.broadcast_to(np.asarray(material_index, dtype=np.int32), (t,)).copy()
        terminator_offset = float(terminator_offset)
        if not 0.0 <= terminator_offset <= 1.0:
            raise ValueError(f"object '{name}': shadow terminator geometry offset must be in "
                             f"0..1, got {terminator_offset!r}")
        normals = None
        if corner_normals is not None:
            normals = np.asarray(corner_normals, dtype=np.float64).reshape(t, 3, 3)
        sm = (np.ones(t, bool) if smooth is None else
              np.broadcast_to(np.asarray(smooth, bool), (t,)).copy())

        # Drop NaN/inf and degenerate (zero-area) triangles, and say how many.
        finite_v = np.isfinite(v).all(axis=1)
        finite, nondegenerate = _triangle_checks(v, tri, finite_v)
        keep = finite & nondegenerate
        if not np.all(keep):
            n_bad = int((~finite).sum())
            n_deg = int((finite & ~nondegenerate).sum())
            msg = (f"object '{name}': dropped {n_bad + n_deg} of {t} triangles "
                   f"({n_bad} with NaN/inf vertices, {n_deg} degenerate)")
            self.warnings.append(msg)
            warnings.warn(msg, stacklevel=2)
        if normals is not None:
            # Unusable shading normals fall back to the flat normal for that triangle.
            sm &= _normals_usable(normals)
        uvs = {str(k): _corner_coordinates(m, t) for k, m in (uv_maps or {}).items()}
        tan = None if tangents is None else np.asarray(tangents, np.float32).reshape(t, 3, 4)
        if not keep.all():
            sm, mi, tri = sm[keep], mi[keep], tri[keep]
            normals = None if normals is None else normals[keep]
            uvs = {k: m[keep] for k, m in uvs.items()}
            tan = None if tan is None else tan[keep]
        if not finite_v.all():  # unreferenced now, but embree should see no NaN at all
            v = np.where(finite_v[:, None], v, 0.0)
        self._meshes.append((name, v, tri, normals, sm, mi, terminator_offset))
        self._uv_maps.append(uvs)
        self._tangents.append(tan)
        return int(keep.sum())

    def build(self, camera: Camera, world: World | None = None) -> Scene:
        camera.validate()
        world = world or World()
        world.validate()
        world_medium = world.medium()
        given = self._materials + ([world_medium] if world_medium is not None else [])
        materials = Materials.from_list(given)
        meshes = self._meshes
        for name, _, _, _, _, mi, _ in meshes:
            if len(mi) and (mi.min() < 0 or mi.max() >= max(len(self._materials), 1)):
                raise ValueError(f"object '{name}': material index out of range "
                                 f"0..{max(len(self._materials), 1) - 1}")
        counts = [len(m[2]) for m in meshes]
        total = sum(counts)
        # Recentre before embree's float32 cast so far-from-origin scenes keep precision:
        # the centre of the bounds of every vertex a kept triangle uses.
        bounds = [_bounds(v, tri) for _, v, tri, *_ in meshes if len(tri)]
        origin = (0.5 * (np.min([lo for lo, _ in bounds], axis=0)
                         + np.max([hi for _, hi in bounds], axis=0)) if bounds else np.zeros(3))
        verts = np.empty((total, 3, 3))
        smooth_all = np.zeros(total, bool)
        any_normals = any(m[3] is not None and m[4].any() for m in meshes)
        norms = np.zeros((total, 3, 3)) if any_normals else None
        start = 0
        for (_, v, tri, n, sm, _, _), count in zip(meshes, counts):
            part = slice(start, start + count)
            _gather_corners(v, tri, origin, verts[part])
            if n is not None and norms is not None:
                smooth_all[part] = sm
                _unit_normals(n, sm, norms[part])
            start += count
        if not smooth_all.any():
            norms = None
        offsets = np.cumsum([0] + [len(m[1]) for m in meshes])
        uv, programs, uv_names = self._programs(materials, counts)
        return Scene(
            vertices=verts, origin=origin, normals=norms, smooth=smooth_all,
            material_index=(np.concatenate([m[5] for m in meshes]) if meshes
                            else np.zeros(0)).astype(np.int32),
            object_index=(np.concatenate([np.full(c, k, np.int32) for k, c in enumerate(counts)])
                          if meshes else np.zeros(0, np.int32)),
            object_names=[m[0] for m in meshes], materials=materials, camera=camera,
            terminator_offset=np.array([m[6] for m in meshes], np.float64),
            world=world, warnings=list(self.warnings), lights=list(self._lights),
            # Recentred like `verts` (same float64 subtraction, so the same float32 values).
            shared_vertices=(np.concatenate([m[1] for m in meshes]) - origin if meshes
                             else np.zeros((0, 3))),
            shared_triangles=(np.concatenate([m[2] + o for m, o in zip(meshes, offsets)])
                              .astype(np.int32) if meshes else np.zeros((0, 3), np.int32)),
            uv=uv, programs=programs, uv_names=uv_names,
            tangents=self._gathered_tangents(materials, counts),
            world_medium=len(given) - 1 if world_medium is not None else -1)

    def _gathered_tangents(self, materials: Materials, counts):
        """The scene's (t, 3, 4) tangents where some material has a normal map, else None.
        Tangents with non-finite values are zeros (their normal map leaves the normal)."""
        if materials.normal_programs is None or all(
                p is None for p in materials.normal_programs):
            return None
        out = np.zeros((sum(counts), 3, 4), np.float32)
        start = 0
        for tan, count in zip(self._tangents, counts):
            if tan is not None:
                out[start:start + count] = np.where(np.isfinite(tan), tan, 0.0)
            start += count
        return out

    def _programs(self, materials: Materials, counts) -> tuple:
        """The scene's (uv, ProgramTable, map names) for the materials' colour programs,
        (None, None, []) without any: the maps the programs read, gathered over every mesh
        (a mesh without one of them reads shading.absent_map_value there, as in Cycles, and
        a warning; the camera's maps are left to the render)."""
        if materials.colour_programs is None:
            return None, None, []
        progs = [[p for p in pair if p is not None] for pair in
                 zip(*materials.program_lists())]
        names = sorted({n for pair in progs for p in pair for n in p.uv_maps}) or [""]
        uv = np.zeros((len(names), sum(counts), 3, 3), np.float32)
        start = 0
        for (name, *_, mi, _), maps, count in zip(self._meshes, self._uv_maps, counts):
            for j, uv_name in enumerate(names):
                if uv_name in maps:
                    uv[j, start:start + count] = maps[uv_name]
                    continue
                if uv_name in VIEW_MAPS:
                    continue
                uv[j, start:start + count] = absent_map_value(uv_name)
                users = [materials.names[k] for k in np.unique(mi)
                         if any(uv_name in p.uv_maps for p in progs[k])]
                if users:
                    msg = (f"object '{name}' has no {map_label(uv_name)}, which material "
                           f"'{users[0]}' reads: its values there are 0"
                           + (" (Alpha 1)" if any(absent_map_value(uv_name)) else ""))
                    self.warnings.append(msg)
                    warnings.warn(msg, stacklevel=3)
            start += count
        return uv, pack(*materials.program_lists()[:2], names.index,
                        *materials.program_lists()[2:]), names


def _check_varying(m: Material) -> None:
    """A ValueError where material m varies (or has) what its kind lacks: a roughness, a
    specular or coat tint, a Diffuse Roughness, an anisotropy (which needs a tangent)."""
    if m.roughness_program is not None and m.kind not in ROUGH_KINDS:
        raise ValueError(f"material '{m.name}': a {m.kind} material's roughness cannot "
                         f"vary (textured roughness: {', '.join(ROUGH_KINDS)})")
    if m.tint_program is not None and m.kind not in TINTED_KINDS and not m.coat_ior > 0:
        raise ValueError(f"material '{m.name}': a {m.kind} material has no specular or "
                         f"coat tint to vary")
    if m.diffuse_roughness_program is not None and m.kind != "principled":
        raise ValueError(f"material '{m.name}': only a Principled BSDF has a Diffuse "
                         f"Roughness to vary")
    if m.specular_ior_program is not None and m.kind != "principled":
        raise ValueError(f"material '{m.name}': only a Principled BSDF's dielectric layer "
                         f"has an IOR that may vary")
    if m.thin_film_program is not None and m.kind not in FILMED_KINDS:
        raise ValueError(f"material '{m.name}': a {m.kind} material has no thin film to vary "
                         f"(thin films: {', '.join(FILMED_KINDS)})")
    if (m.specular_anisotropy != 0.0 or m.anisotropy_program is not None) and \
            (m.kind not in ANISOTROPIC_KINDS or m.tangent_program is None):
        raise ValueError(f"material '{m.name}': anisotropy needs a tangent program and "
                         f"one of the kinds {', '.join(ANISOTROPIC_KINDS)}")


def _corner_coordinates(m, t) -> np.ndarray:
    """(t, 3, 3) float32 per-corner coordinates from (t, 3, 2) UVs (w = 0) or (t, 3, 3)."""
    m = np.asarray(m, np.float32)
    if m.size == t * 6:
        return np.concatenate([m.reshape(t, 3, 2), np.zeros((t, 3, 1), np.float32)], axis=2)
    return m.reshape(t, 3, 3)


# -------------------------------------------------------------------- builder passes
# One compiled loop each: a pass over a million triangles with no temporaries.

@njit(**ALLOCATING)
def _triangle_checks(v, tri, finite_v):
    """(finite, nondegenerate) per triangle: all corners finite; the edge cross product
    above float64 noise, |e1 x e2| > 1e-24 scale^2 (scale: the largest corner coordinate)."""
    t = len(tri)
    finite = np.empty(t, np.bool_)
    nondegenerate = np.empty(t, np.bool_)
    tiny = np.finfo(np.float64).tiny
    for i in range(t):
        a, b, c = tri[i, 0], tri[i, 1], tri[i, 2]
        finite[i] = finite_v[a] and finite_v[b] and finite_v[c]
        if not finite[i]:
            nondegenerate[i] = False
            continue
        e1x, e1y, e1z = v[b, 0] - v[a, 0], v[b, 1] - v[a, 1], v[b, 2] - v[a, 2]
        e2x, e2y, e2z = v[c, 0] - v[a, 0], v[c, 1] - v[a, 1], v[c, 2] - v[a, 2]
        cx = e1y * e2z - e1z * e2y
        cy = e1z * e2x - e1x * e2z
        cz = e1x * e2y - e1y * e2x
        scale = 0.0
        for j in range(3):
            scale = max(scale, abs(v[a, j]), abs(v[b, j]), abs(v[c, j]))
        scale += tiny
        nondegenerate[i] = cx * cx + cy * cy + cz * cz > 1e-48 * scale**4
    return finite, nondegenerate


@njit(**ALLOCATING)
def _normals_usable(normals):
    """(t,) whether all three corner normals are finite and non-zero."""
    ok = np.empty(len(normals), np.bool_)
    for i in range(len(normals)):
        ok[i] = True
        for k in range(3):
            x, y, z = normals[i, k, 0], normals[i, k, 1], normals[i, k, 2]
            length2 = x * x + y * y + z * z
            if not (np.isfinite(length2) and length2 > 0):
                ok[i] = False
    return ok


@njit(**ALLOCATING)
def _bounds(v, tri):
    """(lo, hi) (3,) of the vertices the triangles use."""
    lo = np.full(3, np.inf)
    hi = np.full(3, -np.inf)
    for i in range(len(tri)):
        for k in range(3):
            for j in range(3):
                x = v[tri[i, k], j]
                lo[j] = min(lo[j], x)
                hi[j] = max(hi[j], x)
    return lo, hi


@njit(**ALLOCATING)
def _gather_corners(v, tri, origin, out):
    """out (t, 3, 3) = v[tri] - origin."""
    for i in range(len(tri)):
        for k in range(3):
            for j in range(3):
                out[i, k, j] = v[tri[i, k], j] - origin[j]


@njit(**ALLOCATING)
def _unit_normals(normals, smooth, out):
    """out (t, 3, 3): the corner normals of smooth triangles scaled to unit length, zero
    elsewhere (unusable normals never reach the integrator)."""
    for i in range(len(normals)):
        for k in range(3):
            if smooth[i]:
                x, y, z = normals[i, k, 0], normals[i, k, 1], normals[i, k, 2]
                length = max(math.sqrt(x * x + y * y + z * z), 1e-300)
                out[i, k, 0], out[i, k, 1], out[i, k, 2] = x / length, y / length, z / length
            else:
                out[i, k, 0] = out[i, k, 1] = out[i, k, 2] = 0.0

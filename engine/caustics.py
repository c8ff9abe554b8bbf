"""Caustics: light tracing of light -> specular -> diffuse -> camera paths, weighed against
path tracing by multiple importance sampling.

Path tracing finds a caustic (a diffuse surface lit through glass or by a mirror) only
when a BSDF sample from the diffuse vertex happens to go through the specular chain and
hit an emitter: next-event estimation cannot aim through a delta surface. With a small
emitter that almost never happens. Light tracing (Veach 1997, ch. 10; pbrt-v3's
`bdpt.cpp`, strategy t = 1) starts at the emitter instead, follows the specular chain and
connects its first diffuse vertex to the camera, splatting into whichever pixel it lands
in: it finds such paths as easily as path tracing finds direct light.

Both strategies sample the same family of paths, camera -> x (Lambertian) -> any
Lambertian or specular vertices -> S (mirror, metal, glass) -> y (an emissive triangle, or
an area, point, spot or sun light BSDF rays can hit): the
light path goes on past its first diffuse vertex, connecting each, so light reflected by
a mirror onto a wall and from there onto the floor is found too. Each strategy weighs a
path by the balance heuristic w_LT = r / (1 + r), w_PT = 1 / (1 + r), with the ratio of
the two densities

    r = N_L p_LT / p_PT = N_L (p_sel p_A)(y) (p_dir(y) / |cos y|) E^2 |cos_g x| / (q_cam)
                          / prod(shading_ratio of the vertices between)

computed identically from either end (`light_tracing_ratio`). N_L is the number of light
paths per pass (one per pixel of the render), p_sel p_A(y) the light tracer's density of
the emitter point, p_dir(y) / |cos y| = 1 / (2 pi) for a triangle's two-sided cosine
emission and 1 / pi for an area light's one-sided one (their product: p_emit), E the
ratio n_x / n_y of the refractive indices at the two ends (the chain's Jacobians differ
by (n_x / n_y)^2, by conservation of etendue), and q_cam = |dr / dA_x| p_dir(x) the path
tracer's density per unit raster area of reaching x from the camera (one sample per
pixel) times its BSDF density toward the chain (`camera_side_density`). The weights sum
to one for every path whatever r is, so the combination is unbiased; r only decides how
well it converges. The path tracer's own contribution to such a path is its plain
estimate times w_PT; the light tracer's is `light_tracing_contribution` times w_LT.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from .jit import INLINE, JIT, njit
from .lights import AREA

# p_dir(y) / |cos y| of cosine emission: from either face of a triangle |cos| / (2 pi), from
# the front of an area light cos / pi.
TWO_SIDED_DIRECTION_DENSITY = 1.0 / (2.0 * math.pi)
ONE_SIDED_DIRECTION_DENSITY = 1.0 / math.pi

# The light tracer as the kernel reads it: light paths per pass (0: no light tracing, every
# path tracer weight is 1), and per source (LightSampler's emissive triangles, then its area
# lights) the CDF by power, p_emit = p_sel p_A p_dir / |cos| (the density of a light path's
# start point and direction per projected solid angle), and the light object's index (-1:
# a triangle); per light object its source (-1: none).
# A sun's paths start on a disk across its cone (lights.LightSampler._caustic_sources),
# directions uniform in the cone: p_dir / |cos y| = 1 / (solid angle |cos y|), the cosine
# to the disk's normal being the path's own; pdf_emit holds the rest and the cosine is
# divided at either end. A point or spot light's are lines uniform in dA_perp dw
# (lights.sphere_light_line): p_A p_dir / |cos| = 1 / (pi r^2 x the cone's solid angle).
# disk: (centre, radius) per source, zeros but for suns; cos_cone: the cosine of the cone
# of directions of a sun's, point or spot light's paths.
CausticData = namedtuple("CausticData",
                         "n_light cdf pdf_emit light source_of_light disk cos_cone")


def caustic_data(n_light: float, sampler) -> CausticData:
    """The light tracer's sources from a lights.LightSampler, n_light paths per pass."""
    dist, light = sampler.caustic_distribution, sampler.caustic_light
    o = sampler.objects
    cone = np.zeros(len(light), bool)
    cone[light >= 0] = o.type[light[light >= 0]] != AREA
    solid = 2.0 * np.pi * (1.0 - sampler.caustic_cone)
    per_cos = np.where(light < 0, TWO_SIDED_DIRECTION_DENSITY,
                       np.where(cone, 1.0 / np.where(cone, solid, 1.0),
                                ONE_SIDED_DIRECTION_DENSITY))
    source_of_light = np.full(o.count, -1, np.int64)
    source_of_light[light[light >= 0]] = np.nonzero(light >= 0)[0]
    return CausticData(float(n_light), dist.cdf,
                       dist.pmf / np.maximum(sampler.caustic_area, 1e-300) * per_cos, light,
                       source_of_light, sampler.caustic_disk, sampler.caustic_cone)


def no_caustic_data() -> CausticData:
    """What a kernel compiled with light tracing reads when a scene has none."""
    return CausticData(0.0, np.zeros(0), np.zeros(0), np.zeros(0, np.int64),
                       np.zeros(0, np.int64), np.zeros((0, 4)), np.zeros(0))


@njit(**INLINE)
def camera_side_density(raster_per_area, pdf_direction, cos_chain):
    """q_cam / |cos_g x|: the path tracer's density per unit raster area of arriving at the
    diffuse vertex x (|dr / dA_x|) times its BSDF density toward the specular chain, over
    |cos| of that direction at x's geometric normal (which the ratio needs beside it)."""
    return raster_per_area * pdf_direction / max(cos_chain, 1e-300)


@njit(**INLINE)
def light_tracing_ratio(n_light, pdf_emit, eta2, camera_density):
    """r = N_L p_LT / p_PT for a camera -> x -> S+ -> y path (module docstring): pdf_emit is
    p_sel p_A(y) p_dir(y) / |cos y|, eta2 = (n_x / n_y)^2, camera_density is
    `camera_side_density` at x."""
    if not camera_density > 0.0:
        return math.inf
    return n_light * pdf_emit * eta2 / camera_density


@njit(**JIT)
def path_tracing_weight(n_light, pdf_emit, eta2, camera_density):
    """w_PT = 1 / (1 + r); 1 without light tracing (n_light 0)."""
    if n_light == 0.0:
        return 1.0
    return 1.0 / (1.0 + light_tracing_ratio(n_light, pdf_emit, eta2, camera_density))


@njit(**INLINE)
def light_tracing_weight(n_light, pdf_emit, eta2, camera_density):
    """w_LT = r / (1 + r)."""
    r = light_tracing_ratio(n_light, pdf_emit, eta2, camera_density)
    return 1.0 if math.isinf(r) else r / (1.0 + r)


@njit(**INLINE)
def shading_ratio(cos_s_light, cos_g_light, cos_s_camera, cos_g_camera):
    """At a vertex inside such a path, with |cos| toward its light side and its camera side
    at the lobe's normal (s: the shading normal, or a specular lobe's tilted one) and the
    geometric one (g): cos_s(light) cos_g(camera) / (cos_s(camera) cos_g(light)). Where s is
    not g, scattering does not conserve etendue (projected areas use g, directions s): the
    light path's weight takes this factor (the adjoint BSDF of a shading normal, Veach 1997,
    5.3; for a mirror it is cos_g(camera) / cos_g(light)), and the densities' ratio r
    divides by it. 1 on flat surfaces."""
    return cos_s_light * cos_g_camera / max(cos_s_camera * cos_g_light, 1e-300)


@njit(**INLINE)
def light_tracing_contribution(beta, reflectance, cos_shading, cos_chain, raster_per_area,
                               eta2):
    """What a light path arriving at Lambertian vertex x with weight beta (emitted radiance
    over p_sel p_A p_dir, times the chain's specular weights) adds per unit raster area at
    its raster point: the path tracer's integrand, colour / pi cos_s (x's shading normal
    toward the chain), over the light path's density of x, whose geometric factor is
    |cos_g x| (n_x / n_y)^2 where the path tracer's is |cos y| (etendue)."""
    return beta * reflectance * cos_shading / (math.pi * max(cos_chain, 1e-300)) \
        * raster_per_area / eta2

"""BSDFs with Cycles' semantics at roughness 0: Lambert, mirror, metal, smooth glass.

All functions work on batches: directions are (n, 3) float64 unit vectors in world
space, `wo` points away from the surface (towards where the ray came from) and `n` is
the shading normal already flipped to the side of `wo`. Sampling routines return
(wi, weight, pdf): weight is f * |cos| / pdf per colour channel, pdf is the solid-angle
density for the non-delta lobe (Lambert) and `DELTA_PDF` for delta lobes, which MIS
treats as "BSDF sampling only". A zero weight marks a failed sample, as in Mitsuba.

Radiance across a refractive interface: like Cycles, we apply no eta^2 scaling. A
smooth dielectric's sampled weight is Color whichever lobe is chosen; radiance is
not rescaled by the change of solid angle. (The course project divided refracted
radiance by eta^2; for a closed object seen and lit from outside both factors cancel,
but a camera inside glass sees a brighter world in the course's convention.)
"""

from __future__ import annotations

import numpy as np

from . import sampling

DELTA_PDF = np.inf


def dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("ij,ij->i", a, b)


def reflect(wo: np.ndarray, n: np.ndarray) -> np.ndarray:
    """Mirror wo about n: wi = 2 (n . wo) n - wo."""
    return 2.0 * dot(n, wo)[:, None] * n - wo


def _transmitted_cosine(cos_i: np.ndarray, eta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """cos_theta_t from Snell's law and the total-internal-reflection mask.

    Written as sqrt(eta^2 - 1 + cos_i^2) / eta rather than sqrt(1 - sin_t^2), which keeps
    cos_t == cos_i exactly at eta = 1 (an IOR-1 object must be invisible).
    """
    disc = eta * eta - 1.0 + cos_i * cos_i
    tir = disc <= 0.0
    return np.sqrt(np.maximum(disc, 0.0)) / eta, tir


def fresnel_dielectric(cos_theta_i: np.ndarray, eta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Exact unpolarised Fresnel reflectance for a smooth dielectric.

    cos_theta_i : (n,) cosine between the incident direction and the normal on the
        incident side (negative values are mirrored: the formula is even in it).
    eta : (n,) relative IOR n_transmitted / n_incident (> 0).
    Returns (F, cos_theta_t): F = 1 under total internal reflection (cos_theta_t = 0).
    """
    cos_i = np.clip(np.abs(cos_theta_i), 0.0, 1.0)
    cos_t, tir = _transmitted_cosine(cos_i, eta)
    # Handle grazing incidence with eta = 1, where both denominators vanish: F = 1.
    d_par = eta * cos_i + cos_t
    d_perp = cos_i + eta * cos_t
    ok = (d_par > 0) & (d_perp > 0)
    r_par = (eta * cos_i - cos_t) / np.where(ok, d_par, 1.0)
    r_perp = (cos_i - eta * cos_t) / np.where(ok, d_perp, 1.0)
    f = np.where(tir | ~ok, 1.0, 0.5 * (r_par * r_par + r_perp * r_perp))
    return np.clip(f, 0.0, 1.0), np.where(tir, 0.0, cos_t)


def fresnel_schlick_dielectric(cos_theta_i: np.ndarray, eta: np.ndarray
                               ) -> tuple[np.ndarray, np.ndarray]:
    """Schlick's approximation R0 + (1 - R0)(1 - cos)^5, R0 = ((eta - 1)/(eta + 1))^2.

    The course project's model, with the usual correction that the cosine is taken in
    the optically thinner medium (cos_theta_t when leaving glass), so the approximation
    stays within its known bound of the exact value from both sides. Total internal
    reflection gives 1.
    """
    cos_i = np.clip(np.abs(cos_theta_i), 0.0, 1.0)
    cos_t, tir = _transmitted_cosine(cos_i, eta)
    r0 = ((eta - 1.0) / (eta + 1.0)) ** 2
    c = np.where(eta >= 1.0, cos_i, cos_t)
    f = r0 + (1.0 - r0) * (1.0 - c) ** 5
    return np.where(tir, 1.0, np.clip(f, 0.0, 1.0)), np.where(tir, 0.0, cos_t)


def fresnel_schlick_conductor(cos_theta: np.ndarray, f0: np.ndarray) -> np.ndarray:
    """Principled metallic at roughness 0 with white specular tint (F82-tint, b = 0):
    F = F0 + (1 - F0)(1 - cos)^5 per channel; cos_theta (n,), f0 (n, 3)."""
    c = np.clip(np.abs(cos_theta), 0.0, 1.0)
    f0 = np.clip(f0, 0.0, 1.0)
    return np.clip(f0 + (1.0 - f0) * ((1.0 - c) ** 5)[:, None], 0.0, 1.0)


def refract(wo: np.ndarray, n: np.ndarray, eta: np.ndarray, cos_t: np.ndarray) -> np.ndarray:
    """Snell refraction of wo through a surface with normal n (on wo's side).

    eta = n_t / n_i; cos_t the transmitted cosine from the Fresnel routine.
    Returns the transmitted direction (pointing away from the surface on the far side).
    """
    cos_i = dot(n, wo)
    return -wo / eta[:, None] + (cos_i / eta - cos_t)[:, None] * n


# ----------------------------------------------------------------- Lambert
def sample_diffuse(wo, n, ng, colour, u):
    """Cosine-weighted sampling of Lambert (f = colour / pi): weight = colour.

    Directions below the geometric surface (ng on wo's side) fail, as in Cycles.
    """
    local = sampling.sample_cosine_hemisphere(u)
    s, t = sampling.build_frame(n)
    wi = local[:, :1] * s + local[:, 1:2] * t + local[:, 2:3] * n
    cos = local[:, 2]
    ok = (dot(wi, ng) > 0.0) & (cos > 0.0)
    weight = np.where(ok[:, None], colour, 0.0)
    return wi, weight, np.where(ok, sampling.cosine_hemisphere_pdf(cos), 0.0)


def eval_diffuse(wi, n, ng, colour):
    """Lambert f * cos for light directions wi (n, 3) and its sampling pdf."""
    cos = dot(wi, n)
    ok = (cos > 0.0) & (dot(wi, ng) > 0.0)
    cos = np.where(ok, cos, 0.0)
    return colour * (cos / np.pi)[:, None], cos / np.pi


# ----------------------------------------------------------------- specular
def sample_mirror(wo, n, colour):
    """Glossy BSDF at roughness 0: perfect reflection, weight = colour (no Fresnel)."""
    return reflect(wo, n), colour.copy(), np.full(len(wo), DELTA_PDF)


def sample_metal(wo, n, base_colour):
    """Principled metallic at roughness 0: perfect reflection weighted by F82/Schlick."""
    wi = reflect(wo, n)
    return wi, fresnel_schlick_conductor(dot(n, wo), base_colour), np.full(len(wo), DELTA_PDF)


def sample_dielectric(wo, n, eta, reflection_tint, transmission_tint, u, fresnel="exact"):
    """Smooth dielectric (Cycles' Glass BSDF and Principled transmission at roughness 0).

    eta : (n,) relative IOR across the surface as seen from wo (IOR on front faces,
        1/IOR on back faces). Reflection R = F x reflection_tint, transmission
        T = (1 - F) x transmission_tint; reflection is chosen with probability
        avg(R) / avg(R + T) and the weight is R / p or T / (1 - p), as in Cycles.
    Returns (wi, weight, pdf, transmitted) with transmitted (n,) bool.
    """
    fresnel_fn = fresnel_dielectric if fresnel == "exact" else fresnel_schlick_dielectric
    f, cos_t = fresnel_fn(dot(n, wo), eta)
    r = f[:, None] * reflection_tint
    t = (1.0 - f)[:, None] * transmission_tint
    r_avg, t_avg = r.mean(axis=1), t.mean(axis=1)
    total = r_avg + t_avg
    p_reflect = np.where(total > 0, r_avg / np.where(total > 0, total, 1.0), 1.0)
    choose_r = u < p_reflect
    wi = np.where(choose_r[:, None], reflect(wo, n), refract(wo, n, eta, cos_t))
    weight = np.where(choose_r[:, None], r / np.maximum(p_reflect, 1e-300)[:, None],
                      t / np.maximum(1.0 - p_reflect, 1e-300)[:, None])
    weight = np.where((total > 0)[:, None], weight, 0.0)
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    return wi, weight, np.full(len(wo), DELTA_PDF), ~choose_r

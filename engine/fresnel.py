"""The Fresnel reflectance of a smooth dielectric: one formula for the BSDFs (bsdf.py) and
the shader programs' Fresnel and Layer Weight nodes (shading.py); and of a smooth conductor,
which the metals render through its F82 fit (bsdf.conductor_as_f82)."""

from __future__ import annotations

import math

import numpy as np

from .jit import JIT, njit


@njit(**JIT)
def fresnel_dielectric(cos_i, eta, exact):
    """Unpolarised Fresnel reflectance of a smooth dielectric and the transmitted cosine.

    cos_i : cosine between the incident direction and the normal on the incident side
        (its sign does not matter); eta : relative IOR n_transmitted / n_incident (> 0);
    exact : the exact formula, else Schlick's approximation R0 + (1 - R0)(1 - cos)^5 with
        the cosine taken in the optically thinner medium (cos_t when leaving glass), the
        course project's model, which stays within its known bound from both sides.
    Returns (F, cos_t), F = 1 under total internal reflection (cos_t = 0). cos_t is
    sqrt(eta^2 - 1 + cos_i^2) / eta rather than sqrt(1 - sin_t^2), which keeps
    cos_t == cos_i exactly at eta = 1 (an IOR-1 object must be invisible).
    """
    cos_i = min(max(abs(cos_i), 0.0), 1.0)
    disc = eta * eta - 1.0 + cos_i * cos_i
    if disc <= 0.0:
        return 1.0, 0.0
    cos_t = math.sqrt(disc) / eta
    if exact:
        d_par = eta * cos_i + cos_t
        d_perp = cos_i + eta * cos_t
        if not (d_par > 0 and d_perp > 0):  # grazing incidence at eta = 1
            return 1.0, cos_t
        r_par = (eta * cos_i - cos_t) / d_par
        r_perp = (cos_i - eta * cos_t) / d_perp
        f = 0.5 * (r_par * r_par + r_perp * r_perp)
    else:
        r0 = ((eta - 1.0) / (eta + 1.0)) ** 2
        c = cos_i if eta >= 1.0 else cos_t
        f = r0 + (1.0 - r0) * (1.0 - c) ** 5
    return min(max(f, 0.0), 1.0), cos_t


@njit(**JIT)
def glass_fresnel(cos_i, eta, exact, fresnel_on):
    """What a glass interface reflects (fresnel_dielectric), or for Cycles' Refraction BSDF
    (not fresnel_on), which has no Fresnel, nothing but under total internal reflection,
    where it refracts nothing either (1: the whole of it is not transmitted). Returns
    (F, cos_t)."""
    f, cos_t = fresnel_dielectric(cos_i, eta, exact)
    if fresnel_on:
        return f, cos_t
    return (0.0 if cos_t > 0.0 else 1.0), cos_t


@njit(**JIT)
def tinted_fresnel(f, eta, tint):
    """One channel of the Principled BSDF's dielectric Fresnel under its Specular Tint
    (Cycles' generalized Schlick Fresnel with exponent < 0): from F0 x tint (at most 1)
    rising to 1 as the real Fresnel f of relative IOR eta rises from its own F0, i.e. f's
    place between F0 and 1 carried over. A white tint is f itself."""
    if tint == 1.0:
        return f
    f0 = ((eta - 1.0) / (eta + 1.0)) ** 2
    t0 = min(max(f0 * tint, 0.0), 1.0)
    s = min(max((f - f0) / (1.0 - f0), 0.0), 1.0) if f0 < 1.0 else 1.0
    return t0 + (1.0 - t0) * s


# Cycles clamps every BSDF's IOR input at this (svm_closure.h: fmaxf(ior, 1e-5f)).
MIN_IOR = 1e-5


@njit(**JIT)
def specular_eta(ior, level):
    """The relative IOR of the Principled BSDF's dielectric layer under its Specular IOR
    Level, as Cycles makes it: F0 scaled by 2 x level (0.5 keeps the IOR, 0 leaves no
    reflection), the IOR back from that F0 clamped to [0, 0.99] (Cycles' ior_from_F0), on
    the IOR's side of 1. Its glass lobe keeps the IOR itself."""
    ior = max(ior, MIN_IOR)
    if level == 0.5:
        return ior
    f0 = ((ior - 1.0) / (ior + 1.0)) ** 2 * 2.0 * max(level, 0.0)
    r = math.sqrt(min(max(f0, 0.0), 0.99))
    eta = (1.0 + r) / (1.0 - r)
    return 1.0 / eta if ior < 1.0 else eta


def fresnel_conductor(cos_i, n, k):
    """Unpolarised Fresnel reflectance of a smooth conductor of complex IOR n + ik seen from
    vacuum (Cycles' fresnel_conductor; Born and Wolf 14.4.1), elementwise over numpy
    arrays: the Metallic BSDF's Physical Conductor. At k = 0 it is fresnel_dielectric's."""
    c = np.clip(np.abs(np.asarray(cos_i, np.float64)), 0.0, 1.0)
    n, k = np.asarray(n, np.float64), np.asarray(k, np.float64)
    c2, s2 = c * c, 1.0 - c * c
    t0 = n * n - k * k - s2
    a2b2 = np.sqrt(t0 * t0 + 4.0 * n * n * k * k)  # |(n + ik)^2 - sin^2|
    a = np.sqrt(np.maximum(0.5 * (a2b2 + t0), 0.0))
    t1, t2 = a2b2 + c2, 2.0 * a * c
    r_s = (t1 - t2) / np.maximum(t1 + t2, 1e-300)
    t3, t4 = c2 * a2b2 + s2 * s2, t2 * s2
    r_p = r_s * (t3 - t4) / np.maximum(t3 + t4, 1e-300)
    return 0.5 * (r_s + r_p)

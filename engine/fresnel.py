"""The Fresnel reflectance of a smooth dielectric: one formula for the BSDFs (bsdf.py) and
the shader programs' Fresnel and Layer Weight nodes (shading.py); and of a smooth conductor,
which the metals render through its F82 fit (bsdf.conductor_as_f82)."""

from __future__ import annotations

import math

import numpy as np

from .jit import JIT, njit
from .spectrum import FILM_OPD_MAX, FILM_TABLE_SIZE, film_sensitivity_table


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


@njit(**JIT)
def fresnel_f82(cos_theta, f0, b):
    """The Principled BSDF's metallic Fresnel, one channel (Cycles' fresnel_f82; Hoffman's
    F82 model): Schlick's F0 + (1 - F0)(1 - cos)^5 less b cos (1 - cos)^6, in [0, 1]. b
    (f82_tint_b) bends the curve toward the Specular Tint near grazing; b = 0 is Schlick."""
    mu = min(max(abs(cos_theta), 0.0), 1.0)
    s = 1.0 - mu
    s5 = s ** 5
    g = min(max(f0, 0.0), 1.0)
    return min(max(g + (1.0 - g) * s5 - b * mu * s5 * s, 0.0), 1.0)


@njit(**JIT)
def f82_tint_b(f0, tint):
    """The F82 model's b for one channel of base colour F0 and Specular Tint (at most 1):
    the curve at cos = 1/7 (about 82 degrees) is Schlick's there times the tint (Cycles'
    fresnel_f82tint_B)."""
    f = 6.0 / 7.0
    f5 = f ** 5
    g = min(max(f0, 0.0), 1.0)
    return (g + (1.0 - g) * f5) * (7.0 / (f5 * f)) * (1.0 - min(max(tint, 0.0), 1.0))


@njit(**JIT)
def f82_b(f0, f82):
    """The F82 model's b for one channel of F0 f0 whose curve passes through f82 at
    cos = 1/7 (Cycles' fresnel_f82_B)."""
    f = 6.0 / 7.0
    f5 = f ** 5
    return (7.0 / (f5 * f)) * (f0 + (1.0 - f0) * f5 - f82)


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


# ----------------------------------------------------------------- thin film
# A dielectric film of some nanometres on a surface (the Principled BSDF's Thin Film)
# reflects what light bouncing inside it adds to or cancels from the first reflection, by
# wavelength: iridescence. Cycles follows Belcour and Barla, "A Practical Extension to
# Microfacet Theory for the Modeling of Varying Iridescence" (2017): the Airy series over
# the film's internal bounces, its m-th term's colour read from the Fourier transform of
# the colour-matching functions at m times the optical path difference (spectrum.py),
# truncated after m = 3, for each polarisation. The film replaces the Fresnel of a single
# scattering only: energy compensation and layering keep the film-free estimates, as in
# Cycles ("precomputing LUTs for thin-film iridescence isn't viable").

# Cycles' THINFILM_THICKNESS_CUTOFF (nm): a thinner film is no film.
THIN_FILM_MIN = 0.1
FILM_SENSITIVITY = film_sensitivity_table()
_FILM_STEP = FILM_OPD_MAX / (FILM_TABLE_SIZE - 1)


@njit(**JIT)
def polarised_dielectric(cos_i, eta):
    """Fresnel reflectance of a smooth dielectric of relative IOR eta for s and p
    polarised light, the transmitted cosine (negative: below the surface) and the signs
    of the reflected amplitudes (a dielectric's phase shift is 0 or pi). Total internal
    reflection: (1, 1, 0, 1, 1)."""
    e = eta * eta - (1.0 - cos_i * cos_i)
    if e <= 0.0:
        return 1.0, 1.0, 0.0, 1.0, 1.0
    cos_i = abs(cos_i)
    cos_t = -math.sqrt(e) / eta
    r_s = (cos_i + eta * cos_t) / (cos_i - eta * cos_t)
    r_p = (cos_t + eta * cos_i) / (eta * cos_i - cos_t)
    return (r_s * r_s, r_p * r_p, cos_t, 1.0 if r_s >= 0.0 else -1.0,
            1.0 if r_p >= 0.0 else -1.0)


@njit(**JIT)
def film_sensitivity(opd, c):
    """Channel c's sensitivity (real, imaginary) at optical path difference opd (nm):
    spectrum.film_sensitivity_table, linear between entries, its last beyond them."""
    x = min(max(opd / _FILM_STEP, 0.0), FILM_TABLE_SIZE - 1.0)
    i = min(int(x), FILM_TABLE_SIZE - 2)
    t = x - i
    lo, hi = FILM_SENSITIVITY[i], FILM_SENSITIVITY[i + 1]
    return lo[c] + t * (hi[c] - lo[c]), lo[c + 3] + t * (hi[c + 3] - lo[c + 3])


@njit(**JIT)
def airy_sum(r12, r23, opd, ph_re, ph_im, c):
    """One polarisation's reflectance of the film in channel c (Belcour and Barla's
    equation 10): r12 the top interface's reflectance, r23 the bottom's, opd the optical
    path difference of one round trip, (ph_re, ph_im) the phase shift of one round trip's
    two reflections as a unit complex number."""
    t121 = 1.0 - r12
    r123 = r12 * r23
    amp = math.sqrt(r123)
    rs = t121 * t121 * r23 / (1.0 - r123)
    r = r12 + rs
    cm = rs - t121
    a_re, a_im = ph_re, ph_im
    for m in range(1, 4):  # (the fourth term changes the result by about r123^2)
        cm *= amp
        s_re, s_im = film_sensitivity(m * opd, c)
        r += 2.0 * cm * (a_re * s_re + a_im * s_im)
        a_re, a_im = a_re * ph_re - a_im * ph_im, a_re * ph_im + a_im * ph_re
    return r


@njit(**JIT)
def film_top(cos_i, film_ior, thickness):
    """The film's top interface, from a medium of IOR 1: its IOR (blended toward 1 below
    1 nm, where the wave model stops holding, as Cycles does), (R_s, R_p, cos in the
    film (negative), phase signs) and the optical path difference of one round trip."""
    if thickness < 1.0:
        t = min(max(thickness, 0.0), 1.0)
        film_ior = 1.0 + (film_ior - 1.0) * t * t * (3.0 - 2.0 * t)
    rs, rp, cos_2, ss, sp = polarised_dielectric(cos_i, film_ior)
    return film_ior, rs, rp, cos_2, ss, sp, -2.0 * film_ior * thickness * cos_2


@njit(**JIT)
def film_channel(r12s, r12p, r23s, r23p, opd, ps_re, ps_im, pp_re, pp_im, c):
    """Channel c of a film's reflectance: the mean of both polarisations' Airy sums
    (airy_sum; the phase shift of the s-polarised round trip ps, of the p-polarised pp),
    within [0, 1]."""
    f = 0.5 * (airy_sum(r12s, r23s, opd, ps_re, ps_im, c)
               + airy_sum(r12p, r23p, opd, pp_re, pp_im, c))
    return min(max(f, 0.0), 1.0)


@njit(**JIT)
def thin_film_dielectric(cos_i, eta, film_ior, thickness):
    """Reflectance (3 channels) of a dielectric of relative IOR eta under a film of IOR
    film_ior (both relative to the incident medium) and thickness (nm), seen at cos_i
    (Cycles' fresnel_iridescence on a dielectric substrate). Total internal reflection at
    either interface: 1."""
    film_ior, r12s, r12p, cos_2, s12s, s12p, opd = film_top(cos_i, film_ior, thickness)
    if r12s == 1.0 and r12p == 1.0:
        return 1.0, 1.0, 1.0
    r23s, r23p, _, s23s, s23p = polarised_dielectric(-cos_2, eta / film_ior)
    if r23s == 1.0 and r23p == 1.0:
        return 1.0, 1.0, 1.0
    ps, pp = -s12s * s23s, -s12p * s23p
    return (film_channel(r12s, r12p, r23s, r23p, opd, ps, 0.0, pp, 0.0, 0),
            film_channel(r12s, r12p, r23s, r23p, opd, ps, 0.0, pp, 0.0, 1),
            film_channel(r12s, r12p, r23s, r23p, opd, ps, 0.0, pp, 0.0, 2))


@njit(**JIT)
def conductor_phases(cos_i, eta1, n, k):
    """The phase shifts (unit complex numbers, s then p: re, im, re, im) of light
    reflected at a conductor of complex IOR n + ik from a medium of IOR eta1 at cos_i
    (Born and Wolf 14.4.1 with n + ik for the IOR; Cycles' fresnel_conductor_polarized)."""
    t1 = n * n - k * k - eta1 * eta1 * (1.0 - cos_i * cos_i)
    t2 = math.sqrt(t1 * t1 + (2.0 * n * k) ** 2)
    u2, v2 = max(0.5 * (t2 + t1), 0.0), max(0.5 * (t2 - t1), 0.0)
    u, v = math.sqrt(u2), math.sqrt(v2)
    re_s = -u2 - v2 + (eta1 * cos_i) ** 2
    im_s = -2.0 * eta1 * cos_i * v
    re_p = ((n * n + k * k) * cos_i) ** 2 - eta1 * eta1 * (u2 + v2)
    im_p = 2.0 * eta1 * cos_i * (2.0 * n * k * u - (n * n - k * k) * v)
    ms, mp = math.hypot(re_s, im_s), math.hypot(re_p, im_p)
    if ms == 0.0:
        re_s, im_s, ms = 1.0, 0.0, 1.0
    if mp == 0.0:
        re_p, im_p, mp = 1.0, 0.0, 1.0
    return re_s / ms, im_s / ms, re_p / mp, im_p / mp


@njit(**JIT)
def thin_film_f82(cos_i, f0, b, film_ior, thickness, c):
    """Channel c of an F82 metal (fresnel_f82 of F0 f0 and bend b) under a film of IOR
    film_ior and thickness (nm), seen at cos_i from a medium of IOR 1, as Cycles makes it:
    the metal's complex IOR from F0 and its value at cos = 1/7 (Gulbrandsen's
    "Artist Friendly Metallic Fresnel" mapping) gives the phase at the film's bottom, the
    F82 model of F0 relative to the film its reflectance there."""
    g = fresnel_f82(1.0 / 7.0, f0, b)
    r = min(max(f0, 0.0), 0.999)
    sr = math.sqrt(r)
    n_max, n_min = (1.0 + sr) / (1.0 - sr), (1.0 - r) / (1.0 + r)
    n = n_max + g * (n_min - n_max)
    k = math.sqrt(max((r * (n + 1.0) ** 2 - (n - 1.0) ** 2) / (1.0 - r), 0.0))
    film_ior, r12s, r12p, cos_2, s12s, s12p, opd = film_top(cos_i, film_ior, thickness)
    if r12s == 1.0 and r12p == 1.0:
        return 1.0
    nr, kr = n / film_ior, k / film_ior
    f0_film = ((nr - 1.0) ** 2 + kr * kr) / ((nr + 1.0) ** 2 + kr * kr)
    r23 = fresnel_f82(-cos_2, f0_film, f82_b(f0_film, g))
    ps_re, ps_im, pp_re, pp_im = conductor_phases(-cos_2, film_ior, n, k)
    return film_channel(r12s, r12p, r23, r23, opd, -s12s * ps_re, -s12s * ps_im,
                        -s12p * pp_re, -s12p * pp_im, c)


@njit(**JIT)
def film_tinted(f, eta, tint):
    """One channel of a filmed Principled dielectric's Fresnel f under its Specular Tint
    (Cycles' generalized_schlick_fresnel with a film): f scaled toward F0 x tint / F0 (F0
    x tint at most 1) as far as f lies from 1 toward the film-free F0 of eta (a filmed F
    may fall below F0)."""
    f0 = ((eta - 1.0) / (eta + 1.0)) ** 2
    if tint == 1.0 or not f0 > 1e-5 or f == 1.0:
        return f
    s = min(max((f - 1.0) / (f0 - 1.0), 0.0), 1.0)
    factor = min(max(f0 * tint, 0.0), 1.0) / f0
    return f * (1.0 + s * (factor - 1.0))

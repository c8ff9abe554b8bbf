"""BSDFs with Cycles' semantics: Lambert, mirror, metal, smooth glass, the layered GGX
lobe of the Principled BSDF and the rough Glossy BSDF, and rough (GGX) glass.

Every function works on one shading point (scalars in, scalars out) and is compiled into
the per-bounce kernel (integrator.py). Directions are unit world-space vectors: `wo` points
away from the surface (toward where the ray came from), normals are flipped to wo's side.
Sampling returns the direction, the weight f * |cos| / pdf per channel and the pdf: a
solid-angle density for non-delta lobes, `DELTA_PDF` (inf) for delta lobes, which MIS
treats as "BSDF sampling only". A zero weight marks a failed sample, as in Mitsuba.

Radiance across a refractive interface: like Cycles, no eta^2 scaling. A smooth
dielectric's sampled weight is its tint whichever lobe is chosen. (The course project
divided refracted radiance by eta^2; for a closed object seen and lit from outside both
factors cancel, but a camera inside glass sees a brighter world in the course's
convention.)
"""

from __future__ import annotations

import functools
import math
from collections import namedtuple

import numpy as np

from .fresnel import (f82_tint_b, film_tinted, fresnel_conductor,  # noqa: F401
                      fresnel_dielectric, fresnel_f82, glass_fresnel, thin_film_dielectric,
                      thin_film_f82, tinted_fresnel)
from .jit import ALLOCATING, INLINE, JIT, njit
from .sampling import (build_frame, concentric_disk, cosine_hemisphere, guided_interp,
                       interp_guide)
from .scene import DIFFUSE, GLOSSY, PRINCIPLED, ROUGH_GLASS, ROUGH_METAL, SHEEN, TRANSLUCENT
from .sheen_table import A as _SHEEN_A, ALBEDO as _SHEEN_ALBEDO, B as _SHEEN_B

DELTA_PDF = np.inf


# ----------------------------------------------------------------- Fresnel
def conductor_as_f82(n, k) -> tuple:
    """The F82 metal (fresnel_f82) standing for a conductor of complex IOR n + ik (3,):
    exact at normal incidence and at cos = 1/7, Cycles' own fit of it for its energy
    compensation (fresnel_conductor_Fss), so the multiple scattering matches. Returns (F0
    (3,), the edge tint (3,), at most 1 as f82_tint_b takes it, and the largest deviation
    of the fit from the exact reflectance over the angles, any channel)."""
    mu = np.linspace(0.0, 1.0, 257)
    f0 = fresnel_conductor(1.0, n, k)
    schlick = np.array([fresnel_schlick_conductor(1.0 / 7.0, f) for f in f0])
    tint = np.minimum(fresnel_conductor(1.0 / 7.0, n, k) / np.maximum(schlick, 1e-300), 1.0)
    exact = fresnel_conductor(mu[:, None], n, k)
    fit = np.array([[fresnel_f82(m, f0[j], f82_tint_b(f0[j], tint[j])) for j in range(3)]
                    for m in mu])
    return f0, tint, float(np.abs(fit - exact).max())


@njit(**JIT)
def fresnel_schlick_conductor(cos_theta, f0):
    """Principled metallic with white Specular Tint: fresnel_f82 with b = 0, Schlick's
    F = F0 + (1 - F0)(1 - cos)^5 for one channel."""
    return fresnel_f82(cos_theta, f0, 0.0)


# ----------------------------------------------------------------- specular normals
@njit(**JIT)
def valid_specular_normal(ngx, ngy, ngz, ix, iy, iz, nx, ny, nz):
    """The normal a specular lobe uses: the shading normal n, tilted toward the geometric
    normal ng just enough that the mirror reflection of the view direction i (all unit, on
    the incoming side) leaves the surface at least min(0.9 i.ng, 0.01) above it (Cycles'
    ensure_valid_specular_reflection, its material's default Bump Map Correction). A smooth
    mesh's interpolated normal would otherwise reflect grazing views into the surface."""
    if nx == ngx and ny == ngy and nz == ngz:
        return nx, ny, nz
    ni = nx * ix + ny * iy + nz * iz
    rz = 2.0 * ni * (nx * ngx + ny * ngy + nz * ngz) - (ix * ngx + iy * ngy + iz * ngz)
    i_z = ix * ngx + iy * ngy + iz * ngz
    threshold = min(0.9 * i_z, 0.01)
    if rz >= threshold:
        return nx, ny, nz
    # n's component orthogonal to ng (the X axis of a frame with Z = ng and n in X-Z).
    nz_ = nx * ngx + ny * ngy + nz * ngz
    xx, xy, xz = nx - nz_ * ngx, ny - nz_ * ngy, nz - nz_ * ngz
    length = math.sqrt(xx * xx + xy * xy + xz * xz)
    if length > 0.0:
        xx, xy, xz = xx / length, xy / length, xz / length
    else:
        xx, xy, xz = nx, ny, nz
    i_x = ix * xx + iy * xy + iz * xz
    # The one valid root of 4 a N'z^4 - 2 b N'z^2 + c = 0 for the tilted normal N'.
    a = i_x * i_x + i_z * i_z
    b = 2.0 * (a + i_z * threshold)
    c = (threshold + i_z) ** 2
    root = math.sqrt(max(b * b - 4.0 * a * c, 0.0))
    n_z2 = 0.25 * (b + root) / a if i_x < 0.0 else 0.25 * (b - root) / a
    n_x = math.sqrt(max(1.0 - n_z2, 0.0))
    n_z = math.sqrt(max(n_z2, 0.0))
    return n_x * xx + n_z * ngx, n_x * xy + n_z * ngy, n_x * xz + n_z * ngz


# ----------------------------------------------------------------- Lambert
@njit(**JIT)
def eval_lambert(wx, wy, wz, sx, sy, sz):
    """Lambert cos / pi toward a light direction w, which is also its sampling pdf (times
    the colour: f * cos). Only the shading normal s counts, as in Cycles' bsdf_diffuse_eval:
    a light below the geometric surface but above the shading horizon (a smooth mesh's
    terminator) is left to the shadow ray, which the shadow terminator offset
    (terminator.py) may let through; sampling never goes below the geometric surface."""
    cos = wx * sx + wy * sy + wz * sz
    return cos / np.pi if cos > 0 else 0.0  # `cos > 0`: a NaN normal gives 0


@njit(**JIT)
def sample_lambert(sx, sy, sz, nx, ny, nz, ua, ub):
    """Cosine-weighted direction about the shading normal s: (w, pdf, ok); directions below
    the geometric surface n fail, as in Cycles. The weight is the colour."""
    lx, ly, lz = cosine_hemisphere(ua, ub)
    s, t = build_frame(sx, sy, sz)
    wx = lx * s[0] + ly * t[0] + lz * sx
    wy = lx * s[1] + ly * t[1] + lz * sy
    wz = lx * s[2] + ly * t[2] + lz * sz
    return wx, wy, wz, lz / np.pi, wx * nx + wy * ny + wz * nz > 0.0 and lz > 0.0


# Cycles' Diffuse BSDF with Roughness (bsdf_oren_nayar.h): Fujii's improved Oren-Nayar
# (https://mimosa-pudica.net/improved-oren-nayar.html) with the OpenPBR specification's
# energy-preserving multiple-scattering term, sampled as Lambert. At roughness below
# OREN_NAYAR_MIN Cycles sets up Lambert itself.
OREN_NAYAR_MIN = 1e-5


@njit(**JIT)
def oren_nayar_g(cos):
    """Fujii's G(theta) for a direction of cosine `cos` (bsdf_oren_nayar_G): the
    directional albedo's roughness term; a Taylor expansion at grazing angles."""
    if cos < 1e-6:
        return (0.5 * np.pi - 2.0 / 3.0) - cos
    sin = math.sqrt(max(1.0 - cos * cos, 0.0))
    theta = math.acos(min(cos, 1.0))
    return sin * (theta - 2.0 / 3.0 - sin * cos) + 2.0 / 3.0 * (sin / cos) * (1.0 - sin ** 3)


@njit(**JIT)
def oren_nayar_albedo_term(albedo, e_avg):
    """The multiple-scattering term's colour factor of one channel of albedo in [0, 1]."""
    a = min(max(albedo, 0.0), 1.0)
    if not e_avg < 1.0:  # roughness 0: Lambert, nothing lost
        return 0.0
    return a * a * (e_avg / (1.0 - e_avg)) / (np.pi * (1.0 - a * (1.0 - e_avg)))


@njit(**JIT)
def oren_nayar_ratio(wox, woy, woz, wx, wy, wz, sx, sy, sz, roughness, c0, c1, c2):
    """Cycles' Oren-Nayar of `roughness` (clamped to [0, 1]) and colour c over Lambert's
    f * cos (3 values): f * cos is colour x nl x (A + B t + M(colour) (1 - E(nl))), M the
    multiple scattering of colour's albedo times 1 - E(nv), about the shading normal s for
    the view wo and light w; Lambert's is colour x nl / pi."""
    sigma = min(max(roughness, 0.0), 1.0)
    a = 1.0 / (np.pi + sigma * (0.5 * np.pi - 2.0 / 3.0))
    b = sigma * a
    nl = max(wx * sx + wy * sy + wz * sz, 0.0)
    nv = max(wox * sx + woy * sy + woz * sz, 0.0)
    t = wx * wox + wy * woy + wz * woz - nl * nv
    if t > 0.0:
        t /= max(nl, nv) + 1.1754943508222875e-38  # FLT_MIN
    single = a + b * t
    e_avg = a * np.pi + (2.0 * np.pi - 5.6) / 3.0 * b
    lost = (1.0 - (a * np.pi + b * oren_nayar_g(nl))) * (1.0 - (a * np.pi + b * oren_nayar_g(nv)))
    return (np.pi * (single + oren_nayar_albedo_term(c0, e_avg) * lost),
            np.pi * (single + oren_nayar_albedo_term(c1, e_avg) * lost),
            np.pi * (single + oren_nayar_albedo_term(c2, e_avg) * lost))


# ----------------------------------------------------------------- specular
@njit(**INLINE)
def is_delta_kind(k):
    """Whether material kind k reflects or refracts in delta lobes only (a mirror, a smooth
    metal or glass: no light sampling there), or is no BSDF at all."""
    return not (k == DIFFUSE or k == PRINCIPLED or k == GLOSSY or k == ROUGH_GLASS
                or k == ROUGH_METAL or k == TRANSLUCENT or k == SHEEN)


@njit(**JIT)
def reflect(wox, woy, woz, nx, ny, nz):
    """Mirror wo about n: 2 (n . wo) n - wo, and n . wo."""
    cos_o = nx * wox + ny * woy + nz * woz
    return 2.0 * cos_o * nx - wox, 2.0 * cos_o * ny - woy, 2.0 * cos_o * nz - woz, cos_o


@njit(**JIT)
def sample_dielectric(wox, woy, woz, nx, ny, nz, eta, r_tint, t_tint, st, u, exact,
                      fresnel_on, film_d=0.0, film_n=1.0):
    """Smooth dielectric (Cycles' Glass BSDF and Principled transmission at roughness 0;
    without fresnel_on, the Refraction BSDF: glass_fresnel).

    eta : relative IOR across the surface as seen from wo (IOR on front faces, 1/IOR on
    back faces); r_tint, t_tint : (3,) tints; st : (3,) the Principled BSDF's Specular Tint
    (fresnel.tinted_fresnel: F per channel; white leaves F as it is). Reflection
    R = F x r_tint, transmission T = (1 - F) x t_tint; reflection is chosen with
    probability avg(R) / avg(R + T) and the weight is R / p or T / (1 - p), as in Cycles.
    film_d > 0: under a thin film of that thickness and IOR film_n relative to wo's side
    (filmed_fresnel; the exact Fresnel). Returns (w, weight (3 values), ok).
    """
    wx, wy, wz, cos_o = reflect(wox, woy, woz, nx, ny, nz)
    fr, cos_t = glass_fresnel(cos_o, eta, exact or film_d > 0.0, fresnel_on)
    if film_d > 0.0:
        f0, f1, f2 = filmed_fresnel(cos_o, eta, film_d, film_n, st[0], st[1], st[2])
    else:
        f0, f1, f2 = (tinted_fresnel(fr, eta, st[0]), tinted_fresnel(fr, eta, st[1]),
                      tinted_fresnel(fr, eta, st[2]))
    r0, r1, r2 = f0 * r_tint[0], f1 * r_tint[1], f2 * r_tint[2]
    q0, q1, q2 = (1.0 - f0) * t_tint[0], (1.0 - f1) * t_tint[1], (1.0 - f2) * t_tint[2]
    r_avg = (r0 + r1 + r2) / 3.0
    t_avg = (q0 + q1 + q2) / 3.0
    total = r_avg + t_avg
    ok = total > 0
    p_reflect = r_avg / total if ok else 1.0
    if u < p_reflect:
        inv = 1.0 / max(p_reflect, 1e-300)
        f0, f1, f2 = r0 * inv, r1 * inv, r2 * inv
    else:
        inv = 1.0 / max(1.0 - p_reflect, 1e-300)
        f0, f1, f2 = q0 * inv, q1 * inv, q2 * inv
        c = cos_o / eta - cos_t  # Snell: -wo / eta + (cos_o / eta - cos_t) n
        wx, wy, wz = -wox / eta + c * nx, -woy / eta + c * ny, -woz / eta + c * nz
    length = math.sqrt(wx * wx + wy * wy + wz * wz)
    return wx / length, wy / length, wz / length, f0, f1, f2, ok


# ----------------------------------------------------------------- rough (GGX) lobes
# Cycles' Multiscatter GGX at roughness r: alpha = r^2, isotropic. The single-scatter
# lobe is F D G2 / (4 cos_o) (times cos_i, folded in), sampled from the distribution of
# visible normals (Heitz 2018). Kulla-Conty energy compensation scales it by
# 1 + Fms (1 - E(mu_o)) / E(mu_o), with E the white-furnace albedo of the single-scatter
# lobe, E_avg its cosine-weighted mean and Fms = Fss E_avg / (1 - Fss (1 - E_avg)) for a
# Fresnel whose hemispherical average is Fss (Cycles' microfacet_ggx_preserve_energy).
# Fss is per channel: the dielectric Fresnel's average for the Principled layer, and the
# Glossy BSDF's colour for the Glossy node (Cycles' bsdf_microfacet_setup_fresnel_constant:
# the colour is its constant Fresnel, so a darker colour gets less of the missing energy
# back, not the same share scaled afterwards).
# The Principled BSDF layers this specular over its diffuse base, which keeps the weight
# 1 - A(mu_o) (Cycles' closure_layering_weight), A Cycles' estimate of the layer's albedo
# (MicrofacetTables.estimate_table and layering_table), not the albedo itself.

ALBEDO_TABLE_SIZE = 64
MIN_ALPHA = 1e-4
# numpy 2 renamed trapz (Blender 4.2+ may ship numpy 2).
trapezoid = getattr(np, "trapezoid", None) or np.trapz


@njit(**JIT)
def ggx_d(cos_h, a2):
    """The GGX normal distribution D at cos(theta_h), alpha^2 = a2."""
    c2 = min(cos_h * cos_h, 1.0)
    dd = 1.0 - c2 + a2 * c2
    return a2 / (np.pi * (dd * dd))


@njit(**JIT)
def ggx_lambda(cos_n, a2):
    """Smith's Lambda of GGX for a direction at cos(theta) to the normal."""
    c2 = max(cos_n * cos_n, 1e-300)
    return 0.5 * (math.sqrt(1.0 + a2 * max(1.0 / c2 - 1.0, 0.0)) - 1.0)


@njit(**JIT)
def eval_ggx(cos_o, cos_i, cos_h, cos_hv, a2, eta, fresnel_on):
    """Single-scatter GGX reflection f * cos_i and its visible-normal sampling pdf, from
    the cosines of wo and wi to the normal, of the half vector to the normal and to wo."""
    if not (cos_o > 0 and cos_i > 0):
        return 0.0, 0.0
    d = ggx_d(cos_h, a2)
    f = fresnel_dielectric(cos_hv, eta, True)[0] if fresnel_on else 1.0
    common = d / (4.0 * cos_o)
    return f * common / (1.0 + ggx_lambda(cos_o, a2) + ggx_lambda(cos_i, a2)), \
        common / (1.0 + ggx_lambda(cos_o, a2))


@njit(**JIT)
def ggx_visible_normal(v0, v1, v2, ax, ay, ua, ub):
    """A visible normal of GGX (Heitz 2018) of roughness ax along x and ay along y, for the
    local view direction v, z up."""
    a, b, c = ax * v0, ay * v1, v2
    norm = math.sqrt(a * a + b * b + c * c)
    a, b, c = a / norm, b / norm, c / norm
    lensq = a * a + b * b
    if lensq > 0:
        inv = 1.0 / math.sqrt(lensq)
        t1x, t1y, t1z = -b * inv, a * inv, 0.0
    else:
        t1x, t1y, t1z = 1.0, 0.0, 0.0
    t2x, t2y, t2z = b * t1z - c * t1y, c * t1x - a * t1z, a * t1y - b * t1x
    r = math.sqrt(ua)
    phi = 2.0 * np.pi * ub
    p1 = r * math.cos(phi)
    p2 = r * math.sin(phi)
    sv = 0.5 * (1.0 + c)
    p2 = (1.0 - sv) * math.sqrt(max(0.0, 1.0 - p1 * p1)) + sv * p2
    p3 = math.sqrt(max(0.0, 1.0 - p1 * p1 - p2 * p2))
    hx = ax * (p1 * t1x + p2 * t2x + p3 * a)
    hy = ay * (p1 * t1y + p2 * t2y + p3 * b)
    hz = max(p1 * t1z + p2 * t2z + p3 * c, 1e-12)
    norm = math.sqrt(hx * hx + hy * hy + hz * hz)
    return hx / norm, hy / norm, hz / norm


@njit(**JIT)
def sample_visible_normal(wox, woy, woz, mx, my, mz, alpha, ua, ub):
    """A GGX visible normal (world space) for view wo about the lobe's normal m."""
    s, t = build_frame(mx, my, mz)
    hx, hy, hz = ggx_visible_normal(wox * s[0] + woy * s[1] + woz * s[2],
                                    wox * t[0] + woy * t[1] + woz * t[2],
                                    wox * mx + woy * my + woz * mz, alpha, alpha, ua, ub)
    return (hx * s[0] + hy * t[0] + hz * mx, hx * s[1] + hy * t[1] + hz * my,
            hx * s[2] + hy * t[2] + hz * mz)


# ----------------------------------------------------------------- anisotropic GGX
# Cycles' anisotropic GGX (bsdf_microfacet.h: bsdf_aniso_D, bsdf_aniso_lambda, the VNDF
# sampled with alpha_x along the tangent, alpha_y along N x T): for reflection lobes only
# (Cycles keeps transmission isotropic). Its energy compensation reads the isotropic
# tables at roughness (alpha_x alpha_y)^(1/4), as Cycles' microfacet_ggx_preserve_energy.


@njit(**JIT)
def anisotropic_alphas(roughness, anisotropy, principled):
    """(alpha_x, alpha_y) of a GGX lobe of `roughness` and `anisotropy`, each at most 1 as
    bsdf_microfacet_ggx_setup clamps them. Principled (and its metal): aspect
    sqrt(1 - 0.9 anisotropy), anisotropy in [0, 1], alpha_x = r^2 / aspect; the Glossy
    BSDF: anisotropy in [-0.99, 0.99], alpha_x = r^2 (1 - a) for a >= 0, r^2 / (1 + a)
    below (svm_node_closure_bsdf)."""
    r2 = roughness * roughness
    if principled:
        aspect = math.sqrt(1.0 - min(max(anisotropy, 0.0), 1.0) * 0.9)
        ax, ay = r2 / aspect, r2 * aspect
    else:
        a = min(max(anisotropy, -0.99), 0.99)
        if a < 0.0:
            ax, ay = r2 / (1.0 + a), r2 * (1.0 + a)
        else:
            ax, ay = r2 * (1.0 - a), r2 / (1.0 - a)
    return min(ax, 1.0), min(ay, 1.0)


@njit(**JIT)
def is_anisotropic(anisotropy, principled):
    """Whether Cycles renders this anisotropy as such: Principled's above 0, the Glossy
    BSDF's beyond 1e-4 either way."""
    return anisotropy > 0.0 if principled else abs(anisotropy) > 1e-4


@njit(**JIT)
def tangent_frame(mx, my, mz, tx, ty, tz):
    """The lobe's frame about its normal m from the tangent t (Cycles'
    make_orthonormals_tangent): y = normalize(m x t), x = y x m. ok False where t lies
    along m."""
    yx, yy, yz = my * tz - mz * ty, mz * tx - mx * tz, mx * ty - my * tx
    length = math.sqrt(yx * yx + yy * yy + yz * yz)
    if not length > 1e-12:
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, False
    yx, yy, yz = yx / length, yy / length, yz / length
    return (yy * mz - yz * my, yz * mx - yx * mz, yx * my - yy * mx, yx, yy, yz, True)


@njit(**JIT)
def ggx_aniso_d(hx, hy, hz, ax, ay):
    """The anisotropic GGX distribution D at the local half vector h (z the normal)."""
    x, y = hx / ax, hy / ay
    ll = x * x + y * y + hz * hz
    return 1.0 / (np.pi * ax * ay * ll * ll)


@njit(**JIT)
def ggx_aniso_lambda(vx, vy, vz, ax, ay):
    """Smith's Lambda of anisotropic GGX for the local direction v."""
    t = ((ax * vx) ** 2 + (ay * vy) ** 2) / max(vz * vz, 1e-300)
    return 0.5 * (math.sqrt(1.0 + t) - 1.0)


@njit(**JIT)
def eval_lobe_ggx(wox, woy, woz, wix, wiy, wiz, hx, hy, hz, mx, my, mz, lobe, eta,
                  fresnel_on):
    """eval_ggx for the layer `lobe` about its normal m with half vector h: anisotropic
    where the lobe is (lobe.ax > 0: alpha_x, alpha_y along the frame of its tangent),
    else isotropic of lobe.alpha."""
    cos_o = mx * wox + my * woy + mz * woz
    cos_i = mx * wix + my * wiy + mz * wiz
    cos_hv = hx * wox + hy * woy + hz * woz
    if not lobe.ax > 0.0:
        return eval_ggx(cos_o, cos_i, mx * hx + my * hy + mz * hz, cos_hv,
                        lobe.alpha * lobe.alpha, eta, fresnel_on)
    if not (cos_o > 0 and cos_i > 0):
        return 0.0, 0.0
    xx, xy, xz, yx, yy, yz, _ = tangent_frame(mx, my, mz, lobe.tx, lobe.ty, lobe.tz)
    d = ggx_aniso_d(xx * hx + xy * hy + xz * hz, yx * hx + yy * hy + yz * hz,
                    mx * hx + my * hy + mz * hz, lobe.ax, lobe.ay)
    lo = ggx_aniso_lambda(xx * wox + xy * woy + xz * woz, yx * wox + yy * woy + yz * woz,
                          cos_o, lobe.ax, lobe.ay)
    li = ggx_aniso_lambda(xx * wix + xy * wiy + xz * wiz, yx * wix + yy * wiy + yz * wiz,
                          cos_i, lobe.ax, lobe.ay)
    f = fresnel_dielectric(cos_hv, eta, True)[0] if fresnel_on else 1.0
    common = d / (4.0 * cos_o)
    return f * common / (1.0 + lo + li), common / (1.0 + lo)


@njit(**JIT)
def sample_lobe_normal(wox, woy, woz, mx, my, mz, lobe, ua, ub):
    """sample_visible_normal for the layer `lobe`: anisotropic where it is."""
    if not lobe.ax > 0.0:
        return sample_visible_normal(wox, woy, woz, mx, my, mz, lobe.alpha, ua, ub)
    xx, xy, xz, yx, yy, yz, _ = tangent_frame(mx, my, mz, lobe.tx, lobe.ty, lobe.tz)
    hx, hy, hz = ggx_visible_normal(wox * xx + woy * xy + woz * xz,
                                    wox * yx + woy * yy + woz * yz,
                                    wox * mx + woy * my + woz * mz, lobe.ax, lobe.ay, ua, ub)
    return (hx * xx + hy * yx + hz * mx, hx * xy + hy * yy + hz * my,
            hx * xz + hy * yz + hz * mz)


@njit(**ALLOCATING)
def _lobe_integrands(alpha, fresnel_on, eta, mu, u):
    """White-furnace integrands of the GGX lobe at view cosine mu for the stratified
    samples u (k, 2): f cos / pdf with F = 1, and with the lobe's Fresnel; and the
    Fresnel's place between F0 and 1, (F - F0) / (1 - F0), where the sample reflects above
    the surface, else 0 (the integrand of Cycles' ggx_gen_schlick_ior_s table)."""
    a2 = alpha * alpha
    w = np.zeros(len(u))
    wf = np.zeros(len(u))
    s = np.zeros(len(u))
    f0 = ((eta - 1.0) / (eta + 1.0)) ** 2
    v0 = math.sqrt(max(0.0, 1 - mu * mu))
    lo = ggx_lambda(mu, a2)
    for k in range(len(u)):
        hx, hy, hz = ggx_visible_normal(v0, 0.0, mu, alpha, alpha, u[k, 0], u[k, 1])
        cos_hv = max(hx * v0 + hz * mu, 0.0)
        cos_i = 2.0 * cos_hv * hz - mu
        if cos_i > 0:
            f = fresnel_dielectric(cos_hv, eta, True)[0] if fresnel_on else 1.0
            w[k] = (1.0 / (1.0 + lo + ggx_lambda(cos_i, a2))) / (1.0 / (1.0 + lo))
            wf[k] = w[k] * f
            s[k] = min(max((f - f0) / (1.0 - f0), 0.0), 1.0) if f0 < 1.0 else 1.0
    return w, wf, s


@njit(**ALLOCATING)
def _glass_integrands(alpha, eta, mu, u):
    """White-furnace integrands of GGX glass (reflection and refraction, dielectric Fresnel
    of relative IOR eta, white tints) at view cosine mu: the sampled weight summed over the
    two lobes, each with its chance, for the stratified visible normals u (k, 2)."""
    a2 = alpha * alpha
    w = np.zeros(len(u))
    v0 = math.sqrt(max(0.0, 1 - mu * mu))
    lo = ggx_lambda(mu, a2)
    for k in range(len(u)):
        hx, hy, hz = ggx_visible_normal(v0, 0.0, mu, alpha, alpha, u[k, 0], u[k, 1])
        cos_hv = max(hx * v0 + hz * mu, 0.0)
        fr, cos_t = fresnel_dielectric(cos_hv, eta, True)
        cos_r = 2.0 * cos_hv * hz - mu
        if cos_r > 0:
            w[k] += fr * (1.0 + lo) / (1.0 + lo + ggx_lambda(cos_r, a2))
        cos_refracted = -mu / eta + (cos_hv / eta - cos_t) * hz
        if fr < 1.0 and cos_refracted < 0:
            w[k] += (1.0 - fr) * (1.0 + lo) / (1.0 + lo + ggx_lambda(cos_refracted, a2))
    return w


@njit(**ALLOCATING)
def _fresnel_curve(m, eta):
    out = np.empty(len(m))
    for k in range(len(m)):
        out[k] = fresnel_dielectric(m[k], eta, True)[0]
    return out


def fresnel_average(eta: float) -> float:
    """Fss, the dielectric Fresnel's hemispherical average 2 int F(mu) mu dmu at relative
    IOR eta (2049-point trapezoid): what the compensation and the layering read."""
    m = np.linspace(0.0, 1.0, 2049)
    return float(2.0 * trapezoid(_fresnel_curve(m, float(eta)) * m, m))


@njit(**JIT)
def ior_z(eta):
    """z = sqrt(|eta - 1| / (eta + 1)), Cycles' IOR axis (F0 = z^4), the same for eta and
    1 / eta."""
    return math.sqrt(abs(eta - 1.0) / (eta + 1.0))


def r2_points(n: int) -> np.ndarray:
    """n points (n, 2) of Roberts' R2 sequence in [0, 1)^2. A 32 x 32 grid of visible
    normals left (1 - E) / E up to 0.013 off at normal incidence (its rings alias with the
    grid: 0.034 for 0.021 at roughness 0.36), which made E jagged over roughness; 4096 R2
    points keep it within 0.0022 of a 512 x 512 grid over mu and roughness."""
    g = 1.32471795724474602596  # the plastic number
    return (0.5 + np.outer(np.arange(1, n + 1), (1.0 / g, 1.0 / (g * g)))) % 1.0


_TABLE_POINTS = r2_points(4096)


class MicrofacetTables:
    """Per-material tables over mu_o = cos(theta_o) for one GGX lobe (alpha, Fresnel).

    missing_table : (1 - E) / E, the energy the single-scatter lobe misses;
    compensation_table : the Kulla-Conty factor 1 + Fms (1 - E) / E for the lobe's own Fss;
    albedo_table : directional albedo of the compensated lobe with its Fresnel (what the
        Principled base loses to the specular layer);
    estimate_table : Cycles' estimate of the plain lobe's albedo with a dielectric Fresnel
        (bsdf_microfacet_estimate_albedo), which a Principled layer or coat dims what is
        below by: F0 + (1 - F0) s, s the mean over visible normals of the Fresnel's place
        between F0 and 1 where the reflection lies above the surface (0 where not), as
        its ggx_gen_schlick_ior_s table is made (at 1 / eta below 1, as Cycles reads it).
        Not weighted by the masking, so not the albedo itself: the smooth Fresnel for a
        smooth lobe, less at grazing views as the lobe roughens;
    layering_table : the same estimate for the compensated lobe, times Cycles' darkening
        (1 + Fms (1 - E) / E) E (microfacet_ggx_preserve_energy scales the closure's
        weight by it, and the estimate includes the weight);
    spread : s over mu, the mean place between F0 and 1 (the estimate's own table);
    fss : the Fresnel's hemispherical average (1 without a Fresnel).
    Integrals use a fixed low-discrepancy set of visible-normal samples: deterministic
    tables.
    """

    def __init__(self, alpha: float, fresnel: str = "dielectric", eta: float = 1.5):
        self.alpha = max(float(alpha), MIN_ALPHA)
        n_mu = ALBEDO_TABLE_SIZE
        self.mu = np.linspace(1e-3, 1.0, n_mu)
        u = _TABLE_POINTS
        fresnel_on = fresnel != "none"
        e_white = np.zeros(n_mu)
        e_fresnel = np.zeros(n_mu)
        schlick_s = np.zeros(n_mu)
        # Cycles reads the estimate's table (ggx_gen_schlick_ior_s, made for IORs >= 1) at
        # z = sqrt(|eta - 1| / (eta + 1)), which below 1 is 1 / eta's place (the same F0):
        # what lies below the lobe is dimmed as under 1 / eta, while the lobe reflects with
        # eta's own Fresnel, total internal reflection and all.
        spread_eta = 1.0 / float(eta) if fresnel_on and eta < 1.0 else float(eta)
        for i, mu in enumerate(self.mu):
            w, wf, s = _lobe_integrands(self.alpha, fresnel_on, float(eta), float(mu), u)
            if spread_eta != eta:
                s = _lobe_integrands(self.alpha, True, spread_eta, float(mu), u)[2]
            e_white[i], e_fresnel[i], schlick_s[i] = w.mean(), wf.mean(), s.mean()
        e_white = np.clip(e_white, 1e-6, 1.0)
        self.e_avg = float(2.0 * trapezoid(e_white * self.mu, self.mu))
        if fresnel_on:
            fss = fresnel_average(eta)
        else:
            fss = 1.0
        self.missing_table = (1.0 - e_white) / e_white
        self.fms = float(self.multiscatter_fresnel(fss))
        self.compensation_table = 1.0 + self.fms * self.missing_table
        self.albedo_table = np.clip(e_fresnel * self.compensation_table, 0.0, 1.0)
        f0 = ((float(eta) - 1.0) / (float(eta) + 1.0)) ** 2 if fresnel_on else 1.0
        self.estimate_table = f0 + (1.0 - f0) * schlick_s
        self.layering_table = self.estimate_table * self.compensation_table * e_white
        self.spread, self.fss = schlick_s, float(fss)
        self.fresnel, self.eta = fresnel, float(eta)

    def multiscatter_fresnel(self, fss):
        """Fms for a single-scatter Fresnel average Fss (scalar or per channel)."""
        fss = np.asarray(fss, np.float64)
        return np.vectorize(multiscatter_fresnel)(fss, self.e_avg)


class GlassTables:
    """The albedo tables of one GGX glass lobe (alpha, relative IOR eta) over mu_o, as
    Cycles' ggx_glass_E / ggx_glass_inv_E: E sums reflection and refraction, so with white
    tints the compensated lobe keeps all the energy. One per side of the surface (eta and
    1 / eta: total internal reflection makes them differ).

    missing_table : (1 - E) / E; e_avg : E's cosine-weighted mean (for Fms)."""

    def __init__(self, alpha: float, eta: float):
        self.alpha = max(float(alpha), MIN_ALPHA)
        self.mu = np.linspace(1e-3, 1.0, ALBEDO_TABLE_SIZE)
        # Total internal reflection cuts the integrand off: the 4096 R2 points keep E
        # within 1e-3 of a 512^2 grid over roughness, mu and both sides of IOR 1.5 (a
        # 128^2 grid, four times the work, was 3e-3 off; 32^2 8e-3 at 1 / 1.5, mu 0.98).
        u = _TABLE_POINTS
        e = np.array([_glass_integrands(self.alpha, float(eta), float(mu), u).mean()
                      for mu in self.mu])
        e = np.clip(e, 1e-6, 1.0)
        self.e_avg = float(2.0 * trapezoid(e * self.mu, self.mu))
        self.missing_table = (1.0 - e) / e


@njit(**JIT)
def multiscatter_fresnel(fss, e_avg):
    """Fms, the Fresnel of light that scatters more than once among the microfacets, for
    the single-scatter Fresnel average Fss and the lobe's average albedo E_avg (Kulla and
    Conty 2017, as Cycles' microfacet_ggx_multiscatter)."""
    return fss * e_avg / (1.0 - fss * (1.0 - e_avg))


def layer_fms(tables: MicrofacetTables, principled: bool, colour) -> np.ndarray:
    """(3,) Fms of a rough material's specular lobe: the Principled layer's dielectric
    Fresnel on every channel, or the Glossy colour as its constant Fresnel (Cycles clamps
    it at 0)."""
    if principled:
        return np.full(3, tables.fms)
    return tables.multiscatter_fresnel(np.maximum(np.asarray(colour, np.float64), 0.0))


# A textured roughness' tables are computed on this many roughnesses t^ROUGHNESS_WARP (t
# uniform in [0, 1]: denser toward 0, where the Principled albedo turns fastest at grazing
# angles) and interpolated linearly between them, as Cycles reads its 2D and 3D albedo
# tables of 16 to 32 roughnesses; alpha itself is exact at each hit. Measured against the
# tables of each roughness as a constant over roughness 0.02-0.98 and mu 0.02-1: the
# compensation within 0.4%, the Principled base's weight within 1.5% (at mu 0.02,
# roughness 0.07; 5.5% with 17 uniform rows).
ROUGHNESS_GRID = 33
ROUGHNESS_WARP = 1.5

# A Principled BSDF whose IOR or Specular IOR Level varies over the surface (a texture on
# either: the glTF importer's KHR_materials_specular texture drives the level) reads its
# dielectric layer's spread and Fresnel average at each hit's own relative IOR, from one
# table for every scene (varying_ior_tables): the spread over roughness (t^ROUGHNESS_WARP,
# t uniform, as the rows over roughness), z = sqrt(|eta - 1| / (eta + 1)) (denser toward
# IOR 1, IOR_Z_WARP) and sqrt(mu) (uniform: the spread turns fastest at grazing views),
# read trilinearly; z is Cycles' axis for its own table of the spread
# (ggx_gen_schlick_ior_s), on which eta and 1 / eta meet (what lies below the lobe is
# dimmed alike, MicrofacetTables). The Fresnel
# average, on a finer grid over z, for eta >= 1 and for eta < 1 (total internal
# reflection makes them differ). tests/engine/test_microfacet.py measures both against
# the exact integrals: Cycles' estimate F0 + (1 - F0) s within 0.010 (7e-4 on average);
# 17 rows over z, uniform, left it 0.024 off near IOR 1 at grazing views.
IOR_TABLE_SHAPE = (17, 25, 33)  # roughness, z, sqrt(mu)
IOR_FSS_SIZE = 257  # z
IOR_TABLE_POINTS = 1024  # visible normals per entry (the spread is a mean Fresnel in [0, 1])
IOR_TABLE_MAX_Z = 0.999  # eta 1000: F0 0.996, where the spread hardly matters any more
IOR_Z_WARP = 1.5  # rows at z = MAX_Z t^WARP, t uniform: near IOR 1 the spread is steep


def eta_of_z(z: float) -> float:
    """The relative IOR >= 1 whose z = sqrt((eta - 1) / (eta + 1)) is z (in [0, 1))."""
    return (1.0 + z * z) / (1.0 - z * z)


@functools.lru_cache(maxsize=1)
def varying_ior_tables() -> tuple:
    """(spread (IOR_TABLE_SHAPE), fss (2, z)): the tables a varying IOR reads (see
    IOR_TABLE_SHAPE), the same for every scene; made once per process (about 1 s)."""
    nr, nz, nm = IOR_TABLE_SHAPE
    u = r2_points(IOR_TABLE_POINTS)
    z = IOR_TABLE_MAX_Z * np.linspace(0.0, 1.0, nz) ** IOR_Z_WARP
    spread = np.zeros(IOR_TABLE_SHAPE)
    for i, t in enumerate(np.linspace(0.0, 1.0, nr)):
        alpha = max(float(t ** ROUGHNESS_WARP) ** 2, MIN_ALPHA)
        for j in range(nz):  # (z = 0: the limit toward IOR 1, steep at grazing views)
            eta = eta_of_z(max(float(z[j]), 1e-3))
            for k, root in enumerate(np.linspace(0.0, 1.0, nm)):
                spread[i, j, k] = _lobe_integrands(alpha, True, eta, max(root * root, 1e-3),
                                                   u)[2].mean()
    etas = [eta_of_z(float(x)) for x in np.linspace(0.0, IOR_TABLE_MAX_Z, IOR_FSS_SIZE)]
    fss = np.array([[fresnel_average(eta) for eta in etas],
                    [fresnel_average(1.0 / eta) for eta in etas]])
    return spread, fss


@njit(**JIT)
def ior_spread_at(table, roughness, eta, mu):
    """The spread (MicrofacetTables.spread) of a dielectric GGX lobe of `roughness` and
    relative IOR eta at view cosine mu, read trilinearly from varying_ior_tables'; 0 at
    IOR 1, which reflects nothing (its z = 0 row is the limit toward it)."""
    if eta == 1.0:
        return 0.0
    nr, nz, nm = table.shape
    a = min(max(roughness, 0.0), 1.0) ** (1.0 / ROUGHNESS_WARP) * (nr - 1)
    b = min(ior_z(eta) / IOR_TABLE_MAX_Z, 1.0) ** (
        1.0 / IOR_Z_WARP) * (nz - 1)
    c = math.sqrt(min(max(mu, 0.0), 1.0)) * (nm - 1)
    i, j, k = min(int(a), nr - 2), min(int(b), nz - 2), min(int(c), nm - 2)
    a, b, c = a - i, b - j, c - k
    out = 0.0
    for di in range(2):
        for dj in range(2):
            for dk in range(2):
                wt = (a if di else 1.0 - a) * (b if dj else 1.0 - b) * (c if dk else 1.0 - c)
                out += wt * table[i + di, j + dj, k + dk]
    return out


@njit(**JIT)
def ior_fss_at(table, eta):
    """The dielectric Fresnel's hemispherical average at relative IOR eta, read linearly
    from varying_ior_tables' over z."""
    nz = table.shape[1]
    b = min(ior_z(eta) / IOR_TABLE_MAX_Z, 1.0) * (nz - 1)
    j = min(int(b), nz - 2)
    row = 1 if eta < 1.0 else 0
    return table[row, j] + (b - j) * (table[row, j + 1] - table[row, j])


# The layered lobes' tables for the kernel. Per material (k rows, zeros for other kinds):
# base (k, 3) diffuse colour (Principled) or 0 (Glossy); tint (k, 3) specular weight (1 or
# the Glossy colour); fresnel (k,) bool: dielectric Fresnel (Principled) or none; first and
# count (k,): its rows in the tables below, its own row (first = the material, count 1)
# for a constant roughness, ROUGHNESS_GRID rows over roughness 0..1 for a textured one.
# Per row: alpha; fms (n, 3) per channel; missing and albedo (n, m) over mu (albedo: what
# the lobe takes from the layers below it, MicrofacetTables.layering_table), the grid of
# view cosines (m,) with its guided_interp guide; e_avg the lobe's average albedo (a
# textured Glossy colour's Fms at each hit). Rough glass: fms, missing and e_avg are its
# front side's (entering, IOR), fms_back, missing_back and e_avg_back its back side's
# (leaving, 1 / IOR). spread (n, m): the Principled rows' mean place of the Fresnel between
# F0 and 1 over mu, and fss (k,) the Principled materials' Fresnel average: what a Specular
# Tint's Fresnel needs (tinted_layer_at). varying_ior (k,) bool: a Principled layer whose
# IOR varies, which reads its spread and Fresnel average at each hit's IOR from ior_spread
# and ior_fss (varying_ior_tables; one zero entry each where no material needs them).
LayerTables = namedtuple("LayerTables", "base tint fresnel first count mu mu_guide alpha fms "
                                        "missing albedo e_avg fms_back missing_back "
                                        "e_avg_back spread fss diffuse_roughness "
                                        "varying_ior ior_spread ior_fss")

# One rough vertex's lobe: the diffuse weight dw and specular (reflection) tint (3 each),
# alpha, eta, fresnel_on, the compensation per channel at mu_o (3), the chance of the
# specular lobe, the transmission tint (3; rough glass, else 0), the F82 model's b
# (3; rough metal, fresnel_f82, else 0) and the Principled BSDF's Specular Tint on a
# dielectric Fresnel (3; fresnel.tinted_fresnel; 1 elsewhere); the Principled base's
# Oren-Nayar roughness (0: Lambert) and colour, its albedo (3); an anisotropic lobe's
# alpha_x, alpha_y (ax 0: isotropic, alpha) and tangent t (3; anisotropic_layer); a thin
# film's thickness (nm; 0: none) and IOR relative to the side of wo (filmed_layer).
Layer = namedtuple("Layer", "dw0 dw1 dw2 tint0 tint1 tint2 alpha eta fresnel_on "
                            "comp0 comp1 comp2 p_spec tt0 tt1 tt2 b0 b1 b2 st0 st1 st2 "
                            "sigma base0 base1 base2 ax ay tx ty tz film_d film_n",
                  defaults=(0.0,) * 10 + (1.0,))


@njit(**INLINE)
def no_layer():
    """The Layer of a vertex without a rough lobe."""
    return Layer(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
                 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
                 0.0, 0.0, 1.0)


@njit(**INLINE)
def anisotropic_layer(lobe, ax, ay, tx, ty, tz):
    """`lobe` made anisotropic: alpha_x ax along tangent t, alpha_y across it (Cycles
    keeps the compensation the tables give at its isotropic roughness)."""
    return retailed_layer(lobe, ax, ay, tx, ty, tz, lobe.film_d, lobe.film_n)


@njit(**INLINE)
def filmed_layer(lobe, thickness, film_ior):
    """`lobe` under a thin film of `thickness` (nm) and IOR `film_ior` relative to the side
    of wo: its Fresnel of a single scattering becomes the film's (filmed_fresnel); its
    compensation and its share of the layering keep their film-free values, as Cycles'."""
    return retailed_layer(lobe, lobe.ax, lobe.ay, lobe.tx, lobe.ty, lobe.tz, thickness,
                          film_ior)


@njit(**INLINE)
def retailed_layer(lobe, ax, ay, tx, ty, tz, film_d, film_n):
    """`lobe` with the fields a lobe gains after its tables are read replaced: its
    anisotropy (alpha_x, alpha_y, tangent) and its thin film (thickness, IOR)."""
    return Layer(lobe.dw0, lobe.dw1, lobe.dw2, lobe.tint0, lobe.tint1, lobe.tint2, lobe.alpha,
                 lobe.eta, lobe.fresnel_on, lobe.comp0, lobe.comp1, lobe.comp2, lobe.p_spec,
                 lobe.tt0, lobe.tt1, lobe.tt2, lobe.b0, lobe.b1, lobe.b2, lobe.st0, lobe.st1,
                 lobe.st2, lobe.sigma, lobe.base0, lobe.base1, lobe.base2, ax, ay, tx, ty, tz,
                 film_d, film_n)


@njit(**JIT)
def filmed_fresnel(cos_i, eta, film_d, film_n, st0, st1, st2):
    """A Principled dielectric's Fresnel per channel under its film (fresnel.
    thin_film_dielectric: eta and film_n relative to the incident side) and Specular Tint
    st (fresnel.film_tinted)."""
    f0, f1, f2 = thin_film_dielectric(cos_i, eta, film_n, film_d)
    return film_tinted(f0, eta, st0), film_tinted(f1, eta, st1), film_tinted(f2, eta, st2)


def layer_tables(materials, used) -> LayerTables:
    """The LayerTables of the rough materials (Principled, rough Glossy, rough metal, rough
    glass) among `used`; a material with a roughness program gets its rows over roughness.
    Plain GGX (not Multiscatter) has no compensation: nothing missing."""
    k = len(materials.kind)
    base, tint = np.zeros((k, 3)), np.zeros((k, 3))
    fresnel = np.zeros(k, np.bool_)
    first, count = np.arange(k, dtype=np.int64), np.ones(k, np.int64)
    roughness = materials.roughness if materials.roughness is not None else np.zeros(k)
    textured = materials.roughness_programs or [None] * k
    # An anisotropic lobe reads its tables at (alpha_x alpha_y)^(1/4), which differs from
    # its roughness where an alpha is clamped to 1: it gets the rows over roughness too.
    anisotropic = materials.anisotropic()
    rows = [_lobe_row(materials, j, 0.0, False) for j in range(k)]  # zeros but for `used`
    fss = np.ones(k)
    for j in used:
        kind = materials.kind[j]
        if kind not in (PRINCIPLED, GLOSSY, ROUGH_METAL, ROUGH_GLASS):
            continue
        principled = kind == PRINCIPLED
        fresnel[j] = principled
        if principled:
            fss[j] = microfacet_tables(MIN_ALPHA, "dielectric", float(materials.ior[j])).fss
        base[j] = materials.colour[j] if principled else 0.0
        tint[j] = materials.colour[j] if kind in (GLOSSY, ROUGH_METAL) else float(principled)
        rows[j] = _lobe_row(materials, j, float(roughness[j]))
        if textured[j] is not None or anisotropic[j]:
            first[j], count[j] = len(rows), ROUGHNESS_GRID
            rows += [_lobe_row(materials, j, float(t ** ROUGHNESS_WARP))
                     for t in np.linspace(0.0, 1.0, ROUGHNESS_GRID)]
    mu = np.linspace(1e-3, 1.0, ALBEDO_TABLE_SIZE)
    alpha, fms, missing, albedo, e_avg, fms_back, missing_back, e_avg_back, spread = \
        (np.array(column, np.float64) for column in zip(*rows))
    diffuse_roughness = materials.diffuse_roughness if materials.diffuse_roughness is not None \
        else np.zeros(k)
    varying_ior = np.zeros(k, np.bool_)
    varying_ior[used] = materials.varying_ior()[used] & fresnel[used]
    ior_spread, ior_fss = varying_ior_tables() if varying_ior.any() else \
        (np.zeros((2, 2, 2)), np.zeros((2, 2)))
    return LayerTables(base, tint, fresnel, first, count, mu, interp_guide(mu, 256), alpha,
                       fms, missing, albedo, e_avg, fms_back, missing_back, e_avg_back,
                       spread, fss, np.ascontiguousarray(diffuse_roughness, np.float64),
                       varying_ior, ior_spread, ior_fss)


def _lobe_row(materials, j, roughness, rough=True) -> tuple:
    """One row of LayerTables for material j's lobe at `roughness`: alpha, fms (3,),
    missing (m,), albedo (m,), e_avg, fms_back (3,), missing_back (m,), e_avg_back,
    spread (m,); zeros but for alpha where not `rough`."""
    alpha = max(roughness * roughness, MIN_ALPHA)
    m = ALBEDO_TABLE_SIZE
    zero3, zeros = np.zeros(3), np.zeros(m)
    if not rough:
        return alpha, zero3, zeros, zeros, 0.0, zero3, zeros, 0.0, zeros
    kind, colour, ior = materials.kind[j], materials.colour[j], float(materials.ior[j])
    multiscatter = True if materials.multiscatter is None else bool(materials.multiscatter[j])
    if kind == ROUGH_GLASS:
        sides = []
        for eta in (ior, 1.0 / ior):
            e_avg, missing = _glass_albedo(alpha, eta)
            fss = glass_fss(materials.reflection_tint[j], materials.transmission_tint[j], eta)
            sides.append((np.vectorize(multiscatter_fresnel)(fss, e_avg),
                          missing if multiscatter else zeros, e_avg))
        (fms, missing, e_avg), (fms_back, missing_back, e_avg_back) = sides
        return alpha, fms, missing, zeros, e_avg, fms_back, missing_back, e_avg_back, zeros
    if kind == ROUGH_METAL:
        tables = microfacet_tables(alpha, "none", 1.5)
        fms = tables.multiscatter_fresnel([
            f82_fss(c, f82_tint_b(c, t)) for c, t in zip(colour, materials.reflection_tint[j])])
        return (alpha, fms, tables.missing_table if multiscatter else zeros, zeros,
                tables.e_avg, zero3, zeros, 0.0, zeros)
    principled = kind == PRINCIPLED
    tables = microfacet_tables(alpha, "dielectric" if principled else "none", ior)
    spread = tables.spread if principled else zeros
    if multiscatter:
        return (alpha, layer_fms(tables, principled, colour), tables.missing_table,
                tables.layering_table, tables.e_avg, zero3, zeros, 0.0, spread)
    return (alpha, layer_fms(tables, principled, colour), zeros, tables.estimate_table,
            tables.e_avg, zero3, zeros, 0.0, spread)


@functools.lru_cache(maxsize=512)
def microfacet_tables(alpha: float, fresnel: str, eta: float) -> "MicrofacetTables":
    """MicrofacetTables(alpha, fresnel, eta), kept (read only): 14 ms each, and each
    render of a scene asks for the same ones again."""
    return MicrofacetTables(alpha, fresnel, eta)


@functools.lru_cache(maxsize=512)
def _glass_albedo(alpha: float, eta: float) -> tuple:
    """(E_avg, (1 - E) / E over mu) of GGX glass at (alpha, eta), kept: 0.06 s each, and a
    textured roughness needs them on a grid, per side."""
    g = GlassTables(alpha, eta)
    return g.e_avg, g.missing_table


def glass_fss(reflection_tint, transmission_tint, eta) -> np.ndarray:
    """(3,) the Fresnel average Cycles' glass compensation darkens by at relative IOR eta:
    the transmission tint, which Cycles "assumes makes up most of the overall color" (the
    Glass BSDF's colour, the Principled BSDF's sqrt(base)); for glass that transmits
    nothing, the dielectric Fresnel's average times the reflection tint. Measured: with
    Fss 1 for the Glass BSDF, a rough (0.5) tinted ball was 2.4 % brighter than Cycles'
    (z 4.7, rough_glass_tinted)."""
    t = np.maximum(np.asarray(transmission_tint, np.float64), 0.0)
    if t.any():
        return t
    fss = fresnel_average(eta)
    return fss * np.maximum(np.asarray(reflection_tint, np.float64), 0.0)


@njit(**INLINE)
def lobe_rows(mat, lt, roughness):
    """Material mat's rows of LayerTables lt at a hit: (row, next row, the next's weight,
    alpha). A constant roughness (roughness < 0 or one row) reads the material's own row
    (at its constant); a textured one the grid cell around `roughness`, with alpha =
    roughness^2 exact."""
    first, n = lt.first[mat], lt.count[mat]
    if n <= 1 or roughness < 0.0:
        return mat, mat, 0.0, lt.alpha[mat]
    s = min(max(roughness, 0.0), 1.0) ** (1.0 / ROUGHNESS_WARP) * (n - 1)
    j = min(int(s), n - 2)
    return first + j, first + j + 1, s - j, max(roughness * roughness, MIN_ALPHA)


@njit(**INLINE)
def table_at(mu, lt, table, r0, r1, w):
    """Table (rows over mu) at view cosine mu, between rows r0 and r1 by weight w."""
    a = guided_interp(mu, lt.mu, table[r0], lt.mu_guide)
    if w > 0.0:
        a += w * (guided_interp(mu, lt.mu, table[r1], lt.mu_guide) - a)
    return a


@njit(**INLINE)
def fms_at(fms, r0, r1, w):
    """A per-channel Fms (rows of 3) between rows r0 and r1 by weight w."""
    return (fms[r0, 0] + w * (fms[r1, 0] - fms[r0, 0]),
            fms[r0, 1] + w * (fms[r1, 1] - fms[r0, 1]),
            fms[r0, 2] + w * (fms[r1, 2] - fms[r0, 2]))


@njit(**INLINE)
def layer_at(mat, mu, eta, lt, textured, c0, c1, c2, roughness, st, sigma=-1.0, film_d=0.0,
             film_n=1.0):
    """The layered lobe of rough material `mat` at view cosine mu (to its specular normal)
    from its LayerTables lt; with `textured`, its colour at this point is c (the Principled
    base, or the Glossy tint and, through Fss, its Fms) instead of the table's; roughness
    is the hit's where it is textured (lobe_rows); st (3) the Principled BSDF's Specular
    Tint here (tinted_layer_at); sigma its Diffuse Roughness here (< 0: the table's); eta
    the Principled layer's relative IOR here (its own where it varies, tinted_layer_at);
    film_d > 0: under a thin film of that thickness (nm) and IOR film_n (tinted_layer_at)."""
    if sigma < 0.0:
        sigma = lt.diffuse_roughness[mat]
    if lt.fresnel[mat] and (st[0] != 1.0 or st[1] != 1.0 or st[2] != 1.0
                            or lt.varying_ior[mat] or film_d > 0.0):
        return tinted_layer_at(mat, mu, eta, lt, textured, c0, c1, c2, roughness, st, sigma,
                               film_d, film_n)
    r0, r1, w, alpha = lobe_rows(mat, lt, roughness)
    missing = table_at(mu, lt, lt.missing, r0, r1, w)
    albedo = table_at(mu, lt, lt.albedo, r0, r1, w)
    b0, b1, b2 = lt.base[mat, 0], lt.base[mat, 1], lt.base[mat, 2]
    tint0, tint1, tint2 = lt.tint[mat, 0], lt.tint[mat, 1], lt.tint[mat, 2]
    f0, f1, f2 = fms_at(lt.fms, r0, r1, w)
    if textured:
        if lt.fresnel[mat]:  # Principled: the base
            b0, b1, b2 = c0, c1, c2
        else:  # Glossy: the tint is the Fresnel
            tint0, tint1, tint2 = c0, c1, c2
            e = lt.e_avg[r0] + w * (lt.e_avg[r1] - lt.e_avg[r0])
            f0, f1, f2 = (multiscatter_fresnel(c0, e), multiscatter_fresnel(c1, e),
                          multiscatter_fresnel(c2, e))
    dw0, dw1, dw2 = b0 * (1.0 - albedo), b1 * (1.0 - albedo), b2 * (1.0 - albedo)
    sp = (tint0 + tint1 + tint2) / 3.0 * albedo
    sd = (dw0 + dw1 + dw2) / 3.0
    p_spec = sp / max(sp + sd, 1e-300) if sp + sd > 0 else 1.0
    return Layer(dw0, dw1, dw2, tint0, tint1, tint2, alpha, eta, lt.fresnel[mat],
                 1.0 + f0 * missing, 1.0 + f1 * missing, 1.0 + f2 * missing, p_spec,
                 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, sigma, b0, b1, b2,
                 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)


@njit(**JIT)
def tinted_layer_at(mat, mu, eta, lt, textured, c0, c1, c2, roughness, st, sigma, film_d,
                    film_n):
    """layer_at for a Principled layer under a Specular Tint st (3): Cycles' generalized
    Schlick Fresnel from F0 x st to 1 (fresnel.tinted_fresnel). Per channel, its estimated
    albedo is F0 st + (1 - F0 st) s(mu), s the real Fresnel's mean place between F0 and 1
    (LayerTables.spread), times the compensation's darkening (1 + Fms (1 - E) / E) E, Fms
    from Fss = F0 st + (1 - F0 st) s_ss (the same place for the hemispherical average);
    the base keeps 1 - the largest channel of it (Cycles' closure_layering_weight). Where
    the layer's IOR varies (LayerTables.varying_ior), s and Fss are read at this eta; the
    energy the lobe misses does not depend on it. Under a thin film (film_d > 0) the
    estimate is the film's Fresnel at mu instead (Cycles: no tables for films), the
    compensation the film-free one."""
    r0, r1, w, alpha = lobe_rows(mat, lt, roughness)
    missing = table_at(mu, lt, lt.missing, r0, r1, w)
    if lt.varying_ior[mat]:
        spread = ior_spread_at(lt.ior_spread, math.sqrt(alpha), eta, mu)
        fss = ior_fss_at(lt.ior_fss, eta)
    else:
        spread = table_at(mu, lt, lt.spread, r0, r1, w)
        fss = lt.fss[mat]
    e = lt.e_avg[r0] + w * (lt.e_avg[r1] - lt.e_avg[r0])
    f0 = ((eta - 1.0) / (eta + 1.0)) ** 2
    s_ss = min(max((fss - f0) / (1.0 - f0), 0.0), 1.0) if f0 < 1.0 else 1.0
    b0, b1, b2 = lt.base[mat, 0], lt.base[mat, 1], lt.base[mat, 2]
    if textured:
        b0, b1, b2 = c0, c1, c2
    c0, a0 = _tinted_channel(f0, st[0], s_ss, spread, e, missing)
    c1, a1 = _tinted_channel(f0, st[1], s_ss, spread, e, missing)
    c2, a2 = _tinted_channel(f0, st[2], s_ss, spread, e, missing)
    if film_d > 0.0:
        g0, g1, g2 = filmed_fresnel(mu, eta, film_d, film_n, st[0], st[1], st[2])
        a0, a1, a2 = (g0 * c0 / (1.0 + missing), g1 * c1 / (1.0 + missing),
                      g2 * c2 / (1.0 + missing))
    kept = 1.0 - min(max(a0, max(a1, a2)), 1.0)
    dw0, dw1, dw2 = b0 * kept, b1 * kept, b2 * kept
    sp = (a0 + a1 + a2) / 3.0
    sd = (dw0 + dw1 + dw2) / 3.0
    p_spec = sp / max(sp + sd, 1e-300) if sp + sd > 0 else 1.0
    return Layer(dw0, dw1, dw2, 1.0, 1.0, 1.0, alpha, eta, True, c0, c1, c2, p_spec,
                 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, st[0], st[1], st[2], sigma, b0, b1, b2,
                 0.0, 0.0, 0.0, 0.0, 0.0, film_d, film_n)


@njit(**INLINE)
def _tinted_channel(f0, tint, s_ss, spread, e_avg, missing):
    """One channel of tinted_layer_at: (the compensation 1 + Fms (1 - E) / E, the
    estimated albedo)."""
    t0 = min(max(f0 * tint, 0.0), 1.0)
    comp = 1.0 + multiscatter_fresnel(t0 + (1.0 - t0) * s_ss, e_avg) * missing
    return comp, (t0 + (1.0 - t0) * spread) * comp / (1.0 + missing)


@njit(**JIT)
def f82_fss(f0, b):
    """The hemispherical average 2 int F mu dmu of fresnel_f82 (Cycles' fresnel_f82_Fss):
    F0 + (1 - F0) / 21 - b / 126, in [0, 1]."""
    g = min(max(f0, 0.0), 1.0)
    return min(max(g + (1.0 - g) / 21.0 - b / 126.0, 0.0), 1.0)


@njit(**JIT)
def schlick_fss(f0):
    """f82_fss with b = 0: Schlick's average F0 + (1 - F0) / 21."""
    return f82_fss(f0, 0.0)


@njit(**INLINE)
def metal_layer_at(mat, mu, lt, textured, c0, c1, c2, roughness, edge):
    """The rough metal lobe of material `mat` at view cosine mu from its LayerTables lt:
    tint is the Fresnel's F0 (the base colour, or c where it is textured), `edge` (3,) the
    Specular Tint its F82 curve bends toward (fresnel_f82); roughness as layer_at's."""
    r0, r1, w, alpha = lobe_rows(mat, lt, roughness)
    missing = table_at(mu, lt, lt.missing, r0, r1, w)
    f0, f1, f2 = fms_at(lt.fms, r0, r1, w)
    tint0, tint1, tint2 = lt.tint[mat, 0], lt.tint[mat, 1], lt.tint[mat, 2]
    if textured:
        tint0, tint1, tint2 = c0, c1, c2
    b0, b1, b2 = (f82_tint_b(tint0, edge[0]), f82_tint_b(tint1, edge[1]),
                  f82_tint_b(tint2, edge[2]))
    if textured:
        e = lt.e_avg[r0] + w * (lt.e_avg[r1] - lt.e_avg[r0])
        f0, f1, f2 = (multiscatter_fresnel(f82_fss(c0, b0), e),
                      multiscatter_fresnel(f82_fss(c1, b1), e),
                      multiscatter_fresnel(f82_fss(c2, b2), e))
    return Layer(0.0, 0.0, 0.0, tint0, tint1, tint2, alpha, 1.0, False,
                 1.0 + f0 * missing, 1.0 + f1 * missing, 1.0 + f2 * missing, 1.0,
                 0.0, 0.0, 0.0, b0, b1, b2, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
                 0.0, 0.0, 0.0, 0.0, 1.0)


@njit(**INLINE)
def glass_layer_at(mat, mu, front, ior, lt, r_tint, t_tint, roughness, fresnel_on, textured,
                   st):
    """The rough glass lobe of material `mat` at view cosine mu, on its front side (eta =
    IOR) or its back side (eta = 1 / IOR), from its LayerTables lt; roughness as
    layer_at's; without fresnel_on, the Refraction BSDF's (glass_fresnel); st (3) the
    Principled BSDF's Specular Tint on its Fresnel. With `textured`, the tints are this
    point's: the compensation's Fss is its transmission tint (glass_fss; a texel
    transmitting nothing gets no compensation)."""
    r0, r1, w, alpha = lobe_rows(mat, lt, roughness)
    if front:
        missing = table_at(mu, lt, lt.missing, r0, r1, w)
        f0, f1, f2 = fms_at(lt.fms, r0, r1, w)
        e = lt.e_avg[r0] + w * (lt.e_avg[r1] - lt.e_avg[r0])
        eta = ior
    else:
        missing = table_at(mu, lt, lt.missing_back, r0, r1, w)
        f0, f1, f2 = fms_at(lt.fms_back, r0, r1, w)
        e = lt.e_avg_back[r0] + w * (lt.e_avg_back[r1] - lt.e_avg_back[r0])
        eta = 1.0 / ior
    if textured:
        f0, f1, f2 = (multiscatter_fresnel(max(t_tint[0], 0.0), e),
                      multiscatter_fresnel(max(t_tint[1], 0.0), e),
                      multiscatter_fresnel(max(t_tint[2], 0.0), e))
    return Layer(0.0, 0.0, 0.0, r_tint[0], r_tint[1], r_tint[2], alpha, eta, fresnel_on,
                 1.0 + f0 * missing, 1.0 + f1 * missing, 1.0 + f2 * missing, 1.0,
                 t_tint[0], t_tint[1], t_tint[2], 0.0, 0.0, 0.0, st[0], st[1], st[2], 0.0,
                 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)


@njit(**INLINE)
def coat_layering(cos_o, coat, lt, roughness, ior, weight, tint):
    """Cycles' Principled coat of IOR `ior` and Coat Weight `weight` whose lobe is material
    `coat` (LayerTables lt; roughness as layer_at's), seen at cosine cos_o to its normal:
    (A, the tint's attenuation (3 values)). A is the lobe's albedo as Cycles estimates it
    for the layering (the coat row's albedo column, MicrofacetTables.layering_table: the
    smooth dielectric's Fresnel for a smooth coat, less at grazing views as it roughens),
    so what lies below keeps 1 - weight x A; the tint is the colour kept through the coat
    head-on, so along the view refracted into it, at cosine cos_t, it is tint^(1 / cos_t),
    applied by weight (Cycles: mix(1, tint^(1 / cos_t), weight))."""
    mu = min(max(cos_o, 0.0), 1.0)
    r0, r1, w, _ = lobe_rows(coat, lt, roughness)
    albedo = table_at(mu, lt, lt.albedo, r0, r1, w)
    cos_t = math.sqrt(max(1.0 - (1.0 - mu * mu) / (ior * ior), 0.0))
    depth = 1.0 / max(cos_t, 1e-12)
    return (albedo, 1.0 - weight + weight * tint[0] ** depth,
            1.0 - weight + weight * tint[1] ** depth, 1.0 - weight + weight * tint[2] ** depth)


@njit(**JIT)
def bump_shadowing(bx, by, bz, sx, sy, sz, wx, wy, wz, diffuse, evaluated):
    """Cycles' bump_shadowing_term for a lobe whose normal s a normal map tilted away from
    the mesh's shading normal b, toward light direction w. Zero where w and s lie on
    different sides of the smooth surface b (any lobe when evaluated, a diffuse one when
    sampled too: light must not leak to the back of opaque geometry); for a diffuse lobe,
    else the GGX masking G1 at w's cosine to b for a roughness growing with the tilt,
    alpha^2 = tan^2(b, s) / 8 (Conty Estevez et al., "A Microfacet-Based Shadowing Function
    to Solve the Bump Terminator Problem"; Bump Map Correction, a material's default)."""
    if bx == sx and by == sy and bz == sz:
        return 1.0
    cos_bw = bx * wx + by * wy + bz * wz
    cos_bs = bx * sx + by * sy + bz * sz
    cos_sw = sx * wx + sy * wy + sz * wz
    if cos_bw * cos_bs * cos_sw < 0.0 and (evaluated or diffuse):
        return 0.0
    if not diffuse:
        return 1.0
    cos_i, cos_d = abs(cos_bw), abs(cos_bs)
    if cos_d >= 1.0 or cos_i >= 1.0:
        return 1.0
    if cos_i < 1e-6:
        return 0.0
    alpha2 = min(max(0.125 * (1.0 / (cos_d * cos_d) - 1.0), 0.0), 1.0)
    return 1.0 / (1.0 + ggx_lambda(cos_i, alpha2))


@njit(**INLINE)
def eval_layered(wox, woy, woz, wix, wiy, wiz, sx, sy, sz, mx, my, mz, nx, ny, nz, lobe,
                 sampled, bx, by, bz):
    """The layered lobe's f * cos_i per channel and its lobe-mixture pdf for shading normal
    s (the diffuse base's), specular normal m and geometric normal n (all on wo's side).

    sampled : wi was sampled from the lobe (nothing below the geometric surface, as Cycles'
    sampling routines); otherwise it is a light direction, where the specular lobe still
    needs wi above the geometric surface but the diffuse base only above the shading
    horizon (Cycles' microfacet and diffuse eval; see eval_lambert). b: the mesh's own
    shading normal, which shadows the base where a normal map tilted s (bump_shadowing)."""
    hx, hy, hz = wox + wix, woy + wiy, woz + wiz
    hl = max(math.sqrt(hx * hx + hy * hy + hz * hz), 1e-300)
    hx, hy, hz = hx / hl, hy / hl, hz / hl
    cos_hv = hx * wox + hy * woy + hz * woz
    tinted = lobe.fresnel_on and (lobe.st0 != 1.0 or lobe.st1 != 1.0 or lobe.st2 != 1.0
                                  or lobe.film_d > 0.0)
    spec, pdf_s = eval_lobe_ggx(wox, woy, woz, wix, wiy, wiz, hx, hy, hz, mx, my, mz, lobe,
                                lobe.eta, lobe.fresnel_on and not tinted)
    spec0 = spec1 = spec2 = spec
    if tinted and lobe.film_d > 0.0:
        f0, f1, f2 = filmed_fresnel(cos_hv, lobe.eta, lobe.film_d, lobe.film_n, lobe.st0,
                                    lobe.st1, lobe.st2)
        spec0, spec1, spec2 = spec * f0, spec * f1, spec * f2
    elif tinted:  # the Specular Tint's Fresnel per channel
        f = fresnel_dielectric(cos_hv, lobe.eta, True)[0]
        spec0 = spec * tinted_fresnel(f, lobe.eta, lobe.st0)
        spec1 = spec * tinted_fresnel(f, lobe.eta, lobe.st1)
        spec2 = spec * tinted_fresnel(f, lobe.eta, lobe.st2)
    cos_d = max(sx * wix + sy * wiy + sz * wiz, 0.0)
    if not wix * nx + wiy * ny + wiz * nz > 0.0:
        spec0 = spec1 = spec2 = 0.0
        pdf_s = 0.0
        if sampled:
            cos_d = 0.0
    c = cos_d / np.pi
    if bx != sx or by != sy or bz != sz:  # a normal map tilted s (no call without one)
        c *= bump_shadowing(bx, by, bz, sx, sy, sz, wix, wiy, wiz, True, True)
        if not sampled:
            shadowing = bump_shadowing(bx, by, bz, sx, sy, sz, wix, wiy, wiz, False, True)
            spec0, spec1, spec2 = spec0 * shadowing, spec1 * shadowing, spec2 * shadowing
    c0 = c1 = c2 = c
    if lobe.sigma >= OREN_NAYAR_MIN and c > 0.0:  # the Principled's Diffuse Roughness
        k0, k1, k2 = oren_nayar_ratio(wox, woy, woz, wix, wiy, wiz, sx, sy, sz, lobe.sigma,
                                      lobe.base0, lobe.base1, lobe.base2)
        c0, c1, c2 = c * k0, c * k1, c * k2
    return (lobe.dw0 * c0 + lobe.tint0 * (spec0 * lobe.comp0),
            lobe.dw1 * c1 + lobe.tint1 * (spec1 * lobe.comp1),
            lobe.dw2 * c2 + lobe.tint2 * (spec2 * lobe.comp2),
            lobe.p_spec * pdf_s + (1.0 - lobe.p_spec) * cos_d / np.pi)


@njit(**INLINE)
def sample_layered(wox, woy, woz, sx, sy, sz, mx, my, mz, nx, ny, nz, lobe, u_lobe, ua, ub,
                   bx, by, bz):
    """Sample the layered lobe: pick the specular or the diffuse layer, then evaluate the
    mixture (one-sample MIS over the lobes). Returns (w, weight (3 values), pdf, ok)."""
    if u_lobe < lobe.p_spec:
        hwx, hwy, hwz = sample_lobe_normal(wox, woy, woz, mx, my, mz, lobe, ua, ub)
        wx, wy, wz, _ = reflect(wox, woy, woz, hwx, hwy, hwz)
    else:
        s, t = build_frame(sx, sy, sz)
        lx, ly, lz = cosine_hemisphere(ua, ub)
        wx = lx * s[0] + ly * t[0] + lz * sx
        wy = lx * s[1] + ly * t[1] + lz * sy
        wz = lx * s[2] + ly * t[2] + lz * sz
    g0, g1, g2, pdf = eval_layered(wox, woy, woz, wx, wy, wz, sx, sy, sz, mx, my, mz, nx, ny,
                                   nz, lobe, True, bx, by, bz)
    if pdf > 0:
        return wx, wy, wz, g0 / pdf, g1 / pdf, g2 / pdf, pdf, True
    return wx, wy, wz, 0.0, 0.0, 0.0, pdf, False




# ----------------------------------------------------------------- rough glass
# Cycles' GGX glass (bsdf_microfacet_eval / _sample with a dielectric Fresnel): a visible
# normal h is sampled, then reflection with probability avg(R) / avg(R + T) for
# R = F(h) x reflection tint and T = (1 - F(h)) x transmission tint, else refraction
# through h. Evaluation finds h from the two directions (Walter et al. 2007) and, as in
# Cycles, checks neither the microfacet's side nor the geometric normal; sampling keeps
# reflections above and refractions below both normals. Like smooth glass, radiance is
# not scaled by eta^2 across the interface.


@njit(**JIT)
def eval_rough_dielectric(wox, woy, woz, wix, wiy, wiz, mx, my, mz, lobe):
    """The rough glass lobe's f * |cos_i| per channel and its pdf toward wi, for the
    lobe's normal m on wo's side (Layer: tint reflection, tt transmission, eta relative
    IOR as seen from wo, comp the energy compensation)."""
    cos_o = mx * wox + my * woy + mz * woz
    cos_i = mx * wix + my * wiy + mz * wiz
    if not cos_o > 0.0:
        return 0.0, 0.0, 0.0, 0.0
    eta = lobe.eta
    transmit = cos_i < 0.0
    if transmit:
        hx, hy, hz = -(eta * wix + wox), -(eta * wiy + woy), -(eta * wiz + woz)
    else:
        hx, hy, hz = wox + wix, woy + wiy, woz + wiz
    length = math.sqrt(hx * hx + hy * hy + hz * hz)
    if not length > 1e-12:
        return 0.0, 0.0, 0.0, 0.0
    hx, hy, hz = hx / length, hy / length, hz / length
    cos_ho = hx * wox + hy * woy + hz * woz
    if lobe.film_d > 0.0:
        f0, f1, f2 = filmed_fresnel(cos_ho, eta, lobe.film_d, lobe.film_n, lobe.st0, lobe.st1,
                                    lobe.st2)
    else:
        fr = glass_fresnel(cos_ho, eta, True, lobe.fresnel_on)[0]
        f0, f1, f2 = (tinted_fresnel(fr, eta, lobe.st0), tinted_fresnel(fr, eta, lobe.st1),
                      tinted_fresnel(fr, eta, lobe.st2))
    r0, r1, r2 = f0 * lobe.tint0, f1 * lobe.tint1, f2 * lobe.tint2
    t0, t1, t2 = (1.0 - f0) * lobe.tt0, (1.0 - f1) * lobe.tt1, (1.0 - f2) * lobe.tt2
    total = r0 + r1 + r2 + t0 + t1 + t2
    if not total > 0.0:
        return 0.0, 0.0, 0.0, 0.0
    a2 = lobe.alpha * lobe.alpha
    d = ggx_d(mx * hx + my * hy + mz * hz, a2)
    lo, li = ggx_lambda(cos_o, a2), ggx_lambda(cos_i, a2)
    if transmit:
        common = d / cos_o * (eta / length) ** 2 * abs(cos_ho * (hx * wix + hy * wiy + hz * wiz))
        p_lobe = (t0 + t1 + t2) / total
        s0, s1, s2 = t0, t1, t2
    else:
        common = d / cos_o * 0.25
        p_lobe = (r0 + r1 + r2) / total
        s0, s1, s2 = r0, r1, r2
    g = common / (1.0 + lo + li)
    return (s0 * g * lobe.comp0, s1 * g * lobe.comp1, s2 * g * lobe.comp2,
            common * p_lobe / (1.0 + lo))


@njit(**JIT)
def sample_rough_dielectric(wox, woy, woz, mx, my, mz, nx, ny, nz, lobe, u_lobe, ua, ub):
    """Sample the rough glass lobe about its normal m (geometric normal n, both on wo's
    side). Returns (w, weight (3 values), pdf, ok)."""
    hwx, hwy, hwz = sample_visible_normal(wox, woy, woz, mx, my, mz, lobe.alpha, ua, ub)
    cos_ho = hwx * wox + hwy * woy + hwz * woz
    fr, cos_t = glass_fresnel(cos_ho, lobe.eta, True, lobe.fresnel_on)
    if lobe.film_d > 0.0:
        f0, f1, f2 = filmed_fresnel(cos_ho, lobe.eta, lobe.film_d, lobe.film_n, lobe.st0,
                                    lobe.st1, lobe.st2)
    else:
        f0, f1, f2 = (tinted_fresnel(fr, lobe.eta, lobe.st0),
                      tinted_fresnel(fr, lobe.eta, lobe.st1),
                      tinted_fresnel(fr, lobe.eta, lobe.st2))
    if f0 == fr and f1 == fr and f2 == fr:
        r = fr * (lobe.tint0 + lobe.tint1 + lobe.tint2)
        q = (1.0 - fr) * (lobe.tt0 + lobe.tt1 + lobe.tt2)
    else:
        r = f0 * lobe.tint0 + f1 * lobe.tint1 + f2 * lobe.tint2
        q = (1.0 - f0) * lobe.tt0 + (1.0 - f1) * lobe.tt1 + (1.0 - f2) * lobe.tt2
    if not r + q > 0.0:
        return 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, False
    refract = u_lobe >= r / (r + q)
    if refract:
        eta = lobe.eta
        c = cos_ho / eta - cos_t
        wx, wy, wz = -wox / eta + c * hwx, -woy / eta + c * hwy, -woz / eta + c * hwz
        length = math.sqrt(wx * wx + wy * wy + wz * wz)
        wx, wy, wz = wx / length, wy / length, wz / length
    else:
        wx, wy, wz, _ = reflect(wox, woy, woz, hwx, hwy, hwz)
    below_m = wx * mx + wy * my + wz * mz < 0.0
    below_n = wx * nx + wy * ny + wz * nz < 0.0
    if below_m != refract or below_n != refract:
        return wx, wy, wz, 0.0, 0.0, 0.0, 0.0, False
    g0, g1, g2, pdf = eval_rough_dielectric(wox, woy, woz, wx, wy, wz, mx, my, mz, lobe)
    if pdf > 0:
        return wx, wy, wz, g0 / pdf, g1 / pdf, g2 / pdf, pdf, True
    return wx, wy, wz, 0.0, 0.0, 0.0, pdf, False


# ----------------------------------------------------------------- rough metal
# Cycles' Principled metallic at roughness > 0: GGX reflection (as the Glossy lobe) whose
# Fresnel is the metal's F82-tint (white tint: Schlick with F0 = base colour) at the
# microfacet, per channel.


@njit(**JIT)
def eval_rough_conductor(wox, woy, woz, wix, wiy, wiz, mx, my, mz, nx, ny, nz, lobe):
    """The rough metal lobe's f * cos_i per channel and its pdf toward wi (lobe.tint the
    F0 per channel), above the geometric surface as the layered lobe's specular part."""
    hx, hy, hz = wox + wix, woy + wiy, woz + wiz
    hl = max(math.sqrt(hx * hx + hy * hy + hz * hz), 1e-300)
    hx, hy, hz = hx / hl, hy / hl, hz / hl
    cos_hv = hx * wox + hy * woy + hz * woz
    spec, pdf = eval_lobe_ggx(wox, woy, woz, wix, wiy, wiz, hx, hy, hz, mx, my, mz, lobe, 1.0,
                              False)
    if not wix * nx + wiy * ny + wiz * nz > 0.0:
        return 0.0, 0.0, 0.0, 0.0
    if lobe.film_d > 0.0:
        return (spec * thin_film_f82(cos_hv, lobe.tint0, lobe.b0, lobe.film_n, lobe.film_d, 0)
                * lobe.comp0,
                spec * thin_film_f82(cos_hv, lobe.tint1, lobe.b1, lobe.film_n, lobe.film_d, 1)
                * lobe.comp1,
                spec * thin_film_f82(cos_hv, lobe.tint2, lobe.b2, lobe.film_n, lobe.film_d, 2)
                * lobe.comp2, pdf)
    return (spec * fresnel_f82(cos_hv, lobe.tint0, lobe.b0) * lobe.comp0,
            spec * fresnel_f82(cos_hv, lobe.tint1, lobe.b1) * lobe.comp1,
            spec * fresnel_f82(cos_hv, lobe.tint2, lobe.b2) * lobe.comp2, pdf)


@njit(**JIT)
def sample_rough_conductor(wox, woy, woz, mx, my, mz, nx, ny, nz, lobe, ua, ub):
    """Sample the rough metal lobe about m: a visible normal, the mirror direction.
    Returns (w, weight (3 values), pdf, ok)."""
    hwx, hwy, hwz = sample_lobe_normal(wox, woy, woz, mx, my, mz, lobe, ua, ub)
    wx, wy, wz, _ = reflect(wox, woy, woz, hwx, hwy, hwz)
    g0, g1, g2, pdf = eval_rough_conductor(wox, woy, woz, wx, wy, wz, mx, my, mz, nx, ny, nz,
                                           lobe)
    if pdf > 0 and max(g0, max(g1, g2)) > 0:
        return wx, wy, wz, g0 / pdf, g1 / pdf, g2 / pdf, pdf, True
    return wx, wy, wz, 0.0, 0.0, 0.0, pdf, False


# ----------------------------------------------------------------- microfiber sheen
# Cycles' sheen (the Principled BSDF's Sheen layer and the Sheen BSDF's Microfiber): the
# linearly transformed cosine of Zeltner, Burley and Chiang (2022) about the normal, in
# the frame whose x axis is the view's tangent direction. Its transform (A, B) and albedo
# come from their fitted table over view cosine and roughness (sheen_table.py).
SHEEN_TABLE_SIZE = 32


def sheen_table() -> np.ndarray:
    """(3, 32, 32) float64: A, B and the albedo, each over roughness (rows) and view cosine
    (columns), both 0..1."""
    return np.array([_SHEEN_A, _SHEEN_B, _SHEEN_ALBEDO], np.float64).reshape(
        3, SHEEN_TABLE_SIZE, SHEEN_TABLE_SIZE)


@njit(**JIT)
def _table_read(table, plane, x, y):
    """Cycles' lookup_table_read_2D: bilinear in plane `plane` at x (columns) and y
    (rows), each clamped to [0, 1]."""
    n = table.shape[2]
    fy = min(max(y, 0.0), 1.0) * (n - 1)
    iy = min(int(fy), n - 1)
    ty = fy - iy
    fx = min(max(x, 0.0), 1.0) * (n - 1)
    ix = min(int(fx), n - 1)
    tx = fx - ix
    jx, jy = min(ix + 1, n - 1), min(iy + 1, n - 1)
    r0 = (1.0 - tx) * table[plane, iy, ix] + tx * table[plane, iy, jx]
    r1 = (1.0 - tx) * table[plane, jy, ix] + tx * table[plane, jy, jx]
    return (1.0 - ty) * r0 + ty * r1


@njit(**JIT)
def sheen_ltc(table, cos_o, roughness):
    """(A, B, albedo) of the sheen of `roughness` (clamped to [1e-3, 1], as Cycles) seen at
    cosine cos_o; albedo 0 where the fit has no valid transform (Cycles drops the lobe)."""
    r = min(max(roughness, 1e-3), 1.0)
    a = _table_read(table, 0, cos_o, r)
    b = _table_read(table, 1, cos_o, r)
    albedo = _table_read(table, 2, cos_o, r)
    if abs(a) < 1e-5 or albedo < 1e-5:
        return a, b, 0.0
    return a, b, albedo


@njit(**JIT)
def _sheen_frame(nx, ny, nz, wox, woy, woz):
    """The sheen's tangent frame: t the view's direction along the surface, s = n x t
    (Cycles' make_orthonormals_safe_tangent; any frame where the view is along n)."""
    bx, by, bz = ny * woz - nz * woy, nz * wox - nx * woz, nx * woy - ny * wox
    length = math.sqrt(bx * bx + by * by + bz * bz)
    if length < 0.995 * 1e-3:  # the view along n: any frame will do
        s, t = build_frame(nx, ny, nz)
        return s[0], s[1], s[2], t[0], t[1], t[2]
    bx, by, bz = bx / length, by / length, bz / length
    return by * nz - bz * ny, bz * nx - bx * nz, bx * ny - by * nx, bx, by, bz


@njit(**JIT)
def eval_sheen(wox, woy, woz, wix, wiy, wiz, nx, ny, nz, a, b):
    """The sheen lobe's value (f cos_i, per unit albedo) toward wi, which is also its pdf:
    the cosine distribution under the transform (A, B)."""
    tx, ty, tz, ux, uy, uz = _sheen_frame(nx, ny, nz, wox, woy, woz)
    x = wix * tx + wiy * ty + wiz * tz
    y = wix * ux + wiy * uy + wiz * uz
    z = wix * nx + wiy * ny + wiz * nz
    if z <= 0.0:
        return 0.0
    q = (a * x + b * z) ** 2 + (a * y) ** 2 + z * z
    return z * (a / q) ** 2 / np.pi


@njit(**JIT)
def sample_sheen(wox, woy, woz, nx, ny, nz, gx, gy, gz, a, b, ua, ub):
    """A direction from the sheen lobe: (w, pdf, ok); the sample's weight is the albedo
    (its value equals its pdf). Below the geometric surface g it is dropped, as Cycles."""
    tx, ty, tz, ux, uy, uz = _sheen_frame(nx, ny, nz, wox, woy, woz)
    dx, dy = concentric_disk(ua, ub)
    dz = math.sqrt(max(1.0 - dx * dx - dy * dy, 0.0))
    lx, ly, lz = dx - dz * b, dy, dz * a
    length = math.sqrt(lx * lx + ly * ly + lz * lz)
    lx, ly, lz = lx / length, ly / length, lz / length
    wx = lx * tx + ly * ux + lz * nx
    wy = lx * ty + ly * uy + lz * ny
    wz = lx * tz + ly * uz + lz * nz
    if wx * gx + wy * gy + wz * gz <= 0.0 or lz <= 0.0:
        return wx, wy, wz, 0.0, False
    q = (a * lx + b * lz) ** 2 + (a * ly) ** 2 + lz * lz
    return wx, wy, wz, lz * (a / q) ** 2 / np.pi, True

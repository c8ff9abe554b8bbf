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

import math

import numpy as np

from . import sampling
from .jit import njit

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


def eval_diffuse(wi, n, colour):
    """Lambert f * cos for light directions wi (n, 3) and its sampling pdf.

    Only the shading normal counts, as in Cycles' bsdf_diffuse_eval: a light below the
    geometric surface but above the shading horizon (a smooth mesh's terminator) is left
    to the shadow ray, which the shadow terminator offset (terminator.py) may let through;
    sampling (`sample_diffuse`) still never goes below the geometric surface."""
    cos = dot(wi, n)
    cos = np.where(cos > 0.0, cos, 0.0)  # as the kernel's `cos > 0` (a NaN normal gives 0)
    return colour * (cos / np.pi)[:, None], cos / np.pi


# ----------------------------------------------------------------- specular normals
@njit(cache=True, nogil=True, error_model="numpy")
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


@njit(cache=True, nogil=True, error_model="numpy")
def valid_specular_normals(ng, wo, n):
    """`valid_specular_normal` for (m, 3) arrays (the numpy stages)."""
    out = np.empty_like(n)
    for k in range(len(n)):
        out[k, 0], out[k, 1], out[k, 2] = valid_specular_normal(
            ng[k, 0], ng[k, 1], ng[k, 2], wo[k, 0], wo[k, 1], wo[k, 2], n[k, 0], n[k, 1],
            n[k, 2])
    return out


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
# 1 - albedo_spec(mu_o) (Cycles' closure_layering_weight).

ALBEDO_TABLE_SIZE = 64
# numpy 2 renamed trapz (Blender 4.2+ may ship numpy 2).
trapezoid = getattr(np, "trapezoid", None) or np.trapz
MIN_ALPHA = 1e-4


def ggx_d(cos_h: np.ndarray, a2: np.ndarray) -> np.ndarray:
    c2 = np.minimum(cos_h * cos_h, 1.0)
    return a2 / (np.pi * (1.0 - c2 + a2 * c2) ** 2)


def ggx_lambda(cos_n: np.ndarray, a2: np.ndarray) -> np.ndarray:
    c2 = np.maximum(cos_n * cos_n, 1e-300)
    return 0.5 * (np.sqrt(1.0 + a2 * np.maximum(1.0 / c2 - 1.0, 0.0)) - 1.0)


def sample_ggx_vndf(v_local: np.ndarray, alpha: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Visible-normal sample (Heitz 2018) for view directions v_local (n, 3), z up."""
    vh = np.column_stack([alpha * v_local[:, 0], alpha * v_local[:, 1], v_local[:, 2]])
    vh /= np.linalg.norm(vh, axis=1, keepdims=True)
    lensq = vh[:, 0] ** 2 + vh[:, 1] ** 2
    inv = 1.0 / np.sqrt(np.where(lensq > 0, lensq, 1.0))
    t1 = np.where((lensq > 0)[:, None], np.column_stack([-vh[:, 1] * inv, vh[:, 0] * inv,
                                                         np.zeros(len(vh))]),
                  np.array([1.0, 0.0, 0.0]))
    t2 = np.cross(vh, t1)
    r = np.sqrt(u[:, 0])
    phi = 2.0 * np.pi * u[:, 1]
    p1 = r * np.cos(phi)
    p2 = r * np.sin(phi)
    s = 0.5 * (1.0 + vh[:, 2])
    p2 = (1.0 - s) * np.sqrt(np.maximum(0.0, 1.0 - p1 * p1)) + s * p2
    p3 = np.sqrt(np.maximum(0.0, 1.0 - p1 * p1 - p2 * p2))
    nh = p1[:, None] * t1 + p2[:, None] * t2 + p3[:, None] * vh
    h = np.column_stack([alpha * nh[:, 0], alpha * nh[:, 1], np.maximum(nh[:, 2], 1e-12)])
    return h / np.linalg.norm(h, axis=1, keepdims=True)


def _fresnel_for(kind_fresnel: str, cos_hv: np.ndarray, eta: float) -> np.ndarray:
    if kind_fresnel == "none":
        return np.ones_like(cos_hv)
    return fresnel_dielectric(cos_hv, np.full_like(cos_hv, eta))[0]


class MicrofacetTables:
    """Per-material tables over mu_o = cos(theta_o) for one GGX lobe (alpha, Fresnel).

    compensation(mu) : Kulla-Conty factor 1 + Fms (1 - E) / E.
    albedo(mu) : directional albedo of the compensated lobe with its Fresnel (what the
        Principled base loses to the specular layer).
    Integrals use a fixed stratified set of visible-normal samples, so the tables are
    deterministic.
    """

    def __init__(self, alpha: float, fresnel: str = "dielectric", eta: float = 1.5):
        self.alpha = max(float(alpha), MIN_ALPHA)
        n_mu, n_s = ALBEDO_TABLE_SIZE, 1024
        self.mu = np.linspace(1e-3, 1.0, n_mu)
        k = int(np.sqrt(n_s))
        g = (np.arange(k) + 0.5) / k
        u = np.stack(np.meshgrid(g, g, indexing="ij"), -1).reshape(-1, 2)
        a2 = self.alpha**2
        e_white = np.zeros(n_mu)
        e_fresnel = np.zeros(n_mu)
        for i, mu in enumerate(self.mu):
            v = np.tile([np.sqrt(max(0.0, 1 - mu * mu)), 0.0, mu], (len(u), 1))
            h = sample_ggx_vndf(v, np.full(len(u), self.alpha), u)
            cos_hv = np.maximum(h @ v[0], 0.0)
            wi = 2.0 * cos_hv[:, None] * h - v
            cos_i = wi[:, 2]
            ok = cos_i > 0
            g1v = 1.0 / (1.0 + ggx_lambda(np.full(len(u), mu), a2))
            g2 = 1.0 / (1.0 + ggx_lambda(np.full(len(u), mu), a2) + ggx_lambda(cos_i, a2))
            w = np.where(ok, g2 / g1v, 0.0)  # f cos / pdf for VNDF sampling, F = 1
            e_white[i] = w.mean()
            e_fresnel[i] = (w * _fresnel_for(fresnel, cos_hv, eta)).mean()
        e_white = np.clip(e_white, 1e-6, 1.0)
        self.e_avg = float(2.0 * trapezoid(e_white * self.mu, self.mu))
        if fresnel == "none":
            fss = 1.0
        else:
            m = np.linspace(0.0, 1.0, 2049)
            fss = 2.0 * trapezoid(fresnel_dielectric(m, np.full_like(m, eta))[0] * m, m)
        # The energy the single-scatter lobe misses, (1 - E) / E, per mu_o.
        self.missing_table = (1.0 - e_white) / e_white
        self.fms = float(self.multiscatter_fresnel(fss))
        self.compensation_table = 1.0 + self.fms * self.missing_table
        self.albedo_table = np.clip(e_fresnel * self.compensation_table, 0.0, 1.0)
        self.fresnel, self.eta = fresnel, float(eta)

    def multiscatter_fresnel(self, fss):
        """Fms for a single-scatter Fresnel average Fss (scalar or per channel)."""
        fss = np.asarray(fss, np.float64)
        return fss * self.e_avg / (1.0 - fss * (1.0 - self.e_avg))

    def compensation(self, mu, fms=None):
        """1 + Fms (1 - E(mu)) / E(mu): (n,) for the table's own Fresnel, or (n, 3) for
        per-channel fms (3,) (the Glossy colour's, `multiscatter_fresnel(colour)`)."""
        if fms is None:
            return np.interp(mu, self.mu, self.compensation_table)
        missing = np.interp(mu, self.mu, self.missing_table)
        return 1.0 + np.asarray(fms)[None, :] * missing[:, None]

    def albedo(self, mu):
        return np.interp(mu, self.mu, self.albedo_table)


def layer_fms(tables: MicrofacetTables, principled: bool, colour) -> np.ndarray:
    """(3,) Fms of a rough material's specular lobe: the Principled layer's dielectric
    Fresnel on every channel, or the Glossy colour as its constant Fresnel (Cycles clamps
    it at 0)."""
    if principled:
        return np.full(3, tables.fms)
    return tables.multiscatter_fresnel(np.maximum(np.asarray(colour, np.float64), 0.0))


def eval_ggx(wo, wi, n, alpha, eta, fresnel):
    """Single-scatter GGX reflection f * cos_i (n,) and its VNDF sampling pdf (n,)."""
    cos_o = dot(n, wo)
    cos_i = dot(n, wi)
    h = wo + wi
    h /= np.maximum(np.linalg.norm(h, axis=1, keepdims=True), 1e-300)
    a2 = alpha * alpha
    d = ggx_d(dot(n, h), a2)
    lo, li = ggx_lambda(cos_o, a2), ggx_lambda(cos_i, a2)
    ok = (cos_o > 0) & (cos_i > 0)
    safe_o = np.where(ok, cos_o, 1.0)
    if fresnel == "none":
        f = np.ones(len(wo))
    else:
        f = fresnel_dielectric(dot(h, wo), eta)[0]
    common = d / (4.0 * safe_o)
    value = np.where(ok, f * common / (1.0 + lo + li), 0.0)
    pdf = np.where(ok, common / (1.0 + lo), 0.0)
    return value, pdf


def sample_ggx_reflection(wo, n, alpha, u):
    """Directions wi (n, 3) from the visible normals of GGX about n."""
    s, t = sampling.build_frame(n)
    v = np.column_stack([dot(wo, s), dot(wo, t), dot(wo, n)])
    h_local = sample_ggx_vndf(v, alpha, u)
    h = h_local[:, :1] * s + h_local[:, 1:2] * t + h_local[:, 2:3] * n
    return reflect(wo, h)


def eval_layered(wo, wi, n, ng, base, alpha, eta, spec_tint, fresnel, comp, albedo,
                 sampled=False, n_spec=None):
    """Principled (diffuse base + GGX dielectric specular) or rough Glossy (specular only,
    base = 0): f * cos_i (n, 3) and the lobe-mixture pdf (n,), plus the probability of
    choosing the specular lobe (n,).

    base : (n, 3) diffuse colour (zero for Glossy); spec_tint : (n, 3) specular weight;
    comp : (n, 3) the energy compensation per channel at mu_o; albedo : (n,) the
    specular albedo at mu_o.
    sampled : wi was sampled from the lobe (nothing below the geometric surface, as
    Cycles' sampling routines); otherwise it is a light direction, where the specular lobe
    still needs wi above the geometric surface but the diffuse base only above the shading
    horizon (Cycles' microfacet and diffuse eval; see eval_diffuse).
    n_spec : the specular lobe's normal (`valid_specular_normals`; default n), n the
    diffuse base's.
    """
    diffuse_w = base * (1.0 - albedo)[:, None]
    p_spec = _specular_probability(diffuse_w, spec_tint, albedo)
    spec, pdf_s = eval_ggx(wo, wi, n if n_spec is None else n_spec, alpha, eta, fresnel)
    geometric_ok = (dot(wi, ng) > 0.0)
    cos_i = np.maximum(dot(wi, n), 0.0)
    if sampled:
        cos_i = np.where(geometric_ok, cos_i, 0.0)
    spec = np.where(geometric_ok, spec, 0.0)
    f_cos = diffuse_w * (cos_i / np.pi)[:, None] + spec_tint * (spec[:, None] * comp)
    pdf = p_spec * np.where(geometric_ok, pdf_s, 0.0) + (1.0 - p_spec) * cos_i / np.pi
    return f_cos, pdf, p_spec


def _specular_probability(diffuse_w, spec_tint, albedo):
    s = spec_tint.mean(axis=1) * albedo
    d = diffuse_w.mean(axis=1)
    return np.where(s + d > 0, s / np.maximum(s + d, 1e-300), 1.0)


def sample_layered(wo, n, ng, base, alpha, eta, spec_tint, fresnel, comp, albedo, u_lobe, u,
                   n_spec=None):
    """Sample the layered lobe: pick specular or diffuse, then evaluate both (one-sample
    MIS over the lobes). Returns (wi, weight, pdf)."""
    diffuse_w = base * (1.0 - albedo)[:, None]
    p_spec = _specular_probability(diffuse_w, spec_tint, albedo)
    choose_spec = u_lobe < p_spec
    wi_spec = sample_ggx_reflection(wo, n if n_spec is None else n_spec, alpha, u)
    local = sampling.sample_cosine_hemisphere(u)
    s, t = sampling.build_frame(n)
    wi_diff = local[:, :1] * s + local[:, 1:2] * t + local[:, 2:3] * n
    wi = np.where(choose_spec[:, None], wi_spec, wi_diff)
    f_cos, pdf, _ = eval_layered(wo, wi, n, ng, base, alpha, eta, spec_tint, fresnel, comp,
                                 albedo, sampled=True, n_spec=n_spec)
    ok = pdf > 0
    weight = np.where(ok[:, None], f_cos / np.where(ok, pdf, 1.0)[:, None], 0.0)
    return wi, weight, np.where(ok, pdf, 0.0)

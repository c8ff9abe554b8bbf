"""The Sky Texture's skies of Multiple Scattering (Blender 5's default) and Single
Scattering (Blender 2.90-4.5's Nishita), as Cycles renders them.

The model (Blender's intern/sky, after García Liñán's spectral sky): Earth's atmosphere of
molecules (Rayleigh phase), aerosols (Henyey-Greenstein, g = 0.8) and ozone, their
densities scaled by the node's Air, Aerosol and Ozone, seen from its Altitude. Light is
carried at four wavelengths (630, 560, 490, 430 nm) and turned into CIE XYZ by a fitted
matrix; the kernel turns XYZ into the scene's linear RGB and clamps negative channels.

Cycles precomputes one texture per node, 512 x 256, of the sky without the sun, in XYZ:
each texel's ray is marched in 64 steps through the atmosphere (to its top, or to the
ground), in-scattering sunlight attenuated by a 256 x 64 table of transmittance to the sun
(over the cosine of the sun's zenith angle and the altitude), plus light scattered more
than once (an analytical fit, and the ground's reflection of the sun as a diffuse 0.3),
each step integrated in closed form (Hillaire 2020, "energy-conserving"). Its columns are
the azimuth from the sun's, mirrored about it; its rows spread the elevation
non-linearly, e = sign(l) l^2 pi / 2 for l in [-1, 1], to give the horizon more of them.
The kernel reads it bilinearly, extended at its edges, and adds the sun's disc: between
the radiance of its lowest and its highest point (the transmittance to the sun from there
times the sun's spectral irradiance over the disc's solid angle) by elevation, times the
Sun Intensity and the limb darkening 1 - 0.6 (1 - sqrt(1 - (angle / radius)^2)), wherever
the disc is above the horizon seen from that altitude.

Single Scattering (below) fills the same texture from Nishita's model at 21 wavelengths
(below the horizon, the horizon's colour fading out), and its sun the same way; the kernel
reads both alike.

The precomputation here is numpy's float64 where Cycles' is float32; the lookups
(`texture_coordinates`, `sun_disc`) are compiled into the shading programs.
"""

from __future__ import annotations

import math

import numpy as np

from .jit import JIT, njit

EARTH_RADIUS = 6371.0  # km
ATMOSPHERE_THICKNESS = 100.0  # km
ATMOSPHERE_RADIUS = EARTH_RADIUS + ATMOSPHERE_THICKNESS
MARCH_STEPS = 64  # both the transmittance's and the in-scattering's
TABLE_WIDTH, TABLE_HEIGHT = 256, 64  # transmittance: cos(sun zenith) x altitude
TEXTURE_WIDTH, TEXTURE_HEIGHT = 512, 256
GROUND_ALBEDO = 0.3
AEROSOL_G = 0.8
# Per wavelength (630, 560, 490, 430 nm): the sun's spectral irradiance (urban), the
# molecules' scattering coefficient at sea level (1/km), ozone's absorption cross-section,
# the aerosols' absorption and scattering cross-sections.
SUN_IRRADIANCE = np.array([1.679, 1.828, 1.986, 1.307])
MOLECULAR_SCATTERING = np.array([6.605e-3, 1.067e-2, 1.842e-2, 3.156e-2])
OZONE_ABSORPTION = np.array([3.472e-25, 3.914e-25, 1.349e-25, 11.03e-27])
OZONE_MEAN_DOBSON = 334.5
AEROSOL_ABSORPTION = np.array([2.8722e-24, 4.6168e-24, 7.9706e-24, 1.3578e-23])
AEROSOL_SCATTERING = np.array([1.5908e-22, 1.7711e-22, 2.0942e-22, 2.4033e-22])
AEROSOL_BASE_DENSITY = 1.3681e20
AEROSOL_BACKGROUND_DENSITY = 2e6
AEROSOL_HEIGHT_SCALE = 0.73  # km
# The higher orders' fit, per wavelength.
MULTIPLE_SCATTERING_FIT = np.array([0.217, 0.347, 0.594, 1.0])
# The four wavelengths' radiance to CIE XYZ (rows: wavelengths).
SPECTRAL_TO_XYZ = np.array([
    [53.386917738564668023, 22.981337506691024754, 0.0],
    [43.904844466369358263, 71.347795700053393866, 0.102506867965741307],
    [1.6137278251608962005, 18.422960591455485011, 31.742921188390805758],
    [20.762668673810577145, 2.3614213523314368527, 110.48009643252140334]])
# The Sky Texture's types this module renders.
MODELS = ("SINGLE_SCATTERING", "MULTIPLE_SCATTERING")
# Cycles clamps the sun's diameter from below, "for numerical precision" (get_sun_size).
MIN_SUN_SIZE = 0.0005
# Sun disc parameters in a program (params of shading.OP_SKY): elevation, rotation (both
# as `sun_position` gives them), angular diameter (< 0: no disc), intensity, the horizon's
# elevation (`horizon_elevation`), the XYZ of the disc's lowest and highest points.
DISC_PARAMS = 11


# ----------------------------------------------------------------- the atmosphere
def _coefficients(h, densities):
    """(extinction, molecular scattering, aerosol scattering), each (..., 4) per km, at
    altitudes h (...) in km."""
    air, aerosol, ozone = densities
    h = np.asarray(h, np.float64)[..., None]
    aerosols = aerosol * AEROSOL_BASE_DENSITY * (
        np.exp(-h / AEROSOL_HEIGHT_SCALE) + AEROSOL_BACKGROUND_DENSITY / AEROSOL_BASE_DENSITY)
    molecular = air * MOLECULAR_SCATTERING * np.exp(-0.07771971 * h ** 1.16364243)
    log_h = np.log(np.maximum(h, 1e-4))
    ozone_density = 3.78547397e20 * np.exp(-(log_h - 3.22261) ** 2 * 5.55555555 - log_h)
    ozone_absorption = ozone * OZONE_ABSORPTION * OZONE_MEAN_DOBSON * ozone_density
    aerosol_scattering = AEROSOL_SCATTERING * aerosols
    extinction = AEROSOL_ABSORPTION * aerosols + aerosol_scattering + ozone_absorption \
        + molecular
    return extinction, molecular, aerosol_scattering


def _ray_sphere(origin, direction, radius):
    """Distance along unit directions (..., 3) from origins (..., 3) to the sphere of
    `radius` about the Earth's centre: its far side from inside or on it, its near side
    from outside, -1 where it is missed or behind."""
    b = np.sum(origin * direction, axis=-1)
    c = np.sum(origin * origin, axis=-1) - radius * radius
    d = b * b - c
    root = np.sqrt(np.maximum(d, 0.0))
    t = np.where(d >= b * b, -b + root, -b - root)
    return np.where(((c > 0.0) & (b > 0.0)) | (d < 0.0), -1.0, t)


def _sun_direction(cos_zenith):
    """The sun's direction (..., 3) in the texture's frame (azimuth pi) from the cosine of
    its zenith angle."""
    c = np.asarray(cos_zenith, np.float64)
    return np.stack([-np.sqrt(np.maximum(1.0 - c * c, 0.0)), np.zeros_like(c), c], axis=-1)


def transmittance(cos_zenith, normalised_altitude, densities):
    """(..., 4) the atmosphere's transmittance from an altitude (a fraction of its
    thickness) toward a sun at that zenith cosine, marched to the atmosphere's top."""
    cos_zenith, normalised_altitude = np.broadcast_arrays(
        np.asarray(cos_zenith, np.float64), np.asarray(normalised_altitude, np.float64))
    sun = _sun_direction(cos_zenith)
    origin = np.zeros(sun.shape)
    origin[..., 2] = EARTH_RADIUS + (ATMOSPHERE_RADIUS - EARTH_RADIUS) * normalised_altitude
    step = _ray_sphere(origin, sun, ATMOSPHERE_RADIUS) / MARCH_STEPS
    depth = np.zeros(cos_zenith.shape + (4,))
    for k in range(MARCH_STEPS):
        x = origin + sun * ((k + 0.5) * step)[..., None]
        h = np.maximum(np.linalg.norm(x, axis=-1) - EARTH_RADIUS, 0.0)
        depth += _coefficients(h, densities)[0] * step[..., None]
    return np.exp(-depth)


class Atmosphere:
    """An atmosphere of the node's densities (Air, Aerosol, Ozone), with its
    transmittance table."""

    def __init__(self, air: float, aerosol: float, ozone: float):
        self.densities = (float(air), float(aerosol), float(ozone))
        u = np.arange(TABLE_WIDTH) / (TABLE_WIDTH - 1.0)
        v = np.arange(TABLE_HEIGHT) / (TABLE_HEIGHT - 1.0)
        self.table = transmittance(u[None, :] * 2.0 - 1.0, v[:, None], self.densities)

    def lookup(self, cos_zenith, normalised_altitude):
        """(..., 4) the table's transmittance, bilinear, with Cycles' truncation."""
        x = (TABLE_WIDTH - 1.0) * np.clip(np.asarray(cos_zenith) * 0.5 + 0.5, 0.0, 1.0)
        y = (TABLE_HEIGHT - 1.0) * np.clip(np.asarray(normalised_altitude), 0.0, 1.0)
        x1, y1 = x.astype(np.int64), y.astype(np.int64)
        x2, y2 = np.minimum(x1 + 1, TABLE_WIDTH - 1), np.minimum(y1 + 1, TABLE_HEIGHT - 1)
        fx, fy = (x - x1)[..., None], (y - y1)[..., None]
        t = self.table
        bottom = t[y1, x1] + (t[y1, x2] - t[y1, x1]) * fx
        top = t[y2, x1] + (t[y2, x2] - t[y2, x1]) * fx
        return bottom + (top - bottom) * fy

    def multiple_scattering(self, cos_zenith, normalised_altitude, distance):
        """(..., 4) light scattered more than once toward a point at `distance` km from
        the Earth's centre: the fit of the atmosphere's, and the ground's reflection of
        the sun, seen over the solid angle the Earth covers from there."""
        omega = 2.0 * math.pi * (1.0 - np.sqrt(np.maximum(
            1.0 - (EARTH_RADIUS / distance) ** 2, 0.0)))
        to_ground = self.lookup(cos_zenith, 0.0)
        ground_to_point = self.lookup(1.0, 0.0) / self.lookup(1.0, normalised_altitude)
        ground = (1.0 / (4.0 * math.pi)) * omega[..., None] * (GROUND_ALBEDO / math.pi) \
            * to_ground * ground_to_point * np.asarray(cos_zenith)[..., None]
        fit = 0.02 * MULTIPLE_SCATTERING_FIT / (1.0 + 5.0 * np.exp(
            -17.92 * np.asarray(cos_zenith)))[..., None]
        return fit + ground

    def inscattering(self, sun, origin, directions, length):
        """(N, 4) radiance scattered toward `origin` (3,) along unit `directions` (N, 3)
        over `length` (N,) km, from a sun in direction `sun` (3,)."""
        cos = -(directions @ sun)
        molecular_phase = 3.0 / (16.0 * math.pi) * (1.0 + cos * cos)
        g = AEROSOL_G
        den = 1.0 + g * g + 2.0 * g * cos
        aerosol_phase = (1.0 - g * g) / (4.0 * math.pi * den * np.sqrt(den))
        dt = length / MARCH_STEPS
        radiance = np.zeros((len(cos), 4))
        through = np.ones((len(cos), 4))
        for k in range(MARCH_STEPS):
            x = origin + directions * ((k + 0.5) * dt)[:, None]
            distance = np.linalg.norm(x, axis=-1)
            h = np.maximum(distance - EARTH_RADIUS, 0.0)
            altitude = h / ATMOSPHERE_THICKNESS
            sun_cos = (x @ sun) / distance
            extinction, molecular, aerosol = _coefficients(h, self.densities)
            to_sun = self.lookup(sun_cos, altitude)
            ms = self.multiple_scattering(sun_cos, altitude, distance)
            source = SUN_IRRADIANCE * (molecular * (molecular_phase[:, None] * to_sun + ms)
                                       + aerosol * (aerosol_phase[:, None] * to_sun + ms))
            step = np.exp(-dt[:, None] * extinction)
            radiance += through * (source - source * step) / np.maximum(extinction, 1e-7)
            through *= step
        return radiance


def _altitude_km(altitude):
    """The node's Altitude (m) as the model takes it, in km: clamped to 1 .. 99999 m."""
    return min(max(float(altitude), 1.0), 99999.0) / 1000.0


# ----------------------------------------------------------------- the node's data
def sun_position(elevation: float, rotation: float):
    """(elevation, rotation) as Cycles' kernel reads them (SkyTextureNode's
    simplify_settings): the elevation wrapped into [-pi/2, pi/2] (past the zenith, the
    sun turns to the opposite azimuth), the rotation into [0, 2 pi) and reversed."""
    e = math.fmod(float(elevation), 2.0 * math.pi)
    r = float(rotation)
    if abs(e) >= math.pi:
        e -= math.copysign(2.0 * math.pi, e)
    if e >= math.pi / 2 or e <= -math.pi / 2:
        e = math.copysign(math.pi, e) - e
        r += math.pi
    r = math.fmod(r, 2.0 * math.pi)
    if r < 0.0:
        r += 2.0 * math.pi
    return e, 2.0 * math.pi - r


def horizon_elevation(altitude: float) -> float:
    """The elevation (radians, <= 0) of the Earth's horizon seen from `altitude` m (the
    node's, unclamped): the sun's disc is drawn above it only."""
    return -(math.pi / 2 - math.asin(EARTH_RADIUS / (EARTH_RADIUS + altitude / 1000.0)))


def texture(model: str, elevation: float, altitude: float, air: float, aerosol: float,
            ozone: float) -> np.ndarray:
    """(TEXTURE_HEIGHT, TEXTURE_WIDTH, 3) the sky of `model` (MODELS) without its sun, CIE
    XYZ, row 0 at the bottom, for a sun at `elevation` (as `sun_position` gives it) seen
    from `altitude` m through the given densities."""
    if model == "SINGLE_SCATTERING":
        return _single_scattering_texture(elevation, altitude, (air, aerosol, ozone))
    atmosphere = Atmosphere(air, aerosol, ozone)
    sun = _sun_direction(math.cos(math.pi / 2 - elevation))
    half = TEXTURE_WIDTH // 2
    azimuth = 2.0 * math.pi * (np.arange(half) + 0.5) / TEXTURE_WIDTH
    spread = 2.0 * (np.arange(TEXTURE_HEIGHT) + 0.5) / TEXTURE_HEIGHT - 1.0
    e = np.copysign(spread * spread, spread) * (math.pi / 2)
    e, azimuth = np.meshgrid(e, azimuth, indexing="ij")
    directions = np.stack([np.cos(e) * np.cos(azimuth), np.cos(e) * np.sin(azimuth),
                           np.sin(e)], axis=-1).reshape(-1, 3)
    origin = np.array([0.0, 0.0, EARTH_RADIUS + _altitude_km(altitude)])
    origins = np.broadcast_to(origin, directions.shape)
    ground = _ray_sphere(origins, directions, EARTH_RADIUS)
    length = np.where(ground < 0.0, _ray_sphere(origins, directions, ATMOSPHERE_RADIUS), ground)
    xyz = (atmosphere.inscattering(sun, origin, directions, length) @ SPECTRAL_TO_XYZ)
    xyz = xyz.reshape(TEXTURE_HEIGHT, half, 3)
    return np.concatenate([xyz, xyz[:, ::-1]], axis=1)


def sun_pixels(model: str, elevation: float, angular_diameter: float, altitude: float,
               air: float, aerosol: float, ozone: float):
    """((3,), (3,)) the XYZ radiance of the sun disc's lowest and highest points: the
    transmittance toward each (marched, not the table's) times the sun's irradiance over
    the disc's solid angle."""
    densities = (float(air), float(aerosol), float(ozone))
    if model == "SINGLE_SCATTERING":
        return _single_scattering_sun(elevation, angular_diameter, altitude, densities)
    half = angular_diameter / 2.0
    solid_angle = 2.0 * math.pi * (1.0 - math.cos(half))
    h = _altitude_km(altitude) / ATMOSPHERE_THICKNESS
    return tuple(SUN_IRRADIANCE * transmittance(math.cos(math.pi / 2 - e), h, densities)
                 / solid_angle @ SPECTRAL_TO_XYZ for e in (elevation - half, elevation + half))


# ----------------------------------------------------------------- Single Scattering
# Blender 2.90's sky (Nishita's model as intern/sky has it, Blender 5's Single Scattering):
# 21 wavelengths, 380-780 nm, in metres; a 32-step march of single scattering along the
# view, the sun's optical depth by 8-point Gauss-Laguerre quadrature; below the horizon
# the horizon's colour fading out.
SS_EARTH_RADIUS, SS_ATMOSPHERE_RADIUS = 6360e3, 6420e3
SS_RAYLEIGH_SCALE, SS_MIE_SCALE = 8e3, 1.2e3
SS_MIE_COEFFICIENT, SS_MIE_G = 2e-5, 0.76
SS_STEPS = 32
SS_STEP_LAMBDA = 20.0  # nm between the wavelengths
SS_IRRADIANCE = np.array([
    1.45756829855592995315, 1.56596305559738380175, 1.65148449067670455293,
    1.71496242737209314555, 1.75797983805020541226, 1.78256407885924539336,
    1.79095108475838560302, 1.78541550133410664714, 1.76815554864306845317,
    1.74122069647250410362, 1.70647127164943679389, 1.66556087452739887134,
    1.61993437242451854274, 1.57083597368892080581, 1.51932335059305478886,
    1.46628494965214395407, 1.41245852740172450623, 1.35844961970384092709,
    1.30474913844739281998, 1.25174963272610817455, 1.19975998755420620867])
SS_RAYLEIGH = np.array([
    0.00005424820087636473, 0.00004418549866505454, 0.00003635151910165377,
    0.00003017929012024763, 0.00002526320226989157, 0.00002130859310621843,
    0.00001809838025320633, 0.00001547057129129042, 0.00001330284977336850,
    0.00001150184784075764, 0.00000999557429990163, 0.00000872799973630707,
    0.00000765513700977967, 0.00000674217203751443, 0.00000596134125832052,
    0.00000529034598065810, 0.00000471115687557433, 0.00000420910481110487,
    0.00000377218381260133, 0.00000339051255477280, 0.00000305591531679811])
SS_OZONE = np.array([
    0.00000000325126849861, 0.00000000585395365047, 0.00000001977191155085,
    0.00000007309568762914, 0.00000020084561514287, 0.00000040383958096161,
    0.00000063551335912363, 0.00000096707041180970, 0.00000154797400424410,
    0.00000209038647223331, 0.00000246128056164565, 0.00000273551299461512,
    0.00000215125863128643, 0.00000159051840791988, 0.00000112356197979857,
    0.00000073527551487574, 0.00000046450130357806, 0.00000033096079921048,
    0.00000022512612292678, 0.00000014879129266490, 0.00000016828623364192])
# The CIE 1931 colour-matching functions at those wavelengths.
SS_CMF = np.array([
    [0.00136800000, 0.00003900000, 0.00645000100], [0.01431000000, 0.00039600000, 0.06785001000],
    [0.13438000000, 0.00400000000, 0.64560000000], [0.34828000000, 0.02300000000, 1.74706000000],
    [0.29080000000, 0.06000000000, 1.66920000000], [0.09564000000, 0.13902000000, 0.81295010000],
    [0.00490000000, 0.32300000000, 0.27200000000], [0.06327000000, 0.71000000000, 0.07824999000],
    [0.29040000000, 0.95400000000, 0.02030000000], [0.59450000000, 0.99500000000, 0.00390000000],
    [0.91630000000, 0.87000000000, 0.00165000100], [1.06220000000, 0.63100000000, 0.00080000000],
    [0.85444990000, 0.38100000000, 0.00019000000], [0.44790000000, 0.17500000000, 0.00002000000],
    [0.16490000000, 0.06100000000, 0.00000000000], [0.04677000000, 0.01700000000, 0.00000000000],
    [0.01135916000, 0.00410200000, 0.00000000000], [0.00289932700, 0.00104700000, 0.00000000000],
    [0.00069007860, 0.00024920000, 0.00000000000], [0.00016615050, 0.00006000000, 0.00000000000],
    [0.00004150994, 0.00001499000, 0.00000000000]])
# Gauss-Laguerre (8 nodes) scaled to a ray's length, exp(x) folded into the weights.
SS_NODES = np.array([0.006811185292, 0.03614807107, 0.09004346519, 0.1706680068,
                     0.2818362161, 0.4303406404, 0.6296271457, 0.9145252695])
SS_WEIGHTS = np.array([0.01750893642, 0.04135477391, 0.06678839063, 0.09507698807,
                       0.1283416365, 0.1707430204, 0.2327233347, 0.3562490486])


def _ss_densities(p):
    """(N, 3) relative densities of molecules, aerosols and ozone at points p (N, 3)."""
    h = np.linalg.norm(p, axis=-1) - SS_EARTH_RADIUS
    return np.stack([np.exp(-h / SS_RAYLEIGH_SCALE), np.exp(-h / SS_MIE_SCALE),
                     np.maximum(0.0, 1.0 - np.abs(h - 25000.0) / 15000.0)], axis=-1)


def _ss_exit_length(p, d):
    """(N,) distance from points p (N, 3) along directions d (..., 3) out of the
    atmosphere."""
    b = 2.0 * np.sum(d * p, axis=-1)
    c = np.sum(p * p, axis=-1) - SS_ATMOSPHERE_RADIUS ** 2
    t = (-b + np.sqrt(b * b - 4.0 * c)) / 2.0
    return np.linalg.norm(d * t[..., None], axis=-1)


def _ss_optical_depth(p, d):
    """(N, 3) optical depths (per unit density of each) from points p out along d."""
    length = _ss_exit_length(p, d)
    depth = sum(_ss_densities(p + (node * length)[:, None] * d) * weight
                for node, weight in zip(SS_NODES, SS_WEIGHTS))
    return depth * length[:, None]


def _ss_earth_blocks(p, sun):
    """(N,) whether the line through points p toward the sun meets the Earth (only when
    the sun is below the horizontal, as intern/sky tests it)."""
    if sun[2] >= 0.0:
        return np.zeros(len(p), bool)
    b = 2.0 * (p @ sun)
    return b * b - 4.0 * (np.sum(p * p, axis=-1) - SS_EARTH_RADIUS ** 2) >= 0.0


def _single_scattering_texture(elevation, altitude, densities):
    """The Single Scattering sky texture (`texture`)."""
    scale = np.asarray(densities, np.float64)
    half_w, half_h = TEXTURE_WIDTH // 2, TEXTURE_HEIGHT // 2
    rows = np.arange(half_h, TEXTURE_HEIGHT)  # the horizon and above
    latitude = (math.pi / 2) * (rows / half_h - 1.0) ** 2
    longitude = (2.0 * math.pi / TEXTURE_WIDTH) * np.arange(half_w) - math.pi
    lat, lon = np.meshgrid(latitude, longitude, indexing="ij")
    d = np.stack([np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)],
                 axis=-1).reshape(-1, 3)
    sun = np.array([math.cos(elevation), 0.0, math.sin(elevation)])
    origin = np.array([0.0, 0.0, SS_EARTH_RADIUS + min(max(float(altitude), 1.0), 59999.0)])
    segment = _ss_exit_length(np.broadcast_to(origin, d.shape), d) / SS_STEPS
    mu = d @ sun
    g2 = SS_MIE_G ** 2
    rayleigh_phase = 0.1875 / math.pi * (1.0 + mu * mu)
    mie_phase = 3.0 * (1.0 - g2) * (1.0 + mu * mu) / (
        8.0 * math.pi * (2.0 + g2) * (1.0 + g2 - 2.0 * SS_MIE_G * mu) ** 1.5)
    p = origin + 0.5 * segment[:, None] * d
    depth = np.zeros((len(d), 3))
    spectrum = np.zeros((len(d), len(SS_IRRADIANCE)))
    for _ in range(SS_STEPS):
        density = scale * _ss_densities(p)
        depth += segment[:, None] * density
        total = depth + scale * _ss_optical_depth(p, np.broadcast_to(sun, p.shape))
        attenuation = np.exp(-(total[:, :1] * SS_RAYLEIGH + total[:, 1:2] * 1.11
                               * SS_MIE_COEFFICIENT + total[:, 2:] * SS_OZONE))
        scattering = ((rayleigh_phase * density[:, 0])[:, None] * SS_RAYLEIGH
                      + (mie_phase * density[:, 1] * SS_MIE_COEFFICIENT)[:, None])
        lit = ~_ss_earth_blocks(p, sun)
        spectrum += np.where(lit[:, None], attenuation * scattering * SS_IRRADIANCE
                             * segment[:, None], 0.0)
        p = p + segment[:, None] * d
    xyz = np.zeros((TEXTURE_HEIGHT, half_w, 3))
    xyz[half_h:] = (spectrum @ SS_CMF * SS_STEP_LAMBDA).reshape(len(rows), half_w, 3)
    # Below, the horizon's row fades out.
    z = np.sin((math.pi / 2) * (np.arange(half_h) / half_h - 1.0) ** 2)
    xyz[:half_h] = xyz[half_h] * horizon_fade(z)[:, None, None]
    return np.concatenate([xyz, xyz[:, ::-1]], axis=1)


def horizon_fade(z):
    """What the Single Scattering texture's rows below the horizon hold of its horizon row:
    (1 - 2.5 z)^3, 0 from z = 0.4, where z is the sine of the row's latitude taken as
    above the horizon (intern/sky's)."""
    z = np.asarray(z, np.float64)
    return np.where(z < 0.4, (1.0 - 2.5 * z) ** 3, 0.0)


def _single_scattering_sun(elevation, angular_diameter, altitude, densities):
    """The Single Scattering sun disc's pixels (`sun_pixels`): black once it has set; the
    ozone does not dim it."""
    half = angular_diameter / 2.0
    if elevation + half <= 0.0:
        return np.zeros(3), np.zeros(3)
    solid_angle = 2.0 * math.pi * (1.0 - math.cos(half))
    origin = np.array([[0.0, 0.0, SS_EARTH_RADIUS + min(max(float(altitude), 1.0), 59999.0)]])
    pixels = []
    for e in (max(elevation - half, 0.0), max(elevation + half, 0.0)):
        depth = _ss_optical_depth(origin, np.array([[math.cos(e), 0.0, math.sin(e)]]))[0]
        through = np.exp(-(SS_RAYLEIGH * depth[0] * densities[0]
                           + 1.11 * SS_MIE_COEFFICIENT * depth[1] * densities[1]))
        pixels.append(SS_IRRADIANCE * through / solid_angle @ SS_CMF * SS_STEP_LAMBDA)
    return tuple(pixels)


# ----------------------------------------------------------------- Preetham
# Preetham, Shirley and Smits' analytic daylight (1999), Cycles' Preetham type: the zenith's
# CIE xyY from the turbidity T and the sun's zenith angle, spread over the sky by Perez'
# function of the direction's zenith angle and its angle to the sun, with coefficients
# linear in T. No sun disc; the Sun Direction, Turbidity inputs only.
PREETHAM_PARAMS = 20  # (preetham_params)
_PEREZ = {  # per quantity (Y, x, y): five coefficients, each (slope in T, constant)
    "Y": ((0.1787, -1.4630), (-0.3554, 0.4275), (-0.0227, 5.3251), (0.1206, -2.5771),
          (-0.0670, 0.3703)),
    "x": ((-0.0193, -0.2592), (-0.0665, 0.0008), (-0.0004, 0.2125), (-0.0641, -0.8989),
          (-0.0033, 0.0452)),
    "y": ((-0.0167, -0.2608), (-0.0950, 0.0092), (-0.0079, 0.2102), (-0.0441, -1.6537),
          (-0.0109, 0.0529))}


def perez(coefficients, theta, gamma):
    """Perez' sky luminance distribution at zenith angle theta and angle gamma to the sun."""
    a, b, c, d, e = coefficients
    return (1.0 + a * math.exp(b / math.cos(theta))) * (
        1.0 + c * math.exp(d * gamma) + e * math.cos(gamma) ** 2)


def preetham_params(sun_direction, turbidity: float) -> list:
    """The PREETHAM_PARAMS floats `preetham_xyz` reads: the sun's zenith angle and azimuth
    (Cycles' sky_spherical_coordinates, atan2(x, y)), the zenith's Y, x and y over Perez'
    function toward the zenith (so that the zenith reads them), and the three quantities'
    five Perez coefficients."""
    x, y, z = (float(v) for v in sun_direction)
    theta, phi = math.acos(z), math.atan2(x, y)
    t, t2 = float(turbidity), float(turbidity) ** 2
    th2, th3 = theta * theta, theta ** 3
    chi = (4.0 / 9.0 - t / 120.0) * (math.pi - 2.0 * theta)
    zenith = {
        "Y": 0.06 * ((4.0453 * t - 4.9710) * math.tan(chi) - 0.2155 * t + 2.4192),
        "x": ((0.00166 * th3 - 0.00375 * th2 + 0.00209 * theta) * t2
              + (-0.02903 * th3 + 0.06377 * th2 - 0.03202 * theta + 0.00394) * t
              + (0.11693 * th3 - 0.21196 * th2 + 0.06052 * theta + 0.25886)),
        "y": ((0.00275 * th3 - 0.00610 * th2 + 0.00317 * theta) * t2
              + (-0.04214 * th3 + 0.08970 * th2 - 0.04153 * theta + 0.00516) * t
              + (0.15346 * th3 - 0.26756 * th2 + 0.06670 * theta + 0.26688))}
    out = [theta, phi]
    config = {q: [slope * t + constant for slope, constant in _PEREZ[q]] for q in "Yxy"}
    out += [zenith[q] / perez(config[q], 0.0, theta) for q in "Yxy"]
    for q in "Yxy":
        out += config[q]
    return out


@njit(**JIT)
def _perez(params, p, theta, gamma):
    return (1.0 + params[p] * math.exp(params[p + 1] / math.cos(theta))) * (
        1.0 + params[p + 2] * math.exp(params[p + 3] * gamma)
        + params[p + 4] * math.cos(gamma) ** 2)


@njit(**JIT)
def preetham_xyz(x, y, z, params, p):
    """(X, Y, Z) of the Preetham sky in direction (x, y, z) (sky_radiance_preetham), from
    the PREETHAM_PARAMS floats at params[p:]."""
    theta = math.acos(min(max(z, -1.0), 1.0))
    phi = -math.atan2(y, x) + math.pi / 2
    sun_theta, sun_phi = params[p], params[p + 1]
    cos_gamma = (math.sin(theta) * math.sin(sun_theta) * math.cos(sun_phi - phi)
                 + math.cos(theta) * math.cos(sun_theta))
    gamma = math.acos(min(max(cos_gamma, -1.0), 1.0))
    theta = min(theta, math.pi / 2 - 0.001)  # the horizon's colour below it
    luminance = params[p + 2] * _perez(params, p + 5, theta, gamma)
    cx = params[p + 3] * _perez(params, p + 10, theta, gamma)
    cy = params[p + 4] * _perez(params, p + 15, theta, gamma)
    if cy == 0.0:
        return 0.0, luminance, 0.0
    return cx / cy * luminance, luminance, (1.0 - cx - cy) / cy * luminance


def disc_params(elevation, rotation, angular_diameter, intensity, altitude, bottom, top):
    """The DISC_PARAMS floats `sun_disc` reads (angular_diameter < 0: no disc)."""
    return [elevation, rotation, angular_diameter, intensity, horizon_elevation(altitude),
            *bottom, *top]


# ----------------------------------------------------------------- lookups (compiled)
@njit(**JIT)
def texture_coordinates(x, y, z, rotation):
    """(u, v) of direction (x, y, z) in the sky's texture (sky_radiance_nishita): u the
    azimuth from the sun's (`rotation`, as `sun_position` gives it), v the elevation
    through the inverse of the texture's spread."""
    elevation = math.pi / 2 - math.acos(min(max(z, -1.0), 1.0))
    u = (-math.atan2(y, x) - math.pi / 2 + rotation) / (2.0 * math.pi)
    u -= math.floor(u)
    v = math.copysign(math.sqrt(abs(elevation) * 2.0 / math.pi), elevation) * 0.5 + 0.5
    return u, v


@njit(**JIT)
def sun_direction(elevation, rotation):
    """The unit direction toward the sun (as `sun_position` gives its angles) in the
    texture's frame (spherical_to_direction(elevation - pi/2, rotation - pi/2))."""
    st, ct = math.sin(elevation - math.pi / 2), math.cos(elevation - math.pi / 2)
    return st * math.cos(rotation - math.pi / 2), st * math.sin(rotation - math.pi / 2), ct


@njit(**JIT)
def sun_disc(x, y, z, params, p):
    """(X, Y, Z) of the sun's disc in direction (x, y, z) (0 off it), from the DISC_PARAMS
    floats at params[p:]."""
    elevation, rotation, diameter = params[p], params[p + 1], params[p + 2]
    if diameter < 0.0:
        return 0.0, 0.0, 0.0
    sx, sy, sz = sun_direction(elevation, rotation)
    # The angle between them as Cycles' precise_angle: 2 atan2(|a - b|, |a + b|).
    angle = 2.0 * math.atan2(math.sqrt((x - sx) ** 2 + (y - sy) ** 2 + (z - sz) ** 2),
                             math.sqrt((x + sx) ** 2 + (y + sy) ** 2 + (z + sz) ** 2))
    half = diameter * 0.5
    dir_elevation = math.pi / 2 - math.acos(min(max(z, -1.0), 1.0))
    if not (angle < half and dir_elevation > params[p + 4]):
        return 0.0, 0.0, 0.0
    t = (dir_elevation - elevation) / diameter + 0.5
    darkening = (1.0 - 0.6 * (1.0 - math.sqrt(1.0 - (angle / half) ** 2))) * params[p + 3]
    return ((params[p + 5] + (params[p + 8] - params[p + 5]) * t) * darkening,
            (params[p + 6] + (params[p + 9] - params[p + 6]) * t) * darkening,
            (params[p + 7] + (params[p + 10] - params[p + 7]) * t) * darkening)

"""The Sky Texture's Multiple and Single Scattering skies (engine/sky.py): the precomputed
textures, the sun's position and disc, and how a world's map and its sun light share them
(Cycles' agreement: tests/cycles variants world_sky_texture, world_sky_single_scattering)."""

import math

import numpy as np
import pytest

from engine import environment, shading, sky


@pytest.mark.parametrize("elevation, rotation, expected", [
    (15.0, 0.0, (15.0, 360.0)),     # the rotation reversed: 2 pi - r
    (15.0, -30.0, (15.0, 30.0)),    # wrapped into [0, 2 pi) first
    (100.0, 0.0, (80.0, 180.0)),    # past the zenith: the other side, turned half round
    (-100.0, 40.0, (-80.0, 140.0)),
    (375.0, 400.0, (15.0, 320.0)),  # whole turns
])
def test_sun_position_wraps_as_cycles_simplify_settings(elevation, rotation, expected):
    e, r = sky.sun_position(math.radians(elevation), math.radians(rotation))
    assert (math.degrees(e), math.degrees(r)) == pytest.approx(expected, abs=1e-9)


def test_an_empty_atmosphere_scatters_nothing_and_lets_the_whole_sun_through():
    assert np.all(sky.texture("MULTIPLE_SCATTERING", 0.3, 100.0, 0.0, 0.0, 0.0) == 0.0)
    size = 0.01
    bottom, top = sky.sun_pixels("MULTIPLE_SCATTERING", 0.3, size, 100.0, 0.0, 0.0, 0.0)
    whole = sky.SUN_IRRADIANCE @ sky.SPECTRAL_TO_XYZ / (2 * math.pi * (1 - math.cos(size / 2)))
    assert np.allclose(bottom, whole, rtol=1e-12) and np.allclose(top, whole, rtol=1e-12)


def test_the_texture_is_mirrored_about_the_sun_and_the_sky_blue_at_the_zenith():
    xyz = sky.texture("MULTIPLE_SCATTERING", math.radians(20.0), 100.0, 1.0, 1.0, 1.0)
    assert xyz.shape == (sky.TEXTURE_HEIGHT, sky.TEXTURE_WIDTH, 3)
    assert np.all(np.isfinite(xyz)) and xyz.min() >= 0.0
    assert np.array_equal(xyz, xyz[:, ::-1])
    zenith = xyz[-1].mean(axis=0)
    assert zenith[2] > 1.5 * zenith[0]  # Z (blue) over X
    # Toward the sun (the middle columns, just above the horizon) the sky is brightest.
    horizon = xyz[sky.TEXTURE_HEIGHT // 2 + 8, :, 1]
    assert np.argmax(horizon) in (sky.TEXTURE_WIDTH // 2 - 1, sky.TEXTURE_WIDTH // 2)
    # A denser atmosphere lets less of the sun through.
    e = math.radians(20.0)
    low = sky.sun_pixels("MULTIPLE_SCATTERING", e, 0.01, 100.0, 1.0, 1.0, 1.0)[0]
    hazy = sky.sun_pixels("MULTIPLE_SCATTERING", e, 0.01, 100.0, 1.0, 5.0, 1.0)[0]
    assert np.all(hazy < low)


def test_single_scattering_fades_the_horizon_out_below_it_and_sets_with_its_sun():
    xyz = sky.texture("SINGLE_SCATTERING", math.radians(20.0), 300.0, 1.0, 1.0, 1.0)
    half = sky.TEXTURE_HEIGHT // 2
    assert np.all(np.isfinite(xyz)) and xyz.min() >= 0.0 and np.array_equal(xyz, xyz[:, ::-1])
    assert xyz[half].min() > 0.0 and np.allclose(xyz[half - 1], xyz[half], rtol=1e-3)
    z = np.sin(math.pi / 2 * (np.arange(half) / half - 1.0) ** 2)
    assert np.allclose(xyz[:half], xyz[half] * sky.horizon_fade(z)[:, None, None])
    assert np.all(xyz[:half][z >= 0.4] == 0.0)
    zenith = xyz[-1].mean(axis=0)
    assert zenith[2] > 1.5 * zenith[0]
    assert np.all(sky.texture("SINGLE_SCATTERING", 0.3, 100.0, 0.0, 0.0, 0.0) == 0.0)
    # The disc: dimmer low down, black once set (ozone does not dim it).
    high = sky.sun_pixels("SINGLE_SCATTERING", 0.8, 0.01, 100.0, 1.0, 1.0, 1.0)
    low = sky.sun_pixels("SINGLE_SCATTERING", 0.1, 0.01, 100.0, 1.0, 1.0, 1.0)
    assert np.all(low[0] < high[0]) and np.all(low[0] < low[1])
    assert np.allclose(sky.sun_pixels("SINGLE_SCATTERING", 0.3, 0.01, 100.0, 1, 1, 0.0),
                       sky.sun_pixels("SINGLE_SCATTERING", 0.3, 0.01, 100.0, 1, 1, 5.0))
    assert np.all(np.concatenate(sky.sun_pixels("SINGLE_SCATTERING", -0.02, 0.01, 100.0,
                                                1.0, 1.0, 1.0)) == 0.0)


def test_the_sun_lies_in_the_middle_of_the_texture_and_its_disc_around_it():
    e, r = sky.sun_position(math.radians(30.0), math.radians(70.0))
    s = np.array(sky.sun_direction(e, r))
    assert np.linalg.norm(s) == pytest.approx(1.0) and s[2] == pytest.approx(math.sin(e))
    u, v = sky.texture_coordinates(*s, r)
    assert u == pytest.approx(0.5) and v == pytest.approx(0.5 + 0.5 * math.sqrt(e * 2 / math.pi))
    size = 0.02
    bottom, top = np.array([1.0, 2.0, 3.0]), np.array([3.0, 4.0, 5.0])
    params = np.array(sky.disc_params(e, r, size, 2.0, 100.0, bottom, top))
    assert np.allclose(sky.sun_disc(*s, params, 0), 2.0 * (bottom + top) / 2)
    # Off the disc, nothing; at 0.9 of its radius, the limb darkening.
    side = np.cross(s, (0.0, 0.0, 1.0))
    side /= np.linalg.norm(side)
    assert sky.sun_disc(*(math.cos(0.011) * s + math.sin(0.011) * side), params, 0) \
        == (0.0, 0.0, 0.0)
    # (Level with the centre, the disc's gradient from bottom to top is about halfway.)
    flat = np.array(sky.disc_params(e, r, size, 2.0, 100.0, bottom, bottom))
    near = sky.sun_disc(*(math.cos(0.009) * s + math.sin(0.009) * side), flat, 0)
    darkening = 1 - 0.6 * (1 - math.sqrt(1 - 0.9 ** 2))
    assert np.allclose(near, 2.0 * bottom * darkening, rtol=1e-6)
    above = sky.sun_disc(*(math.cos(0.009) * s + math.sin(0.009) * np.cross(side, s)),
                         params, 0)
    assert np.allclose(above, 2.0 * (bottom + 0.95 * (top - bottom)) * darkening, rtol=1e-3)
    params[2] = -1.0  # Sun Disc off
    assert sky.sun_disc(*s, params, 0) == (0.0, 0.0, 0.0)


def test_a_sun_below_the_horizon_shows_no_disc():
    e, r = sky.sun_position(math.radians(-2.0), 0.0)
    params = np.array(sky.disc_params(e, r, 0.01, 1.0, 100.0, (1.0,) * 3, (1.0,) * 3))
    assert sky.sun_disc(*sky.sun_direction(e, r), params, 0) == (0.0, 0.0, 0.0)
    # ... but one above the horizon as seen from the altitude (it dips below 0 up there).
    assert sky.horizon_elevation(100.0) == pytest.approx(-math.sqrt(2 * 0.1 / 6371), rel=1e-3)


def test_the_preetham_zenith_reads_its_zenith_values_and_the_sky_peaks_toward_the_sun():
    sun = np.array([0.3, -0.5, 0.6])
    sun /= np.linalg.norm(sun)
    params = np.array(sky.preetham_params(sun, 2.5))
    assert len(params) == sky.PREETHAM_PARAMS
    # Cycles' sun azimuth: atan2(x, y); its zenith angle: acos(z).
    assert params[0] == pytest.approx(math.acos(sun[2]))
    assert params[1] == pytest.approx(math.atan2(sun[0], sun[1]))
    # At the zenith Perez' function is its value at the zenith: the zenith's xyY.
    zenith = [params[2] * sky.perez(params[5:10], 0.0, params[0]),
              params[3] * sky.perez(params[10:15], 0.0, params[0]),
              params[4] * sky.perez(params[15:20], 0.0, params[0])]
    X, Y, Z = sky.preetham_xyz(0.0, 0.0, 1.0, params, 0)
    assert Y == pytest.approx(zenith[0])
    assert (X / (X + Y + Z), Y / (X + Y + Z)) == pytest.approx((zenith[1], zenith[2]))
    # Brightest toward the sun (Cycles' phi = pi/2 - atan2: the sun's own direction).
    d = np.array([math.sin(params[0]) * math.sin(params[1]),
                  math.sin(params[0]) * math.cos(params[1]), math.cos(params[0])])
    assert np.allclose(d, sun)
    away = sky.preetham_xyz(*(-d[0], -d[1], d[2]), params, 0)[1]
    assert sky.preetham_xyz(*d, params, 0)[1] > 3 * away


def _sky_program(params):
    """A world program of the sky's steps as the exporter wires them (shader_nodes._n_sky),
    on a black texture: only the disc shines; XYZ taken as RGB."""
    p = shading.Program()
    lookup = p.emit(shading.OP_SKY, 6, a=p.uv(shading.GENERATED), d=0, params=params)
    texture = shading.Texture("sky", np.zeros((4, 8, 4), np.float32), "Linear", "EXTEND")
    xyz = p.image(texture, lookup, False)
    p.out = p.emit(shading.OP_SKY, 3, a=xyz, b=lookup + 3, d=1, params=np.eye(3).ravel())
    return p


def test_the_map_leaves_the_disc_out_and_the_sun_light_carries_its_power():
    """A wide disc (0.3 rad) of radiance 1 before its limb darkening: the baked map is black,
    and disc_irradiance is the integral of the darkened disc times the cosine, to 1e-4."""
    e, r, size = 0.6, 1.0, 0.3
    p = _sky_program(sky.disc_params(e, r, size, 1.0, 100.0, (1.0, 2.0, 3.0), (1.0, 2.0, 3.0)))
    assert np.all(environment.bake(p, 64, 32) == 0.0)
    s = sky.sun_direction(e, r)
    got = environment.disc_irradiance(p, s, size)
    theta = np.linspace(0.0, size / 2, 200001)
    f = (1 - 0.6 * (1 - np.sqrt(np.maximum(1 - (theta / (size / 2)) ** 2, 0.0)))) \
        * np.cos(theta) * np.sin(theta) * 2 * math.pi
    expected = np.sum((f[1:] + f[:-1]) / 2 * np.diff(theta))
    assert np.allclose(got, expected * np.array([1.0, 2.0, 3.0]), rtol=1e-4)
    # No disc: no power.
    params = sky.disc_params(e, r, -1.0, 1.0, 100.0, (1.0,) * 3, (1.0,) * 3)
    assert np.all(environment.disc_irradiance(_sky_program(params), s, size) == 0.0)

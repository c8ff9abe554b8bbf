"""Procedural textures (engine/noise.py); their agreement with Cycles' own is
tests/cycles' procedural_textures (every noise dimension and fractal type, every gradient)."""

import math

import numpy as np
import pytest

from engine import noise


@pytest.mark.parametrize("d", [1, 2, 3, 4])
def test_perlin_noise_is_zero_on_the_lattice_and_continuous_across_cells(d, rng):
    """Gradient noise: each corner's gradient dotted with a zero offset there, and cells
    that meet at a face agree on it (the quintic fade's value and slope)."""
    for point in rng.integers(-50, 50, (20, 4)):
        assert noise.perlin(d, *map(float, point)) == 0.0
    for point in rng.uniform(-20.0, 20.0, (50, 4)):
        edge = point.copy()
        edge[0] = math.floor(edge[0]) + 1.0
        below, above = edge.copy(), edge.copy()
        below[0] -= 1e-9
        above[0] += 1e-9
        assert abs(noise.perlin(d, *below) - noise.perlin(d, *above)) < 1e-7


def test_signed_noise_stays_within_its_scaled_range(rng):
    for d in (1, 2, 3, 4):
        values = [noise.snoise(d, *p) for p in rng.uniform(-100.0, 100.0, (4000, 4))]
        assert max(abs(v) for v in values) <= 1.05, d
        assert np.std(values) > 0.1  # (not a constant)


def test_one_octave_of_normalized_fbm_is_signed_noise_remapped_to_0_1(rng):
    fbm = noise.NOISE_TYPES.index("FBM")
    for p in rng.uniform(-10.0, 10.0, (30, 4)):
        got = noise.fractal(fbm, 3, *p, 0.0, 0.5, 2.0, 0.0, 1.0, True)
        assert got == pytest.approx(0.5 * noise.snoise(3, *p) + 0.5, abs=1e-15)


def test_a_fractional_detail_blends_toward_the_next_octave(rng):
    """Detail 1.25 is a quarter of the way from 1 octave to 2 (unnormalized fBM)."""
    fbm = noise.NOISE_TYPES.index("FBM")
    for p in rng.uniform(-10.0, 10.0, (30, 4)):
        one, two, mid = (noise.fractal(fbm, 2, *p, detail, 0.5, 2.0, 0.0, 1.0, False)
                         for detail in (1.0, 2.0, 1.25))
        assert mid == pytest.approx(one + 0.25 * (two - one), abs=1e-12)


@pytest.mark.parametrize("kind, point, want", [
    ("LINEAR", (0.3, 0.9, 0.0), 0.3), ("LINEAR", (1.7, 0.0, 0.0), 1.0),
    ("QUADRATIC", (0.5, 0.0, 0.0), 0.25), ("EASING", (0.5, 0.0, 0.0), 0.5),
    ("DIAGONAL", (0.2, 0.6, 0.0), 0.4), ("RADIAL", (0.0, 1.0, 0.0), 0.75),
    ("SPHERICAL", (0.6, 0.0, 0.0), 0.399999), ("QUADRATIC_SPHERE", (0.0, 0.0, 2.0), 0.0)])
def test_gradient_texture_types(kind, point, want):
    assert noise.gradient(noise.GRADIENT_TYPES.index(kind), *point) == \
        pytest.approx(want, abs=1e-9)


def test_wave_profiles_and_magic_are_bounded(rng):
    """Wave's sine, saw and triangle profiles stay in [0, 1]; Magic is 0.5 where its
    distortion is 0 at depth 0 (sin and cos divided by nothing, then 0.5 - them)."""
    for p in rng.uniform(-5.0, 5.0, (200, 3)):
        for profile in range(3):
            for kind in range(2):
                f = noise.wave(kind, 3, 3, profile, *p, 2.0, 2.0, 1.0, 0.5, 0.3)
                assert 0.0 <= f <= 1.0
        r, g, b = noise.magic(*p, 1.0, 0, 0.0)
        assert (r, g, b) == pytest.approx((0.5 - math.sin((p.sum()) * 5.0),
                                           0.5 - math.cos((-p[0] + p[1] - p[2]) * 5.0),
                                           0.5 + math.cos((-p[0] - p[1] + p[2]) * 5.0)),
                                          abs=1e-9)


def test_float_bits_are_the_float32_bits(rng):
    """float_bits is numpy's float32 view of the value, for normal, subnormal, signed-zero
    and infinite values."""
    values = np.concatenate([rng.normal(size=50) * 10.0 ** rng.integers(-40, 38, 50),
                             [0.0, -0.0, 1e-45, -3e-39, np.inf, -np.inf, 1.0, -7.25]])
    for x in values:
        assert noise.float_bits(x) == int(np.float32(x).view(np.uint32)), x


def test_white_noise_hashes_the_point_as_cycles_orders_it(rng):
    """Each dimension's Color hashes the point's float32 bits with a channel number
    (1D-3D) or reordered (4D), as util/hash.h's hash_float*_to_float3."""
    h = noise._hash_to_float
    for _ in range(20):
        x, y, z, w = rng.normal(size=4) * 5.0
        want = {1: (h(w), h(w, 1.0), h(w, 2.0)),
                2: (h(x, y), h(x, y, 1.0), h(x, y, 2.0)),
                3: (h(x, y, z), h(x, y, z, 1.0), h(x, y, z, 2.0)),
                4: (h(x, y, z, w), h(z, x, w, y), h(w, z, y, x))}
        for d in range(1, 5):
            assert noise.white_noise(d, x, y, z, w) == pytest.approx(want[d], abs=0.0), d


def test_object_random_hashes_the_name_as_cycles():
    """Object Info's Random of an object that is not an instance: hash_uint2 of the name's
    hash_string (37 i + c over signed chars) and 0, over 2^32; an instance's is its own
    random_id over 2^32."""
    assert noise.hash_string("") == 0
    assert noise.hash_string("Ab") == (65 * 37 + 98)
    assert noise.hash_string("é") == ((0xC3 - 256) * 37 + (0xA9 - 256)) & noise.MASK
    h = noise.hash_uint.py_func(2, noise.hash_string("Cube"), 0, 0, 0)
    assert noise.object_random("Cube") == pytest.approx(h / 2.0 ** 32, rel=1e-7)
    assert noise.object_random("Cube", 2 ** 31) == 0.5
    assert noise.object_random("Cube", -1) == pytest.approx(1.0)


def test_bricks_lay_in_offset_rows_with_mortar_between():
    """A Brick Texture's mortar is 1 within Mortar Size of a brick's edge and 0 inside it;
    every offset_frequency-th row is shifted by the offset (a brick's tint is the same
    across its width, and changes where the shifted row's joint falls); a squashed row's
    bricks are narrower; tints stay in [0, 1]."""
    b = noise.brick.py_func
    settings = dict(mortar_size=0.02, mortar_smooth=0.0, bias=0.0, brick_width=0.5,
                    row_height=0.25, offset_amount=0.5, offset_frequency=2, squash_amount=1.0,
                    squash_frequency=2)
    assert b(0.5, 0.1, **settings)[1] == 0.0
    assert b(0.25, 0.1, **settings)[1] == 1.0 and b(0.5, 0.24, **settings)[1] == 1.0
    # Row 0 (offset: 0 % 2 == 0) has its joints at x = 0.25 + k/2, row 1 at x = k/2.
    assert b(0.26, 0.1, **settings)[1] == 1.0 and b(0.26, 0.35, **settings)[1] == 0.0
    assert b(0.3, 0.1, **settings)[0] == b(0.6, 0.1, **settings)[0]
    assert b(0.3, 0.35, **settings)[0] != b(0.6, 0.35, **settings)[0]
    squashed = dict(settings, squash_amount=0.5)
    assert b(0.12, 0.1, **squashed)[1] == 1.0 and b(0.12, 0.35, **squashed)[1] == 0.0
    for x in np.linspace(-3, 3, 50):
        tint = b(x, 0.37 * x, **dict(settings, bias=0.3))[0]
        assert 0.0 <= tint <= 1.0

"""Procedural textures as Cycles computes them: Perlin noise and its fractals (the Noise
Texture node), and the Gradient Texture.

Cycles' Noise Texture (kernel/svm/noisetex.h, fractal_noise.h, noise.h; Perlin's improved
noise as Open Shading Language has it) hashes each lattice corner's integer coordinates
with Bob Jenkins' lookup3 (util/hash.h), takes one of a few gradients by the hash's low
bits, blends the corners' dot products with the quintic fade, and scales the result to
about [-1, 1] by a factor per dimension. Its fractals add, multiply or ridge octaves of it
at `lacunarity` times the frequency and `roughness` times the amplitude; Distortion moves
the point by noise at seeded offsets first, and the Color output is the same fractal at two
more seeded offsets. The hashes are exact (32-bit wrap-around on int64); the arithmetic is
float64 where Cycles' is float32, which moves values by about 1e-7.

A point has up to four coordinates (x, y, z, w); `d` (1-4) says how many are read: 1D reads
w alone, as Cycles' 1D noise reads the W input.
"""

from __future__ import annotations

import math

import numpy as np

from .jit import JIT, njit

NOISE_TYPES = ("MULTIFRACTAL", "RIDGED_MULTIFRACTAL", "HYBRID_MULTIFRACTAL", "FBM",
               "HETERO_TERRAIN")
GRADIENT_TYPES = ("LINEAR", "QUADRATIC", "EASING", "DIAGONAL", "SPHERICAL",
                  "QUADRATIC_SPHERE", "RADIAL")
MASK = 0xFFFFFFFF
# The factors that map each dimension's Perlin noise to about [-1, 1] (found by the OSL
# developers; Cycles' noise_scale1..4).
NOISE_SCALE = (0.25, 0.6616, 0.9820, 0.8344)


# ----------------------------------------------------------------- lookup3 (32-bit)
@njit(**JIT)
def _rot(x, k):
    return ((x << k) | (x >> (32 - k))) & MASK


@njit(**JIT)
def _final(a, b, c):
    c = ((c ^ b) - _rot(b, 14)) & MASK
    a = ((a ^ c) - _rot(c, 11)) & MASK
    b = ((b ^ a) - _rot(a, 25)) & MASK
    c = ((c ^ b) - _rot(b, 16)) & MASK
    a = ((a ^ c) - _rot(c, 4)) & MASK
    b = ((b ^ a) - _rot(a, 14)) & MASK
    c = ((c ^ b) - _rot(b, 24)) & MASK
    return c


@njit(**JIT)
def _step(x, y, z, k):
    """One line of lookup3's mix: x -= y; x ^= rot(y, k); y += z."""
    return ((x - y) & MASK) ^ _rot(y, k), (y + z) & MASK


@njit(**JIT)
def _mix(a, b, c):
    for k1, k2, k3 in ((4, 6, 8), (16, 19, 4)):
        a, c = _step(a, c, b, k1)
        b, a = _step(b, a, c, k2)
        c, b = _step(c, b, a, k3)
    return a, b, c


@njit(**JIT)
def hash_uint(n, kx, ky, kz, kw):
    """Cycles' hash_uint / hash_uint2 / 3 / 4 of the first n keys (each taken mod 2^32)."""
    a = b = c = (0xDEADBEEF + (n << 2) + 13) & MASK
    if n == 4:
        a, b, c = _mix((a + kx) & MASK, (b + ky) & MASK, (c + kz) & MASK)
        return _final((a + kw) & MASK, b, c)
    if n >= 3:
        c = (c + kz) & MASK
    if n >= 2:
        b = (b + ky) & MASK
    return _final((a + kx) & MASK, b, c)


# ----------------------------------------------------------------- Perlin noise
@njit(**JIT)
def _fade(t):
    return t * t * t * (t * (t * 6.0 - 15.0) + 10.0)


@njit(**JIT)
def _grad(d, h, x, y, z, w):
    """The gradient the hash h picks, dotted with the offset to the corner (Cycles' grad1
    .. grad4)."""
    if d == 1:
        h &= 15
        g = 1.0 + (h & 7)
        return -g * x if h & 8 else g * x
    if d == 2:
        h &= 7
        u, v = (x, 2.0 * y) if h < 4 else (y, 2.0 * x)
        return (-u if h & 1 else u) + (-v if h & 2 else v)
    if d == 3:
        h &= 15
        u = x if h < 8 else y
        v = y if h < 4 else (x if h == 12 or h == 14 else z)
        return (-u if h & 1 else u) + (-v if h & 2 else v)
    h &= 31
    u = x if h < 24 else y
    v = y if h < 16 else z
    s = z if h < 8 else w
    return (-u if h & 1 else u) + (-v if h & 2 else v) + (-s if h & 4 else s)


@njit(**JIT)
def perlin(d, x, y, z, w):
    """Perlin noise of dimension d at (x, y, z, w) (1D: at x), unscaled: the corners'
    gradients blended by the quintic fade, multilinearly."""
    fx, fy, fz, fw = math.floor(x), math.floor(y), math.floor(z), math.floor(w)
    kx, ky, kz, kw = int(fx), int(fy), int(fz), int(fw)
    rx, ry, rz, rw = x - fx, y - fy, z - fz, w - fw
    ux, uy, uz, uw = _fade(rx), _fade(ry), _fade(rz), _fade(rw)
    total = 0.0
    for corner in range(1 << d):
        bx, by, bz, bw = corner & 1, (corner >> 1) & 1, (corner >> 2) & 1, (corner >> 3) & 1
        h = hash_uint(d, (kx + bx) & MASK, (ky + by) & MASK, (kz + bz) & MASK,
                      (kw + bw) & MASK)
        g = _grad(d, h, rx - bx, ry - by, rz - bz, rw - bw)
        weight = ux if bx else 1.0 - ux
        if d >= 2:
            weight *= uy if by else 1.0 - uy
        if d >= 3:
            weight *= uz if bz else 1.0 - uz
        if d >= 4:
            weight *= uw if bw else 1.0 - uw
        total += weight * g
    return total


@njit(**JIT)
def _wrapped(p):
    """A coordinate repeated every 100000 (Cycles: against float precision), nudged by
    half a cell beyond 1e6."""
    if abs(p) < 100000.0:
        return p
    return p - 100000.0 * math.trunc(p / 100000.0) + (0.5 if abs(p) >= 1000000.0 else 0.0)


@njit(**JIT)
def snoise(d, x, y, z, w):
    """Signed noise in about [-1, 1] (Cycles' snoise_1d .. snoise_4d; 1D reads x)."""
    return NOISE_SCALE[d - 1] * perlin(d, _wrapped(x), _wrapped(y), _wrapped(z),
                                       _wrapped(w))


# ----------------------------------------------------------------- fractals
@njit(**JIT)
def fractal(kind, d, x, y, z, w, detail, roughness, lacunarity, offset, gain, normalize):
    """Cycles' noise_select: the fractal `kind` (NOISE_TYPES index) of snoise over
    floor(detail) + 1 octaves, the remainder of detail blending one more."""
    octaves = int(detail)
    rmd = detail - math.floor(detail)
    if kind == 3:  # FBM
        fscale, amp, maxamp, total = 1.0, 1.0, 0.0, 0.0
        for _ in range(octaves + 1):
            total += snoise(d, fscale * x, fscale * y, fscale * z, fscale * w) * amp
            maxamp += amp
            amp *= roughness
            fscale *= lacunarity
        if rmd != 0.0:
            t = snoise(d, fscale * x, fscale * y, fscale * z, fscale * w)
            total2 = total + t * amp
            if normalize:
                a = 0.5 * total / maxamp + 0.5
                return a + rmd * (0.5 * total2 / (maxamp + amp) + 0.5 - a)
            return total + rmd * (total2 - total)
        return 0.5 * total / maxamp + 0.5 if normalize else total
    if kind == 0:  # MULTIFRACTAL
        value, pwr = 1.0, 1.0
        for _ in range(octaves + 1):
            value *= pwr * snoise(d, x, y, z, w) + 1.0
            pwr *= roughness
            x, y, z, w = x * lacunarity, y * lacunarity, z * lacunarity, w * lacunarity
        if rmd != 0.0:
            value *= rmd * pwr * snoise(d, x, y, z, w) + 1.0
        return value
    if kind == 4:  # HETERO_TERRAIN
        pwr = roughness
        value = offset + snoise(d, x, y, z, w)
        x, y, z, w = x * lacunarity, y * lacunarity, z * lacunarity, w * lacunarity
        for _ in range(1, octaves + 1):
            value += (snoise(d, x, y, z, w) + offset) * pwr * value
            pwr *= roughness
            x, y, z, w = x * lacunarity, y * lacunarity, z * lacunarity, w * lacunarity
        if rmd != 0.0:
            value += rmd * ((snoise(d, x, y, z, w) + offset) * pwr * value)
        return value
    if kind == 2:  # HYBRID_MULTIFRACTAL
        pwr, value, weight = 1.0, 0.0, 1.0
        i = 0
        while weight > 0.001 and i <= octaves:
            weight = min(weight, 1.0)
            signal = (snoise(d, x, y, z, w) + offset) * pwr
            pwr *= roughness
            value += weight * signal
            weight *= gain * signal
            x, y, z, w = x * lacunarity, y * lacunarity, z * lacunarity, w * lacunarity
            i += 1
        if rmd != 0.0 and weight > 0.001:
            value += rmd * min(weight, 1.0) * ((snoise(d, x, y, z, w) + offset) * pwr)
        return value
    # RIDGED_MULTIFRACTAL
    pwr = roughness
    signal = offset - abs(snoise(d, x, y, z, w))
    signal *= signal
    value, weight = signal, 1.0
    for _ in range(1, octaves + 1):
        x, y, z, w = x * lacunarity, y * lacunarity, z * lacunarity, w * lacunarity
        weight = min(max(signal * gain, 0.0), 1.0)
        signal = offset - abs(snoise(d, x, y, z, w))
        signal *= signal * weight
        value += signal * pwr
        pwr *= roughness
    return value


# ----------------------------------------------------------------- the seeded offsets
def _hash_to_float(*floats) -> float:
    """Cycles' hash_float(2)_to_float of float32 keys: their bits hashed, as a float32 in
    [0, 1]."""
    bits = [int(np.float32(f).view(np.uint32)) for f in floats]
    n = len(bits)
    h = hash_uint.py_func(n, *(bits + [0] * (4 - n))) if hasattr(hash_uint, "py_func") \
        else hash_uint(n, *(bits + [0] * (4 - n)))
    return float(np.float32(h) * (np.float32(1.0) / np.float32(0xFFFFFFFF)))


def _offsets() -> np.ndarray:
    """(4, 6, 4): per dimension d - 1, the offsets Cycles adds for seeds 0-5
    (random_float_offset .. random_float4_offset: each component 100 + 100 x a hash of
    (seed, component); 1D: of the seed alone), in float32 as Cycles has them."""
    out = np.zeros((4, 6, 4))
    for seed in range(6):
        out[0, seed, 0] = np.float32(100.0) + np.float32(_hash_to_float(seed)) * np.float32(100)
        for d in range(2, 5):
            for j in range(d):
                out[d - 1, seed, j] = np.float32(100.0) + \
                    np.float32(_hash_to_float(seed, j)) * np.float32(100.0)
    return out


OFFSETS = _offsets()


@njit(**JIT)
def noise_texture(d, kind, normalize, x, y, z, w, detail, roughness, lacunarity, offset,
                  gain, distortion, colour):
    """Cycles' Noise Texture at the scaled point (x, y, z, w) (1D reads w): (Fac, and with
    `colour` the Color's other two channels). Distortion moves the point by signed noise
    at seeded offsets, a coordinate at a time; Color's green and blue are the fractal at
    two more seeded offsets."""
    detail = min(max(detail, 0.0), 15.0)
    roughness = max(roughness, 0.0)
    if d == 1:
        x, y, z, w = w, 0.0, 0.0, 0.0
    o = OFFSETS[d - 1]
    if distortion != 0.0:
        if d == 1:
            x += snoise(d, x + o[0, 0], 0.0, 0.0, 0.0) * distortion
        else:
            dx = snoise(d, x + o[0, 0], y + o[0, 1], z + o[0, 2], w + o[0, 3]) * distortion
            dy = snoise(d, x + o[1, 0], y + o[1, 1], z + o[1, 2], w + o[1, 3]) * distortion
            dz = dw = 0.0
            if d >= 3:
                dz = snoise(d, x + o[2, 0], y + o[2, 1], z + o[2, 2], w + o[2, 3]) * distortion
            if d == 4:
                dw = snoise(d, x + o[3, 0], y + o[3, 1], z + o[3, 2], w + o[3, 3]) * distortion
            x, y, z, w = x + dx, y + dy, z + dz, w + dw
    value = fractal(kind, d, x, y, z, w, detail, roughness, lacunarity, offset, gain,
                    normalize)
    if not colour:
        return value, value, value
    first = d  # the seeds after distortion's
    g = fractal(kind, d, x + o[first, 0], y + o[first, 1], z + o[first, 2], w + o[first, 3],
                detail, roughness, lacunarity, offset, gain, normalize)
    b = fractal(kind, d, x + o[first + 1, 0], y + o[first + 1, 1], z + o[first + 1, 2],
                w + o[first + 1, 3], detail, roughness, lacunarity, offset, gain, normalize)
    return value, g, b


@njit(**JIT)
def gradient(kind, x, y, z):
    """Cycles' Gradient Texture (kind: GRADIENT_TYPES index), clamped to [0, 1]."""
    if kind == 0:
        f = x
    elif kind == 1:
        r = max(x, 0.0)
        f = r * r
    elif kind == 2:
        r = min(max(x, 0.0), 1.0)
        t = r * r
        f = 3.0 * t - 2.0 * t * r
    elif kind == 3:
        f = (x + y) * 0.5
    elif kind == 6:
        f = math.atan2(y, x) / (2.0 * math.pi) + 0.5
    else:
        r = max(0.999999 - math.sqrt(x * x + y * y + z * z), 0.0)
        f = r * r if kind == 5 else r
    return min(max(f, 0.0), 1.0)


WAVE_TYPES = ("BANDS", "RINGS")
WAVE_BANDS = ("X", "Y", "Z", "DIAGONAL")
WAVE_RINGS = ("X", "Y", "Z", "SPHERICAL")
WAVE_PROFILES = ("SIN", "SAW", "TRI")


@njit(**JIT)
def wave(kind, bands, rings, profile, x, y, z, distortion, detail, dscale, droughness,
         phase):
    """Cycles' Wave Texture (svm_wave) at the scaled point: bands along an axis or the
    diagonal, or rings about an axis or the origin, 20 per unit, shifted by `phase` and
    distorted by normalized fBM noise (lacunarity 2); a sine, saw or triangle profile."""
    x, y, z = (x + 0.000001) * 0.999999, (y + 0.000001) * 0.999999, (z + 0.000001) * 0.999999
    if kind == 0:
        n = (x * 20.0 if bands == 0 else y * 20.0 if bands == 1 else z * 20.0 if bands == 2
             else (x + y + z) * 10.0)
    else:
        rx, ry, rz = (0.0 if rings == 0 else x), (0.0 if rings == 1 else y), \
            (0.0 if rings == 2 else z)
        n = math.sqrt(rx * rx + ry * ry + rz * rz) * 20.0
    n += phase
    if distortion != 0.0:
        # (np.int64, np.bool_: a literal argument would compile fractal a second time.)
        fbm = fractal(np.int64(3), np.int64(3), x * dscale, y * dscale, z * dscale, 0.0,
                      min(max(detail, 0.0), 15.0), droughness, 2.0, 0.0, 1.0, np.bool_(True))
        n += distortion * (fbm * 2.0 - 1.0)
    if profile == 0:
        return 0.5 + 0.5 * math.sin(n - 0.5 * math.pi)
    n /= 2.0 * math.pi
    if profile == 1:
        return n - math.floor(n)
    return abs(n - math.floor(n + 0.5)) * 2.0


@njit(**JIT)
def _fmod(p, m):
    return p - m * math.trunc(p / m)


@njit(**JIT)
def magic(x, y, z, scale, depth, distortion):
    """Cycles' Magic Texture (svm_magic): sines and cosines of the point folded into
    each other `depth` times, as an RGB colour about 0.5."""
    px, py, pz = _fmod(x, 2.0 * math.pi), _fmod(y, 2.0 * math.pi), _fmod(z, 2.0 * math.pi)
    a = math.sin((px + py + pz) * 5.0 * scale)
    b = math.cos((-px + py - pz) * 5.0 * scale)
    c = -math.cos((-px - py + pz) * 5.0 * scale)
    if depth > 0:
        a, b, c = a * distortion, b * distortion, c * distortion
        b = -math.cos(a - b + c) * distortion
        if depth > 1:
            a = math.cos(a - b - c) * distortion
        if depth > 2:
            c = math.sin(-a - b - c) * distortion
        if depth > 3:
            a = -math.cos(-a + b - c) * distortion
        if depth > 4:
            b = -math.sin(-a + b + c) * distortion
        if depth > 5:
            b = -math.cos(-a + b + c) * distortion
        if depth > 6:
            a = math.cos(a + b + c) * distortion
        if depth > 7:
            c = math.sin(a + b - c) * distortion
        if depth > 8:
            a = -math.cos(-a - b + c) * distortion
        if depth > 9:
            b = -math.sin(a - b + c) * distortion
    if distortion != 0.0:
        a, b, c = a / (2.0 * distortion), b / (2.0 * distortion), c / (2.0 * distortion)
    return 0.5 - a, 0.5 - b, 0.5 - c


# ----------------------------------------------------------------- white noise
@njit(**JIT)
def float_bits(x):
    """The bits of x rounded to float32, as an integer (C's __float_as_uint), without an
    array to view: sign, biased exponent and mantissa put together (subnormals, zeros,
    infinities and NaN included)."""
    f = float(np.float32(x))
    sign = 0x80000000 if math.copysign(1.0, f) < 0.0 else 0
    f = abs(f)
    if f != f:
        return 0x7FC00000
    if f == math.inf:
        return sign | 0x7F800000
    if f == 0.0:
        return sign
    m, e = math.frexp(f)  # f = m 2^e, m in [0.5, 1)
    if e + 126 <= 0:  # subnormal: f / 2^-149 is the mantissa
        return sign | int(f * 2.0 ** 149)
    return sign | ((e + 126) << 23) | int((m * 2.0 - 1.0) * 8388608.0)


@njit(**JIT)
def _hash_floats(n, x, y, z, w):
    """Cycles' hash_float(n)_to_float: the float32 bits of the first n keys hashed, in
    [0, 1] (uint_to_float_incl)."""
    h = hash_uint(n, float_bits(x), float_bits(y), float_bits(z), float_bits(w))
    return float(np.float32(h)) * 2.0 ** -32


@njit(**JIT)
def white_noise(d, x, y, z, w):
    """Cycles' White Noise Texture (svm_node_tex_white_noise) of dimension d (1D reads w):
    its Color (r, g, b); its Value is r. Each channel hashes the point with a channel
    number or its coordinates reordered, as util/hash.h's hash_float*_to_float3."""
    # (Counts as np.int64: literal ones would compile _hash_floats once per count.)
    n1, n2, n3, n4 = np.int64(1), np.int64(2), np.int64(3), np.int64(4)
    if d == 1:
        return (_hash_floats(n1, w, 0.0, 0.0, 0.0), _hash_floats(n2, w, 1.0, 0.0, 0.0),
                _hash_floats(n2, w, 2.0, 0.0, 0.0))
    if d == 2:
        return (_hash_floats(n2, x, y, 0.0, 0.0), _hash_floats(n3, x, y, 1.0, 0.0),
                _hash_floats(n3, x, y, 2.0, 0.0))
    if d == 3:
        return (_hash_floats(n3, x, y, z, 0.0), _hash_floats(n4, x, y, z, 1.0),
                _hash_floats(n4, x, y, z, 2.0))
    return (_hash_floats(n4, x, y, z, w), _hash_floats(n4, z, x, w, y),
            _hash_floats(n4, w, z, y, x))


# ----------------------------------------------------------------- object random numbers
def hash_string(text: str) -> int:
    """Cycles' hash_string: i = 37 i + c over the UTF-8 bytes, each a signed char as C
    reads it on x86 (bytes past 127 count negative), in 32 bits."""
    h = 0
    for byte in text.encode("utf-8"):
        h = (h * 37 + (byte - 256 if byte > 127 else byte)) & MASK
    return h


def object_random(name: str, instance_random_id: int | None = None) -> float:
    """The Object Info node's Random: Cycles' random_id, the depsgraph instance's own for an
    instance, else hash_uint2(hash_string(the object's name), 0), as a float32 times
    1 / 2^32 (Cycles' (float)random_id * (1.0f / (float)0xFFFFFFFF))."""
    rid = instance_random_id if instance_random_id is not None else \
        hash_uint.py_func(2, hash_string(name), 0, 0, 0) if hasattr(hash_uint, "py_func") \
        else hash_uint(2, hash_string(name), 0, 0, 0)
    return float(np.float32(rid & MASK) / np.float32(4294967296.0))


# ----------------------------------------------------------------- bricks
@njit(**JIT)
def _brick_noise(n):
    """Cycles' brick_noise: a fast integer hash of n to [0, 1), in 32-bit arithmetic."""
    n = (n + 1013) & 0x7FFFFFFF
    n = (n >> 13) ^ n
    nn = (n * ((n * n * 60493 + 19990303) & MASK) + 1376312589) & 0x7FFFFFFF
    return 0.5 * (nn / 1073741824.0)


@njit(**JIT)
def brick(x, y, mortar_size, mortar_smooth, bias, brick_width, row_height, offset_amount,
          offset_frequency, squash_amount, squash_frequency):
    """Cycles' Brick Texture (svm_brick) at the scaled point (x, y): (tint, mortar). Every
    offset_frequency-th row is shifted by offset_amount of a brick, every
    squash_frequency-th row's bricks are squash_amount as wide; a brick's tint is a hash
    of its row and column plus the bias; mortar is 1 within mortar_size of a brick's
    edge, smoothed over mortar_smooth of it."""
    row = int(math.floor(y / row_height))
    offset = 0.0
    if offset_frequency != 0 and squash_frequency != 0:
        if row % squash_frequency == 0:
            brick_width *= squash_amount
        if row % offset_frequency == 0:
            offset = brick_width * offset_amount
    column = int(math.floor((x + offset) / brick_width))
    bx = (x + offset) - brick_width * column
    by = y - row_height * row
    tint = min(max(_brick_noise(((row << 16) + (column & 0xFFFF)) & MASK) + bias, 0.0), 1.0)
    distance = min(min(bx, by), min(brick_width - bx, row_height - by))
    if distance >= mortar_size:
        return tint, 0.0
    if mortar_smooth == 0.0:
        return tint, 1.0
    f = (1.0 - distance / mortar_size) / mortar_smooth
    return tint, 0.0 if f <= 0.0 else (1.0 if f >= 1.0 else (3.0 - 2.0 * f) * f * f)

"""World lighting from an equirectangular environment image, importance-sampled.

Blender's mapping (Cycles' `direction_to_equirectangular`): for a direction d in the
texture's frame, u = 0.5 - atan2(d.y, d.x) / (2 pi), v = 0.5 + elevation / pi, with image
row 0 at the bottom (v = 0 looks straight down). Radiance is looked up with bilinear
interpolation (the Environment Texture node's default "Linear"), wrapping in u.

Sampling picks a pixel in proportion to the average of its RGB times cos(elevation) (the
solid angle it covers), as Cycles' background_cdf weighs its map, then a uniform point
inside it; the solid-angle density is p_pixel x W x H / (2 pi^2 cos(elevation)). The pdf
sets the MIS weights, and where light samples and bounces see different worlds (a Light
Path node in the world) the weights decide the image: they must be Cycles'.

`EnvironmentMap` builds the map's data once; the functions below work on one direction and
are compiled into the kernel.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from .jit import ALLOCATING, INLINE, JIT, njit
from .sampling import Distribution1D, sample_cdf, uniform_cone
from .scene import LUMINANCE
from .shading import (GENERATED, LIGHT_PATH_OUTPUTS, MAX_REGISTERS, NORMAL, OBJECT,
                      OP_LIGHT_PATH, POSITION, RAY_CAMERA, RAY_DIFFUSE, RAY_FLAG_COUNT,
                      RAY_GLOSSY, RAY_REFLECT, RAY_SINGULAR, RAY_TRANSMIT, RAY_VOLUME_SCATTER,
                      SKY_WITHOUT_SUN, TRUE_NORMAL, WIDTH, equirectangular,
                      equirectangular_direction, pack, run, set_geometry, set_light_path)

# The map as the kernel reads it: image (H, W, 3) float32, texture_from_world and
# world_from_texture (3, 3), pmf and cdf (H W,) of its pixel distribution, and the images
# rays of some kinds see instead: ray_images (K, H, W, 3) and image_of_flags (RAY_FLAGS,),
# the index into them of a ray of those path flags (shading.RAY_*), -1: image.
Environment = namedtuple("Environment", "image texture_from_world world_from_texture pmf "
                         "cdf ray_images image_of_flags")
# Every value of a path's flags (shading.RAY_*, 8 bits).
RAY_FLAGS = 1 << RAY_FLAG_COUNT
# The path flags a ray may carry when it leaves the scene (integrator.bounce_flags and
# count_bounce: Cycles' path_state_next): a camera ray, a diffuse, glossy or singular
# reflection or transmission, a volume scatter. A light sample's world is read without
# any (Cycles evaluates it with PATH_RAY_EMISSION alone), and so is `image`.
ESCAPING_RAYS = (RAY_CAMERA, RAY_DIFFUSE | RAY_REFLECT, RAY_DIFFUSE | RAY_TRANSMIT,
                 RAY_GLOSSY | RAY_REFLECT, RAY_GLOSSY | RAY_TRANSMIT,
                 RAY_GLOSSY | RAY_SINGULAR | RAY_REFLECT, RAY_GLOSSY | RAY_SINGULAR | RAY_TRANSMIT,
                 RAY_VOLUME_SCATTER)


class EnvironmentMap:
    """image : (H, W, 3) radiance (strength applied), row 0 at the bottom.
    texture_from_world : (3, 3) rotation taking world directions into the texture's frame
    (a Mapping node's rotation).
    ray_images : {path flags: (H, W, 3)} the radiance rays of those flags (shading.RAY_*)
    see instead (a world whose Light Path node tells rays apart), or None: the image for
    all. Only `image` is sampled: it is what light samples see."""

    def __init__(self, image: np.ndarray, texture_from_world: np.ndarray | None = None,
                 ray_images: dict | None = None):
        self.image = np.ascontiguousarray(image, np.float32)
        # One copy of each distinct map (several kinds of ray may share one).
        self.image_of_flags = np.full(RAY_FLAGS, -1, np.int64)
        stack, index = [], {}
        for flags, img in (ray_images or {}).items():
            if id(img) not in index:
                index[id(img)] = len(stack)
                stack.append(np.asarray(img, np.float32))
            self.image_of_flags[flags] = index[id(img)]
        self.ray_images = np.ascontiguousarray(
            np.stack(stack) if stack else np.zeros((0,) + self.image.shape, np.float32))
        self.height, self.width = self.image.shape[:2]
        m = np.eye(3) if texture_from_world is None else np.asarray(texture_from_world, float)
        self.texture_from_world = np.ascontiguousarray(m, np.float64)
        self.world_from_texture = np.ascontiguousarray(np.linalg.inv(m), np.float64)
        elevation = (np.arange(self.height) + 0.5) / self.height * np.pi - 0.5 * np.pi
        weight = pixel_weights(self.image) * np.cos(elevation)[:, None]
        weight = np.maximum(weight, 0.0)
        # A black map would leave nothing to sample: fall back to uniform over the sphere.
        if weight.sum() <= 0:
            weight = np.ones_like(weight) * np.cos(elevation)[:, None]
        self.distribution = Distribution1D(weight.ravel())
        self.mean_radiance = float(np.mean(self.image.astype(np.float64) @ LUMINANCE
                                           * np.cos(elevation)[:, None]) * np.pi / 2)

    def data(self) -> Environment:
        return Environment(self.image, self.texture_from_world, self.world_from_texture,
                           self.distribution.pmf, self.distribution.cdf, self.ray_images,
                           self.image_of_flags)


def pixel_weights(image: np.ndarray) -> np.ndarray:
    """(H, W) how much each texel of a map (H, W, 3) is sampled, per solid angle: the
    average of its RGB, Cycles' (background_cdf), not its luminance. Measured: with the
    luminance, a world telling diffuse bounces from light samples (world_ray_kinds) was 2 %
    off Cycles in green and blue, |z| 21.7."""
    return image.astype(np.float64).mean(axis=2)


FLOAT32_MAX = float(np.finfo(np.float32).max)
# What a world's shader reads in each coordinate map, as a multiple of the ray's direction D
# (Cycles' shader_setup_from_background: P = D, N = Ng = -D; the Texture Coordinate's
# Generated and Object are P there).
WORLD_MAPS = {POSITION: 1.0, GENERATED: 1.0, OBJECT: 1.0, NORMAL: -1.0, TRUE_NORMAL: -1.0}


def bake(program, width: int, height: int, flags: int = 0) -> np.ndarray:
    """(height, width, 3) float32: a world's radiance `program` (a shading.Program) run in
    the direction of each texel's centre, row 0 at the bottom: the map an EnvironmentMap
    samples. Its maps must be WORLD_MAPS'; the Geometry node reads N and the view
    direction as -D, the Light Path node a ray of `flags` (shading.RAY_*) of unbounded
    length. Negative results are 0, as an emission's are, and so are NaN and
    infinite ones and those beyond float32 (an Exponent node overflows), which the map
    would hold as inf. Sky Textures' sun discs are left out (`disc_irradiance`)."""
    image = np.empty((height, width, 3), np.float32)
    _bake(*_packed(program), program.out, flags, image)
    return image


def _packed(program):
    """(ProgramTable, signs of its maps) of a world's program (bake)."""
    unknown = [name for name in program.uv_maps if name not in WORLD_MAPS]
    if unknown:
        raise ValueError(f"a world's program cannot read the maps {unknown}")
    signs = np.array([WORLD_MAPS[name] for name in program.uv_maps] or [0.0])
    return pack([program], None, program.uv_maps.index), signs


def disc_irradiance(program, direction, diameter: float, flags: int = 0, rings: int = 128,
                    sectors: int = 8) -> np.ndarray:
    """(3,) the irradiance a world's sun disc (a Sky Texture's, which `bake` leaves out)
    of angular `diameter` centred on unit `direction` gives a surface facing it, as rays of
    path `flags` see the world (0: light samples): the world's radiance with the disc less
    that without it, times the cosine to the centre, integrated over the disc's cone
    (`rings` equal solid-angle rings of `sectors` points). A sun light of that irradiance
    and angle carries the disc's power; it is uniform where the disc darkens toward its
    limb."""
    d = np.asarray(direction, np.float64)
    d = d / np.linalg.norm(d)
    cos_max = math.cos(0.5 * diameter)
    # Stratified points of sampling.uniform_cone: rings equal in solid angle.
    cones = np.array([uniform_cone(d[0], d[1], d[2], cos_max, (i + 0.5) / rings,
                                   (j + 0.5) / sectors)
                      for i in range(rings) for j in range(sectors)])
    pt, signs = _packed(program)
    shaded = np.empty((2, len(cones), 3))
    for k, without_sun in enumerate((0.0, 1.0)):
        _shade(pt, signs, program.out, flags, without_sun,
               np.ascontiguousarray(cones[:, :3]), shaded[k])
    return (shaded[0] - shaded[1]).T @ cones[:, 3] / cones[0, 4] / len(cones)


def bake_rays(program, width: int, height: int) -> dict:
    """{path flags: (height, width, 3)} the maps of a world's radiance `program` that
    rays leaving the scene see where it tells them from light samples (bake of flags 0)
    by the Light Path node's Is ... Ray outputs: one bake per distinct reading of those
    outputs, shared by the kinds of ray (ESCAPING_RAYS) that read alike; {} where none
    differs. The program reads no other Light Path output (its ray length and depths
    differ along a path: a map cannot hold them)."""
    code = np.asarray(program.code, np.int64).reshape(-1, WIDTH)
    read = code[code[:, 0] == OP_LIGHT_PATH, 5]  # (the instruction's d: the output)
    if np.any(read >= RAY_FLAG_COUNT):
        raise ValueError(f"a world's program cannot read the Light Path's "
                         f"{LIGHT_PATH_OUTPUTS[int(read.max())]}")
    mask = int(np.bitwise_or.reduce(1 << read.astype(np.int64))) if len(read) else 0
    maps, by_reading = {}, {}
    for flags in ESCAPING_RAYS:
        reading = flags & mask
        if reading:
            if reading not in by_reading:
                by_reading[reading] = bake(program, width, height, reading)
            maps[flags] = by_reading[reading]
    return maps


@njit(**ALLOCATING)
def _bake(pt, signs, out, flags, image):
    """The program run in each texel's direction, without sun discs."""
    h, w = image.shape[0], image.shape[1]
    corners = np.zeros((len(signs), 1, 3, 3), np.float32)
    reg = np.zeros(MAX_REGISTERS)
    set_light_path(reg, flags, np.inf, 0, 0, 0, 0, 0)
    reg[SKY_WITHOUT_SUN] = 1.0
    for i in range(h):
        for j in range(w):
            x, y, z = equirectangular_direction((j + 0.5) / w, (i + 0.5) / h)
            _shade_direction(pt, signs, corners, reg, x, y, z)
            for c in range(3):
                image[i, j, c] = _radiance(reg[out + c])


@njit(**ALLOCATING)
def _shade(pt, signs, out, flags, without_sun, directions, result):
    """The program (as rays of path `flags` see it) run in each of `directions` (N, 3)
    into result (N, 3), with sun discs or without."""
    corners = np.zeros((len(signs), 1, 3, 3), np.float32)
    reg = np.zeros(MAX_REGISTERS)
    set_light_path(reg, flags, np.inf, 0, 0, 0, 0, 0)
    reg[SKY_WITHOUT_SUN] = without_sun
    for k in range(len(directions)):
        _shade_direction(pt, signs, corners, reg, directions[k, 0], directions[k, 1],
                         directions[k, 2])
        for c in range(3):
            result[k, c] = _radiance(reg[out + c])


@njit(**JIT)
def _shade_direction(pt, signs, corners, reg, x, y, z):
    """The direction into the maps (one "triangle" whose corners all hold it), then the
    program run there."""
    for m in range(len(signs)):
        for c in range(3):
            corners[m, 0, c, 0] = signs[m] * x
            corners[m, 0, c, 1] = signs[m] * y
            corners[m, 0, c, 2] = signs[m] * z
    set_geometry(reg, -x, -y, -z, -x, -y, -z, False)
    run(0, len(pt.code), pt, corners, 0, 0.0, 0.0, reg)


@njit(**JIT)
def _radiance(v):
    """A program's radiance as a map holds it: negative, NaN and float32-overflowing
    values are 0."""
    return v if 0.0 < v < FLOAT32_MAX else 0.0


@njit(**JIT)
def to_uv(dx, dy, dz, m):
    """Texture coordinates (u, v) of a world direction; m = texture_from_world."""
    x = dx * m[0, 0] + dy * m[0, 1] + dz * m[0, 2]
    y = dx * m[1, 0] + dy * m[1, 1] + dz * m[1, 2]
    z = dx * m[2, 0] + dy * m[2, 1] + dz * m[2, 2]
    u, v = equirectangular(x, y, z)
    return u % 1.0, min(max(v, 0.0), 1.0)


@njit(**INLINE)
def lookup(u, v, image):
    """Bilinear radiance at (u, v), wrapping in u."""
    h, w = image.shape[0], image.shape[1]
    x = u * w - 0.5
    y = min(max(v * h - 0.5, 0.0), h - 1.0)
    x0 = int(math.floor(x))
    y0 = min(int(math.floor(y)), h - 1)
    fx, fy = x - x0, y - y0
    x0 %= w
    x1 = (x0 + 1) % w
    y1 = min(y0 + 1, h - 1)
    a, b = 1 - fx, 1 - fy
    r0 = ((np.float64(image[y0, x0, 0]) * a + np.float64(image[y0, x1, 0]) * fx) * b
          + (np.float64(image[y1, x0, 0]) * a + np.float64(image[y1, x1, 0]) * fx) * fy)
    r1 = ((np.float64(image[y0, x0, 1]) * a + np.float64(image[y0, x1, 1]) * fx) * b
          + (np.float64(image[y1, x0, 1]) * a + np.float64(image[y1, x1, 1]) * fx) * fy)
    r2 = ((np.float64(image[y0, x0, 2]) * a + np.float64(image[y0, x1, 2]) * fx) * b
          + (np.float64(image[y1, x0, 2]) * a + np.float64(image[y1, x1, 2]) * fx) * fy)
    return r0, r1, r2


@njit(**JIT)
def pixel_pdf(u, v, pk, w, h):
    """The solid-angle density at (u, v) of a pixel of probability pk."""
    cos_el = math.cos((v - 0.5) * np.pi)
    return pk * w * h / (2.0 * np.pi**2 * max(cos_el, 1e-12))


@njit(**INLINE)
def pdf(u, v, env):
    """The solid-angle density of `sample` at texture coordinates (u, v)."""
    h, w = env.image.shape[0], env.image.shape[1]
    col = min(int(u * w), w - 1)
    row = min(int(v * h), h - 1)
    return pixel_pdf(u, v, env.pmf[row * w + col], w, h)


@njit(**INLINE)
def sample(ua, ub, env):
    """A pixel by average RGB x solid angle (ua; its remainder reused for x), a point in it
    (ub for the row position): the world direction and its solid-angle pdf."""
    h, w = env.image.shape[0], env.image.shape[1]
    k = sample_cdf(env.cdf, ua)
    cdf_lo = env.cdf[k - 1] if k > 0 else 0.0
    pk = env.pmf[k]
    fx = min(max((ua - cdf_lo) / (pk if pk > 0 else 1.0), 0.0), 1.0 - 1e-12)
    row, col = k // w, k % w
    u = (col + fx) / w
    v = (row + ub) / h
    x, y, z = equirectangular_direction(u, v)
    m = env.world_from_texture
    return (x * m[0, 0] + y * m[0, 1] + z * m[0, 2], x * m[1, 0] + y * m[1, 1] + z * m[1, 2],
            x * m[2, 0] + y * m[2, 1] + z * m[2, 2], pixel_pdf(u, v, pk, w, h))

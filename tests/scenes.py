"""Scenes built directly as engine arrays (no bpy), shared by tests and benchmarks.

The Cornell box follows the course project rebuilt in Blender's z-up frame: x in
[-1, 1], depth y in [-1, 1] (front open at y = -1), height z in [0, 1.5].
"""

from __future__ import annotations

import math

import numpy as np

from engine import Camera, Material, RenderSettings, SceneBuilder, World


def quad(p0, p1, p2, p3):
    """Two triangles for a quad p0 p1 p2 p3 (counter-clockwise seen from the front)."""
    return np.array([p0, p1, p2, p3], float), np.array([[0, 1, 2], [0, 2, 3]])


def closed_box(lo, hi):
    """Vertices (8, 3) and triangles (12, 3) of the box lo..hi, wound counter-clockwise seen
    from outside (outward geometric normals: crossing into it is crossing a front face)."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    v = np.array([[x0, y0, z0], [x1, y0, z0], [x1, y1, z0], [x0, y1, z0],
                  [x0, y0, z1], [x1, y0, z1], [x1, y1, z1], [x0, y1, z1]], float)
    faces = [(0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (2, 3, 7, 6), (1, 2, 6, 5), (0, 4, 7, 3)]
    return v, np.array([t for a, b, c, d in faces for t in ((a, b, c), (a, c, d))])


def uv_sphere(centre, radius, segments=48, rings=24):
    """Vertices (n, 3), triangles (t, 3) and per-corner normals (t, 3, 3)."""
    th = np.linspace(0, np.pi, rings + 1)
    ph = np.linspace(0, 2 * np.pi, segments + 1)
    T, P = np.meshgrid(th, ph, indexing="ij")
    n = np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], -1).reshape(-1, 3)
    idx = np.arange(len(n)).reshape(rings + 1, segments + 1)
    a, b = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel()
    c, d = idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    tris = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    v = np.asarray(centre, float) + radius * n
    # Drop the degenerate triangles at the poles (the builder would drop them anyway).
    area = np.linalg.norm(np.cross(v[tris[:, 1]] - v[tris[:, 0]], v[tris[:, 2]] - v[tris[:, 0]]),
                          axis=1)
    tris = tris[area > 1e-12 * radius * radius]
    return v, tris, n[tris]


def look_at(eye, target, up=(0, 0, 1)):
    """A Blender camera matrix_world: local -Z toward target, +Y up."""
    eye, target, up = (np.asarray(x, float) for x in (eye, target, up))
    fwd = target - eye
    fwd /= np.linalg.norm(fwd)
    right = np.cross(fwd, up)
    right /= np.linalg.norm(right)
    true_up = np.cross(right, fwd)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = right, true_up, -fwd, eye
    return m


def lens_for_fov(fov_deg, sensor=36.0):
    return sensor / (2 * math.tan(math.radians(fov_deg) / 2))


def cornell_box(builder: SceneBuilder | None = None, emitter_radiance=10.0, spheres=True,
                glass_ior=1.45, mirror=True, glass=True, light_half=(0.4, 0.3), light_z=1.49,
                light_mesh=True, glass_roughness=0.0):
    b = builder or SceneBuilder()
    grey = b.add_material(Material.diffuse("white", (0.6, 0.6, 0.6)))
    red = b.add_material(Material.diffuse("red", (0.6, 0.2, 0.2)))
    blue = b.add_material(Material.diffuse("blue", (0.2, 0.2, 0.6)))
    light = b.add_material(Material.emission_only("light", (1, 1, 1), emitter_radiance))
    hx, hy = light_half
    walls = [
        ("floor", quad((-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)), grey),
        ("ceiling", quad((-1, -1, 1.5), (-1, 1, 1.5), (1, 1, 1.5), (1, -1, 1.5)), grey),
        ("back", quad((-1, 1, 0), (1, 1, 0), (1, 1, 1.5), (-1, 1, 1.5)), grey),
        ("left", quad((-1, -1, 0), (-1, 1, 0), (-1, 1, 1.5), (-1, -1, 1.5)), red),
        ("right", quad((1, -1, 0), (1, -1, 1.5), (1, 1, 1.5), (1, 1, 0)), blue),
        ("light", quad((-hx, -hy, light_z), (-hx, hy, light_z), (hx, hy, light_z),
                       (hx, -hy, light_z)),
         light),
    ]
    for name, (v, t), m in walls if light_mesh else walls[:-1]:
        b.add_mesh(name, v, t, m)
    if spheres:
        if mirror:
            mm = b.add_material(Material.mirror("mirror", (1, 1, 1)))
            v, t, n = uv_sphere((-0.45, 0.2, 0.3), 0.3)
            b.add_mesh("mirror sphere", v, t, mm, corner_normals=n)
        if glass:
            gm = b.add_material(Material.glass("glass", (1, 1, 1), glass_ior,
                                               roughness=glass_roughness))
            v, t, n = uv_sphere((0.45, -0.2, 0.3), 0.3)
            b.add_mesh("glass sphere", v, t, gm, corner_normals=n)
    return b


def cornell_camera(**kw):
    kw = {"sensor_fit": "HORIZONTAL", **kw}
    return Camera(world_from_camera=look_at((0, -3, 0.75), (0, 0, 0.75)),
                  lens_mm=lens_for_fov(49.13), **kw)


def cbspheres(**kw):
    return cornell_box(**kw).build(cornell_camera(), World((0, 0, 0)))


def caustic_box(light_half=0.05, light_z=1.2, **kw):
    """CBspheres lit by a small quad (2 light_half wide, at height light_z) as bright in
    total as the usual one: the caustics under the glass sphere and beside the mirror
    sphere come from paths path tracing finds rarely (issue 16's scenes). The quad emits
    from both faces, as mesh lights do; 1 cm under the ceiling (light_z 1.49) its back face
    makes a hot spot there that lights the room as a second small, bright source."""
    radiance = 10.0 * (0.8 * 0.6) / (4 * light_half * light_half)
    return cornell_box(emitter_radiance=radiance, light_half=(light_half, light_half),
                       light_z=light_z, **kw).build(cornell_camera(), World((0, 0, 0)))


def caustic_box_area_light(light_half=0.2, light_z=1.2):
    """caustic_box with a Blender area light (a square facing down, as bright toward the
    floor as the quad's lower face) in place of the emissive quad."""
    from engine import Light

    radiance = 10.0 * (0.8 * 0.6) / (4 * light_half * light_half)
    power = radiance * np.pi * (2 * light_half) ** 2  # one-sided: P = pi A L
    b = cornell_box(light_mesh=False)
    b.add_light(Light("panel", "AREA", (power,) * 3,
                      look_at((0, 0, light_z), (0, 0, light_z - 1), up=(0, 1, 0)),
                      size_x=2 * light_half))
    return b.build(cornell_camera(), World((0, 0, 0)))


def caustic_box_sphere_light(radius=0.2, light_z=1.2, soft_falloff=True):
    """caustic_box with a Blender point light of the given radius (Soft Falloff on: a disk
    facing each point it lights; off: a sphere) in place of the quad, about as bright."""
    from engine import Light

    b = cornell_box(light_mesh=False)
    m = np.eye(4)
    m[:3, 3] = (0.0, 0.0, light_z)
    b.add_light(Light("bulb", "POINT", (30.0,) * 3, m, radius=radius,
                      soft_falloff=soft_falloff))
    return b.build(cornell_camera(), World((0, 0, 0)))


def caustic_box_spot(radius=0.15, soft_falloff=False):
    """caustic_box lit by a 70-degree spot light of the given radius above the glass sphere
    and aimed at it (a sphere light by default: Soft Falloff off)."""
    from engine import Light

    b = cornell_box(light_mesh=False)
    b.add_light(Light("spot", "SPOT", (60.0,) * 3,
                      look_at((0.3, -0.3, 1.3), (0.45, -0.2, 0.3), up=(0, 1, 0)),
                      radius=radius, soft_falloff=soft_falloff, spot_size=math.radians(70.0)))
    return b.build(cornell_camera(), World((0, 0, 0)))


def sun_caustic_scene(angle_degrees=30.0, strength=3.0):
    """A glass sphere and a mirror sphere on a floor in the sun (30 degrees from the
    zenith, of the given angular diameter), seen from above; black world."""
    from engine import Light

    b = SceneBuilder()
    grey = b.add_material(Material.diffuse("floor", (0.6, 0.6, 0.6)))
    v, t = quad((-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0))
    b.add_mesh("floor", v, t, grey)
    gm = b.add_material(Material.glass("glass", (1, 1, 1), 1.5))
    v, t, n = uv_sphere((0.0, 0.0, 0.3), 0.3)
    b.add_mesh("glass sphere", v, t, gm, corner_normals=n)
    mm = b.add_material(Material.mirror("mirror", (1, 1, 1)))
    v, t, n = uv_sphere((0.75, 0.35, 0.2), 0.2)
    b.add_mesh("mirror sphere", v, t, mm, corner_normals=n)
    toward = np.array([-math.sin(math.radians(30)), 0.3, math.cos(math.radians(30))])
    b.add_light(Light("sun", "SUN", (strength,) * 3, look_at(toward, (0, 0, 0), up=(0, 1, 0)),
                      angle=math.radians(angle_degrees)))
    cam = Camera(world_from_camera=look_at((0.3, -2.2, 2.0), (0.3, 0.0, 0.15)),
                 lens_mm=lens_for_fov(40.0), sensor_fit="HORIZONTAL")
    return b.build(cam, World((0, 0, 0)))


def pane_under_glowing_ceiling(material, camera_z):
    """A large quad at z = 0 wearing `material` under a larger emitter of radiance 1 at z = 1
    (a black world), seen head-on by an orthographic camera at height camera_z looking at
    it (from below where camera_z < 0): every camera ray meets the pane at normal
    incidence."""
    b = SceneBuilder()
    v, t = quad((-50, -50, 0), (50, -50, 0), (50, 50, 0), (-50, 50, 0))
    b.add_mesh("pane", v, t, b.add_material(material))
    v, t = quad((-500, -500, 1), (-500, 500, 1), (500, 500, 1), (500, -500, 1))
    b.add_mesh("ceiling", v, t, b.add_material(Material.emission_only("sky", (1, 1, 1), 1.0)))
    cam = Camera(type="ORTHO", ortho_scale=2.0,
                 world_from_camera=look_at((0, 0, camera_z), (0, 0, 0), up=(0, 1, 0)))
    return b.build(cam, World((0.0, 0.0, 0.0)))


def settings(**kw):
    base = dict(width=96, height=72, samples=8, max_bounces=8, seed=1)
    base.update(kw)
    return RenderSettings(**base)


def checker_texels(n=8, c1=(0.9, 0.6, 0.1), c2=(0.1, 0.3, 0.8)):
    """An n x n image (h, w, 4) of two colours in squares, with a red texel at (0, 0) and a
    green one at the top right, so a flipped or transposed lookup shows."""
    iy, ix = np.mgrid[0:n, 0:n]
    texels = np.where(((ix + iy) % 2 == 0)[..., None], c1, c2)
    texels[0, 0] = (1.0, 0.0, 0.0)
    texels[n - 1, n - 1] = (0.0, 1.0, 0.0)
    return np.concatenate([texels, np.ones((n, n, 1))], axis=2).astype(np.float32)


def image_program(texels, interpolation="Closest", extension="REPEAT", srgb=False,
                  scale=1.0):
    """A colour program: the image on the default UV map, coordinates scaled by `scale`
    (a Mapping node's Scale)."""
    from engine.shading import OP_MAPPING, Program, Texture
    p = Program()
    uv = p.uv("")
    if scale != 1.0:
        uv = p.emit(OP_MAPPING, 3, a=uv, params=[scale, 0, 0, 0, 0, scale, 0, 0, 0, 0, scale, 0])
    p.out = p.image(Texture("checker", texels, interpolation, extension, srgb), uv, False)
    return p


def quad_uvs():
    """Per-corner UVs (2, 3, 2) of `quad`'s two triangles: p0 (0, 0) .. p2 (1, 1)."""
    corners = np.array([(0, 0), (1, 0), (1, 1), (0, 1)], float)
    return corners[np.array([[0, 1, 2], [0, 2, 3]])]


def textured_box(interpolation="Closest", extension="REPEAT", srgb=False, scale=1.0,
                 kind="diffuse", texels=None, textured_light=False):
    """The Cornell box with spheres whose back wall and floor carry an image texture
    (`checker_texels`) on their own UVs; with `textured_light` its ceiling light's emission
    is the texture too (radiance 10 x texel)."""
    b = cornell_box(light_mesh=not textured_light)
    texels = checker_texels() if texels is None else texels
    prog = image_program(texels, interpolation, extension, srgb, scale)
    mean = tuple(float(c) for c in texels[..., :3].reshape(-1, 3).mean(axis=0))
    if textured_light:
        from engine.shading import OP_BLEND
        glow = image_program(texels, interpolation, extension, srgb)
        fac, ten = glow.const([1.0]), glow.const([10.0] * 3)
        glow.out = glow.emit(OP_BLEND, 3, a=fac, b=glow.out, c=ten, d=2)  # Multiply
        light = b.add_material(Material.emission_only("textured light", mean, 10.0,
                                                      emission_program=glow))
        v, t = quad((-0.4, -0.3, 1.49), (-0.4, 0.3, 1.49), (0.4, 0.3, 1.49), (0.4, -0.3, 1.49))
        b.add_mesh("textured light", v, t, light, uv_maps={"": quad_uvs()})
    if kind == "diffuse":
        mat = Material.diffuse("textured", mean, colour_program=prog)
    else:
        mat = Material.principled("textured", mean, roughness=0.4, colour_program=prog)
    m = b.add_material(mat)
    for name, corners in (("textured back", ((-1, 0.99, 0), (1, 0.99, 0), (1, 0.99, 1.5),
                                               (-1, 0.99, 1.5))),
                          ("textured floor", ((-1, -1, 0.001), (1, -1, 0.001), (1, 1, 0.001),
                                              (-1, 1, 0.001)))):
        v, t = quad(*corners)
        b.add_mesh(name, v, t, m, uv_maps={"": quad_uvs()})
    return b.build(cornell_camera(), World((0, 0, 0)))


def normal_map_texels(n=8, tilt=0.6):
    """An n x n tangent-space normal map (h, w, 4) of vertical stripes tilted alternately
    toward +u and -u by `tilt` (the normal (+-tilt, 0, sqrt(1 - tilt^2)) as (N + 1) / 2)."""
    z = np.sqrt(1.0 - tilt * tilt)
    ix = np.mgrid[0:n, 0:n][1]
    x = np.where(ix % 2 == 0, tilt, -tilt)
    texels = np.stack([(x + 1) / 2, np.full_like(x, 0.5), np.full_like(x, (z + 1) / 2),
                       np.ones_like(x)], axis=-1)
    return texels.astype(np.float32)


def normal_mapped_box(kind="diffuse", strength=1.0, texels=None, height=None):
    """The Cornell box (no spheres) whose floor carries a striped normal map on its UVs
    (tangent +x, bitangent sign +1), in a diffuse or a rough Principled material; with a
    `height` program, that bump map in place of the normal map."""
    b = cornell_box(spheres=False)
    prog = image_program(normal_map_texels() if texels is None else texels, "Linear")
    if kind == "diffuse":
        mat = Material.diffuse("bumpy", (0.7, 0.7, 0.7))
    else:
        mat = Material.principled("bumpy", (0.7, 0.7, 0.7), roughness=0.3)
    from dataclasses import replace
    tilt = {"height_program": height} if height is not None else \
        {"normal_program": prog, "normal_strength": strength}
    m = b.add_material(replace(mat, **tilt))
    v, t = quad((-1, -1, 0.001), (1, -1, 0.001), (1, 1, 0.001), (-1, 1, 0.001))
    tangents = np.zeros((2, 3, 4))
    tangents[..., 0], tangents[..., 3] = 1.0, 1.0
    b.add_mesh("bumpy floor", v, t, m, uv_maps={"": quad_uvs()}, tangents=tangents)
    return b.build(cornell_camera(), World((0, 0, 0)))

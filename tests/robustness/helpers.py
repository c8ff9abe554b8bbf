"""Scenes and checks shared by the robustness tests (numpy-built, no bpy)."""

from __future__ import annotations

import numpy as np

from engine import Camera, Material, RenderSettings, SceneBuilder, World, render
from tests.scenes import look_at, quad, uv_sphere

LUM = np.array([0.2126, 0.7152, 0.0722])


def all_finite(result) -> bool:
    """Every pass of a RenderResult is free of NaN and inf."""
    return all(np.isfinite(a).all() for a in (result.combined, result.depth, result.normal,
                                               result.error, result.variance))


def image_mean_and_error(result):
    """Mean luminance over the image and its standard error (pixels independent)."""
    lum = result.combined[..., :3] @ LUM
    return float(lum.mean()), float(np.sqrt(np.sum(result.error.astype(float) ** 2)) / lum.size)


def cube(b: SceneBuilder, name: str, material: int, half=1.0, centre=(0.0, 0.0, 0.0)):
    """A closed axis-aligned cube, faces wound outward."""
    v = np.array([[x, y, z] for x in (-half, half) for y in (-half, half) for z in (-half, half)])
    faces = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    tris = [t for a, b_, c, d in faces for t in ((a, b_, c), (a, c, d))]
    b.add_mesh(name, v + np.asarray(centre), np.array(tris), material)


def sphere(b: SceneBuilder, name: str, material: int, centre=(0, 0, 0), radius=1.0,
           segments=64, rings=32):
    v, t, n = uv_sphere(centre, radius, segments=segments, rings=rings)
    b.add_mesh(name, v, t, material, corner_normals=n)


def render_sphere_in_world(material: Material, world=(1.0, 1.0, 1.0), eye=(0, -4, 0),
                           max_bounces=64, samples=4, size=(32, 24), seed=7, lens_mm=50.0):
    """A unit sphere of `material` in a uniform world (the white-furnace test)."""
    b = SceneBuilder()
    m = b.add_material(material)
    sphere(b, "sphere", m)
    cam = Camera(world_from_camera=look_at(eye, (0, 0, 0.01)), lens_mm=lens_mm,
                 clip_start=1e-3)
    return render(b.build(cam, World(world)),
                  RenderSettings(width=size[0], height=size[1], samples=samples,
                                 max_bounces=max_bounces, seed=seed))


__all__ = ["Camera", "Material", "RenderSettings", "SceneBuilder", "World", "look_at", "quad",
           "render", "uv_sphere"]

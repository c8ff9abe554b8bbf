"""Validation at the scene boundary."""

import warnings

import numpy as np
import pytest

from engine import Camera, Material, RenderSettings, SceneBuilder, World

TRI = np.array([[0, 1, 2]])


def test_nan_and_degenerate_triangles_are_dropped_and_counted():
    b = SceneBuilder()
    m = b.add_material(Material.diffuse("grey", (0.5, 0.5, 0.5)))
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [np.nan, 0, 0], [2, 0, 0], [np.inf, 1, 1]])
    tris = np.array([[0, 1, 2], [3, 1, 2], [0, 1, 4], [5, 0, 1], [0, 0, 2]])
    with pytest.warns(UserWarning, match=r"object 'Suzanne': dropped 4 of 5 triangles "
                                         r"\(2 with NaN/inf vertices, 2 degenerate\)"):
        kept = b.add_mesh("Suzanne", v, tris, m)
    assert kept == 1
    scene = b.build(Camera(), World())
    assert scene.num_triangles == 1 and "Suzanne" in scene.warnings[0]


def test_shared_vertex_mesh_is_the_same_triangles():
    """The indexed copy embree is built from gives exactly the kept triangles' corners, in
    order, across meshes and after dropping bad triangles."""
    b = SceneBuilder()
    m = b.add_material(Material.diffuse("grey", (0.5, 0.5, 0.5)))
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [np.nan, 0, 0], [2, 0, 0], [0, 3, 1.0]])
    with pytest.warns(UserWarning):
        b.add_mesh("a", v, np.array([[0, 1, 2], [3, 1, 2], [0, 0, 2], [4, 5, 0]]), m)
    b.add_mesh("b", v[[1, 4, 5]] + 10.0, np.array([[0, 1, 2], [2, 1, 0]]), m)
    s = b.build(Camera(), World())
    assert s.num_triangles == 4
    np.testing.assert_array_equal(s.shared_vertices[s.shared_triangles], s.vertices)
    assert np.isfinite(s.shared_vertices).all()


def test_geometry_is_recentred_before_the_float32_cast():
    b = SceneBuilder()
    b.add_material(Material.diffuse("grey", (0.5, 0.5, 0.5)))
    v = np.array([[1e5, 1e5, 1e5], [1e5 + 1, 1e5, 1e5], [1e5, 1e5 + 1, 1e5]])
    s = b.build(Camera(), World()) if b.add_mesh("far", v, TRI, 0) else None
    assert np.abs(s.vertices).max() <= 1.0
    assert np.allclose(s.vertices[0] + s.origin, v)


@pytest.mark.parametrize("material,needle", [
    (Material.glass("Glass", ior=0.0), "IOR"),
    (Material.glass("Glass", ior=-1.5), "IOR"),
    (Material.glass("Glass", ior=float("nan")), "IOR"),
    (Material.diffuse("Paint", (-0.1, 0.5, 0.5)), "negative"),
    (Material.diffuse("Paint", (np.nan, 0.5, 0.5)), "finite"),
])
def test_invalid_materials_raise_naming_the_material(material, needle):
    b = SceneBuilder()
    b.add_material(material)
    with pytest.raises(ValueError, match=needle) as e:
        b.build(Camera(), World())
    assert material.name in str(e.value)


@pytest.mark.parametrize("camera,needle", [
    (Camera(use_dof=True, fstop=0.0), "fstop"),
    (Camera(use_dof=True, fstop=-2.0), "fstop"),
    (Camera(lens_mm=0.0), "lens_mm"),
    (Camera(sensor_fit="DIAGONAL"), "sensor fit"),
    (Camera(clip_start=5.0, clip_end=1.0), "clip"),
])
def test_invalid_cameras_raise_naming_the_value(camera, needle):
    with pytest.raises(ValueError, match=needle):
        SceneBuilder().build(camera, World())


@pytest.mark.parametrize("kw,needle", [
    (dict(width=0), "width"), (dict(height=0), "height"), (dict(samples=0), "samples"),
    (dict(max_bounces=-1), "max_bounces"), (dict(fresnel="fast"), "fresnel"),
    (dict(filter_width=0.0), "filter_width"), (dict(filter_type="MITCHELL"), "filter_type"),
])
def test_invalid_settings_raise_naming_the_value(kw, needle):
    with pytest.raises(ValueError, match=needle):
        RenderSettings(**kw).validate()


def test_world_colour_must_be_valid():
    with pytest.raises(ValueError, match="world colour"):
        SceneBuilder().build(Camera(), World((-1, 0, 0)))


def test_bad_shading_normals_fall_back_to_flat():
    b = SceneBuilder()
    b.add_material(Material.diffuse("grey", (0.5, 0.5, 0.5)))
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0.0]])
    normals = np.array([[[0, 0, 1], [0, 0, 0], [0, 0, 1.0]]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        b.add_mesh("flat", v, TRI, 0, corner_normals=normals)
    s = b.build(Camera(), World())
    assert not s.smooth.any() and s.normals is None


def test_core_never_imports_bpy():
    """The core runs without Blender: importing and rendering pulls in no bpy."""
    import subprocess
    import sys
    from pathlib import Path

    code = ("import sys\nsys.modules['bpy'] = None  # any import of bpy now fails\n"
            "from engine import render, World\nfrom tests import scenes\n"
            "render(scenes.cbspheres(), scenes.settings(width=8, height=6, samples=1))\n"
            "print('ok')")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=str(Path(__file__).parents[2]))
    assert out.returncode == 0 and out.stdout.strip() == "ok", out.stderr

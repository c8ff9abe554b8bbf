"""Render farms: a frame rendered as four border regions, each by its own `blender -b`
process (cropped to the border, as Flamenco and Deadline tile jobs do), stitches into
exactly the whole-frame render, because each pixel's samples depend only on (seed, pixel,
sample). Uses Debian's Blender 3.4 with the legacy add-on.

The core's own renders are bit-identical for any region or chunking (see
tests/engine/test_render.py::test_regions_stitch_into_the_whole_frame). Blender 3.4 itself
is not: it accumulates smooth vertex normals over its worker threads, so the spheres'
normals differ in the last float32 bit from one `blender -b` run to the next (measured:
six runs of cbspheres.blend gave six different hashes of MirrorSphere's and GlassSphere's
normals; Blender 5.0.1 gives one). That changed 9-25 of 10,800 pixels by ~4e-7 relative
between whole-frame runs, whatever the region. With `-t 1` Blender's own threads run one
after another and its normals repeat exactly (six runs, one hash); Specula's render threads
are its own setting (0: every core), so the renders still run on both cores. The
comparison is then exact.
"""

import os

import numpy as np
import pytest

from . import helpers

pytestmark = pytest.mark.slow

# Uneven splits, so the pixel edges come from Blender's own float32 rounding.
SPLIT_X, SPLIT_Y = 0.37, 0.61
SETUP = ("import bpy; s = bpy.context.scene; s.specula.samples = 4; "
         "s.render.resolution_percentage = 25; r = s.render; ")


def render(env, out, border=None, crop=True):
    code = SETUP
    if border is not None:
        code += ("r.use_border = True; r.use_crop_to_border = {}; "
                 "(r.border_min_x, r.border_max_x, r.border_min_y, r.border_max_y) = {}"
                 ).format(crop, tuple(border))
    scene = os.path.join(helpers.SCENES_34, "cbspheres.blend")
    # -t 1: Blender 3.4's threaded normal accumulation repeats only on one thread (above).
    helpers.run([helpers.BLENDER, "-b", scene, "-t", "1", "-E", "SPECULA", "--python-expr", code,
                 "-o", out + "_####", "-F", "OPEN_EXR", "-f", "1"], env=env)
    return out + "_0001.exr"


def assert_same_image(actual, expected):
    """The same image, to the last bit."""
    np.testing.assert_array_equal(actual, expected)


def pixel_edges(fraction, size):
    return int(np.float32(fraction) * np.float32(size))  # Blender's border arithmetic


def test_four_regions_stitch_into_the_whole_frame(blender34, tmp_path):
    whole = render(blender34, str(tmp_path / "whole"))
    tiles = {}
    for i, (x0, x1) in enumerate(((0.0, SPLIT_X), (SPLIT_X, 1.0))):
        for j, (y0, y1) in enumerate(((0.0, SPLIT_Y), (SPLIT_Y, 1.0))):
            tiles[i, j] = render(blender34, str(tmp_path / f"tile{i}{j}"), (x0, x1, y0, y1))
    images = helpers.read_images([whole, *tiles.values()])
    full = images[whole]
    h, w = full.shape[:2]
    assert (w, h) == (120, 90)
    assert full[..., :3].mean() > 0.05
    sx, sy = pixel_edges(SPLIT_X, w), pixel_edges(SPLIT_Y, h)
    # Row 0 at the bottom (Blender's order): tile (i, j) is column block i, row block j.
    stitched = np.zeros_like(full)
    for (i, j), path in tiles.items():
        xs = slice(0, sx) if i == 0 else slice(sx, w)
        ys = slice(0, sy) if j == 0 else slice(sy, h)
        tile = images[path]
        assert tile.shape[:2] == (ys.stop - ys.start, xs.stop - xs.start)
        stitched[ys, xs] = tile
    assert_same_image(stitched, full)


def test_border_without_crop_keeps_the_frame_size(blender34, tmp_path):
    whole = render(blender34, str(tmp_path / "whole"))
    border = (0.25, 0.75, 0.5, 1.0)
    part = render(blender34, str(tmp_path / "part"), border, crop=False)
    images = helpers.read_images([whole, part])
    full, image = images[whole], images[part]
    assert image.shape == full.shape
    h, w = full.shape[:2]
    xs = slice(pixel_edges(border[0], w), pixel_edges(border[1], w))
    ys = slice(pixel_edges(border[2], h), pixel_edges(border[3], h))
    assert_same_image(image[ys, xs], full[ys, xs])
    outside = np.ones((h, w), bool)
    outside[ys, xs] = False
    assert not image[outside].any()

"""The report helpers draw what they are asked to (no bpy: pure numpy)."""

import struct
import zlib

import numpy as np

from addon import imaging


def _read_png(path):
    data = open(path, "rb").read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    w, h = struct.unpack(">II", data[16:24])
    idat = data[data.index(b"IDAT") + 4:data.index(b"IEND") - 8]
    raw = np.frombuffer(zlib.decompress(idat), np.uint8).reshape(h, 1 + 3 * w)
    assert (raw[:, 0] == 0).all()
    return raw[:, 1:].reshape(h, w, 3)


def test_png_round_trip(tmp_path, rng):
    img = rng.integers(0, 256, (7, 5, 3), dtype=np.uint8)
    imaging.write_png(str(tmp_path / "x.png"), img)
    assert np.array_equal(_read_png(str(tmp_path / "x.png")), img)


def test_srgb_matches_the_standard_view_transform():
    assert imaging.srgb(np.array([[0.0, 0.18, 1.0]]))[0].tolist() == [0, 118, 255]


def test_contact_sheet_places_every_image():
    tiles = [[np.full((10, 12, 3), 50 * (i + j), np.uint8) for j in range(3)] for i in range(2)]
    sheet = imaging.contact_sheet(tiles, ["A", "B"], ["1", "2", "3"], title="T")
    for i in range(2):
        for j in range(3):
            assert (sheet == 50 * (i + j)).all(axis=2).sum() >= 120 or 50 * (i + j) == 0


def test_loglog_plot_draws_each_series():
    img = imaging.loglog_plot({"A": ([1, 2, 4], [0.1, 0.07, 0.05]),
                               "B": ([1, 2, 4], [0.05, 0.035, 0.025])}, "t", "s", "e")
    for colour in imaging._PALETTE[:2]:
        assert (img == colour).all(axis=2).sum() > 50

"""Minimal PNG output for engine tests and benchmarks (no bpy in the core's tests)."""

from __future__ import annotations

import struct
import zlib

import numpy as np


def srgb_encode(linear: np.ndarray) -> np.ndarray:
    x = np.clip(linear, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)


def write_png(path, rgb_linear: np.ndarray) -> None:
    """Write an (H, W, 3|4) linear image stored bottom row first as an 8-bit sRGB PNG."""
    img = (srgb_encode(np.asarray(rgb_linear)[..., :3]) * 255 + 0.5).astype(np.uint8)[::-1]
    h, w = img.shape[:2]
    raw = b"".join(b"\x00" + img[y].tobytes() for y in range(h))

    def chunk(tag, data):
        c = struct.pack(">I", len(data)) + tag + data
        return c + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)

    png = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
           + chunk(b"IDAT", zlib.compress(raw, 6)) + chunk(b"IEND", b""))
    with open(path, "wb") as f:
        f.write(png)

"""Small image utilities for reports: PNG writing, display encoding, contact sheets, text
and log-log line plots, in numpy alone (no bpy, no matplotlib).

Images are (H, W, 3) arrays with row 0 at the TOP here; `flip` renders' bottom-up rows
before use. PNGs are 8-bit RGB written with zlib.

Part of the add-on because `python -m addon compare` draws its report with it (the packaged
add-on has neither matplotlib nor the tests); the benchmarks and test reports use it too.
"""

from __future__ import annotations

import math
import struct
import zlib

import numpy as np


def write_png(path: str, rgb: np.ndarray) -> None:
    """Write (H, W, 3) uint8 (row 0 at the top) as a PNG."""
    rgb = np.ascontiguousarray(rgb, dtype=np.uint8)
    h, w = rgb.shape[:2]
    raw = b"".join(b"\x00" + rgb[y].tobytes() for y in range(h))

    def chunk(tag, data):
        return (struct.pack(">I", len(data)) + tag + data
                + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF))

    png = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
           + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))
    with open(path, "wb") as f:
        f.write(png)


def srgb(linear: np.ndarray, exposure: float = 1.0) -> np.ndarray:
    """Linear RGB -> 8-bit sRGB (clipped), like Blender's 'Standard' view."""
    x = np.clip(np.nan_to_num(np.asarray(linear, np.float64)[..., :3] * exposure), 0.0, 1.0)
    y = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)
    return np.round(y * 255.0).astype(np.uint8)


def flip(bottom_up: np.ndarray) -> np.ndarray:
    """A render (row 0 at the bottom) as an image (row 0 at the top)."""
    return np.asarray(bottom_up)[::-1]


def upscale(img: np.ndarray, k: int) -> np.ndarray:
    return np.repeat(np.repeat(img, k, axis=0), k, axis=1) if k > 1 else img


def diff_image(a: np.ndarray, b: np.ndarray, scale: float) -> np.ndarray:
    """Signed luminance difference a - b as 8-bit: red where a is brighter, blue where
    darker, black where equal; full colour at |a - b| = scale."""
    lum = np.array([0.2126, 0.7152, 0.0722])
    d = (np.asarray(a)[..., :3] - np.asarray(b)[..., :3]) @ lum / max(scale, 1e-12)
    out = np.zeros(d.shape + (3,))
    out[..., 0] = np.clip(d, 0, 1)
    out[..., 2] = np.clip(-d, 0, 1)
    return np.round(out * 255).astype(np.uint8)


# ---------------------------------------------------------------------------------------
# Text: a 5x7 pixel font for labels (digits, letters, a little punctuation)

_FONT = {
    "0": "01110 10001 10011 10101 11001 10001 01110",
    "1": "00100 01100 00100 00100 00100 00100 01110",
    "2": "01110 10001 00001 00010 00100 01000 11111",
    "3": "11110 00001 00001 01110 00001 00001 11110",
    "4": "00010 00110 01010 10010 11111 00010 00010",
    "5": "11111 10000 11110 00001 00001 10001 01110",
    "6": "00110 01000 10000 11110 10001 10001 01110",
    "7": "11111 00001 00010 00100 01000 01000 01000",
    "8": "01110 10001 10001 01110 10001 10001 01110",
    "9": "01110 10001 10001 01111 00001 00010 01100",
    "A": "01110 10001 10001 11111 10001 10001 10001",
    "B": "11110 10001 10001 11110 10001 10001 11110",
    "C": "01110 10001 10000 10000 10000 10001 01110",
    "D": "11110 10001 10001 10001 10001 10001 11110",
    "E": "11111 10000 10000 11110 10000 10000 11111",
    "F": "11111 10000 10000 11110 10000 10000 10000",
    "G": "01110 10001 10000 10111 10001 10001 01111",
    "H": "10001 10001 10001 11111 10001 10001 10001",
    "I": "01110 00100 00100 00100 00100 00100 01110",
    "J": "00111 00010 00010 00010 00010 10010 01100",
    "K": "10001 10010 10100 11000 10100 10010 10001",
    "L": "10000 10000 10000 10000 10000 10000 11111",
    "M": "10001 11011 10101 10101 10001 10001 10001",
    "N": "10001 10001 11001 10101 10011 10001 10001",
    "O": "01110 10001 10001 10001 10001 10001 01110",
    "P": "11110 10001 10001 11110 10000 10000 10000",
    "Q": "01110 10001 10001 10001 10101 10010 01101",
    "R": "11110 10001 10001 11110 10100 10010 10001",
    "S": "01111 10000 10000 01110 00001 00001 11110",
    "T": "11111 00100 00100 00100 00100 00100 00100",
    "U": "10001 10001 10001 10001 10001 10001 01110",
    "V": "10001 10001 10001 10001 10001 01010 00100",
    "W": "10001 10001 10001 10101 10101 10101 01010",
    "X": "10001 10001 01010 00100 01010 10001 10001",
    "Y": "10001 10001 01010 00100 00100 00100 00100",
    "Z": "11111 00001 00010 00100 01000 10000 11111",
    ".": "00000 00000 00000 00000 00000 01100 01100",
    "-": "00000 00000 00000 11111 00000 00000 00000",
    "=": "00000 00000 11111 00000 11111 00000 00000",
    "%": "11000 11001 00010 00100 01000 10011 00011",
    ":": "00000 01100 01100 00000 01100 01100 00000",
    "/": "00001 00010 00010 00100 01000 01000 10000",
    "(": "00010 00100 01000 01000 01000 00100 00010",
    ")": "01000 00100 00010 00010 00010 00100 01000",
    "+": "00000 00100 00100 11111 00100 00100 00000",
    ",": "00000 00000 00000 00000 01100 00100 01000",
    "_": "00000 00000 00000 00000 00000 00000 11111",
    " ": "00000 00000 00000 00000 00000 00000 00000",
}
_GLYPHS = {k: np.array([[c == "1" for c in row] for row in v.split()]) for k, v in _FONT.items()}


def draw_text(img: np.ndarray, text: str, x: int, y: int, colour=(255, 255, 255),
              scale: int = 1) -> None:
    """Draw `text` (upper-cased; unknown characters as blanks) with its top-left at (x, y)."""
    for i, ch in enumerate(text.upper()):
        glyph = upscale(_GLYPHS.get(ch, _GLYPHS[" "]).astype(np.uint8), scale).astype(bool)
        gx, gy = x + i * 6 * scale, y
        h = min(glyph.shape[0], img.shape[0] - gy)
        w = min(glyph.shape[1], img.shape[1] - gx)
        if h <= 0 or w <= 0 or gx < 0 or gy < 0:
            continue
        img[gy:gy + h, gx:gx + w][glyph[:h, :w]] = colour


def text_width(text: str, scale: int = 1) -> int:
    return len(text) * 6 * scale


# ---------------------------------------------------------------------------------------
# Contact sheets


def contact_sheet(rows: list[list[np.ndarray]], row_labels: list[str], col_labels: list[str],
                  captions: list[list[str]] | None = None, pad: int = 6, scale: int = 1,
                  title: str = "") -> np.ndarray:
    """Tile 8-bit images (all the same size) in a grid with labels; returns (H, W, 3)."""
    h, w = rows[0][0].shape[:2]
    label_w = max(text_width(s, scale) for s in row_labels) + 2 * pad
    top = (10 * scale + pad) * (2 if title else 1) + pad
    cap_h = (10 * scale) if captions else 0
    n_cols = max(len(r) for r in rows)
    sheet_w = label_w + n_cols * (w + pad) + pad
    sheet_h = top + len(rows) * (h + cap_h + pad) + pad
    sheet = np.full((sheet_h, sheet_w, 3), 32, np.uint8)
    if title:
        draw_text(sheet, title, pad, pad, scale=scale)
    for j, lab in enumerate(col_labels):
        draw_text(sheet, lab, label_w + j * (w + pad), top - 10 * scale, scale=scale)
    for i, row in enumerate(rows):
        y = top + i * (h + cap_h + pad)
        draw_text(sheet, row_labels[i], pad, y + h // 2 - 3 * scale, scale=scale)
        for j, img in enumerate(row):
            x = label_w + j * (w + pad)
            sheet[y:y + h, x:x + w] = img
            if captions and captions[i] and j < len(captions[i]):
                draw_text(sheet, captions[i][j], x, y + h + 2, colour=(200, 200, 120), scale=scale)
    return sheet


# ---------------------------------------------------------------------------------------
# Log-log line plots

_PALETTE = [(230, 90, 60), (60, 140, 230), (90, 190, 90), (200, 160, 40), (170, 90, 200)]


def _line(img, x0, y0, x1, y1, colour, width=2):
    n = int(max(abs(x1 - x0), abs(y1 - y0))) + 1
    xs = np.linspace(x0, x1, n).round().astype(int)
    ys = np.linspace(y0, y1, n).round().astype(int)
    for dx in range(-(width // 2), width - width // 2):
        for dy in range(-(width // 2), width - width // 2):
            x, y = xs + dx, ys + dy
            ok = (x >= 0) & (x < img.shape[1]) & (y >= 0) & (y < img.shape[0])
            img[y[ok], x[ok]] = colour


def loglog_plot(series: dict, title: str, xlabel: str, ylabel: str, size=(520, 380),
                dashed: set | None = None) -> np.ndarray:
    """series: name -> (xs, ys) with positive values; returns an 8-bit (H, W, 3) plot with
    decade grid lines, axis labels and a legend. Names in `dashed` are drawn dashed."""
    w, h = size
    img = np.full((h, w, 3), 255, np.uint8)
    left, right, top, bottom = 62, 16, 28, 40
    pts = [(x, y) for xs, ys in series.values() for x, y in zip(xs, ys)
           if x > 0 and y > 0 and math.isfinite(x) and math.isfinite(y)]
    if not pts:
        draw_text(img, title + " (no data)", 8, 8, colour=(0, 0, 0))
        return img
    lx = np.log10([p[0] for p in pts])
    ly = np.log10([p[1] for p in pts])
    x_lo, x_hi = math.floor(lx.min() * 2) / 2, math.ceil(lx.max() * 2) / 2
    y_lo, y_hi = math.floor(ly.min() * 2) / 2, math.ceil(ly.max() * 2) / 2
    x_hi, y_hi = max(x_hi, x_lo + 0.5), max(y_hi, y_lo + 0.5)

    def px(x, y):
        u = (math.log10(x) - x_lo) / (x_hi - x_lo)
        v = (math.log10(y) - y_lo) / (y_hi - y_lo)
        return left + u * (w - left - right), h - bottom - v * (h - top - bottom)

    grey, black = (215, 215, 215), (0, 0, 0)
    for e in np.arange(math.ceil(x_lo * 2) / 2, x_hi + 1e-9, 0.5):
        x, _ = px(10 ** e, 10 ** y_lo)
        _line(img, x, top, x, h - bottom, grey, 1)
        lab = _tick(e)
        draw_text(img, lab, int(x) - text_width(lab) // 2, h - bottom + 5, colour=black)
    for e in np.arange(math.ceil(y_lo * 2) / 2, y_hi + 1e-9, 0.5):
        _, y = px(10 ** x_lo, 10 ** e)
        _line(img, left, y, w - right, y, grey, 1)
        lab = _tick(e)
        draw_text(img, lab, left - text_width(lab) - 4, int(y) - 3, colour=black)
    _line(img, left, h - bottom, w - right, h - bottom, black, 1)
    _line(img, left, top, left, h - bottom, black, 1)
    draw_text(img, title, left, 8, colour=black)
    draw_text(img, xlabel, (w - text_width(xlabel)) // 2, h - 14, colour=black)
    for k, (name, (xs, ys)) in enumerate(series.items()):
        colour = _PALETTE[k % len(_PALETTE)]
        pts = [px(x, y) for x, y in zip(xs, ys) if x > 0 and y > 0]
        for i, ((x0, y0), (x1, y1)) in enumerate(zip(pts, pts[1:])):
            if dashed and name in dashed:
                for s in np.linspace(0, 1, 9)[::2]:
                    a, b = s, min(s + 1 / 8, 1)
                    _line(img, x0 + a * (x1 - x0), y0 + a * (y1 - y0),
                          x0 + b * (x1 - x0), y0 + b * (y1 - y0), colour)
            else:
                _line(img, x0, y0, x1, y1, colour)
        for x, y in pts:
            img[max(int(y) - 2, 0):int(y) + 3, max(int(x) - 2, 0):int(x) + 3] = colour
        draw_text(img, name, w - right - 170, top + 6 + 12 * k, colour=colour)
    draw_text(img, ylabel, left + 6, h - bottom - 12, colour=(90, 90, 90))
    return img


def _tick(e: float) -> str:
    v = 10 ** e
    if abs(e - round(e)) > 1e-9:
        return ""  # label decades only
    return f"{v:g}" if 1e-3 <= v < 1e4 else f"1E{int(round(e))}"

"""`python -m addon merge A.exr B.exr ... -o C.exr`: renders of disjoint replicate sets of
one still merged into the render of their union.

A render with `--replicates A-B/N` writes each of its replicates as two passes of a
multilayer EXR ('Specula Replicate r': the replicate's mean in RGB, its sample count per
pixel in A; 'Specula Replicate r Spread': its samples' sums of squared deviations, R, G, B
and luminance), and the scene's seed and replicate set in the header. The image and its error are a
function of those passes alone (engine.film.estimate), so merging is: gather the
replicates of every input, check they belong together, and evaluate that function once
more. The result is the same image and error, to the last bit, as one render of all the
replicates (tests/addon/test_merge.py): a still split across machines.

Needs the OpenEXR package (a test and command-line dependency; the packaged add-on does not
use it). Depth and Normal are not merged (they are not kept per replicate). Each
replicate's mean transparency ('Specula Replicate r Transparency': a transparent film or a
holdout; zero otherwise) gives the merge's alpha (engine.film.alpha).
"""

from __future__ import annotations

import json
import os
import re
import sys

import numpy as np

from . import console

_PASS = re.compile(r"^(?P<layer>.*)\.Specula Replicate (?P<id>\d+)"
                   r"(?P<kind> Spread| Transparency)?(\.X)?$")
_SPAN = re.compile(r"^(\d+)-(\d+)/(\d+)$")


class MergeError(ValueError):
    """Inputs that cannot be merged; the message names the file and what is wrong."""


def read(path):
    """(header, {replicate id: (means (H, W, 3), counts (H, W), spread (H, W, 4),
    transparency (H, W) or None)}, layer name) of one EXR, rows from the top as stored."""
    import OpenEXR
    try:
        f = OpenEXR.File(path)
    except Exception as exc:  # noqa: BLE001 - OpenEXR raises RuntimeError and others
        raise MergeError(f"{path}: cannot read it as an EXR ({exc})")
    header = dict(f.parts[0].header)
    for part in f.parts[1:]:
        header.update({k: v for k, v in part.header.items() if k.startswith("Specula")})
    found, layer = {}, None
    for part in f.parts:
        for name, channel in part.channels.items():
            m = _PASS.match(name)
            if m is None:
                continue
            px = np.asarray(channel.pixels, np.float32)
            kind = (m.group("kind") or "").strip()
            if kind == "Transparency":
                if px.ndim == 3 and px.shape[2] == 1:
                    px = px[..., 0]
                if px.ndim != 2:
                    raise MergeError(f"{path}: pass '{name}' is not one channel")
            elif px.ndim != 3 or px.shape[2] != 4:
                raise MergeError(f"{path}: pass '{name}' is not RGBA")
            found[(int(m.group("id")), kind)] = px
            layer = m.group("layer")
    ids = sorted({r for r, _ in found})
    if not ids:
        raise MergeError(f"{path}: no 'Specula Replicate' passes; render it with "
                         f"--replicates and an .exr output")
    replicates = {}
    for r in ids:
        if (r, "") not in found or (r, "Spread") not in found:
            raise MergeError(f"{path}: replicate {r} lacks its mean or its spread pass")
        px = found[(r, "")]
        replicates[r] = (px[..., :3], px[..., 3], found[(r, "Spread")],
                         found.get((r, "Transparency")))
    return header, replicates, layer


def _field(header, key, path):
    value = header.get(key)
    if value is None:
        raise MergeError(f"{path}: the header has no '{key}' (not a Specula render?)")
    return value.decode() if isinstance(value, bytes) else str(value)


def merge(paths):
    """(combined (H, W, 4) float32, error (H, W) float32, replicates dict, metadata dict,
    layer name) of the union of the inputs' replicates. Raises MergeError."""
    from . import core
    film = core.load().film
    gathered, seed, total, shape, layer, samples = {}, None, None, None, None, 0
    for path in paths:
        header, reps, name = read(path)
        span = _SPAN.match(_field(header, "Specula Replicates", path))
        if span is None:
            raise MergeError(f"{path}: unreadable 'Specula Replicates' field")
        file_seed, file_total = _field(header, "Specula Seed", path), int(span.group(3))
        first = next(iter(reps.values()))[0]
        if seed is None:
            seed, total, shape, layer = file_seed, file_total, first.shape[:2], name
        elif (file_seed, file_total, first.shape[:2]) != (seed, total, shape):
            raise MergeError(f"{path}: seed {file_seed}, {file_total} replicates, "
                             f"{first.shape[1]}x{first.shape[0]} pixels; the first input has "
                             f"seed {seed}, {total} replicates, {shape[1]}x{shape[0]}")
        for r, value in reps.items():
            if r in gathered:
                raise MergeError(f"{path}: replicate {r} is also in {gathered[r][1]}; "
                                 f"merged renders must hold disjoint replicates")
            gathered[r] = (value, path)
        samples += int(_field(header, "Specula Samples", path))
    ids = sorted(gathered)
    h, w = shape
    # The film's order: pixels row-major from the bottom row (EXR rows are from the top).
    def stacked(k, channels):
        arrays = [gathered[r][0][k][::-1] for r in ids]
        return np.ascontiguousarray(np.stack(arrays, axis=2).reshape(h * w, len(ids),
                                                                     *channels))

    counts = stacked(1, ()).astype(np.int32)
    est = film.estimate(counts, stacked(0, (3,)), stacked(2, (4,)), (h, w))
    combined = np.ones((h, w, 4), np.float32)
    combined[..., :3] = est.combined.reshape(h, w, 3)[::-1]
    transparent = [gathered[r][0][3] is not None for r in ids]
    if any(transparent) and not all(transparent):
        r = ids[transparent.index(False)]
        raise MergeError(f"{gathered[r][1]}: replicate {r} has no Transparency pass, unlike "
                         f"{gathered[ids[transparent.index(True)]][1]} (written by an older "
                         f"Specula?)")
    if all(transparent):
        combined[..., 3] = film.alpha(counts, stacked(3, ())).reshape(h, w)[::-1]
    contiguous = ids == list(range(ids[0], ids[-1] + 1))
    metadata = {
        "Specula Relative Error": f"{est.relative_error:.6g}",
        "Specula Error Interval": f"{est.interval[0]:.6g} {est.interval[1]:.6g}",
        "Specula Replicates": (f"{ids[0]}-{ids[-1]}/{total}" if contiguous
                               else ",".join(map(str, ids)) + f"/{total}"),
        "Specula Seed": seed, "Specula Samples": str(samples), "Specula t95": f"{est.t95:.6g}",
        "Specula Merged From": json.dumps([os.path.basename(p) for p in paths])}
    return (combined, np.ascontiguousarray(est.error.reshape(h, w)[::-1]),
            {r: gathered[r][0] for r in ids},
            metadata, layer, est)


def write(path, combined, error, replicates, metadata, layer):
    """A multilayer EXR laid out as Blender writes Specula's: one part per pass."""
    import OpenEXR
    base = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    parts = [OpenEXR.Part({**base, **metadata}, {f"{layer}.Combined": combined},
                          f"{layer}.Combined"),
             OpenEXR.Part(dict(base), {f"{layer}.Specula Error.X": error},
                          f"{layer}.Specula Error")]
    for r, (means, counts, spread, transparency) in replicates.items():
        rgba = np.concatenate([means, counts[..., None]], axis=2).astype(np.float32)
        name = f"{layer}.Specula Replicate {r}"
        parts.append(OpenEXR.Part(dict(base), {name: rgba}, name))
        parts.append(OpenEXR.Part(dict(base), {name + " Spread": np.ascontiguousarray(spread)},
                                  name + " Spread"))
        if transparency is not None:
            t_name = name + " Transparency"
            parts.append(OpenEXR.Part(dict(base), {t_name + ".X": np.ascontiguousarray(
                transparency, np.float32)}, t_name))
    os.makedirs(os.path.dirname(os.path.abspath(path)) or ".", exist_ok=True)
    OpenEXR.File(parts).write(path)


def run(args) -> int:
    try:
        import OpenEXR  # noqa: F401
    except ImportError:
        print("error: merge needs the OpenEXR package (pip install OpenEXR)", file=sys.stderr)
        return 1
    missing = [p for p in args.inputs if not os.path.isfile(p)]
    if missing:
        print(f"error: no such file: {missing[0]}", file=sys.stderr)
        return 1
    try:
        combined, error, reps, metadata, layer, est = merge(args.inputs)
        write(args.output, combined, error, reps, metadata, layer)
    except MergeError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    console.emit_json({"output": os.path.abspath(args.output), "inputs": args.inputs,
                       "replicates": metadata["Specula Replicates"],
                       "samples": int(metadata["Specula Samples"]),
                       "relative_error": est.relative_error,
                       "error_interval": list(est.interval)}, args.json)
    return 0

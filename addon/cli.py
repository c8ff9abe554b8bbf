"""`python -m addon render SCENE.blend [...]`: render a .blend through Blender's pipeline.

Uses the bpy module in-process: registers the add-on, opens the file, applies the
command-line overrides and runs `bpy.ops.render.render(write_still=True)`. `.exr` output is
linear 32-bit float; `.png` goes through the scene's view transform. The last line printed
is one JSON object describing the render. Exit codes: 0 success, 1 unreadable scene or a
failed render, 2 bad arguments (argparse).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

ENGINES = ("SPECULA", "CYCLES")
FORMATS = {".exr": "OPEN_EXR", ".png": "PNG"}


def _number(kind, minimum, what):
    """An argparse type: `kind` (int or float) that is finite and >= minimum."""
    def parse(text):
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}") from None
        if not minimum <= value < float("inf"):
            raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}")
        return value
    return parse


_positive_int = _number(int, 1, "a positive integer")
_non_negative_int = _number(int, 0, "an integer >= 0")
_non_negative_float = _number(float, 0.0, "a finite number >= 0")


def _resolution(text):
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected WIDTHxHEIGHT, e.g. 480x360, got {text!r}"
                                         ) from None
    if w < 1 or h < 1:
        raise argparse.ArgumentTypeError(f"resolution must be positive, got {text!r}")
    return w, h


def _output(text):
    ext = os.path.splitext(text)[1].lower()
    if ext not in FORMATS:
        raise argparse.ArgumentTypeError(f"output must end in .exr or .png, got {text!r}")
    return text


def build_parser():
    parser = argparse.ArgumentParser(prog="python -m addon",
                                     description="Specula for Blender, from the command line")
    sub = parser.add_subparsers(dest="command", required=True)
    r = sub.add_parser("render", help="render a .blend file's scene to an image")
    r.add_argument("scene", help="the .blend file to render")
    r.add_argument("--engine", type=str.upper, choices=ENGINES, default="SPECULA",
                   help="render engine (default SPECULA; CYCLES is set up unbiased to compare)")
    r.add_argument("--samples", type=_positive_int, help="samples per pixel")
    r.add_argument("--time-limit", type=_non_negative_float, help="seconds (0 for none)")
    r.add_argument("--max-bounces", type=_non_negative_int, help="total bounce limit")
    r.add_argument("--resolution", type=_resolution, help="WIDTHxHEIGHT at 100%%")
    r.add_argument("--seed", type=_non_negative_int, help="sample-sequence seed")
    r.add_argument("--output", type=_output, action="append",
                   help="image path, .exr (linear float) or .png (view transform); repeat to "
                   "save one render in several files; default out/<scene>.exr")
    return parser


def _configure_specula(scene, args):
    s = scene.specula
    if args.samples is not None:
        s.samples = args.samples
    if args.time_limit is not None:
        s.time_limit = args.time_limit
    if args.max_bounces is not None:
        s.max_bounces = args.max_bounces
    if args.seed is not None:
        s.seed = args.seed


def _configure_cycles(scene, args):
    """Cycles without its biased defaults, so it can be compared with Specula."""
    c = scene.cycles
    s = scene.specula
    c.device = "CPU"
    c.samples = args.samples if args.samples is not None else s.samples
    c.time_limit = args.time_limit if args.time_limit is not None else s.time_limit
    c.seed = args.seed if args.seed is not None else s.seed
    c.use_denoising = False
    c.use_adaptive_sampling = False
    c.sample_clamp_direct = 0.0
    c.sample_clamp_indirect = 0.0
    c.blur_glossy = 0.0
    c.light_sampling_threshold = 0.0
    bounces = args.max_bounces if args.max_bounces is not None else s.max_bounces
    # Every per-type limit equals the total, so only the total limits a path, as in Specula;
    # transparent bounces are left as they are.
    for name in ("max_bounces", "diffuse_bounces", "glossy_bounces", "transmission_bounces",
                 "volume_bounces"):
        setattr(c, name, bounces)
    c.pixel_filter_type = s.filter_type
    scene.cycles.filter_width = s.filter_width  # Film > Pixel Filter width
    for layer in scene.view_layers:
        layer.cycles.use_denoising = False


def _fail(message, code=1):
    print(f"error: {message}", file=sys.stderr)
    return code


def _save(bpy, scene, output):
    """Save the Render Result through Blender's image pipeline; returns an error or None.

    EXR is written as linear 32-bit float; PNG gets the scene's view transform."""
    image = scene.render.image_settings
    ext = os.path.splitext(output)[1].lower()
    image.file_format = FORMATS[ext]
    image.color_mode = "RGBA"
    image.color_depth = "32" if ext == ".exr" else "8"
    os.makedirs(os.path.dirname(output), exist_ok=True)
    result = bpy.data.images.get("Render Result")
    if result is None:
        return "the render produced no image"
    try:
        result.save_render(output, scene=scene)
    except RuntimeError as exc:
        return f"cannot write {output}: {str(exc).strip()}"
    if not os.path.isfile(output):
        return f"Blender did not write {output}"
    return None


def render(args):
    path = os.path.abspath(args.scene)
    if not os.path.isfile(path):
        return _fail(f"scene file not found: {args.scene}")
    if not os.access(path, os.R_OK):
        return _fail(f"scene file is not readable: {args.scene}")
    outputs = [os.path.abspath(o) for o in (args.output or [os.path.join(
        "out", os.path.splitext(os.path.basename(path))[0] + ".exr")])]

    import bpy  # after argument checks: importing bpy takes a second

    from . import register, render_session
    register()
    try:
        bpy.ops.wm.open_mainfile(filepath=path)
    except RuntimeError as exc:
        return _fail(f"cannot read {args.scene}: {str(exc).strip()}")
    scene = bpy.context.scene
    scene.render.engine = args.engine
    if args.resolution is not None:
        scene.render.resolution_x, scene.render.resolution_y = args.resolution
        scene.render.resolution_percentage = 100
    if args.engine == "SPECULA":
        _configure_specula(scene, args)
    else:
        _configure_cycles(scene, args)
    render_session.last_summary = {}
    t0 = time.perf_counter()
    try:
        bpy.ops.render.render()
    except RuntimeError as exc:
        return _fail(f"render failed: {str(exc).strip()}")
    seconds = time.perf_counter() - t0
    if args.engine == "SPECULA":
        summary = dict(render_session.last_summary)
        if not summary or "error" in summary:
            return _fail(summary.get("error", "render failed (no result)"))
    else:
        summary = {"engine": "CYCLES", "samples": int(scene.cycles.samples),
                   "seconds": seconds, "relative_error": None, "plan": None}
    for output in outputs:
        error = _save(bpy, scene, output)
        if error:
            return _fail(error)
    summary["output"] = outputs[0] if len(outputs) == 1 else outputs
    summary["scene"] = path
    print(json.dumps(summary, default=str))
    return 0


def main(argv=None):
    args = build_parser().parse_args(argv)
    if args.command == "render":
        return render(args)
    return 2


classes = ()


def register():
    pass


def unregister():
    pass

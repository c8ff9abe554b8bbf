"""`python -m addon render|compare SCENE.blend [...]`: Specula from the command line.

`render` uses the bpy module in-process: registers the add-on, opens the file, applies the
command-line overrides and runs `bpy.ops.render.render()`, then saves the Render Result.
`.exr` output is linear 32-bit float; `.png` goes through the scene's view transform. Exit
codes: 0 success, 1 unreadable scene or a failed render, 2 bad arguments (argparse).

`compare` renders the scene with Specula and with Cycles and tests whether they agree
(compare.py; exit 0 agree, 1 differ, 2 bad arguments or scipy missing, 3 no comparison).

`merge A.exr B.exr -o C.exr` merges renders of disjoint replicate sets into the render of
their union (merge.py; exit 0 merged, 1 files that cannot be merged).

Both print warnings as one `warning: ...` line each on stderr, repeats grouped, Blender's
own output on stderr too, and the JSON summary as the last line of stdout (console.py);
`--json PATH` also writes it to a file.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

from . import console

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


def _replicates(text):
    """`N` (all N replicates) or `A-B/N` (replicates A..B of N): (N, (A, B + 1) or None)."""
    try:
        if "/" not in text:
            n, span = int(text), None
        else:
            ids, n = text.split("/")
            first, _, last = ids.partition("-")
            n, span = int(n), (int(first), int(last or first) + 1)
    except ValueError:
        raise argparse.ArgumentTypeError(f"replicates must be N or A-B/N, got {text!r}")
    if not 1 <= n <= 64 or span is not None and not 0 <= span[0] < span[1] <= n:
        raise argparse.ArgumentTypeError(
            f"replicates must be N (1-64) or A-B/N with 0 <= A <= B < N, got {text!r}")
    return n, span


def _output(text):
    ext = os.path.splitext(text)[1].lower()
    if ext not in FORMATS:
        raise argparse.ArgumentTypeError(f"output must end in .exr or .png, got {text!r}")
    return text


def _png(text):
    if os.path.splitext(text)[1].lower() != ".png":
        raise argparse.ArgumentTypeError(f"the comparison image must end in .png, got {text!r}")
    return text


_positive_float = _number(float, 1e-3, "a number of seconds >= 0.001")


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
    r.add_argument("--replicates", type=_replicates, metavar="N|A-B/N",
                   help="N independent replicates (the error estimate), or replicates A to B "
                   "of N only, to merge with renders of the others; .exr output then holds "
                   "every replicate as a pass (multilayer EXR)")
    r.add_argument("--plot", metavar="PATH", type=_png,
                   help="write the estimated error against time as a log-log plot (PNG)")
    r.add_argument("--json", metavar="PATH", help="also write the JSON summary to PATH")

    m = sub.add_parser(
        "merge", help="merge renders of disjoint replicate sets into one",
        description="Merge EXRs rendered with --replicates A-B/N over disjoint replicate sets "
        "of the same scene, seed and size into the EXR of their union: the same image and "
        "error, to the last bit, as one render of all of them.")
    m.add_argument("inputs", nargs="+", help="the multilayer EXRs to merge")
    m.add_argument("-o", "--output", required=True, help="the merged EXR")
    m.add_argument("--json", metavar="PATH", help="also write the JSON summary to PATH")

    c = sub.add_parser(
        "compare", help="render a .blend with Specula and with Cycles and test if they agree",
        description="Render the scene with Specula and with Cycles (set up unbiased, same "
        "pixel filter, bounces and threads; Cycles twice, for its variance) and compare them "
        "block by block. Exit 0 when they agree, 1 when they differ, 2 on bad arguments, "
        "3 when no comparison could be made.")
    c.add_argument("scene", help="the .blend file to compare")
    c.add_argument("--samples", type=_positive_int,
                   help="samples per pixel for each render (default: the scene's Specula "
                   "samples; an upper bound with --time)")
    c.add_argument("--time", type=_positive_float, metavar="SECONDS",
                   help="equal time: each render stops after SECONDS")
    c.add_argument("--max-bounces", type=_non_negative_int, help="total bounce limit")
    c.add_argument("--resolution", type=_resolution, help="WIDTHxHEIGHT at 100%%")
    c.add_argument("--seed", type=_non_negative_int,
                   help="Specula's seed; Cycles uses seed + 1 and seed + 2")
    c.add_argument("--output", type=_png,
                   help="the report image (PNG); default out/compare/<scene>.png")
    c.add_argument("--json", metavar="PATH", help="also write the JSON summary to PATH")
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
    if args.replicates is not None:
        s.replicates, span = args.replicates
        s.use_replicate_subset = span is not None
        if span is not None:
            s.replicate_first, s.replicate_last = span[0], span[1] - 1
        for layer in scene.view_layers:
            layer.specula.use_pass_replicates = True


def _configure_cycles(scene, args):
    """Cycles without its biased defaults (renderers.configure_cycles_unbiased), with the
    command line's values or else the scene's Specula settings."""
    from .renderers import configure_cycles_unbiased

    s = scene.specula

    def pick(value, default):
        return value if value is not None else default

    configure_cycles_unbiased(scene, samples=pick(args.samples, s.samples),
                              time_limit=pick(args.time_limit, s.time_limit),
                              seed=pick(args.seed, s.seed),
                              max_bounces=pick(args.max_bounces, s.max_bounces))


def _fail(message, code=1):
    print(f"error: {message}", file=sys.stderr)
    return code


def _save(bpy, scene, output, multilayer=False):
    """Save the Render Result through Blender's image pipeline; returns an error or None.

    EXR is written as linear 32-bit float (every pass, if `multilayer`); PNG gets the
    scene's view transform."""
    image = scene.render.image_settings
    ext = os.path.splitext(output)[1].lower()
    multilayer = multilayer and ext == ".exr"
    if hasattr(image, "media_type"):  # Blender 5: multilayer is a media type first
        image.media_type = "MULTI_LAYER_IMAGE" if multilayer else "IMAGE"
    image.file_format = "OPEN_EXR_MULTILAYER" if multilayer else FORMATS[ext]
    image.color_mode = "RGBA"
    image.color_depth = "32" if ext == ".exr" else "8"
    os.makedirs(os.path.dirname(output), exist_ok=True)
    # By type, not by name: a file with its own image called "Render Result" (or a renamed
    # one) gets "Render Result.001".
    result = next((img for img in bpy.data.images if img.type == "RENDER_RESULT"), None)
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
    log = console.Warnings()
    with console.captured_output(log):
        summary, error = _render(args, path, outputs)
    log.print()
    if error:
        return _fail(error)
    summary["warnings"] = log.lines()
    if args.plot and summary.get("series"):
        _plot(summary["series"], args.plot, os.path.basename(path))
        summary["plot"] = os.path.abspath(args.plot)
    console.emit_json(summary, args.json)
    return 0


def _plot(series, path, title):
    """The estimated relative error against seconds, log-log, its 95% interval dashed, and
    a 1/sqrt(t) line through the last point for reference."""
    from . import imaging
    pts = [p for p in series if p["relative_error"] > 0 and p["seconds"] > 0]
    curves = {}
    if pts:
        t = [p["seconds"] for p in pts]
        curves["estimated error"] = (t, [p["relative_error"] for p in pts])
        curves["95% interval, low"] = (t, [p["interval"][0] for p in pts])
        curves["95% interval, high"] = (t, [p["interval"][1] for p in pts])
        t_end, e_end = t[-1], pts[-1]["relative_error"]
        curves["1/sqrt(t)"] = (t, [e_end * (t_end / x) ** 0.5 for x in t])
    img = imaging.loglog_plot(curves, f"{title}: estimated error against time", "seconds",
                              "relative RMS error",
                              dashed={"95% interval, low", "95% interval, high", "1/sqrt(t)"})
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    imaging.write_png(path, img)


def _render(args, path, outputs):
    """(summary, None) or (None, error message); Blender's output is captured meanwhile."""
    import bpy  # after argument checks: importing bpy takes a second

    from . import register, render_session
    if not hasattr(bpy.types.Scene, "specula"):
        register()
    try:
        bpy.ops.wm.open_mainfile(filepath=path)
    except RuntimeError as exc:
        return None, f"cannot read {args.scene}: {str(exc).strip()}"
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
        return None, f"render failed: {str(exc).strip()}"
    seconds = time.perf_counter() - t0
    if args.engine == "SPECULA":
        summary = dict(render_session.last_summary)
        if not summary or "error" in summary:
            return None, summary.get("error", "render failed (no result)")
    else:
        summary = {"engine": "CYCLES", "samples": int(scene.cycles.samples),
                   "seconds": seconds, "relative_error": None, "plan": None}
    multilayer = args.engine == "SPECULA" and args.replicates is not None
    for output in outputs:
        error = _save(bpy, scene, output, multilayer)
        if error:
            return None, error
    summary["output"] = outputs[0] if len(outputs) == 1 else outputs
    summary["scene"] = path
    return summary, None


def main(argv=None):
    """Run a command; argv None means this process is the command (`python -m addon`)."""
    console.install_warning_format()
    args = build_parser().parse_args(argv)
    if args.command == "render":
        code = render(args)
    elif args.command == "merge":
        from . import merge
        code = merge.run(args)
    else:
        from . import compare
        code = compare.run(args)
    if argv is None:
        console.close_stdout()
    return code


classes = ()


def register():
    pass


def unregister():
    pass

"""What the command line prints: one-line warnings, grouped, and a JSON line that stays last.

A user (or a script) reads the CLI's stderr for problems and the last line of its stdout for
the JSON summary. Three things got in the way:

* Python's `warnings` print two lines with a source line (`engine/scene.py` warns about
  dropped triangles), which looks like a crash; here every warning is one
  `warning: ...` line.
* Blender prints its reports (`Warning: Specula: ...`, `Read blend: ...`) with C stdio
  straight to file descriptor 1, and one warning per object repeats the same sentence for
  every object. `captured_output` takes descriptor 1 while Blender works, turns its warning
  lines into ours and passes everything else on to stderr; `Warnings.lines` groups
  sentences that differ only in quoted names and numbers into one line with a count.
* Blender prints at exit, after our JSON, e.g. "Not freed memory blocks" for files saved by
  newer Blender versions. `close_stdout` flushes the JSON and then points descriptor 1 at
  stderr, so whatever Blender prints while the process ends goes there.
"""

from __future__ import annotations

import contextlib
import ctypes
import json
import os
import re
import sys
import tempfile
import warnings

# Blender's report lines: "Warning: Specula: text" (the add-on's reports), "Warning: text".
# Blender 5 may prefix its log lines with "00:00.568  reports          | ".
_BLENDER_WARNING = re.compile(
    r"^(?:\d\d:\d\d\.\d+\s+\S+\s+\|\s+)?WARNING:?\s+(?:Specula:\s+)?(.*)$", re.IGNORECASE)
_QUOTED = re.compile(r"'[^']*'")
_NUMBER = re.compile(r"[-+]?\d+(?:\.\d+)?(?:e[-+]?\d+)?", re.IGNORECASE)
# How many of a group's names the grouped line spells out.
NAMES_SHOWN = 3


class Warnings:
    """Warnings in the order they came, each text once; see `lines` for the grouped form."""

    def __init__(self):
        self.messages: list[str] = []

    def add(self, message) -> None:
        text = " ".join(str(message).split()).removeprefix("Specula: ")
        if text and text not in self.messages:
            self.messages.append(text)

    def extend(self, messages) -> None:
        for m in messages:
            self.add(m)

    def lines(self) -> list[str]:
        """One line per kind of warning: sentences equal but for quoted names and numbers
        (one per object, say) become the first one plus "(and N more like it: 'b', 'c')"."""
        groups: dict[str, list[str]] = {}
        for m in self.messages:
            groups.setdefault(_NUMBER.sub("#", _QUOTED.sub("'*'", m)), []).append(m)
        out = []
        for group in groups.values():
            line = group[0]
            if len(group) > 1:
                names = [(_QUOTED.findall(m) or ["?"])[0] for m in group[1:]]
                shown = ", ".join(names[:NAMES_SHOWN]) + (", ..." if len(names) > NAMES_SHOWN
                                                          else "")
                line += f" (and {len(group) - 1} more like it: {shown})"
            out.append(line)
        return out

    def print(self, file=None) -> None:
        for line in self.lines():
            print(f"warning: {line}", file=file or sys.stderr)


# The collector that Python warnings and captured Blender warnings go to, if any.
_active: Warnings | None = None


def _show_warning(message, category, filename, lineno, file=None, line=None):
    """warnings.showwarning: one line, no source line; collected while a command runs."""
    if _active is not None:
        _active.add(message)
    else:
        print(f"warning: {message}", file=file or sys.stderr)


def install_warning_format() -> None:
    warnings.showwarning = _show_warning


@contextlib.contextmanager
def collecting(log: Warnings):
    """Send Python warnings to `log` while the block runs (each text once, however often
    it is warned: the default filter would show a repeat from another line again)."""
    global _active
    previous, _active = _active, log
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("always")
            warnings.showwarning = _show_warning
            yield log
    finally:
        _active = previous


def _flush_c_stdio() -> None:
    """Flush C's stdout buffer (Blender writes with printf; a pipe is block-buffered)."""
    try:
        ctypes.CDLL(None).fflush(None)
    except (OSError, AttributeError, TypeError):  # no C library by that name (Windows)
        pass


@contextlib.contextmanager
def captured_output(log: Warnings, drop=()):
    """Take file descriptor 1 while Blender works; afterwards its warning lines go to `log`,
    lines containing any string in `drop` nowhere (e.g. "Saved: <our temporary file>") and
    the others to stderr, so stdout carries only what the command prints itself."""
    sys.stdout.flush()
    _flush_c_stdio()
    saved = os.dup(1)
    with tempfile.TemporaryFile(mode="w+b") as tmp:
        os.dup2(tmp.fileno(), 1)
        try:
            with collecting(log):
                yield log
        finally:
            sys.stdout.flush()
            _flush_c_stdio()
            os.dup2(saved, 1)
            os.close(saved)
            tmp.seek(0)
            for raw in tmp.read().decode("utf-8", "replace").splitlines():
                match = _BLENDER_WARNING.match(raw.strip())
                if match:
                    log.add(match.group(1))
                elif raw.strip() and not any(d in raw for d in drop):
                    print(raw, file=sys.stderr)
            sys.stderr.flush()


def emit_json(summary: dict, json_path: str | None = None) -> None:
    """Print `summary` as one line on stdout (and write it to `json_path`)."""
    text = json.dumps(summary, default=str)
    if json_path:
        os.makedirs(os.path.dirname(os.path.abspath(json_path)), exist_ok=True)
        with open(json_path, "w", encoding="utf-8") as f:
            f.write(text + "\n")
    print(text, flush=True)


def close_stdout() -> None:
    """End stdout here: flush it, then point descriptor 1 at stderr. Blender prints while
    the process ends (atexit handlers freeing its data, e.g. "Not freed memory blocks");
    that text goes to stderr instead of following the JSON line. Only for a process that
    is the command (`python -m addon`), not for callers of `cli.main` in their own process."""
    sys.stdout.flush()
    _flush_c_stdio()
    os.dup2(2, 1)
    sys.stdout = sys.stderr

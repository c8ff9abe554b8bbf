"""Are this checkout's images the same as an older one's, to the last bit?

Exports every agreement variant (tests/cycles/variants.py) once, through this checkout's
add-on, and renders the same exported scenes with both checkouts' cores (3 samples, one
thread), then compares every pass bit for bit. Exporting once matters: Blender's
triangulation order of a mesh can differ from one process to the next, which changes a
render's noise (not its mean) whatever the core.

    .venv/bin/python tools/compare_engines.py --before /tmp/before [--kernel specialised]
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import pickle
import subprocess
import sys
import tempfile

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

RENDER = """
import os, pickle, sys
sys.path.insert(0, sys.argv[1])
import numpy as np
from engine import RenderSettings, render
out = {}
for name, scene, st in pickle.load(open(sys.argv[2], "rb")):
    st = dict(st, samples=3, threads=1, **({"kernel": sys.argv[4]} if sys.argv[4] else {}))
    r = render(scene, RenderSettings(**st))
    for p in ("combined", "variance", "depth", "normal"):
        out[name + "/" + p] = getattr(r, p)
np.savez(sys.argv[3], **out)
"""


def export_all(path):
    sys.path.insert(0, ROOT)
    from tests.cycles import renderers, variants
    items = []
    for name, v in variants.VARIANTS.items():
        scene, settings, _ = renderers.specula_scene(v)
        items.append((name, scene, dataclasses.asdict(settings)))
    with open(path, "wb") as f:
        pickle.dump(items, f)
    return len(items)


def render_in(tree, scenes, out, kernel):
    subprocess.run([sys.executable, "-c", RENDER, tree, scenes, out, kernel], cwd=tree,
                   check=True)
    return np.load(out)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before", required=True, help="the older checkout")
    ap.add_argument("--kernel", default="", help="this checkout's kernel setting")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        scenes = os.path.join(tmp, "scenes.pkl")
        n = export_all(scenes)
        a = render_in(args.before, scenes, os.path.join(tmp, "before.npz"), "")
        b = render_in(ROOT, scenes, os.path.join(tmp, "after.npz"), args.kernel)
        differ = [k for k in a.files if not np.array_equal(a[k], b[k])]
    print(f"{n} scenes, {len(a.files)} passes: {len(a.files) - len(differ)} identical")
    for k in differ:
        print("differs:", k)
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())

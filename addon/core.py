"""The one place that finds Specula's rendering core.

The core is the top-level package `engine/` next to `addon/` in the repository. A packaged
add-on will carry a copy as `addon/bundled/engine/`; a checkout (or a symlink from Blender's
scripts/addons to the checkout) uses the repository's copy. The add-on's own `engine.py`
holds the RenderEngine class, so the bundled core cannot live at `addon/engine/`.
"""

import importlib
import os
import sys

_core = None


def _repo_root():
    # realpath: Blender may load the add-on through a symlink in scripts/addons.
    return os.path.dirname(os.path.dirname(os.path.realpath(__file__)))


def load():
    """Return the core module (`engine`), importing it on first use.

    Raises ImportError with a message saying where the core was looked for.
    """
    global _core
    if _core is not None:
        return _core
    try:
        from .bundled import engine as core  # packaged add-on
    except ImportError:
        root = _repo_root()
        if not os.path.isfile(os.path.join(root, "engine", "__init__.py")):
            raise ImportError(
                f"Specula's core was not found: no bundled copy in {os.path.dirname(__file__)}"
                f"/bundled and no engine/ package in {root}") from None
        # Only a checkout gets its root on sys.path, and only once.
        if root not in sys.path:
            sys.path.insert(0, root)
        try:
            core = importlib.import_module("engine")
        except ImportError as exc:
            raise ImportError(f"Specula's core in {root}/engine failed to import: {exc}") from exc
    _core = core
    return core


classes = ()


def register():
    pass


def unregister():
    pass

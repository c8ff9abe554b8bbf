"""The one place that finds Specula's rendering core.

The core is the top-level package `engine/` next to `addon/` in the repository. The packaged
add-on and extensions (tools/build_extension.py) carry a copy as `specula/bundled/engine/`;
a checkout (or a symlink from Blender's scripts/addons to the checkout) uses the repository's
copy. The add-on's own `engine.py`
holds the RenderEngine class, so the bundled core cannot live at `addon/engine/`.
"""

import importlib
import os
import sys
import threading

_core = None
_load_lock = threading.Lock()


def _repo_root():
    # realpath: Blender may load the add-on through a symlink in scripts/addons.
    return os.path.dirname(os.path.dirname(os.path.realpath(__file__)))


def _import_embreex():
    """Import embreex so that its bundled Embree binds to its own bundled TBB.

    A Blender executable linked against a shared TBB (Debian's Blender 3.4 uses the system's
    libtbb 2021.8; official Linux builds ship their own) puts that TBB in the global symbol
    scope, and embreex's Embree, built against TBB 2021.12, would bind to it and crash in its
    first scene build. RTLD_DEEPBIND makes embreex's libraries look in their own
    dependencies first. Linux only; harmless where nothing else loaded a TBB (the bpy module).
    """
    if "embreex" in sys.modules or not sys.platform.startswith("linux"):
        return
    flags = sys.getdlopenflags()
    sys.setdlopenflags(flags | os.RTLD_DEEPBIND)
    try:
        importlib.import_module("embreex.rtcore_scene")
        importlib.import_module("embreex.mesh_construction")
    except ImportError:
        pass  # reported by the core's own import below, with the core's context
    finally:
        sys.setdlopenflags(flags)


def load():
    """Return the core module (`engine`), importing it on first use (thread-safe: the
    background warm-up and a render may both ask at once).

    Raises ImportError with a message saying where the core was looked for.
    """
    with _load_lock:
        return _load()


def _load():
    global _core
    if _core is not None:
        return _core
    _import_embreex()
    here = os.path.dirname(os.path.abspath(__file__))
    if os.path.isfile(os.path.join(here, "bundled", "engine", "__init__.py")):
        # Packaged add-on or extension: the core is a subpackage, no sys.path change.
        try:
            from .bundled import engine as core
        except ImportError as exc:
            raise ImportError(f"Specula's bundled core failed to import: {exc}") from exc
    else:
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


# Set when the interface's warm-up found the generic kernel uncached: it compiles after the
# first render instead (after_render).
_generic_after_render = False


def _interactive() -> bool:
    import bpy
    return not bpy.app.background


def warm_up_in_background() -> None:
    """Import the core and load its compiled kernels on a daemon thread, so the first
    Render does not wait for them. Failures are left for that render to report.

    Only a cached generic kernel is loaded here (engine.warm_up). numba compiles one
    function at a time per process, so a cold compile begun at registration made the first
    render wait for it (about 5 min) before it could even load its own scene's cached kernel.
    In the interface the generic kernel compiles after the first render instead, ready for
    the scenes after it; a background Blender (`blender -b`, the bpy module) never compiles
    it cold, its renders compile their own plans' kernels."""
    _warm_up(compile_cold=False, later=_interactive())


def after_render() -> None:
    """When a render has finished: the generic kernel the interface's warm-up left for
    later compiles now."""
    global _generic_after_render
    if _generic_after_render:
        _generic_after_render = False
        _warm_up(compile_cold=True, later=False)


def _warm_up(compile_cold: bool, later: bool) -> None:
    """engine.warm_up on a daemon thread; `later`: if it found nothing to load, compile
    after the next render."""
    def run():
        global _generic_after_render
        try:
            loaded = load().warm_up(compile_cold=compile_cold)
        except Exception:  # noqa: BLE001 - a render will say what is wrong
            return
        _generic_after_render = later and not loaded

    threading.Thread(target=run, name="specula-warm-up", daemon=True).start()


def register():
    pass


def unregister():
    pass

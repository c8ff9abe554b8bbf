"""Specula: a physically based path tracer for Blender, checked against Cycles.

Register with `addon.register()` (the bpy module, tests, `python -m addon`) or enable
the add-on in Blender after linking this folder into scripts/addons as `specula`.
"""

bl_info = {
    "name": "Specula",
    "author": "Specula developers",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "Properties > Render > Render Engine > Specula",
    "description": "Progressive numpy/Embree path tracer with Cycles-matching materials",
    "category": "Render",
}

# Importing bpy-dependent modules lazily keeps `python -m addon --help` fast and lets the
# package be imported for its CLI without a Blender context.
_MODULES = ("properties", "engine", "ui")


def _modules():
    import importlib
    return [importlib.import_module(f".{name}", __name__) for name in _MODULES]


def register():
    for module in _modules():
        module.register()
    from . import core
    core.warm_up_in_background()


def unregister():
    for module in reversed(_modules()):
        module.unregister()

"""Specula's rendering core: a wavefront path tracer on numpy and embreex.

The core never imports bpy. Callers build a `Scene` with `SceneBuilder`, then call
`render(scene, settings, on_pass=..., should_stop=...)`.
"""

from . import bsdf, camera, kernel  # noqa: F401
from .plan import Plan, make_plan  # noqa: F401
from .renderer import Pass, RenderResult, render  # noqa: F401
from .scene import (  # noqa: F401
    Camera,
    Light,
    Material,
    Materials,
    RenderSettings,
    Scene,
    SceneBuilder,
    World,
)

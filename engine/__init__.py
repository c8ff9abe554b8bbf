"""Specula's rendering core: a wavefront path tracer on numpy, embreex and numba.

The core never imports bpy. Callers build a `Scene` with `SceneBuilder`, then call
`render(scene, settings, on_pass=..., should_stop=...)`.
"""

from . import (  # noqa: F401
    bsdf, camera, environment, fresnel, integrator, kernels, mesh_attributes, noise, shading,
    sky, spectrum)
from .plan import Plan, make_plan  # noqa: F401
from .film import Pass  # noqa: F401
from .renderer import RenderResult, render, warm_up  # noqa: F401
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

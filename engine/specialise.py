"""Compile a set of functions for one set of compile-time constants.

The integrator's stage functions read the scene's plan as module globals (`HAS_GLASS`, ...).
numba freezes globals when it compiles and prunes the branches they decide, so compiling
a copy of the stages whose globals hold one plan's values leaves the code for absent
features out of that kernel altogether (pbrt-v4 specialises per material type at compile
time the same way). Each copy gets its own qualified name, so numba caches every plan's
kernel in its own files; the name carries a hash of the core's sources, because numba
checks only the stamp of the file that defines a function, not of the functions it calls.
"""

from __future__ import annotations

import types

from . import jit
from .jit import njit

# (jit.SOURCE_HASH: 8 hex digits of the core's sources as imported.)
SOURCE_HASH = jit.SOURCE_HASH


def specialise(functions: dict, namespace: dict, constants: dict, tag: str,
               cache: bool = True) -> dict:
    """Compile copies of `functions` (name -> (plain Python function, numba options)) whose
    globals are `namespace` with `constants` in place: the copies call one another, so a
    whole kernel is specialised together. Returns name -> dispatcher (or the plain copies
    where numba is absent)."""
    g = dict(namespace)
    g.update(constants)
    out = {}
    for name, (f, options) in functions.items():
        copy = types.FunctionType(f.__code__, g, f.__name__, f.__defaults__, f.__closure__)
        copy.__qualname__ = f"{f.__qualname__}__{tag}"
        copy.__module__, copy.__doc__ = f.__module__, f.__doc__
        g[name] = out[name] = njit(**dict(options, cache=cache))(copy)
    return out

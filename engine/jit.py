"""numba when it is installed, else the same functions as plain Python.

Every formula of the core is a small function decorated with `njit(**JIT)`; numba compiles
and inlines them into the per-bounce kernel (integrator.py). Without numba (a platform
without its wheel) the decorator leaves the function as it is, and the same kernel runs as
Python: the same image, about two orders of magnitude slower (README, "Platforms").
`NUMBA` says which of the two this process has.
"""

from __future__ import annotations

try:
    from llvmlite import ir
    from numba import njit, types
    from numba.core import cgutils
    from numba.extending import intrinsic
    NUMBA = True
except ImportError:  # pragma: no cover - exercised on platforms without numba
    NUMBA = False
    ir = types = cgutils = None

    def njit(*args, **kwargs):
        if args and callable(args[0]):
            return args[0]
        return lambda f: f

    def intrinsic(f):
        return None

# Options of every compiled formula: cached on disk, no GIL (the render's threads run the
# kernels side by side), numpy's floating-point semantics (division by zero gives inf or
# NaN, as the formulas expect, rather than raising), and no reference counting (numba's
# `_nrt` flag off): the formulas and the kernel allocate nothing, and every array a function
# read from a structure or took as an argument was an atomic count on memory both threads
# share, more than half the kernel's time (CBspheres 160x120, 24 spp: 0.69 s with, 0.34 s
# without). Functions that allocate arrays use ALLOCATING.
ALLOCATING = dict(cache=True, nogil=True, error_model="numpy")
JIT = dict(ALLOCATING, _nrt=False)
# Stage functions and formulas that take the scene's arrays: inlined into the caller by
# numba itself, so no reference counting is paid per call (a helper taking a tuple of
# arrays cost ~100 ns a call, measured, more than the rest of a light sample).
INLINE = dict(JIT, inline="always")

__all__ = ["ALLOCATING", "INLINE", "JIT", "NUMBA", "cgutils", "intrinsic", "ir", "njit", "types"]

"""numba when it is installed, else a do-nothing decorator.

numba is optional: platforms without its wheel (macOS x86-64 in Blender, Blender 3.4's
legacy install) render with the numpy stages. `kernel.AVAILABLE` is the switch the core
reads at run time (tests turn it off to check the numpy path); `NUMBA` only says whether
the import worked.
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

    intrinsic = njit

__all__ = ["NUMBA", "cgutils", "intrinsic", "ir", "njit", "types"]

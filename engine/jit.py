"""numba when it is installed, else the same functions as plain Python.

Every formula of the core is a small function decorated with `njit(**JIT)`; numba compiles
and inlines them into the per-bounce kernel (integrator.py). Without numba (a platform
without its wheel) the decorator leaves the function as it is, and the same kernel runs as
Python: the same image, about two orders of magnitude slower (README, "Platforms").
`NUMBA` says which of the two this process has.
"""

from __future__ import annotations

import glob
import hashlib
import os
import shutil
import time

try:
    from llvmlite import ir
    from numba import njit, types
    from numba.core import caching, cgutils, config
    from numba.extending import intrinsic
    from numba.misc.appdirs import AppDirs
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


ENGINE_DIR = os.path.dirname(os.path.abspath(__file__))


def _sources_hash() -> str:
    h = hashlib.sha256()
    for path in sorted(glob.glob(os.path.join(ENGINE_DIR, "*.py"))):
        with open(path, "rb") as f:
            h.update(f.read())
    return h.hexdigest()[:8]


# 8 hex digits of the core's sources as imported: a changed formula anywhere gets new kernels
# (specialise.py names each plan's kernel with it) and a new cache folder (below).
SOURCE_HASH = _sources_hash()


# The core's package as imported ("engine" from a checkout, "bl_ext.user_default.specula.
# bundled.engine" as an extension, "specula.bundled.engine" as a legacy add-on): numba's
# cache entries name their module, and load only where it imports by that name.
PACKAGE = __name__.rpartition(".")[0]


def cache_root() -> str:
    """Where the core's compiled functions are cached: beside numba's own user-wide cache
    (NUMBA_CACHE_DIR where set), in a folder named by the core's sources and package."""
    if not NUMBA:
        return None
    base = config.CACHE_DIR or AppDirs(appname="numba", appauthor=False).user_cache_dir
    package = hashlib.sha256(PACKAGE.encode()).hexdigest()[:6]
    return os.path.join(base, f"specula-{SOURCE_HASH}-{package}")


if NUMBA:
    class EngineCacheLocator(caching._SourceFileBackedLocatorMixin, caching._CacheLocator):
        """numba's cache for the core's own functions, found by the core's sources and
        package name, not by the folder they were installed in: numba's locators name the
        cache after the source folder, so the same extension installed twice (Blender 4.2
        and 5.0 beside each other, or reinstalled) compiled every kernel again, the
        generic one taking minutes. Entries still carry numba's stamp (the source file's
        content hash) and version."""

        def __init__(self, py_func, py_file):
            self._py_file = py_file
            self._lineno = py_func.__code__.co_firstlineno
            self._cache_path = cache_root()

        def get_cache_path(self):
            return self._cache_path

        @classmethod
        def from_function(cls, py_func, py_file):
            if os.path.dirname(os.path.abspath(py_file)) != ENGINE_DIR:
                return None  # not the core's (a test's own compiled helper)
            return super().from_function(py_func, py_file)  # None where not writable

    if EngineCacheLocator not in caching.CacheImpl._locator_classes:
        caching.CacheImpl._locator_classes.insert(0, EngineCacheLocator)


# Cache folders of other sources (older versions, a developer's earlier edits) kept beside
# this one's: the most recently used this many, so that switching back is free; the rest
# are removed.
KEPT_CACHES = 6


def prune_caches(root: str | None = None, keep: int = KEPT_CACHES) -> list:
    """Mark this core's cache folder used and remove all but the `keep` most recently used
    other `specula-*` folders beside it; returns the removed paths. Never raises (a cache
    another process is reading, or a read-only folder, is left as it is)."""
    root = root or cache_root()
    if root is None:
        return []
    parent, own = os.path.dirname(root), os.path.basename(root)
    try:
        if os.path.isdir(root):
            now = time.time()
            os.utime(root, (now, now))
        others = [e for e in os.scandir(parent)
                  if e.name.startswith("specula-") and e.name != own and e.is_dir()]
    except OSError:
        return []
    removed = []
    for entry in sorted(others, key=lambda e: e.stat().st_mtime, reverse=True)[keep:]:
        shutil.rmtree(entry.path, ignore_errors=True)
        removed.append(entry.path)
    return removed

__all__ = ["ALLOCATING", "INLINE", "JIT", "NUMBA", "SOURCE_HASH", "cache_root", "cgutils",
           "intrinsic", "ir", "njit", "prune_caches", "types"]

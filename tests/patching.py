"""Put a wrong (or poisoned) formula into the compiled kernel, for tests with power.

numba freezes the functions a kernel calls when it compiles, so monkeypatching a module
after the fact changes nothing. Instead, `one_off_kernels(monkeypatch, **overrides)` makes
every render inside the test compile a fresh, uncached kernel (kernels.Kernel overrides):
a stage name maps to a replacement stage (plain Python, compiled into the kernel with the
integrator's globals, so it can call e.g. `original_handle_emission` passed alongside), and
a module name (`bsdf`, `lights`, ...) maps to `module_with(module, ...)`, a copy of that
module whose compiled functions see the replacements.
"""

from __future__ import annotations

import types

from engine import kernels
from engine.jit import INLINE, NUMBA, njit


def module_with(module, **replacements):
    """A copy of `module` whose compiled functions call `replacements` (plain Python
    functions are compiled, inlined, with the copy's globals) instead of the originals."""
    copy = types.ModuleType(module.__name__)
    copy.__dict__.update(vars(module))
    for name, value in vars(module).items():
        py = getattr(value, "py_func", None)
        if py is None or py.__module__ != module.__name__ or name in replacements:
            continue
        options = {k: v for k, v in value.targetoptions.items() if k != "nopython"}
        copy.__dict__[name] = _compiled(py, copy.__dict__, options)
    for name, value in replacements.items():
        if isinstance(value, types.FunctionType):
            value = _compiled(value, copy.__dict__, INLINE)
        copy.__dict__[name] = value
    return copy


def _compiled(f, namespace, options):
    g = types.FunctionType(f.__code__, namespace, f.__name__, f.__defaults__, f.__closure__)
    g.__qualname__ = f.__qualname__ + "__patched"
    g.__module__ = f.__module__
    return njit(**dict(options, cache=False))(g) if NUMBA else g


def one_off_kernels(monkeypatch, **overrides):
    """Every kernel a render builds from now on (in this test) is compiled afresh with
    `overrides` (see kernels.Kernel). The plan's own kernel, not the generic one the suite
    otherwise shares: uncached, the generic kernel takes about five times as long to compile
    (CBspheres: 73 s against 15 s, measured), and both give the same pixels."""
    monkeypatch.setenv("SPECULA_KERNEL", "specialised")

    def build(constants, compile_with):
        k = kernels.Kernel(constants, cache=False, overrides=overrides)
        compile_with(k)
        return k

    monkeypatch.setattr(kernels, "build_now", build)
    monkeypatch.setattr(kernels, "ready_kernel", lambda constants: None)
    monkeypatch.setattr(kernels, "build_in_background", lambda constants, compile_with: None)

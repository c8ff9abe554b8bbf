import glob
import os
import time
import zlib

import numpy as np
import pytest


@pytest.fixture
def rng():
    return np.random.default_rng(20261121)


# "auto" renders take the generic kernel in the tests: one compile for the whole suite
# instead of one per plan (tests/engine/test_kernel.py renders with the plans' own kernels
# and checks they give the same bits). Inherited by the Blender processes the tests start.
os.environ.setdefault("SPECULA_KERNEL", "generic")

# A material the reader fails on is rendered as grey 0.8 with a warning for a user; in the
# tests it raises, so that a bug in the reader fails the test that met it instead of
# passing as grey (addon.materials.convert).
os.environ.setdefault("SPECULA_STRICT_MATERIALS", "1")


# `make test` runs the suite in two processes (pytest-xdist): most of its time is numba
# compiling kernels, which uses one core. A file's tests stay in one process (its module
# fixtures are made once), and so do the install tests (one `make dist`, one Blender 3.4 user
# folder); the Cycles comparisons are split between the two by variant, a variant's injected
# errors in the process that made its agreement render (test_power.py's ids start with the
# variant). (xdist's own --dist loadgroup does not group under pytest 9.2: its group suffix
# no longer reaches the nodeids it schedules, pytest-dev/pytest-xdist#1386.)
BY_VARIANT = ("tests/cycles/test_agreement.py", "tests/cycles/test_power.py")


def process_group(nodeid: str) -> str:
    """The process-sharing group of a test: its file's, the install folder's, or for a
    Cycles comparison one of two halves of the variants."""
    path, _, test = nodeid.partition("::")
    if path.startswith("tests/install/"):
        return "install"
    if path in BY_VARIANT and "[" in test:
        variant = test[test.index("[") + 1:].rstrip("]").split("-")[0]
        return f"cycles-{zlib.crc32(variant.encode()) % 2}"
    return path


def pytest_xdist_make_scheduler(config, log):
    from xdist.scheduler import LoadScopeScheduling

    class GroupScheduling(LoadScopeScheduling):
        def _split_scope(self, nodeid):
            return process_group(nodeid)

    return GroupScheduling(config, log)


STARTED = time.time()
CYCLES_SUMMARIES = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "out",
                                "cycles", "summary-*.txt")


def pytest_terminal_summary(terminalreporter):
    """The Cycles comparisons' summary (where the references came from, how each
    comparison went), as the processes that ran them left it (tests/cycles/conftest.py)."""
    lines = []
    for path in sorted(glob.glob(CYCLES_SUMMARIES)):
        if os.path.getmtime(path) >= STARTED:
            with open(path) as f:
                lines += f.read().splitlines()
    if lines:
        terminalreporter.section("Specula vs Cycles")
        for line in lines:
            terminalreporter.write_line(line)

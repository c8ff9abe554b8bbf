import collections
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

        def _assign_work_unit(self, node):
            # The install tests first (xdist orders groups by test count, which put them
            # near the end): they spend ~11 min in Blender processes compiling into caches
            # of their own, while the other process compiles the suite's generic kernel,
            # which it would otherwise compile too, at the same moment (5 min, measured).
            # Last, they left one process working alone for their length.
            if "install" in self.workqueue:
                self.workqueue.move_to_end("install", last=False)
            super()._assign_work_unit(node)

    return GroupScheduling(config, log)


STARTED = time.time()
CYCLES_SUMMARIES = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "out",
                                "cycles", "summary-*.txt")


# Seconds spent per test file (setup, call and teardown), for the summary: CI must stay well
# under an hour, and most of it is numba compiling kernels cold, which --durations shows
# only for the test that happened to compile first.
FILE_SECONDS = collections.Counter()


def pytest_runtest_logreport(report):
    FILE_SECONDS[report.nodeid.partition("::")[0]] += report.duration


def pytest_terminal_summary(terminalreporter):
    """Time per test file; then the Cycles comparisons' summary (where the references came
    from, how each comparison went), as the processes that ran them left it
    (tests/cycles/conftest.py)."""
    if FILE_SECONDS:
        terminalreporter.section("seconds per test file")
        total = sum(FILE_SECONDS.values())
        for path, seconds in FILE_SECONDS.most_common(25):
            terminalreporter.write_line(f"{seconds:8.1f}  {path}")
        terminalreporter.write_line(f"{total:8.1f}  all files (both processes)")
    lines = []
    for path in sorted(glob.glob(CYCLES_SUMMARIES)):
        if os.path.getmtime(path) >= STARTED:
            with open(path) as f:
                lines += f.read().splitlines()
    if lines:
        terminalreporter.section("Specula vs Cycles")
        for line in lines:
            terminalreporter.write_line(line)

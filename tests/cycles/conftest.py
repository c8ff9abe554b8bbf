"""Set-up for the Cycles comparison tests: bpy, the add-on registered once per process, and
a terminal summary saying where the Cycles references came from and how each comparison
went."""

import os

import pytest

bpy = pytest.importorskip("bpy")

from . import harness, references, renderers  # noqa: E402 - after the bpy check

renderers.ensure_registered()


def pytest_sessionfinish(session):
    """Leave this process's summary for the terminal (tests/conftest.py prints it): under
    pytest-xdist the comparisons run in a worker, whose own summary nobody sees."""
    lines = references.summary_lines() + harness.summary_lines()
    if lines:
        worker = os.environ.get("PYTEST_XDIST_WORKER", "main")
        os.makedirs(harness.DIAGNOSTICS, exist_ok=True)
        with open(os.path.join(harness.DIAGNOSTICS, f"summary-{worker}.txt"), "w") as f:
            f.write("\n".join(lines) + "\n")

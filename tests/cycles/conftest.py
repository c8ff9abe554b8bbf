"""Set-up for the Cycles comparison tests: bpy, the add-on registered once per process, and
a terminal summary saying where the Cycles references came from and how each comparison
went."""

import pytest

bpy = pytest.importorskip("bpy")

from . import harness, references, renderers  # noqa: E402 - after the bpy check

renderers.ensure_registered()


def pytest_terminal_summary(terminalreporter):
    lines = references.summary_lines()
    if lines or harness.RESULTS:
        terminalreporter.section("Specula vs Cycles")
        for line in lines + harness.summary_lines():
            terminalreporter.write_line(line)

"""Specula's images are Cycles' images: every variant agrees statistically (compare.py)."""

import pytest

from . import harness
from .variants import VARIANTS


def _params():
    for name, v in VARIANTS.items():
        marks = [pytest.mark.xfail(reason=v.xfail, strict=False)] if v.xfail else []
        yield pytest.param(name, marks=marks, id=name)


@pytest.mark.slow
@pytest.mark.parametrize("name", list(_params()))
def test_agrees_with_cycles(name):
    c = harness.agreement(name)
    assert c.agree, f"{name}: {c.describe()}"

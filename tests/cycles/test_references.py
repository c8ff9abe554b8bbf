"""The committed Cycles references are current: a stale one is re-rendered during the run
(minutes each, 32 of them once took CI past its hour), so a stale cache fails here, fast,
naming the variants and the command that renders them."""

from . import references
from .variants import VARIANTS


def test_every_variant_has_a_current_cached_reference():
    stale = {}
    for name, variant in VARIANTS.items():
        runs, why = references.load(variant)
        if runs is None:
            stale[name] = why
    assert not stale, ("stale Cycles references (render them with `.venv/bin/python -m "
                       f"tests.cycles.references --only {' '.join(stale)}`): {stale}")

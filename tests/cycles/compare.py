"""The block z-test that decides whether two renders agree lives in the add-on
(`addon/agreement.py`), where `python -m addon compare` uses it too; the tests import it
from here so the statistic exists once."""

from addon.agreement import (  # noqa: F401 - re-exported for the tests and benchmarks
    ALPHA,
    BLOCK_SHAPES,
    REL_TOLERANCE,
    Comparison,
    block_sums,
    compare,
)

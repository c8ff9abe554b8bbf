import os

import numpy as np
import pytest


@pytest.fixture
def rng():
    return np.random.default_rng(20261121)


# "auto" renders take the generic kernel in the tests: one compile for the whole suite
# instead of one per plan (tests/engine/test_kernel.py renders with the plans' own kernels
# and checks they give the same bits). Inherited by the Blender processes the tests start.
os.environ.setdefault("SPECULA_KERNEL", "generic")

import os
import shutil

import pytest

from . import helpers


@pytest.fixture(autouse=True)
def users_kernel_choice(monkeypatch):
    """The Blender processes started here choose their kernels as a user's do ("auto": the
    scene's own, compiled where it is not cached) rather than the suite's shared generic
    one (tests/conftest.py). Each of them has its own kernel cache (another Python's numba,
    or the extension's package name). The add-on's warm-up no longer compiles the generic
    kernel before a first render (addon.core), so on a fresh cache (measured, the install
    tests alone): Blender 3.4's farm test 91 s (335 s when the warm-up compiled the generic
    kernel first), the bpy 4.2 extension test, three scenes' kernels, 128 s (383 s)."""
    monkeypatch.setenv("SPECULA_KERNEL", "auto")


@pytest.fixture(scope="session")
def dist():
    """The zips of `make dist`, built once per session: {platform | 'legacy': path}."""
    return helpers.build_dist()


@pytest.fixture(scope="session")
def blender34(dist, tmp_path_factory):
    """Debian's Blender 3.4 with the legacy add-on installed in a fresh user folder, as
    docs/INSTALL.md says; returns the environment that selects that folder."""
    if helpers.BLENDER is None:
        pytest.skip("Debian's blender is not installed (`apt-get install blender`; .ci/run "
                    "installs it)")
    if helpers.blender_version() != (3, 4):
        pytest.skip(f"these tests expect Debian's Blender 3.4, found {helpers.blender_version()}")
    user = str(tmp_path_factory.mktemp("blender34_user"))
    return helpers.install_legacy(user, dist["legacy"])


@pytest.fixture(scope="session")
def artifacts():
    os.makedirs(helpers.ARTIFACTS, exist_ok=True)
    return helpers.ARTIFACTS


def need(binary):
    if shutil.which(binary) is None:
        pytest.skip(f"{binary} is not installed (.ci/run installs it with apt-get)")

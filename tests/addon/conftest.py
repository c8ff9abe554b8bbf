"""Shared set-up for the add-on tests: bpy imported and Specula registered once per session.

bpy can be imported only once per process, so every test shares it; `fresh` resets
Blender to an empty factory scene before a test.
"""

import os
import sys

import pytest

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
if REPO not in sys.path:
    sys.path.insert(0, REPO)

bpy = pytest.importorskip("bpy")

import addon  # noqa: E402 - needs REPO on sys.path

if not hasattr(bpy.types.Scene, "specula"):  # tests/cycles' conftest may have done it
    addon.register()

SCENES_DIR = os.path.join(REPO, "blend_scenes")


@pytest.fixture
def fresh():
    """An empty factory scene with Specula as the engine."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine = "SPECULA"
    return scene


@pytest.fixture(scope="session")
def repo():
    return REPO


@pytest.fixture
def rng():
    import numpy as np
    return np.random.default_rng(20261121)


@pytest.fixture(scope="session")
def core():
    """The rendering core, or skip when it cannot be imported yet."""
    from addon import core as core_loader
    try:
        return core_loader.load()
    except ImportError as exc:
        pytest.skip(f"core not importable: {exc}")

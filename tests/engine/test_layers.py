"""The core's structure: modules import only from layers below them, with no import hidden
inside a function, and no function is longer than about 80 lines."""

import ast
import os

ENGINE = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(
    __file__)))), "engine")
# Bottom to top: a module may import only modules listed before it.
LAYERS = ["jit", "spectrum", "specialise", "fresnel", "noise", "sky", "mesh_attributes", "voronoi",
          "sheen_table", "sampling", "media", "shading", "scene",
          "bsdf", "terminator", "environment", "camera", "film", "accel", "lights", "caustics",
          "plan", "integrator", "light_tracing", "kernels", "renderer", "__init__"]
MAX_FUNCTION_LINES = 80


def _modules():
    for name in sorted(os.listdir(ENGINE)):
        if name.endswith(".py"):
            with open(os.path.join(ENGINE, name)) as f:
                yield name[:-3], ast.parse(f.read())


def _engine_imports(node):
    if isinstance(node, ast.ImportFrom) and node.level == 1:
        return [node.module] if node.module else [a.name for a in node.names]
    if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("engine"):
        return [node.module.split(".")[1] if "." in node.module else a.name
                for a in node.names]
    return []


def test_every_module_has_a_layer():
    assert sorted(name for name, _ in _modules()) == sorted(LAYERS)


def test_imports_go_down_the_layers_only():
    bad = []
    for name, tree in _modules():
        for node in ast.walk(tree):
            for target in _engine_imports(node):
                if target not in LAYERS or LAYERS.index(target) >= LAYERS.index(name):
                    bad.append(f"{name} imports {target}")
    assert not bad, bad


def test_no_import_inside_a_function():
    bad = []
    for name, tree in _modules():
        for fn in ast.walk(tree):
            if isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef)):
                for node in ast.walk(fn):
                    if isinstance(node, (ast.Import, ast.ImportFrom)):
                        bad.append(f"{name}.{fn.name} line {node.lineno}")
    assert not bad, bad


def test_no_function_is_longer_than_80_lines():
    long = [f"{name}.{fn.name}: {fn.end_lineno - fn.lineno + 1} lines"
            for name, tree in _modules() for fn in ast.walk(tree)
            if isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef))
            and fn.end_lineno - fn.lineno + 1 > MAX_FUNCTION_LINES]
    assert not long, long


def test_the_checks_have_power():
    """An upward import and a cycle are caught by the rule the tests apply."""
    tree = ast.parse("from .renderer import render\n")
    targets = [t for node in ast.walk(tree) for t in _engine_imports(node)]
    assert targets == ["renderer"] and LAYERS.index("renderer") >= LAYERS.index("bsdf")

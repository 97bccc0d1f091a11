"""The import contract: data flows one way, and the import graph proves it. Read from the source (no import runs),
so a new module that breaks a layer fails here, naming the module and the import."""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "bridge"

# Each top-level module or package of bridge and its layer: a module may import only from its own layer or below.
LAYERS = {
    "errors": 0,
    "values": 1, "files": 1, "names": 1, "optim": 1, "probability": 1,  # values, I/O, naming, search: no physics
    "timelimit": 1,
    "odb": 2,
    "world": 3,
    "recording": 4,
    "sim": 5,  # the only layer that imports Drake
    "inference": 6, "planning": 6, "diff": 6,
    "bodies": 7,
    "rollout": 8,
    "params": 9,
    "fit": 10, "diagnosis": 10,
    "prove": 11,
    "teleop": 12, "enactment": 12, "session": 12, "uncertainty": 12, "check": 12,
    "commands": 13, "progress": 13,  # progress: the commands' bars and lines (tqdm); the library takes callbacks
    "cli": 14,
    "__init__": 14,  # the package's re-exports
}


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imports(path: Path) -> list[str]:
    """Every module `path` imports (relative imports resolved; `from . import x` as the module `pkg.x`)."""
    name = _module_name(path)
    package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            found += [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[:len(package.split(".")) - node.level + 1]
                module = ".".join(base + ([node.module] if node.module else []))
            else:
                module = node.module
            found += [f"{module}.{alias.name}" for alias in node.names] if node.module is None else [module]
    return found


def _layer_of(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "__init__"


SOURCES = sorted(PACKAGE.rglob("*.py"))
EDGES = {path: _imports(path) for path in SOURCES}


def test_every_module_has_a_layer():
    missing = sorted({_layer_of(_module_name(p)) for p in SOURCES} - set(LAYERS))
    assert not missing, f"modules without a layer in LAYERS: {missing}"


@pytest.mark.parametrize("path", SOURCES, ids=lambda p: _module_name(p))
def test_imports_point_down_the_layers(path):
    own = _layer_of(_module_name(path))
    upward = [m for m in EDGES[path] if m.startswith("bridge.") and LAYERS[_layer_of(m)] > LAYERS[own]]
    assert not upward, f"{_module_name(path)} (layer {own}) imports from above: {upward}"


def test_drake_is_imported_only_under_bridge_sim():
    outside = {_module_name(p): [m for m in ms if m.split(".")[0] == "pydrake"] for p, ms in EDGES.items()
               if not _module_name(p).startswith("bridge.sim")}
    assert not {k: v for k, v in outside.items() if v}


def test_values_and_errors_stand_alone():
    """The bottom: errors import nothing of bridge; values only the error family."""
    assert not [m for m in EDGES[PACKAGE / "errors.py"] if m.startswith("bridge")]
    assert {m for m in EDGES[PACKAGE / "values.py"] if m.startswith("bridge")} == {"bridge.errors"}


def test_the_command_line_only_parses_and_calls_command_functions():
    bridge_imports = {m for m in EDGES[PACKAGE / "cli.py"] if m.startswith("bridge")}
    assert bridge_imports == {"bridge.commands"}
    tree = ast.parse((PACKAGE / "cli.py").read_text(encoding="utf-8"))
    calls = {node.func.attr for node in ast.walk(tree) if isinstance(node, ast.Call)
             and isinstance(node.func, ast.Attribute) and isinstance(node.func.value, ast.Name)
             and node.func.value.id == "commands"}
    assert calls == {"run"}  # and names command functions in its table; nothing else of bridge runs there


def test_the_contract_sees_a_violation(tmp_path):
    """The checker itself: a module importing Drake or a higher layer is caught."""
    bad = tmp_path / "bridge" / "odb" / "bad.py"
    bad.parent.mkdir(parents=True)
    bad.write_text("from pydrake.all import Simulator\nfrom ..fit import fit\n")
    global PACKAGE
    saved, PACKAGE = PACKAGE, tmp_path / "bridge"
    try:
        imports = _imports(bad)
    finally:
        PACKAGE = saved
    assert imports == ["pydrake.all", "bridge.fit"]
    assert LAYERS[_layer_of("bridge.fit")] > LAYERS["odb"]

"""The object database: resolved types plus the PDDL view of them (type tree, predicate signatures)."""
from __future__ import annotations

from pathlib import Path
from typing import Iterable, Mapping

from ..errors import ObjectDatabaseError
from .loader import dataset_names, dataset_roots_from_env, load_sie_class, read_types
from .types import ObjectType, PredicateDecl

REPO_ROOT = Path(__file__).resolve().parents[2]
DEFAULT_ROOT = REPO_ROOT / "odb"


class ObjectDatabase:
    """Read-only after loading; SIE instances are made once and cached (mass properties: bridge.sim.shapes)."""

    def __init__(self, root: Path, types: Mapping[str, ObjectType], package: str, datasets: Mapping[str, Path]):
        self.root = root
        self.types = dict(types)
        self.datasets = dict(datasets)
        self._package = package
        self._sies: dict[tuple[str, str], object] = {}
        self.pddl_types = self._pddl_tree()
        self.predicates = self._signatures()

    # --- lookup -------------------------------------------------------------------------------
    def get(self, name: str, *, where: str = "") -> ObjectType:
        try:
            return self.types[name]
        except KeyError:
            raise ObjectDatabaseError(
                f"unknown object type {name!r}; known types: {', '.join(sorted(self.concrete_types()))}", source=where or None
            ) from None

    def concrete_types(self) -> list[str]:
        return [n for n, t in self.types.items() if not t.abstract]

    def robot_types(self) -> list[str]:
        return [n for n, t in self.types.items() if t.is_robot and not t.abstract]

    def pddl_is_a(self, pddl_type: str, ancestor: str) -> bool:
        """True when `pddl_type` equals `ancestor` or descends from it in the PDDL type tree."""
        current: str | None = pddl_type
        while current is not None:
            if current == ancestor:
                return True
            current = self.pddl_types.get(current)
        return ancestor == "object"

    # --- SIEs ---------------------------------------------------------------------------------
    def sie(self, type_name: str, predicate: str):
        """The SIE instance deciding `predicate` for objects of `type_name`, or None if none is declared."""
        key = (type_name, predicate)
        if key not in self._sies:
            decl = self.get(type_name).predicates.get(predicate)
            if decl is None or decl.sie is None:
                self._sies[key] = None
            else:
                cls = load_sie_class(self._package, decl.sie)
                try:
                    instance = cls(**dict(decl.sie.params))
                except TypeError as exc:
                    raise ObjectDatabaseError(f"bad parameters for {decl.sie}: {exc}", source=decl.sie.source) from None
                instance.predicate = predicate
                instance.declaration = decl
                self._sies[key] = instance
        return self._sies[key]

    # --- PDDL view ----------------------------------------------------------------------------
    def _pddl_tree(self) -> dict[str, str | None]:
        tree: dict[str, str | None] = {"object": None}
        owner: dict[str, str] = {}
        for t in self.types.values():
            parent = self.types[t.parent].pddl_type if t.parent else "object"
            if t.pddl_type == parent or t.pddl_type == "object":
                continue
            if t.pddl_type in tree and tree[t.pddl_type] != parent:
                raise ObjectDatabaseError(
                    f"PDDL type {t.pddl_type!r} has parent {parent!r} here but {tree[t.pddl_type]!r} in type {owner[t.pddl_type]!r}",
                    source=str(t.source), field=f"{t.name}.pddl_type")
            tree[t.pddl_type] = parent
            owner.setdefault(t.pddl_type, t.name)
        return tree

    def _signatures(self) -> dict[str, PredicateDecl]:
        signatures: dict[str, PredicateDecl] = {}
        for t in self.types.values():
            for name, decl in t.predicates.items():
                for i, p in enumerate(decl.params):
                    if p not in self.pddl_types:
                        raise ObjectDatabaseError(
                            f"parameter type {p!r} is not a PDDL type of the database; known: {', '.join(sorted(self.pddl_types))}",
                            source=str(t.source), field=f"{t.name}.predicates.{name}.params[{i}]")
                other = signatures.get(name)
                if other is not None and other.params != decl.params:
                    raise ObjectDatabaseError(
                        f"predicate {name!r} declared with params {list(decl.params)} here but {list(other.params)} in type {other.declared_by!r}",
                        source=str(t.source), field=f"{t.name}.predicates.{name}")
                signatures.setdefault(name, decl)
        return signatures


def load_object_database(root: str | Path | None = None, *, datasets: Mapping[str, str | Path] | None = None) -> ObjectDatabase:
    """Load and validate the database under `root` (default: this repository's ``odb/``).

    `datasets` maps names used in ``dataset://NAME/...`` mesh paths to folders; names not given are looked up in
    the environment (``BRIDGE_DATASET_<NAME>``) and then in ``../shared/datasets/NAME`` beside the repository.
    """
    root = Path(root) if root is not None else DEFAULT_ROOT
    if not root.is_dir():
        raise ObjectDatabaseError("object database folder not found", source=str(root))
    given = {k: Path(v) for k, v in (datasets or {}).items()}
    wanted = dataset_names(root) - set(given)
    roots = {**dataset_roots_from_env(wanted, REPO_ROOT), **given}
    types, package = read_types(root, roots)
    return ObjectDatabase(root, types, package, roots)


def parse_dataset_options(options: Iterable[str]) -> dict[str, Path]:
    """``NAME=PATH`` strings from the command line."""
    roots = {}
    for item in options:
        name, sep, path = item.partition("=")
        if not sep or not name or not path:
            raise ObjectDatabaseError(f"--dataset takes NAME=PATH, got {item!r}")
        roots[name] = Path(path)
    return roots

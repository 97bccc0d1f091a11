"""The object database: resolved types plus the PDDL view of them (type tree, predicate signatures)."""
from __future__ import annotations

import inspect
from pathlib import Path
from typing import Iterable, Mapping

from ..errors import ObjectDatabaseError
from .loader import dataset_names, dataset_roots_from_env, load_sie_class, read_types
from .types import ObjectType, PredicateDecl, SIERef

REPO_ROOT = Path(__file__).resolve().parents[2]
DEFAULT_ROOT = REPO_ROOT / "odb"


class ObjectDatabase:
    """Read-only after loading; SIE instances are made once and cached, all of them when the database is read
    (`check_sies`), so a bad SIE parameter shows then (mass properties: bridge.sim.shapes)."""

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
                instance = make_sie(load_sie_class(self._package, decl.sie), decl.sie)
                instance.predicate = predicate
                instance.declaration = decl
                self._sies[key] = instance
        return self._sies[key]

    def check_sies(self) -> int:
        """Make the SIE of every predicate of every concrete type, so that a parameter its class does not take, or
        one it needs, is found when the database is read, not after a replay. Returns how many there are."""
        count = 0
        for name in self.concrete_types():
            for predicate in self.types[name].predicates:
                count += self.sie(name, predicate) is not None
        return count

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


def make_sie(cls: type, ref: SIERef):
    """An instance of the SIE class `ref` names, made with its parameters; a parameter the class does not take,
    one it needs that is not given, or a constructor that raises is one error naming the file and the entry."""
    params = dict(ref.params)
    source, entry = (ref.file, ref.entry) if ref.file else (ref.source, "")
    where = f"{entry}.params" if entry else "params"
    try:
        signature = inspect.signature(cls)
    except (TypeError, ValueError):  # a class whose constructor Python cannot inspect: its call says what is wrong
        signature = None
    if signature is not None:
        named = [p for p in signature.parameters.values() if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)]
        takes = ", ".join(p.name for p in named) or "none"
        if not any(p.kind is p.VAR_KEYWORD for p in signature.parameters.values()):
            unknown = sorted(k for k in params if k not in {p.name for p in named})
            if unknown:
                raise ObjectDatabaseError(f"SIE {ref} takes no parameter {unknown[0]!r}; its parameters: {takes}",
                                          source=source, field=f"{where}.{unknown[0]}")
        missing = [p.name for p in signature.parameters.values()
                   if p.default is p.empty and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD) and p.name not in params]
        if missing:
            raise ObjectDatabaseError(f"SIE {ref} needs the parameter {missing[0]!r} (its parameters: {takes})",
                                      source=source, field=f"{where}.{missing[0]}")
    try:
        return cls(**params)
    except Exception as exc:  # the SIE's own constructor refused the values
        given = ", ".join(f"{k}={v!r}" for k, v in params.items())
        raise ObjectDatabaseError(f"SIE {ref}({given}) failed: {type(exc).__name__}: {exc}", source=source,
                                  field=where) from None


def load_object_database(root: str | Path | None = None, *, datasets: Mapping[str, str | Path] | None = None) -> ObjectDatabase:
    """Load and validate the database under `root` (default: this repository's ``odb/``).

    `datasets` maps names used in ``dataset://NAME/...`` mesh paths to folders; names not given are looked up in
    the environment (``BRIDGE_DATASET_<NAME>``, then ``BRIDGE_<NAME>``) and then in ``../shared/datasets/NAME`` beside the repository.
    """
    root = Path(root) if root is not None else DEFAULT_ROOT
    if not root.is_dir():
        raise ObjectDatabaseError("object database folder not found", source=str(root))
    given = {k: Path(v) for k, v in (datasets or {}).items()}
    wanted = dataset_names(root) - set(given)
    roots = {**dataset_roots_from_env(wanted, REPO_ROOT), **given}
    types, package = read_types(root, roots)
    database = ObjectDatabase(root, types, package, roots)
    database.check_sies()
    return database


def parse_dataset_options(options: Iterable[str]) -> dict[str, Path]:
    """``NAME=PATH`` strings from the command line."""
    roots = {}
    for item in options:
        name, sep, path = item.partition("=")
        if not sep or not name or not path:
            raise ObjectDatabaseError(f"--dataset takes NAME=PATH, got {item!r}")
        roots[name] = Path(path)
    return roots

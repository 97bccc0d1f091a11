"""Reversible mapping between object names and PDDL identifiers.

PDDL names are case-insensitive identifiers; users name objects as they like ("Cup 1", "1st box"). A name that
is already a lowercase identifier is kept; any other is lowercased, its other characters replaced by '_', and
prefixed with 'o_' if it does not start with a letter. Two names that would meet are an error, never a silent merge.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Iterable, Mapping

from .errors import BridgeError

_BAD = re.compile(r"[^a-z0-9_\-]")


def to_identifier(name: str) -> str:
    ident = _BAD.sub("_", name.lower())
    if not ident or not ident[0].isalpha():
        ident = "o_" + ident
    return ident


@dataclass(frozen=True)
class NameMap:
    to_pddl: Mapping[str, str] = field(default_factory=dict)
    from_pddl: Mapping[str, str] = field(default_factory=dict)

    def pddl(self, name: str) -> str:
        return self.to_pddl.get(name, name)

    def original(self, ident: str) -> str:
        return self.from_pddl.get(ident.lower(), ident)

    def renamed(self) -> dict[str, str]:
        """Only the names that PDDL had to change: what must travel with a problem file."""
        return {k: v for k, v in self.to_pddl.items() if k != v}


def build_name_map(names: Iterable[str], *, source: str | None = None, error: type[BridgeError] = BridgeError) -> NameMap:
    """Map every name; two names that meet are an error naming both."""
    to_pddl: dict[str, str] = {}
    from_pddl: dict[str, str] = {}
    for name in names:
        ident = to_identifier(name)
        if ident in from_pddl:
            raise error(
                f"object names {from_pddl[ident]!r} and {name!r} both become the PDDL name {ident!r}; rename one",
                source=source, field="objects")
        to_pddl[name] = ident
        from_pddl[ident] = name
    return NameMap(to_pddl, from_pddl)

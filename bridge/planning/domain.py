"""The PDDL domain: types from the object database's type tree, predicates from its signatures, the templates' actions."""
from __future__ import annotations

from typing import Mapping

from pddl.core import Domain
from pddl.formatter import domain_to_string
from pddl.logic.predicates import Predicate
from pddl.logic.terms import Variable
from pddl.requirements import Requirements

from ..errors import PddlError
from ..odb import ObjectDatabase
from .parsing import KEYWORDS
from .templates import ActionTemplate, DomainSettings, check_requirements

DEFAULT_DOMAIN_NAME = DomainSettings.name


def build_domain(odb: ObjectDatabase, templates: Mapping[str, ActionTemplate], *, name: str | None = None,
                 settings: DomainSettings | None = None) -> Domain:
    """The domain of `templates` over the object database's types and predicates.

    Requirements are the settings' (checked to cover what the actions use) or, without settings, exactly what
    the actions use. `name` overrides the settings' name.
    """
    settings = settings or DomainSettings()
    requirements = check_requirements(settings, templates)
    domain_name = name or settings.name
    for word in (domain_name, *odb.pddl_types, *odb.predicates):
        if word.lower() in KEYWORDS and word != "object":
            raise PddlError(f"{word!r} is a PDDL keyword and cannot name a domain, type or predicate")
    try:
        return Domain(
            domain_name,
            requirements=[Requirements(r) for r in requirements],
            types=pddl_types(odb),
            predicates=predicate_skeletons(odb),
            actions=[t.to_action() for t in sorted(templates.values(), key=lambda t: t.name)],
        )
    except Exception as exc:  # the library's own validation: a bug in our checks if it ever fires
        raise PddlError(f"the pddl library rejected the domain: {exc}") from None


def domain_text(odb: ObjectDatabase, templates: Mapping[str, ActionTemplate], *, name: str | None = None,
                settings: DomainSettings | None = None) -> str:
    return domain_to_string(build_domain(odb, templates, name=name, settings=settings)) + "\n"


def pddl_types(odb: ObjectDatabase) -> dict[str, str | None]:
    """Child -> parent as the library wants it: children of `object` map to None.

    `object` itself is listed (with no parent) so that ``?x - object`` passes the library's check; it is not
    printed. VAL needs the explicit ``- object``: it rejects untyped variables in a typed domain.
    """
    return {t: (None if parent == "object" else parent) for t, parent in odb.pddl_types.items()}


def predicate_skeletons(odb: ObjectDatabase) -> list[Predicate]:
    """``(on ?a - movable ?b - object)``: one predicate per signature."""
    return [Predicate(name, *(Variable(_letter(i), [p]) for i, p in enumerate(decl.params)))
            for name, decl in sorted(odb.predicates.items())]


def _letter(i: int) -> str:
    return "abcdefghijklmnopqrstuvwxyz"[i] if i < 26 else f"x{i}"

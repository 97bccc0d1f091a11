"""Action templates (paper, Section III-A): a symbolic PDDL header plus the name of the motion that grounds it.

One YAML file per action under ``pddl/templates/``, and ``pddl/domain.yaml`` for the domain's name and
requirements::

    name: push_over
    doc: Tip an upright box over by pushing it high on its side.
    parameters: "?r - robot ?o - box ?s - object"
    precondition: "(and (upright ?o) (on ?o ?s) (clear ?o) (hand-empty ?r))"
    effect: "(not (upright ?o))"
    body: push_over          # the motion generator in bridge/sim/bodies.py; optional

The PDDL is parsed with the `pddl` library; what it leaves unchecked (declared predicates, arities, argument
types, variable scopes, known types) is checked against the object database. Every problem is one `PddlError`
naming the file and the field.
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

from pddl.action import Action
from pddl.logic.base import Formula
from pddl.logic.terms import Variable

from ..errors import PddlError
from ..odb import ObjectDatabase
from ..odb.database import REPO_ROOT
from ..files import read_yaml
from ..values import is_identifier
from .formulas import FormulaChecker, expand_requirements, used_requirements, variable_type
from .parsing import KEYWORDS, SUPPORTED_REQUIREMENTS, parse_action, relocated

PDDL_ROOT = REPO_ROOT / "pddl"
TEMPLATE_KEYS = {"name", "doc", "parameters", "precondition", "effect", "body"}
REQUIRED_KEYS = ("name", "parameters", "precondition", "effect")
DOMAIN_KEYS = {"name", "doc", "requirements"}


@dataclass(frozen=True)
class ActionTemplate:
    """One action: typed parameters, precondition and effect (pddl library formulas), and its motion."""

    name: str
    parameters: tuple[tuple[str, str], ...]  # (variable without '?', PDDL type)
    precondition: Formula
    effect: Formula
    body: str | None = None
    doc: str = ""
    source: Path | None = None

    @property
    def requirements(self) -> frozenset[str]:
        """The PDDL requirements this action uses."""
        return used_requirements(self.precondition, self.effect)

    def signature(self) -> str:
        """``?r - robot ?o - box ?s - object``"""
        return " ".join(f"?{v} - {t}" for v, t in self.parameters)

    def to_action(self) -> Action:
        """The library's `Action`."""
        params = [Variable(v, [t]) for v, t in self.parameters]
        return Action(self.name, params, precondition=self.precondition, effect=self.effect)


@dataclass(frozen=True)
class DomainSettings:
    """``pddl/domain.yaml``: the domain's name and the requirements it declares."""

    name: str = "bridge-tabletop"
    requirements: tuple[str, ...] | None = None  # None: exactly what the templates use
    doc: str = ""
    source: Path | None = None


# --- domain settings ----------------------------------------------------------------------------
def load_domain_settings(root: str | Path | None = None) -> DomainSettings:
    """Read ``domain.yaml`` from `root` (the folder holding it, or the file itself; default: ``pddl/``)."""
    path = Path(root) if root is not None else PDDL_ROOT
    if path.is_dir():
        path = path / "domain.yaml"
    src = str(path)
    data = read_yaml(path, "domain settings file", PddlError)
    if not isinstance(data, dict):
        raise PddlError("must be a mapping with 'name' and 'requirements'", source=src)
    _no_unknown(data, DOMAIN_KEYS, src, None)
    name = data.get("name", DomainSettings.name)
    _check_name(name, src, "name", "domain")
    requirements = data.get("requirements")
    if requirements is not None:
        if not isinstance(requirements, list) or not all(isinstance(r, str) for r in requirements):
            raise PddlError("must be a list of PDDL requirements like [strips, typing]", source=src, field="requirements")
        requirements = tuple(r.lstrip(":").lower() for r in requirements)
        for i, r in enumerate(requirements):
            if r not in SUPPORTED_REQUIREMENTS:
                raise PddlError(f"unsupported requirement {r!r}; supported: {', '.join(SUPPORTED_REQUIREMENTS)}",
                                source=src, field=f"requirements[{i}]")
    doc = data.get("doc", "")
    if not isinstance(doc, str):
        raise PddlError("must be text", source=src, field="doc")
    return DomainSettings(str(name), requirements, doc, path)


def check_requirements(settings: DomainSettings, templates: Mapping[str, ActionTemplate]) -> tuple[str, ...]:
    """The requirements to declare: the settings' own, after checking they cover what every action uses."""
    used = set().union(*(t.requirements for t in templates.values())) if templates else {"strips", "typing"}
    if settings.requirements is None:
        return tuple(r for r in SUPPORTED_REQUIREMENTS if r in used)
    declared = expand_requirements(settings.requirements)
    for template in sorted(templates.values(), key=lambda t: t.name):
        missing = sorted(template.requirements - declared)
        if missing:
            raise PddlError(f"action {template.name!r} ({template.source}) uses {', '.join(missing)}, which is not declared; "
                            f"declared: {', '.join(settings.requirements)}",
                            source=str(settings.source) if settings.source else None, field="requirements")
    return settings.requirements


# --- templates ----------------------------------------------------------------------------------
def load_action_templates(folder: str | Path | None, odb: ObjectDatabase) -> dict[str, ActionTemplate]:
    """Every ``*.yaml`` in `folder` (default ``pddl/templates``), checked against the object database."""
    folder = Path(folder) if folder is not None else PDDL_ROOT / "templates"
    if not folder.is_dir():
        raise PddlError("action template folder not found", source=str(folder))
    paths = sorted(folder.glob("*.yaml"))
    if not paths:
        raise PddlError("no action templates (*.yaml) in this folder", source=str(folder))
    templates: dict[str, ActionTemplate] = {}
    for path in paths:
        template = load_action_template(path, odb)
        key = template.name.lower()  # PDDL names ignore case
        if key in templates:
            raise PddlError(f"action name {template.name!r} is already used by {templates[key].source}",
                            source=str(path), field="name")
        templates[key] = template
    return templates


def load_action_template(path: str | Path, odb: ObjectDatabase) -> ActionTemplate:
    path = Path(path)
    src = str(path)
    data = read_yaml(path, "action template", PddlError)
    if not isinstance(data, dict):
        raise PddlError(f"an action template is a mapping with keys {', '.join(REQUIRED_KEYS)} (and doc, body)", source=src)
    _no_unknown(data, TEMPLATE_KEYS, src, None)
    for key in REQUIRED_KEYS:
        if key not in data or data[key] is None:
            raise PddlError(f"missing key {key!r}; an action template needs {', '.join(REQUIRED_KEYS)}", source=src, field=key)
    name = data["name"]
    _check_name(name, src, "name", "action")
    for key in ("parameters", "precondition", "effect"):
        if not isinstance(data[key], str):
            raise PddlError(f"must be PDDL written as text (quote it), got {data[key]!r}", source=src, field=key)
    body = data.get("body")
    if body is not None:
        _check_name(body, src, "body", "motion generator", pddl=False)
    doc = data.get("doc", "")
    if not isinstance(doc, str):
        raise PddlError("must be text", source=src, field="doc")

    fields = {k: data[k] for k in ("parameters", "precondition", "effect")}
    written = [w.lower() for w in re.findall(r"\?([A-Za-z][-_A-Za-z0-9]*)", fields["parameters"])]
    twice = sorted({w for w in written if written.count(w) > 1})
    if twice:
        raise PddlError(f"parameter ?{twice[0]} is declared twice", source=src, field="parameters")
    try:
        action = parse_action(name, fields)
    except PddlError as exc:
        raise relocated(exc, source=src) from None
    parameters = _parameters(action, odb, src)
    scope = dict(parameters)
    checker = FormulaChecker(odb)
    for key, check in (("precondition", checker.condition), ("effect", checker.effect)):
        try:
            check(getattr(action, key), scope)
        except PddlError as exc:
            raise relocated(exc, source=src, field=key) from None
    return ActionTemplate(
        name=str(name), parameters=parameters,
        precondition=action.precondition, effect=action.effect,
        body=body, doc=doc.strip(), source=path)


def _parameters(action: Action, odb: ObjectDatabase, src: str) -> tuple[tuple[str, str], ...]:
    result = []
    for variable in action.parameters:
        try:
            result.append((str(variable.name).lower(), variable_type(variable, odb)))
        except PddlError as exc:
            raise relocated(exc, source=src, field="parameters") from None
    return tuple(result)


def _check_name(value: Any, src: str, fld: str, what: str, *, pddl: bool = True) -> None:
    if not isinstance(value, str) or not is_identifier(value):
        raise PddlError(f"{what} name {value!r} is not an identifier (a letter, then letters, digits, '_' or '-')",
                        source=src, field=fld)
    if pddl and value.lower() in KEYWORDS:
        raise PddlError(f"{what} name {value!r} is a PDDL keyword", source=src, field=fld)


def _no_unknown(data: Mapping[str, Any], valid: set[str], src: str, fld: str | None) -> None:
    unknown = sorted(str(k) for k in set(data) - valid)
    if unknown:
        raise PddlError(f"unknown key {unknown[0]!r}; valid keys: {', '.join(sorted(valid))}", source=src, field=fld)

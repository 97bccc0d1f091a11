"""The one place that talks to the `pddl` library's parser; everything else gets formulas or a `PddlError`.

Three gaps of pddl 0.5.1 are bridged here, so the rest of the package can trust what it gets:

- The library validates a whole `Domain` while parsing, and rejects ``?x - object`` (it counts ``object`` as an
  available type only when a domain lists it). Actions are therefore parsed without building a `Domain`; the
  semantic checks (types, predicates, arities, scopes) are ours, in `formulas.py`.
- A problem's goal is parsed with an empty requirement set, so ``or``, ``forall`` and ``=`` in a goal fail.
  Goals are parsed with every requirement allowed and checked against the object database afterwards.
- A parser object keeps state after an error. The grammar is compiled once; every parse gets a fresh transformer.
"""
from __future__ import annotations

import functools
import re
from dataclasses import dataclass
from typing import Any

from lark import Lark
from lark.exceptions import UnexpectedCharacters, UnexpectedEOF, UnexpectedInput, UnexpectedToken, VisitError
from pddl.action import Action
from pddl.core import Plan, Problem
from pddl.parser import GRAMMAR_FILE, PARSERS_DIRECTORY
from pddl.parser.domain import DomainTransformer
from pddl.parser.plan import PlanTransformer
from pddl.parser.problem import ProblemTransformer
from pddl.parser.symbols import ALL_SYMBOLS
from pddl.requirements import Requirements

from ..errors import BridgeError, PddlError
from ..values import is_identifier

# Words PDDL (and the library) reserve: no object, action, predicate or type may be called like this.
KEYWORDS = frozenset(s for s in ALL_SYMBOLS if is_identifier(s))

# What a template may use; the requirements a domain must declare are computed from what the actions do use.
SUPPORTED_REQUIREMENTS = (
    "strips", "typing", "negative-preconditions", "disjunctive-preconditions", "equality",
    "existential-preconditions", "universal-preconditions", "quantified-preconditions", "conditional-effects", "adl",
)


@functools.cache
def _grammar(start: str) -> Lark:
    """Compiling the grammar takes ~0.1 s; parsing a template ~2 ms."""
    return Lark(GRAMMAR_FILE.read_text(encoding="utf-8"), parser="lalr", import_paths=[PARSERS_DIRECTORY], start=start)


class _ActionTransformer(DomainTransformer):
    """Returns the parsed actions instead of a validated `Domain` (see the module docstring)."""

    def domain(self, args):
        return [arg for arg in args if isinstance(arg, Action)]


class _ProblemTransformer(ProblemTransformer):
    def __init__(self) -> None:
        super().__init__()
        # the library never hands a problem's requirements to the goal parser; allow what templates may use
        self._domain_transformer._extended_requirements = {Requirements(r) for r in SUPPORTED_REQUIREMENTS}

    # ... nor the rules that read quantified variables in a goal
    def typed_list_variable(self, args):
        return self._domain_transformer.typed_list_variable(args)

    def type_def(self, args):
        return self._domain_transformer.type_def(args)


def relocated(exc: BridgeError, *, source: str | None = None, field: str | None = None) -> BridgeError:
    """The same error (same class, same message) placed in `source` and `field` (kept from `exc` when not given)."""
    where = ": ".join(part for part in (exc.source, exc.field) if part)
    text = str(exc)
    message = text[len(where) + 2:] if where and text.startswith(where + ": ") else text
    return type(exc)(message, source=source if source is not None else exc.source,
                     field=field if field is not None else exc.field)


@dataclass(frozen=True)
class SyntaxProblem:
    """A parse failure: a one-line message and, when the parser knows it, the character offset in the text."""

    message: str
    offset: int | None = None


class _ParseFailure(Exception):
    def __init__(self, problem: SyntaxProblem):
        super().__init__(problem.message)
        self.problem = problem


def _transform(start: str, transformer: Any, text: str) -> Any:
    """Parse `text` from grammar rule `start`; any failure becomes a `SyntaxProblem` raised as `_ParseFailure`."""
    try:
        tree = _grammar(start).parse(text)
    except UnexpectedInput as exc:
        raise _ParseFailure(_describe(exc, text)) from None
    try:
        return transformer.transform(tree)
    except VisitError as exc:
        raise _ParseFailure(SyntaxProblem(_library_message(exc.orig_exc))) from None
    except Exception as exc:  # the library signals with ValueError, AssertionError, its own errors, ...
        raise _ParseFailure(SyntaxProblem(_library_message(exc))) from None


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip() or type(exc).__name__
    return text.splitlines()[0]


def _library_message(exc: BaseException) -> str:
    text = _first_line(exc)
    match = re.fullmatch(r"Constant '(.+)' not defined\.", text)
    if match:
        return f"{match.group(1)!r} is not a variable: write ?{match.group(1)}; a template names objects only through variables"
    return text


def _describe(exc: UnexpectedInput, text: str) -> SyntaxProblem:
    if isinstance(exc, UnexpectedEOF):
        return SyntaxProblem("unexpected end of text (a parenthesis not closed?)", len(text))
    if isinstance(exc, UnexpectedCharacters):
        return SyntaxProblem(f"unexpected character {text[exc.pos_in_stream]!r}", exc.pos_in_stream)
    if isinstance(exc, UnexpectedToken):
        token = exc.token
        if token.type == "$END":
            return SyntaxProblem("unexpected end of text (a parenthesis not closed?)", len(text))
        return SyntaxProblem(f"unexpected {str(token)!r}", token.start_pos)
    return SyntaxProblem(_first_line(exc), getattr(exc, "pos_in_stream", None))


# --- entry points -------------------------------------------------------------------------------
_ACTION_HEAD = ("(define (domain check)\n(:requirements " + " ".join(":" + r for r in SUPPORTED_REQUIREMENTS) + ")\n"
                "(:action {name}\n:parameters (")


def _action_text(name: str, fields: dict[str, str]) -> tuple[str, list[tuple[int, int, str | None]]]:
    """The action as a domain text, with the span each field occupies in it."""
    layout = [(_ACTION_HEAD.format(name=name), None), (fields["parameters"], "parameters"), ("\n)\n:precondition ", None),
              (fields["precondition"], "precondition"), ("\n:effect ", None), (fields["effect"], "effect"), ("\n))", None)]
    text, spans = "", []
    for part, key in layout:
        spans.append((len(text), len(text) + len(part), key))
        text += part
    return text, spans


def parse_action(name: str, fields: dict[str, str]) -> Action:
    """Parse one action from its `parameters`, `precondition` and `effect` texts.

    Raises `PddlError` with `field` set to the field the parser stumbled in (the source is added by the caller).
    """
    for key in ("parameters", "precondition", "effect"):
        problem = check_parentheses(fields[key], allow_forms=key != "parameters")
        if problem:
            raise PddlError(problem, field=key)
    text, spans = _action_text(name, fields)
    try:
        return _transform("domain", _ActionTransformer(), text)[0]
    except _ParseFailure as failure:
        key, where = _locate(failure.problem, spans, name, fields, text)
        raise PddlError(failure.problem.message + where, field=key) from None


def _locate(problem: SyntaxProblem, spans, name: str, fields: dict[str, str], text: str) -> tuple[str, str]:
    """The field an error lies in: from its offset (one in the layout right after a field, past nothing but
    white space, is that field's end), or else by parsing the fields one after the other."""
    if problem.offset is not None:
        offset, last = problem.offset, None
        for start, end, key in spans:
            if key and start <= offset <= end:
                local = offset - start
                return key, f" (at character {local + 1}: {_excerpt(fields[key], local)})"
            if key:
                last = (start, end, key)
            elif last is not None and start <= offset <= end and not text[last[1]:offset].strip():
                local = last[1] - last[0]
                return last[2], f" (at character {local + 1}: {_excerpt(fields[last[2]], local)})"
        return "effect", ""
    for key, partial in (("parameters", {**fields, "precondition": "(and)", "effect": "(and)"}),
                         ("precondition", {**fields, "effect": "(and)"})):
        try:
            _transform("domain", _ActionTransformer(), _action_text(name, partial)[0])
        except _ParseFailure:
            return key, ""
    return "effect", ""


def _excerpt(text: str, offset: int, span: int = 20) -> str:
    start = max(0, offset - span)
    snippet = text[start:offset + span].replace("\n", " ")
    return ("..." if start else "") + snippet + ("..." if offset + span < len(text) else "")


def parse_problem(text: str) -> Problem:
    """A problem file's text (objects, init, goal); raises `PddlError` without a source."""
    try:
        return _transform("problem", _ProblemTransformer(), text)
    except _ParseFailure as failure:
        where = ""
        if failure.problem.offset is not None:
            line = text.count("\n", 0, failure.problem.offset) + 1
            where = f" (line {line})"
        raise PddlError(f"PDDL syntax error: {failure.problem.message}{where}") from None


_GOAL_HEAD = "(define (problem goal) (:domain goal) (:init)\n(:goal "


def parse_goal(text: str):
    """A goal formula written in PDDL, e.g. ``(and (on box tray) (not (upright box)))``."""
    problem = check_parentheses(text, allow_forms=True)
    if problem:
        raise PddlError(problem, field="goal")
    try:
        return _transform("problem", _ProblemTransformer(), _GOAL_HEAD + text + "\n))").goal
    except _ParseFailure as failure:
        where = ""
        local = None if failure.problem.offset is None else failure.problem.offset - len(_GOAL_HEAD)
        if local is not None and 0 <= local <= len(text):
            where = f" (at character {local + 1}: {_excerpt(text, local)})"
        raise PddlError(f"PDDL syntax error: {failure.problem.message}{where}", field="goal") from None


def parse_plan(text: str) -> Plan:
    """A plan as planners write it: one ``(action arg ...)`` per line, ``;`` comments."""
    try:
        return _transform("plan", PlanTransformer(), text)
    except _ParseFailure as failure:
        where = ""
        if failure.problem.offset is not None:
            where = f" (line {text.count(chr(10), 0, failure.problem.offset) + 1})"
        raise PddlError(f"plan syntax error: {failure.problem.message}{where}") from None


def check_parentheses(text: str, *, allow_forms: bool) -> str | None:
    """None if `text` is one balanced formula (or, for parameters, has no parentheses); else what is wrong.

    Checked before parsing so a field can neither reach into the text around it nor give a confusing message.
    """
    if not isinstance(text, str):
        return f"must be PDDL written as text, got {text!r}"
    # comments blanked, not removed, so positions count in the text as written
    code = "\n".join(line if ";" not in line else line[:line.index(";")] + " " * (len(line) - line.index(";"))
                     for line in text.splitlines())
    if not allow_forms:
        if re.search(r"(?<![\w?-])either(?![\w-])", code, re.IGNORECASE):
            return "(either ...) types are not supported; give each parameter one type"
        if "(" in code or ")" in code:
            return "parameters are written without parentheses, e.g. '?r - robot ?o - box'"
        return None
    if not code.strip():
        return "is empty; write a formula such as '(and)'"
    depth, closed_at = 0, None
    for i, ch in enumerate(code):
        if ch == "(":
            if depth == 0 and closed_at is not None:
                return f"more than one formula (a second one starts at character {i + 1}); wrap them in (and ...)"
            depth += 1
        elif ch == ")":
            depth -= 1
            if depth < 0:
                return f"unbalanced parentheses: ')' at character {i + 1} closes nothing"
            if depth == 0:
                closed_at = i
        elif depth == 0 and not ch.isspace():
            return f"must be a formula in parentheses, found {code[i:].split()[0]!r} outside"
    if depth > 0:
        return f"unbalanced parentheses: {depth} '(' not closed"
    return None

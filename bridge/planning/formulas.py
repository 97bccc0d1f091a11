"""What the `pddl` library does not check about formulas, and small walks over them.

- `FormulaChecker`: every atom names a declared predicate with the right arity and argument types, every variable
  is declared (a parameter or a quantifier), every object is known. Raises `PddlError` without a source; callers
  add the file and field.
- `used_requirements`: the PDDL requirements a precondition and effect need, so a domain declares exactly those.
- `map_terms`: the same formula with its terms replaced (goal objects written in their canonical PDDL names).
- `ground_text`: a formula printed with its variables replaced by object names, for messages.
"""
from __future__ import annotations

from typing import Callable, Mapping

from pddl.logic.base import And, ExistsCondition, ForallCondition, Formula, Imply, Not, Or
from pddl.logic.effects import Forall, When
from pddl.logic.predicates import EqualTo, Predicate
from pddl.logic.terms import Constant, Term, Variable

from ..errors import PddlError
from ..odb import ObjectDatabase

Scope = Mapping[str, str]  # variable name (lowercase, no '?') -> PDDL type


def variable_type(variable: Variable, odb: ObjectDatabase) -> str:
    """The PDDL type of a declared variable; an untyped one is an `object`."""
    tags = sorted(str(t).lower() for t in variable.type_tags)
    if len(tags) > 1:
        raise PddlError(f"?{variable.name} has the types (either {' '.join(tags)}); give one type")
    pddl_type = tags[0] if tags else "object"
    if pddl_type not in odb.pddl_types:
        raise PddlError(f"unknown type {pddl_type!r} of ?{variable.name}; PDDL types: {', '.join(sorted(odb.pddl_types))}")
    return pddl_type


def declare(variables, scope: Scope, odb: ObjectDatabase) -> dict[str, str]:
    """`scope` plus the quantified `variables` (an inner declaration hides an outer one of the same name)."""
    inner = dict(scope)
    for v in sorted(variables, key=lambda v: str(v.name)):
        inner[str(v.name).lower()] = variable_type(v, odb)
    return inner


class FormulaChecker:
    """Checks formulas against the object database; `objects` (PDDL name -> PDDL type) for ground formulas."""

    def __init__(self, odb: ObjectDatabase, objects: Mapping[str, str] | None = None):
        self.odb = odb
        self.objects = {k.lower(): v for k, v in (objects or {}).items()}
        self.predicates = {name.lower(): decl for name, decl in odb.predicates.items()}

    # --- conditions ---------------------------------------------------------------------------
    def condition(self, formula: Formula, scope: Scope) -> None:
        if isinstance(formula, Predicate):
            self.atom(formula, scope)
        elif isinstance(formula, EqualTo):
            self.term_type(formula.left, scope, formula)
            self.term_type(formula.right, scope, formula)
        elif isinstance(formula, (And, Or, Imply)):
            for operand in formula.operands:
                self.condition(operand, scope)
        elif isinstance(formula, Not):
            self.condition(formula.argument, scope)
        elif isinstance(formula, (ForallCondition, ExistsCondition)):
            self.condition(formula.condition, declare(formula.variables, scope, self.odb))
        else:
            raise PddlError(f"{formula} is not supported in a condition (use and, or, not, imply, forall, exists, =, atoms)")

    # --- effects ------------------------------------------------------------------------------
    def effect(self, formula, scope: Scope) -> None:
        if isinstance(formula, Predicate):
            self.atom(formula, scope)
        elif isinstance(formula, Not) and isinstance(formula.argument, Predicate):
            self.atom(formula.argument, scope)
        elif isinstance(formula, Not) or isinstance(formula, EqualTo):
            raise PddlError(f"{formula} cannot be an effect: an effect adds an atom or deletes one with (not (atom ...))")
        elif isinstance(formula, And):
            for operand in formula.operands:
                self.effect(operand, scope)
        elif isinstance(formula, When):
            self.condition(formula.condition, scope)
            self.effect(formula.effect, scope)
        elif isinstance(formula, Forall):
            self.effect(formula.effect, declare(formula.variables, scope, self.odb))
        else:
            raise PddlError(f"{formula} is not supported in an effect (use and, not, when, forall, atoms)")

    # --- atoms and terms ----------------------------------------------------------------------
    def atom(self, atom: Predicate, scope: Scope) -> None:
        name = str(atom.name).lower()
        decl = self.predicates.get(name)
        if decl is None:
            raise PddlError(f"predicate {name!r} is not declared; declared: {', '.join(sorted(self.predicates))}")
        if atom.arity != decl.arity:
            raise PddlError(f"{atom}: {name} takes {decl.arity} argument(s) ({' '.join(decl.params)}), got {atom.arity}")
        for term, expected in zip(atom.terms, decl.params):
            actual = self.term_type(term, scope, atom)
            if not self.odb.pddl_is_a(actual, expected):
                raise PddlError(f"{atom}: {term} is {article(actual)}, but {name} expects {article(expected)} there")

    def term_type(self, term: Term, scope: Scope, where: Formula) -> str:
        if isinstance(term, Variable):
            key = str(term.name).lower()
            if key not in scope:
                raise PddlError(f"{where}: variable ?{term.name} is not declared in the parameters or a quantifier")
            return scope[key]
        key = str(term.name).lower()
        if key not in self.objects:
            known = ", ".join(sorted(self.objects)) or "none"
            raise PddlError(f"{where}: unknown object {str(term.name)!r}; objects: {known}")
        return self.objects[key]


def article(word: str) -> str:
    """'a box', 'an object'."""
    return ("an " if word[:1].lower() in "aeiou" else "a ") + word


# --- requirements -------------------------------------------------------------------------------
REQUIREMENT_GROUPS = {
    "adl": {"strips", "typing", "negative-preconditions", "disjunctive-preconditions", "equality",
            "existential-preconditions", "universal-preconditions", "quantified-preconditions", "conditional-effects"},
    "quantified-preconditions": {"existential-preconditions", "universal-preconditions"},
}


def expand_requirements(requirements) -> frozenset[str]:
    """The requirements a declared set stands for (``adl`` covers most)."""
    result = set(requirements)
    for group, members in REQUIREMENT_GROUPS.items():
        if group in result:
            result |= members
    return frozenset(result)


def used_requirements(precondition: Formula | None, effect) -> frozenset[str]:
    """The requirements an action's precondition and effect use (always strips and typing)."""
    used = {"strips", "typing"}

    def condition(f) -> None:
        if isinstance(f, Not):
            used.add("negative-preconditions")
            condition(f.argument)
        elif isinstance(f, (Or, Imply)):
            used.add("disjunctive-preconditions")
            for op in f.operands:
                condition(op)
        elif isinstance(f, And):
            for op in f.operands:
                condition(op)
        elif isinstance(f, ForallCondition):
            used.add("universal-preconditions")
            condition(f.condition)
        elif isinstance(f, ExistsCondition):
            used.add("existential-preconditions")
            condition(f.condition)
        elif isinstance(f, EqualTo):
            used.add("equality")

    def eff(f) -> None:
        if isinstance(f, And):
            for op in f.operands:
                eff(op)
        elif isinstance(f, When):
            used.add("conditional-effects")
            condition(f.condition)
            eff(f.effect)
        elif isinstance(f, Forall):
            used.add("conditional-effects")  # PDDL puts universal effects under :conditional-effects
            eff(f.effect)

    if precondition is not None:
        condition(precondition)
    if effect is not None:
        eff(effect)
    return frozenset(used)


# --- rewriting and printing ---------------------------------------------------------------------
def map_terms(formula, fn: Callable[[Term], Term]):
    """The same formula with every term (and every quantified variable) replaced by `fn(term)`."""
    if isinstance(formula, Predicate):
        return Predicate(formula.name, *(fn(t) for t in formula.terms))
    if isinstance(formula, EqualTo):
        return EqualTo(fn(formula.left), fn(formula.right))
    if isinstance(formula, (And, Or, Imply)):
        return type(formula)(*(map_terms(op, fn) for op in formula.operands))
    if isinstance(formula, Not):
        return Not(map_terms(formula.argument, fn))
    if isinstance(formula, (ForallCondition, ExistsCondition)):
        return type(formula)(map_terms(formula.condition, fn), [fn(v) for v in _ordered(formula.variables)])
    if isinstance(formula, When):
        return When(map_terms(formula.condition, fn), map_terms(formula.effect, fn))
    if isinstance(formula, Forall):
        return Forall(map_terms(formula.effect, fn), [fn(v) for v in _ordered(formula.variables)])
    raise PddlError(f"{formula} is not supported")


def _ordered(variables) -> list[Variable]:
    return sorted(variables, key=lambda v: str(v.name))


def ground_text(formula, binding: Mapping[str, str], names: Callable[[str], str] = str) -> str:
    """`formula` printed with variables bound to object names (`names` maps a PDDL constant to how to print it)."""

    def term(t: Term) -> str:
        if isinstance(t, Variable):
            return binding.get(str(t.name).lower(), f"?{t.name}")
        return names(str(t.name))

    if isinstance(formula, Predicate):
        return "(" + " ".join([str(formula.name), *(term(t) for t in formula.terms)]) + ")"
    if isinstance(formula, EqualTo):
        return f"(= {term(formula.left)} {term(formula.right)})"
    if isinstance(formula, (And, Or, Imply)):
        return f"({formula.SYMBOL} " + " ".join(ground_text(op, binding, names) for op in formula.operands) + ")"
    if isinstance(formula, Not):
        return f"(not {ground_text(formula.argument, binding, names)})"
    if isinstance(formula, (ForallCondition, ExistsCondition)):
        bound = {str(v.name).lower() for v in formula.variables}
        inner = {k: v for k, v in binding.items() if k not in bound}
        declared = " ".join(f"?{v.name}" + (f" - {' '.join(sorted(map(str, v.type_tags)))}" if v.type_tags else "")
                            for v in _ordered(formula.variables))
        return f"({formula.SYMBOL} ({declared}) {ground_text(formula.condition, inner, names)})"
    return str(formula)


def constant_names(formula) -> set[str]:
    """Every constant (object) a formula names, lowercase."""
    found: set[str] = set()

    def collect(t: Term) -> Term:
        if isinstance(t, Constant):
            found.add(str(t.name).lower())
        return t

    if formula is not None:
        map_terms(formula, collect)
    return found

"""Apply ground actions to a world state: the autonomous half of the paper's loop (Section III-A).

An action applies when its precondition holds in the state; the successor has the effects' deletes removed and
then their adds added (PDDL semantics: an atom both deleted and added holds afterwards). Conditions of ``when``
effects are evaluated in the state before the action. Poses are not touched: this is the symbolic state only.
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable, Iterator, Mapping, Sequence

from pddl.logic.base import And, ExistsCondition, ForallCondition, Formula, Imply, Not, Or
from pddl.logic.effects import Forall, When
from pddl.logic.predicates import EqualTo, Predicate
from pddl.logic.terms import Term, Variable

from ..errors import ActionError, PddlError
from ..files import read_text_file
from ..odb import ObjectDatabase
from ..values import Fact
from ..world import WorldState
from .formulas import FormulaChecker, article, ground_text
from .parsing import parse_goal, parse_plan, relocated
from .problem import pddl_objects, problem_names
from .templates import ActionTemplate


@dataclass(frozen=True)
class PlanStep:
    """One ground action, e.g. ``PlanStep("pick", ("arm", "small_box", "table"))``."""

    action: str
    args: tuple[str, ...] = ()

    def __str__(self) -> str:
        return "(" + " ".join((self.action, *self.args)) + ")"


class StateView:
    """A world state as a planner sees it: facts by predicate and arguments, objects by PDDL type."""

    def __init__(self, world: WorldState, odb: ObjectDatabase):
        self.world = world
        self.odb = odb
        self.names = problem_names(world)
        self.types = {n: odb.get(world.type_name(n)).pddl_type for n in world.all_names()}
        self.facts = {(f.predicate.lower(), f.args) for f in world.facts}
        self.predicates = {name.lower(): name for name in odb.predicates}

    # --- objects ------------------------------------------------------------------------------
    def resolve(self, name: str) -> str | None:
        """An object's name from its own name or its PDDL name."""
        if name in self.types:
            return name
        original = self.names.original(name.lower())
        return original if original in self.types else None

    def objects_of(self, pddl_type: str) -> list[str]:
        return [n for n, t in self.types.items() if self.odb.pddl_is_a(t, pddl_type)]

    def value(self, term: Term, binding: Mapping[str, str]) -> str:
        if isinstance(term, Variable):
            return binding[str(term.name).lower()]
        resolved = self.resolve(str(term.name))
        if resolved is None:
            raise PddlError(f"unknown object {str(term.name)!r}")
        return resolved

    def bindings(self, variables, binding: Mapping[str, str]) -> Iterator[dict[str, str]]:
        """Every assignment of objects of the right types to quantified `variables`, added to `binding`."""
        ordered = sorted(variables, key=lambda v: str(v.name))
        domains = [self.objects_of(_type_of(v)) for v in ordered]
        for combo in itertools.product(*domains):
            yield {**binding, **{str(v.name).lower(): obj for v, obj in zip(ordered, combo)}}

    # --- conditions ---------------------------------------------------------------------------
    def holds(self, formula: Formula, binding: Mapping[str, str]) -> bool:
        return self.unmet(formula, binding) is None

    def unmet(self, formula: Formula, binding: Mapping[str, str]) -> str | None:
        """None when `formula` holds; otherwise the first part that does not, as ground text."""
        if isinstance(formula, Predicate):
            key = (str(formula.name).lower(), tuple(self.value(t, binding) for t in formula.terms))
            return None if key in self.facts else self.text(formula, binding)
        if isinstance(formula, EqualTo):
            same = self.value(formula.left, binding) == self.value(formula.right, binding)
            return None if same else self.text(formula, binding)
        if isinstance(formula, Not):
            return self.text(formula, binding) if self.holds(formula.argument, binding) else None
        if isinstance(formula, And):
            for operand in formula.operands:
                reason = self.unmet(operand, binding)
                if reason:
                    return reason
            return None
        if isinstance(formula, Or):
            return None if any(self.holds(op, binding) for op in formula.operands) else self.text(formula, binding)
        if isinstance(formula, Imply):
            premise, conclusion = formula.operands
            return self.unmet(conclusion, binding) if self.holds(premise, binding) else None
        if isinstance(formula, ForallCondition):
            for inner in self.bindings(formula.variables, binding):
                reason = self.unmet(formula.condition, inner)
                if reason:
                    return reason
            return None
        if isinstance(formula, ExistsCondition):
            if any(self.holds(formula.condition, inner) for inner in self.bindings(formula.variables, binding)):
                return None
            return self.text(formula, binding)
        raise PddlError(f"cannot evaluate {formula}")

    def text(self, formula: Formula, binding: Mapping[str, str]) -> str:
        return ground_text(formula, binding, lambda ident: self.resolve(ident) or ident)

    # --- effects ------------------------------------------------------------------------------
    def changes(self, effect, binding: Mapping[str, str]) -> tuple[set[Fact], set[Fact]]:
        """(adds, deletes) of an effect, every condition evaluated in this (the earlier) state."""
        adds: set[Fact] = set()
        deletes: set[Fact] = set()

        def collect(f, b: Mapping[str, str]) -> None:
            if isinstance(f, Predicate):
                adds.add(self.fact(f, b))
            elif isinstance(f, Not):
                deletes.add(self.fact(f.argument, b))
            elif isinstance(f, And):
                for op in f.operands:
                    collect(op, b)
            elif isinstance(f, When):
                if self.holds(f.condition, b):
                    collect(f.effect, b)
            elif isinstance(f, Forall):
                for inner in self.bindings(f.variables, b):
                    collect(f.effect, inner)
            else:
                raise PddlError(f"cannot apply the effect {f}")

        collect(effect, binding)
        return adds, deletes

    def fact(self, atom: Predicate, binding: Mapping[str, str]) -> Fact:
        return Fact(self.predicates[str(atom.name).lower()], tuple(self.value(t, binding) for t in atom.terms))


def _type_of(variable: Variable) -> str:
    tags = sorted(str(t).lower() for t in variable.type_tags)
    return tags[0] if tags else "object"


# --- actions ------------------------------------------------------------------------------------
def apply_action(world: WorldState, odb: ObjectDatabase, templates: Mapping[str, ActionTemplate], action: str,
                 args: Sequence[str]) -> WorldState:
    """The world after `action(args)`; `ActionError` names the first unmet precondition.

    Arguments are object names, or their PDDL names (as a planner writes them).
    """
    template = templates.get(action.lower()) or templates.get(action)
    if template is None:
        raise ActionError(f"unknown action {action!r}; actions: {', '.join(sorted(templates))}")
    call = f"{template.name}({', '.join(args)})"
    if len(args) != len(template.parameters):
        raise ActionError(f"{call}: {template.name} takes {len(template.parameters)} argument(s) "
                          f"({template.signature()}), got {len(args)}")
    state = StateView(world, odb)
    binding: dict[str, str] = {}
    for arg, (variable, pddl_type) in zip(args, template.parameters):
        name = state.resolve(arg)
        if name is None:
            raise ActionError(f"{call}: unknown object {arg!r} for ?{variable}; objects: {', '.join(sorted(state.types))}")
        if not odb.pddl_is_a(state.types[name], pddl_type):
            raise ActionError(f"{call}: ?{variable} must be {article(pddl_type)}, but {name!r} is {article(state.types[name])}")
        binding[variable] = name
    call = f"{template.name}({', '.join(binding.values())})"
    reason = state.unmet(template.precondition, binding)
    if reason is not None:
        raise ActionError(f"{call}: precondition {reason} does not hold")
    adds, deletes = state.changes(template.effect, binding)
    return world.with_facts((world.facts - deletes) | adds)


def apply_plan(world: WorldState, odb: ObjectDatabase, templates: Mapping[str, ActionTemplate],
               steps: Iterable[PlanStep | tuple[str, Sequence[str]] | str]) -> WorldState:
    """The world after every step in order; an `ActionError` names the step that cannot be applied."""
    for number, step in enumerate(steps, start=1):
        step = _as_step(step)
        try:
            world = apply_action(world, odb, templates, step.action, step.args)
        except ActionError as exc:
            raise ActionError(f"plan step {number} {step}: {exc}") from None
    return world


def _as_step(step) -> PlanStep:
    if isinstance(step, PlanStep):
        return step
    if isinstance(step, str):
        steps = read_plan(step)
        if len(steps) != 1:
            raise ActionError(f"a plan step is one ground action like '(pick arm box table)', got {step!r}")
        return steps[0]
    action, args = step
    return PlanStep(str(action), tuple(str(a) for a in args))


def read_plan(path_or_text: str | Path) -> tuple[PlanStep, ...]:
    """A plan as planners write it (``sas_plan``): ``(action arg ...)`` lines, ``;`` comments."""
    if _is_path(path_or_text):
        path = Path(path_or_text)
        text = read_text_file(path, "plan", PddlError)
        try:
            plan = parse_plan(text)
        except PddlError as exc:
            raise relocated(exc, source=str(path)) from None
    else:
        plan = parse_plan(str(path_or_text))
    return tuple(PlanStep(str(name).lower(), tuple(str(c.name) for c in params)) for name, params in plan.actions)


def _is_path(value: str | Path) -> bool:
    """A Path, or a string that cannot be a plan's text (no parenthesis, no line break, no comment)."""
    if isinstance(value, Path):
        return True
    text = value.strip()
    return bool(text) and "(" not in text and "\n" not in text and not text.startswith(";")


# --- goals --------------------------------------------------------------------------------------
def unmet_goal(world: WorldState, odb: ObjectDatabase, goal: str | None = None) -> str | None:
    """None when `goal` (default: the world's goal) holds in `world`; otherwise the first part that does not."""
    text = goal if goal is not None else world.goal
    if text is None or not text.strip():
        return None
    formula = parse_goal(text)
    FormulaChecker(odb, pddl_objects(world, odb, problem_names(world))).condition(formula, {})
    return StateView(world, odb).unmet(formula, {})


def goal_holds(world: WorldState, odb: ObjectDatabase, goal: str | None = None) -> bool:
    return unmet_goal(world, odb, goal) is None

"""PDDL problems: written from a world state, read back into facts with the world's own object names.

Object names that are not PDDL identifiers ("Cup 1") are renamed (``cup_1``, see `bridge.names`); the renamed
ones are listed at the top of the problem as comments, so the file alone maps back::

    ; bridge-name cup_1 "Cup 1"

A world state with fact probabilities (`bridge infer --samples`) tells the planner only what is at least
`min_probability` likely (default 0.9); the facts in between, which an operator or a sensing action should
settle, are listed in comments and in `uncertain_json`::

    ; bridge-uncertain (upright big_box) p=0.62 [0.42, 0.79] of 24 samples
"""
from __future__ import annotations

import json
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Mapping

from pddl.core import Problem
from pddl.formatter import domain_to_string, problem_to_string
from pddl.logic.base import And, Formula, Not
from pddl.logic.predicates import Predicate
from pddl.logic.terms import Constant, Term

from ..errors import PddlError
from ..names import NameMap, build_name_map, to_identifier
from ..files import read_text_file, write_set
from ..odb import ObjectDatabase
from ..probability import DEFAULT_MIN_PROBABILITY, check_min_probability, wilson_interval
from ..values import Fact
from ..world import WorldState
from .domain import DEFAULT_DOMAIN_NAME, build_domain
from .formulas import FormulaChecker, map_terms
from .parsing import KEYWORDS, parse_goal, parse_problem, relocated
from .templates import ActionTemplate, DomainSettings

NAME_COMMENT = re.compile(r"^\s*;\s*bridge-name\s+(\S+)\s+(.+?)\s*$")


@dataclass(frozen=True)
class ProblemFacts:
    """What a problem file says, in the world's names: objects with PDDL types, the initial facts, the goal."""

    objects: Mapping[str, str]  # original object name -> PDDL type
    facts: frozenset[Fact]
    goal: str | None = None  # PDDL text in PDDL names; None when the goal is empty
    name: str = "problem"
    domain_name: str = DEFAULT_DOMAIN_NAME
    names: NameMap = field(default_factory=NameMap, compare=False)
    source: str | None = None


# --- names --------------------------------------------------------------------------------------
def problem_names(world: WorldState) -> NameMap:
    """The world's name map (built here if the world was made in code), with PDDL keywords refused."""
    names = world.names
    if any(n not in names.to_pddl for n in world.all_names()):
        names = build_name_map(world.all_names(), error=PddlError)
    for original, ident in names.to_pddl.items():
        if ident in KEYWORDS:
            raise PddlError(f"object name {original!r} is the PDDL keyword {ident!r}; rename the object", field="objects")
    return names


def pddl_objects(world: WorldState, odb: ObjectDatabase, names: NameMap) -> dict[str, str]:
    """PDDL name -> PDDL type of every object and the robot."""
    return {names.pddl(n): odb.get(world.type_name(n)).pddl_type for n in world.all_names()}


# --- what the planner is told ------------------------------------------------------------------
def believed_facts(world: WorldState, min_probability: float = DEFAULT_MIN_PROBABILITY) -> frozenset[Fact]:
    """The facts at least `min_probability` likely (every fact of a world without probabilities)."""
    check_min_probability(min_probability)
    unsure = {f for f, p in world.probabilities.items() if p < min_probability}
    return frozenset(world.facts - unsure) | {f for f, p in world.probabilities.items() if p >= min_probability}


def uncertain_facts(world: WorldState, min_probability: float = DEFAULT_MIN_PROBABILITY) -> list[tuple[Fact, float]]:
    """The facts neither believed nor believed false: 1 - min_probability < p < min_probability, likeliest first."""
    check_min_probability(min_probability)
    return sorted(((f, p) for f, p in world.probabilities.items() if 1 - min_probability < p < min_probability),
                  key=lambda fp: (-fp[1], fp[0]))


def uncertain_json(world: WorldState, min_probability: float = DEFAULT_MIN_PROBABILITY) -> dict:
    """The uncertain facts for an operator or a sensing action: fact (world names), probability, 95 % interval."""
    return {"min_probability": min_probability, "samples": world.samples,
            "uncertain": [{"fact": str(f), "p": round(p, 4),
                           "interval": [round(v, 4) for v in wilson_interval(p, world.samples)]}
                          for f, p in uncertain_facts(world, min_probability)]}


# --- writing ------------------------------------------------------------------------------------
def build_problem(world: WorldState, odb: ObjectDatabase, domain_name: str = DEFAULT_DOMAIN_NAME,
                  goal: str | None = None, min_probability: float = DEFAULT_MIN_PROBABILITY) -> Problem:
    """Typed objects (the robot too), ``:init`` from the believed facts, ``:goal`` from `goal` or else the world's
    goal.

    A goal is written in PDDL names (``cup_1`` for "Cup 1"). Without any goal the problem's goal is empty.
    """
    names = problem_names(world)
    objects = pddl_objects(world, odb, names)
    constants = {ident: Constant(ident, pddl_type) for ident, pddl_type in objects.items()}
    init = [Predicate(f.predicate, *(constants[names.pddl(a)] for a in f.args))
            for f in sorted(believed_facts(world, min_probability))]
    goal_text = goal if goal is not None else world.goal
    formula = And() if goal_text is None or not goal_text.strip() else ground_goal(goal_text, odb, objects)
    name = to_identifier(world.name or "problem")
    return Problem(name if name not in KEYWORDS else f"{name}-problem", domain_name=domain_name,
                   objects=list(constants.values()), init=init, goal=formula)


def ground_goal(text: str, odb: ObjectDatabase, objects: Mapping[str, str]) -> Formula:
    """Parse and check a goal over `objects` (PDDL name -> type); names are written as the problem writes them."""
    formula = parse_goal(text)
    try:
        FormulaChecker(odb, objects).condition(formula, {})
    except PddlError as exc:
        raise PddlError(f"{exc} (goal {' '.join(text.split())})", field="goal") from None
    canonical = {k.lower(): k for k in objects}

    def rename(term: Term) -> Term:
        return Constant(canonical[str(term.name).lower()]) if isinstance(term, Constant) else term

    return map_terms(formula, rename)


def problem_text(world: WorldState, odb: ObjectDatabase, domain_name: str = DEFAULT_DOMAIN_NAME,
                 goal: str | None = None, min_probability: float = DEFAULT_MIN_PROBABILITY) -> str:
    """The problem file: a header naming the world, one ``; bridge-name`` line per renamed object, one
    ``; bridge-uncertain`` line per fact left out as uncertain, the PDDL."""
    return _render(world, build_problem(world, odb, domain_name, goal, min_probability), min_probability)


def _render(world: WorldState, problem: Problem, min_probability: float = DEFAULT_MIN_PROBABILITY) -> str:
    header = [f"; bridge problem for world state {json.dumps(world.name)}"]
    header += [f"; bridge-name {ident} {json.dumps(original)}" for original, ident in sorted(problem_names(world).renamed().items())]
    names = problem_names(world)
    for fact, p in uncertain_facts(world, min_probability):
        lo, hi = wilson_interval(p, world.samples)
        pddl = Fact(fact.predicate, tuple(names.pddl(a) for a in fact.args))
        header.append(f"; bridge-uncertain {pddl} p={p:.2f} [{lo:.2f}, {hi:.2f}] of {world.samples} samples "
                      f"(not in :init; below {min_probability:g})")
    return "\n".join(header) + "\n" + problem_to_string(problem) + "\n"


def export_pddl(world: WorldState, odb: ObjectDatabase, templates: Mapping[str, ActionTemplate],
                out_dir: str | Path | None = None, *, domain_path: str | Path | None = None,
                problem_path: str | Path | None = None, domain_name: str | None = None,
                settings: DomainSettings | None = None, goal: str | None = None,
                min_probability: float = DEFAULT_MIN_PROBABILITY) -> tuple[Path, Path]:
    """Write ``domain.pddl`` and ``problem.pddl`` (into `out_dir`, or to the explicit paths) as one set
    (`bridge.files.write_set`: all or nothing, even when interrupted); for a world with fact probabilities also
    the uncertain facts beside the problem (`uncertain_path`), else a stale file of that name is removed.

    Both texts are built and checked before either file is touched.
    """
    if out_dir is None and (domain_path is None or problem_path is None):
        raise PddlError("give a folder for domain.pddl and problem.pddl, or both file paths")
    domain_path = Path(domain_path) if domain_path is not None else Path(out_dir) / "domain.pddl"  # type: ignore[arg-type]
    problem_path = Path(problem_path) if problem_path is not None else Path(out_dir) / "problem.pddl"  # type: ignore[arg-type]
    domain = build_domain(odb, templates, name=domain_name, settings=settings)
    problem = build_problem(world, odb, domain.name, goal, min_probability)
    try:
        problem.check(domain)  # the library's own cross-check of types, as a safety net
    except Exception as exc:
        raise PddlError(f"the problem does not fit the domain: {exc}") from None
    domain_file, problem_file = domain_to_string(domain) + "\n", _render(world, problem, min_probability)
    write_set({domain_path: domain_file, problem_path: problem_file,
               uncertain_path(problem_path): uncertain_text(world, min_probability)})
    return domain_path, problem_path


def uncertain_path(problem_path: str | Path) -> Path:
    """Where the uncertain facts of a problem go: ``problem.pddl`` -> ``problem.uncertain.json``."""
    return Path(problem_path).with_suffix(".uncertain.json")


def uncertain_text(world: WorldState, min_probability: float = DEFAULT_MIN_PROBABILITY) -> str | None:
    """The uncertain-facts file of a world with fact probabilities; None for a world without (in a `write_set`:
    a stale file of an earlier sampled run is removed)."""
    if not world.samples:
        return None
    return json.dumps(uncertain_json(world, min_probability), indent=1) + "\n"


def write_uncertain(world: WorldState, problem_path: str | Path,
                    min_probability: float = DEFAULT_MIN_PROBABILITY) -> Path | None:
    """`uncertain_json` beside the problem, for a world with fact probabilities (else nothing)."""
    text = uncertain_text(world, min_probability)
    if text is None:
        return None
    path = uncertain_path(problem_path)
    write_set({path: text})
    return path


# --- reading ------------------------------------------------------------------------------------
def read_problem(path_or_text: str | Path, odb: ObjectDatabase) -> ProblemFacts:
    """Read a problem file (a path, or the text itself): objects, initial facts and goal, in original names.

    Checks what the `pddl` library leaves open: declared predicates, arities, argument types, declared objects.
    """
    if isinstance(path_or_text, Path) or "(" not in str(path_or_text):
        path = Path(path_or_text)
        src: str | None = str(path)
        text = read_text_file(path, "problem file", PddlError)
    else:
        text, src = str(path_or_text), None
    try:
        renamed = _name_comments(text)
        problem = parse_problem(text)
    except PddlError as exc:
        raise relocated(exc, source=src) from None

    objects: dict[str, str] = {}
    for constant in sorted(problem.objects, key=lambda c: str(c.name)):
        ident = str(constant.name).lower()
        pddl_type = str(constant.type_tag).lower() if constant.type_tag is not None else "object"
        if pddl_type not in odb.pddl_types:
            raise PddlError(f"object {constant.name} has the unknown type {pddl_type!r}; PDDL types: "
                            f"{', '.join(sorted(odb.pddl_types))}", source=src, field="objects")
        objects[ident] = pddl_type
    for ident in renamed:
        if ident not in objects:
            raise PddlError(f"a bridge-name comment renames {ident!r}, which is not an object of the problem",
                            source=src, field="objects")
    originals = {ident: renamed.get(ident, ident) for ident in objects}
    names = NameMap({o: i for i, o in originals.items()}, dict(originals))
    if len(names.to_pddl) != len(originals):
        raise PddlError("two objects map back to the same name in the bridge-name comments", source=src, field="objects")

    checker = FormulaChecker(odb, objects)
    canonical = {name.lower(): name for name in odb.predicates}
    facts = set()
    for atom in sorted(problem.init, key=str):
        if isinstance(atom, Not) or not isinstance(atom, Predicate):
            raise PddlError(f"{atom}: the initial state lists the atoms that hold, nothing else", source=src, field="init")
        try:
            checker.atom(atom, {})
        except PddlError as exc:
            raise relocated(exc, source=src, field="init") from None
        facts.add(Fact(canonical[str(atom.name).lower()], tuple(originals[str(t.name).lower()] for t in atom.terms)))

    goal = problem.goal
    goal_text = None
    if not (isinstance(goal, And) and not goal.operands):
        try:
            checker.condition(goal, {})
        except PddlError as exc:
            raise relocated(exc, source=src, field="goal") from None
        goal_text = str(goal)
    return ProblemFacts(objects={originals[i]: t for i, t in objects.items()}, facts=frozenset(facts), goal=goal_text,
                        name=str(problem.name), domain_name=str(problem.domain_name), names=names, source=src)


def _name_comments(text: str) -> dict[str, str]:
    """``; bridge-name <ident> <json string>`` lines: PDDL name -> original name."""
    renamed: dict[str, str] = {}
    for number, line in enumerate(text.splitlines(), start=1):
        match = NAME_COMMENT.match(line)
        if not match:
            continue
        ident, quoted = match.group(1).lower(), match.group(2)
        try:
            original = json.loads(quoted)
        except json.JSONDecodeError:
            original = None
        if not isinstance(original, str) or not original:
            raise PddlError(f"bridge-name comment: the original name must be a JSON string, got {quoted}", field=f"line {number}")
        if ident in renamed and renamed[ident] != original:
            raise PddlError(f"bridge-name comment: {ident} is renamed twice", field=f"line {number}")
        renamed[ident] = original
    return renamed

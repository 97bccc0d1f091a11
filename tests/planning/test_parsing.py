"""The PDDL parser front: library objects out of valid text, one `PddlError` naming the field or line out of bad text,
and the three gaps of pddl 0.5.1 (``?x - object``, rich goals, a transformer poisoned by a failed parse) bridged."""
import re

import pytest
from pddl.action import Action
from pddl.core import Plan, Problem
from pddl.formatter import plan_to_string, problem_to_string
from pddl.logic.base import And, Not

from bridge.errors import ActionError, PddlError
from bridge.planning.parsing import (
    KEYWORDS,
    check_parentheses,
    parse_action,
    parse_goal,
    parse_plan,
    parse_problem,
    relocated,
)

NUDGE = {
    "parameters": "?r - robot ?o - movable ?s - object",
    "precondition": "(and (upright ?o) (on ?o ?s) (not (= ?o ?s)))",
    "effect": "(and (not (upright ?o)) (forall (?x - object) (when (touching ?o ?x) (not (touching ?o ?x)))))",
}

PROBLEM = """(define (problem p) (:domain d)
  (:objects a b - box t - tray)
  (:init (on a t) (upright a))
  (:goal (and (on a b) (not (upright b)))))"""


def action_fields(action: Action) -> dict[str, str]:
    """The three field texts back from the library's printout of an action."""
    match = re.search(r":parameters \((.*)\)\n\s*:precondition (.*)\n\s*:effect (.*)\n\)", str(action))
    assert match, str(action)
    return dict(zip(("parameters", "precondition", "effect"), match.groups()))


def raised(call, *args) -> PddlError:
    with pytest.raises(PddlError) as info:
        call(*args)
    assert type(info.value) is PddlError
    assert "\n" not in str(info.value), str(info.value)
    return info.value


# --- valid input -------------------------------------------------------------------------------
def test_parse_action_gives_the_library_action():
    action = parse_action("nudge", NUDGE)
    assert isinstance(action, Action) and action.name == "nudge"
    assert [(str(p.name), set(p.type_tags)) for p in action.parameters] == [
        ("r", {"robot"}), ("o", {"movable"}), ("s", {"object"})]
    assert str(action.precondition) == NUDGE["precondition"]
    assert str(action.effect) == NUDGE["effect"]


def test_object_typed_and_grouped_parameters_are_accepted():
    """pddl 0.5.1 refuses '?x - object' when it validates a whole domain that does not list 'object'."""
    action = parse_action("x", {"parameters": "?r - robot ?a ?b - object ?c", "precondition": "(and)",
                                "effect": "(and)"})
    assert [(str(p.name), set(p.type_tags)) for p in action.parameters] == [
        ("r", {"robot"}), ("a", {"object"}), ("b", {"object"}), ("c", set())]
    quantified = parse_action("y", {"parameters": "?o - object", "precondition": "(exists (?y - object) (on ?o ?y))",
                                    "effect": "(forall (?z - object) (not (on ?o ?z)))"})
    assert str(quantified.precondition) == "(exists (?y - object) (on ?o ?y))"


def test_action_round_trip_through_the_library_printer():
    action = parse_action("nudge", NUDGE)
    again = parse_action("nudge", action_fields(action))
    assert again == action and str(again) == str(action)
    spaced = {k: "  " + v.replace(" (", "\n   (") + "  ; a comment\n" if k != "parameters" else v
              for k, v in NUDGE.items()}
    assert parse_action("nudge", spaced) == action  # layout and comments do not matter
    assert parse_action("nudge", {**NUDGE, "effect": "(upright ?o)"}) != action


def test_parse_problem_gives_the_library_problem():
    problem = parse_problem(PROBLEM)
    assert isinstance(problem, Problem) and problem.name == "p" and problem.domain_name == "d"
    assert sorted((str(o.name), o.type_tag) for o in problem.objects) == [("a", "box"), ("b", "box"), ("t", "tray")]
    assert sorted(str(f) for f in problem.init) == ["(on a t)", "(upright a)"]
    assert str(problem.goal) == "(and (on a b) (not (upright b)))"


GOALS = [
    "(or (on a b) (on b a))",
    "(forall (?x - box) (on ?x t))",
    "(exists (?x - box) (not (on ?x t)))",
    "(= a b)",
    "(not (= a b))",
    "(imply (on a b) (upright a))",
    "(or (= a b) (forall (?x) (on ?x a)))",
]


@pytest.mark.parametrize("goal", GOALS)
def test_goals_parse_with_every_supported_requirement(goal):
    """pddl 0.5.1 parses a problem's goal with no requirements, so or / forall / = would fail there."""
    assert str(parse_goal(goal)) == goal
    text = PROBLEM.replace("(:domain d)", "(:domain d) (:requirements :strips)").replace(
        "(and (on a b) (not (upright b)))", goal)
    problem = parse_problem(text)
    assert str(problem.goal) == goal
    assert parse_problem(problem_to_string(problem)) == problem


def test_problem_round_trip_through_the_library_printer():
    problem = parse_problem(PROBLEM)
    again = parse_problem(problem_to_string(problem))
    assert again == problem
    assert (again.name, again.domain_name, again.objects, again.init, str(again.goal)) == \
        (problem.name, problem.domain_name, problem.objects, problem.init, str(problem.goal))


def test_parse_goal_gives_a_formula_of_constants():
    goal = parse_goal("(and (on box tray) ; a comment\n (not (upright box)))")
    assert isinstance(goal, And) and isinstance(goal.operands[1], Not)
    on = goal.operands[0]
    assert on.name == "on" and [str(t.name) for t in on.terms] == ["box", "tray"]
    assert parse_goal(str(goal)) == goal


def test_parse_plan_reads_steps_and_skips_comments():
    plan = parse_plan("(pick arm box t)\n; cost = 2 (unit cost)\n(place arm box tray)\n")
    assert isinstance(plan, Plan)
    assert [(str(name), [str(c.name) for c in args]) for name, args in plan.actions] == [
        ("pick", ["arm", "box", "t"]), ("place", ["arm", "box", "tray"])]
    assert parse_plan(plan_to_string(plan)) == plan
    assert parse_plan("; cost = 0 (unit cost)\n").actions == []


# --- a failed parse does not poison the next one ------------------------------------------------
def test_failed_problem_parse_leaves_no_objects_behind():
    """The library's transformer keeps the objects of the last problem; a reused one would type the next init."""
    bad = PROBLEM.replace("(upright a)", "(upright and)")
    error = raised(parse_problem, bad)
    assert "invalid name 'and': it is a keyword" in str(error)
    untyped = parse_problem("(define (problem q) (:domain d) (:init (on a t)) (:goal (on a t)))")
    assert [(str(t.name), t.type_tag) for f in untyped.init for t in f.terms] == [("a", None), ("t", None)]


def test_failed_parses_do_not_change_later_results():
    action, goal, problem = parse_action("nudge", NUDGE), parse_goal(GOALS[1]), parse_problem(PROBLEM)
    for bad in ({**NUDGE, "effect": "(and (when (upright ?o)))"}, {**NUDGE, "parameters": "?r - robot ?and - box"},
                {**NUDGE, "precondition": "(on ?o table)"}):
        raised(parse_action, "nudge", bad)
        assert parse_action("nudge", NUDGE) == action
    for bad in ("(forall (?x - box) (on ?x not))", "(and (on a b) #)"):
        raised(parse_goal, bad)
        assert parse_goal(GOALS[1]) == goal
    raised(parse_problem, PROBLEM.replace("(:init", "(:init ("))
    assert parse_problem(PROBLEM) == problem


# --- syntax errors: one PddlError naming the field, with an excerpt ------------------------------
ACTION_ERRORS = [
    # (case, overridden field, text, expected message after "<field>: ")
    ("unclosed", "precondition", "(and (upright ?o)", "unbalanced parentheses: 1 '(' not closed"),
    ("stray close", "precondition", "(upright ?o))", "unbalanced parentheses: ')' at character 13 closes nothing"),
    ("unexpected token", "effect", "(and (when (upright ?o)))",
     "unexpected ')' (at character 24: ...d (when (upright ?o))))"),
    ("unexpected character", "effect", "(and (upright ?o) #)", "unexpected character '#' (at character 19: (and (upright ?o) #))"),
    ("empty not", "effect", "(and (not))", "unexpected ')' (at character 10: (and (not)))"),
    ("missing type", "parameters", "?r - robot ?o -", "unexpected ')' (at character 16: ?r - robot ?o -)"),
    ("keyword parameter", "parameters", "?r - robot ?and - box", "invalid name 'and': it is a keyword"),
    ("keyword predicate", "precondition", "(and (upright ?o) (either ?o))", "invalid name 'either': it is a keyword"),
    ("keyword term", "effect", "(not (forall ?o))", "invalid name 'forall': it is a keyword"),
    ("constant", "precondition", "(on ?o table)",
     "'table' is not a variable: write ?table; a template names objects only through variables"),
    ("two formulas", "effect", "(upright ?o) (clear ?o)",
     "more than one formula (a second one starts at character 14); wrap them in (and ...)"),
    ("bare word", "precondition", "upright", "must be a formula in parentheses, found 'upright' outside"),
    ("empty", "effect", "  ", "is empty; write a formula such as '(and)'"),
    ("parenthesised parameters", "parameters", "?r - robot (?o)",
     "parameters are written without parentheses, e.g. '?r - robot ?o - box'"),
    ("either", "parameters", "?o - (either box cup)", "(either ...) types are not supported; give each parameter one type"),
    ("not text", "effect", None, "must be PDDL written as text, got None"),
]


@pytest.mark.parametrize("case,field,text,message", ACTION_ERRORS, ids=[c[0] for c in ACTION_ERRORS])
def test_action_syntax_error_names_the_field(case, field, text, message):
    error = raised(parse_action, "nudge", {**NUDGE, field: text})
    assert error.field == field and error.source is None
    assert str(error) == f"{field}: {message}"


def test_action_error_excerpt_is_cut_around_the_offset():
    effect = "(and " + "(upright ?o) " * 4 + "# " + "(clear ?o) " * 4 + ")"
    offset = effect.index("#")
    error = raised(parse_action, "nudge", {**NUDGE, "effect": effect})
    assert str(error) == (f"effect: unexpected character '#' (at character {offset + 1}: "
                          f"...{effect[offset - 20:offset + 20]}...)")


def test_action_error_offset_counts_in_the_field_across_lines_and_comments():
    precondition = "(and ; why\n  (upright ?o)\n  (on ?o ?s) #)"
    error = raised(parse_action, "nudge", {**NUDGE, "precondition": precondition})
    local = precondition.index("#")
    assert error.field == "precondition"
    assert f"(at character {local + 1}: ...{precondition[local - 20:].replace(chr(10), ' ')})" in str(error)


PROBLEM_ERRORS = [
    ("unclosed init", PROBLEM.replace("(:init (on a t) (upright a))", "(:init (on a t) (upright a)"),
     "PDDL syntax error: unexpected ':goal' (line 4)"),
    ("character", PROBLEM.replace("(upright a))", "(upright a) #)"), "PDDL syntax error: unexpected character '#' (line 3)"),
    ("end of text", PROBLEM[:-2], "PDDL syntax error: unexpected end of text (a parenthesis not closed?) (line 4)"),
    ("keyword object", PROBLEM.replace("a b - box", "a and - box"), "PDDL syntax error: invalid name 'and': it is a keyword"),
    ("nested object list", PROBLEM.replace("(:objects a", "(:objects (a"), "PDDL syntax error: unexpected '(' (line 2)"),
]


@pytest.mark.parametrize("case,text,message", PROBLEM_ERRORS, ids=[c[0] for c in PROBLEM_ERRORS])
def test_problem_syntax_error_names_the_line(case, text, message):
    error = raised(parse_problem, text)
    assert str(error) == message and error.source is None and error.field is None


GOAL_ERRORS = [
    ("(and (on a b)", "goal: unbalanced parentheses: 1 '(' not closed"),
    ("(on a b) (on b c)", "goal: more than one formula (a second one starts at character 10); wrap them in (and ...)"),
    ("(on not tray)", "goal: PDDL syntax error: invalid name 'not': it is a keyword"),
    ("(and (on a b) (or (on a)) #)", "goal: PDDL syntax error: unexpected character '#' (at character 27: ...on a b) (or (on a)) #))"),
    ("(and (on a b)\n (when (on a b) (on b c)))",
     "goal: PDDL syntax error: unexpected '(' (at character 22: ...and (on a b)  (when (on a b) (on b c))))"),
    ("", "goal: is empty; write a formula such as '(and)'"),
]


@pytest.mark.parametrize("goal,message", GOAL_ERRORS, ids=[g for g, _ in GOAL_ERRORS])
def test_goal_syntax_error_names_the_goal_with_an_excerpt(goal, message):
    error = raised(parse_goal, goal)
    assert error.field == "goal" and str(error) == message


PLAN_ERRORS = [
    ("(pick arm b t)\n(place arm b", "plan syntax error: unexpected end of text (a parenthesis not closed?) (line 2)"),
    ("(pick arm b t)\n(place arm (b))", "plan syntax error: unexpected '(' (line 2)"),
    ("; header\n\n(pick arm b t) #", "plan syntax error: unexpected character '#' (line 3)"),
    ("pick arm", "plan syntax error: unexpected 'pick' (line 1)"),
]


@pytest.mark.parametrize("text,message", PLAN_ERRORS, ids=[t for t, _ in PLAN_ERRORS])
def test_plan_syntax_error_names_the_line(text, message):
    assert str(raised(parse_plan, text)) == message


# --- check_parentheses ---------------------------------------------------------------------------
PARENTHESES = [
    ("(and (a) (b))", True, None),
    ("  (a) ; a comment with ) and (\n", True, None),
    ("(a)\n; (b)", True, None),
    ("?r - robot ?o - box", False, None),
    ("?r - robot ; the arm (left)\n?o - box", False, None),
    ("(a))", True, "unbalanced parentheses: ')' at character 4 closes nothing"),
    ("((a)", True, "unbalanced parentheses: 1 '(' not closed"),
    ("(a) (b)", True, "more than one formula (a second one starts at character 5); wrap them in (and ...)"),
    ("upright ?o", True, "must be a formula in parentheses, found 'upright' outside"),
    ("; only a comment", True, "is empty; write a formula such as '(and)'"),
    ("?r - (robot)", False, "parameters are written without parentheses, e.g. '?r - robot ?o - box'"),
    ("?o - EITHER", False, "(either ...) types are not supported; give each parameter one type"),
    (["(a)"], True, "must be PDDL written as text, got ['(a)']"),
]


@pytest.mark.parametrize("text,allow_forms,expected", PARENTHESES, ids=[repr(t) for t, _, _ in PARENTHESES])
def test_check_parentheses(text, allow_forms, expected):
    assert check_parentheses(text, allow_forms=allow_forms) == expected


def test_keywords_are_the_reserved_identifiers():
    assert {"and", "or", "not", "forall", "exists", "when", "imply", "either", "object", "define"} <= KEYWORDS
    assert all(re.fullmatch(r"[a-z][a-z0-9_-]*", k) for k in KEYWORDS)  # no ':requirements' or '?'-forms


# --- relocated -----------------------------------------------------------------------------------
def test_relocated_keeps_message_and_class_and_sets_source():
    error = PddlError("unexpected ')'", field="effect")
    moved = relocated(error, source="templates/nudge.yaml")
    assert type(moved) is PddlError and moved is not error
    assert (moved.source, moved.field) == ("templates/nudge.yaml", "effect")
    assert str(moved) == "templates/nudge.yaml: effect: unexpected ')'"
    assert str(error) == "effect: unexpected ')'" and error.source is None  # the input is not changed


def test_relocated_replaces_rather_than_stacks():
    error = ActionError("precondition (clear b) does not hold", source="plan.txt", field="step 2")
    moved = relocated(relocated(error, source="other.txt"), field="step 3")
    assert type(moved) is ActionError
    assert str(moved) == "other.txt: step 3: precondition (clear b) does not hold"
    bare = relocated(PddlError("goal: looks like a field but is the message"), source="w.yaml", field="goal")
    assert str(bare) == "w.yaml: goal: goal: looks like a field but is the message"
    assert str(relocated(PddlError("m", source="a"))) == "a: m"


# --- bugs found while writing these tests (see the report) ---------------------------------------
def test_parameter_whose_name_contains_either_is_accepted():
    """'either' is refused as a word, not as part of a name such as ?neither."""
    action = parse_action("nudge", {**NUDGE, "parameters": "?r - robot ?neither - movable ?s - object",
                                    "precondition": "(upright ?neither)", "effect": "(not (upright ?neither))"})
    assert [str(p.name) for p in action.parameters] == ["r", "neither", "s"]


def test_comment_at_the_end_of_the_parameters():
    """check_parentheses allows comments in parameters; one at the end must not swallow what follows the field."""
    fields = {**NUDGE, "parameters": "?r - robot ?o - movable ?s - object ; s: the support"}
    assert parse_action("nudge", fields) == parse_action("nudge", NUDGE)


def test_text_after_the_formula_is_what_is_named_outside():
    assert check_parentheses("(upright ?o) clear", allow_forms=True) == \
        "must be a formula in parentheses, found 'clear' outside"


def test_check_parentheses_counts_characters_in_the_text_as_written():
    text = "(and ; note (\n  (upright ?o)))"
    assert check_parentheses(text, allow_forms=True) == \
        f"unbalanced parentheses: ')' at character {text.rindex(')') + 1} closes nothing"
    second = "(a) ; first\n(b)"
    assert check_parentheses(second, allow_forms=True) == \
        f"more than one formula (a second one starts at character {second.index('(b)') + 1}); wrap them in (and ...)"

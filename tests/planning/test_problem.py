"""PDDL problems: a world state goes out as a problem file and comes back with the same objects, names and facts."""
import os

import pytest

from bridge.errors import PddlError
from bridge.planning import build_problem, export_pddl, problem_text, read_problem
from bridge.values import Fact

FACTS = ["(on big_box table)", "(on small_box big_box)", "(on tray_1 table)", "(on cup_1 tray_1)", "(in cup_1 tray_1)",
         "(upright big_box)", "(upright cup_1)", "(clear small_box)", "(clear cup_1)", "(hand-empty arm)"]


def test_round_trip_keeps_objects_names_types_and_facts(odb, world_of):
    world = world_of(FACTS, goal="(and (on cup_1 table) (not (in cup_1 tray_1)))")
    assert Fact("in", ("Cup 1", "Tray 1")) in world.facts
    text = problem_text(world, odb)
    assert '; bridge-name cup_1 "Cup 1"' in text and '; bridge-name tray_1 "Tray 1"' in text
    assert "(in cup_1 tray_1)" in text and "Cup 1" not in text.split("(define")[1]
    back = read_problem(text, odb)
    assert back.objects == {"table": "table", "big_box": "box", "small_box": "box", "Tray 1": "tray", "Cup 1": "cup",
                            "arm": "robot"}
    assert back.facts == world.facts
    assert back.goal == "(and (on cup_1 table) (not (in cup_1 tray_1)))"
    assert back.names.original("cup_1") == "Cup 1" and back.names.pddl("Tray 1") == "tray_1"
    assert back.domain_name == "bridge-tabletop" and back.name == "test_world"


def test_round_trip_of_the_fixture_world(odb, toppled, tmp_path):
    path = tmp_path / "problem.pddl"
    path.write_text(problem_text(toppled, odb))
    back = read_problem(path, odb)
    assert back.facts == toppled.facts and set(back.objects) == set(toppled.all_names())
    assert back.source == str(path)


def test_problem_structure(odb, toppled):
    problem = build_problem(toppled, odb, "bridge-tabletop")
    objects = {str(c.name): str(c.type_tag) for c in problem.objects}
    assert objects["arm"] == "robot" and objects["tray_1"] == "tray" and objects["work_table"] == "table"
    assert len(problem.init) == len(toppled.facts)
    assert str(problem.goal) == "(and (upright small_box) (on small_box tray_1))"


def test_goal_argument_overrides_and_is_normalised(odb, toppled):
    problem = build_problem(toppled, odb, goal="(and (TOUCHING small_box Big_Box) (exists (?t - tray) (on big_box ?t)))")
    assert str(problem.goal) == "(and (TOUCHING small_box big_box) (exists (?t - tray) (on big_box ?t)))"
    empty = build_problem(toppled, odb, goal="")
    assert str(empty.goal) == "(and )"


def test_goals_may_use_or_forall_and_equality(odb, toppled):
    goal = "(or (= small_box big_box) (forall (?b - box) (upright ?b)))"
    back = read_problem(problem_text(toppled, odb, goal=goal), odb)
    assert back.goal == goal


BAD_GOALS = [
    ("(holds arm small_box)", "predicate 'holds' is not declared"),
    ("(on small_box)", "on takes 2 argument(s)"),
    ("(upright arm)", "arm is a robot, but upright expects a movable"),
    ("(on small_box shelf)", "unknown object 'shelf'"),
    ("(upright ?b)", "variable ?b is not declared"),
    ("(forall (?b - crate) (upright ?b))", "unknown type 'crate'"),
    ("(and (upright small_box)", "unbalanced parentheses"),
    ("(and (upright small_box) (> 1 2))", "is not supported in a condition"),
]


@pytest.mark.parametrize("goal,fragment", BAD_GOALS, ids=[g for g, _ in BAD_GOALS])
def test_bad_goal_is_one_clear_error(odb, toppled, goal, fragment):
    with pytest.raises(PddlError) as info:
        build_problem(toppled, odb, goal=goal)
    assert info.value.field == "goal" and fragment in str(info.value) and "\n" not in str(info.value)


def test_keyword_object_name_is_refused(odb, world_of):
    objects = {"table": {"type": "table"}, "Not": {"type": "cup"}}
    with pytest.raises(PddlError, match="object name 'Not' is the PDDL keyword 'not'"):
        problem_text(world_of(["(on Not table)"], objects=objects), odb)


PROBLEM = """; bridge-name tray_1 "Tray 1"
(define (problem p) (:domain bridge-tabletop)
  (:objects table - table big_box - box tray_1 - tray arm - robot)
  (:init (on big_box table) (on tray_1 table) (hand-empty arm))
  (:goal (on big_box tray_1)))
"""

BAD_PROBLEMS = [
    ("undeclared predicate", PROBLEM.replace("(hand-empty arm))", "(hand-full arm))"), "init",
     "predicate 'hand-full' is not declared"),
    ("wrong arity", PROBLEM.replace("(on tray_1 table)", "(on tray_1)"), "init", "on takes 2 argument(s)"),
    ("wrong argument type", PROBLEM.replace("(hand-empty arm)", "(hand-empty table)"), "init",
     "table is a table, but hand-empty expects a robot"),
    ("undeclared object", PROBLEM.replace("(on big_box table)", "(on big_box shelf)"), "init", "unknown object 'shelf'"),
    ("unknown type", PROBLEM.replace("tray_1 - tray", "tray_1 - platter"), "objects", "unknown type 'platter'"),
    ("negative init", PROBLEM.replace("(hand-empty arm))", "(not (hand-empty arm)))"), "init",
     "the initial state lists the atoms that hold"),
    ("goal object", PROBLEM.replace("(:goal (on big_box tray_1))", "(:goal (on big_box shelf))"), "goal",
     "unknown object 'shelf'"),
    ("bad name comment", PROBLEM.replace('"Tray 1"', "Tray 1"), "line 1", "must be a JSON string"),
    ("renamed non-object", PROBLEM.replace("; bridge-name tray_1", "; bridge-name tray_2"), "objects",
     "renames 'tray_2', which is not an object"),
    ("syntax", PROBLEM.replace("(:init", "(:init ("), None, "PDDL syntax error"),
]


@pytest.mark.parametrize("case,text,field,fragment", BAD_PROBLEMS, ids=[c[0] for c in BAD_PROBLEMS])
def test_malformed_problem_file(odb, tmp_path, case, text, field, fragment):
    path = tmp_path / "problem.pddl"
    path.write_text(text)
    with pytest.raises(PddlError) as info:
        read_problem(path, odb)
    message = str(info.value)
    assert message.startswith(str(path)) and fragment in message and "\n" not in message, message
    if field:
        assert info.value.field == field, message
    assert path.read_text() == text


def test_read_problem_of_the_example(odb, tmp_path):
    back = read_problem(PROBLEM, odb)
    assert back.objects["Tray 1"] == "tray" and Fact("on", ("Tray 1", "table")) in back.facts
    with pytest.raises(PddlError, match="problem file not found"):
        read_problem(tmp_path / "missing.pddl", odb)


def test_export_writes_both_files(odb, templates, settings, toppled, tmp_path):
    domain_path, problem_path = export_pddl(toppled, odb, templates, tmp_path / "out", settings=settings)
    assert domain_path == tmp_path / "out" / "domain.pddl" and problem_path == tmp_path / "out" / "problem.pddl"
    assert domain_path.read_text().startswith("(define (domain bridge-tabletop)")
    assert "(:domain bridge-tabletop)" in problem_path.read_text()
    assert read_problem(problem_path, odb).facts == toppled.facts
    d, p = export_pddl(toppled, odb, templates, domain_path=tmp_path / "d.pddl", problem_path=tmp_path / "p.pddl",
                       domain_name="other")
    assert "(define (domain other)" in d.read_text() and "(:domain other)" in p.read_text()


def test_failed_export_touches_nothing(odb, templates, toppled, tmp_path):
    (tmp_path / "domain.pddl").write_text("old domain\n")
    (tmp_path / "problem.pddl").write_text("old problem\n")
    with pytest.raises(PddlError, match="predicate 'holds' is not declared"):
        export_pddl(toppled, odb, templates, tmp_path, goal="(holds arm small_box)")
    assert (tmp_path / "domain.pddl").read_text() == "old domain\n"
    assert (tmp_path / "problem.pddl").read_text() == "old problem\n"
    assert sorted(os.listdir(tmp_path)) == ["domain.pddl", "problem.pddl"]


def test_export_needs_a_place(odb, templates, toppled):
    with pytest.raises(PddlError, match="give a folder"):
        export_pddl(toppled, odb, templates)


def test_world_file_with_renamed_objects_round_trips(odb, world_of, tmp_path):
    """Facts about "Cup 1" are saved in PDDL names (cup_1), the only way they can be written, and read back."""
    from bridge.world import load_world_state, save_world_state

    world = world_of(FACTS)
    save_world_state(world, tmp_path / "w.yaml")
    assert "(in cup_1 tray_1)" in (tmp_path / "w.yaml").read_text()
    assert load_world_state(tmp_path / "w.yaml", odb).facts == world.facts


def test_the_planner_is_told_only_what_is_likely_enough(odb, world_of, templates, tmp_path):
    """With fact probabilities the problem's :init holds the facts at least `min_probability` likely; the ones in
    between are listed in comments and beside the problem as JSON (Wilson intervals); the rest count as false."""
    import json
    from dataclasses import replace

    from bridge.errors import BridgeError
    from bridge.planning.problem import believed_facts, uncertain_facts, uncertain_path

    world = world_of(FACTS)
    upright, on, tipped = Fact("upright", ("big_box",)), Fact("on", ("small_box", "big_box")), Fact("upright", ("Cup 1",))
    world = replace(world, probabilities={upright: 0.62, on: 0.97, tipped: 0.04, Fact("clear", ("big_box",)): 0.3},
                    samples=24)
    believed = believed_facts(world)
    assert on in believed and upright not in believed and tipped not in believed
    assert Fact("clear", ("big_box",)) not in believed and Fact("on", ("big_box", "table")) in believed  # certain
    assert [f for f, _ in uncertain_facts(world)] == [upright, Fact("clear", ("big_box",))]
    assert believed_facts(world, 0.6) >= {upright, on}
    text = problem_text(world, odb)
    assert "; bridge-uncertain (upright big_box) p=0.62" in text and "; bridge-uncertain (upright cup_1)" not in text
    assert read_problem(text, odb).facts == believed  # the comments do not disturb reading it back
    _, problem_path = export_pddl(world, odb, templates, tmp_path)
    listed = json.loads(uncertain_path(problem_path).read_text())
    assert listed["samples"] == 24 and listed["uncertain"][0]["fact"] == "(upright big_box)"
    lo, hi = listed["uncertain"][0]["interval"]
    assert 0.4 < lo < 0.62 < hi < 0.8
    with pytest.raises(BridgeError, match="minimum probability must be in \\(0.5, 1\\]"):
        believed_facts(world, 0.5)

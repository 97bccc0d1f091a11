"""The applier: preconditions checked with a message naming the unmet atom; effects with PDDL's semantics."""
import pytest

from bridge.errors import ActionError, PddlError
from bridge.planning import PlanStep, apply_action, apply_plan, goal_holds, load_action_templates, read_plan, unmet_goal
from bridge.values import Fact

BASE = ["(on big_box table)", "(on small_box table)", "(on tray_1 table)", "(upright big_box)", "(upright small_box)",
        "(upright tray_1)", "(clear big_box)", "(clear small_box)", "(clear tray_1)", "(hand-empty arm)"]


def facts(world):
    return sorted(str(f) for f in world.facts)


def test_unmet_precondition_names_the_atom(odb, templates, world_of):
    world = world_of([f for f in BASE if f != "(clear big_box)"] + ["(on small_box big_box)"])
    with pytest.raises(ActionError) as info:
        apply_action(world, odb, templates, "pick", ["arm", "big_box", "table"])
    assert str(info.value) == "pick(arm, big_box, table): precondition (clear big_box) does not hold"


def test_negative_and_universal_preconditions_name_the_atom(odb, templates, world_of):
    world = world_of(BASE)
    with pytest.raises(ActionError, match=r"stand_up\(arm, big_box, table\): precondition \(not \(upright big_box\)\) does not hold"):
        apply_action(world, odb, templates, "stand_up", ["arm", "big_box", "table"])
    holding = apply_action(world, odb, templates, "pick", ["arm", "small_box", "table"])
    blocked = holding.with_facts(holding.facts - {Fact("clear", ("big_box",))})
    with pytest.raises(ActionError, match=r"place\(arm, small_box, big_box\): precondition \(clear big_box\) does not hold"):
        apply_action(blocked, odb, templates, "place", ["arm", "small_box", "big_box"])
    with pytest.raises(ActionError, match=r"precondition \(not \(= small_box small_box\)\) does not hold"):
        apply_action(holding, odb, templates, "place", ["arm", "small_box", "small_box"])


def test_bad_calls(odb, templates, world_of):
    world = world_of(BASE)
    with pytest.raises(ActionError, match="unknown action 'grab'; actions: pick, place, push"):
        apply_action(world, odb, templates, "grab", ["arm", "big_box"])
    with pytest.raises(ActionError, match=r"pick takes 3 argument\(s\) \(\?r - robot \?o - movable \?s - object\), got 2"):
        apply_action(world, odb, templates, "pick", ["arm", "big_box"])
    with pytest.raises(ActionError, match=r"unknown object 'shelf' for \?s; objects: Cup 1, Tray 1, arm"):
        apply_action(world, odb, templates, "pick", ["arm", "big_box", "shelf"])
    with pytest.raises(ActionError, match=r"\?o must be a movable, but 'table' is a table"):
        apply_action(world, odb, templates, "pick", ["arm", "table", "big_box"])
    with pytest.raises(ActionError, match=r"\?o must be a box, but 'Cup 1' is a cup"):
        apply_action(world, odb, templates, "push_over", ["arm", "Cup 1", "table"])


def test_push_over_and_stand_up(odb, templates, world_of):
    world = world_of(BASE)
    toppled = apply_action(world, odb, templates, "push_over", ["arm", "big_box", "table"])
    assert set(world.facts) - set(toppled.facts) == {Fact("upright", ("big_box",))}
    assert toppled.facts <= world.facts and world.facts == frozenset(world_of(BASE).facts)  # input not changed
    again = apply_action(toppled, odb, templates, "stand_up", ["arm", "big_box", "table"])
    assert again.facts == world.facts and again.objects == world.objects


def test_pick_and_place_conditional_and_universal_effects(odb, templates, world_of):
    world = world_of(BASE + ["(on cup_1 tray_1)", "(in cup_1 tray_1)", "(upright cup_1)",
                             "(clear cup_1)", "(touching cup_1 small_box)", "(touching small_box cup_1)"])
    world = world.with_facts(world.facts - {Fact("clear", ("Tray 1",))})
    held = apply_action(world, odb, templates, "pick", ["arm", "cup_1", "tray_1"])  # PDDL names work too
    gone = {Fact("on", ("Cup 1", "Tray 1")), Fact("in", ("Cup 1", "Tray 1")), Fact("hand-empty", ("arm",)),
            Fact("touching", ("Cup 1", "small_box")), Fact("touching", ("small_box", "Cup 1"))}
    assert world.facts - held.facts == gone
    assert held.facts - world.facts == {Fact("holding", ("arm", "Cup 1")), Fact("clear", ("Tray 1",))}

    placed = apply_action(held, odb, templates, "place", ["arm", "Cup 1", "big_box"])
    assert placed.facts - held.facts == {Fact("on", ("Cup 1", "big_box")), Fact("hand-empty", ("arm",))}
    assert held.facts - placed.facts == {Fact("holding", ("arm", "Cup 1")), Fact("clear", ("big_box",))}
    back = apply_action(apply_action(placed, odb, templates, "pick", ["arm", "Cup 1", "big_box"]),
                        odb, templates, "place", ["arm", "Cup 1", "Tray 1"])
    assert Fact("in", ("Cup 1", "Tray 1")) in back.facts and Fact("clear", ("Tray 1",)) not in back.facts
    on_table = apply_action(held, odb, templates, "place", ["arm", "Cup 1", "table"])
    assert not any(f.predicate == "in" for f in on_table.facts)


def test_pick_leaves_a_support_unclear_while_something_else_rests_on_it(odb, templates, world_of):
    world = world_of(["(on big_box table)", "(on tray_1 table)", "(on small_box tray_1)", "(on cup_1 tray_1)",
                      "(upright cup_1)", "(clear cup_1)", "(clear small_box)", "(upright small_box)", "(hand-empty arm)"])
    held = apply_action(world, odb, templates, "pick", ["arm", "cup_1", "tray_1"])
    assert Fact("clear", ("Tray 1",)) not in held.facts


def test_deletes_come_before_adds(odb, templates, world_of):
    touching = ["(touching small_box big_box)", "(touching big_box small_box)"]
    world = world_of(BASE + touching)
    after = apply_action(world, odb, templates, "push_against", ["arm", "small_box", "big_box", "table"])
    assert after.facts == world.facts  # the forall deletes the contact with big_box, the add puts it back
    pushed = apply_action(world, odb, templates, "push", ["arm", "small_box", "table"])
    assert world.facts - pushed.facts == {Fact.parse(t) for t in touching}


def test_delete_and_add_of_one_atom_in_one_template(odb, tmp_path, world_of):
    (tmp_path / "flip.yaml").write_text(
        'name: flip\nparameters: "?o - box"\nprecondition: "(and)"\n'
        'effect: "(and (when (upright ?o) (not (upright ?o))) (when (not (upright ?o)) (upright ?o)) (not (clear ?o)) (clear ?o))"\n')
    templates = load_action_templates(tmp_path, odb)
    world = world_of(BASE)
    flipped = apply_action(world, odb, templates, "flip", ["big_box"])
    # conditions are read in the state before: only the first 'when' fires; clear is deleted and added: it holds
    assert world.facts - flipped.facts == {Fact("upright", ("big_box",))} and flipped.facts <= world.facts
    assert apply_action(flipped, odb, templates, "flip", ["big_box"]).facts == world.facts


def test_apply_plan_names_the_failing_step(odb, templates, toppled):
    steps = [PlanStep("stand_up", ("arm", "small_box", "work_table")), "(pick arm small_box work_table)",
             ("place", ["arm", "small_box", "tray_1"])]
    final = apply_plan(toppled, odb, templates, steps)
    assert goal_holds(final, odb) and unmet_goal(toppled, odb) == "(upright small_box)"
    with pytest.raises(ActionError, match=r"plan step 2 \(place arm small_box tray_1\): place\(arm, small_box, Tray 1\): "
                                          r"precondition \(holding arm small_box\) does not hold"):
        apply_plan(toppled, odb, templates, [steps[0], steps[2]])


def test_goals_with_quantifiers(odb, toppled):
    assert goal_holds(toppled, odb, "(exists (?b - box) (not (upright ?b)))")
    assert not goal_holds(toppled, odb, "(forall (?b - box) (upright ?b))")
    assert unmet_goal(toppled, odb, "(forall (?b - box) (upright ?b))") == "(upright small_box)"
    assert unmet_goal(toppled, odb, "(or (holding arm big_box) (= big_box small_box))") == \
        "(or (holding arm big_box) (= big_box small_box))"
    assert goal_holds(toppled, odb, "(imply (holding arm big_box) (upright small_box))")
    with pytest.raises(PddlError, match="unknown object 'shelf'"):
        goal_holds(toppled, odb, "(on big_box shelf)")


def test_read_plan(tmp_path):
    path = tmp_path / "sas_plan"
    path.write_text("(pick arm small_box work_table)\n(place arm small_box tray_1)\n; cost = 2 (unit cost)\n")
    assert read_plan(path) == (PlanStep("pick", ("arm", "small_box", "work_table")), PlanStep("place", ("arm", "small_box", "tray_1")))
    assert read_plan("; cost = 0 (unit cost)\n") == ()
    with pytest.raises(PddlError, match="plan syntax error"):
        read_plan("(pick arm (small_box))")

"""Differences between world states, and between a world state and a PDDL problem."""
import json
import math
from dataclasses import replace
from pathlib import Path

import pytest

from bridge.diff import ObjectMove, diff_world_problem, diff_worlds
from bridge.odb import load_object_database
from bridge.planning import problem_text, read_problem
from bridge.values import Fact, Pose
from bridge.world import ObjectState, load_world_state

REPO = Path(__file__).resolve().parents[1]
TOPPLED = REPO / "tests" / "fixtures" / "worlds" / "toppled.yaml"


@pytest.fixture(scope="module")
def world():
    return load_world_state(TOPPLED, load_object_database())


def test_no_change(world):
    diff = diff_worlds(world, world)
    assert diff.empty and diff.text() == "no change"
    assert diff.to_json() == {"added": [], "removed": [], "moved": [], "objects_added": [], "objects_removed": [],
                              "uncertain": []}


def test_facts_and_moves(world):
    box = world.objects["big_box"].pose
    tipped = Pose.from_rpy((box.xyz[0] + 0.152, box.xyz[1], 0.80), (0.0, math.radians(87.3), 0.0))
    nudged = Pose((world.objects["small_box"].pose.xyz[0] + 0.005,) + world.objects["small_box"].pose.xyz[1:],
                  world.objects["small_box"].pose.quat)
    after = world.with_poses({"big_box": tipped, "small_box": nudged}).with_facts(
        (world.facts - {Fact("upright", ("big_box",))}) | {Fact("touching", ("big_box", "small_box"))})
    diff = diff_worlds(world, after)
    assert diff.added == {Fact("touching", ("big_box", "small_box"))}
    assert diff.removed == {Fact("upright", ("big_box",))}
    assert [m.object for m in diff.moved] == ["big_box"]  # small_box moved 5 mm: under the 1 cm threshold
    move = diff.moved[0]
    assert move.rotation_deg == pytest.approx(87.3, abs=1e-6)
    assert move.translation_m == pytest.approx(math.hypot(0.152, 0.075), abs=1e-9)
    assert diff.text().splitlines() == [
        "- (upright big_box)", "+ (touching big_box small_box)", "~ big_box moved 0.169 m, turned 87.3 deg"]
    data = json.loads(json.dumps(diff.to_json()))
    assert data["added"] == ["(touching big_box small_box)"] and data["removed"] == ["(upright big_box)"]
    assert data["moved"] == [{"object": "big_box", "translation_m": round(move.translation_m, 6), "rotation_deg": 87.3}]
    finer = diff_worlds(world, after, translation_threshold=0.001)
    assert [m.object for m in finer.moved] == ["big_box", "small_box"]
    assert diff_worlds(world, after, translation_threshold=1.0, rotation_threshold_deg=90).moved == ()


def test_objects_added_and_removed(world):
    objects = dict(world.objects)
    del objects["big_box"]
    objects["Cup 2"] = ObjectState("Cup 2", "cup", Pose((0.5, 0.0, 0.8)))
    after = replace(world, objects=objects, facts=frozenset(f for f in world.facts if "big_box" not in f.args))
    diff = diff_worlds(world, after)
    assert diff.objects_added == ("Cup 2",) and diff.objects_removed == ("big_box",)
    assert diff.text().splitlines()[:2] == ["- object big_box", "+ object Cup 2"]
    assert diff.moved == ()


def test_world_against_problem(world):
    odb = load_object_database()
    text = problem_text(world, odb).replace("(clear small_box)", "(upright small_box)")
    diff = diff_world_problem(world, read_problem(text, odb))
    assert diff.added == {Fact("upright", ("small_box",))} and diff.removed == {Fact("clear", ("small_box",))}
    assert diff.text() == "- (clear small_box)\n+ (upright small_box)"
    assert diff.moved == () and diff.objects_added == () and diff.objects_removed == ()
    bare = "\n".join(line for line in text.splitlines() if not line.startswith("; bridge-name"))
    assert read_problem(bare, odb).objects.get("tray_1") == "tray"  # without the comments: PDDL names
    assert diff_world_problem(world, read_problem(bare, odb)) == diff  # mapped back through the world's names


def test_object_move_is_a_value():
    assert ObjectMove("a", 0.1, 2.0) == ObjectMove("a", 0.1, 2.0)

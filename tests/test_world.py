"""World state files: round trip, atomic save, and one clear message per malformed input."""
import math
import os
from pathlib import Path

import pytest

from bridge.errors import WorldStateError
from bridge.values import Fact, Pose
from bridge.world import load_world_state, save_world_state

REPO = Path(__file__).resolve().parents[1]
DEMO = REPO / "demo" / "worlds" / "tabletop.yaml"


def test_demo_world_round_trip(odb, tmp_path):
    world = load_world_state(DEMO, odb)
    assert Fact("on", ("big_box", "table")) in world.facts
    assert world.robot is not None and world.robot.type == "demo_arm"
    out = tmp_path / "w.yaml"
    save_world_state(world, out)
    again = load_world_state(out, odb)
    assert again.facts == world.facts
    for name, obj in world.objects.items():
        assert again.objects[name].pose.translation_to(obj.pose) < 1e-9
        assert again.objects[name].pose.rotation_to(obj.pose) < 1e-9
    assert again.robot == world.robot


def test_save_is_atomic(odb, tmp_path, monkeypatch):
    world = load_world_state(DEMO, odb)
    out = tmp_path / "w.yaml"
    out.write_text("old content\n")

    def broken_replace(src, dst):
        raise OSError("disk full")

    monkeypatch.setattr(os, "replace", broken_replace)
    with pytest.raises(WorldStateError, match="w.yaml: cannot write file: disk full"):
        save_world_state(world, out)
    assert out.read_text() == "old content\n"
    assert [p.name for p in tmp_path.iterdir()] == ["w.yaml"]  # no temp file left behind


BASE = """objects:
  table: {type: table, pose: {xyz: [0.75, 0, 0.725]}}
  box: {type: big_box, pose: {xyz: [0.6, 0, 0.875]}}
robot: {name: arm, type: demo_arm}
facts: ["(on box table)"]
"""

BAD_WORLDS = [
    ("yaml syntax", BASE + "facts: [\n", ["YAML syntax error", "line"]),
    ("unknown type", BASE.replace("type: big_box", "type: huge_box"), ["objects.box.type", "unknown object type 'huge_box'", "big_box"]),
    ("abstract type", BASE.replace("type: big_box", "type: movable"), ["objects.box.type", "unknown object type 'movable'"]),
    ("bad pose", BASE.replace("xyz: [0.6, 0, 0.875]", "xyz: [0.6, 0]"), ["objects.box.pose", "list of 3 numbers"]),
    ("nan pose", BASE.replace("xyz: [0.6, 0, 0.875]", "xyz: [0.6, .nan, 0.8]"), ["objects.box.pose", "finite"]),
    ("bad quaternion", BASE.replace("xyz: [0.6, 0, 0.875]", "xyz: [0.6, 0, 0.8], quat: [2, 0, 0, 0]"), ["objects.box.pose", "norm"]),
    ("undeclared predicate", BASE.replace("(on box table)", "(above box table)"), ["facts[0]", "undeclared predicate 'above'"]),
    ("wrong arity", BASE.replace("(on box table)", "(on box)"), ["facts[0]", "takes 2 argument(s)"]),
    ("wrong argument type", BASE.replace("(on box table)", "(upright table)"), ["facts[0]", "'table' is a table", "expects a movable"]),
    ("unknown object", BASE.replace("(on box table)", "(on box shelf)"), ["facts[0]", "unknown object 'shelf'"]),
    ("name clash", BASE.replace("  box: {", "  Box: {type: small_box, pose: {xyz: [0.5, 0.2, 0.81]}}\n  box: {"),
     ["objects", "'Box' and 'box' both become the PDDL name 'box'"]),
    ("robot joint", BASE.replace("type: demo_arm}", "type: demo_arm, joints: {elbow: 0.3}}"), ["robot.joints.elbow", "has no joint 'elbow'"]),
    ("robot type", BASE.replace("type: demo_arm}", "type: big_box}"), ["robot.type", "unknown robot type 'big_box'"]),
    ("unknown key", BASE + "state: 3\n", ["unknown key 'state'"]),
]


@pytest.mark.parametrize("case,text,fragments", BAD_WORLDS, ids=[c[0] for c in BAD_WORLDS])
def test_malformed_world_gives_one_clear_message(odb, tmp_path, case, text, fragments):
    path = tmp_path / "world.yaml"
    path.write_text(text)
    with pytest.raises(WorldStateError) as info:
        load_world_state(path, odb)
    message = str(info.value)
    assert str(path) in message and "\n" not in message
    for fragment in fragments:
        assert fragment in message, message
    assert path.read_text() == text


def test_non_identifier_names_are_kept(odb, tmp_path):
    path = tmp_path / "w.yaml"
    path.write_text(BASE.replace("  box: {", "  Cup 1: {type: cup, pose: {xyz: [0.5, 0.2, 0.8]}}\n  box: {"))
    world = load_world_state(path, odb)
    assert world.names.pddl("Cup 1") == "cup_1" and world.names.original("cup_1") == "Cup 1"


def test_pose_helpers():
    p = Pose.from_rpy((0, 0, 0), (0, 0, 1.0))
    assert p.yaw() == pytest.approx(1.0)
    flipped = Pose.from_rpy((0, 0, 0), (math.pi, 0, 0))
    assert Pose().rotation_to(flipped) == pytest.approx(math.pi)
    assert Pose.from_matrix(p.matrix()).rotation_to(p) < 1e-9


def test_probabilities_round_trip_and_old_files_still_load(odb, tmp_path):
    """Facts that held in only some parameter samples keep their share beside the facts; a file without them is a
    world state as before (every fact certain)."""
    world = load_world_state(DEMO, odb)
    assert world.probabilities == {} and world.samples == 0
    text = DEMO.read_text() + 'probabilities:\n  samples: 24\n  facts: {"(upright big_box)": 0.625}\n'
    path = tmp_path / "uncertain.yaml"
    path.write_text(text)
    uncertain = load_world_state(path, odb)
    assert uncertain.probabilities == {Fact("upright", ("big_box",)): 0.625} and uncertain.samples == 24
    assert uncertain.probability(Fact("upright", ("big_box",))) == 0.625
    save_world_state(uncertain, tmp_path / "again.yaml")
    assert load_world_state(tmp_path / "again.yaml", odb) == uncertain


@pytest.mark.parametrize("body, field, words", [
    ('probabilities: {samples: 0, facts: {}}', "probabilities.samples", ["whole number >= 1"]),
    ('probabilities: {samples: 4, facts: {"(upright big_box)": 1.5}}', "probabilities.facts", ["number in [0, 1]"]),
    ('probabilities: {samples: 4, facts: {"(upright ghost)": 0.5}}', "probabilities.facts", ["unknown object 'ghost'"]),
    ('probabilities: {samples: 4, facts: [1]}', "probabilities.facts", ["must map facts"]),
    ('probabilities: {samples: 4, shares: {}}', "probabilities", ["unknown key 'shares'"]),
])
def test_bad_probabilities_name_the_field(odb, tmp_path, body, field, words):
    path = tmp_path / "bad.yaml"
    path.write_text(DEMO.read_text() + body + "\n")
    with pytest.raises(WorldStateError) as info:
        load_world_state(path, odb)
    assert str(path) in str(info.value) and field in str(info.value)
    for word in words:
        assert word in str(info.value)

"""The object database: inheritance, SIE overrides, and one clear error per bad input."""
import hashlib
from pathlib import Path

import numpy as np
import pytest

from bridge.errors import ObjectDatabaseError
from bridge.odb import load_object_database


def snapshot(root: Path) -> dict[str, str]:
    return {str(p): hashlib.sha1(p.read_bytes()).hexdigest() for p in root.rglob("*") if p.is_file() and "__pycache__" not in p.parts}


def test_bundled_database_inherits_and_overrides(odb_copy):
    odb = load_object_database(odb_copy)
    small = odb.get("small_box")
    assert small.ancestors == ("small_box", "box", "movable", "object")
    assert small.pddl_type == "box" and odb.pddl_is_a("box", "movable") and not odb.pddl_is_a("box", "robot")
    assert set(small.predicates) >= {"on", "upright", "holding", "in", "clear"}
    # tray overrides the inherited upright SIE with a tighter threshold; boxes keep the paper's 20 degrees
    assert odb.sie("tray", "upright").max_tilt < odb.sie("small_box", "upright").max_tilt
    assert odb.sie("small_box", "upright").max_tilt == pytest.approx(np.radians(20))
    assert odb.predicates["holding"].params == ("robot", "movable")


BAD_INPUTS = [
    # (file, text appended or replacing, expected fragments)
    ("syntax", "types/extra.yaml", "lamp: {parent: movable\n", ["extra.yaml", "YAML syntax error", "line"]),
    ("unknown parent", "types/extra.yaml", "lamp: {parent: furniture}\n", ["extra.yaml", "lamp.parent", "unknown parent type 'furniture'"]),
    ("cycle", "types/extra.yaml", "a_type: {parent: b_type}\nb_type: {parent: a_type}\n", ["inheritance cycle", "a_type -> b_type -> a_type"]),
    ("missing mesh", "types/extra.yaml", "lamp: {parent: movable, geometry: {shape: mesh, mesh: lamp.obj}, physics: {mass: 1}}\n",
     ["lamp.geometry.mesh", "lamp.obj", "not found"]),
    ("bad SIE module", "types/extra.yaml", "lamp: {parent: small_box, predicates: {upright: {sie: sies.nothing:Upright}}}\n",
     ["lamp.predicates.upright.sie", "sies.nothing", "not found"]),
    ("bad SIE class", "types/extra.yaml", "lamp: {parent: small_box, predicates: {upright: {sie: 'sies.pose:Sideways'}}}\n",
     ["lamp.predicates.upright.sie", "sies.pose:Sideways", "not an SIE class"]),
    ("SIE reference form", "types/extra.yaml", "lamp: {parent: small_box, predicates: {upright: {sie: sies.pose.Upright}}}\n",
     ["must look like 'sies.module:ClassName'"]),
    ("unknown predicate param type", "types/extra.yaml", "lamp: {parent: movable, abstract: true, predicates: {lit: {params: [lamp_type]}}}\n",
     ["lamp.predicates.lit.params[0]", "'lamp_type' is not a PDDL type"]),
    ("signature clash", "types/extra.yaml", "lamp: {parent: small_box, predicates: {on: {params: [movable]}}}\n",
     ["lamp.predicates.on.params", "redeclares the signature"]),
    ("negative mass", "types/extra.yaml", "lamp: {parent: box, geometry: {shape: sphere, size: [0.1]}, physics: {mass: -1}}\n",
     ["lamp.physics.mass", "must be positive"]),
    ("bad size", "types/extra.yaml", "lamp: {parent: box, geometry: {shape: box, size: [0.1, 0.1]}}\n",
     ["lamp.geometry.size", "list of 3 numbers"]),
    ("unknown shape", "types/extra.yaml", "lamp: {parent: box, geometry: {shape: cone, size: [0.1]}}\n",
     ["lamp.geometry.shape", "'cone' is not one of box, cylinder, sphere, mesh"]),
    ("unknown key", "types/extra.yaml", "lamp: {parent: box, colour: red}\n", ["unknown key 'colour'", "valid keys"]),
    ("duplicate type", "types/extra.yaml", "small_box: {parent: box}\n", ["type 'small_box' is defined twice"]),
    ("missing robot model", "types/extra.yaml", "bot: {parent: robot, robot: {model: nowhere.sdf, joints: [a]}}\n",
     ["bot.robot.model", "nowhere.sdf", "not found"]),
    ("concrete without geometry", "types/extra.yaml", "lamp: {parent: movable, physics: {mass: 1}}\n",
     ["lamp.geometry", "needs a geometry"]),
]


@pytest.mark.parametrize("case,rel,text,fragments", BAD_INPUTS, ids=[c[0] for c in BAD_INPUTS])
def test_malformed_database_gives_one_clear_message(odb_copy, case, rel, text, fragments):
    (odb_copy / rel).write_text(text)
    before = snapshot(odb_copy)
    with pytest.raises(ObjectDatabaseError) as info:
        load_object_database(odb_copy)
    message = str(info.value)
    assert "\n" not in message
    for fragment in fragments:
        assert fragment in message, message
    assert snapshot(odb_copy) == before

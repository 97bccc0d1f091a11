"""The inference module on hand-made geometric states (the Drake-driven tests live in tests/sim)."""
from pathlib import Path

import pytest

from bridge.inference import infer_state
from bridge.odb import load_object_database
from bridge.values import Contact, Fact, Pose
from bridge.world import load_world_state

REPO = Path(__file__).resolve().parents[1]
DEMO = REPO / "demo" / "worlds" / "tabletop.yaml"


@pytest.fixture(scope="module")
def world(odb):
    return load_world_state(DEMO, odb)


def resting_contacts(*pairs):
    return [Contact(a, b, (0.0, 0.0, 5.0)) for a, b in pairs]


def test_toppled_box_loses_upright_and_stays_on_table(odb, world):
    lying = Pose.from_rpy((0.55, 0.2, 0.75 + 0.05), (1.5708, 0, 0))
    result = infer_state(world, odb, {"big_box": lying}, resting_contacts(("big_box", "table"), ("small_box", "table")),
                         moved=["big_box"])
    assert Fact("upright", ("big_box",)) in result.removed
    assert Fact("on", ("big_box", "table")) in result.world.facts
    assert "small_box" not in result.evaluated  # nobody touched it: not re-evaluated


def test_untouched_object_keeps_its_facts_even_if_they_look_wrong(odb, world):
    # small_box's pose says it floats, but it did not move and nothing that moved touched it
    floating = Pose((0.55, -0.15, 1.2))
    result = infer_state(world, odb, {"small_box": floating}, resting_contacts(("big_box", "table")), moved=[])
    assert Fact("on", ("small_box", "table")) in result.world.facts
    assert not result.added and not result.removed


def test_box_moved_onto_tray_is_on_and_in_it(odb, world):
    on_tray = Pose((0.80, 0.0, 0.77 + 0.06))
    contacts = resting_contacts(("small_box", "tray"), ("tray", "table"))
    result = infer_state(world, odb, {"small_box": on_tray}, contacts, moved=["small_box"],
                         contact_pairs=[("small_box", "tray")])
    assert Fact("on", ("small_box", "tray")) in result.added
    assert Fact("in", ("small_box", "tray")) in result.added
    assert Fact("on", ("small_box", "table")) in result.removed
    assert Fact("clear", ("tray",)) in result.removed  # the tray was re-evaluated because it touched small_box


def test_sie_failures_are_reported_and_change_nothing(tmp_path, world):
    import shutil

    root = tmp_path / "odb"
    shutil.copytree(REPO / "odb", root, ignore=shutil.ignore_patterns("__pycache__"))
    robots = root / "types" / "robots.yaml"
    robots.write_text(robots.read_text().replace("../../models/", f"{REPO}/models/"))
    (root / "sies" / "broken.py").write_text(
        "from bridge.inference import SIE\nfrom bridge.values import Fact\n"
        "class Raises(SIE):\n    def evaluate(self, obj, ctx):\n        raise ZeroDivisionError('tilt sensor')\n"
        "class Malformed(SIE):\n    def evaluate(self, obj, ctx):\n        return [('on', obj, 'table')]\n"
        "class Foreign(SIE):\n    def evaluate(self, obj, ctx):\n        return [Fact('clear', ('small_box',))]\n")
    types = root / "types" / "tabletop.yaml"
    types.write_text(types.read_text().replace(
        "  physics: {mass: 1.0}",
        "  physics: {mass: 1.0}\n  predicates:\n    upright: {sie: sies.broken:Raises}\n    on: {sie: sies.broken:Malformed}\n"
        "    clear: {sie: sies.broken:Foreign}"))
    odb = load_object_database(root)
    lying = Pose.from_rpy((0.55, 0.2, 0.80), (1.5708, 0, 0))
    result = infer_state(world, odb, {"big_box": lying}, resting_contacts(("big_box", "table")), moved=["big_box"])
    failed = {f.predicate: f for f in result.failures}
    assert set(failed) == {"upright", "on", "clear"}
    assert "big_box" in str(failed["upright"]) and "sies.broken:Raises" in str(failed["upright"])
    assert "ZeroDivisionError" in failed["upright"].message
    assert "expected Fact" in failed["on"].message
    assert "not about 'big_box'" in failed["clear"].message
    # the failing SIEs' facts are kept as they were
    assert {Fact("upright", ("big_box",)), Fact("on", ("big_box", "table")), Fact("clear", ("big_box",))} <= result.world.facts

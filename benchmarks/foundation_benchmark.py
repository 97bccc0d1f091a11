"""Time the foundation on a large world: load the object database, export PDDL, diff two world states.

A world of 1,000 objects and 5,000 facts. Target (issue 2): each step under one second on the project machine.
Prints a table and writes benchmarks/results/foundation.json so two revisions can be compared.
"""
from __future__ import annotations

import json
import random
import tempfile
import time
from pathlib import Path

from bridge.diff import diff_worlds
from bridge.odb import load_object_database
from bridge.planning.problem import export_pddl
from bridge.planning.templates import load_action_templates, load_domain_settings
from bridge.values import Fact, Pose
from bridge.world import ObjectState, RobotState, WorldState, load_world_state, save_world_state
from bridge.names import build_name_map

REPO = Path(__file__).resolve().parents[1]
TARGET_S = 1.0


def large_world(n_objects: int = 1000, n_facts: int = 5000, seed: int = 0) -> WorldState:
    rng = random.Random(seed)
    kinds = ["big_box", "small_box", "bottle", "cup", "tray"]
    objects = {"table": ObjectState("table", "table", Pose((0.75, 0.0, 0.725)))}
    for i in range(n_objects - 1):
        kind = kinds[i % len(kinds)]
        objects[f"{kind}_{i}"] = ObjectState(f"{kind}_{i}", kind, Pose.from_rpy((rng.uniform(0.4, 1.1), rng.uniform(-0.5, 0.5), 0.8), (0, 0, rng.uniform(-3, 3))))
    movables = [n for n in objects if n != "table"]
    trays = [n for n in movables if n.startswith("tray")]
    facts: set[Fact] = {Fact("hand-empty", ("arm",))}
    for n in movables:
        facts |= {Fact("on", (n, "table")), Fact("upright", (n,)), Fact("clear", (n,))}
    while len(facts) < n_facts:
        a, b = rng.sample(movables, 2)
        facts.add(Fact("touching", (a, b)) if rng.random() < 0.7 else Fact("in", (a, rng.choice(trays))))
    robot = RobotState("arm", "demo_arm", Pose((0, 0, 0.75)))
    return WorldState(objects, frozenset(facts), robot, name="large", names=build_name_map(list(objects) + ["arm"]))


def timed(fn):
    start = time.perf_counter()
    value = fn()
    return value, time.perf_counter() - start


def main() -> None:
    odb, t_odb = timed(load_object_database)
    templates = load_action_templates(REPO / "pddl" / "templates", odb)
    settings = load_domain_settings(REPO / "pddl")
    world = large_world()
    rows = [("load object database", t_odb)]
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "large.yaml"
        save_world_state(world, path)
        world, t_load = timed(lambda: load_world_state(path, odb))
        rows.append(("load world state (1,000 objects, 5,000 facts)", t_load))
        _, t_export = timed(lambda: export_pddl(world, odb, templates, Path(tmp) / "pddl", settings=settings))
        rows.append(("export domain + problem", t_export))
    moved = {n: Pose((o.pose.xyz[0] + 0.05, *o.pose.xyz[1:]), o.pose.quat) for n, o in list(world.objects.items())[::10]}
    after = world.with_poses(moved).with_facts(list(world.facts)[100:])
    diff, t_diff = timed(lambda: diff_worlds(world, after))
    rows.append((f"diff ({len(diff.removed)} facts removed, {len(diff.moved)} moved)", t_diff))
    print(f"{'step':52s} {'seconds':>8s} {'target':>8s}")
    for name, seconds in rows:
        print(f"{name:52s} {seconds:8.3f} {'< ' + str(TARGET_S):>8s}{'' if seconds < TARGET_S else '  MISSED'}")
    out = REPO / "benchmarks" / "results" / "foundation.json"
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps({"target_s": TARGET_S, "rows": [{"step": n, "seconds": round(s, 4)} for n, s in rows]}, indent=2))
    print(f"wrote {out}")


if __name__ == "__main__":
    main()

"""Time the action bodies: planning (IK, clearance check) and the Drake replay of their telemetry, per action.

Every demo action from the world it starts in (place: the world a pick's replay ends in); for each: seconds of
telemetry, planning time, replay wall time, real-time factor, and whether the inferred facts equal the
template's effects. Prints a table and writes benchmarks/results/bodies.json so two revisions can be compared.
"""
from __future__ import annotations

import json
import platform
import time
from pathlib import Path

from bridge.inference import infer_state
from bridge.odb import load_object_database
from bridge.planning import apply_action, load_action_templates
from bridge.bodies import BODIES, world_after_replay
from bridge.enactment import REPLAY
from bridge.rollout import Rollout, run_rollout
from bridge.world import load_world_state

REPO = Path(__file__).resolve().parents[1]
TABLETOP = REPO / "demo" / "worlds" / "tabletop.yaml"
TOPPLED = REPO / "tests" / "fixtures" / "worlds" / "toppled.yaml"
CASES = [
    ("push_over", TABLETOP, ("arm", "big_box", "table")),
    ("push", TABLETOP, ("arm", "big_box", "table")),
    ("push_against", TABLETOP, ("arm", "small_box", "big_box", "table")),
    ("pick", TABLETOP, ("arm", "small_box", "table")),
    ("place", None, ("arm", "small_box", "tray")),  # from the world after the pick
    ("stand_up", TOPPLED, ("arm", "small_box", "work_table")),
]


def main() -> None:
    odb = load_object_database()
    templates = load_action_templates(REPO / "pddl" / "templates", odb)
    rows, held = [], None
    for action, path, args in CASES:
        world = held if path is None else load_world_state(path, odb)
        started = time.perf_counter()
        telemetry = BODIES[action](world, odb, list(args))
        planning = time.perf_counter() - started
        result = run_rollout(Rollout(world, telemetry), odb, REPLAY)
        inferred = infer_state(world, odb, result.final_poses, result.final_contacts, result.moved, result.contact_pairs())
        expected = apply_action(world, odb, templates, action, list(args))
        if action == "pick":
            held = world_after_replay(world, result, inferred.world.facts)
        rows.append({"action": action, "args": list(args), "telemetry_s": round(telemetry.duration, 2),
                     "samples": len(telemetry), "planning_s": round(planning, 3), "replay_wall_s": round(result.wall_time, 2),
                     "realtime_factor": round(result.realtime_factor, 2), "facts_match": inferred.world.facts == expected.facts})
    print(f"{'action':14s} {'telemetry':>10s} {'planning':>9s} {'replay':>8s} {'RTF':>6s}  facts")
    for r in rows:
        print(f"{r['action']:14s} {r['telemetry_s']:9.1f}s {r['planning_s']:8.2f}s {r['replay_wall_s']:7.1f}s "
              f"{r['realtime_factor']:6.2f}  {'match' if r['facts_match'] else 'DIFFER'}")
    out = REPO / "benchmarks" / "results" / "bodies.json"
    out.write_text(json.dumps({"machine": platform.processor() or platform.machine(), "rows": rows}, indent=2) + "\n")
    print(f"wrote {out}")


if __name__ == "__main__":
    main()

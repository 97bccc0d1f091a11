"""Replay speed of the paper's four demo trials, and whether a coarser step changes the inferred facts.

For each trial: the real-time factor of the replay at the default 2 ms step with sleeping objects (the default)
and without (every object stepped), the share of the replay stepped with contact dynamics, the wall time from
the end of the telemetry to the PDDL problem written, and whether the facts equal those of the full simulation
and of a 1 ms step (and the largest final-pose difference to the full simulation). Reference: the paper's Gazebo
7.7 / ODE ran at about 2.2x real time. Target (issue 3): >= 20x.
Writes benchmarks/results/replay.json.
"""
from __future__ import annotations

import json
import tempfile
import time
from pathlib import Path

from bridge.odb import load_object_database
from bridge.planning.problem import problem_text
from bridge.recording.recording import load_recording
from bridge.sim.scene import SimConfig
from bridge.sim.simulate import SimOptions
from bridge.teleop import infer_recording
from bridge.files import write_atomic

REPO = Path(__file__).resolve().parents[1]
PAPER_RTF = 2.2
TARGET_RTF = 20.0


def main() -> None:
    odb = load_object_database()
    rows = []
    for folder in sorted((REPO / "demo" / "recordings").iterdir()):
        if not (folder / "world.yaml").is_file():
            continue
        recording = load_recording(folder)
        session = infer_recording(recording, odb)
        started = time.perf_counter()
        with tempfile.TemporaryDirectory() as tmp:
            write_atomic(Path(tmp) / "problem.pddl", problem_text(session.inference.world, odb, "bridge-tabletop"))
        to_pddl = session.seconds_to_state + (time.perf_counter() - started)
        full = infer_recording(recording, odb, options=SimOptions(sleep=False))
        fine = infer_recording(recording, odb, config=SimConfig(time_step=0.001), options=SimOptions(sleep=False))
        replay = session.replay
        gap = max(1000 * full.replay.final_poses[n].translation_to(p) for n, p in replay.final_poses.items())
        rows.append({
            "trial": folder.name, "sim_s": round(replay.sim_time, 2),
            "rtf_2ms": round(replay.realtime_factor, 2), "rtf_2ms_full": round(full.replay.realtime_factor, 2),
            "rtf_1ms_full": round(fine.replay.realtime_factor, 2),
            "stepped_share": round(sum(b - a for a, b in replay.awake) / replay.sim_time, 3),
            "end_to_pddl_ms": round(1000 * to_pddl, 1),
            "same_facts_as_full": session.inference.world.facts == full.inference.world.facts,
            "final_pose_gap_to_full_mm": round(gap, 6),
            "same_facts_as_1ms": session.inference.world.facts == fine.inference.world.facts,
        })
    print(f"{'trial':18s} {'sim s':>6s} {'RTF':>6s} {'RTF full':>9s} {'RTF 1ms':>8s} {'stepped':>8s} {'end->PDDL ms':>13s} "
          f"{'= full':>7s} {'gap mm':>8s} {'= 1ms':>6s}   paper RTF {PAPER_RTF}, target {TARGET_RTF}")
    for r in rows:
        print(f"{r['trial']:18s} {r['sim_s']:6.1f} {r['rtf_2ms']:6.1f} {r['rtf_2ms_full']:9.1f} {r['rtf_1ms_full']:8.1f} "
              f"{r['stepped_share']:8.0%} {r['end_to_pddl_ms']:13.1f} {str(r['same_facts_as_full']):>7s} "
              f"{r['final_pose_gap_to_full_mm']:8.1e} {str(r['same_facts_as_1ms']):>6s}")
    out = REPO / "benchmarks" / "results" / "replay.json"
    out.write_text(json.dumps({"paper_rtf": PAPER_RTF, "target_rtf": TARGET_RTF, "rows": rows}, indent=2))
    print(f"wrote {out}")


if __name__ == "__main__":
    main()

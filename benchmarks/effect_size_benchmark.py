"""How much each concealed effect of the mismatched proof changed what was recorded, beside the verdict it got.

Each case is generated twice (`bridge.prove.generate.generate_case`): as the proof writes it and as its twin with
the effect's mechanism left out (the same draws, pushes, world and sensor noise), and the two sets of recordings
are compared push by push: how far the recorded object moved apart (mm, deg, the largest over the push), how far the
recorded rod did (a clock or an encoder that reads wrong, a servo held back), and the recorded force's ratio. A
verdict that misses an effect the recordings barely show is a different failure from one that misses an effect
that moved the object by centimetres: this tells them apart. The pushes the diagnosis fits are counted apart
(`fitted_showing`, its default hold-out left aside): an effect only the held-out pushes show can be predicted at
best, never found.

    python benchmarks/effect_size_benchmark.py [--proof benchmarks/results/prove_mismatched.json] [--only EFFECT]

Needs the MIT dataset's meshes (BRIDGE_MIT_PUSH or ../shared/datasets/mit-push); measures the MIT-format cases
(the tabletop's recording folders are left out). Prints one row a case and a summary; the full run (no `--only`)
also writes them to benchmarks/results/effect_size.json.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bridge.diagnosis.pipeline import held_out_indices  # noqa: E402
from bridge.odb import load_object_database  # noqa: E402
from bridge.prove.generate import generate_case  # noqa: E402
from bridge.prove.proof import SETTINGS, proof_cases  # noqa: E402
from bridge.recording.mitpush import load_push  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
OUT = REPO / "benchmarks" / "results" / "effect_size.json"
SHOWS_MM, SHOWS_DEG, SHOWS_FORCE = 1.0, 1.0, 0.1  # a push shows the effect when the object or the rod parted by
#                      more than a millimetre (3-4 x the proof's position noise) or a degree, or the force's mean
#                      changed by more than a tenth (log ratio; the force sensors' own gain error is 2-3 %)


def push_difference(concealed: Path, twin: Path) -> dict[str, float | None]:
    """One push with the effect against its twin: the largest parting of the object (mm, deg) and of the rod (mm),
    and the log of the ratio of their mean recorded force magnitudes (None without a force)."""
    a, b = load_push(concealed), load_push(twin)
    n = min(len(a), len(b))
    moved = np.linalg.norm(a.object_pose[:n, :2] - b.object_pose[:n, :2], axis=1)
    turned = np.degrees(np.abs(a.object_pose[:n, 2] - b.object_pose[:n, 2]))
    rod = np.linalg.norm(a.tip_xy[:n] - b.tip_xy[:n], axis=1)
    force = None
    if a.wrench is not None and b.wrench is not None:
        fa, fb = (np.linalg.norm(w[:n, :2], axis=1).mean() for w in (a.wrench, b.wrench))
        force = float(math.log(fa / fb)) if fa > 0 and fb > 0 else None
    return {"object_mm": float(moved.max() * 1e3), "object_deg": float(turned.max()), "rod_mm": float(rod.max() * 1e3),
            "log_force": force}


def shows(push: dict[str, float | None]) -> bool:
    return (push["object_mm"] > SHOWS_MM or push["object_deg"] > SHOWS_DEG or push["rod_mm"] > SHOWS_MM
            or abs(push["log_force"] or 0.0) > SHOWS_FORCE)


def fitted_showing(pushes: list[dict[str, float | None]]) -> int:
    """How many of the pushes `bridge diagnose` fits (its default hold-out left aside) show the effect: one the
    held-out pushes alone show cannot be found, only predicted."""
    held = held_out_indices(len(pushes), None)
    return sum(shows(p) for k, p in enumerate(pushes) if k not in held)


def summarise(rows: list[dict]) -> dict[str, int]:
    """Counts over the cases, those whose fitted pushes show the effect in half of them or more apart."""
    def fitted(r: dict) -> int:
        return len(r["pushes"]) - len(held_out_indices(len(r["pushes"]), None))

    judged = [r for r in rows if r["right"] is not None]
    shown = [r for r in judged if 2 * r["fitted_showing"] >= fitted(r)]
    return {"cases": len(rows), "judged": len(judged),
            "showing_in_no_push": sum(r["pushes_showing"] == 0 for r in rows),
            "wrong_showing_in_half_or_more": sum(not r["right"] and 2 * r["pushes_showing"] >= len(r["pushes"])
                                                 for r in judged),
            "wrong": sum(not r["right"] for r in judged),
            "fitted_showing_in_half_or_more": len(shown), "right_of_those": sum(r["right"] for r in shown)}


def case_size(case, odb, recordings: int) -> list[dict[str, float | None]]:
    with tempfile.TemporaryDirectory() as folder:
        concealed, _ = generate_case(case, odb, Path(folder) / "concealed", recordings)
        twin, _ = generate_case(case, odb, Path(folder) / "twin", recordings, concealed=False)
        return [push_difference(a, b) for a, b in zip(concealed, twin)]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--proof", default=str(REPO / "benchmarks" / "results" / "prove_mismatched.json"),
                        help="the proof's results (or its OUT/progress.json), for the verdicts beside the sizes")
    measured = proof_cases("full", world="mismatched")
    effects = sorted({c.effect for c in measured if c.effect != "none"})
    parser.add_argument("--only", default=None, choices=effects, help="only the cases of one effect")
    args = parser.parse_args()
    odb = load_object_database()
    proof = Path(args.proof)
    data = json.loads(proof.read_text()) if proof.is_file() else []
    verdicts = {c["case"]: c["verdict"] for c in (data["cases"] if isinstance(data, dict) else data)}
    cases = [c for c in measured if c.scene.startswith("mit_") and c.effect != "none" and args.only in (None, c.effect)]
    started, rows = time.perf_counter(), []
    for case in cases:
        pushes = case_size(case, odb, SETTINGS["full"].recordings)
        verdict = verdicts.get(case.name)
        row = {"case": case.name, "effect": case.effect, "magnitude": case.magnitude, "verdict": verdict,
               "right": None if verdict is None else verdict == case.effect,
               "pushes_showing": sum(shows(p) for p in pushes), "fitted_showing": fitted_showing(pushes),
               "pushes": pushes}
        rows.append(row)
        most = {k: max(abs(p[k] or 0.0) for p in pushes) for k in ("object_mm", "object_deg", "rod_mm", "log_force")}
        print(f"{case.name:52s} {str(verdict):22s} shows in {row['pushes_showing']}/{len(pushes)} "
              f"({row['fitted_showing']} fitted): object "
              f"{most['object_mm']:5.1f} mm {most['object_deg']:5.1f} deg, rod {most['rod_mm']:5.1f} mm, force "
              f"x{math.exp(most['log_force']):.2f}", flush=True)
    summary = summarise(rows)
    print(json.dumps(summary))
    if args.only is not None:
        return  # a part of the proof: printed, the file keeps the full run's figures
    OUT.write_text(json.dumps({"seconds": round(time.perf_counter() - started, 1), "proof": str(proof.name),
                               "thresholds": {"object_mm": SHOWS_MM, "object_deg": SHOWS_DEG,
                                              "log_force": SHOWS_FORCE},
                               "summary": summary, "cases": rows}, indent=1))


if __name__ == "__main__":
    main()

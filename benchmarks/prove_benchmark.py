"""The full proof, in the diagnosis' own worlds and in mismatched ones, side by side.

Matched: every planar effect concealed at three magnitudes (two seeds each), com_offset and hidden_obstacle in the
tabletop scene, and clean cases, the recordings made by the diagnosis' own model. Mismatched (`--world
mismatched`, needs the MIT dataset's meshes): every effect of the catalog at three magnitudes with two seeds on the
shapes rect1, ellip1, ellip3, hex, tri1, butter in turn, a clean world of every shape per seed, and the tabletop's
effects, each world differing from the model beneath the effect (bridge/prove/mismatch.py) and recorded as MIT
pushing h5 files. Each case is diagnosed blind from 8 recordings (6 fitted, 2 held out). Prints the confusion
matrix and the summaries of both worlds side by side, writes benchmarks/results/prove.json (matched) and
prove_mismatched.json. Targets (both worlds): verdict right >= 90 %, `none` (or `friction` where the world's
frictions were moved) on clean worlds >= 90 %, held-out error down >= 60 % when the verdict is right (median over
those cases, of the residual above the noise floor), diagnosing 8 recordings <= 5 min on 2 cores.

    python benchmarks/prove_benchmark.py [--world matched|mismatched|both] [--out DIR] [--workers 2]
                                         [--only SCENE] [--limit N] [--cases A,B] [--no-fit-contact]
                                         [--resume|--summarise]

The figures cover every case in OUT/progress.json (so a run resumed after an interruption counts them all).
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import time
from pathlib import Path

from bridge.odb import load_object_database
from bridge.prove.proof import SETTINGS, WORLDS, proof_cases, proof_json, proof_text, run_cases, summaries

REPO = Path(__file__).resolve().parents[1]
TARGETS = {"verdict_right": 0.9, "none_on_clean": 0.9, "held_out_excess_reduction_when_right_median": 0.6,
           "seconds_per_case_max": 300.0}  # seconds: diagnosing one case's 8 recordings


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(REPO / "out" / "prove_full"))
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--world", choices=WORLDS, default="both")
    parser.add_argument("--only", default=None, metavar="SCENE", help="only the cases of one scene (planar, tabletop, "
                        "mit_<shape>)")
    parser.add_argument("--limit", type=int, default=None, help="at most N cases (in the proof's order)")
    parser.add_argument("--cases", default=None, metavar="A,B", help="only the cases named")
    parser.add_argument("--fit-contact", action=argparse.BooleanOptionalAction, default=True,
                        help="diagnose with the object's contact stiffness and damping among the ordinary parameters "
                        "(identify.Options.contact, the default); with --no-fit-contact at the object database's "
                        "contact, the figures going to prove_*_database_contact.json")
    parser.add_argument("--resume", action="store_true", help="skip cases already in OUT/progress.json")
    parser.add_argument("--summarise", action="store_true",
                        help="run nothing: print and save the figures of the cases in OUT/progress.json")
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    progress_path = out / "progress.json"
    rows = json.loads(progress_path.read_text()) if (args.resume or args.summarise) and progress_path.is_file() else []
    started = time.perf_counter()
    if not args.summarise:
        odb = load_object_database()
        cases = [c for c in proof_cases("full", world=args.world) if args.only is None or c.scene == args.only]
        if args.cases:  # in the order named
            by_name = {c.name: c for c in cases}
            unknown = [n for n in args.cases.split(",") if n not in by_name]
            if unknown:
                raise SystemExit(f"--cases: no case {', '.join(unknown)} in the {args.world} proof"
                                 + (f" of {args.only}" if args.only else "") + "; names as in progress.json's \"case\"")
            cases = [by_name[n] for n in args.cases.split(",")]
        cases = cases[:args.limit] if args.limit is not None else cases
        settings = SETTINGS["full"]
        options = dataclasses.replace(settings.options, contact=args.fit_contact)
        settings = dataclasses.replace(settings, options=options)
        done = {r["case"] for r in rows}
        todo = [c for c in cases if c.name not in done]
        for k, r in enumerate(run_cases(todo, odb, out, settings, workers=args.workers)):
            rows.append(r.to_json())
            progress_path.write_text(json.dumps(rows, indent=1))
            print(f"[{k + 1}/{len(todo)}] {r.case.name}: {r.verdict} ({r.recovery.text}) {r.seconds:.0f} s", flush=True)
    text = proof_text(rows)
    print(text)
    seconds = time.perf_counter() - started
    for world, name in (("matched", "prove.json"), ("mismatched", "prove_mismatched.json")):
        chosen = [r for r in rows if r.get("world", "matched") == world]
        if chosen:
            result_path = REPO / "benchmarks" / "results" / (name if args.fit_contact else
                                                             name.replace(".json", "_database_contact.json"))
            result_path.parent.mkdir(parents=True, exist_ok=True)
            data = {**proof_json("full", chosen, seconds), "contact_fitted": args.fit_contact}
            result_path.write_text(json.dumps(data, indent=2) + "\n")
            print(f"wrote {result_path}")
    (out / "proof.md").write_text("# Proof (full)\n\n```\n" + text + "\n```\n")
    for world, summary in summaries(rows).items():
        missed = [k for k, t in TARGETS.items() if summary.get(k) is None
                  or (summary[k] > t if k.startswith("seconds") else summary[k] < t)]
        print(f"targets ({world}): " + ("all met" if not missed else "missed " + ", ".join(missed)))


if __name__ == "__main__":
    main()

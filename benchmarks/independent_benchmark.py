"""The diagnosis on recordings bridge did not make (issue 11): MIT-format pushes from an independent MuJoCo
generator (`independent_pushes.py`: another simulator, contact model, rod and world, one effect concealed per
case), diagnosed blind by `bridge diagnose` as a user would run it.

    pip install -e .[bench]   # mujoco
    python benchmarks/independent_benchmark.py [--shapes rect1,ellip1,hex] [--effects all] [--seeds 1]
                                               [--pushes 8] [--hold-out 2] [--workers 2] [--label now]

Per case: the verdict (right: the concealed effect; on a clean world `none` or `friction`, since every world's
frictions are drawn away from the object database's), the parameters against the truth where the effect has a
number to compare, the held-out error e before and after, the seconds. Cases are generated once into
benchmarks/results/independent/ (not committed) and diagnosed again on every run; results go to
benchmarks/results/independent.json under `--label` (other labels kept, so two revisions compare side by side).
"""
from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "benchmarks"))

import independent_pushes as gen  # noqa: E402

from bridge.diagnosis.pipeline import diagnose_paths  # noqa: E402
from bridge.odb import load_object_database  # noqa: E402
from bridge.recording.mitpush import find_mit_push_root  # noqa: E402

RESULT = REPO / "benchmarks" / "results" / "independent.json"
CASES = Path(os.environ.get("BRIDGE_INDEPENDENT_CASES", REPO / "benchmarks" / "results" / "independent"))


def right(effect: str, verdict: str) -> bool:
    if effect == "none":
        return verdict in ("none", "friction")  # every world's frictions were drawn away from the database's
    return verdict == effect


def recovered(world: dict, data: dict) -> dict:
    """The fitted numbers beside the concealed ones, where the effect has one to compare."""
    winner = next((e for e in data["effects"] if e["effect"] == data["verdict"]), None)
    if winner is None or data["verdict"] != world["effect"]:
        return {}
    p = winner["params"]

    def get(prefix: str) -> list[float]:
        return [v for k, v in p.items() if k.startswith(prefix)]
    effect = world["effect"]
    if effect == "latency":
        return {"true_ms": 1e3 * world["latency"], "fitted_ms": 1e3 * get("latency")[0]}
    if effect == "pusher_offset":
        return {"true_mm": [1e3 * v for v in world["rod_offset"]], "fitted_mm": [1e3 * v for v in get("joint_offset")]}
    if effect == "surface_tilt":
        return {"true_deg": [math.degrees(v) for v in world["tilt"]],
                "fitted_deg": [math.degrees(v) for v in get("surface_slope")]}
    if effect in ("mass", "com_offset"):
        return {"slug": world["slug"], "fitted": p}
    return {"fitted": p}


def run_case(root: Path, shape: str, effect: str, seed: int, pushes: int, hold_out: int, workers: int, odb) -> dict:
    folder = CASES / f"{shape}_{effect}_s{seed}"
    made = json.loads((folder / "truth.json").read_text()) if (folder / "truth.json").is_file() else {}
    if made.get("generator") != gen.GENERATOR or len(list(folder.glob("*.h5"))) != pushes:
        for old in folder.glob("*.h5"):
            old.unlink()
        folder = gen.make_case(root, CASES, shape, effect, seed, pushes)
    truth = json.loads((folder / "truth.json").read_text())
    files = sorted(str(f) for f in folder.glob("*.h5"))
    out = folder / "diagnosis"  # kept beside the recordings: report.md, diagnosis.json, plots
    started = time.perf_counter()
    run = diagnose_paths(files, odb, out, held_out=hold_out, workers=workers, quiet=True)
    seconds = time.perf_counter() - started
    data = run.data
    e = data["error"]
    return {"case": folder.name, "shape": shape, "effect": effect, "seed": seed, "verdict": data["verdict"],
            "right": right(effect, data["verdict"]), "recovered": recovered(truth["world"], data),
            "runner_up": (data.get("runner_up") or {}).get("effect"),
            "e_before": e["before"]["e"], "e_after": e["after"]["e"],
            "held_out_e_before": e.get("held_out_before", {}).get("e"),
            "held_out_e_after": e.get("held_out_after", {}).get("e"),
            "nominal_rms_sigma": e["before"].get("rms_sigma"), "seconds": round(seconds, 1),
            "simulations": data["simulations"], "stability": stability_of(data),
            "rod_friction": {k: v for k, v in ((data.get("evidence") or {}).get("rod_friction") or {}).items()
                             if k in ("fitted", "factor", "factor_sd", "contradicts")} or None,
            "support_pressure": {k: v for k, v in ((data.get("evidence") or {}).get("support_pressure") or {}).items()
                                 if k in ("scale", "scale_sd", "agree", "fitted", "contradicts")} or None,
            "notes": data.get("notes", [])[-3:]}


def stability_of(data: dict) -> dict | None:
    """The verdict's stability (`Stability`: the selection with each recording left out), without the names."""
    found = (data.get("cross_validation") or {}).get("stability")
    return {k: found[k] for k in ("agree", "selections", "stable")} if found else None


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--shapes", default="rect1,ellip1,hex")
    parser.add_argument("--effects", default="all")
    parser.add_argument("--seeds", default="1")
    parser.add_argument("--pushes", type=int, default=8)
    parser.add_argument("--hold-out", type=int, default=2)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--label", default="now")
    parser.add_argument("--cases", default=None, help="only these cases (comma-separated names like ellip1_none_s1)")
    parser.add_argument("--resume", action="store_true", help="skip the cases this label already has")
    args = parser.parse_args()
    try:
        import mujoco  # noqa: F401
    except ImportError:
        sys.exit("independent_benchmark: needs the `mujoco` package (pip install -e .[bench])")
    root = find_mit_push_root()
    if root is None:
        sys.exit("independent_benchmark: the MIT pushing data (the shapes' outlines) is not found (set BRIDGE_MIT_PUSH)")
    odb = load_object_database(datasets={"mit-push": str(root)})
    effects = gen.EFFECTS if args.effects == "all" else tuple(args.effects.split(","))
    results = json.loads(RESULT.read_text()) if RESULT.is_file() else {}
    entry = results.setdefault(args.label, {"cases": {}})
    if not args.resume:
        entry["cases"] = {}
    entry.update(revision=os.popen(f"git -C {REPO} rev-parse --short HEAD").read().strip(),
                 date=time.strftime("%Y-%m-%d %H:%M"), pushes=args.pushes, hold_out=args.hold_out)
    for seed in (int(s) for s in args.seeds.split(",")):
        for effect in effects:
            for shape in args.shapes.split(","):
                name = f"{shape}_{effect}_s{seed}"
                if (args.cases and name not in args.cases.split(",")) or (args.resume and name in entry["cases"]):
                    continue
                r = run_case(root, shape, effect, seed, args.pushes, args.hold_out, args.workers, odb)
                entry["cases"][r["case"]] = r
                RESULT.write_text(json.dumps(results, indent=1) + "\n")
                print(f"{r['case']:32s} {r['verdict']:22s} {'right' if r['right'] else 'WRONG':5s} "
                      f"held-out e {r['held_out_e_before'] or 0:.4f} -> {r['held_out_e_after'] or 0:.4f} "
                      f"{r['seconds']:5.0f} s {json.dumps(r['recovered'])[:120]}", flush=True)
    cases = list(entry["cases"].values())
    if cases:
        hits = sum(c["right"] for c in cases)
        print(f"{args.label}: {hits} of {len(cases)} right ({100 * hits / len(cases):.0f} %), "
              f"median {sorted(c['seconds'] for c in cases)[len(cases) // 2]:.0f} s a case")
        unstable = [c for c in cases if c.get("stability") and not c["stability"]["stable"]]
        print(f"not stable (the verdict changes with one recording left out in half the selections or more): "
              f"{len(unstable)} ({sum(c['right'] for c in unstable)} of them right)")


if __name__ == "__main__":
    main()

"""What the force reads before any fit, over sets of recordings: the rod's friction from the force's direction
(`bridge.diagnosis.cone`) and the footprint's torsion from the force and the twist (`bridge.diagnosis.pressure`),
each against the nominal model's replays (the footprint calibrated by a second replay where the pushes agree on a
scale off uniform, as the diagnosis does); and the sliding coefficient the robot's work reads window by window
(`bridge.diagnosis.work`), per push speed: whether the support's friction changes with the sliding speed.

    python benchmarks/force_readings_benchmark.py --mit ellip1 ellip3 hex rect1 --cases /tmp/ind --label X

`--mit` reads the shared MIT shapes (BRIDGE_MIT_PUSH or ../shared/datasets/mit-push); `--cases DIR` every case
folder under DIR (`independent_pushes.py` output: *.h5 beside truth.json). Writes
benchmarks/results/force_readings.json (by label), prints one row per set.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import replace
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bridge.diagnosis.cone import rod_reading  # noqa: E402
from bridge.diagnosis.pressure import calibrated_reading  # noqa: E402
from bridge.diagnosis.work import WINDOW, push_windows  # noqa: E402
from bridge.errors import RecordingError  # noqa: E402
from bridge.fit.evaluate import sim_options  # noqa: E402
from bridge.odb import load_object_database  # noqa: E402
from bridge.params import trial_rollout  # noqa: E402
from bridge.params.model import Setting  # noqa: E402
from bridge.recording.mitpush import find_mit_push_root, parse_push_name  # noqa: E402
from bridge.rollout import load_trials, make_executor  # noqa: E402
from bridge.rollout.limit_surface import pushed_object  # noqa: E402
from bridge.rollout.rollout import Job  # noqa: E402
from bridge.sim.shapes import mass_properties  # noqa: E402
from bridge.values import GRAVITY  # noqa: E402

OUT = Path(__file__).resolve().parent / "results" / "force_readings.json"


def read_set(name: str, paths: list[Path], odb, executor) -> dict:
    trials = load_trials(paths, odb)
    obj = pushed_object(trials[0], odb).name
    started = time.perf_counter()

    def replays(model) -> list:
        jobs = [Job(trial_rollout(t, model, odb), replace(sim_options(t), robot_force=True, joint_track=True))
                for t in trials]
        return [None if o.failed else o.result for o in executor.run(jobs)]

    uniform = replays(())
    rod = rod_reading(trials, uniform, odb, obj, 1.0, 1.0)
    support = calibrated_reading(trials, uniform, lambda s: replays((Setting("support_scale", obj, s),)), odb, obj)
    truth = paths[0].parent / "truth.json"
    return {"set": name, "recordings": len(trials), "seconds": round(time.perf_counter() - started, 1),
            "truth": json.loads(truth.read_text()).get("world") if truth.exists() else None,
            "rod_factor": None if rod is None else {"factor": rod.factor, "sd": rod.factor_sd,
                                                    "recorded": rod.recorded.coefficient},
            "support": None if support is None else {"scale": support.scale, "sd": support.scale_sd,
                                                     "agree": support.agree, "contradicts_uniform": support.contradicts,
                                                     "pushes": [round(p.scale, 3) for p in support.pushes]},
            "work_by_speed": work_by_speed(trials, paths, odb, obj)}


def work_by_speed(trials, paths: list[Path], odb, obj: str) -> list[dict] | None:
    """The windows' own sliding coefficient (work over m g times the footprint's mean sliding speed D, no slope)
    grouped by the push speed the file names give (0: not given): median and quartiles, with the windows'
    median D."""
    import numpy as np

    pushes = push_windows(trials, odb, obj)
    if not pushes:
        return None
    weight = float(mass_properties(odb, trials[0].world.objects[obj].type).mass) * GRAVITY
    speeds: dict[float, list[tuple[float, float]]] = {}
    for k, rows in pushes:
        try:
            v = parse_push_name(paths[k]).v
        except RecordingError:  # not named as the dataset names its files: one group
            v = 0.0
        speeds.setdefault(v, []).extend((r[0] / r[1], r[1] / (weight * WINDOW)) for r in rows if r[1] > 0)
    out = []
    for v in sorted(speeds):
        mu, d = np.array(speeds[v]).T
        out.append({"push_mm_s": v, "windows": len(mu), "sliding_mm_s": round(1e3 * float(np.median(d)), 1),
                    "coefficient": round(float(np.median(mu)), 3),
                    "quartiles": [round(float(q), 3) for q in np.percentile(mu, [25, 75])]})
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--mit", nargs="*", default=[], help="MIT shapes to read (all their pushes)")
    ap.add_argument("--cases", type=Path, help="a folder of generated case folders (*.h5 beside truth.json)")
    ap.add_argument("--label", default="head")
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args()
    root = find_mit_push_root()
    if root is None:
        sys.exit("force_readings_benchmark: the MIT pushing data is not found (set BRIDGE_MIT_PUSH)")
    odb = load_object_database(datasets={"mit-push": str(root)})
    sets = [(f"mit {s}", sorted((root / "train").glob(f"*shape={s}_*.h5"))) for s in args.mit]
    if args.cases is not None:
        sets += [(d.name, sorted(d.glob("*.h5"))) for d in sorted(args.cases.iterdir()) if d.is_dir()]
    sets = [(n, p) for n, p in sets if p]
    if not sets:
        sys.exit("force_readings_benchmark: nothing to read (give --mit shapes or --cases DIR)")
    rows = []
    with make_executor("process", odb, workers=args.workers) as executor:
        for name, paths in sets:
            row = read_set(name, paths, odb, executor)
            rows.append(row)
            rod, sup = row["rod_factor"], row["support"]
            rod_text = "-" if rod is None else "{factor:.2f} +- {sd:.2f}".format(**rod)
            sup_text = "-" if sup is None else "{scale:.2f} +- {sd:.2f} {0}".format(
                "agree" if sup["agree"] else "disagree", **sup)
            print(f"{name:32s} rod x {rod_text:14s} footprint {sup_text:24s} ({row['seconds']:.0f} s)", flush=True)
            for w in row["work_by_speed"] or ():
                print(f"{'':32s} work at {w['push_mm_s']:4.0f} mm/s: coefficient {w['coefficient']:.3f} "
                      f"({w['quartiles'][0]:.3f}-{w['quartiles'][1]:.3f}) over {w['windows']} windows sliding "
                      f"{w['sliding_mm_s']:.0f} mm/s", flush=True)
    data = json.loads(OUT.read_text()) if OUT.exists() else {}
    data[args.label] = rows
    OUT.write_text(json.dumps(data, indent=1) + "\n")
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()

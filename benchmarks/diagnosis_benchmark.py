"""Diagnosis throughput on real recordings (issue 13, item 4): `bridge diagnose` on 8 MIT planar pushes of each of a
few shapes (Yu, Bauza, Fazeli, Rodriguez, IROS 2016), 2 held out, on a process pool of 2 workers. Target: at most
5 minutes per shape on 2 cores, ellipses included.

    python benchmarks/diagnosis_benchmark.py [--shapes rect1,ellip1,hex] [--workers 2] [--label now]
                                             [--time-step auto|SECONDS]

The 8 recordings of a shape are its files in the dataset's train/ folder sorted by name, 8 of them evenly spread
(all when there are fewer). Each run is stored under its `--label` in benchmarks/results/diagnosis.json (other
labels are kept), and the table shows every label side by side: run it once with `--label before` on an older
revision (`PYTHONPATH=OLD_CHECKOUT python benchmarks/diagnosis_benchmark.py --label before`), then on this one.
Per shape: wall seconds, simulations asked for and actually run (the rest came from the rollout cache), the CPU
seconds of the worker processes, the verdict and the fitted recordings' error e before and after.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path and "PYTHONPATH" not in os.environ:
    sys.path.insert(0, str(REPO))

from bridge.diagnosis.pipeline import diagnose_paths  # noqa: E402
from bridge.odb import load_object_database  # noqa: E402
from bridge.recording.mitpush import find_mit_push_root  # noqa: E402

TARGET_S = 300.0
RESULT = REPO / "benchmarks" / "results" / "diagnosis.json"


def recordings(root: Path, shape: str, n: int = 8) -> list[Path]:
    files = sorted((root / "train").glob(f"*_shape={shape}_*.h5"))
    if len(files) <= n:
        return files
    return [files[int(round(k))] for k in np.linspace(0, len(files) - 1, n)]


def children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def run_shape(shape: str, files: list[Path], odb, workers: int, time_step: float | str = "auto") -> dict:
    with tempfile.TemporaryDirectory() as out:
        cpu0, started = children_cpu(), time.perf_counter()
        run = diagnose_paths([str(f) for f in files], odb, out, workers=workers, quiet=True, time_step=time_step)
        wall = time.perf_counter() - started
        cpu = children_cpu() - cpu0  # the pool's workers, counted once they have exited
    data = run.data
    rollouts = data.get("rollouts") or {"simulated": data["simulations"], "cached": 0}
    return {"shape": shape, "recordings": [f.name for f in files], "seconds": round(wall, 1),
            "simulations": data["simulations"], "rollouts": rollouts, "worker_cpu_s": round(cpu, 1),
            "time_step_s": (data.get("time_step") or {}).get("time_step_s"),
            "time_step_share": (data.get("time_step") or {}).get("share"),
            "time_scales": (data.get("time_scales") or {}).get("taken"),
            "forked": (data.get("forks") or {}).get("forked"),
            "params": (data.get("winner") or {}).get("params") if data["verdict"] != "none" else {},
            "params_range": ((data.get("winner") or {}).get("cv") or {}).get("params_range", {})
            if data["verdict"] != "none" else {},
            "stability": (data.get("cross_validation") or {}).get("stability"),
            "rod_friction": {k: v for k, v in ((data.get("evidence") or {}).get("rod_friction") or {}).items()
                             if k in ("fitted", "factor", "factor_sd", "contradicts")} or None,
            "support_pressure": {k: v for k, v in ((data.get("evidence") or {}).get("support_pressure") or {}).items()
                                 if k in ("scale", "scale_sd", "agree", "fitted", "contradicts")} or None,
            "verdict": data["verdict"], "e_before": data["error"]["before"]["e"], "e_after": data["error"]["after"]["e"],
            "held_out_e_before": data["error"].get("held_out_before", {}).get("e"),
            "held_out_e_after": data["error"].get("held_out_after", {}).get("e")}


def table(results: dict) -> str:
    labels = list(results)
    shapes = list(dict.fromkeys(s for label in labels for s in results[label]["shapes"]))
    head = f"{'shape':8s}" + "".join(f" | {label + ': s, sims (run), cpu s, verdict, e':52s}" for label in labels)
    lines = [head, "-" * len(head)]
    for shape in shapes:
        row = f"{shape:8s}"
        for label in labels:
            r = results[label]["shapes"].get(shape)
            if r is None:
                row += f" | {'-':52s}"
                continue
            cell = (f"{r['seconds']:6.0f} s, {r['simulations']:4d} ({r['rollouts']['simulated']:4d}), "
                    f"{r['worker_cpu_s']:6.0f}, {r['verdict']}, {r['e_before']:.4f}->{r['e_after']:.4f}")
            row += f" | {cell:52s}"
        lines.append(row)
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--shapes", default="rect1,ellip1,hex")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--label", default="now")
    parser.add_argument("--json", default=str(RESULT))
    parser.add_argument("--time-step", default="auto", help="of every replay, s, or auto (bridge diagnose's default)")
    args = parser.parse_args()
    root = find_mit_push_root()
    if root is None:
        sys.exit("diagnosis_benchmark: the MIT pushing data is not found (set BRIDGE_MIT_PUSH)")
    odb = load_object_database(datasets={"mit-push": str(root)})
    path = Path(args.json)
    results = json.loads(path.read_text()) if path.is_file() else {}
    entry = results.setdefault(args.label, {"shapes": {}})
    entry.update(machine=f"{platform.machine()}, {os.cpu_count()} CPUs", workers=args.workers,
                 revision=_revision(), date=time.strftime("%Y-%m-%d %H:%M"))
    for shape in args.shapes.split(","):
        files = recordings(root, shape)
        if not files:
            print(f"{shape}: no recordings in {root / 'train'}; skipped", flush=True)
            continue
        r = run_shape(shape, files, odb, args.workers,
                      args.time_step if args.time_step == "auto" else float(args.time_step))
        entry["shapes"][shape] = r
        print(f"{args.label} {shape}: {r['seconds']:.0f} s, {r['simulations']} simulations "
              f"({r['rollouts']['simulated']} run, {r['rollouts']['cached']} cached), worker CPU {r['worker_cpu_s']:.0f} s, "
              f"verdict {r['verdict']}" + (f", the same in {r['stability']['agree']} of "
                                           f"{r['stability']['selections']} selections with one recording left out"
                                           if r["stability"] else ""), flush=True)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(results, indent=1) + "\n")
    print(table(results))
    now = entry["shapes"].values()
    worst = max((r["seconds"] for r in now), default=0.0)
    print(f"target: <= {TARGET_S:.0f} s per shape on {args.workers} workers: "
          + ("met" if worst <= TARGET_S else f"missed (worst {worst:.0f} s)"))
    print(f"wrote {path}")


def _revision() -> str:
    import subprocess

    try:
        import bridge

        where = Path(bridge.__file__).resolve().parents[1]
        return subprocess.run(["git", "-C", str(where), "rev-parse", "--short", "HEAD"], capture_output=True,
                              text=True, check=True).stdout.strip()
    except Exception:  # noqa: BLE001 - a revision label is a nicety
        return "?"


if __name__ == "__main__":
    main()

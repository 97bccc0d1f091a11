"""Contact geometry of the MIT pushing shapes (issue 13, item 4): what one replay costs per shape with Drake's own
representation of a compliant mesh (`SimConfig(mesh_contact="drake")`, before) and with the prism representation
(`"prism"`, the default: exact outline for the rod, a footprint of at most 16 vertices fanned from its centre for
the surface; docs/rollout.md), and how far the replays of the two part.

    python benchmarks/contact_benchmark.py [--shapes rect1,tri1,hex,ellip1,ellip2,ellip3,butter] [--trials N]

Per shape: the CPU seconds of one replay (this process, one core; the mean over the recordings) and the contact
polygons between the object and the surface at rest, for both; the difference of the prism replays from Drake's:
final position and yaw and the largest along the track (median and max over the recordings); and the same
difference for Drake's own representation with the mesh file's vertices in another order (the same shape, its
faces triangulated from another vertex): how far today's replay moves under a change that means nothing, its
numerical floor. The dataset's noise floor is of the order of 1 mm / 1 deg (docs/diagnosis.md, section 7).
Shapes with recordings in the dataset's train/ folder are replayed on them (yaw frames as `load_trials` finds
them); the others (tri1, ellip2, butter) on eight generated pushes of the rod through the object from eight
directions at 50 mm/s. butter is not convex: Drake's representation is its hull, the prism one keeps its notches,
so their difference is a change of shape, not noise. Writes benchmarks/results/contact.json.
"""
from __future__ import annotations

import argparse
import json
import math
import shutil
import sys
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from bridge.names import build_name_map  # noqa: E402
from bridge.odb import load_object_database  # noqa: E402
from bridge.params import trial_rollout  # noqa: E402
from bridge.recording.mitpush import find_mit_push_root  # noqa: E402
from bridge.recording.telemetry import Telemetry  # noqa: E402
from bridge.rollout import Rollout, load_trials, run_rollout  # noqa: E402
from bridge.rollout.rollout import scene_for  # noqa: E402
from bridge.sim.prisms import centroid, mesh_prism  # noqa: E402
from bridge.sim.scene import SimConfig  # noqa: E402
from bridge.sim.simulate import SimOptions  # noqa: E402
from bridge.values import Pose  # noqa: E402
from bridge.world import ObjectState, RobotState, WorldState  # noqa: E402

SHAPES = ("rect1", "tri1", "hex", "ellip1", "ellip2", "ellip3", "butter")
DRAKE, PRISM = SimConfig(mesh_contact="drake"), SimConfig()
ROD = 0.00476
OPTIONS = SimOptions(sample_rate=50.0, robot_force=True)  # what the diagnosis records


def reordered_copy(odb_root: Path, mesh: Path, shape: str, tmp: Path) -> str:
    """A type `<shape>_reordered` whose mesh is the shape's with its vertex list rotated by a third (faces
    renumbered): the same surface, other triangulations of the hull's faces."""
    lines = mesh.read_text().splitlines()
    vertices = [line for line in lines if line.startswith("v ")]
    n = len(vertices)
    k = n // 3
    order = list(range(k, n)) + list(range(k))  # new position -> old index
    new_index = {old: new for new, old in enumerate(order)}
    out = [vertices[i] for i in order]
    for line in lines:
        if line.startswith("f "):
            corners = [str(new_index[int(c.split("/")[0]) - 1] + 1) for c in line.split()[1:]]
            out.append("f " + " ".join(corners))
    path = tmp / f"{shape}_reordered.obj"
    path.write_text("\n".join(out) + "\n")
    name = f"{shape}_reordered"
    (odb_root / "types" / f"zz_{name}.yaml").write_text(
        f"{name}: {{parent: mit_shape, geometry: {{shape: mesh, mesh: {path}, contact: drake}}}}\n")
    return name


def generated_rollouts(shape: str, odb, n: int = 8) -> list[Rollout]:
    """The rod through the object's centroid from n directions: 5 mm clear at the start, 50 mm/s for 1 s."""
    prism = mesh_prism(odb.get(shape).geometry.mesh, odb.get(shape).geometry.scale)
    outline, half = prism.outline, 0.5 * (prism.z1 - prism.z0)
    c = centroid(outline)
    rollouts = []
    for k in range(n):
        a = 2 * math.pi * (k + 0.5) / n
        d = np.array([math.cos(a), math.sin(a)])
        reach = float(np.max((outline - c) @ -d))  # how far the outline reaches against the push
        start = c - d * (reach + ROD + 0.005)
        times = np.linspace(0.0, 1.3, 131)
        moving = np.clip(times - 0.1, 0.0, 1.0) * 0.05
        path = start + np.outer(moving, d)
        objects = {"surface": ObjectState("surface", "push_surface", Pose((c[0], c[1], -0.005))),
                   shape: ObjectState(shape, shape, Pose((0.0, 0.0, half)))}
        robot = RobotState("pusher", "planar_pusher", Pose((0.0, 0.0, half)),
                           (("pusher_x", float(path[0, 0])), ("pusher_y", float(path[0, 1]))))
        world = WorldState(objects, robot=robot, name=f"{shape}_push{k}", names=build_name_map([*objects, "pusher"]))
        rollouts.append(Rollout(world, Telemetry(times, ("pusher_x", "pusher_y"), path), name=world.name))
    return rollouts


def with_type(rollout: Rollout, shape: str, type_name: str) -> Rollout:
    objects = dict(rollout.world.objects)
    objects[shape] = replace(objects[shape], type=type_name)
    return rollout.with_world(replace(rollout.world, objects=objects))


def support_polygons(rollout: Rollout, odb, shape: str) -> int:
    """Contact polygons between the object and the surface 50 ms into the replay (at rest, before the push)."""
    from pydrake.systems.analysis import Simulator

    from bridge.sim.contacts import ContactReader
    from bridge.sim.simulate import start_replay

    scene = scene_for(rollout, odb)
    context, *_ = start_replay(scene, rollout.telemetry, world=rollout.world, values=rollout.values)
    Simulator(scene.diagram, context).AdvanceTo(0.05)
    results = scene.plant.get_contact_results_output_port().Eval(scene.plant.GetMyContextFromRoot(context))
    reader = ContactReader(scene)
    faces = 0
    for i in range(results.num_hydroelastic_contacts()):
        s = results.hydroelastic_contact_info(i).contact_surface()
        if {reader.name(s.id_M()), reader.name(s.id_N())} == {shape, "surface"}:
            faces += s.num_faces()
    return faces


def difference(a, b, shape: str) -> tuple[float, float, float, float]:
    """Final position (mm) and yaw (deg) apart, and the largest of each along the track."""
    ta, tb = a.tracks[shape], b.tracks[shape]
    dp = np.linalg.norm(ta[:, :2] - tb[:, :2], axis=1) * 1e3
    yaw = [np.unwrap(2 * np.arctan2(t[:, 6], t[:, 3])) for t in (ta, tb)]
    dy = np.degrees(np.abs(yaw[0] - yaw[1]))
    return float(dp[-1]), float(dy[-1]), float(dp.max()), float(dy.max())


def summary(diffs: list) -> dict:
    d = np.array(diffs)
    keys = ("final_mm", "final_deg", "track_mm", "track_deg")
    return {k: {"median": round(float(np.median(d[:, i])), 3), "max": round(float(d[:, i].max()), 3)}
            for i, k in enumerate(keys)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--shapes", default=",".join(SHAPES))
    parser.add_argument("--trials", type=int, default=None, help="at most this many recordings per shape")
    parser.add_argument("--json", default=str(REPO / "benchmarks" / "results" / "contact.json"))
    args = parser.parse_args()
    root = find_mit_push_root()
    if root is None:
        sys.exit("contact_benchmark: the MIT pushing data is not found (set BRIDGE_MIT_PUSH)")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        odb_root = tmp / "odb"
        shutil.copytree(REPO / "odb", odb_root, ignore=shutil.ignore_patterns("__pycache__"))
        robots = odb_root / "types" / "robots.yaml"
        robots.write_text(robots.read_text().replace("../../models/", f"{REPO}/models/"))
        base = load_object_database(datasets={"mit-push": str(root)})
        shapes = args.shapes.split(",")
        reordered = {s: reordered_copy(odb_root, base.get(s).geometry.mesh, s, tmp) for s in shapes}
        odb = load_object_database(odb_root, datasets={"mit-push": str(root)})
        for shape in shapes:
            files = sorted((root / "train").glob(f"*_shape={shape}_*.h5"))
            if files:
                trials = load_trials(files[:args.trials] if args.trials else files, odb)
                rollouts, source = [trial_rollout(t, (), odb) for t in trials], f"{len(trials)} recordings"
            else:
                rollouts = generated_rollouts(shape, odb)[:args.trials] if args.trials else generated_rollouts(shape, odb)
                source = f"{len(rollouts)} generated pushes"
            runs = {}
            for label, config, type_name in (("drake", DRAKE, shape), ("prism", PRISM, shape),
                                             ("drake_reordered", DRAKE, reordered[shape])):
                run_rollout(replace(with_type(rollouts[0], shape, type_name), config=config), odb, OPTIONS)  # warm
                runs[label] = [run_rollout(replace(with_type(r, shape, type_name), config=config), odb, OPTIONS)
                               for r in rollouts]
            cpu = {k: float(np.mean([r.cpu_time for r in v])) for k, v in runs.items()}
            sim = float(np.mean([r.sim_time for r in runs["drake"]]))
            polygons = {label: support_polygons(replace(rollouts[0], config=config), odb, shape)
                        for label, config in (("drake", DRAKE), ("prism", PRISM))}
            row = {"shape": shape, "source": source, "sim_s": round(sim, 2),
                   "cpu_s": {k: round(v, 3) for k, v in cpu.items()},
                   "speedup": round(cpu["drake"] / cpu["prism"], 2), "support_polygons": polygons,
                   "outline_vertices": len(mesh_prism(odb.get(shape).geometry.mesh, 1.0).outline)
                   if mesh_prism(odb.get(shape).geometry.mesh, 1.0) is not None else None,
                   "prism_vs_drake": summary([difference(a, b, shape) for a, b in zip(runs["prism"], runs["drake"])]),
                   "drake_floor": summary([difference(a, b, shape)
                                           for a, b in zip(runs["drake_reordered"], runs["drake"])])}
            rows.append(row)
            p, f = row["prism_vs_drake"], row["drake_floor"]
            print(f"{shape:7s} {source:20s} sim {sim:4.1f} s  cpu drake {cpu['drake']:5.2f} s prism {cpu['prism']:5.2f} s "
                  f"({row['speedup']:.1f}x)  polygons {polygons['drake']:3d} -> {polygons['prism']:3d}  "
                  f"prism-drake final {p['final_mm']['median']:.2f}/{p['final_mm']['max']:.2f} mm "
                  f"{p['final_deg']['median']:.2f}/{p['final_deg']['max']:.2f} deg (median/max); "
                  f"floor {f['final_mm']['median']:.2f}/{f['final_mm']['max']:.2f} mm "
                  f"{f['final_deg']['median']:.2f}/{f['final_deg']['max']:.2f} deg", flush=True)
    out = Path(args.json)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps({"options": "50 Hz, robot force", "rows": rows}, indent=1) + "\n")
    print(f"wrote {out}")


if __name__ == "__main__":
    main()

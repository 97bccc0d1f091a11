"""Recordings with a concealed effect, for the proof: each effect made by a physical mechanism that differs from
the model the diagnosis fits wherever it can (the effect's own `conceal`, in its file under
`bridge/diagnosis/effects/`):

| effect          | concealed by (generator)                                   | modelled by (diagnosis)                     |
|-----------------|------------------------------------------------------------|---------------------------------------------|
| friction        | the surface's coefficient (another surface material)       | the object's or the surface's coefficient   |
| mass            | a dense slug welded at the object's centre                  | the body's mass parameter                    |
| com_offset      | a dense slug welded off-centre (moves COM, adds mass)       | the body's centre-of-mass parameter          |
| surface_tilt    | the support fixture rotated about a point off its centre    | the fixture rotated about its centre, raised |
| friction_patch  | a sheet of another material welded flush on the surface     | a 1 um sheet over a square that carries      |
|                 | (a rectangle; objects on it press on sheet and surface)     | what stands on it alone                      |
| latency         | telemetry stamped dt early (resampled at the recorder's    | telemetry shifted by dt                      |
| (cont.)         | clock, 100 Hz)                                              |                                              |
| pusher_offset   | the robot's base mounted off by (dx, dy)                   | offsets added to the joint readings          |
| hidden_obstacle | a welded box of random size and yaw                         | a welded post of radius 15 mm                |

Observations are the true simulation sampled at 50 Hz with Gaussian measurement noise (position and a small
random rotation), and the contact force on the rod as a planar force sensor reads it (fx, fy, with noise). The
truth of each case is written beside the recordings (truth.json), never inside them.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from ..diagnosis.effects import Truth, get_effect
from ..files import dump_yaml, write_atomic
from ..odb import ObjectDatabase
from ..recording.forces import ObservedForce
from ..recording.observations import ObservedPoses, ObservedTrack
from ..recording.recording import save_recording
from ..recording.telemetry import Telemetry
from ..rollout.rollout import Rollout, run_rollout
from ..sim.simulate import SimOptions
from ..values import Pose
from ..world import world_to_dict
from .scenes import (MAGNITUDES, NOISE_FORCE, NOISE_POSITION, NOISE_ROTATION, OBS_RATE, Case, SceneSpec, design_pushes,
                     nominal_world, scene_spec)


def case_truth(case: Case, spec: SceneSpec, odb: ObjectDatabase, rng: np.random.Generator) -> Truth:
    """Draw the concealed effect's true values (the same for every recording of the case): a sign first (for
    effects that go either way), then the effect's own draws."""
    sign = 1.0 if rng.random() < 0.5 else -1.0
    return get_effect(case.effect).draw_truth(spec, odb, rng, MAGNITUDES.index(case.magnitude), sign)


def noisy_track(obj: str, times: np.ndarray, track: np.ndarray, rng: np.random.Generator,
                noise: tuple[float, float]) -> ObservedTrack:
    poses = []
    for row in track:
        xyz = row[:3] + rng.normal(0.0, noise[0], 3)
        R = Rotation.from_rotvec(rng.normal(0.0, noise[1], 3)) * Rotation.from_quat(row[[4, 5, 6, 3]])
        q = R.as_quat()
        poses.append(Pose(tuple(xyz), (q[3], q[0], q[1], q[2])))
    return ObservedTrack(obj, times, tuple(poses))


def generate_case(case: Case, odb: ObjectDatabase, folder: Path, n: int, *,
                  noise: tuple[float, float] = (NOISE_POSITION, NOISE_ROTATION),
                  force_noise: float | None = NOISE_FORCE) -> tuple[list[Path], Truth]:
    """Write `n` recording folders under `folder` (rec_00, ...) with `case`'s effect concealed; truth.json beside.
    `force_noise` None leaves the rod's force sensor out (poses only)."""
    spec = scene_spec(case.scene, odb)
    rng = np.random.default_rng(case.seed)
    truth = case_truth(case, spec, odb, rng)
    effect = get_effect(case.effect)
    paths = []
    for k, push in enumerate(design_pushes(spec, odb, rng, n)):
        exact = Rollout(nominal_world(spec, odb, push.start), Telemetry(push.times, ("pusher_x", "pusher_y"), push.path),
                        name=f"{case.name}/rec_{k:02d}")
        true, recorded = effect.conceal(truth, spec, odb, exact)
        result = run_rollout(true, odb, SimOptions(sample_rate=OBS_RATE, end=float(push.times[-1]), robot_force=True))
        times, force = result.times, result.robot_force
        observed = noisy_track(spec.object, times, result.tracks[spec.object], rng, noise)
        sensed = None
        if force_noise is not None:  # a planar force sensor on the rod: fx, fy
            planar = force[:, :2] + rng.normal(0.0, force_noise, (len(times), 2))
            sensed = ObservedForce(times, np.column_stack([planar, np.zeros(len(times))]))
        first = observed.poses[:5]
        x = float(np.mean([p.xyz[0] for p in first]))
        y = float(np.mean([p.xyz[1] for p in first]))
        yaw = float(np.angle(np.mean([np.exp(1j * p.yaw()) for p in first])))
        world = nominal_world(spec, odb, (x, y, yaw))
        path = folder / f"rec_{k:02d}"
        save_recording(path, "# bridge world state\n" + dump_yaml(world_to_dict(world)), recorded,
                       ObservedPoses((observed,)), {"name": f"{case.scene}_rec_{k:02d}", "robot": "planar_pusher"},
                       force=sensed, overwrite=True)
        paths.append(path)
    write_atomic(folder / "truth.json", json.dumps({"case": case.name, **truth.to_json()}, indent=2))
    return paths, truth

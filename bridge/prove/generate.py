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
| hidden_obstacle | a welded box of random size and yaw                         | a welded post of fitted radius               |
| object_frame    | the recorder reports a frame fixed on the body off its      | the body started from the recorded pose      |
| (cont.)         | centre and turned (`Effect.recorded_track`)                 | moved, compared in the frame (`frames`)      |
| object_scale    | the object another size (pushes designed around it)         | the same: a size has no other mechanism      |

Observations are the true simulation sampled at 50 Hz with Gaussian measurement noise (position and a small
random rotation), and the contact force on the rod as a planar force sensor reads it (fx, fy, with noise). The
truth of each case is written beside the recordings (truth.json), never inside them.
"""
from __future__ import annotations

import json
import math
import zlib
from dataclasses import replace
from pathlib import Path
from typing import Sequence

import numpy as np
from scipy.spatial.transform import Rotation

from ..diagnosis.effects import Truth, get_effect, pname
from ..files import dump_yaml, write_atomic
from ..odb import ObjectDatabase
from ..recording.forces import ObservedForce
from ..recording.mitpush import save_push
from ..recording.observations import ObservedPoses, ObservedTrack
from ..recording.recording import save_recording
from ..recording.telemetry import Telemetry
from ..rollout.rollout import Rollout, run_rollout
from ..sim.scene import SimConfig, contact_mode
from ..sim.simulate import SimOptions
from ..values import Pose
from ..world import world_to_dict
from .mismatch import TIME_STEPS, Mismatch, Sensors, draw_mismatch
from .scenes import (MAGNITUDES, NOISE_FORCE, NOISE_POSITION, NOISE_ROTATION, OBS_RATE, PUSH_SPEEDS, TEL_RATE,
                     Case, SceneSpec, design_pushes, nominal_world, scene_spec)


def case_truth(case: Case, spec: SceneSpec, odb: ObjectDatabase, rng: np.random.Generator) -> Truth:
    """Draw the concealed effect's true values (the same for every recording of the case): a sign first (for
    effects that go either way), then the effect's own draws."""
    sign = 1.0 if rng.random() < 0.5 else -1.0
    return get_effect(case.effect).draw_truth(spec, odb, rng, MAGNITUDES.index(case.magnitude), sign)


def noisy_track(obj: str, times: np.ndarray, track: np.ndarray, rng: np.random.Generator,
                noise: tuple[float, float] | Sensors) -> ObservedTrack:
    """The track as a motion-capture system reports it: white `noise` (position, rotation sigma) or `Sensors`."""
    if isinstance(noise, Sensors):
        dxyz, drot = noise.pose_noise(times, rng)
    else:
        draws = [(rng.normal(0.0, noise[0], 3), rng.normal(0.0, noise[1], 3)) for _ in track]
        dxyz, drot = np.array([d[0] for d in draws]).reshape(-1, 3), np.array([d[1] for d in draws]).reshape(-1, 3)
    poses = []
    for row, e_p, e_r in zip(track, dxyz, drot):
        R = Rotation.from_rotvec(e_r) * Rotation.from_quat(row[[4, 5, 6, 3]])
        q = R.as_quat()
        poses.append(Pose(tuple(row[:3] + e_p), (q[3], q[0], q[1], q[2])))
    return ObservedTrack(obj, times, tuple(poses))


def generate_case(case: Case, odb: ObjectDatabase, folder: Path, n: int, *,
                  noise: tuple[float, float] = (NOISE_POSITION, NOISE_ROTATION),
                  force_noise: float | None = NOISE_FORCE,
                  speeds: tuple[float, float] = PUSH_SPEEDS, concealed: bool = True) -> tuple[list[Path], Truth]:
    """Write `n` recordings under `folder` with `case`'s effect concealed, truth.json beside them: recording
    folders (rec_00, ...) or, in a scene recorded as the MIT pushing dataset records (`mit_<shape>`), h5 files
    (rec_00.h5, ...). A case in a mismatched world (`case.world`) draws its `Mismatch` after the effect's truth
    and applies it beneath the effect; it draws everything from a generator of its own (its seed and its name):
    from the seed alone, cases whose truths take as many draws shared a world (the 93 cases had 10 worlds, 25 of
    them one) and their truths one direction. `force_noise` None leaves the rod's force sensor out (poses only); the
    rod's speeds are drawn from `speeds` (m/s). `concealed` False writes the case's twin: the same draws, pushes,
    world and noise with the effect's mechanism left out (`benchmarks/effect_size_benchmark.py`: how much the
    effect changed what was recorded)."""
    mismatched = case.world == "mismatched"
    spec = scene_spec(case.scene, odb, varied=mismatched)
    rng = np.random.default_rng([case.seed, zlib.crc32(case.name.encode())] if mismatched else case.seed)
    truth = case_truth(case, spec, odb, rng)
    mismatch = Mismatch()
    if mismatched:
        mismatch = draw_mismatch(rng, odb, spec.object_type, spec.surface_type, frictions=case.effect != "friction")
    else:
        mismatch = replace(mismatch, sensors=Sensors(position=noise[0], rotation=noise[1], force=force_noise or 0.0))
    effect = get_effect(case.effect)
    mechanism = effect if concealed else get_effect("none")
    paths = []
    real_size = truth.params.get(pname("object_scale", spec.object), 1.0)  # pushes start clear of the real object
    hull = contact_mode(odb.get(spec.object_type), SimConfig(mesh_contact=mismatch.mesh_contact))[0] != "prism"
    pushes = design_pushes(spec, odb, rng, n, mismatch.gap, local=effect.local, scale=real_size, speeds=speeds,
                           hull=hull)

    def exact_of(k: int, push) -> Rollout:
        telemetry = Telemetry(push.times, ("pusher_x", "pusher_y"), push.path)
        exact = Rollout(nominal_world(spec, odb, push.start), telemetry, name=f"{case.name}/rec_{k:02d}")
        return mismatch.apply(exact, spec.object, spec.surface, odb) if mismatched else exact

    drawn_step = mismatch.time_step
    if mismatched:  # the world's step made one a recording can come from (`recordable_step`); no draw is consumed
        trues = [effect.conceal(truth, spec, odb, exact_of(k, push))[0] for k, push in enumerate(pushes)]
        mismatch = replace(mismatch, time_step=recordable_step(trues, spec.object, odb))
    for k, push in enumerate(pushes):
        exact = exact_of(k, push)
        true, recorded = mechanism.conceal(truth, spec, odb, exact)
        transformed = recorded is not true.telemetry
        if spec.recorder == "mit":
            paths.append(_write_mit_push(folder / f"rec_{k:02d}.h5", spec, odb, mechanism, truth, true, exact, mismatch,
                                         rng, with_force=force_noise is not None, transformed=transformed))
            continue
        # a mismatched world's servo is not the model's: its telemetry is what the encoders read, as a real
        # robot's (the matched proof keeps the command, which the model's own servo follows exactly as the world's)
        rate = TEL_RATE if mismatched else OBS_RATE
        result = run_rollout(true, odb, SimOptions(sample_rate=rate, end=float(push.times[-1]), robot_force=True,
                                                   joint_track=mismatched))
        if mismatched:
            recorded = _encoders(result, true.telemetry.joint_names, mechanism, truth, spec, odb, exact, transformed)
        rows = _every(len(result.times), round(rate / OBS_RATE))
        times, force = result.times[rows], result.robot_force[rows]
        observed = noisy_track(spec.object, times, mechanism.recorded_track(truth, result.tracks[spec.object][rows]),
                               rng, noise if not mismatched else mismatch.sensors)
        sensed = None
        if force_noise is not None:  # a planar force sensor on the rod: fx, fy
            sensors = mismatch.sensors
            planar = sensors.force_gain * force[:, :2] + rng.normal(0.0, sensors.force, (len(times), 2))
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
    if mismatched:  # the world's differences belong to the truth: a clean world whose frictions moved is `friction`
        truth = replace(truth, extra={**truth.extra, "mismatch": mismatch.to_json(),
                                      **({"time_step_drawn": drawn_step} if mismatch.time_step != drawn_step else {})})
    if not concealed:
        truth = replace(truth, extra={**truth.extra, "concealed": False})
    write_atomic(folder / "truth.json", json.dumps({"case": case.name, **truth.to_json()}, indent=2))
    return paths, truth


TIP = math.radians(2.0)  # rad: how much further than at half its step a world may tip its object out of the plane of
# its support. A step too coarse for the contact adds energy and the object rocks or hops, in every push more than
# at half the step: Drake's discrete contact at 4 ms on Drake's own fan of a mesh's hull (`mesh_contact: "drake"`,
# drawn until session 47) tips the MIT shapes 3-6 deg more than at 2 ms on a level sheet and flips one on a tilted
# one; on an even footprint no world of the full proof tips more. Where tipping is the world's own (the tabletop's
# boxes under the arm tip 2-21 deg), it depends on the step either way, by up to 6 deg down to 0.5 ms, and at the
# coarser step by at most 1.3 deg more in the proof's worlds: chaos of the contact, not energy from the step


def recordable_step(trues: Sequence[Rollout], obj: str, odb: ObjectDatabase) -> float:
    """The step of the worlds `trues` (one per push, all at the same step), halved while a push tips `obj` out of
    the plane of its support by more than TIP further than the same push at half the step does (down to the
    smallest of `mismatch.TIME_STEPS`). A simulation that gains energy from its step is no world a recording can
    come from: at 4 ms on Drake's fan of a mesh's hull the steel MIT shapes rock a few degrees on a level sheet
    and hop tens of millimetres off a tilted one (a hexagon on a 1 deg tilt: 3 of 8 pushes flipped, 3 tipped 45-62
    deg), where no real object leaves the table; a diagnosis of such a world judges the simulator's failure, not
    the method. Every other world keeps its drawn step (every difference the mismatch drew, a coarse step's
    included, stays)."""
    step = trues[0].config.time_step

    def tips(h: float) -> np.ndarray:
        return np.array([out_of_plane(run_rollout(replace(t, config=replace(t.config, time_step=h)), odb,
                                                  SimOptions(sample_rate=100.0, end=float(t.telemetry.times[-1]))), obj)
                         for t in trues])

    coarse = tips(step) if step > min(TIME_STEPS) else None  # a world at the finest step is not replayed again
    while step > min(TIME_STEPS):
        fine = tips(step / 2)
        if np.max(coarse - fine) <= TIP:
            break
        step, coarse = step / 2, fine
    return step


def out_of_plane(result, obj: str) -> float:
    """The largest angle (rad) between `obj`'s up axis and the world's vertical over a replay."""
    up = Rotation.from_quat(result.tracks[obj][:, [4, 5, 6, 3]]).apply([0.0, 0.0, 1.0])
    return float(np.max(np.arccos(np.clip(up[:, 2], -1.0, 1.0))))


def _encoders(result, joints, effect, truth: Truth, spec: SceneSpec, odb: ObjectDatabase, exact: Rollout,
              transformed: bool) -> Telemetry:
    """The robot's `joints` as its encoders read them in a replay (`joint_track`): a servo that lags its command
    is recorded as it moved. When the effect's recorder does not read the joints as they are (`transformed`: a
    clock that stamps late, an encoder offset), its `conceal` is applied to the measured joints."""
    columns = [result.joint_names.index(j) for j in joints]
    measured = Telemetry(result.times, tuple(joints), result.joint_track[:, columns])
    return effect.conceal(truth, spec, odb, exact.with_telemetry(measured))[1] if transformed else measured


def _every(n: int, k: int) -> np.ndarray:
    """Every k-th of n samples, the last one always."""
    return np.unique(np.append(np.arange(0, n, max(1, k)), n - 1))


MIT_RATE = 250.0  # Hz of the MIT pushing dataset's streams
UNIX_START = 1.46e9  # s: the recordings' clock starts somewhere in 2016, as the dataset's


def _write_mit_push(path: Path, spec: SceneSpec, odb: ObjectDatabase, effect, truth: Truth, true: Rollout,
                    exact: Rollout, mismatch: Mismatch, rng: np.random.Generator, *, with_force: bool,
                    transformed: bool) -> Path:
    """One push as the MIT dataset records it: the rod where its encoders say it is (the simulated joints, so a
    servo that lags its command is recorded as it moved; a base mounted off is not seen), the object's pose from
    motion capture (x, y, yaw with the sensors' noise) and the force on the rod (fx, fy, with noise and gain),
    250 Hz on a unix clock. When the effect's recorder does not read the joints as they are (`transformed`: a
    clock that stamps late), its `conceal` is applied to the measured joints."""
    end = float(true.telemetry.times[-1])
    result = run_rollout(true, odb, SimOptions(sample_rate=MIT_RATE, end=end, robot_force=with_force,
                                               joint_track=True))
    times = result.times
    tip = _encoders(result, ("pusher_x", "pusher_y"), effect, truth, spec, odb, exact, transformed).sample(times)
    sensors = mismatch.sensors
    dxyz, drot = sensors.pose_noise(times, rng)
    track = effect.recorded_track(truth, result.tracks[spec.object])
    yaw = np.array([Rotation.from_quat(row[[4, 5, 6, 3]]).as_euler("zyx")[0] for row in track]) + drot[:, 2]
    clock = UNIX_START + rng.uniform(0.0, 3.0e7) + times
    stamps = clock.copy()
    if sensors.jitter > 0:  # a few pose timestamps stepped back, as in 20 of the dataset's 50 files
        late = np.nonzero(rng.random(len(stamps)) < sensors.jitter)[0]
        late = late[(late > 0) & (late < len(stamps) - 1)]
        stamps[late] = stamps[late - 1] - rng.uniform(2e-4, 1.5e-3, len(late))
    zeros = np.zeros(len(times))
    object_pose = np.column_stack([stamps, track[:, 0] + dxyz[:, 0], track[:, 1] + dxyz[:, 1], np.unwrap(yaw)])
    tip_pose = np.column_stack([clock, tip[:, 0], tip[:, 1], zeros])
    wrench = None
    if with_force:
        planar = sensors.force_gain * result.robot_force[:, :2] + rng.normal(0.0, sensors.force, (len(times), 2))
        wrench = np.column_stack([clock, planar, zeros])
    return save_push(path, tip_pose, object_pose, wrench, shape=spec.object_type)

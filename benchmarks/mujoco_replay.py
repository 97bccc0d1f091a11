"""Replay telemetry in MuJoCo, naively: every 2 ms step simulated with every object, and read back as bridge's
`ReplayResult` so the same inference and the same comparisons serve both simulators. Benchmark-only.

The loop does what bridge's replay does: the robot starts where its telemetry starts, follows it (desired
positions and velocities from a first-order hold of the samples, held before the first and after the last) for
the telemetry's duration plus `settle`; poses are sampled at `sample_rate` (a multiple of the step), the body
pairs in contact at every sample, and at the end the contacts with their forces and the pairs closer than 4 mm
(bridge's `PROXIMITY`) for inference. `stamps` and `cpu_stamps` hold the clocks at every sample, so a span's wall time can
be read off afterwards.
"""
from __future__ import annotations

import time as wallclock
from dataclasses import dataclass

import numpy as np
from mujoco_scene import MujocoScene, scene_xml

from bridge.odb import ObjectDatabase
from bridge.recording.telemetry import Telemetry
from bridge.sim.contacts import PROXIMITY
from bridge.sim.simulate import MOVED_ROTATION, MOVED_TRANSLATION, ReplayResult, sample_times
from bridge.values import Contact
from bridge.world import WorldState


@dataclass(frozen=True, eq=False)
class MujocoReplay:
    result: ReplayResult
    stamps: np.ndarray  # (T,) wall seconds since the start of stepping, at every sample
    cpu_stamps: np.ndarray  # (T,) CPU seconds likewise
    scene: MujocoScene


def replay(world: WorldState, telemetry: Telemetry, odb: ObjectDatabase, *, time_step: float = 0.002,
           settle: float = 0.5, sample_rate: float = 50.0) -> MujocoReplay:
    """Build the MuJoCo model of `world` and replay `telemetry` in it."""
    import mujoco

    scene = scene_xml(world, odb, time_step=time_step)
    model = mujoco.MjModel.from_xml_string(scene.xml)
    data = mujoco.MjData(model)
    columns = [telemetry.joint_names.index(j) for j in scene.actuated]
    qadr = np.array([model.jnt_qposadr[model.joint(j).id] for j in scene.actuated])
    data.qpos[qadr] = telemetry.sample(0.0)[columns]
    mujoco.mj_forward(model, data)

    end = telemetry.end + settle
    times = sample_times(end, sample_rate)
    steps = int(round(end / time_step))
    per_sample = int(round(1.0 / (sample_rate * time_step)))
    controls, desired = _controls(telemetry, columns, scene, steps, time_step)
    bodies = {name: model.body(name).id for name in scene.free}
    owner = np.array([scene.owners.get(model.geom(g).name, "world") for g in range(model.ngeom)], dtype=object)
    tracks = {name: np.zeros((len(times), 7)) for name in scene.free}
    log: list[Contact] = []
    stamps, cpu_stamps = np.zeros(len(times)), np.zeros(len(times))
    worst = 0.0
    started, cpu = wallclock.perf_counter(), wallclock.process_time()
    k = 0
    for step in range(steps + 1):
        if step % per_sample == 0 and k < len(times):
            t = step * time_step
            for name, b in bodies.items():
                tracks[name][k, :3] = data.xpos[b]
                tracks[name][k, 3:] = data.xquat[b]
            log.extend(_pairs(data, owner, t))
            if t <= telemetry.end:
                worst = max(worst, float(np.max(np.abs(data.qpos[qadr] - desired[step]))))
            stamps[k] = wallclock.perf_counter() - started
            cpu_stamps[k] = wallclock.process_time() - cpu
            k += 1
        if step < steps:
            data.ctrl[:] = controls[step]
            mujoco.mj_step(model, data)
    wall, cpu = wallclock.perf_counter() - started, wallclock.process_time() - cpu
    if k < len(times):  # `end` between two samples: the last one at the end
        times = times[:k]
        tracks = {n: v[:k] for n, v in tracks.items()}
        stamps, cpu_stamps = stamps[:k], cpu_stamps[:k]
    final = _final_contacts(mujoco, model, data, owner, float(times[-1]))
    moved = tuple(n for n in scene.free if _moved(tracks[n]))
    robot = scene.robot
    touched = tuple(sorted({c.other(robot) for c in log if c.involves(robot)
                            and not c.other(robot).startswith(robot + "/")} - {"world"}))
    result = ReplayResult(times, tracks, tuple(final), tuple(log), moved, touched, worst, float(times[-1]), wall, cpu,
                          robot, scene.actuated, None, None)
    return MujocoReplay(result, stamps, cpu_stamps, scene)


def _controls(telemetry: Telemetry, columns, scene: MujocoScene, steps: int, dt: float):
    """Per step: the actuators' controls q_d + (Kd / Kp) v_d and the desired positions, from the first-order hold
    of the telemetry at the step's start (held outside the recording: zero desired velocity)."""
    t = np.arange(steps + 1) * dt
    times, positions = telemetry.times, telemetry.positions[:, columns]
    q = np.column_stack([np.interp(t, times, positions[:, j]) for j in range(len(columns))])
    slopes = np.diff(positions, axis=0) / np.diff(times)[:, None]
    segment = np.clip(np.searchsorted(times, t, side="right") - 1, 0, len(times) - 2)
    v = slopes[segment]
    v[(t < times[0]) | (t >= times[-1])] = 0.0
    ratio = np.asarray(scene.kd) / np.asarray(scene.kp)
    return q + ratio * v, q


def _pairs(data, owner: np.ndarray, t: float) -> list[Contact]:
    """One contact per body pair touching at time t (forces are read only at the end)."""
    n = data.ncon
    if n == 0:
        return []
    geoms = np.column_stack([data.contact.geom1[:n], data.contact.geom2[:n]])
    touching = data.contact.dist[:n] <= 0.0
    names = {(owner[a], owner[b]) for (a, b), hit in zip(geoms, touching) if hit and owner[a] != owner[b]}
    return [Contact(a, b, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), t) for a, b in sorted(names)]


def _final_contacts(mujoco, model, data, owner: np.ndarray, t: float) -> list[Contact]:
    """Contacts with their world-frame forces (on body b by body a), and pairs closer than PROXIMITY."""
    found: dict[tuple[str, str], np.ndarray] = {}
    points: dict[tuple[str, str], np.ndarray] = {}
    wrench = np.zeros(6)
    for i in range(data.ncon):
        c = data.contact[i]
        a, b = owner[c.geom1], owner[c.geom2]
        if a == b or c.dist > 0.0:
            continue
        mujoco.mj_contactForce(model, data, i, wrench)
        force = c.frame.reshape(3, 3).T @ wrench[:3]  # on geom2 by geom1 (the frame's normal points 1 -> 2)
        found[(a, b)] = found.get((a, b), np.zeros(3)) + force
        points[(a, b)] = c.pos.copy()
    contacts = [Contact(a, b, tuple(f), tuple(points[(a, b)]), t) for (a, b), f in found.items()]
    seen = {frozenset(p) for p in found}
    for p in range(model.npair):
        g1, g2 = model.pair_geom1[p], model.pair_geom2[p]
        a, b = owner[g1], owner[g2]
        if a == b or frozenset((a, b)) in seen:
            continue
        if mujoco.mj_geomDistance(model, data, g1, g2, PROXIMITY, None) < PROXIMITY:
            contacts.append(Contact(a, b, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), t))
            seen.add(frozenset((a, b)))
    return contacts


def _moved(track: np.ndarray) -> bool:
    """bridge's rule (bridge.sim.simulate): more than 5 mm or 3 degrees from the start at any sample."""
    if np.max(np.linalg.norm(track[:, :3] - track[0, :3], axis=1)) > MOVED_TRANSLATION:
        return True
    dots = np.abs(track[:, 3:7] @ track[0, 3:7]) / (np.linalg.norm(track[:, 3:7], axis=1) * np.linalg.norm(track[0, 3:7]))
    return bool(2 * np.arccos(np.clip(np.min(dots), -1, 1)) > MOVED_ROTATION)

"""Locate the mismatch: per recording and object, where and when the simulated and observed poses part.

For each observed object of each recording (nominal model, i.e. the world model as it is):
- the residual split into along-push / across-push (push direction: the object's overall displacement, observed
  and simulated together), z, yaw and tilt;
- the noise floor, estimated from the data (`residuals.estimate_noise`: second differences of the observed
  track) and the level of the residual in its quiet part (before anything moves);
- the onset: the first time the smoothed, noise-normalised residual rises above 3 (noise floors) and stays
  there; a residual already there at rest (a tilted or misplaced object) has its onset at the first sample;
- the contact event just before the onset (from the replay's contact log: which bodies started touching);
- features an effect's signature reads (onset relative to the push, slide-on share, correlation with speed, ...);
- a ranking of objects and recordings by excess chi^2 (chi^2 minus its expected value under pure noise).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

from ..odb import ObjectDatabase
from ..odb.geometry import support
from ..rollout.compare import pose_error_arrays, sample_track
from ..values import Pose, rotation_to_quat
from .residuals import ObservedSeries
from .runs import Prepared, Run, Runner

ONSET_SIGMA = 3.0  # smoothed normalised residual (in noise-floor units) above which a deviation starts
ONSET_HOLD = 3  # samples it must stay above
SMOOTH = 3  # samples in the moving average
SIGNIFICANT = 2.0  # RMS of the normalised residual above which a (recording, object) carries a mismatch
QUIET_MOTION = 0.001  # m: before the object has moved this far (observed and simulated) the residual is "quiet"
TURN_LEVEL = math.radians(3.0)  # a simulated turn below this (or 5 noise floors of yaw) gives no turn ratio
JAM_RATIO = 2.5  # a recorded force this many times the simulated one and the push's typical force is a jam ...
JAM_HOLD = 3  # ... when it lasts this many samples (at the residual rate: 0.12 s at 25 Hz)
JAM_SURGE = 10.0  # ... or, whether the object moves or not, this many times: no coefficient error makes it. Real
#                  MIT pushes never hold (0.12 s) more than 1.5 times their median force; a frictions' error of
#                  x/3 moves it 3 times. An object squeezed past a post keeps moving at half its speed while the
#                  rod's force rises a hundredfold (MuJoCo worlds: 100-1000 N on a 1 N push), and read as moving,
#                  it never jammed.


@dataclass(frozen=True, eq=False)
class LocatedObject:
    recording: str
    object: str
    times: np.ndarray
    components: dict[str, np.ndarray]  # along, across (m), z (m), yaw, tilt (rad)
    sigma: dict[str, float]  # noise per component (m, rad), estimated from the observations
    measured: tuple[str, ...]
    direction: tuple[float, float]
    quiet_level: float | None  # RMS of the normalised residual in the quiet part (1 = noise)
    onset_s: float | None
    contact: tuple[str, str] | None
    contact_s: float | None
    push_s: tuple[float, float] | None  # first and last simulated robot contact with the object
    chi2: float
    n: int
    error: dict[str, float]  # the paper's e_t (m), e_R (rad), e (eq. 1-4)
    features: dict[str, Any]
    sim_xy: np.ndarray  # (n, 2) simulated path at the residual times
    obs_xy: np.ndarray

    @property
    def rms(self) -> float:
        """RMS of the noise-normalised residual (1 = at the noise floor)."""
        return math.sqrt(self.chi2 / self.n) if self.n else 0.0

    @property
    def excess(self) -> float:
        return self.chi2 - self.n

    @property
    def significant(self) -> bool:
        return bool(self.features.get("significant"))

    def to_json(self) -> dict[str, Any]:
        return {
            "recording": self.recording, "object": self.object,
            "onset_s": _round(self.onset_s, 3), "contact": list(self.contact) if self.contact else None,
            "contact_s": _round(self.contact_s, 3),
            "direction": [round(v, 4) for v in self.direction],
            "push_s": [round(v, 3) for v in self.push_s] if self.push_s else None,
            "noise": {k: float(f"{v:.3g}") for k, v in self.sigma.items()},
            "measured": list(self.measured),
            "quiet_level": _round(self.quiet_level, 3),
            "rms_sigma": round(self.rms, 3), "significant": self.significant,
            "error": {k: float(f"{v:.4g}") for k, v in self.error.items()},
            "peak": {k: float(f"{float(np.max(np.abs(v))):.4g}") for k, v in self.components.items()},
            "final": {k: float(f"{float(v[-1]):.4g}") for k, v in self.components.items()},
        }


@dataclass(frozen=True, eq=False)
class LocatedForce:
    """The robot's recorded force against the simulated one in one recording: how far off (noise floors) and by
    what factor (observed / simulated mean magnitude while it pushes: > 1, the object resists more than the model
    says, e.g. heavier or rougher)."""

    recording: str
    chi2: float
    n: int
    scale: float | None
    sigma: float  # N
    jam_s: float | None = None  # when the recorded force first jammed (`locate_force`), None if it never did

    @property
    def rms(self) -> float:
        return math.sqrt(self.chi2 / self.n) if self.n else 0.0

    @property
    def significant(self) -> bool:
        return self.rms > SIGNIFICANT

    def to_json(self) -> dict[str, Any]:
        return {"recording": self.recording, "rms_sigma": round(self.rms, 3), "significant": self.significant,
                "scale": _round(self.scale, 3), "noise_N": float(f"{self.sigma:.3g}"), "jam_s": _round(self.jam_s, 3)}


@dataclass(frozen=True, eq=False)
class Localisation:
    objects: tuple[LocatedObject, ...]
    runs: tuple[Run, ...] = field(default=())
    forces: tuple[LocatedForce, ...] = ()

    @property
    def any_significant(self) -> bool:
        return any(o.significant for o in self.objects) or any(f.significant for f in self.forces)

    def force_scale(self) -> float | None:
        """Median observed / simulated force over the recordings that recorded one."""
        scales = [f.scale for f in self.forces if f.scale is not None]
        return float(np.median(scales)) if scales else None

    def ranking(self) -> list[LocatedObject]:
        return sorted(self.objects, key=lambda o: -o.excess)

    def recordings_ranked(self) -> list[tuple[str, float]]:
        totals: dict[str, float] = {}
        for o in self.objects:
            totals[o.recording] = totals.get(o.recording, 0.0) + o.excess
        return sorted(totals.items(), key=lambda kv: -kv[1])

    def objects_ranked(self) -> list[tuple[str, float]]:
        totals: dict[str, float] = {}
        for o in self.objects:
            totals[o.object] = totals.get(o.object, 0.0) + o.excess
        return sorted(totals.items(), key=lambda kv: -kv[1])

    def to_json(self) -> list[dict[str, Any]]:
        return [o.to_json() for o in self.objects]

    def text(self) -> str:
        lines = ["recording / object                        rms/sigma  onset_s  contact before onset          direction"]
        for o in self.ranking():
            contact = " - ".join(o.contact) if o.contact else "-"
            onset = f"{o.onset_s:7.2f}" if o.onset_s is not None else "      -"
            lines.append(f"{(o.recording + ' / ' + o.object)[:42]:42s} {o.rms:9.1f} {onset}  {contact[:30]:30s} "
                         f"({o.direction[0]:+.2f}, {o.direction[1]:+.2f})")
        for f in self.forces:
            scale = f"{f.scale:.2f}x the simulated force" if f.scale is not None else "no push in both"
            lines.append(f"{(f.recording + ' / robot force')[:42]:42s} {f.rms:9.1f}          {scale}")
        lines.append("objects by excess chi^2: " + ", ".join(f"{n} {v:.3g}" for n, v in self.objects_ranked()))
        lines.append("recordings by excess chi^2: " + ", ".join(f"{n} {v:.3g}" for n, v in self.recordings_ranked()))
        return "\n".join(lines)


def _round(value, digits):
    return None if value is None else round(float(value), digits)


# --- the entry function -----------------------------------------------------------------------------------------
def locate(runner: Runner, indices: Sequence[int] | None = None, model=()) -> Localisation:
    """Replay every trial (or `indices`) with `model` (default: nothing added) and locate the mismatch."""
    indices = list(range(len(runner.prepared))) if indices is None else list(indices)
    runs = runner.run(tuple(model), indices, tracks=True, contacts=True)
    located, forces = [], []
    for i, run in zip(indices, runs):
        p = runner.prepared[i]
        if run.failed is not None:
            continue
        force = locate_force(p, run) if p.force is not None and run.force_residual is not None else None
        for s in p.series:
            located.append(locate_object(p, s, run, runner.odb, force.jam_s if force is not None else None))
        if force is not None:
            forces.append(force)
    return Localisation(tuple(located), tuple(runs), tuple(forces))


def locate_force(p: Prepared, run: Run) -> LocatedForce:
    """How far the recorded force is off, by what factor while both push, and when it jammed (`_jam`)."""
    obs = p.force
    m = obs.measured
    observed = np.linalg.norm(obs.force[:, m], axis=1)
    simulated = np.linalg.norm((obs.force - run.force_residual)[:, m], axis=1)
    floor = 5 * float(np.mean(obs.sigma[m]))
    pushing = (observed > floor) & (simulated > floor)
    scale = float(np.mean(observed[pushing]) / np.mean(simulated[pushing])) if pushing.sum() >= 3 else None
    return LocatedForce(p.name, run.force_chi2, run.force_n, scale, float(np.mean(obs.sigma[m])),
                        _jam(p, observed, simulated, floor))


def _jam(p: Prepared, observed: np.ndarray, simulated: np.ndarray, floor: float) -> float | None:
    """When the robot first jammed: its recorded force JAM_RATIO times what the model pushes with (the larger of
    the simulated force then and its median while pushing) while the real object stands still (slower than a
    fifth of its median speed while moving), or JAM_SURGE times whether it moves or not, for JAM_HOLD samples
    in a row. Something the model lacks holds the object back (an obstacle in its way): the recorded rod stops
    with it, so the poses hardly show it, the force does; an object that slides past the obstacle still moves,
    and its force shows it more. The start of a push (an impact, the object not yet moving) is no jam: the
    object must have moved before."""
    moving = simulated > floor
    if moving.sum() < 3 or not p.series:
        return None
    s = p.series[0]
    speed = np.linalg.norm(np.gradient(s.xyz[:, :2], s.times, axis=0), axis=1)
    speed = np.interp(p.force.times, s.times, speed)
    travelled = np.interp(p.force.times, s.times, np.linalg.norm(s.xyz[:, :2] - s.xyz[0, :2], axis=1))
    fast = speed > 0.2 * float(np.median(speed[moving])) if np.any(speed[moving] > 0) else np.zeros(len(speed), bool)
    push = float(np.median(simulated[moving]))
    reference = np.maximum(simulated, push)
    jammed = (((observed > JAM_RATIO * reference) & ~fast) | (observed > JAM_SURGE * reference)) & (travelled > 0.002)
    for k in range(len(jammed) - JAM_HOLD + 1):
        if jammed[k:k + JAM_HOLD].all():
            return float(p.force.times[k])
    return None


def locate_object(p: Prepared, s: ObservedSeries, run: Run, odb: ObjectDatabase,
                  jam_s: float | None = None) -> LocatedObject:
    r = run.residuals[s.object]
    sim_xyz, sim_R = sample_track(run.sim_times, run.tracks[s.object], s.times)
    d = _push_direction(s, sim_xyz)
    perp = np.array([-d[1], d[0]])
    comps = {"along": r[:, :2] @ d, "across": r[:, :2] @ perp, "z": r[:, 2], "yaw": r[:, 5],
             "tilt": np.hypot(r[:, 3], r[:, 4])}
    sig_xy = float(np.mean(s.sigma[:2]))
    sigma = {"along": sig_xy, "across": sig_xy, "z": float(s.sigma[2]), "yaw": float(s.sigma[5]),
             "tilt": float(np.mean(s.sigma[3:5]))}
    measured = tuple(k for k, m in (("along", s.measured[0] or s.measured[1]), ("across", s.measured[0] or s.measured[1]),
                                    ("z", s.measured[2]), ("yaw", s.measured[5]),
                                    ("tilt", s.measured[3] or s.measured[4])) if m)
    z2 = (r[:, s.measured] / s.tolerance[:, s.measured]) ** 2  # (n, m): where the model forks, its fork counts too
    chi_t = np.sqrt(np.mean(z2, axis=1)) if z2.size else np.zeros(len(s.times))
    chi2, n = float(z2.sum()), int(z2.size)

    moved_obs = np.linalg.norm(s.xyz - s.xyz[0], axis=1)
    moved_sim = np.linalg.norm(sim_xyz - sim_xyz[0], axis=1)
    quiet = (moved_obs < QUIET_MOTION) & (moved_sim < QUIET_MOTION)
    quiet_idx = np.nonzero(quiet)[0]
    quiet_idx = quiet_idx[quiet_idx == np.arange(len(quiet_idx))]  # the leading quiet stretch only
    quiet_level = float(np.sqrt(np.mean(chi_t[quiet_idx] ** 2))) if len(quiet_idx) >= 3 else None
    onset_i = _onset(chi_t, ONSET_SIGMA)
    onset = float(s.times[onset_i]) if onset_i is not None else None

    robot = p.world.robot.name if p.world.robot else None
    push = _push_interval(run, s.object, robot)
    contact, contact_s = _contact_before(run, s.object, onset)
    error = pose_error_arrays(s.xyz, s.R, sim_xyz, sim_R)
    features = _features(p, s, comps, sigma, measured, chi_t, chi2, n, onset_i, push, sim_xyz, sim_R, d, odb)
    if jam_s is not None:  # where the object was when the robot's force jammed, and how far it reached ahead
        k = int(np.clip(np.searchsorted(s.times, jam_s), 0, len(s.times) - 1))
        geometry = odb.get(p.world.objects[s.object].type).geometry
        pose = Pose(tuple(s.xyz[k]), rotation_to_quat(s.R[k]))
        features.update(jam_s=jam_s, jam_xy_obs=tuple(float(v) for v in s.xyz[k, :2]), jam_yaw_obs=pose.yaw(),
                        jam_reach=float(support(geometry, pose, np.array([d[0], d[1], 0.0])) - float(s.xyz[k, :2] @ d)))
        line = _jam_line(p, s.object, jam_s, s.xyz[k, :2])
        if line is not None:
            features.update(jam_rod_xy=line[0], jam_force_dir=line[1])
    return LocatedObject(p.name, s.object, s.times, comps, sigma, measured, (float(d[0]), float(d[1])), quiet_level,
                         onset, contact, contact_s, push, chi2, n,
                         {"e_t": error.e_t, "e_R": error.e_R, "e": error.e}, features, sim_xyz[:, :2], s.xyz[:, :2])


def _jam_line(p: Prepared, obj: str, jam_s: float, object_xy: np.ndarray) -> tuple[tuple, tuple] | None:
    """The line the jammed object is squeezed along: the recorded rod's centre and the direction of the recorded
    force into the object, over the JAM_HOLD samples from the jam (None without a planar pusher or a force). A
    force many times what sliding needs leaves the object two forces in balance, the rod's and the obstacle's,
    so they share a line: the obstacle touches the object where that line leaves it."""
    from .outline import rod_xy

    rod = rod_xy(p.trial, obj, np.array([jam_s]))
    if rod is None or p.force is None:
        return None
    k = int(np.searchsorted(p.force.times, jam_s))
    force = np.mean(p.force.force[k:k + JAM_HOLD, :2], axis=0)
    norm = float(np.linalg.norm(force))
    if not np.isfinite(norm) or norm == 0.0:
        return None
    u = force / norm
    if float(u @ (np.asarray(object_xy) - rod[0])) < 0.0:  # the sensor's sign: into the object
        u = -u
    return tuple(float(v) for v in rod[0]), tuple(float(v) for v in u)


def _push_direction(s: ObservedSeries, sim_xyz: np.ndarray) -> np.ndarray:
    total = (s.xyz[-1, :2] - s.xyz[0, :2]) + (sim_xyz[-1, :2] - sim_xyz[0, :2])
    norm = float(np.linalg.norm(total))
    return total / norm if norm > 1e-6 else np.array([1.0, 0.0])


def _onset(chi_t: np.ndarray, threshold: float) -> int | None:
    if len(chi_t) < SMOOTH:
        return 0 if len(chi_t) and float(np.max(chi_t)) > threshold else None
    smooth = np.convolve(chi_t, np.ones(SMOOTH) / SMOOTH, mode="same")
    above = smooth > threshold
    hold = min(ONSET_HOLD, len(above))
    for i in range(len(above) - hold + 1):
        if above[i:i + hold].all():
            # back up to where the raw residual first crossed half the threshold in this rise
            j = i
            while j > 0 and chi_t[j - 1] > 0.5 * threshold:
                j -= 1
            return j
    return None


def _push_interval(run: Run, obj: str, robot: str | None) -> tuple[float, float] | None:
    if robot is None:
        return None
    times = [c.time for c in run.contacts if c.involves(obj) and c.involves(robot)]
    return (min(times), max(times)) if times else None


def _contact_before(run: Run, obj: str, onset: float | None) -> tuple[tuple[str, str] | None, float | None]:
    """The contact pair involving `obj` that started last at or before the onset (its start time)."""
    if onset is None:
        return None, None
    times = sorted({c.time for c in run.contacts})
    if not times:
        return None, None
    step = min(np.diff(times)) if len(times) > 1 else 0.02
    last_seen: dict[tuple[str, str], float] = {}
    started: dict[tuple[str, str], float] = {}
    for c in sorted(run.contacts, key=lambda c: c.time):
        if c.time > onset + 1e-9 or not c.involves(obj):
            continue
        pair = tuple(sorted((c.body_a, c.body_b)))
        if pair not in last_seen or c.time - last_seen[pair] > 1.5 * step:
            started[pair] = c.time
        last_seen[pair] = c.time
    active = {p: t for p, t in started.items() if onset - last_seen[p] <= 3 * step + 1e-9}
    pool = active or started
    if not pool:
        return None, None
    pair = max(pool, key=lambda p: pool[p])
    return pair, float(pool[pair])


def _features(p, s, comps, sigma, measured, chi_t, chi2, n, onset_i, push, sim_xyz, sim_R, d, odb) -> dict:
    """What signatures read; all shares are fractions of the normalised residual."""
    f: dict[str, Any] = {"recording": p.name, "object": s.object, "direction": (float(d[0]), float(d[1]))}
    rms = math.sqrt(chi2 / n) if n else 0.0
    f["rms"] = rms
    f["significant"] = bool(rms > SIGNIFICANT and onset_i is not None)
    energy = {k: float(np.sum((comps[k] / sigma[k]) ** 2)) if k in measured else 0.0
              for k in ("along", "across", "z", "yaw", "tilt")}
    total = sum(energy.values()) or 1.0
    f.update({k: v / total for k, v in energy.items()})
    t = s.times
    if push is not None and onset_i is not None:
        span = max(push[1] - push[0], 1e-3)
        f["onset_rel"] = float((t[onset_i] - push[0]) / span)
    else:
        f["onset_rel"] = None
    pos = np.column_stack([comps["along"], comps["across"]]) / sigma["along"]
    mag = np.linalg.norm(pos, axis=1)
    if push is not None:
        k_end = int(np.clip(np.searchsorted(t, push[1]), 0, len(t) - 1))
        f["slide_share"] = float(max(0.0, mag[-1] - mag[k_end]) / (mag.max() or 1.0))
    else:
        f["slide_share"] = 0.0
    v = np.gradient(sim_xyz[:, :2], t, axis=0) @ d if len(t) > 2 else np.zeros(len(t))
    if np.std(v) > 0 and np.std(comps["along"]) > 0:
        f["speed_corr"] = float(abs(np.corrcoef(v, comps["along"])[0, 1]))
    else:
        f["speed_corr"] = 0.0
    # when the object starts to move, observed and simulated: a clock offset shifts one against the other
    level = max(QUIET_MOTION, 5.0 * float(np.mean(s.sigma[:2])))
    for key, xyz in (("moves_obs_s", s.xyz), ("moves_sim_s", sim_xyz)):
        f[key] = _crossing(t, np.linalg.norm(xyz[:, :2] - xyz[:3, :2].mean(axis=0), axis=1), level)
    # how much the object turned, observed / simulated (a pressure distribution or a wrong moment of the support
    # scales every turn alike; an off-centre mass turns one way or the other by which side is pushed)
    turns = [float(np.unwrap(np.arctan2(R[:, 1, 0], R[:, 0, 0]))[-1] - np.arctan2(R[0, 1, 0], R[0, 0, 0]))
             for R in (s.R, sim_R)]
    f["turn_ratio"] = turns[0] / turns[1] if abs(turns[1]) > max(TURN_LEVEL, 5.0 * sigma["yaw"]) else None
    # the planar poses (x, y, yaw) observed and simulated, where an obstacle's seed looks for a place the simulated
    # object went and the real one did not (`hidden_obstacle._swept_spots`)
    f["poses_obs"] = np.column_stack([s.xyz[:, :2], np.arctan2(s.R[:, 1, 0], s.R[:, 0, 0])])
    f["poses_sim"] = np.column_stack([sim_xyz[:, :2], np.arctan2(sim_R[:, 1, 0], sim_R[:, 0, 0])])
    f["final_along"] = float(comps["along"][-1] / sigma["along"])
    f["final_across"] = float(comps["across"][-1] / sigma["across"])
    peak = float(np.max(np.abs(comps["along"]))) or 1.0
    f["transient"] = float(1.0 - abs(comps["along"][-1]) / peak)
    world_res = np.column_stack([comps["along"] * d[0] - comps["across"] * d[1],
                                 comps["along"] * d[1] + comps["across"] * d[0]])
    tail = world_res[onset_i:] if onset_i is not None else world_res
    mean_dir = tail.mean(axis=0)
    f["world_dir"] = tuple(mean_dir / (np.linalg.norm(mean_dir) or 1.0))
    if onset_i is not None:
        obs_move = float(np.linalg.norm(s.xyz[-1, :2] - s.xyz[onset_i, :2]))
        sim_move = float(np.linalg.norm(sim_xyz[-1, :2] - sim_xyz[onset_i, :2]))
        f["stall"] = float(obs_move / sim_move) if sim_move > 1e-4 else 1.0
        f["onset_xy_obs"] = tuple(float(v) for v in s.xyz[onset_i, :2])
        f["onset_xy_sim"] = tuple(float(v) for v in sim_xyz[onset_i, :2])
        geometry = odb.get(p.world.objects[s.object].type).geometry
        pose = Pose(tuple(s.xyz[onset_i]), rotation_to_quat(s.R[onset_i]))
        f["onset_yaw_obs"] = pose.yaw()
        f["reach"] = float(support(geometry, pose, np.array([d[0], d[1], 0.0])) - float(np.dot(s.xyz[onset_i, :2], d)))
    return f


def _crossing(t: np.ndarray, d: np.ndarray, level: float) -> float | None:
    """The time `d` first crosses `level`, interpolated between samples (None if it never does)."""
    above = np.nonzero(d > level)[0]
    if not len(above):
        return None
    k = int(above[0])
    if k == 0:
        return float(t[0])
    w = (level - d[k - 1]) / max(d[k] - d[k - 1], 1e-12)
    return float(t[k - 1] + np.clip(w, 0.0, 1.0) * (t[k] - t[k - 1]))

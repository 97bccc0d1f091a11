"""Observed object poses: ground truth (AprilTags, motion capture) that the simulation is compared against.

Sparse observations hold each object's pose before and after the teleoperation; dense ones hold a track.
Times share the telemetry's clock: seconds since the first telemetry sample.
"""
from __future__ import annotations

import csv
import io
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Collection, Iterator

import numpy as np

from ..errors import RecordingError
from ..files import write_atomic
from ..values import Pose
from .telemetry import first_row, parse_number, read_text, skip_row

COLUMNS = ("t", "object", "x", "y", "z", "qw", "qx", "qy", "qz")
QUAT_TOLERANCE = 1e-3  # how far a quaternion's norm may be from 1 before it is an error rather than rounding


@dataclass(frozen=True, eq=False)
class ObservedTrack:
    """One object's observed poses at increasing `times` (s). Equality is identity (numpy times)."""

    object: str
    times: np.ndarray
    poses: tuple[Pose, ...]

    def __post_init__(self) -> None:
        if not isinstance(self.object, str) or not self.object.strip():
            raise RecordingError(f"an observed track needs an object name, got {self.object!r}")
        try:
            times = np.array(self.times, dtype=float)
        except (TypeError, ValueError):
            raise RecordingError(f"times must be numbers, got {self.times!r}", field=self.object) from None
        poses = tuple(self.poses)
        if times.ndim != 1 or times.size == 0 or times.size != len(poses):
            raise RecordingError(f"{times.size} times for {len(poses)} poses; a track needs one time per pose "
                                 f"and at least one pose", field=self.object)
        if not all(isinstance(p, Pose) for p in poses):
            raise RecordingError("poses must be bridge.values.Pose values", field=self.object)
        if not np.all(np.isfinite(times)) or np.any(np.diff(times) <= 0):
            raise RecordingError(f"times {times.tolist()} must be finite and strictly increasing", field=self.object)
        times.setflags(write=False)
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "poses", poses)

    def __len__(self) -> int:
        return len(self.poses)

    def initial(self) -> Pose:
        return self.poses[0]

    def final(self) -> Pose:
        return self.poses[-1]

    def at(self, t: float, *, nearest: bool = False) -> Pose:
        """The pose at `t` (s): the nearest sample, or position lerp + quaternion slerp between the two samples
        around `t`; held at the first / last pose outside the track."""
        if not math.isfinite(t):
            raise RecordingError(f"cannot look up an observed pose at time {t!r}", field=self.object)
        times = self.times
        if t <= times[0]:
            return self.poses[0]
        if t >= times[-1]:
            return self.poses[-1]
        i = int(np.searchsorted(times, t, side="right")) - 1
        w = (t - times[i]) / (times[i + 1] - times[i])
        if nearest:
            return self.poses[i + 1] if w > 0.5 else self.poses[i]
        a, b = self.poses[i], self.poses[i + 1]
        xyz = (1.0 - w) * a.position + w * b.position
        return Pose(tuple(xyz), slerp(a.quat, b.quat, w))  # type: ignore[arg-type]


@dataclass(frozen=True, eq=False)
class ObservedPoses:
    """The observed tracks of a recording, at most one per object, in file order."""

    tracks: tuple[ObservedTrack, ...]
    source: str = "<memory>"

    def __post_init__(self) -> None:
        tracks = tuple(self.tracks)
        names = [tr.object for tr in tracks if isinstance(tr, ObservedTrack)]
        if len(names) != len(tracks):
            raise RecordingError("observed poses are built from ObservedTrack values", source=self.source)
        if len(set(names)) != len(names):
            raise RecordingError(f"object {next(n for n in names if names.count(n) > 1)!r} has two tracks",
                                 source=self.source)
        object.__setattr__(self, "tracks", tracks)

    def __len__(self) -> int:
        return len(self.tracks)

    def __iter__(self) -> Iterator[ObservedTrack]:
        return iter(self.tracks)

    def __contains__(self, name: object) -> bool:
        return any(tr.object == name for tr in self.tracks)

    @property
    def objects(self) -> tuple[str, ...]:
        return tuple(tr.object for tr in self.tracks)

    @property
    def is_dense(self) -> bool:
        """True when every object has more than the two (before / after) samples of a sparse observation."""
        return bool(self.tracks) and all(len(tr) > 2 for tr in self.tracks)

    def get(self, name: str) -> ObservedTrack | None:
        return next((tr for tr in self.tracks if tr.object == name), None)

    def track(self, name: str) -> ObservedTrack:
        """The track of `name`, or an error listing the observed objects."""
        found = self.get(name)
        if found is None:
            raise RecordingError(f"object {name!r} was not observed; observed objects: "
                                 f"{', '.join(self.objects) or 'none'}", source=self.source)
        return found

    def initial(self) -> dict[str, Pose]:
        return {tr.object: tr.initial() for tr in self.tracks}

    def final(self) -> dict[str, Pose]:
        return {tr.object: tr.final() for tr in self.tracks}

    def at(self, t: float, *, nearest: bool = False) -> dict[str, Pose]:
        return {tr.object: tr.at(t, nearest=nearest) for tr in self.tracks}


def slerp(q0: tuple[float, ...], q1: tuple[float, ...], w: float) -> tuple[float, float, float, float]:
    """Spherical interpolation of unit quaternions (w, x, y, z) along the shorter arc, `w` in [0, 1]."""
    a, b = np.asarray(q0, dtype=float), np.asarray(q1, dtype=float)
    dot = float(a @ b)
    if dot < 0.0:
        b, dot = -b, -dot
    if dot > 0.9995:  # nearly equal: lerp avoids dividing by sin(theta) ~ 0
        q = a + w * (b - a)
    else:
        theta = math.acos(dot)
        q = (math.sin((1.0 - w) * theta) * a + math.sin(w * theta) * b) / math.sin(theta)
    q = q / np.linalg.norm(q)
    return tuple(float(v) for v in q)  # type: ignore[return-value]


def load_observations_csv(path: str | os.PathLike[str], known_objects: Collection[str] | None = None) -> ObservedPoses:
    """Read ``t,object,x,y,z,qw,qx,qy,qz`` rows (s, m, unit quaternion w first), sparse or dense, objects in any
    interleaving. `known_objects` (e.g. the world state's objects) turns a typo into an error."""
    src = str(path)
    reader = csv.reader(io.StringIO(read_text(Path(path), "observations")))
    header, header_line = first_row(reader)
    if header is None:
        raise RecordingError("observations file has no header line", source=src)
    column = _check_header(header, header_line, src)
    known = None if known_objects is None else set(known_objects)
    times: dict[str, list[float]] = {}
    poses: dict[str, list[Pose]] = {}
    last_line: dict[str, int] = {}
    for cells in reader:
        if skip_row(cells):
            continue
        line = reader.line_num
        if len(cells) != len(header):
            raise RecordingError(f"{len(cells)} values, but the header (line {header_line}) has {len(header)} "
                                 f"columns", source=src, field=f"line {line}")
        k = column["object"]
        name = cells[k].strip()
        where = f"line {line}, column {k + 1} ('object')"
        if not name:
            raise RecordingError("empty object name", source=src, field=where)
        if known is not None and name not in known:
            raise RecordingError(f"unknown object {name!r}; known objects: {', '.join(sorted(known)) or 'none'}",
                                 source=src, field=where)
        v = {c: parse_number(cells[column[c]], src, line, column[c], header[column[c]])
             for c in COLUMNS if c != "object"}
        if name in times and v["t"] <= times[name][-1]:
            problem = "repeats" if v["t"] == times[name][-1] else "is earlier than"
            raise RecordingError(f"time {v['t']:g} for {name!r} {problem} its time {times[name][-1]:g} on line "
                                 f"{last_line[name]}; each object's times must strictly increase", source=src,
                                 field=f"line {line}, column {column['t'] + 1} ({header[column['t']]!r})")
        quat = (v["qw"], v["qx"], v["qy"], v["qz"])
        norm = math.sqrt(sum(q * q for q in quat))
        if abs(norm - 1.0) > QUAT_TOLERANCE:
            raise RecordingError(f"quaternion (qw, qx, qy, qz) = {quat} has norm {norm:.6f}; it must be a unit "
                                 f"quaternion (norm within {QUAT_TOLERANCE} of 1)", source=src, field=f"line {line}")
        times.setdefault(name, []).append(v["t"])
        poses.setdefault(name, []).append(Pose((v["x"], v["y"], v["z"]), quat))  # Pose normalises the rest
        last_line[name] = line
    if not times:
        raise RecordingError("no observation rows after the header", source=src)
    return ObservedPoses(tuple(ObservedTrack(n, np.array(times[n]), tuple(poses[n])) for n in times), source=src)


def save_observations_csv(path: str | os.PathLike[str], observed: ObservedPoses) -> None:
    """Write `observed` as CSV (atomically), one object's rows after another, shortest exact decimals."""
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(COLUMNS)
    for track in observed.tracks:
        for t, pose in zip(track.times.tolist(), track.poses):
            writer.writerow([repr(t), track.object, *map(repr, pose.xyz), *map(repr, pose.quat)])
    write_atomic(path, buffer.getvalue(), RecordingError)


def _check_header(header: list[str], line: int, src: str) -> dict[str, int]:
    """Column index by canonical name; columns may come in any order, 'time' may stand for 't'."""
    expected = ", ".join(COLUMNS)
    column: dict[str, int] = {}
    for k, raw in enumerate(header):
        name = "t" if raw.lower() == "time" else raw.lower()
        where = f"line {line}, column {k + 1}"
        if name not in COLUMNS:
            raise RecordingError(f"unknown column {raw!r}; the header must name {expected}", source=src, field=where)
        if name in column:
            raise RecordingError(f"column {raw!r} repeats column {column[name] + 1}", source=src, field=where)
        column[name] = k
    missing = [c for c in COLUMNS if c not in column]
    if missing:
        raise RecordingError(f"missing column {', '.join(map(repr, missing))}; the header must name {expected} "
                             f"(quaternion w first)", source=src, field=f"line {line}")
    return column

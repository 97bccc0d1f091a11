"""Recorded joint telemetry: the robot's joint positions over time, read from CSV files or ROS bags.

The simulation replays these positions as they are, so every check happens here, once, with a message naming
the file, the line (or bag message) and the column (or joint); inside bridge a `Telemetry` is trusted.
"""
from __future__ import annotations

import csv
import io
import math
import os
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Mapping, NamedTuple, Sequence

import numpy as np

from ..errors import RecordingError
from ..files import read_text_file, write_atomic
from ..odb.ranges import joint_problem

TIME_COLUMNS = ("t", "time")
JOINT_STATE = "sensor_msgs/msg/JointState"
FORMATS = ".csv, a ROS 2 bag folder (with metadata.yaml), .mcap, .db3 or a ROS 1 .bag"


@dataclass(frozen=True, eq=False)
class Telemetry:
    """Joint positions (rad; m for prismatic joints) of the named joints, one row per sample time (s).

    Loaders start `times` at 0.0 and keep the recorded clock reading of that instant in `t0` (for a bag, Unix
    seconds), so ``t0 + times`` is the original clock. Arrays are read-only copies; equality is identity.
    """

    times: np.ndarray
    joint_names: tuple[str, ...]
    positions: np.ndarray
    source: str = "<memory>"
    t0: float = 0.0

    def __post_init__(self) -> None:
        fail = lambda message: RecordingError(message, source=self.source)  # noqa: E731
        try:
            times, positions = _read_only(self.times), _read_only(self.positions)
        except (TypeError, ValueError) as err:
            raise fail(f"telemetry times and positions must be numbers: {err}") from None
        names = tuple(self.joint_names)
        if times.ndim != 1 or times.size == 0:
            raise fail(f"telemetry times must be a non-empty 1-D array, got shape {times.shape}")
        if not names:
            raise fail("telemetry names no joints")
        for name in names:
            if not isinstance(name, str) or not name or name != name.strip():
                raise fail(f"joint name {name!r} must be a non-empty string without surrounding spaces")
        if len(set(names)) != len(names):
            raise fail(f"joint {next(n for n in names if names.count(n) > 1)!r} appears twice")
        if positions.shape != (times.size, len(names)):
            raise fail(f"positions have shape {positions.shape}, expected {(times.size, len(names))} (samples, joints)")
        if not (np.all(np.isfinite(times)) and np.all(np.isfinite(positions)) and math.isfinite(self.t0)):
            raise fail("telemetry contains NaN or infinite values")
        if times.size > 1 and np.any(np.diff(times) <= 0):
            k = int(np.argmax(np.diff(times) <= 0)) + 1
            raise fail(f"sample {k}: time {times[k]} does not come after {times[k - 1]}; times must increase")
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "positions", positions)
        object.__setattr__(self, "joint_names", names)
        object.__setattr__(self, "t0", float(self.t0))

    def __len__(self) -> int:
        return int(self.times.size)

    def __repr__(self) -> str:
        return (f"Telemetry({len(self)} samples, {self.duration:.3f} s, joints={list(self.joint_names)}, "
                f"source={self.source!r})")

    @property
    def start(self) -> float:
        return float(self.times[0])

    @property
    def end(self) -> float:
        return float(self.times[-1])

    @property
    def duration(self) -> float:
        return float(self.times[-1] - self.times[0])

    def sample(self, t: float | np.ndarray) -> np.ndarray:
        """Positions at time `t` (s): (J,) for a scalar, (M, J) for M times. Linear between samples, held
        at the first / last sample outside the recording (the robot is assumed still before and after)."""
        tq = np.asarray(t, dtype=float)
        if not np.all(np.isfinite(tq)):
            raise RecordingError(f"cannot sample telemetry at time {t!r}", source=self.source)
        if self.times.size == 1:
            return np.broadcast_to(self.positions[0], (*tq.shape, len(self.joint_names))).copy()
        tc = np.clip(tq, self.times[0], self.times[-1])
        i = np.clip(np.searchsorted(self.times, tc, side="right") - 1, 0, self.times.size - 2)
        w = ((tc - self.times[i]) / (self.times[i + 1] - self.times[i]))[..., None]
        return (1.0 - w) * self.positions[i] + w * self.positions[i + 1]

    def select(self, joint_names: Sequence[str]) -> "Telemetry":
        """The same telemetry with only `joint_names`, in that order (e.g. the simulated robot's order)."""
        names = tuple(joint_names)
        missing = [n for n in names if n not in self.joint_names]
        if missing:
            raise RecordingError(f"telemetry has no joint {_names(missing)}; it has {_names(self.joint_names)}",
                                 source=self.source)
        index = [self.joint_names.index(n) for n in names]
        return replace(self, joint_names=names, positions=self.positions[:, index])

    def shifted(self, dt: float) -> "Telemetry":
        """Every sample `dt` seconds later (dt > 0 models a command latency): ``shifted(dt).sample(t + dt)``
        equals ``sample(t)``."""
        if not math.isfinite(dt):
            raise RecordingError(f"cannot shift telemetry by {dt!r} s", source=self.source)
        return replace(self, times=self.times + float(dt))

    def with_offsets(self, offsets: Mapping[str, float]) -> "Telemetry":
        """Joint positions plus a constant per-joint offset (calibration error, rad or m)."""
        unknown = [n for n in offsets if n not in self.joint_names]
        if unknown:
            raise RecordingError(f"offset for unknown joint {_names(unknown)}; telemetry joints are "
                                 f"{_names(self.joint_names)}", source=self.source)
        delta = np.array([float(offsets.get(n, 0.0)) for n in self.joint_names])
        return replace(self, positions=self.positions + delta)


def validate_telemetry(tel: Telemetry, robot_joints: Sequence[str], *, required: Sequence[str] | None = None,
                       limits: Mapping[str, tuple[float, float]] | None = None, model: str = "the robot model") -> None:
    """Check that `tel` can drive a robot with `robot_joints`: it names no joint the robot lacks, lacks none
    of `required` (default: every robot joint) and, given the model's joint `limits`, never leaves them (a
    recording in degrees, or of another robot, would otherwise be replayed as it is)."""
    robot = tuple(robot_joints)
    unknown = [n for n in tel.joint_names if n not in robot]
    if unknown:
        raise RecordingError(f"telemetry joint {_names(unknown)} is not a joint of the robot; the robot's joints "
                             f"are {_names(robot)}", source=tel.source, field=f"joint {unknown[0]!r}")
    missing = [n for n in (robot if required is None else tuple(required)) if n not in tel.joint_names]
    if missing:
        raise RecordingError(f"telemetry lacks joint {_names(missing)} that the robot needs; it has "
                             f"{_names(tel.joint_names)}", source=tel.source, field=f"joint {missing[0]!r}")
    for k, name in enumerate(tel.joint_names):
        if limits is None or name not in limits:
            continue
        column = tel.positions[:, k]
        worst = int(np.argmax(np.abs(column - np.clip(column, *limits[name]))))
        problem = joint_problem(float(column[worst]), limits[name], name, model)
        if problem:
            raise RecordingError(problem, source=tel.source, field=f"sample {worst + 1} (t = {tel.times[worst]:g} s)")


def load_telemetry(path: str | os.PathLike[str], *, topic: str | None = None) -> Telemetry:
    """Read telemetry in any supported format, chosen by suffix (folders are ROS 2 bags)."""
    path = Path(path)
    if path.is_dir() or path.suffix.lower() in (".mcap", ".db3", ".bag"):
        return load_telemetry_rosbag(path, topic)
    if path.suffix.lower() == ".csv":
        return load_telemetry_csv(path)
    if not path.exists():
        raise RecordingError("telemetry file not found", source=str(path))
    raise RecordingError(f"unknown telemetry format {path.suffix or '(no suffix)'!r}; expected {FORMATS}",
                         source=str(path))


# --- CSV ------------------------------------------------------------------------------------------------------
def load_telemetry_csv(path: str | os.PathLike[str]) -> Telemetry:
    """Read ``t,<joint>,...`` rows (time in s, positions in rad or m). Blank lines and ``#`` lines are skipped."""
    src = str(path)
    reader = csv.reader(io.StringIO(read_text(Path(path), "telemetry")))
    header, header_line = first_row(reader)
    if header is None:
        raise RecordingError("telemetry file has no header line", source=src)
    _check_header(header, header_line, src)
    times: list[float] = []
    rows: list[list[float]] = []
    lines: list[int] = []
    for cells in reader:
        if skip_row(cells):
            continue
        line = reader.line_num
        if len(cells) != len(header):
            raise RecordingError(f"{len(cells)} values, but the header (line {header_line}) has {len(header)} "
                                 f"columns", source=src, field=f"line {line}")
        values = [parse_number(cell, src, line, k, name) for k, (name, cell) in enumerate(zip(header, cells))]
        t = values[0]
        if times and t <= times[-1]:
            problem = "repeats" if t == times[-1] else "is earlier than"
            raise RecordingError(f"time {t:g} {problem} time {times[-1]:g} on line {lines[-1]}; times must "
                                 f"strictly increase", source=src, field=f"line {line}, column 1 ({header[0]!r})")
        times.append(t)
        rows.append(values[1:])
        lines.append(line)
    if len(times) < 2:
        raise RecordingError(f"{len(times)} sample row(s) after the header; telemetry needs at least 2", source=src)
    t0 = times[0]
    return Telemetry(np.array(times) - t0, tuple(header[1:]), np.array(rows), source=src, t0=t0)


def save_telemetry_csv(path: str | os.PathLike[str], tel: Telemetry) -> None:
    """Write `tel` as CSV (atomically). Times are written as they are (not ``t0 + times``), shortest exact
    decimals, so loading gives back the same numbers when the first time is 0."""
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(("t", *tel.joint_names))
    for t, row in zip(tel.times.tolist(), tel.positions.tolist()):
        writer.writerow([repr(t), *map(repr, row)])
    write_atomic(path, buffer.getvalue(), RecordingError)


def _check_header(header: list[str], line: int, src: str) -> None:
    if header[0].lower() not in TIME_COLUMNS:
        raise RecordingError(f"the first column must be the time in seconds, named 't' or 'time'; got "
                             f"{header[0]!r}", source=src, field=f"line {line}, column 1")
    if len(header) < 2:
        raise RecordingError("no joint columns after the time column", source=src, field=f"line {line}")
    seen: dict[str, int] = {}
    for k, name in enumerate(header, start=1):
        if not name:
            raise RecordingError("column has no name", source=src, field=f"line {line}, column {k}")
        if name in seen:
            raise RecordingError(f"column name {name!r} repeats column {seen[name]}", source=src,
                                 field=f"line {line}, column {k}")
        seen[name] = k


def parse_number(cell: str, src: str, line: int, k: int, column: str) -> float:
    """One finite number from a CSV cell; the error names file, line and column (`k` counts from 0)."""
    text = cell.strip()
    where = f"line {line}, column {k + 1} ({column!r})"
    if not text:
        raise RecordingError("empty value", source=src, field=where)
    try:
        value = float(text)
    except ValueError:
        raise RecordingError(f"{text!r} is not a number", source=src, field=where) from None
    if not math.isfinite(value):
        raise RecordingError(f"value {text!r} is not finite (NaN and infinity are not allowed)", source=src,
                             field=where)
    return value


def skip_row(cells: list[str]) -> bool:
    """Blank CSV lines and ``#`` comment lines carry no data."""
    return not any(c.strip() for c in cells) or cells[0].lstrip().startswith("#")


def first_row(reader: Any) -> tuple[list[str] | None, int]:
    """The first data line of a `csv.reader` (stripped cells) and its line number, or (None, 0)."""
    for cells in reader:
        if not skip_row(cells):
            return [c.strip() for c in cells], reader.line_num
    return None, 0


# --- ROS bags -------------------------------------------------------------------------------------------------
class _JointState(NamedTuple):
    log_ns: int
    stamp_ns: int
    names: tuple[str, ...]
    position: np.ndarray


def load_telemetry_rosbag(path: str | os.PathLike[str], topic: str | None = None) -> Telemetry:
    """Read ``sensor_msgs/msg/JointState`` messages from a ROS 2 bag (folder, or bare .mcap / .db3) or a ROS 1
    .bag, without ROS. Times are header stamps, or log times when no message is stamped."""
    path = Path(path)
    src = str(path)
    chosen, messages = _read_joint_states(path, topic)
    field = f"topic {chosen!r}"
    if len(messages) < 2:
        raise RecordingError(f"{len(messages)} JointState message(s); telemetry needs at least 2", source=src,
                             field=field)
    stamped = [m.stamp_ns != 0 for m in messages]
    if any(stamped) and not all(stamped):
        raise RecordingError(f"message {stamped.index(False) + 1} has no header stamp but message "
                             f"{stamped.index(True) + 1} has one; header stamps and log times cannot be mixed",
                             source=src, field=field)
    names = messages[0].names
    if not names or len(set(names)) != len(names):
        raise RecordingError(f"message 1 carries joint names {list(names)}; they must be present and unique",
                             source=src, field=field)
    times_ns, rows = [], []
    for i, m in enumerate(messages, start=1):
        where = f"{field}, message {i}"
        if len(m.names) != len(names) or set(m.names) != set(names):
            raise RecordingError(f"message carries joints {list(m.names)} but message 1 carries {list(names)}; "
                                 f"every message must carry the same joints", source=src, field=where)
        if m.position.shape != (len(names),):
            raise RecordingError(f"message has {len(names)} joint names but {m.position.size} positions",
                                 source=src, field=where)
        row = m.position[[m.names.index(n) for n in names]]
        if not np.all(np.isfinite(row)):
            bad = names[int(np.argmin(np.isfinite(row)))]
            raise RecordingError(f"joint {bad!r} position is not finite", source=src, field=where)
        times_ns.append(m.stamp_ns if all(stamped) else m.log_ns)
        rows.append(row)
    order = sorted(range(len(times_ns)), key=times_ns.__getitem__)  # stamps may arrive out of log order
    for a, b in zip(order, order[1:]):
        if times_ns[a] == times_ns[b]:
            raise RecordingError(f"messages {a + 1} and {b + 1} have the same time ({times_ns[a]} ns)", source=src,
                                 field=field)
    stamps = np.array([times_ns[k] for k in order], dtype=np.int64)
    return Telemetry((stamps - stamps[0]) / 1e9, names, np.array([rows[k] for k in order]), source=src,
                     t0=int(stamps[0]) / 1e9)


def _read_joint_states(path: Path, topic: str | None) -> tuple[str, list[_JointState]]:
    """The chosen topic and its messages in log order; every failure of the bag reader becomes a RecordingError."""
    src = str(path)
    if not path.exists():
        raise RecordingError("ROS bag not found", source=src)
    if path.is_dir() and not (path / "metadata.yaml").is_file():
        raise RecordingError("folder is not a ROS 2 bag: it has no metadata.yaml", source=src)
    if not path.is_dir() and path.suffix.lower() not in (".mcap", ".db3", ".bag"):
        raise RecordingError("not a ROS bag; expected a ROS 2 bag folder, .mcap, .db3 or .bag", source=src)
    try:
        from rosbags.highlevel import AnyReader
        from rosbags.typesys import Stores, get_typestore
    except ImportError:  # pragma: no cover - rosbags is a dependency
        raise RecordingError("reading ROS bags needs the 'rosbags' package", source=src) from None
    ros1 = not path.is_dir() and path.suffix.lower() == ".bag"
    default = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)  # for bags without definitions
    try:
        with AnyReader([path], default_typestore=default) as reader:
            chosen = _choose_topic({c.topic: c.msgtype for c in reader.connections}, topic, src)
            messages = []
            for conn, log_ns, raw in reader.messages([c for c in reader.connections if c.topic == chosen]):
                msg: Any = reader.deserialize(raw, conn.msgtype)
                stamp = msg.header.stamp
                messages.append(_JointState(int(log_ns), int(stamp.sec) * 10**9 + int(stamp.nanosec),
                                            tuple(msg.name), np.asarray(msg.position, dtype=float)))
    except RecordingError:
        raise
    except Exception as err:  # rosbags raises many types on broken bags (reader, sqlite, struct, serde errors)
        raise RecordingError(f"cannot read ROS bag: {err}", source=src) from err
    return chosen, messages


def _choose_topic(types: Mapping[str, str], topic: str | None, src: str) -> str:
    joint_topics = sorted(t for t, msgtype in types.items() if msgtype == JOINT_STATE)
    listing = ", ".join(f"{t!r} ({types[t]})" for t in sorted(types)) or "no topics"
    if topic is not None:
        if types.get(topic) == JOINT_STATE:
            return topic
        problem = f"topic {topic!r} carries {types[topic]}" if topic in types else f"no topic {topic!r}"
        raise RecordingError(f"{problem}; {JOINT_STATE} topics in the bag: {_names(joint_topics) or 'none'}",
                             source=src, field="topic")
    if not joint_topics:
        raise RecordingError(f"no {JOINT_STATE} topic; the bag has {listing}", source=src)
    if len(joint_topics) > 1:
        raise RecordingError(f"several {JOINT_STATE} topics: {_names(joint_topics)}; choose one (topic=..., or "
                             f"'telemetry_topic' in recording.yaml)", source=src)
    return joint_topics[0]


# --- files (shared with the other recording modules) ----------------------------------------------------------
def read_text(path: Path, what: str) -> str:
    """The text of a UTF-8 file, or a RecordingError saying why it cannot be read (a byte that is not UTF-8: its
    offset) or is empty."""
    text = read_text_file(path, f"{what} file", RecordingError)
    if not text.strip():
        raise RecordingError(f"{what} file is empty", source=str(path))
    return text


def _read_only(values: Any) -> np.ndarray:
    array = np.array(values, dtype=float)
    array.setflags(write=False)
    return array


def _names(names: Sequence[str]) -> str:
    return ", ".join(repr(n) for n in names)

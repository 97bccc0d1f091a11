"""Observed contact force on the robot (a wrist or rod force-torque sensor), the channel that tells mass from
friction: in a quasi-static push the object's path barely depends on either, the force scales with both.

`force.csv` in a recording folder: ``t,fx,fy,fz`` (s, N; world frame; the force the objects exert on the
robot, i.e. opposing the push, as the planar pushing dataset records it). Times share the telemetry's clock.
A column that is constant to the last digit (fz of a planar sensor) is taken as not measured.
"""
from __future__ import annotations

import csv
import io
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import RecordingError
from ..files import write_atomic
from .telemetry import first_row, parse_number, read_text, skip_row

COLUMNS = ("t", "fx", "fy", "fz")


@dataclass(frozen=True, eq=False)
class ObservedForce:
    """The force on the robot from everything it touches, (n, 3) N in the world frame, at increasing `times`."""

    times: np.ndarray
    force: np.ndarray
    source: str = ""

    def __post_init__(self) -> None:
        times = np.array(self.times, dtype=float)
        force = np.array(self.force, dtype=float)
        where = self.source or None
        if times.ndim != 1 or times.size < 2 or force.shape != (times.size, 3):
            raise RecordingError(f"a force track needs n >= 2 times and (n, 3) forces, got {times.shape} and "
                                 f"{force.shape}", source=where)
        if not (np.all(np.isfinite(times)) and np.all(np.isfinite(force))):
            raise RecordingError("force track holds NaN or infinite values", source=where)
        if np.any(np.diff(times) <= 0):
            k = int(np.argmax(np.diff(times) <= 0)) + 1
            raise RecordingError(f"force times must strictly increase (sample {k}: {times[k]:g} after "
                                 f"{times[k - 1]:g})", source=where)
        times.setflags(write=False)
        force.setflags(write=False)
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "force", force)

    @property
    def measured(self) -> np.ndarray:
        """(3,) bool: the component varies, so the sensor measures it."""
        return np.ptp(self.force, axis=0) > 1e-12


def load_force_csv(path: str | os.PathLike[str]) -> ObservedForce:
    src = str(path)
    reader = csv.reader(io.StringIO(read_text(Path(path), "force")))
    header, header_line = first_row(reader)
    if header is None:
        raise RecordingError("force file has no header line", source=src)
    names = ["t" if h.strip().lower() == "time" else h.strip().lower() for h in header]
    if sorted(names) != sorted(COLUMNS):
        raise RecordingError(f"header {header} must name the columns {', '.join(COLUMNS)}", source=src,
                             field=f"line {header_line}")
    column = {n: k for k, n in enumerate(names)}
    rows = []
    for cells in reader:
        if skip_row(cells):
            continue
        line = reader.line_num
        if len(cells) != len(header):
            raise RecordingError(f"{len(cells)} values, but the header has {len(header)} columns", source=src,
                                 field=f"line {line}")
        rows.append([parse_number(cells[column[c]], src, line, column[c], c) for c in COLUMNS])
    if len(rows) < 2:
        raise RecordingError("a force file needs at least two rows", source=src)
    data = np.array(rows)
    return ObservedForce(data[:, 0], data[:, 1:], source=src)


def save_force_csv(path: str | os.PathLike[str], observed: ObservedForce) -> None:
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(COLUMNS)
    for t, f in zip(observed.times.tolist(), observed.force.tolist()):
        writer.writerow([repr(t), *map(repr, f)])
    write_atomic(path, buffer.getvalue(), RecordingError)

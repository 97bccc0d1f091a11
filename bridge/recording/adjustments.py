"""What a loader changed in a recording on the way to a replayable session, kept as data, not only as words.

A loader has to repair some recordings before they can be replayed (a rod that starts inside the object would
kick it at t = 0; clock jitter makes timestamps step back; the object's pose frame is not its mesh frame). Each
repair is also an observation: a rod that starts millimetres inside the object is evidence of a pusher
calibration offset or a wrong object model, and the diagnosis reads it (`bridge.diagnosis.loader`). So every
repair is one small frozen record here, with the numbers it undid, and its `text()` is the note a user reads.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar, Union


@dataclass(frozen=True)
class StartClearance:
    """The rod's gap to the object's outline at t = 0 as recorded (negative: inside), and what the loader did.

    `shift` (m, world x y) was added to every tip sample to start the rod `target` clear of the outline (zero
    when it started clear); `joints` names the robot joints the shift went to (x, y order). `normal` is the
    outline's outward normal at the nearest point (world frame); `lever` (m) the distance from the object's
    centre to the rod's centre at t = 0 (a yaw error of the pose moves the outline there by lever x yaw);
    `contact_spread` (m) the scatter (1.4826 MAD) of the same gap while the rod pushes the object, where it
    should be zero: what the outline's mismatch with the real object and the motion capture explain;
    `contact_gap` (m) its median, which should be zero too (a rod that pushes from millimetres away is not
    where the recording says: a calibration offset moves it by -D.n, an outline too small or large by its
    error), and `contact_normal` the outline's mean outward normal there (world frame); `contact_speed` (m/s) the
    rod's median speed into the object there (along -`contact_normal`): a recorded rod that leads or lags the real
    one by a latency tau sits tau x that speed inside or outside the outline."""

    kind: ClassVar[str] = "start_clearance"
    object: str
    clearance: float
    normal: tuple[float, float]
    shift: tuple[float, float]
    target: float
    lever: float
    contact_spread: float | None = None
    joints: tuple[str, str] = ("pusher_x", "pusher_y")
    contact_gap: float | None = None
    contact_normal: tuple[float, float] | None = None
    contact_speed: float | None = None

    @property
    def penetration(self) -> float:
        """How deep (m) the recorded rod started inside the outline (0 when it started clear)."""
        return max(0.0, -self.clearance)

    @property
    def moved(self) -> bool:
        return self.shift != (0.0, 0.0)

    def text(self) -> str:
        sx, sy = self.shift
        if not self.moved:
            return f"the rod started {self.clearance * 1e3:.2f} mm clear of {self.object}'s outline"
        return (f"the rod started {self.penetration * 1e3:.2f} mm inside the outline: the whole tip track was moved "
                f"{math.hypot(sx, sy) * 1e3:.2f} mm along the outline's normal (x {sx * 1e3:+.2f} mm, "
                f"y {sy * 1e3:+.2f} mm) to start {self.target * 1e3:.1f} mm clear")

    def to_json(self) -> dict[str, Any]:
        return {"kind": self.kind, "object": self.object, "clearance_m": _g(self.clearance),
                "penetration_m": _g(self.penetration), "shift_m": [_g(v) for v in self.shift],
                "normal": [_g(v) for v in self.normal], "lever_m": _g(self.lever),
                "contact_spread_m": None if self.contact_spread is None else _g(self.contact_spread),
                "contact_gap_m": None if self.contact_gap is None else _g(self.contact_gap),
                "contact_normal": None if self.contact_normal is None else [_g(v) for v in self.contact_normal],
                "contact_speed_m_s": None if self.contact_speed is None else _g(self.contact_speed),
                "joints": list(self.joints)}


@dataclass(frozen=True)
class FrameYaw:
    """The object's mesh frame turned by `yaw` (rad) from the recorded pose frame; `estimated` from the pushes
    of the shape (`estimate_frame_yaw`) or given by the caller."""

    kind: ClassVar[str] = "frame_yaw"
    object: str
    yaw: float
    estimated: bool = True

    def text(self) -> str:
        how = "estimated from the pushes" if self.estimated else "as given"
        return f"{self.object}: mesh frame turned {math.degrees(self.yaw):+.0f} deg from the pose frame ({how})"

    def to_json(self) -> dict[str, Any]:
        return {"kind": self.kind, "object": self.object, "yaw_rad": _g(self.yaw), "estimated": self.estimated}


@dataclass(frozen=True)
class DroppedRows:
    """Rows of a stream dropped because their timestamp stepped back (clock jitter); `detail` names each."""

    kind: ClassVar[str] = "dropped_rows"
    stream: str
    count: int
    detail: tuple[str, ...] = ()

    def text(self) -> str:
        return f"{self.count} {self.stream} row(s) dropped for clock jitter (see load_push)"

    def to_json(self) -> dict[str, Any]:
        return {"kind": self.kind, "stream": self.stream, "count": self.count, "detail": list(self.detail)}


Adjustment = Union[StartClearance, FrameYaw, DroppedRows]


def dropped_rows(repairs: tuple[str, ...]) -> tuple[DroppedRows, ...]:
    """`PushRecording.repairs` ("stream: dropped row ...") grouped per stream."""
    by: dict[str, list[str]] = {}
    for line in repairs:
        by.setdefault(line.split(":", 1)[0], []).append(line)
    return tuple(DroppedRows(stream, len(lines), tuple(lines)) for stream, lines in by.items())


def _g(value: float) -> float:
    return float(f"{value:.4g}")

"""Value types shared by every layer: facts, poses and contacts.

They carry no Drake and no YAML, so the planning side can be used (and tested) without a simulator.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Iterable, Sequence

import numpy as np

from .errors import BridgeError

GRAVITY = 9.81  # m/s^2: Drake's MultibodyPlant default, which no scene changes

_IDENT = re.compile(r"^[A-Za-z][A-Za-z0-9_\-]*$")


def is_identifier(name: str) -> bool:
    """True when `name` can stand in PDDL as it is."""
    return bool(_IDENT.match(name))


@dataclass(frozen=True, order=True)
class Fact:
    """A ground atom, e.g. ``Fact("on", ("box_1", "table"))``, printed ``(on box_1 table)``."""

    predicate: str
    args: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if not isinstance(self.predicate, str) or not self.predicate:
            raise BridgeError(f"a fact needs a predicate name, got {self.predicate!r}")
        if not isinstance(self.args, tuple) or not all(isinstance(a, str) and a for a in self.args):
            raise BridgeError(f"fact {self.predicate}: arguments must be a tuple of names, got {self.args!r}")

    def __str__(self) -> str:
        return "(" + " ".join((self.predicate, *self.args)) + ")"

    @classmethod
    def of(cls, predicate: str, *args: str) -> "Fact":
        return cls(predicate, tuple(args))

    @classmethod
    def parse(cls, text: str) -> "Fact":
        """Read ``(on box_1 table)``; the parentheses may be left out."""
        if not isinstance(text, str):
            raise BridgeError(f"a fact must be written as text like '(on box table)', got {text!r}")
        body = text.strip()
        if body.startswith("(") and body.endswith(")"):
            body = body[1:-1]
        if "(" in body or ")" in body:
            raise BridgeError(f"fact {text!r}: nested parentheses; write one atom like '(on box table)'")
        words = body.split()
        if not words:
            raise BridgeError(f"fact {text!r} is empty")
        return cls(words[0], tuple(words[1:]))


def _unit_quat(quat: Sequence[float], what: str) -> tuple[float, float, float, float]:
    q = np.asarray(quat, dtype=float)
    if q.shape != (4,) or not np.all(np.isfinite(q)):
        raise BridgeError(f"{what}: a quaternion is four finite numbers [w, x, y, z], got {list(quat)!r}")
    norm = float(np.linalg.norm(q))
    if abs(norm - 1.0) > 1e-3:
        raise BridgeError(f"{what}: quaternion {list(quat)!r} has norm {norm:.4f}, expected 1")
    q = q / norm
    if q[0] < 0:  # one sign per rotation keeps poses comparable
        q = -q
    return tuple(float(v) for v in q)  # type: ignore[return-value]


@dataclass(frozen=True)
class Pose:
    """A rigid pose in the world: position in metres and unit quaternion ``(w, x, y, z)``."""

    xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)
    quat: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        xyz = np.asarray(self.xyz, dtype=float)
        if xyz.shape != (3,) or not np.all(np.isfinite(xyz)):
            raise BridgeError(f"a position is three finite numbers [x, y, z], got {self.xyz!r}")
        object.__setattr__(self, "xyz", tuple(float(v) for v in xyz))
        object.__setattr__(self, "quat", _unit_quat(self.quat, "pose"))

    # --- construction -------------------------------------------------------------------------
    @classmethod
    def from_rpy(cls, xyz: Sequence[float], rpy: Sequence[float]) -> "Pose":
        """Roll, pitch, yaw in radians, applied about fixed x, y, z axes (Drake's RollPitchYaw)."""
        r, p, y = (float(v) for v in rpy)
        cr, sr, cp, sp, cy, sy = math.cos(r / 2), math.sin(r / 2), math.cos(p / 2), math.sin(p / 2), math.cos(y / 2), math.sin(y / 2)
        quat = (
            cr * cp * cy + sr * sp * sy,
            sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy,
        )
        return cls(tuple(xyz), quat)  # type: ignore[arg-type]

    @classmethod
    def from_matrix(cls, transform: np.ndarray) -> "Pose":
        """From a 4x4 homogeneous transform (or a 3x4 [R | t])."""
        t = np.asarray(transform, dtype=float)
        return cls(tuple(t[:3, 3]), rotation_to_quat(t[:3, :3]))  # type: ignore[arg-type]

    # --- views --------------------------------------------------------------------------------
    @property
    def position(self) -> np.ndarray:
        return np.array(self.xyz)

    def rotation(self) -> np.ndarray:
        """The 3x3 rotation matrix of this pose."""
        return quat_to_rotation(self.quat)

    def matrix(self) -> np.ndarray:
        m = np.eye(4)
        m[:3, :3] = self.rotation()
        m[:3, 3] = self.xyz
        return m

    def rpy(self) -> tuple[float, float, float]:
        R = self.rotation()
        pitch = math.asin(max(-1.0, min(1.0, -R[2, 0])))
        roll = math.atan2(R[2, 1], R[2, 2])
        yaw = math.atan2(R[1, 0], R[0, 0])
        return roll, pitch, yaw

    def yaw(self) -> float:
        return self.rpy()[2]

    def z_axis(self) -> np.ndarray:
        return self.rotation()[:, 2]

    def transform_point(self, p: Sequence[float]) -> np.ndarray:
        return self.rotation() @ np.asarray(p, dtype=float) + self.position

    def translation_to(self, other: "Pose") -> float:
        return float(np.linalg.norm(other.position - self.position))

    def rotation_to(self, other: "Pose") -> float:
        """Geodesic angle (rad) between the two orientations."""
        return rotation_angle(self.rotation().T @ other.rotation())


def quat_to_rotation(quat: Sequence[float]) -> np.ndarray:
    w, x, y, z = quat
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def rotation_to_quat(R: np.ndarray) -> tuple[float, float, float, float]:
    """Shepperd's method: stable for every rotation, including half turns."""
    R = np.asarray(R, dtype=float)
    tr = np.trace(R)
    if tr > 0:
        s = math.sqrt(tr + 1.0) * 2
        q = (0.25 * s, (R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s)
    elif R[0, 0] > R[1, 1] and R[0, 0] > R[2, 2]:
        s = math.sqrt(1.0 + R[0, 0] - R[1, 1] - R[2, 2]) * 2
        q = ((R[2, 1] - R[1, 2]) / s, 0.25 * s, (R[0, 1] + R[1, 0]) / s, (R[0, 2] + R[2, 0]) / s)
    elif R[1, 1] > R[2, 2]:
        s = math.sqrt(1.0 + R[1, 1] - R[0, 0] - R[2, 2]) * 2
        q = ((R[0, 2] - R[2, 0]) / s, (R[0, 1] + R[1, 0]) / s, 0.25 * s, (R[1, 2] + R[2, 1]) / s)
    else:
        s = math.sqrt(1.0 + R[2, 2] - R[0, 0] - R[1, 1]) * 2
        q = ((R[1, 0] - R[0, 1]) / s, (R[0, 2] + R[2, 0]) / s, (R[1, 2] + R[2, 1]) / s, 0.25 * s)
    n = math.sqrt(sum(v * v for v in q))
    q = tuple(v / n for v in q)
    return q if q[0] >= 0 else tuple(-v for v in q)  # type: ignore[return-value]


def rotation_angle(R: np.ndarray) -> float:
    """Angle of a rotation matrix, i.e. ||log(R)||_F / sqrt(2); accurate near 0 and near pi."""
    R = np.asarray(R, dtype=float)
    axis_part = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    return float(math.atan2(0.5 * np.linalg.norm(axis_part), 0.5 * (np.trace(R) - 1.0)))


@dataclass(frozen=True)
class Contact:
    """Two bodies touching at one instant. Bodies are object names or ``robot/<link>``."""

    body_a: str
    body_b: str
    force: tuple[float, float, float] = (0.0, 0.0, 0.0)  # on body_b by body_a, world frame, N
    point: tuple[float, float, float] = (0.0, 0.0, 0.0)  # world frame, m
    time: float = 0.0

    @property
    def magnitude(self) -> float:
        return float(np.linalg.norm(self.force))

    def involves(self, name: str) -> bool:
        return name in (self.body_a, self.body_b) or any(
            body.startswith(name + "/") for body in (self.body_a, self.body_b)
        )

    def other(self, name: str) -> str:
        return self.body_b if self.body_a == name or self.body_a.startswith(name + "/") else self.body_a


def fact_set(facts: Iterable[Fact | str]) -> frozenset[Fact]:
    return frozenset(f if isinstance(f, Fact) else Fact.parse(f) for f in facts)

"""Recordings of the MIT planar pushing dataset (Yu, Bauza, Fazeli, Rodriguez, IROS 2016): one push per h5 file.

A file holds three N x 4 float arrays ``[unix time s, a, b, c]``: `tip_pose` (x, y, yaw of the pusher rod),
`object_pose` (x, y, yaw of the object's centre) and `ft_wrench` (fx, fy, torque_z at the pusher). Their
lengths and clocks differ slightly, so `load_push` puts them on one time base (the object's timestamps inside
the overlap of the streams, linear interpolation) and validates everything once.

Clock jitter: in 20 of the 50 bundled files a few `object_pose` timestamps step back by up to 1.7 ms (the
poses themselves are in order). Such rows are dropped (`max_time_jitter`, default 3 ms, and listed in
`PushRecording.repairs`); a larger step back or an exactly repeated timestamp is an error.

Frames: the object's pose frame is not always the mesh frame (README: about 90 degrees for ellip3 and hex).
`estimate_frame_yaw` measures the offset from where the recorded pusher touches the outline.

Names: the dataset's file names tell the shape pushed (and the push: surface, speed, side, ...). A file under
another name is read too: its shape then comes from a `shape` attribute of the file's root, if it has one, or
from the caller (`shape=`, the command line's --shape); the other push parameters are then unknown (None).
"""
from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import numpy as np

from ..errors import RecordingError

DATASET_ENV = "BRIDGE_MIT_PUSH"
_DATASET_ENV_ODB = "BRIDGE_DATASET_MIT_PUSH"  # the name the object database loader uses for dataset://mit-push
PUSHER_RADIUS = 0.00476  # m, the steel rod
MOVING_SHARE = 0.3  # a sample pushes when the object moves at this share of its 90th-percentile speed
LEVER = 0.05  # m: rotation's share of that speed (|v| + LEVER |omega|)
MAX_TIME_JITTER = 0.003  # s, largest backward timestamp step repaired by dropping the row
QUARTER_TURNS = (0.0, math.pi / 2, math.pi, -math.pi / 2)
TOUCH_SHARE = 0.1  # a moving sample touches when its force exceeds this share of the push's (`touching`)

_NUMBER = r"-?\d+(?:\.\d+)?"
_NAME = re.compile(
    rf"^motion_surface=(?P<surface>[A-Za-z0-9]+)_shape=(?P<shape>[A-Za-z0-9]+)_a=(?P<a>{_NUMBER})"
    rf"_v=(?P<v>{_NUMBER})_i=(?P<i>{_NUMBER})_s=(?P<s>{_NUMBER})_t=(?P<t>{_NUMBER})\.h5$")
_NAME_PATTERN = "motion_surface=<surface>_shape=<shape>_a=<acc>_v=<mm/s>_i=<side>_s=<0..1>_t=<rad>.h5"
_SHAPE = re.compile(r"^[A-Za-z0-9_]+$")
_COLUMNS = {"tip_pose": ("time", "x", "y", "yaw"), "object_pose": ("time", "x", "y", "yaw"),
            "ft_wrench": ("time", "fx", "fy", "torque_z")}


@dataclass(frozen=True)
class PushSpec:
    """The push a file name encodes: surface, shape, acceleration `a` (0 = constant speed), pusher speed `v`
    (mm/s), side `i` pushed, contact position `s` along it (0..1), push angle `t` to the side's normal (rad).
    For a file named otherwise only the shape is known (`shape_from`: where the shape was read)."""

    surface: str | None
    shape: str
    a: float | None = None
    v: float | None = None
    i: int | None = None
    s: float | None = None
    t: float | None = None
    shape_from: str = "file name"


@dataclass(frozen=True, eq=False)
class PushRecording:
    """One push on a common time base; arrays are read-only, `t` in seconds since `start_time` (unix s).

    tip_xy (N, 2) m; object_pose (N, 3) x m, y m, yaw rad (unwrapped, world frame); wrench (N, 3) fx N, fy N,
    torque_z N m at the pusher, or None when the file's wrench is constant or absent (not recorded).
    """

    spec: PushSpec
    path: Path
    t: np.ndarray
    tip_xy: np.ndarray
    object_pose: np.ndarray
    wrench: np.ndarray | None
    start_time: float
    repairs: tuple[str, ...] = ()

    @property
    def duration(self) -> float:
        return float(self.t[-1])

    def __len__(self) -> int:
        return len(self.t)


# --- file names -----------------------------------------------------------------------------------------
def parse_push_name(path: str | os.PathLike) -> PushSpec:
    """The push parameters in a file name, e.g.
    ``motion_surface=abs_shape=rect1_a=0_v=75_i=2.000_s=0.700_t=-1.047.h5``."""
    name = Path(path).name
    match = _NAME.match(name)
    if match is None:
        raise RecordingError(f"file name does not follow the pattern {_NAME_PATTERN}", source=str(path))
    side = float(match["i"])
    if side != int(side) or side < 0:
        raise RecordingError(f"side index i={match['i']} is not a whole number >= 0", source=str(path))
    spec = PushSpec(surface=match["surface"], shape=match["shape"], a=float(match["a"]), v=float(match["v"]),
                    i=int(side), s=float(match["s"]), t=float(match["t"]))
    if not 0.0 <= spec.s <= 1.0:
        raise RecordingError(f"contact position s={match['s']} is outside 0..1", source=str(path))
    if spec.v <= 0:
        raise RecordingError(f"pusher speed v={match['v']} mm/s must be > 0", source=str(path))
    return spec


def follows_push_name(path: str | os.PathLike) -> bool:
    """Whether the file's name is one of the dataset's (and so tells the shape)."""
    return _NAME.match(Path(path).name) is not None


def push_spec(path: Path, shape: str | None, attribute: str | None) -> PushSpec:
    """The push of a file: from its name when it follows the dataset's pattern, else the shape from the file's
    `shape` attribute, else `shape` (the command line's --shape). A shape given that contradicts the file's own
    is an error, and so is a file nothing names the shape of."""
    if shape is not None and (not isinstance(shape, str) or not _SHAPE.match(shape)):
        raise RecordingError(f"--shape must be a name like 'rect1', got {shape!r}")
    if follows_push_name(path):
        spec = parse_push_name(path)
        told, where = spec.shape, "its file name"
    elif attribute is not None:
        spec = PushSpec(None, attribute, shape_from="the file's 'shape' attribute")
        told, where = attribute, "its 'shape' attribute"
    elif shape is not None:
        return PushSpec(None, shape, shape_from="--shape")
    else:
        raise RecordingError(f"cannot tell which shape was pushed: the file name does not follow the dataset's "
                             f"pattern ({_NAME_PATTERN}) and the file has no 'shape' attribute; name it with "
                             "--shape NAME", source=str(path))
    if shape is not None and shape != told:
        raise RecordingError(f"{where} says shape {told!r}, --shape says {shape!r}", source=str(path))
    return spec


# --- loading --------------------------------------------------------------------------------------------
def load_push(path: str | os.PathLike, *, max_duration: float | None = None,
              max_time_jitter: float = MAX_TIME_JITTER, shape: str | None = None) -> PushRecording:
    """Read, validate and resample one push file; every problem is a RecordingError naming file and dataset.
    `shape`: the shape pushed, for a file whose name and attributes do not tell it (`push_spec`)."""
    path = Path(path)
    if follows_push_name(path):
        parse_push_name(path)  # a bad value in a dataset name is refused before the file is read
    if max_duration is not None and not (math.isfinite(max_duration) and max_duration > 0):
        raise RecordingError(f"max_duration must be a positive number of seconds, got {max_duration!r}",
                             source=str(path))
    raw, attribute = _read_streams(path)
    spec = push_spec(path, shape, attribute)
    repairs: list[str] = []
    streams = {name: _clean_times(array, path, name, max_time_jitter, repairs) for name, array in raw.items()}

    wrench = streams.get("ft_wrench")
    if wrench is not None and float(np.ptp(wrench[:, 1:], axis=0).max()) == 0.0:
        wrench = None  # constant: not recorded in this trial
    used = {name: a for name, a in (("tip_pose", streams["tip_pose"]), ("object_pose", streams["object_pose"]),
                                    ("ft_wrench", wrench)) if a is not None}
    start = max(a[0, 0] for a in used.values())
    end = min(a[-1, 0] for a in used.values())
    if start >= end:
        spans = ", ".join(f"{n} {a[0, 0]:.3f}..{a[-1, 0]:.3f}" for n, a in used.items())
        raise RecordingError(f"the streams do not overlap in time (unix s: {spans})", source=str(path))
    obj = streams["object_pose"]
    inside = (obj[:, 0] >= start) & (obj[:, 0] <= end)
    base = obj[inside]
    if max_duration is not None:
        base = base[base[:, 0] - base[0, 0] <= max_duration] if len(base) else base
    if len(base) < 2:
        why = f"within max_duration={max_duration} s" if max_duration is not None else "where all streams overlap"
        raise RecordingError(f"fewer than 2 object_pose samples {why}", source=str(path), field="object_pose")

    times = base[:, 0]
    tip = streams["tip_pose"]
    tip_xy = np.column_stack([np.interp(times, tip[:, 0], tip[:, k]) for k in (1, 2)])
    wrench_on_base = None if wrench is None else np.column_stack(
        [np.interp(times, wrench[:, 0], wrench[:, k]) for k in (1, 2, 3)])
    return PushRecording(
        spec=spec, path=path, t=_frozen(times - times[0]), tip_xy=_frozen(tip_xy),
        object_pose=_frozen(base[:, 1:4].copy()),
        wrench=None if wrench_on_base is None else _frozen(wrench_on_base),
        start_time=float(times[0]), repairs=tuple(repairs))


def save_push(path: str | os.PathLike, tip_pose: np.ndarray, object_pose: np.ndarray,
              ft_wrench: np.ndarray | None = None, *, shape: str | None = None) -> Path:
    """Write a push in the dataset's format: `tip_pose`, `object_pose` and (when given) `ft_wrench`, each N x 4
    ``[unix time s, a, b, c]`` as `load_push` reads them; `shape` becomes the root's `shape` attribute (for a file
    whose name does not follow the dataset's pattern). Written to a temporary file beside `path`, then renamed:
    a reader never sees half a file."""
    import h5py

    path = Path(path)
    if shape is not None and not _SHAPE.match(shape):
        raise RecordingError(f"shape must be a name like 'rect1', got {shape!r}", source=str(path))
    streams = {"tip_pose": tip_pose, "object_pose": object_pose, "ft_wrench": ft_wrench}
    for name, array in streams.items():
        if array is not None and (np.ndim(array) != 2 or np.shape(array)[1] != 4):
            raise RecordingError(f"expected N x 4 [{', '.join(_COLUMNS[name])}], got shape {np.shape(array)}",
                                 source=str(path), field=name)
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        with h5py.File(temporary, "w") as handle:
            for name, array in streams.items():
                if array is not None:
                    handle.create_dataset(name, data=np.asarray(array, dtype=float))
            if shape is not None:
                handle.attrs["shape"] = shape
        os.replace(temporary, path)
    finally:
        temporary.unlink(missing_ok=True)
    return path


def _read_streams(path: Path) -> tuple[dict[str, np.ndarray], str | None]:
    """The streams, and the root's `shape` attribute (None when absent)."""
    import h5py  # local: only this reader needs it

    if not path.is_file():
        raise RecordingError("no such file", source=str(path))
    try:
        handle = h5py.File(path, "r")
    except OSError as exc:
        message = str(exc)
        if "truncated file" in message:
            detail = re.search(r"eof = (\d+).*stored_eof = (\d+)", message)
            size = f" ({detail[1]} of {detail[2]} bytes)" if detail else ""
            raise RecordingError(f"truncated HDF5 file{size}; copy it again", source=str(path)) from None
        if "signature not found" in message or not h5py.is_hdf5(path):
            raise RecordingError("not an HDF5 file (no HDF5 signature)", source=str(path)) from None
        raise RecordingError(f"cannot open HDF5 file: {message}", source=str(path)) from None
    with handle:
        present = sorted(handle.keys())
        streams: dict[str, np.ndarray] = {}
        for name in _COLUMNS:
            if name not in handle:
                if name == "ft_wrench":
                    continue  # optional: a trial without force data
                raise RecordingError(f"missing dataset; the file has {', '.join(present) or 'no datasets'}",
                                     source=str(path), field=name)
            streams[name] = _read_array(handle[name], path, name)
        attribute = handle.attrs.get("shape")
    if attribute is not None:
        if isinstance(attribute, bytes):
            attribute = attribute.decode("utf-8", errors="replace")
        if isinstance(attribute, np.ndarray) and attribute.size == 1:
            attribute = attribute.reshape(-1)[0]
        attribute = attribute.decode("utf-8", errors="replace") if isinstance(attribute, bytes) else attribute
        if not isinstance(attribute, str) or not _SHAPE.match(attribute):
            raise RecordingError(f"the 'shape' attribute must be a shape's name like 'rect1', got {attribute!r}",
                                 source=str(path), field="shape")
    return streams, attribute


def _read_array(node, path: Path, name: str) -> np.ndarray:
    import h5py

    if not isinstance(node, h5py.Dataset):
        raise RecordingError("is a group, expected an N x 4 dataset", source=str(path), field=name)
    columns = ", ".join(_COLUMNS[name])
    if len(node.shape) != 2 or node.shape[1] != 4:
        raise RecordingError(f"has shape {node.shape}, expected N x 4 [{columns}]", source=str(path), field=name)
    if node.dtype.kind not in "fiu":
        raise RecordingError(f"has type {node.dtype}, expected numbers", source=str(path), field=name)
    try:
        array = np.asarray(node[()], dtype=float)
    except OSError as exc:
        raise RecordingError(f"cannot read the data (corrupt or truncated file): {exc}",
                             source=str(path), field=name) from None
    if len(array) < 2:
        raise RecordingError(f"has {len(array)} row(s), need at least 2", source=str(path), field=name)
    bad = ~np.isfinite(array)
    if bad.any():
        row, col = (int(v) for v in np.argwhere(bad)[0])
        raise RecordingError(f"row {row} (counting from 0) has a non-finite {_COLUMNS[name][col]}: "
                             f"{array[row].tolist()}", source=str(path), field=name)
    return array


def _clean_times(array: np.ndarray, path: Path, name: str, jitter: float, repairs: list[str]) -> np.ndarray:
    """Strictly increasing times: rows stepping back by <= `jitter` are dropped, anything else is an error."""
    times = array[:, 0]
    before = np.maximum.accumulate(times)[:-1]  # latest time seen before each row
    steps = times[1:] - before
    repeated = np.nonzero(steps == 0)[0]
    if len(repeated):
        row = int(repeated[0]) + 1
        raise RecordingError(f"row {row} (counting from 0) repeats timestamp {times[row]!r} of an earlier row",
                             source=str(path), field=name)
    back = np.nonzero(steps < 0)[0]
    if len(back) and float(-steps[back].min()) > jitter:
        row = int(back[np.argmin(steps[back])]) + 1
        raise RecordingError(f"timestamps are not increasing: row {row} (counting from 0) is "
                             f"{-steps[row - 1]:.4f} s earlier than a row before it "
                             f"(more than the {jitter} s clock jitter tolerated)", source=str(path), field=name)
    if len(back):
        repairs.extend(f"{name}: dropped row {int(k) + 1} (timestamp {-steps[k] * 1e3:.3f} ms behind an earlier row)"
                       for k in back)
        keep = np.ones(len(array), dtype=bool)
        keep[back + 1] = False
        array = array[keep]
        if len(array) < 2:
            raise RecordingError("fewer than 2 rows left after dropping out-of-order timestamps",
                                 source=str(path), field=name)
    if name == "object_pose":
        array = array.copy()
        array[:, 3] = np.unwrap(array[:, 3])  # before interpolation, so yaw never jumps by 2 pi
    return array


def _frozen(array: np.ndarray) -> np.ndarray:
    array = np.ascontiguousarray(array, dtype=float)
    array.setflags(write=False)
    return array


# --- dataset folder, outlines, meshes -------------------------------------------------------------------
def find_mit_push_root(explicit: str | os.PathLike | None = None) -> Path | None:
    """The dataset folder: `explicit`, else $BRIDGE_MIT_PUSH (or $BRIDGE_DATASET_MIT_PUSH), else
    ``../shared/datasets/mit-push`` beside the repository root when it exists; None when nothing is found.
    A folder named explicitly or by the environment that does not exist is an error, not a silent None."""
    if explicit is not None:
        return _existing_dir(Path(explicit), "dataset folder")
    for variable in (DATASET_ENV, _DATASET_ENV_ODB):
        value = os.environ.get(variable)
        if value:
            return _existing_dir(Path(value), f"${variable}")
    default = _repository_root().parent / "shared" / "datasets" / "mit-push"
    return default if default.is_dir() else None


def load_outline(shape: str, dataset_root: str | os.PathLike | None = None) -> np.ndarray:
    """The shape's 2-D outline (K, 2), metres, in the mesh frame, from ``obj/<shape>_ext.npy``."""
    path = _object_file(shape, "_ext.npy", dataset_root)
    try:
        outline = np.load(path, allow_pickle=False)
    except (OSError, ValueError) as exc:
        raise RecordingError(f"cannot read the outline: {exc}", source=str(path)) from None
    if outline.ndim != 2 or outline.shape[1] != 2 or len(outline) < 3:
        raise RecordingError(f"outline has shape {outline.shape}, expected K x 2 vertices with K >= 3",
                             source=str(path))
    if not np.all(np.isfinite(outline)):
        raise RecordingError("outline has non-finite vertices", source=str(path))
    return _frozen(outline)


def mesh_path(shape: str, dataset_root: str | os.PathLike | None = None) -> Path:
    """The shape's mesh ``obj/<shape>.obj`` (centred, 12.8 mm thick)."""
    return _object_file(shape, ".obj", dataset_root)


def _object_file(shape: str, suffix: str, dataset_root: str | os.PathLike | None) -> Path:
    root = find_mit_push_root(dataset_root)
    if root is None:
        raise RecordingError(f"MIT planar pushing dataset not found: pass its folder, set {DATASET_ENV}, "
                             "or put it at ../shared/datasets/mit-push")
    if not isinstance(shape, str) or not _SHAPE.match(shape):
        raise RecordingError(f"shape must be a name like 'rect1', got {shape!r}")
    path = root / "obj" / f"{shape}{suffix}"
    if not path.is_file():
        known = sorted(p.name[: -len("_ext.npy")] for p in (root / "obj").glob("*_ext.npy"))
        raise RecordingError(f"no {suffix} file for shape {shape!r}; shapes: {', '.join(known) or 'none'}",
                             source=str(path))
    return path


def _existing_dir(path: Path, what: str) -> Path:
    if not path.is_dir():
        raise RecordingError(f"{what} {path} is not a folder; it should hold the MIT pushing dataset "
                             "(train/, obj/)")
    return path


def _repository_root() -> Path:
    """The folder holding pyproject.toml above this file, else the one holding the `bridge` package."""
    here = Path(__file__).resolve()
    for folder in here.parents:
        if (folder / "pyproject.toml").is_file():
            return folder
    return here.parents[2]


# --- frame of the pose relative to the mesh -------------------------------------------------------------
def estimate_frame_yaw(recording: PushRecording | Sequence[PushRecording], outline: np.ndarray,
                       pusher_radius: float = PUSHER_RADIUS, *, candidates: Sequence[float] = QUARTER_TURNS,
                       refine_window: float = 0.0, tie_tolerance: float = 5e-4) -> float:
    """Yaw offset d (rad, in (-pi, pi]) of the mesh frame relative to the recorded pose frame.

    Convention: a mesh point p lies in the world at ``xy + Rot(yaw + d) p``, so the rod's centre expressed in
    the mesh frame is ``Rot(-(yaw + d)) (tip - xy)``. The offset is the candidate that puts it closest to
    `pusher_radius` outside the outline while the object is being pushed, from the first contact on
    (`frame_yaw_cost`). Several recordings of one shape may be passed to pool their samples.
    Candidates whose cost is within `tie_tolerance` (m) of the best are ties, which symmetric shapes cannot
    avoid (a square fits every quarter turn, a circle every angle, a hexagon repeats every 60 deg, an ellipse
    every 180 deg); ties go to the smallest |d|, then to d > 0, so the answer for such shapes is a convention,
    not a measurement. `refine_window` > 0 then searches +-window around the chosen candidate (1 deg steps,
    then 0.25 deg around the best), unless the cost is flat there (a circle), when the candidate stays.
    """
    yaws = np.array([_wrap(float(c)) for c in candidates], dtype=float)
    if yaws.size == 0:
        raise RecordingError("estimate_frame_yaw needs at least one candidate yaw")
    costs = frame_yaw_cost(recording, outline, yaws, pusher_radius)
    ties = np.nonzero(costs <= costs.min() + tie_tolerance)[0]
    best = float(yaws[min(ties, key=lambda k: (round(abs(yaws[k]), 9), yaws[k] < 0))])
    if refine_window > 0:
        coarse = np.arange(-refine_window, refine_window + 1e-12, math.radians(1.0))
        cost = frame_yaw_cost(recording, outline, best + coarse, pusher_radius)
        if float(cost.max() - cost.min()) > tie_tolerance:
            centre = best + float(coarse[int(np.argmin(cost))])
            fine = centre + np.radians(np.arange(-1.0, 1.0 + 1e-9, 0.25))
            best = float(fine[int(np.argmin(frame_yaw_cost(recording, outline, fine, pusher_radius)))])
    return _wrap(best)


def frame_yaw_cost(recording: PushRecording | Sequence[PushRecording], outline: np.ndarray,
                   yaws: Sequence[float], pusher_radius: float = PUSHER_RADIUS) -> np.ndarray:
    """For each yaw offset: median |signed distance of the rod's centre to the outline - pusher_radius| (m)
    over the samples in which the object is being pushed (`pushed_samples`), pooled over the recordings."""
    outline = np.asarray(outline, dtype=float)
    if outline.ndim != 2 or outline.shape[1] != 2 or len(outline) < 3:
        raise RecordingError(f"outline must be K x 2 vertices with K >= 3, got shape {outline.shape}")
    recordings = (recording,) if isinstance(recording, PushRecording) else tuple(recording)
    if not recordings:
        raise RecordingError("frame_yaw_cost needs at least one recording")
    rel_parts, heading_parts = [], []
    for rec in recordings:
        pushed = pushed_samples(rec)
        rel_parts.append(rec.tip_xy[pushed] - rec.object_pose[pushed, :2])
        heading_parts.append(rec.object_pose[pushed, 2])
    rel, heading = np.concatenate(rel_parts), np.concatenate(heading_parts)
    costs = []
    for d in np.asarray(yaws, dtype=float).reshape(-1):
        c, s = np.cos(heading + d), np.sin(heading + d)
        local = np.column_stack([c * rel[:, 0] + s * rel[:, 1], -s * rel[:, 0] + c * rel[:, 1]])
        costs.append(float(np.median(np.abs(signed_distance(local, outline) - pusher_radius))))
    return np.array(costs)


def pushed_samples(recording: PushRecording) -> np.ndarray:
    """`moving_samples` of a push as recorded."""
    pose = recording.object_pose
    return moving_samples(recording.t, pose[:, :2], pose[:, 2])


def moving_samples(times: np.ndarray, xy: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """Indices where the object moves at more than MOVING_SHARE of its 90th-percentile speed (|v| + LEVER x
    |omega|); none when it never moves.

    In a quasi-static push the object moves only while the rod touches it, so these samples (from the
    first contact on) pin down where the rod is on the outline; samples at rest before contact do not.
    """
    times = np.asarray(times, dtype=float)
    speed = (np.hypot(*np.gradient(np.asarray(xy, dtype=float), times, axis=0).T)
             + LEVER * np.abs(np.gradient(np.unwrap(np.asarray(yaw, dtype=float)), times)))
    if not np.any(speed > 0):
        return np.zeros(0, dtype=int)
    return np.nonzero(speed >= MOVING_SHARE * np.percentile(speed, 90))[0]


def touching(force_magnitude: np.ndarray) -> np.ndarray:
    """Which samples of a pushing force's magnitude (N, the samples where the object moves) have the rod on the
    object: above TOUCH_SHARE of the push's 90th-percentile force (tenths of a newton to a newton on the MIT
    pushes, whose sensor noise is a few hundredths). A push that kicks the object ahead of the rod (an impact at
    speed) moves it while nothing touches; such samples say nothing about where the rod meets the outline. (The
    real MIT pushes touch in 93-100 % of their moving samples, a MuJoCo world's 77-90 %.)"""
    m = np.asarray(force_magnitude, dtype=float)
    if m.size == 0:
        return np.zeros(0, dtype=bool)
    return m > TOUCH_SHARE * float(np.percentile(m, 90))


def signed_distance(points: np.ndarray, polygon: np.ndarray) -> np.ndarray:
    """Distance of each point to the closed polygon's boundary, negative inside (even-odd rule)."""
    return closest_on_outline(points, polygon)[0]


def closest_on_outline(points: np.ndarray, outline: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For points (B, 2): signed distance to the closed outline (negative inside, even-odd rule), the nearest
    outline point (B, 2) and the outward unit normal there (B, 2: towards the point; the edge's normal when on it)."""
    a, b = outline, np.roll(outline, -1, axis=0)
    ab = b - a
    ap = points[:, None, :] - a[None, :, :]
    u = np.clip(np.sum(ap * ab, axis=-1) / np.maximum(np.sum(ab * ab, axis=-1), 1e-300), 0.0, 1.0)
    foot = a[None] + u[..., None] * ab[None]
    gap = np.linalg.norm(points[:, None, :] - foot, axis=-1)
    k = np.argmin(gap, axis=1)
    rows = np.arange(len(points))
    nearest, dist = foot[rows, k], gap[rows, k]
    x, y = points[:, 0:1], points[:, 1:2]
    crosses = (a[:, 1] > y) != (b[:, 1] > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        x_cross = a[:, 0] + (y - a[:, 1]) * ab[:, 0] / ab[:, 1]
    inside = (np.sum(crosses & (x < x_cross), axis=1) % 2) == 1
    sign = np.where(inside, -1.0, 1.0)
    edge_normal = np.column_stack([ab[k, 1], -ab[k, 0]]) / np.linalg.norm(ab[k], axis=1, keepdims=True)
    away = (points - nearest) * sign[:, None]
    normal = np.where(dist[:, None] > 1e-9, away / np.maximum(dist, 1e-300)[:, None], edge_normal)
    return sign * dist, nearest, normal


def _wrap(angle: float) -> float:
    """Angle in (-pi, pi]."""
    wrapped = math.remainder(angle, 2 * math.pi)
    return math.pi if wrapped == -math.pi else wrapped


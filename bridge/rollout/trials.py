"""Trials: recordings prepared for comparison with simulation (fitting, diagnosis, the proof), each a world state
before, telemetry, observed poses and, when recorded, the robot's force.

`load_trials` accepts recording folders (world.yaml, telemetry, observed.csv), MIT planar pushing h5 files
and folders of such files. MIT pushes of one shape share one frame offset, estimated from all of them
together (`estimate_frame_yaw`), because one push alone often cannot tell a symmetric shape's quarter turns
apart.
"""
from __future__ import annotations

import os
from collections import defaultdict
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Iterable, Mapping, Sequence

from ..errors import RecordingError
from ..odb import ObjectDatabase
from ..recording.adjustments import Adjustment, FrameYaw, dropped_rows
from ..recording.forces import ObservedForce
from ..recording.observations import ObservedPoses
from ..recording.telemetry import Telemetry
from ..world import WorldState

H5_SUFFIXES = (".h5", ".hdf5")
DEFAULT_SETTLE = 0.5  # s simulated after the telemetry when the last observation is a sparse "after" pose


@dataclass(frozen=True, eq=False)
class Trial:
    """One recording ready for fitting. `adjustments` are what the loader changed on the way, as data
    (`bridge.recording.adjustments`: a shifted tip track, a turned frame, dropped rows), which the diagnosis reads
    as evidence; `notes` say the same (and other facts) in words."""

    name: str
    world: WorldState
    telemetry: Telemetry
    observations: ObservedPoses
    source: Path
    notes: tuple[str, ...] = ()
    force: ObservedForce | None = None  # the robot's force sensor, when recorded
    base: tuple = ()  # settings (`bridge.params.Setting`) every replay of the trial starts from: a diagnosed model
    adjustments: tuple[Adjustment, ...] = ()

    @property
    def settle(self) -> float:
        """Seconds to simulate after the telemetry: up to the last dense observation, or `DEFAULT_SETTLE` for a
        sparse (before / after) one, which is compared with the objects at rest."""
        if self.observations.is_dense:
            last = max(float(tr.times[-1]) for tr in self.observations)
            return max(0.0, last - self.telemetry.end)
        return DEFAULT_SETTLE

    @property
    def is_planar_push(self) -> bool:
        """An MIT planar push (plotted as x-y paths in the report)."""
        return self.source.suffix.lower() in H5_SUFFIXES


def load_trials(paths: Iterable[str | os.PathLike], odb: ObjectDatabase, *, max_duration: float | None = None,
                observation_rate: float | None = None, frame_yaws: Mapping[str, float] | None = None,
                shape: str | None = None) -> list[Trial]:
    """Read every path: a recording folder, an MIT h5 file, or a folder of h5 files (sorted by name).

    `max_duration` (s) truncates MIT pushes (tests and quick runs); `observation_rate` (Hz, default 25)
    subsamples their motion-capture track; `frame_yaws` fixes a shape's frame offset instead of estimating it;
    `shape` is the shape pushed in h5 files whose name does not follow the dataset's pattern and that carry no
    `shape` attribute (`mitpush.push_spec`). Trial names are the folder names / file stems, made unique with a
    suffix when two collide.
    """
    from ..recording.mitpush import load_push

    expanded = _expand(paths)
    if not expanded:
        raise RecordingError("no recordings given: pass recording folders, MIT .h5 files or folders of .h5 files")
    if shape is not None:
        check_shape(shape, odb)
        if not any(p.suffix.lower() in H5_SUFFIXES for p in expanded):
            raise RecordingError(f"--shape {shape} names the shape pushed in MIT .h5 files, but no .h5 file was given")
    pushes = {}
    for path in expanded:
        if path.suffix.lower() in H5_SUFFIXES:
            pushes[path] = load_push(path, shape=shape)  # in full: the frame offset is estimated from whole pushes
    yaws = _frame_yaws(pushes.values(), odb, frame_yaws or {})
    trials: list[Trial] = []
    for path in expanded:
        if path in pushes:
            push = pushes[path] if max_duration is None else load_push(path, max_duration=max_duration, shape=shape)
            given = push.spec.shape in (frame_yaws or {})
            trials.append(_push_trial(push, odb, yaws[push.spec.shape], observation_rate, estimated=not given))
        else:
            trials.append(_recording_trial(path, odb))
    return _unique_names(trials)


def check_shape(shape: str, odb: ObjectDatabase) -> None:
    """`shape` must be one of the MIT pushing dataset's shapes in the object database (odb/types/mit_push.yaml)."""
    from ..recording.mitsession import SHAPE_TYPE

    known = sorted(n for n, t in odb.types.items() if t.is_a(SHAPE_TYPE) and not t.abstract)
    if shape not in known:
        raise RecordingError(f"--shape {shape!r} is not a shape of the MIT pushing dataset; shapes: "
                             f"{', '.join(known) or 'none in the object database'}")


def _expand(paths: Iterable[str | os.PathLike]) -> list[Path]:
    expanded: list[Path] = []
    for raw in paths:
        path = Path(raw)
        if path.is_dir() and not (path / "world.yaml").is_file():
            found = sorted(p for p in path.iterdir() if p.suffix.lower() in H5_SUFFIXES)
            if not found:
                raise RecordingError("folder is neither a recording (no world.yaml) nor a folder of MIT .h5 files",
                               source=str(path))
            expanded.extend(found)
        elif path.exists():
            expanded.append(path)
        else:
            raise RecordingError("recording not found", source=str(path))
    return expanded


def _frame_yaws(pushes, odb: ObjectDatabase, given: Mapping[str, float]) -> dict[str, float]:
    from ..recording.mitpush import estimate_frame_yaw

    by_shape = defaultdict(list)
    for push in pushes:
        by_shape[push.spec.shape].append(push)
    yaws: dict[str, float] = {}
    for shape, group in by_shape.items():
        if shape in given:
            yaws[shape] = float(given[shape])
            continue
        outline = shape_outline(shape, odb)
        if outline is None:
            yaws[shape] = 0.0  # push_session reports the missing type or dataset
            continue
        yaws[shape] = estimate_frame_yaw(group, outline)
    return yaws


def shape_outline(shape: str, odb: ObjectDatabase):
    """The outline of a shape type (`prisms.outline_of`), None when the type is unknown, its mesh is not available
    or it is no prism."""
    from ..sim.prisms import outline_of

    geometry = odb.types[shape].geometry if shape in odb.types else None
    return None if geometry is None else outline_of(geometry)


def _push_trial(push, odb: ObjectDatabase, frame_yaw: float, observation_rate: float | None, *,
                estimated: bool = True) -> Trial:
    """The push as a trial; every repair the loader made is kept in `adjustments` (and said in `notes`)."""
    from ..recording.mitsession import OBSERVATION_RATE, push_session

    session = push_session(push, odb, frame_yaw=frame_yaw,
                           observation_rate=OBSERVATION_RATE if observation_rate is None else observation_rate,
                           outline=shape_outline(push.spec.shape, odb))
    notes = list(session.notes)
    adjustments: list[Adjustment] = [session.start] if session.start is not None else []
    if frame_yaw:
        adjustments.append(FrameYaw(push.spec.shape, float(frame_yaw), estimated))
        notes.append(adjustments[-1].text())
    if push.spec.shape_from != "file name":
        notes.append(f"{push.path.name}: the shape {push.spec.shape} comes from {push.spec.shape_from}")
    for dropped in dropped_rows(push.repairs):
        adjustments.append(dropped)
        notes.append(dropped.text())
    return Trial(push.path.stem, session.world, session.telemetry, session.observations, push.path, tuple(notes),
                 session.force, adjustments=tuple(adjustments))


def _recording_trial(folder: Path, odb: ObjectDatabase) -> Trial:
    from ..recording.recording import load_recording, recording_world

    recording = load_recording(folder)
    if recording.observations is None:
        raise RecordingError("the recording has no observed poses (observed.csv); fitting and diagnosis compare with them",
                       source=str(folder))
    world = recording_world(recording, odb)
    return Trial(recording.name, world, recording.telemetry, recording.observations, folder,
                 force=recording.force)


def _unique_names(trials: Sequence[Trial]) -> list[Trial]:
    seen: dict[str, int] = {}
    result = []
    for trial in trials:
        count = seen.get(trial.name, 0)
        seen[trial.name] = count + 1
        result.append(trial if count == 0 else replace(trial, name=f"{trial.name}#{count + 1}"))
    return result

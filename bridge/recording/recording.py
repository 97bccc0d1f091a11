"""Recording folders: one teleoperation session on disk (world state before it, telemetry, observed poses).

The world state is kept as a path: reading it needs the object database (`recording_world` reads it and checks
the recording against it). The format is documented in docs/recordings.md.
"""
from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

import yaml

from ..errors import RecordingError
from ..files import load_yaml_text, read_yaml, replace_folder, write_atomic, yaml_error
from ..odb import ObjectDatabase
from ..world import WorldState, load_world_state
from .forces import ObservedForce, load_force_csv, save_force_csv
from .observations import ObservedPoses, load_observations_csv, save_observations_csv
from .telemetry import Telemetry, load_telemetry, read_text, save_telemetry_csv, validate_telemetry

RECORDING_FILE = "recording.yaml"
WORLD_FILE = "world.yaml"
OBSERVATIONS_FILE = "observed.csv"
FORCE_FILE = "force.csv"
TELEMETRY_FILE = "telemetry.csv"  # what save_recording writes
TELEMETRY_CANDIDATES = ("telemetry.csv", "telemetry.mcap", "telemetry", "telemetry.bag")  # looked for, in order
FIELDS = ("name", "robot", "telemetry", "telemetry_topic", "observations", "force", "scene", "notes")
PATH_FIELDS = ("telemetry", "observations", "force", "scene")  # relative to the recording folder


@dataclass(frozen=True, eq=False)
class Recording:
    """One teleoperation session: the world state file before it, what the robot did, and what was seen after."""

    name: str
    folder: Path
    world_path: Path
    telemetry: Telemetry
    observations: ObservedPoses | None = None
    metadata: dict[str, Any] = field(default_factory=dict)  # recording.yaml as written (empty when absent)
    force: ObservedForce | None = None  # force.csv: what the robot's force sensor read

    @property
    def robot(self) -> str | None:
        """The object-database robot type, when recording.yaml names one."""
        return self.metadata.get("robot")

    @property
    def notes(self) -> str:
        return self.metadata.get("notes") or ""

    @property
    def scene_path(self) -> Path | None:
        """The fitted scene / parameter file named in recording.yaml, resolved against the folder."""
        scene = self.metadata.get("scene")
        return None if scene is None else self.folder / scene


def load_recording(folder: str | os.PathLike[str]) -> Recording:
    """Read a recording folder; telemetry and observations are loaded and checked, the world state is not."""
    folder = Path(folder)
    if not folder.exists():
        raise RecordingError("recording folder not found", source=str(folder))
    if not folder.is_dir():
        raise RecordingError(f"a recording is a folder holding {WORLD_FILE} and telemetry, not a file",
                             source=str(folder))
    metadata = _load_metadata(folder / RECORDING_FILE)
    world_path = folder / WORLD_FILE
    if not world_path.is_file():
        raise RecordingError(f"no {WORLD_FILE}: a recording needs the world state from before the teleoperation",
                             source=str(folder))
    telemetry = load_telemetry(_telemetry_path(folder, metadata), topic=metadata.get("telemetry_topic"))
    observations_path = _named_path(folder, metadata, "observations")
    if observations_path is None and (folder / OBSERVATIONS_FILE).is_file():
        observations_path = folder / OBSERVATIONS_FILE
    observations = None if observations_path is None else load_observations_csv(observations_path)
    force_path = _named_path(folder, metadata, "force")
    if force_path is None and (folder / FORCE_FILE).is_file():
        force_path = folder / FORCE_FILE
    force = None if force_path is None else load_force_csv(force_path)
    _named_path(folder, metadata, "scene")  # checked here so a missing scene file is reported with the recording
    return Recording(name=metadata.get("name") or folder.resolve().name, folder=folder, world_path=world_path,
                     telemetry=telemetry, observations=observations, metadata=metadata, force=force)


def recording_world(recording: Recording, odb: ObjectDatabase) -> WorldState:
    """The recording's world state before, with the recording checked against it before anything is simulated:
    every observed object is in the world, and the telemetry drives the world's robot (no joint it lacks, none it
    needs missing, every position within the robot model's joint limits)."""
    world = load_world_state(recording.world_path, odb)
    if recording.observations is not None:
        unknown = [name for name in recording.observations.objects if name not in world.objects]
        if unknown:
            raise RecordingError(f"observed object {unknown[0]!r} is not in {recording.world_path}; objects: "
                                 f"{', '.join(world.objects)}", source=recording.observations.source,
                                 field=f"object {unknown[0]!r}")
    if world.robot is not None:
        spec = odb.get(world.robot.type).robot
        validate_telemetry(recording.telemetry, spec.joints, limits=spec.limits, model=spec.model.name)
    return world


def input_paths(folder: str | os.PathLike[str]) -> tuple[Path, ...]:
    """The files a recording folder is read from, by their usual names (an output must not overwrite them)."""
    folder = Path(folder)
    return tuple(folder / name for name in (WORLD_FILE, RECORDING_FILE, OBSERVATIONS_FILE, FORCE_FILE,
                                            *TELEMETRY_CANDIDATES))


def check_recording_folder(folder: str | os.PathLike[str], overwrite: bool = False) -> None:
    """Refuse, before any work, a recording folder that cannot be written: a file, or a folder that holds files
    when not `overwrite` (the hint names the command line's --overwrite and the Python argument)."""
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise RecordingError("cannot save a recording: the path is a file", source=str(folder))
    if folder.is_dir() and not overwrite and any(folder.iterdir()):
        raise RecordingError("folder is not empty; pass --overwrite (overwrite=True from Python) to replace its "
                             "recording", source=str(folder))


def save_recording(folder: str | os.PathLike[str], world: str | os.PathLike[str], telemetry: Telemetry,
                   observations: ObservedPoses | None = None, metadata: Mapping[str, Any] | None = None, *,
                   force: ObservedForce | None = None, overwrite: bool = False) -> Recording:
    """Write a recording folder and read it back. `world` is the world-state YAML text (a str) or a file to
    copy (a path object). Telemetry is written as telemetry.csv, observations as observed.csv, a force track as
    force.csv. The folder is written as a whole (`bridge.files.replace_folder`: built beside it, renamed into
    place), so an interrupted save leaves the old folder or none. An existing non-empty folder is refused unless
    `overwrite`; then its recording files are replaced and its other files (a scene file, notes) kept."""
    folder = Path(folder)
    src = str(folder)
    check_recording_folder(folder, overwrite)
    meta = _check_metadata(dict(metadata or {}), "metadata argument")
    for key in ("telemetry", "observations", "force", "telemetry_topic"):
        if key in meta:
            raise RecordingError(f"save_recording sets {key!r} itself; leave it out of the metadata",
                                 source="metadata argument", field=key)
    if meta.get("scene") is not None and not (folder / meta["scene"]).exists():
        raise RecordingError(f"scene file not found (paths are relative to the recording folder {src})",
                             source="metadata argument", field="scene")
    for name, given in ((OBSERVATIONS_FILE, observations), (FORCE_FILE, force)):
        if given is None and (folder / name).exists():
            raise RecordingError(f"{name} already exists and would be read back as this recording's "
                                 f"{'observations' if name == OBSERVATIONS_FILE else 'force'}; remove it or pass "
                                 f"{'observations' if name == OBSERVATIONS_FILE else 'force'}", source=src)
    world_text = _world_text(world)
    meta["telemetry"] = TELEMETRY_FILE
    if observations is not None:
        meta["observations"] = OBSERVATIONS_FILE
    if force is not None:
        meta["force"] = FORCE_FILE
    ordered = {key: meta[key] for key in FIELDS if key in meta}
    with replace_folder(folder, RecordingError) as new:
        write_atomic(new / WORLD_FILE, world_text, RecordingError)
        save_telemetry_csv(new / TELEMETRY_FILE, telemetry)
        if observations is not None:
            save_observations_csv(new / OBSERVATIONS_FILE, observations)
        if force is not None:
            save_force_csv(new / FORCE_FILE, force)
        write_atomic(new / RECORDING_FILE, yaml.safe_dump(ordered, sort_keys=False, allow_unicode=True),
                     RecordingError)
    return load_recording(folder)


def _load_metadata(path: Path) -> dict[str, Any]:
    if not path.exists():
        return {}
    data = read_yaml(path, "recording metadata", RecordingError)
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise RecordingError(f"must be a mapping of fields ({', '.join(FIELDS)}), got {type(data).__name__}",
                             source=str(path))
    return _check_metadata(data, str(path))


def _check_metadata(data: dict[Any, Any], src: str) -> dict[str, Any]:
    """Every field known and text (or empty); `src` names where the fields came from."""
    for key, value in data.items():
        if key not in FIELDS:
            raise RecordingError(f"unknown field; recording.yaml fields are {', '.join(FIELDS)}", source=src,
                                 field=str(key))
        if value is not None and not isinstance(value, str):
            raise RecordingError(f"must be text, got {type(value).__name__} {value!r}", source=src, field=key)
        if key in PATH_FIELDS + ("name",) and value is not None and not value.strip():
            raise RecordingError("must not be empty", source=src, field=key)
    return {key: value for key, value in data.items() if value is not None}


def _named_path(folder: Path, metadata: Mapping[str, Any], key: str) -> Path | None:
    """The file recording.yaml names under `key` (relative to the folder), checked to exist."""
    if metadata.get(key) is None:
        return None
    path = folder / metadata[key]
    if not path.exists():
        raise RecordingError(f"file {str(path)!r} not found (paths are relative to the recording folder)",
                             source=str(folder / RECORDING_FILE), field=key)
    return path


def _telemetry_path(folder: Path, metadata: Mapping[str, Any]) -> Path:
    named = _named_path(folder, metadata, "telemetry")
    if named is not None:
        return named
    found = [folder / name for name in TELEMETRY_CANDIDATES if (folder / name).exists()]
    if not found:
        looked = ", ".join(n if "." in n else f"{n}/ (ROS 2 bag folder)" for n in TELEMETRY_CANDIDATES)
        raise RecordingError(f"no telemetry found; looked for {looked} (or name the file "
                             f"in {RECORDING_FILE} as 'telemetry: <file>')", source=str(folder))
    if len(found) > 1:
        raise RecordingError(f"several telemetry files ({', '.join(p.name for p in found)}); name the one to use "
                             f"in {RECORDING_FILE} as 'telemetry: <file>'", source=str(folder))
    return found[0]


def _world_text(world: str | os.PathLike[str]) -> str:
    """World-state YAML text from text or a file, checked to be a YAML mapping (its meaning is checked later)."""
    if isinstance(world, os.PathLike):
        src = str(world)
        text = read_text(Path(world), "world state")
    elif isinstance(world, str):
        src, text = "world argument", world
    else:
        raise RecordingError(f"world must be YAML text or a path, got {type(world).__name__}")
    try:
        data = load_yaml_text(text)
    except yaml.YAMLError as err:
        raise yaml_error(err, src, RecordingError) from None
    if not isinstance(data, dict):
        raise RecordingError("world state must be a YAML mapping (pass a pathlib.Path to copy a file)", source=src)
    return text

"""Recording folders: save / load round trip, telemetry discovery and the errors for malformed folders."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from bridge.errors import RecordingError
from bridge.recording.observations import ObservedPoses, ObservedTrack
from bridge.recording.recording import Recording, load_recording, save_recording
from bridge.recording.telemetry import Telemetry
from bridge.values import Pose

WORLD = "objects:\n  box: {type: box, pose: {xyz: [0.5, 0, 0.8]}}\nfacts:\n  - (on box table)\n"
CSV = "t,shoulder,elbow\n0,0,0\n0.5,0.1,0.2\n1.0,0.2,0.4\n"


def make_telemetry() -> Telemetry:
    return Telemetry(np.array([0.0, 0.5, 1.0]), ("shoulder", "elbow"), np.array([[0, 0], [0.1, 0.2], [0.2, 0.4]]))


def make_observations() -> ObservedPoses:
    return ObservedPoses((ObservedTrack("box", np.array([0.0, 1.0]), (Pose((0.5, 0.0, 0.8)), Pose((0.6, 0.0, 0.8)))),))


def make_folder(tmp_path: Path, files: dict[str, str], name: str = "session") -> Path:
    folder = tmp_path / name
    folder.mkdir()
    for file, text in files.items():
        (folder / file).write_text(text)
    return folder


def test_save_and_load_round_trip(tmp_path):
    folder = tmp_path / "sessions" / "push_box"
    scene = tmp_path / "sessions" / "push_box" / "params.yaml"
    scene.parent.mkdir(parents=True)
    scene.write_text("friction: 0.4\n")
    meta = {"name": "push the box", "robot": "panda", "notes": "second try", "scene": "params.yaml"}
    rec = save_recording(folder, WORLD, make_telemetry(), make_observations(), meta, overwrite=True)
    assert isinstance(rec, Recording)
    assert rec.name == "push the box" and rec.robot == "panda" and rec.notes == "second try"
    assert rec.scene_path == scene and rec.world_path == folder / "world.yaml"
    assert rec.world_path.read_text() == WORLD
    np.testing.assert_array_equal(rec.telemetry.positions, make_telemetry().positions)
    assert rec.telemetry.joint_names == ("shoulder", "elbow")
    assert rec.observations is not None and rec.observations.final()["box"].xyz == (0.6, 0.0, 0.8)
    written = yaml.safe_load((folder / "recording.yaml").read_text())
    assert written == {**meta, "telemetry": "telemetry.csv", "observations": "observed.csv"}
    assert rec.metadata == written
    assert sorted(p.name for p in folder.iterdir()) == [
        "observed.csv", "params.yaml", "recording.yaml", "telemetry.csv", "world.yaml"]


def test_save_copies_a_world_file_and_refuses_a_full_folder(tmp_path):
    world = tmp_path / "before.yaml"
    world.write_text(WORLD)
    rec = save_recording(tmp_path / "rec", world, make_telemetry())
    assert rec.world_path.read_text() == WORLD and rec.observations is None and rec.name == "rec"
    with pytest.raises(RecordingError, match="not empty; pass --overwrite \\(overwrite=True from Python\\)"):
        save_recording(tmp_path / "rec", world, make_telemetry())
    again = save_recording(tmp_path / "rec", world, make_telemetry().shifted(1.0), overwrite=True)
    assert again.telemetry.t0 == 1.0


@pytest.mark.parametrize(
    "kwargs, fragments",
    [
        (dict(world="worlds/before.yaml"), ["world argument", "YAML mapping", "pathlib.Path"]),
        (dict(world="a: [1"), ["world argument", "YAML syntax error"]),
        (dict(metadata={"telemetry": "x.csv"}), ["telemetry", "sets 'telemetry' itself"]),
        (dict(metadata={"colour": "red"}), ["colour", "unknown field", "name, robot, telemetry"]),
        (dict(metadata={"robot": 3}), ["robot", "must be text"]),
        (dict(metadata={"scene": "fit.yaml"}), ["scene", "not found"]),
    ],
)
def test_save_errors(tmp_path, kwargs, fragments):
    args = dict(world=WORLD, telemetry=make_telemetry()) | kwargs
    with pytest.raises(RecordingError) as err:
        save_recording(tmp_path / "rec", **args)
    for fragment in fragments:
        assert fragment in str(err.value)
    assert not (tmp_path / "rec").exists()  # nothing written on a refused save


def test_save_refuses_to_leave_stale_observations(tmp_path):
    save_recording(tmp_path / "rec", WORLD, make_telemetry(), make_observations())
    with pytest.raises(RecordingError, match="observed.csv already exists"):
        save_recording(tmp_path / "rec", WORLD, make_telemetry(), overwrite=True)


def test_minimal_folder_finds_its_files(tmp_path):
    folder = make_folder(tmp_path, {"world.yaml": WORLD, "telemetry.csv": CSV})
    rec = load_recording(folder)
    assert rec.name == "session" and rec.metadata == {} and rec.observations is None and rec.robot is None
    assert rec.telemetry.source == str(folder / "telemetry.csv") and rec.scene_path is None
    (folder / "observed.csv").write_text("t,object,x,y,z,qw,qx,qy,qz\n0,box,0,0,0,1,0,0,0\n")
    assert load_recording(folder).observations.objects == ("box",)


def test_named_files_and_a_ros2_bag_folder(tmp_path):
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_typestore

    folder = make_folder(tmp_path, {
        "world.yaml": WORLD,
        "poses.csv": "t,object,x,y,z,qw,qx,qy,qz\n0,box,0,0,0,1,0,0,0\n",
        "recording.yaml": "telemetry_topic: /arm/joint_states\nobservations: poses.csv\n",
    })
    typestore = get_typestore(Stores.ROS2_HUMBLE)
    types = typestore.types
    with Writer(folder / "telemetry", version=9) as writer:
        for topic in ("/arm/joint_states", "/gripper/joint_states"):
            connection = writer.add_connection(topic, "sensor_msgs/msg/JointState", typestore=typestore)
            for k in range(3):
                stamp = types["builtin_interfaces/msg/Time"](sec=k + 1, nanosec=0)
                msg = types["sensor_msgs/msg/JointState"](
                    header=types["std_msgs/msg/Header"](stamp=stamp, frame_id=""), name=[topic.split("/")[1]],
                    position=np.array([0.1 * k]), velocity=np.array([]), effort=np.array([]))
                writer.write(connection, 10 + k, typestore.serialize_cdr(msg, "sensor_msgs/msg/JointState"))
    rec = load_recording(folder)
    assert rec.telemetry.joint_names == ("arm",)
    np.testing.assert_array_equal(rec.telemetry.times, [0.0, 1.0, 2.0])
    assert rec.observations.objects == ("box",)


@pytest.mark.parametrize(
    "files, fragments",
    [
        ({"telemetry.csv": CSV}, ["no world.yaml"]),
        ({"world.yaml": WORLD}, ["no telemetry found", "telemetry.csv, telemetry.mcap, telemetry/ (ROS 2 bag folder), telemetry.bag"]),
        ({"world.yaml": WORLD, "telemetry.csv": CSV, "telemetry.bag": "x"}, ["several telemetry files",
                                                                            "telemetry.csv, telemetry.bag"]),
        ({"world.yaml": WORLD, "telemetry.csv": CSV, "recording.yaml": "name: [a\n"},
         ["recording.yaml", "YAML syntax error", "line 2, column 1"]),
        ({"world.yaml": WORLD, "telemetry.csv": CSV, "recording.yaml": "- a\n"}, ["recording.yaml", "mapping"]),
        ({"world.yaml": WORLD, "telemetry.csv": CSV, "recording.yaml": "robt: panda\n"},
         ["recording.yaml: robt: unknown field", "name, robot, telemetry, telemetry_topic"]),
        ({"world.yaml": WORLD, "telemetry.csv": CSV, "recording.yaml": "notes: [1, 2]\n"},
         ["recording.yaml: notes: must be text"]),
        ({"world.yaml": WORLD, "telemetry.csv": CSV, "recording.yaml": "name: ''\n"},
         ["recording.yaml: name: must not"]),
        ({"world.yaml": WORLD, "recording.yaml": "telemetry: arm.csv\n"}, ["recording.yaml: telemetry", "arm.csv",
                                                                           "not found"]),
        ({"world.yaml": WORLD, "telemetry.csv": CSV, "recording.yaml": "observations: seen.csv\n"},
         ["recording.yaml: observations", "seen.csv", "not found"]),
        ({"world.yaml": WORLD, "telemetry.csv": CSV, "recording.yaml": "scene: fit.yaml\n"},
         ["recording.yaml: scene", "fit.yaml"]),
        ({"world.yaml": WORLD, "telemetry.csv": "t,a\n0,1\n"}, ["telemetry.csv", "at least 2"]),
        ({"world.yaml": WORLD, "telemetry.csv": CSV, "observed.csv": "t,object\n"}, ["observed.csv", "missing column"]),
    ],
)
def test_load_errors(tmp_path, files, fragments):
    folder = make_folder(tmp_path, files)
    with pytest.raises(RecordingError) as err:
        load_recording(folder)
    assert str(folder) in str(err.value)
    for fragment in fragments:
        assert fragment in str(err.value)


def test_missing_folder_or_a_file(tmp_path):
    with pytest.raises(RecordingError, match="recording folder not found"):
        load_recording(tmp_path / "absent")
    (tmp_path / "file.csv").write_text(CSV)
    with pytest.raises(RecordingError, match="is a folder holding world.yaml"):
        load_recording(tmp_path / "file.csv")

"""Telemetry values, the CSV reader/writer and the ROS bag reader (bags are written here with rosbags)."""
from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from bridge.errors import RecordingError
from bridge.recording.telemetry import (
    Telemetry,
    load_telemetry,
    load_telemetry_csv,
    load_telemetry_rosbag,
    save_telemetry_csv,
    validate_telemetry,
)


def make_telemetry(**overrides) -> Telemetry:
    values = dict(times=np.array([0.0, 1.0, 3.0]), joint_names=("j1", "j2"),
                  positions=np.array([[0.0, 10.0], [1.0, 20.0], [3.0, 0.0]]), source="mem.csv")
    values.update(overrides)
    return Telemetry(**values)


def write(tmp_path: Path, text: str, name: str = "tel.csv") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def message(err: pytest.ExceptionInfo) -> str:
    return str(err.value)


# --- the value ------------------------------------------------------------------------------------------------
def test_sample_interpolates_linearly_and_holds_the_ends():
    tel = make_telemetry()
    np.testing.assert_allclose(tel.sample(0.5), [0.5, 15.0])
    np.testing.assert_allclose(tel.sample(2.0), [2.0, 10.0])
    np.testing.assert_array_equal(tel.sample(1.0), [1.0, 20.0])
    np.testing.assert_array_equal(tel.sample(-5.0), [0.0, 10.0])
    np.testing.assert_array_equal(tel.sample(99.0), [3.0, 0.0])
    np.testing.assert_allclose(tel.sample(np.array([0.0, 0.5, 3.0])), [[0.0, 10.0], [0.5, 15.0], [3.0, 0.0]])
    assert tel.duration == 3.0 and len(tel) == 3


def test_sample_rejects_nan_time():
    with pytest.raises(RecordingError, match="cannot sample"):
        make_telemetry().sample(float("nan"))


def test_arrays_are_read_only_copies():
    times = np.array([0.0, 1.0])
    tel = make_telemetry(times=times, positions=np.zeros((2, 2)))
    times[1] = 5.0
    assert tel.times[1] == 1.0
    with pytest.raises(ValueError):
        tel.positions[0, 0] = 1.0


def test_select_reorders_and_subsets():
    tel = make_telemetry()
    swapped = tel.select(["j2", "j1"])
    assert swapped.joint_names == ("j2", "j1")
    np.testing.assert_array_equal(swapped.positions[:, 0], tel.positions[:, 1])
    assert tel.select(["j2"]).positions.shape == (3, 1)
    with pytest.raises(RecordingError) as err:
        tel.select(["j1", "elbow"])
    assert "'elbow'" in message(err) and "'j1', 'j2'" in message(err) and "mem.csv" in message(err)


def test_shifted_delays_every_sample():
    tel = make_telemetry()
    late = tel.shifted(0.25)
    np.testing.assert_allclose(late.times, tel.times + 0.25)
    np.testing.assert_allclose(late.sample(0.75), tel.sample(0.5))
    np.testing.assert_array_equal(tel.times, [0.0, 1.0, 3.0])  # the input is untouched


def test_with_offsets_adds_per_joint_constants():
    tel = make_telemetry()
    moved = tel.with_offsets({"j2": 0.5})
    np.testing.assert_allclose(moved.positions[:, 1], tel.positions[:, 1] + 0.5)
    np.testing.assert_array_equal(moved.positions[:, 0], tel.positions[:, 0])
    with pytest.raises(RecordingError, match="'wrist'"):
        tel.with_offsets({"wrist": 0.1})


@pytest.mark.parametrize(
    "overrides, fragment",
    [
        (dict(positions=np.zeros((2, 2))), "shape (2, 2)"),
        (dict(times=np.array([0.0, 2.0, 1.0])), "times must increase"),
        (dict(joint_names=("j1", "j1")), "'j1' appears twice"),
        (dict(joint_names=("j1", "")), "non-empty"),
        (dict(positions=np.array([[0.0, np.nan], [1.0, 2.0], [3.0, 4.0]])), "NaN"),
    ],
)
def test_constructor_checks(overrides, fragment):
    with pytest.raises(RecordingError) as err:
        make_telemetry(**overrides)
    assert fragment in message(err)


def test_validate_telemetry_names_unknown_joint_file_and_robot_joints():
    tel = make_telemetry()
    validate_telemetry(tel, ["j1", "j2"])
    with pytest.raises(RecordingError) as err:
        validate_telemetry(tel, ["j1", "j3"], required=["j1"])
    text = message(err)
    assert "'j2'" in text and "mem.csv" in text and "'j1', 'j3'" in text


def test_validate_telemetry_names_missing_joint():
    tel = make_telemetry()
    with pytest.raises(RecordingError) as err:
        validate_telemetry(tel, ["j1", "j2", "j3"])
    assert "lacks joint 'j3'" in message(err) and "mem.csv" in message(err)
    validate_telemetry(tel, ["j1", "j2", "j3"], required=["j1", "j2"])  # j3 is optional here


# --- CSV ------------------------------------------------------------------------------------------------------
def test_csv_round_trip(tmp_path):
    tel = make_telemetry(times=np.array([0.0, 0.1, 0.30000000000000004]),
                         positions=np.array([[0.1, -1e-7], [1 / 3, 2.5], [np.pi, -np.e]]))
    path = tmp_path / "out" / "tel.csv"
    save_telemetry_csv(path, tel)
    back = load_telemetry_csv(path)
    assert back.joint_names == tel.joint_names and back.source == str(path) and back.t0 == 0.0
    np.testing.assert_array_equal(back.times, tel.times)
    np.testing.assert_array_equal(back.positions, tel.positions)
    assert [p.name for p in path.parent.iterdir()] == ["tel.csv"]  # no temporary file left behind


def test_csv_starts_at_zero_and_keeps_the_offset(tmp_path):
    path = write(tmp_path, "# exported from the arm\ntime, shoulder ,elbow\n\n100.5,0,1\n101.0,0.5,1.5\n")
    tel = load_telemetry(path)
    assert tel.joint_names == ("shoulder", "elbow") and tel.t0 == 100.5
    np.testing.assert_array_equal(tel.times, [0.0, 0.5])
    np.testing.assert_array_equal(tel.positions, [[0.0, 1.0], [0.5, 1.5]])


@pytest.mark.parametrize(
    "text, fragments",
    [
        ("", ["telemetry file is empty"]),
        ("\n  \n", ["telemetry file is empty"]),
        ("# only a comment\n", ["no header"]),
        ("a,b\n0,1\n1,2\n", ["line 1, column 1", "'t' or 'time'", "'a'"]),
        ("t\n0\n1\n", ["line 1", "no joint columns"]),
        ("t,a,a\n0,1,2\n1,2,3\n", ["line 1, column 3", "'a' repeats column 2"]),
        ("t,a,\n0,1,2\n1,2,3\n", ["line 1, column 3", "no name"]),
        ("t,a,b\n0,1,2\n0.1,abc,2\n", ["line 3, column 2 ('a')", "'abc' is not a number"]),
        ("t,a,b\n0,1,2\n0.1,1,\n", ["line 3, column 3 ('b')", "empty value"]),
        ("t,a,b\n0,1,nan\n0.1,1,2\n", ["line 2, column 3 ('b')", "not finite"]),
        ("t,a,b\n0,1,2\n0.1,-inf,2\n", ["line 3, column 2 ('a')", "not finite"]),
        ("t,a,b\n0,1,2\n0.2,1,2\n0.1,1,2\n", ["line 4, column 1 ('t')", "earlier than time 0.2 on line 3"]),
        ("t,a,b\n0,1,2\n# pause\n0,1,2\n", ["line 4, column 1 ('t')", "repeats time 0 on line 2"]),
        ("t,a,b\n0,1,2\n", ["1 sample row(s)", "at least 2"]),
        ("t,a,b\n0,1,2\n0.1,1\n", ["line 3", "2 values", "header (line 1) has 3 columns"]),
        ("t,a,b\n0,1,2\n0.1,1,2,3\n", ["line 3", "4 values"]),
    ],
)
def test_csv_errors_name_file_line_and_column(tmp_path, text, fragments):
    path = write(tmp_path, text)
    with pytest.raises(RecordingError) as err:
        load_telemetry_csv(path)
    assert str(path) in message(err)
    for fragment in fragments:
        assert fragment in message(err)


def test_csv_missing_file(tmp_path):
    with pytest.raises(RecordingError) as err:
        load_telemetry_csv(tmp_path / "nope.csv")
    assert "not found" in message(err) and "nope.csv" in message(err)


def test_load_telemetry_rejects_unknown_formats(tmp_path):
    with pytest.raises(RecordingError) as err:
        load_telemetry(write(tmp_path, "x", "tel.txt"))
    assert "'.txt'" in message(err) and ".csv" in message(err) and ".mcap" in message(err)
    with pytest.raises(RecordingError, match="not found"):
        load_telemetry(tmp_path / "absent.txt")
    (tmp_path / "folder").mkdir()
    with pytest.raises(RecordingError, match="no metadata.yaml"):
        load_telemetry(tmp_path / "folder")


# --- ROS bags -------------------------------------------------------------------------------------------------
# (topic, log time ns, header stamp ns, joint names, positions)
Msg = tuple[str, int, int, tuple[str, ...], tuple[float, ...]]

ARM = ("shoulder", "elbow")
STAMPED: list[Msg] = [
    ("/joint_states", 1_000, 1_700_000_000 * 10**9, ARM, (0.0, 1.0)),
    ("/joint_states", 2_000, 1_700_000_000 * 10**9 + 10_000_000, ("elbow", "shoulder"), (1.5, 0.5)),
    ("/joint_states", 3_000, 1_700_000_000 * 10**9 + 30_000_000, ARM, (1.0, 2.0)),
]


def _joint_state(typestore, stamp_ns: int, names, positions, ros1: bool):
    types = typestore.types
    stamp = types["builtin_interfaces/msg/Time"](sec=stamp_ns // 10**9, nanosec=stamp_ns % 10**9)
    header = (types["std_msgs/msg/Header"](seq=0, stamp=stamp, frame_id="") if ros1
              else types["std_msgs/msg/Header"](stamp=stamp, frame_id=""))
    empty = np.array([], dtype=float)
    return types["sensor_msgs/msg/JointState"](header=header, name=list(names),
                                               position=np.array(positions, dtype=float), velocity=empty, effort=empty)


def write_ros2_bag(path: Path, messages: list[Msg], storage: str = "sqlite3", extra_topics=()) -> Path:
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    typestore = get_typestore(Stores.ROS2_HUMBLE)
    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    with Writer(path, version=9, storage_plugin=plugin) as writer:
        connections = {}
        for topic in dict.fromkeys(m[0] for m in messages):
            connections[topic] = writer.add_connection(topic, "sensor_msgs/msg/JointState", typestore=typestore)
        for topic, msgtype in extra_topics:
            writer.add_connection(topic, msgtype, typestore=typestore)
        for topic, log_ns, stamp_ns, names, positions in messages:
            msg = _joint_state(typestore, stamp_ns, names, positions, ros1=False)
            writer.write(connections[topic], log_ns, typestore.serialize_cdr(msg, "sensor_msgs/msg/JointState"))
    return path


def write_ros1_bag(path: Path, messages: list[Msg]) -> Path:
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_typestore

    typestore = get_typestore(Stores.ROS1_NOETIC)
    with Writer(path) as writer:
        connections = {}
        for topic in dict.fromkeys(m[0] for m in messages):
            connections[topic] = writer.add_connection(topic, "sensor_msgs/msg/JointState", typestore=typestore)
        for topic, log_ns, stamp_ns, names, positions in messages:
            msg = _joint_state(typestore, stamp_ns, names, positions, ros1=True)
            writer.write(connections[topic], log_ns, typestore.serialize_ros1(msg, "sensor_msgs/msg/JointState"))
    return path


def check_stamped(tel: Telemetry) -> None:
    assert tel.joint_names == ARM
    np.testing.assert_allclose(tel.times, [0.0, 0.01, 0.03], atol=1e-12)
    np.testing.assert_array_equal(tel.positions, [[0.0, 1.0], [0.5, 1.5], [1.0, 2.0]])
    assert tel.t0 == 1_700_000_000.0


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_ros2_bag_uses_header_stamps_and_reorders_joints(tmp_path, storage):
    bag = write_ros2_bag(tmp_path / "bag", STAMPED, storage)
    tel = load_telemetry(bag)
    check_stamped(tel)
    assert tel.source == str(bag)


def test_bare_mcap_and_db3_files(tmp_path):
    for storage, suffix in (("mcap", ".mcap"), ("sqlite3", ".db3")):
        bag = write_ros2_bag(tmp_path / f"bag_{storage}", STAMPED, storage)
        bare = tmp_path / f"telemetry{suffix}"
        shutil.move(next(bag.glob(f"*{suffix}")), bare)
        check_stamped(load_telemetry(bare))


def test_ros1_bag_without_stamps_uses_log_times(tmp_path):
    messages = [("/joint_states", 5 * 10**9 + k * 20_000_000, 0, ARM, (k, -k)) for k in range(4)]
    tel = load_telemetry(write_ros1_bag(tmp_path / "arm.bag", messages))
    assert tel.joint_names == ARM and tel.t0 == 5.0
    np.testing.assert_allclose(tel.times, [0.0, 0.02, 0.04, 0.06], atol=1e-12)
    np.testing.assert_array_equal(tel.positions[:, 1], [0, -1, -2, -3])


def test_stamps_out_of_log_order_are_sorted(tmp_path):
    messages = [STAMPED[0], (*STAMPED[2][:1], 2_000, *STAMPED[2][2:]), (*STAMPED[1][:1], 3_000, *STAMPED[1][2:])]
    check_stamped(load_telemetry(write_ros2_bag(tmp_path / "bag", messages)))


def test_several_joint_state_topics_need_a_choice(tmp_path):
    messages = STAMPED + [("/gripper/joint_states", 1_500 + k, 10**9 + k, ("finger",), (0.01,)) for k in range(2)]
    bag = write_ros2_bag(tmp_path / "bag", messages)
    with pytest.raises(RecordingError) as err:
        load_telemetry(bag)
    assert "'/gripper/joint_states', '/joint_states'" in message(err) and str(bag) in message(err)
    check_stamped(load_telemetry(bag, topic="/joint_states"))
    assert load_telemetry_rosbag(bag, "/gripper/joint_states").joint_names == ("finger",)


def test_topic_errors_list_the_joint_state_topics(tmp_path):
    bag = write_ros2_bag(tmp_path / "bag", STAMPED, extra_topics=[("/tf", "tf2_msgs/msg/TFMessage")])
    with pytest.raises(RecordingError) as err:
        load_telemetry(bag, topic="/tf")
    assert "'/tf' carries tf2_msgs/msg/TFMessage" in message(err) and "'/joint_states'" in message(err)
    with pytest.raises(RecordingError) as err:
        load_telemetry(bag, topic="/arm")
    assert "no topic '/arm'" in message(err) and "'/joint_states'" in message(err)


def test_bag_without_joint_states_lists_its_topics(tmp_path):
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_typestore

    bag = tmp_path / "bag"
    with Writer(bag, version=9) as writer:
        writer.add_connection("/tf", "tf2_msgs/msg/TFMessage", typestore=get_typestore(Stores.ROS2_HUMBLE))
    with pytest.raises(RecordingError) as err:
        load_telemetry(bag)
    assert "no sensor_msgs/msg/JointState topic" in message(err) and "'/tf' (tf2_msgs/msg/TFMessage)" in message(err)


def test_message_with_other_joints_is_named(tmp_path):
    messages = STAMPED[:2] + [("/joint_states", 3_000, 1_700_000_001 * 10**9, ("shoulder", "wrist"), (1.0, 2.0))]
    bag = write_ros2_bag(tmp_path / "bag", messages)
    with pytest.raises(RecordingError) as err:
        load_telemetry(bag)
    text = message(err)
    assert "message 3" in text and "'wrist'" in text and "same joints" in text and str(bag) in text


def test_mixed_stamps_and_duplicate_times_are_errors(tmp_path):
    mixed = [STAMPED[0], ("/joint_states", 2_000, 0, ARM, (0.0, 1.0)), STAMPED[2]]
    with pytest.raises(RecordingError, match="message 2 has no header stamp"):
        load_telemetry(write_ros1_bag(tmp_path / "mixed.bag", mixed))
    twice = [STAMPED[0], (*STAMPED[1][:2], STAMPED[0][2], *STAMPED[1][3:])]
    with pytest.raises(RecordingError, match="messages 1 and 2 have the same time"):
        load_telemetry(write_ros2_bag(tmp_path / "twice", twice))


def test_too_few_messages_and_non_finite_positions(tmp_path):
    with pytest.raises(RecordingError, match="1 JointState message"):
        load_telemetry(write_ros2_bag(tmp_path / "one", STAMPED[:1]))
    bad = STAMPED[:2] + [(*STAMPED[2][:4], (np.nan, 1.0))]
    with pytest.raises(RecordingError) as err:
        load_telemetry(write_ros2_bag(tmp_path / "nan", bad))
    assert "message 3" in message(err) and "'shoulder'" in message(err) and "not finite" in message(err)


def test_broken_bags_become_recording_errors(tmp_path):
    for name in ("broken.bag", "broken.mcap", "broken.db3"):
        path = write(tmp_path, "not a bag at all\n", name)
        with pytest.raises(RecordingError) as err:
            load_telemetry(path)
        assert str(path) in message(err) and "cannot read ROS bag" in message(err)
    with pytest.raises(RecordingError, match="not found"):
        load_telemetry_rosbag(tmp_path / "absent.bag")

"""Observed object poses: tracks, interpolation, the CSV reader/writer and its errors."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from bridge.errors import RecordingError
from bridge.recording.observations import (
    ObservedPoses,
    ObservedTrack,
    load_observations_csv,
    save_observations_csv,
    slerp,
)
from bridge.values import Pose

HEADER = "t,object,x,y,z,qw,qx,qy,qz\n"
QZ90 = (math.cos(math.pi / 4), 0.0, 0.0, math.sin(math.pi / 4))  # 90 degrees about z

SPARSE = HEADER + (
    "0,box,0.1,0.2,0.3,1,0,0,0\n"
    "0,mug,0.5,0,0.8,1,0,0,0\n"
    f"4,box,0.3,0.2,0.3,{QZ90[0]},0,0,{QZ90[3]}\n"
    "4,mug,0.5,0,0.8,1,0,0,0\n"
)


def write(tmp_path: Path, text: str, name: str = "observed.csv") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def test_sparse_observations(tmp_path):
    observed = load_observations_csv(write(tmp_path, SPARSE), known_objects={"box", "mug", "table"})
    assert observed.objects == ("box", "mug") and not observed.is_dense and len(observed) == 2
    assert "box" in observed and "table" not in observed and observed.get("table") is None
    assert observed.initial()["box"].xyz == (0.1, 0.2, 0.3)
    final = observed.final()
    assert final["box"].xyz == (0.3, 0.2, 0.3)
    assert final["box"].yaw() == pytest.approx(math.pi / 2)
    middle = observed.at(2.0)["box"]
    assert middle.xyz == pytest.approx((0.2, 0.2, 0.3))
    assert middle.yaw() == pytest.approx(math.pi / 4)
    assert observed.at(1.0, nearest=True)["box"].xyz == (0.1, 0.2, 0.3)
    assert observed.at(-1.0)["box"] == observed.initial()["box"]
    assert observed.at(10.0)["box"] == final["box"]
    assert observed.source.endswith("observed.csv")


def test_dense_observations_and_column_order(tmp_path):
    rows = "".join(f"{0.1 * k},{0.01 * k},0,0,box,0,0,0,1\n" for k in range(5))
    observed = load_observations_csv(write(tmp_path, "time,x,y,z,object,qx,qy,qz,qw\n" + rows))
    assert observed.is_dense
    track = observed.track("box")
    assert len(track) == 5 and track.final().xyz == (0.04, 0.0, 0.0)
    np.testing.assert_allclose(track.times, [0.0, 0.1, 0.2, 0.3, 0.4])


def test_nearly_unit_quaternion_is_normalised(tmp_path):
    observed = load_observations_csv(write(tmp_path, HEADER + "0,box,0,0,0,1.0005,0,0,0\n"))
    assert observed.final()["box"].quat == (1.0, 0.0, 0.0, 0.0)


def test_round_trip(tmp_path):
    track = ObservedTrack("box", np.array([0.0, 0.5, 1.25]),
                          (Pose((0.1, 0.2, 0.3)), Pose.from_rpy((1 / 3, 0.0, 0.7), (0.1, -0.2, 2.0)), Pose()))
    observed = ObservedPoses((track, ObservedTrack("mug, blue", np.array([0.0]), (Pose((1.0, 2.0, 3.0)),))))
    path = tmp_path / "sub" / "observed.csv"
    save_observations_csv(path, observed)
    back = load_observations_csv(path)
    assert back.objects == ("box", "mug, blue")
    for a, b in zip(observed, back):
        np.testing.assert_array_equal(a.times, b.times)
        assert a.poses == b.poses
    assert [p.name for p in path.parent.iterdir()] == ["observed.csv"]


def test_slerp_halfway_and_shorter_arc():
    half = slerp((1.0, 0.0, 0.0, 0.0), QZ90, 0.5)
    assert Pose(quat=half).yaw() == pytest.approx(math.pi / 4)
    flipped = slerp((1.0, 0.0, 0.0, 0.0), tuple(-v for v in QZ90), 0.5)
    assert Pose(quat=flipped).yaw() == pytest.approx(math.pi / 4)


def test_values_check_themselves():
    with pytest.raises(RecordingError, match="strictly increasing"):
        ObservedTrack("box", np.array([1.0, 0.0]), (Pose(), Pose()))
    with pytest.raises(RecordingError, match="one time per pose"):
        ObservedTrack("box", np.array([0.0]), (Pose(), Pose()))
    track = ObservedTrack("box", np.array([0.0]), (Pose(),))
    with pytest.raises(RecordingError, match="'box' has two tracks"):
        ObservedPoses((track, track))
    with pytest.raises(RecordingError) as err:
        ObservedPoses((track,), source="obs.csv").track("mug")
    assert "'mug' was not observed" in str(err.value) and "box" in str(err.value)


@pytest.mark.parametrize(
    "text, fragments",
    [
        ("", ["observations file is empty"]),
        ("t,object,x,y,z,qw,qx,qy\n", ["line 1", "missing column 'qz'", "t, object, x, y, z, qw, qx, qy, qz"]),
        ("t,object,x,y,z,roll,qw,qx,qy,qz\n", ["line 1, column 6", "unknown column 'roll'"]),
        ("t,object,x,y,z,qw,qx,qy,qz,x\n", ["line 1, column 10", "'x' repeats column 3"]),
        (HEADER, ["no observation rows"]),
        (HEADER + "0,bx,0,0,0,1,0,0,0\n", ["line 2, column 2 ('object')", "unknown object 'bx'", "box, mug"]),
        (HEADER + "0,,0,0,0,1,0,0,0\n", ["line 2, column 2", "empty object name"]),
        (HEADER + "0,box,0,nan,0,1,0,0,0\n", ["line 2, column 4 ('y')", "not finite"]),
        (HEADER + "0,box,0,0,0,1,0,0,one\n", ["line 2, column 9 ('qz')", "'one' is not a number"]),
        (HEADER + "0,box,0,0,0,1,0,0,0.1\n", ["line 2", "norm 1.004988", "unit quaternion"]),
        (HEADER + "0,box,0,0,0,0,0,0,0\n", ["line 2", "norm 0.000000"]),
        (HEADER + "1,box,0,0,0,1,0,0,0\n0,mug,0,0,0,1,0,0,0\n0.5,box,0,0,0,1,0,0,0\n",
         ["line 4, column 1 ('t')", "0.5 for 'box' is earlier than its time 1 on line 2"]),
        (HEADER + "1,box,0,0,0,1,0,0,0\n1,box,0,0,0,1,0,0,0\n", ["line 3", "repeats its time 1 on line 2"]),
        (HEADER + "0,box,0,0,0,1,0,0\n", ["line 2", "8 values", "9 columns"]),
    ],
)
def test_csv_errors(tmp_path, text, fragments):
    path = write(tmp_path, text)
    with pytest.raises(RecordingError) as err:
        load_observations_csv(path, known_objects=["box", "mug"])
    assert str(path) in str(err.value)
    for fragment in fragments:
        assert fragment in str(err.value)


def test_missing_file(tmp_path):
    with pytest.raises(RecordingError, match="observations file not found"):
        load_observations_csv(tmp_path / "observed.csv")

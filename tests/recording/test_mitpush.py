"""Reader for the MIT planar pushing h5 files: names, resampling, malformed input, frame offsets."""
from __future__ import annotations

import math
from pathlib import Path

import h5py
import numpy as np
import pytest

from bridge.errors import RecordingError
from bridge.recording.mitpush import (
    PushRecording, PushSpec, estimate_frame_yaw, find_mit_push_root, frame_yaw_cost, load_outline, load_push,
    mesh_path, parse_push_name)

NAME = "motion_surface=abs_shape=rect1_a=0_v=75_i=2.000_s=0.700_t=-1.047.h5"
JITTERY = "motion_surface=abs_shape=ellip1_a=0_v=100_i=0.000_s=0.075_t=0.349.h5"  # object_pose row 233 steps back


def write_push(path: Path, **datasets: np.ndarray) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    with h5py.File(path, "w") as h5:
        for name, data in datasets.items():
            h5.create_dataset(name, data=np.asarray(data, dtype=float))
    return path


def stream(times, *columns) -> np.ndarray:
    return np.column_stack([times, *columns])


def good_streams(n: int = 50) -> dict[str, np.ndarray]:
    t0 = 1.46e9
    t_obj = t0 + 0.004 * np.arange(n)
    t_tip = t0 - 0.001 + 0.0041 * np.arange(n + 2)
    return {
        "object_pose": stream(t_obj, 0.3 + 0.1 * (t_obj - t0), np.full(n, -0.05), np.linspace(0, 0.2, n)),
        "tip_pose": stream(t_tip, 0.25 + 0.1 * (t_tip - t0), 0.01 * (t_tip - t0), np.zeros(n + 2)),
        "ft_wrench": stream(t_obj + 0.0005, np.full(n, 2.0) + np.arange(n) * 0.01, np.zeros(n), np.zeros(n)),
    }


# --- names -----------------------------------------------------------------------------------------------
def test_parse_push_name_reads_every_field():
    spec = parse_push_name(Path("/data/train") / NAME)
    assert spec == PushSpec(surface="abs", shape="rect1", a=0.0, v=75.0, i=2, s=0.7, t=-1.047)


@pytest.mark.parametrize("name", [
    "push.h5",
    "motion_surface=abs_shape=rect1_a=0_v=75_i=2.000_s=0.700.h5",
    "motion_surface=abs_shape=rect1_a=0_v=75_i=2.000_s=0.700_t=-1.047.hdf5",
    "motion_surface=abs_shape=rect1_a=0_v=75_i=2.500_s=0.700_t=-1.047.h5",
    "motion_surface=abs_shape=rect1_a=0_v=75_i=2.000_s=1.700_t=-1.047.h5",
])
def test_parse_push_name_rejects_other_names_naming_the_file(name):
    with pytest.raises(RecordingError) as info:
        parse_push_name(name)
    assert name in str(info.value)


# --- real files ------------------------------------------------------------------------------------------
def test_load_a_real_file(mit_push_root):
    rec = load_push(mit_push_root / "train" / NAME)
    n = len(rec)
    assert rec.spec.shape == "rect1" and rec.path.name == NAME
    assert rec.t.shape == (n,) and rec.tip_xy.shape == (n, 2) and rec.object_pose.shape == (n, 3)
    assert rec.wrench is not None and rec.wrench.shape == (n, 3)
    assert rec.t[0] == 0.0 and np.all(np.diff(rec.t) > 0) and 1.0 < rec.duration < 1.4
    assert 280 < n < 310  # ~250 Hz over ~1.2 s
    assert np.all(np.abs(np.diff(rec.object_pose[:, 2])) < 0.1)  # unwrapped, no 2 pi jumps
    # the rod starts next to the 90 mm square: within its half-diagonal plus the rod's radius
    assert np.linalg.norm(rec.tip_xy[0] - rec.object_pose[0, :2]) < 0.045 * math.sqrt(2) + 0.005
    with pytest.raises(ValueError):
        rec.tip_xy[0, 0] = 1.0  # read-only


def test_max_duration_cuts_the_recording(mit_push_root):
    rec = load_push(mit_push_root / "train" / NAME, max_duration=0.5)
    assert 0.48 < rec.duration <= 0.5


def test_clock_jitter_in_real_files_is_repaired_and_reported(mit_push_root):
    rec = load_push(mit_push_root / "train" / JITTERY)
    assert rec.repairs == ("object_pose: dropped row 233 (timestamp 0.112 ms behind an earlier row)",)
    assert np.all(np.diff(rec.t) > 0)


def test_every_bundled_file_loads(mit_push_root):
    files = sorted((mit_push_root / "train").glob("*.h5"))
    assert len(files) >= 50
    for path in files:
        rec = load_push(path)
        assert len(rec) > 200 and np.all(np.diff(rec.t) > 0)


def test_outlines_and_meshes(mit_push_root):
    outline = load_outline("rect1", mit_push_root)
    np.testing.assert_allclose(np.abs(outline), 0.045)
    assert load_outline("hex", mit_push_root).shape == (6, 2)
    assert mesh_path("ellip3", mit_push_root) == mit_push_root / "obj" / "ellip3.obj"
    with pytest.raises(RecordingError, match=r"no _ext.npy file for shape 'star'; shapes: .*rect1"):
        load_outline("star", mit_push_root)
    with pytest.raises(RecordingError, match=r"shape must be a name"):
        mesh_path("../rect1", mit_push_root)


# --- resampling on synthetic files -----------------------------------------------------------------------
def test_streams_are_resampled_onto_the_object_timestamps(tmp_path):
    data = good_streams()
    rec = load_push(write_push(tmp_path / NAME, **data))
    obj = data["object_pose"]
    # the tip stream starts 1 ms before the object's and ends later: every object sample is kept
    assert len(rec) == len(obj) - 1  # the wrench starts 0.5 ms late, so the first object sample is outside
    assert rec.start_time == obj[1, 0]
    np.testing.assert_allclose(rec.t, obj[1:, 0] - obj[1, 0])
    # tip x = 0.25 + 0.1 (t - t0), y = 0.01 (t - t0): linear, so interpolation is exact
    elapsed = obj[1:, 0] - 1.46e9
    np.testing.assert_allclose(rec.tip_xy, np.column_stack([0.25 + 0.1 * elapsed, 0.01 * elapsed]), atol=1e-9)
    np.testing.assert_allclose(rec.object_pose, obj[1:, 1:])
    np.testing.assert_allclose(rec.wrench[:, 0], 2.0 + (elapsed - 0.0005) / 0.004 * 0.01, atol=1e-6)


def test_yaw_is_unwrapped_before_interpolation(tmp_path):
    data = good_streams()
    yaw = np.linspace(3.0, 3.4, len(data["object_pose"]))
    data["object_pose"][:, 3] = np.angle(np.exp(1j * yaw))  # crosses +pi -> -pi in the file
    rec = load_push(write_push(tmp_path / NAME, **data))
    np.testing.assert_allclose(rec.object_pose[:, 2], yaw[1:], atol=1e-9)


def test_constant_or_absent_wrench_is_none(tmp_path):
    data = good_streams()
    data["ft_wrench"][:, 1:] = [0.5, -0.2, 0.0]
    assert load_push(write_push(tmp_path / "a" / NAME, **data)).wrench is None
    del data["ft_wrench"]
    assert load_push(write_push(tmp_path / "b" / NAME, **data)).wrench is None


# --- malformed files -------------------------------------------------------------------------------------
def expect_error(path: Path, *fragments: str) -> str:
    with pytest.raises(RecordingError) as info:
        load_push(path)
    message = str(info.value)
    assert str(path) in message
    for fragment in fragments:
        assert fragment in message, message
    return message


def test_text_file_renamed_h5(tmp_path):
    path = tmp_path / NAME
    path.write_text("time,x,y\n0,1,2\n")
    expect_error(path, "not an HDF5 file")


def test_truncated_copy_of_a_real_file(tmp_path, mit_push_root):
    data = (mit_push_root / "train" / NAME).read_bytes()
    path = tmp_path / NAME
    path.write_bytes(data[: len(data) // 2])
    expect_error(path, "truncated HDF5 file", f"{len(data) // 2} of {len(data)} bytes")


def test_missing_file(tmp_path):
    expect_error(tmp_path / NAME, "no such file")


def test_missing_object_pose(tmp_path):
    data = good_streams()
    del data["object_pose"]
    expect_error(write_push(tmp_path / NAME, **data), "object_pose", "missing dataset", "ft_wrench, tip_pose")


def test_n_by_3_array(tmp_path):
    data = good_streams()
    data["tip_pose"] = data["tip_pose"][:, :3]
    expect_error(write_push(tmp_path / NAME, **data), "tip_pose", "shape (52, 3)", "expected N x 4")


def test_nan_row(tmp_path):
    data = good_streams()
    data["object_pose"][7, 2] = np.nan
    expect_error(write_push(tmp_path / NAME, **data), "object_pose", "row 7", "non-finite y")


def test_infinite_time(tmp_path):
    data = good_streams()
    data["ft_wrench"][3, 0] = np.inf
    expect_error(write_push(tmp_path / NAME, **data), "ft_wrench", "row 3", "non-finite time")


def test_non_monotonic_time(tmp_path):
    data = good_streams()
    data["object_pose"][20, 0] -= 0.05  # 50 ms back: rows out of order, not clock jitter
    expect_error(write_push(tmp_path / NAME, **data), "object_pose", "not increasing", "row 20")


def test_duplicated_time(tmp_path):
    data = good_streams()
    data["tip_pose"][11, 0] = data["tip_pose"][10, 0]
    expect_error(write_push(tmp_path / NAME, **data), "tip_pose", "row 11", "repeats timestamp")


def test_fewer_than_two_rows(tmp_path):
    data = good_streams()
    data["tip_pose"] = data["tip_pose"][:1]
    expect_error(write_push(tmp_path / NAME, **data), "tip_pose", "1 row(s), need at least 2")


def test_streams_that_do_not_overlap(tmp_path):
    data = good_streams()
    data["tip_pose"][:, 0] += 10.0
    expect_error(write_push(tmp_path / NAME, **data), "do not overlap in time", "tip_pose", "object_pose")


def test_bad_file_name_is_reported_before_reading(tmp_path):
    # a dataset name with a bad value is refused before the file is opened (which does not exist here) ...
    expect_error(tmp_path / NAME.replace("s=0.700", "s=1.700"), "contact position s=1.700 is outside 0..1")
    # ... another name is read, and refused when nothing names the shape
    path = write_push(tmp_path / "push.h5", **good_streams())
    expect_error(path, "does not follow the dataset's pattern", "--shape")


# --- dataset folder --------------------------------------------------------------------------------------
def test_find_root_prefers_explicit_then_environment(tmp_path, monkeypatch):
    explicit, env = tmp_path / "explicit", tmp_path / "env"
    explicit.mkdir()
    env.mkdir()
    monkeypatch.setenv("BRIDGE_MIT_PUSH", str(env))
    assert find_mit_push_root(explicit) == explicit
    assert find_mit_push_root() == env
    monkeypatch.setenv("BRIDGE_MIT_PUSH", str(tmp_path / "nowhere"))
    with pytest.raises(RecordingError, match=r"\$BRIDGE_MIT_PUSH .*nowhere is not a folder"):
        find_mit_push_root()
    with pytest.raises(RecordingError, match=r"dataset folder .*missing is not a folder"):
        find_mit_push_root(tmp_path / "missing")


def test_default_root_is_beside_the_repository(mit_push_root, monkeypatch):
    monkeypatch.delenv("BRIDGE_MIT_PUSH", raising=False)
    monkeypatch.delenv("BRIDGE_DATASET_MIT_PUSH", raising=False)
    expected = Path(__file__).resolve().parents[2].parent / "shared" / "datasets" / "mit-push"
    if not expected.is_dir():
        pytest.skip("the dataset is not at ../shared/datasets/mit-push")
    assert find_mit_push_root() == expected


# --- frame of the pose relative to the mesh --------------------------------------------------------------
def synthetic_push(offset: float) -> tuple[PushRecording, np.ndarray]:
    """A right triangle (no symmetry) pushed on its long leg, its pose frame turned by -offset from the mesh's."""
    outline = np.array([[-0.05, -0.04], [0.08, -0.04], [-0.05, 0.06]])
    n = 100
    t = np.linspace(0.0, 1.0, n)
    mesh_yaw = 0.4 * t  # the object turns while it is pushed
    xy = np.column_stack([0.3 + 0.05 * t, 0.02 * t])
    contact = np.array([0.01, -0.04 - 0.00476])  # rod centre in the mesh frame, touching the side y = -0.04
    c, s = np.cos(mesh_yaw), np.sin(mesh_yaw)
    tip = xy + np.column_stack([c * contact[0] - s * contact[1], s * contact[0] + c * contact[1]])
    pose = np.column_stack([xy, mesh_yaw - offset])
    spec = PushSpec("abs", "synthetic", 0.0, 50.0, 0, 0.5, 0.0)
    return PushRecording(spec, Path("synthetic.h5"), t, tip, pose, None, 0.0), outline


@pytest.mark.parametrize("offset", [0.0, math.pi / 2, -math.pi / 2, math.pi])
def test_frame_yaw_of_a_synthetic_push_among_quarter_turns(offset):
    rec, outline = synthetic_push(offset)
    assert estimate_frame_yaw(rec, outline) == pytest.approx(offset)


def test_frame_yaw_refinement_finds_an_odd_offset():
    rec, outline = synthetic_push(math.radians(80.0))
    assert math.degrees(estimate_frame_yaw(rec, outline, refine_window=math.radians(30))) == pytest.approx(
        80.0, abs=0.25)


SHAPE_FILES = {"rect1": 13, "ellip1": 13, "ellip3": 10, "hex": 14}


def shape_recordings(root: Path, shape: str) -> list[PushRecording]:
    return [load_push(p) for p in sorted((root / "train").glob(f"*_shape={shape}_*.h5"))]


@pytest.mark.parametrize("shape, expected", [("rect1", 0.0), ("ellip1", 0.0), ("ellip3", math.pi / 2),
                                             ("hex", math.pi / 2)])
def test_frame_yaw_on_the_real_recordings(mit_push_root, shape, expected):
    recordings = shape_recordings(mit_push_root, shape)
    assert len(recordings) == SHAPE_FILES[shape]
    outline = load_outline(shape, mit_push_root)
    assert estimate_frame_yaw(recordings, outline) == pytest.approx(expected)  # all files pooled
    per_file = [estimate_frame_yaw(rec, outline) for rec in recordings]
    agreeing = sum(math.isclose(d, expected, abs_tol=1e-9) for d in per_file)
    assert agreeing >= len(per_file) - 1  # one hex push (sliding along a side) cannot tell 0 from 90 deg
    refined = math.degrees(estimate_frame_yaw(recordings, outline, refine_window=math.radians(30)))
    assert refined == pytest.approx(math.degrees(expected), abs=7.0)


def test_frame_yaw_evidence_by_shape(mit_push_root):
    """What the contact geometry can and cannot tell: costs (mm) at 0, 90, 180, -90 degrees."""
    quarter = [0.0, math.pi / 2, math.pi, -math.pi / 2]
    costs = {shape: 1000 * frame_yaw_cost(shape_recordings(mit_push_root, shape),
                                          load_outline(shape, mit_push_root), quarter)
             for shape in SHAPE_FILES}
    assert np.ptp(costs["ellip1"]) < 0.05 and np.ptp(costs["rect1"]) < 0.05  # circle, square: no evidence
    assert costs["ellip3"][0] > 10 * costs["ellip3"][1]  # 0 deg puts the rod ~27 mm off the ellipse
    assert costs["hex"][0] > 2 * costs["hex"][1]


# --- files under other names: the shape from an attribute or from the caller (--shape) ----------------------------
def test_a_file_under_another_name_needs_its_shape_named(tmp_path):
    path = write_push(tmp_path / "push.h5", **good_streams())
    message = expect_error(path, "cannot tell which shape was pushed", "--shape NAME")
    assert message.count("\n") == 0
    rec = load_push(path, shape="rect1")
    assert rec.spec == PushSpec(None, "rect1", shape_from="--shape") and len(rec) > 10


def test_a_shape_attribute_names_it_and_a_contradicting_shape_is_refused(tmp_path):
    path = write_push(tmp_path / "push.h5", **good_streams())
    with h5py.File(path, "a") as h5:
        h5.attrs["shape"] = "ellip1"
    assert load_push(path).spec.shape == "ellip1" and load_push(path, shape="ellip1").spec.shape == "ellip1"
    with pytest.raises(RecordingError, match=r"push.h5: its 'shape' attribute says shape 'ellip1', --shape says 'rect1'"):
        load_push(path, shape="rect1")
    with pytest.raises(RecordingError, match=r"its file name says shape 'rect1', --shape says 'hex'"):
        load_push(write_push(tmp_path / NAME, **good_streams()), shape="hex")
    with h5py.File(path, "a") as h5:
        h5.attrs["shape"] = "../rect1"
    expect_error(path, "shape: the 'shape' attribute must be a shape's name")


def test_a_real_push_copied_under_any_name_reads_as_the_original(tmp_path, mit_push_root):
    original = mit_push_root / "train" / NAME
    copy = tmp_path / "push.h5"
    copy.write_bytes(original.read_bytes())
    a, b = load_push(original), load_push(copy, shape="rect1")
    assert b.spec.shape == a.spec.shape == "rect1" and b.spec.v is None
    np.testing.assert_array_equal(a.t, b.t)
    np.testing.assert_array_equal(a.object_pose, b.object_pose)

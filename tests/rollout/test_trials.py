"""load_trials: recording folders, MIT h5 files and folders of them; every bad input is one clear error."""
from __future__ import annotations

import math

import h5py
import numpy as np
import pytest

from bridge.errors import BridgeError, RecordingError
from bridge.rollout.trials import load_trials

NAME = "motion_surface=abs_shape=rect1_a=0_v=75_i=2.000_s=0.700_t=-1.047.h5"


def write_push(path, n: int = 300):
    t0 = 1.46e9
    t = t0 + 0.004 * np.arange(n)
    with h5py.File(path, "w") as h5:
        h5.create_dataset("object_pose", data=np.column_stack([t, 0.35 + 0.0 * t, -0.03 + 0.0 * t, 0.0 * t]))
        h5.create_dataset("tip_pose", data=np.column_stack([t, 0.29 + 0.01 * (t - t0), -0.03 + 0.0 * t, 0.0 * t]))
        h5.create_dataset("ft_wrench", data=np.column_stack([t, 0.0 * t, 0.0 * t, 0.0 * t]))
    return path


def test_a_truncated_h5_file_is_one_clear_error(tmp_path, odb):
    path = write_push(tmp_path / NAME)
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(RecordingError) as info:
        load_trials([path], odb)
    message = str(info.value)
    assert str(path) in message and "truncated HDF5 file" in message and "\n" not in message


@pytest.mark.parametrize("problem, match", [
    ("text", "not an HDF5 file"),
    ("missing", "object_pose: missing dataset; the file has ft_wrench, tip_pose"),
    ("shape", "tip_pose: has shape \\(300, 3\\), expected N x 4"),
    ("nan", "object_pose: row 7 .* non-finite x"),
])
def test_malformed_h5_files_name_file_and_dataset(tmp_path, odb, problem, match):
    path = write_push(tmp_path / NAME)
    if problem == "text":
        path.write_text("not hdf5")
    else:
        with h5py.File(path, "a") as h5:
            if problem == "missing":
                del h5["object_pose"]
            elif problem == "shape":
                data = h5["tip_pose"][()]
                del h5["tip_pose"]
                h5.create_dataset("tip_pose", data=data[:, :3])
            else:
                h5["object_pose"][7, 1] = np.nan
    with pytest.raises(RecordingError, match=match) as info:
        load_trials([path], odb)
    assert str(path) in str(info.value)


def test_paths_that_are_not_recordings(tmp_path, odb):
    with pytest.raises(RecordingError, match="recording not found"):
        load_trials([tmp_path / "nowhere"], odb)
    (tmp_path / "empty").mkdir()
    with pytest.raises(RecordingError, match="neither a recording .* nor a folder of MIT .h5 files"):
        load_trials([tmp_path / "empty"], odb)
    with pytest.raises(RecordingError, match="no recordings given"):
        load_trials([], odb)
    bad_name = write_push(tmp_path / "push.h5")
    with pytest.raises(BridgeError, match="file name does not follow the dataset's pattern .* --shape NAME"):
        load_trials([bad_name], odb)


def test_a_recording_without_observations_cannot_be_fitted(tmp_path, odb):
    from bridge.fit.synthetic import push_telemetries, push_world
    from bridge.recording.recording import save_recording
    from bridge.world import save_world_state

    save_world_state(push_world(), tmp_path / "world.yaml")
    folder = tmp_path / "rec"
    save_recording(folder, tmp_path / "world.yaml", push_telemetries()["slide"])
    with pytest.raises(RecordingError, match="no observed poses"):
        load_trials([folder], odb)


def test_real_pushes_share_a_frame_offset_per_shape(mit_push_root, odb):
    files = sorted((mit_push_root / "train").glob("*shape=hex*.h5"))[:3] + sorted(
        (mit_push_root / "train").glob("*shape=rect1*.h5"))[:2]
    trials = load_trials(files, odb, max_duration=0.5)
    assert len({t.name for t in trials}) == 5 and all(t.is_planar_push for t in trials)
    for trial in trials:
        shape = trial.name.split("shape=")[1].split("_")[0]
        turned = any("mesh frame turned +90 deg" in n for n in trial.notes)
        assert turned == (shape == "hex")  # README: hex's pose frame is a quarter turn from its mesh frame
        kinds = {a.kind: a for a in trial.adjustments}
        assert "start_clearance" in kinds and ("frame_yaw" in kinds) == turned  # kept as data, not only words
        if turned:
            assert kinds["frame_yaw"].yaw == pytest.approx(math.pi / 2) and kinds["frame_yaw"].estimated
        assert trial.telemetry.duration <= 0.5 + 1e-9 and trial.settle == pytest.approx(0.0, abs=1e-9)
    fixed = load_trials(files[:1], odb, frame_yaws={"hex": 0.0}, max_duration=0.5)[0]
    yaw = lambda t: t.world.objects["hex"].pose.yaw()  # noqa: E731
    assert math.remainder(yaw(trials[0]) - yaw(fixed), 2 * math.pi) == pytest.approx(math.pi / 2)


# --- a push file under any name: --shape ---------------------------------------------------------------------------
def test_a_renamed_push_file_loads_with_its_shape_named(mit_push_root, odb, tmp_path):
    push = tmp_path / "push.h5"
    push.write_bytes((mit_push_root / "train" / NAME).read_bytes())
    with pytest.raises(RecordingError, match=r"push.h5: cannot tell which shape was pushed.*--shape NAME"):
        load_trials([push], odb)
    renamed = load_trials([push], odb, shape="rect1", max_duration=0.5)[0]
    original = load_trials([mit_push_root / "train" / NAME], odb, max_duration=0.5)[0]
    assert renamed.name == "push" and renamed.is_planar_push
    assert "push.h5: the shape rect1 comes from --shape" in renamed.notes
    assert renamed.world.objects["rect1"].pose == original.world.objects["rect1"].pose
    np.testing.assert_array_equal(renamed.telemetry.positions, original.telemetry.positions)


@pytest.mark.slow
def test_bridge_fit_and_infer_read_a_renamed_push_file_with_shape(mit_push_root, tmp_path, capsys):
    import json

    from bridge.cli import main

    push = tmp_path / "push.h5"
    push.write_bytes((mit_push_root / "train" / NAME).read_bytes())
    dataset = ["--dataset", f"mit-push={mit_push_root}"]
    out = tmp_path / "fit"
    argv = ["fit", str(push), "--shape", "rect1", "--out", str(out), "--executor", "serial", "--generations", "1",
            "--popsize", "2", "--hold-out", "0", "--max-duration", "0.8", *dataset]
    assert main(argv) == 0, capsys.readouterr().err
    data = json.loads((out / "fit.json").read_text())
    assert data["fit_trials"] == ["push"] and "push.h5: the shape rect1 comes from --shape" in data["notes"]
    world_out = tmp_path / "after.yaml"
    assert main(["infer", str(push), "--shape", "rect1", "--world-out", str(world_out), *dataset]) == 0
    assert "rect1 moved" in capsys.readouterr().out and (tmp_path / "problem_after.pddl").is_file()

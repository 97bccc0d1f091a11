"""Bad input to the long commands' options: --time-limit (fit, diagnose, prove, infer --samples) and MIT push
files whose shape nothing names (--shape). Each is refused in one line naming the option or file, before any
replay, with nothing written."""
from __future__ import annotations

import h5py
import numpy as np
import pytest

DATASET_NAME = "motion_surface=abs_shape=rect1_a=0_v=75_i=2.000_s=0.700_t=-1.047.h5"
BAD_SECONDS = ["0", "-1", "nan", "inf", "abc"]


def write_push(path, shape_attribute=None):
    """A small, valid MIT-format push file (three N x 4 streams on one clock)."""
    n, t0 = 50, 1.46e9
    t = t0 + 0.004 * np.arange(n)
    streams = {"object_pose": np.column_stack([t, 0.3 + 0.1 * (t - t0), np.full(n, -0.05), np.zeros(n)]),
               "tip_pose": np.column_stack([t, 0.2 + 0.1 * (t - t0), np.full(n, -0.05), np.zeros(n)]),
               "ft_wrench": np.column_stack([t, np.linspace(1, 2, n), np.zeros(n), np.zeros(n)])}
    with h5py.File(path, "w") as h5:
        for name, data in streams.items():
            h5.create_dataset(name, data=data)
        if shape_attribute is not None:
            h5.attrs["shape"] = shape_attribute
    return path


@pytest.fixture
def push(tmp_path):
    return write_push(tmp_path / "push.h5")


# --- --time-limit ------------------------------------------------------------------------------------------------
def _time_limit_argv(command, recording, out, value):
    return {"fit": ["fit", recording, "--out", out, "--time-limit", value],
            "diagnose": ["diagnose", recording, "--out", out, "--time-limit", value],
            "prove": ["prove", "--out", out, "--time-limit", value],
            "infer": ["infer", recording, "--samples", "2", "--world-out", out / "w.yaml", "--time-limit", value],
            }[command]


@pytest.mark.parametrize("value", BAD_SECONDS)
@pytest.mark.parametrize("command", ["fit", "diagnose", "prove", "infer"])
def test_a_time_limit_must_be_a_finite_number_of_seconds_above_zero(refuse, recording, tmp_path, command, value):
    out = tmp_path / "out"
    line = refuse(_time_limit_argv(command, recording, out, value), "--time-limit", repr(value), inputs=(recording,),
                  absent=(out,), code=2)
    assert "finite number of seconds > 0" in line


@pytest.mark.parametrize("value", ["0", "-0.003", "nan", "inf", "fast"])
def test_a_time_step_must_be_auto_or_a_finite_number_above_zero(refuse, recording, tmp_path, value):
    out = tmp_path / "out"
    line = refuse(["diagnose", recording, "--out", out, "--time-step", value], "--time-step", repr(value),
                  inputs=(recording,), absent=(out,), code=2)
    assert "finite number > 0" in line


def test_run_diagnosis_refuses_a_time_step_that_is_not_one(odb):
    from bridge.diagnosis.pipeline import run_diagnosis
    from bridge.errors import DiagnosisError

    with pytest.raises(DiagnosisError, match="time_step"):
        run_diagnosis([object()], odb, None, time_step="fast")


def test_infer_time_limit_needs_samples(refuse, recording, tmp_path):
    refuse(["infer", recording, "--time-limit", "5", "--world-out", tmp_path / "w.yaml"], "--time-limit", "--samples",
           inputs=(recording,), absent=(tmp_path / "w.yaml", recording / "world_after.yaml"))


# --- --shape -----------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("command", ["fit", "diagnose", "infer", "view"])
def test_a_push_file_whose_shape_nothing_names_is_refused_naming_it_and_the_option(refuse, push, tmp_path, command):
    out = tmp_path / "out"
    argv = {"fit": ["fit", push, "--out", out], "diagnose": ["diagnose", push, "--out", out],
            "infer": ["infer", push, "--world-out", out / "w.yaml"], "view": ["view", push, "--out", out / "v.html"],
            }[command]
    line = refuse(argv, push, "--shape", inputs=(push,), absent=(out,))
    assert "cannot tell which shape was pushed" in line


def test_an_unknown_shape_is_refused_with_the_known_ones(refuse, push, tmp_path):
    line = refuse(["fit", push, "--shape", "rectX", "--out", tmp_path / "out"], "--shape", "rectX",
                  inputs=(push,), absent=(tmp_path / "out",))
    assert "rect1" in line and "ellip1" in line


def test_a_shape_that_is_no_name_is_refused(refuse, push, tmp_path):
    refuse(["diagnose", push, "--shape", "../rect1", "--out", tmp_path / "out"], "--shape", "../rect1",
           inputs=(push,), absent=(tmp_path / "out",))


def test_a_shape_contradicting_the_file_name_is_refused(refuse, tmp_path):
    named = write_push(tmp_path / DATASET_NAME)
    refuse(["fit", named, "--shape", "hex", "--out", tmp_path / "out"], named, "--shape", "'rect1'", "'hex'",
           inputs=(named,), absent=(tmp_path / "out",))


def test_a_shape_contradicting_the_file_attribute_is_refused(refuse, tmp_path):
    path = write_push(tmp_path / "push.h5", shape_attribute="ellip1")
    refuse(["view", path, "--shape", "rect1", "--out", tmp_path / "v.html"], path, "--shape", "'ellip1'",
           inputs=(path,), absent=(tmp_path / "v.html",))


def test_a_shape_attribute_that_is_no_name_is_refused(refuse, tmp_path):
    path = write_push(tmp_path / "push.h5", shape_attribute="rect 1")
    refuse(["fit", path, "--out", tmp_path / "out"], path, "shape", "'rect 1'", inputs=(path,),
           absent=(tmp_path / "out",))


def test_a_shape_for_a_recording_folder_is_refused(refuse, recording, tmp_path):
    refuse(["infer", recording, "--shape", "rect1", "--world-out", tmp_path / "w.yaml"], "--shape", recording,
           inputs=(recording,), absent=(tmp_path / "w.yaml",))
    refuse(["fit", recording, "--shape", "rect1", "--out", tmp_path / "out"], "--shape", "no .h5 file",
           inputs=(recording,), absent=(tmp_path / "out",))

"""The robot's force track: force.csv round trip, its errors, the recording folder, and the MIT reader's rule
for a sensor that only spikes."""
from __future__ import annotations

import numpy as np
import pytest

from bridge.errors import RecordingError
from bridge.recording.forces import ObservedForce, load_force_csv, save_force_csv


def test_force_csv_round_trips_and_marks_constant_columns_unmeasured(tmp_path):
    t = np.linspace(0.0, 1.0, 11)
    force = np.column_stack([np.sin(t), np.cos(t), np.zeros_like(t)])
    save_force_csv(tmp_path / "force.csv", ObservedForce(t, force))
    back = load_force_csv(tmp_path / "force.csv")
    assert np.array_equal(back.times, t) and np.array_equal(back.force, force)
    assert back.measured.tolist() == [True, True, False]


@pytest.mark.parametrize("text, words", [
    ("t,fx,fy\n0,1,2\n0.1,1,2\n", "must name the columns"),
    ("t,fx,fy,fz\n0,1,2,0\n0.1,nan,2,0\n", "line 3"),
    ("t,fx,fy,fz\n0,1,2,0\n0,1,2,0\n", "strictly increase"),
    ("t,fx,fy,fz\n0,1,2,0\n0.1,1,2\n", "line 3"),
    ("t,fx,fy,fz\n0,1,2,0\n", "at least two rows"),
])
def test_bad_force_files_name_file_and_place(tmp_path, text, words):
    path = tmp_path / "force.csv"
    path.write_text(text)
    with pytest.raises(RecordingError) as err:
        load_force_csv(path)
    assert words in str(err.value) and "force.csv" in str(err.value)


def test_recording_folder_carries_its_force(tmp_path):
    from bridge.recording.recording import load_recording, save_recording
    from bridge.recording.telemetry import Telemetry

    t = np.linspace(0.0, 1.0, 11)
    telemetry = Telemetry(t, ("pusher_x", "pusher_y"), np.column_stack([t, 0 * t]))
    force = ObservedForce(t, np.column_stack([t, -t, 0 * t]))
    rec = save_recording(tmp_path / "rec", "objects: {}\n", telemetry, force=force)
    assert rec.metadata["force"] == "force.csv"
    assert np.allclose(load_recording(tmp_path / "rec").force.force, force.force)


def test_mit_force_is_kept_unless_it_only_spikes(mit_push_root):
    from bridge.recording.mitpush import load_push
    from bridge.recording.mitsession import _force

    root = mit_push_root / "train"
    ellipse = next(iter(sorted(root.glob("*shape=ellip1*.h5"))))
    force, why = _force(load_push(ellipse))
    assert force is not None and not why and force.measured.tolist() == [True, True, False]
    rect = next(iter(sorted(root.glob("*shape=rect1*.h5"))))
    force, why = _force(load_push(rect))
    assert force is None and "spikes" in why

"""The HTML replay opens framed on the scene: the camera's target is the centre of the objects and the robot's
base, its distance fits them in view (read back from the Meshcat commands the page carries)."""
from __future__ import annotations

import base64
import re
import shutil
import struct
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pydrake")

from bridge.sim.viewer import CAMERA_FOV, camera_pose, scene_bounds  # noqa: E402
from bridge.world import load_world_state  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
PUSH_NAME = "motion_surface=abs_shape=rect1_a=0_v=75_i=2.000_s=0.700_t=-1.047.h5"


def camera_commands(html: str) -> dict[str, np.ndarray]:
    """The last camera position and target the page sets, in Drake's z-up world frame (Meshcat sends them in
    three.js's y-up frame: (x, z, -y))."""
    found = {}
    for blob in re.findall(r'data:application/octet-binary;base64,([A-Za-z0-9+/=]+)"', html):
        data = base64.b64decode(blob)
        if b"set_target" in data:
            key = "target"
        elif b"/Cameras/default/rotated/<object>" in data and b"position" in data:
            key = "camera"
        else:
            continue
        at = data.index(b"value\x93") + 6  # msgpack: the key "value", then an array of three float64
        x, y, z = (struct.unpack(">d", data[at + 9 * k + 1: at + 9 * k + 9])[0] for k in range(3))
        assert all(data[at + 9 * k] == 0xCB for k in range(3))
        found[key] = np.array([x, -z, y])
    return found


def test_the_camera_frames_the_tabletop_not_the_floor(odb):
    world = load_world_state(REPO / "demo" / "recordings" / "1_push_over" / "world.yaml", odb)
    lower, upper = scene_bounds(world, odb)
    # the table's top (0.8 x 1.2 m around x = 0.75, z 0.7-0.75), the boxes on it (the big one to z = 1.0), the
    # arm's base at the origin
    np.testing.assert_allclose(lower, [0.0, -0.6, 0.7], atol=1e-9)
    np.testing.assert_allclose(upper, [1.15, 0.6, 1.0], atol=1e-9)
    camera, target = camera_pose(lower, upper)
    np.testing.assert_allclose(target, (lower + upper) / 2)
    distance = np.linalg.norm(camera - target)
    radius = np.linalg.norm(upper - lower) / 2
    assert radius / np.sin(np.radians(CAMERA_FOV / 2)) < distance < 3 * radius  # all in view, and not far off
    assert camera[2] > upper[2]  # from above


@pytest.mark.slow
def test_bridge_view_of_a_renamed_push_file_opens_on_the_push(mit_push_root, tmp_path, capsys):
    from bridge.cli import main

    push = tmp_path / "push.h5"
    shutil.copy(mit_push_root / "train" / PUSH_NAME, push)
    out = tmp_path / "view.html"
    argv = ["view", str(push), "--shape", "rect1", "--out", str(out), "--dataset", f"mit-push={mit_push_root}"]
    assert main(argv) == 0, capsys.readouterr().err
    found = camera_commands(out.read_text())
    # the scene: the 1 m push surface under the object's start, the pusher's base at the origin
    from bridge.odb import load_object_database
    from bridge.rollout import load_trials

    odb = load_object_database(datasets={"mit-push": mit_push_root})
    world = load_trials([push], odb, shape="rect1")[0].world
    lower, upper = scene_bounds(world, odb)
    np.testing.assert_allclose(found["target"], (lower + upper) / 2, atol=1e-9)
    np.testing.assert_allclose(found["camera"], camera_pose(lower, upper)[0], atol=1e-9)
    assert np.linalg.norm(found["camera"] - found["target"]) < 3.0  # Meshcat's default frames a 10 m floor

"""The independent generator's worlds are what it says they are (benchmarks/independent_pushes.py): sliding
friction Coulomb's and the same in every direction, twisting that of uniform pressure, the effects concealed
where the truth says, the recordings in the dataset's format. A benchmark that mislabels its worlds measures
nothing: MuJoCo on 175 support spheres twisted 1.3-1.7 times harder than Coulomb friction does, which read as a
pressure distribution in every case. Skipped without MuJoCo (`pip install -e .[bench]`) or the shapes' outlines."""
import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco", reason="mujoco not installed: pip install -e .[bench]")

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "benchmarks"))

import independent_pushes as gen  # noqa: E402

G = 9.81


@pytest.fixture(scope="module")
def square(mit_push_root):
    return gen.outline(mit_push_root, "rect1")


def _settled(world, poly):
    model = mujoco.MjModel.from_xml_string(gen.model_xml(world, poly, (0.3, 0.0, 0.0)))
    data = mujoco.MjData(model)
    for _ in range(200):
        mujoco.mj_step(model, data)
    free = model.jnt_dofadr[[j for j in range(model.njnt) if model.jnt_type[j] == 0][0]]
    return model, data, free


def test_sliding_is_coulombs_in_every_direction_and_twisting_that_of_uniform_pressure(square):
    mu = 0.2
    world = gen.World("rect1", "none", mu, 0.2, gen.DENSITY, 0.005)
    slides = []
    for angle in np.radians([0.0, 30.0, 45.0, 100.0]):
        model, data, free = _settled(world, square)
        start = data.body("object").xpos.copy()
        data.qvel[free:free + 2] = 0.2 * np.array([math.cos(angle), math.sin(angle)])
        for _ in range(800):
            mujoco.mj_step(model, data)
        slides.append(np.linalg.norm(data.body("object").xpos[:2] - start[:2]))
    assert slides == pytest.approx([0.2 ** 2 / (2 * mu * G)] * 4, rel=0.02)
    # a spin-down turns the object as far as mu m g <r> stops it (<r> of the square: a (sqrt 2 + asinh 1) / 6)
    model, data, free = _settled(world, square)
    body = model.body("object").id
    q0 = data.body("object").xquat.copy()
    data.qvel[free + 5] = 1.0
    for _ in range(1500):
        mujoco.mj_step(model, data)
    q1 = data.body("object").xquat
    turned = 2 * math.atan2(q0[0] * q1[3] - q0[3] * q1[0] + q0[1] * q1[2] - q0[2] * q1[1], float(q0 @ q1))
    mean_r = 0.09 * (math.sqrt(2) + math.asinh(1)) / 6
    want = model.body_inertia[body].max() / (2 * mu * model.body_mass[body] * G * mean_r)
    assert turned == pytest.approx(want, rel=0.05)


def test_a_case_writes_pushes_the_loader_reads_and_its_truth(mit_push_root, odb, tmp_path):
    from bridge.rollout.trials import load_trials

    folder = gen.make_case(mit_push_root, tmp_path, "rect1", "pusher_offset", 2, n=2)
    truth = json.loads((folder / "truth.json").read_text())
    assert truth["generator"] == gen.GENERATOR and truth["world"]["effect"] == "pusher_offset"
    assert math.hypot(*truth["world"]["rod_offset"]) == pytest.approx(0.004)
    trials = load_trials(sorted(folder.glob("*.h5")), odb)
    assert len(trials) == 2 and all(t.force is not None for t in trials)
    moved = [p["moved_mm"] for p in truth["pushes"]]
    assert all(m > 10 for m in moved), moved  # every push moves the object

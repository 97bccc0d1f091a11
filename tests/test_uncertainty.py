"""Fact probabilities from the parameter uncertainty: the drawing, the shares, and what they say through real Drake
replays (a box pushed far below and near its tipping height, a grasp and place) and on the command line."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from bridge.names import build_name_map
from bridge.recording.telemetry import Telemetry
from bridge.rollout import Rollout
from bridge.uncertainty import (Uncertain, default_parameters, draw, fact_probabilities, sample_session,
                                with_probabilities)
from bridge.values import Fact, Pose
from bridge.world import ObjectState, RobotState, WorldState

REPO = Path(__file__).resolve().parents[1]
TOP = 0.75  # the table's top
UPRIGHT, ON = Fact("upright", ("big_box",)), Fact("on", ("big_box", "table"))
FAR_BELOW, NEAR = 0.05, 0.102  # m: rod heights; the 25 cm box tips near 0.10-0.11 m at friction 0.5


def tipping_world(height: float) -> WorldState:
    """A standing big box on the table, the planar rod `height` above the table top, 2 mm behind the box."""
    objects = {"table": ObjectState("table", "table", Pose((0.75, 0.0, TOP - 0.025))),
               "big_box": ObjectState("big_box", "big_box", Pose((0.6, 0.0, TOP + 0.125)))}
    robot = RobotState("pusher", "planar_pusher", Pose((0.0, 0.0, TOP + height)), (("pusher_x", 0.5), ("pusher_y", 0.0)))
    return WorldState(objects, frozenset({ON, UPRIGHT}), robot, name="tip", names=build_name_map([*objects, "pusher"]))


def push(speed: float = 0.05, travel: float = 0.1) -> Telemetry:
    """The rod still for 0.3 s, then 10 cm along +x at 5 cm/s, into the box."""
    x0 = 0.6 - 0.05 - 0.00476 - 0.002
    t = np.arange(0.0, 0.3 + travel / speed + 0.01, 0.01)
    x = np.minimum(x0 + np.clip(t - 0.3, 0.0, None) * speed, x0 + travel)
    return Telemetry(t, ("pusher_x", "pusher_y"), np.column_stack([x, np.zeros_like(x)]))


# --- drawing and counting -----------------------------------------------------------------------------------------
def test_a_latin_hypercube_stratifies_every_parameter_and_keeps_to_the_bounds(odb):
    world = tipping_world(FAR_BELOW)
    params = [Uncertain("friction", "table", 0.5, 0.075, "test"), Uncertain("com_x", "big_box", 0.0, 0.003, "test"),
              Uncertain("friction", "big_box", 0.03, 0.5, "test")]
    values = draw(params, 20, world, odb, seed=3)
    from scipy.stats import norm

    for j, p in enumerate(params[:2]):  # one draw in each of 20 equally likely slices of the normal
        strata = np.floor(norm.cdf((values[:, j] - p.mean) / p.sd) * 20).astype(int)
        assert sorted(strata) == list(range(20))
    assert values[:, 2].min() >= 0.02  # a friction stays inside its kind's bounds, however wide its sigma
    np.testing.assert_array_equal(values, draw(params, 20, world, odb, seed=3))  # seeded
    assert not np.array_equal(values, draw(params, 20, world, odb, seed=4))


def test_default_ranges_cover_what_was_touched_around_the_rollouts_values(odb):
    from bridge.params import Setting, apply_model

    rollout = apply_model((Setting("friction", "table", 0.4),), Rollout(tipping_world(FAR_BELOW), push()), odb)
    params = {p.name: p for p in default_parameters(rollout, odb, ["table", "big_box"])}
    assert set(params) == {"friction[table]", "friction[big_box]", "mass[big_box]", "com_x[big_box]",
                           "com_y[big_box]"}  # a fixture has no mass to doubt
    assert params["friction[table]"].mean == 0.4 and params["friction[table]"].sd == pytest.approx(0.15 * 0.4)
    assert params["mass[big_box]"].sd == pytest.approx(0.05 * 1.0) and params["com_x[big_box]"].sd == 0.003


def test_shares_count_successful_samples_and_the_state_keeps_the_disputed_ones():
    samples = [frozenset({ON, UPRIGHT}), frozenset({ON}), None, frozenset({ON, UPRIGHT}), frozenset({ON})]
    p = fact_probabilities(samples, frozenset({ON, UPRIGHT}))
    assert p == {ON: 1.0, UPRIGHT: 0.5}  # the failed replay counts in neither
    world = with_probabilities(tipping_world(NEAR), p, 4)
    assert world.probabilities == {UPRIGHT: 0.5} and world.samples == 4
    assert world.probability(ON) == 1.0 and world.probability(UPRIGHT) == 0.5
    from bridge.errors import BridgeError

    with pytest.raises(BridgeError, match="every one of the 2 sampled replays failed"):
        fact_probabilities([None, None], frozenset())


# --- through real Drake replays ------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def sampled(odb, pool):
    """The push far below and near the tipping height, 16 samples each from the database's ranges."""
    return {h: sample_session(Rollout(tipping_world(h), push()), odb, 16, executor=pool, seed=1)
            for h in (FAR_BELOW, NEAR)}


@pytest.mark.slow
def test_a_push_far_below_the_tipping_height_leaves_the_box_surely_upright(sampled):
    session = sampled[FAR_BELOW]
    assert session.samples == 16 and not session.failures
    assert session.probabilities[UPRIGHT] >= 0.99 and session.probabilities[ON] >= 0.99
    assert session.world.probabilities == {}  # nothing disputed: the planner is told the facts as before


@pytest.mark.slow
def test_a_push_near_the_tipping_height_may_or_may_not_have_toppled_the_box(sampled):
    session = sampled[NEAR]
    assert 0.1 < session.probabilities[UPRIGHT] < 0.9, session.probabilities
    assert session.world.probability(UPRIGHT) == session.probabilities[UPRIGHT]
    tilts = [np.degrees(np.arccos(np.clip(f["big_box"].z_axis()[2], -1, 1))) for f in session.finals]
    assert min(tilts) < 10 and max(tilts) > 80  # some stood, some lay: the poses agree with the facts
    drawn = {p.name for p in session.parameters}
    assert {"friction[table]", "friction[big_box]", "mass[big_box]"} <= drawn and "friction[pusher]" not in drawn


@pytest.mark.slow
def test_a_diagnosed_scene_file_narrows_the_probabilities(sampled, odb, pool, tmp_path):
    """With what a diagnosis measured (frictions known to 0.01, nothing else in doubt) the near push is no longer
    a coin toss, and the final poses spread far less than under the database's ranges."""
    from bridge.params import apply_model, load_param_file, replay_model
    from bridge.uncertainty import parameters_from_file

    scene = tmp_path / "scene.yaml"
    scene.write_text(yaml.safe_dump({"params": [
        {"kind": "friction", "target": "table", "value": 0.5, "std": 0.01, "effect": "friction"},
        {"kind": "friction", "target": "big_box", "value": 0.5, "std": 0.01, "effect": "friction"}]}))
    model = load_param_file(scene)
    rollout = apply_model(replay_model(model), Rollout(tipping_world(NEAR), push()), odb)
    narrow = sample_session(rollout, odb, 16, executor=pool, seed=1,
                            parameters=parameters_from_file(model, rollout.world, odb))
    wide = sampled[NEAR]
    p_narrow, p_wide = narrow.probabilities.get(UPRIGHT, 0.0), wide.probabilities[UPRIGHT]
    assert abs(p_narrow - 0.5) > abs(p_wide - 0.5) and p_narrow in (0.0, 1.0)

    def spread(session):
        return float(np.std([f["big_box"].xyz[0] for f in session.finals]))

    assert spread(narrow) < 0.5 * spread(wide)


@pytest.mark.slow
def test_a_firm_grasp_and_place_is_surely_on_the_tray(odb, pool):
    from bridge.recording.recording import load_recording
    from bridge.world import load_world_state

    recording = load_recording(REPO / "demo" / "recordings" / "4_pick_place")
    rollout = Rollout(load_world_state(recording.world_path, odb), recording.telemetry)
    session = sample_session(rollout, odb, 4, executor=pool, seed=2)
    assert session.samples == 4
    assert session.probabilities[Fact("on", ("small_box", "tray"))] >= 0.99
    assert session.probabilities[Fact("in", ("small_box", "tray"))] >= 0.99


# --- the command line ----------------------------------------------------------------------------------------------
@pytest.mark.slow
def test_bridge_infer_samples_writes_probabilities_the_planner_and_the_operator_read(odb, tmp_path, capsys):
    from bridge.cli import main
    from bridge.planning.problem import read_problem
    from bridge.recording.recording import save_recording
    from bridge.world import load_world_state, save_world_state

    save_world_state(tipping_world(NEAR), tmp_path / "world.yaml")
    rec = save_recording(tmp_path / "rec", tmp_path / "world.yaml", push()).folder
    world_out, problem_out = tmp_path / "after.yaml", tmp_path / "after.pddl"
    argv = ["infer", str(rec), "--samples", "8", "--executor", "serial", "--seed", "1", "--events",
            "--world-out", str(world_out), "--problem-out", str(problem_out)]
    assert main(argv) == 0
    captured = capsys.readouterr()
    final = json.loads(captured.out.strip().splitlines()[-1])
    assert final["final"] and final["samples"] == 8
    after = load_world_state(world_out, odb)
    p = after.probability(UPRIGHT)
    assert 0.0 < p < 1.0 and after.samples == 8 and final["probabilities"]["(upright big_box)"]["p"] == p
    assert f"? (upright big_box) p = {p:.2f}" in captured.err and "8 samples (latin hypercube" in captured.err
    problem = read_problem(problem_out, odb)
    assert (UPRIGHT in problem.facts) == (p >= 0.9) and ON in problem.facts
    assert "; bridge-uncertain (upright big_box)" in problem_out.read_text()
    uncertain = json.loads(problem_out.with_suffix(".uncertain.json").read_text())
    assert [u["fact"] for u in uncertain["uncertain"]] == ["(upright big_box)"]
    lo, hi = uncertain["uncertain"][0]["interval"]
    assert lo < p < hi
    # bridge export: a lower threshold tells the planner what is likelier than it
    assert main(["export", str(world_out), "--out", str(tmp_path / "export"), "--min-probability", "0.51"]) == 0
    exported = read_problem(tmp_path / "export" / "problem.pddl", odb)
    assert (UPRIGHT in exported.facts) == (p >= 0.51)
    assert "uncertain fact(s) left out" in capsys.readouterr().out
    assert main(["diff", str(tmp_path / "world.yaml"), str(world_out), "--json"]) == 0
    diff = json.loads(capsys.readouterr().out)
    assert diff["uncertain"][0]["fact"] == "(upright big_box)" and diff["uncertain"][0]["p"] == round(p, 4)
    assert main(["infer", str(rec), "--samples", "2", "--min-probability", "0.4"]) == 1
    assert "minimum probability must be in (0.5, 1]" in capsys.readouterr().err


@pytest.mark.slow
def test_bridge_view_draws_the_sampled_final_poses_as_ghosts(tmp_path, capsys):
    from bridge.cli import main
    from bridge.recording.recording import save_recording
    from bridge.world import save_world_state

    save_world_state(tipping_world(NEAR), tmp_path / "world.yaml")
    rec = save_recording(tmp_path / "rec", tmp_path / "world.yaml", push()).folder
    out = tmp_path / "view.html"
    assert main(["view", str(rec), "--samples", "4", "--executor", "serial", "--out", str(out)]) == 0
    assert "4 sampled final poses as ghosts" in capsys.readouterr().out
    html = out.read_text()
    # Meshcat's page carries its commands as base64 msgpack (plain JSON in older Drakes)
    import base64
    import re

    commands = html + "".join(base64.b64decode(b).decode("latin-1")
                              for b in re.findall(r'octet-binary;base64,([A-Za-z0-9+/=]+)"', html))
    assert all(f"samples/{k}/big_box" in commands for k in range(4))


@pytest.mark.slow
def test_bridge_infer_samples_stops_at_its_time_limit_with_the_samples_done(odb, tmp_path, capsys):
    from bridge.cli import main
    from bridge.recording.recording import save_recording
    from bridge.world import load_world_state, save_world_state

    save_world_state(tipping_world(NEAR), tmp_path / "world.yaml")
    rec = save_recording(tmp_path / "rec", tmp_path / "world.yaml", push()).folder
    world_out = tmp_path / "after.yaml"
    argv = ["infer", str(rec), "--samples", "40", "--executor", "serial", "--seed", "1", "--events",
            "--time-limit", "1", "--world-out", str(world_out)]
    assert main(argv) == 0
    captured = capsys.readouterr()
    final = json.loads(captured.out.strip().splitlines()[-1])
    assert final["final"] and final["requested"] == 40 and final["stopped"] == "time limit"
    assert 1 <= final["samples"] < 40
    after = load_world_state(world_out, odb)
    assert after.samples in (0, final["samples"])  # 0: the samples replayed all agreed
    assert f"partial: the time limit of 1 s stopped the sampling after {final['samples']} of 40 samples" in captured.err
    assert "\r" not in captured.err and "sample 1/40 (2%)" in captured.err

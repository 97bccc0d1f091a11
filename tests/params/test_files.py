"""Parameter files (also the diagnosis' scene files): parsing, every malformed case named by file and field,
targets checked against worlds, fitted files round-tripped."""
from __future__ import annotations

import textwrap

import numpy as np
import pytest

from bridge.errors import ParameterError
from bridge.fit.synthetic import push_telemetries, push_world
from bridge.params import KINDS, apply_model, check_targets, load_param_file, parse_params, replay_model, save_param_file
from bridge.rollout import Rollout


def write(tmp_path, text: str):
    path = tmp_path / "params.yaml"
    path.write_text(textwrap.dedent(text))
    return path


GOOD = """\
    params:
      - {kind: friction, target: big_box, bounds: [0.1, 1.0], start: 0.5}
      - {kind: friction, target: table, bounds: [0.1, 1.0], start: 0.5}
      - {kind: hydroelastic_modulus, target: big_box, bounds: [1e5, 1e8], start: 1e6, scale: log}
      - {kind: mass, target: small_box, bounds: [0.5, 2.0]}
      - {kind: com_x, target: big_box, bounds: [-0.03, 0.03], start: 0}
      - {kind: dissipation, target: type:box, value: 2.0, effect: friction}
"""


def test_reads_free_and_fixed_entries(tmp_path):
    spec = load_param_file(write(tmp_path, GOOD))
    assert spec.names == ("friction[big_box]", "friction[table]", "hydroelastic_modulus[big_box]", "mass[small_box]",
                          "com_x[big_box]")
    assert [p.name for p in spec.fixed] == ["dissipation[type:box]"] and spec.fixed[0].effect == "friction"
    np.testing.assert_allclose(spec.start_values(), [0.5, 0.5, 1e6, 1.25, 0.0])  # mass: middle of its bounds
    modulus = spec.free[2]
    assert modulus.to_unit(1e6) == pytest.approx(1 / 3)  # log scale: 1e5 .. 1e8
    assert modulus.from_unit(2 / 3) == pytest.approx(1e7)


def test_unit_box_and_normal_coordinates_round_trip(tmp_path):
    spec = load_param_file(write(tmp_path, GOOD))
    values = np.array([0.3, 0.9, 3e7, 1.7, -0.01])
    np.testing.assert_allclose(spec.from_unit(spec.to_unit(values)), values)
    np.testing.assert_allclose(spec.from_unit([-1, 2, 0, 1, 0.5]), [0.1, 1.0, 1e5, 2.0, 0.0])
    np.testing.assert_allclose(spec.from_normal(spec.to_normal(values)), values)
    np.testing.assert_allclose(spec.to_normal(spec.start_values()), 0.0)  # the start is the origin
    assert spec.steps[0] == pytest.approx(0.9 / 20)  # a file's entry: a twentieth of its bounds per unit
    # a point on a bound (or a rounding error past it) comes back within the bounds, never past them
    lower, upper = spec.normal_bounds()
    assert np.all(spec.from_normal(lower - 1e-12) >= [p.bounds[0] for p in spec.free])
    assert np.all(spec.from_normal(upper + 1e-12) <= [p.bounds[1] for p in spec.free])


@pytest.mark.parametrize("text, field, words", [
    ("params:\n  - {kind: frction, target: big_box, bounds: [0.1, 1]}", "params[0].kind",
     ["unknown kind 'frction'", "friction", "mass", "latency", "surface_slope_x", "obstacle_x"]),
    ("params:\n  - {kind: friction, bounds: [0.1, 1]}", "params[0]", ["missing field 'target'"]),
    ("params:\n  - {target: big_box, bounds: [0.1, 1]}", "params[0]", ["missing field 'kind'"]),
    ("params:\n  - {kind: friction, target: big_box}", "params[0]", ["missing field 'bounds'", "'value'"]),
    ("params:\n  - {kind: friction, target: big_box, bounds: [1.0, 0.1]}", "params[0].bounds",
     ["bounds must increase"]),
    ("params:\n  - {kind: friction, target: big_box, bounds: [0.5, 0.5]}", "params[0].bounds", ["increase"]),
    ("params:\n  - {kind: friction, target: big_box, bounds: [0.1]}", "params[0].bounds", ["two numbers"]),
    ("params:\n  - {kind: friction, target: big_box, bounds: [0.1, 1.0], start: 2}", "params[0].start",
     ["start 2 is outside the bounds [0.1, 1]"]),
    ("params:\n  - {kind: mass, target: big_box, bounds: [0, 2]}", "params[0].bounds[0]", ["mass 0 kg is outside the physical range (0, 1000] kg"]),
    ("params:\n  - {kind: friction, target: big_box, bounds: [-0.1, 1]}", "params[0].bounds[0]", ["friction -0.1 is outside the physical range [0, 5]"]),
    ("params:\n  - {kind: obstacle_radius, target: table, value: 0}", "params[0].value",
     ["obstacle_radius 0 m is outside the physical range (0, 0.5] m"]),
    ("params:\n  - {kind: com_x, target: big_box, bounds: [-0.1, 0.1], scale: log}", "params[0].bounds",
     ["log scale needs bounds > 0"]),
    ("params:\n  - {kind: friction, target: big_box, bounds: [0.1, 1], scale: cubic}", "params[0].scale",
     ["linear, log"]),
    ("params:\n  - {kind: friction, target: big_box, bounds: [0.1, 1], stat: 0.5}", "params[0]",
     ["unknown key 'stat'", "start"]),
    ("params:\n  - {kind: friction, target: big_box, value: 0.3, bounds: [0.1, 1]}", "params[0]", ["not both"]),
    ("params:\n  - {kind: friction, target: big_box, bounds: [0.1, x]}", "params[0].bounds[1]", ["finite number"]),
    ("params:\n  - {kind: friction, target: big_box, value: .nan}", "params[0].value", ["finite number"]),
    ("params:\n  - {kind: friction, target: big_box, value: 0.3, effect: 3}", "params[0].effect", ["effect's name"]),
    ("params:\n  - {kind: friction, target: big_box, value: 0.3}\n  - {kind: friction, target: big_box, value: 0.4}",
     "params[1]", ["friction[big_box] is given twice"]),
    ("params: []", "params", ["non-empty list"]),
    ("parms:\n  - {kind: friction}", None, ["'params' list"]),
    ("params:\n  - {kind: friction, target: big_box, value: 0.3}\nextra: 1", None, ["unknown key 'extra'"]),
    ("params:\n  - friction", "params[0]", ["must be a mapping"]),
    ("format: 1\neffects:\n  - {effect: friction, target: block, params: {mu: 0.3}}", None,
     ["scene file of bridge 0.1", "run bridge diagnose again"]),
])
def test_malformed_files_name_file_field_and_choices(tmp_path, text, field, words):
    path = write(tmp_path, text + "\n")
    with pytest.raises(ParameterError) as info:
        load_param_file(path)
    message = str(info.value)
    assert str(path) in message
    if field:
        assert f": {field}:" in message
    for word in words:
        assert word in message, message


def test_missing_file_and_yaml_syntax_error(tmp_path):
    with pytest.raises(ParameterError, match="parameter file not found"):
        load_param_file(tmp_path / "nope.yaml")
    with pytest.raises(ParameterError, match="line 3, column 1: YAML syntax error"):
        load_param_file(write(tmp_path, "params:\n  - {kind: friction, target: [\n"))


@pytest.fixture(scope="module")
def world():
    return push_world()


def test_unknown_target_lists_objects_types_and_links(tmp_path, world, odb):
    spec = load_param_file(write(tmp_path, "params:\n  - {kind: friction, target: bigbox, bounds: [0.1, 1]}\n"))
    with pytest.raises(ParameterError) as info:
        check_targets(spec, [world], odb)
    message = str(info.value)
    for word in ("params[0].target", "unknown target 'bigbox'", "big_box, small_box, table", "type:<type>",
                 "pusher"):
        assert word in message, message
    fixture_mass = parse_params({"params": [{"kind": "mass", "target": "table", "bounds": [1, 2]}]})
    with pytest.raises(ParameterError, match="objects: big_box, small_box;"):
        check_targets(fixture_mass, [world], odb)  # a fixture has no mass to fit
    latency = parse_params({"params": [{"kind": "latency", "target": "robot", "bounds": [0, 0.1]}]})
    with pytest.raises(ParameterError, match="latency targets the robot: pusher"):
        check_targets(latency, [world], odb)
    slope = parse_params({"params": [{"kind": "surface_slope_x", "target": "big_box", "value": 0.01}]})
    with pytest.raises(ParameterError, match="objects: table;"):
        check_targets(slope, [world], odb)  # a tilt tilts a fixture


def test_fitted_file_round_trip_and_use_without_bounds(tmp_path, world, odb):
    spec = load_param_file(write(tmp_path, GOOD))
    fitted = spec.fixed_at([0.31, 0.62, 2e6, 0.9, 0.004])
    path = tmp_path / "fitted.yaml"
    save_param_file(path, fitted, header="fitted by a test", record={"fit": {"optimizer": "cmaes"}})
    assert path.read_text().startswith("# fitted by a test\n")
    again = load_param_file(path)
    assert not again.free and [p.value for p in again.entries] == [0.31, 0.62, 2e6, 0.9, 0.004, 2.0]
    assert again.entries[-1].effect == "friction"  # the label survives
    rollout = apply_model(replay_model(again), Rollout(world, push_telemetries()["slide"]), odb)
    assert rollout.values.objects["big_box"].hydroelastic_modulus == 2e6
    assert rollout.values.objects["big_box"].dissipation == rollout.values.objects["small_box"].dissipation == 2.0
    no_start = parse_params({"params": [{"kind": "friction", "target": "table", "bounds": [0.1, 1]}]}, "p.yaml")
    with pytest.raises(ParameterError, match="p.yaml: parameter friction\\[table\\] has bounds but no value"):
        replay_model(no_start)


def test_every_kind_can_be_named_in_a_file(world, odb):
    """Every kind of the registry reads from a parameter file (what `bridge fit --params` reads) and says what it
    does, in which unit, on which targets."""
    for name, kind in KINDS.items():
        assert kind.name == name and kind.doc, name
        assert kind.targets in ("objects", "contacts", "free objects", "surfaces", "robot", "joints"), name
        target = {"robot": "pusher", "joints": "pusher_x", "surfaces": "table"}.get(kind.targets, "big_box")
        lo, hi = kind.bounds(world, odb, target)
        spec = parse_params({"params": [{"kind": name, "target": target, "bounds": [lo, hi]}]}, f"{name}.yaml")
        check_targets(spec, [world], odb)
        assert lo <= kind.null(world, odb, target) <= hi and kind.step(world, odb, target) > 0, name

"""Parameter files: parsing, every malformed case named by file and field, the kind registry, applying values."""
from __future__ import annotations

import math
import textwrap
from typing import ClassVar

import numpy as np
import pytest

from bridge.errors import FitError
from bridge.fit.params import (
    PARAMETER_KINDS, ParameterKind, apply_params, check_targets, load_param_file, parse_params, register_kind,
    save_param_file, scene_setting)
from bridge.fit.synthetic import push_telemetries, push_world


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
      - {kind: dissipation, target: type:box, value: 2.0}
"""


def test_reads_free_and_fixed_entries(tmp_path):
    spec = load_param_file(write(tmp_path, GOOD))
    assert spec.names == ("friction[big_box]", "friction[table]", "hydroelastic_modulus[big_box]", "mass[small_box]",
                          "com_x[big_box]")
    assert [p.name for p in spec.fixed] == ["dissipation[type:box]"]
    np.testing.assert_allclose(spec.start_values(), [0.5, 0.5, 1e6, 1.25, 0.0])  # mass: middle of its bounds
    modulus = spec.free[2]
    assert modulus.to_unit(1e6) == pytest.approx(1 / 3)  # log scale: 1e5 .. 1e8
    assert modulus.from_unit(2 / 3) == pytest.approx(1e7)


def test_unit_box_round_trip_and_clipping(tmp_path):
    spec = load_param_file(write(tmp_path, GOOD))
    values = np.array([0.3, 0.9, 3e7, 1.7, -0.01])
    np.testing.assert_allclose(spec.from_unit(spec.to_unit(values)), values)
    np.testing.assert_allclose(spec.from_unit([-1, 2, 0, 1, 0.5]), [0.1, 1.0, 1e5, 2.0, 0.0])


@pytest.mark.parametrize("text, field, words", [
    ("params:\n  - {kind: frction, target: big_box, bounds: [0.1, 1]}", "params[0].kind",
     ["unknown kind 'frction'", "friction", "mass", "latency"]),
    ("params:\n  - {kind: friction, bounds: [0.1, 1]}", "params[0]", ["missing field 'target'"]),
    ("params:\n  - {target: big_box, bounds: [0.1, 1]}", "params[0]", ["missing field 'kind'"]),
    ("params:\n  - {kind: friction, target: big_box}", "params[0]", ["missing field 'bounds'", "'value'"]),
    ("params:\n  - {kind: friction, target: big_box, bounds: [1.0, 0.1]}", "params[0].bounds",
     ["bounds must increase"]),
    ("params:\n  - {kind: friction, target: big_box, bounds: [0.5, 0.5]}", "params[0].bounds", ["increase"]),
    ("params:\n  - {kind: friction, target: big_box, bounds: [0.1]}", "params[0].bounds", ["two numbers"]),
    ("params:\n  - {kind: friction, target: big_box, bounds: [0.1, 1.0], start: 2}", "params[0].start",
     ["start 2 is outside the bounds [0.1, 1]"]),
    ("params:\n  - {kind: mass, target: big_box, bounds: [0, 2]}", "params[0].bounds[0]", ["mass must be > 0"]),
    ("params:\n  - {kind: friction, target: big_box, bounds: [-0.1, 1]}", "params[0].bounds[0]", [">= 0"]),
    ("params:\n  - {kind: com_x, target: big_box, bounds: [-0.1, 0.1], scale: log}", "params[0].bounds",
     ["log scale needs bounds > 0"]),
    ("params:\n  - {kind: friction, target: big_box, bounds: [0.1, 1], scale: cubic}", "params[0].scale",
     ["linear, log"]),
    ("params:\n  - {kind: friction, target: big_box, bounds: [0.1, 1], stat: 0.5}", "params[0]",
     ["unknown key 'stat'", "start"]),
    ("params:\n  - {kind: friction, target: big_box, value: 0.3, bounds: [0.1, 1]}", "params[0]", ["not both"]),
    ("params:\n  - {kind: friction, target: big_box, bounds: [0.1, x]}", "params[0].bounds[1]", ["finite number"]),
    ("params:\n  - {kind: friction, target: big_box, value: .nan}", "params[0].value", ["finite number"]),
    ("params:\n  - {kind: friction, target: big_box, value: 0.3}\n  - {kind: friction, target: big_box, value: 0.4}",
     "params[1]", ["friction[big_box] is given twice"]),
    ("params: []", "params", ["non-empty list"]),
    ("parms:\n  - {kind: friction}", None, ["'params' list"]),
    ("params:\n  - {kind: friction, target: big_box, value: 0.3}\nextra: 1", None, ["unknown key 'extra'"]),
    ("params:\n  - friction", "params[0]", ["must be a mapping"]),
])
def test_malformed_files_name_file_field_and_choices(tmp_path, text, field, words):
    path = write(tmp_path, text + "\n")
    with pytest.raises(FitError) as info:
        load_param_file(path)
    message = str(info.value)
    assert str(path) in message
    if field:
        assert f": {field}:" in message
    for word in words:
        assert word in message, message


def test_missing_file_and_yaml_syntax_error(tmp_path):
    with pytest.raises(FitError, match="parameter file not found"):
        load_param_file(tmp_path / "nope.yaml")
    with pytest.raises(FitError, match="line 3, column 1: YAML syntax error"):
        load_param_file(write(tmp_path, "params:\n  - {kind: friction, target: [\n"))


@pytest.fixture(scope="module")
def world():
    return push_world()


def test_unknown_target_lists_objects_types_and_links(tmp_path, world, odb):
    spec = load_param_file(write(tmp_path, "params:\n  - {kind: friction, target: bigbox, bounds: [0.1, 1]}\n"))
    with pytest.raises(FitError) as info:
        check_targets(spec, [world], odb)
    message = str(info.value)
    for word in ("params[0].target", "unknown target 'bigbox'", "big_box, small_box, table", "type:<type>",
                 "pusher"):
        assert word in message, message
    fixture_mass = parse_params({"params": [{"kind": "mass", "target": "table", "bounds": [1, 2]}]})
    with pytest.raises(FitError, match="objects in the trials: big_box, small_box;"):
        check_targets(fixture_mass, [world], odb)  # a fixture has no mass to fit
    latency = parse_params({"params": [{"kind": "latency", "target": "robot", "bounds": [0, 0.1]}]})
    with pytest.raises(FitError, match="latency targets the robot: pusher"):
        check_targets(latency, [world], odb)


def test_apply_writes_scene_params_and_telemetry(world, odb):
    telemetry = push_telemetries()["slide"]
    spec = parse_params({"params": [
        {"kind": "friction", "target": "type:box", "bounds": [0.1, 1]},
        {"kind": "friction", "target": "pusher/pusher_rod", "bounds": [0.1, 1]},
        {"kind": "com_x", "target": "big_box", "bounds": [-0.05, 0.05]},
        {"kind": "com_z", "target": "big_box", "bounds": [-0.05, 0.05]},
        {"kind": "force_y", "target": "small_box", "bounds": [-1, 1]},
        {"kind": "latency", "target": "pusher", "bounds": [0, 0.2]},
        {"kind": "joint_offset", "target": "pusher_y", "bounds": [-0.01, 0.01]},
        {"kind": "mass", "target": "small_box", "value": 0.7},
    ]})
    params, tel = apply_params(spec, [0.4, 0.2, 0.01, -0.02, 0.5, 0.05, 0.003], world, telemetry, odb)
    assert params.objects["big_box"].friction == params.objects["small_box"].friction == 0.4  # type:box: both boxes
    assert params.objects["pusher/pusher_rod"].friction == 0.2
    assert params.objects["big_box"].com == pytest.approx((0.01, 0.0, -0.02))  # the other axes keep the database's
    assert params.objects["small_box"].mass == 0.7
    assert params.external_forces["small_box"] == (0.0, 0.5, 0.0)
    np.testing.assert_allclose(tel.times, telemetry.times + 0.05)
    np.testing.assert_allclose(tel.positions[:, 1], telemetry.positions[:, 1] + 0.003)
    np.testing.assert_allclose(tel.positions[:, 0], telemetry.positions[:, 0])
    assert "table" not in params.objects  # nothing else touched; the inputs unchanged
    assert telemetry.times[0] == 0.0


def test_a_new_kind_is_one_registered_class(world, odb):
    @register_kind
    class TableFriction(ParameterKind):
        name: ClassVar[str] = "test_table_friction"
        doc = "friction of every fixture (a test kind)"

        def apply(self, value, names, setting):
            return setting.with_object("table", friction=2 * value)

    try:
        spec = parse_params({"params": [{"kind": "test_table_friction", "target": "table", "bounds": [0.1, 1]}]})
        params, _ = apply_params(spec, [0.3], world, push_telemetries()["slide"], odb)
        assert params.objects["table"].friction == pytest.approx(0.6)
    finally:
        del PARAMETER_KINDS["test_table_friction"]


def test_fitted_file_round_trip_and_use_without_bounds(tmp_path, world, odb):
    spec = load_param_file(write(tmp_path, GOOD))
    fitted = spec.fixed_at([0.31, 0.62, 2e6, 0.9, 0.004])
    path = tmp_path / "fitted.yaml"
    save_param_file(path, fitted, header="fitted by a test")
    assert path.read_text().startswith("# fitted by a test\n")
    again = load_param_file(path)
    assert not again.free and [p.value for p in again.entries] == [0.31, 0.62, 2e6, 0.9, 0.004, 2.0]
    params, _ = scene_setting(again, world, push_telemetries()["slide"], odb)
    assert params.objects["big_box"].hydroelastic_modulus == 2e6
    assert params.objects["big_box"].dissipation == params.objects["small_box"].dissipation == 2.0
    no_start = parse_params({"params": [{"kind": "friction", "target": "table", "bounds": [0.1, 1]}]}, "p.yaml")
    with pytest.raises(FitError, match="p.yaml: parameter friction\\[table\\] has bounds but no value"):
        scene_setting(no_start, world, push_telemetries()["slide"], odb)


def test_kinds_travel_to_workers_by_name():
    """Tasks pickle their kinds; a kind class made inside a function (not importable) must survive that too."""
    import pickle

    from bridge.fit.kinds import kind_named

    register_kind(type("LocalKind", (ParameterKind,), {"name": "test_local_kind", "doc": "made in a function"}))
    try:
        for name in ("friction", "latency", "test_local_kind"):
            kind = PARAMETER_KINDS[name]
            assert pickle.loads(pickle.dumps(kind)) is kind
    finally:
        del PARAMETER_KINDS["test_local_kind"]
    with pytest.raises(FitError, match="unknown parameter kind 'test_local_kind'; kinds: .*friction"):
        kind_named("test_local_kind")


def test_every_registered_kind_says_what_it_does():
    for name, kind in PARAMETER_KINDS.items():
        assert kind.name == name and kind.doc, name
        assert kind.targets in ("objects", "contacts", "free objects", "robot", "joints"), name
    assert not math.isnan(PARAMETER_KINDS["friction"].minimum)

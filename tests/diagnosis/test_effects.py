"""The catalog: exactly the named effects, each with parameters, a model that enters the replay, and a scene
file that round-trips."""
import math

import pytest

from bridge.diagnosis.effects import EFFECTS, Applied, Effect, get_effect, register_effect
from bridge.diagnosis.scenefile import load_scene_file, parse_scene, save_scene_file
from bridge.diagnosis.simulation import resolve
from bridge.errors import DiagnosisError
from bridge.sim.shapes import mass_properties

NAMES = ["none", "friction", "mass", "com_offset", "surface_tilt", "friction_patch", "latency", "pusher_offset",
         "hidden_obstacle"]


def test_registry_holds_exactly_the_catalog():
    assert list(EFFECTS) == NAMES
    for name, effect in EFFECTS.items():
        assert isinstance(effect, Effect) and effect.name == name
        assert effect.summary and effect.mechanism and effect.signature_text


@pytest.mark.parametrize("name", NAMES)
def test_every_effect_has_bounded_parameters_and_a_null_model(name, planar_world, odb):
    effect = get_effect(name)
    targets = effect.targets(planar_world, odb, ["block"])
    assert targets, name
    for target in targets:
        specs = effect.params(planar_world, odb, target)
        for p in specs:
            assert p.lower <= p.null <= p.upper and p.scale > 0
        if effect.smooth and name != "none":
            null = resolve((Applied.of(name, target, effect.null_values(planar_world, odb, target)),), planar_world, odb)
            assert not null.extras and not null.hooks
            assert null.telemetry.is_identity


def test_models_enter_the_replay_the_documented_way(planar_world, odb):
    setup = resolve((Applied.of("friction", "surface", {"mu": 0.4}),
                     Applied.of("com_offset", "block", {"dx": 0.01, "dy": 0.0}),
                     Applied.of("latency", "pusher", {"dt": 0.05}),
                     Applied.of("pusher_offset", "pusher", {"pusher_x": 0.002, "pusher_y": 0.0})), planar_world, odb)
    assert setup.params.objects["surface"].friction == 0.4
    assert setup.params.objects["block"].com[0] == pytest.approx(0.01)
    assert setup.telemetry.time_shift == 0.05 and dict(setup.telemetry.joint_offsets)["pusher_x"] == 0.002
    tilt = resolve((Applied.of("surface_tilt", "surface", {"slope_x": 0.02, "slope_y": 0.0, "dz": 0.0}),), planar_world, odb)
    poses = dict(tilt.poses)
    assert poses["block"].xyz[:2] == pytest.approx(planar_world.objects["block"].pose.xyz[:2])
    assert math.degrees(poses["surface"].rotation_to(planar_world.objects["surface"].pose)) == pytest.approx(
        math.degrees(0.02), rel=1e-6)
    post = resolve((Applied.of("hidden_obstacle", "surface", {"x": 0.1, "y": 0.0}),), planar_world, odb)
    assert post.extras[0].shape == "cylinder" and post.extras[0].xyz[:2] == (0.1, 0.0)
    patch = resolve((Applied.of("friction_patch", "surface", {"cx": 0.1, "cy": 0.0, "half": 0.05, "mu": 0.1}),),
                    planar_world, odb)
    sheet = patch.extras[0]
    assert sheet.friction == 0.1 and sheet.region == pytest.approx((0.05, 0.15, -0.05, 0.05))


def test_scene_file_round_trips_and_names_bad_entries(tmp_path, planar_world, odb):
    model = (Applied.of("friction", "block", {"mu": 0.3}), Applied.of("hidden_obstacle", "surface", {"x": 0.1, "y": 0.02}))
    path = save_scene_file(tmp_path / "scene.yaml", model, {"verdict": "hidden_obstacle"})
    scene = load_scene_file(path)
    assert scene.effects == model
    setup = scene.resolve(planar_world, odb)
    assert setup.params.objects["block"].friction == 0.3 and len(setup.extras) == 1
    with pytest.raises(DiagnosisError, match="unknown effect 'gravity'"):
        parse_scene({"effects": [{"effect": "gravity", "target": "block", "params": {}}]}, "s.yaml")
    with pytest.raises(DiagnosisError, match="cannot target 'table'"):
        parse_scene({"effects": [{"effect": "mass", "target": "table", "params": {"mass": 1.0}}]}).check(planar_world, odb)
    with pytest.raises(DiagnosisError, match="has no parameter 'm'"):
        parse_scene({"effects": [{"effect": "mass", "target": "block", "params": {"m": 1.0}}]}).check(planar_world, odb)
    with pytest.raises(DiagnosisError, match="finite number"):
        parse_scene({"effects": [{"effect": "mass", "target": "block", "params": {"mass": "x"}}]})


def test_a_user_effect_is_one_class(planar_world, odb):
    from bridge.diagnosis.effects.base import Contribution, ParamSpec

    class Wind(Effect):
        name = "wind"
        summary, mechanism, signature_text = "a draught pushes objects", "scene values: a force", "steady drift"

        def targets(self, world, odb, observed):
            return tuple(observed)

        def params(self, world, odb, target):
            return (ParamSpec("fx", -1.0, 1.0, 0.0, 0.1, "N"),)

        def contribute(self, world, odb, target, values):
            return Contribution(forces=((target, (values["fx"], 0.0, 0.0)),))

    try:
        register_effect(Wind())
        setup = resolve((Applied.of("wind", "block", {"fx": 0.2}),), planar_world, odb)
        assert setup.params.external_forces["block"] == (0.2, 0.0, 0.0)
    finally:
        EFFECTS.pop("wind", None)


def test_negligible_parameters_are_the_effects_own(planar_world, odb):
    """A centre of mass moved 0.5 mm is negligible even with a doubled mass (the mass is `mass`'s business);
    3 mm is not; an effect without declared sizes (an obstacle) never is."""
    from bridge.diagnosis.effects import get_effect

    com, m = get_effect("com_offset"), mass_properties(odb, "steel_block").mass
    assert com.negligible(planar_world, odb, "block", {"dx": 0.0005, "dy": -0.0003, "mass": 2 * m})
    assert not com.negligible(planar_world, odb, "block", {"dx": 0.003, "dy": 0.0, "mass": m})
    assert get_effect("mass").negligible(planar_world, odb, "block", {"mass": 1.03 * m, "spread": 0.0})
    assert not get_effect("hidden_obstacle").negligible(planar_world, odb, "surface", {"x": 0.0, "y": 0.0})


def test_the_ordinary_replay_refuses_a_scene_file_that_needs_context_hooks(planar_world, odb):
    """A user's effect may change the running context (`Contribution.hooks`); only the diagnosis' replay runs
    those, so `infer`/`view`/`demo`/`fit --scene` say so, naming the file, instead of silently dropping them."""
    import numpy as np

    from bridge.diagnosis.effects.base import Contribution, ParamSpec
    from bridge.diagnosis.scenefile import SceneFile, replay_setting
    from bridge.recording.telemetry import Telemetry

    class Gust(Effect):
        name = "gust"
        summary, mechanism, signature_text = "a gust now and then", "context hook", "sudden drift"

        def targets(self, world, odb, observed):
            return tuple(observed)

        def params(self, world, odb, target):
            return (ParamSpec("f", 0.0, 1.0, 0.0, 0.1, "N"),)

        def contribute(self, world, odb, target, values):
            return Contribution(hooks=(object(),))

    telemetry = Telemetry(np.array([0.0, 1.0]), ("pusher_x", "pusher_y"), np.zeros((2, 2)))
    try:
        register_effect(Gust())
        scene = SceneFile((Applied.of("gust", "block", {"f": 0.5}),), source="gusty.yaml")
        with pytest.raises(DiagnosisError, match="context hooks") as raised:
            replay_setting(scene, planar_world, telemetry, odb)
        assert "gusty.yaml" in str(raised.value)
    finally:
        EFFECTS.pop("gust", None)

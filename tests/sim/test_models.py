"""The robot models load in Drake with the names, actuators, limits and frames the scene builder relies on."""
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pydrake")

from pydrake.geometry import Box, ProximityProperties  # noqa: E402
from pydrake.math import RigidTransform  # noqa: E402
from pydrake.multibody.inverse_kinematics import InverseKinematics  # noqa: E402
from pydrake.multibody.parsing import Parser  # noqa: E402
from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlantConfig  # noqa: E402
from pydrake.multibody.tree import JointActuatorIndex  # noqa: E402
from pydrake.solvers import Solve  # noqa: E402
from pydrake.systems.framework import DiagramBuilder  # noqa: E402

MODELS = Path(__file__).resolve().parents[2] / "models"
ARM_SDF = MODELS / "arm7" / "arm7.sdf"
PUSHER_SDF = MODELS / "pusher2d" / "pusher2d.sdf"

ARM_JOINTS = tuple(f"arm_joint{i}" for i in range(1, 8)) + ("finger_left_joint", "finger_right_joint")
ARM_LINKS = ("arm_base",) + tuple(f"arm_link{i}" for i in range(1, 8)) + ("hand", "finger_left", "finger_right")
TABLE_TOP = 0.75


def _load(sdf: Path, base: str, base_xyz, with_table: bool = False):
    builder = DiagramBuilder()
    plant, _ = AddMultibodyPlant(MultibodyPlantConfig(time_step=0.002, discrete_contact_approximation="lagged"),
                                 builder)
    (instance,) = Parser(plant).AddModels(str(sdf))
    plant.WeldFrames(plant.world_frame(), plant.GetFrameByName(base, instance), RigidTransform(base_xyz))
    if with_table:
        plant.RegisterCollisionGeometry(plant.world_body(), RigidTransform([0.75, 0.0, TABLE_TOP - 0.025]),
                                        Box(0.8, 1.2, 0.05), "table", ProximityProperties())
    plant.Finalize()
    return builder.Build(), plant, instance


def _actuated_joint_names(plant, instance):
    actuators = (plant.get_joint_actuator(JointActuatorIndex(i)) for i in range(plant.num_actuators()))
    return tuple(a.joint().name() for a in actuators if a.model_instance() == instance)


def _check_limits(plant):
    for lower, upper in ((plant.GetPositionLowerLimits(), plant.GetPositionUpperLimits()),
                         (plant.GetVelocityLowerLimits(), plant.GetVelocityUpperLimits())):
        assert np.all(np.isfinite(lower)) and np.all(np.isfinite(upper))
        assert np.all(lower < upper)
    for i in range(plant.num_actuators()):
        actuator = plant.get_joint_actuator(JointActuatorIndex(i))
        assert 0 < actuator.effort_limit() < np.inf, actuator.name()
        assert actuator.has_controller(), actuator.name()


def test_arm7_joints_links_actuators_and_limits():
    _, plant, instance = _load(ARM_SDF, "arm_base", [0, 0, TABLE_TOP])
    assert plant.num_positions() == 9
    assert plant.num_actuators() == 9
    assert _actuated_joint_names(plant, instance) == ARM_JOINTS
    for name in ARM_LINKS:
        assert plant.HasBodyNamed(name, instance), name
    assert plant.HasFrameNamed("tcp", instance)
    _check_limits(plant)
    for finger in ("finger_left_joint", "finger_right_joint"):
        joint = plant.GetJointByName(finger, instance)
        assert joint.position_lower_limits()[0] == 0.0
        assert joint.position_upper_limits()[0] == pytest.approx(0.05)
    for name in ARM_LINKS[1:]:
        assert plant.GetCollisionGeometriesForBody(plant.GetBodyByName(name, instance)), name


def test_arm7_reaches_the_table_top_pointing_down():
    diagram, plant, instance = _load(ARM_SDF, "arm_base", [0, 0, TABLE_TOP], with_table=True)
    context = plant.GetMyMutableContextFromRoot(diagram.CreateDefaultContext())
    ik = InverseKinematics(plant, context)
    tcp = plant.GetFrameByName("tcp", instance)
    target = np.array([0.6, 0.1, 0.80])
    ik.AddPositionConstraint(tcp, np.zeros(3), plant.world_frame(), target - 1e-4, target + 1e-4)
    ik.AddAngleBetweenVectorsConstraint(tcp, [0, 0, 1], plant.world_frame(), [0, 0, -1], 0.0, 0.01)
    ik.AddMinimumDistanceLowerBoundConstraint(0.005)
    home = np.array([0.0, 0.35, 0.0, 1.95, 0.0, 0.85, 0.0, 0.04, 0.04])
    ik.prog().AddQuadraticErrorCost(np.eye(9), home, ik.q())
    ik.prog().SetInitialGuess(ik.q(), home)
    result = Solve(ik.prog())
    assert result.is_success()
    plant.SetPositions(context, result.GetSolution(ik.q()))
    X_WT = tcp.CalcPoseInWorld(context)
    np.testing.assert_allclose(X_WT.translation(), target, atol=1e-3)
    assert X_WT.rotation().matrix()[:, 2] @ [0, 0, -1] > np.cos(0.02)


def test_pusher2d_joints_actuators_limits_and_tip():
    _, plant, instance = _load(PUSHER_SDF, "pusher_base", [0, 0, 0.0064])
    assert plant.num_positions() == 2
    assert plant.num_actuators() == 2
    assert _actuated_joint_names(plant, instance) == ("pusher_x", "pusher_y")
    _check_limits(plant)
    np.testing.assert_allclose(plant.GetPositionUpperLimits(), [1.0, 1.0])
    assert plant.HasFrameNamed("tip", instance)
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, [0.1, -0.2])
    tip = plant.GetFrameByName("tip", instance).CalcPoseInWorld(context).translation()
    np.testing.assert_allclose(tip, [0.1, -0.2, 0.0064], atol=1e-12)
    rod = plant.GetBodyByName("pusher_rod", instance)
    assert rod.default_mass() == pytest.approx(0.1)


def test_add_models_reads_the_same_model_from_text_and_resolves_a_mesh_beside_its_file(tmp_path, monkeypatch):
    """`scene.add_models` parses a self-contained model from its text (libsdformat rebuilds its schema for every
    file it loads) and one that names a mesh from its file, so the mesh's relative path resolves beside it."""
    from bridge.sim.scene import add_models

    def joints(path):
        plant, _ = AddMultibodyPlant(MultibodyPlantConfig(time_step=0.002), DiagramBuilder())
        (instance,) = add_models(Parser(plant, "r"), path)
        plant.Finalize()
        return sorted(plant.get_joint(j).name() for j in plant.GetJointIndices(instance)), plant.num_actuators()

    assert joints(PUSHER_SDF) == (["pusher_base", "pusher_x", "pusher_y"], 2)  # the base floats: not welded here
    folder = tmp_path / "model"
    folder.mkdir()
    (folder / "cube.obj").write_text("v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nv 0 0 0.1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n")
    text = PUSHER_SDF.read_text().replace(
        "<geometry><cylinder><radius>0.00476</radius><length>0.010</length></cylinder></geometry>",
        "<geometry><mesh><uri>cube.obj</uri></mesh></geometry>", 1)  # rigid hydroelastic: Drake reads it
    assert "cube.obj" in text
    (folder / "meshed.sdf").write_text(text)
    monkeypatch.chdir(tmp_path)  # not beside the mesh: only the file's folder resolves it
    assert joints(folder / "meshed.sdf") == (["pusher_base", "pusher_x", "pusher_y"], 2)


def test_a_model_parsed_from_its_text_is_named_by_its_file_in_drakes_error(tmp_path):
    """Drake calls a model parsed from text "<data-string>"; `add_models` puts the file's path there, as a parse of
    the file would."""
    from bridge.sim.scene import add_models

    broken = tmp_path / "broken.sdf"
    broken.write_text(PUSHER_SDF.read_text().replace("<mass>0.1</mass>", "<mass>heavy</mass>", 1))
    plant, _ = AddMultibodyPlant(MultibodyPlantConfig(time_step=0.002), DiagramBuilder())
    with pytest.raises(RuntimeError) as err:
        add_models(Parser(plant, "r"), broken)
    assert str(err.value).startswith(f"{broken}:") and "<mass>" in str(err.value)
    assert "-string>" not in str(err.value)

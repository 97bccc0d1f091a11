"""Shared by the contact-physics tests: pushes of the proof's steel block on its plate, as real Drake rollouts."""
import numpy as np
import pytest


@pytest.fixture(scope="session")
def block_pushes(odb):
    """Two pushes of the block (`bridge.prove.scenes`, seed 3): the first turns it by ~45 deg, the second runs
    nearly straight along +x."""
    from bridge.prove.scenes import design_pushes, nominal_world, scene_spec
    from bridge.recording.telemetry import Telemetry
    from bridge.rollout.rollout import Rollout

    spec = scene_spec("planar", odb)
    return [Rollout(nominal_world(spec, odb, p.start), Telemetry(p.times, ("pusher_x", "pusher_y"), p.path))
            for p in design_pushes(spec, odb, np.random.default_rng(3), 2)]


@pytest.fixture(scope="session")
def block_track(odb):
    """Replays a rollout of the block; returns its track (n, 7: x y z qw qx qy qz) at 50 Hz."""
    from bridge.rollout.rollout import run_rollout
    from bridge.sim.simulate import SimOptions

    def replay(rollout):
        end = float(rollout.telemetry.times[-1])
        return run_rollout(rollout, odb, SimOptions(sample_rate=50.0, end=end)).tracks["block"]

    return replay


SPIN = 10.0  # rad/s: the spin a torsion test starts an object with (the MIT shapes' rims slide at 0.3-0.6 m/s)
SPIN_STEP = 0.05  # s: the turn is summed over steps this short (at most half a radian each at SPIN)


@pytest.fixture(scope="session")
def spin_down():
    """How far (rad) an object turns when, resting on what carries it with the robot taken away, it starts
    spinning about the vertical at `spin`: the torsion its weight's friction gives it, as the simulator has it.
    The turn is spin^2 I / (2 mu m g <r>), <r> the weight's mean distance from the centre, so two contact
    geometries of one object, coefficients and mass turn in the inverse ratio of their <r>: the ratio
    `SupportPressure.scale` sets."""
    import math
    from dataclasses import replace

    from pydrake.multibody.math import SpatialVelocity
    from pydrake.systems.analysis import Simulator

    from bridge.sim.scene import build_scene

    def turn(world, odb, obj, config, values=None, extras=(), spin=SPIN, settle=0.2, longest=5.0) -> float:
        world = replace(world, robot=None)
        scene = build_scene(world, odb, config, extras=extras)
        context = scene.new_context(world, values)
        plant = scene.plant
        plant_ctx = plant.GetMyMutableContextFromRoot(context)
        body = scene.bodies[obj]
        simulator = Simulator(scene.diagram, context)
        simulator.Initialize()
        simulator.AdvanceTo(settle)
        plant.SetFreeBodySpatialVelocity(plant_ctx, body, SpatialVelocity(np.array([0.0, 0.0, spin]), np.zeros(3)))
        turned, t = 0.0, settle
        before = plant.EvalBodyPoseInWorld(plant_ctx, body).rotation()
        while t < settle + longest:
            t += SPIN_STEP
            simulator.AdvanceTo(t)
            after = plant.EvalBodyPoseInWorld(plant_ctx, body).rotation()
            r = before.inverse().multiply(after).matrix()
            turned += math.atan2(r[1, 0] - r[0, 1], r[0, 0] + r[1, 1])
            before = after
            if abs(plant.EvalBodySpatialVelocityInWorld(plant_ctx, body).rotational()[2]) < 1e-3 * spin:
                break
        return turned

    return turn

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

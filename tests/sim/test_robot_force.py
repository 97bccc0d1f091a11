"""The contact force on the robot, as a force sensor reads it, through the real Drake simulation: during a
steady push it balances the support's friction (mu m g), and it doubles with the mass while the path stays
(why the diagnosis needs it to tell mass from friction)."""
from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("pydrake")

from bridge.odb import load_object_database  # noqa: E402
from bridge.prove.scenes import design_pushes, nominal_world, scene_spec  # noqa: E402
from bridge.recording.telemetry import Telemetry  # noqa: E402
from bridge.sim.friction import combined_friction  # noqa: E402
from bridge.sim.scene import SceneValues, build_scene  # noqa: E402
from bridge.sim.shapes import mass_properties  # noqa: E402
from bridge.sim.simulate import SimOptions, simulate  # noqa: E402

G = 9.81


@pytest.mark.slow
def test_push_force_balances_friction_and_scales_with_mass():
    odb = load_object_database()
    spec = scene_spec("planar", odb)
    push = design_pushes(spec, odb, np.random.default_rng(3), 1)[0]
    world = nominal_world(spec, odb, push.start)
    scene = build_scene(world, odb)
    telemetry = Telemetry(push.times, ("pusher_x", "pusher_y"), push.path)
    m = mass_properties(odb, spec.object_type).mass
    mu = combined_friction(odb.get(spec.object_type).physics.friction, odb.get(spec.surface_type).physics.friction)

    def run(mass):
        values = SceneValues().with_object(spec.object, mass=mass)
        return simulate(scene, telemetry, world=world, values=values,
                        options=SimOptions(end=float(push.times[-1]), robot_force=True))

    light, heavy = run(m), run(2 * m)
    f_light = np.linalg.norm(light.robot_force[:, :2], axis=1)
    f_heavy = np.linalg.norm(heavy.robot_force[:, :2], axis=1)
    pushing = (f_light > 0.3 * mu * m * G) & (f_heavy > 0.3 * mu * m * G)
    assert pushing.sum() > 10
    steady = np.median(f_light[pushing])
    # a pushed box slides and turns: the rod's force lies between the pure-slide mu m g and a fraction of it
    assert 0.6 * mu * m * G < steady < 1.3 * mu * m * G
    assert np.median(f_heavy[pushing] / f_light[pushing]) == pytest.approx(2.0, rel=0.1)
    # the path barely changes: the force is what tells them apart
    end_gap = np.linalg.norm(light.tracks[spec.object][-1, :2] - heavy.tracks[spec.object][-1, :2])
    travel = np.linalg.norm(light.tracks[spec.object][-1, :2] - light.tracks[spec.object][0, :2])
    assert end_gap < 0.1 * travel
    assert np.all(light.robot_force[:5] == 0.0)  # before the rod reaches the block nothing pushes back

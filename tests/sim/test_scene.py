"""The scene builder's promise: one diagram per scene structure, everything a replay varies (values, initial
poses) written into a fresh context and the robot's desired trajectory into the diagram's source at the
replay's start, so a fit never rebuilds the diagram and nothing of one replay stays behind for the next. Bad
input is one `SceneError` that names what is wrong and the valid choices."""
from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("pydrake")

from bridge.errors import SceneError  # noqa: E402
from bridge.fit.synthetic import push_telemetries, push_world  # noqa: E402
from bridge.sim.extras import Slug, SurfacePatch, WeldedShape  # noqa: E402
from bridge.sim.scene import SceneValues, build_scene, from_drake  # noqa: E402
from bridge.sim.shapes import mass_properties  # noqa: E402
from bridge.sim.simulate import SimOptions, simulate  # noqa: E402
from bridge.values import Pose  # noqa: E402

SETTLE = 0.2  # s after the push: enough for the lying boxes to stop, short for the test's runtime


@pytest.fixture(scope="module")
def world():
    return push_world()


@pytest.fixture(scope="module")
def telemetries():
    return push_telemetries()


@pytest.fixture(scope="module")
def scene(world, odb):
    return build_scene(world, odb)


def _final_gap(a, b) -> tuple[float, float]:
    """Largest final translation (m) and rotation (deg) between two replays' objects."""
    moved, turned = 0.0, 0.0
    for name in a.tracks:
        pa, pb = a.tracks[name][-1], b.tracks[name][-1]
        moved = max(moved, float(np.linalg.norm(pa[:3] - pb[:3])))
        dot = min(1.0, abs(float(pa[3:] @ pb[3:])) / (np.linalg.norm(pa[3:]) * np.linalg.norm(pb[3:])))
        turned = max(turned, math.degrees(2 * math.acos(dot)))
    return moved, turned


def test_each_context_carries_its_own_values_and_nothing_stays_behind(scene, telemetries):
    """A fit replays one diagram with many candidate values: each must act in its own replay only, and a replay
    with the database's values must come out bit for bit the same whatever ran before it."""
    turn = telemetries["turn"]
    options = SimOptions(settle=SETTLE)
    first = simulate(scene, turn, options=options)
    assert set(first.moved) == {"big_box", "small_box"}  # the push does something the values can change
    variants = {
        "friction": SceneValues().with_object("big_box", friction=0.2),
        "mass": SceneValues().with_object("small_box", mass=1.0),
        "com": SceneValues().with_object("big_box", com=(0.0, 0.0, 0.04)),
        "force": SceneValues().with_force("small_box", (0.0, 1.0, 0.0)),
    }
    for what, values in variants.items():
        other = simulate(scene, turn, values=values, options=options)
        moved, turned = _final_gap(first, other)
        assert moved > 0.003 or turned > 3.0, f"{what}: the value changed nothing ({moved * 1e3:.1f} mm, {turned:.1f} deg)"
    again = simulate(scene, turn, options=options)
    for name, track in first.tracks.items():
        np.testing.assert_array_equal(again.tracks[name], track, err_msg=name)
    # the diagram's own default context still holds the database's mass
    default = scene.plant.GetMyContextFromRoot(scene.diagram.CreateDefaultContext())
    assert scene.bodies["small_box"].get_mass(default) == pytest.approx(0.3)


def test_new_context_writes_the_worlds_poses_not_the_scenes(scene, world):
    """Recordings of one scene share its diagram however their objects start: the poses come from the world
    given to the context."""
    moved_pose = Pose.from_rpy((0.4, -0.3, 0.8), (0.0, math.pi / 2, 0.7))
    elsewhere = world.with_poses({"big_box": moved_pose})
    plant = scene.plant
    context = scene.new_context(elsewhere)
    X = from_drake(plant.EvalBodyPoseInWorld(plant.GetMyContextFromRoot(context), scene.bodies["big_box"]))
    assert X.xyz == pytest.approx(moved_pose.xyz)
    assert X.rotation_to(moved_pose) == pytest.approx(0.0, abs=1e-9)
    X = from_drake(plant.EvalBodyPoseInWorld(plant.GetMyContextFromRoot(scene.new_context()),
                                             scene.bodies["big_box"]))
    assert X.xyz == pytest.approx(world.objects["big_box"].pose.xyz)  # the scene's own world is untouched


def test_a_replay_follows_its_own_telemetry_whatever_ran_before(scene, telemetries):
    """The desired trajectory is set in the diagram's source at each replay's start (`sources.set_desired`):
    a replay after one of other telemetry follows its own, bit for bit as it does alone."""
    slide, turn = telemetries["slide"], telemetries["turn"]
    options = SimOptions(settle=SETTLE, joint_track=True)
    alone = simulate(scene, slide, options=options)
    other = simulate(scene, turn, options=options)
    followed = turn.select(other.joint_names).sample(other.times)
    assert np.max(np.abs(other.joint_track - followed)[other.times <= turn.end]) < 0.01  # turn follows turn ...
    assert np.max(np.abs(other.joint_track - alone.joint_track)) > 0.1  # ... which goes elsewhere than slide
    again = simulate(scene, slide, options=options)
    for name, track in alone.tracks.items():
        np.testing.assert_array_equal(again.tracks[name], track, err_msg=name)


def test_each_thread_replays_on_scenes_of_its_own(world, odb, telemetries):
    """A scene runs one replay at a time (its desired trajectory lives in the diagram), so the scene cache is
    per thread: two threads replaying different telemetry at once get their serial results (to round-off: run
    at once, they once differed by 2e-13 m, docs/rollout.md; a shared scene follows the other telemetry)."""
    from concurrent.futures import ThreadPoolExecutor

    from bridge.rollout.rollout import Rollout, run_rollout, scene_for

    rollouts = [Rollout(world, telemetries[name]) for name in ("slide", "turn")]
    options = SimOptions(settle=SETTLE)
    serial = [run_rollout(r, odb, options) for r in rollouts]
    with ThreadPoolExecutor(2) as pool:
        both = list(pool.map(lambda r: (run_rollout(r, odb, options), scene_for(r, odb)), rollouts))
    assert both[0][1] is not both[1][1] and scene_for(rollouts[0], odb) is not both[0][1]
    for (result, _), alone in zip(both, serial):
        for name, track in alone.tracks.items():
            np.testing.assert_allclose(result.tracks[name], track, rtol=0.0, atol=1e-9, err_msg=name)


def _rotational_inertia_about_com(scene, context, name):
    body = scene.bodies[name]
    M = body.CalcSpatialInertiaInBodyFrame(scene.plant.GetMyContextFromRoot(context))
    return M.get_mass(), M.get_com(), M.Shift(M.get_com()).CalcRotationalInertia().CopyToFullMatrix3()


def test_mass_spread_says_whether_the_inertia_scales_with_the_mass(scene, odb):
    """Spread 1: a heavier object of the same material everywhere (inertia scales with the mass); spread 0: a
    compact weight at the centre of mass (the inertia stays the database's); in between, proportionally."""
    mp = mass_properties(odb, "big_box")
    assert mp.mass == pytest.approx(1.0)
    cases = {None: 2.0, 1.0: 2.0, 0.0: 1.0, 0.5: 1.5}  # spread -> factor on the inertia at double the mass
    for spread, factor in cases.items():
        values = SceneValues().with_object("big_box", mass=2.0, spread=spread)
        mass, com, inertia = _rotational_inertia_about_com(scene, scene.new_context(values=values), "big_box")
        assert mass == pytest.approx(2.0)
        np.testing.assert_allclose(com, mp.com, atol=1e-12)
        np.testing.assert_allclose(inertia, factor * mp.inertia, rtol=1e-9, atol=1e-12, err_msg=f"spread {spread}")
    # half the mass spread like the object's own: half the inertia
    values = SceneValues().with_object("big_box", mass=0.5)
    _, _, inertia = _rotational_inertia_about_com(scene, scene.new_context(values=values), "big_box")
    np.testing.assert_allclose(inertia, 0.5 * mp.inertia, rtol=1e-9, atol=1e-12)
    # a moved centre of mass keeps the mass and the inertia about the (new) centre of mass
    values = SceneValues().with_object("big_box", com=(0.01, 0.0, 0.03))
    mass, com, inertia = _rotational_inertia_about_com(scene, scene.new_context(values=values), "big_box")
    assert mass == pytest.approx(1.0)
    np.testing.assert_allclose(com, (0.01, 0.0, 0.03), atol=1e-12)
    np.testing.assert_allclose(inertia, mp.inertia, rtol=1e-9, atol=1e-12)


def test_values_for_an_unknown_name_list_objects_and_robot_links(scene):
    """A misspelt target must stop the replay with the names it could have meant, robot links included."""
    with pytest.raises(SceneError) as err:
        scene.new_context(values=SceneValues().with_object("bigbox", friction=0.3))
    message = str(err.value)
    assert "'bigbox'" in message
    assert "objects: big_box, small_box, table" in message
    assert "robot links with collision geometry: pusher/pusher_rod" in message


@pytest.mark.parametrize("name", ["smallbox", "table"])
def test_an_external_force_on_no_free_object_is_an_error(scene, name):
    """A force parameter aimed at a misspelt object, or at a fixture that cannot move, must not be dropped
    silently (the replay would run as if the force were there): like any other value, it names the object and
    the free objects a force can act on."""
    with pytest.raises(SceneError) as err:
        scene.new_context(values=SceneValues().with_force(name, (0.0, 5.0, 0.0)))
    message = str(err.value)
    assert f"'{name}'" in message and "big_box" in message and "small_box" in message


@pytest.mark.parametrize("change", [{"mass": 0.5}, {"com": (0.0, 0.0, 0.01)}, {"hydroelastic_modulus": 1e7},
                                    {"spread": 0.0}])
def test_a_robot_link_takes_only_contact_values(scene, change):
    """The robot's links come from its model; only the contact material may be varied."""
    with pytest.raises(SceneError, match="robot link 'pusher/pusher_rod': only friction, dynamic_friction and "
                                         "dissipation can be set"):
        scene.new_context(values=SceneValues().with_object("pusher/pusher_rod", **change))


@pytest.mark.parametrize("change", [{"mass": 5.0}, {"com": (0.0, 0.0, 0.01)}, {"spread": 0.0}])
def test_a_fixture_takes_only_contact_values(scene, change):
    """A table does not move: a mass for it is a mistake, said so rather than ignored."""
    with pytest.raises(SceneError, match="'table' is a fixture: it has no mass to change"):
        scene.new_context(values=SceneValues().with_object("table", **change))


def test_robot_link_friction_is_written_into_the_context(scene):
    """A fit may vary the rod's friction: it lands in the rod's contact properties of that context only."""
    context = scene.new_context(values=SceneValues().with_object("pusher/pusher_rod", friction=0.9,
                                                                  dynamic_friction=0.7))
    (gid,) = scene.link_geometries()["pusher/pusher_rod"]

    def friction(ctx):
        inspector = scene.scene_graph.get_query_output_port().Eval(
            scene.scene_graph.GetMyContextFromRoot(ctx)).inspector()
        return inspector.GetProximityProperties(gid).GetProperty("material", "coulomb_friction")

    assert (friction(context).static_friction(), friction(context).dynamic_friction()) == (0.9, 0.7)
    assert friction(scene.new_context()).static_friction() == 0.25  # the model's value in the next context


@pytest.mark.parametrize("extra, message", [
    (WeldedShape("post", "sphere", (0.02,), (0.5, 0.3, 0.8)), "extra 'post': shape must be 'box' .* got 'sphere'"),
    (WeldedShape("post", "box", (0.02, 0.02), (0.5, 0.3, 0.8)), "extra 'post': .* got 'box' with 2 sizes"),
    (Slug("ghost", 0.1, (0.0, 0.0, 0.0)), "slug: no free object 'ghost'"),
    (Slug("big_box", 0.0, (0.0, 0.0, 0.0)), "slug in 'big_box': mass must be > 0"),
    (SurfacePatch("sheet", (0.6, 0.5, -0.1, 0.1), 0.75, 0.2), "surface patch 'sheet': region must have x1 > x0"),
])
def test_a_bad_extra_is_a_scene_error(world, odb, extra, message):
    """Extras are checked when the scene is built, each message naming the extra and what is allowed."""
    with pytest.raises(SceneError, match=message):
        build_scene(world, odb, extras=(extra,))


def test_drakes_own_failure_while_building_is_one_scene_error(world, odb):
    """Drake refuses a second geometry named like the table's: the user sees which world and extras, not a
    traceback from inside Drake."""
    with pytest.raises(SceneError, match="Drake cannot build the scene of world 'synthetic_push' with extras "
                                         "WeldedShape: .*table/collision"):
        build_scene(world, odb, extras=(WeldedShape("table", "box", (0.1, 0.1, 0.1), (0.5, 0.3, 0.8)),))

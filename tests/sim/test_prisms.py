"""Contact geometry of compliant mesh prisms (`bridge/sim/prisms.py`, SimConfig.mesh_contact): the outline read
from the mesh, the footprint that carries the object, a non-convex outline kept non-convex, all through real
Drake scenes."""
import math
from dataclasses import replace

import numpy as np
import pytest

pytest.importorskip("pydrake")

from bridge.errors import ObjectDatabaseError  # noqa: E402
from bridge.names import build_name_map  # noqa: E402
from bridge.odb import load_object_database  # noqa: E402
from bridge.sim.contacts import ContactReader  # noqa: E402
from bridge.sim.prisms import (centroid, convex_pieces, footprint_polygon, is_convex, is_simple,  # noqa: E402
                               mesh_prism, prism_tetrahedra, signed_area, simplify)
from bridge.sim.scene import SceneValues, SimConfig, build_scene  # noqa: E402
from bridge.sim.support import bottom_polygon  # noqa: E402
from bridge.values import Pose  # noqa: E402
from bridge.world import ObjectState, RobotState, WorldState  # noqa: E402

HALF = 0.00635  # m, half the thickness of the MIT shapes


def write_prism(path, outline, half=HALF, hole=None):
    """An OBJ prism over `outline` (counter-clockwise): caps fanned from their first vertex (a convex outline) or
    from the centroid (a star-shaped one), side quads as two triangles; `hole` (a small square) punched through."""
    outline = np.asarray(outline, dtype=float)
    n = len(outline)
    lines = [f"v {x:.9f} {y:.9f} {-half:.9f}" for x, y in outline] + [f"v {x:.9f} {y:.9f} {half:.9f}" for x, y in outline]
    c = centroid(outline)
    lines += [f"v {c[0]:.9f} {c[1]:.9f} {-half:.9f}", f"v {c[0]:.9f} {c[1]:.9f} {half:.9f}"]
    cb, ct = 2 * n + 1, 2 * n + 2
    faces = []
    for i in range(n):
        j = (i + 1) % n
        faces += [(cb, j + 1, i + 1), (ct, n + i + 1, n + j + 1), (i + 1, j + 1, n + j + 1), (i + 1, n + j + 1, n + i + 1)]
    if hole is not None:  # a separate little prism inside: its own boundary loop on each cap (a hole's outline)
        k = len(lines) + 1
        (x0, y0), s = hole, 0.002
        square = [(x0 - s, y0 - s), (x0 + s, y0 - s), (x0 + s, y0 + s), (x0 - s, y0 + s)]
        lines += [f"v {x} {y} {-half}" for x, y in square] + [f"v {x} {y} {half}" for x, y in square]
        faces += [(k, k + 2, k + 1), (k, k + 3, k + 2), (k + 4, k + 5, k + 6), (k + 4, k + 6, k + 7)]
    path.write_text("\n".join(lines + [f"f {a} {b} {c}" for a, b, c in faces]) + "\n")
    return path


def circle(radius=0.0524, n=61):
    a = 2 * math.pi * np.arange(n) / n
    return np.column_stack([radius * np.cos(a), radius * np.sin(a)])


# a U: 80 x 60 mm with a notch 20 mm wide and 30 mm deep from the top edge, counter-clockwise
U_SHAPE = np.array([[-0.04, -0.03], [0.04, -0.03], [0.04, 0.03], [0.01, 0.03], [0.01, 0.0], [-0.01, 0.0],
                    [-0.01, 0.03], [-0.04, 0.03]])
# a C whose opening turns the corner: not star-shaped from its centroid, so it is cut into convex pieces
C_SHAPE = np.array([[0.0, 0.0], [0.06, 0.0], [0.06, 0.015], [0.015, 0.015], [0.015, 0.045], [0.06, 0.045],
                    [0.06, 0.06], [0.0, 0.06]])


# --- the outline read from the mesh -------------------------------------------------------------------------
def test_a_mesh_prism_gives_its_outline_without_collinear_vertices_or_holes(tmp_path):
    square = np.array([[-0.045, -0.045], [0.0, -0.045], [0.045, -0.045], [0.045, 0.045], [-0.045, 0.045]])
    prism = mesh_prism(write_prism(tmp_path / "sq.obj", square, hole=(0.02, 0.02)), 1.0)
    assert prism is not None and (prism.z0, prism.z1) == pytest.approx((-HALF, HALF))
    assert len(prism.outline) == 4 and prism.convex  # the midpoint of the bottom edge is no corner
    assert signed_area(prism.outline) == pytest.approx(0.09 ** 2)  # the hole is left out, as the hull does
    u = mesh_prism(write_prism(tmp_path / "u.obj", U_SHAPE), 2.0)  # scaled
    assert len(u.outline) == 8 and not u.convex and signed_area(u.outline) == pytest.approx(4 * signed_area(U_SHAPE))


def test_a_mesh_that_is_no_prism_gives_none(tmp_path):
    frustum = tmp_path / "frustum.obj"  # the top smaller than the bottom
    frustum.write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.2 0.2 1\nv 0.8 0.2 1\nv 0.8 0.8 1\nv 0.2 0.8 1\n"
                       "f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 2 3 7\nf 2 7 6\nf 3 4 8\nf 3 8 7\n"
                       "f 4 1 5\nf 4 5 8\n")
    assert mesh_prism(frustum, 1.0) is None
    tetra = tmp_path / "tetra.obj"  # vertices on more than two planes
    tetra.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 3 1 4\n")
    assert mesh_prism(tetra, 1.0) is None


# --- the footprint and the tetrahedra ------------------------------------------------------------------------
@pytest.mark.parametrize("outline", [circle(), circle() * [1.5, 1.0], U_SHAPE], ids=["circle", "ellipse", "U"])
def test_a_footprint_keeps_area_and_centroid_with_at_most_n_vertices(outline):
    for n in (6, 12, 16):
        foot = simplify(outline, n)
        assert len(foot) <= max(n, 3) and is_simple(foot)
        assert signed_area(foot) == pytest.approx(signed_area(outline), rel=1e-9)
        assert centroid(foot) == pytest.approx(centroid(outline), abs=1e-9)
    assert is_convex(simplify(circle(), 16))


@pytest.mark.parametrize("outline", [circle(), U_SHAPE, C_SHAPE], ids=["circle", "U (star)", "C (pieces)"])
def test_the_tetrahedra_fill_the_prism_once_and_conform(outline):
    points, tets = prism_tetrahedra(outline, -HALF, HALF)
    volumes = [np.dot(np.cross(points[b] - points[a], points[c] - points[a]), points[d] - points[a]) / 6
               for a, b, c, d in tets]
    assert min(volumes) > 0
    assert sum(volumes) == pytest.approx(signed_area(outline) * 2 * HALF, rel=1e-9)
    faces: dict = {}
    for t in tets:  # a conforming mesh: every face is shared by at most two tetrahedra
        for k in range(4):
            face = tuple(sorted(t[:k] + t[k + 1:]))
            faces[face] = faces.get(face, 0) + 1
    assert max(faces.values()) == 2


def test_convex_pieces_cover_a_polygon_that_is_not_star_shaped():
    pieces = convex_pieces(C_SHAPE)
    assert len(pieces) >= 3 and all(is_convex(C_SHAPE[p]) for p in pieces)
    assert sum(signed_area(C_SHAPE[p]) for p in pieces) == pytest.approx(signed_area(C_SHAPE))


# --- in Drake ------------------------------------------------------------------------------------------------
def _odb(odb_copy, tmp_path, shapes: dict[str, tuple]) -> object:
    """The bundled database plus steel types over the given outlines (name -> (outline, extra geometry keys))."""
    lines = []
    for name, (outline, extra) in shapes.items():
        mesh = write_prism(tmp_path / f"{name}.obj", outline)
        keys = "".join(f", {k}: {v}" for k, v in extra.items())
        lines.append(f"{name}: {{parent: mit_shape, geometry: {{shape: mesh, mesh: {mesh}{keys}}}}}")
    (odb_copy / "types" / "test_prisms.yaml").write_text("\n".join(lines) + "\n")
    return load_object_database(odb_copy)


def _world(shape: str, rod_xy=(0.2, 0.2)) -> WorldState:
    objects = {"surface": ObjectState("surface", "push_surface", Pose((0.0, 0.0, -0.005))),
               "obj": ObjectState("obj", shape, Pose((0.0, 0.0, HALF)))}
    robot = RobotState("pusher", "planar_pusher", Pose((0.0, 0.0, HALF)),
                       (("pusher_x", float(rod_xy[0])), ("pusher_y", float(rod_xy[1]))))
    return WorldState(objects, robot=robot, name=shape, names=build_name_map([*objects, "pusher"]))


def _contacts(scene, world, settle=0.02):
    """Contacts after `settle` s (the object starts touching the surface, without pressing on it)."""
    from pydrake.systems.analysis import Simulator

    from bridge.sim.simulate import start_replay

    context, *_ = start_replay(scene, None, world=world, values=SceneValues())
    simulator = Simulator(scene.diagram, context)
    simulator.AdvanceTo(settle)
    return ContactReader(scene).read(context, settle), context


def _faces(scene, context, body: str) -> int:
    """Contact polygons between `body` and the surface (what the discrete solver gets one constraint each for)."""
    results = scene.plant.get_contact_results_output_port().Eval(scene.plant.GetMyContextFromRoot(context))
    reader = ContactReader(scene)
    total = 0
    for i in range(results.num_hydroelastic_contacts()):
        s = results.hydroelastic_contact_info(i).contact_surface()
        if {reader.name(s.id_M()), reader.name(s.id_N())} == {body, "surface"}:
            total += s.num_faces()
    return total


def test_a_disk_rests_on_its_footprint_with_a_quarter_of_the_polygons(odb_copy, tmp_path):
    odb = _odb(odb_copy, tmp_path, {"disk": (circle(), {})})
    world = _world("disk")
    prism = build_scene(world, odb, SimConfig())
    drake = build_scene(world, odb, SimConfig(mesh_contact="drake"))
    # the outline, the footprint and the sole (what the sheet's plane top carries); Drake's one mesh
    assert set(prism.footprints) == {"obj"} and len(prism.geometries["obj"]) == 3 and len(drake.geometries["obj"]) == 1
    (contacts, ctx_prism), (_, ctx_drake) = _contacts(prism, world), _contacts(drake, world)
    assert [frozenset((c.body_a, c.body_b)) for c in contacts] == [frozenset(("obj", "surface"))]  # carried once
    weight = 7950 * signed_area(circle()) * 2 * HALF * 9.81
    assert abs(contacts[0].force[2]) == pytest.approx(weight, rel=0.05)  # settling: not yet at rest
    assert 4 * _faces(prism, ctx_prism, "obj") <= 1.2 * _faces(drake, ctx_drake, "obj")


def test_the_rod_meets_the_outline_not_the_footprint(odb_copy, tmp_path):
    """The rod 1 mm into a 61-gon disk's side touches it (the exact outline), and where a 6-vertex footprint would
    reach beyond the outline, it does not."""
    odb = _odb(odb_copy, tmp_path, {"disk": (circle(), {"footprint_vertices": 6})})
    r = 0.0524 - 0.001 + 0.00476
    contacts, _ = _contacts(build_scene(_world("disk", (r, 0.0)), odb, SimConfig()), _world("disk", (r, 0.0)), 0.0)
    assert frozenset(("obj", "pusher/pusher_rod")) in {frozenset((c.body_a, c.body_b)) for c in contacts}
    foot = simplify(circle(), 6)  # area-preserving: its vertices lie outside the circle
    corner = foot[np.argmax(np.linalg.norm(foot, axis=1))]
    beyond = corner / np.linalg.norm(corner) * (0.0524 + 0.0005 + 0.00476)  # past the circle, inside the hexagon
    assert np.linalg.norm(beyond) - 0.00476 < np.linalg.norm(corner)
    contacts, _ = _contacts(build_scene(_world("disk", beyond), odb, SimConfig()), _world("disk", beyond), 0.0)
    assert all("pusher/pusher_rod" not in (c.body_a, c.body_b) for c in contacts)


def test_a_non_convex_outline_stays_non_convex(odb_copy, tmp_path):
    """A rod in the U's notch is inside the convex hull but outside the outline: it touches the object when Drake
    takes the mesh (its hull) or the hull is asked for, not with the prism representation; one 1 mm into the U's
    side touches with both."""
    odb = _odb(odb_copy, tmp_path, {"u_part": (U_SHAPE, {"convex": "false"})})

    def pairs(rod, config, settle=0.0):
        world = _world("u_part", rod)
        contacts, _ = _contacts(build_scene(world, odb, config), world, settle)
        return {frozenset((c.body_a, c.body_b)) for c in contacts}

    rod = frozenset(("obj", "pusher/pusher_rod"))
    in_notch, on_side = (0.0, 0.02), (0.04 + 0.00476 - 0.001, 0.0)
    assert rod not in pairs(in_notch, SimConfig()) and rod in pairs(in_notch, SimConfig(mesh_contact="drake"))
    assert rod in pairs(on_side, SimConfig()) and rod in pairs(on_side, SimConfig(mesh_contact="drake"))
    assert frozenset(("obj", "surface")) in pairs(in_notch, SimConfig(), settle=0.02)  # carried by its own footprint
    hull = SimConfig(mesh_contact="hull")  # the hull as the rod meets it, on the hull's footprint
    assert rod in pairs(in_notch, hull) and frozenset(("obj", "surface")) in pairs((0.2, 0.2), hull, settle=0.02)
    # what a support, anisotropic friction or a friction field spreads over: the hull's footprint in that mode
    assert signed_area(bottom_polygon(odb.get("u_part"), 16, hull=True)[0]) == pytest.approx(0.08 * 0.06)
    assert signed_area(bottom_polygon(odb.get("u_part"), 16)[0]) == pytest.approx(0.08 * 0.06 - 0.02 * 0.03)


def test_drakes_own_hull_twists_by_where_it_stands_the_footprint_does_not(odb_copy, tmp_path, spin_down):
    """Why the mismatched proof's worlds take the hull as geometry on an even footprint (`mesh_contact: "hull"`),
    not Drake's own fan (`prove/mismatch.py`): spun on the sheet, a triangle resting on the fan turns by amounts
    that hinge on where the sheet's triangles cut its few bottom tetrahedra (tri1 on the MIT sheet: 0.14 to 2.5
    times the footprint's turn in four places), where on its footprint, or on the hull's, it turns alike
    everywhere: a solver's torsion, not an object's."""
    triangle = np.array([[-0.04, -0.03], [0.05, -0.03], [-0.01, 0.05]])
    odb = _odb(odb_copy, tmp_path, {"tri": (triangle, {})})
    places = [(0.0, 0.0), (0.05, 0.0), (0.0, 0.05), (0.1, -0.07)]

    def turns(mode: str) -> np.ndarray:
        out = []
        for xy in places:
            world = _world("tri")
            world = replace(world, objects={**world.objects, "obj": replace(world.objects["obj"], pose=Pose(
                (xy[0], xy[1], HALF)))})
            out.append(spin_down(world, odb, "obj", SimConfig(mesh_contact=mode)))
        return np.array(out)

    footprint, hull, fan = turns("prism"), turns("hull"), turns("drake")
    assert np.ptp(footprint) < 0.02 * footprint.mean() and np.allclose(hull, footprint, rtol=0.02)
    assert fan.max() > 1.3 * footprint.mean() and fan.min() < 0.7 * footprint.mean()


def test_a_type_chooses_its_representation(odb_copy, tmp_path):
    odb = _odb(odb_copy, tmp_path, {"plain": (circle(), {"contact": "drake"}), "coarse": (circle(), {"footprint_vertices": 8})})
    assert build_scene(_world("plain"), odb, SimConfig()).footprints == {}
    scene = build_scene(_world("coarse"), odb, SimConfig())
    assert set(scene.footprints) == {"obj"}
    small = _odb(odb_copy, tmp_path, {"hexagon": (circle(n=6), {})})
    assert set(build_scene(_world("hexagon"), small, SimConfig()).footprints) == {"obj"}  # subdivided to 16


def test_a_bad_representation_is_one_error_naming_the_field(odb_copy, tmp_path):
    (tmp_path / "m").mkdir()
    write_prism(tmp_path / "m" / "disk.obj", circle())
    path = odb_copy / "types" / "zz.yaml"
    path.write_text(f"d: {{parent: mit_shape, geometry: {{shape: mesh, mesh: {tmp_path}/m/disk.obj, contact: hulls}}}}\n")
    with pytest.raises(ObjectDatabaseError,
                       match=r"d\.geometry\.contact: contact 'hulls' is not one of prism, hull, drake"):
        load_object_database(odb_copy)
    path.write_text(f"d: {{parent: mit_shape, geometry: {{shape: mesh, mesh: {tmp_path}/m/disk.obj, "
                    "footprint_vertices: 2}}\n")
    with pytest.raises(ObjectDatabaseError, match=r"footprint_vertices must be a whole number >= 3, got 2"):
        load_object_database(odb_copy)


def test_a_coarse_outline_rests_on_its_own_polygon_subdivided():
    square = np.array([(-0.045, -0.045), (0.045, -0.045), (0.045, 0.045), (-0.045, 0.045)])
    for poly in (square, circle(n=3), circle(n=7)):
        foot = footprint_polygon(poly, 16)
        assert len(foot) == 16 and is_convex(poly)
        assert signed_area(foot) == pytest.approx(signed_area(poly)) and np.allclose(centroid(foot), centroid(poly))
        assert all(min(np.linalg.norm(np.cross(b - a, v - a)) for a, b in zip(poly, np.roll(poly, -1, axis=0)))
                   < 1e-12 for v in foot)  # every vertex on an edge of the outline: the same polygon
    assert footprint_polygon(U_SHAPE, 16) is None  # non-convex: its own mesh is fanned from its centre already


def test_a_coarse_outline_pushes_alike_wherever_the_support_is_meshed(odb_copy, tmp_path):
    """A 90 mm square pushed off its centre line, the MIT sheet moved under it by 1e-7 m to 3 cm: Drake's `Convex`
    (no footprint: it rests on the sheet's box) rests the square on two bottom tetrahedra (two contact points for
    the friction moment), and the push ends where the box face's triangles and rounding decide (0.7 mm, 1.4 deg
    apart); its subdivided footprint (16 fan triangles) rests on the sheet's plane top, which has no triangles:
    the push is the same wherever the sheet lies (docs/rollout.md "Why coarse outlines are subdivided")."""
    from bridge.recording.telemetry import Telemetry
    from bridge.rollout.rollout import Rollout, run_rollout
    from bridge.sim.simulate import SimOptions

    square = np.array([(-0.045, -0.045), (0.045, -0.045), (0.045, 0.045), (-0.045, 0.045)])
    odb = _odb(odb_copy, tmp_path, {"square": (square, {}), "square_drake": (square, {"contact": "drake"})})
    t = np.linspace(0.0, 1.2, 61)
    x = -0.06 + 0.06 * np.clip(t - 0.1, 0.0, None)
    telemetry = Telemetry(t, ("pusher_x", "pusher_y"), np.column_stack([x, np.full_like(x, 0.02)]))

    def spread(shape: str) -> np.ndarray:
        finals = []
        for dx in (0.0, 1e-7, 1e-4, 0.013, 0.03):
            world = _world(shape, (x[0], 0.02)).with_poses({"surface": Pose((dx, 0.7 * dx, -0.005))})
            final = run_rollout(Rollout(world, telemetry), odb, SimOptions(sleep=False)).final_poses["obj"]
            finals.append((*final.xyz[:2], final.yaw()))
        finals = np.array(finals)
        assert finals[0, 0] > 0.02 and abs(finals[0, 2]) > math.radians(2)  # pushed and turned
        return np.ptp(finals, axis=0)

    footprint, convex = spread("square"), spread("square_drake")
    assert np.all(footprint < 1e-9) and max(convex[:2]) > 2e-4 and convex[2] > math.radians(0.5)


def _settle(scene, world, values=SceneValues(), seconds=0.3):
    from pydrake.systems.analysis import Simulator

    from bridge.sim.simulate import start_replay

    context, *_ = start_replay(scene, None, world=world, values=values)
    Simulator(scene.diagram, context).AdvanceTo(seconds)
    return context


def test_a_plane_top_carries_soles_with_fewer_polygons_and_the_sheets_friction(odb_copy, tmp_path):
    """The MIT sheet's top is a plane (`plane_top`) for the soles, pyramids over the footprints: a 61-gon disk
    rests on less than half the contact polygons it rests on with its footprint on the same sheet's box (no face
    triangle splits them, one sliver per side), and the sheet's friction set for one replay reaches the plane: a
    sideways push of 0.3 m g slides the disk on a 0.1 sheet (0.14 with the steel's 0.25) and not on a 0.9 one
    (0.39)."""
    odb = _odb(odb_copy, tmp_path, {"disk": (circle(), {})})
    (odb_copy / "types" / "test_prisms.yaml").open("a").write(
        "box_sheet: {parent: push_surface, geometry: {shape: box, size: [1.0, 1.0, 0.01]}}\n")
    odb = load_object_database(odb_copy)
    on_plane = _world("disk")
    on_box = replace(on_plane, objects=dict(on_plane.objects, surface=replace(on_plane.objects["surface"],
                                                                              type="box_sheet")))
    scene_plane, scene_box = build_scene(on_plane, odb, SimConfig()), build_scene(on_box, odb, SimConfig())
    plane_faces = _faces(scene_plane, _settle(scene_plane, on_plane, seconds=0.02), "obj")
    box_faces = _faces(scene_box, _settle(scene_box, on_box, seconds=0.02), "obj")
    assert 0 < plane_faces <= 0.5 * box_faces
    weight = 7950 * signed_area(circle()) * 2 * HALF * 9.81

    def moved(mu: float) -> float:
        values = SceneValues().with_object("surface", friction=mu).with_force("obj", (0.3 * weight, 0.0, 0.0))
        context = _settle(scene_plane, on_plane, values)
        X = scene_plane.plant.EvalBodyPoseInWorld(scene_plane.plant.GetMyContextFromRoot(context),
                                                  scene_plane.bodies["obj"])
        return float(X.translation()[0])
    assert moved(0.1) > 0.05 and abs(moved(0.9)) < 1e-3


def test_a_post_meets_the_footprints_upright_side_not_the_soles_slope(odb_copy, tmp_path):
    """A post welded beside a disk on the plane top, 3 mm into its side: it pushes the disk sideways (the
    footprint's upright side; 5 % of the force vertical), not down as the sole's side, sloping at 14 deg, would."""
    from bridge.sim.extras import WeldedShape

    odb = _odb(odb_copy, tmp_path, {"disk": (circle(), {})})
    world = _world("disk")
    post = WeldedShape("post", "cylinder", (0.01, 0.05), (0.0524 + 0.01 - 0.003, 0.0, 0.025))
    scene = build_scene(world, odb, SimConfig(), extras=(post,))
    context = _settle(scene, world, seconds=0.003)
    post_contacts = [c for c in ContactReader(scene).read(context, 0.003) if {c.body_a, c.body_b} == {"obj", "world"}]
    assert post_contacts and all(c.point[0] > 0.05 for c in post_contacts)  # the post, not the floor
    assert all(abs(c.force[2]) < 0.1 * math.hypot(c.force[0], c.force[1]) for c in post_contacts)
    # who may touch whom: the sole only the plane, the footprint the post but neither the plane nor the sheet's box
    inspector = scene.scene_graph.model_inspector()
    ids = {inspector.GetName(g).split("::")[-1]: g for g in inspector.GetAllGeometryIds()}
    touch = {(a, b): not inspector.CollisionFiltered(ids[a], ids[b]) for a in ("obj/sole", "obj/footprint",
             "obj/collision") for b in ("surface/plane", "surface/collision", "post/collision")}
    assert touch == {("obj/sole", "surface/plane"): True, ("obj/sole", "surface/collision"): False,
                     ("obj/sole", "post/collision"): False, ("obj/footprint", "surface/plane"): False,
                     ("obj/footprint", "surface/collision"): False, ("obj/footprint", "post/collision"): True,
                     ("obj/collision", "surface/plane"): False, ("obj/collision", "surface/collision"): False,
                     ("obj/collision", "post/collision"): False}


def test_a_plane_top_carries_only_what_would_rest_on_the_sheet(odb_copy, tmp_path):
    """The plane carries the prisms' footprints and nothing else: a steel block (a box of its own, no footprint)
    set down beside the sheet, level with its top, falls to the floor 10 mm below; a disk there is held by the
    plane, which is why a sheet is a
    plane top only when it is wider than anything on it travels (the MIT sheet: a metre, pushes of centimetres)."""
    odb = _odb(odb_copy, tmp_path, {"disk": (circle(), {})})
    world = _world("disk").with_poses({"obj": Pose((0.7, 0.0, HALF))})
    objects = dict(world.objects, block=ObjectState("block", "steel_block", Pose((-0.7, 0.0, 0.0064))))
    world = WorldState(objects, robot=world.robot, name="beside", names=build_name_map([*objects, "pusher"]))
    scene = build_scene(world, odb, SimConfig())
    context = _settle(scene, world, seconds=0.4)
    plant_ctx = scene.plant.GetMyContextFromRoot(context)
    z = {n: float(scene.plant.EvalBodyPoseInWorld(plant_ctx, scene.bodies[n]).translation()[2])
         for n in ("obj", "block")}
    assert abs(z["obj"] - HALF) < 1e-3 and abs(z["block"] - (-0.01 + 0.0064)) < 1e-3


# --- on the MIT recordings -------------------------------------------------------------------------------------
def test_an_ellipse_push_replays_as_before_within_a_tenth_of_a_millimetre(mit_push_root):
    """A push of ellip1 (one whose replay does not hinge on how its faces are triangulated) ends where Drake's own
    representation puts it; the whole comparison over every trial is in docs/rollout.md."""
    from dataclasses import replace

    from bridge.params import trial_rollout
    from bridge.rollout import load_trials, run_rollout
    from bridge.sim.simulate import SimOptions

    odb = load_object_database(datasets={"mit-push": mit_push_root})
    path = mit_push_root / "train" / "motion_surface=abs_shape=ellip1_a=0_v=100_i=0.000_s=0.075_t=0.000.h5"
    trial = load_trials([path], odb)[0]
    runs = [run_rollout(replace(trial_rollout(trial, (), odb), config=config), odb, SimOptions())
            for config in (SimConfig(), SimConfig(mesh_contact="drake"))]
    a, b = (r.tracks["ellip1"] for r in runs)
    assert np.max(np.linalg.norm(a[:, :2] - b[:, :2], axis=1)) < 1e-4
    yaw = [np.unwrap(2 * np.arctan2(t[:, 6], t[:, 3])) for t in (a, b)]
    assert np.degrees(np.max(np.abs(yaw[0] - yaw[1]))) < 0.1
    assert np.linalg.norm(a[-1, :2] - a[0, :2]) > 0.02  # it was pushed

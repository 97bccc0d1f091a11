"""`bridge check` refuses what `infer` and `export` would refuse, with the same line, before any replay.

Each case plants one defect in writable copies of the object database, the demo's push-over recording and the
PDDL folder, and asserts that `bridge check` refuses it naming the file and the field. A case that names the
command that used to be the first to refuse it (`later`: infer or export) also runs that command and asserts the
same message: check and the command agree.
"""
from __future__ import annotations

import shutil
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import pytest

REPO = Path(__file__).resolve().parents[2]
RECORDINGS = sorted(p for p in (REPO / "demo" / "recordings").iterdir() if (p / "world.yaml").is_file())


@dataclass
class Setup:
    """Writable copies of what a check reads, and the command lines that read them."""

    tmp: Path
    odb: Path
    rec: Path
    pddl: Path

    @property
    def common(self) -> list:
        return ["--odb", self.odb, "--templates", self.pddl]

    @property
    def out(self) -> Path:
        return self.tmp / "out"

    def infer(self, *extra) -> list:
        return ["infer", self.rec, *self.common, "--world-out", self.out / "world_after.yaml", *extra]

    def export(self) -> list:
        return ["export", self.rec / "world.yaml", *self.common, "--out", self.out]

    def write(self, relative: str, text: str) -> Path:
        path = self.tmp / relative
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
        return path


@dataclass
class Planted:
    names: tuple  # what the one error line must name: the file, the field, the value
    check: list = field(default_factory=list)  # paths and options after `bridge check`
    later: list | None = None  # the command that refused it before check did, with the same message


def edit(path: Path, old: str, new: str) -> Path:
    text = path.read_text()
    assert old in text, f"{old!r} not in {path}"
    path.write_text(text.replace(old, new, 1))
    return path


def add_type(s: Setup, text: str, obj: str | None = None) -> Path:
    """A type file `extra.yaml` in the database; with `obj`, an object of that type in the recording's world."""
    path = s.odb / "types" / "extra.yaml"
    path.write_text(text)
    if obj is not None:
        edit(s.rec / "world.yaml", "objects:\n", f"objects:\n  {obj}: {{type: {obj}, pose: {{xyz: [1.6, 1.6, 0.5]}}}}\n")
    return path


# --- the object database: SIEs -----------------------------------------------------------------------------------
def sie_parameter_misspelled(s):
    path = edit(s.odb / "types" / "base.yaml", "max_tilt_deg: 20", "max_tilt_dg: 20")
    return Planted((path, "movable.predicates.upright.sie.params.max_tilt_dg", "max_tilt_deg"), [s.rec], s.infer())


def sie_parameter_missing(s):
    (s.odb / "sies" / "strict.py").write_text(
        "from bridge.inference import SIE\n\n\nclass Level(SIE):\n    def __init__(self, level):\n"
        "        self.level = level\n\n    def evaluate(self, obj, ctx):\n        return []\n")
    path = edit(s.odb / "types" / "tabletop.yaml", "upright: {sie: {class: sies.pose:Upright, params: {max_tilt_deg: 10}}}",
                "upright: {sie: sies.strict:Level}")
    return Planted((path, "tray.predicates.upright.sie.params.level", "sies.strict:Level"), [s.rec], s.infer())


def sie_parameter_value_refused(s):
    path = edit(s.odb / "types" / "tabletop.yaml", "max_tilt_deg: 10", "max_tilt_deg: steep")
    return Planted((path, "tray.predicates.upright.sie.params", "'steep'"), [s.rec], s.infer())


def sie_class_missing(s):
    path = edit(s.odb / "types" / "base.yaml", "sies.pose:Upright", "sies.pose:Uprite")
    return Planted((path, "movable.predicates.upright.sie", "sies.pose:Uprite"), [s.rec], s.infer())


# --- the object database: mass properties and meshes ---------------------------------------------------------------
def negative_mass(s):
    path = edit(s.odb / "types" / "tabletop.yaml", "physics: {mass: 1.0}", "physics: {mass: -1.0}")
    return Planted((path, "big_box.physics.mass", "-1.0"), [s.rec], s.infer())


def inertia_breaks_triangle_inequality(s):
    path = edit(s.odb / "types" / "tabletop.yaml", "physics: {mass: 1.0}",
                "physics: {mass: 1.0, inertia: [1.0, 0.01, 0.01, 0, 0, 0]}")
    return Planted((path, "big_box.physics.inertia", "each at most the sum of the other two"), [s.rec], s.infer())


def inertia_negative_moment(s):
    path = edit(s.odb / "types" / "tabletop.yaml", "physics: {mass: 0.3}",
                "physics: {mass: 0.3, inertia: [-0.001, 0.001, 0.001, 0, 0, 0]}")
    return Planted((path, "small_box.physics.inertia", "not physically valid"), [s.rec], s.infer())


def garbage_mesh(s):
    (s.odb / "types" / "junk.obj").write_text("this is not an OBJ file\n")
    path = add_type(s, "junk: {parent: box, geometry: {shape: mesh, mesh: junk.obj}, physics: {mass: 0.2}}\n", "junk")
    return Planted((path, "junk.geometry.mesh", "junk.obj"), [s.rec], s.infer())


def mesh_with_bad_face(s):
    (s.odb / "types" / "junk.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n")
    path = add_type(s, "junk: {parent: box, geometry: {shape: mesh, mesh: junk.obj}, physics: {mass: 0.2}}\n", "junk")
    return Planted((path, "junk.geometry.mesh", "junk.obj"), [s.rec], s.infer())


def mesh_without_volume(s):
    (s.odb / "types" / "flat.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n")
    path = add_type(s, "flat: {parent: box, geometry: {shape: mesh, mesh: flat.obj, convex: false}, "
                       "physics: {mass: 0.2}}\n", "flat")
    return Planted((path, "flat.geometry.mesh", "volume"), [s.rec], s.infer())


def fixture_garbage_mesh(s):
    (s.odb / "types" / "junk.obj").write_text("\x00\x01 binary junk\n")
    path = add_type(s, "ramp: {parent: fixture, pddl_type: surface, geometry: {shape: mesh, mesh: junk.obj}}\n", "ramp")
    return Planted((path, "ramp.geometry.mesh", "junk.obj"), [s.rec], s.infer())


# --- the object database: robots --------------------------------------------------------------------------------
def robot_base_link_unknown(s):
    path = edit(s.odb / "types" / "robots.yaml", "base_link: arm_base", "base_link: arm_bsae")
    return Planted((path, "demo_arm.robot.base_link", "'arm_bsae'"), [s.rec], s.infer())


def gripper_finger_link_unknown(s):
    path = edit(s.odb / "types" / "robots.yaml", "finger_links: [finger_left, finger_right]",
                "finger_links: [finger_left, finger_rigth]")
    return Planted((path, "demo_arm.robot.gripper.finger_links", "'finger_rigth'"), [s.rec], s.infer())


def gripper_tcp_frame_unknown(s):
    path = edit(s.odb / "types" / "robots.yaml", "tcp_frame: tcp", "tcp_frame: tool")
    return Planted((path, "demo_arm.robot.gripper.tcp_frame", "'tool'"), [s.rec], s.infer())


def robot_model_broken(s):
    # well-formed XML that Drake refuses (a joint's parent link does not exist); the model is parsed from its text
    # (`scene.add_models`), where Drake's own message names no file: the error line must
    model = s.odb / "types" / "broken_arm.sdf"
    model.write_text((REPO / "models" / "arm7" / "arm7.sdf").read_text().replace(
        "<parent>arm_link1</parent>", "<parent>arm_link_missing</parent>", 1))
    edit(s.odb / "types" / "robots.yaml", f"model: {REPO / 'models' / 'arm7' / 'arm7.sdf'}", "model: broken_arm.sdf")
    return Planted(("broken_arm.sdf", "cannot load robot model"), [s.rec], s.infer())


# --- recordings and world states --------------------------------------------------------------------------------
def world_robot_joint_unknown(s):
    path = edit(s.rec / "world.yaml", "pose: {xyz: [0.0, 0.0, 0.75]}}", "pose: {xyz: [0.0, 0.0, 0.75]}, "
                "joints: {arm_joint9: 0.1}}")
    return Planted((path, "robot.joints.arm_joint9"), [s.rec], s.infer())


def world_file_unknown_type(s):
    path = edit(s.rec / "world.yaml", "{type: big_box,", "{type: big_boxx,")
    return Planted((path, "objects.big_box.type", "'big_boxx'"), [path], s.export())


def telemetry_joint_the_robot_lacks(s):
    path = edit(s.rec / "telemetry.csv", "arm_joint7,", "arm_joint8,")
    return Planted((path, "joint 'arm_joint8'"), [s.rec], s.infer())


def telemetry_lacks_a_robot_joint(s):
    path = s.rec / "telemetry.csv"
    path.write_text("".join(line.rsplit(",", 1)[0] + "\n" for line in path.read_text().splitlines()))
    return Planted((path, "joint 'finger_right_joint'"), [s.rec], s.infer())


def observed_object_unknown(s):
    path = s.rec / "observed.csv"
    path.write_text(path.read_text().replace(",big_box,", ",bigbox,"))
    return Planted((path, "'bigbox'"), [s.rec])


def no_such_recording(s):
    return Planted((s.tmp / "nowhere",), [s.tmp / "nowhere"])


# --- scene and parameter files ----------------------------------------------------------------------------------
def scene_target_names_no_object(s):
    scene = s.write("scene.yaml", "params:\n  - {kind: friction, target: bigbox, value: 0.4}\n")
    return Planted((scene, "friction[bigbox]", "names nothing"), [s.rec, "--scene", scene], s.infer("--scene", scene))


def scene_target_unknown_robot_link(s):
    scene = s.write("scene.yaml", "params:\n  - {kind: friction, target: arm/finger_lft, value: 0.4}\n")
    return Planted((scene, "friction[arm/finger_lft]", "arm/finger_left"), [s.rec, "--scene", scene],
                   s.infer("--scene", scene))


def params_target_unknown_robot(s):
    params = s.write("params.yaml", "params:\n  - {kind: latency, target: arn, value: 0.05}\n")
    return Planted((params, "latency[arn]"), [s.rec / "world.yaml", "--params", params],
                   s.infer("--params", params))


def scene_file_without_a_recording(s):
    scene = s.write("scene.yaml", "params:\n  - {kind: friction, target: big_box, value: 0.4}\n")
    return Planted((scene, "--scene"), ["--scene", scene])


def scene_file_given_as_a_path(s):
    scene = s.write("scene.yaml", "params:\n  - {kind: friction, target: big_box, value: 0.4}\n")
    return Planted((scene, "--scene"), [scene])


# --- domain.yaml and the action templates -----------------------------------------------------------------------
def domain_unknown_key(s):
    path = edit(s.pddl / "domain.yaml", "requirements:", "requirement:")
    return Planted((path, "'requirement'"), [], s.export())


def domain_unknown_requirement(s):
    path = edit(s.pddl / "domain.yaml", "requirements: [strips, typing,", "requirements: [strips, typing, fluents,")
    return Planted((path, "requirements[2]", "'fluents'"), [], s.export())


def domain_requirements_not_a_list(s):
    path = s.pddl / "domain.yaml"
    path.write_text("name: bridge-tabletop\nrequirements: strips typing\n")
    return Planted((path, "requirements", "list"), [], s.export())


def domain_requirements_miss_what_actions_use(s):
    path = s.pddl / "domain.yaml"
    path.write_text("name: bridge-tabletop\nrequirements: [strips, typing]\n")
    return Planted((path, "requirements", "action 'pick'", "conditional-effects"), [], s.export())


def domain_name_not_an_identifier(s):
    path = edit(s.pddl / "domain.yaml", "name: bridge-tabletop", "name: bridge tabletop")
    return Planted((path, "name", "'bridge tabletop'"), [], s.export())


CASES: list[Callable[[Setup], Planted]] = [
    sie_parameter_misspelled, sie_parameter_missing, sie_parameter_value_refused, sie_class_missing,
    negative_mass, inertia_breaks_triangle_inequality, inertia_negative_moment, garbage_mesh, mesh_with_bad_face,
    mesh_without_volume, fixture_garbage_mesh,
    robot_base_link_unknown, gripper_finger_link_unknown, gripper_tcp_frame_unknown, robot_model_broken,
    world_robot_joint_unknown, world_file_unknown_type, telemetry_joint_the_robot_lacks, telemetry_lacks_a_robot_joint,
    observed_object_unknown, no_such_recording,
    scene_target_names_no_object, scene_target_unknown_robot_link, params_target_unknown_robot,
    scene_file_without_a_recording, scene_file_given_as_a_path,
    domain_unknown_key, domain_unknown_requirement, domain_requirements_not_a_list,
    domain_requirements_miss_what_actions_use, domain_name_not_an_identifier,
]


@pytest.fixture
def setup(tmp_path, odb_copy, recording) -> Setup:
    pddl = tmp_path / "pddl"
    shutil.copytree(REPO / "pddl", pddl)
    return Setup(tmp_path, odb_copy, recording, pddl)


@pytest.mark.parametrize("plant", CASES, ids=[c.__name__.replace("_", "-") for c in CASES])
def test_check_refuses_what_a_later_command_would(setup, refuse, plant):
    s = setup
    planted = plant(s)
    inputs = [s.odb, s.rec, s.pddl, *(p for p in s.tmp.glob("*.yaml"))]
    line = refuse(["check", *planted.check, *s.common], *planted.names, inputs=inputs)
    assert line.startswith("bridge check: error: ")
    if planted.later is not None:
        command = planted.later[0]
        later = refuse(planted.later, *planted.names, inputs=inputs, absent=[s.out])
        assert later.split(": error: ", 1)[1] == line.split(": error: ", 1)[1], f"{command} and check disagree"


# --- what passes -------------------------------------------------------------------------------------------------
def test_check_of_the_bundled_database_and_pddl_is_ok(capsys):
    from bridge.cli import main

    assert main(["check"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[-1] == "ok"
    assert any("SIEs made with their parameters" in line for line in out)
    assert any(line.startswith("domain bridge-tabletop") and "negative-preconditions" in line for line in out)


@pytest.mark.parametrize("folder", RECORDINGS, ids=[p.name for p in RECORDINGS])
def test_check_of_each_demo_recording_is_ok(folder, capsys):
    from bridge.cli import main

    assert main(["check", str(folder), str(folder / "world.yaml")]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[-1] == "ok"
    assert any(line.startswith(f"recording {folder}:") and "scene built in Drake" in line for line in out)
    assert any(line.startswith(f"world state {folder / 'world.yaml'}:") for line in out)


def test_check_applies_scene_and_parameter_files_to_recordings_and_worlds(tmp_path, recording, capsys):
    from bridge.cli import main

    scene = tmp_path / "scene.yaml"
    scene.write_text("params:\n  - {kind: friction, target: arm/finger_left, value: 0.8}\n"
                     "  - {kind: latency, target: arm, value: 0.02}\n  - {kind: obstacle_x, target: table, value: 0.6}\n")
    params = tmp_path / "params.yaml"
    params.write_text("params:\n  - {kind: mass, target: big_box, value: 1.2}\n")
    argv = ["check", recording, recording / "world.yaml", "--scene", scene, "--params", params]
    assert main([str(a) for a in argv]) == 0
    out = capsys.readouterr().out
    assert out.count(f"--scene {scene}, --params {params} applied; scene built in Drake") == 2


def test_export_declares_the_requirements_of_domain_yaml(tmp_path, capsys):
    from bridge.cli import main

    pddl = tmp_path / "pddl"
    shutil.copytree(REPO / "pddl", pddl)
    edit(pddl / "domain.yaml", "requirements: [strips, typing,", "requirements: [strips, typing, existential-preconditions,")
    edit(pddl / "domain.yaml", "name: bridge-tabletop", "name: my-kitchen")
    world = REPO / "demo" / "recordings" / "1_push_over" / "world.yaml"
    assert main(["export", str(world), "--templates", str(pddl), "--out", str(tmp_path / "out")]) == 0
    domain = (tmp_path / "out" / "domain.pddl").read_text()
    assert ":existential-preconditions" in domain and ":conditional-effects" in domain
    assert "(domain my-kitchen)" in domain
    assert "(:domain my-kitchen)" in (tmp_path / "out" / "problem.pddl").read_text()

"""The bad-input battery, values: every value a user gives is checked at the edge (physical ranges, finiteness,
duplicate keys, undecodable bytes, garbage meshes, option ranges, robot joint limits, a recording against its
world) and refused in one line naming the file and field, before anything is simulated.

Each case builds one bad input in a fresh folder and hands the command line to `refuse` (tests/bad_input/
conftest.py). None of them replays a recording: every refusal comes before Drake simulates anything.
"""
from __future__ import annotations

import shutil
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import pytest

REPO = Path(__file__).resolve().parents[2]
TABLETOP = REPO / "demo" / "worlds" / "tabletop.yaml"


@dataclass
class Ctx:
    """Where a case builds its input: a fresh folder, a writable copy of the push-over recording, and a writable
    object database (made on demand)."""

    tmp: Path
    rec: Path
    _odb: Path | None = None

    @property
    def odb(self) -> Path:
        if self._odb is None:
            self._odb = self.tmp / "odb"
            shutil.copytree(REPO / "odb", self._odb, ignore=shutil.ignore_patterns("__pycache__"))
            robots = self._odb / "types" / "robots.yaml"
            robots.write_text(robots.read_text().replace("../../models/", f"{REPO}/models/"))
        return self._odb

    def write(self, name: str, text: str | bytes) -> Path:
        path = self.tmp / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(text if isinstance(text, bytes) else text.encode())
        return path

    @property
    def out(self) -> Path:
        return self.rec / "world_after.yaml"


@dataclass
class Case:
    argv: list
    names: tuple
    inputs: tuple = ()
    absent: tuple = ()
    extra: dict = field(default_factory=dict)


def params(*entries: str) -> str:
    return "params:\n" + "".join(f"  - {e}\n" for e in entries)


def infer_with(option: str, *entries: str, names: tuple = ()) -> Callable[[Ctx], Case]:
    """`bridge infer` of the recording with a parameter (--params) or scene (--scene) file of `entries`."""

    def build(c: Ctx) -> Case:
        path = c.write(f"{option}.yaml", params(*entries))
        return Case(["infer", c.rec, f"--{option}", path], (path.name, *names), (c.rec, path), (c.out,))

    return build


def shorten_telemetry(rec: Path, until: float) -> None:
    """Keep the telemetry's samples up to `until` seconds."""
    lines = (rec / "telemetry.csv").read_text().splitlines()
    kept = [lines[0]] + [line for line in lines[1:] if float(line.split(",")[0]) <= until]
    (rec / "telemetry.csv").write_text("\n".join(kept) + "\n")


def world_text(rec: Path) -> str:
    return (rec / "world.yaml").read_text()


def bad_world(edit: Callable[[str], str], *names: str) -> Callable[[Ctx], Case]:
    """`bridge infer` of the recording with its world.yaml edited."""

    def build(c: Ctx) -> Case:
        (c.rec / "world.yaml").write_text(edit(world_text(c.rec)))
        return Case(["infer", c.rec], ("world.yaml", *names), (c.rec,), (c.out,))

    return build


def with_joints(joints: str) -> Callable[[str], str]:
    return lambda text: text.replace("pose: {xyz: [0.0, 0.0, 0.75]}}",
                                     f"pose: {{xyz: [0.0, 0.0, 0.75]}}, joints: {{{joints}}}}}")


def bad_recording_file(name: str, edit: Callable[[bytes], bytes], *names: str) -> Callable[[Ctx], Case]:
    """`bridge infer` of the recording with one of its files edited (bytes in, bytes out)."""

    def build(c: Ctx) -> Case:
        path = c.rec / name
        path.write_bytes(edit(path.read_bytes()))
        return Case(["infer", c.rec], (name, *names), (c.rec,), (c.out,))

    return build


def bad_telemetry_column(column: str, value: str, *names: str) -> Callable[[Ctx], Case]:
    """The telemetry with one joint's column replaced by `value` from the tenth sample on."""

    def edit(data: bytes) -> bytes:
        lines = data.decode().splitlines()
        k = lines[0].split(",").index(column)
        out = lines[:10]
        for line in lines[10:]:
            cells = line.split(",")
            cells[k] = value
            out.append(",".join(cells))
        return ("\n".join(out) + "\n").encode()

    return bad_recording_file("telemetry.csv", edit, *names)


def bad_odb(name: str, text: str | bytes, *names: str, mesh: tuple[str, bytes] | None = None) -> Callable[[Ctx], Case]:
    """`bridge export` of the demo world with an object database holding one more (bad) file."""

    def build(c: Ctx) -> Case:
        root = c.odb
        path = root / "types" / name
        path.write_bytes(text if isinstance(text, bytes) else text.encode())
        if mesh is not None:
            (root / "types" / mesh[0]).write_bytes(mesh[1])
        out = c.tmp / "pddl"
        return Case(["export", TABLETOP, "--odb", root, "--out", out], names, (root,), (out,))

    return build


def bad_templates(edit: Callable[[Path], Path], *names: str) -> Callable[[Ctx], Case]:
    """`bridge export` of the demo world with a copy of the PDDL templates folder, edited."""

    def build(c: Ctx) -> Case:
        root = c.tmp / "pddl_src"
        shutil.copytree(REPO / "pddl", root)
        edit(root)
        out = c.tmp / "pddl"
        return Case(["export", TABLETOP, "--templates", root, "--out", out], names, (root,), (out,))

    return build


def option(*argv: str, names: tuple) -> Callable[[Ctx], Case]:
    """A command line with one bad option; `REC` stands for the recording, `OUT` for a fresh output folder."""

    def build(c: Ctx) -> Case:
        args = [c.rec if a == "REC" else c.tmp / "out" if a == "OUT" else a for a in argv]
        return Case(args, names, (c.rec,), (c.out, c.tmp / "out"))

    return build


def fit_with(*entries: str, names: tuple, until: float | None = None) -> Callable[[Ctx], Case]:
    """`bridge fit` of the recording with a parameter file of `entries` (serial: refused before any worker)."""

    def build(c: Ctx) -> Case:
        if until is not None:
            shorten_telemetry(c.rec, until)
        path = c.write("fit.yaml", params(*entries))
        out = c.tmp / "fit_out"
        return Case(["fit", c.rec, "--params", path, "--out", out, "--executor", "serial"], (path.name, *names),
                    (c.rec, path), (out / "params.yaml", out / "checkpoint.json"))

    return build


def shortened(until: float, build: Callable[[Ctx], Case]) -> Callable[[Ctx], Case]:
    def wrapped(c: Ctx) -> Case:
        shorten_telemetry(c.rec, until)
        return build(c)

    return wrapped


def duplicate_in_template(root: Path) -> Path:
    path = root / "templates" / "push.yaml"
    path.write_text(path.read_text().replace("body: push", "body: push\nname: push_twice"))
    return path


def duplicate_in_domain(root: Path) -> Path:
    path = root / "domain.yaml"
    path.write_text(path.read_text() + "name: another-domain\n")
    return path


def non_utf8_domain(root: Path) -> Path:
    path = root / "domain.yaml"
    path.write_bytes(path.read_bytes().replace(b"Tabletop", b"Tabletop \xe9t\xe9"))
    return path


def problem_diff(c: Ctx) -> Case:
    problem = c.write("problem.pddl", b"(define (problem p) (:domain d) ; caf\xe9\n)")
    return Case(["diff", TABLETOP, problem], ("problem.pddl", "UTF-8", "offset"), (problem,))


BIG_BOX_TWICE = "  big_box:   {type: big_box,   pose: {xyz: [0.55, 0.20, 0.875]}}\n"

CASES: dict[str, Callable[[Ctx], Case]] = {
    # --- parameter and scene values: physical ranges -----------------------------------------------------------
    "params-latency-120-meant-as-ms": infer_with("params", "{kind: latency, target: arm, value: 120}",
                                                 names=("params[0].value", "latency 120 s", "physical range")),
    "params-latency-1e9": infer_with("params", "{kind: latency, target: arm, value: 1.0e9}",
                                     names=("params[0].value", "latency")),
    "scene-latency-120-as-dt": infer_with("scene", "{kind: latency, target: arm, value: 120, effect: latency}",
                                          names=("params[0].value", "latency")),
    "scene-negative-friction": infer_with("scene", "{kind: friction, target: table, value: -0.4}",
                                          names=("params[0].value", "friction -0.4")),
    "params-negative-mass": infer_with("params", "{kind: mass, target: big_box, value: -1}",
                                       names=("params[0].value", "mass -1 kg")),
    "params-zero-mass": infer_with("params", "{kind: mass, target: big_box, value: 0}",
                                   names=("params[0].value", "mass 0 kg")),
    "params-friction-50": infer_with("params", "{kind: friction, target: big_box, value: 50}",
                                     names=("params[0].value", "[0, 5]")),
    "scene-tilt-3-rad": infer_with("scene", "{kind: surface_slope_x, target: table, value: 3}",
                                   names=("params[0].value", "surface_slope_x 3 rad")),
    "scene-dz-half-metre": infer_with("scene", "{kind: surface_dz, target: table, value: 0.5}",
                                      names=("params[0].value", "surface_dz")),
    "params-dissipation-1000": infer_with("params", "{kind: dissipation, target: big_box, value: 1000}",
                                          names=("params[0].value", "dissipation 1000 s/m")),
    "params-modulus-10-pa": infer_with("params", "{kind: hydroelastic_modulus, target: big_box, value: 10}",
                                       names=("params[0].value", "hydroelastic_modulus 10 Pa")),
    "params-com-z-5-m": infer_with("params", "{kind: com_z, target: big_box, value: 5}",
                                   names=("params[0].value", "com_z 5 m")),
    "params-force-5000-n": infer_with("params", "{kind: force_x, target: big_box, value: 5000}",
                                      names=("params[0].value", "force_x 5000 N")),
    "params-joint-offset-4-rad": infer_with("params", "{kind: joint_offset, target: arm_joint1, value: 4}",
                                            names=("params[0].value", "joint_offset 4")),
    "params-mass-spread-5": infer_with("params", "{kind: mass_spread, target: big_box, value: 5}",
                                       names=("params[0].value", "mass_spread 5")),
    "scene-patch-half-0": infer_with("scene", "{kind: patch_half, target: table, value: 0}",
                                     names=("params[0].value", "patch_half 0 m")),
    "scene-patch-mu-negative": infer_with("scene", "{kind: patch_mu, target: table, value: -1}",
                                          names=("params[0].value", "patch_mu -1")),
    "params-second-entry-named": infer_with("params", "{kind: friction, target: big_box, value: 0.5}",
                                            "{kind: mass, target: small_box, value: 3000}",
                                            names=("params[1].value", "mass 3000 kg")),
    "params-std-negative": infer_with("params", "{kind: friction, target: big_box, value: 0.5, std: -0.1}",
                                      names=("params[0].std", ">= 0")),
    "params-value-nan": infer_with("params", "{kind: friction, target: big_box, value: .nan}",
                                   names=("params[0].value", "finite")),
    # --- parameter and scene values: against the recording and the models -------------------------------------
    "latency-past-half-the-telemetry": shortened(1.0, infer_with("params", "{kind: latency, target: arm, value: 0.8}",
                                                                 names=("params[0].value", "telemetry.csv",
                                                                        "latency 0.8 s"))),
    "scene-mass-in-grams": infer_with("scene", "{kind: mass, target: big_box, value: 300}",
                                      names=("params[0].value", "300 times", "'big_box'")),
    "params-mass-of-a-type-in-grams": infer_with("params", "{kind: mass, target: 'type:small_box', value: 300}",
                                                 names=("params[0].value", "'small_box'", "not in kg")),
    "params-com-outside-the-body": infer_with("params", "{kind: com_x, target: big_box, value: 0.3}",
                                              names=("params[0].value", "com_x 0.3 m", "'big_box'")),
    "params-force-lifts-the-box": infer_with("params", "{kind: force_z, target: small_box, value: 500}",
                                             names=("params[0].value", "weight of 'small_box'")),
    "params-finger-offset-past-its-range": infer_with("params",
                                                      "{kind: joint_offset, target: finger_left_joint, value: 0.1}",
                                                      names=("params[0].value", "finger_left_joint", "[0, 0.05]")),
    "scene-post-off-the-table": infer_with("scene", "{kind: obstacle_x, target: table, value: 5.0}",
                                           names=("params[0].value", "off the top of 'table'")),
    "fit-latency-bounds-in-ms": fit_with("{kind: latency, target: arm, bounds: [0, 120]}",
                                         names=("params[0].bounds[1]", "latency 120 s")),
    "fit-latency-bounds-past-the-telemetry": fit_with("{kind: latency, target: arm, bounds: [-0.3, 0.3]}",
                                                      names=("params[0].bounds[0]", "telemetry.csv"), until=0.5),
    "fit-tilt-bounds-in-degrees": fit_with("{kind: surface_slope_y, target: table, bounds: [-5, 5]}",
                                           names=("params[0].bounds[0]", "surface_slope_y -5 rad")),
    # --- duplicate keys ---------------------------------------------------------------------------------------
    "world-object-twice": bad_world(lambda t: t.replace("  tray:", BIG_BOX_TWICE + "  tray:"),
                                    "duplicate key 'big_box'", "line 7"),
    "world-facts-twice": bad_world(lambda t: t + "facts: []\n", "duplicate key 'facts'"),
    "world-pose-xyz-twice": bad_world(lambda t: t.replace("{xyz: [0.55, 0.20, 0.875]}",
                                                          "{xyz: [0.55, 0.20, 0.875], xyz: [0, 0, 2]}"),
                                      "duplicate key 'xyz'"),
    "params-key-twice": lambda c: infer_with("params", "{kind: friction, target: big_box, value: 0.5, "
                                             "value: 0.9}", names=("duplicate key 'value'", "line 2"))(c),
    "recording-yaml-key-twice": bad_recording_file("recording.yaml", lambda b: b + b"name: another\n",
                                                   "duplicate key 'name'"),
    "odb-type-twice-in-one-file": bad_odb("extra.yaml", "lamp: {parent: box, geometry: {shape: box, size: [0.1, 0.1, "
                                          "0.1]}}\nlamp: {parent: box, geometry: {shape: sphere, size: [0.05]}}\n",
                                          "extra.yaml", "duplicate key 'lamp'", "line 2"),
    "template-key-twice": bad_templates(duplicate_in_template, "push.yaml", "duplicate key 'name'"),
    "domain-key-twice": bad_templates(duplicate_in_domain, "domain.yaml", "duplicate key 'name'"),
    # --- bytes that are not UTF-8 -------------------------------------------------------------------------------
    "world-not-utf8": bad_recording_file("world.yaml", lambda b: b.replace(b"tabletop", b"tablet\xf6p", 1),
                                         "UTF-8", "offset"),
    "recording-yaml-not-utf8": bad_recording_file("recording.yaml", lambda b: b"notes: caf\xe9\n" + b,
                                                  "UTF-8", "offset 10"),
    "telemetry-not-utf8": bad_recording_file("telemetry.csv", lambda b: b + b"# \xff\n", "UTF-8", "byte"),
    "observed-not-utf8": bad_recording_file("observed.csv", lambda b: b.replace(b"big_box", b"big_b\xf6x", 1),
                                            "UTF-8", "byte"),
    "params-not-utf8": lambda c: (lambda p: Case(["infer", c.rec, "--params", p], ("p.yaml", "UTF-8", "offset"),
                                                 (c.rec, p), (c.out,)))(
        c.write("p.yaml", b"# r\xe9glage\nparams:\n  - {kind: friction, target: big_box, value: 0.5}\n")),
    "odb-type-file-not-utf8": bad_odb("extra.yaml", b"# l\xe4mp\nlamp: {parent: box}\n", "extra.yaml", "UTF-8"),
    "domain-not-utf8": bad_templates(non_utf8_domain, "domain.yaml", "UTF-8", "offset"),
    "problem-not-utf8": problem_diff,
    # --- meshes that are no OBJ -----------------------------------------------------------------------------------
    "obj-random-bytes": bad_odb("extra.yaml", "lamp: {parent: box, geometry: {shape: mesh, mesh: lamp.obj}}\n",
                                "lamp.obj", "not an OBJ mesh", mesh=("lamp.obj", bytes(range(256)) * 4)),
    "obj-other-text": bad_odb("extra.yaml", "lamp: {parent: box, geometry: {shape: mesh, mesh: lamp.obj}}\n",
                              "lamp.obj", "not an OBJ mesh", mesh=("lamp.obj", b"<html>not a mesh</html>\n")),
    "obj-vertex-of-two-numbers": bad_odb("extra.yaml", "lamp: {parent: box, geometry: {shape: mesh, mesh: lamp.obj}}\n",
                                         "lamp.obj", "line 2", mesh=("lamp.obj", b"v 0 0 0\nv 1 0\nv 0 1 0\nf 1 2 3\n")),
    "obj-face-past-the-vertices": bad_odb("extra.yaml", "lamp: {parent: box, geometry: {shape: mesh, mesh: lamp.obj}}\n",
                                          "lamp.obj", "line 4", mesh=("lamp.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n")),
    "odb-friction-in-percent": bad_odb("extra.yaml", "lamp: {parent: box, geometry: {shape: box, size: [0.1, 0.1, "
                                       "0.1]}, physics: {friction: 40}}\n", "extra.yaml", "lamp.physics.friction",
                                       "[0, 5]"),
    "odb-mass-in-grams": bad_odb("extra.yaml", "lamp: {parent: box, geometry: {shape: box, size: [0.1, 0.1, "
                                 "0.1]}, physics: {mass: 2500}}\n", "extra.yaml", "lamp.physics.mass", "kg"),
    # --- options ------------------------------------------------------------------------------------------------
    "diagnose-unknown-effect": option("diagnose", "REC", "--out", "OUT", "--effects", "friction,gravity",
                                      names=("'gravity'", "friction_patch", "hidden_obstacle")),
    "infer-event-period-0": option("infer", "REC", "--events", "--event-period", "0", names=("--event-period", "> 0")),
    "infer-event-period-negative": option("infer", "REC", "--events", "--event-period", "-1",
                                          names=("--event-period",)),
    "infer-event-period-nan": option("infer", "REC", "--event-period", "nan", names=("--event-period", "'nan'")),
    "diff-translation-nan": option("diff", str(TABLETOP), str(TABLETOP), "--translation", "nan",
                                   names=("--translation", "finite")),
    "diff-translation-inf": option("diff", str(TABLETOP), str(TABLETOP), "--translation", "inf",
                                   names=("--translation",)),
    "diff-rotation-negative": option("diff", str(TABLETOP), str(TABLETOP), "--rotation", "-5",
                                     names=("--rotation", ">= 0")),
    "infer-samples-negative": option("infer", "REC", "--samples", "-1", names=("--samples", ">= 0")),
    "infer-workers-0": option("infer", "REC", "--samples", "4", "--workers", "0", names=("--workers", ">= 1")),
    "infer-seed-negative": option("infer", "REC", "--seed", "-3", names=("--seed",)),
    "fit-generations-0": option("fit", "REC", "--out", "OUT", "--generations", "0", names=("--generations",)),
    "fit-popsize-1": option("fit", "REC", "--out", "OUT", "--popsize", "1", names=("--popsize", ">= 2")),
    "fit-hold-out-negative": option("fit", "REC", "--out", "OUT", "--hold-out", "-1", names=("--hold-out",)),
    "fit-max-duration-0": option("fit", "REC", "--out", "OUT", "--max-duration", "0", names=("--max-duration",)),
    "fit-workers-text": option("fit", "REC", "--out", "OUT", "--workers", "two", names=("--workers", "'two'")),
    "diagnose-max-duration-negative": option("diagnose", "REC", "--out", "OUT", "--max-duration", "-1",
                                             names=("--max-duration",)),
    "diagnose-workers-0": option("diagnose", "REC", "--out", "OUT", "--workers", "0", names=("--workers",)),
    "prove-workers-0": option("prove", "--out", "OUT", "--workers", "0", names=("--workers",)),
    "export-min-probability-nan": option("export", str(TABLETOP), "--out", "OUT", "--min-probability", "nan",
                                         names=("minimum probability", "(0.5, 1]")),
    "infer-min-probability-half": option("infer", "REC", "--min-probability", "0.5",
                                         names=("minimum probability", "0.5")),
    # --- robot joints in a world state ----------------------------------------------------------------------------
    "world-joint-inf": bad_world(with_joints("arm_joint2: .inf"), "robot.joints.arm_joint2", "finite"),
    "world-joint-nan": bad_world(with_joints("arm_joint2: .nan"), "robot.joints.arm_joint2", "finite"),
    "world-joint-past-its-limit": bad_world(with_joints("arm_joint2: 5.0"), "robot.joints.arm_joint2", "5",
                                            "[-2.0944, 2.0944]", "arm7.sdf"),
    "world-joint-in-degrees": bad_world(with_joints("arm_joint1: 170"), "robot.joints.arm_joint1", "170"),
    "world-finger-open-half-a-metre": bad_world(with_joints("finger_left_joint: 0.5"),
                                                "robot.joints.finger_left_joint", "[0, 0.05]"),
    "world-joint-the-robot-lacks": bad_world(with_joints("elbow: 0.1"), "robot.joints.elbow", "no joint 'elbow'"),
    # --- telemetry against the robot ------------------------------------------------------------------------------
    "telemetry-in-degrees": bad_telemetry_column("arm_joint4", "111.7", "arm_joint4", "111.7", "[-2.618, 2.618]",
                                                 "sample 10"),
    "telemetry-finger-past-its-limit": bad_telemetry_column("finger_right_joint", "0.2", "finger_right_joint"),
    "telemetry-infinite": bad_telemetry_column("arm_joint2", "inf", "line 11", "arm_joint2", "not finite"),
    "telemetry-joint-the-robot-lacks": bad_recording_file(
        "telemetry.csv", lambda b: b.replace(b"finger_right_joint", b"elbow", 1), "'elbow'", "not a joint"),
    "telemetry-lacks-a-joint": bad_recording_file(
        "telemetry.csv", lambda b: b"\n".join(line.rsplit(b",", 1)[0] for line in b.split(b"\n")),
        "lacks joint 'finger_right_joint'"),
    # --- observations against the world ---------------------------------------------------------------------------
    "observed-object-not-in-world": bad_recording_file("observed.csv", lambda b: b.replace(b"big_box", b"ghost_box"),
                                                       "'ghost_box'", "world.yaml"),
}


@pytest.mark.parametrize("build", CASES.values(), ids=CASES.keys())
def test_bad_value_is_refused(build, refuse, recording, tmp_path):
    case = build(Ctx(tmp_path, recording))
    refuse(case.argv, *case.names, inputs=case.inputs, absent=case.absent)


def test_the_battery_is_large_enough():
    assert len(CASES) >= 40


# --- valid edge values are still accepted -----------------------------------------------------------------------
@pytest.fixture
def demo(recording, odb):
    from bridge.recording.recording import load_recording, recording_world
    from bridge.rollout import Rollout

    rec = load_recording(recording)
    return Rollout(recording_world(rec, odb), rec.telemetry, name=rec.name)


@pytest.mark.parametrize("entry", [
    "{kind: latency, target: arm, value: 0.05}",
    "{kind: latency, target: arm, value: -0.12}",
    "{kind: surface_slope_x, target: table, value: 0.1}",
    "{kind: surface_slope_y, target: table, value: -0.5}",
    "{kind: friction, target: big_box, value: 0}",
    "{kind: mass, target: big_box, value: 3.5, std: 0.2}",
    "{kind: com_x, target: big_box, value: 0.05}",
    "{kind: force_z, target: big_box, value: -20}",
    "{kind: joint_offset, target: finger_left_joint, value: 0.002}",
    "{kind: obstacle_x, target: table, value: 1.15}",
    "{kind: latency, target: arm, bounds: [-0.3, 0.3]}",
], ids=lambda e: e.split("kind: ")[1].split(",")[0] + "=" + e.split(": ")[-1].rstrip("}"))
def test_valid_edge_values_load(entry, demo, odb, tmp_path):
    from bridge.params import check_values, load_param_file

    path = tmp_path / "p.yaml"
    path.write_text(params(entry))
    check_values(load_param_file(path), [demo], odb)


def test_world_joints_at_their_limits_load(odb, tmp_path):
    from bridge.world import load_world_state

    path = tmp_path / "w.yaml"
    path.write_text(with_joints("arm_joint2: 2.0944, arm_joint4: -2.63, finger_left_joint: 0.0")(
        TABLETOP.read_text()))
    joints = load_world_state(path, odb).robot.joint_positions()
    assert joints["arm_joint2"] == 2.0944 and joints["arm_joint4"] == -2.63  # within the 1 % tolerance


def test_yaml_merge_keys_may_still_be_overridden():
    from bridge.files import load_yaml_text

    data = load_yaml_text("base: &b {u: 1, v: 2}\nc: {<<: *b, u: 3}\n")
    assert data["c"] == {"u": 3, "v": 2}


def test_a_byte_order_mark_is_no_error(tmp_path):
    from bridge.files import read_yaml

    path = tmp_path / "x.yaml"
    path.write_bytes(b"\xef\xbb\xbfa: 1\n")
    assert read_yaml(path, "file") == {"a": 1}


@pytest.mark.parametrize("argv", [
    ["diff", "a", "b", "--translation", "0", "--rotation", "0"],
    ["infer", "r", "--event-period", "0.01", "--samples", "0", "--workers", "1", "--seed", "0"],
    ["fit", "r", "--out", "o", "--generations", "1", "--popsize", "2", "--hold-out", "0", "--max-duration", "0.5"],
], ids=["diff-zero-thresholds", "infer-smallest", "fit-smallest"])
def test_edge_options_parse(argv):
    from bridge.cli import build_parser

    build_parser().parse_args(argv)


def test_a_valid_mesh_loads(odb_copy):
    from bridge.odb import load_object_database

    (odb_copy / "types" / "lamp.obj").write_text(
        "# a tetrahedron\nv 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nv 0 0 0.1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2/1 3/2 4/3\n")
    (odb_copy / "types" / "extra.yaml").write_text("lamp: {parent: box, geometry: {shape: mesh, mesh: lamp.obj}}\n")
    assert load_object_database(odb_copy).types["lamp"].geometry.mesh.name == "lamp.obj"

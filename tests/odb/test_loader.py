"""The object database loader on its own: inheritance key by key, robot joints read from the model file,
``dataset://`` meshes, SIE references checked by shape (not ancestry), YAML 1.2 booleans."""
import sys
import textwrap
from pathlib import Path

import pytest

from bridge.errors import ObjectDatabaseError
from bridge.odb.loader import dataset_names, dataset_roots_from_env, load_sie_class, read_types
from bridge.odb.types import Geometry, SIERef

REPO = Path(__file__).resolve().parents[2]

# SIE classes that know nothing of bridge: the database checks their shape only
DUCK = '''
class On:
    def evaluate(self, obj, ctx):
        return []


class OnTop(On):
    pass


class Flag:
    def __init__(self, level=0):
        self.level = level

    def evaluate(self, obj, ctx):
        return []


def function(obj, ctx):
    return []


class NoEvaluate:
    pass


class Attribute:
    evaluate = 3


instance = On()
'''

BASE = '''
thing:
  abstract: true
  physics: {friction: 0.4, dissipation: 2.0}
  predicates:
    on:  {params: [thing, thing], sie: sies.duck:On}
    yes: {params: [thing], sie: {class: sies.duck:Flag, params: {level: 1}}}
block:
  parent: thing
  pddl_type: block
  geometry: {shape: box, size: [0.1, 0.2, 0.3], color: [1, 0, 0, 1]}
  physics: {mass: 2.0, com: [0, 0, 0.01]}
  predicates:
    yes: {sie: {class: sies.duck:Flag, params: {level: 2}}}
small_block:
  parent: block
  physics: {friction: 0.9}
  predicates:
    on: {sie: sies.duck:OnTop}
    off: {params: [block], subject: 0}
'''

BALLS = '''
ball:
  parent: block
  geometry: {shape: sphere, size: [0.05]}
  physics: {density: 500, hydroelastic_modulus: 1.0e+6}
rigid_ball:
  parent: ball
  physics: {hydroelastic_modulus: null}
lamp:
  parent: thing
  pddl_type: lamp
  geometry: {shape: mesh, mesh: ../../meshes/lamp.obj, scale: 0.001, convex: false}
  physics: {mass: 0.4}
'''


def write_db(root: Path, types: dict[str, str], sies: dict[str, str] | None = None) -> Path:
    """A database under `root`: types/<file> for each entry of `types`, sies/<module>.py for each of `sies`."""
    for rel, text in types.items():
        (root / "types" / rel).parent.mkdir(parents=True, exist_ok=True)
        (root / "types" / rel).write_text(textwrap.dedent(text))
    (root / "sies").mkdir(parents=True, exist_ok=True)
    for module, text in {"duck": DUCK, **(sies or {})}.items():
        (root / "sies" / f"{module}.py").write_text(textwrap.dedent(text))
    return root


@pytest.fixture
def small_db(tmp_path) -> Path:
    root = write_db(tmp_path / "db", {"base.yaml": BASE, "more/balls.yaml": BALLS})
    (root / "meshes").mkdir()
    (root / "meshes" / "lamp.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    return root


def read_error(root: Path, datasets=None) -> ObjectDatabaseError:
    with pytest.raises(ObjectDatabaseError) as info:
        read_types(root, datasets or {})
    assert "\n" not in str(info.value), str(info.value)
    return info.value


# --- inheritance ---------------------------------------------------------------------------------
def test_lineage_pddl_type_and_flags(small_db):
    types, _ = read_types(small_db, {})
    assert set(types) == {"thing", "block", "small_block", "ball", "rigid_ball", "lamp"}
    small = types["small_block"]
    assert small.ancestors == ("small_block", "block", "thing") and small.parent == "block"
    assert types["rigid_ball"].ancestors == ("rigid_ball", "ball", "block", "thing")
    assert types["thing"].pddl_type == "object" and small.pddl_type == "block" and types["lamp"].pddl_type == "lamp"
    assert types["thing"].abstract and not types["block"].abstract  # 'abstract' is not inherited
    assert types["ball"].source == small_db / "types" / "more" / "balls.yaml"
    assert small.source == small_db / "types" / "base.yaml"


def test_geometry_is_replaced_whole(small_db):
    types, _ = read_types(small_db, {})
    block = types["block"].geometry
    assert block == Geometry("box", (0.1, 0.2, 0.3), color=(1.0, 0.0, 0.0, 1.0))
    assert types["small_block"].geometry == block
    # the ball's sphere keeps nothing of the box: not its size, not its colour
    assert types["ball"].geometry == Geometry("sphere", (0.05,))
    lamp = types["lamp"].geometry
    assert lamp.shape == "mesh" and lamp.mesh == small_db / "meshes" / "lamp.obj"  # relative to the YAML file
    assert lamp.scale == 0.001 and lamp.convex is False and lamp.unresolved is None


def test_physics_is_merged_field_by_field(small_db):
    types, _ = read_types(small_db, {})
    small, ball, rigid = types["small_block"].physics, types["ball"].physics, types["rigid_ball"].physics
    assert (small.mass, small.density, small.com) == (2.0, None, (0.0, 0.0, 0.01))  # from block
    assert (small.friction, small.dissipation) == (0.9, 2.0)  # own friction, dissipation from thing
    assert types["block"].physics.friction == 0.4
    # density replaces the inherited mass (one of them drives the mass), the rest is kept
    assert (ball.mass, ball.density, ball.com, ball.friction) == (None, 500.0, (0.0, 0.0, 0.01), 0.4)
    assert ball.hydroelastic_modulus == 1.0e6 and rigid.hydroelastic_modulus is None  # null resets it
    assert rigid.density == 500.0


def test_predicates_are_inherited_and_overridden_by_name(small_db):
    types, _ = read_types(small_db, {})
    thing, block, small = (types[n].predicates for n in ("thing", "block", "small_block"))
    assert set(thing) == {"on", "yes"} and set(block) == {"on", "yes"} and set(small) == {"on", "yes", "off"}
    assert block["on"] == thing["on"]  # inherited as is
    # an SIE overridden without re-declaring params keeps the signature and who declared it
    assert small["on"].params == ("thing", "thing") and small["on"].declared_by == "thing"
    assert (small["on"].sie.module, small["on"].sie.cls) == ("sies.duck", "OnTop")
    assert thing["on"].sie.cls == "On"
    assert thing["yes"].sie.params == (("level", 1),) and block["yes"].sie.params == (("level", 2),)
    assert small["yes"].sie == block["yes"].sie and small["yes"].params == ("thing",)
    assert small["off"].params == ("block",) and small["off"].declared_by == "small_block" and small["off"].sie is None
    assert block["yes"].sie.source == f"{small_db / 'types' / 'base.yaml'}: block.predicates.yes.sie"


def test_subject_is_inherited_with_the_signature(tmp_path):
    root = write_db(tmp_path / "db", {"t.yaml": """
        hand: {abstract: true, predicates: {holding: {params: [hand, thing], subject: 1, sie: sies.duck:On}}}
        left_hand: {parent: hand, abstract: true, predicates: {holding: {sie: sies.duck:OnTop}}}
        thing: {abstract: true}
        """})
    types, _ = read_types(root, {})
    assert types["left_hand"].predicates["holding"].subject == 1
    assert types["left_hand"].predicates["holding"].sie.cls == "OnTop"


def test_sie_package_is_the_database_root(small_db):
    _, package = read_types(small_db, {})
    assert package.startswith("_bridge_odb_")
    assert list(sys.modules[package].__path__) == [str(small_db)]
    assert read_types(small_db, {})[1] == package  # the same root, the same package


# --- YAML 1.2 booleans ---------------------------------------------------------------------------
def test_yaml_1_1_booleans_stay_strings(tmp_path):
    root = write_db(tmp_path / "db", {"t.yaml": """
        on:
          abstract: true
          predicates: {on: {params: [on]}, yes: {params: [on]}, no: {params: [on]}, off: {params: [on]}}
        y: {parent: on, pddl_type: n, abstract: true}
        """})
    types, _ = read_types(root, {})
    assert set(types) == {"on", "y"} and all(isinstance(k, str) for k in types)
    assert set(types["on"].predicates) == {"on", "yes", "no", "off"}
    assert types["y"].pddl_type == "n" and types["on"].predicates["yes"].params == ("on",)
    (root / "types" / "t.yaml").write_text("thing: {abstract: yes}\n")
    error = read_error(root)
    assert error.field == "thing.abstract" and str(error).endswith("must be true or false, got 'yes'")


# --- malformed definitions not covered by tests/odb/test_database.py -----------------------------
BAD = [
    ("mass and density", "x: {parent: thing, geometry: {shape: sphere, size: [1]}, physics: {mass: 1, density: 2}}",
     "x.physics", "give mass or density, not both"),
    ("negative friction", "x: {parent: block, physics: {friction: -0.1}}", "x.physics.friction", "must not be negative, got -0.1"),
    ("boolean number", "x: {parent: block, physics: {mass: true}}", "x.physics.mass", "must be a finite number, got True"),
    ("nan", "x: {parent: block, physics: {mass: .nan}}", "x.physics.mass", "must be a finite number, got nan"),
    ("infinite size", "x: {parent: block, geometry: {shape: sphere, size: [.inf]}}", "x.geometry.size[0]",
     "must be a finite number, got inf"),
    ("subject out of range", "x: {parent: block, predicates: {lit: {params: [block], subject: 1}}}",
     "x.predicates.lit.subject", "subject must index one of the 1 params"),
    ("new predicate without params", "x: {parent: block, predicates: {lit: {sie: sies.duck:On}}}",
     "x.predicates.lit", "a new predicate needs 'params' (its argument types)"),
    ("sie params not a mapping", "x: {parent: block, predicates: {on: {sie: {class: sies.duck:On, params: [1]}}}}",
     "x.predicates.on.sie.params", "params must be a mapping"),
    ("pddl_type", "x: {parent: block, pddl_type: two words}", "x.pddl_type", "pddl_type 'two words' is not a PDDL identifier"),
    ("movable without mass", "x: {parent: thing, geometry: {shape: sphere, size: [1]}}", "x.physics",
     "a concrete movable type needs physics.mass or physics.density"),
    ("mesh without path", "x: {parent: block, geometry: {shape: mesh}}", "x.geometry.mesh",
     "a mesh geometry needs 'mesh': a path to an OBJ file"),
    ("plane top not a flag", "x: {parent: block, fixed: true, geometry: {shape: box, size: [1, 1, 1], plane_top: 1}}",
     "x.geometry.plane_top", "must be true or false, got 1"),
    ("plane top of a cylinder", "x: {parent: block, fixed: true, geometry: {shape: cylinder, size: [1, 1], "
     "plane_top: true}}", "x.geometry.plane_top", "plane_top applies to box geometry only, not cylinder"),
    ("plane top of a mesh", "x: {parent: block, fixed: true, geometry: {shape: mesh, mesh: m.obj, plane_top: true}}",
     "x.geometry.plane_top", "plane_top applies to box geometry only, not mesh"),
    ("plane top of a free object", "x: {parent: block, geometry: {shape: box, size: [1, 1, 1], plane_top: true}}",
     "x.geometry.plane_top", "plane_top applies to fixtures only (a free object's top carries nothing as a plane)"),
]


@pytest.mark.parametrize("case,text,field,message", BAD, ids=[c[0] for c in BAD])
def test_malformed_definition_is_one_error_naming_the_field(small_db, case, text, field, message):
    path = small_db / "types" / "zz.yaml"
    path.write_text(text + "\n")
    error = read_error(small_db)
    assert (error.source, error.field) == (str(path), field)
    assert str(error) == f"{path}: {field}: {message}"


def test_database_files_and_folders(tmp_path):
    assert "no 'types' folder" in str(read_error(tmp_path))
    (tmp_path / "types").mkdir()
    (tmp_path / "types" / "empty.yaml").write_text("# nothing yet\n")
    assert str(read_error(tmp_path)) == f"{tmp_path}: no object types found in types/*.yaml"
    (tmp_path / "types" / "list.yaml").write_text("- thing\n")
    assert str(read_error(tmp_path)) == f"{tmp_path / 'types' / 'list.yaml'}: must map type names to definitions"
    (tmp_path / "types" / "list.yaml").write_text("thing:\n")  # an empty body is an empty mapping
    assert "thing.geometry: a concrete type needs a geometry" in str(read_error(tmp_path))
    (tmp_path / "types" / "list.yaml").write_text("thing: {abstract: true}\n")
    assert set(read_types(tmp_path, {})[0]) == {"thing"}


# --- robots --------------------------------------------------------------------------------------
SDF = """<?xml version="1.0"?>
<sdf version="1.7"><model name="bot">
  <link name="base"/><link name="l1"/><link name="l2"/><link name="l3"/>
  <joint name="shoulder" type="revolute"><parent>base</parent><child>l1</child></joint>
  <joint name="slide" type="prismatic"><parent>l1</parent><child>l2</child></joint>
  <joint name="weld" type="fixed"><parent>l2</parent><child>l3</child></joint>
</model></sdf>
"""


def robot_db(tmp_path: Path, robot: str, model_text: str = SDF, model_name: str = "bot.sdf") -> Path:
    root = write_db(tmp_path / "db", {"robots.yaml": f"""
        robot: {{abstract: true, pddl_type: robot}}
        bot:
          parent: robot
          robot: {robot}
        """})
    (root / "models").mkdir()
    (root / "models" / model_name).write_text(model_text)
    return root


def test_bundled_robot_joint_types_come_from_the_model_files(odb_copy):
    types, _ = read_types(odb_copy, {})
    pusher = types["planar_pusher"].robot
    assert pusher.joint_type == {"pusher_x": "prismatic", "pusher_y": "prismatic"}
    assert pusher.model == REPO / "models" / "pusher2d" / "pusher2d.sdf"
    arm = types["demo_arm"].robot
    assert arm.joint_types == tuple((f"arm_joint{i}", "revolute") for i in range(1, 8)) + (
        ("finger_left_joint", "prismatic"), ("finger_right_joint", "prismatic"))
    assert "hand_weld" not in arm.joint_type  # only the listed (actuated) joints
    assert arm.gripper.joints == ("finger_left_joint", "finger_right_joint") and arm.gripper.open_position == 0.04
    assert arm.home_positions()["arm_joint4"] == 1.95 and pusher.home_positions() == {"pusher_x": 0.0, "pusher_y": 0.0}


def test_robot_entry_of_a_small_database(tmp_path):
    root = robot_db(tmp_path, "{model: ../models/bot.sdf, joints: [slide, shoulder], home: {slide: 0.1}, kp: 50}")
    spec = read_types(root, {})[0]["bot"].robot
    assert spec.model == root / "models" / "bot.sdf"  # relative to the YAML file
    assert spec.joints == ("slide", "shoulder")
    assert spec.joint_types == (("slide", "prismatic"), ("shoulder", "revolute"))  # in the listed order
    assert spec.home_positions() == {"slide": 0.1, "shoulder": 0.0} and spec.kp == 50.0 and spec.kd == 40.0
    assert spec.base_link == "base" and spec.gripper is None


def test_joint_missing_from_the_model_names_the_joint_and_lists_the_models_joints(tmp_path):
    root = robot_db(tmp_path, "{model: ../models/bot.sdf, joints: [shoulder, elbow]}")
    error = read_error(root)
    assert (error.source, error.field) == (str(root / "types" / "robots.yaml"), "bot.robot.joints")
    assert str(error).endswith("robot model bot.sdf has no joint 'elbow'; its joints: shoulder, slide, weld")


def test_model_that_is_not_xml_is_one_clear_error(tmp_path):
    root = robot_db(tmp_path, "{model: ../models/bot.sdf, joints: [shoulder]}", model_text="model: not xml\n")
    error = read_error(root)
    assert error.field == "bot.robot.model"
    assert f"cannot read robot model {root / 'models' / 'bot.sdf'}: syntax error" in str(error)


ROBOT_ERRORS = [
    ("no model", "{joints: [shoulder]}", "bot.robot.model", "needs 'model': a path to the robot's SDF/URDF"),
    ("no joints", "{model: ../models/bot.sdf, joints: []}", "bot.robot.joints", "joints must be a non-empty list of joint names"),
    ("gripper joint", "{model: ../models/bot.sdf, joints: [shoulder], gripper: {joints: [slide]}}", "bot.robot.gripper.joints",
     "gripper joint 'slide' is not in the robot's joints"),
    ("home joint", "{model: ../models/bot.sdf, joints: [shoulder], home: {slide: 0.1}}", "bot.robot.home",
     "home must map the robot's joints to positions"),
    ("unknown key", "{model: ../models/bot.sdf, joints: [shoulder], speed: 1}", "bot.robot",
     "unknown key 'speed'; valid keys: base_link, gripper, home, joints, kd, kp, model"),
    ("gain", "{model: ../models/bot.sdf, joints: [shoulder], kd: 0}", "bot.robot.kd", "must be positive, got 0"),
]


@pytest.mark.parametrize("case,robot,field,message", ROBOT_ERRORS, ids=[c[0] for c in ROBOT_ERRORS])
def test_malformed_robot_entry(tmp_path, case, robot, field, message):
    root = robot_db(tmp_path, robot)
    error = read_error(root)
    assert error.field == field and str(error).endswith(f"{field}: {message}")


# --- dataset:// meshes ---------------------------------------------------------------------------
MESHES = {
    "shapes.yaml": """
        thing: {abstract: true}
        puck: {parent: thing, geometry: {shape: mesh, mesh: "dataset://alpha/obj/puck.obj"}, physics: {mass: 1}}
        cube: {parent: thing, geometry: {shape: box, size: [1, 1, 1]}, physics: {mass: 1}}
        """,
    "sub/more.yaml": """
        big_puck: {parent: puck}
        tile: {parent: thing, geometry: {shape: mesh, mesh: dataset://beta-set/deep/tile.obj, scale: 2}, physics: {mass: 1}}
        """,
}


def test_dataset_names_are_found_without_resolving(tmp_path):
    root = write_db(tmp_path / "db", MESHES)
    assert dataset_names(root) == {"alpha", "beta-set"}


def test_dataset_roots_from_the_environment_then_beside_the_repository(tmp_path, monkeypatch):
    for var in ("BRIDGE_DATASET_ALPHA", "BRIDGE_DATASET_BETA_SET", "BRIDGE_DATASET_GAMMA"):
        monkeypatch.delenv(var, raising=False)
    repo = tmp_path / "repo"
    (tmp_path / "shared" / "datasets" / "alpha").mkdir(parents=True)
    (tmp_path / "shared" / "datasets" / "beta-set").mkdir(parents=True)
    names = {"alpha", "beta-set", "gamma"}
    assert dataset_roots_from_env(names, repo) == {"alpha": tmp_path / "shared" / "datasets" / "alpha",
                                                   "beta-set": tmp_path / "shared" / "datasets" / "beta-set"}
    monkeypatch.setenv("BRIDGE_DATASET_BETA_SET", str(tmp_path / "elsewhere"))  # '-' becomes '_', upper case
    roots = dataset_roots_from_env(names, repo)
    assert roots["beta-set"] == tmp_path / "elsewhere" and "gamma" not in roots  # the environment wins
    assert dataset_roots_from_env(names, None) == {"beta-set": tmp_path / "elsewhere"}
    assert dataset_roots_from_env(set(), repo) == {}


def test_the_short_variable_names_a_dataset_as_the_recording_loaders_read_it(tmp_path, monkeypatch):
    """BRIDGE_MIT_PUSH set for the recordings must also resolve the object database's dataset://mit-push meshes;
    a clean clone with only that variable set failed every test that built an MIT shape."""
    for var in ("BRIDGE_DATASET_MIT_PUSH", "BRIDGE_MIT_PUSH"):
        monkeypatch.delenv(var, raising=False)
    repo = tmp_path / "repo"  # nothing beside it
    assert dataset_roots_from_env({"mit-push"}, repo) == {}
    monkeypatch.setenv("BRIDGE_MIT_PUSH", str(tmp_path / "short"))
    assert dataset_roots_from_env({"mit-push"}, repo) == {"mit-push": tmp_path / "short"}
    monkeypatch.setenv("BRIDGE_DATASET_MIT_PUSH", str(tmp_path / "long"))  # the long form wins
    assert dataset_roots_from_env({"mit-push"}, repo) == {"mit-push": tmp_path / "long"}


def test_unknown_dataset_leaves_the_mesh_unresolved(tmp_path):
    root = write_db(tmp_path / "db", MESHES)
    types, _ = read_types(root, {})
    puck = types["puck"].geometry
    assert puck.mesh is None and puck.unresolved == "dataset://alpha/obj/puck.obj"
    assert types["big_puck"].geometry == puck  # inherited unresolved
    assert types["tile"].geometry.unresolved == "dataset://beta-set/deep/tile.obj" and types["tile"].geometry.scale == 2.0


def test_known_dataset_resolves_the_mesh(tmp_path):
    root = write_db(tmp_path / "db", MESHES)
    alpha, beta = tmp_path / "alpha", tmp_path / "beta"
    (alpha / "obj").mkdir(parents=True)
    (alpha / "obj" / "puck.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    types, _ = read_types(root, {"alpha": alpha})
    assert types["puck"].geometry.mesh == alpha / "obj" / "puck.obj" and types["puck"].geometry.unresolved is None
    assert types["tile"].geometry.mesh is None  # beta-set still unknown
    error = read_error(root, {"alpha": alpha, "beta-set": beta})  # known, but the file is not there
    assert error.field == "tile.geometry.mesh"
    assert str(error).endswith(f"mesh file {beta / 'deep' / 'tile.obj'} not found")


# --- SIE references ------------------------------------------------------------------------------
@pytest.fixture
def sie_db(tmp_path):
    root = write_db(tmp_path / "db", {"t.yaml": "thing: {abstract: true}\n"}, {
        "helpers": "def nothing(obj, ctx):\n    return []\n",
        "relative": "from .helpers import nothing\n\n\nclass Near:\n    evaluate = staticmethod(nothing)\n",
        "broken": "raise RuntimeError('boom')\n",
        "syntax": "class Oops(\n",
        "needs_dep": "import bridge_no_such_dependency\n\n\nclass Dep:\n"
                     "    def evaluate(self, obj, ctx):\n        return []\n",
    })
    return root, read_types(root, {})[1]


def ref(module: str, cls: str) -> SIERef:
    return SIERef(module, cls, (), "t.yaml: thing.predicates.p.sie")


def test_any_class_with_evaluate_is_an_sie(sie_db):
    _, package = sie_db
    flag = load_sie_class(package, ref("sies.duck", "Flag"))
    assert flag.__name__ == "Flag" and flag.__module__ == f"{package}.sies.duck"
    assert flag(level=3).level == 3 and flag().evaluate("box", None) == []
    assert load_sie_class(package, ref("sies.duck", "OnTop")).__mro__[1].__name__ == "On"
    near = load_sie_class(package, ref("sies.relative", "Near"))  # SIE modules import each other relatively
    assert near.evaluate("box", None) == []


NOT_SIES = [
    ("instance", "sies.duck:instance is not an SIE class"),
    ("function", "sies.duck:function is not an SIE class"),
    ("NoEvaluate", "sies.duck:NoEvaluate is not an SIE class"),
    ("Attribute", "sies.duck:Attribute is not an SIE class"),
    ("Missing", "sies.duck:Missing is not an SIE class"),
]


@pytest.mark.parametrize("cls,message", NOT_SIES, ids=[c for c, _ in NOT_SIES])
def test_reference_to_something_else_is_refused(sie_db, cls, message):
    _, package = sie_db
    with pytest.raises(ObjectDatabaseError) as info:
        load_sie_class(package, ref("sies.duck", cls))
    text = str(info.value)
    assert text.startswith(f"t.yaml: thing.predicates.p.sie: {message} (a class with evaluate(obj, ctx)")
    assert "\n" not in text


BAD_MODULES = [
    ("sies.nothing", "SIE module 'sies.nothing' not found"),
    ("sies.broken", "SIE module 'sies.broken' failed to import: RuntimeError: boom"),
    ("sies.syntax", "SIE module 'sies.syntax' failed to import: SyntaxError: "),
]


@pytest.mark.parametrize("module,message", BAD_MODULES, ids=[m for m, _ in BAD_MODULES])
def test_bad_module_is_one_message_naming_the_reference(sie_db, module, message):
    _, package = sie_db
    for _ in range(2):  # a failed import is not cached as a success
        with pytest.raises(ObjectDatabaseError) as info:
            load_sie_class(package, ref(module, "Anything"))
        assert str(info.value).startswith(f"t.yaml: thing.predicates.p.sie: {message}") and "\n" not in str(info.value)
        assert info.value.source == "t.yaml: thing.predicates.p.sie"


def test_bad_reference_fails_when_the_database_is_read(sie_db):
    root, _ = sie_db
    path = root / "types" / "t.yaml"
    path.write_text("thing: {abstract: true, predicates: {p: {params: [thing], sie: sies.broken:X}}}\n")
    error = read_error(root)
    assert str(error) == f"{path}: thing.predicates.p.sie: SIE module 'sies.broken' failed to import: RuntimeError: boom"


def test_two_databases_keep_their_own_sie_modules(tmp_path):
    flag = "class Flag:\n    LEVEL = {}\n\n    def evaluate(self, obj, ctx):\n        return []\n"
    one = write_db(tmp_path / "one", {"t.yaml": "thing: {abstract: true}\n"}, {"duck": flag.format(1)})
    two = write_db(tmp_path / "two", {"t.yaml": "thing: {abstract: true}\n"}, {"duck": flag.format(2)})
    (_, p1), (_, p2) = read_types(one, {}), read_types(two, {})
    assert p1 != p2
    assert load_sie_class(p1, ref("sies.duck", "Flag")).LEVEL == 1
    assert load_sie_class(p2, ref("sies.duck", "Flag")).LEVEL == 2


# --- bugs found while writing these tests (see the report) ---------------------------------------
def test_module_with_a_missing_dependency_failed_to_import(sie_db):
    """sies/needs_dep.py exists; what is missing is a module it imports, so 'not found' would send the user astray."""
    _, package = sie_db
    with pytest.raises(ObjectDatabaseError) as info:
        load_sie_class(package, ref("sies.needs_dep", "Dep"))
    assert "SIE module 'sies.needs_dep' failed to import" in str(info.value)
    assert "bridge_no_such_dependency" in str(info.value)


URDF = """<?xml version="1.0"?>
<robot name="bot">
  <link name="base"/><link name="l1"/>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 0 1"/></joint>
  <transmission name="shoulder_tr">
    <type>transmission_interface/SimpleTransmission</type>
    <joint name="shoulder"><hardwareInterface>hardware_interface/EffortJointInterface</hardwareInterface></joint>
    <actuator name="shoulder_motor"><mechanicalReduction>1</mechanicalReduction></actuator>
  </transmission>
</robot>
"""


def test_urdf_transmission_does_not_hide_the_joint_type(tmp_path):
    """A URDF's <transmission> names its joint in a <joint> element without a type; the joint's own type counts."""
    root = robot_db(tmp_path, "{model: ../models/bot.urdf, joints: [shoulder]}", model_text=URDF, model_name="bot.urdf")
    assert read_types(root, {})[0]["bot"].robot.joint_type == {"shoulder": "revolute"}


def test_dataset_names_come_from_mesh_paths_not_comments(tmp_path):
    root = write_db(tmp_path / "db", {**MESHES, "notes.yaml": "# meshes live in dataset://alpha (see the docs)\n"})
    assert dataset_names(root) == {"alpha", "beta-set"}
    assert dataset_names(REPO / "odb") == {"mit-push"}

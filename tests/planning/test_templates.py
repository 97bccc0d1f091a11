"""Action templates: the bundled ones load and mean what the SIEs decide; malformed ones give one clear error."""
from pathlib import Path

import pytest

from bridge.errors import PddlError
from bridge.planning import domain_text, load_action_templates, load_domain_settings
from bridge.planning.templates import check_requirements

REPO = Path(__file__).resolve().parents[2]


def test_bundled_templates_load(templates):
    assert sorted(templates) == ["pick", "place", "push", "push_against", "push_over", "stand_up"]
    for name, template in templates.items():
        assert template.body == name  # the motion generators in bridge/sim/bodies.py carry the same names
        assert template.doc and template.source.name == f"{name}.yaml"
    assert templates["push_over"].parameters == (("r", "robot"), ("o", "box"), ("s", "object"))
    assert templates["push_against"].signature() == "?r - robot ?o - movable ?t - movable ?s - object"


def test_domain_settings_cover_what_the_templates_use(templates, settings):
    assert settings.name == "bridge-tabletop"
    assert check_requirements(settings, templates) == settings.requirements
    assert "conditional-effects" in templates["pick"].requirements
    assert "universal-preconditions" in templates["place"].requirements
    assert templates["push_over"].requirements == {"strips", "typing"}


def test_missing_requirement_names_the_action(templates, tmp_path):
    (tmp_path / "domain.yaml").write_text("name: d\nrequirements: [strips, typing, negative-preconditions]\n")
    settings = load_domain_settings(tmp_path)
    with pytest.raises(PddlError) as info:
        check_requirements(settings, templates)
    message = str(info.value)
    assert str(tmp_path / "domain.yaml") in message and "requirements:" in message
    assert "'pick'" in message and "conditional-effects" in message


def test_adl_covers_everything(templates, tmp_path):
    (tmp_path / "domain.yaml").write_text("name: d\nrequirements: [':adl']\n")
    assert check_requirements(load_domain_settings(tmp_path), templates) == ("adl",)


def test_domain_text(odb, templates, settings):
    text = domain_text(odb, templates, settings=settings)
    assert text.startswith("(define (domain bridge-tabletop)")
    assert "tray - container" in text and "box" in text
    assert "(on ?a - movable ?b - object)" in text  # VAL wants '- object' spelled out
    assert "(:action push_against" in text and ":parameters (?r - robot ?o - movable ?t - movable ?s - object)" in text


def test_subtype_argument_is_fine_supertype_is_not(odb, template_folder):
    """A box may stand where a movable is expected; an object where a movable is expected may not."""
    (template_folder / "lift.yaml").write_text(
        'name: lift\nparameters: "?r - robot ?o - box"\nprecondition: "(and (clear ?o) (hand-empty ?r))"\n'
        'effect: "(and (holding ?r ?o) (not (hand-empty ?r)))"\n')
    assert load_action_templates(template_folder, odb)["lift"].parameters[1] == ("o", "box")
    (template_folder / "lift.yaml").write_text(
        'name: lift\nparameters: "?r - robot ?o - object"\nprecondition: "(clear ?o)"\neffect: "(holding ?r ?o)"\n')
    with pytest.raises(PddlError, match=r"precondition: \(clear \?o\): \?o is an object, but clear expects a movable"):
        load_action_templates(template_folder, odb)


GOOD = {
    "name": "nudge",
    "parameters": '"?r - robot ?o - movable ?s - object"',
    "precondition": '"(and (upright ?o) (on ?o ?s) (hand-empty ?r))"',
    "effect": '"(forall (?x - movable) (when (touching ?o ?x) (not (touching ?o ?x))))"',
}


def template(**fields) -> str:
    merged = {**GOOD, **fields}
    return "".join(f"{k}: {v}\n" for k, v in merged.items() if v is not None)


# (case, file text, field named in the message, fragments of the message)
BAD_TEMPLATES = [
    ("yaml syntax", template(effect='"(not (upright ?o))'), "line", ["YAML syntax error"]),
    ("undeclared predicate", template(effect='"(holds ?r ?o)"'), "effect",
     ["predicate 'holds' is not declared", "declared: clear, hand-empty, holding"]),
    ("wrong arity", template(precondition='"(on ?o)"'), "precondition", ["on takes 2 argument(s) (movable object), got 1"]),
    ("wrong argument type", template(effect='"(holding ?o ?r)"'), "effect",
     ["(holding ?o ?r)", "?o is a movable, but holding expects a robot"]),
    ("robot where movable expected", template(effect='"(upright ?r)"'), "effect", ["?r is a robot, but upright expects a movable"]),
    ("undeclared variable", template(effect='"(not (upright ?x))"'), "effect",
     ["variable ?x is not declared in the parameters or a quantifier"]),
    ("variable outside its quantifier", template(effect='"(and (forall (?x - movable) (clear ?x)) (upright ?x))"'),
     "effect", ["variable ?x is not declared"]),
    ("unknown parameter type", template(parameters='"?r - robot ?o - crate ?s"'), "parameters",
     ["unknown type 'crate' of ?o", "PDDL types:", "movable"]),
    ("unknown quantifier type", template(effect='"(forall (?x - crate) (not (touching ?o ?x)))"'), "effect",
     ["unknown type 'crate' of ?x"]),
    ("missing effect", template(effect=None), "effect", ["missing key 'effect'"]),
    ("missing parameters", template(parameters=None), "parameters", ["missing key 'parameters'"]),
    ("bad name", template(name="'nudge it'"), "name", ["'nudge it' is not an identifier"]),
    ("keyword name", template(name="forall"), "name", ["'forall' is a PDDL keyword"]),
    ("name not text", template(name="3"), "name", ["3 is not an identifier"]),
    ("unknown key", template() + "cost: 3\n", None, ["unknown key 'cost'", "valid keys: body, doc, effect"]),
    ("unbalanced", template(precondition='"(and (upright ?o) (on ?o ?s)"'), "precondition", ["unbalanced parentheses"]),
    ("two formulas", template(effect='"(upright ?o) (clear ?o)"'), "effect", ["more than one formula", "(and ...)"]),
    ("syntax error", template(effect='"(and (when (upright ?o)))"'), "effect", ["unexpected ')'"]),
    ("constant", template(precondition='"(on ?o table)"'), "precondition", ["'table' is not a variable: write ?table"]),
    ("duplicate parameter", template(parameters='"?r - robot ?o - movable ?o - object"'), "parameters",
     ["?o is declared twice"]),
    ("either type", template(parameters='"?r - robot ?o - (either box cup) ?s"'), "parameters",
     ["(either ...) types are not supported"]),
    ("negated equality as effect", template(effect='"(not (= ?o ?s))"'), "effect", ["cannot be an effect"]),
    ("numeric effect", template(effect='"(increase (cost) 1)"'), "effect", ["is not supported in an effect"]),
    ("not text", template(effect="[1, 2]"), "effect", ["must be PDDL written as text"]),
    ("duplicate name", template(name="pick"), "name", ["action name 'pick' is already used by", "pick.yaml"]),
]


@pytest.mark.parametrize("case,text,field,fragments", BAD_TEMPLATES, ids=[c[0] for c in BAD_TEMPLATES])
def test_malformed_template_gives_one_clear_error(odb, template_folder, case, text, field, fragments):
    path = template_folder / "zz_nudge.yaml"  # sorts after pick.yaml, so a duplicate name is found here
    path.write_bytes(text.encode())
    with pytest.raises(PddlError) as info:
        load_action_templates(template_folder, odb)
    message = str(info.value)
    assert message.startswith(f"{path}: "), message
    if field:
        assert f"{path}: {field}" in message, message
    assert "\n" not in message
    for fragment in fragments:
        assert fragment in message, message
    assert path.read_bytes() == text.encode()  # the file is left untouched


def test_error_fields_are_set(odb, template_folder):
    (template_folder / "zz.yaml").write_text(template(effect='"(holds ?r ?o)"'))
    with pytest.raises(PddlError) as info:
        load_action_templates(template_folder, odb)
    assert info.value.source == str(template_folder / "zz.yaml") and info.value.field == "effect"


def test_missing_or_empty_folder(odb, tmp_path):
    with pytest.raises(PddlError, match="action template folder not found"):
        load_action_templates(tmp_path / "nope", odb)
    with pytest.raises(PddlError, match=r"no action templates \(\*\.yaml\)"):
        load_action_templates(tmp_path, odb)


def test_domain_settings_errors(tmp_path):
    path = tmp_path / "domain.yaml"
    path.write_text("name: d\nrequirements: [strips, fluents]\n")
    with pytest.raises(PddlError, match=r"requirements\[1\]: unsupported requirement 'fluents'"):
        load_domain_settings(tmp_path)
    path.write_text("name: d\nplanner: lama\n")
    with pytest.raises(PddlError, match="unknown key 'planner'"):
        load_domain_settings(path)
    assert load_domain_settings(REPO / "pddl" / "domain.yaml").name == "bridge-tabletop"

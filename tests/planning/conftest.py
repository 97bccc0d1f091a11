"""Fixtures of the planning tests: the bundled object database and templates, and small world states."""
import shutil
from pathlib import Path

import pytest

from bridge.planning import load_action_templates, load_domain_settings
from bridge.world import load_world_state, world_from_dict

REPO = Path(__file__).resolve().parents[2]
FIXTURES = REPO / "tests" / "fixtures"
TOPPLED = FIXTURES / "worlds" / "toppled.yaml"
DEMO = REPO / "demo" / "worlds" / "tabletop.yaml"


@pytest.fixture(scope="session")
def templates(odb):
    return load_action_templates(REPO / "pddl" / "templates", odb)


@pytest.fixture(scope="session")
def settings():
    return load_domain_settings(REPO / "pddl")


@pytest.fixture(scope="session")
def toppled(odb):
    """small_box lies on its side on work_table; big_box and "Tray 1" stand on it; the goal: box upright on the tray."""
    return load_world_state(TOPPLED, odb)


@pytest.fixture
def template_folder(tmp_path) -> Path:
    """A writable copy of the bundled action templates."""
    folder = tmp_path / "templates"
    shutil.copytree(REPO / "pddl" / "templates", folder)
    return folder


@pytest.fixture(scope="session")
def world_of(odb):
    """Build a world in code from its facts (and optionally objects, goal); see `make_world`."""
    return lambda facts, **kwargs: make_world(odb, facts, **kwargs)


def make_world(odb, facts, objects=None, goal=None):
    """A table, big_box, small_box, "Tray 1" and "Cup 1" with the arm; poses do not matter to PDDL."""
    objects = objects or {
        "table": {"type": "table", "pose": {"xyz": [0.75, 0, 0.725]}},
        "big_box": {"type": "big_box", "pose": {"xyz": [0.55, 0.2, 0.875]}},
        "small_box": {"type": "small_box", "pose": {"xyz": [0.55, -0.15, 0.81]}},
        "Tray 1": {"type": "tray", "pose": {"xyz": [0.8, 0, 0.76]}},
        "Cup 1": {"type": "cup", "pose": {"xyz": [0.8, 0.1, 0.82]}},
    }
    data = {"name": "test world", "objects": objects, "robot": {"name": "arm", "type": "demo_arm"}, "facts": list(facts)}
    if goal is not None:
        data["goal"] = goal
    return world_from_dict(data, odb)

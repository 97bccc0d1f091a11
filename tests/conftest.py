"""Fixtures shared by every test layer."""
import os
import shutil
import signal
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(autouse=True)
def _signal_handlers_kept(request):
    """A test that leaves SIGINT or SIGTERM handled otherwise than it found them fails (and the handler is put
    back): tests of Ctrl-C behaviour that run after it in the same worker would otherwise fail for its sake."""
    signums = (signal.SIGINT, signal.SIGTERM)
    before = {s: signal.getsignal(s) for s in signums}
    yield
    left = {s: signal.getsignal(s) for s in signums if signal.getsignal(s) is not before[s]}
    for s in left:
        signal.signal(s, before[s])
    if left:
        pytest.fail(f"{request.node.nodeid} left " + ", ".join(f"{signal.Signals(s).name} handled by {h!r}"
                                                                for s, h in left.items()))


def pytest_collection_modifyitems(config, items):
    """The proof's two halves first, one per core: they are the longest files by far, and with the tests spread
    over the cores file by file (pytest-xdist, `--dist loadfile --no-loadscope-reorder`) the other files then run
    beside them instead of after them."""
    items.sort(key=lambda item: not item.nodeid.startswith("tests/prove/test_proof"))


def find_mit_push() -> Path | None:
    candidates = [os.environ.get("BRIDGE_MIT_PUSH"), os.environ.get("BRIDGE_DATASET_MIT_PUSH"),
                  str(REPO.parent / "shared" / "datasets" / "mit-push")]
    for c in candidates:
        if c and (Path(c) / "train").is_dir():
            return Path(c)
    return None


@pytest.fixture(scope="session")
def mit_push_root() -> Path:
    root = find_mit_push()
    if root is None:
        pytest.skip("MIT planar pushing dataset not found: set BRIDGE_MIT_PUSH or put it at ../shared/datasets/mit-push")
    return root


@pytest.fixture
def odb_copy(tmp_path) -> Path:
    """A writable copy of the bundled object database, robot models pointing back at the repository."""
    root = tmp_path / "odb"
    shutil.copytree(REPO / "odb", root, ignore=shutil.ignore_patterns("__pycache__"))
    robots = root / "types" / "robots.yaml"
    robots.write_text(robots.read_text().replace("../../models/", f"{REPO}/models/"))
    return root


@pytest.fixture(scope="session")
def odb():
    """The bundled object database (mit-push meshes from ../shared when present)."""
    pytest.importorskip("pydrake")
    from bridge.odb import load_object_database

    return load_object_database()


@pytest.fixture(scope="session")
def trials(odb):
    """The synthetic push scenario ('slide', 'turn') observed with `bridge.fit.synthetic.TRUE_VALUES`."""
    from bridge.fit.synthetic import push_trials

    return push_trials(odb)


@pytest.fixture(scope="session")
def slide(trials):
    return [t for t in trials if t.name == "slide"]


@pytest.fixture(scope="session")
def pool(odb):
    """Two spawned worker processes, shared by the slow tests (spawning and importing Drake costs seconds)."""
    from bridge.rollout import make_executor

    with make_executor("process", odb, workers=2) as executor:
        yield executor

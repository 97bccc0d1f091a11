"""The proof's fixtures: one folder and one pool of workers per test file."""
import pytest


@pytest.fixture(scope="module")
def proof_root(tmp_path_factory):
    return tmp_path_factory.mktemp("proof")


@pytest.fixture(scope="module")
def executor(odb):
    """One pool of two workers for every case of a file (starting one costs seconds)."""
    from bridge.rollout import make_executor

    with make_executor("process", odb, workers=2) as pool:
        yield pool

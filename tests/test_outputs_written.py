"""Writing outputs (bridge/files.py): sets of files published together, folders replaced whole, the umask's mode,
output folders locked while a run writes them. Interrupts are real signals where the code defers them and raised
exceptions where a test stands for a crash."""
from __future__ import annotations

import os
import signal
import stat
import subprocess
import sys
from pathlib import Path

import pytest

from bridge import files
from bridge.errors import BridgeError
from bridge.files import LOCK_FILE, claim_outputs, deferred_signals, replace_folder, write_atomic, write_set

REPO = Path(__file__).resolve().parents[1]


def _temps(folder: Path) -> list[Path]:
    return sorted(folder.rglob("*.tmp"))


@pytest.fixture
def old_set(tmp_path):
    paths = [tmp_path / "world_after.yaml", tmp_path / "problem_after.pddl", tmp_path / "problem_after.uncertain.json"]
    for p in paths:
        p.write_text(f"old {p.name}\n")
    return paths


def _new(paths):
    return {p: f"new {p.name}\n" for p in paths}


# --- write_set --------------------------------------------------------------------------------------------------
def test_write_set_publishes_every_file(old_set, tmp_path):
    write_set(_new(old_set))
    assert [p.read_text() for p in old_set] == [f"new {p.name}\n" for p in old_set]
    assert not _temps(tmp_path)


def test_an_interrupt_while_writing_leaves_the_old_set(old_set, tmp_path, monkeypatch):
    calls = []
    real_fsync = os.fsync

    def fsync(fd):
        calls.append(fd)
        if len(calls) == 2:  # the second temporary file: the first one is written already
            raise KeyboardInterrupt
        real_fsync(fd)

    monkeypatch.setattr(os, "fsync", fsync)
    with pytest.raises(KeyboardInterrupt):
        write_set(_new(old_set))
    assert [p.read_text() for p in old_set] == [f"old {p.name}\n" for p in old_set]
    assert not _temps(tmp_path)


@pytest.fixture
def ctrl_c():
    """Ctrl-C as an interactive run has it (KeyboardInterrupt): a shell that starts the tests in the background
    (`pytest &` in a script) leaves SIGINT ignored, and an ignored signal is not delivered at all."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous)


def test_a_sigint_after_the_first_rename_waits_for_the_whole_set(old_set, tmp_path, monkeypatch, ctrl_c):
    """A real SIGINT between two renames is held back: the set is completed, then the interrupt is raised."""
    real_replace = os.replace
    renamed = []

    def replace(src, dst):
        real_replace(src, dst)
        renamed.append(dst)
        if len(renamed) == 1:
            os.kill(os.getpid(), signal.SIGINT)

    monkeypatch.setattr(os, "replace", replace)
    with pytest.raises(KeyboardInterrupt):
        write_set(_new(old_set))
    assert len(renamed) == 3
    assert [p.read_text() for p in old_set] == [f"new {p.name}\n" for p in old_set]
    assert not _temps(tmp_path)


@pytest.mark.parametrize("failure", [KeyboardInterrupt, OSError], ids=["interrupt-raised", "os-error"])
def test_a_failure_after_the_first_rename_puts_the_old_set_back(old_set, tmp_path, monkeypatch, failure):
    real_replace = os.replace
    renamed = []

    def replace(src, dst):
        if len(renamed) == 1 and str(src).endswith(".tmp") and ".old." not in str(src):
            raise failure(5, "Input/output error") if failure is OSError else failure()
        real_replace(src, dst)
        renamed.append(dst)

    monkeypatch.setattr(os, "replace", replace)
    with pytest.raises(BridgeError if failure is OSError else KeyboardInterrupt) as err:
        write_set(_new(old_set))
    assert [p.read_text() for p in old_set] == [f"old {p.name}\n" for p in old_set]
    assert not _temps(tmp_path)
    if failure is OSError:
        assert str(old_set[1]) in str(err.value) and "Input/output error" in str(err.value)


def test_a_none_content_removes_a_stale_member(old_set):
    write_set({old_set[0]: "new\n", old_set[2]: None})
    assert old_set[0].read_text() == "new\n" and not old_set[2].exists() and old_set[1].read_text().startswith("old")


def test_deferred_signals_deliver_after_the_block(ctrl_c):
    seen = []
    with pytest.raises(KeyboardInterrupt):
        with deferred_signals():
            os.kill(os.getpid(), signal.SIGINT)
            seen.append("block ran to its end")
    assert seen == ["block ran to its end"]
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


@pytest.mark.parametrize("writer", ["write_atomic", "write_set", "replace_folder"])
def test_new_files_get_the_umask_mode(tmp_path, writer):
    old = os.umask(0o027)
    try:
        target = tmp_path / "a.txt"
        if writer == "write_atomic":
            write_atomic(target, "x")
        elif writer == "write_set":
            write_set({target: "x", tmp_path / "b.txt": b"y"})
        else:
            with replace_folder(tmp_path / "rec") as new:
                (new / "a.txt").write_text("x")
                write_atomic(new / "b.txt", "y")
            target = tmp_path / "rec" / "b.txt"
            assert stat.S_IMODE((tmp_path / "rec").stat().st_mode) == 0o750
    finally:
        os.umask(old)
    assert stat.S_IMODE(target.stat().st_mode) == 0o640


def test_write_errors_name_the_path(tmp_path):
    (tmp_path / "afile").write_text("")
    (tmp_path / "adir").mkdir()
    with pytest.raises(BridgeError, match="afile is a file, not a folder") as err:
        write_atomic(tmp_path / "afile" / "x.yaml", "x")
    assert str(tmp_path / "afile" / "x.yaml") in str(err.value)
    with pytest.raises(BridgeError, match="is a folder, not a file"):
        write_set({tmp_path / "ok.txt": "x", tmp_path / "adir": "y"})
    assert not (tmp_path / "ok.txt").exists() and not _temps(tmp_path)


# --- replace_folder -----------------------------------------------------------------------------------------------
def test_replace_folder_keeps_the_old_folder_when_interrupted(tmp_path):
    folder = tmp_path / "rec"
    folder.mkdir()
    (folder / "world.yaml").write_text("old")
    with pytest.raises(KeyboardInterrupt):
        with replace_folder(folder) as new:
            (new / "world.yaml").write_text("new")
            raise KeyboardInterrupt
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rec"] and (folder / "world.yaml").read_text() == "old"
    with pytest.raises(KeyboardInterrupt):
        with replace_folder(tmp_path / "fresh") as new:
            (new / "world.yaml").write_text("new")
            raise KeyboardInterrupt
    assert not (tmp_path / "fresh").exists() and not _temps(tmp_path)


def test_replace_folder_swaps_whole_and_carries_the_other_files(tmp_path, monkeypatch, ctrl_c):
    folder = tmp_path / "rec"
    (folder / "sub").mkdir(parents=True)
    (folder / "world.yaml").write_text("old")
    (folder / "notes.txt").write_text("mine")
    (folder / "sub" / "scene.yaml").write_text("scene")
    real_rename = os.rename
    calls = []

    def rename(src, dst):  # a real SIGINT between moving the old folder away and the new one in: held back
        real_rename(src, dst)
        calls.append(dst)
        if len(calls) == 1:
            os.kill(os.getpid(), signal.SIGINT)

    monkeypatch.setattr(os, "rename", rename)
    with pytest.raises(KeyboardInterrupt):
        with replace_folder(folder) as new:
            (new / "world.yaml").write_text("new")
    assert (folder / "world.yaml").read_text() == "new" and (folder / "notes.txt").read_text() == "mine"
    assert (folder / "sub" / "scene.yaml").read_text() == "scene"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rec"]


# --- claim_outputs ------------------------------------------------------------------------------------------------
def _hold(path: Path, kind: str = "folders"):
    """Another process holding the claim on `path` (a bridge run writing there) until it is told to stop."""
    code = ("import sys\nfrom bridge.files import claim_outputs\n"
            f"with claim_outputs({kind}=[sys.argv[1]]):\n    print('held', flush=True)\n    sys.stdin.read()\n")
    proc = subprocess.Popen([sys.executable, "-c", code, str(path)], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            text=True, cwd=REPO, env={**os.environ, "PYTHONPATH": str(REPO)})
    assert proc.stdout.readline().strip() == "held"
    return proc


def test_a_second_writer_is_refused_naming_the_folder_and_pid(tmp_path):
    out = tmp_path / "export"
    holder = _hold(out)
    try:
        with pytest.raises(BridgeError) as err:
            with claim_outputs(folders=[out]):
                pytest.fail("claimed a folder another process holds")
        assert str(out) in str(err.value) and f"pid {holder.pid}" in str(err.value)
        with pytest.raises(BridgeError, match="another bridge run"):  # a file in it: its folder is locked
            with claim_outputs([out / "domain.pddl"]):
                pass
    finally:
        holder.communicate("")
    assert not (out / LOCK_FILE).exists()  # the holder removed its lock file
    with claim_outputs(folders=[out]):  # free again
        assert (out / LOCK_FILE).read_text().strip() == str(os.getpid())
    assert not out.exists()  # made again by this claim, and left empty


def test_a_claim_removes_what_it_made_when_the_run_writes_nothing(tmp_path):
    with claim_outputs([tmp_path / "out" / "rec" / "world_after.yaml"]):
        assert (tmp_path / "out" / "rec" / LOCK_FILE).is_file()
    assert list(tmp_path.iterdir()) == []
    with claim_outputs([tmp_path / "out" / "rec" / "world_after.yaml"]):
        write_atomic(tmp_path / "out" / "rec" / "world_after.yaml", "x")
    assert [p.name for p in (tmp_path / "out" / "rec").iterdir()] == ["world_after.yaml"]


def test_a_claim_inside_a_claim_of_this_process(tmp_path):
    with claim_outputs(folders=[tmp_path]):
        with claim_outputs([tmp_path / "a.txt"]):
            pass
        assert (tmp_path / LOCK_FILE).is_file()  # still held by the outer claim
    assert not (tmp_path / LOCK_FILE).exists() and files._held == {}

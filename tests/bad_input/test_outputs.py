"""Bad outputs: every output that cannot be written is refused in one line naming the path, BEFORE the long work
(each case replaces the replay, fit, diagnosis or proof with a function that fails the test), with the inputs
unchanged and nothing written. Then what a run leaves when interrupted, and where `infer` writes by default.

Read-only folders: when the tests run as root, permissions do not stop anyone, so the folder is made immutable
(`chattr +i`, which stops root too); where that is not possible either, creating a file or folder in it is made
to fail with EACCES (monkeypatched `os.open` / `os.mkdir`), as the kernel would for another user.
"""
from __future__ import annotations

import errno
import hashlib
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from bridge.files import LOCK_FILE

REPO = Path(__file__).resolve().parents[2]
PUSH = ["push_over", "arm", "big_box", "table"]


class Env:
    """Builds the bad outputs of one case: files and folders in the way, read-only folders, folders another
    bridge process is writing."""

    def __init__(self, tmp_path: Path, recording: Path, monkeypatch, request):
        self.tmp, self.recording, self.monkeypatch, self.request = tmp_path, recording, monkeypatch, request

    def file(self, name: str) -> Path:
        path = self.tmp / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text("in the way\n")
        return path

    def folder(self, name: str) -> Path:
        path = self.tmp / name
        path.mkdir(parents=True, exist_ok=True)
        return path

    def readonly(self, name: str) -> Path:
        path = self.folder(name)
        if os.geteuid() != 0:
            path.chmod(0o555)
            self.request.addfinalizer(lambda: path.chmod(0o755))
        elif shutil.which("chattr") and subprocess.run(["chattr", "+i", str(path)], capture_output=True).returncode == 0:
            self.request.addfinalizer(lambda: subprocess.run(["chattr", "-i", str(path)], check=True))
        else:
            self._refuse_writes_in(path)
        return path

    def _refuse_writes_in(self, folder: Path) -> None:
        real_open, real_mkdir = os.open, os.mkdir

        def inside(path) -> bool:
            return Path(os.path.abspath(path)).parent == folder

        def fake_open(path, flags, *args, **kwargs):
            if flags & os.O_CREAT and inside(path):
                raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), str(path))
            return real_open(path, flags, *args, **kwargs)

        def fake_mkdir(path, *args, **kwargs):
            if inside(path):
                raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), str(path))
            return real_mkdir(path, *args, **kwargs)

        self.monkeypatch.setattr(os, "open", fake_open)
        self.monkeypatch.setattr(os, "mkdir", fake_mkdir)

    def locked(self, path: Path, kind: str = "folders") -> Path:
        """`path` claimed by another bridge process (as `bridge.files.claim_outputs` does for a run)."""
        code = ("import sys\nfrom bridge.files import claim_outputs\n"
                f"with claim_outputs({kind}=[sys.argv[1]]):\n    print('held', flush=True)\n    sys.stdin.read()\n")
        proc = subprocess.Popen([sys.executable, "-c", code, str(path)], stdin=subprocess.PIPE,
                                stdout=subprocess.PIPE, text=True, cwd=REPO, env={**os.environ, "PYTHONPATH": str(REPO)})
        self.request.addfinalizer(lambda: proc.communicate(""))
        assert proc.stdout.readline().strip() == "held"
        return path


@pytest.fixture
def env(tmp_path, recording, monkeypatch, request) -> Env:
    return Env(tmp_path, recording, monkeypatch, request)


@pytest.fixture
def no_long_work(monkeypatch):
    """Every long piece of work a command starts fails the test: a bad output must be refused before it."""
    import bridge.diagnosis.pipeline
    import bridge.enactment
    import bridge.fit.fit
    import bridge.prove.proof
    import bridge.sim.viewer
    import bridge.teleop
    import bridge.uncertainty

    for module, name in ((bridge.teleop, "run_session"), (bridge.uncertainty, "sample_session"),
                         (bridge.sim.viewer, "write_replay_html"), (bridge.enactment, "enact"),
                         (bridge.fit.fit, "fit_parameters"), (bridge.diagnosis.pipeline, "diagnose_paths"),
                         (bridge.prove.proof, "run_proof")):
        def fail(*args, _name=name, **kwargs):
            pytest.fail(f"{_name} ran before the bad output was refused")
        monkeypatch.setattr(module, name, fail)


def _infer(e: Env, *options):
    return ["infer", e.recording, *options]


# Each case: env -> (argv, names the error line must hold, outputs that must not appear)
CASES = {
    # infer: --world-out / --problem-out / the default out/NAME/
    "infer-world-out-is-a-folder": lambda e: (_infer(e, "--world-out", e.folder("w")), [e.tmp / "w", "folder"], []),
    "infer-problem-out-is-a-folder": lambda e: (_infer(e, "--world-out", e.tmp / "w.yaml", "--problem-out", e.folder("p.pddl")),
                                                [e.tmp / "p.pddl", "folder"], [e.tmp / "w.yaml"]),
    "infer-world-out-under-a-file": lambda e: (_infer(e, "--world-out", e.file("f") / "w.yaml"), [e.tmp / "f", "is a file"], []),
    "infer-world-and-problem-out-the-same-file": lambda e: (
        _infer(e, "--world-out", e.tmp / "same", "--problem-out", e.tmp / "same"), [e.tmp / "same", "twice"], [e.tmp / "same"]),
    "infer-world-out-is-the-recordings-world": lambda e: (_infer(e, "--world-out", e.recording / "world.yaml"),
                                                          [e.recording / "world.yaml", "input"], []),
    "infer-problem-out-is-the-telemetry": lambda e: (_infer(e, "--problem-out", e.recording / "telemetry.csv"),
                                                     [e.recording / "telemetry.csv", "input"], []),
    "infer-world-out-in-a-read-only-folder": lambda e: (_infer(e, "--world-out", e.readonly("ro") / "w.yaml"),
                                                        [e.tmp / "ro", "cannot write"], [e.tmp / "ro" / "w.yaml"]),
    "infer-world-out-below-a-read-only-folder": lambda e: (_infer(e, "--world-out", e.readonly("ro") / "a" / "w.yaml"),
                                                           [e.tmp / "ro" / "a", "cannot make"], [e.tmp / "ro" / "a"]),
    "infer-default-out-is-a-file": lambda e: (_infer(e), [Path("out") / "rec", "out is a file"], []),
    "infer-samples-default-out-is-a-folder": lambda e: (
        _infer(e, "--samples", "2", "--executor", "serial"), [Path("out") / "rec" / "world_after.yaml", "folder"], []),
    "infer-into-a-folder-another-run-writes": lambda e: (_infer(e, "--world-out", e.locked(e.tmp / "busy") / "w.yaml"),
                                                         [e.tmp / "busy", "another bridge run", "pid"], [e.tmp / "busy" / "w.yaml"]),
    # view
    "view-out-is-a-folder": lambda e: (["view", e.recording, "--out", e.folder("v.html")], [e.tmp / "v.html", "folder"], []),
    "view-out-under-a-file": lambda e: (["view", e.recording, "--out", e.file("f") / "v.html"], [e.tmp / "f"], []),
    "view-out-in-a-read-only-folder": lambda e: (["view", e.recording, "--out", e.readonly("ro") / "v.html"],
                                                 [e.tmp / "ro"], [e.tmp / "ro" / "v.html"]),
    # demo
    "demo-out-is-a-file": lambda e: (["demo", "--recordings", e.tmp, "--out", e.file("d")], [e.tmp / "d", "is a file"], []),
    "demo-out-in-a-read-only-folder": lambda e: (["demo", "--recordings", e.tmp, "--out", e.readonly("ro")],
                                                 [e.tmp / "ro"], [e.tmp / "ro" / "rec"]),
    "demo-into-a-folder-another-run-writes": lambda e: (["demo", "--recordings", e.tmp, "--out", e.tmp / "d"],
                                                        [e.locked(e.tmp / "d" / "rec"), "another bridge run"], []),
    # export
    "export-out-is-a-file": lambda e: (["export", e.recording / "world.yaml", "--out", e.file("x")], [e.tmp / "x", "is a file"], []),
    "export-domain-pddl-is-a-folder": lambda e: (["export", e.recording / "world.yaml", "--out", e.tmp / "x"],
                                                 [e.folder("x/domain.pddl"), "folder"], [e.tmp / "x" / "problem.pddl"]),
    "export-out-is-read-only": lambda e: (["export", e.recording / "world.yaml", "--out", e.readonly("ro")],
                                          [e.tmp / "ro", "read-only"], [e.tmp / "ro" / "domain.pddl"]),
    "export-into-a-folder-another-run-writes": lambda e: (["export", e.recording / "world.yaml", "--out", e.locked(e.tmp / "x")],
                                                          [e.tmp / "x", "another bridge run"], [e.tmp / "x" / "domain.pddl"]),
    # apply
    "apply-out-is-a-folder": lambda e: (["apply", e.recording / "world.yaml", *PUSH, "--out", e.folder("a.yaml")],
                                        [e.tmp / "a.yaml", "folder"], []),
    "apply-out-under-a-file": lambda e: (["apply", e.recording / "world.yaml", *PUSH, "--out", e.file("f") / "a.yaml"],
                                         [e.tmp / "f", "is a file"], []),
    # act
    "act-out-is-a-file": lambda e: (["act", e.recording / "world.yaml", *PUSH, "--out", e.file("r")], [e.tmp / "r", "is a file"], []),
    "act-out-not-empty-without-overwrite": lambda e: (["act", e.recording / "world.yaml", *PUSH, "--out", e.recording],
                                                      [e.recording, "--overwrite"], []),
    "act-out-under-a-file": lambda e: (["act", e.recording / "world.yaml", *PUSH, "--out", e.file("f") / "r"], [e.tmp / "f"], []),
    "act-out-in-a-read-only-folder": lambda e: (["act", e.recording / "world.yaml", *PUSH, "--out", e.readonly("ro") / "r"],
                                                [e.tmp / "ro"], [e.tmp / "ro" / "r"]),
    "act-into-a-folder-another-run-writes": lambda e: (
        ["act", e.recording / "world.yaml", *PUSH, "--out", e.locked(e.tmp / "r", "replaced")],
        [e.tmp / "r", "another bridge run"], [e.tmp / "r"]),
    # fit, diagnose, prove
    "fit-out-is-a-file": lambda e: (["fit", e.recording, "--out", e.file("fit")], [e.tmp / "fit", "is a file"], []),
    "fit-out-is-read-only": lambda e: (["fit", e.recording, "--out", e.readonly("ro")], [e.tmp / "ro"], [e.tmp / "ro" / "checkpoint.json"]),
    "fit-into-a-folder-another-run-writes": lambda e: (["fit", e.recording, "--out", e.locked(e.tmp / "fit")],
                                                       [e.tmp / "fit", "another bridge run"], [e.tmp / "fit" / "checkpoint.json"]),
    "diagnose-out-is-a-file": lambda e: (["diagnose", e.recording, "--out", e.file("diag")], [e.tmp / "diag", "is a file"], []),
    "diagnose-into-a-folder-another-run-writes": lambda e: (["diagnose", e.recording, "--out", e.locked(e.tmp / "diag")],
                                                            [e.tmp / "diag", "another bridge run"], []),
    "prove-out-is-a-file": lambda e: (["prove", "--out", e.file("proof")], [e.tmp / "proof", "is a file"], []),
    "prove-out-is-read-only": lambda e: (["prove", "--out", e.readonly("ro") / "proof"], [e.tmp / "ro"], [e.tmp / "ro" / "proof"]),
}


@pytest.mark.parametrize("case", CASES, ids=list(CASES))
def test_bad_output_is_refused_before_the_work(case, env, refuse, no_long_work, monkeypatch, tmp_path):
    monkeypatch.chdir(tmp_path)  # default outputs (out/NAME) go under the current folder
    if case == "infer-default-out-is-a-file":
        env.file("out")
    if case == "infer-samples-default-out-is-a-folder":
        env.folder("out/rec/world_after.yaml")
    argv, names, absent = CASES[case](env)
    refuse(argv, *names, inputs=[env.recording], absent=absent)
    assert not [p for p in tmp_path.rglob(LOCK_FILE)] or "another-run" in case  # only the other run's lock


def _snapshot(folder: Path) -> dict[str, str]:
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(folder.iterdir())}


# --- what a run leaves --------------------------------------------------------------------------------------------
def test_the_lock_of_another_run_is_left_to_it(env, refuse, no_long_work):
    busy = env.locked(env.tmp / "x")
    refuse(["export", env.recording / "world.yaml", "--out", busy], busy)
    assert (busy / LOCK_FILE).is_file()  # still the other run's


@pytest.mark.slow
def test_infer_writes_under_out_by_default_and_leaves_the_recording_alone(recording, monkeypatch, tmp_path, capsys):
    from bridge.cli import main


    monkeypatch.chdir(tmp_path)
    before = _snapshot(recording)
    assert main(["infer", str(recording)]) == 0
    assert "wrote out/rec/world_after.yaml and out/rec/problem_after.pddl" in capsys.readouterr().out
    assert sorted(p.name for p in (tmp_path / "out" / "rec").iterdir()) == ["problem_after.pddl", "world_after.yaml"]
    assert _snapshot(recording) == before  # same files, same bytes


@pytest.mark.slow
def test_infer_interrupted_while_writing_leaves_the_old_world_and_problem(recording, monkeypatch, tmp_path, capsys):
    """An interrupt once the first output file is written: both old files stay, no temporary file, exit 130."""
    from bridge.cli import main

    monkeypatch.chdir(tmp_path)
    out = tmp_path / "out" / "rec"
    out.mkdir(parents=True)
    (out / "world_after.yaml").write_text("old world\n")
    (out / "problem_after.pddl").write_text("old problem\n")
    real_fsync, calls = os.fsync, []

    def fsync(fd):
        calls.append(fd)
        if len(calls) == 2:
            raise KeyboardInterrupt
        real_fsync(fd)

    monkeypatch.setattr(os, "fsync", fsync)
    assert main(["infer", str(recording)]) == 130
    assert capsys.readouterr().err.strip() == "bridge infer: interrupted"
    assert (out / "world_after.yaml").read_text() == "old world\n"
    assert (out / "problem_after.pddl").read_text() == "old problem\n"
    assert sorted(p.name for p in out.iterdir()) == ["problem_after.pddl", "world_after.yaml"]  # no lock, no temp


def _fake_enact(world, odb, templates, steps, *, rng=None, free_motion=None):
    """The enactment without its simulation (seconds of Drake): the demo's telemetry, nothing moved."""
    from types import SimpleNamespace

    from bridge.enactment import Enactment, _steps
    from bridge.recording.telemetry import load_telemetry

    telemetry = load_telemetry(REPO / "demo" / "recordings" / "1_push_over" / "telemetry.csv")
    replay = SimpleNamespace(final_poses={name: obj.pose for name, obj in world.objects.items()}, sim_time=1.0)
    return Enactment(telemetry, replay, world, world, world, _steps(steps))


@pytest.mark.parametrize("existing", [False, True], ids=["new-folder", "overwrite-old-recording"])
def test_act_interrupted_leaves_no_folder_or_the_old_one(existing, recording, monkeypatch, tmp_path, capsys):
    import bridge.enactment
    import bridge.recording.recording as rec_module
    from bridge.cli import main


    monkeypatch.setattr(bridge.enactment, "enact", _fake_enact)
    out = recording if existing else tmp_path / "new"
    before = _snapshot(recording)

    def interrupted(*args, **kwargs):  # world.yaml and telemetry.csv are written by now
        raise KeyboardInterrupt

    monkeypatch.setattr(rec_module, "save_observations_csv", interrupted)
    argv = ["act", str(recording / "world.yaml"), *PUSH, "--out", str(out)] + (["--overwrite"] if existing else [])
    assert main(argv) == 130
    assert capsys.readouterr().err.strip() == "bridge act: interrupted"
    assert out.exists() == existing and _snapshot(recording) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rec"]  # no temporary folder, no lock file
    monkeypatch.undo()
    monkeypatch.setattr(bridge.enactment, "enact", _fake_enact)
    assert main(argv) == 0  # and without the interrupt, the folder is written whole
    assert sorted(p.name for p in out.iterdir()) == ["observed.csv", "recording.yaml", "telemetry.csv", "world.yaml"]
    assert "(push_over arm big_box table)" in (out / "recording.yaml").read_text()


def test_export_publishes_domain_and_problem_as_one_set(recording, tmp_path, capsys):
    """A world without fact probabilities: the uncertain facts of an earlier export do not stay beside the new
    problem; nothing else is left in the folder (no lock, no temporary file)."""
    from bridge.cli import main

    out = tmp_path / "x"
    out.mkdir()
    (out / "problem.uncertain.json").write_text('{"uncertain": [{"fact": "(upright big_box)"}]}\n')
    assert main(["export", str(recording / "world.yaml"), "--out", str(out)]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["domain.pddl", "problem.pddl"]

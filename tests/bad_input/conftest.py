"""The bad-input battery's one assertion: bad input is refused as a user needs it.

`refuse(argv, *names)` runs the `bridge` command line in-process and asserts what every bad input must give:
a non-zero exit, exactly one line on stderr that is an error (not an internal error, not a traceback) and names
each of `names` (the file, field, option or object), inputs left byte for byte as they were, no temporary file
left behind and none of the `absent` outputs written.
"""
from __future__ import annotations

import hashlib
import shutil
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


def _snapshot(paths) -> dict[Path, str]:
    files = {}
    for p in map(Path, paths):
        for f in ([p] if p.is_file() else sorted(x for x in p.rglob("*") if x.is_file()) if p.is_dir() else []):
            files[f] = hashlib.sha256(f.read_bytes()).hexdigest()
    return files


@pytest.fixture
def refuse(tmp_path, capsys):
    from bridge.cli import main

    def run(argv, *names, inputs=(), absent=(), code=None):
        argv = [str(a) for a in argv]
        before = _snapshot(inputs)
        capsys.readouterr()
        try:
            rc = main(argv)
        except SystemExit as exc:  # argparse refuses an option
            rc = exc.code
        captured = capsys.readouterr()
        lines = [line for line in captured.err.splitlines() if line.strip()]
        assert rc not in (0, None), f"{argv} was accepted:\n{captured.out}{captured.err}"
        if code is not None:
            assert rc == code, captured.err
        assert len(lines) == 1, f"expected one line on stderr, got:\n{captured.err}"
        line = lines[0]
        assert "error" in line and "internal error" not in line and "Traceback" not in line, line
        for name in names:
            assert str(name) in line, f"{name!r} not named in: {line}"
        assert _snapshot(inputs) == before, "an input file was changed"
        assert not [p for p in tmp_path.rglob("*.tmp")], "a temporary file was left behind"
        for path in absent:
            assert not Path(path).exists(), f"{path} was written"
        return line

    return run


@pytest.fixture
def recording(tmp_path) -> Path:
    """A writable copy of the demo's push-over recording."""
    dst = tmp_path / "rec"
    shutil.copytree(REPO / "demo" / "recordings" / "1_push_over", dst)
    return dst

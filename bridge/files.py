"""Reading YAML and writing files, for every layer: one YAML dialect and one way to write outputs safely.

YAML is read with YAML 1.2 booleans (only true/false), so the predicate name `on` stays a string.

Outputs (docs/CONVENTIONS.md, "Outputs"):
- `write_atomic` / `write_set`: files are written to temporary files beside their targets, then renamed over
  them in a row with SIGINT/SIGTERM held back, so a reader and an interrupted run see the old set of files or
  the new one, never half of a file and never a new world state beside an old problem. A new file gets the mode
  a plain open() gives it (0o666 less the umask).
- `replace_folder`: a folder's new content (a recording) is built in a temporary folder beside it and renamed
  into place; an interrupted run leaves the old folder or nothing.
- `claim_outputs`: before the long work, every output is checked to be writable (not a folder where a file is
  expected, parent folders creatable and writable, not an input of the run) and every output folder is locked
  (`fcntl.flock` on `.bridge.lock` holding the run's pid, removed at the end), so a second run writing into the
  same folder at the same time is refused in one line instead of mixing its files with the first run's.
"""
from __future__ import annotations

import errno
import os
import re
import secrets
import shutil
import signal
import stat
import threading
from contextlib import contextmanager, suppress
from pathlib import Path
from typing import Any, Iterable, Iterator, Mapping

try:
    import fcntl
except ImportError:  # not on Windows: outputs are checked but not locked
    fcntl = None  # type: ignore[assignment]

import yaml

from .errors import BridgeError


class DuplicateKeyError(yaml.constructor.ConstructorError):
    """A mapping names one key twice: YAML would keep the last silently (a second object of one name in a world
    state, a type defined twice in one file), so a world other than the one written would be simulated."""


class _Yaml12Loader(yaml.SafeLoader):
    """YAML 1.2 booleans: only true/false. In YAML 1.1 the predicate name `on` would read as True. A key given
    twice in one mapping is an error (`DuplicateKeyError`), not a silent overwrite; merge keys (`<<`) may still
    be overridden."""

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
        if isinstance(node, yaml.MappingNode):
            seen: dict[Any, yaml.Node] = {}
            for key_node, _ in node.value:
                if key_node.tag == "tag:yaml.org,2002:merge":
                    continue
                key = self.construct_object(key_node, deep=True)
                try:
                    first = seen.setdefault(key, key_node)
                except TypeError:  # an unhashable key: the constructor below reports it
                    continue
                if first is not key_node:
                    raise DuplicateKeyError(
                        "while constructing a mapping", node.start_mark,
                        f"duplicate key {key!r} (first on line {first.start_mark.line + 1}); the last would win "
                        "silently", key_node.start_mark)
        return super().construct_mapping(node, deep=deep)


_Yaml12Loader.yaml_implicit_resolvers = {
    key: [(tag, regexp) for tag, regexp in resolvers if tag != "tag:yaml.org,2002:bool"]
    for key, resolvers in yaml.SafeLoader.yaml_implicit_resolvers.items()
}
_Yaml12Loader.add_implicit_resolver(
    "tag:yaml.org,2002:bool", re.compile(r"^(?:true|True|TRUE|false|False|FALSE)$"), list("tTfF"))


def load_yaml_text(text: str) -> Any:
    """The one YAML dialect of bridge (see `_Yaml12Loader`); raises `yaml.YAMLError`."""
    return yaml.load(text, Loader=_Yaml12Loader)


def read_text_file(path: str | os.PathLike[str], what: str, error: type[BridgeError] = BridgeError) -> str:
    """The text of a UTF-8 file (a leading byte-order mark dropped); a missing file, a folder, an OS error or a
    byte that is not UTF-8 is one `error` naming the file (and the byte's offset)."""
    path = Path(path)
    try:
        return path.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise error(f"{what} not found", source=str(path)) from None
    except IsADirectoryError:
        raise error(f"{what} is a folder, not a file", source=str(path)) from None
    except UnicodeDecodeError as exc:
        raise error(f"{what} is not UTF-8 text: byte 0x{exc.object[exc.start]:02x} at offset {exc.start} "
                    f"({exc.reason})", source=str(path)) from None
    except OSError as exc:
        raise error(f"cannot read {what}: {exc.strerror or exc}", source=str(path)) from None


def read_yaml(path: str | os.PathLike[str], what: str, error: type[BridgeError] = BridgeError) -> Any:
    """Parse one YAML file; a missing file, a byte that is not UTF-8, a syntax error or a key given twice is one
    `error` naming the file (and line)."""
    path = Path(path)
    text = read_text_file(path, what, error)
    try:
        return load_yaml_text(text)
    except yaml.YAMLError as exc:
        raise yaml_error(exc, str(path), error) from None


def yaml_error(exc: yaml.YAMLError, source: str, error: type[BridgeError] = BridgeError) -> BridgeError:
    """A PyYAML error as one `error` naming `source`, the line and column, and the problem."""
    mark = getattr(exc, "problem_mark", None)
    where = f"line {mark.line + 1}, column {mark.column + 1}" if mark else None
    problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
    if isinstance(exc, DuplicateKeyError):
        return error(problem, source=source, field=where)
    return error(f"YAML syntax error: {problem}", source=source, field=where)


def dump_yaml(data: Any) -> str:
    """Block-style YAML with short lists inline, keys in the given order."""
    return yaml.safe_dump(data, sort_keys=False, default_flow_style=None, width=120, allow_unicode=True)


# --- writing outputs ----------------------------------------------------------------------------------------------
LOCK_FILE = ".bridge.lock"
TEMP_SUFFIX = ".tmp"
Content = str | bytes | None  # None: remove the file (a stale member of the set)


@contextmanager
def deferred_signals(signums: Iterable[int] = (signal.SIGINT, signal.SIGTERM)) -> Iterator[None]:
    """Hold SIGINT/SIGTERM back while the block runs (renames that belong together), then deliver them.

    Only the main thread can set signal handlers; elsewhere the block runs as it is."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught: list[int] = []
    previous: dict[int, Any] = {}
    try:
        for signum in signums:
            previous[signum] = signal.signal(signum, lambda number, frame: caught.append(number))
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler if handler is not None else signal.SIG_DFL)
        for signum in dict.fromkeys(caught):
            signal.raise_signal(signum)  # now handled as it would have been (KeyboardInterrupt for SIGINT)


def _temp_name(path: Path, tag: str = "") -> Path:
    return path.parent / f".{path.name[:96]}.{secrets.token_hex(4)}{tag}{TEMP_SUFFIX}"


def _create_temp(path: Path) -> tuple[int, Path]:
    """A new temporary file beside `path`, created with mode 0o666 so the umask applies as for a plain open()
    (tempfile.mkstemp would make it 0o600 whatever the umask)."""
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_CLOEXEC", 0)
    while True:
        tmp = _temp_name(path)
        try:
            return os.open(tmp, flags, 0o666), tmp
        except FileExistsError:
            continue


def _blocking_ancestor(path: Path) -> Path | None:
    """The nearest existing ancestor of `path` that is not a folder (so `path` cannot be created), if any."""
    for parent in path.parents:
        if parent.exists():
            return None if parent.is_dir() else parent
    return None


def _reason(err: OSError) -> str:
    reason = err.strerror or str(err)
    if err.errno in (errno.EACCES, errno.EPERM, errno.EROFS):
        reason += " (is the folder read-only?)"
    return reason


def _os_problem(path: Path, err: OSError, what: str) -> str:
    """One clear reason for an OS error on an output `path` (a file or folder: `what`)."""
    blocking = _blocking_ancestor(path)
    if blocking is not None:
        return f"cannot write {what}: {blocking} is a file, not a folder"
    if err.errno == errno.EISDIR:
        return f"is a folder, not a {what}"
    return f"cannot write {what}: {_reason(err)}"


def write_atomic(path: str | os.PathLike[str], text: str | bytes, error: type[BridgeError] = BridgeError) -> None:
    """Write one file through a temporary file in the same folder and `os.replace`; an OS failure is one `error`."""
    write_set({path: text}, error)


def write_set(files: Mapping[str | os.PathLike[str], Content], error: type[BridgeError] = BridgeError) -> None:
    """Publish files that belong together (a world state, its problem, its uncertain facts): all of them are
    written to temporary files first, then renamed over their targets in a row with SIGINT/SIGTERM held back;
    a content of None removes that file (a stale member of an earlier set). An OS failure while renaming puts
    the old files back, so the folder holds the old set or the new one. Any failure is one `error` naming the
    file."""
    items = [(Path(p), content) for p, content in files.items()]
    if len({os.path.abspath(p) for p, _ in items}) != len(items):
        raise error("the same file is given twice as an output", source=str(items[0][0]))
    temps: dict[Path, Path] = {}
    current = items[0][0] if items else Path(".")
    try:
        try:
            for path, content in items:
                current = path
                if path.is_dir():
                    raise IsADirectoryError(errno.EISDIR, os.strerror(errno.EISDIR), str(path))
                if content is None:
                    continue
                path.parent.mkdir(parents=True, exist_ok=True)
                fd, tmp = _create_temp(path)
                temps[path] = tmp
                with os.fdopen(fd, "wb") as handle:
                    handle.write(content.encode("utf-8") if isinstance(content, str) else content)
                    handle.flush()
                    os.fsync(handle.fileno())
            with deferred_signals():
                _publish(items, temps)
        finally:
            for tmp in temps.values():
                with suppress(OSError):
                    os.unlink(tmp)  # the ones not renamed: after a failure or an interrupt while writing
    except _PublishError as err:
        raise error(_os_problem(err.path, err.cause, "file"), source=str(err.path)) from None
    except OSError as err:
        raise error(_os_problem(current, err, "file"), source=str(current)) from None


class _PublishError(Exception):
    def __init__(self, path: Path, cause: OSError):
        super().__init__(str(cause))
        self.path, self.cause = path, cause


def _publish(items: list[tuple[Path, Content]], temps: dict[Path, Path]) -> None:
    """Rename the temporary files over their targets (remove the None ones). On an OS error (or an exception
    raised in here by a test) put back what was there before: kept as hard links while renaming, when there are
    several files."""
    backups: dict[Path, Path] = {}
    existed = {path for path, _ in items if path.exists()}
    done: list[Path] = []
    path = items[0][0] if items else Path(".")
    try:
        if len(items) > 1:
            for path, _ in items:
                if path.is_file():
                    backup = _temp_name(path, ".old")
                    with suppress(OSError):  # no hard links here: that file cannot be put back
                        os.link(path, backup)
                        backups[path] = backup
        for path, content in items:
            if content is None:
                with suppress(FileNotFoundError):
                    os.unlink(path)
            else:
                os.replace(temps[path], path)
                del temps[path]  # renamed: nothing to clean up
            done.append(path)
    except BaseException as err:
        for earlier in reversed(done):
            with suppress(OSError):
                if earlier in backups:
                    os.replace(backups.pop(earlier), earlier)
                elif earlier not in existed:
                    os.unlink(earlier)
        if isinstance(err, OSError):
            raise _PublishError(path, err) from None
        raise
    finally:
        for backup in backups.values():
            with suppress(OSError):
                os.unlink(backup)


# --- a folder written as a whole ----------------------------------------------------------------------------------
def _make_temp_dir(folder: Path) -> Path:
    """A new folder beside `folder`, made with mode 0o777 so the umask applies (tempfile.mkdtemp gives 0o700)."""
    while True:
        tmp = _temp_name(folder)
        try:
            os.mkdir(tmp, 0o777)
            return tmp
        except FileExistsError:
            continue


def _link_or_copy(src: str, dst: str) -> None:
    try:
        os.link(src, dst, follow_symlinks=False)
    except OSError:
        shutil.copy2(src, dst, follow_symlinks=False)


@contextmanager
def replace_folder(folder: str | os.PathLike[str], error: type[BridgeError] = BridgeError) -> Iterator[Path]:
    """Build a folder's new content in a temporary folder beside it (yielded); when the block ends normally the
    files of the old folder that the block did not write are carried over and the new folder is renamed into
    place (SIGINT/SIGTERM held back), then the old one is removed. After a failure or an interrupt the old folder
    is as it was, or there is no folder; no temporary folder is left."""
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise error("is a file, not a folder", source=str(folder))
    try:
        folder.parent.mkdir(parents=True, exist_ok=True)
        tmp = _make_temp_dir(folder)
    except OSError as err:
        raise error(_os_problem(folder, err, "folder"), source=str(folder)) from None
    old: Path | None = None
    try:
        yield tmp
        try:
            if folder.is_dir():
                os.chmod(tmp, stat.S_IMODE(folder.stat().st_mode))
                for entry in folder.iterdir():
                    target = tmp / entry.name
                    if entry.name == LOCK_FILE or target.exists() or target.is_symlink():
                        continue
                    if entry.is_dir() and not entry.is_symlink():
                        shutil.copytree(entry, target, symlinks=True, copy_function=_link_or_copy)
                    else:
                        _link_or_copy(str(entry), str(target))
            with deferred_signals():
                if folder.is_dir():
                    old = _temp_name(folder, ".old")
                    os.rename(folder, old)
                    try:
                        os.rename(tmp, folder)
                    except BaseException:
                        os.rename(old, folder)
                        old = None
                        raise
                else:
                    os.rename(tmp, folder)
                if old is not None:
                    shutil.rmtree(old, ignore_errors=True)
        except OSError as err:
            raise error(_os_problem(folder, err, "folder"), source=str(folder)) from None
    finally:
        shutil.rmtree(tmp, ignore_errors=True)  # gone already when renamed into place


# --- claiming outputs before the long work ------------------------------------------------------------------------
_held: dict[str, int] = {}  # lock files this process holds -> how many claims hold each


def _lock(lock_path: Path, folder: Path, error: type[BridgeError]) -> int | None:
    """An exclusive advisory lock on `lock_path` (created; the holder's pid written in it), or one `error` naming
    `folder` and the holder's pid. None when this process holds it already (a claim inside a claim)."""
    key = os.path.abspath(lock_path)
    if key in _held:
        _held[key] += 1
        return None
    if fcntl is None:
        _held[key] = 1
        return None
    flags = os.O_RDWR | os.O_CREAT | getattr(os, "O_CLOEXEC", 0)
    while True:
        fd = os.open(lock_path, flags, 0o666)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = ""
            with suppress(OSError, ValueError):
                holder = os.read(fd, 32).decode("ascii").strip()
            os.close(fd)
            pid = f" (pid {holder})" if holder.isdigit() else ""
            raise error(f"another bridge run{pid} is writing into this folder; wait for it to end or choose "
                        "another output", source=str(folder)) from None
        except BaseException:
            os.close(fd)
            raise
        try:  # the previous holder may have removed the file between our open and our lock: lock the new one
            same = os.path.samestat(os.fstat(fd), os.stat(lock_path))
        except FileNotFoundError:
            same = False
        if same:
            break
        os.close(fd)
    os.ftruncate(fd, 0)
    os.write(fd, f"{os.getpid()}\n".encode("ascii"))
    _held[key] = 1
    return fd


def _unlock(lock_path: Path, fd: int | None) -> None:
    key = os.path.abspath(lock_path)
    _held[key] -= 1
    if _held[key]:
        return
    del _held[key]
    if fd is None:
        return
    with suppress(OSError):  # removed while still locked, so the next run never finds a stale file
        if os.path.samestat(os.fstat(fd), os.stat(lock_path)):
            os.unlink(lock_path)
    os.close(fd)


def _make_folders(folder: Path, created: list[Path]) -> None:
    """`mkdir -p`, remembering the folders made (to remove them again if the run leaves them empty)."""
    missing = []
    for path in (folder, *folder.parents):
        if path.is_dir():
            break
        missing.append(path)
    for path in reversed(missing):
        os.mkdir(path, 0o777)
        created.append(path)


@contextmanager
def claim_outputs(files: Iterable[str | os.PathLike[str]] = (), folders: Iterable[str | os.PathLike[str]] = (), *,
                  replaced: Iterable[str | os.PathLike[str]] = (), inputs: Iterable[str | os.PathLike[str]] = (),
                  error: type[BridgeError] = BridgeError) -> Iterator[None]:
    """Check every output of a run before its long work, and lock where it writes until the block ends.

    `files` are output files (their folder is made and locked), `folders` output folders (made and locked),
    `replaced` folders written whole by `replace_folder` (locked beside them, as `.NAME.bridge.lock`). An output
    that is a folder where a file is expected (or the reverse), under a file, in a folder that cannot be made or
    written, given twice, one of `inputs`, or in a folder another run holds is one `error` naming the path.
    At the end the locks are removed, and so are the folders made here if the run left them empty."""
    files = [Path(p) for p in files]
    folders = [Path(p) for p in folders]
    replaced = [Path(p) for p in replaced]
    inputs_seen = {os.path.realpath(p) for p in inputs}
    seen: dict[str, Path] = {}
    for path in files + folders + replaced:
        key = os.path.realpath(path)
        if key in seen:
            also = f" (also as {seen[key]})" if str(seen[key]) != str(path) else ""
            raise error(f"is given twice as an output{also}", source=str(path))
        seen[key] = path
        if key in inputs_seen:
            raise error("is an input of this run; write the output elsewhere", source=str(path))
        blocking = _blocking_ancestor(path)
        if blocking is not None:
            raise error(f"cannot write here: {blocking} is a file, not a folder", source=str(path))
    for path in files:
        if path.is_dir():
            raise error("is a folder, not a file; give a file name", source=str(path))
    for path in folders + replaced:
        if path.exists() and not path.is_dir():
            raise error("is a file, not a folder", source=str(path))
    locks = [(folder, folder / LOCK_FILE) for folder in dict.fromkeys(p.parent for p in files)]
    locks += [(folder, folder / LOCK_FILE) for folder in dict.fromkeys(folders)]
    locks += [(folder, folder.parent / f".{folder.name}{LOCK_FILE}") for folder in dict.fromkeys(replaced)]
    created: list[Path] = []
    held: list[tuple[Path, int | None]] = []
    try:
        for folder, lock_path in locks:
            try:
                _make_folders(lock_path.parent, created)
                held.append((lock_path, _lock(lock_path, folder, error)))
            except OSError as err:
                failed = Path(err.filename) if err.filename else lock_path
                if failed == lock_path:  # the folder it writes into: the output's own, or a replaced one's parent
                    raise error(f"cannot write into this folder: {_reason(err)}", source=str(lock_path.parent)) from None
                what = "this folder" if failed == folder else f"the folder {failed}"
                raise error(f"cannot make {what}: {_reason(err)}", source=str(folder)) from None
        yield
    finally:
        for lock_path, fd in reversed(held):
            _unlock(lock_path, fd)
        for path in reversed(created):
            with suppress(OSError):
                path.rmdir()  # only when the run left it empty

"""Reading YAML and writing files, for every layer: one YAML dialect and one way to write a file safely.

YAML is read with YAML 1.2 booleans (only true/false), so the predicate name `on` stays a string. Files are
written to a temporary file beside the target and renamed over it, so a reader sees the old file or the new
one, never half of one (a world state is never left half-written).
"""
from __future__ import annotations

import os
import re
import tempfile
from contextlib import suppress
from pathlib import Path
from typing import Any

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


def write_atomic(path: str | os.PathLike[str], text: str, error: type[BridgeError] = BridgeError) -> None:
    """Write `text` through a temporary file in the same folder and `os.replace`; an OS failure is one `error`."""
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
        try:
            with os.fdopen(fd, "w", encoding="utf-8", newline="") as handle:
                handle.write(text)
                handle.flush()
                os.fsync(handle.fileno())
            os.chmod(tmp, 0o644)
            os.replace(tmp, path)
        except BaseException:
            with suppress(OSError):
                os.unlink(tmp)
            raise
    except OSError as err:
        raise error(f"cannot write file: {err.strerror or err}", source=str(path)) from None

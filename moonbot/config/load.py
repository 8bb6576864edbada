"""Loading and validating configurations.

A config file is YAML (JSON is YAML too) holding a subset of the schema's fields; the rest take
their defaults. Unknown fields, wrong types, out-of-range values and a key given twice in one
mapping raise `ConfigError` with the dotted path of the field, before anything is rendered.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import types
import typing
from importlib import resources
from pathlib import Path
from typing import Any, Literal, get_args, get_origin

import yaml

from moonbot.config.schema import Config


class ConfigError(ValueError):
    """A configuration is malformed; the message starts with the file and the field path."""


def default_config_path() -> Path:
    """The embedded default configuration, shipped inside the package."""
    return Path(str(resources.files("moonbot.config") / "default.yaml"))


def load_config(path: str | Path | None = None, overrides: dict[str, Any] | None = None) -> Config:
    """Read a config file (None = the embedded default), apply dotted-path `overrides` such as
    {"sun.elevation_deg": 5}, and validate. Raises ConfigError naming the file and field."""
    source = Path(path) if path is not None else default_config_path()
    try:
        text = source.read_text(encoding="utf-8")
    except OSError as e:
        raise ConfigError(f"{source}: cannot read config ({e.strerror or e})") from e
    data = parse_yaml(text, str(source))
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise ConfigError(f"{source}: the top level must be a mapping of fields")
    for dotted, value in (overrides or {}).items():
        _set_dotted(data, dotted, value, source)
    try:
        return from_mapping(Config, data)
    except ConfigError as e:
        raise ConfigError(f"{source}: {e}") from None


def parse_overrides(items: list[str] | tuple[str, ...]) -> dict[str, Any]:
    """`FIELD=VALUE` strings (dotted field paths, YAML values) → {field: value}; ConfigError on a
    malformed item."""
    parsed = {}
    for item in items:
        field, sep, value = item.partition("=")
        if not sep or not field.strip():
            raise ConfigError(f"--set: expected FIELD=VALUE, got {item!r}")
        name = field.strip()
        parsed[name] = parse_yaml(value, f"--set {name}", invalid="value is not valid YAML", root=name)
    return parsed


def parse_yaml(text: str, source: str, invalid: str = "not valid YAML/JSON", root: str = "") -> Any:
    """The one YAML document in `text` as Python objects (yaml.safe_load's types), read from
    `source` (a file name, or what the text is, for messages). Raises ConfigError on invalid YAML
    ("SOURCE: INVALID (line N: the parser's complaint)") and on a key given twice in one mapping,
    naming the line and the key's dotted path: PyYAML keeps the last of two `camera:` blocks
    without a word, and so loses every field of the first. `root`: the dotted path of the
    document itself in the config (a --set value's field), for the keys' paths."""
    return _parse(text, source, invalid, root, single=True)


def parse_yaml_documents(text: str, source: str) -> list[Any]:
    """Every document of a multi-document YAML stream (`---` between them), checked as parse_yaml
    checks one."""
    return _parse(text, source, "not valid YAML/JSON", "", single=False)


def _parse(text: str, source: str, invalid: str, root: str, single: bool) -> Any:
    loader = yaml.SafeLoader(text)
    try:
        if single:
            node = loader.get_single_node()
            nodes = [] if node is None else [node]
        else:
            nodes = []
            while loader.check_node():
                nodes.append(loader.get_node())
        documents = []
        for node in nodes:
            _reject_duplicate_keys(node, loader, source, root)
            documents.append(loader.construct_document(node))
        return (documents[0] if documents else None) if single else documents
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        problem = getattr(e, "problem", None) or e
        raise ConfigError(f"{source}: {invalid} ({f'line {mark.line + 1}: ' if mark else ''}{problem})") from None
    finally:
        loader.dispose()


def _reject_duplicate_keys(document: yaml.Node, loader: yaml.SafeLoader, source: str, root: str) -> None:
    """Walks the composed document (before construction, so each key's dotted path is known) and
    raises ConfigError naming every key given twice in one mapping, in line order. Keys compare as
    the values they construct to (`1` and `0x1` are one key, as in the dict they would build);
    merge keys (`<<`) are YAML's way of reusing a mapping, not duplicates. A node shared through
    an alias is walked once."""
    duplicates: list[tuple[int, str, int]] = []  # (line, dotted path, line of the first)
    walked: set[int] = set()
    stack: list[tuple[yaml.Node, str]] = [(document, root)]
    while stack:
        node, path = stack.pop()
        if id(node) in walked:
            continue
        walked.add(id(node))
        if isinstance(node, yaml.SequenceNode):
            stack.extend((item, f"{path}[{i}]") for i, item in enumerate(node.value))
        elif isinstance(node, yaml.MappingNode):
            first_line: dict[Any, int] = {}
            for key_node, value_node in node.value:
                if key_node.tag == "tag:yaml.org,2002:merge":
                    stack.append((value_node, path))
                    continue
                key = loader.construct_object(key_node, deep=True)
                key_path = f"{path}.{key}" if path else str(key)
                line = key_node.start_mark.line + 1
                try:
                    first = first_line.get(key)
                except TypeError:  # an unhashable (sequence or mapping) key: construction rejects it
                    continue
                if first is not None:
                    duplicates.append((line, key_path, first))
                else:
                    first_line[key] = line
                stack.append((value_node, key_path))
    if duplicates:
        raise ConfigError(
            "\n".join(
                f"{source}:{line}: {key_path}: duplicate key (first given at line {first}; "
                "YAML would keep only the last)"
                for line, key_path, first in sorted(duplicates)
            )
        )


def config_hash(config: Any) -> str:
    """SHA-256 of the canonical JSON of a resolved config dataclass (all defaults filled in): the
    whole `Config`, or one of its sections."""
    canonical = json.dumps(dataclasses.asdict(config), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(canonical.encode()).hexdigest()


# Field metadata marking a `dict[str, Any]` field that keeps, as they are, the keys of the mapping
# the dataclass does not declare (a file record's fields that no reader interprets), instead of
# rejecting them as unknown.
KEEP_UNKNOWN = "keep_unknown"


def from_mapping(cls: type, data: Any, path: str = "") -> Any:
    """Build dataclass `cls` from a mapping, recursively, checking names, types and ranges (field
    metadata: `lo`, `lo_open`, `hi`, and `length` for a tuple); ConfigError names the dotted field
    path. A field without a default must be given; a key the dataclass does not declare is an
    error, or kept in its KEEP_UNKNOWN field when it has one. Configs and the file records
    (moonbot.records) are both read through it."""
    if not isinstance(data, dict):
        raise ConfigError(f"{path or 'config'}: must be a mapping, got {type(data).__name__}")
    where = f"{path}." if path else ""
    fields = {f.name: f for f in dataclasses.fields(cls)}
    keeper = next((f.name for f in fields.values() if f.metadata.get(KEEP_UNKNOWN)), None)
    unknown = sorted(set(data) - set(fields) - {keeper})
    if unknown and keeper is None:
        raise ConfigError(f"{where}{unknown[0]}: unknown field (known: {', '.join(fields)})")
    for name, f in fields.items():
        required = f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING
        if required and name not in data and name != keeper:
            raise ConfigError(f"{where}{name}: missing")
    hints = typing.get_type_hints(cls)
    values = {}
    for name, value in data.items():
        if name not in fields or name == keeper:
            continue
        field_path = f"{path}.{name}" if path else name
        values[name] = _convert(hints[name], value, fields[name].metadata, field_path)
    if keeper is not None:
        values[keeper] = {name: data[name] for name in data if name in unknown}
    try:
        return cls(**values)
    except ValueError as e:  # a dataclass's own cross-field checks name the field
        raise ConfigError(f"{path}.{e}" if path else str(e)) from None


def _convert(kind: Any, value: Any, meta: typing.Mapping[str, Any], path: str) -> Any:
    if kind is Any:
        return value
    if kind is type(None):
        if value is not None:
            raise ConfigError(f"{path}: must be null, got {value!r}")
        return None
    if dataclasses.is_dataclass(kind):
        return from_mapping(kind, value, path)
    if kind is dict or get_origin(kind) is dict:
        # A mapping of names to values of one kind (`dict[str, float]`: seconds per stage); a bare
        # `dict` or `dict[str, Any]` holds any JSON object as it is.
        if not isinstance(value, dict):
            raise ConfigError(f"{path}: must be a mapping, got {type(value).__name__}")
        key_kind, item_kind = get_args(kind) or (str, Any)
        if key_kind is not str or not all(isinstance(k, str) for k in value):
            raise ConfigError(f"{path}: must be a mapping with string keys")
        return {k: _convert(item_kind, v, meta, f"{path}.{k}") for k, v in value.items()}
    if get_origin(kind) in (typing.Union, types.UnionType):
        # A value of one of several kinds (`float | Literal["auto"]`): the first member whose
        # kind the value has converts it, ranges included; a value of no member's kind names all.
        members = get_args(kind)
        for member in members:
            if _has_kind(member, value):
                return _convert(member, value, meta, path)
        wanted = " or ".join(_describe(m) for m in members)
        raise ConfigError(f"{path}: must be {wanted}, got {value!r}")
    if get_origin(kind) is Literal:
        choices = get_args(kind)
        if value not in choices:
            raise ConfigError(f"{path}: must be one of {', '.join(map(str, choices))}, got {value!r}")
        return value
    if get_origin(kind) is tuple:
        if not isinstance(value, (list, tuple)):
            raise ConfigError(f"{path}: must be a list, got {type(value).__name__}")
        length = meta.get("length")
        if length is not None and len(value) != length:
            raise ConfigError(f"{path}: must have {length} items, got {len(value)}")
        item_kind = get_args(kind)[0]
        return tuple(_convert(item_kind, v, meta, f"{path}[{i}]") for i, v in enumerate(value))
    if kind is bool:
        if not isinstance(value, bool):
            raise ConfigError(f"{path}: must be true or false, got {value!r}")
        return value
    if kind is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError(f"{path}: must be an integer, got {value!r}")
        return _check_range(value, meta, path)
    if kind is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ConfigError(f"{path}: must be a number, got {value!r}")
        if not math.isfinite(value):
            raise ConfigError(f"{path}: must be finite, got {value!r}")
        return _check_range(float(value), meta, path)
    if kind is str:
        if not isinstance(value, str):
            raise ConfigError(f"{path}: must be a string, got {value!r}")
        return value
    raise TypeError(f"{path}: schema type {kind!r} has no converter")  # a schema bug, not input


def _has_kind(kind: Any, value: Any) -> bool:
    """Whether `value` is of the kind a union member converts (before range checks)."""
    if get_origin(kind) is Literal:
        return value in get_args(kind)
    if dataclasses.is_dataclass(kind) or kind is dict or get_origin(kind) is dict:
        return isinstance(value, dict)
    if get_origin(kind) is tuple:
        return isinstance(value, (list, tuple))
    if kind in (int, float):
        return not isinstance(value, bool) and isinstance(value, (int, float) if kind is float else int)
    return isinstance(value, kind)


def _describe(kind: Any) -> str:
    if get_origin(kind) is Literal:
        return " or ".join(map(str, get_args(kind)))
    if dataclasses.is_dataclass(kind) or kind is dict or get_origin(kind) is dict:
        return "a mapping"
    if get_origin(kind) is tuple:
        return "a list"
    return {float: "a number", int: "an integer", str: "a string", bool: "true or false", type(None): "null"}.get(
        kind, str(kind)
    )


def _check_range(value: float, meta: typing.Mapping[str, Any], path: str) -> Any:
    lo, hi = meta.get("lo"), meta.get("hi")
    if lo is not None:
        if meta.get("lo_open") and not value > lo:
            raise ConfigError(f"{path}: must be > {lo}, got {value}")
        if not value >= lo:
            raise ConfigError(f"{path}: must be >= {lo}, got {value}")
    if hi is not None and not value <= hi:
        raise ConfigError(f"{path}: must be <= {hi}, got {value}")
    return value


def _set_dotted(data: dict, dotted: str, value: Any, source: Path) -> None:
    keys = dotted.split(".")
    node = data
    for key in keys[:-1]:
        child = node.setdefault(key, {})
        if not isinstance(child, dict):
            raise ConfigError(f"{source}: {dotted}: {key} is not a section")
        node = child
    node[keys[-1]] = value

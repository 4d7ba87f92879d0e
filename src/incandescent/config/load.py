"""Scene files (TOML or JSON) and dicts → a validated :class:`~incandescent.config.schema.Scene`.

Errors are one :class:`SceneError` (a ``ValueError``) whose message names the file, the dotted key
path and the problem: unknown keys get a "did you mean", type errors quote the value and the
expected type, TOML/JSON syntax errors give the line and column.

Paths. Relative paths in a file (``volume.path``, ``output.path``, ``output.stats``) resolve
against the file's folder and must stay inside it: ``../..`` out of it is refused, naming the key
(a scene file someone sends cannot write, or read, next to it by accident), and so is an output
reached through a symlink that leads out. An absolute path (or ``~/…``) is the user's explicit
choice and is taken as given. Paths in ``overrides`` (command-line flags) are left as given,
i.e. relative to the working directory. A path holding a NUL byte is refused. What the run then
writes is checked by ``io.atomic.check_output``: an output is never one of the run's inputs (the
volume, the scene file, by any name, even with overwrite), and an existing file is replaced only
with ``--overwrite`` or ``[output] overwrite = true``.
"""

from __future__ import annotations

import difflib
import json
import os
import types
import typing
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ValidationError

from incandescent.config.legacy import LegacyKeyError, upgrade
from incandescent.config.schema import Scene
from incandescent.io.formats import SCENE_SUFFIXES
from incandescent.io.textfiles import parse_json, parse_toml
from incandescent.renderer.integrators import EmissionAbsorption

__all__ = ["SUFFIXES", "SceneError", "load_scene", "merge_overrides", "scene_from_dict"]

SUFFIXES = SCENE_SUFFIXES
#: Keys holding file paths, resolved against the scene file's folder.
PATH_KEYS = (("volume", "path"), ("output", "path"), ("output", "stats"))
#: The path keys a run writes (dotted).
OUTPUT_KEYS = ("output.path", "output.stats")
#: At most this many problems are spelled out in one message.
MAX_REPORTED = 5


class SceneError(ValueError):
    """An invalid scene file, dict or override; the message is meant for the user as is."""


def load_scene(path: str | Path, overrides: Mapping[str, Any] | None = None) -> Scene:
    """Read a ``.toml`` or ``.json`` scene file and apply ``overrides`` over its values.

    ``overrides`` is a nested dict such as ``{"render": {"width": 64}}`` (what CLI flags produce);
    keys whose value is ``None`` are ignored (a flag not given). Raises ``FileNotFoundError``
    for a missing file and :class:`SceneError` for everything else.
    """
    path = Path(path)
    _check_no_nul(str(path), "scene file path", repr(str(path)))
    data = _upgraded(_read(path), str(path))
    _check_path_keys(data, str(path))
    _resolve_paths(data, path.parent, str(path))
    return _validate(_merge(data, overrides), str(path), overrides)


def scene_from_dict(
    data: Mapping[str, Any],
    base_dir: str | Path | None = None,
    overrides: Mapping[str, Any] | None = None,
    source: str = "scene",
) -> Scene:
    """Validate a scene given as a dict (the Python API); relative paths in ``data`` resolve
    against ``base_dir`` (default: left relative to the working directory)."""
    if not isinstance(data, Mapping):
        raise SceneError(f"{source}: a scene is a table of sections; got {type(data).__name__}")
    copy = _upgraded(_plain(data), source)
    _check_path_keys(merge_overrides(copy, overrides), source)
    if base_dir is not None:
        _resolve_paths(copy, Path(base_dir), source)
    return _validate(_merge(copy, overrides), source, overrides)


def _upgraded(data: dict, source: str) -> dict:
    """``data`` with the keys of earlier releases in today's sections (``config.legacy``)."""
    try:
        return upgrade(data, source)
    except LegacyKeyError as error:
        raise SceneError(str(error)) from None


def _merge(data: dict, overrides: Mapping[str, Any] | None) -> dict:
    """:func:`merge_overrides`, except that an override naming another integrator ``type``
    replaces the scene's ``[integrator]`` (whose parameters belong to the other one)."""
    given = _lookup(overrides or {}, ["integrator", "type"])
    table = data.get("integrator")
    if given in (_MISSING, None) or not isinstance(table, dict):
        return merge_overrides(data, overrides)
    if table.get("type", EmissionAbsorption.name) != given:
        data = {k: v for k, v in data.items() if k != "integrator"}
    return merge_overrides(data, overrides)


def merge_overrides(data: Mapping[str, Any], overrides: Mapping[str, Any] | None) -> dict:
    """A copy of ``data`` with ``overrides`` applied key by key (nested dicts merge, ``None`` in
    ``overrides`` means "not given")."""
    merged = _plain(data)
    for key, value in (overrides or {}).items():
        if value is None:
            continue
        if isinstance(value, Mapping) and isinstance(merged.get(key), Mapping):
            merged[key] = merge_overrides(merged[key], value)
        elif isinstance(value, Mapping):
            merged[key] = merge_overrides({}, value)
        else:
            merged[key] = value
    return merged


def _plain(data: Mapping[str, Any]) -> dict:
    return {k: _plain(v) if isinstance(v, Mapping) else v for k, v in data.items()}


# --- reading ------------------------------------------------------------------------------------


def _read(path: Path) -> dict:
    suffix = path.suffix.lower()
    if suffix not in SUFFIXES:
        raise SceneError(
            f"{path}: unsupported scene format {path.suffix!r}; expected .toml or .json"
        )
    from incandescent.io.volumes import check_input_file

    check_input_file(path, "scene file")
    try:
        text = path.read_bytes().decode("utf-8")
    except UnicodeDecodeError as error:
        raise SceneError(f"{path}: not UTF-8 text ({error})") from None
    try:
        data = _parse_toml(text, path) if suffix == ".toml" else _parse_json(text, path)
    except RecursionError:
        raise SceneError(f"{path}: nested too deeply to be a scene (tables in tables)") from None
    if not isinstance(data, dict):
        raise SceneError(f"{path}: a scene is a table of sections; got {type(data).__name__}")
    return data


def _parse_toml(text: str, path: Path) -> dict:
    return parse_toml(text, path, SceneError)


def _parse_json(text: str, path: Path) -> Any:
    return parse_json(text, path, SceneError)


def _check_no_nul(text: str, where: str, shown: str) -> None:
    if "\0" in text:  # the OS cannot take it: one clear line, not "embedded null byte"
        raise SceneError(f"{where}: a path cannot contain a NUL byte (\\x00); got {shown}")


def _check_path_keys(data: Mapping[str, Any], source: str) -> None:
    """Refuse a path key (``PATH_KEYS``, ``emission.line_table``) holding a NUL byte."""
    for section, key in (*PATH_KEYS, ("emission", "line_table")):
        value = _lookup(data, [section, key])
        if isinstance(value, (str, Path)):
            _check_no_nul(str(value), f"{source}: {section}.{key}", repr(str(value)))


def _resolve_paths(data: dict, base_dir: Path, source: str) -> None:
    """Relative path keys → absolute, against ``base_dir``; one that leaves it is refused."""
    for section, key in PATH_KEYS:
        table = data.get(section)
        if isinstance(table, dict) and isinstance(table.get(key), str):
            path = Path(table[key]).expanduser()
            if not path.is_absolute():
                dotted = f"{section}.{key}"
                path = _inside(
                    base_dir.absolute(), path, f"{source}: {dotted}", dotted in OUTPUT_KEYS
                )
            table[key] = str(path)
    lights = data.get("light")
    for index, table in enumerate(lights if isinstance(lights, list) else []):
        if isinstance(table, dict) and isinstance(table.get("map"), str):
            path = Path(table["map"]).expanduser()
            if not path.is_absolute():
                path = _inside(base_dir.absolute(), path, f"{source}: light.{index}.map", False)
            table["map"] = str(path)


def _inside(base: Path, relative: Path, where: str, output: bool) -> Path:
    """``base / relative``, refused when it is not inside ``base`` — by ``..`` or, for an output
    key, through a symlink (an output would land outside the scene's folder)."""
    joined = Path(os.path.normpath(base / relative))
    real_base = os.path.realpath(base)
    escapes = not joined.is_relative_to(os.path.normpath(base))
    if not escapes and output:
        escapes = not Path(os.path.realpath(joined)).is_relative_to(real_base)
    if escapes:
        raise SceneError(
            f"{where}: {str(relative)!r} leaves the scene's folder {base}; a relative path in a "
            "scene file stays inside its folder (give an absolute path to go elsewhere)"
        )
    return joined


# --- errors -------------------------------------------------------------------------------------


def _validate(data: dict, source: str, overrides: Mapping[str, Any] | None) -> Scene:
    try:  # strict JSON-mode validation: no str → number or bool → number coercion
        return Scene.model_validate_json(json.dumps(data, default=_jsonable))
    except ValidationError as error:
        raise SceneError(_message(error, data, source, overrides)) from None


def _jsonable(value: Any) -> Any:
    """JSON for values TOML and Python callers produce beyond JSON's types."""
    if isinstance(value, (tuple, set)):
        return list(value)
    if hasattr(value, "tolist"):  # NumPy scalars and arrays
        return value.tolist()
    return str(value)  # paths, dates


def _message(error: ValidationError, data: dict, source: str, overrides) -> str:
    lines: dict[str, str] = {}  # key path → problem (union members report once)
    for item in error.errors():
        keys = _key_path(item["loc"])
        dotted = ".".join(keys)
        if dotted not in lines:
            problem = _problem(item, keys, data, exact=len(keys) == len(item["loc"]))
            if overrides and _given(_lookup(overrides, keys)):
                problem += " (from an override)"
            lines[dotted] = f"{dotted}: {problem}" if dotted else problem
    shown = list(lines.values())[:MAX_REPORTED]
    more = len(lines) - len(shown)
    if len(shown) == 1:
        return f"{source}: {shown[0]}"
    text = f"{source}: {len(lines)} problems\n" + "\n".join(f"  - {line}" for line in shown)
    return text + (f"\n  ... and {more} more" if more else "")


def _key_path(loc: tuple) -> list[str]:
    """The loc's components that are keys of the scene (drops union tags and list indices)."""
    keys: list[str] = []
    for part in loc:
        if not isinstance(part, str):
            break
        parent = _annotation(keys)
        if keys and not _is_model(parent) and typing.get_origin(parent) is not dict:
            break
        keys.append(part)  # a field, a table key, or an unknown key (extra_forbidden)
    return keys


def _is_model(obj: Any) -> bool:
    return isinstance(obj, type) and issubclass(obj, BaseModel)


def _annotation(keys: list[str]) -> Any:
    """The type the schema declares at ``keys`` (None where it declares nothing)."""
    annotation: Any = Scene
    for key in keys:
        if _is_model(annotation):
            field = annotation.model_fields.get(key)
            annotation = None if field is None else field.annotation
        elif typing.get_origin(annotation) is dict:
            annotation = typing.get_args(annotation)[1]
        else:
            return None
    return annotation


def _fields_at(keys: list[str]) -> list[str]:
    model = _annotation(keys)
    return list(model.model_fields) if _is_model(model) else []


_MISSING = object()


def _lookup(data: Any, keys: list[str]) -> Any:
    for key in keys:
        if not isinstance(data, Mapping) or key not in data:
            return _MISSING
        data = data[key]
    return data


def _given(value: Any) -> bool:
    """Whether an override holds a value (a table of flags not given, all None, holds none)."""
    if isinstance(value, Mapping):
        return any(_given(v) for v in value.values())
    return value is not _MISSING and value is not None


def _problem(item: Mapping[str, Any], keys: list[str], data: dict, exact: bool) -> str:
    kind = item["type"]
    if kind == "extra_forbidden":
        return _unknown_key(keys)
    if kind == "missing" and exact:
        return "required key is missing"
    if kind == "setting":
        return str(item["ctx"]["message"])
    value = _lookup(data, keys)
    value = item.get("input") if value is _MISSING else value
    expected = _describe(_annotation(keys))
    if expected is None:
        return str(item["msg"])
    bound = _BOUNDS.get(kind)
    if bound is not None:  # a constraint such as ge=0: say it, not only the type
        expected = f"{expected} {bound[1]} {item['ctx'][bound[0]]!r}"
    return f"expected {expected}; got {value!r} ({type(value).__name__})"


#: pydantic's bound error types → (its context key, the comparison in words).
_BOUNDS = {
    "greater_than_equal": ("ge", ">="),
    "greater_than": ("gt", ">"),
    "less_than_equal": ("le", "<="),
    "less_than": ("lt", "<"),
}


def _unknown_key(keys: list[str]) -> str:
    key, parent = keys[-1], keys[:-1]
    valid = _fields_at(parent)
    close = difflib.get_close_matches(key, valid, n=1)
    hint = f"did you mean {close[0]!r}?" if close else f"valid keys: {', '.join(valid)}"
    return f"unknown key {key!r}; {hint}"


_NAMES = {int: "an integer", float: "a finite number", bool: "true or false", str: "a string"}


def _describe(annotation: Any) -> str | None:
    """Plain words for a field's type: 'an integer', 'a list of 3 numbers', ..."""
    if annotation in _NAMES:
        return _NAMES[annotation]
    if annotation is Path:
        return "a path (a string)"
    if _is_model(annotation):
        return "a table"
    origin, args = typing.get_origin(annotation), typing.get_args(annotation)
    if origin in (typing.Union, types.UnionType):
        words = [_describe(a) for a in args if a is not type(None)]
        return " or ".join(w for w in words if w) or None
    if origin is tuple and args and all(a is float for a in args):
        return f"a list of {len(args)} finite numbers"
    if origin is dict:
        return "a table of numbers" if args[-1:] == (float,) else "a table"
    return None

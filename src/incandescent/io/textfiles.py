"""TOML and JSON text → Python data, with syntax errors as one line naming the file, the line
and the column (scene files, fire settings files)."""

from __future__ import annotations

import json
import re
import tomllib
from pathlib import Path
from typing import Any


def parse_toml(text: str, path: Path, error: type[ValueError] = ValueError) -> dict:
    """``text`` of the TOML file ``path``; a syntax error raises ``error`` with its position."""
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as problem:
        message = str(problem)
        where = re.search(r"\(at line (\d+), column (\d+)\)", message)
        if where is None:
            raise error(f"{path}: TOML syntax error: {message}") from None
        what = message[: where.start()].strip()
        raise error(
            f"{path}: TOML syntax error at line {where[1]}, column {where[2]}: {what}"
        ) from None


def parse_json(text: str, path: Path, error: type[ValueError] = ValueError) -> Any:
    """``text`` of the JSON file ``path``; a syntax error raises ``error`` with its position."""
    try:
        return json.loads(text)
    except json.JSONDecodeError as problem:
        raise error(
            f"{path}: JSON syntax error at line {problem.lineno}, column {problem.colno}: "
            f"{problem.msg}"
        ) from None

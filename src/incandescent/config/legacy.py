"""Scene keys of earlier releases, read into today's sections (kept for one release).

Before the integrators (issue 26) ``[render]`` carried the transport's and the emission's modes.
They are read as:

* ``render.brightness = "physical" | "paper"`` → ``integrator.type = "emission_absorption" |
  "paper2011"``;
* ``render.spectral_bins`` → ``integrator.spectral_bins``;
* ``render.paper_exponent``, ``paper_gain``, ``paper_min_K`` → ``integrator.exponent``,
  ``gain``, ``min_K``;
* ``render.observer``, ``constants``, ``line_table`` → ``emission.observer``, ``constants``,
  ``line_table``;
* ``render.soot_alpha`` → ``volume.soot_alpha``.

A scene with old keys gives one :class:`FutureWarning` naming each and its new key; an old key
and its new spelling both given is an error.
"""

from __future__ import annotations

import warnings
from typing import Any

#: ``brightness`` values → integrator names.
BRIGHTNESS_INTEGRATORS = {"physical": "emission_absorption", "paper": "paper2011"}
#: old ``[render]`` key → (section, key) it now is.
MOVED = {
    "brightness": ("integrator", "type"),
    "spectral_bins": ("integrator", "spectral_bins"),
    "paper_exponent": ("integrator", "exponent"),
    "paper_gain": ("integrator", "gain"),
    "paper_min_K": ("integrator", "min_K"),
    "observer": ("emission", "observer"),
    "constants": ("emission", "constants"),
    "line_table": ("emission", "line_table"),
    "soot_alpha": ("volume", "soot_alpha"),
}


class LegacyKeyError(ValueError):
    """An old key and its new spelling both given."""


def upgrade(data: dict[str, Any], source: str) -> dict[str, Any]:
    """``data`` with the old ``[render]`` keys moved to their sections (in place; returned)."""
    render = data.get("render")
    if not isinstance(render, dict):
        return data
    moved = []
    for old in [k for k in MOVED if k in render]:
        section, key = MOVED[old]
        value = render.pop(old)
        if old == "brightness":
            value = BRIGHTNESS_INTEGRATORS.get(value, value) if isinstance(value, str) else value
        _put(data, section, key, value, f"{source}: render.{old}")
        moved.append(f"render.{old} is now {section}.{key}")
    if moved:
        warnings.warn(
            f"{source}: {'; '.join(moved)} (read as such; the old keys go in a later release)",
            FutureWarning,
            stacklevel=3,
        )
    return data


def _put(data: dict, section: str, key: str, value: Any, where: str) -> None:
    table = data.setdefault(section, {})
    if not isinstance(table, dict):
        return  # the schema reports a section that is not a table
    if key in table:
        raise LegacyKeyError(f"{where} and {section}.{key} both given; keep {section}.{key}")
    table[key] = value

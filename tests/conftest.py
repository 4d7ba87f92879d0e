"""Shared fixtures: backends parametrised so every Dr.Jit test runs on cpu, and on cuda where a GPU
exists (skipped cleanly elsewhere)."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest
from _backends import backend_param

#: The doc scripts and their helpers (``scripts/docpage.py``) import each other as top-level
#: modules, as ``python scripts/NAME.py`` runs them.
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
#: Generators of test data, run by hand (they need the OS's pyopenvdb), not tests or doctests.
collect_ignore_glob = ["data/*", "blender/blender_session.py"]  # the latter runs inside Blender


@pytest.fixture(params=[backend_param("cpu"), backend_param("cuda")])
def jit_backend(request) -> str:
    """A Dr.Jit backend name: "cpu" always, "cuda" where a GPU is available."""
    return request.param

#!/usr/bin/env bash
# Set up (scripts/setup.sh), lint, and run the whole test suite. CI runs exactly this.
set -euo pipefail
cd "$(dirname "$0")/.."
# Real Blender for the add-on's tests (tests/blender, marker "blender"), unless they are deselected.
case " $* " in *"not blender"*) ;; *) export INCANDESCENT_SETUP_BLENDER=1 ;; esac
bash scripts/setup.sh
.venv/bin/ruff check src tests scripts benchmarks integrations
.venv/bin/mypy src
.venv/bin/python -m pytest -q "$@"

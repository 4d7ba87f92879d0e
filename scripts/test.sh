#!/usr/bin/env bash
# Set up (scripts/setup.sh), lint, and run the whole test suite. CI runs exactly this.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
.venv/bin/ruff check src tests scripts benchmarks
.venv/bin/mypy src
.venv/bin/python -m pytest -q "$@"

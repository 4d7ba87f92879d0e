#!/usr/bin/env bash
# Set up incandescent from scratch: a .venv with the package and its dev tools, and — for the CPU
# backend — a shared libLLVM >= 17 (Debian/Ubuntu: libllvm19; needs root or sudo) when missing,
# and OpenVDB's Python module for the system Python (python3-openvdb) to read .vdb files.
set -euo pipefail
cd "$(dirname "$0")/.."

have_llvm() {
    local f
    for f in /usr/lib/*/libLLVM*.so* /usr/lib/llvm-*/lib/libLLVM*.so* /usr/lib64/libLLVM*.so*; do
        [[ "$(basename "$f")" =~ LLVM-?([0-9]+) ]] && (( BASH_REMATCH[1] >= 17 )) && return 0
    done
    return 1
}

if ! have_llvm; then
    if command -v apt-get >/dev/null; then
        sudo=""; [ "$(id -u)" -eq 0 ] || sudo="sudo"
        echo "setup: installing libllvm19 (Dr.Jit's CPU backend needs libLLVM >= 17)"
        $sudo apt-get update -qq
        DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq libllvm19 >/dev/null
    else
        echo "setup: warning: no libLLVM >= 17 found; the cpu backend will not run" \
             "(macOS: brew install llvm; see README)" >&2
    fi
fi

# OpenVDB's own reader for .vdb files (active tiles, half floats, vectors): its Python module is
# built for the system Python, which runs it in a worker (src/incandescent/io/openvdb.py).
if ! env -u PYTHONPATH /usr/bin/python3 -c "import pyopenvdb" >/dev/null 2>&1; then
    if command -v apt-get >/dev/null; then
        sudo=""; [ "$(id -u)" -eq 0 ] || sudo="sudo"
        echo "setup: installing python3-openvdb (OpenVDB reads .vdb files exactly)"
        $sudo apt-get update -qq
        DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq python3-openvdb >/dev/null
    else
        echo "setup: note: OpenVDB's Python module not found; .vdb files are read with tinyvdb" \
             "(no active tiles); macOS: brew install openvdb (see README)" >&2
    fi
fi

# Blender for the add-on's tests (tests/blender): only when they are asked for
# (INCANDESCENT_SETUP_BLENDER=1, which scripts/test.sh sets unless run with -m "not blender").
if [ "${INCANDESCENT_SETUP_BLENDER:-0}" = 1 ] && ! command -v blender >/dev/null; then
    if command -v apt-get >/dev/null; then
        sudo=""; [ "$(id -u)" -eq 0 ] || sudo="sudo"
        echo "setup: installing blender (the Blender add-on's tests run in real Blender)"
        $sudo apt-get update -qq
        DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends \
            blender >/dev/null
    else
        echo "setup: warning: no apt-get; install Blender >= 3.4 for tests/blender" >&2
    fi
fi

# Chromium and its driver: the viewer's tests (`incandescent view`) run the page in a real
# headless browser through Selenium and the system chromedriver (no browser download).
if ! command -v chromium >/dev/null || ! command -v chromedriver >/dev/null; then
    if command -v apt-get >/dev/null; then
        sudo=""; [ "$(id -u)" -eq 0 ] || sudo="sudo"
        echo "setup: installing chromium and chromium-driver (the viewer's browser tests)"
        $sudo apt-get update -qq
        DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq chromium chromium-driver \
            >/dev/null || echo "setup: note: chromium not installed; the viewer's browser tests" \
            "will be skipped" >&2
    else
        echo "setup: note: no chromium/chromedriver; the viewer's browser tests will be skipped" >&2
    fi
fi

python=${PYTHON:-python3}

# pidng (the camera extra's DNG writer) is published only as source with a C extension: building
# it needs a C compiler and the Python headers (Debian/Ubuntu: gcc, python3-dev).
has_headers() {
    "$python" -c 'import os, sys, sysconfig
sys.exit(not os.path.isfile(os.path.join(sysconfig.get_paths()["include"], "Python.h")))'
}
if ! command -v cc >/dev/null || ! has_headers; then
    if command -v apt-get >/dev/null; then
        sudo=""; [ "$(id -u)" -eq 0 ] || sudo="sudo"
        echo "setup: installing gcc and python3-dev (pidng, the DNG writer, is built from source)"
        $sudo apt-get update -qq
        DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq gcc python3-dev >/dev/null
    else
        echo "setup: warning: no C compiler or Python headers; pidng (DNG output) will not" \
             "build (macOS: xcode-select --install)" >&2
    fi
fi

[ -x .venv/bin/python ] || "$python" -m venv .venv
.venv/bin/python -m pip install -q --upgrade pip
.venv/bin/python -m pip install -q -e ".[dev]"
# An editable install compiles nothing; byte-compile the package once, as a wheel install would,
# so every command starts from .pyc files even where PYTHONDONTWRITEBYTECODE is set (~75 ms).
.venv/bin/python -m compileall -q src/incandescent >/dev/null
echo "setup: done (.venv/bin/incandescent)"

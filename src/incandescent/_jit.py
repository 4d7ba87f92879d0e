"""Loading Dr.Jit and checking that its backends can run here.

Dr.Jit's CPU (LLVM) backend loads a shared libLLVM at run time. libLLVM 15 and 16 abort the process
on ``dr.maximum`` ("Cannot select fmaximum"), so we require libLLVM ≥ 17 and point Dr.Jit at the
newest one found when the user has not chosen one (``DRJIT_LIBLLVM_PATH``).
"""

from __future__ import annotations

import functools
import glob
import importlib
import os
import re

MIN_LLVM = 17
_SEARCH = (
    "/usr/lib/x86_64-linux-gnu/libLLVM*.so*",
    "/usr/lib/aarch64-linux-gnu/libLLVM*.so*",
    "/usr/lib/llvm-*/lib/libLLVM*.so*",
    "/usr/lib64/libLLVM*.so*",
    "/usr/local/lib/libLLVM*.so*",
    "/opt/homebrew/opt/llvm/lib/libLLVM.dylib",
    "/usr/local/opt/llvm/lib/libLLVM.dylib",
)

INSTALL_HINT = (
    "the CPU backend needs a shared libLLVM >= 17: on Debian/Ubuntu `apt-get install libllvm19`, "
    "on macOS `brew install llvm`, on Windows install LLVM from llvm.org and set "
    "DRJIT_LIBLLVM_PATH to its LLVM-C.dll (or use backend='reference' or 'cuda')"
)


class BackendUnavailable(RuntimeError):
    """A requested backend cannot run on this machine; the message says what to install."""


def _llvm_major(path: str) -> int:
    match = re.search(r"LLVM-?(\d+)", os.path.basename(path))
    return int(match.group(1)) if match else 0


def _point_drjit_at_newest_llvm() -> None:
    if os.environ.get("DRJIT_LIBLLVM_PATH"):
        return
    found = [p for pattern in _SEARCH for p in glob.glob(pattern)]
    candidates = sorted((p for p in found if _llvm_major(p) >= MIN_LLVM), key=_llvm_major)
    if candidates:
        os.environ["DRJIT_LIBLLVM_PATH"] = candidates[-1]


@functools.cache
def drjit_module():
    """Import drjit once, after choosing a libLLVM."""
    _point_drjit_at_newest_llvm()
    import drjit

    return drjit


@functools.cache
def llvm_problem() -> str | None:
    """None if the LLVM backend is usable, else one sentence saying why not and what to install."""
    dr = drjit_module()
    if not dr.has_backend(dr.JitBackend.LLVM):
        return f"Dr.Jit found no libLLVM; {INSTALL_HINT}"
    version = tuple(dr.detail.llvm_version())
    if version[0] < MIN_LLVM:
        return f"Dr.Jit loaded libLLVM {'.'.join(map(str, version))}; {INSTALL_HINT}"
    return None


@functools.cache
def cuda_problem() -> str | None:
    """None if the CUDA backend is usable, else why not."""
    dr = drjit_module()
    if not dr.has_backend(dr.JitBackend.CUDA):
        return "no NVIDIA GPU with a CUDA driver was found (Dr.Jit CUDA backend unavailable)"
    return None


def array_module(kind: str):
    """``drjit.llvm`` for kind "cpu", ``drjit.cuda`` for "cuda"; raises BackendUnavailable."""
    problem = llvm_problem() if kind == "cpu" else cuda_problem()
    if problem:
        raise BackendUnavailable(f"backend {kind!r} is unavailable: {problem}")
    drjit_module()
    return importlib.import_module("drjit.llvm" if kind == "cpu" else "drjit.cuda")


def device_name(kind: str) -> str:
    """A human-readable description of the device a backend runs on."""
    dr = drjit_module()
    if kind == "cpu":
        version = ".".join(map(str, dr.detail.llvm_version()))
        return f"CPU, {dr.thread_count()} threads (Dr.Jit {dr.__version__} LLVM {version})"
    return f"CUDA GPU (Dr.Jit {dr.__version__}, CUDA {dr.detail.cuda_version()})"

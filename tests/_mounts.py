"""Private mount namespaces for tests that need a real small or read-only file system."""

from __future__ import annotations

import shutil
import subprocess

import pytest


def skip_without_private_mounts() -> None:
    """Skip the test, saying why, where ``unshare -rm`` cannot give it a mount namespace."""
    if shutil.which("unshare") is None:
        pytest.skip("needs unshare(1) for a private mount namespace")
    probe = subprocess.run(["unshare", "-rm", "true"], capture_output=True)
    if probe.returncode != 0:
        pytest.skip(f"user or mount namespaces unavailable: {probe.stderr.decode().strip()}")

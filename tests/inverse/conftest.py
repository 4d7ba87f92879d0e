"""Fixtures of the inverse-rendering tests."""

from __future__ import annotations

import pytest


@pytest.fixture
def one_thread():
    """Dr.Jit on one thread: its scatter-adds then sum in a fixed order, so the fit is the same
    on every run (on several threads the float32 gradients differ in their last bits, and the
    fit of this small, under-determined case ends anywhere from 19 K to 135 K)."""
    import drjit as dr

    before = dr.thread_count()
    dr.set_thread_count(1)
    yield
    dr.set_thread_count(before)

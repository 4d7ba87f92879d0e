"""Budgets checked before work: memory and ray-march samples, estimated from sizes alone.

Every long or large job is estimated before anything is allocated or marched — an input array
from its file header, a render from the volume's shape, the image size and the step — and
refused with :class:`BudgetError` when the estimate exceeds

* the memory available now (``MemAvailable`` in ``/proc/meminfo``; ``os.sysconf`` elsewhere), or
  ``Limits.max_memory_bytes`` (``--max-memory GiB`` on the command line); and
* ``Limits.max_samples`` trilinear samples (``--max-samples``; default 1e11, about a quarter of
  an hour on two CPU cores at the upper bound, which assumes every ray crosses the whole box).

The message gives the estimate, the limit and the flag that raises it.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

#: Default bound on the estimated samples of one render (see module doc).
DEFAULT_MAX_SAMPLES = 1e11
GIB = 1024**3


class BudgetError(ValueError):
    """Work refused before it starts: its estimate exceeds a limit (the message says which)."""


def available_memory_bytes() -> int:
    """Memory the system can give a new allocation now without swapping, in bytes."""
    try:
        with open("/proc/meminfo", encoding="ascii") as handle:
            for line in handle:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")


def gib(n_bytes: float) -> str:
    """``n_bytes`` for messages: GiB to 0.1, else MiB, KiB or bytes to three significant digits
    (a small limit never reads "0 MiB")."""
    if n_bytes >= GIB:
        return f"{n_bytes / GIB:.1f} GiB"
    for unit, size in (("MiB", 1024**2), ("KiB", 1024)):
        if n_bytes >= size:
            return f"{_significant(n_bytes / size)} {unit}"
    return f"{n_bytes:.0f} bytes"


def _significant(value: float) -> str:
    """``value`` (1 ≤ value < 1024) to three significant digits, without an exponent."""
    return f"{value:.0f}" if value >= 100 else f"{value:.3g}"


@dataclass(frozen=True)
class Limits:
    """Bounds on one job. ``max_memory_bytes`` None: the memory available when checked."""

    max_memory_bytes: float | None = None
    max_samples: float = DEFAULT_MAX_SAMPLES

    def __post_init__(self) -> None:
        for name in ("max_memory_bytes", "max_samples"):
            value = getattr(self, name)
            if value is None and name == "max_memory_bytes":
                continue
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not value > 0:
                raise ValueError(f"limit {name} must be a number > 0; got {value!r}")

    def memory_bytes(self) -> float:
        """The memory limit now: ``max_memory_bytes``, or what the machine has available."""
        return available_memory_bytes() if self.max_memory_bytes is None else self.max_memory_bytes

    def check_memory(self, need_bytes: float, what: str) -> None:
        """Refuse ``what`` when it needs more memory than the limit."""
        limit: float
        if self.max_memory_bytes is None:
            limit, source = available_memory_bytes(), "available on this machine"
        else:
            limit, source = self.max_memory_bytes, "allowed by --max-memory"
        if need_bytes > limit:
            raise BudgetError(
                f"{what} needs about {gib(need_bytes)} of memory, more than the {gib(limit)} "
                f"{source}; make it smaller, or raise the limit with --max-memory GIB "
                "(Limits(max_memory_bytes=...)) if the memory is there"
            )

    def check_samples(self, samples: float, what: str) -> None:
        """Refuse ``what`` when its estimated samples exceed ``max_samples``."""
        if samples > self.max_samples:
            raise BudgetError(
                f"{what} would take up to {samples:.2g} ray-march samples, more than the limit "
                f"of {self.max_samples:.2g}; use a larger step or a smaller image, or raise the "
                "limit with --max-samples N (Limits(max_samples=...))"
            )

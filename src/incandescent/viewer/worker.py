"""One render thread per page, latest request wins: a request that arrives while another renders
replaces the one waiting (a stale view is dropped, never queued), and a preview left alone for
:data:`REFINE_AFTER_S` is rendered again at full size (progressive: coarse while dragging,
refined when still)."""

from __future__ import annotations

import json
import threading
from collections.abc import Callable
from dataclasses import replace
from typing import Any

from incandescent.viewer.session import Request

#: A preview with no newer request after this many seconds is refined.
REFINE_AFTER_S = 0.2


def same_view(a: Request, b: Request) -> bool:
    """Whether ``a`` and ``b`` ask for the same image (frame, overrides, size)."""
    key = lambda r: json.dumps([r.frame, r.overrides, r.preview], sort_keys=True)  # noqa: E731
    return key(a) == key(b)


class LatestWins:
    """Renders with ``work(request)`` on a thread of its own and hands each result (or the
    exception) to ``deliver(request, result)``; :meth:`submit` replaces the waiting request."""

    def __init__(self, work: Callable[[Request], Any], deliver: Callable[[Request, Any], None]):
        self.work, self.deliver = work, deliver
        self.dropped = 0  # requests replaced before they were rendered
        self._pending: Request | None = None
        self._last_final: tuple[Request, Any] | None = None  # the last full-size render
        self._closed = False
        self._wake = threading.Condition()
        self._thread = threading.Thread(target=self._run, name="incandescent-view", daemon=True)
        self._thread.start()

    def submit(self, request: Request) -> None:
        with self._wake:
            self.dropped += self._pending is not None
            self._pending = request
            self._wake.notify()

    def close(self) -> None:
        with self._wake:
            self._closed = True
            self._wake.notify()

    def _next(self) -> Request | None:
        with self._wake:
            while self._pending is None and not self._closed:
                self._wake.wait()
            request, self._pending = self._pending, None
            return None if self._closed else request

    def _refine(self, request: Request) -> None:
        """After a preview: its full-size render unless a newer request comes within
        :data:`REFINE_AFTER_S` (or the request's own ``refine_after_s``)."""
        with self._wake:
            wait_s = REFINE_AFTER_S if request.refine_after_s is None else request.refine_after_s
            self._wake.wait_for(lambda: self._pending is not None or self._closed, wait_s)
            if self._pending is None:
                self._pending = replace(request, preview=False)

    def _run(self) -> None:
        while (request := self._next()) is not None:
            last = self._last_final
            if not request.preview and last is not None and same_view(request, last[0]):
                self.deliver(request, last[1])  # rendered already (a release after a refine)
                continue
            try:
                result = self.work(request)
            except Exception as error:  # every failure goes to the page, as one line
                result = error
            if not request.preview and not isinstance(result, Exception):
                self._last_final = (request, result)
            self.deliver(request, result)
            if request.preview and not isinstance(result, Exception):
                self._refine(request)

"""``incandescent view``: a fire seen interactively in the browser or a notebook — our renderer
behind a small ASGI app (``server``), one latest-wins render thread per page (``worker``), the
views rendered as ``incandescent render`` renders them (``session``)."""

from __future__ import annotations

import html
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from incandescent.viewer.server import LOOPBACK, CommandLine, Server, Viewer
from incandescent.viewer.session import Inputs, Session, open_inputs

__all__ = ["Inputs", "Inline", "Server", "Session", "Viewer", "open_inputs", "serve", "view"]


def serve(given: str, base: dict | None = None, backend: str | None = None, limits=None,
          host: str = LOOPBACK, port: int = 0,
          command_line: CommandLine | None = None) -> Server:  # fmt: skip
    """A server (not yet serving) of INPUT ``given`` with the ``base`` scene overrides."""
    session = Session(open_inputs(given), base, backend, limits)
    return Server(Viewer(session, command_line), host, port)


@dataclass
class Inline:
    """The viewer in a notebook cell: an iframe of the running server's tokenised ``url``
    (Jupyter shows ``_repr_html_``); :meth:`close` stops the server."""

    server: Server
    width: int = 1100
    height: int = 720

    @property
    def url(self) -> str:
        return self.server.url

    def _repr_html_(self) -> str:
        return (f'<iframe src="{html.escape(self.url)}" width="{self.width}" '
                f'height="{self.height}" style="border:0"></iframe>')  # fmt: skip

    def close(self) -> None:
        self.server.stop()


def view(volume_or_path: Any, command_line: CommandLine | None = None, **base: Any) -> Inline:
    """Show a volume (a ``Volume``, saved first to a temporary ``.npz``) or INPUT (a path, as
    ``incandescent view`` takes it) in a notebook; ``base``: scene overrides by section, e.g.
    ``display={"tonemap": "reinhard"}``."""
    from incandescent.volume import Volume

    if isinstance(volume_or_path, Volume):
        volume_or_path = _saved(volume_or_path)
    server = serve(str(volume_or_path), base, command_line=command_line).start()
    return Inline(server)


def _saved(volume) -> Path:
    """``volume`` written to a temporary ``.npz`` (the session reads its inputs from files)."""
    import tempfile

    from incandescent.io.output import save_volume

    folder = Path(tempfile.mkdtemp(prefix="incandescent-view-"))
    return save_volume(volume, folder / "volume.npz")

"""The viewer's web server: a small ASGI app (starlette) under uvicorn, a hand-written page whose
files are served from the package, the image streamed over a websocket.

Safety: it binds 127.0.0.1 unless told otherwise; every request and socket must carry the
random token of the URL (as Jupyter's); no request parameter reaches the file system (the page
sends scene overrides from ``session.VIEW_KEYS`` and a frame index; the page's files are read
once, at start, from the package).
"""

from __future__ import annotations

import asyncio
import base64
import json
import secrets
import socket
import tempfile
import threading
from collections.abc import Callable
from importlib import resources
from pathlib import Path
from typing import Any

from starlette.applications import Starlette
from starlette.requests import Request as HTTPRequest
from starlette.responses import JSONResponse, PlainTextResponse, Response
from starlette.routing import Route, WebSocketRoute
from starlette.websockets import WebSocket, WebSocketDisconnect

from incandescent.viewer.session import Frame, Request, Session, check_view, histogram, probe
from incandescent.viewer.worker import LatestWins

#: The page's files (served from the package, never from a path in a request).
STATIC = {"index.html": "text/html", "viewer.js": "text/javascript", "viewer.css": "text/css"}
#: Websocket close code of a refused socket (RFC 6455: policy violation).
POLICY_VIOLATION = 1008
LOOPBACK = "127.0.0.1"
#: Open sockets get this long to close after Ctrl-C (s; uvicorn waits with asyncio, a float
#: works though its annotation says int): Ctrl-C stops the viewer within a second.
SHUTDOWN_S = 0.3

CommandLine = Callable[[str, dict], str]


def page_files() -> dict[str, bytes]:
    """The page's files, read from the package once."""
    root = resources.files("incandescent.viewer") / "static"
    return {name: (root / name).read_bytes() for name in STATIC}


class TokenGuard:
    """ASGI middleware: an HTTP request or websocket without ``?token=`` equal to ``token``
    (compared in constant time) is refused — 403, or the socket closed before it opens."""

    def __init__(self, app, token: str) -> None:
        self.app, self.token = app, token

    async def __call__(self, scope, receive, send) -> None:
        if scope["type"] not in ("http", "websocket") or self._allowed(scope):
            await self.app(scope, receive, send)
        elif scope["type"] == "http":
            await PlainTextResponse("a token is required", status_code=403)(scope, receive, send)
        else:
            await send({"type": "websocket.close", "code": POLICY_VIOLATION})

    def _allowed(self, scope) -> bool:
        from urllib.parse import parse_qs

        given = parse_qs(scope.get("query_string", b"").decode("latin-1")).get("token", [""])
        return secrets.compare_digest(given[0].encode(), self.token.encode())


class Viewer:
    """The session served: its last full-size frame (what "save" and "copy command" give) and
    the command that reproduces a view (``command_line(source, overrides)``, from the CLI's
    flag table)."""

    def __init__(self, session: Session, command_line: CommandLine | None = None) -> None:
        self.session, self.command_line = session, command_line
        self.last: Frame | None = None
        self._histograms: dict[int, dict] = {}

    def command(self, frame: Frame) -> str | None:
        """``incandescent render …`` of ``frame``'s view; None where no command gives it (a
        scene file whose volume is a sequence: save the scene file instead)."""
        inputs = self.session.inputs
        if self.command_line is None or (inputs.scene_file and inputs.is_sequence):
            return None
        source = inputs.scene_file or inputs.frames[frame.request.frame]
        from incandescent.config import merge_overrides

        return self.command_line(
            str(source), merge_overrides(self.session.base, frame.request.overrides)
        )

    def scene_data(self, frame: Frame) -> dict:
        """``frame``'s scene as a scene file's data (no ``[output]``; the volume's absolute
        path): ``incandescent render`` of it gives the view."""
        data = frame.scene.model_dump(mode="json", exclude_unset=True, exclude={"output"})
        data["volume"]["path"] = str(Path(data["volume"]["path"]).absolute())
        return data

    def message(self, frame: Frame) -> dict:
        """What the page gets of a frame: the PNG, its size, camera, timing, and for a
        full-size one the command and the temperature histogram."""
        camera = frame.camera
        out = {"type": "frame", "seq": frame.request.seq, "frame": frame.request.frame,
               "preview": frame.request.preview, "width": frame.image.width,
               "height": frame.image.height, "seconds": frame.image.metadata.get("seconds"),
               "camera": {"eye": list(camera.eye), "target": list(camera.target),
                          "up": list(camera.up), "fov_deg": camera.fov_deg},
               "png": base64.b64encode(frame.png()).decode("ascii")}  # fmt: skip
        if not frame.request.preview:
            out["command"] = self.command(frame)
            out["histogram"] = self._histogram(frame)
        return out

    def _histogram(self, frame: Frame) -> dict:
        key = id(frame.volume)
        if key not in self._histograms:
            self._histograms = {key: histogram(frame.volume)}
        return self._histograms[key]

    def hello(self) -> dict:
        inputs = self.session.inputs
        return {"type": "hello", "given": inputs.given, "frames": len(inputs.frames),
                "names": [p.name for p in inputs.frames], "base": self.session.base}  # fmt: skip


def create_app(viewer: Viewer, token: str) -> TokenGuard:
    """The ASGI app of ``viewer``, every request checked for ``token``."""
    files = page_files()

    async def page(request: HTTPRequest) -> Response:
        name = request.path_params.get("name", "index.html")
        if name not in files:
            return PlainTextResponse("not found", status_code=404)
        return Response(files[name], media_type=STATIC[name],
                        headers={"Cache-Control": "no-store"})  # fmt: skip

    async def png(request: HTTPRequest) -> Response:
        return await _saved(viewer, ".png")

    async def exr(request: HTTPRequest) -> Response:
        return await _saved(viewer, ".exr")

    async def scene(request: HTTPRequest) -> Response:
        return await _scene_file(viewer)

    async def command(request: HTTPRequest) -> Response:
        return await _command(viewer)

    async def stream(ws: WebSocket) -> None:
        await _stream(viewer, ws)

    routes = [Route("/", page), Route("/static/{name}", page), Route("/image.png", png),
              Route("/image.exr", exr), Route("/scene.json", scene), Route("/command", command),
              WebSocketRoute("/ws", stream)]  # fmt: skip
    return TokenGuard(Starlette(routes=routes), token)


async def _saved(viewer: Viewer, suffix: str) -> Response:
    """The last full-size image as a file (``save_image``: PNG through the display settings,
    EXR linear), downloaded as ``incandescent-view.png|.exr``."""
    frame = viewer.last
    if frame is None:
        return PlainTextResponse("no image yet", status_code=409)
    data = await asyncio.to_thread(_image_bytes, frame, suffix)
    media = "image/png" if suffix == ".png" else "image/x-exr"
    disposition = f'attachment; filename="incandescent-view{suffix}"'
    return Response(data, media_type=media, headers={"Content-Disposition": disposition})


def _image_bytes(frame: Frame, suffix: str) -> bytes:
    from incandescent.output import save_image

    with tempfile.TemporaryDirectory(prefix="incandescent-view-") as folder:
        path = save_image(
            frame.image, Path(folder) / f"view{suffix}", frame.scene.display_settings()
        )
        return path.read_bytes()


async def _scene_file(viewer: Viewer) -> Response:
    if viewer.last is None:
        return PlainTextResponse("no image yet", status_code=409)
    body = json.dumps(viewer.scene_data(viewer.last), indent=2)
    disposition = 'attachment; filename="incandescent-view.json"'
    return Response(body, media_type="application/json",
                    headers={"Content-Disposition": disposition})  # fmt: skip


async def _command(viewer: Viewer) -> Response:
    if viewer.last is None:
        return PlainTextResponse("no image yet", status_code=409)
    return JSONResponse({"command": viewer.command(viewer.last)})


async def _stream(viewer: Viewer, ws: WebSocket) -> None:
    """One page: its view requests to a latest-wins render thread, frames back as they come."""
    await ws.accept()
    loop, outbox = asyncio.get_running_loop(), asyncio.Queue()  # type: ignore[var-annotated]

    def deliver(request: Request, result: Any) -> None:
        loop.call_soon_threadsafe(outbox.put_nowait, (request, result))

    worker = LatestWins(viewer.session.render, deliver)
    sender = asyncio.create_task(_send_frames(viewer, ws, outbox))
    await ws.send_json(viewer.hello())
    try:
        while True:
            await _receive(viewer, ws, worker, await ws.receive_json())
    except (WebSocketDisconnect, RuntimeError):
        pass
    finally:
        worker.close()
        sender.cancel()


async def _receive(viewer: Viewer, ws: WebSocket, worker: LatestWins, message: Any) -> None:
    kind = message.get("type") if isinstance(message, dict) else None
    try:
        if kind == "view":
            worker.submit(_request(message))
        elif kind == "probe":
            await ws.send_json({"type": "probe", **_probe(viewer, message)})
        else:
            raise ValueError(f"unknown message type {kind!r}")
    except (ValueError, TypeError, KeyError) as error:
        await ws.send_json({"type": "error", "message": str(error)})


def _request(message: dict) -> Request:
    frame, seq = message.get("frame", 0), message.get("seq", 0)
    if not (isinstance(frame, int) and isinstance(seq, int)) or isinstance(frame, bool):
        raise ValueError(f"frame and seq are integers; got {frame!r}, {seq!r}")
    overrides = check_view(message.get("overrides", {}))
    refine = message.get("refine_after_s")
    if refine is not None and not (isinstance(refine, (int, float)) and 0 <= refine <= 10):
        raise ValueError(f"refine_after_s is a number of seconds in [0, 10]; got {refine!r}")
    preview = bool(message.get("preview", False))
    return Request(overrides, frame, preview, seq, None if refine is None else float(refine))


def _probe(viewer: Viewer, message: dict) -> dict:
    if viewer.last is None:
        raise ValueError("probe: no image yet")
    column, row = message.get("column"), message.get("row")
    if not (isinstance(column, int) and isinstance(row, int)):
        raise ValueError(f"probe: column and row are integers; got {column!r}, {row!r}")
    return probe(viewer.last, column, row)


async def _send_frames(viewer: Viewer, ws: WebSocket, outbox: asyncio.Queue) -> None:
    while True:
        request, result = await outbox.get()
        if isinstance(result, Exception):
            await ws.send_json({"type": "error", "message": str(result) or type(result).__name__,
                                "seq": request.seq})  # fmt: skip
            continue
        if not request.preview:
            viewer.last = result
        message = await asyncio.to_thread(viewer.message, result)
        await ws.send_json(message | {"seq": request.seq})


def bind(host: str, port: int) -> socket.socket:
    """A listening socket on ``host``:``port`` (0: a free port the system chooses)."""
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    sock = socket.socket(family, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        sock.bind((host, port))
    except OSError as error:
        sock.close()
        raise OSError(
            f"--host {host} --port {port}: cannot listen there ({error.strerror})"
        ) from None
    sock.listen(64)
    return sock


class Server:
    """``viewer`` served on ``host``:``port`` under a fresh token; :attr:`url` is the page's.
    :meth:`run` serves in this thread until Ctrl-C; :meth:`start` in a thread of its own
    (notebooks, tests) until :meth:`stop`."""

    def __init__(self, viewer: Viewer, host: str = LOOPBACK, port: int = 0) -> None:
        import uvicorn

        self.viewer, self.token = viewer, secrets.token_urlsafe(32)
        self.socket = bind(host, port)
        self.host, self.port = host, self.socket.getsockname()[1]
        config = uvicorn.Config(create_app(viewer, self.token), log_level="warning",
                                lifespan="off", ws="websockets-sansio",
                                timeout_graceful_shutdown=SHUTDOWN_S)  # type: ignore[arg-type]  # fmt: skip
        self.uvicorn = uvicorn.Server(config)
        self._thread: threading.Thread | None = None

    @property
    def url(self) -> str:
        shown = f"[{self.host}]" if ":" in self.host else self.host
        return f"http://{shown}:{self.port}/?token={self.token}"

    def run(self) -> None:
        self.uvicorn.run(sockets=[self.socket])

    def start(self) -> Server:
        self._thread = threading.Thread(target=self.run, name="incandescent-view-server",
                                        daemon=True)  # fmt: skip
        self._thread.start()
        return self

    def stop(self) -> None:
        self.uvicorn.should_exit = True
        if self._thread is not None:
            self._thread.join(timeout=5)

"""The viewer's server without a browser: the token on every request and socket, nothing a
request names reaches the file system, saved scene files and commands reproduce the view bit
for bit, the notebook's inline viewer, the command line (warning, Ctrl-C), and the render
thread's latest-wins queue."""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
import signal
import subprocess
import sys
import threading
import urllib.error
import urllib.request
from pathlib import Path

import numpy as np
import pytest
from _viewer_fixtures import blob, decode_png, run_render, serve
from typer.testing import CliRunner

from incandescent.cli import app
from incandescent.io.images import read_exr
from incandescent.viewer.session import Request
from incandescent.viewer.worker import LatestWins

websockets = pytest.importorskip("websockets", reason="the viewer extra is not installed")


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("viewer_server")
    blob(folder / "blob.npz")
    blob(folder / "secret.npz", 3000.0)  # outside the inputs: never to be read
    return folder


@pytest.fixture(scope="module")
def server(folder):
    served = serve(folder / "blob.npz")
    yield served
    served.stop()


def get(url: str) -> tuple[int, bytes]:
    try:
        with urllib.request.urlopen(url, timeout=60) as answer:
            return answer.status, answer.read()
    except urllib.error.HTTPError as error:
        return error.code, error.read()


def base_url(server) -> str:
    return f"http://127.0.0.1:{server.port}"


def exchange(server, messages: list[dict], token: str | None = None) -> list[dict]:
    """Send ``messages`` over the page's socket; the answers: a frame (or error) per view, an
    answer per probe or refused message, in order."""

    async def talk() -> list[dict]:
        url = f"ws://127.0.0.1:{server.port}/ws?token={server.token if token is None else token}"
        async with websockets.connect(url, max_size=2**26) as ws:
            answers = [json.loads(await ws.recv())]  # hello
            for message in messages:
                await ws.send(json.dumps(message))
                answers.append(json.loads(await asyncio.wait_for(ws.recv(), 120)))
            return answers

    return asyncio.run(talk())


def view(overrides: dict | None = None, frame: int = 0, seq: int = 1) -> dict:
    return {"type": "view", "overrides": overrides or {}, "frame": frame, "seq": seq}


def test_the_server_listens_on_loopback_only_by_default(server):
    assert server.host == "127.0.0.1" and server.socket.getsockname()[0] == "127.0.0.1"
    assert len(server.token) >= 40  # secrets.token_urlsafe(32)


@pytest.mark.parametrize("path", ["/", "/static/viewer.js", "/image.png", "/image.exr",
                                  "/scene.json", "/command"])  # fmt: skip
def test_every_request_without_the_token_is_refused(server, path):
    assert get(base_url(server) + path)[0] == 403
    assert get(base_url(server) + path + "?token=" + server.token[:-1])[0] == 403


def test_a_socket_without_the_token_is_refused(server):
    with pytest.raises(websockets.exceptions.InvalidStatus):
        exchange(server, [], token="")
    with pytest.raises(websockets.exceptions.InvalidStatus):
        exchange(server, [], token="guess")


def test_no_request_parameter_reaches_the_file_system(server, folder):
    """Every path a request may name — a volume, an output, a line table, a sky map, a page
    file — is refused, and the file is never opened (an audit hook records every open)."""
    secret = folder / "secret.npz"
    opened: list[str] = []
    recording = threading.Event()

    def hook(event: str, args: tuple) -> None:
        if recording.is_set() and event == "open" and isinstance(args[0], (str, bytes, Path)):
            opened.append(os.fsdecode(args[0]))

    sys.addaudithook(hook)
    recording.set()
    try:
        answers = exchange(server, [
            view({"volume": {"path": str(secret)}}),
            view({"output": {"path": str(folder / "out.png")}}),
            view({"emission": {"line_table": str(secret)}}),
            view({"light": [{"type": "environment", "map": str(secret)}]}),
            view({"volume": {"grids": {"temperature": "../secret"}}}),
            view(frame=3), view(frame=-1), {"type": "view", "frame": str(secret)},
            {"type": "open", "path": str(secret)},
        ])  # fmt: skip
        names = ("..%2Fsecret.npz", str(secret).replace("/", "%2F"), "secret.npz")
        pages = [get(f"{base_url(server)}/static/{n}?token={server.token}")[0] for n in names]
        pages.append(get(f"{base_url(server)}/..%2F..%2Fsecret.npz?token={server.token}")[0])
    finally:
        recording.clear()
    assert [a["type"] for a in answers[1:]] == ["error"] * 9
    assert "volume.path" in answers[1]["message"] and "output.path" in answers[2]["message"]
    assert "frame 3 is not one of 0..0" in answers[6]["message"]
    assert pages == [404, 404, 404, 404]
    assert not [p for p in opened if "secret" in p], opened


def test_a_saved_scene_file_and_the_command_reproduce_a_changed_view(server, tmp_path):
    """Several controls at once (exposure, tone map, species, absorption, auto exposure off, a
    remap): the command and the saved scene file both render the page's pixels."""
    overrides = {
        "camera": {"eye": [0.3, 0.9, 2.1], "target": [0.01, -0.02, 0.0], "fov_deg": 35.5},
        "display": {"exposure_ev": -0.7, "tonemap": "reinhard", "auto_exposure": False},
        "volume": {"temperature": {"offset": 100.0, "scale": 1.1, "cutoff_K": 950.0},
                   "species": {"Na": 0.01},
                   "absorption": 1.5},
    }  # fmt: skip
    (frame,) = exchange(server, [view(overrides)])[1:]
    assert frame["type"] == "frame", frame
    shown = decode_png(frame["png"])
    assert shown.max() > 0
    copied = decode_png(run_render(frame["command"], tmp_path / "command.png").read_bytes())
    np.testing.assert_array_equal(copied, shown)
    status, body = get(f"{base_url(server)}/scene.json?token={server.token}")
    assert status == 200
    scene_file = tmp_path / "view.json"
    scene_file.write_bytes(body)
    result = CliRunner().invoke(app, ["render", str(scene_file), "-o", str(tmp_path / "s.png"),
                                      "--backend", "cpu"])  # fmt: skip
    assert result.exit_code == 0, result.output
    np.testing.assert_array_equal(decode_png((tmp_path / "s.png").read_bytes()), shown)
    status, png = get(f"{base_url(server)}/image.png?token={server.token}")
    assert status == 200
    np.testing.assert_array_equal(decode_png(png), shown)
    status, exr = get(f"{base_url(server)}/image.exr?token={server.token}")
    (tmp_path / "view.exr").write_bytes(exr)
    rgb, meta, _ = read_exr(tmp_path / "view.exr")
    reference, _, _ = read_exr(run_render(frame["command"], tmp_path / "command.exr"))
    assert status == 200 and meta["colour_space"] == "srgb"
    np.testing.assert_array_equal(rgb, reference)  # the linear image, unclipped


def test_a_sun_and_scattering_render_as_the_command_says(server, tmp_path):
    overrides = {"volume": {"albedo": 0.5, "phase_g": 0.3}, "integrator": {"spp": 2},
                 "light": [{"type": "directional", "direction": [0.0, 1.0, 0.3],
                            "illuminance_lux": 50000.0}]}  # fmt: skip
    (frame,) = exchange(server, [view(overrides)])[1:]
    assert frame["type"] == "frame", frame
    assert "--sun 0.0,1.0,0.3,50000.0" in frame["command"] and "--albedo 0.5" in frame["command"]
    copied = decode_png(run_render(frame["command"], tmp_path / "sun.png").read_bytes())
    np.testing.assert_array_equal(copied, decode_png(frame["png"]))


def test_the_probe_finds_the_hottest_voxel_on_the_central_ray(server, folder):
    """The centre pixel of an odd-sized image looks along the camera's axis through the box
    centre, where the blob's 8 hottest voxels meet: the probe reports their temperature."""
    from _viewer_fixtures import HEIGHT, WIDTH

    answers = exchange(server, [view(), {"type": "probe", "column": WIDTH // 2,
                                         "row": HEIGHT // 2}])  # fmt: skip
    with np.load(folder / "blob.npz") as grids:
        hottest = float(grids["temperature"].max())
    assert answers[2]["hottest_K"] == pytest.approx(hottest, rel=1e-6)
    assert answers[2]["luminance_cd_m2"] > 0 and answers[2]["transmittance"] < 1


def test_the_notebook_viewer_is_an_iframe_of_the_answering_server(folder):
    import incandescent
    from incandescent.volume import Volume

    with np.load(folder / "blob.npz") as grids:
        volume = Volume.from_arrays(grids["temperature"], voxel_size_m=0.01)
    inline = incandescent.view(volume, render={"width": 40, "height": 30})
    try:
        html = inline._repr_html_()
        assert (
            "<iframe" in html
            and "token=" in inline.url
            and inline.url.startswith("http://127.0.0.1:")
        )
        status, page = get(inline.url)
        assert status == 200 and b"incandescent view" in page
        assert get(inline.url.split("?")[0])[0] == 403
    finally:
        inline.close()


def test_view_refuses_a_missing_input_in_one_line(tmp_path):
    result = CliRunner().invoke(app, ["view", str(tmp_path / "none.npz"), "--no-browser"])
    assert result.exit_code == 2
    assert "none.npz: no such volume file" in result.output


def test_the_command_warns_on_an_open_host_and_stops_on_ctrl_c(folder):
    process = subprocess.Popen(
        [sys.executable, "-m", "incandescent.cli", "view", str(folder / "blob.npz"),
         "--no-browser", "--host", "0.0.0.0", "--backend", "cpu", "--width", "32",
         "--height", "24"],
        stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        lines = [process.stderr.readline() for _ in range(2)]  # type: ignore[union-attr]
        assert "warning: --host 0.0.0.0: other machines can reach the viewer" in lines[0]
        url = lines[1].split("incandescent view: ", 1)[1].strip()
        local = url.replace("0.0.0.0", "127.0.0.1")
        assert get(local)[0] == 200 and get(local.split("?")[0])[0] == 403
        _interrupt_while_rendering(local, process)
        assert process.wait(timeout=10) == 130
        assert "stopped: Ctrl-C" in process.stderr.read()  # type: ignore[union-attr]
    finally:
        process.kill()
        process.wait()


def _interrupt_while_rendering(url: str, process: subprocess.Popen) -> None:
    """Ctrl-C to ``process`` while its page's socket is open and a 1024² view renders (a Dr.Jit
    thread in flight must not abort the exit)."""

    async def talk() -> None:
        socket_url = url.replace("http://", "ws://").replace("/?", "/ws?")
        async with websockets.connect(socket_url, max_size=2**26) as ws:
            await ws.recv()
            big = {"render": {"width": 1024, "height": 1024}}
            await ws.send(json.dumps(view(big)))
            await asyncio.sleep(0.05)
            process.send_signal(signal.SIGINT)

    with contextlib.suppress(websockets.exceptions.ConnectionClosed):
        asyncio.run(talk())


def test_a_stale_request_is_dropped_not_queued():
    """While one view renders, three more arrive: only the last is rendered next."""
    started, release = threading.Event(), threading.Event()
    rendered, delivered = [], threading.Semaphore(0)

    def work(request: Request) -> int:
        rendered.append(request.seq)
        started.set()
        release.wait(30)
        return request.seq

    worker = LatestWins(work, lambda request, result: delivered.release())
    try:
        worker.submit(Request({"view": 1}, seq=1))
        assert started.wait(30)
        for seq in (2, 3, 4):
            worker.submit(Request({"view": seq}, seq=seq))
        release.set()
        assert delivered.acquire(timeout=30) and delivered.acquire(timeout=30)
        assert rendered == [1, 4] and worker.dropped == 2
    finally:
        worker.close()


@pytest.mark.parametrize("refine_after_s", [None, 0.0])  # the default wait; the first view's
def test_a_preview_left_alone_is_refined(refine_after_s):
    rendered, done = [], threading.Semaphore(0)
    worker = LatestWins(lambda r: rendered.append((r.seq, r.preview)),
                        lambda request, result: done.release())  # fmt: skip
    try:
        worker.submit(Request({}, preview=True, seq=7, refine_after_s=refine_after_s))
        assert done.acquire(timeout=30) and done.acquire(timeout=30)
        assert rendered == [(7, True), (7, False)]
    finally:
        worker.close()


def test_inputs_are_what_render_and_animate_take(tmp_path):
    """A volume file, a #### sequence, a glob, a scene file over a sequence, a simulation's
    folder; each frame's scene names that frame's file."""
    from incandescent.viewer.session import Session, open_inputs

    frames = [blob(tmp_path / f"fire_{i:04d}.npz", 1500.0 + 100 * i) for i in range(3)]
    (tmp_path / "scene.toml").write_text('[volume]\npath = "fire_####.npz"\n')
    assert open_inputs(str(frames[0])).frames == (frames[0],)
    for given in (str(tmp_path / "fire_####.npz"), str(tmp_path / "fire_*.npz"), str(tmp_path)):
        inputs = open_inputs(given)
        assert inputs.frames == tuple(frames) and inputs.is_sequence, given
    inputs = open_inputs(str(tmp_path / "scene.toml"))
    assert inputs.scene_file == tmp_path / "scene.toml" and len(inputs.frames) == 3
    session = Session(inputs, backend="cpu")
    assert session.scene(2, {}).volume.path == frames[2]
    with pytest.raises(ValueError, match="frame 3 is not one of 0..2"):
        session.scene(3, {})
    with pytest.raises(FileNotFoundError, match="without fire_####.npz/.vdb frames"):
        open_inputs(str((tmp_path / "empty").mkdir() or tmp_path / "empty"))

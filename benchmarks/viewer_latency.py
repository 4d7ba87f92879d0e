"""Latency of ``incandescent view`` (issue 31): the first image after the server is up, and
frames per second while orbiting, over the page's own websocket (closed loop: a view is sent
when the last frame has arrived — render, PNG encoding, base64 and transfer included).

Volumes: the plume demo at 128³ and 256³ (``api.demo_volume``), saved as .npz. Sizes: the
preview of a 512² view (256²) and the 512² view itself. "first image" runs in a fresh process
(imports, reading the file and Dr.Jit's first kernels included; its kernel cache on disk may be
warm from earlier runs, as it is for a user's second launch).

    python benchmarks/viewer_latency.py                 # a table
    python benchmarks/viewer_latency.py --json          # the figures as JSON
    python benchmarks/viewer_latency.py --sizes 128 --frames 20

Targets (the issue's): first image <= 1.5 s after the server is up; >= 10 preview frames/s at
128³, on 2 cores.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import math
import subprocess
import sys
import tempfile
import time
from pathlib import Path

#: The view's size (pixels per side); its preview is half of it per side.
VIEW_PX = 512


def _server(path: Path, backend: str):
    from incandescent import viewer
    from incandescent.cli.flags import command_line

    base = {"render": {"width": VIEW_PX, "height": VIEW_PX}}
    return viewer.serve(str(path), base, backend, command_line=command_line).start()


async def _frames(server, views: list[dict]) -> list[float]:
    """Seconds from sending each view to its frame (after the first, unmeasured, frame)."""
    import websockets

    url = f"ws://127.0.0.1:{server.port}/ws?token={server.token}"
    seconds = []
    async with websockets.connect(url, max_size=2**27) as ws:
        await ws.recv()  # hello
        for seq, message in enumerate(views):
            start = time.perf_counter()
            await ws.send(json.dumps(message | {"type": "view", "seq": seq}))
            while True:
                answer = json.loads(await ws.recv())
                if answer.get("seq") == seq:
                    break
            if answer["type"] == "error":
                raise RuntimeError(answer["message"])
            seconds.append(time.perf_counter() - start)
    return seconds[1:]


def orbit_views(camera: dict, frames: int, preview: bool) -> list[dict]:
    """``frames`` + 1 views turning ``camera`` about the vertical through its target, 4° apart
    (the first a warm-up)."""
    eye, target = camera["eye"], camera["target"]
    dx, dz = eye[0] - target[0], eye[2] - target[2]
    radius, start = math.hypot(dx, dz), math.atan2(dx, dz)
    views = []
    for k in range(frames + 1):
        angle = start + math.radians(4.0 * k)
        moved = [target[0] + radius * math.sin(angle), eye[1], target[2] + radius * math.cos(angle)]
        overrides = {"camera": {"eye": moved, "target": list(target)}}
        views.append({"overrides": overrides, "preview": preview})
    return views


def orbit_rate(path: Path, backend: str, frames: int) -> dict:
    """Frames per second while orbiting ``path``: previews (256²) and full views (512²)."""
    server = _server(path, backend)
    try:
        first = asyncio.run(_first_camera(server))
        out = {}
        for name, preview in (("preview", True), ("full", False)):
            seconds = asyncio.run(_frames(server, orbit_views(first, frames, preview)))
            out[name] = {"frames_per_s": len(seconds) / sum(seconds),
                         "median_ms": 1e3 * sorted(seconds)[len(seconds) // 2]}  # fmt: skip
        return out
    finally:
        server.stop()


async def _first_camera(server, times: dict | None = None) -> dict:
    """The first view's camera, as the page asks for it: a preview refined at once; ``times``
    gets the seconds until each arrived."""
    import websockets

    url = f"ws://127.0.0.1:{server.port}/ws?token={server.token}"
    start = time.perf_counter()
    async with websockets.connect(url, max_size=2**27) as ws:
        await ws.recv()
        message = {"type": "view", "overrides": {}, "seq": 0, "preview": True, "refine_after_s": 0}
        await ws.send(json.dumps(message))
        while True:
            answer = json.loads(await ws.recv())
            key = "first_preview_s" if answer.get("preview") else "first_image_s"
            (times if times is not None else {}).setdefault(key, time.perf_counter() - start)
            if not answer.get("preview"):
                return answer["camera"]


def first_image(path: Path, backend: str) -> dict:
    """In a fresh process: seconds from the start of the process to the server being up, and
    from then to the first preview and the first full-size frame (the page's first view: a
    preview refined at once)."""
    code = (
        "import sys, time, json, asyncio; t0 = time.perf_counter(); "
        "sys.path.insert(0, sys.argv[3]); import viewer_latency as b; "
        "from pathlib import Path; s = b._server(Path(sys.argv[1]), sys.argv[2]); "
        "up = time.perf_counter(); t = {'server_up_s': up - t0}; "
        "asyncio.run(b._first_camera(s, t)); print(json.dumps(t))"
    )
    here = str(Path(__file__).resolve().parent)
    run = subprocess.run([sys.executable, "-c", code, str(path), backend, here],
                         capture_output=True, text=True, check=True)  # fmt: skip
    return json.loads(run.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="128,256", help="grid sides of the plume demo")
    parser.add_argument("--frames", type=int, default=30, help="timed frames per case")
    parser.add_argument("--backend", default="cpu")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    from incandescent import api

    report: dict = {"view_px": VIEW_PX, "preview_px": VIEW_PX // 2, "cases": {}}
    with tempfile.TemporaryDirectory(prefix="viewer-latency-") as folder:
        for side in (int(s) for s in args.sizes.split(",")):
            path = api.save_volume(api.demo_volume("plume", side), Path(folder) / f"p{side}.npz")
            case = {"first": first_image(path, args.backend)}
            case |= orbit_rate(path, args.backend, args.frames)
            report["cases"][f"{side}^3"] = case
    if args.json:
        print(json.dumps(report, indent=2))
    else:
        _table(report)
    return report


def _table(report: dict) -> None:
    print(f"view {report['view_px']}², preview {report['preview_px']}²")
    print("volume | server up (s) | first preview (s) | first image (s) | preview frames/s | "
          "512² frames/s")  # fmt: skip
    for name, case in report["cases"].items():
        first, preview, full = case["first"], case["preview"], case["full"]
        print(f"{name} | {first['server_up_s']:.2f} | {first['first_preview_s']:.2f} | "
              f"{first['first_image_s']:.2f} | "
              f"{preview['frames_per_s']:.1f} | {full['frames_per_s']:.1f}")  # fmt: skip


if __name__ == "__main__":
    main()

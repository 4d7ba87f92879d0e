"""Sequences read ahead: frame n + 1 is read and prepared on a helper thread while frame n
renders (``animation._ahead``) — in order, one ahead, errors at their turn, never waited for."""

from __future__ import annotations

import threading
import time

import pytest

from incandescent import animation


def _wait_for(condition, seconds: float = 10.0) -> None:
    deadline = time.monotonic() + seconds
    while not condition() and time.monotonic() < deadline:
        time.sleep(0.001)


def test_the_next_item_is_made_while_this_one_is_used_and_no_further():
    made: list[int] = []

    def items():
        for i in range(4):
            made.append(i)
            yield i

    seen = []
    for item in animation._ahead(items()):
        ahead = min(item + 2, 4)
        _wait_for(lambda a=ahead: len(made) >= a)
        assert made == list(range(ahead))  # this one and the next, never two ahead
        seen.append(item)
    assert seen == [0, 1, 2, 3]


def test_an_error_is_raised_at_its_items_turn():
    def items():
        yield 0
        yield 1
        raise ValueError("frame 2: unreadable")

    stream = animation._ahead(items())
    assert [next(stream), next(stream)] == [0, 1]
    with pytest.raises(ValueError, match="frame 2: unreadable"):
        next(stream)


def test_leaving_early_does_not_wait_for_a_read_in_progress():
    release, started = threading.Event(), threading.Event()

    def items():
        yield 0
        started.set()
        release.wait(30)  # a slow read (a big file)
        yield 1

    stream = animation._ahead(items())
    assert next(stream) == 0
    assert started.wait(10)
    stream.close()  # what Ctrl-C or a failed frame does to the loop
    helpers = [t for t in threading.enumerate() if t.name == "incandescent-read-ahead"]
    assert helpers and all(t.daemon and t.is_alive() for t in helpers)  # closed mid-read
    release.set()


def test_render_video_renders_volumes_the_read_ahead_prepared(tmp_path, monkeypatch):
    """render_video streams (volume, camera) pairs; the helper prepares the volume inside (its
    leaf macrocells, hottest voxel, κ test) before the frame's render is called."""
    from incandescent import scenes
    from incandescent.camera import default_camera
    from incandescent.imaging import DisplaySettings
    from incandescent.renderer import RenderSettings
    from incandescent.volume.sparse import LEAF

    volumes = [scenes.soot_plume(12) for _ in range(3)]
    seen: list[tuple[bool, str]] = []
    real_render = animation.render.render  # the module animation/render.py

    def spy(volume, camera, *args, **kwargs):
        # the hottest voxel comes with the volume (MediumSummary); the κ scan and the leaf
        # macrocells are what the helper computed
        prepared = {("macrocells", LEAF, "absorption"), "two_valued_kappa"}
        known = volume.medium is not None and volume.medium.max_temperature_K is not None
        done = known and prepared <= volume._cache.keys()
        seen.append((done, threading.current_thread().name))
        return real_render(volume, camera, *args, **kwargs)

    monkeypatch.setattr(animation.render, "render", spy)
    camera = default_camera(volumes[0].bounds_m)
    settings, display = RenderSettings(width=8, height=8), DisplaySettings(exposure_ev=0.0)
    animation.render_video(
        volumes.__getitem__, 3, tmp_path / "frames", camera, settings, display, progress=False
    )
    assert seen == [(True, "MainThread")] * 3


_SECOND_FRAME_FAULTS = """
import resource, sys
import numpy as np
from incandescent.animation import keep_frame_memory

kept = keep_frame_memory() if sys.argv[1] == "keep" else None
a = np.ones(48 << 18, np.float32)  # one frame's 48 MB array, freed
del a
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
b = np.ones(48 << 18, np.float32)  # the next frame's
print(kept, resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)
"""


@pytest.mark.parametrize("mode", ["default", "keep"])
def test_a_kept_frame_buffer_is_reused_without_page_faults(mode):
    """keep_frame_memory (the CLI's animate calls it): the next frame's array reuses the pages the
    last one freed — no page faults — where by default glibc returned them and they fault in
    again. In a subprocess: it changes the process's allocator."""
    import subprocess
    import sys

    done = subprocess.run(
        [sys.executable, "-c", _SECOND_FRAME_FAULTS, mode],
        capture_output=True, text=True, timeout=120, check=True,
    )  # fmt: skip
    kept, faults = done.stdout.split()
    if mode == "default":
        assert int(faults) > 0
    elif kept != "True":
        pytest.skip("not glibc: keep_frame_memory is a no-op here")
    else:
        assert int(faults) == 0

"""Issue 25, resume: a frame's manifest entry is written before the frame (the frame it
replaces removed first), so a run killed at any point — in-process or while workers of
``animate --workers`` commit frames the client never hears of — resumes without --overwrite."""

from __future__ import annotations

import numpy as np
import pytest

from incandescent import animation
from incandescent.animation import frame_path, render_sequence, sequence


class _Volume:
    def __init__(self, value: float) -> None:
        self.max_temperature_K = value


def _volumes(n: int):
    return (_Volume(float(i)) for i in range(n))


def _grey(volume) -> np.ndarray:
    return np.full((4, 6, 3), int(volume.max_temperature_K) * 10, np.uint8)


def _key(i: int) -> str:
    return f"job:{i}"


def test_a_run_interrupted_as_a_frame_is_committed_resumes_without_overwrite(tmp_path, monkeypatch):
    folder, real, written = tmp_path / "seq", sequence.write_png, []

    def dies_on_the_third(path, *args, **kwargs):
        if len(written) == 2:
            raise KeyboardInterrupt  # the manifest already names frame 2: it is simply redone
        written.append(path)
        return real(path, *args, **kwargs)

    monkeypatch.setattr(sequence, "write_png", dies_on_the_third)
    with pytest.raises(KeyboardInterrupt):
        render_sequence(_volumes(4), 4, folder, _grey, False, frame_key=_key)
    monkeypatch.setattr(sequence, "write_png", real)
    calls = []
    render_sequence(_volumes(4), 4, folder, lambda v: calls.append(v) or _grey(v), False, _key)
    assert [v.max_temperature_K for v in calls] == [2.0, 3.0]  # frames 0 and 1 reused


def test_frames_workers_wrote_before_the_client_died_are_reused(tmp_path):
    """The cluster path: workers commit PNGs the client never heard of (it was SIGKILLed)."""
    folder = tmp_path / "seq"

    def client_dies(todo, on_done):
        for i in todo[:2]:
            sequence.write_png(frame_path(folder, i), _grey(_Volume(float(i))))
        raise KeyboardInterrupt

    folder.mkdir()
    with pytest.raises(KeyboardInterrupt):  # what animate --workers runs, under its lock
        animation._render_missing(_volumes(4), 4, folder, _grey, False, _key, False, client_dies)
    calls = []
    render_sequence(_volumes(4), 4, folder, lambda v: calls.append(v) or _grey(v), False, _key)
    assert [v.max_temperature_K for v in calls] == [2.0, 3.0]


def test_an_old_frame_is_removed_before_its_new_key_is_recorded(tmp_path, monkeypatch):
    """Same job, changed input: the old PNG must not survive under the new key if the run dies."""
    folder = tmp_path / "seq"
    render_sequence(_volumes(2), 2, folder, _grey, False, frame_key=_key)
    monkeypatch.setattr(
        sequence, "write_png", lambda *a, **k: (_ for _ in ()).throw(OSError("disk"))
    )
    with pytest.raises(OSError, match="disk"):
        render_sequence(_volumes(2), 2, folder, _grey, False, lambda i: f"job:{i}-touched")
    assert not frame_path(folder, 0).exists()

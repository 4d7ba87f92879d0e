"""Camera paths for animations: an orbit around the target, and keyframes interpolated linearly.

A path is a function ``frame index ↦ Camera`` (frozen cameras; nothing is mutated).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from incandescent.camera.camera import Camera

CameraPath = Callable[[int], Camera]


def orbit(camera: Camera, n_frames: int, degrees: float = 360.0) -> CameraPath:
    """Rotate ``camera``'s eye about the vertical (+y) axis through its target by ``degrees``
    over ``n_frames`` frames (frame 0 is ``camera``; a full turn does not repeat frame 0)."""
    if n_frames < 1:
        raise ValueError(f"an orbit needs at least one frame; got {n_frames}")
    if not np.isfinite(degrees):
        raise ValueError(f"orbit degrees must be a finite number; got {degrees!r}")
    target = np.asarray(camera.target)
    offset = np.asarray(camera.eye) - target
    step = np.radians(degrees) / (n_frames if abs(degrees) >= 360.0 else max(n_frames - 1, 1))

    def at(frame: int) -> Camera:
        c, s = np.cos(step * frame), np.sin(step * frame)
        rotated = np.array(
            [c * offset[0] + s * offset[2], offset[1], -s * offset[0] + c * offset[2]]
        )
        return camera.replace(eye=tuple(target + rotated))

    return at


def keyframes(keys: Sequence[tuple[int, Camera]]) -> CameraPath:
    """Linear interpolation of eye, target, up and fov between ``(frame, camera)`` keys (sorted
    by frame); frames before the first or after the last key hold that key."""
    if not keys:
        raise ValueError("keyframes need at least one (frame, camera) pair")
    keys = sorted(keys, key=lambda k: k[0])
    frames = [f for f, _ in keys]

    def at(frame: int) -> Camera:
        i = int(np.searchsorted(frames, frame, side="right"))
        if i == 0 or i == len(keys):
            return keys[max(i - 1, 0)][1]
        (f0, a), (f1, b) = keys[i - 1], keys[i]
        w = (frame - f0) / (f1 - f0)

        def mix(u, v):
            return tuple((1 - w) * np.asarray(u) + w * np.asarray(v))

        return a.replace(
            eye=mix(a.eye, b.eye),
            target=mix(a.target, b.target),
            up=mix(a.up, b.up),
            fov_deg=(1 - w) * a.fov_deg + w * b.fov_deg,
        )

    return at

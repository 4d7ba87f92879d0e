"""Look-at cameras (DESIGN.md §4): right-handed world, +y up, image row 0 at the top,
pixel centres at (i + 0.5, j + 0.5). Cameras are frozen values; change them with
:meth:`Camera.replace`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from incandescent import _validate

PROJECTIONS = ("perspective", "orthographic")
#: Narrowest field of view, degrees: the default camera then stands ~11 000 box radii away, where
#: float32 ray positions still resolve a voxel; narrower views are refused rather than rendered
#: empty.
MIN_FOV_DEG = 0.01
#: Eye and target closer than this fraction of their distance from the world origin coincide: a
#: view direction from positions that differ only in their last few float64 bits is noise.
COINCIDE_RELATIVE = 1e-9
#: Bounds whose centre is within this many float64 roundings of 0 are centred on 0 (the box's
#: corners are ``origin + index · voxel``, each rounded; their mean is then off by ~1e-17 m).
CENTRE_ROUNDINGS = 8


def _vec3(value: ArrayLike, name: str) -> tuple[float, float, float]:
    arr = _validate.finite(_validate.real_array(value, f"camera {name}"), f"camera {name}")
    if arr.shape != (3,):
        raise ValueError(f"camera {name} must be 3 numbers x,y,z (m); got {np.asarray(value)!r}")
    return (float(arr[0]), float(arr[1]), float(arr[2]))


@dataclass(frozen=True)
class Camera:
    """A look-at camera.

    Attributes
    ----------
    eye, target: world positions in m. up: approximate up direction.
    fov_deg: vertical field of view in degrees (perspective).
    projection: "perspective" or "orthographic".
    ortho_height_m: height of the view in m (orthographic).
    """

    eye: tuple[float, float, float]
    target: tuple[float, float, float] = (0.0, 0.0, 0.0)
    up: tuple[float, float, float] = (0.0, 1.0, 0.0)
    fov_deg: float = 40.0
    projection: str = "perspective"
    ortho_height_m: float = 1.0

    def __post_init__(self) -> None:
        for name in ("eye", "target", "up"):
            object.__setattr__(self, name, _vec3(getattr(self, name), name))
        _validate.choice(self.projection, "camera projection", PROJECTIONS)
        fov = _validate.positive_scalar(self.fov_deg, "camera fov_deg")
        if not MIN_FOV_DEG <= fov < 180.0:
            raise ValueError(
                f"camera fov_deg must be in [{MIN_FOV_DEG:g}, 180) degrees; got {self.fov_deg!r}"
            )
        _validate.positive_scalar(self.ortho_height_m, "camera ortho_height_m")
        self.basis()  # rejects degenerate eye/target/up now, not at render time

    def replace(self, **changes) -> Camera:
        return replace(self, **changes)

    def basis(self) -> tuple[NDArray, NDArray, NDArray]:
        """Orthonormal (right, up, forward) vectors; errors on degenerate input."""
        forward = np.subtract(self.target, self.eye)
        distance = float(np.linalg.norm(forward))
        scale = max(float(np.linalg.norm(self.eye)), float(np.linalg.norm(self.target)))
        if not distance > COINCIDE_RELATIVE * scale or distance == 0.0:
            raise ValueError(
                f"camera eye and target coincide: eye {self.eye}, target {self.target} "
                f"({distance:.3g} m apart); they must differ"
            )
        forward = forward / distance
        right = np.cross(forward, self.up)
        norm = np.linalg.norm(right)
        if norm < 1e-9 * max(float(np.linalg.norm(self.up)), 1e-300):
            raise ValueError(
                f"camera up {self.up} is parallel to the view direction {tuple(forward.round(6))} "
                "(or zero); choose an up vector not along eye→target"
            )
        right = right / norm
        return right, np.cross(right, forward), forward

    def generate_rays(
        self, width: int, height: int, supersample: int = 1
    ) -> tuple[NDArray, NDArray]:
        """World-space ray origins and unit directions, float64 (n, 3).

        Ray order (the canonical ray index every backend uses, e.g. for jitter) is column-major
        with the ``supersample``² sub-pixel rays of a pixel adjacent: ray r belongs to pixel
        column ``r // (height·s²)``, row ``(r // s²) % height``. The Dr.Jit kernels march the
        same rays in a tiled order (``incandescent.renderer.rays.lane_order``).
        """
        px, py = _film_coordinates(width, height, supersample)
        right, up, forward = self.basis()
        aspect = width / height
        if self.projection == "perspective":
            half = np.tan(np.radians(self.fov_deg) / 2.0)
            d = forward + (px * half * aspect)[:, None] * right + (py * half)[:, None] * up
            d /= np.linalg.norm(d, axis=1, keepdims=True)
            return np.broadcast_to(np.asarray(self.eye), d.shape).copy(), d
        half_h = self.ortho_height_m / 2.0
        o = np.asarray(self.eye) + (px * half_h * aspect)[:, None] * right
        o = o + (py * half_h)[:, None] * up
        return o, np.broadcast_to(forward, o.shape).copy()


def _film_coordinates(width: int, height: int, s: int) -> tuple[NDArray, NDArray]:
    """Film coordinates in [-1, 1] (x right, y up) of every sub-pixel centre, column-major."""
    for name, v in (("width", width), ("height", height), ("supersample", s)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
            raise ValueError(f"image {name} must be a positive integer; got {v!r}")
    col, row, sx, sy = np.meshgrid(
        np.arange(width), np.arange(height), np.arange(s), np.arange(s), indexing="ij"
    )
    x = (col + (sx + 0.5) / s) / width
    y = (row + (sy + 0.5) / s) / height
    return (2.0 * x - 1.0).ravel(), (1.0 - 2.0 * y).ravel()


def default_camera(bounds_m: tuple[ArrayLike, ArrayLike], fov_deg: float = 40.0) -> Camera:
    """A three-quarter view from the front-right, slightly above, framing the whole box."""
    lo, hi = (np.asarray(b, dtype=np.float64) for b in bounds_m)
    centre = box_centre(lo, hi)
    radius = np.linalg.norm(hi - lo) / 2.0
    direction = np.array([0.55, 0.35, 0.76])
    direction /= np.linalg.norm(direction)
    distance = 1.05 * radius / np.sin(np.radians(fov_deg) / 2.0)
    return Camera(eye=tuple(centre + distance * direction), target=tuple(centre), fov_deg=fov_deg)


def box_centre(lo: NDArray, hi: NDArray) -> NDArray:
    """The centre of the box ``lo``–``hi`` (m), exactly 0 on axes where it differs from 0 only by
    the rounding of the corners (a box centred on the origin has its centre there, not at
    −2.8e−17 m)."""
    centre = (lo + hi) / 2.0
    noise = CENTRE_ROUNDINGS * np.finfo(np.float64).eps * (np.abs(lo) + np.abs(hi))
    return np.where(np.abs(centre) <= noise, 0.0, centre)

"""Emission tomography: the temperature grid that explains a set of calibrated views.

Each view is an absolute XYZ image with its camera. The loss is the views' relative squared
error, Σ_v |XYZ_v(T) − XYZ_v*|² / Σ_v |XYZ_v*|², plus a total-variation prior
λ·mean √(|∇T|² + ε²) / 1000 K (forward differences per voxel, smoothed); its gradient comes
from the replay adjoint (``adjoint``), one forward and one adjoint march per view and
evaluation. The absorption grid is given (known soot, e.g. from an extinction measurement):
T alone is solved, unless ``Settings.absorption`` (κ too, a = κ/κ_ref per voxel after the v's,
TV on a; emission alone hardly determines it).

Why it converges (what the first version, Adam on kelvin, did not):

- The unknown is the square root of the voxel's blackbody luminance relative to 2000 K,
  v = (Y_bb(T)/Y_bb(2000 K))^p with p = ½ (``Settings.power``), not T: emission is exponential
  in −1/T (Wien), so in kelvin a hot voxel's gradient is ~10⁵ times a warm one's. In Y itself
  (p = 1) the problem is linear but T(Y) is steep where Y → 0 (the TV prior's gradient blows
  up); in ln Y (p → 0) a dim voxel's gradient vanishes and it keeps its glow. On 16³ from 8
  views (``tests/inverse/test_reconstruct.py``'s flame) the RMSE over voxels above 1000 K is
  215 K with p = 1, 37 K with p = ¼, 18 K with p = ½, 74 K with the log. T = T(v) from a 1 K
  table of ``spectra.blackbody_xyz``.
- L-BFGS-B (scipy; Byrd et al. 1995, Zhu et al. 1997) on this smooth least squares, with the
  bounds T ∈ [visible_K, ceiling_K] as box bounds on v (positivity: below visible_K a voxel
  emits nothing the float32 render can see; such voxels are written as floor_K, ambient).
- Coarse to fine: the grid at 1/2^(levels−1) of the resolution first (κ block-averaged), its
  T upsampled (trilinear, in v) as the next level's start. The coarse grids are
  well-determined by few views and set the large scale; each finer level adds detail.
- The start is a uniform T whose views' summed luminance equals the inputs' (bisection).
- Voxels without absorption in reach (κ = 0 there and around) cannot be seen: they are held
  at the lower bound and written at ``floor_K``.

TV continuation (``Settings.tv_continuation``): at the finest level the TV weight is then relaxed
step by step, each weight from the last one's fit, stopped once the data term reaches the
views' noise² when ``Settings.noise`` is given (Morozov's discrepancy principle).

L-BFGS-B restarts every ``Settings.round`` iterations (its memory is not kept); after each
round the state (level, iterations done, v, losses) is written to the checkpoint atomically, so
a run resumed from it repeats the uninterrupted run exactly.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from incandescent.camera import Camera, Rig
from incandescent.inverse.adjoint import DeviceGradients, gradients_on
from incandescent.inverse.gradients import Gradients, gradients
from incandescent.renderer import RenderSettings, render
from incandescent.spectra.blackbody import blackbody_xyz

#: T of the log-luminance's zero, K.
REFERENCE_K = 2000.0
#: The bounds of a = κ/κ_ref when κ is solved (κ_ref: the start's largest κ)
ABSORPTION_BOUNDS = (1e-4, 100.0)


@dataclass(frozen=True, eq=False)
class View:
    """One calibrated view: its XYZ image (H, W, 3; Y in cd/m²), camera and film settings;
    ``name`` (e.g. its file) names it in errors."""

    xyz: NDArray
    camera: Camera
    settings: RenderSettings
    name: str = "a view"

    def __post_init__(self) -> None:
        xyz = np.asarray(self.xyz, dtype=np.float64)
        want = (self.settings.height, self.settings.width, 3)
        if xyz.shape[:2] != want[:2] or xyz.shape != want:
            raise ValueError(f"{self.name}: its image is {xyz.shape[1]}×{xyz.shape[0]} pixels "
                             f"(shape {xyz.shape}); its camera's film is {want[1]}×{want[0]} "
                             f"(shape {want})")  # fmt: skip
        bad = ~np.isfinite(xyz).all(axis=-1)
        if bad.any():
            y, x = np.argwhere(bad)[0]
            count = int(bad.sum())
            raise ValueError(
                f"{self.name}: {count} NaN or infinite pixels (first at x={x}, y={y}); "
                "radiance must be finite"
            )
        if (xyz[..., 1] < 0).any():
            y, x = np.argwhere(xyz[..., 1] < 0)[0]
            raise ValueError(f"{self.name}: negative radiance (luminance {xyz[y, x, 1]:g} at "
                             f"x={x}, y={y}); calibrated views are ≥ 0")  # fmt: skip
        object.__setattr__(self, "xyz", xyz)

    def check_sees(self, volume) -> None:
        """A one-line error when no pixel's ray meets ``volume``'s box."""
        transmittance = render(_box(volume), self.camera, self.settings, "reference").transmittance
        if transmittance is None or bool(np.all(np.asarray(transmittance) >= 1.0)):
            raise ValueError(f"{self.name}: its camera at {tuple(self.camera.eye)} looking at "
                             f"{tuple(self.camera.target)} does not see the volume's box "
                             f"{[list(b) for b in volume.bounds_m]} m")  # fmt: skip


def _box(volume):
    """An opaque, cold copy of ``volume``'s box: its render's transmittance is 1 exactly where
    a pixel's ray misses the box."""
    ones = np.full(volume.shape, 1e6, dtype=np.float32)
    return volume.replace(temperature_K=np.full(volume.shape, 300.0, np.float32),
                          absorption_per_m=ones, species={}, emission_scale=None)  # fmt: skip


@dataclass(frozen=True)
class Settings:
    """The optimisation: L-BFGS-B iterations per level (``iterations``; the finest level's,
    coarser levels get the same), the levels of coarse to fine (1: the given grid only), the
    TV weight λ (relative to the data term, per 1000 K of mean gradient per voxel), T's bounds
    (K), L-BFGS's memory, the iterations per round (a checkpoint after each) and the power p
    of the unknown v = (Y_bb(T)/Y_bb(2000 K))^p (0: its log). ``axisymmetric``: T is a radial
    profile about the vertical (y) axis through the box's centre, T(r, y) (``Radial``): one view
    suffices (the Abel case). ``dark_fraction``: voxels whose κ and their neighbours' is at
    most that fraction of the grid's largest are held at the floor, as those with none are."""

    iterations: int = 100
    levels: int = 3
    tv_weight: float = 3e-3
    #: the TV's smoothing ε, K per voxel: Σ √(|∇T|² + ε²) is quadratic (a smoothness prior)
    #: for steps well below ε and linear (edge-preserving) above
    tv_eps_K: float = 100.0
    floor_K: float = 300.0
    visible_K: float = 700.0
    ceiling_K: float = 4000.0
    memory: int = 50
    round: int = 100
    power: float = 0.5
    axisymmetric: bool = False
    #: voxels whose κ, and their neighbours', is at most this fraction of the largest are held
    #: dark (at the floor)
    dark_fraction: float = 0.0
    #: solve κ too, from the start's κ as the first guess (``absorption``: κ/κ_ref per voxel)
    absorption: bool = False
    #: TV continuation: after ``iterations`` at the finest level, ``continuation_iterations``
    #: more at each of these TV weights in turn — the coarse levels and the first round set the
    #: flame's shape under a strong prior, then the prior is relaxed so that the views decide
    #: its edges (``docs/inverse.md``: 76 → 44 K at 64³ from 12 views). Empty: none
    tv_continuation: tuple[float, ...] = ()
    #: L-BFGS-B iterations at each continuation weight (0: ``iterations``)
    continuation_iterations: int = 0
    #: the views' relative noise per pixel (σ/value), if known: the continuation stops before a
    #: weight once the data term is at most noise² (Morozov's discrepancy principle — a closer
    #: fit fits the noise); 0: the views are taken as exact and every weight is run
    noise: float = 0.0
    #: Gauss–Newton steps at the finest level after L-BFGS-B (``inverse.gauss_newton``; 0: none)
    gauss_newton: int = 0
    #: conjugate-gradient iterations per Gauss–Newton step
    gauss_newton_cg: int = 60

    def __post_init__(self) -> None:
        if int(self.continuation_iterations) < 0:
            raise ValueError(f"continuation_iterations is {self.continuation_iterations}; "
                             "expected ≥ 0 (0: iterations)")  # fmt: skip
        for name in ("iterations", "levels", "memory", "round"):
            if int(getattr(self, name)) < 1:
                raise ValueError(f"reconstruction {name} is {getattr(self, name)}; expected ≥ 1")
        if not self.floor_K <= self.visible_K < self.ceiling_K:
            raise ValueError(f"temperature bounds {self.floor_K:g} ≤ {self.visible_K:g} < "
                             f"{self.ceiling_K:g} K do not hold")  # fmt: skip
        if self.tv_weight < 0:
            raise ValueError(f"tv_weight is {self.tv_weight:g}; expected ≥ 0")
        object.__setattr__(self, "tv_continuation", tuple(float(w) for w in self.tv_continuation))
        if any(not w >= 0 for w in self.tv_continuation) or not 0 <= self.noise < 1:
            raise ValueError(f"tv_continuation {list(self.tv_continuation)} and noise "
                             f"{self.noise:g}: expected weights ≥ 0 and 0 ≤ noise < 1")  # fmt: skip
        if not self.tv_eps_K > 0:
            raise ValueError(f"tv_eps_K is {self.tv_eps_K:g}; expected > 0 K")
        if self.absorption and self.axisymmetric:
            raise ValueError("absorption and axisymmetric cannot be solved together yet")
        if int(self.gauss_newton) < 0 or int(self.gauss_newton_cg) < 1:
            raise ValueError(
                f"gauss_newton is {self.gauss_newton} with gauss_newton_cg "
                f"{self.gauss_newton_cg}; expected ≥ 0 steps of ≥ 1 iteration"
            )
        if self.gauss_newton and (self.absorption or self.axisymmetric):
            raise ValueError("gauss_newton refines T on the voxels only (not with absorption "
                             "or axisymmetric)")  # fmt: skip
        if not 0 <= self.dark_fraction < 1:
            raise ValueError(f"dark_fraction is {self.dark_fraction:g}; expected in [0, 1)")


class Luminance:
    """T ↔ v = (Y_bb(T)/Y_bb(2000 K))^p on [lo_K, hi_K] (p = 0: ln(Y_bb(T)/Y_bb(2000 K))), from
    a 1 K table (monotone)."""

    def __init__(self, lo_K: float, hi_K: float, power: float = 0.0) -> None:
        self.t_K, self.power = np.arange(lo_K, hi_K + 1.0), power
        ln = np.log(blackbody_xyz(self.t_K)[:, 1] / blackbody_xyz(REFERENCE_K)[1])
        self.v = ln if power == 0 else np.exp(power * ln)
        self.dv_dT = np.gradient(self.v, self.t_K)

    def of(self, temp_K: NDArray) -> NDArray:
        return np.interp(temp_K, self.t_K, self.v)

    def temperature(self, v: NDArray) -> tuple[NDArray, NDArray]:
        """(T in K, dT/dv) at v."""
        temp = np.interp(v, self.v, self.t_K)
        return temp, 1.0 / np.interp(temp, self.t_K, self.dv_dT)


def total_variation(temp: NDArray, eps: float = 1.0) -> tuple[float, NDArray]:
    """(Σ √(|∇T|² + ε²), its gradient) with forward differences (K; ε in K)."""
    grads = [np.diff(temp, axis=a, append=np.take(temp, [-1], axis=a)) for a in range(3)]
    norm = np.sqrt(sum(g * g for g in grads) + eps * eps)
    out = np.zeros_like(temp)
    for a, g in enumerate(grads):
        unit = g / norm
        out -= unit
        out += np.roll(unit, 1, axis=a) * (np.arange(temp.shape[a]) > 0).reshape(
            [-1 if b == a else 1 for b in range(3)])  # fmt: skip
    return float(norm.sum()), out


def data_term(volume, views: Sequence[View], backend: str) -> tuple[float, NDArray, list]:
    """(Σ_v |residual|² / Σ_v |XYZ*|², its T and κ gradients (2, *shape), the rendered XYZ
    images). On a Dr.Jit backend views that share their film settings are rendered, and
    differentiated, as one rig (``camera.Rig``): one forward and one adjoint launch for all."""
    norm = max(sum(float(np.sum(view.xyz**2)) for view in views), 1e-300)
    loss, grad, images = 0.0, np.zeros((2, *volume.shape)), []
    for group in _films(views, backend):
        camera, settings = _film(group)
        image = render(volume, camera, settings, backend)
        assert image.xyz is not None, "emission–absorption renders radiance"
        parts = camera.split(image.xyz) if isinstance(camera, Rig) else [image.xyz]
        residuals = [np.asarray(x, np.float64) - v.xyz for x, v in zip(parts, group, strict=True)]
        loss += sum(float(np.sum(r**2)) for r in residuals) / norm
        weights = np.concatenate(residuals, axis=1) * (2.0 / norm)
        grad += _gradient(backend, volume, camera, settings, weights, image)
        images += [np.asarray(x) for x in parts]
    return loss, grad, images


def _films(views: Sequence[View], backend: str) -> list[list[View]]:
    """The views in groups rendered together: all that share their film settings on a Dr.Jit
    backend, each alone on the reference (its float64 adjoint tapes per view)."""
    if backend == "reference":
        return [[view] for view in views]
    groups: dict[RenderSettings, list[View]] = {}
    for view in views:
        groups.setdefault(view.settings, []).append(view)
    return list(groups.values())


def _film(group: Sequence[View]) -> tuple[Camera | Rig, RenderSettings]:
    """One view's camera and settings, or a rig of several on a film as wide as all."""
    settings = group[0].settings
    if len(group) == 1:
        return group[0].camera, settings
    rig = Rig(tuple(view.camera for view in group))
    return rig, settings.replace(width=settings.width * len(group))


def _gradient(backend: str, volume, camera, settings, weights: NDArray, image) -> NDArray:
    """∂(Σ weights·XYZ)/∂T and ∂/∂κ, (2, *shape): the float64 adjoint on the reference backend
    (deterministic), the replay adjoint on a Dr.Jit one (float32; its scatter-adds sum in no
    fixed order)."""
    result: Gradients | DeviceGradients
    if backend == "reference":
        result = gradients(volume, camera, settings, weights)
    else:
        result = gradients_on(backend, volume, camera, settings, weights, image)
    return np.stack([result.temperature_K, result.absorption_per_m])


def level_volume(start, level: int):
    """``start`` at 1/2^level resolution over (at least) the same box: κ block-averaged (the
    grid zero-padded to a multiple of 2^level)."""
    f = 2**level
    if f == 1:
        return start
    kappa = np.asarray(start.absorption_per_m, dtype=np.float64)
    pad = [(0, -n % f) for n in kappa.shape]
    kappa = np.pad(kappa, pad)
    shape = tuple(n // f for n in kappa.shape)
    blocks = kappa.reshape(shape[0], f, shape[1], f, shape[2], f).mean(axis=(1, 3, 5))
    return start.replace(temperature_K=np.full(shape, 300.0, np.float32),
                         absorption_per_m=blocks.astype(np.float32),
                         voxel_size_m=start.voxel_size_m * f, species={}, emission_scale=None,
                         velocity_m_s=None)  # fmt: skip


def upsampled(values: NDArray, shape: tuple[int, ...], factor: int) -> NDArray:
    """A coarse grid (voxels ``factor`` times larger, same corner) sampled (bi/tri)linearly at
    the centres of a finer grid of ``shape`` (a radial profile's nodes: near enough, as a
    start)."""
    from scipy.ndimage import map_coordinates

    axes = [(np.arange(n) + 0.5) / factor - 0.5 for n in shape]
    points = np.meshgrid(*axes, indexing="ij")
    return map_coordinates(values, points, order=1, mode="nearest")


@dataclass
class State:
    """Where a reconstruction is: its level (``levels − 1`` is the coarsest, 0 the given grid),
    the L-BFGS-B iterations done at it, v on its grid, and the loss of every evaluation."""

    level: int
    done: int
    v: NDArray
    losses: list[float] = field(default_factory=list)


def _fingerprint(views: Sequence[View], start, settings: Settings) -> str:
    """What a checkpoint must match to be resumed: the views, the grid and the settings."""
    h = hashlib.sha256(json.dumps(asdict(settings), sort_keys=True).encode())
    for view in views:
        h.update(np.ascontiguousarray(view.xyz, dtype=np.float64).tobytes())
        h.update(repr(view.camera).encode())
    h.update(np.ascontiguousarray(start.absorption_per_m).tobytes())
    h.update(repr((start.shape, start.voxel_size_m, start.origin_m)).encode())
    return h.hexdigest()[:16]


def save_checkpoint(path: Path, state: State, fingerprint: str) -> None:
    """Write ``state`` to ``path`` (.npz) atomically, replacing the previous checkpoint."""
    from incandescent.io.atomic import atomic_write

    def write(tmp: Path) -> None:
        with open(tmp, "xb") as handle:
            np.savez(handle, level=state.level, done=state.done, v=state.v,
                     losses=np.asarray(state.losses), fingerprint=fingerprint)  # fmt: skip

    atomic_write(path, write, overwrite=True)


def load_checkpoint(path: Path, fingerprint: str) -> State:
    """The state saved at ``path``; a one-line error when it is of another reconstruction."""
    try:
        with np.load(path) as data:
            if str(data["fingerprint"]) != fingerprint:
                raise ValueError(
                    f"checkpoint {path} is of another reconstruction (other views, grid or "
                    "settings); remove it or start without resume"
                )
            return State(int(data["level"]), int(data["done"]), np.array(data["v"]),
                         [float(x) for x in data["losses"]])  # fmt: skip
    except (OSError, KeyError, ValueError, EOFError) as error:
        if isinstance(error, ValueError) and "another reconstruction" in str(error):
            raise
        raise ValueError(f"checkpoint {path} cannot be read ({error})") from None


@dataclass(frozen=True, eq=False)
class Result:
    """The reconstructed volume, the loss of every evaluation, and the views re-rendered from
    it with their residuals (rendered − input, XYZ)."""

    volume: object
    losses: list[float]
    rendered: list[NDArray]
    residuals: list[NDArray]


def uniform_start(views: Sequence[View], grid, settings: Settings, backend: str) -> float:
    """The uniform T (K) whose views' summed luminance equals the inputs' (bisection)."""
    want = sum(float(view.xyz[..., 1].sum()) for view in views)
    films = [_film(group) for group in _films(views, backend)]
    lo, hi = settings.visible_K, settings.ceiling_K
    for _ in range(20):
        mid = 0.5 * (lo + hi)
        trial = grid.replace(temperature_K=np.full(grid.shape, mid, np.float32))
        got = sum(_luminance(render(trial, camera, film, backend)) for camera, film in films)
        lo, hi = (mid, hi) if got < want else (lo, mid)
    return 0.5 * (lo + hi)


class Radial:
    """T(r, y) about the vertical axis through the box's centre, on nodes r_j = j·Δ (Δ: the
    voxel side) per voxel layer y: each voxel's v is the linear interpolation in r of its
    layer's profile (``matrix``, voxels × nodes), so the gradient of a profile node is the sum
    of its voxels' gradients with their weights (the transpose)."""

    def __init__(self, shape: tuple[int, int, int]) -> None:
        from scipy.sparse import csr_matrix

        nx, ny, nz = shape
        x, z = (np.arange(nx) + 0.5 - nx / 2), (np.arange(nz) + 0.5 - nz / 2)
        r = np.hypot(x[:, None], z[None, :])  # in voxels
        self.nodes = int(np.ceil(r.max())) + 1
        j = np.minimum(np.floor(r).astype(int), self.nodes - 2)
        f = np.clip(r - j, 0.0, 1.0)
        voxel = np.arange(nx * ny * nz).reshape(shape)
        rows, cols, weights = [], [], []
        for node, weight in ((j, 1.0 - f), (j + 1, f)):
            for y in range(ny):
                rows.append(voxel[:, y, :].ravel())
                cols.append((node * ny + y).ravel())
                weights.append(weight.ravel())
        self.shape = (self.nodes, ny)
        where = (np.concatenate(rows), np.concatenate(cols))
        size = (voxel.size, self.nodes * ny)
        self.matrix = csr_matrix((np.concatenate(weights), where), shape=size)
        self.voxels = shape


def _unknowns(grid, settings: Settings):
    """The map from the unknowns to the voxels: None (one per voxel) or a :class:`Radial`."""
    return Radial(grid.shape) if settings.axisymmetric else None


def dark_voxels(grid, fraction: float = 0.0) -> NDArray[np.bool_]:
    """Voxels whose T no render can see: κ = 0 there and in the 26 around (a sample's trilinear
    κ and T reach one voxel out), or at most ``fraction`` of the grid's largest κ. They are held
    at the lower bound (written as the floor)."""
    from scipy.ndimage import maximum_filter

    local = maximum_filter(np.asarray(grid.absorption_per_m), size=3, mode="nearest")
    return local <= fraction * float(local.max())


def _luminance(image) -> float:
    """An image's summed Y (cd/m²)."""
    assert image.xyz is not None, "emission–absorption renders radiance"
    return float(np.sum(image.xyz[..., 1]))


class _Problem:
    """Loss and gradient in v on one level's grid."""

    def __init__(self, views, grid, settings: Settings, backend: str, table, state, progress,
                 kappa_ref: float = 1.0):  # fmt: skip
        self.views, self.grid, self.settings, self.backend = views, grid, settings, backend
        self.table, self.state, self.progress = table, state, progress
        self.kappa_ref = kappa_ref
        self.tv_weight = settings.tv_weight
        self.map = _unknowns(grid, settings)
        self.dark = np.zeros(grid.shape if self.map is None else self.map.shape, bool)
        if self.map is None and not settings.absorption:
            self.dark = dark_voxels(grid, settings.dark_fraction)

    def __call__(self, flat: NDArray) -> tuple[float, NDArray]:
        loss, grad = self.voxels(flat if self.map is None else self.map.matrix @ flat)
        return loss, grad if self.map is None else self.map.matrix.T @ grad

    def voxels(self, flat: NDArray) -> tuple[float, NDArray]:
        """Loss and gradient in each voxel's v (and, solving κ, its a = κ/κ_ref after them)."""
        shape, absorption = self.grid.shape, self.settings.absorption
        unknowns = flat.reshape((2, *shape) if absorption else shape)
        temp, dtemp = self.table.temperature(unknowns[0] if absorption else unknowns)
        volume = self.grid.replace(temperature_K=temp.astype(np.float32))
        if absorption:
            kappa = unknowns[1] * self.kappa_ref
            volume = volume.replace(absorption_per_m=kappa.astype(np.float32))
        loss, (grad, grad_kappa), _ = data_term(volume, self.views, self.backend)
        tv, tv_grad = total_variation(temp, self.settings.tv_eps_K)
        weight = self.tv_weight / (temp.size * 1000.0)
        loss, grad = loss + weight * tv, (grad + weight * tv_grad) * dtemp
        if absorption:  # TV on a, per 1/1000 of κ_ref as T's is per 1000 K
            tv_a, tv_a_grad = total_variation(unknowns[1], eps=1e-3)
            loss += weight * 1000.0 * tv_a
            grad = np.stack([grad, grad_kappa * self.kappa_ref + weight * 1000.0 * tv_a_grad])
        self.state.losses.append(loss)
        if self.progress is not None:
            self.progress(self.state.level, len(self.state.losses), loss)
        return loss, grad.ravel()


def _round(problem: _Problem, state: State, bounds, iterations: int) -> None:
    """Up to ``iterations`` L-BFGS-B iterations from ``state.v`` (fresh memory)."""
    from scipy.optimize import minimize

    settings = problem.settings
    lo, hi = bounds
    dark = problem.dark.ravel()
    box = [(lo, lo) if d else (lo, hi) for d in dark]
    start = state.v.ravel().copy()
    start[: dark.size] = np.where(dark, lo, start[: dark.size])
    if settings.absorption:  # a = κ/κ_ref > 0: a κ = 0 sample far from the flame is skipped
        box += [ABSORPTION_BOUNDS] * dark.size
    result = minimize(problem, start, jac=True, method="L-BFGS-B", bounds=box,
                      options={"maxiter": iterations, "maxfun": 2 * iterations + 5,
                               "maxcor": settings.memory, "gtol": 0.0,
                               "ftol": 1e-12})  # fmt: skip
    state.v = result.x.reshape(state.v.shape)
    state.done += iterations


def reconstruct(
    views: Sequence[View],
    start,
    settings: Settings = Settings(),
    backend: str = "cpu",
    progress: Callable[[int, int, float], None] | None = None,
    checkpoint: Path | None = None,
    resume: bool = False,
) -> Result:
    """T on ``start``'s grid (its absorption and placement kept; its T ignored) that fits
    ``views``. ``progress(level, evaluation, loss)`` after each evaluation; with ``checkpoint``
    the state is saved after every round, and ``resume`` continues from it."""
    fingerprint = _fingerprint(views, start, settings)
    table = Luminance(settings.visible_K, settings.ceiling_K, settings.power)
    bounds = (float(table.v[0]), float(table.v[-1]))
    state = _initial(views, start, settings, backend, table, checkpoint, resume, fingerprint)
    kappa_ref = _kappa_ref(start)
    while True:
        grid = level_volume(start, state.level)
        problem = _Problem(views, grid, settings, backend, table, state, progress, kappa_ref)
        while state.done < settings.iterations:
            _round(problem, state, bounds, min(settings.round, settings.iterations - state.done))
            if checkpoint is not None:
                save_checkpoint(checkpoint, state, fingerprint)
        if state.level == 0:
            _relax(problem, state, bounds, checkpoint, fingerprint)
            _refine(problem, state, table, checkpoint, fingerprint)
            break
        finer = level_volume(start, state.level - 1)
        shape = _unknown_shape(finer, settings)
        parts, each = (state.v, shape[1:]) if settings.absorption else (state.v[None], shape)
        finer_v = np.stack([upsampled(part, each, 2) for part in parts]).reshape(shape)
        state = State(state.level - 1, 0, finer_v, state.losses)
    return _result(views, start, settings, table, state, backend)


def _relax(problem: _Problem, state: State, bounds, checkpoint, fingerprint: str) -> None:
    """The TV continuation (``Settings.tv_continuation``) at the finest level:
    ``continuation_iterations`` (or ``iterations``) of L-BFGS-B at each weight in turn, counted
    on in ``state.done`` (a checkpoint after each round); before each weight the discrepancy
    stop, if ``noise`` is set."""
    settings = problem.settings
    weights = settings.tv_continuation
    for stage, weight in enumerate(weights, start=1):
        end = _relaxed(settings, stage)
        if state.done >= end:
            continue
        if settings.noise > 0 and _data_term(problem, state.v) <= settings.noise**2:
            state.done = _relaxed(settings, len(weights))
            break
        problem.tv_weight = weight
        while state.done < end:
            _round(problem, state, bounds, min(settings.round, end - state.done))
            if checkpoint is not None:
                save_checkpoint(checkpoint, state, fingerprint)
    problem.tv_weight = weights[-1] if weights else settings.tv_weight  # Gauss–Newton's


def _relaxed(settings: Settings, stages: int) -> int:
    """The finest level's iterations done after ``stages`` continuation weights."""
    each = settings.continuation_iterations or settings.iterations
    return settings.iterations + stages * each


def _data_term(problem: _Problem, v: NDArray) -> float:
    """The views' relative squared error at ``v`` (the loss without its prior; not counted as
    an evaluation)."""
    weight, progress = problem.tv_weight, problem.progress
    problem.tv_weight, problem.progress = 0.0, None
    try:
        return problem(v.ravel())[0]
    finally:
        problem.tv_weight, problem.progress = weight, progress
        problem.state.losses.pop()


def _refine(problem: _Problem, state: State, table, checkpoint, fingerprint: str) -> None:
    """``gauss_newton`` steps at the finest level (``inverse.gauss_newton``), counted on from
    L-BFGS-B's iterations in ``state.done`` (a checkpoint after each, so a resumed run goes on
    from the last)."""
    from incandescent.inverse import gauss_newton as gn

    settings = replace(problem.settings, tv_weight=problem.tv_weight)  # the continuation's last
    start = _relaxed(settings, len(settings.tv_continuation))
    end = start + settings.gauss_newton
    if state.done >= end:
        return
    model = gn.Model(_targets(problem.views, problem.backend), problem.grid, settings,
                     problem.backend, ~problem.dark, total_variation, _gradient)  # fmt: skip
    temp, _ = table.temperature(state.v)
    parts = model.residuals(temp)
    loss = model.loss(temp, parts)
    while state.done < end:
        temp, parts, loss = gn.step(model, temp, parts, loss)
        state.v, state.done = table.of(temp), state.done + 1
        state.losses.append(loss)
        if problem.progress is not None:
            problem.progress(state.level, len(state.losses), loss)
        if checkpoint is not None:
            save_checkpoint(checkpoint, state, fingerprint)


def _targets(views: Sequence[View], backend: str) -> list[tuple]:
    """(camera or rig, settings, the input XYZ side by side) per group rendered together."""
    return [(*_film(g), np.concatenate([v.xyz for v in g], axis=1)) for g in _films(views, backend)]


def _initial(views, start, settings, backend, table, checkpoint, resume, fingerprint) -> State:
    """The checkpoint's state (``resume``), or the coarsest level at a uniform T."""
    if resume and checkpoint is not None and Path(checkpoint).exists():
        return load_checkpoint(Path(checkpoint), fingerprint)
    level = min(settings.levels - 1, int(np.log2(max(min(start.shape) // 2, 1))))
    grid = level_volume(start, level)
    temp = uniform_start(views, grid, settings, backend)
    v = np.full(grid.shape if settings.absorption else _unknown_shape(grid, settings),
                float(table.of(temp)))  # fmt: skip
    if settings.absorption:
        a = np.clip(grid.absorption_per_m / _kappa_ref(start), *ABSORPTION_BOUNDS)
        v = np.stack([v, a])
    return State(level, 0, v)


def _kappa_ref(start) -> float:
    """κ_ref, 1/m: the start's largest κ (1 where it has none)."""
    top = float(np.max(start.absorption_per_m))
    return top if top > 0 else 1.0


def _unknown_shape(grid, settings: Settings) -> tuple[int, ...]:
    if settings.absorption:
        return (2, *grid.shape)
    unknowns = _unknowns(grid, settings)
    return grid.shape if unknowns is None else unknowns.shape


def _result(views, start, settings, table, state, backend) -> Result:
    unknowns = _unknowns(start, settings)
    v = state.v[0] if settings.absorption else state.v
    v = v if unknowns is None else (unknowns.matrix @ v.ravel()).reshape(start.shape)
    temp, _ = table.temperature(v)
    temp = np.where(v <= table.v[0] + 1e-9, settings.floor_K, temp)  # invisible: ambient
    volume = start
    if settings.absorption:
        kappa = state.v[1] * _kappa_ref(start)
        volume = start.replace(absorption_per_m=kappa.astype(np.float32))
    elif unknowns is None:
        temp = np.where(dark_voxels(start, settings.dark_fraction), settings.floor_K, temp)
    volume = volume.replace(temperature_K=temp.astype(np.float32))
    rendered = [np.asarray(render(volume, v.camera, v.settings, backend).xyz) for v in views]
    residuals = [image - view.xyz for image, view in zip(rendered, views, strict=True)]
    return Result(volume, state.losses, rendered, residuals)

"""Simulated pool fires against fire science: puffing (Cetegen & Ahmed 1993), mean flame height
(Heskestad 1983) and the plume's centreline temperature (McCaffrey 1979).

For each pool (D, Q) of ``--pools`` at each ``--resolution``: ``pool_fire(D, Q)`` (methane; a
diffusion flame — burning at once, or with ``--reaction mixing_time`` at its sub-grid mixing
rate — or the premixed equivalent with ``--combustion front``) is run on ``--backend``
(cpu; cuda on a GPU, where ``--jobs`` runs the pools side by side in their own processes) at 24
samples per second, first for a warmup that is dropped — ``--warmup`` seconds, or three times
the time its feed takes to fill the pool's cells if longer (``FILL_TIMES``) — then for
``--seconds`` that are measured:

- the puffing frequency: the dominant frequency above 0.5 Hz of the luminous volume (gas above
  1000 K, the diagnostics' flame), of the luminous region's tip height and, for a diffusion
  flame, of the flame's own volume (gas at or above Z_st, ``puffing_sheet_hz``);
- the mean flame height: where a layer holds luminous gas half the time (50 % intermittency);
  for a diffusion flame also where a layer holds gas at or above the stoichiometric mixture
  fraction half the time (``height_sheet_m``): fast chemistry burns the fuel at the sheet
  Z = Z_st, so that is where its flame ends, while gas above 1000 K reaches on into the lean
  plume (methane with χ_r = 0.2: down to Z ≈ 0.45 Z_st);
- the centreline: the time-mean temperature of the 2×2 central columns; its log–log slope above
  the flame, in McCaffrey's plume region (z/Q^(2/5) > 0.2 m/kW^(2/5)) below the top 15 % of the
  domain (its open outflow), against McCaffrey's −5/3; and the same of the mean plume's own
  axis, the hottest point of each layer of the time-mean field (``pool.plume_peak``, with its
  distance from the centreline), which differs where the mean plume has drifted off it.

Writes ``OUT.json`` (every figure, and the profiles) and ``OUT.md`` (the table, and the time-mean
centreline's — and axis's — ratio to McCaffrey's excess in each of his three regions, the
continuous flame, the intermittent flame and the plume: ``pool.mccaffrey_ratios``); with ``--plot``
also ``OUT.png`` (spectra and profiles). Usage:
``python benchmarks/fire_validation.py OUT [--resolution 64] [--seconds 9] [--warmup 3]
[--pools 0.2:10,0.2:20,0.5:50,0.5:150,1.0:200,1.0:600] [--backend cpu] [--jobs 1] [--plot]
[--state-relation burke_schumann|equilibrium]``.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import numpy as np

from incandescent.simulation import FireSolver
from incandescent.simulation.diagnostics import HOT_K
from incandescent.simulation.pool import (
    centreline_K,
    characteristic_diameter_m,
    dominant_hz,
    heskestad_height_m,
    intermittency_height_m,
    mccaffrey_excess_K,
    mccaffrey_ratios,
    plume_peak,
    pool_fire,
    power_law_slope,
    puffing_hz,
)
from incandescent.simulation.run import advance_frame
from incandescent.simulation.solver import grid_shape

RATE_HZ = 24.0


def sample_run(
    diameter_m: float,
    heat_kW: float,
    resolution: int,
    seconds: float,
    backend: str = "cpu",
    combustion: str = "mixing",
    reaction: str = "fast",
    expansion: bool | None = None,
    mean_from: int = 0,
    state_relation: str = "burke_schumann",
) -> dict:
    """Per-sample series of one pool fire: luminous volume, tip height and layer presence
    (NumPy arrays), the time-mean temperature field from sample ``mean_from`` on, with the
    solver's cell size and wall time."""
    changes = {"fps": RATE_HZ, "reaction": reaction}
    if combustion == "mixing":
        changes["state_relation"] = state_relation
    if expansion is not None:  # else pool_fire's choice
        changes["expansion"] = expansion
    settings = pool_fire(diameter_m, heat_kW, changes=changes, combustion=combustion)
    solver = FireSolver(settings, resolution, backend)
    state, h = solver.initial_state(), solver.h
    volume, tip, present, sheet, flame = [], [], [], [], []
    total_K, began = np.zeros(solver.shape), time.perf_counter()
    for sample in range(round(seconds * RATE_HZ)):
        state, _ = advance_frame(solver, state)
        t = solver.ops.numpy(state.temperature.values).reshape(solver.shape)
        hot = t > HOT_K
        layers = hot.any(axis=(0, 2))
        volume.append(hot.sum() * h**3)
        tip.append((np.nonzero(layers)[0].max() + 1) * h if layers.any() else 0.0)
        present.append(layers)
        if sample >= mean_from:
            total_K += t
        if settings.combustion == "mixing":
            z = solver.ops.numpy(state.mixture.values).reshape(solver.shape)
            rich = z >= settings.stoichiometric_mixture
            sheet.append(rich.any(axis=(0, 2)))
            flame.append(rich.sum() * h**3)
    return {
        "h": h,
        "expansion": settings.expansion,
        "shape": solver.shape,
        "wall_s": time.perf_counter() - began,
        "volume": np.array(volume),
        "tip": np.array(tip),
        "present": np.array(present),
        "mean_K": total_K / max(round(seconds * RATE_HZ) - mean_from, 1),
        "sheet": np.array(sheet),
        "flame": np.array(flame),
    }


#: A diffusion flame's pool cells fill with fuel over h/v_f (a cell's height at the vapour's
#: speed: 4 s for the 0.5 m, 50 kW pool at 64 cells, 8 s for the 1 m pools); the samples start
#: after this many of those, when the feed and the outflow balance (within e⁻³ = 5 %).
FILL_TIMES = 3.0


def fill_s(diameter_m: float, heat_kW: float, resolution: int, combustion: str) -> float:
    """h / v_f: the time (s) the feed takes to fill the pool's cells (0 for the premixed front,
    whose inflow is the burning mixture itself)."""
    if combustion != "mixing":
        return 0.0
    settings = pool_fire(diameter_m, heat_kW, combustion=combustion)
    _, h = grid_shape(settings, resolution)
    return h / settings.sources[0].jet_m_s


def measure(
    diameter_m: float,
    heat_kW: float,
    resolution: int,
    seconds: float,
    warmup: float,
    backend: str = "cpu",
    combustion: str = "mixing",
    reaction: str = "fast",
    expansion: bool | None = None,
    state_relation: str = "burke_schumann",
):
    """The figures of one pool fire against the correlations (see the module docstring)."""
    fill = fill_s(diameter_m, heat_kW, resolution, combustion)
    warmup = max(warmup, FILL_TIMES * fill)
    run = sample_run(
        diameter_m, heat_kW, resolution, warmup + seconds, backend, combustion, reaction,
        expansion, round(warmup * RATE_HZ), state_relation,
    )  # fmt: skip
    keep = slice(round(warmup * RATE_HZ), None)
    h, ny = run["h"], run["shape"][1]
    z = (np.arange(ny) + 0.5) * h
    excess = centreline_K(run["mean_K"]) - 300.0
    peak_K, offset_m = plume_peak(run["mean_K"], h)
    plume = (z / heat_kW**0.4 > 0.2) & (z < 0.85 * ny * h) & (excess > 0)
    return {
        "D_m": diameter_m,
        "Q_kW": heat_kW,
        "resolution": resolution,
        "backend": backend,
        "combustion": combustion,
        "reaction": reaction,
        "expansion": run["expansion"],
        "state_relation": state_relation if combustion == "mixing" else None,
        "warmup_s": warmup,
        "measured_s": seconds,
        "fill_s": fill,
        "shape": list(run["shape"]),
        "cells_across_D": diameter_m / h,
        "wall_s": run["wall_s"],
        "puffing_expected_hz": puffing_hz(diameter_m),
        "puffing_volume_hz": dominant_hz(run["volume"][keep], RATE_HZ),
        "puffing_tip_hz": dominant_hz(run["tip"][keep], RATE_HZ),
        "puffing_sheet_hz": (
            dominant_hz(run["flame"][keep], RATE_HZ) if len(run["flame"]) else None
        ),
        "height_expected_m": heskestad_height_m(heat_kW, diameter_m),
        "height_m": intermittency_height_m(run["present"][keep], h),
        "height_sheet_m": (
            intermittency_height_m(run["sheet"][keep], h) if len(run["sheet"]) else None
        ),
        "domain_height_m": ny * h,
        "plume_slope": _slope(z[plume], excess[plume]),
        "plume_points": int(plume.sum()),
        "peak_slope": _slope(z[plume], peak_K[plume] - 300.0),
        "z_m": z.tolist(),
        "centreline_excess_K": excess.tolist(),
        "mccaffrey_excess_K": mccaffrey_excess_K(z, heat_kW).tolist(),
        "peak_excess_K": (peak_K - 300.0).tolist(),
        "peak_offset_m": offset_m.tolist(),
        "volume_m3": run["volume"][keep].tolist(),
        "presence": run["present"][keep].mean(axis=0).tolist(),
        "sheet_presence": run["sheet"][keep].mean(axis=0).tolist() if len(run["sheet"]) else None,
    }


def _slope(height_m: np.ndarray, excess_K: np.ndarray) -> float | None:
    """``power_law_slope`` where three points or more were kept, else None."""
    return power_law_slope(height_m, excess_K) if len(height_m) >= 3 else None


def table(results: list[dict]) -> str:
    """The results as a Markdown table, each figure beside its correlation."""
    rows = [
        "| D (m) | Q (kW) | cells | D*/δx | puffing Hz (vol / tip / flame) | Cetegen–Ahmed Hz "
        "| flame height m, T > 1000 K / Z ≥ Z_st | Heskestad m | plume slope | McCaffrey "
        "| wall s (backend) |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in results:
        slope = "—" if r["plume_slope"] is None else f"{r['plume_slope']:.2f}"
        if r.get("peak_slope") is not None:  # measured from the 49th stop on
            slope += f" (axis {r['peak_slope']:.2f})"
        height = f"{r['height_m']:.2f}"
        if r["height_m"] >= r["domain_height_m"] - 1e-9:
            height = f"≥ {height} (the top)"
        sheet = r.get("height_sheet_m")
        height += " / —" if sheet is None else f" / {sheet:.2f}"
        rows.append(
            f"| {r['D_m']:g} | {r['Q_kW']:g} | {r['resolution']} ({r['cells_across_D']:.0f} "
            f"across D) | {_resolved(r):.1f} | {r['puffing_volume_hz']:.2f} / "
            f"{r['puffing_tip_hz']:.2f}{_flame_hz(r)} | "
            f"{r['puffing_expected_hz']:.2f} | {height} | "
            f"{r['height_expected_m']:.2f} | {slope} | −1.67 | {r['wall_s']:.0f} "
            f"({r.get('backend', 'cpu')}) |"
        )
    return "\n".join(rows) + "\n"


def regions_table(results: list[dict]) -> str:
    """The time-mean centreline (and the mean plume's axis, where it was recorded) against
    McCaffrey's correlation in each of his three regions (``pool.mccaffrey_ratios``), below the
    top 15 % of the domain, as a Markdown table."""
    rows = [
        "| D (m) | Q (kW) | cells | ΔT ÷ McCaffrey's: continuous flame (z/Q^⅖ < 0.08) "
        "| intermittent (0.08–0.2) | plume (> 0.2) |",
        "|---|---|---|---|---|---|",
    ]
    for r in results:
        top = 0.85 * r["domain_height_m"]
        centre = mccaffrey_ratios(r["z_m"], r["centreline_excess_K"], r["Q_kW"], top)
        axis = None  # recorded from the 49th stop on
        if "peak_excess_K" in r:
            axis = mccaffrey_ratios(r["z_m"], r["peak_excess_K"], r["Q_kW"], top)
        cells = [_region_cell(centre[name], axis and axis[name]) for name in centre]
        rows.append(f"| {r['D_m']:g} | {r['Q_kW']:g} | {r['resolution']} | {' | '.join(cells)} |")
    return "\n".join(rows) + "\n"


def _region_cell(centre: float | None, axis: float | None) -> str:
    """``1.27 (axis 1.58)``; the axis left out where it was not recorded; None as —."""
    text = "—" if centre is None else f"{centre:.2f}"
    return text if axis is None else f"{text} (axis {axis:.2f})"


def _flame_hz(result: dict) -> str:
    """`` / f``: the puffing of the flame's own volume (Z ≥ Z_st), where it was measured."""
    flame = result.get("puffing_sheet_hz")
    return "" if flame is None else f" / {flame:.2f}"


def _resolved(result: dict) -> float:
    """D*/δx: the fire's characteristic diameter in cells (``pool.characteristic_diameter_m``)."""
    cell_m = result["D_m"] / result["cells_across_D"]
    return characteristic_diameter_m(result["Q_kW"]) / cell_m


def plot(results: list[dict], path: Path) -> None:
    """Centreline excess temperature against McCaffrey's, one panel per pool; vertical lines:
    Heskestad's flame height (grey), ours by 1000 K (blue, dotted) and by Z ≥ Z_st (green)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(results), figsize=(3.0 * len(results), 3.2), squeeze=False)
    for ax, r in zip(axes[0], results, strict=True):
        z = np.array(r["z_m"])
        ax.loglog(z, np.maximum(r["centreline_excess_K"], 1.0), label="simulated")
        ax.loglog(z, r["mccaffrey_excess_K"], "--", label="McCaffrey 1979")
        if "peak_excess_K" in r:
            ax.loglog(
                z, np.maximum(r["peak_excess_K"], 1.0), "-.", color="C3", label="mean plume's axis"
            )
        ax.axvline(r["height_expected_m"], color="grey", lw=0.8)
        for key, colour in (("height_m", "C0"), ("height_sheet_m", "C2")):
            if r.get(key):  # None (no sheet) or 0 (no flame half the time): no line on a log axis
                ax.axvline(r[key], color=colour, lw=0.8, ls=":")
        ax.set_title(f"D {r['D_m']:g} m, Q {r['Q_kW']:g} kW ({r['resolution']})", fontsize=8)
        ax.set_xlabel("z (m)")
    axes[0][0].set_ylabel("centreline ΔT (K)")
    axes[0][0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=90)


def run_pools(pools: list[tuple[float, ...]], args: argparse.Namespace) -> list[dict]:
    """``measure`` of every pool, ``args.jobs`` at a time (each in its own spawned process, as
    Dr.Jit's CUDA context is not fork-safe), the JSON rewritten as each one ends (so a run
    stopped early keeps the pools it finished), in the order of ``pools``."""
    common = (
        args.resolution, args.seconds, args.warmup, args.backend, args.combustion, args.reaction,
        args.expansion, args.state_relation,
    )  # fmt: skip
    context = multiprocessing.get_context("spawn")
    results: list[dict] = []
    with ProcessPoolExecutor(max_workers=max(args.jobs, 1), mp_context=context) as pool:
        futures = [pool.submit(measure, d, q, *common) for d, q in pools]
        for future in as_completed(futures):
            done = future.result()
            results = sorted([*results, done], key=lambda r: pools.index((r["D_m"], r["Q_kW"])))
            print(table([done]).splitlines()[-1], flush=True)
            args.out.with_suffix(".json").write_text(json.dumps(results, indent=1))
    return results


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("out", type=Path, help="OUT: writes OUT.json, OUT.md (and OUT.png)")
    parser.add_argument("--resolution", type=int, default=64)
    parser.add_argument("--seconds", type=float, default=9.0, help="measured, after the warmup")
    parser.add_argument("--warmup", type=float, default=3.0, help="at least; see FILL_TIMES")
    parser.add_argument("--pools", default="0.2:10,0.2:20,0.5:50,0.5:150,1.0:200,1.0:600")
    parser.add_argument("--backend", default="cpu", help="cpu or cuda")
    parser.add_argument(
        "--combustion", default="mixing", choices=("front", "mixing"), help="pool_fire's model"
    )
    parser.add_argument(
        "--reaction", default="fast", choices=("fast", "mixing_time"), help="a diffusion flame's"
    )
    parser.add_argument(
        "--expansion",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="a fast diffusion flame's low-Mach expansion (default: pool_fire's, on)",
    )
    parser.add_argument(
        "--state-relation",
        default="burke_schumann",
        choices=("burke_schumann", "equilibrium"),
        help="a fast diffusion flame's T(Z)",
    )
    parser.add_argument("--jobs", type=int, default=1, help="pools run at once (own processes)")
    parser.add_argument("--plot", action="store_true")
    parser.add_argument("--again", action="store_true", help="remake OUT.md/.png from OUT.json")
    args = parser.parse_args()
    if args.again:
        results = json.loads(args.out.with_suffix(".json").read_text())
        args.out.with_suffix(".md").write_text(table(results) + "\n" + regions_table(results))
        plot(results, args.out.with_suffix(".png"))
        return
    args.out.parent.mkdir(parents=True, exist_ok=True)
    pools = [tuple(float(v) for v in pool.split(":")) for pool in args.pools.split(",")]
    results = run_pools(pools, args)
    args.out.with_suffix(".md").write_text(table(results) + "\n" + regions_table(results))
    if args.plot:
        plot(results, args.out.with_suffix(".png"))


if __name__ == "__main__":
    main()

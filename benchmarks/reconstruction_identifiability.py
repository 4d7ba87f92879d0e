"""How much the views see of each temperature band of the held-out fire (issue 30's target).

The held-out fire of ``reconstruction_accuracy.py`` (n³, 12 views of P² on its ring) rendered
noise free; then every voxel whose true T lies in a band shifted by ±ΔT and the views rendered
again. Reported per band: its voxels, their share of the voxels above 1000 K (the target's RMSE
set), the RMSE that shift alone gives over that set, and the data term it costs — the
reconstruction's relative squared error Σ|XYZ − XYZ*|²/Σ|XYZ*|² — for the CIE observer and for
a band of 760–830 nm (the renderer's reddest; near-infrared pyrometry's side). A shift whose
data term lies below the noise floor (1 % Gaussian noise per pixel costs 10⁻⁴) or below what a
fit's residual leaves (1.2·10⁻⁵ at 64³) cannot be told from the truth by any fit of the views.

    python benchmarks/reconstruction_identifiability.py OUT.json [--size 64] [--pixels 128]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
from reconstruction_accuracy import fire, ring

BANDS_K = ((1000, 1150), (1000, 1300), (1300, 1600), (1600, 3000))
SHIFTS_K = (150.0, -150.0, 50.0)


def observers() -> dict:
    """The CIE observer and a 760–830 nm band (each channel the same boxcar), as Emissions."""
    from incandescent.emission import Emission
    from incandescent.spectra.cmf import cmfs, register_observer

    grid = cmfs().wavelength_nm
    weights = np.zeros((grid.size, 3))
    weights[(grid >= 760) & (grid <= 830), :] = 1.0
    return {
        "CIE XYZ": Emission(),
        "760-830 nm": Emission(observer=register_observer("nir", weights)),
    }


def views(volume, cameras, settings, emission) -> list:
    """The views of ``volume`` through ``emission``'s observer (cpu backend, float64 copies)."""
    import incandescent as inc
    from incandescent.renderer.integrators import EmissionAbsorption

    integrator = EmissionAbsorption(emission=emission)
    return [np.asarray(inc.render(volume, c, settings, "cpu", integrator=integrator).xyz,
                       np.float64) for c in cameras]  # fmt: skip


def data_term(truth, temperature_K, cameras, settings, emission, reference) -> float:
    """Σ|views(T) − reference|² / Σ|reference|² over the views: the measure of
    ``inverse.reconstruct.data_term``, which renders through the CIE observer only."""
    volume = truth.replace(temperature_K=temperature_K.astype(np.float32))
    got = views(volume, cameras, settings, emission)
    num = sum(float(np.sum((g - r) ** 2)) for g, r in zip(got, reference, strict=True))
    return num / sum(float(np.sum(r**2)) for r in reference)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--size", type=int, default=64)
    parser.add_argument("--pixels", type=int, default=128)
    args = parser.parse_args()
    truth = fire(args.size)
    cameras, settings = ring(12, args.pixels)
    temp = np.asarray(truth.temperature_K, np.float64)
    hot, rows = temp > 1000, []
    for name, emission in observers().items():
        reference = views(truth, cameras, settings, emission)
        for lo, hi in BANDS_K:
            band = (temp >= lo) & (temp < hi)
            for shift in SHIFTS_K:
                moved = np.where(band, temp + shift, temp)
                rows.append({"observer": name, "band_K": [lo, hi], "voxels": int(band.sum()),
                             "share_of_hot": float(band[hot].mean()), "shift_K": shift,
                             "rmse_hot_K": float(np.sqrt(np.mean((moved - temp)[hot] ** 2))),
                             "data_term": data_term(truth, moved, cameras, settings, emission,
                                                    reference)})  # fmt: skip
                print(json.dumps(rows[-1]), flush=True)
    args.out.write_text(json.dumps({"size": args.size, "pixels": args.pixels, "views": 12,
                                    "rows": rows}, indent=1) + "\n")  # fmt: skip


if __name__ == "__main__":
    main()

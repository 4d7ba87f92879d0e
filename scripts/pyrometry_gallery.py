"""Render the pictures of docs/pyrometry.md: the synthetic laminar flame as the eye sees it, its
raw Bayer exposure (and a demosaiced preview), the two-colour temperature map against the
emission-weighted truth, the Abel-inverted radial temperature against the field, and the
line-of-sight and axisymmetry errors of pyrometry on a simulated (non-axisymmetric) fire.

    python scripts/pyrometry_gallery.py --out docs          # docs/pyrometry/*.png
    python scripts/pyrometry_gallery.py --out /tmp/x --quick
"""

from __future__ import annotations

import argparse
import io
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from docpage import PageImages

import incandescent as inc
from incandescent.imaging.pipeline import display_pixels
from incandescent.photograph import photograph
from incandescent.pyrometry import RatioTable, superpixels, temperature_map
from incandescent.pyrometry.abel import self_absorption_corrected
from incandescent.pyrometry.table import channel_rates, emissivity
from incandescent.scenes import SCENES, laminar
from incandescent.sensor import Sensor


def _figure_pixels(fig) -> np.ndarray:
    """A matplotlib figure as 8-bit RGB pixels."""
    import matplotlib.pyplot as plt
    from PIL import Image

    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=100, bbox_inches="tight")
    plt.close(fig)
    buffer.seek(0)
    return np.asarray(Image.open(buffer).convert("RGB"))


def _maps(panels, title: str) -> np.ndarray:
    """Side-by-side images with colour bars: (array, label, cmap, vmin, vmax) each."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(panels), figsize=(2.6 * len(panels), 5.2))
    for ax, (data, label, cmap, low, high) in zip(np.atleast_1d(axes), panels, strict=True):
        shown = ax.imshow(data, cmap=cmap, vmin=low, vmax=high, interpolation="nearest")
        ax.set_title(label, fontsize=9)
        ax.set_xticks([])
        ax.set_yticks([])
        fig.colorbar(shown, ax=ax, fraction=0.08)
    fig.suptitle(title, fontsize=10)
    return _figure_pixels(fig)


def _mosaic_closeup(mosaic: np.ndarray, sensor: Sensor, size: int = 48, zoom: int = 6):
    """A ``size``² crop of the mosaic at mid-height, left of centre (the soot ring's edge), each
    photosite drawn in its filter's colour at its DN above black, ``zoom`` × enlarged."""
    height, width = mosaic.shape
    size = min(size, width // 2, height // 2) & ~1
    top, left = (height // 2) & ~1, (width // 2 - size) & ~1
    crop = mosaic[top : top + size, left : left + size].astype(np.float64)
    level = np.clip(
        (crop - sensor.black_level_dn) / max(crop.max() - sensor.black_level_dn, 1), 0, 1
    )
    rgb = np.zeros(crop.shape + (3,))
    channel = sensor.channel_map(size, size)
    for c in range(3):
        rgb[..., c] = np.where(channel == c, level, 0.0)
    big = np.repeat(np.repeat(rgb, zoom, axis=0), zoom, axis=1)
    return (255 * big**0.5).astype(np.uint8)


def emission_weighted_T(volume, sensor, alpha: float) -> np.ndarray:
    """Per voxel column along −z: Σ T·w / Σ w, w = κ·ė_G(T)·Tr to the camera (rows top down)."""
    temp, kappa = volume.temperature_K.astype(np.float64), volume.absorption_per_m.astype(float)
    grid = np.arange(250.0, 3000.0)
    green = np.interp(temp, grid, channel_rates(sensor, grid, emissivity(None, alpha))[:, 1])
    behind = np.cumsum(kappa[:, :, ::-1], axis=2)[:, :, ::-1] - kappa
    w = kappa * green * np.exp(-behind * volume.voxel_size_m)
    with np.errstate(invalid="ignore"):
        out = ((w * temp).sum(axis=2) / w.sum(axis=2)).T[::-1]
    if out.shape[1] % 2 == 0:  # the camera's odd last column lies outside the box
        out = np.pad(out, ((0, 0), (0, 1)), constant_values=np.nan)
    return out


def side_view(volume) -> tuple[inc.Camera, inc.RenderSettings]:
    """An orthographic camera along −z, one superpixel per voxel (the mosaic at half a voxel),
    an odd number of superpixel columns (Abel's axis on the middle one)."""
    n, ny, _ = volume.shape
    low, high = volume.bounds_m
    centre = 0.5 * (np.asarray(low) + np.asarray(high))
    centre[0] = low[0] + (n // 2 + 0.5) * volume.voxel_size_m  # voxel n//2's centre: column n//2
    n |= 1
    camera = inc.Camera(eye=(centre[0], centre[1], high[2] + 1.0), target=tuple(centre),
                        projection="orthographic",
                        ortho_height_m=ny * volume.voxel_size_m)  # fmt: skip
    return camera, inc.RenderSettings(width=2 * n, height=2 * ny, jitter=False)


def flame_pages(page: PageImages, voxel_m: float) -> dict[str, float]:
    """The laminar flame's pictures; returns the figures the page quotes."""
    volume = laminar.laminar_flame(voxel_m)
    camera, settings = side_view(volume)
    eye = inc.render(volume, camera, settings.replace(width=settings.width // 2,
                                                      height=settings.height // 2))  # fmt: skip
    page.add("flame_eye", display_pixels(eye), "the laminar flame, as the eye sees it")
    sensor = Sensor(exposure_s=3.5e-3)
    shot = photograph(volume, camera, settings, sensor, "cpu", seed=3)
    page.add("flame_raw", _mosaic_closeup(shot.mosaic, sensor),
             "the raw Bayer mosaic at mid-height, each photosite in its filter's "
             "colour")  # fmt: skip
    table = RatioTable.of(sensor, alpha=laminar.SOOT_ALPHA)
    result = temperature_map(shot.mosaic, sensor, table, calibration=1.0, max_sigma_K=20.0)
    truth = emission_weighted_T(volume, sensor, laminar.SOOT_ALPHA)
    error = result.temperature_K - truth
    page.add("flame_maps", _maps([
        (result.temperature_K, "pyrometry T (K)", "inferno", 1200, 2000),
        (np.where(result.usable, truth, np.nan), "emission-weighted T (K)", "inferno", 1200, 2000),
        (error, "error (K)", "coolwarm", -50, 50),
        (result.sigma_K, "predicted σ_T (K)", "viridis", 0, 20),
    ], "line of sight: calibrated two-colour pyrometry of the raw exposure"), "maps")  # fmt: skip
    field = self_absorption_corrected(superpixels(shot.mosaic, sensor), table, voxel_m, sensor)
    heights = (np.arange(field.temperature_K.shape[0])[::-1] + 0.5) * voxel_m
    true_t, fv = laminar.fields(field.radius_m[None, :], heights[:, None])
    sooty = fv > 0.3 * laminar.PEAK_FV
    page.add("flame_abel", _maps([
        (field.temperature_K, "Abel T(r) (K)", "inferno", 1200, 2000),
        (np.where(sooty, true_t, np.nan), "true T(r), soot ring (K)", "inferno", 1200, 2000),
        (np.where(sooty, field.temperature_K - true_t, np.nan), "error (K)", "coolwarm", -100,
         100),
    ], "radial: BASEX inversion corrected for self-absorption (axis on the left)"),
        "abel")  # fmt: skip
    usable = result.usable
    return {"usable": float(usable.mean()), "mean_error": float(np.nanmean(error[usable])),
            "worst": float(np.nanmax(np.abs(error[usable])))}  # fmt: skip


def fire_pages(page: PageImages) -> dict[str, float]:
    """Pyrometry of the simulated campfire (not axisymmetric): its line-of-sight error and what
    an Abel inversion, which assumes symmetry, makes of it against the true central plane."""
    volume = SCENES["fire"].build(None)
    camera, settings = side_view(volume)
    sensor = Sensor(exposure_s=1e-3)
    rates_peak = photograph(volume, camera, settings, sensor, "cpu", noise=False).electrons.max()
    sensor = Sensor(exposure_s=1e-3 * 0.6 * sensor.full_well_e / rates_peak)
    shot = photograph(volume, camera, settings, sensor, "cpu", seed=5)
    alpha = volume.soot_alpha
    table = RatioTable.of(sensor, alpha=alpha)
    result = temperature_map(shot.mosaic, sensor, table, calibration=1.0, max_sigma_K=20.0)
    truth = emission_weighted_T(volume, sensor, alpha)
    error = result.temperature_K - truth
    n = volume.shape[0]
    field = self_absorption_corrected(superpixels(shot.mosaic, sensor), table,
                                      volume.voxel_size_m, sensor)  # fmt: skip
    plane = volume.temperature_K[n // 2 :, :, volume.shape[2] // 2].T[::-1]  # x ≥ axis, y down
    cols = min(plane.shape[1], field.temperature_K.shape[1])
    abel_error = field.temperature_K[:, :cols] - plane[:, :cols]
    page.add("fire_maps", _maps([
        (result.temperature_K, "pyrometry T (K)", "inferno", 900, 2100),
        (error, "line-of-sight error (K)", "coolwarm", -100, 100),
        (field.temperature_K, "Abel T(r) (K)", "inferno", 900, 2100),
        (abel_error, "Abel − central plane (K)", "coolwarm", -300, 300),
    ], "a simulated campfire: the line of sight, and Abel's symmetry assumption"),
        "fire")  # fmt: skip
    usable = result.usable
    abel_ok = np.isfinite(abel_error)
    return {"fire_mean": float(np.nanmean(error[usable])),
            "fire_p95": float(np.nanpercentile(np.abs(error[usable]), 95)),
            "abel_median": float(np.nanmedian(np.abs(abel_error[abel_ok])))}  # fmt: skip


def main(argv: Sequence[str] | None = None) -> list[Path]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path(__file__).resolve().parents[1] / "docs")
    parser.add_argument("--quick", action="store_true", help="coarse renders (for tests)")
    args = parser.parse_args(argv)
    page = PageImages(args.out, "pyrometry", "scripts/pyrometry_gallery.py")
    figures = flame_pages(page, 8e-4 if args.quick else 2e-4)
    figures |= fire_pages(page)
    for name, value in figures.items():
        print(f"{name}: {value:.3g}")
    return page.written


if __name__ == "__main__":
    main()

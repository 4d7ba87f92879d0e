"""Write docs/species.md and its images in docs/species/: coloured flames, sooty vs clean.

Usage::

    python scripts/species_gallery.py [--out docs] [--quick] [--backend auto]

Renders the flames of :mod:`incandescent.scenes.species` in physical mode (display pipeline, auto
exposure) and plots each emitter's spectrum at 2000 K (``species_spectrum``) against the 2000 K
blackbody with matplotlib (the ``docs`` extra). Every number on the page is computed here.
``--quick`` renders tiny images (for the tests). Files are written atomically.
"""

from __future__ import annotations

import argparse
import io
import math
import time
from collections.abc import Sequence
from pathlib import Path
from typing import NamedTuple

import numpy as np
from docpage import PageImages
from numpy.typing import NDArray

from incandescent import __version__
from incandescent.colorimetry import xyz_to_xy
from incandescent.imaging import DisplaySettings, lit_percentile, to_display
from incandescent.imaging.pipeline import display_pixels
from incandescent.renderer import HDRImage, RenderSettings, render
from incandescent.scenes import COLOURED_FLAME_NAMES, SCENES
from incandescent.scenes.species import (
    CLEAN_SPECIES,
    COLOURED_FLAMES,
    COLOURED_SOOT_PER_M,
    SOOTY_KAPPA_PER_M,
    T_ON_K,
    flame_camera,
    sooty_flame,
)
from incandescent.spectra import blackbody_xyz, planck_radiance
from incandescent.spectra.lines import T_REF_K, LineTable, load_lines, species_spectrum, species_xyz

DEFAULT_OUT = Path(__file__).resolve().parent.parent / "docs"
IMAGE_DIR = "species"
#: Spectrum plots: wavelength range (nm) and temperature (K).
PLOT_NM = (360.0, 830.0)
PLOT_K = T_REF_K
#: Temperature of the "how steeply do lines fade" column, K.
COOL_K = 1500.0
#: The display pipeline of every render: auto exposure, filmic; gamut "clip" (see the page).
DISPLAY = DisplaySettings(gamut="clip")


class Sizes(NamedTuple):
    """Sizes of one run: image width and height (px), grid n³, plot dpi."""

    width: int
    height: int
    n: int
    dpi: int


FULL = Sizes(width=240, height=320, n=128, dpi=80)
QUICK = Sizes(width=24, height=32, n=24, dpi=30)


# --- renders -----------------------------------------------------------------------------------
def render_flames(sizes: Sizes, backend: str) -> dict[str, HDRImage]:
    """Every coloured flame by name, then "sooty" and "clean" (the scenes registry); one camera."""
    settings = RenderSettings(width=sizes.width, height=sizes.height)
    camera = flame_camera()
    names = (*COLOURED_FLAME_NAMES, "sooty", "clean")
    volumes = {name: SCENES[name].build(sizes.n) for name in names}
    return {name: render(v, camera, settings, backend=backend) for name, v in volumes.items()}


def p99(image: HDRImage) -> float:
    """99th percentile of the lit pixels' luminance, cd/m² (what auto exposure maps to 0.8)."""
    return lit_percentile(image.luminance)


def image_xy(image: HDRImage) -> NDArray[np.float64]:
    """Chromaticity of the whole image's summed XYZ."""
    return xyz_to_xy(image.xyz.reshape(-1, 3).sum(axis=0))


# --- spectra -----------------------------------------------------------------------------------
def wavelengths() -> NDArray[np.float64]:
    """The plots' 1 nm grid over :data:`PLOT_NM` (the CMF grid, on which lines are deposited)."""
    return np.arange(PLOT_NM[0], PLOT_NM[1] + 0.5, 1.0)


def swatch(xyz: NDArray[np.float64]) -> tuple[float, float, float]:
    """Display colour (0..1 sRGB) of an emitter's chromaticity, for its plot."""
    unit = np.asarray(xyz, dtype=np.float64) / xyz[1]
    rgb = to_display(unit[None, None] * 0.6, DisplaySettings(auto_exposure=False, gamut="clip"))
    r, g, b = (float(c) / 255.0 for c in rgb[0, 0])
    return r, g, b


def spectrum_png(
    table: LineTable, species: dict[str, float], title: str, dpi: int, soot_kappa: float = 0.0
) -> NDArray[np.uint8]:
    """Log plot of f·S_species(λ, 2000 K) per species (fraction f) and of the 2000 K blackbody
    (× κ when ``soot_kappa`` > 0, else per unit optical depth); returns RGB pixels."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from PIL import Image

    lam = wavelengths()
    bb = planck_radiance(lam, PLOT_K) * (soot_kappa if soot_kappa > 0 else 1.0)
    fig, ax = plt.subplots(figsize=(4.8, 2.6), dpi=dpi)
    bb_label = f"blackbody {PLOT_K:.0f} K" + (f" × κ={soot_kappa:g}/m" if soot_kappa else "")
    ax.plot(lam, bb, color="0.35", ls="--", lw=1.2, label=bb_label)
    top = float(bb.max())
    for name, fraction in species.items():
        s = fraction * species_spectrum(table, name, PLOT_K, lam)
        x, y = xyz_to_xy(species_xyz(table, name, PLOT_K))
        colour = swatch(species_xyz(table, name, PLOT_K))
        label = (
            f"{name}" + (f" × {fraction:g}" if fraction != 1 else "") + f"  (x,y={x:.2f},{y:.2f})"
        )
        ax.fill_between(lam, 1e-3, np.maximum(s, 1e-3), color=colour, alpha=0.55, lw=0)
        ax.plot(lam, s, color=colour, lw=1.0, label=label)
        top = max(top, float(s.max()))
    ax.set_yscale("log")
    ax.set_ylim(0.1, top * 60.0)  # headroom for the legend
    ax.set_xlim(*PLOT_NM)
    ax.set_xlabel("wavelength (nm)", fontsize=8)
    ax.set_ylabel("W sr⁻¹ m⁻² nm⁻¹", fontsize=8)
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=7, loc="upper left", frameon=False, ncol=2)
    ax.tick_params(labelsize=7)
    fig.tight_layout(pad=0.3)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    plt.close(fig)
    buf.seek(0)
    with Image.open(buf) as im:
        return np.asarray(im.convert("RGB"), dtype=np.uint8)


def band_power(table: LineTable, species: str) -> float:
    """Radiant power (W·sr⁻¹·m⁻² per m of path) of ``species`` at its clean-flame fraction and
    :data:`PLOT_K` over :data:`PLOT_NM`."""
    spectrum = species_spectrum(table, species, PLOT_K, wavelengths())
    return float(CLEAN_SPECIES[species] * spectrum.sum())  # 1 nm grid


# --- tables ------------------------------------------------------------------------------------
def provenance(table: LineTable, species: str) -> str:
    """ "n rows: sources; k marked estimate" for one species, from the table's source column."""
    rows = table.rows_of(species)
    sources = [table.source[i] for i in rows]
    origins = sorted({s.split(":")[0].strip() for s in sources})
    estimates = sum("estimate" in s for s in sources)
    lines = int(np.sum(table.width_nm[rows] == 0))
    bands = len(rows) - lines
    return (
        f"{lines} line(s), {bands} band(s); {', '.join(origins)}; "
        f"{estimates} of {len(rows)} rows marked estimate"
    )


def species_rows(table: LineTable) -> list[str]:
    """Markdown rows: species, x y at 2000 K, Y(1500 K)/Y(2000 K), strongest row, provenance."""
    bb_ratio = float(blackbody_xyz(COOL_K)[1] / blackbody_xyz(PLOT_K)[1])
    out = [f"| blackbody | — | {bb_ratio:.3f} | continuum | Planck's law |"]
    names = [f.species for f in COLOURED_FLAMES] + list(CLEAN_SPECIES)
    for name in names:
        xyz = species_xyz(table, name, [COOL_K, PLOT_K])
        x, y = xyz_to_xy(xyz[1])
        rows = table.rows_of(name)
        strongest = rows[int(np.argmax(table.relative_intensity[rows]))]
        ratio = float(xyz[0, 1] / xyz[1, 1])
        out.append(
            f"| {name} | {x:.3f}, {y:.3f} | {ratio:.3f} | "
            f"{table.wavelength_nm[strongest]:g} nm (E_u {table.upper_energy_eV[strongest]:g} eV) "
            f"| {provenance(table, name)} |"
        )
    return out


# --- the page ----------------------------------------------------------------------------------
def markdown(images: dict[str, str], facts: dict[str, object], rows: list[str]) -> str:
    """The whole docs/species.md text; ``images`` maps keys to paths relative to the page."""
    flame_rows = "\n".join(
        f"| {f.name} ({f.species}) — {f.colour} | ![{f.name} flame]({images[f.name]}) "
        f"| ![{f.species} spectrum]({images[f'{f.name}_spectrum']}) |"
        for f in COLOURED_FLAMES
    )
    return _PAGE.format(
        version=__version__,
        flame_rows=flame_rows,
        sooty=images["sooty"],
        clean=images["clean"],
        pair_spectrum=images["pair_spectrum"],
        species_rows="\n".join(rows),
        t_on=T_ON_K,
        t_ref=PLOT_K,
        cool=COOL_K,
        coloured_soot=COLOURED_SOOT_PER_M,
        sooty_kappa=SOOTY_KAPPA_PER_M,
        clean_species=", ".join(f"{k} {v:g}" for k, v in CLEAN_SPECIES.items()),
        y_bb=float(blackbody_xyz(PLOT_K)[1]),
        **facts,
    )


_PAGE = """# Gallery: coloured flames and sooty vs clean flames

<!-- Generated by scripts/species_gallery.py (incandescent {version}); do not edit by hand. -->

Flames with emitting species (`incandescent.scenes.species`), rendered in physical mode and shown
through the display pipeline (auto exposure: 99th percentile of the lit luminance → 0.8, filmic
tone map, sRGB). Each emitter's spectrum at {t_ref:.0f} K is plotted next to its flame. Regenerate
with `python scripts/species_gallery.py --out docs` ({size} renders of {n}³ grids; needs
matplotlib, the `docs` extra).

**Scenes.** Every flame is the plume of `incandescent.scenes.plume_temperature` (1 m box, hottest
voxel {t_ref:.0f} K). Species fractions and soot κ *follow the hot gas*: each is its peak value
times w(T) = clip((T − {t_on:.0f} K)/(T_max − {t_on:.0f} K), 0, 1). The coloured flames hold one
species at peak fraction 1 over a faint soot continuum (κ = {coloured_soot:g}/m in the core); the
sooty flame has soot κ = {sooty_kappa:g}/m in the core and no line emitters; the clean flame has
κ = 0 and the CH* and C2 Swan bands (peak fractions {clean_species}). Camera: `flame_camera()`,
a front view.

**Physics of the lines** (`incandescent.spectra.lines`).

- Each line or band j of a species has emitted power P_j(T) = I_j · exp(−E_u,j/k·(1/T − 1/T_ref)),
  i.e. a constant strength times the Boltzmann factor exp(−E_u/kT) of its upper level (local
  thermodynamic equilibrium), with I_j the table's relative intensity at T_ref = {t_ref:.0f} K.
  Lines with higher E_u fade faster as the gas cools: the column Y(1500 K)/Y(2000 K) below.
- A line table has no absolute strength, so each species is normalised (a documented convention,
  not physics): at fraction 1 and T_ref its luminance per metre of path equals that of a
  {t_ref:.0f} K blackbody per unit optical depth, Y = {y_bb:.3g} cd/m². A voxel emits
  f · species_xyz(T) per metre; fraction 1 of a species is "as bright as soot of κ = 1/m at
  {t_ref:.0f} K" there, with its own colour.
- Lines are optically thin and emission only: they add light but absorb nothing, so a coloured
  flame never saturates and the gas behind it shows through; only the soot κ absorbs. Soot is
  grey here (the LUT renderer); real soot absorbs more in the blue.
- Atomic lines have zero width and are deposited onto the 1 nm grid preserving their power (hence
  the spikes in the plots, in W·sr⁻¹·m⁻²·nm⁻¹ per unit path at fraction 1 — one line holds the
  luminance the blackbody spreads over the whole spectrum, so the y axes are logarithmic); molecular
  bands are Gaussians of the tabulated FWHM.

## Coloured flames

| flame | render | spectrum at {t_ref:.0f} K (log scale) |
|:---|:---:|:---:|
{flame_rows}

Each render is exposed on its own (auto exposure), so these show colour, not relative brightness:
the brightest (99th-percentile luminance) is {bright_name}, {bright_ratio:.1f}× the dimmest,
{dim_name}. Whole-image chromaticities (x, y): {image_xys}.

- **Sodium** is the D doublet at 589.0/589.6 nm: a pure spectral yellow-orange.
- **Lithium** (670.8 nm) and **strontium** (SrOH/SrCl bands 606–682 nm) lie outside the sRGB
  gamut (x ≈ 0.73 and 0.67): the display can only show them as its reddest red; strontium's
  orange SrOH band makes it a little less deep.
- **Copper** here is the CuCl blue band system (429–452 nm, with weaker blue-green and green
  bands), as in chlorinated pyrotechnic flames; copper without chlorine burns green (CuOH), which
  the table does not list.
- **Barium** is the BaCl green bands (507–532 nm) with the Ba I 553.5 nm line.

## Sooty vs clean flame

| sooty (κ = {sooty_kappa:g}/m core, no lines) | clean (κ = 0; CH*, C2) |
|:---:|:---:|
| ![sooty flame]({sooty}) | ![clean flame]({clean}) |

![CH and C2 spectra against the soot continuum]({pair_spectrum})

- **Sooty:** the soot is a blackbody emitter of emissivity 1 − e^(−τ), so its colour is that of
  the gas temperature (orange at ≤ {t_ref:.0f} K) and the core, with optical depth up to
  {sooty_tau:.1f} along the view, partly hides the gas behind it.
- **Clean:** no continuum at all; the CH* 431 nm band and the C2 Swan bands (438–619 nm, strongest
  516.5 nm) at equal radiant power (CH*/C2 power ratio {power_ratio:.2f} at {t_ref:.0f} K; the
  fractions are in luminance units, and the eye is far less sensitive at 431 nm) give a cyan-blue
  (x, y = {clean_xy}). Real blue flames owe these bands largely to chemiluminescence in the thin
  reaction zone, not to thermal excitation of the whole hot gas as modelled here.
- **Brightness:** with the same exposure the sooty flame would look {pair_ratio:.1f}× brighter
  (99th-percentile luminance): soot of κ = {sooty_kappa:g}/m emits, per metre, like
  {sooty_kappa:g} units of species fraction at {t_ref:.0f} K, and the clean flame's bands are
  optically thin.

## The line table: what the numbers rest on

`src/incandescent/spectra/data/lines.csv` cites every row (its `source` column). Atomic lines
(wavelength in air and upper-level energy E_u) are from the NIST Atomic Spectra Database, with
relative intensities within a multiplet computed for LTE at {t_ref:.0f} K from NIST transition
probabilities (K 404 nm and Cu I A_ki uncertain by tens of per cent). Molecular bands (SrOH, SrCl,
BaCl, CaOH, CuCl) follow Meyerriecks & Kosanke, J. Pyrotechnics 18 (2003), and CH/C2 follow Pearse &
Gaydon (1976): their centres are approximate (±2 nm) and their widths, intensities and the
line-to-band ratio within a species are **estimates** chosen to reproduce the flame colours, not
tabulated values; for bands "E_u" is roughly the photon energy. Colours of band emitters are
therefore good to the hue, not to a measured chromaticity; temperature trends of bands carry the
E_u uncertainty.

| species | x, y at {t_ref:.0f} K | Y({cool:.0f} K)/Y({t_ref:.0f} K) | strongest row \
| rows: provenance |
|:---|---:|---:|:---|:---|
{species_rows}

**Display.** The pipeline's default gamut map desaturates *after* the tone curve; for these
colours, far outside sRGB, the tone-mapped negative components outweigh the positive ones, the
luminance it preserves becomes ≤ 0, and the brightest parts of the lithium and strontium flames
(and of CH-dominated violet) turned black, leaving a hollow outline. This page therefore uses
`DisplaySettings(gamut="clip")`, which only removes negative components (hue and luminance shift a
little, nothing turns black).
"""


def main(argv: Sequence[str] | None = None) -> list[Path]:
    """Write species.md and species/*.png into ``--out``; return the paths written (page last)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT, help="output folder (docs)")
    parser.add_argument("--quick", action="store_true", help="tiny renders (for tests)")
    parser.add_argument("--backend", default="auto", help="render backend (default auto)")
    args = parser.parse_args(argv)
    sizes = QUICK if args.quick else FULL
    start = time.perf_counter()
    table = load_lines()
    page = PageImages(args.out, IMAGE_DIR, "scripts/species_gallery.py")
    emit = page.add
    images = render_flames(sizes, args.backend)
    for name, image in images.items():
        emit(name, display_pixels(image, DISPLAY), f"species_scenes {name} flame, physical")
    for flame in COLOURED_FLAMES:
        title = f"{flame.name} ({flame.species}) at {PLOT_K:.0f} K, per unit path, fraction 1"
        emit(
            f"{flame.name}_spectrum",
            spectrum_png(table, {flame.species: 1.0}, title, sizes.dpi),
            title,
        )
    pair_title = f"clean flame bands vs sooty flame continuum at {PLOT_K:.0f} K"
    emit(
        "pair_spectrum",
        spectrum_png(table, dict(CLEAN_SPECIES), pair_title, sizes.dpi, SOOTY_KAPPA_PER_M),
        pair_title,
    )

    coloured = {f.name: p99(images[f.name]) for f in COLOURED_FLAMES}
    bright = max(coloured, key=coloured.__getitem__)
    dim = min(coloured, key=coloured.__getitem__)
    clean_xy = image_xy(images["clean"])
    soot = sooty_flame(sizes.n)
    sooty_tau = float(soot.absorption_per_m.sum(axis=2).max()) * soot.voxel_size_m
    facts = {
        "size": f"{sizes.width}×{sizes.height}",
        "n": sizes.n,
        "bright_name": bright,
        "dim_name": dim,
        "bright_ratio": coloured[bright] / coloured[dim] if coloured[dim] > 0 else math.inf,
        "image_xys": "; ".join(
            f"{f.name} {x:.2f}, {y:.2f}"
            for f in COLOURED_FLAMES
            for x, y in [image_xy(images[f.name])]
        ),
        "clean_xy": f"{clean_xy[0]:.2f}, {clean_xy[1]:.2f}",
        "pair_ratio": p99(images["sooty"]) / max(p99(images["clean"]), 1e-300),
        "power_ratio": band_power(table, "CH") / band_power(table, "C2"),
        "sooty_tau": sooty_tau,
    }
    written = page.page("species.md", markdown(page.links, facts, species_rows(table)))
    print(f"species gallery: {time.perf_counter() - start:.1f} s")
    return written


if __name__ == "__main__":
    main()

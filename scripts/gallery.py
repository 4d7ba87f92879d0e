"""Write docs/gallery.md and its images in docs/gallery/: the 2011 paper's method vs ours.

Usage::

    python scripts/gallery.py [--out docs] [--quick] [--backend auto]

Renders the paper's scenes (:mod:`incandescent.scenes.paper`) with both integrators —
the ``paper2011`` integrator (Zonenberg & Forrest 2011, §4) and ``emission_absorption`` — draws the
blackbody colour strip under both colour models and tabulates the chromaticity shift caused by the
paper's 380–650 nm truncation (:func:`incandescent.spectra.paper2011.truncation_shift_uv`). Every
number on the page is computed here. ``--quick`` renders tiny images (for the tests). Images and
the page are written atomically (a temporary file moved into place).
"""

from __future__ import annotations

import argparse
import math
import time
from collections.abc import Sequence
from pathlib import Path
from typing import NamedTuple

import numpy as np
from docpage import PageImages, draw_kelvin_ticks
from numpy.typing import NDArray

from incandescent import __version__, blackbody_xyz
from incandescent.animation import plate_camera
from incandescent.colorimetry import xyz_to_uv_prime
from incandescent.imaging import DisplaySettings, auto_exposure_scale, lit_percentile, to_display
from incandescent.imaging.pipeline import display_pixels
from incandescent.renderer import EmissionAbsorption, HDRImage, Paper2011, RenderSettings, render
from incandescent.renderer.integrators.paper2011 import PAPER_GAIN, PAPER_MIN_K
from incandescent.scenes.paper import PlateScene, paper_sphere
from incandescent.spectra.paper2011 import paper_rgb, paper_spectrum_xyz, truncation_shift_uv

DEFAULT_OUT = Path(__file__).resolve().parent.parent / "docs"
IMAGE_DIR = "gallery"
#: Plate frames shown: before, at (104–105: the paper's triangular artifact) and after edge cooling.
PLATE_FRAMES = (60, 104, 105, 180)
#: Temperatures of the truncation table, K.
TRUNCATION_K = (800, 1000, 1500, 2000, 3000, 4000, 6500, 10_000)
#: Blackbody strip: temperature range (log scale), ticks, band and label heights (pixels).
T_LOW_K, T_HIGH_K = 800.0, 12_000.0
TICKS_K = (800, 1000, 1500, 2000, 3000, 4000, 6500, 10_000, 12_000)
BAND_HEIGHT, LABEL_HEIGHT = 40, 16
#: Exposure (stops) of the physical strip band: Y = 1 maps to 2^-0.5 ≈ 0.71 before tone mapping
#: (as in docs/blackbody.md).
STRIP_EV = -0.5


class Sizes(NamedTuple):
    """Image sizes of one run."""

    width: int
    height: int
    sphere_n: int
    strip_width: int


FULL = Sizes(width=320, height=240, sphere_n=64, strip_width=1024)
QUICK = Sizes(width=32, height=24, sphere_n=16, strip_width=192)


# --- renders -----------------------------------------------------------------------------------
def _settings(sizes: Sizes) -> RenderSettings:
    return RenderSettings(width=sizes.width, height=sizes.height)


#: The two transports compared: the paper's sums and emission–absorption.
INTEGRATORS = {"paper": Paper2011(), "physical": EmissionAbsorption()}


def render_sphere_pair(sizes: Sizes, backend: str) -> dict[str, HDRImage]:
    """The soot sphere (paper Fig. 2) with both integrators, default camera."""
    volume = paper_sphere(sizes.sphere_n)
    return {
        mode: render(volume, settings=_settings(sizes), backend=backend, integrator=integrator)
        for mode, integrator in INTEGRATORS.items()
    }


def render_plate_frames(
    sizes: Sizes, backend: str, scene: PlateScene | None = None
) -> tuple[dict[int, dict[str, HDRImage]], dict[int, float]]:
    """:data:`PLATE_FRAMES` of the plate video with both integrators, one fixed camera.

    Returns the images by frame and mode, and each frame's hottest gas temperature (K).
    """
    scene = scene or PlateScene()
    camera = plate_camera(scene)
    images: dict[int, dict[str, HDRImage]] = {}
    hottest: dict[int, float] = {}
    for index in PLATE_FRAMES:
        temperature = scene.frame(index)
        hottest[index] = float(temperature.max())
        volume = scene.volume(temperature)
        images[index] = {
            mode: render(volume, camera, _settings(sizes), backend=backend, integrator=integrator)
            for mode, integrator in INTEGRATORS.items()
        }
    return images, hottest


def auto_ev(image: HDRImage) -> float:
    """The default auto exposure of ``image`` in stops (99th percentile of lit luminance → 0.8)."""
    return math.log2(auto_exposure_scale(image.luminance))


def plate_display(physical: Sequence[HDRImage]) -> DisplaySettings:
    """One fixed exposure for all physical plate frames: the mean, in stops, of each frame's own
    auto exposure.

    Exposing every frame like the hottest one (``fixed_display``'s choice for the demo video) is
    set by the freshly heated ~9500 K gas, which leaves the cooled frames nearly black; the mean
    puts every frame within a few stops of its own auto exposure.
    """
    ev = float(np.mean([auto_ev(image) for image in physical]))
    return DisplaySettings(auto_exposure=False, exposure_ev=ev)


def saturated_fraction(pixels: NDArray[np.uint8]) -> float:
    """Fraction of the lit pixels (any channel > 0) with some channel at 255."""
    lit = pixels.max(axis=-1) > 0
    if not lit.any():
        return 0.0
    return float((pixels[lit].max(axis=-1) == 255).mean())


# --- blackbody strip ---------------------------------------------------------------------------
def strip_temperatures_K(width: int) -> NDArray[np.float64]:
    """One temperature per pixel column, logarithmically spaced from 800 K to 12 000 K."""
    return np.geomspace(T_LOW_K, T_HIGH_K, width)


def physical_strip_rgb8(temperatures_K: NDArray[np.float64]) -> NDArray[np.uint8]:
    """Blackbody colour at Y = 1 through ``to_display`` at a fixed exposure, shape (W, 3)."""
    xyz = blackbody_xyz(temperatures_K)
    unit = xyz / xyz[:, 1:2]
    settings = DisplaySettings(auto_exposure=False, exposure_ev=STRIP_EV)
    return to_display(unit[None], settings)[0]


def paper_strip_rgb8(temperatures_K: NDArray[np.float64]) -> NDArray[np.uint8]:
    """The paper's normalised colour ``paper_rgb(T) / T^1.5`` (max component 1) × 255, (W, 3).

    These are the values the paper's renderer sums and writes out directly: no tone map, no
    transfer function.
    """
    rgb = paper_rgb(temperatures_K) / (temperatures_K**1.5)[:, None]
    return np.round(np.clip(rgb, 0.0, 1.0) * 255.0).astype(np.uint8)


def strip_image(width: int) -> NDArray[np.uint8]:
    """Physical band over paper band over a tick row, (2·BAND_HEIGHT + LABEL_HEIGHT, width, 3)."""
    temps = strip_temperatures_K(width)
    physical = np.broadcast_to(physical_strip_rgb8(temps), (BAND_HEIGHT, width, 3))
    paper = np.broadcast_to(paper_strip_rgb8(temps), (BAND_HEIGHT, width, 3))
    labels = np.full((LABEL_HEIGHT, width, 3), 24, dtype=np.uint8)
    return _annotate(np.concatenate([physical, paper, labels], axis=0), width)


def _annotate(image: NDArray[np.uint8], width: int) -> NDArray[np.uint8]:
    """Band names and kelvin ticks, with Pillow's default font."""
    from PIL import Image, ImageDraw, ImageFont

    canvas = Image.fromarray(np.ascontiguousarray(image))
    draw = ImageDraw.Draw(canvas)
    font = ImageFont.load_default()
    for row, name in enumerate(("physical", "paper")):
        top = row * BAND_HEIGHT + 2
        box = draw.textbbox((3, top), name, font=font)
        draw.rectangle((box[0] - 2, box[1] - 1, box[2] + 2, box[3] + 1), fill=(24, 24, 24))
        draw.text((3, top), name, fill=(230, 230, 230), font=font)
    draw_kelvin_ticks(draw, font, TICKS_K, 2 * BAND_HEIGHT, width, T_LOW_K, T_HIGH_K)
    return np.asarray(canvas, dtype=np.uint8)


# --- truncation table --------------------------------------------------------------------------
def truncation_rows(temperatures_K: Sequence[float] = TRUNCATION_K) -> list[str]:
    """Markdown rows: T, Δu′v′, u′v′ of the full blackbody, u′v′ of the paper's 19 samples."""
    temps = np.asarray(temperatures_K, dtype=np.float64)
    shift = truncation_shift_uv(temps)
    full = xyz_to_uv_prime(blackbody_xyz(temps, constants="paper"))
    paper = xyz_to_uv_prime(paper_spectrum_xyz(temps))
    return [
        f"| {t:.0f} | {d:.4f} | {fu:.4f}, {fv:.4f} | {pu:.4f}, {pv:.4f} |"
        for t, d, (fu, fv), (pu, pv) in zip(temps, shift, full, paper, strict=True)
    ]


# --- the page ----------------------------------------------------------------------------------
def _luminance_ratio(t_low: float, t_high: float) -> float:
    lum = blackbody_xyz([t_low, t_high])[:, 1]
    return float(lum[1] / lum[0])


def markdown(images: dict[str, str], facts: dict[str, object]) -> str:
    """The whole docs/gallery.md text; ``images`` maps keys to paths relative to the page."""
    plate_rows = "\n".join(
        f"| {f} | ![paper, frame {f}]({images[f'plate_{f}_paper']}) "
        f"| ![physical, frame {f}]({images[f'plate_{f}_physical']}) |"
        for f in PLATE_FRAMES
    )
    return _PAGE.format(
        version=__version__,
        sphere_paper=images["sphere_paper"],
        sphere_physical=images["sphere_physical"],
        plate_rows=plate_rows,
        strip=images["strip"],
        truncation_rows="\n".join(truncation_rows()),
        frames=", ".join(str(f) for f in PLATE_FRAMES),
        min_K=PAPER_MIN_K,
        gain=PAPER_GAIN,
        strip_ev=STRIP_EV,
        t_low=T_LOW_K,
        t_high=T_HIGH_K,
        **facts,
    )


_PAGE = """# Gallery: the 2011 paper's method vs physical rendering

<!-- Generated by scripts/gallery.py (incandescent {version}); do not edit by hand. -->

The scenes of Zonenberg & Forrest (2011) rendered twice: with the `paper2011` integrator, which
reproduces the paper's §4 colour model, and with `emission_absorption`, the default. Regenerate
with `python scripts/gallery.py --out docs` ({size} renders).

**What differs, and why.**

- **Physical** (`[integrator] type = "emission_absorption"`): every sample emits absolute Planck
  radiance κ(T)·B_λ(T) and absorbs with the same κ (Kirchhoff's law: a medium emits only as much
  as it absorbs), so the radiance along a ray is L = ∫ κ B_λ(T) e^(−τ) ds over 360–830 nm, in
  cd/m². A thick or long column of gas saturates towards the blackbody radiance of its temperature
  instead of growing without bound, and gas behind hot gas is partly hidden. Brightness depends on
  temperature as nature does: from 1000 K to 10 000 K the luminance of a blackbody grows by a
  factor {lum_1k_10k:.1e}. The display pipeline (exposure, filmic tone map, desaturating gamut
  map, sRGB encoding) is applied afterwards, to the finished image.
- **Paper** (`[integrator] type = "paper2011"`): each voxel's colour is the blackbody
  *chromaticity* (19 Planck samples 380–650 nm × the CIE 1931 functions → x, y, z → sRGB matrix →
  negatives clamped → largest component 1) times T^1.5, an exponent the paper chose "for a
  manageable dynamic range": 1000 K to 10 000 K is only a factor 10^1.5 ≈ 32. These display values
  are summed along the ray with no absorption and capped at 255 per channel. Brightness is
  therefore proportional to path length, long paths clip, and because the red channel reaches 255
  first the clipped parts of orange gas turn yellow and then white.
- **Our choices for what the paper leaves open** (see docs/paper2011.md):
  samples below `min_K` = {min_K:.0f} K contribute nothing (without a threshold 300 K air
  would glow at about 3 % of 3000 K gas per voxel, since 300^1.5 / 3000^1.5 ≈ 0.03), and
  `gain` = {gain:.4g} per voxel of path, so that 32 voxels of 3000 K gas sum to 255.

## Soot sphere (paper Fig. 2)

`paper_sphere()`: a {sphere_n}³ sphere of transparent soot at 3000 K (optical depth 0.5 along
a diameter), default camera.

| paper | physical |
|:---:|:---:|
| ![soot sphere, paper mode]({sphere_paper}) | ![soot sphere, physical]({sphere_physical}) |

- **Paper:** a chord through the centre crosses {sphere_n} voxels of ~3000 K gas,
  {sphere_ratio:.1f}× the 32 that sum to 255, so the middle clips — the paper's "saturation of
  intensity at center of image" ({sphere_clipped:.0%} of the lit pixels have a channel at 255).
  The red channel clips first, so the 3000 K orange turns yellow in the middle while the thin
  limb keeps its hue.
- **Physical:** the same chord has optical depth 0.5, so the centre emits 1 − e^(−0.5) ≈ 39 % of
  the blackbody radiance, and the brightness falls off only near the limb, where chords are short
  (the filmic curve compresses the rest); the hue is that of 3000 K everywhere except the thin
  rim where the temperature falls to ambient. Auto exposure (99th percentile
  of the lit luminance → 0.8) and the filmic tone map keep the centre from clipping
  ({sphere_phys_clipped:.0%} of the lit pixels at 255).

## Plate video (paper Figs. 3–4)

`PlateScene()`: a ~10 000 K plate flies through air at 0.8 voxels per frame and leaves a trail
of heated gas that cools. Frames {frames}, all with the same camera (`plate_camera`).
The paper mode images are the capped paper values as 8 bit. The physical images share **one fixed
exposure**, the mean (in stops) of the {n_frames} frames' own auto exposures (99th percentile of
the lit luminance → 0.8): {plate_ev:+.2f} EV. Exposing all frames for the hottest one (what
`fixed_display` does for the demo video) is set by the freshly heated ~9500 K gas beside the
plate (the plate itself is not drawn: what glows is the gas it heats) and left frame 180 nearly
black; this exposure is {plate_ev_gain:.1f} stops brighter, which moves the hot frames further
onto the tone curve's shoulder (nearly flat white) and keeps frame 180, {ev_under_180:.1f} stops
under its own auto exposure, dim but visible.

| frame | paper | physical |
|---:|:---:|:---:|
{plate_rows}

- **Brightness vs temperature.** Frame 180 (hottest gas {t180:.0f} K) is {phys_drop:.1f} stops
  darker than frame 104 ({t104:.0f} K) in the physical renders (99th-percentile luminance): the
  gas has cooled; in paper mode T^1.5 and the cap at 255 keep it almost as bright (mean pixel value
  {paper_180:.0f} vs {paper_104:.0f}).
- **Cooled gas.** A blackbody at 2000 K is {lum_9500_2000:.1e} times less luminous than at
  9500 K; the paper's T^1.5 makes that a factor {paper_9500_2000:.0f}. So in paper mode the cooled
  gas at the trailing (left) end still sums to a bright orange fringe, while physically it fades
  to a dark brown edge. In paper mode gas that cools below {min_K:.0f} K vanishes at once (the
  threshold); physically it has long been invisible by then.
- **Hue.** Physically the hottest gas is white with a slight blue cast (about 9500 K, no white
  balance: D65 is the display white); the paper's sums clip to white in the middle with orange
  edges, where the path through the gas is short.
- **Frames 104–105** are where the paper saw its triangular artifact (it appeared "once the
  leftmost column of voxels has cooled to below some threshold", frame 105; our simulation's
  x = 0 layer falls below 1000 K at frame 105 by construction). Our renders show no artifact in
  either mode: `tests/scenes/test_paper_scenes.py` checks that every frame is mirror-symmetric and
  that renders change smoothly from frame to frame around the cooling edge.

## Blackbody colours under both models

![Blackbody colours {t_low:.0f}–{t_high:.0f} K, physical over paper]({strip})

{strip_width} columns, temperature logarithmic from {t_low:.0f} K (left) to {t_high:.0f} K
(right), ticks in kelvin. Both bands show colour at a fixed brightness, not the absolute
brightness (docs/blackbody.md shows that).

- **Top — physical:** `blackbody_xyz(T)` (360–830 nm at 1 nm) normalised to Y = 1, through
  `to_display` with a fixed exposure of {strip_ev:+g} EV (filmic tone map, desaturating gamut map,
  sRGB encoding, no white balance).
- **Bottom — paper:** `paper_rgb(T) / T^1.5`, the paper's normalised colour (largest component 1)
  × 255, written as it is: the paper sums these values and writes them out without a transfer
  function. Below about 1900 K the blackbody lies outside the sRGB gamut; clamping the negative
  component makes the paper's low end pure red (green 0 at 800 K and under 4 % at 1000 K, blue 0
  up to about 2000 K) where the gamut map desaturates the physical one towards crimson and
  orange. Without the sRGB encoding the paper's warm colours stay more saturated, both bands are
  near white at 6500 K (close to D65), and the normalisation (largest channel = 1) turns the
  paper's hot end a clear blue where the physical band is a pale blue-grey.

## The 380–650 nm truncation

The paper sums 19 Planck samples from 380 to 650 nm every 15 nm, which drops the red and
infrared tail that dominates a cool blackbody's visible emission (650–830 nm). Δu′v′ is the
distance in the CIE 1976 UCS diagram between the paper's 19-sample chromaticity and the full
360–830 nm blackbody (both with the paper's Planck constants), from `truncation_shift_uv`:

| T (K) | Δu′v′ | u′, v′ full blackbody | u′, v′ paper (19 samples) |
|---:|---:|---:|---:|
{truncation_rows}

The truncated sum is always less red than the blackbody (lower u′). The shift is largest for
cool gas, whose spectrum rises steeply towards the red, so the missing 650–830 nm tail holds a
large share of what the eye sees; as T rises the spectrum flattens across the visible and the
shift falls to a few thousandths (what remains at high T is the coarse 15 nm sampling and the
cut ends together). Differences of a few thousandths in u′v′ are visible side by side; at
800–1000 K the paper's gas is noticeably less red than a real blackbody.
"""


def main(argv: Sequence[str] | None = None) -> list[Path]:
    """Write gallery.md and gallery/*.png into ``--out``; return the paths written."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT, help="output folder (docs)")
    parser.add_argument("--quick", action="store_true", help="tiny renders (for tests)")
    parser.add_argument("--backend", default="auto", help="render backend (default auto)")
    args = parser.parse_args(argv)
    sizes = QUICK if args.quick else FULL
    start = time.perf_counter()
    page = PageImages(args.out, IMAGE_DIR, "scripts/gallery.py")
    emit = page.add
    sphere = render_sphere_pair(sizes, args.backend)
    sphere_px = {mode: display_pixels(image) for mode, image in sphere.items()}
    for mode, pixels in sphere_px.items():
        emit(f"sphere_{mode}", pixels, f"paper_sphere, {mode} brightness")

    plate, hottest = render_plate_frames(sizes, args.backend)
    display = plate_display([plate[f]["physical"] for f in PLATE_FRAMES])
    paper_means = {}
    for index in PLATE_FRAMES:
        paper_px = display_pixels(plate[index]["paper"])
        paper_means[index] = float(paper_px.mean())
        emit(f"plate_{index}_paper", paper_px, f"PlateScene frame {index}, paper brightness")
        emit(
            f"plate_{index}_physical",
            display_pixels(plate[index]["physical"], display),
            f"PlateScene frame {index}, physical brightness, {display.exposure_ev:+.2f} EV",
        )
    frame_evs = {f: auto_ev(plate[f]["physical"]) for f in PLATE_FRAMES}

    emit("strip", strip_image(sizes.strip_width), "Blackbody colours: physical over paper")

    facts = {
        "size": f"{sizes.width}×{sizes.height}",
        "sphere_n": sizes.sphere_n,
        "sphere_clipped": saturated_fraction(sphere_px["paper"]),
        "sphere_phys_clipped": saturated_fraction(sphere_px["physical"]),
        "lum_1k_10k": _luminance_ratio(1000.0, 10_000.0),
        "n_frames": len(PLATE_FRAMES),
        "plate_ev": display.exposure_ev,
        "plate_ev_gain": display.exposure_ev - min(frame_evs.values()),
        "ev_under_180": frame_evs[180] - display.exposure_ev,
        "lum_9500_2000": _luminance_ratio(2000.0, 9500.0),
        "paper_9500_2000": (9500.0 / 2000.0) ** 1.5,
        "sphere_ratio": sizes.sphere_n / 32.0,
        "t104": hottest[104],
        "t180": hottest[180],
        "phys_drop": math.log2(
            lit_percentile(plate[104]["physical"].luminance)
            / lit_percentile(plate[180]["physical"].luminance)
        ),
        "paper_104": paper_means[104],
        "paper_180": paper_means[180],
        "strip_width": sizes.strip_width,
    }
    written = page.page("gallery.md", markdown(page.links, facts))
    print(f"gallery: {time.perf_counter() - start:.1f} s")
    return written


if __name__ == "__main__":
    main()

"""Render the pictures of docs/scattering.md: the fire demo dark and sunlit; the campfire and
explosion demos with their smoke lit (by their own fire, a sky and a sun) beside the same frame
with ``--max-bounces 0``, each pair at one exposure; pbrt-v4's fire-lit cloud beside ours; a
shadow under a point sun and a sun disk; grey and Rayleigh scattering in spectral bins, of a sun
and of the explosion's own fire and sky.

    python scripts/scattering_gallery.py --out docs          # docs/scattering/*.png
    python scripts/scattering_gallery.py --out /tmp/x --quick
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np
from docpage import PageImages

import incandescent as inc
from incandescent import api
from incandescent.colorimetry import rgb_to_xyz
from incandescent.imaging import DisplaySettings
from incandescent.imaging.exposure import auto_exposure_scale
from incandescent.imaging.pipeline import display_pixels
from incandescent.io.images import read_exr
from incandescent.renderer.integrators import MultipleScattering, SingleScattering
from incandescent.renderer.lights import DirectionalLight, EmissionLight
from incandescent.scenes import SCENES, pbrt

#: The fire demo's smoke for the sunlit picture (our choice; soot smoke's albedo is lower,
#: ~0.2–0.4, pale wood smoke's higher) and its sun (lux).
ALBEDO, PHASE_G, SUN = 0.7, 0.3, DirectionalLight((0.6, 0.7, 0.4), 1e4)
DATA = Path(__file__).resolve().parents[1] / "tests" / "data" / "pbrt_d2"


def _fixed(image: inc.HDRImage, display: DisplaySettings | None) -> DisplaySettings:
    """``display`` with the exposure auto exposure picks for ``image``, fixed (a pair shares it)."""
    base = display or DisplaySettings()
    ev = float(np.log2(auto_exposure_scale(image.luminance, base.auto_percentile)))
    return replace(base, auto_exposure=False, exposure_ev=ev)


def fire_pair(size: int) -> dict[str, tuple[inc.HDRImage, DisplaySettings | None]]:
    """The fire demo, emission–absorption and sunlit (auto exposure each, as before)."""
    scene = SCENES["fire"]
    volume = scene.build(None)
    camera = scene.camera() if scene.camera else None
    settings = inc.RenderSettings(width=size, height=size)
    lit = volume.with_scattering(albedo=ALBEDO, phase_g=PHASE_G)
    sunlit = SingleScattering(lights=(SUN,))
    return {
        "fire_dark": (inc.render(volume, camera, settings), scene.display),
        "fire_sunlit": (inc.render(lit, camera, settings, integrator=sunlit), scene.display),
    }


def lit_demo(name: str, size: int) -> dict[str, tuple[inc.HDRImage, DisplaySettings | None]]:
    """Demo ``name`` with ``--max-bounces 0`` and lit (as ``incandescent demo NAME``), at the
    lit image's exposure."""
    scene = SCENES[name]
    camera = scene.camera() if scene.camera else None
    settings = inc.RenderSettings(width=size, height=size)
    volume = api.demo_volume(name)
    lit, integrator = api.demo_lighting(name, volume)
    bright = inc.render(lit, camera, settings, integrator=integrator)
    dark = inc.render(volume, camera, settings)
    display = _fixed(bright, scene.display)
    return {f"{name}_dark": (dark, display), f"{name}_lit": (bright, display)}


def spectral_demo(name: str, size: int) -> dict[str, tuple[inc.HDRImage, DisplaySettings | None]]:
    """Demo ``name`` lit (its fire, sky and sun, one order) in 16 spectral bins with σ_s ∝ λ^−4
    (β = 4), at the grey lit image's exposure: its fire's light reddened by soot, its sky's
    light scattered blue."""
    scene = SCENES[name]
    camera = scene.camera() if scene.camera else None
    settings = inc.RenderSettings(width=size, height=size)
    lit, integrator = api.demo_lighting(name, api.demo_volume(name))
    grey = inc.render(lit, camera, settings, integrator=integrator)
    binned = replace(integrator, spectral_bins=16)
    image = inc.render(lit.replace(scattering_alpha=4.0), camera, settings, integrator=binned)
    return {f"{name}_rayleigh": (image, _fixed(grey, scene.display))}


def in_scatter_pair(size: int) -> dict[str, tuple[inc.HDRImage, DisplaySettings | None]]:
    """The lit campfire demo (its fire's light and a sky, one order) with the fire's light and
    the sky estimated at every sample (2 pairs, as ``incandescent demo campfire``) and from the
    per-camera in-scatter cache (16 samples a voxel), one exposure."""
    scene = SCENES["campfire"]
    camera = scene.camera() if scene.camera else None
    settings = inc.RenderSettings(width=size, height=size)
    lit, integrator = api.demo_lighting("campfire", api.demo_volume("campfire"))
    cached = replace(integrator, in_scatter="cache", cache_pairs=16)
    images = {
        "campfire_per_sample": inc.render(lit, camera, settings, integrator=integrator),
        "campfire_cache": inc.render(lit, camera, settings, integrator=cached),
    }
    display = _fixed(images["campfire_per_sample"], scene.display)
    return {name: (image, display) for name, image in images.items()}


def _shadow_scene(n: int) -> inc.Volume:
    """A thin smoke floor under a dense, dark ball (the shadow caster), n voxels of 1 cm wide."""
    x, y, z = (np.indices((n, (3 * n) // 4, n)) + 0.5) / n
    ball = (x - 0.5) ** 2 + (y - 0.55) ** 2 + (z - 0.5) ** 2 < 0.09**2
    floor = (y > 0.04) & (y < 0.12)
    cold = inc.Volume.from_arrays(np.zeros(x.shape), absorption=np.where(ball, 300.0, 0.2),
                                  voxel_size_m=1.0 / n)  # fmt: skip
    return cold.with_scattering(np.where(floor, 12.0, 0.0), phase_g=0.2)


def shadow_pair(size: int) -> dict[str, tuple[inc.HDRImage, DisplaySettings | None]]:
    """The ball's shadow on the floor under a point sun and a 10° disk (the real sun: 0.53°),
    at one exposure: the disk's penumbra."""
    volume = _shadow_scene(32 if size < 64 else 96)
    camera = inc.Camera(eye=(0.0, 0.9, 1.1), target=(0.0, -0.3, 0.0), fov_deg=45.0)
    settings = inc.RenderSettings(width=size, height=size)
    images = {}
    for name, diameter in (("shadow_point", 0.0), ("shadow_disk", 10.0)):
        sun = DirectionalLight((0.35, 1.0, 0.25), 1e4, angular_diameter_deg=diameter)
        lit = SingleScattering(lights=(sun,))
        images[name] = inc.render(volume, camera, settings, integrator=lit)
    display = _fixed(images["shadow_point"], None)
    return {name: (image, display) for name, image in images.items()}


def rayleigh_pair(size: int) -> dict[str, tuple[inc.HDRImage, DisplaySettings | None]]:
    """The fire demo's sunlit smoke in 16 spectral bins: grey scattering (β = 0) beside
    Rayleigh's σ_s ∝ λ^−4 (β = 4), one exposure."""
    scene = SCENES["fire"]
    volume = scene.build(None)
    camera = scene.camera() if scene.camera else None
    settings = inc.RenderSettings(width=size, height=size)
    sunlit = SingleScattering(lights=(SUN,), spectral_bins=16)
    images = {}
    for name, beta in (("fire_grey", 0.0), ("fire_rayleigh", 4.0)):
        lit = volume.with_scattering(albedo=ALBEDO, phase_g=PHASE_G, scattering_alpha=beta)
        images[name] = inc.render(lit, camera, settings, integrator=sunlit)
    display = _fixed(images["fire_grey"], scene.display)
    return {name: (image, display) for name, image in images.items()}


def pbrt_pair(quick: bool) -> dict[str, tuple[inc.HDRImage, DisplaySettings | None]]:
    """pbrt-v4's D2 (all orders, 8192 spp, 85 s on 2 threads: its JSON) and ours (8 paths, ~4 s)."""

    gas, camera = pbrt.glowing_core(DATA), pbrt.CAMERA
    lit = MultipleScattering(lights=(EmissionLight(),), spp=2 if quick else 8)
    settings = inc.RenderSettings(width=64, height=64)
    image = inc.render(gas, camera, settings, integrator=lit)
    rgb = read_exr(DATA / "D2_glowing_core_ms_8192spp.exr")[0]
    # pbrt's film: XYZ without 683 and per unit B_peak(2000 K) (tests/data/pbrt_d2/README.md)
    theirs_xyz = rgb_to_xyz(rgb, "srgb") * pbrt.D2_CD_M2
    theirs = inc.HDRImage(theirs_xyz.astype(np.float32), image.transmittance)
    display = _fixed(image, None)
    return {"d2_ours": (image, display), "d2_pbrt": (theirs, display)}


def main(argv: Sequence[str] | None = None) -> list[Path]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path(__file__).resolve().parents[1] / "docs")
    parser.add_argument("--quick", action="store_true", help="tiny renders (for tests)")
    parser.add_argument("--only-in-scatter", action="store_true",
                        help="only the per-sample / cached campfire pair")  # fmt: skip
    args = parser.parse_args(argv)
    page = PageImages(args.out, "scattering", "scripts/scattering_gallery.py")
    size = 32 if args.quick else 320
    if args.only_in_scatter:
        return _written(page, in_scatter_pair(size), ("campfire_per_sample", "campfire_cache"))
    images = {**fire_pair(size), **lit_demo("campfire", size), **lit_demo("explosion", size),
              **pbrt_pair(args.quick), **shadow_pair(size), **rayleigh_pair(size),
              **spectral_demo("explosion", size), **in_scatter_pair(size)}  # fmt: skip
    timed = ("fire_sunlit", "campfire_lit", "explosion_lit", "explosion_rayleigh", "d2_ours",
             "campfire_per_sample", "campfire_cache")  # fmt: skip
    return _written(page, images, timed)


def _written(page: PageImages, images: dict, timed: Sequence[str]) -> list[Path]:
    """Each image as a PNG of ``page``; the march time of those ``timed``."""
    written = [
        page.add(name, display_pixels(image, display), name.replace("_", ", "))
        for name, (image, display) in images.items()
    ]
    for name in timed:
        print(f"{name}: {images[name][0].metadata['seconds']:.2f} s march")
    return written


if __name__ == "__main__":
    main()

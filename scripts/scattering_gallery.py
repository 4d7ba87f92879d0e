"""Render the pictures of docs/scattering.md: the fire demo's smoke, dark (emission–absorption)
and lit by a sun (single scattering), side by side, with the cost of each.

    python scripts/scattering_gallery.py --out docs          # docs/scattering/*.png
    python scripts/scattering_gallery.py --out /tmp/x --quick
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from docpage import PageImages

import incandescent as inc
from incandescent.imaging.pipeline import display_pixels
from incandescent.renderer.integrators import SingleScattering
from incandescent.renderer.lights import DirectionalLight
from incandescent.scenes import SCENES

#: The smoke's single-scattering albedo and phase asymmetry, and the sun (lux): our choices
#: for a picture (soot smoke's albedo is lower, ~0.2–0.4; pale wood smoke's higher).
ALBEDO, PHASE_G, SUN = 0.7, 0.3, DirectionalLight((0.6, 0.7, 0.4), 1e4)


def renders(size: int, backend: str = "cpu") -> dict[str, inc.HDRImage]:
    """The fire demo, emission–absorption and sunlit (the same exposure settings)."""
    scene = SCENES["fire"]
    volume = scene.build(None)
    camera = scene.camera() if scene.camera else None
    settings = inc.RenderSettings(width=size, height=size)
    lit = volume.with_scattering(albedo=ALBEDO, phase_g=PHASE_G)
    return {
        "fire_dark": inc.render(volume, camera, settings, backend),
        "fire_sunlit": inc.render(
            lit, camera, settings, backend, integrator=SingleScattering(lights=(SUN,))
        ),
    }


def main(argv: Sequence[str] | None = None) -> list[Path]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path(__file__).resolve().parents[1] / "docs")
    parser.add_argument("--quick", action="store_true", help="tiny renders (for tests)")
    args = parser.parse_args(argv)
    page = PageImages(args.out, "scattering", "scripts/scattering_gallery.py")
    images = renders(32 if args.quick else 320)
    display = SCENES["fire"].display
    written = [
        page.add(name, display_pixels(image, display), f"the fire demo, {name.split('_')[1]}")
        for name, image in images.items()
    ]
    ratio = images["fire_sunlit"].metadata["seconds"] / images["fire_dark"].metadata["seconds"]
    print(
        f"march time, sunlit / dark: {ratio:.1f}×; lit pixels differ: "
        f"{np.mean(images['fire_sunlit'].luminance > images['fire_dark'].luminance):.2f}"
    )
    return written


if __name__ == "__main__":
    main()

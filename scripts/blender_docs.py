"""docs/blender/compare.png: our render of a Blender Mantaflow fire beside Cycles' render of the
emission grid the add-on bakes from it (a stock Principled Volume), same camera and exposure.

    python scripts/blender_docs.py [--out docs/blender]        # needs Blender (~1 min)

It bakes a 48-cell fire + smoke (scripts/make_blender_fire_cache.py), runs the add-on in Blender
as its tests do (tests/blender/blender_session.py: "Render with incandescent", "Bake physical
emission", Cycles at 64 samples, Standard view, linear EXR) at 256 × 384 pixels, and prints the
chromaticities it compares.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

from incandescent.colorimetry.rgb_spaces import rgb_to_xyz
from incandescent.dcc import EMISSION_UNIT_CD_M2
from incandescent.imaging import auto_exposure_scale
from incandescent.imaging.pipeline import DisplaySettings, to_display
from incandescent.io.images import read_exr

ROOT = Path(__file__).resolve().parents[1]
FRAME = 20


def _blender(*args: str, env=None) -> None:
    blender = shutil.which("blender")
    if blender is None:
        raise SystemExit("blender is not installed (Debian: apt-get install blender)")
    done = subprocess.run([blender, "-b", *args], capture_output=True, text=True, env=env)
    if done.returncode != 0:
        raise SystemExit(done.stdout[-2000:] + done.stderr[-2000:])


def session(work: Path) -> dict:
    """Bake, then the add-on's render, bake and a Cycles render in one Blender session."""
    sys.path.insert(0, str(ROOT / "scripts"))
    from package_blender_addon import package

    bake = ["--frames", str(FRAME), "--resolution", "48", "--flow-type", "BOTH", "--scene"]
    script = ROOT / "scripts" / "make_blender_fire_cache.py"
    _blender("--factory-startup", "--python", str(script), "--", str(work / "fire"), *bake)
    job = {"zip": str(package(work / "addon.zip")), "frame": FRAME, "out": str(work),
           "executable": str(Path(sys.executable).with_name("incandescent")),
           "upright_vdb": str(ROOT / "tests" / "data" / "missing.vdb"), "samples": 64,
           "percent": 400}  # fmt: skip
    (work / "job.json").write_text(json.dumps(job))
    env = os.environ | {"BLENDER_USER_SCRIPTS": str(work / "scripts")}
    driver = ROOT / "tests" / "blender" / "blender_session.py"
    _blender(str(work / "fire" / "fire.blend"), "--factory-startup", "--python", str(driver),
             "--", str(work / "job.json"), env=env)  # fmt: skip
    return json.loads((work / "session.json").read_text())


def _xy(xyz: np.ndarray) -> np.ndarray:
    return xyz[:2] / xyz.sum()


def picture(ours_exr: Path, cycles_exr: Path, out: Path) -> str:
    """Both images through one display (our exposure for both), side by side; returns the
    figures the page quotes."""
    ours = rgb_to_xyz(read_exr(ours_exr)[0].astype(np.float64), "srgb")
    cycles = EMISSION_UNIT_CD_M2 * rgb_to_xyz(read_exr(cycles_exr)[0].astype(np.float64), "srgb")
    scale = auto_exposure_scale(ours[..., 1])
    display = DisplaySettings(auto_exposure=False)
    panels = [to_display(image * scale, display) for image in (ours, cycles)]
    lit = np.argwhere((ours[..., 1] > 0.002 * ours[..., 1].max()) | (cycles[..., 1] > 0))
    (top, left), (bottom, right) = lit.min(axis=0) - 24, lit.max(axis=0) + 25
    top, left = max(top, 0), max(left, 0)
    panels = [panel[top:bottom, left:right] for panel in panels]
    gap = np.zeros((panels[0].shape[0], 8, 3), np.uint8)
    canvas = Image.fromarray(np.concatenate([panels[0], gap, panels[1]], axis=1))
    draw = ImageDraw.Draw(canvas)
    draw.text((6, 6), "incandescent", fill=(255, 255, 255))
    draw.text((panels[0].shape[1] + 14, 6), "Cycles, baked grid", fill=(255, 255, 255))
    out.parent.mkdir(parents=True, exist_ok=True)
    canvas.save(out, optimize=True)
    flame = ours[..., 1] > 0.05 * ours[..., 1].max()
    a, b = _xy(ours[flame].sum(axis=0)), _xy(cycles[flame].sum(axis=0))
    ratio = cycles[..., 1].sum() / ours[..., 1].sum()
    return f"flame xy: ours {a.round(4)}, Cycles {b.round(4)}; Cycles/ours luminance {ratio:.3f}"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "blender")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="incandescent-blender-docs-") as folder:
        result = session(Path(folder))
        for step in ("render", "cycles"):
            if "failed" in result[step]:
                raise SystemExit(f"{step}: {result[step]['failed']}")
        figures = picture(Path(result["render"]["exr"]), Path(result["cycles"]["exr"]),
                          args.out / "compare.png")  # fmt: skip
    print(f"wrote {args.out / 'compare.png'}; {figures}")


if __name__ == "__main__":
    main()

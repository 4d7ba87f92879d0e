"""Hash every kind of image the renderer makes, to show that a refactor changed no bit.

    python scripts/render_hashes.py --out before.json         # on the old code
    python scripts/render_hashes.py --compare before.json     # on the new code: exit 1 on change

Each case renders a small image (every emission model and combination the renderer had, the
demo scenes, both fast and reference backends) and records SHA-256 digests of its XYZ (or
display RGB), transmittance and depth arrays. Digests depend on the machine (CPU features,
LLVM version), so compare runs made on one machine.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np

import incandescent as inc
from incandescent.scenes import synthetic as scenes

SIZE = {"width": 40, "height": 32}


def _digest(image) -> dict[str, str]:
    arrays = {"values": image.xyz, "transmittance": image.transmittance, "depth": image.depth_m}
    for name in ("display_rgb",):
        if getattr(image, name, None) is not None:
            arrays["values"] = getattr(image, name)
    out = {}
    for name, values in arrays.items():
        data = np.ascontiguousarray(values)
        out[name] = hashlib.sha256(data.tobytes() + str(data.dtype).encode()).hexdigest()[:16]
    return out


EA, PAPER = inc.EmissionAbsorption, inc.Paper2011


def _cases() -> dict[str, Callable[[], tuple]]:
    plume = scenes.plume(24)
    temp = scenes.plume_temperature(24)
    cut = inc.Volume.from_arrays(temp, 3.0, remap=inc.Remap(cutoff_K=900.0))
    soot = scenes.soot_plume(24)
    scale = inc.Volume.from_arrays(
        temp, emission_scale=np.linspace(0, 2, temp.size).reshape(temp.shape)
    )
    lines = inc.Volume.from_arrays(temp, species={"Na": 0.02, "Li": np.full(temp.shape, 0.01)})
    thin = inc.Volume.from_arrays(temp, 0.0, species={"Sr": 0.05})
    sodium = plume.with_sodium(np.clip((temp - 300.0) / 1700.0, 0.0, 1.0))
    s = inc.RenderSettings(**SIZE)
    ortho = inc.Camera(eye=(0, 0.4, 2), target=(0, 0.4, 0), projection="orthographic")
    return {
        "grey": lambda: (plume, None, s, None),
        "grey ss2": lambda: (plume, None, s.replace(supersample=2), None),
        "grey no skip": lambda: (plume, None, s.replace(skip_empty=False), None),
        "grey ortho": lambda: (plume, ortho, s, None),
        "cutoff": lambda: (cut, None, s, None),
        "soot graded": lambda: (soot, None, s, None),
        "emission scale": lambda: (scale, None, s, None),
        "spectral 4": lambda: (soot.with_soot_alpha(1.39), None, s, EA(spectral_bins=4)),
        "spectral 1": lambda: (plume, None, s, EA(spectral_bins=1)),
        "species": lambda: (lines, None, s, None),
        "species thin": lambda: (thin, None, s, None),
        "paper": lambda: (plume, None, s, PAPER()),
        "paper sodium": lambda: (sodium, None, s, PAPER()),
        "demo sparse": lambda: (scenes.sparse_flame(48), None, s, None),
    }


def _demo_cases() -> dict[str, Callable[[], tuple]]:
    from incandescent.scenes import COLOURED_FLAME_NAMES, SCENES

    s = inc.RenderSettings(**SIZE)
    names = ("plume", "sphere", *COLOURED_FLAME_NAMES, "sooty", "clean")
    return {f"demo {n}": (lambda n=n: (SCENES[n].build(24), None, s, None)) for n in names}


def _blur_cases() -> dict[str, Callable[[], tuple]]:
    """Motion blur (cpu only: the reference does not blur), dense and sparse."""
    plume = scenes.plume(24)
    velocity = np.zeros(plume.shape + (3,), np.float32)
    velocity[..., 1] = 0.6  # rising at 0.6 m/s
    s = inc.RenderSettings(**SIZE, shutter=(-0.25, 0.25), supersample=2)
    blurred = plume.with_velocity(velocity)
    return {
        "blur": lambda: (blurred, None, s, None),
        "blur sparse": lambda: (blurred, None, s.replace(layout="sparse"), None),
    }


def hashes(backends=("cpu", "reference")) -> dict[str, dict[str, str]]:
    out = {}
    for name, make in {**_cases(), **_demo_cases(), **_blur_cases()}.items():
        volume, camera, settings, integrator = make()
        for backend in backends:
            if backend == "reference" and (settings.supersample > 1 or settings.shutter):
                continue
            image = inc.render(volume, camera, settings, backend, integrator=integrator)
            out[f"{name} / {backend}"] = _digest(image)
    return out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path)
    parser.add_argument("--compare", type=Path)
    args = parser.parse_args()
    table = hashes()
    if args.out:
        args.out.write_text(json.dumps(table, indent=1, sort_keys=True) + "\n")
        print(f"{len(table)} cases written to {args.out}")
    if args.compare:
        before = json.loads(args.compare.read_text())
        changed = sorted(k for k in before if table.get(k) != before[k])
        for key in changed:
            print(f"changed: {key}: {before[key]} -> {table.get(key)}")
        print(f"{len(before) - len(changed)} of {len(before)} cases bit-identical")
        return 1 if changed else 0
    return 0


if __name__ == "__main__":
    sys.exit(main())

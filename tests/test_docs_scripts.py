"""The docs generators in scripts/ run end to end into a temporary folder."""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

SCRIPTS = Path(__file__).resolve().parent.parent / "scripts"


def _load_script(name: str):
    spec = importlib.util.spec_from_file_location(f"_script_{name}", SCRIPTS / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def blackbody_docs(tmp_path_factory) -> tuple[Path, Path]:
    out = tmp_path_factory.mktemp("docs")
    written = _load_script("blackbody_table").main(["--out", str(out)])
    return out / "blackbody.md", out / "blackbody_strip.png", written


def test_blackbody_table_writes_both_files(blackbody_docs):
    md, png, written = blackbody_docs
    assert written == [md, png]
    assert md.is_file()
    assert png.is_file()
    assert not list(md.parent.glob(".*.tmp"))  # atomic writes leave no temporary files


def test_blackbody_table_6500K_row(blackbody_docs):
    text = blackbody_docs[0].read_text(encoding="utf-8")
    row = re.search(r"^\| 6500 \| ([0-9.]+) \| ([0-9.]+) \|", text, flags=re.MULTILINE)
    assert row is not None
    np.testing.assert_allclose([float(row[1]), float(row[2])], [0.3135, 0.3236], atol=2e-3)


def test_blackbody_table_rows_cover_range_and_mark_out_of_gamut(blackbody_docs):
    text = blackbody_docs[0].read_text(encoding="utf-8")
    temps = [int(t) for t in re.findall(r"^\| (\d+) \|", text, flags=re.MULTILINE)]
    assert temps[0] == 800
    assert temps[-1] == 12_000
    assert temps == sorted(temps)
    assert "| 800 |" in text and "† |" in text  # 800 K is outside sRGB (negative component)


def test_blackbody_strip_image(blackbody_docs):
    with Image.open(blackbody_docs[1]) as image:
        assert image.mode == "RGB"
        assert image.size == (1024, 96)
        pixels = np.asarray(image)
    chroma, absolute = pixels[20], pixels[60]
    assert chroma.min(axis=-1).max() > 150  # fixed-brightness band is lit everywhere...
    assert (chroma.max(axis=-1) > 100).all()
    assert absolute[0].max() == 0  # ...the absolute band is black at 800 K
    assert absolute[-1].min() > 150  # and bright at 12 000 K


def test_scattering_gallery_renders_the_lit_smoke_brighter(tmp_path):
    """Each pair shares one exposure, so lit smoke is brighter than dark smoke; ours and pbrt's
    fire-lit cloud look alike at one exposure; Rayleigh's smoke is bluer than grey smoke, under a
    sun and under the explosion's own fire and sky."""
    written = _load_script("scattering_gallery").main(["--out", str(tmp_path), "--quick"])
    names = [p.name.removesuffix(".png") for p in written]
    assert names == ["fire_dark", "fire_sunlit", "campfire_dark", "campfire_lit",
                     "explosion_dark", "explosion_lit", "d2_ours", "d2_pbrt", "shadow_point",
                     "shadow_disk", "fire_grey", "fire_rayleigh", "explosion_rayleigh",
                     "campfire_per_sample", "campfire_cache"]  # fmt: skip
    pixels = {
        n: np.asarray(Image.open(p), dtype=float) for n, p in zip(names, written, strict=True)
    }
    for dark, lit in (("fire_dark", "fire_sunlit"), ("explosion_dark", "explosion_lit")):
        assert pixels[lit].mean() > pixels[dark].mean()  # the smoke is lit
    grey, rayleigh = pixels["fire_grey"], pixels["fire_rayleigh"]
    assert (rayleigh[..., 2] > rayleigh[..., 0]).sum() > (grey[..., 2] > grey[..., 0]).sum()
    grey, rayleigh = pixels["explosion_lit"], pixels["explosion_rayleigh"]
    assert (rayleigh[..., 2] > rayleigh[..., 0]).sum() > (grey[..., 2] > grey[..., 0]).sum()
    ours, theirs = pixels["d2_ours"].mean(), pixels["d2_pbrt"].mean()
    assert abs(ours / theirs - 1) < 0.1
    cached, per_sample = pixels["campfire_cache"].mean(), pixels["campfire_per_sample"].mean()
    assert abs(cached / per_sample - 1) < 0.1  # the in-scatter cache: the same picture


def test_pyrometry_gallery_maps_the_flame_and_the_fire(tmp_path, capsys):
    """The pyrometry page's pictures: the flame, its raw close-up, the maps, the Abel figure and
    the simulated fire's; the fire's line-of-sight error is the larger (at this coarse size too)."""
    written = _load_script("pyrometry_gallery").main(["--out", str(tmp_path), "--quick"])
    names = [p.name.removesuffix(".png") for p in written]
    assert names == ["flame_eye", "flame_raw", "flame_maps", "flame_abel", "fire_maps"]
    figures = dict(line.split(": ") for line in capsys.readouterr().out.strip().splitlines())
    assert abs(float(figures["mean_error"])) < abs(float(figures["fire_mean"]))


def test_inverse_gallery_shows_the_gradients(tmp_path):
    """The gradient picture is written (a float64 and a Dr.Jit adjoint of a 24³ flame)."""
    written = _load_script("inverse_gallery").main(["--out", str(tmp_path)])
    assert [p.name for p in written] == ["gradients.png"]


def test_tomography_gallery_writes_its_cases(tmp_path):
    """The worked examples at a tiny size (12³, 24², 5 iterations a level): five slice
    pictures (the last two with Gauss–Newton steps and with the TV continuation), the loss
    curves and the numbers."""
    script = _load_script("tomography_gallery")
    written = script.main(["--out", str(tmp_path), "--size", "12", "--pixels", "24",
                           "--iterations", "5"])  # fmt: skip
    assert [p.name for p in written] == [
        "ring12.png",
        "ring4.png",
        "noisy3.png",
        "ring12gn.png",
        "ring12tv.png",
        "losses.png",
        "cases.json",
    ]
    import json

    cases = json.loads(written[-1].read_text())
    assert set(cases) == {"ring12", "ring4", "noisy3", "ring12gn", "ring12tv"}
    assert all(np.isfinite(c["rmse_hot_K"]) for c in cases.values())
    assert cases["ring12tv"]["evaluations"] > cases["ring12"]["evaluations"]

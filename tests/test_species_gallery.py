"""scripts/species_gallery.py runs end to end (``--quick``) and the species scenes are sound."""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from incandescent.scenes import species as ss

SCRIPT = Path(__file__).resolve().parent.parent / "scripts" / "species_gallery.py"


@pytest.fixture(scope="module")
def gallery(tmp_path_factory) -> tuple[Path, list[Path]]:
    pytest.importorskip("matplotlib")  # the docs extra
    spec = importlib.util.spec_from_file_location("_script_species_gallery", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    out = tmp_path_factory.mktemp("docs")
    return out, module.main(["--out", str(out), "--quick"])


def test_species_gallery_writes_page_and_images(gallery):
    out, written = gallery
    page = out / "species.md"
    assert written[-1] == page
    images = written[:-1]
    n_flames = len(ss.COLOURED_FLAMES)
    assert len(images) == 2 * n_flames + 3  # flames + spectra, sooty, clean, pair spectrum
    assert {p.parent for p in images} == {out / "species"}
    assert sorted(p.name for p in (out / "species").iterdir()) == sorted(p.name for p in images)
    assert not list(out.rglob(".*.tmp"))
    for path in images:
        with Image.open(path) as image:
            assert image.mode == "RGB"
            assert np.asarray(image).max() > 0
    text = page.read_text(encoding="utf-8")
    linked = set(re.findall(r"!\[[^\]]*\]\(([^)]+)\)", text))
    assert linked == {p.relative_to(out).as_posix() for p in images}
    assert "{" not in text.replace("{ ", "")  # no unformatted template fields


def _mean_rgb(path: Path) -> np.ndarray:
    with Image.open(path) as image:
        px = np.asarray(image, dtype=np.float64)
    lit = px.max(axis=-1) > 8
    return px[lit].mean(axis=0)


@pytest.mark.parametrize(
    ("name", "dominant"), [("sodium", 0), ("lithium", 0), ("barium", 1), ("copper", 2)]
)
def test_flames_have_their_colour(gallery, name, dominant):
    rgb = _mean_rgb(gallery[0] / "species" / f"{name}.png")
    assert int(np.argmax(rgb)) == dominant


def test_lit_flames_have_no_black_holes(gallery):
    """The brightest pixels of a saturated flame are not black (the gamut-map pitfall)."""
    with Image.open(gallery[0] / "species" / "lithium.png") as image:
        px = np.asarray(image)
    assert px[..., 0].max() > 200


def test_species_follow_the_hot_gas():
    vol = ss.coloured_flame("sodium", n=16)
    na = vol.species["Na"]
    assert na.max() == pytest.approx(1.0)
    assert (na[vol.temperature_K < ss.T_ON_K] == 0).all()
    assert (vol.absorption_per_m[na == 0] == 0).all()
    assert vol.absorption_per_m.max() == pytest.approx(ss.COLOURED_SOOT_PER_M)
    sooty, clean = ss.sooty_flame(n=16), ss.clean_flame(n=16)
    assert sooty.absorption_per_m.max() == pytest.approx(ss.SOOTY_KAPPA_PER_M)
    assert not sooty.species
    assert clean.absorption_per_m.max() == 0
    assert set(clean.species) == {"CH", "C2"}


def test_unknown_flame_is_a_clear_error():
    with pytest.raises(ValueError, match="unknown coloured flame 'neon'"):
        ss.coloured_flame("neon", n=8)

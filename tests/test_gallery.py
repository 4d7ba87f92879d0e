"""scripts/gallery.py runs end to end (``--quick``: tiny renders) into a temporary folder."""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

SCRIPT = Path(__file__).resolve().parent.parent / "scripts" / "gallery.py"


@pytest.fixture(scope="module")
def gallery(tmp_path_factory) -> tuple[Path, list[Path]]:
    spec = importlib.util.spec_from_file_location("_script_gallery", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    out = tmp_path_factory.mktemp("docs")
    return out, module.main(["--out", str(out), "--quick"])


def test_gallery_writes_page_and_images(gallery):
    out, written = gallery
    page = out / "gallery.md"
    assert written[-1] == page
    images = written[:-1]
    assert len(images) == 11  # sphere ×2, 4 plate frames ×2, strip
    for path in written:
        assert path.is_file()
    assert {p.parent for p in images} == {out / "gallery"}
    assert sorted(p.name for p in (out / "gallery").iterdir()) == sorted(p.name for p in images)
    assert not list(out.rglob(".*.tmp"))  # atomic writes leave no temporary files
    for path in images:
        with Image.open(path) as image:
            assert image.mode == "RGB"
            assert np.asarray(image).max() > 0  # nothing rendered black


def test_gallery_page_references_every_image(gallery):
    out, written = gallery
    text = (out / "gallery.md").read_text(encoding="utf-8")
    linked = set(re.findall(r"!\[[^\]]*\]\(([^)]+)\)", text))
    assert linked == {p.relative_to(out).as_posix() for p in written[:-1]}


@pytest.mark.parametrize(("temperature", "low", "high"), [(1000, 0.02, 0.035), (3000, 0.003, 0.01)])
def test_gallery_truncation_table(gallery, temperature, low, high):
    text = (gallery[0] / "gallery.md").read_text(encoding="utf-8")
    row = re.search(rf"^\| {temperature} \| ([0-9.]+) \|", text, flags=re.MULTILINE)
    assert row is not None
    assert low < float(row[1]) < high

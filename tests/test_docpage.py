"""Helpers of the generated documentation pages and the lit-pixel percentile."""

from __future__ import annotations

import numpy as np
from docpage import PageImages, log_axis_x
from PIL import Image

from incandescent.imaging import auto_exposure_scale, lit_percentile


def test_log_axis_puts_the_ends_on_the_first_and_last_column():
    assert log_axis_x(800.0, 800.0, 12_000.0, 1024) == 0
    assert log_axis_x(12_000.0, 800.0, 12_000.0, 1024) == 1023
    middle = float(np.sqrt(800.0 * 12_000.0))  # geometric mean: the middle of a log axis
    assert log_axis_x(middle, 800.0, 12_000.0, 101) == 50


def test_lit_percentile_ignores_unlit_pixels_and_matches_auto_exposure():
    lum = np.array([[0.0, 0.0, 2.0], [4.0, 0.0, 8.0]])
    assert lit_percentile(lum, 50.0) == 4.0
    assert lit_percentile(np.zeros((3, 3))) == 0.0
    assert auto_exposure_scale(lum) == 0.8 / lit_percentile(lum)


def test_page_images_writes_titled_pngs_then_the_page(tmp_path):
    page = PageImages(tmp_path, "img", "tests")
    page.add("a", np.full((2, 3, 3), 200, dtype=np.uint8), "first")
    written = page.page("page.md", "![a](img/a.png)\n")
    assert written == [tmp_path / "img" / "a.png", tmp_path / "page.md"]
    assert page.links == {"a": "img/a.png"}
    assert Image.open(written[0]).text["Title"] == "first"
    assert (tmp_path / "page.md").read_text() == "![a](img/a.png)\n"

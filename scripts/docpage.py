"""Writing the generated documentation pages (``scripts/*.py``): their PNG images, with title and
software metadata, and kelvin tick labels under colour strips.

Generated pages are rebuilt in place, so everything here overwrites (atomically).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from incandescent._version import __version__
from incandescent.io.images import write_png
from incandescent.io.output import write_text

LABEL_RGB = (230, 230, 230)


class PageImages:
    """The PNG images of one page, written into ``folder/subdir``.

    ``written`` lists the paths in order; ``links`` maps each key to its path relative to
    ``folder`` (for the page's Markdown).
    """

    def __init__(self, folder: Path, subdir: str, software: str) -> None:
        self.folder, self.subdir = Path(folder), subdir
        self.software = f"incandescent {__version__} {software}"
        (self.folder / subdir).mkdir(parents=True, exist_ok=True)
        self.written: list[Path] = []
        self.links: dict[str, str] = {}

    def add(self, key: str, pixels: NDArray[np.uint8], title: str) -> Path:
        """Write ``pixels`` as ``subdir/key.png`` with ``title`` in its metadata."""
        name = f"{self.subdir}/{key}.png"
        meta = {"Title": title, "Software": self.software}
        path = write_png(self.folder / name, pixels, overwrite=True, metadata=meta)
        self.written.append(path)
        self.links[key] = name
        return path

    def page(self, name: str, text: str) -> list[Path]:
        """Write the page ``folder/name`` last; return every path written, the page last."""
        self.written.append(write_text(self.folder / name, text, overwrite=True))
        for path in self.written:
            print(f"wrote {path}")
        return self.written


def log_axis_x(temperature_K: float, low_K: float, high_K: float, width: int) -> int:
    """Pixel column of ``temperature_K`` on a strip spanning low_K … high_K logarithmically."""
    frac = math.log(temperature_K / low_K) / math.log(high_K / low_K)
    return int(round(frac * (width - 1)))


def draw_kelvin_ticks(
    draw, font, ticks_K: Sequence[float], top: int, width: int, low_K: float, high_K: float
) -> None:
    """Tick marks from row ``top`` down and their kelvin labels, kept inside the image (Pillow)."""
    for t in ticks_K:
        x = log_axis_x(t, low_K, high_K, width)
        draw.line([(x, top), (x, top + 3)], fill=LABEL_RGB)
        text = f"{t:g}"
        text_w = draw.textlength(text, font=font)
        left = min(max(x - text_w / 2, 1), width - text_w - 1)
        draw.text((left, top + 3), text, fill=LABEL_RGB, font=font)

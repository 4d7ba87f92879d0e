"""colour-science for the tests that compare against it (the package itself never imports it)."""

from __future__ import annotations

import warnings


def import_colour():
    """Import colour-science without its warnings about optional SciPy/Matplotlib features."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        import colour
    return colour

"""The shipped CIE tables (``spectra/data/cmf_*.csv``) are colour-science's, bit for bit."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from incandescent.spectra.cmf import OBSERVERS, cmfs


@pytest.mark.parametrize("observer", list(OBSERVERS))
def test_shipped_cmfs_equal_colour_science(observer):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        import colour
    data = colour.MSDS_CMFS[OBSERVERS[observer]]
    wavelength = np.asarray(data.wavelengths, dtype=np.float64)
    keep = (wavelength >= 360) & (wavelength <= 830)
    shipped = cmfs(observer)
    np.testing.assert_array_equal(shipped.wavelength_nm, wavelength[keep])
    np.testing.assert_array_equal(shipped.xyz_bar, np.asarray(data.values, dtype=np.float64)[keep])
    assert shipped.step_nm == 1.0 and shipped.xyz_bar.shape == (471, 3)

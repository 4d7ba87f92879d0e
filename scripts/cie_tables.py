"""Write the CIE colour matching functions the package ships (``spectra/data/cmf_*.csv``).

    python scripts/cie_tables.py

The render path reads these files instead of importing colour-science (whose import pulls in
matplotlib and pandas: ~0.9 s of every ``incandescent render``). Values are colour-science's
tabulations of CIE 015:2018, 360–830 nm at 1 nm, written with full float64 precision, so they
are bit-identical to what the package used before; ``tests/spectra/test_cmf_data.py`` checks that.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from incandescent.spectra.cmf import DATA, OBSERVERS


def main() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        import colour
    for key, name in OBSERVERS.items():
        data = colour.MSDS_CMFS[name]
        wavelength = np.asarray(data.wavelengths, dtype=np.float64)
        values = np.asarray(data.values, dtype=np.float64)
        keep = (wavelength >= 360) & (wavelength <= 830)
        header = (
            f"{name}, 360-830 nm at 1 nm: wavelength_nm, x_bar, y_bar, z_bar.\n"
            f"Source: CIE 015:2018 via colour-science {colour.__version__} "
            f"(colour.MSDS_CMFS['{name}']),\n"
            "written with full float64 precision by scripts/cie_tables.py; "
            "tests/spectra/test_cmf_data.py compares\nit with colour-science."
        )
        rows = np.column_stack([wavelength[keep], values[keep]])
        target = Path(DATA) / f"cmf_{key}.csv"
        np.savetxt(target, rows, fmt="%.17g", delimiter=",", header=header)
        print(f"wrote {target}")


if __name__ == "__main__":
    main()

"""incandescent: physically based volumetric rendering of incandescent gas."""

from incandescent.spectra import blackbody_xyz, planck_radiance

__version__ = "0.1.0"

__all__ = ["__version__", "blackbody_xyz", "planck_radiance"]

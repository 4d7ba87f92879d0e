"""incandescent: physically based volumetric rendering of incandescent gas."""

__version__ = "0.1.0"

from incandescent.camera import Camera, default_camera  # noqa: E402
from incandescent.render import HDRImage, RenderSettings, render  # noqa: E402
from incandescent.spectra import blackbody_xyz, planck_radiance  # noqa: E402
from incandescent.volume import Remap, Volume  # noqa: E402

__all__ = [
    "Camera",
    "HDRImage",
    "Remap",
    "RenderSettings",
    "Volume",
    "__version__",
    "blackbody_xyz",
    "default_camera",
    "planck_radiance",
    "render",
]

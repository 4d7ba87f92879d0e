"""incandescent: physically based volumetric rendering of incandescent gas."""

from incandescent._version import __version__  # noqa: E402
from incandescent.camera import Camera, default_camera  # noqa: E402
from incandescent.renderer import HDRImage, RenderSettings, render  # noqa: E402
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
    "simulate",
]


def __getattr__(name: str):
    """``incandescent.simulate`` (the fire solver) is imported when first used, so that rendering
    does not pay for it."""
    if name == "simulate":
        from incandescent.simulation import simulate

        return simulate
    raise AttributeError(f"module 'incandescent' has no attribute {name!r}")

"""incandescent: physically based volumetric rendering of incandescent gas."""

from incandescent._version import __version__  # noqa: E402
from incandescent.camera import Camera, default_camera  # noqa: E402
from incandescent.emission import Emission  # noqa: E402
from incandescent.renderer import (  # noqa: E402
    EmissionAbsorption,
    HDRImage,
    Integrator,
    Paper2011,
    RenderSettings,
    render,
)
from incandescent.spectra import blackbody_xyz, planck_radiance  # noqa: E402
from incandescent.volume import Remap, Volume  # noqa: E402

__all__ = [
    "Camera",
    "Emission",
    "EmissionAbsorption",
    "HDRImage",
    "Integrator",
    "Paper2011",
    "Remap",
    "RenderSettings",
    "Volume",
    "__version__",
    "blackbody_xyz",
    "default_camera",
    "planck_radiance",
    "render",
    "simulate",
    "view",
]


def view(volume_or_path, **base):
    """The interactive viewer inline in a notebook (``incandescent view`` in a cell): a
    ``Volume`` or INPUT (a volume file, a sequence pattern, a scene file, a simulation folder);
    ``base``: scene overrides by section, e.g. ``display={"tonemap": "reinhard"}``. Returns an
    object Jupyter shows as an iframe of the running viewer (``.url``, ``.close()``)."""
    from incandescent import viewer
    from incandescent.cli.flags import command_line

    return viewer.view(volume_or_path, command_line, **base)


def __getattr__(name: str):
    """``incandescent.simulate`` (the fire solver) is imported when first used, so that rendering
    does not pay for it."""
    if name == "simulate":
        from incandescent.simulation import simulate

        return simulate
    raise AttributeError(f"module 'incandescent' has no attribute {name!r}")

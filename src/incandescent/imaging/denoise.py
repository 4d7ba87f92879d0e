"""Denoising a Monte Carlo render for previews: Intel Open Image Denoise's ``RT`` filter in its
HDR mode (through the ``pyoidn`` binding, the optional extra ``incandescent[denoise]``).

OIDN's ray-tracing filter is trained on path-traced images and takes auxiliary albedo and
normal images where surfaces exist; a volume has neither, and OIDN documents that the colour
alone is valid input (``RT`` without ``albedo``/``normal``). It is a learned filter, not an
estimator: a denoised image is no longer an unbiased measurement, so it is applied only when
asked (``render --denoise``) and the image's metadata says so.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

#: What a denoised image's metadata records.
DENOISER = "Intel Open Image Denoise RT filter, hdr, colour only (pyoidn)"


def denoise_rgb(rgb: NDArray, luminance: NDArray) -> NDArray[np.float32]:
    """OIDN's ``RT`` filter on linear HDR RGB (H, W, 3) whose ``luminance`` is (H, W): its
    ``inputScale`` maps the 99th percentile of the lit pixels' luminance to 1 (OIDN's HDR
    mode works in that range; its own auto-exposure left the fire-lit cloud D2 7.5 % darker at
    1 path, this 2.4 %)."""
    try:
        import pyoidn
    except ImportError as error:
        raise ValueError(
            "denoising needs Intel Open Image Denoise's Python binding: pip install "
            "'incandescent[denoise]'"
        ) from error
    color = np.ascontiguousarray(rgb, dtype=np.float32)
    out = np.zeros_like(color)
    device = pyoidn.Device()
    device.commit()
    try:
        flt = pyoidn.Filter(device, "RT")
        flt.set_image(pyoidn.OIDN_IMAGE_COLOR, color, pyoidn.OIDN_FORMAT_FLOAT3)
        flt.set_image(pyoidn.OIDN_IMAGE_OUTPUT, out, pyoidn.OIDN_FORMAT_FLOAT3)
        flt.set_bool("hdr", True)
        lit = luminance[luminance > 0]
        if lit.size:
            flt.set_float("inputScale", float(1.0 / np.percentile(lit, 99.0)))
        flt.commit()
        flt.execute()
        flt.release()
    finally:
        device.release()
    return out

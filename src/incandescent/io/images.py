"""Image files: scene-linear OpenEXR and display PNG, written atomically with metadata.

Every writer goes through :func:`incandescent.io.atomic.atomic_write`: a hidden temporary file
beside the target, moved into place; only regular files are ever replaced, and a failed write
leaves any existing file untouched and no temporary file behind.

PNG is encoded here with :mod:`zlib` (ISO/IEC 15948:2004, the PNG specification) rather than
Pillow, because Pillow has no 48-bit (16 bit per channel) RGB image mode to write from.
"""

from __future__ import annotations

import os
import struct
import zlib
from collections.abc import Mapping
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from incandescent import _validate
from incandescent.io.atomic import atomic_write

PathLike = str | os.PathLike

#: Attributes OpenEXR itself sets; caller metadata may not use these names.
EXR_RESERVED_ATTRIBUTES: frozenset[str] = frozenset(
    {
        "channels",
        "compression",
        "dataWindow",
        "displayWindow",
        "lineOrder",
        "pixelAspectRatio",
        "screenWindowCenter",
        "screenWindowWidth",
        "type",
        "name",
        "tiles",
        "version",
        "chunkCount",
    }
)
_RGB = ("R", "G", "B")
_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def _check_metadata(metadata: Mapping[str, str] | None) -> dict[str, str]:
    if metadata is None:
        return {}
    if not isinstance(metadata, Mapping):
        raise TypeError(f"metadata must be a dict[str, str]; got {type(metadata).__name__}")
    for key, value in metadata.items():
        if not isinstance(key, str) or not isinstance(value, str):
            raise TypeError(f"metadata must map str keys to str values; got {key!r}: {value!r}")
        if not key:
            raise ValueError(f"metadata keys must be non-empty; got {key!r}: {value!r}")
    return dict(metadata)


# --- OpenEXR ------------------------------------------------------------------------------


def _float_image(value: ArrayLike, name: str, shape: tuple[int, ...] | None) -> NDArray[np.float32]:
    """``value`` as a C-ordered float32 image (OpenEXR reads the buffer in C order): float32 as
    it is (nothing to narrow), anything else through float64, refusing values beyond the float32
    range."""
    arr = _validate.real_grid(value, name)
    if shape is not None and arr.shape != shape:
        raise ValueError(f"{name} must have shape {shape}; got {arr.shape}")
    if arr.dtype == np.float32:
        return np.ascontiguousarray(arr)
    with np.errstate(over="ignore"):
        out = arr.astype(np.float32)
    overflow = int((np.isinf(out) & np.isfinite(arr)).sum())
    if overflow:
        raise ValueError(f"{name} has {overflow} value(s) beyond the float32 range (±3.4e38)")
    return out


def _exr_channels(rgb: ArrayLike, extra: Mapping[str, ArrayLike] | None) -> dict[str, NDArray]:
    arr = _validate.real_grid(rgb, "rgb")
    if arr.ndim != 3 or arr.shape[2] != 3 or 0 in arr.shape:
        raise ValueError(f"rgb must have shape (H, W, 3) with H, W >= 1; got {arr.shape}")
    channels = {c: _float_image(arr[..., i], "rgb", None) for i, c in enumerate(_RGB)}
    for name, values in (extra or {}).items():
        if not isinstance(name, str) or not name or name in _RGB:
            raise ValueError(f"extra channel names must be non-empty and not R, G, B; got {name!r}")
        channels[name] = _float_image(values, f"extra channel {name!r}", arr.shape[:2])
    return channels


def write_exr(
    path: PathLike,
    rgb: ArrayLike,
    metadata: Mapping[str, str] | None = None,
    overwrite: bool = False,
    extra_channels: Mapping[str, ArrayLike] | None = None,
) -> Path:
    """Write scene-linear RGB ``(H, W, 3)`` to an OpenEXR file as 32-bit float, ZIP-compressed.

    Values are written as given: linear, unclipped (negative = out of gamut), no tone mapping.

    Parameters
    ----------
    path:
        Destination file; its directory must exist.
    rgb:
        Linear RGB, shape (H, W, 3); the caller states its units and space in ``metadata``.
    metadata:
        String header attributes, e.g. ``{"units": "cd/m^2", "colorSpace": "srgb-linear"}``.
        Names reserved by OpenEXR (``channels``, ``compression``, …) are rejected.
    overwrite:
        Replace an existing file (otherwise ``FileExistsError``).
    extra_channels:
        Further float channels, name → array (H, W), e.g. ``{"A": alpha, "Z": depth_m}``.

    Returns
    -------
    The path written.
    """
    OpenEXR = _openexr()
    meta = _check_metadata(metadata)
    clash = sorted(EXR_RESERVED_ATTRIBUTES & meta.keys())
    if clash:
        raise ValueError(f"metadata keys {clash} are reserved by OpenEXR; rename them")
    channels = _exr_channels(rgb, extra_channels)
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage, **meta}

    def write(tmp: Path) -> None:
        with OpenEXR.File(header, channels) as exr:
            exr.write(str(tmp))

    return atomic_write(path, write, overwrite)


def _openexr():
    """The OpenEXR module, compressing and decompressing on every core: the Python binding starts
    with no worker threads (a 512² ZIP-compressed write took 52 ms on one core, 31–38 ms on two).
    A count set before (other than 0) is kept."""
    import OpenEXR

    from incandescent._parallel import workers

    if OpenEXR.global_thread_count() == 0:
        OpenEXR.set_global_thread_count(workers())
    return OpenEXR


def _open_exr(path: Path):
    OpenEXR = _openexr()
    if not path.is_file():
        raise FileNotFoundError(f"no such EXR file: {path}")
    try:
        exr = OpenEXR.File(str(path), separate_channels=True)
        header = dict(exr.header())
        pixels = {name: np.asarray(ch.pixels) for name, ch in exr.channels().items()}
    except Exception as err:  # OpenEXR raises RuntimeError with no file-format detail
        raise ValueError(f"cannot read {path} as an OpenEXR image: {err}") from err
    return header, pixels


def read_exr(
    path: PathLike,
) -> tuple[NDArray[np.float32], dict[str, str], dict[str, NDArray[np.float32]]]:
    """Read an OpenEXR file written by :func:`write_exr` (or any file with R, G, B channels).

    Returns
    -------
    rgb:
        float32 array (H, W, 3).
    metadata:
        The string-valued header attributes.
    extra:
        Every other channel, name → float32 array (H, W).

    Raises
    ------
    ValueError
        If the file is not a readable OpenEXR image (corrupt, truncated, another format) or
        lacks one of R, G, B; the message names the file.
    """
    target = Path(os.fspath(path))
    header, pixels = _open_exr(target)
    missing = [c for c in _RGB if c not in pixels]
    if missing:
        raise ValueError(f"{target} has no {', '.join(missing)} channel(s); found {sorted(pixels)}")
    rgb = np.stack([pixels[c].astype(np.float32) for c in _RGB], axis=-1)
    metadata = {k: v for k, v in header.items() if isinstance(v, str)}
    extra = {k: v.astype(np.float32) for k, v in pixels.items() if k not in _RGB}
    return rgb, metadata, extra


# --- PNG ----------------------------------------------------------------------------------


def _png_chunk(kind: bytes, data: bytes) -> bytes:
    """One PNG chunk: length, type, data, CRC-32 of type + data (PNG spec §5.3)."""
    crc = zlib.crc32(kind + data) & 0xFFFFFFFF
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", crc)


def _png_text_chunk(key: str, value: str) -> bytes:
    """``tEXt`` for Latin-1 text, ``iTXt`` (UTF-8) otherwise (PNG spec §11.3.4)."""
    if not 1 <= len(key) <= 79 or "\0" in key or key != key.strip():
        raise ValueError(
            f"PNG metadata key must be 1-79 characters, no NUL/edge spaces; got {key!r}"
        )
    try:
        keyword = key.encode("latin-1")
    except UnicodeEncodeError:
        raise ValueError(f"PNG metadata key must be Latin-1; got {key!r}") from None
    try:
        return _png_chunk(b"tEXt", keyword + b"\0" + value.replace("\0", "").encode("latin-1"))
    except UnicodeEncodeError:
        return _png_chunk(b"iTXt", keyword + b"\0\0\0\0\0" + value.encode("utf-8"))


def _png_idat(image: NDArray) -> bytes:
    """Big-endian samples, every scanline with filter type 2 ("Up", PNG spec §9.2)."""
    height = image.shape[0]
    raw = np.ascontiguousarray(image.astype(image.dtype.newbyteorder(">"))).view(np.uint8)
    raw = raw.reshape(height, -1)
    up = raw - np.vstack([np.zeros_like(raw[:1]), raw[:-1]])  # uint8 wraps modulo 256
    lines = np.hstack([np.full((height, 1), 2, dtype=np.uint8), up])
    return zlib.compress(lines.tobytes(), 6)


def encode_png(image: NDArray, metadata: Mapping[str, str] | None = None) -> bytes:
    """PNG bytes for an RGB ``uint8`` or ``uint16`` image (H, W, 3), with text metadata."""
    bits = 8 * image.dtype.itemsize
    height, width = image.shape[:2]
    ihdr = struct.pack(">IIBBBBB", width, height, bits, 2, 0, 0, 0)  # colour type 2 = RGB
    text = b"".join(_png_text_chunk(k, v) for k, v in _check_metadata(metadata).items())
    idat = _png_chunk(b"IDAT", _png_idat(image))
    return _PNG_SIGNATURE + _png_chunk(b"IHDR", ihdr) + text + idat + _png_chunk(b"IEND", b"")


def _check_png_image(image: ArrayLike) -> NDArray:
    arr = np.asarray(image)
    if arr.dtype not in (np.uint8, np.uint16):
        raise TypeError(f"image must be uint8 or uint16 (see imaging.quantize); got {arr.dtype}")
    if arr.ndim != 3 or arr.shape[2] != 3 or 0 in arr.shape:
        raise ValueError(f"image must have shape (H, W, 3) with H, W >= 1; got {arr.shape}")
    if max(arr.shape[:2]) >= 2**31:
        raise ValueError(f"image of shape {arr.shape} is too large for PNG")
    return arr


def write_png(
    path: PathLike,
    image: ArrayLike,
    overwrite: bool = False,
    metadata: Mapping[str, str] | None = None,
) -> Path:
    """Write a display image ``(H, W, 3)`` as an 8-bit (uint8) or 16-bit (uint16) RGB PNG.

    Parameters
    ----------
    path:
        Destination file; its directory must exist.
    image:
        Encoded (e.g. sRGB) integer RGB, as returned by
        :func:`incandescent.imaging.to_display`. Floats are rejected: quantise first.
    overwrite:
        Replace an existing file (otherwise ``FileExistsError``).
    metadata:
        Text chunks, ``dict[str, str]`` (keys 1–79 Latin-1 characters).

    Returns
    -------
    The path written.
    """
    data = encode_png(_check_png_image(image), metadata)

    def write(tmp: Path) -> None:
        with open(tmp, "xb") as handle:
            handle.write(data)
            handle.flush()
            os.fsync(handle.fileno())

    return atomic_write(path, write, overwrite)

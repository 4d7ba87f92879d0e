"""A camera's raw Bayer mosaic as a file: DNG, 16-bit TIFF or NumPy, always with a JSON sidecar.

:class:`RawImage` is what a sensor records: the colour-filter mosaic in DN (digital numbers),
its Bayer pattern, black and white (saturation) levels, bit depth, and every sensor parameter
(for the sidecar). :func:`write_raw` writes it by suffix:

- ``.dng`` — Adobe DNG 1.4 through ``pidng``: one uncompressed tile, ``BitsPerSample`` 16,
  ``PhotometricInterpretation`` CFA, ``CFARepeatPatternDim`` 2×2, ``CFAPattern``,
  ``BlackLevel``, ``WhiteLevel``; LibRaw (``rawpy``) reads its ``raw_image`` back bit for bit.
  LibRaw refuses any image under 22 pixels on a side, so a smaller mosaic is refused here.
- ``.tiff``/``.tif`` — the mosaic as a 16-bit single-channel TIFF (Pillow, mode ``I;16``).
- ``.npy`` — the mosaic as a ``uint16`` NumPy array.

Beside the file goes ``PATH.json`` (``frame.dng`` → ``frame.dng.json``): pattern, levels, bits
and the metadata. A ``.tiff``/``.npy`` file needs it to be read; a ``.dng`` carries its pattern
and levels itself, and its sidecar (where present) must agree with them. The file and its
sidecar are written together or not at all (:func:`incandescent.io.atomic.all_or_nothing`),
each read back before it replaces anything.

DNG, TIFF and NumPy need the optional extra ``camera`` for DNG (``pidng`` to write, ``rawpy``
to read); TIFF and NumPy need only the core dependencies.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from incandescent.io.atomic import all_or_nothing, atomic_write, check_output
from incandescent.io.textfiles import parse_json

PathLike = str | os.PathLike
MetadataValue = str | float | int

#: The Bayer patterns, named by the 2×2 tile read row by row from the mosaic's top-left pixel.
PATTERNS: tuple[str, ...] = ("RGGB", "BGGR", "GRBG", "GBRG")
#: Suffixes :func:`write_raw` writes and :func:`read_raw` reads.
RAW_SUFFIXES: tuple[str, ...] = (".dng", ".tiff", ".tif", ".npy")
#: LibRaw treats an image under this many pixels on either side as "not a raw file".
DNG_MIN_SIDE = 22
#: What the sidecar says it is, and its layout's version.
SIDECAR_FORMAT = "incandescent raw image"
SIDECAR_VERSION = 1
_INSTALL_HINT = "pip install 'incandescent[camera]'"


# --- the value ----------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class RawImage:
    """A raw Bayer mosaic and how to read it.

    ``mosaic`` is (H, W) DN, both even, stored as read-only ``uint16`` (any integer array is
    accepted and converted). ``pattern`` is one of :data:`PATTERNS`; ``black_level_dn`` <
    ``white_level_dn`` ≤ 2^``bits`` − 1 ≤ 65535, every pixel ≤ ``white_level_dn`` (the saturation
    DN). ``metadata`` maps names to str, int or finite float values: every sensor parameter, for
    the sidecar. ``xyz_to_camera`` is the DNG ``ColorMatrix1`` (XYZ → camera RGB, row-major, 9
    numbers); the identity when not given (the sidecar's spectral data is the real description).
    """

    mosaic: NDArray[np.uint16]
    pattern: str
    black_level_dn: int
    white_level_dn: int
    bits: int
    metadata: dict[str, MetadataValue] = field(default_factory=dict)
    xyz_to_camera: tuple[float, ...] = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)

    def __post_init__(self) -> None:
        _check_pattern(self.pattern)
        bits = _int_field(self.bits, "bits", 1, 16, "a sensor of 1 to 16 bits")
        top = (1 << bits) - 1
        white = _int_field(self.white_level_dn, "white_level_dn", 1, top, f"≤ 2^{bits} − 1")
        black = _int_field(self.black_level_dn, "black_level_dn", 0, white - 1, "< white level")
        object.__setattr__(self, "bits", bits)
        object.__setattr__(self, "white_level_dn", white)
        object.__setattr__(self, "black_level_dn", black)
        object.__setattr__(self, "mosaic", _checked_mosaic(self.mosaic, white))
        object.__setattr__(self, "metadata", _checked_metadata(self.metadata))
        object.__setattr__(self, "xyz_to_camera", _checked_matrix(self.xyz_to_camera))

    @property
    def shape(self) -> tuple[int, int]:
        """(height, width) of the mosaic in pixels."""
        return (int(self.mosaic.shape[0]), int(self.mosaic.shape[1]))


def _check_pattern(pattern: object) -> None:
    if not isinstance(pattern, str) or pattern not in PATTERNS:
        raise ValueError(
            f"unknown Bayer pattern {pattern!r}; expected one of: {', '.join(PATTERNS)}"
        )


def _int_field(value: object, name: str, low: int, high: int, why: str) -> int:
    """``value`` as an int in [low, high] (``why`` says where the bound comes from); a bool, a
    float or anything out of range is refused."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be an integer; got {type(value).__name__} {value!r}")
    number = int(value)
    if not low <= number <= high:
        raise ValueError(f"{name} must be in [{low}, {high}] ({why}); got {number}")
    return number


def _checked_mosaic(value: object, white: int) -> NDArray[np.uint16]:
    """``value`` as a read-only C-ordered uint16 (H, W) copy, H and W even, values in [0, white]."""
    arr = np.asarray(value)
    if arr.ndim != 2 or 0 in arr.shape:
        raise ValueError(f"mosaic must be a 2-D (H, W) array of DN; got shape {arr.shape}")
    if arr.dtype.kind not in "ui":
        raise TypeError(f"mosaic must hold integer DN (uint16); got dtype {arr.dtype}")
    height, width = arr.shape
    if height % 2 or width % 2:
        raise ValueError(
            f"mosaic must have even height and width (whole 2×2 Bayer tiles); got {height}×{width}"
        )
    low, high = int(arr.min()), int(arr.max())
    if low < 0:
        raise ValueError(f"mosaic has a negative value ({low} DN); DN are ≥ 0")
    if high > white:
        where = np.unravel_index(int(np.argmax(arr)), arr.shape)
        raise ValueError(
            f"mosaic value {high} DN at (row {where[0]}, column {where[1]}) is above the white "
            f"level {white} DN"
        )
    out = np.array(arr, dtype=np.uint16, order="C", copy=True)
    out.setflags(write=False)
    return out


def _checked_metadata(value: object) -> dict[str, MetadataValue]:
    """A plain-dict copy of ``value``: non-empty str keys, str/int/finite float values."""
    if not isinstance(value, Mapping):
        raise TypeError(
            f"metadata must be a dict[str, str | int | float]; got {type(value).__name__}"
        )
    out: dict[str, MetadataValue] = {}
    for key, item in value.items():
        if not isinstance(key, str) or not key:
            raise ValueError(f"metadata keys must be non-empty strings; got {key!r}")
        out[key] = _metadata_value(key, item)
    return out


def _metadata_value(key: str, item: object) -> MetadataValue:
    if isinstance(item, (bool, np.bool_)):
        raise TypeError(f"metadata {key!r} must be a str, int or float; got bool {item!r}")
    if isinstance(item, str):
        return item
    if isinstance(item, (int, np.integer)):
        return int(item)
    if isinstance(item, (float, np.floating)):
        if not math.isfinite(float(item)):
            raise ValueError(f"metadata {key!r} must be finite; got {item!r}")
        return float(item)
    raise TypeError(
        f"metadata {key!r} must be a str, int or float; got {type(item).__name__} {item!r}"
    )


def _checked_matrix(value: object) -> tuple[float, ...]:
    """``value`` as 9 finite floats (a 3×3 matrix, row-major)."""
    try:
        arr = np.asarray(value, dtype=np.float64).ravel()
    except (TypeError, ValueError):
        arr = np.empty(0)
    if arr.size != 9 or not np.all(np.isfinite(arr)):
        raise ValueError(f"xyz_to_camera must be 9 finite numbers (a 3×3 matrix); got {value!r}")
    return tuple(float(v) for v in arr)


# --- the sidecar --------------------------------------------------------------------------------


def sidecar_path(path: PathLike) -> Path:
    """The JSON sidecar of raw file ``path``: the same name with ``.json`` appended."""
    target = Path(os.fspath(path))
    return target.with_name(target.name + ".json")


def _sidecar_data(raw: RawImage, name: str) -> dict[str, Any]:
    return {
        "format": SIDECAR_FORMAT,
        "version": SIDECAR_VERSION,
        "file": name,
        "shape": list(raw.shape),
        "pattern": raw.pattern,
        "black_level_dn": raw.black_level_dn,
        "white_level_dn": raw.white_level_dn,
        "bits": raw.bits,
        "xyz_to_camera": list(raw.xyz_to_camera),
        "metadata": raw.metadata,
    }


def _sidecar_text(raw: RawImage, name: str) -> str:
    return json.dumps(_sidecar_data(raw, name), indent=2, allow_nan=False) + "\n"


def _read_sidecar(path: Path, required: bool) -> dict[str, Any] | None:
    """The sidecar of raw file ``path`` as checked data; ``None`` when absent and not required."""
    side = sidecar_path(path)
    if not side.is_file():
        if not required:
            return None
        raise FileNotFoundError(
            f"{path}: its sidecar {side} is missing; a {path.suffix} raw image is read with the "
            "JSON sidecar write_raw writes beside it (pattern, black and white levels, bits)"
        )
    try:
        text = side.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as error:
        raise ValueError(f"{side}: cannot read the sidecar ({error})") from None
    data = parse_json(text, side)
    if not isinstance(data, dict) or data.get("format") != SIDECAR_FORMAT:
        raise ValueError(
            f'{side}: not an incandescent raw sidecar (no "format": "{SIDECAR_FORMAT}")'
        )
    missing = [
        k for k in ("shape", "pattern", "black_level_dn", "white_level_dn", "bits") if k not in data
    ]
    if missing:
        raise ValueError(f"{side}: the sidecar lacks {', '.join(missing)}")
    if data.get("version") != SIDECAR_VERSION:
        raise ValueError(
            f"{side}: sidecar version {data.get('version')!r}; this incandescent reads version "
            f"{SIDECAR_VERSION}"
        )
    return data


def _from_sidecar(mosaic: NDArray, data: dict[str, Any], path: Path) -> RawImage:
    """A RawImage of ``mosaic`` read from ``path`` with its sidecar's levels; errors name both."""
    side = sidecar_path(path)
    shape = data["shape"]
    if not isinstance(shape, list) or shape != list(mosaic.shape):
        raise ValueError(
            f"{side}: the sidecar says shape {shape!r} but {path} is "
            f"{_shape_text(mosaic.shape)}; the two do not belong together"
        )
    try:
        return RawImage(
            mosaic,
            data["pattern"],
            data["black_level_dn"],
            data["white_level_dn"],
            data["bits"],
            data.get("metadata", {}),
            data.get("xyz_to_camera", RawImage.xyz_to_camera),
        )
    except (TypeError, ValueError) as error:
        raise ValueError(f"{path} (with {side.name}): {error}") from None


# --- writing ------------------------------------------------------------------------------------


def write_raw(path: PathLike, raw: RawImage, overwrite: bool = False) -> Path:
    """Write ``raw`` to ``path`` by its suffix (``.dng``, ``.tiff``/``.tif``, ``.npy``) and its
    JSON sidecar to ``PATH.json``, both or neither; returns the raw file's path.

    Both outputs are checked before any work (suffix, folder, an existing file without
    ``overwrite`` is a ``FileExistsError``), each is written to a temporary file and read back
    before it replaces anything.
    """
    if not isinstance(raw, RawImage):
        raise TypeError(f"write_raw needs a RawImage; got {type(raw).__name__}")
    target = check_output(path, overwrite, suffixes=RAW_SUFFIXES, what="raw image")
    side = sidecar_path(path)
    check_output(side, overwrite, what="raw image sidecar")
    write, verify = _writer(target.suffix.lower(), raw)
    text = _sidecar_text(raw, Path(os.fspath(path)).name)
    with all_or_nothing():
        written = atomic_write(path, write, overwrite, verify=verify)
        atomic_write(side, _text_writer(text), overwrite, verify=_text_verifier(text))
    return written


Writer = Callable[[Path], None]


def _writer(suffix: str, raw: RawImage) -> tuple[Writer, Writer]:
    """The (write, verify) pair for ``suffix``; a DNG's needs are checked here, before work."""
    if suffix == ".dng":
        return _dng_writer(raw), _dng_verifier(raw)
    if suffix in (".tiff", ".tif"):
        return _tiff_writer(raw.mosaic), _mosaic_verifier(raw.mosaic, _read_tiff_pixels)
    return _npy_writer(raw.mosaic), _mosaic_verifier(raw.mosaic, _read_npy_pixels)


def _text_writer(text: str) -> Writer:
    def write(tmp: Path) -> None:
        with open(tmp, "x", encoding="utf-8", newline="\n") as handle:
            handle.write(text)

    return write


def _text_verifier(text: str) -> Writer:
    def verify(tmp: Path) -> None:
        if tmp.read_text(encoding="utf-8") != text:
            raise ValueError("the sidecar's text differs from what was written")

    return verify


def _mosaic_verifier(mosaic: NDArray, read: Callable[[Path], NDArray]) -> Writer:
    def verify(tmp: Path) -> None:
        if not np.array_equal(read(tmp), mosaic):
            raise ValueError("its pixels differ from the mosaic written")

    return verify


def _npy_writer(mosaic: NDArray) -> Writer:
    def write(tmp: Path) -> None:
        with open(tmp, "xb") as handle:  # a handle: np.save would append ".npy" to a name
            np.save(handle, mosaic.astype("<u2"), allow_pickle=False)

    return write


def _tiff_writer(mosaic: NDArray) -> Writer:
    def write(tmp: Path) -> None:
        from PIL import Image

        Image.fromarray(np.ascontiguousarray(mosaic, dtype="<u2")).save(tmp, format="TIFF")

    return write


# --- DNG ------------------------------------------------------------------------------------


def _pidng() -> Any:
    try:
        import pidng.core
        import pidng.defs
        import pidng.dng
    except ImportError:
        raise ValueError(f"writing DNG needs the pidng package: {_INSTALL_HINT}") from None
    return pidng


def _rawpy() -> Any:
    try:
        import rawpy
    except ImportError:
        raise ValueError(f"reading DNG needs the rawpy package (LibRaw): {_INSTALL_HINT}") from None
    return rawpy


def _check_dng_size(raw: RawImage) -> None:
    height, width = raw.shape
    if min(height, width) < DNG_MIN_SIDE or max(height, width) > 65535:
        raise ValueError(
            f"a DNG mosaic must be {DNG_MIN_SIDE} to 65535 pixels on each side (LibRaw reads "
            f"nothing smaller; one tile holds it); got {height}×{width} — write .tiff or .npy"
        )


def _rational(value: float) -> list[int]:
    """``value`` as a signed TIFF rational [numerator, denominator] (1e-6 resolution)."""
    denominator = 1_000_000
    return [int(round(value * denominator)), denominator]


def _dng_tags(raw: RawImage, pidng: Any) -> Any:
    """pidng's tag set for ``raw``: one uncompressed tile, 16 bits, CFA with pattern and levels."""
    tag, defs = pidng.dng.Tag, pidng.defs
    height, width = raw.shape
    tags = pidng.dng.DNGTags()
    model = raw.metadata.get("name")
    for key, value in (
        (tag.ImageWidth, width),
        (tag.ImageLength, height),
        (tag.TileWidth, width),
        (tag.TileLength, height),
        (tag.Orientation, defs.Orientation.Horizontal),
        (tag.PhotometricInterpretation, defs.PhotometricInterpretation.Color_Filter_Array),
        (tag.SamplesPerPixel, 1),
        (tag.BitsPerSample, 16),
        (tag.CFARepeatPatternDim, [2, 2]),
        (tag.CFAPattern, getattr(defs.CFAPattern, raw.pattern)),
        (tag.BlackLevel, raw.black_level_dn),
        (tag.WhiteLevel, raw.white_level_dn),
        (tag.ColorMatrix1, [_rational(v) for v in raw.xyz_to_camera]),
        (tag.CalibrationIlluminant1, defs.CalibrationIlluminant.D65),
        (tag.AsShotNeutral, [[1, 1], [1, 1], [1, 1]]),
        (tag.Make, "incandescent"),
        (tag.Model, _ascii(model) if isinstance(model, str) and model else "simulated sensor"),
        (tag.UniqueCameraModel, "incandescent simulated sensor"),
        (tag.ImageDescription, _ascii(json.dumps(raw.metadata, allow_nan=False))),
    ):
        tags.set(key, value)
    return tags


def _ascii(text: str) -> str:
    """``text`` as 7-bit ASCII (TIFF ASCII tags), other characters as ``\\uXXXX`` escapes."""
    return text.encode("ascii", "backslashreplace").decode("ascii")


def _dng_writer(raw: RawImage) -> Writer:
    _check_dng_size(raw)
    pidng = _pidng()
    _rawpy()  # the read-back needs it: say so before any work

    def write(tmp: Path) -> None:
        converter = pidng.core.RAW2DNG()
        converter.options(_dng_tags(raw, pidng), path="", compress=False)
        buffer = converter.convert(np.ascontiguousarray(raw.mosaic, dtype=np.uint16))
        with open(tmp, "xb") as handle:  # convert() with no file name returns the bytes
            handle.write(buffer)

    return write


def _dng_verifier(raw: RawImage) -> Writer:
    def verify(tmp: Path) -> None:
        back = _read_dng_fields(tmp)
        if not np.array_equal(back["mosaic"], raw.mosaic):
            raise ValueError("LibRaw reads other pixels than the mosaic written")
        written = (raw.pattern, raw.black_level_dn, raw.white_level_dn)
        read = (back["pattern"], back["black_level_dn"], back["white_level_dn"])
        if read != written:
            raise ValueError(f"LibRaw reads pattern and levels {read}, not {written}")

    return verify


def _read_dng_fields(path: Path) -> dict[str, Any]:
    """LibRaw's view of a DNG: visible mosaic, pattern, one black level, white level."""
    rawpy = _rawpy()
    try:
        with rawpy.imread(os.fspath(path)) as image:
            mosaic = np.array(image.raw_image_visible, dtype=np.uint16, copy=True)
            colors = np.array(image.raw_colors_visible[:2, :2])
            description = image.color_desc.decode("ascii", "replace")
            blacks = [int(b) for b in image.black_level_per_channel]
            white = int(image.white_level)
    except rawpy.LibRawError as error:
        raise ValueError(f"{path}: LibRaw cannot read it as a raw image ({error})") from None
    return {
        "mosaic": mosaic,
        "pattern": _pattern_name(colors, description, path),
        "black_level_dn": _one_black(blacks, path),
        "white_level_dn": white,
    }


def _pattern_name(colors: NDArray, description: str, path: Path) -> str:
    """The Bayer pattern name of LibRaw's 2×2 colour indices (``color_desc`` e.g. ``RGBG``)."""
    try:
        name = "".join(description[int(i)] for i in colors.ravel())
    except IndexError:
        name = "?"
    if name not in PATTERNS:
        raise ValueError(
            f"{path}: its colour filter is not a Bayer pattern of R, G, B (LibRaw reads "
            f"{name!r} from {description!r}); expected one of: {', '.join(PATTERNS)}"
        )
    return name


def _one_black(blacks: list[int], path: Path) -> int:
    if len(set(blacks)) != 1:
        raise ValueError(
            f"{path}: its black levels differ by channel ({blacks} DN); a RawImage holds one"
        )
    return blacks[0]


# --- reading ------------------------------------------------------------------------------------


def read_raw(path: PathLike, expected_shape: tuple[int, int] | None = None) -> RawImage:
    """Read a raw image written by :func:`write_raw` (or any Bayer DNG LibRaw reads).

    ``.dng`` is read through LibRaw (``rawpy``): pixels, pattern, black and white levels from
    the file; bits and metadata from its sidecar where present (else bits from the white level).
    ``.tiff``/``.tif`` and ``.npy`` need their sidecar. ``expected_shape`` — the sensor's
    (height, width) — is checked against the file's size before its pixels are trusted.
    """
    target = Path(os.fspath(path))
    suffix = target.suffix.lower()
    if suffix not in RAW_SUFFIXES:
        got = repr(target.suffix) if target.suffix else "no suffix"
        raise ValueError(
            f"{target}: unsupported raw image format ({got}); expected {', '.join(RAW_SUFFIXES)}"
        )
    if not target.is_file():
        raise FileNotFoundError(f"no such raw image file: {target}")
    shape = _checked_expected(expected_shape)
    if suffix == ".dng":
        return _read_dng(target, shape)
    reader = _read_npy_pixels if suffix == ".npy" else _read_tiff_pixels
    mosaic = reader(target, shape)
    return _from_sidecar(mosaic, _read_sidecar(target, required=True) or {}, target)


def _checked_expected(shape: object) -> tuple[int, int] | None:
    if shape is None:
        return None
    ok = (
        isinstance(shape, (tuple, list))
        and len(shape) == 2
        and all(
            isinstance(n, (int, np.integer)) and not isinstance(n, bool) and n > 0 for n in shape
        )
    )
    if not ok:
        raise ValueError(f"expected_shape must be (height, width), two integers > 0; got {shape!r}")
    return (int(shape[0]), int(shape[1]))  # type: ignore[index]


def _shape_text(shape: Any) -> str:
    return f"{shape[0]}×{shape[1]} pixels"


def _check_shape(path: Path, shape: tuple[int, ...], expected: tuple[int, int] | None) -> None:
    if expected is not None and tuple(shape) != expected:
        raise ValueError(
            f"{path}: the raw image is {_shape_text(shape)} but the sensor is "
            f"{_shape_text(expected)} (height × width); taken with another sensor, cropped or "
            "binned?"
        )


def _read_dng(path: Path, expected: tuple[int, int] | None) -> RawImage:
    fields = _read_dng_fields(path)
    _check_shape(path, fields["mosaic"].shape, expected)
    data = _read_sidecar(path, required=False)
    if data is None:
        return _dng_without_sidecar(path, fields)
    said = (data["pattern"], data["black_level_dn"], data["white_level_dn"])
    found = (fields["pattern"], fields["black_level_dn"], fields["white_level_dn"])
    if tuple(said) != found:
        raise ValueError(
            f"{sidecar_path(path)}: the sidecar says pattern and levels {said} but {path} has "
            f"{found}; the two do not belong together"
        )
    return _from_sidecar(fields["mosaic"], data, path)


def _dng_without_sidecar(path: Path, fields: dict[str, Any]) -> RawImage:
    white = fields["white_level_dn"]
    try:
        return RawImage(
            fields["mosaic"],
            fields["pattern"],
            fields["black_level_dn"],
            white,
            max(1, int(white).bit_length()),
            {"source": path.name},
        )
    except (TypeError, ValueError) as error:
        raise ValueError(f"{path}: {error}") from None


def _read_npy_pixels(path: Path, expected: tuple[int, int] | None = None) -> NDArray:
    """The integer (H, W) array of a ``.npy`` file; its header is checked before its data."""
    try:
        mapped = np.load(path, mmap_mode="r", allow_pickle=False)
    except (OSError, ValueError) as error:
        raise ValueError(f"{path}: cannot read it as a NumPy array ({error})") from None
    if mapped.ndim != 2 or mapped.dtype.kind not in "ui":
        raise ValueError(
            f"{path}: a raw mosaic is a 2-D integer array; got {mapped.dtype} of shape "
            f"{mapped.shape}"
        )
    _check_shape(path, mapped.shape, expected)
    return np.array(mapped)


def _read_tiff_pixels(path: Path, expected: tuple[int, int] | None = None) -> NDArray:
    """The uint16 (H, W) pixels of a 16-bit single-channel TIFF; its size is checked first."""
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(path) as image:
            if image.format != "TIFF" or image.mode not in ("I;16", "I;16B", "I;16L"):
                raise ValueError(
                    f"{path}: a raw mosaic is a 16-bit single-channel TIFF; got a "
                    f"{image.format} image of mode {image.mode}"
                )
            _check_shape(path, (image.height, image.width), expected)
            return np.asarray(image, dtype=np.uint16).copy()
    except (OSError, UnidentifiedImageError, Image.DecompressionBombError) as error:
        raise ValueError(f"{path}: cannot read it as a TIFF image ({error})") from None

"""Raw mosaics as files: LibRaw reads our DNG back bit for bit (all four Bayer patterns, levels as
written, an uncompressed 16-bit CFA in the file's own tags), TIFF and NumPy round trips through
the sidecar, and bad inputs as one line each."""

from __future__ import annotations

import json
import os
import struct
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from incandescent.io.raw import PATTERNS, RawImage, read_raw, sidecar_path, write_raw

META = {"gain_e_per_dn": 1.7, "read_noise_e": 2.4, "exposure_s": 1e-3, "seed": 7, "name": "ü"}
SHAPE = (24, 32)  # LibRaw reads nothing under 22 pixels a side


def _raw(pattern="RGGB", shape=SHAPE, bits=12, black=64, seed=0) -> RawImage:
    white = (1 << bits) - 1
    mosaic = np.random.default_rng(seed).integers(0, white + 1, shape, dtype=np.uint16)
    mosaic[0, 0], mosaic[-1, -1] = 0, white  # both extremes present
    return RawImage(mosaic, pattern, black, white, bits, dict(META))


def _one_line(error: pytest.ExceptionInfo) -> str:
    text = str(error.value)
    assert "\n" not in text and text
    return text


def _ifd0(path: Path) -> dict[int, tuple[int, int, bytes]]:
    """IFD0 of a little-endian TIFF/DNG: tag → (type, count, value or offset bytes)."""
    data = path.read_bytes()
    assert data[:4] == b"II*\x00"
    (offset,) = struct.unpack_from("<I", data, 4)
    (count,) = struct.unpack_from("<H", data, offset)
    entries = {}
    for i in range(count):
        tag, kind, n, value = struct.unpack_from("<HHI4s", data, offset + 2 + 12 * i)
        entries[tag] = (kind, n, value)
    return entries


def _short(entry: tuple[int, int, bytes]) -> int:
    return struct.unpack_from("<H", entry[2])[0]


# --- DNG ------------------------------------------------------------------------------------


@pytest.mark.parametrize("pattern", PATTERNS)
def test_rawpy_reads_our_dng_exactly(tmp_path, pattern):
    rawpy = pytest.importorskip("rawpy")
    pytest.importorskip("pidng")
    raw = _raw(pattern, seed=PATTERNS.index(pattern))
    path = write_raw(tmp_path / "frame.dng", raw)
    with rawpy.imread(str(path)) as image:
        assert image.raw_image.dtype == np.uint16
        assert np.array_equal(image.raw_image, raw.mosaic)
        assert list(image.black_level_per_channel) == [64] * 4
        assert image.white_level == 4095
        desc = image.color_desc.decode()
        assert "".join(desc[i] for i in image.raw_pattern.ravel()) == pattern
    back = read_raw(path, expected_shape=SHAPE)
    assert np.array_equal(back.mosaic, raw.mosaic)
    assert (back.pattern, back.black_level_dn, back.white_level_dn, back.bits) == (
        pattern,
        64,
        4095,
        12,
    )
    assert back.metadata == META


def test_dng_tags_are_an_uncompressed_16_bit_cfa(tmp_path):
    pytest.importorskip("pidng")
    pytest.importorskip("rawpy")
    path = write_raw(tmp_path / "frame.dng", _raw("GBRG", black=100))
    tags = _ifd0(path)
    assert _short(tags[258]) == 16  # BitsPerSample
    assert _short(tags[259]) == 1  # Compression: none
    assert _short(tags[262]) == 32803  # PhotometricInterpretation: CFA
    assert tags[33422][2] == bytes([1, 2, 0, 1])  # CFAPattern GBRG (0 R, 1 G, 2 B)
    assert _short(tags[50714]) == 100  # BlackLevel
    assert _short(tags[50717]) == 4095  # WhiteLevel
    assert 50706 in tags  # DNGVersion


def test_dng_without_sidecar_reads_from_its_tags(tmp_path):
    pytest.importorskip("pidng")
    pytest.importorskip("rawpy")
    raw = _raw("BGGR", bits=14, black=512)
    path = write_raw(tmp_path / "frame.dng", raw)
    sidecar_path(path).unlink()
    back = read_raw(path)
    assert np.array_equal(back.mosaic, raw.mosaic)
    assert (back.pattern, back.black_level_dn, back.white_level_dn, back.bits) == (
        "BGGR",
        512,
        16383,
        14,
    )


def test_dng_sidecar_that_disagrees_is_refused(tmp_path):
    pytest.importorskip("pidng")
    pytest.importorskip("rawpy")
    path = write_raw(tmp_path / "frame.dng", _raw("RGGB"))
    side = sidecar_path(path)
    data = json.loads(side.read_text())
    data["pattern"] = "BGGR"
    side.write_text(json.dumps(data))
    with pytest.raises(ValueError, match="do not belong together") as error:
        read_raw(path)
    assert "frame.dng.json" in _one_line(error)


def test_dng_too_small_for_libraw_is_refused_before_writing(tmp_path):
    pytest.importorskip("pidng")
    with pytest.raises(ValueError, match="22 to 65535") as error:
        write_raw(tmp_path / "small.dng", _raw(shape=(20, 32)))
    assert "20×32" in _one_line(error)
    assert os.listdir(tmp_path) == []


# --- TIFF and NumPy -------------------------------------------------------------------------


@pytest.mark.parametrize("suffix", [".tiff", ".tif", ".npy"])
def test_tiff_and_npy_round_trip_with_sidecar(tmp_path, suffix):
    raw = _raw("GRBG", bits=16, black=0)
    path = write_raw(tmp_path / f"frame{suffix}", raw)
    assert sorted(os.listdir(tmp_path)) == [f"frame{suffix}", f"frame{suffix}.json"]
    back = read_raw(path, expected_shape=SHAPE)
    assert np.array_equal(back.mosaic, raw.mosaic) and back.mosaic.dtype == np.uint16
    assert (back.pattern, back.black_level_dn, back.white_level_dn, back.bits) == (
        "GRBG",
        0,
        65535,
        16,
    )
    assert back.metadata == META
    side = json.loads(sidecar_path(path).read_text(encoding="utf-8"))
    assert side["pattern"] == "GRBG" and side["bits"] == 16 and side["metadata"] == META
    assert side["shape"] == list(SHAPE) and side["file"] == f"frame{suffix}"


def test_tiff_is_16_bit_single_channel(tmp_path):
    raw = _raw("RGGB")
    path = write_raw(tmp_path / "frame.tiff", raw)
    with Image.open(path) as image:
        assert image.format == "TIFF" and image.mode == "I;16"
        assert np.array_equal(np.asarray(image), raw.mosaic)


def test_overwrite(tmp_path):
    path = write_raw(tmp_path / "frame.npy", _raw(seed=1))
    with pytest.raises(FileExistsError, match="overwrite") as error:
        write_raw(path, _raw(seed=2))
    assert "frame.npy" in _one_line(error)
    assert np.array_equal(read_raw(path).mosaic, _raw(seed=1).mosaic)  # untouched
    write_raw(path, _raw(seed=2), overwrite=True)
    assert np.array_equal(read_raw(path).mosaic, _raw(seed=2).mosaic)


def test_existing_sidecar_is_refused_before_the_raw_file_is_written(tmp_path):
    side = tmp_path / "frame.tiff.json"
    side.write_text("{}")
    with pytest.raises(FileExistsError, match="frame.tiff.json") as error:
        write_raw(tmp_path / "frame.tiff", _raw())
    _one_line(error)
    assert os.listdir(tmp_path) == ["frame.tiff.json"]


# --- bad input, one line each -----------------------------------------------------------------


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"mosaic": np.zeros((5, 8), np.uint16)}, "even height and width.*5×8"),
        ({"mosaic": np.full((4, 4), 4096, np.uint16)}, "4096 DN .* above the white level 4095"),
        ({"pattern": "RGBG"}, "unknown Bayer pattern 'RGBG'"),
        ({"black": 4095}, r"black_level_dn must be in \[0, 4094\].*got 4095"),
        ({"white": 5000}, r"white_level_dn must be in \[1, 4095\].*got 5000"),
        ({"bits": 17}, r"bits must be in \[1, 16\].*got 17"),
        ({"mosaic": np.zeros((4, 4), np.float32)}, "integer DN.*float32"),
        ({"metadata": {"t": float("nan")}}, "metadata 't' must be finite"),
    ],
)
def test_bad_raw_image(kwargs, match):
    args = {"mosaic": np.zeros((4, 4), np.uint16), "pattern": "RGGB", "black": 64}
    args |= {"white": 4095, "bits": 12, "metadata": {}} | kwargs
    with pytest.raises((ValueError, TypeError), match=match) as error:
        RawImage(
            args["mosaic"],
            args["pattern"],
            args["black"],
            args["white"],
            args["bits"],
            args["metadata"],
        )
    _one_line(error)


def test_mosaic_is_a_read_only_copy():
    mosaic = np.zeros((4, 4), np.uint16)
    raw = RawImage(mosaic, "RGGB", 0, 255, 8)
    mosaic[0, 0] = 9
    assert raw.mosaic[0, 0] == 0 and not raw.mosaic.flags.writeable


@pytest.mark.parametrize("suffix", [".dng", ".tiff", ".npy"])
def test_shape_mismatch_on_read(tmp_path, suffix):
    if suffix == ".dng":
        pytest.importorskip("pidng")
        pytest.importorskip("rawpy")
    path = write_raw(tmp_path / f"frame{suffix}", _raw())
    with pytest.raises(ValueError, match="24×32 pixels but the sensor is 480×640") as error:
        read_raw(path, expected_shape=(480, 640))
    assert f"frame{suffix}" in _one_line(error)


@pytest.mark.parametrize("suffix", [".tiff", ".npy"])
def test_missing_sidecar(tmp_path, suffix):
    path = write_raw(tmp_path / f"frame{suffix}", _raw())
    sidecar_path(path).unlink()
    with pytest.raises(FileNotFoundError, match="sidecar .*frame.*json is missing") as error:
        read_raw(path)
    assert f"frame{suffix}" in _one_line(error)


def test_unsupported_suffix_and_missing_file(tmp_path):
    with pytest.raises(ValueError, match="unsupported raw image format") as error:
        write_raw(tmp_path / "frame.png", _raw())
    _one_line(error)
    with pytest.raises(FileNotFoundError, match="no such raw image file") as error:
        read_raw(tmp_path / "absent.npy")
    _one_line(error)


def test_broken_sidecar_is_one_line(tmp_path):
    path = write_raw(tmp_path / "frame.npy", _raw())
    sidecar_path(path).write_text('{"format": ')
    with pytest.raises(ValueError, match="JSON syntax error at line 1") as error:
        read_raw(path)
    assert "frame.npy.json" in _one_line(error)

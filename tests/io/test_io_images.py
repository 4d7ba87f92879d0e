"""Image files: EXR/PNG round trips, metadata, atomic and non-clobbering writes, clear errors."""

from __future__ import annotations

import os
import struct
import zlib
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from incandescent.io.images import atomic_write, read_exr, write_exr, write_png

META = {"units": "cd/m^2", "colorSpace": "linear srgb (D65)", "exposure": "0 EV", "note": "é→✓"}


def _rgb(shape=(5, 7)):
    rng = np.random.default_rng(3)
    return rng.normal(0.0, 1e5, (*shape, 3))  # negative and large: unclipped scene values


def _listing(directory: Path) -> list[str]:
    return sorted(os.listdir(directory))


def _decode_png(data: bytes) -> tuple[dict, np.ndarray]:
    """Minimal independent PNG decoder (RGB, filters None/Sub/Up) checking every chunk's CRC."""
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    pos, chunks = 8, []
    while pos < len(data):
        (length,) = struct.unpack(">I", data[pos : pos + 4])
        kind, body = data[pos + 4 : pos + 8], data[pos + 8 : pos + 8 + length]
        (crc,) = struct.unpack(">I", data[pos + 8 + length : pos + 12 + length])
        assert crc == zlib.crc32(kind + body) & 0xFFFFFFFF
        chunks.append((kind, body))
        pos += 12 + length
    width, height, bits, colour_type = struct.unpack(">IIBB", chunks[0][1][:10])
    assert colour_type == 2
    raw = zlib.decompress(b"".join(b for k, b in chunks if k == b"IDAT"))
    stride = width * 3 * bits // 8
    rows, prev = [], bytearray(stride)
    for r in range(height):
        line = raw[r * (stride + 1) : (r + 1) * (stride + 1)]
        kind, cur = line[0], bytearray(line[1:])
        bpp = 3 * bits // 8
        for i in range(stride):
            if kind == 1:
                cur[i] = (cur[i] + (cur[i - bpp] if i >= bpp else 0)) & 0xFF
            elif kind == 2:
                cur[i] = (cur[i] + prev[i]) & 0xFF
            else:
                assert kind == 0, f"filter {kind} not supported by the test decoder"
        rows.append(bytes(cur))
        prev = cur
    dtype = ">u1" if bits == 8 else ">u2"
    pixels = np.frombuffer(b"".join(rows), dtype=dtype).reshape(height, width, 3)
    return {"bits": bits}, pixels


# --- EXR -----------------------------------------------------------------------------------


def test_exr_round_trip_values_metadata_extra(tmp_path):
    rgb = _rgb()
    alpha, depth = np.linspace(0, 1, 35).reshape(5, 7), np.full((5, 7), 12.5)
    path = write_exr(tmp_path / "beauty.exr", rgb, META, extra_channels={"A": alpha, "Z": depth})
    assert path == tmp_path / "beauty.exr"
    back, meta, extra = read_exr(path)
    assert back.dtype == np.float32
    assert back.shape == (5, 7, 3)
    np.testing.assert_array_equal(back, rgb.astype(np.float32))
    assert back.min() < 0  # unclipped
    for key, value in META.items():
        assert meta[key] == value
    assert sorted(extra) == ["A", "Z"]
    np.testing.assert_array_equal(extra["A"], alpha.astype(np.float32))
    np.testing.assert_array_equal(extra["Z"], depth.astype(np.float32))
    assert _listing(tmp_path) == ["beauty.exr"]  # no temporary file left behind


def test_exr_compressed_on_every_core_is_the_same_file(tmp_path):
    """write_exr starts OpenEXR's worker threads (the binding starts with none); the blocks it
    compresses in parallel make the same file as one thread does."""
    import OpenEXR

    from incandescent._parallel import workers

    rgb = np.random.default_rng(3).random((96, 64, 3), dtype=np.float32) * 4.0
    before = OpenEXR.global_thread_count()
    try:
        OpenEXR.set_global_thread_count(0)
        write_exr(tmp_path / "threads.exr", rgb)
        assert OpenEXR.global_thread_count() == workers()
        OpenEXR.set_global_thread_count(1)  # a count set before is kept
        write_exr(tmp_path / "one.exr", rgb)
        assert OpenEXR.global_thread_count() == 1
    finally:
        OpenEXR.set_global_thread_count(before)
    assert (tmp_path / "threads.exr").read_bytes() == (tmp_path / "one.exr").read_bytes()
    assert np.array_equal(read_exr(tmp_path / "threads.exr")[0], rgb)


def test_exr_refuses_overwrite_then_allows(tmp_path):
    path = tmp_path / "a.exr"
    write_exr(path, np.zeros((2, 2, 3)))
    with pytest.raises(FileExistsError, match=r"a\.exr already exists; pass --overwrite"):
        write_exr(path, np.ones((2, 2, 3)))
    assert read_exr(path)[0].max() == 0.0
    write_exr(path, np.ones((2, 2, 3)), overwrite=True)
    assert read_exr(path)[0].min() == 1.0
    assert _listing(tmp_path) == ["a.exr"]


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"rgb": np.zeros((2, 2))}, ValueError, r"rgb must have shape \(H, W, 3\)"),
        ({"rgb": np.full((2, 2, 3), "x")}, TypeError, "rgb must be a real number array"),
        ({"rgb": np.full((2, 2, 3), 1e39)}, ValueError, "beyond the float32 range"),
        ({"metadata": {"units": 3}}, TypeError, "metadata must map"),
        ({"metadata": {"compression": "none"}}, ValueError, "reserved by OpenEXR"),
        ({"extra_channels": {"Z": np.zeros((3, 3))}}, ValueError, r"'Z' must have shape \(2, 2\)"),
        ({"extra_channels": {"R": np.zeros((2, 2))}}, ValueError, "not R, G, B"),
        ({"overwrite": "yes"}, TypeError, "overwrite must be True or False"),
    ],
)
def test_failed_exr_write_leaves_existing_file_untouched(tmp_path, kwargs, error, match):
    path = tmp_path / "keep.exr"
    write_exr(path, np.full((2, 2, 3), 7.0))
    before = path.read_bytes()
    args = {"rgb": np.zeros((2, 2, 3)), "overwrite": True, **kwargs}
    with pytest.raises(error, match=match):
        write_exr(path, **args)
    assert path.read_bytes() == before
    assert _listing(tmp_path) == ["keep.exr"]


def test_failure_during_write_leaves_no_partial_file(tmp_path):
    path = tmp_path / "out.exr"
    path.write_bytes(b"original")

    def half_write(tmp: Path) -> None:
        tmp.write_bytes(b"partial")
        raise OSError("disk full")

    with pytest.raises(OSError, match="disk full"):
        atomic_write(path, half_write, overwrite=True)
    with pytest.raises(OSError, match="disk full"):
        atomic_write(tmp_path / "new.exr", half_write)
    assert path.read_bytes() == b"original"
    assert _listing(tmp_path) == ["out.exr"]


def test_failure_while_moving_into_place_cleans_up(tmp_path, monkeypatch):
    def broken_replace(src, dst):
        raise PermissionError("rename refused")

    monkeypatch.setattr(os, "replace", broken_replace)
    with pytest.raises(PermissionError, match="rename refused"):
        write_exr(tmp_path / "x.exr", np.zeros((2, 2, 3)), overwrite=True)
    assert _listing(tmp_path) == []


def test_missing_directory_is_a_clear_error(tmp_path):
    target = tmp_path / "nope" / "a.exr"
    with pytest.raises(FileNotFoundError, match=r"folder .*nope does not exist"):
        write_exr(target, np.zeros((2, 2, 3)))
    with pytest.raises(FileNotFoundError, match=r"folder .*nope does not exist"):
        write_png(tmp_path / "nope" / "a.png", np.zeros((2, 2, 3), np.uint8))


def test_read_corrupt_files_names_the_file(tmp_path):
    good = write_exr(tmp_path / "good.exr", _rgb((40, 40)))
    data = good.read_bytes()
    cases = {
        "truncated.exr": data[: len(data) // 2],
        "header_only.exr": data[:120],
        "text.exr": b"this is not an image",
        "empty.exr": b"",
    }
    write_png(tmp_path / "picture.png", np.zeros((2, 2, 3), np.uint8))
    for name, payload in cases.items():
        (tmp_path / name).write_bytes(payload)
    for name in [*cases, "picture.png"]:
        with pytest.raises(ValueError, match=rf"cannot read .*{name} as an OpenEXR image"):
            read_exr(tmp_path / name)


def test_read_missing_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="no such EXR file"):
        read_exr(tmp_path / "absent.exr")


def test_read_exr_without_rgb_channels(tmp_path):
    import OpenEXR

    path = tmp_path / "depth.exr"
    with OpenEXR.File({}, {"Z": np.zeros((2, 2), np.float32)}) as exr:
        exr.write(str(path))
    with pytest.raises(ValueError, match=r"depth\.exr has no R, G, B channel"):
        read_exr(path)


# --- PNG -----------------------------------------------------------------------------------


def test_png_8_bit_round_trip_with_text(tmp_path):
    image = np.random.default_rng(0).integers(0, 256, (9, 11, 3), dtype=np.uint8)
    path = write_png(tmp_path / "a.png", image, metadata=META)
    with Image.open(path) as png:
        png.load()
        assert png.mode == "RGB"
        np.testing.assert_array_equal(np.asarray(png), image)
        assert png.text == META
    np.testing.assert_array_equal(_decode_png(path.read_bytes())[1], image)
    assert _listing(tmp_path) == ["a.png"]


def test_png_16_bit_round_trip(tmp_path):
    image = np.random.default_rng(1).integers(0, 65536, (6, 5, 3), dtype=np.uint16)
    image[0, 0] = [0, 65535, 256]
    path = write_png(tmp_path / "b.png", image, metadata={"bits": "16"})
    info, pixels = _decode_png(path.read_bytes())
    assert info["bits"] == 16
    np.testing.assert_array_equal(pixels, image)
    with Image.open(path) as png:  # Pillow reads 48-bit RGB as 8-bit: the high bytes
        png.load()
        np.testing.assert_array_equal(np.asarray(png), (image >> 8).astype(np.uint8))
        assert png.text == {"bits": "16"}


def test_png_refuses_overwrite(tmp_path):
    path = tmp_path / "c.png"
    write_png(path, np.zeros((1, 1, 3), np.uint8))
    before = path.read_bytes()
    with pytest.raises(FileExistsError, match=r"c\.png already exists; pass --overwrite"):
        write_png(path, np.full((1, 1, 3), 255, np.uint8))
    assert path.read_bytes() == before
    write_png(path, np.full((1, 1, 3), 255, np.uint8), overwrite=True)
    assert path.read_bytes() != before


@pytest.mark.parametrize(
    ("image", "metadata", "error", "match"),
    [
        (np.zeros((2, 2, 3)), None, TypeError, "must be uint8 or uint16"),
        (np.zeros((2, 2), np.uint8), None, ValueError, r"shape \(H, W, 3\)"),
        (np.zeros((2, 2, 3), np.uint8), {"k" * 80: "x"}, ValueError, "1-79 characters"),
        (np.zeros((2, 2, 3), np.uint8), {"": "x"}, ValueError, "keys must be non-empty"),
        (np.zeros((2, 2, 3), np.uint8), {"k": 1}, TypeError, "metadata must map"),
    ],
)
def test_png_errors_leave_existing_file(tmp_path, image, metadata, error, match):
    path = tmp_path / "d.png"
    write_png(path, np.zeros((1, 1, 3), np.uint8))
    before = path.read_bytes()
    with pytest.raises(error, match=match):
        write_png(path, image, overwrite=True, metadata=metadata)
    assert path.read_bytes() == before
    assert _listing(tmp_path) == ["d.png"]


def test_exr_extra_channels_from_non_contiguous_arrays_keep_their_layout(tmp_path):
    """A transposed (non-C-contiguous) channel must be written in image order, not memory order."""
    alpha = np.arange(12, dtype=np.float32).reshape(4, 3).T  # (3, 4), Fortran-ordered view
    rgb = np.zeros((3, 4, 3), dtype=np.float32)
    _, _, extra = read_exr(write_exr(tmp_path / "t.exr", rgb, extra_channels={"A": alpha}))
    np.testing.assert_array_equal(extra["A"], alpha)


def test_float32_exr_channels_are_written_as_they_are(tmp_path):
    """float32 RGB (a strided view) and extra channels reach the file bit for bit, the float32
    extremes (largest, smallest subnormal, inf) included."""
    rng = np.random.default_rng(7)
    big = rng.random((3, 5, 4)).astype(np.float32)
    big[0, 0, :3] = [np.finfo(np.float32).max, np.finfo(np.float32).smallest_subnormal, np.inf]
    rgb = big[..., :3]  # not contiguous
    depth = rng.random((3, 5)).astype(np.float32)
    write_exr(tmp_path / "f32.exr", rgb, extra_channels={"Z": depth})
    back, _, extra = read_exr(tmp_path / "f32.exr")
    assert back.tobytes() == np.ascontiguousarray(rgb).tobytes()
    assert extra["Z"].tobytes() == depth.tobytes()

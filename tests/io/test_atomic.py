"""Issue 25, the shared mechanisms of io.atomic: a staged file must read back before it replaces
anything, and no output may be one of the run's inputs, by whatever name."""

from __future__ import annotations

import os

import pytest

from incandescent.io.atomic import OutputError, all_or_nothing, atomic_write, check_output


def _write(text: bytes):
    return lambda tmp: tmp.write_bytes(text)


def _refuse(tmp):
    raise ValueError("truncated header")


def test_a_file_that_does_not_read_back_replaces_nothing(tmp_path):
    out = tmp_path / "grid.vdb"
    out.write_bytes(b"good")
    with pytest.raises(OutputError, match=r"grid.vdb.*does not read back \(truncated header\)"):
        atomic_write(out, _write(b"bad"), overwrite=True, verify=_refuse)
    assert out.read_bytes() == b"good"
    assert os.listdir(tmp_path) == ["grid.vdb"]  # no temporary left


def test_verify_sees_the_staged_bytes_and_lets_a_good_file_through(tmp_path):
    seen = []
    atomic_write(tmp_path / "a.bin", _write(b"xyz"), verify=lambda p: seen.append(p.read_bytes()))
    assert seen == [b"xyz"] and (tmp_path / "a.bin").read_bytes() == b"xyz"


def test_verify_failure_inside_a_batch_commits_nothing(tmp_path):
    def both():
        with all_or_nothing():
            atomic_write(tmp_path / "image.png", _write(b"png"))
            atomic_write(tmp_path / "grid.vdb", _write(b"vdb"), verify=_refuse)

    with pytest.raises(OutputError):
        both()
    assert os.listdir(tmp_path) == []


@pytest.mark.parametrize("how", ["same", "symlink", "hardlink", "dotdot"])
def test_an_input_is_never_an_output_even_with_overwrite(tmp_path, how):
    source = tmp_path / "in.npz"
    source.write_bytes(b"input")
    (tmp_path / "sub").mkdir()
    name = {
        "same": source,
        "symlink": tmp_path / "link.npz",
        "hardlink": tmp_path / "hard.npz",
        "dotdot": tmp_path / "sub" / ".." / "in.npz",
    }[how]
    if how == "symlink":
        name.symlink_to(source)
    elif how == "hardlink":
        os.link(source, name)
    with pytest.raises(OutputError, match="input.*never replaced"):
        check_output(name, overwrite=True, inputs=[source])
    assert source.read_bytes() == b"input"


def test_a_different_file_is_not_mistaken_for_the_input(tmp_path):
    source = tmp_path / "in.npz"
    source.write_bytes(b"input")
    assert check_output(tmp_path / "out.npz", inputs=[source]) == tmp_path / "out.npz"

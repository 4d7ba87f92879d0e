"""Issue 25: `incandescent simulate` hardened — never a file it did not write replaced, frames on
a full disk named and never left truncated, resume checking the format, one validation path for
checkpoints and for settings (files, bools, sources, stability bounds), messages naming the key.

Each case runs the command line as a user meets it (typer's runner; a real private tmpfs for the
full disk) on tiny grids (16 cells on the longest side), asserting the exit status, the one error
line and what is left on disk.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from _mounts import skip_without_private_mounts
from typer.testing import CliRunner

from incandescent.cli import app
from incandescent.io import openvdb

runner = CliRunner()
TINY = ("--resolution", "16", "--backend", "cpu")


def _simulate(out: Path, *args) -> object:
    return runner.invoke(app, ["simulate", "torch", "-o", str(out), *TINY, *map(str, args)])


def _error(result, *fragments: str) -> str:
    """The one error line of a failed command; asserts exit 2, no traceback, the fragments."""
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output
    text = " ".join(result.output.split())  # the console may wrap a long line
    assert text.count("error:") == 1, result.output
    line = text[text.index("error:") :]
    for fragment in fragments:
        assert fragment in line, line
    return line


def _ok(result) -> None:
    assert result.exit_code == 0, result.output


def _checkpoint_frame(folder: Path) -> int:
    with np.load(folder / "checkpoint.npz") as data:
        return int(data["frame"])


# --- 1: a file this run did not write is never replaced without --overwrite -------------------


def test_frames_in_a_folder_without_a_checkpoint_are_refused_before_any_work(tmp_path):
    out = tmp_path / "fire"
    out.mkdir()
    (out / "fire_0002.npz").write_bytes(b"someone else's frame")
    line = _error(_simulate(out, "--frames", 3), "fire_0002.npz", "already exists", "--overwrite")
    assert "no checkpoint" in line
    assert sorted(p.name for p in out.iterdir()) == ["fire_0002.npz"]  # no checkpoint, no frame
    assert (out / "fire_0002.npz").read_bytes() == b"someone else's frame"
    _ok(_simulate(out, "--frames", 3, "--overwrite"))
    assert _checkpoint_frame(out) == 3 and (out / "fire_0002.npz").stat().st_size > 100


def test_on_resume_only_the_frame_after_the_checkpoint_may_be_replaced(tmp_path):
    """A run stopped between committing frame 3 and its checkpoint leaves fire_0003: the next
    run replaces it; a fire_0005 no checkpoint accounts for is refused."""
    out = tmp_path / "fire"
    _ok(_simulate(out, "--frames", 2))
    shutil.copy(out / "fire_0002.npz", out / "fire_0003.npz")  # the interrupted frame 3
    (out / "fire_0005.npz").write_bytes(b"not ours")
    _error(_simulate(out, "--frames", 5), "fire_0005.npz", "checkpoint is at frame 2")
    assert (out / "fire_0005.npz").read_bytes() == b"not ours" and _checkpoint_frame(out) == 2
    (out / "fire_0005.npz").unlink()
    _ok(_simulate(out, "--frames", 3))
    assert _checkpoint_frame(out) == 3
    with np.load(out / "fire_0003.npz") as three, np.load(out / "fire_0002.npz") as two:
        assert not np.array_equal(three["temperature"], two["temperature"])  # simulated anew


# --- 2: a full disk names the frame and leaves nothing truncated -----------------------------


def _full_disk_run(tmp_path: Path, suffix: str, free_kib: int) -> tuple[str, Path]:
    """Frame 1 in a 2 MiB tmpfs, then the disk filled up to ``free_kib`` KiB and frames 2–3
    asked for; returns (stderr, a copy of the folder as the failed run left it)."""
    skip_without_private_mounts()
    mount, kept = tmp_path / "mnt", tmp_path / "kept"
    mount.mkdir()
    command = " ".join([sys.executable, "-m", "incandescent.cli", "simulate", "torch", *TINY,
                        "--format", suffix[1:], "-o", f"{mount}/fire"])  # fmt: skip
    script = (
        f"mount -t tmpfs -o size=2m tmpfs {mount} && {command} --frames 1 >/dev/null && "
        f"(dd if=/dev/zero of={mount}/fill bs=4k 2>/dev/null; "
        f"truncate -s -{free_kib}K {mount}/fill) && "
        f"{command} --frames 3 >/dev/null; echo rc=$? >&2; cp -a {mount}/fire {kept}"
    )
    result = subprocess.run(["unshare", "-rm", "sh", "-c", script], capture_output=True, text=True)
    assert "rc=2" in result.stderr, result.stderr
    assert "Traceback" not in result.stderr
    return result.stderr, kept


@pytest.mark.parametrize("suffix", [".npz", ".vdb"])
@pytest.mark.parametrize("free_kib", [4, 40], ids=["frame-does-not-fit", "checkpoint-does-not"])
def test_a_full_disk_names_the_frame_and_leaves_nothing_truncated(tmp_path, suffix, free_kib):
    """Whether the frame (4 KiB free) or its checkpoint (40 KiB free: the checkpoint is ~65 KB)
    does not fit, the error names fire_0002, and the folder is as frame 1 left it: frame 1 and
    its checkpoint intact, no frame 2, no temporary file — so the run resumes once there is
    space."""
    if suffix == ".vdb" and openvdb.problem() is not None:
        pytest.skip(str(openvdb.problem()))
    stderr, kept = _full_disk_run(tmp_path, suffix, free_kib)
    error = " ".join(line for line in stderr.splitlines() if line.startswith("error:"))
    assert "frame 2" in error and f"fire_0002{suffix}" in error, stderr
    assert "No space left on device" in error or "does not read back" in error, stderr
    if suffix == ".npz" and free_kib == 4:  # the frame itself fails, before its checkpoint
        assert "checkpoint" not in error, error
    names = ["checkpoint.npz", "diagnostics.jsonl", f"fire_0001{suffix}"]
    assert sorted(p.name for p in kept.iterdir()) == names
    assert _checkpoint_frame(kept) == 1
    from incandescent import api

    assert api.load_volume(kept / f"fire_0001{suffix}").temperature_K.max() > 1000.0
    _ok(_simulate(kept, "--frames", 2, "--format", suffix[1:]))  # resumes where it stopped


def test_a_vdb_frame_that_does_not_fit_fails_at_the_frame_itself(tmp_path):
    if openvdb.problem() is not None:
        pytest.skip(str(openvdb.problem()))
    stderr, kept = _full_disk_run(tmp_path, ".vdb", 4)
    error = " ".join(line for line in stderr.splitlines() if line.startswith("error:"))
    assert "cannot write" in error and "fire_0002.vdb:" in error and "checkpoint" not in error


# --- 3: resume checks the frame format --------------------------------------------------------


def test_resuming_in_another_format_is_refused_naming_both(tmp_path):
    out = tmp_path / "fire"
    _ok(_simulate(out, "--frames", 2))
    before = sorted(p.name for p in out.iterdir())
    _error(_simulate(out, "--frames", 3, "--format", "vdb"), ".npz", ".vdb", "--format npz")
    assert sorted(p.name for p in out.iterdir()) == before and _checkpoint_frame(out) == 2


def test_a_checkpoint_without_a_recorded_format_takes_its_frames_format(tmp_path):
    """A checkpoint written before the format was recorded: the frames on disk say it."""
    out = tmp_path / "fire"
    _ok(_simulate(out, "--frames", 2))
    data = dict(np.load(out / "checkpoint.npz"))
    del data["format"]
    np.savez(out / "checkpoint.npz", **data)
    _error(_simulate(out, "--frames", 3, "--format", "vdb"), ".npz", ".vdb")
    _ok(_simulate(out, "--frames", 3))


# --- 4: one validation path for checkpoints, and no "pickled data" ----------------------------


def _tampered(out: Path, **changes) -> None:
    data = dict(np.load(out / "checkpoint.npz"))
    for key, value in changes.items():
        if value is None:
            del data[key]
        else:
            data[key] = value
    np.savez(out / "checkpoint.npz", **data)


def _with_nan(out: Path) -> np.ndarray:
    with np.load(out / "checkpoint.npz") as data:
        t = data["temperature"].copy()
    t[3] = np.nan
    return t


CHECKPOINTS = {
    "negative frame": (lambda out: _tampered(out, frame=np.int64(-1)), "frame is -1"),
    "float frame": (lambda out: _tampered(out, frame=np.float64(2.0)), "not an integer"),
    "wrong shape": (lambda out: _tampered(out, phi=np.zeros(7)), "phi is float64 of shape (7,)"),
    "nan": (lambda out: _tampered(out, temperature=_with_nan(out)), "temperature holds NaN"),
    "missing key": (lambda out: _tampered(out, soot=None), "no 'soot' array"),
    "huge member": (lambda out: _tampered(out, soot=np.zeros(300_000)), "inflates to"),
    "random bytes": (
        lambda out: (out / "checkpoint.npz").write_bytes(np.random.default_rng(1).bytes(5000)),
        "not an .npz archive",
    ),
    "a .npy array": (
        lambda out: np.save(open(out / "checkpoint.npz", "wb"), np.zeros(4)),  # noqa: SIM115
        "not a readable checkpoint",
    ),
}


@pytest.mark.parametrize("case", CHECKPOINTS)
def test_a_bad_checkpoint_is_refused_naming_it_and_writes_nothing(tmp_path, case):
    out = tmp_path / "fire"
    _ok(_simulate(out, "--frames", 2))
    damage, fragment = CHECKPOINTS[case]
    damage(out)
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    line = _error(_simulate(out, "--frames", 4), "checkpoint.npz", fragment, "--overwrite")
    assert "pickled" not in line and "drjit" not in line.lower()
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before  # no fire_-001, nothing new
    _ok(_simulate(out, "--frames", 2, "--overwrite"))  # the way out it names


def test_random_bytes_as_an_npz_volume_are_not_called_pickled_data(tmp_path):
    path = tmp_path / "noise.npz"
    path.write_bytes(np.random.default_rng(0).bytes(4096))
    for command in (["info", str(path)], ["render", str(path), "-o", str(tmp_path / "o.png")]):
        line = _error(runner.invoke(app, command), "noise.npz", "not an .npz archive")
        assert "pickled" not in line


# --- 5, 6, 9: settings validated strictly, naming the key -------------------------------------


def _settings(tmp_path: Path, text: str, name: str = "s.toml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


@pytest.mark.parametrize(
    ("text", "fragments"),
    [
        ("seed = true", ["seed", "valid integer", "True (bool)"]),
        ("maccormack = 1", ["maccormack", "valid boolean"]),
        ("fps = '24'", ["fps", "'24' (str)"]),
        (
            "[[sources]]\ncentre = [0.5, 1.5, 0.5]",
            ["sources.0.centre", "outside the domain", "0.3 × 0.6 × 0.3 m"],
        ),
        ("t_max_K = 1e30", ["t_max_K", "less than or equal to 100000", "emission tables"]),
        ("gravity_m_s2 = 1e30", ["gravity_m_s2", "faster than sound", "at most 1.18e+05"]),
        ("buoyancy_m_s2_K = 0.01", ["buoyancy_m_s2_K was removed", "gravity_m_s2"]),
        ("[[sources]]\nkind = 'nozzle'\njet_m_s = 900.0", ["sources.0.jet_m_s", "sound"]),
        ("density_ratio = 1e4", ["flame_speed_m_s", "density_ratio", "sound"]),
    ],
)
def test_settings_are_refused_naming_the_key_before_any_work(tmp_path, text, fragments):
    out = tmp_path / "fire"
    path = _settings(tmp_path, text)
    line = _error(_simulate(out, "--settings", path), "s.toml", *fragments)
    assert "--scale" not in line and "--temperature-range" not in line  # render's advice
    assert not out.exists()


def test_a_tiny_domain_is_refused_naming_domain_m(tmp_path):
    out = tmp_path / "fire"
    for text, fragment in [
        ("domain_m = [1e-8, 1e-8, 1e-8]", "a cell must be 1e-06"),
        ("domain_m = [0.3, 0.01, 0.3]", "the y side (0.01 m) is 0.53 cells"),
    ]:
        _error(_simulate(out, "--settings", _settings(tmp_path, text)), "domain_m", fragment)
        assert not out.exists()


def test_seed_from_the_flag_is_named_as_from_the_flag(tmp_path):
    line = _error(_simulate(tmp_path / "fire", "--seed", "-3"), "--seed", "seed")
    assert "greater than or equal to 0" in line


# --- 7: settings files that are not settings --------------------------------------------------


SETTINGS_FILES = {
    "bad syntax.toml": (b"seed = = 3\n", "TOML syntax error at line 1"),
    "bad syntax.json": (b'{"seed": 3,}', "JSON syntax error at line 1"),
    "binary.json": (b"\x00\xff\xfe\x80" * 64, "not UTF-8 text"),
    "deep.json": (b"[" * 100_000 + b"]" * 100_000, "nested too deeply"),
    "deep.toml": (b"a = " + b"[" * 100_000 + b"]" * 100_000, "nested too deeply"),
    "yaml.yaml": (b"seed: 3\n", "unsupported settings format ('.yaml'); expected a .toml or .json"),
    "yaml.json": (b"seed: 3\nfps: 24\n", "JSON syntax error"),
    "list.json": (b"[1, 2, 3]", "expected a table of FireSettings keys"),
    "missing.json": (None, "no such settings file"),
}


@pytest.mark.parametrize("name", SETTINGS_FILES)
def test_a_settings_file_that_is_not_settings_is_one_line_naming_it(tmp_path, name):
    content, fragment = SETTINGS_FILES[name]
    path = tmp_path / name
    if content is not None:
        path.write_bytes(content)
    _error(_simulate(tmp_path / "fire", "--settings", path), name, fragment)
    assert not (tmp_path / "fire").exists()


def test_a_settings_folder_is_named(tmp_path):
    folder = tmp_path / "s.json"
    folder.mkdir()
    _error(_simulate(tmp_path / "fire", "--settings", folder), "s.json", "is a folder")


# --- 8: a run that goes non-finite names the frame and the key, and leaves no empty folder ----


def test_a_run_gone_non_finite_names_the_frame_and_key_and_leaves_no_folder(tmp_path):
    out = tmp_path / "new" / "fire"
    path = _settings(tmp_path, "vorticity = 1e37")
    _error(_simulate(out, "--settings", path, "--frames", 3),
           "frame 1", "non-finite", "vorticity = 1e+37", "frame 1 was not written")  # fmt: skip
    assert not (tmp_path / "new").exists()  # neither the folder nor the parent it made
    out.mkdir(parents=True)  # a folder the user made stays, as it was: empty
    _error(_simulate(out, "--settings", path, "--frames", 3), "frame 1", "vorticity")
    assert out.is_dir() and list(out.iterdir()) == []


def test_a_speed_gone_infinite_between_frames_is_reported_as_non_finite(tmp_path):
    """Confinement 10²⁸ × the presets': frame 1 ends with max |u| ~10²⁸ m/s, finite; the next
    frame's sub-steps, measured from a speed that overflows float32, stop the run with the
    one-line non-finite error naming frame 2 (once an OverflowError from the sub-step count)."""
    path = _settings(tmp_path, "vorticity = 1e30")
    _error(_simulate(tmp_path / "fire", "--settings", path, "--frames", 3),
           "frame 2", "non-finite", "vorticity = 1e+30", "frame 2 was not written")  # fmt: skip


def test_a_run_gone_non_finite_later_keeps_its_frames_to_resume(tmp_path, monkeypatch):
    """Frames already committed stay (with their checkpoint); only the bad one is not written."""
    from incandescent.simulation import run

    real = run.frame_fields
    calls = {"n": 0}

    def poisoned(solver, state):
        fields = real(solver, state)
        calls["n"] += 1
        if calls["n"] == 2:
            fields["temperature_K"].flat[0] = np.nan
        return fields

    monkeypatch.setattr(run, "frame_fields", poisoned)
    out = tmp_path / "fire"
    line = _error(_simulate(out, "--frames", 3), "frame 2", "temperature_K")
    assert "one of gravity_m_s2" in line  # no key out of range: all the driving ones named
    names = ["checkpoint.npz", "diagnostics.jsonl", "fire_0001.npz"]
    assert sorted(p.name for p in out.iterdir()) == names
    assert _checkpoint_frame(out) == 1


# --- 10: small memory budgets read sensibly ---------------------------------------------------


def test_a_small_memory_limit_is_shown_in_kib_not_zero_mib(tmp_path):
    line = _error(_simulate(tmp_path / "fire", "--max-memory", "0.0001"),
                  "needs about 208 KiB of memory, more than the 105 KiB allowed")  # fmt: skip
    assert "0 MiB" not in line
    assert not (tmp_path / "fire").exists()


def test_gib_keeps_three_significant_digits_below_a_gib():
    from incandescent.budget import gib

    assert [gib(n) for n in (512, 1536, 107374, 2**20, 1.5 * 2**20, 26 * 2**30)] == [
        "512 bytes", "1.5 KiB", "105 KiB", "1 MiB", "1.5 MiB", "26.0 GiB"
    ]  # fmt: skip


def test_the_settings_json_round_trip_keeps_presets_valid():
    """Every preset passes its own strict validation (JSON mode, as files are read)."""
    from incandescent.simulation.settings import PRESETS, from_changes

    for name, settings in PRESETS.items():
        assert from_changes(name, json.loads(settings.model_dump_json())) == settings


# --- issue 28: each frame's diagnostics beside the frames, shown by `info FOLDER` -------------


def test_info_on_a_simulation_folder_shows_its_diagnostics_and_a_capped_frame(tmp_path):
    """`simulate` writes one record per frame to diagnostics.jsonl and prints a frame's CFL and
    speed; a frame over the step cap is a warning line; `info FOLDER` shows the table (capped
    frames named) and `--json` the records; resuming keeps the records one per frame."""
    out = tmp_path / "fire"
    path = _settings(tmp_path, "max_steps_per_frame = 1\ncfl = 0.25")
    result = _simulate(out, "--settings", path, "--frames", 2)
    _ok(result)
    text = " ".join(result.output.split())
    assert "CFL" in text and "max |u|" in text and "hit max_steps_per_frame" in text
    _ok(_simulate(out, "--settings", path, "--frames", 3))  # resumed: frame 3 added
    shown = runner.invoke(app, ["info", str(out), "--json"])
    _ok(shown)
    frames = json.loads(shown.output)["frames"]
    assert [r["frame"] for r in frames] == [1, 2, 3] and all(r["capped"] for r in frames)
    table = runner.invoke(app, ["info", str(out)])
    _ok(table)
    assert "CFL max" in table.output and "hit max_steps_per_frame" in " ".join(table.output.split())
    _error(runner.invoke(app, ["info", str(tmp_path)]), "without diagnostics.jsonl")

"""docs/cli.md is what scripts/cli_reference.py generates from the typer app: the reference
stays true as the command line changes."""

from __future__ import annotations

import importlib.util
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def _generator():
    spec = importlib.util.spec_from_file_location(
        "_script_cli_reference", ROOT / "scripts" / "cli_reference.py"
    )
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_docs_cli_md_is_up_to_date():
    expected = _generator().generate()
    current = (ROOT / "docs" / "cli.md").read_text(encoding="utf-8")
    assert current == expected, (
        "docs/cli.md differs from the command line: run "
        "`.venv/bin/python scripts/cli_reference.py` and commit docs/cli.md"
    )


def test_the_reference_lists_every_command_and_option():
    from typer.main import get_command

    from incandescent.cli import app

    text = _generator().generate()
    group = get_command(app)
    for name, command in group.commands.items():
        assert f"\n## incandescent {name}\n" in text
        for param in command.params:
            for flag in param.opts if param.param_type_name == "option" else []:
                assert f"`{flag}`" in text, (name, flag)
    assert "\x1b" not in text  # no terminal escape codes


def test_the_reference_does_not_depend_on_the_terminal_width(monkeypatch):
    generator = _generator()
    monkeypatch.setenv("COLUMNS", "40")
    narrow = generator.generate()
    monkeypatch.setenv("COLUMNS", "300")
    assert generator.generate() == narrow


def test_check_mode_reports_a_stale_file(tmp_path, capsys):
    generator = _generator()
    out = tmp_path / "cli.md"
    out.write_text("stale\n", encoding="utf-8")
    assert generator.main(["--out", str(out), "--check"]) == 1
    assert "scripts/cli_reference.py" in capsys.readouterr().out
    assert generator.main(["--out", str(out)]) == 0
    assert generator.main(["--out", str(out), "--check"]) == 0
    assert not list(tmp_path.glob(".*.tmp"))

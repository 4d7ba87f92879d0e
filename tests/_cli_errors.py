"""What every bad-input test of the CLI checks: exit status 2, one ``error:`` line naming what it
must, and no traceback."""

from __future__ import annotations


def one_line_error(result, *fragments: str) -> str:
    """The error line of a CliRunner ``result`` (status 2, one ``error:``, no traceback), after
    checking it holds every one of ``fragments``."""
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output
    line = " ".join(result.output.split())
    assert line.count("error:") == 1, result.output
    for fragment in fragments:
        assert fragment in line, line
    return line

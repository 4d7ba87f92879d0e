"""``python -m incandescent.cli``: the command line."""

from incandescent.cli import app

app()

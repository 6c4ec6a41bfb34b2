"""``python -m fogsim`` = the ``fogsim`` command."""

from fogsim.cli import entry

entry()

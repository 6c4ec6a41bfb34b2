"""``python -m fogsim`` = the ``fogsim`` command."""

from fogsim.cli import main

raise SystemExit(main())

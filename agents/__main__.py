"""``python -m agents``: the ``slam-env`` command."""

from agents.cli import main

raise SystemExit(main())

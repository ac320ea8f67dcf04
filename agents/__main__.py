"""``python -m agents``: the ``slam-env`` command."""

from agents.cli.main import main

raise SystemExit(main())

"""The ``slam-env`` command (also ``python -m agents``): train, evaluate, suite, demo."""

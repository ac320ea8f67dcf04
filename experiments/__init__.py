"""Research scripts: what was tried and measured about the agents' choices (the research
record in the docs cites each with its command, ``python -m experiments.NAME``)."""

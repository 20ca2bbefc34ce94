"""``python -m rths`` is the same as the ``rths`` console script."""

from rths.cli import console

console()

"""``python -m rths`` is the same as the ``rths`` console script."""

import sys

from rths.cli import main

sys.exit(main())

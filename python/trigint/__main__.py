"""``python -m trigint``: the ``trigint`` command."""

import sys

from .cli import main

sys.exit(main())

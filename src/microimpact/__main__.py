"""``python -m microimpact``: the command line, as the ``microimpact`` script."""

import sys

from .cli import main

sys.exit(main())

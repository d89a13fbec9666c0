"""``python -m microimpact.cli``."""

import sys

from . import main

sys.exit(main())

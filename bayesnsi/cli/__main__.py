"""``python -m bayesnsi.cli``."""

import sys

from . import main

sys.exit(main())

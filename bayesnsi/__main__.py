"""``python -m bayesnsi``: the command line (:func:`bayesnsi.cli.main`)."""

import sys

from .cli import main

if __name__ == "__main__":
    sys.exit(main())

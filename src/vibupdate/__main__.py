"""``python -m vibupdate``: the command line (`vibupdate.cli`)."""

import sys

from vibupdate.cli import main

if __name__ == "__main__":
    sys.exit(main())

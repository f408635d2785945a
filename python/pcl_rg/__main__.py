"""`python -m pcl_rg`: the command line."""

import sys

from .cli import main

# Guarded: worker processes started by `pcl-rg batch` import the main module again.
if __name__ == "__main__":
    sys.exit(main())

"""`python -m pcl_rg`: the command line."""

import sys

from .cli import main

sys.exit(main())

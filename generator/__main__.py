"""`python -m s2gen` runs the command line."""

import sys

from s2gen.cli import main

sys.exit(main())

"""`python -m s2gen.experiments.unseen` runs the benchmark (see the package docstring)."""

import sys

from s2gen.experiments.unseen.command import main

sys.exit(main())

"""`python -m cosim.sensing`: the sensing study's table (cosim.sensing.study)."""

import sys

from .study import main

sys.exit(main())

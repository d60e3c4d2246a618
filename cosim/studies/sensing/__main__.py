"""`python -m cosim.studies.sensing`: the sensing study's table (cosim.studies.sensing.study)."""

import sys

from .study import main

sys.exit(main())

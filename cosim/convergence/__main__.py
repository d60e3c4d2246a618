"""`python -m cosim.convergence`: the FMU convergence study (cosim/convergence/__init__.py)."""

from . import main

raise SystemExit(main())

"""`python -m cosim.studies.convergence`: the FMU convergence study
(cosim/studies/convergence/__init__.py)."""

from . import main

raise SystemExit(main())

"""`python -m cosim.engines.native build`: build the native closed loop
(cosim/engines/native/build.py)."""

from .build import main

raise SystemExit(main())

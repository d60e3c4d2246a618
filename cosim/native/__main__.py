"""`python -m cosim.native build`: build the native closed loop (cosim/native/build.py)."""

from .build import main

raise SystemExit(main())

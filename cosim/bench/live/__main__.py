"""`python -m cosim.bench.live`: the live view's own process, started by `bowden bench watch` and
`run --live` (cosim.bench.live.view.ViewProcess), not by hand."""

import sys

from .view import view_main

if __name__ == "__main__":
    sys.exit(view_main(sys.argv[1:]))

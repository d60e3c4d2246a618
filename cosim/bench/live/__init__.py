"""The live view of a run (`bowden bench watch`, `run --live`): `view` (the ring a recording
fills, the terminal's and the page's views, the view's own process: `python -m
cosim.bench.live`) and `page` (the page's HTML and script). It reads the link's telemetry and
imports nothing of the simulation."""

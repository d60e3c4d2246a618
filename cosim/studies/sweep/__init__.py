"""`bowden sweep SPEC.yaml --out DIR`: many native closed-loop runs on Dask, one table.

Each point of the specification (cosim/studies/sweep/spec.py: a grid or a random sample over
scenario settings, end-effector position, plant parameters, gains and compensator mode) is one run
of the native engine (cosim/engines/native); the command line is cosim/cli/sweep.py. The points run
on a Dask cluster: by default a LocalCluster with one single-threaded worker process per core of
this machine; `--scheduler tcp://HOST:PORT` sends the same sweep to a running cluster (its workers
need this project installed and built, but not DIR: each returns its points' rows through Dask).
Outputs in DIR, written by `bowden sweep` alone:

- ``points/<id>.json``: one file per finished point, written atomically as its result arrives (a
  killed sweep restarts where it stopped: `bowden sweep` again with the same SPEC and DIR);
- ``sweep.parquet``: the table, one row per point (axis values, status, error, figures, the
  build that computed it: a row of a worker of another build is not saved, and the sweep exits 1);
- ``error_map.png`` (with a position_m axis) and ``error_vs_<axis>.png`` per numeric axis;
- ``summary.json``: points, failed, the table's and the plots' names.

Every file is written to a temporary name of the process's own and renamed into place. When every
point a run ran failed, no table is written and the sweep exits 1 with the first error.
"""

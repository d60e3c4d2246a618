"""Studies built on the engines: the paper's demo (demo), the workspace map (workspace), the
gain tuning (tune), parameter sweeps (sweep), the load-cell front-end choice (sensing) and the
FMU's convergence (convergence)."""

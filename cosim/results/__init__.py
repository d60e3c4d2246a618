"""What a run leaves behind and how it is judged: the trace format (trace), the tracking
metrics (metrics), the figures (plots) and the capstan friction fit (capstan_fit)."""

# --- live: the bench tool's API reference and the browser its live page is tested in -----------
# (cosim/bench/README.md, "Python API" and "Live view")
#
#   make bench-docs      build/docs/api: the reference of cosim.bench.api (pdoc), any warning an error
#   make browser-setup   Debian's chromium for the live page's headless test, when run as root with
#                        apt-get (.ci/run calls it before `make test`); elsewhere it says the test
#                        will skip. Never fatal. `make test` itself changes nothing outside the checkout.

.PHONY: bench-docs browser-setup

bench-docs: $(VENV_STAMP)
	$(PY) -W error -m pdoc --output-directory $(BUILD)/docs/api cosim.bench.api
	@echo "bench-docs: $(BUILD)/docs/api/cosim/bench/api.html"

browser-setup:
	@if command -v chromium >/dev/null 2>&1 || command -v chromium-browser >/dev/null 2>&1; then \
	  :; \
	elif [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then \
	  echo "browser-setup: installing Debian's chromium (the live page's headless test)"; \
	  { DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null 2>&1 || \
	    { apt-get update -qq >/dev/null 2>&1 && \
	      DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null 2>&1; }; } || \
	  echo "browser-setup: chromium could not be installed: the live page's browser test will skip"; \
	else \
	  echo "browser-setup: no chromium, and not root with apt-get: the live page's browser test will skip"; \
	fi

# A run of 60 s with both live views working: every sample recorded? (figures in
# cosim/bench/README.md, "Live view")
.PHONY: perf-live
PERF_TARGETS += perf-live

perf-live: $(BENCH_SO) fmu
	$(PY) -m cosim.perf.live_view --seconds 60

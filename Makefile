# Two commands a new user needs: `make demo` and `make test`. Both set up first when needed.
VENV ?= .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.pcrp-setup

.PHONY: setup demo test robustness eval bench robot clean-venv

setup: $(STAMP)

$(STAMP): requirements.txt requirements.lock setup.py
	@# open3d 0.20 cannot import without libusb; install it from Debian when missing.
	@ldconfig -p | grep -q 'libusb-1.0.so.0' || { \
	  echo "installing libusb-1.0-0 (needed by open3d)"; \
	  SUDO=$$( [ "$$(id -u)" = 0 ] || echo sudo ); \
	  $$SUDO apt-get update -qq && $$SUDO apt-get install -y -qq libusb-1.0-0; }
	@test -x $(PY) || python3 -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -r requirements.txt -c requirements.lock
	$(PY) -m pip install -q --no-deps -e .
	@touch $(STAMP)

demo: setup
	$(VENV)/bin/pcrp demo

# Two pytest processes, one per core: the node tests mostly wait on DDS and timers, so they share
# a core with the paper evaluation's quick run while everything else takes the other (on 2 cores,
# 9.5 minutes instead of 12.8 in one process; only the first uses DDS). The first's report follows
# the second's.
FIRST := test/ros test/tools/test_evaluation.py
test: setup
	@log=$$(mktemp); \
	$(PY) -m pytest -q $(FIRST) > $$log 2>&1 & first=$$!; \
	$(PY) -m pytest -q test $(FIRST:%=--ignore=%); rest=$$?; \
	echo "== $(FIRST) (run beside the above)"; wait $$first; mine=$$?; \
	cat $$log; rm -f $$log; exit $$(( rest || mine ))

# regenerates docs/results/ROBUSTNESS.md (about 15 minutes: every bad input, then a 10-minute soak)
robustness: setup
	$(PY) -m tools robustness --out docs/results

# regenerates docs/results/RESULTS.md: the paper's experiments and the baselines (about an hour on 2 cores);
# its seed was drawn fresh for the report (every choice was made at other seeds) and used once
eval: setup
	$(PY) -m tools paper-eval --data ../shared/data/modelnet40 --out docs/results --seed 20261202

# regenerates docs/results/BENCHMARKS.md: speed, memory, scale, the node under load (about 30 minutes;
# 55 when a change to pcrp_core makes it build its galleries and models again)
bench: setup
	$(PY) -m tools bench --out docs/results

# regenerates docs/results/ROBOT_validation.md (pcrp only, with the min_confidence sweep: about 6
# minutes) and ROBOT.md (pcrp and Open3D's pipelines on YCB depth-camera views: about an hour on a
# shared 2-core machine, nearly all of it Open3D's; --baseline-views 1 halves that), then
# SEGMENTATION_validation.md and SEGMENTATION.md (the same views as a segmenter may cut them: about
# 7 minutes each)
robot: setup
	$(PY) -m tools robot-report --data ../shared/data/ycb --out docs/results --split validation --no-baselines
	$(PY) -m tools robot-report --data ../shared/data/ycb --out docs/results
	$(PY) -m tools segmentation-report --data ../shared/data/ycb --out docs/results --split validation
	$(PY) -m tools segmentation-report --data ../shared/data/ycb --out docs/results

clean-venv:
	rm -rf $(VENV)

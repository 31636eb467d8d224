# The README's commands. Everything runs inside .venv with ROS 2 Jazzy sourced (scripts/env.sh).
SHELL := /bin/bash
.DEFAULT_GOAL := help
ENV := source scripts/env.sh &&
SIM := install/tracker_ptz_sim/lib/tracker_ptz_sim
PYTEST_ARGS ?=
VIDEO ?=
DEMO_ARGS ?=
STRESS_ARGS ?=
BENCHMARK_ARGS ?=
SCENE ?=
GT ?=

.PHONY: help setup build test lint format shell sample demo rtsp-server bench benchmark stress evaluate clean freeze check-apt-pins

help:  ## List the targets
	@grep -E '^[a-z]+:.*## ' $(MAKEFILE_LIST) | awk -F':.*## ' '{printf "  make %-10s %s\n", $$1, $$2}'

setup:  ## Create .venv, install ROS 2 Jazzy + libraries (pinned), build the workspace (idempotent)
	@bash scripts/setup.sh

build: setup  ## Rebuild the workspace (colcon build --symlink-install)
	@$(ENV) colcon build --symlink-install --event-handlers console_cohesion- summary+ $$(bash scripts/installed_interfaces.sh)

lint: setup  ## ruff lint + format check + mypy type check
	@$(ENV) ruff check src tests bench scripts && ruff format --check src tests bench scripts && mypy

format: setup  ## Apply ruff's fixes and formatting
	@$(ENV) ruff check --fix src tests bench scripts; ruff format src tests bench scripts

test: setup lint  ## Set up if needed, build, lint, and run every test
	@$(ENV) python -m pytest tests/ $(PYTEST_ARGS)

shell: setup  ## A bash shell with ROS 2, the venv and this workspace sourced
	@bash --rcfile scripts/shell-rc.sh -i

sample: setup  ## Fetch and verify the sample clip vtest.avi (cached outside the repository)
	@$(ENV) $(SIM)/fetch_sample

demo: setup  ## Run the surveillance demo (VIDEO=path/to/video to use your own; LIVE=1: Foxglove live view)
	@$(ENV) $(SIM)/run_demo $(if $(VIDEO),--video "$(VIDEO)") $(if $(LIVE),--live) $(DEMO_ARGS)

rtsp-server: setup  ## Serve VIDEO (default vtest.avi) as an RTSP camera on rtsp://127.0.0.1:8554/live (PORT=...)
	@$(ENV) bash scripts/rtsp_camera.sh "$(VIDEO)" "$(or $(PORT),8554)"

bench: setup  ## Benchmarks: prints tables, writes out/bench/*.json
	@$(ENV) for b in bench/bench_*.py; do echo "== $$b"; python "$$b" || exit 1; done

benchmark: setup  ## Accuracy of record on real people: the annotated clip (graph + in-process) and real-people scenes (out/benchmark); CamShift / colour particles per person (out/single_target); voxel rooms (out/voxel_benchmark)
	@$(ENV) $(SIM)/benchmark --graph vtest $(BENCHMARK_ARGS) && $(SIM)/single_target_benchmark && $(SIM)/voxel_benchmark

evaluate: setup  ## Score the graph against ground truth: SCENE=dir, or VIDEO=file GT=gt.txt (default: a street scene)
	@$(ENV) if [ -n "$(VIDEO)" ]; then $(SIM)/evaluate --video "$(VIDEO)" --gt "$(GT)" $(DEMO_ARGS); \
	  else scene="$(or $(SCENE),out/scenes/walkers)"; \
	    [ -n "$(SCENE)" ] || [ -f "$$scene/scene.json" ] || $(SIM)/make_scene "$$scene" --street walkers; \
	    $(SIM)/evaluate --scene "$$scene" --out out/eval $(DEMO_ARGS); fi

stress: setup  ## Shutdown stress: 50 SIGINT/SIGTERM per node at random moments, exit-code histogram
	@$(ENV) python scripts/stress_signals.py $(STRESS_ARGS)

clean:  ## Remove build products (keeps .venv and the sample cache)
	rm -rf build install log out

check-apt-pins:  ## The no-ROS tests on the libraries an apt ROS 2 Jazzy gets (NumPy 1.26, constraints-apt.txt)
	@bash scripts/check_apt_pins.sh

freeze: setup  ## Rewrite constraints.txt from the current .venv
	@$(ENV) pip freeze --exclude-editable | grep -vE '^[A-Za-z0-9]+(_[A-Za-z0-9]+)+==|^(rclpy|rcutils|pip|setuptools|wheel)==' | sort -f > constraints.tmp && \
	  { echo "# Exact versions of every Python package the workspace installs (pip install -c constraints.txt)."; \
	    echo "# Regenerate with 'make freeze' after changing requirements.txt."; cat constraints.tmp; } > constraints.txt && rm constraints.tmp

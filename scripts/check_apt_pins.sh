#!/usr/bin/env bash
# `make check-apt-pins`: the libraries as an apt-installed ROS 2 Jazzy gets them (NumPy 1.26 and
# constraints-apt.txt's pins, see scripts/constraints.sh) in a fresh venv, then every test that
# needs no ROS (the algorithms, scenes, metrics, the filters' kernels) run against them. The ROS
# side itself is the apt install's (built for NumPy 1.26); this checks our code and pins fit it.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VENV="${CHECK_VENV:-$ROOT/.venv-apt-check}"
PYTHON="${PYTHON:-python3}"
say() { printf '\033[1m[check-apt-pins]\033[0m %s\n' "$*"; }

[ -x "$VENV/bin/python" ] || { say "creating $VENV"; "$PYTHON" -m venv "$VENV"; }
bash "$ROOT/scripts/constraints.sh" apt "$VENV/constraints-apt.txt"
libs="$(sed -n '/^# --- libs ---/,/^# --- no-deps ---/p' "$ROOT/requirements.txt" | grep -v '^#')"
nodeps="$(sed -n '/^# --- no-deps ---/,$p' "$ROOT/requirements.txt" | grep -v '^#')"
say "installing the libraries with the apt pins"
# shellcheck disable=SC2086
"$VENV/bin/pip" install -q --disable-pip-version-check -c "$VENV/constraints-apt.txt" $libs \
  2> >(grep -v "is ignored: it is neither a file nor a directory" >&2)
# shellcheck disable=SC2086
"$VENV/bin/pip" install -q --disable-pip-version-check --no-deps -c "$VENV/constraints-apt.txt" $nodeps
"$VENV/bin/python" -c 'import numpy; assert numpy.__version__.startswith("1."), numpy.__version__; print("numpy", numpy.__version__)'
say "running the tests that need no ROS"
cd "$ROOT"
PYTHONPATH="$ROOT/src/tracker_msgs:$ROOT/src/tracker_detect:$ROOT/src/tracker_filter:$ROOT/src/tracker_ptz_sim" \
  "$VENV/bin/python" -m pytest tests/ -q -p no:cacheprovider -m "not ros" "$@"

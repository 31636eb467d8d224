#!/usr/bin/env bash
# scripts/constraints.sh MODE OUT: write the pip constraints for MODE (wheels | apt) to OUT:
# constraints.txt, with constraints-apt.txt's pins replacing its own for apt (an apt-installed ROS 2
# Jazzy is built for the system's NumPy 1.26).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
mode="$1" out="$2"
if [ "$mode" = apt ]; then
  names="$(grep -oE '^[A-Za-z0-9_.-]+==' "$ROOT/constraints-apt.txt" | tr -d '=' | paste -sd'|')"
  { grep -viE "^($names)==" "$ROOT/constraints.txt"; grep -v '^#' "$ROOT/constraints-apt.txt"; } > "$out"
else
  cp "$ROOT/constraints.txt" "$out"
fi

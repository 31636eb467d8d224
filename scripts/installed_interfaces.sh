#!/usr/bin/env bash
# Prints colcon's `--packages-skip ...` for this workspace's stand-ins of standard interface
# packages (src/interfaces: vision_msgs, tf2_msgs, ptz_action_server_msgs) that the sourced ROS already provides, so the
# installed ones are used (an overlay would hide the messages they have and ours leave out).
# Needs the ROS environment sourced (AMENT_PREFIX_PATH). Prints nothing when none is installed.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
skip=()
for package in "$root"/src/interfaces/*/; do
  name="$(basename "$package")"
  IFS=: read -r -a prefixes <<< "${AMENT_PREFIX_PATH:-}"
  for prefix in "${prefixes[@]}"; do
    case "$prefix" in "$root"/install*) continue ;; esac
    if [ -f "$prefix/share/$name/package.xml" ]; then skip+=("$name"); break; fi
  done
done
if [ ${#skip[@]} -gt 0 ]; then echo "--packages-skip ${skip[*]}"; fi

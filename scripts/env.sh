# Source this file (bash) for a shell with ROS 2 Jazzy, the venv and this workspace set up:
#   source scripts/env.sh            (or: make shell)
# With --no-workspace it skips install/setup.bash (used by setup.sh before the first build).
_tracker_root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
if [ ! -x "$_tracker_root/.venv/bin/python" ]; then
  echo "scripts/env.sh: no .venv yet; run 'make setup' first" >&2
  return 1 2>/dev/null || exit 1
fi
if [ -f /opt/ros/jazzy/setup.bash ] && [ -z "${TRACKER_FORCE_WHEELS:-}" ]; then
  # shellcheck disable=SC1091
  source /opt/ros/jazzy/setup.bash
  # shellcheck disable=SC1091
  source "$_tracker_root/.venv/bin/activate"
else
  # shellcheck disable=SC1091
  source "$_tracker_root/.venv/local_setup.bash"
fi
# Images travel through Fast DDS shared memory only with a segment larger than the default 0.5 MB.
export FASTRTPS_DEFAULT_PROFILES_FILE="${FASTRTPS_DEFAULT_PROFILES_FILE:-$_tracker_root/src/tracker_ptz_sim/config/fastdds_shm.xml}"
# Multi-megabyte images from the heap instead of a fresh mmap each (page faults on every image):
# the same value as tracker_ptz_sim.bringup.graph.MALLOC_TUNABLES (tested equal).
export GLIBC_TUNABLES="${GLIBC_TUNABLES:-glibc.malloc.mmap_threshold=4194304:glibc.malloc.trim_threshold=134217728}"
if [ "${1:-}" != "--no-workspace" ] && [ -f "$_tracker_root/install/setup.bash" ]; then
  # shellcheck disable=SC1091
  source "$_tracker_root/install/setup.bash"
fi
unset _tracker_root

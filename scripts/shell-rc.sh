# rcfile for `make shell`: the user's bashrc, then the workspace environment.
# shellcheck disable=SC1090,SC1091
[ -f ~/.bashrc ] && source ~/.bashrc
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
PS1="(tracker) ${PS1:-\$ }"
echo "ROS 2 Jazzy + tracker workspace sourced. Try: ros2-style runs like install/tracker_ptz_sim/lib/tracker_ptz_sim/video_source"

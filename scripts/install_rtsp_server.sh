#!/usr/bin/env bash
# GStreamer's RTSP server on the system Python (scripts/rtsp_server.py needs it): installs Debian's
# packages when `import gi` with GstRtspServer fails. Used by .ci/run and `make rtsp-server`.
set -euo pipefail
if /usr/bin/python3 -c "import gi; gi.require_version('GstRtspServer', '1.0')" 2>/dev/null; then
  exit 0
fi
packages=(python3-gi gir1.2-gst-rtsp-server-1.0 gstreamer1.0-plugins-good gstreamer1.0-plugins-base)
sudo=""
[ "$(id -u)" -ne 0 ] && sudo="sudo"
echo "installing GStreamer's RTSP server: ${packages[*]}"
$sudo apt-get update -qq
DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq "${packages[@]}" >/dev/null

#!/usr/bin/env bash
# `make rtsp-server`: serve a video as a local RTSP camera (for trying `make demo VIDEO=rtsp://...`
# without a camera). Installs GStreamer's RTSP server from Debian if it is missing, writes the
# video's frames as JPEG into out/rtsp_frames, and serves them looping until Ctrl-C.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VIDEO="${1:-}"
PORT="${2:-8554}"
bash "$ROOT/scripts/install_rtsp_server.sh"
FRAMES="$ROOT/out/rtsp_frames"
rm -rf "$FRAMES" && mkdir -p "$FRAMES"
FPS="$(python - "$VIDEO" "$FRAMES" <<'PY'
import sys
import cv2
from tracker_ptz_sim.bringup.sample import fetch_sample
from tracker_ptz_sim.simulation.frame_sources import open_source
source = open_source(sys.argv[1] or fetch_sample())
for frame in source.frames():
    cv2.imwrite(f"{sys.argv[2]}/{frame.index:06d}.jpg", frame.image, [cv2.IMWRITE_JPEG_QUALITY, 90])
print(max(1, round(source.fps)))
PY
)"
exec /usr/bin/python3 "$ROOT/scripts/rtsp_server.py" "$FRAMES" --port "$PORT" --fps "$FPS"

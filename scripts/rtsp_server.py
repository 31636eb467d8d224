#!/usr/bin/python3
"""Serve a folder of JPEG frames as an RTSP camera (GStreamer's RTSP server), looping.

Runs on the system Python with Debian's GStreamer bindings (python3-gi,
gir1.2-gst-rtsp-server-1.0, gstreamer1.0-plugins-good/base), not in the project's venv:

    /usr/bin/python3 scripts/rtsp_server.py FRAMES_DIR [--port 8554] [--mount /live] [--fps 10]
        [--user U --password P]
    /usr/bin/python3 scripts/rtsp_server.py --latest FRAME.jpg [...]

The frames are sent as RTP/JPEG without re-encoding, paced at --fps with presentation times, to
every client of one shared stream. With --latest, each frame is FRAME.jpg as it is when the frame
is due (another program rewrites it: a camera whose view follows a simulated head). With
--user/--password the server asks for Basic authentication. Prints
"ready rtsp://127.0.0.1:PORT/MOUNT" once it listens; stops on SIGTERM or Ctrl-C.
`make rtsp-server VIDEO=...` writes the frames of a video and starts it.
"""

from __future__ import annotations

import argparse
import contextlib
import signal
import sys
from pathlib import Path

import gi

gi.require_version("Gst", "1.0")
gi.require_version("GstRtspServer", "1.0")
from gi.repository import GLib, Gst, GstRtspServer  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "frames", type=Path, nargs="?", help="folder of .jpg frames, sent in name order"
    )
    parser.add_argument("--latest", type=Path, help="send this .jpg as it is when each is due")
    parser.add_argument("--port", type=int, default=8554)
    parser.add_argument("--mount", default="/live")
    parser.add_argument("--fps", type=int, default=10)
    parser.add_argument("--user", default="")
    parser.add_argument("--password", default="")
    args = parser.parse_args()
    if args.latest is not None:
        jpegs = [args.latest.read_bytes()] if args.latest.exists() else []
    else:
        jpegs = [path.read_bytes() for path in sorted(args.frames.glob("*.jpg"))]
    if not jpegs:
        print(f"error: no .jpg frames in {args.latest or args.frames}", file=sys.stderr)
        return 2
    Gst.init(None)
    server = GstRtspServer.RTSPServer()
    server.set_service(str(args.port))
    factory = GstRtspServer.RTSPMediaFactory()
    live = "is-live=true do-timestamp=true " if args.latest is not None else ""
    factory.set_launch(
        f"( appsrc name=frames {live}format=time caps=image/jpeg,framerate={args.fps}/1 "
        "! jpegparse ! rtpjpegpay name=pay0 pt=26 )"
    )
    factory.set_shared(True)
    period = Gst.SECOND // args.fps

    def configure(_factory: object, media: GstRtspServer.RTSPMedia) -> None:
        sent = [0]

        def need_data(source: Gst.Element, _length: int) -> None:
            buffer = Gst.Buffer.new_wrapped(jpegs[sent[0] % len(jpegs)])
            buffer.pts, buffer.duration = sent[0] * period, period
            sent[0] += 1
            source.emit("push-buffer", buffer)

        def push_latest(source: Gst.Element) -> bool:
            """A live camera: the frame as it is now, stamped now, at --fps (the writer replaces
            the file whole, by a rename: never half a frame; while it does, the last goes again)."""
            with contextlib.suppress(OSError):
                jpegs[0] = args.latest.read_bytes()
            return source.emit("push-buffer", Gst.Buffer.new_wrapped(jpegs[0])) == Gst.FlowReturn.OK

        source = media.get_element().get_by_name("frames")
        if args.latest is not None:
            GLib.timeout_add(1000 // args.fps, push_latest, source)
        else:
            source.connect("need-data", need_data)

    factory.connect("media-configure", configure)
    if args.user:
        auth = GstRtspServer.RTSPAuth()
        token = GstRtspServer.RTSPToken()
        token.set_string(GstRtspServer.RTSP_TOKEN_MEDIA_FACTORY_ROLE, "viewer")
        auth.add_basic(GstRtspServer.RTSPAuth.make_basic(args.user, args.password), token)
        server.set_auth(auth)
        permissions = GstRtspServer.RTSPPermissions()
        permissions.add_role("viewer")
        permissions.add_permission_for_role("viewer", "media.factory.access", True)
        permissions.add_permission_for_role("viewer", "media.factory.construct", True)
        factory.set_permissions(permissions)
    server.get_mount_points().add_factory(args.mount, factory)
    if server.attach(None) == 0:
        print(f"error: cannot listen on port {args.port}", file=sys.stderr)
        return 1
    loop = GLib.MainLoop()
    for signum in (signal.SIGTERM, signal.SIGINT):
        GLib.unix_signal_add(GLib.PRIORITY_DEFAULT, signum, loop.quit)
    print(f"ready rtsp://127.0.0.1:{args.port}{args.mount}", flush=True)
    loop.run()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

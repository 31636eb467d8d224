"""Live stream input: stamps, diagnosis of bad URLs, newest frame wins, reconnection; against a
local RTSP camera (GStreamer's RTSP server streaming JPEG frames)."""

from __future__ import annotations

import time

import numpy as np
import pytest
from rtsp_camera import RtspCamera, require_gstreamer, write_jpegs

from tracker_ptz_sim.simulation.frame_sources import SourceError
from tracker_ptz_sim.simulation.live_stream import (
    MAX_STAMP_DRIFT_NS,
    PROBE_US,
    READ_TIMEOUT_S,
    LiveStreamSource,
    StreamClock,
    ffmpeg_options,
    is_live_stream,
    open_input,
    redacted,
    stream_problem,
)


def test_stream_urls_and_devices_are_live_and_files_are_not(tmp_path):
    for url in (
        "rtsp://cam/live",
        "RTSP://cam:554/a",
        "http://cam/mjpg",
        "https://x/y",
        "/dev/video0",
    ):
        assert is_live_stream(url), url
    for path in (tmp_path / "clip.mp4", "clip.avi", "/dev/video", "rtsp_clip.mp4"):
        assert not is_live_stream(path), path


def test_passwords_never_reach_a_log_line():
    assert redacted("rtsp://admin:s3cret@10.0.0.7:554/h264") == "rtsp://admin:***@10.0.0.7:554/h264"
    assert redacted("rtsp://10.0.0.7/h264") == "rtsp://10.0.0.7/h264"


def test_stamps_follow_the_streams_time_and_only_increase():
    clock = StreamClock()
    assert clock.stamp(1_000_000_000, 0.0) == 1_000_000_000
    # arrival jitters by 30 ms; the stream says 100 ms later: the stamp is the stream's
    assert clock.stamp(1_130_000_000, 100.0) == 1_100_000_000
    # a frame that came sooner than the stream's time says is stamped on arrival, and anchors
    assert clock.stamp(1_180_000_000, 200.0) == 1_180_000_000
    assert clock.stamp(1_290_000_000, 300.0) == 1_280_000_000
    # the stream time runs away from arrival by more than the drift allowed: arrival again
    far = 1_300_000_000 - 2 * MAX_STAMP_DRIFT_NS
    assert clock.stamp(1_300_000_000, 200.0 + (far - 1_180_000_000) / 1e6) == 1_300_000_000
    # without stream time (< 0): arrival, never before the last stamp
    assert clock.stamp(1_150_000_000, -1.0) == 1_300_000_001
    clock.reconnected()  # a new connection's stream time starts again at 0
    assert clock.stamp(1_500_000_000, 0.0) == 1_500_000_000


@pytest.fixture(scope="module")
def jpeg_frames(tmp_path_factory):
    """40 frames of 160x120, each with its number in the top row's first pixel value."""
    frames = []
    for index in range(40):
        image = np.full((120, 160, 3), 40, np.uint8)
        image[40:80, 4 * index : 4 * index + 20] = 220
        frames.append(image)
    return write_jpegs(frames, tmp_path_factory.mktemp("jpegs"))


@pytest.fixture()
def camera(jpeg_frames):
    require_gstreamer()
    with RtspCamera(jpeg_frames, fps=20) as server:
        yield server


def test_a_wrong_url_or_password_is_named_in_plain_words(jpeg_frames):
    require_gstreamer()
    with RtspCamera(jpeg_frames, user="viewer", password="right") as server:
        port = server.port
        assert "needs credentials" in stream_problem(f"rtsp://127.0.0.1:{port}/live", 2.0)
        wrong = f"rtsp://viewer:wrong@127.0.0.1:{port}/live"
        assert "refused the user name or password" in stream_problem(wrong, 2.0)
        missing = f"rtsp://viewer:right@127.0.0.1:{port}/nothing"
        assert "no stream at /nothing" in stream_problem(missing, 2.0)
        with pytest.raises(SourceError) as raised:
            LiveStreamSource(wrong, open_timeout_s=2.0)
        assert "viewer:***@" in str(raised.value) and "wrong" not in str(raised.value)
        source = open_input(server.url)  # the right password plays
        try:
            assert next(source.frames(0, 1)).image.shape == (120, 160, 3)
        finally:
            source.close()
    assert "connection refused" in stream_problem(f"rtsp://127.0.0.1:{port}/live", 2.0)


def test_a_slow_reader_gets_the_newest_frame_and_the_others_are_counted_dropped(camera):
    source = LiveStreamSource(camera.url)
    try:
        frames = source.frames(0, None)
        next(frames)
        time.sleep(1.0)  # 20 frames arrive while the reader is busy
        before = source.dropped
        start = time.monotonic()
        frame = next(frames)
        assert time.monotonic() - start < 0.1  # the newest frame was waiting: no queue to drain
        assert source.dropped - before >= 10
        assert source.lost == source.dropped
        assert frame.index == 1  # numbered as taken
    finally:
        source.close()


def test_rtsp_goes_over_tcp_unless_asked_otherwise_and_every_stream_is_probed_briefly():
    probe = f"analyzeduration;{PROBE_US}"
    assert ffmpeg_options("rtsp://cam/live", "tcp") == (probe, "rtsp_transport;tcp")
    assert ffmpeg_options("RTSPS://cam/live", "udp") == (probe, "rtsp_transport;udp")
    assert ffmpeg_options("rtsp://cam/live", "auto") == (probe,)
    assert ffmpeg_options("http://cam/mjpg", "tcp") == (probe,)
    with pytest.raises(ValueError, match="tcp, udp, auto"):
        ffmpeg_options("rtsp://cam/live", "quic")


def test_the_stream_survives_the_server_restarting(camera):
    events = []

    def note(level, message):
        events.append((level, message, time.monotonic()))

    source = LiveStreamSource(camera.url, note)
    stamps = []
    try:
        frames = source.frames(0, None)
        for _ in range(10):
            stamps.append(next(frames).stamp_ns)
        camera.stop()
        stopped = time.monotonic()
        time.sleep(1.0)
        camera.start()
        for _ in range(10):
            stamps.append(next(frames).stamp_ns)
    finally:
        source.close()
    assert source.reconnects == 1
    assert np.all(np.diff(stamps) > 0)
    levels = [level for level, _, _ in events]
    assert levels == ["warning", "info"], events
    assert "stream lost" in events[0][1] and "stream back" in events[1][1]
    # over TCP the closed connection tells at once; over UDP only the read timeout would
    assert events[0][2] - stopped < READ_TIMEOUT_S / 2, events


def test_a_failure_in_the_reader_thread_ends_the_stream_with_its_cause(camera):
    def broken_sink(level, message):
        raise ValueError("the logger broke")

    source = LiveStreamSource(camera.url, broken_sink)
    frames = source.frames(0, None)
    next(frames)
    camera.stop()  # the outage is reported to the broken sink
    with pytest.raises(SourceError, match="the logger broke"):
        for _ in frames:
            pass
    source.close()

"""frame_sources on bad inputs: empty paths, damaged and truncated videos, MP4s without an index.

Every clip is written here by OpenCV (small, seeded, each frame numbered); damage is done to the
bytes of a copy, and what the reader yields is compared with a plain decode of the undamaged file.
"""

from __future__ import annotations

import os
import struct

import cv2
import numpy as np
import pytest

from tracker_msgs_py.codec import frame_stamp_ns
from tracker_ptz_sim.simulation import frame_sources
from tracker_ptz_sim.simulation.frame_sources import SourceError, open_source

W, H, FPS = 160, 120, 10.0
FORMATS = {"mjpg.avi": "MJPG", "xvid.avi": "XVID", "mp4v.mp4": "mp4v"}
# Measured with opencv-python-headless 4.11 (the last for NumPy 1, constraints-apt.txt): its FFmpeg
# resynchronises past damaged chunks silently, so later frames come out under smaller indices.
INDEX_ORDER_READS = pytest.mark.skipif(
    int(cv2.__version__.split(".")[0]) < 5,
    reason="OpenCV < 5: damaged video chunks are skipped silently, later frames renumbered",
)


def write_clip(path, frames=60):
    """A clip of noise with the frame number drawn in; returns the path."""
    rng = np.random.default_rng(7)
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*FORMATS[path.name]), FPS, (W, H))
    assert writer.isOpened()
    for i in range(frames):
        image = cv2.GaussianBlur(rng.integers(0, 256, (H, W, 3), dtype=np.uint8), (0, 0), 3)
        cv2.putText(image, str(i), (20, 80), cv2.FONT_HERSHEY_SIMPLEX, 2, (255, 255, 255), 4)
        writer.write(image)
    writer.release()
    return path


def decode(path):
    """Every frame of an undamaged clip, read plainly with OpenCV."""
    capture = cv2.VideoCapture(str(path))
    images = []
    while (frame := capture.read())[0]:
        images.append(frame[1])
    capture.release()
    return images


def damaged_copy(path, first, last, name="damaged"):
    """A copy of `path` with bytes [first, last) zeroed."""
    data = bytearray(path.read_bytes())
    data[first:last] = bytes(last - first)
    copy = path.with_name(f"{name}_{path.name}")
    copy.write_bytes(data)
    return copy


def cut_copy(path, size, name="cut"):
    copy = path.with_name(f"{name}_{path.name}")
    copy.write_bytes(path.read_bytes()[:size])
    return copy


def avi_frame_chunks(data):
    """(offset, length with header) of each frame chunk ('00dc') of an AVI's movi list."""
    movi = data.index(b"movi")
    end = movi - 4 + struct.unpack("<I", data[movi - 4 : movi])[0]
    chunks, offset = [], movi + 4
    while offset < end:
        kind, size = struct.unpack("<4sI", data[offset : offset + 8])
        if kind[2:] in (b"dc", b"db"):
            chunks.append((offset, 8 + size))
        offset += 8 + size + (size & 1)
    return chunks


def boxes(data, start=0, end=None):
    """(type, offset, length) of the ISO-BMFF boxes in data[start:end] (32-bit lengths only)."""
    offset, end = start, len(data) if end is None else end
    while offset < end:
        length, kind = struct.unpack(">I4s", data[offset : offset + 8])
        yield kind, offset, length
        offset += length


def moov_first(path):
    """A copy of an MP4 with its index (moov) moved before the frames ("fast start"), as streaming
    recorders write them: cutting it short leaves the index but loses frames."""
    data = path.read_bytes()
    top = {kind: (offset, length) for kind, offset, length in boxes(data)}
    offset, length = top[b"moov"]
    moov = bytearray(data[offset : offset + length])

    def shift_chunk_offsets(start, end):
        for kind, at, size in boxes(moov, start, end):
            if kind in (b"trak", b"mdia", b"minf", b"stbl"):
                shift_chunk_offsets(at + 8, at + size)
            elif kind == b"stco":
                count = struct.unpack(">I", moov[at + 12 : at + 16])[0]
                for entry in range(at + 16, at + 16 + 4 * count, 4):
                    value = struct.unpack(">I", moov[entry : entry + 4])[0]
                    moov[entry : entry + 4] = struct.pack(">I", value + length)

    shift_chunk_offsets(8, length)
    ftyp_end = top[b"ftyp"][1]
    rest = data[:offset] + data[offset + length :]
    copy = path.with_name(f"faststart_{path.name}")
    copy.write_bytes(rest[:ftyp_end] + bytes(moov) + rest[ftyp_end:])
    return copy


def read_all(source, start=0, end=None):
    frames = list(source.frames(start, end))
    for frame in frames:
        assert frame.stamp_ns == frame_stamp_ns(frame.index, FPS)
    return frames


# --- the path -----------------------------------------------------------------------------------


@pytest.mark.parametrize("path", ["", "   ", "\t\n"])
def test_an_empty_path_is_an_error_not_the_current_directory(path, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    cv2.imwrite(str(tmp_path / "0.png"), np.zeros((H, W, 3), np.uint8))  # "." would replay this
    with pytest.raises(SourceError) as error:
        open_source(path)
    message = str(error.value)
    assert message.startswith("no input given") and "'path' parameter" in message
    assert "video file, an image folder, a rosbag2 or a stream URL" in message


# --- damage in the middle -----------------------------------------------------------------------


@INDEX_ORDER_READS
def test_damaged_mjpg_avi_loses_only_the_damaged_frames(tmp_path):
    """30 frames (more than the old limit of 25 failures in a row) whose chunks, headers included,
    are zeroed. FFmpeg reading the AVI front to back would resync past them silently and number
    every later frame 30 too low; read in index order, exactly the 30 frames are skipped."""
    clip = write_clip(tmp_path / "mjpg.avi")
    reference = decode(clip)
    chunks = avi_frame_chunks(clip.read_bytes())
    assert len(chunks) == len(reference) == 60
    first, last = chunks[20][0], sum(chunks[49])
    source = open_source(damaged_copy(clip, first, last))
    frames = read_all(source)
    assert [f.index for f in frames] == [*range(20), *range(50, 60)]
    for frame in frames:  # MJPG is intra-only: the same bytes decode to the same pixels
        assert np.array_equal(frame.image, reference[frame.index]), frame.index
    assert (source.skipped, source.lost, source.end_note) == (30, 0, "")


@pytest.mark.parametrize("name", [pytest.param("xvid.avi", marks=INDEX_ORDER_READS), "mp4v.mp4"])
def test_damage_in_inter_coded_video_costs_only_the_damaged_frames(name, tmp_path):
    """A third of the bytes zeroed (some 29 frames): every frame after the damage is still read,
    under its own index; from the next keyframe on (every 12 frames) the pixels are exact."""
    clip = write_clip(tmp_path / name, frames=96)
    reference = decode(clip)
    size = clip.stat().st_size
    source = open_source(damaged_copy(clip, size * 3 // 10, size * 6 // 10))
    frames = read_all(source)
    indices = [f.index for f in frames]
    assert indices == sorted(set(indices)) and indices[-1] == 95
    assert len(frames) + source.skipped == 96 and source.skipped > 25
    assert (source.lost, source.end_note) == (0, "")
    late = [f for f in frames if f.index >= 72]
    assert [f.index for f in late] == list(range(72, 96))
    for frame in late:
        assert np.array_equal(frame.image, reference[frame.index]), frame.index


# --- truncation ---------------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["mjpg.avi", "xvid.avi", "mp4v.mp4"])
def test_a_truncated_video_reports_the_frames_it_lost(name, tmp_path):
    clip = write_clip(tmp_path / name)
    reference = decode(clip)
    if name.endswith(".mp4"):
        clip = moov_first(clip)  # with the index at the end, a cut MP4 cannot be opened at all
    source = open_source(cut_copy(clip, clip.stat().st_size // 2))
    assert source.total == 60
    for _ in range(2):  # a second pass (loop) reports the same, once
        frames = read_all(source)
        reached = len(frames) + source.skipped
        assert [f.index for f in frames] == list(range(len(frames)))
        assert 20 < reached < 40 and source.skipped <= 1 and source.lost == 60 - reached
        assert source.end_note == (
            f"the video ends at frame {reached} of 60: {source.lost} frames could not be read "
            "(the file looks truncated)"
        )
    if name == "mjpg.avi":  # all but the last frame, which the cut may have damaged, are exact
        for frame in frames[:-1]:
            assert np.array_equal(frame.image, reference[frame.index]), frame.index


def test_only_frames_asked_for_count_as_lost(tmp_path):
    clip = write_clip(tmp_path / "mjpg.avi")
    source = open_source(cut_copy(clip, clip.stat().st_size // 2))  # ends at frame 31
    assert [f.index for f in read_all(source, 5, 20)] == list(range(5, 20))
    assert (source.lost, source.end_note) == (0, "")
    assert read_all(source, 40) == []
    assert source.lost == 20 and "20 frames could not be read" in source.end_note


# --- the normal case stays as it was ------------------------------------------------------------


class CaptureLog:
    """Stands in for cv2.VideoCapture: counts the files opened and records every set() call."""

    def __init__(self, monkeypatch):
        self.opened, self.sets = [], []
        real = cv2.VideoCapture
        log = self

        class Capture:
            def __init__(self, *args):
                log.opened.append((args, os.environ.get(frame_sources.CAPTURE_OPTIONS)))
                self.capture = real(*args)

            def set(self, *args):
                log.sets.append(args)
                return self.capture.set(*args)

            def __getattr__(self, name):
                return getattr(self.capture, name)

        monkeypatch.setattr(cv2, "VideoCapture", Capture)


@pytest.mark.parametrize("name", ["mjpg.avi", "xvid.avi", "mp4v.mp4"])
def test_an_undamaged_video_is_read_in_one_pass_without_seeking(name, tmp_path, monkeypatch):
    clip = write_clip(tmp_path / name)
    reference = decode(clip)
    monkeypatch.setenv(frame_sources.CAPTURE_OPTIONS, "probesize;5000000")  # the user's own
    log = CaptureLog(monkeypatch)
    source = open_source(clip)
    log.opened.clear()
    frames = read_all(source)
    assert [f.index for f in frames] == list(range(60))
    for frame in frames:
        assert np.array_equal(frame.image, reference[frame.index]), frame.index
    assert (source.skipped, source.lost, source.end_note) == (0, 0, "")
    late = read_all(source, start=45)  # skipping to a start frame keeps indices exact
    assert [f.index for f in late] == list(range(45, 60))
    assert np.array_equal(late[0].image, reference[45])
    assert len(log.opened) == 2 and log.sets == []  # one open per pass, no seek, no probe
    expected = "probesize;5000000|fflags;+sortdts" if name.endswith(".avi") else "probesize;5000000"
    assert all(options == expected for _, options in log.opened)
    assert os.environ[frame_sources.CAPTURE_OPTIONS] == "probesize;5000000"  # restored


# --- files that cannot be opened ----------------------------------------------------------------


def iso_box(kind, payload, length=None):
    return struct.pack(">I4s", 8 + len(payload) if length is None else length, kind) + payload


@pytest.mark.parametrize("case", ["cut_before_moov", "cut_in_mdat", "mdat_to_end", "mdat_64bit"])
def test_an_mp4_without_its_index_says_the_recording_was_not_finalised(case, tmp_path):
    clip = write_clip(tmp_path / "mp4v.mp4")
    data = clip.read_bytes()
    top = {kind: (offset, length) for kind, offset, length in boxes(data)}
    assert list(top) == [b"ftyp", b"free", b"mdat", b"moov"]  # OpenCV writes the index last
    mdat_offset, mdat_length = top[b"mdat"]
    frames = data[mdat_offset + 8 : mdat_offset + mdat_length]
    ftyp = data[: top[b"ftyp"][1]]
    content = {
        "cut_before_moov": data[: top[b"moov"][0]],
        "cut_in_mdat": data[: mdat_offset + mdat_length // 2],
        # a recorder killed before it wrote the length: size 0 means "to the end of the file"
        "mdat_to_end": ftyp + iso_box(b"mdat", frames, length=0),
        "mdat_64bit": ftyp + struct.pack(">I4sQ", 1, b"mdat", 16 + len(frames)) + frames,
    }[case]
    path = tmp_path / ("recording.mov" if case == "mdat_64bit" else "recording.mp4")
    path.write_bytes(content)
    with pytest.raises(SourceError) as error:
        open_source(path)
    message = str(error.value)
    kind = "MOV" if path.suffix == ".mov" else "MP4"
    assert message.startswith(f"{path}: the {kind} has no index ('moov' atom not found)")
    assert "not finalised" in message and "untrunc" in message


@pytest.mark.parametrize("case", ["empty", "text", "damaged_avi_header"])
def test_an_unreadable_file_names_the_cause(case, tmp_path):
    path = tmp_path / "input.avi"
    if case == "empty":
        path.write_bytes(b"")
        expected = f"{path}: the file is empty"
    elif case == "text":
        path.write_text("this is not a video")
        expected = f"{path}: not a video OpenCV can read (not a video format it recognises)"
    else:
        path = damaged_copy(write_clip(tmp_path / "mjpg.avi"), 12, 200)
        expected = f"{path}: not a video OpenCV can read: an AVI file it cannot open"
    with pytest.raises(SourceError) as error:
        open_source(path)
    assert str(error.value).startswith(expected)


def write_image_bag(path, encoding, rows, step, frames=2):
    """A rosbag2 of `frames` sensor_msgs/Image messages holding the bytes `rows` (H, step)."""
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import Image

    from tracker_msgs_py.codec import ns_to_stamp
    from tracker_ptz_sim.evaluation.recording import BagWriter

    writer = BagWriter(path, {"/camera/image_raw": "sensor_msgs/msg/Image"})
    for k in range(frames):
        stamp = 1_000_000_000 + k * 100_000_000
        width = rows.shape[1] // (2 if encoding == "16UC1" else 1)
        msg = Image(height=rows.shape[0], width=width, encoding=encoding, step=step)
        msg.header.stamp = ns_to_stamp(stamp)
        msg.data = rows.tobytes()
        writer.write("/camera/image_raw", stamp, serialize_message(msg))
    writer.close()


@pytest.mark.ros
def test_a_bag_of_raw_bayer_images_is_read_in_colour(tmp_path):
    # bayer_rggb8 of an orange scene: R at the even rows' even columns, B at the odd ones' odd
    rows, cols = np.indices((8, 12))
    mosaic = np.where((rows % 2 == 0) & (cols % 2 == 0), 230, 130)
    mosaic = np.where((rows % 2 == 1) & (cols % 2 == 1), 30, mosaic).astype(np.uint8)
    write_image_bag(tmp_path / "bag", "bayer_rggb8", mosaic, step=12)
    frames = list(open_source(tmp_path / "bag").frames())
    assert len(frames) == 2
    assert np.abs(frames[0].image[2:-2, 2:-2].astype(int) - [30, 130, 230]).max() <= 1


@pytest.mark.ros
def test_a_bag_image_that_cannot_be_read_is_skipped_with_its_cause(tmp_path):
    write_image_bag(tmp_path / "bag", "16UC1", np.zeros((4, 8), np.uint8), step=8)
    source = open_source(tmp_path / "bag")
    assert list(source.frames()) == []
    assert source.skipped == 2
    assert "/camera/image_raw: unsupported image encoding '16UC1'" in source.skip_cause


@pytest.mark.ros
def test_a_bag_with_several_image_topics_says_which_it_replays_and_at_what_rate(tmp_path):
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import CompressedImage

    from tracker_ptz_sim.evaluation.recording import BagWriter

    topics = ["/left/image_raw/compressed", "/right/image_raw/compressed"]
    writer = BagWriter(tmp_path / "bag", dict.fromkeys(topics, "sensor_msgs/msg/CompressedImage"))
    ok, png = cv2.imencode(".png", np.full((4, 6, 3), 7, np.uint8))
    for k in range(3):
        for topic in topics:
            msg = CompressedImage(format="png", data=png.tobytes())
            msg.header.stamp.sec = 1 + k
            # recorded 100 times faster than the stamps run, as a lockstep replay records
            writer.write(topic, (1 + k) * 10_000_000, serialize_message(msg))
    writer.close()
    chosen = open_source(tmp_path / "bag")
    assert chosen.topic in topics and len(list(chosen.frames())) == 3
    assert chosen.fps == pytest.approx(1.0)  # the stamps' rate, not the recording's
    other = next(t for t in topics if t != chosen.topic)
    assert other in chosen.note and "bag_topic" in chosen.note
    asked = open_source(tmp_path / "bag", bag_topic=other)
    assert asked.topic == other and asked.note == ""


def test_a_folder_of_images_says_the_rate_it_assumes(tmp_path):
    for k in range(3):
        cv2.imwrite(str(tmp_path / f"{k}.png"), np.full((4, 6, 3), k, np.uint8))
    assumed = open_source(tmp_path)
    assert assumed.fps == 10.0 and "10 fps" in assumed.note and "fps parameter" in assumed.note
    assert [f.stamp_ns for f in assumed.frames()] == [0, 100_000_000, 200_000_000]
    given = open_source(tmp_path, fps=30.0)
    assert given.fps == 30.0 and given.note == ""

"""The shared helpers: scene geometry, message conversions and parameter validation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tracker_msgs_py.geometry import Rect, SceneGeometry, camera_pixel_to_angles


def test_scene_mapping_follows_rep103_signs():
    geometry = SceneGeometry(width=768, height=576, focal_length=400.0)
    assert geometry.angles_to_pixel(0.0, 0.0) == (384.0, 288.0)
    x, y = geometry.angles_to_pixel(0.1, 0.05)  # pan left, tilt down
    assert x == pytest.approx(384.0 - 40.0) and y == pytest.approx(288.0 + 20.0)
    assert geometry.pixel_to_angles(x, y) == pytest.approx((0.1, 0.05))
    vx, vy = geometry.rate_to_pixel_velocity(0.2, -0.1)
    assert (vx, vy) == pytest.approx((-80.0, -40.0))
    assert geometry.pixel_velocity_to_rate(vx, vy) == pytest.approx((0.2, -0.1))


def test_scene_geometry_rejects_nonsense():
    with pytest.raises(ValueError, match="focal_length"):
        SceneGeometry(100, 100, float("nan"))
    with pytest.raises(ValueError, match="scene size"):
        SceneGeometry(0, 100, 10.0)


def test_camera_pixel_to_angles_matches_pinhole_rays():
    # A pixel 100 px right of the principal point with fx = 100 is 45 deg to the right (pan -pi/4).
    pan, tilt = camera_pixel_to_angles(420.0, 240.0, 0.2, 0.1, 100.0, 100.0, 320.0, 240.0)
    assert pan == pytest.approx(0.2 - math.pi / 4) and tilt == pytest.approx(0.1)
    pan, tilt = camera_pixel_to_angles(320.0, 340.0, 0.0, 0.0, 100.0, 100.0, 320.0, 240.0)
    assert pan == pytest.approx(0.0) and tilt == pytest.approx(math.pi / 4)


def test_rect_operations():
    a, b = Rect(0, 0, 10, 10), Rect(5, 5, 10, 10)
    assert a.intersection(b) == Rect(5, 5, 5, 5)
    assert a.iou(b) == pytest.approx(25 / 175)
    assert a.intersection(Rect(20, 20, 1, 1)) is None and a.iou(Rect(20, 20, 1, 1)) == 0.0
    assert Rect.from_center(5, 5, 10, 4) == Rect(0, 3, 10, 4)
    assert a.contains(0, 0) and not a.contains(10, 5)


@pytest.mark.ros
class TestConversions:
    def test_image_round_trip_all_encodings(self):
        from tracker_msgs_py.codec import (
            array_to_image,
            image_to_array,
            image_to_bgr,
            image_to_gray,
            ns_to_stamp,
        )

        rng = np.random.default_rng(1)
        bgr = rng.integers(0, 256, (4, 5, 3), dtype=np.uint8)
        stamp = ns_to_stamp(1_500_000_001)
        msg = array_to_image(bgr, "bgr8", stamp, "cam")
        assert (msg.height, msg.width, msg.step, msg.header.frame_id) == (4, 5, 15, "cam")
        assert np.array_equal(image_to_array(msg), bgr)
        rgb_msg = array_to_image(np.ascontiguousarray(bgr[:, :, ::-1]), "rgb8", stamp, "cam")
        assert np.array_equal(image_to_bgr(rgb_msg), bgr)
        gray = image_to_gray(msg)
        b, g, r = (bgr[..., i].astype(float) for i in range(3))
        assert np.abs(gray - (0.299 * r + 0.587 * g + 0.114 * b)).max() <= 1.0
        mono = array_to_image(gray, "mono8", stamp, "cam")
        assert np.array_equal(image_to_gray(mono), gray)

    @pytest.mark.parametrize(
        ("encoding", "red_at"),
        [
            ("bayer_rggb8", (0, 0)),
            ("bayer_bggr8", (1, 1)),
            ("bayer_gbrg8", (1, 0)),
            ("bayer_grbg8", (0, 1)),
        ],
    )
    def test_bayer_mosaics_are_demosaiced(self, encoding, red_at):
        from sensor_msgs.msg import Image

        from tracker_msgs_py.codec import image_to_bgr, image_to_gray

        # A camera's raw mosaic of a uniform colour: each pixel keeps one channel, R at `red_at`
        # of every 2x2 block, B diagonally opposite, G on the other two.
        bgr = np.array([40, 120, 220], dtype=np.uint8)
        height, width = 8, 10
        rows, cols = np.indices((height, width))
        at_red = (rows % 2 == red_at[0]) & (cols % 2 == red_at[1])
        at_blue = (rows % 2 != red_at[0]) & (cols % 2 != red_at[1])
        mosaic = np.where(at_red, bgr[2], np.where(at_blue, bgr[0], bgr[1])).astype(np.uint8)
        padded = np.zeros((height, width + 2), dtype=np.uint8)
        padded[:, :width] = mosaic
        msg = Image(height=height, width=width, encoding=encoding, step=width + 2)
        msg.data = padded.tobytes()
        pixels = image_to_bgr(msg)
        assert pixels.shape == (height, width, 3)
        assert np.abs(pixels[2:-2, 2:-2].astype(int) - bgr).max() <= 1
        gray = image_to_gray(msg)
        assert abs(int(gray[4, 4]) - round(0.299 * 220 + 0.587 * 120 + 0.114 * 40)) <= 1

    @pytest.mark.parametrize("encoding", ["yuv422", "uyvy", "yuv422_yuy2", "yuyv"])
    def test_yuv422_is_read_in_its_byte_order(self, encoding):
        from sensor_msgs.msg import Image

        from tracker_msgs_py.codec import image_to_bgr

        # No chroma (U = V = 128) and the luma alternating dark / bright: read in the wrong byte
        # order, the luma would be taken as chroma and the pixels come out coloured.
        height, width = 2, 6
        luma = np.tile([60, 200], (height, width // 2))
        chroma = np.full((height, width), 128)
        first, second = (chroma, luma) if encoding in ("yuv422", "uyvy") else (luma, chroma)
        packed = np.stack([first, second], axis=2).astype(np.uint8)
        msg = Image(height=height, width=width, encoding=encoding, step=width * 2)
        msg.data = packed.tobytes()
        pixels = image_to_bgr(msg).astype(int)
        assert pixels.shape == (height, width, 3)
        assert np.abs(pixels - pixels[:, :, 1:2]).max() <= 2  # neutral
        assert (pixels[:, 1::2, 1] - pixels[:, 0::2, 1] > 100).all()  # bright after dark

    def test_yuv422_of_odd_width_is_named(self):
        from sensor_msgs.msg import Image

        from tracker_msgs_py.codec import UnsupportedEncodingError, image_to_bgr

        with pytest.raises(UnsupportedEncodingError, match="odd width"):
            image_to_bgr(Image(height=1, width=3, encoding="yuv422", step=6, data=b"\x80" * 6))

    def test_padded_rows_are_read_correctly(self):
        from sensor_msgs.msg import Image

        from tracker_msgs_py.codec import image_to_array

        msg = Image(height=2, width=3, encoding="mono8", step=4)
        msg.data = bytes([1, 2, 3, 99, 4, 5, 6, 99])
        assert image_to_array(msg).tolist() == [[1, 2, 3], [4, 5, 6]]

    def test_unsupported_and_malformed_images_are_named(self):
        from sensor_msgs.msg import Image

        from tracker_msgs_py.codec import UnsupportedEncodingError, image_to_array

        with pytest.raises(UnsupportedEncodingError, match="'16UC1'.*bayer_rggb8"):
            image_to_array(Image(height=1, width=1, encoding="16UC1", step=2, data=b"\0\0"))
        with pytest.raises(UnsupportedEncodingError, match="malformed"):
            image_to_array(Image(height=2, width=2, encoding="bgr8", step=6, data=b"\0" * 6))

    def test_stamps_and_rects(self):
        from tracker_msgs_py.codec import msg_to_rect, ns_to_stamp, rect_to_msg, stamp_to_ns

        assert stamp_to_ns(ns_to_stamp(12_345_678_901)) == 12_345_678_901
        with pytest.raises(ValueError):
            ns_to_stamp(-1)
        rect = Rect(1.5, 2.0, 3.0, 4.0)
        assert msg_to_rect(rect_to_msg(rect)) == rect
        bad = rect_to_msg(rect)
        bad.width = float("nan")
        with pytest.raises(ValueError, match="invalid rectangle"):
            msg_to_rect(bad)

    def test_a_camera_window_is_a_finite_rectangle_of_positive_size(self):
        from tracker_msgs_py.codec import msg_to_window, rect_to_msg

        assert msg_to_window(rect_to_msg(Rect(10.0, 20.0, 264.0, 264.0))).center == (142.0, 152.0)
        with pytest.raises(ValueError, match="empty rectangle"):
            msg_to_window(rect_to_msg(Rect(10.0, 20.0, 0.0, 264.0)))
        with pytest.raises(ValueError, match="invalid rectangle"):
            msg_to_window(rect_to_msg(Rect(float("inf"), 20.0, 264.0, 264.0)))


@pytest.mark.ros
def test_parameters_are_validated_at_startup_and_on_change():
    import rclpy
    from rclpy.node import Node
    from rclpy.parameter import Parameter

    from tracker_msgs_py.params import ParameterError, ParamSpec, declare_parameters

    specs = [
        ParamSpec("gap", 3, "frames", 1, 30),
        ParamSpec("threshold", 0.5, "SSIM", -1.0, 1.0),
        ParamSpec("mode", "fast", "estimator", choices=("fast", "seed")),
        ParamSpec("low", 1.0, "lower bound"),
        ParamSpec("high", 2.0, "upper bound"),
    ]
    changes = []

    def ordered(values):
        return None if values["low"] < values["high"] else "low must be below high"

    context = rclpy.Context()
    rclpy.init(context=context, args=["--ros-args", "-p", "gap:=4"])
    try:
        node = Node("param_test", context=context)
        values = declare_parameters(node, specs, on_change=changes.append, check_all=ordered)
        assert values["gap"] == 4
        for name, value, reason in [
            ("gap", 31, "out of range"),
            ("mode", "slow", "one of"),
            ("high", 0.5, "low must be below high"),
            ("threshold", float("nan"), ""),
        ]:
            result = node.set_parameters([Parameter(name, value=value)])[0]
            assert not result.successful and reason in result.reason
        assert changes == [] and values["gap"] == 4 and values["mode"] == "fast"
        assert node.set_parameters([Parameter("threshold", value=0.6)])[0].successful
        assert changes == [{"threshold": 0.6}] and values["threshold"] == 0.6
        with pytest.raises(ParameterError, match="mode must be one of"):
            declare_parameters(
                Node("bad", context=context, parameter_overrides=[Parameter("mode", value="slow")]),
                [specs[2]],
            )
        node.destroy_node()
    finally:
        rclpy.shutdown(context=context)


def test_decimal_parameters_take_whole_numbers_and_refuse_non_finite_values_and_inverted_ranges():
    """`max_speed:=2` is 2.0 at start and at run time (also for arrays); NaN in an array and a
    [min, max] pair the wrong way round are refused at start and at run time, naming the
    parameter and what it must be."""
    import rclpy
    from rclpy.node import Node
    from rclpy.parameter import Parameter

    from tracker_msgs_py.params import ParameterError, ParamSpec, declare_parameters

    specs = [
        ParamSpec("max_speed", 1.0, "rad/s", 0.0, 10.0),
        ParamSpec("pan_limits", [-1.0, 1.0], "[min, max] rad", interval=True),
        ParamSpec("home", [0.0, 0.0], "rad"),
    ]
    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        given = [Parameter("max_speed", value=2), Parameter("pan_limits", value=[-2, 2])]
        node = Node("whole_numbers", context=context, parameter_overrides=given)
        values = declare_parameters(node, specs)
        assert values["max_speed"] == 2.0 and isinstance(values["max_speed"], float)
        assert values["pan_limits"] == [-2.0, 2.0]
        assert node.set_parameters([Parameter("max_speed", value=3)])[0].successful
        assert values["max_speed"] == 3.0 and node.get_parameter("max_speed").value == 3.0
        for name, value, reason in [
            ("max_speed", 11, "max_speed out of range Min: 0.0, Max: 10.0, value: 11.0"),
            ("pan_limits", [float("nan"), 1.0], "pan_limits must hold finite numbers"),
            ("pan_limits", [1.0, -1.0], "pan_limits must be [min, max] with min < max"),
            ("home", [float("nan"), float("nan")], "home must hold finite numbers"),
        ]:
            result = node.set_parameters([Parameter(name, value=value)])[0]
            assert not result.successful and reason in result.reason, result.reason
        assert values["pan_limits"] == [-2.0, 2.0] and values["home"] == [0.0, 0.0]
        for bad, reason in [
            (Parameter("pan_limits", value=[float("nan"), 1.0]), "must hold finite numbers"),
            (Parameter("pan_limits", value=[1.0, -1.0]), "with min < max"),
            (Parameter("max_speed", value=-5), "max_speed.*out of range"),
        ]:
            with pytest.raises(ParameterError, match=reason):
                declare_parameters(Node("bad", context=context, parameter_overrides=[bad]), specs)
        node.destroy_node()
    finally:
        rclpy.shutdown(context=context)


def test_parameters_given_to_every_node_are_read_from_the_ros_arguments(tmp_path):
    from tracker_msgs_py.params import parameters_for_every_node, ros_sections

    params = tmp_path / "graph.yaml"
    params.write_text(
        "/**:\n  ros__parameters:\n    reliable_images: true\n    qos: {depth: 5}\n"
        "/**/tracker:\n  ros__parameters:\n    lead_time: 0.1\n"
    )
    argv = ["prog", "-p", "not_ros:=1", "--ros-args", "--params-file", str(params)]
    argv += ["-p", "use_sim_time:=true", "-p", "tracker:lead_tme:=0.2", "--", "-p", "x:=1"]
    assert ros_sections(argv)[:2] == ["--params-file", str(params)]
    assert parameters_for_every_node(argv) == {"reliable_images", "qos.depth", "use_sim_time"}
    assert parameters_for_every_node(["--ros-args", "--params-file", str(tmp_path / "no")]) == set()


def test_a_node_names_the_parameters_it_was_given_but_does_not_declare(tmp_path):
    import rclpy

    from tracker_msgs_py.node_main import SuiteNode

    params = tmp_path / "graph.yaml"
    params.write_text(
        "/**:\n  ros__parameters:\n    reliable_images: true\n"
        "/**/probe:\n  ros__parameters:\n    lead_time: 0.1\n    lead_tme: 0.2\n"
    )
    context = rclpy.Context()
    rclpy.init(context=context, args=[])
    try:
        arguments = ["--ros-args", "--params-file", str(params), "-p", "probe:gap_typo:=3"]
        node = SuiteNode("probe", context=context, cli_args=arguments)
        node.declare_parameter("lead_time", 0.0)
        # the misspelt ones given to it by name; not those every node gets (reliable_images)
        assert node.unused_overrides() == ["gap_typo", "lead_tme"]
        node.destroy_node()
    finally:
        rclpy.shutdown(context=context)


def test_the_header_stamp_of_a_serialized_image_is_read_without_deserializing():
    pytest.importorskip("rclpy")
    from rclpy.serialization import serialize_message

    from tracker_msgs_py.codec import array_to_image, header_stamp_ns, ns_to_stamp

    stamp_ns = 1_795_704_779_012_524_643
    image = array_to_image(np.zeros((4, 6, 3), np.uint8), "bgr8", ns_to_stamp(stamp_ns), "scene")
    assert header_stamp_ns(serialize_message(image)) == stamp_ns

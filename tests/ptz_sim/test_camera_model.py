"""The simulated pan-tilt-zoom camera: mapping, clamping, servo limits, latency, watchdog, zoom."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tracker_ptz_sim.simulation.camera_model import PtzCameraModel, PtzCommand, PtzConfig

W, H = 320, 240
DT = 0.1


def model(**changes) -> PtzCameraModel:
    return PtzCameraModel(PtzConfig(**changes), W, H)


def test_defaults_are_the_seeds_window_scaled_to_the_input():
    camera = model()
    assert camera.base_size == (110, 110)
    assert PtzCameraModel(PtzConfig(), 768, 576).base_size == (264, 264)
    snapshot = camera.advance(0.0)
    assert snapshot.window.center == (160.0, 120.0) and snapshot.pan == 0.0 and snapshot.tilt == 0.0


def test_angles_and_window_agree_through_the_scene_mapping():
    camera = model(servo="instant")
    camera.command(PtzCommand(0.0, "position", pan=0.1, tilt=-0.05))
    snapshot = camera.advance(0.0)
    x, y = camera.geometry.angles_to_pixel(snapshot.pan, snapshot.tilt)
    assert (x, y) == pytest.approx(snapshot.window.center)
    # pan left (+) moves the window left, tilt up (-) moves it up
    assert snapshot.window.center[0] < 160 and snapshot.window.center[1] < 120
    assert snapshot.window.x == int(snapshot.window.x)  # whole pixels: views are exact slices


@pytest.mark.parametrize(
    ("pan", "tilt", "edge"),
    [(5.0, 0.0, "left"), (-5.0, 0.0, "right"), (0.0, -5.0, "top"), (0.0, 5.0, "bottom")],
)
def test_window_is_clamped_at_all_four_borders(pan, tilt, edge):
    camera = model(servo="instant")
    camera.command(PtzCommand(0.0, "position", pan=pan, tilt=tilt))
    window = camera.advance(0.0).window
    expected = {
        "left": window.x == 0,
        "right": window.x + window.width == W,
        "top": window.y == 0,
        "bottom": window.y + window.height == H,
    }
    assert expected[edge]
    assert (
        window.x >= 0
        and window.x + window.width <= W
        and window.y >= 0
        and window.y + window.height <= H
    )


def test_speed_and_acceleration_limits_hold_frame_to_frame():
    camera = model(max_speed=0.5, max_acceleration=2.0, view_height_fraction=0.3)
    camera.command(PtzCommand(0.0, "position", pan=-0.6, tilt=0.3))
    pans, rates = [], []
    for k in range(40):
        camera.advance(k * DT)
        pans.append(camera.pan.position)
        rates.append(camera.pan.rate)
    speeds = np.abs(np.diff(pans)) / DT
    assert speeds.max() <= 0.5 + 1e-9
    assert np.abs(np.diff(rates)).max() / DT <= 2.0 + 1e-9
    (lo, _), _ = camera.limits()
    assert (
        camera.pan.position == pytest.approx(max(-0.6, lo)) and camera.pan.rate == 0.0
    )  # stopped on target
    assert speeds.max() == pytest.approx(0.5)  # and it did reach full speed


def test_velocity_watchdog_stops_the_unit():
    camera = model(velocity_timeout=0.3, max_acceleration=100.0)
    camera.advance(0.0)
    camera.command(PtzCommand(0.0, "velocity", pan_rate=0.2))
    camera.advance(0.2)
    assert camera.pan.rate == pytest.approx(0.2)
    camera.advance(0.5)
    assert camera.pan.rate == 0.0
    stopped = camera.pan.position
    camera.advance(1.0)
    assert camera.pan.position == stopped
    assert stopped == pytest.approx(0.2 * 0.3, abs=0.01)


def test_command_latency_delays_the_motion():
    camera = model(servo="instant", command_latency=0.2)
    camera.command(PtzCommand(0.0, "position", pan=0.1))
    assert camera.advance(0.1).pan == 0.0
    assert camera.advance(0.2).pan == pytest.approx(0.1, abs=1 / camera.geometry.focal_length)


def pan_per_frame(camera, commands, frames=5):
    """Pan at frames 0.. (DT apart); `commands[i]` is given after frame i, answering it."""
    pans = []
    for index in range(frames):
        pans.append(camera.advance(index * DT).pan)
        if index in commands:
            camera.command(commands[index])
    return pans


@pytest.mark.parametrize("delay", [1, 2, 3])
def test_a_command_acts_from_the_frame_its_delay_names(delay):
    camera = model(servo="instant", command_delay_frames=delay)
    pans = pan_per_frame(camera, {0: PtzCommand(0.0, "position", pan=0.1)})
    moved = [pan != 0.0 for pan in pans]
    assert moved == [index >= delay for index in range(5)]


def test_a_late_command_acts_from_the_same_frame_as_an_early_one():
    """Pipelined lockstep: the answer to frame 0 may reach the camera before or after frame 1 is
    rendered; with a delay of 2 frames it acts from frame 2 either way (the replay is
    deterministic)."""
    early = model(servo="instant", command_delay_frames=2)
    late = model(servo="instant", command_delay_frames=2)
    early.advance(0.0)
    early.command(PtzCommand(0.0, "position", pan=0.1))
    late.advance(0.0)
    assert early.advance(DT).pan == late.advance(DT).pan == 0.0
    late.command(PtzCommand(0.0, "position", pan=0.1))
    assert early.advance(2 * DT).pan == late.advance(2 * DT).pan != 0.0


def test_a_command_stamped_between_frames_answers_the_frame_before_it():
    camera = model(servo="instant", command_delay_frames=2)
    camera.advance(0.0)
    camera.command(PtzCommand(0.05, "position", pan=0.1))  # after frame 0, before frame 1
    assert camera.advance(DT).pan == 0.0
    assert camera.advance(2 * DT).pan != 0.0


def test_the_velocity_watchdog_counts_from_when_a_delayed_command_acts():
    camera = model(velocity_timeout=0.25, max_acceleration=100.0, command_delay_frames=3)
    pans = pan_per_frame(
        camera, {0: PtzCommand(0.0, "velocity", pan_rate=0.2)}, frames=6
    )  # acts from 0.2 s (the interval before frame 3), not from its stamp
    assert pans[:3] == [0.0, 0.0, 0.0]
    assert pans[3] < pans[4] < pans[5]  # still turning after stamp + timeout (0.25 s)


def test_hold_stops_immediately():
    camera = model(max_acceleration=1000.0)
    camera.advance(0.0)
    camera.command(PtzCommand(0.0, "velocity", pan_rate=0.3))
    camera.advance(0.2)
    camera.command(PtzCommand(0.2, "hold"))
    position = camera.advance(0.2).pan
    assert camera.advance(0.6).pan == pytest.approx(position)


def test_zoom_shrinks_the_window_and_keeps_the_output_size():
    camera = model(servo="instant")
    scene = np.random.default_rng(0).integers(0, 255, (H, W, 3), dtype=np.uint8)
    camera.command(PtzCommand(0.0, "hold", zoom=2.0))
    snapshot = camera.advance(0.0)
    assert snapshot.zoom == 2.0 and (snapshot.window.width, snapshot.window.height) == (55.0, 55.0)
    assert camera.render(scene).shape == (110, 110, 3)
    fx, fy, cx, cy = camera.intrinsics()
    assert fx == pytest.approx(camera.geometry.focal_length * 2.0) and (cx, cy) == (55.0, 55.0)
    camera.command(PtzCommand(0.1, "hold", zoom=99.0))
    assert camera.advance(0.1).zoom == camera.config.max_zoom


def test_zoom_below_one_widens_the_window_up_to_the_scene():
    camera = PtzCameraModel(PtzConfig(min_zoom=0.25), 320, 240)
    base_w, base_h = camera.base_size
    camera.command(PtzCommand(0.0, "hold", zoom=0.5))
    snapshot = camera.advance(0.0)
    assert (snapshot.window.width, snapshot.window.height) == (2 * base_w, 2 * base_h)
    assert camera.render(np.zeros((240, 320, 3), np.uint8)).shape[:2] == (base_h, base_w)
    camera.command(PtzCommand(0.1, "hold", zoom=0.01))  # clamped to min_zoom: the whole height
    snapshot = camera.advance(0.1)
    assert snapshot.zoom == 0.25 and snapshot.window.height == 240
    assert snapshot.window.width == pytest.approx(240 * base_w / base_h, abs=1)
    assert PtzCameraModel(PtzConfig(), 320, 240).config.min_zoom == 1.0  # the seed cannot widen
    with pytest.raises(ValueError, match="min_zoom"):
        PtzCameraModel(PtzConfig(min_zoom=1.5), 320, 240)


def test_render_is_an_exact_slice_at_zoom_one():
    camera = model(servo="instant")
    scene = np.random.default_rng(1).integers(0, 255, (H, W, 3), dtype=np.uint8)
    camera.command(PtzCommand(0.0, "position", pan=0.123, tilt=0.045))
    window = camera.advance(0.0).window
    view = camera.render(scene)
    x, y, w, h = (int(v) for v in (window.x, window.y, window.width, window.height))
    assert np.array_equal(view, scene[y : y + h, x : x + w])
    with pytest.raises(ValueError, match="set up for 320x240"):
        camera.render(scene[:100])


def test_same_commands_give_the_same_trajectory():
    def run():
        camera = model()
        out = []
        for k in range(30):
            if k % 7 == 0:
                camera.command(PtzCommand(k * DT, "velocity", pan_rate=math.sin(k), tilt_rate=0.1))
            out.append(camera.advance(k * DT))
        return out

    assert run() == run()


def test_bad_config_and_commands_are_rejected():
    with pytest.raises(ValueError, match="servo"):
        model(servo="magic")
    with pytest.raises(ValueError, match="non-finite"):
        model().command(PtzCommand(0.0, "position", pan=float("nan")))
    with pytest.raises(ValueError, match="mode"):
        model().command(PtzCommand(0.0, "spin"))


def test_the_standard_interfaces_pinhole_image_registers_with_the_bridged_window():
    """The stand-in for a real unit renders a pinhole camera's image; the window
    ptz_state_bridge makes of its pan, tilt and CameraInfo (the edge rays), with the image
    resampled onto the equiangular grid (the detector's image_projection: pinhole), is the scene
    there: the linear view over it is exact, as a panning camera's background registration
    needs."""
    import cv2

    from tracker_detect.pinhole import to_equiangular
    from tracker_detect.registration import CameraIntrinsics, view_from_pan_tilt

    rng = np.random.default_rng(3)
    noise = rng.uniform(0, 255, (480, 640)).astype(np.float32)
    scene = cv2.GaussianBlur(noise, (0, 0), 3.0)  # texture a few pixels across
    camera = PtzCameraModel(PtzConfig(servo="instant", view_fov=1.0), 640, 480)
    camera.command(PtzCommand(0.0, "position", pan=0.2, tilt=-0.1))
    snapshot = camera.advance(0.0)
    image = camera.render(scene, snapshot.window, pinhole=True)
    out_w, out_h = camera.output_size()
    window = view_from_pan_tilt(
        snapshot.pan,
        snapshot.tilt,
        CameraIntrinsics(out_w, out_h, *camera.intrinsics()),
        camera.geometry,
    ).rect
    assert window.width == pytest.approx(camera.pinhole_span(snapshot.window)[0])
    u = (np.arange(out_w, dtype=np.float32) + 0.5) * window.width / out_w + window.x - 0.5
    v = (np.arange(out_h, dtype=np.float32) + 0.5) * window.height / out_h + window.y - 0.5
    linear = cv2.remap(scene, *np.meshgrid(u, v), cv2.INTER_LINEAR)
    rectified = to_equiangular(image, (window.width, window.height), camera.geometry.focal_length)
    inner = (slice(2, -2), slice(2, -2))
    assert np.abs(rectified - linear)[inner].mean() < 0.5
    assert np.abs(image - linear)[inner].mean() > 5 * np.abs(rectified - linear)[inner].mean()

"""The pan-tilt controller's control law and state machine, against an ideal pan-tilt plant."""

from __future__ import annotations

import math

import pytest

from tracker_ptz_sim.control.controller import (
    CameraPose,
    CommandMode,
    ControllerConfig,
    ControlState,
    PanTiltController,
    TargetEstimate,
)

F = 400.0  # scene px per rad
CX, CY = 384.0, 288.0  # scene centre
DT = 0.1


class IdealUnit:
    """Pan-tilt unit that follows commands exactly (position jumps, velocity integrates)."""

    def __init__(self, limit: float = 0.6):
        self.pan = self.tilt = 0.0
        self.limit = limit

    def apply(self, command, dt: float) -> None:
        if command.mode is CommandMode.POSITION:
            self.pan, self.tilt = command.pan, command.tilt
        elif command.mode is CommandMode.VELOCITY:
            self.pan += command.pan_rate * dt
            self.tilt += command.tilt_rate * dt
        self.pan = max(-self.limit, min(self.limit, self.pan))

    def pose(self) -> CameraPose:
        return CameraPose(self.pan, self.tilt, CX - F * self.pan, CY + F * self.tilt, F)


def target_at(x: float, y: float, vx: float = 0.0, vy: float = 0.0, lead: float = 0.0):
    return TargetEstimate(x, y, vx, vy, x + vx * lead, y + vy * lead)


def test_direct_mode_jumps_to_the_target():
    controller = PanTiltController(ControllerConfig(mode="direct"))
    unit = IdealUnit()
    command = controller.step(0.0, unit.pose(), target_at(CX - 40.0, CY + 20.0))
    assert command.mode is CommandMode.POSITION
    assert (command.pan, command.tilt) == pytest.approx((0.1, 0.05))  # left and down, REP-103


def test_hold_mode_keeps_a_fixed_camera_still_whatever_is_tracked():
    """Seed 004's static camera: every target, or none, is answered with HOLD (no zoom), and
    losing a target starts no scan, homing or search."""
    config = ControllerConfig(mode="hold", zoom_control=True, search="sweep", home_dwell_time=0.0)
    controller = PanTiltController(config)
    unit = IdealUnit()
    for k in range(60):
        target = target_at(CX + 150.0, CY - 80.0, 40.0, 10.0) if k < 20 else None
        command = controller.step(k * DT, unit.pose(), target)
        assert command.mode is CommandMode.HOLD and command.zoom == 0.0
        unit.apply(command, DT)
    assert (unit.pan, unit.tilt) == (0.0, 0.0)


@pytest.mark.parametrize("feed_forward", [True, False])
def test_servo_centres_a_moving_target(feed_forward):
    config = ControllerConfig(mode="servo", feed_forward=feed_forward, kp=3.0, ki=0.5)
    controller = PanTiltController(config)
    unit = IdealUnit(limit=10.0)
    errors = []
    x, vx = CX + 60.0, 30.0  # starts off-centre, moves right at 30 px/s
    for k in range(200):
        x += vx * DT
        command = controller.step(k * DT, unit.pose(), target_at(x, CY, vx, 0.0, lead=DT))
        unit.apply(command, DT)
        errors.append(abs(unit.pose().center_x - x))
    steady = max(errors[-50:])
    assert steady < (3.0 if feed_forward else 12.0)
    assert max(errors) > 30.0  # it did have to move


def test_dead_zone_holds_still_for_small_errors():
    controller = PanTiltController(ControllerConfig(mode="servo", dead_zone=0.02))
    command = controller.step(0.0, IdealUnit().pose(), target_at(CX + 4.0, CY - 4.0))  # 0.01 rad
    assert command.mode is CommandMode.VELOCITY
    assert command.pan_rate == 0.0 and command.tilt_rate == 0.0


def test_rates_are_limited():
    controller = PanTiltController(ControllerConfig(mode="servo", max_rate=0.5))
    command = controller.step(0.0, IdealUnit().pose(), target_at(CX + 380.0, CY))
    assert command.pan_rate == pytest.approx(-0.5)


def test_sweep_reverses_at_limits_and_on_a_stall():
    controller = PanTiltController(
        ControllerConfig(search="sweep", sweep_rate=0.3, pan_limits=(-0.4, 0.4))
    )
    unit = IdealUnit(limit=0.25)  # the unit stops before the configured limits: a stall
    pans = []
    for k in range(120):
        unit.apply(controller.step(k * DT, unit.pose(), None), DT)
        pans.append(unit.pan)
    assert controller.state is ControlState.SEARCH
    assert max(pans) == pytest.approx(0.25) and min(pans) == pytest.approx(-0.25)
    steps = [b - a for a, b in zip(pans, pans[1:], strict=False) if abs(b - a) > 1e-9]
    reversals = sum(1 for a, b in zip(steps, steps[1:], strict=False) if a * b < 0)
    assert 3 <= reversals <= 8


def test_loss_scans_then_returns_home_then_searches():
    config = ControllerConfig(
        mode="direct",
        lost_scan_time=2.0,
        home_dwell_time=1.0,
        home=(0.05, 0.02),
        scan_amplitude=0.1,
    )
    controller = PanTiltController(config)
    unit = IdealUnit()
    last_x = CX - 120.0  # target at pan 0.3
    unit.apply(controller.step(0.0, unit.pose(), target_at(last_x, CY)), DT)
    assert controller.state is ControlState.TRACK
    states, scan_pans, commands = [], [], []
    t = DT
    while t < 4.5:
        command = controller.step(t, unit.pose(), None)
        unit.apply(command, DT)
        states.append(controller.state)
        commands.append(command)
        if controller.state is ControlState.SCAN:
            scan_pans.append(command.pan)
        t += DT
    assert states[0] is ControlState.SCAN
    assert max(scan_pans) == pytest.approx(0.4, abs=0.01) and min(scan_pans) == pytest.approx(
        0.2, abs=0.01
    )
    first_home = states.index(ControlState.HOME)
    assert first_home * DT == pytest.approx(2.0, abs=DT + 1e-9)
    assert ControlState.SEARCH in states[first_home:]
    assert (commands[first_home].pan, commands[first_home].tilt) == (0.05, 0.02)
    first_search = states.index(ControlState.SEARCH)
    assert (first_search - first_home) * DT == pytest.approx(1.0, abs=DT + 1e-9)


def test_time_held_without_a_decision_counts_for_no_timer():
    """Lost at t = 0.1, then held 5 s (no images to judge by): the scan still has its whole
    lost_scan_time to run once stepping resumes."""
    config = ControllerConfig(mode="direct", lost_scan_time=2.0, scan_amplitude=0.1)
    controller = PanTiltController(config)
    unit = IdealUnit()
    controller.step(0.0, unit.pose(), target_at(CX - 120.0, CY))
    controller.step(0.1, unit.pose(), None)
    assert controller.state is ControlState.SCAN
    assert controller.hold(5.1).mode is CommandMode.HOLD
    states = [
        controller.step(5.1 + k * DT, unit.pose(), None) and controller.state for k in range(1, 40)
    ]
    first_home = states.index(ControlState.HOME) + 1
    assert first_home * DT == pytest.approx(1.9, abs=DT + 1e-9)


def test_after_a_gap_a_lost_target_is_looked_for_standing_still_until_it_is_locked_again():
    """Images return at t = 5 after a gap while a target was followed: no target -> HOLD (still
    tracking) for up to lost_scan_time, then the usual scan; a locked target ends the wait, and a
    later loss is scanned for at once."""
    config = ControllerConfig(mode="direct", lost_scan_time=2.0, scan_amplitude=0.1)
    unit = IdealUnit()
    waiting = PanTiltController(config)
    waiting.step(0.0, unit.pose(), target_at(CX - 120.0, CY))
    waiting.resume(5.0)
    held = [waiting.step(5.0 + k * DT, unit.pose(), None) for k in range(round(2.0 / DT) + 1)]
    assert all(c.mode is CommandMode.HOLD for c in held)
    assert waiting.state is ControlState.TRACK
    assert waiting.step(7.0 + DT, unit.pose(), None).mode is CommandMode.POSITION
    assert waiting.state is ControlState.SCAN

    found = PanTiltController(config)
    found.step(0.0, unit.pose(), target_at(CX - 120.0, CY))
    found.resume(5.0)
    assert found.step(5.0, unit.pose(), None).mode is CommandMode.HOLD
    assert found.step(5.1, unit.pose(), target_at(CX - 100.0, CY)).mode is CommandMode.POSITION
    found.step(5.2, unit.pose(), None)
    assert found.state is ControlState.SCAN  # lost again: no more waiting


def test_the_aim_leads_a_moving_target_by_the_units_latency():
    """A target moving right at 100 px/s on a unit that starts moving 0.2 s after a command: the
    aim is 20 px ahead of the tracker's prediction."""
    unit = IdealUnit()
    target = target_at(CX, CY, vx=100.0)
    plain = PanTiltController(ControllerConfig(mode="direct")).step(0.0, unit.pose(), target)
    late = PanTiltController(ControllerConfig(mode="direct", unit_latency=0.2))
    led = late.step(0.0, unit.pose(), target)
    assert (plain.pan - led.pan) * F == pytest.approx(20.0)
    assert led.tilt == plain.tilt


def test_home_position_is_commanded():
    controller = PanTiltController(ControllerConfig(search="none", home=(0.1, -0.05)))
    command = controller.step(0.0, IdealUnit().pose(), None)
    assert controller.state is ControlState.HOME
    assert (command.mode, command.pan, command.tilt) == (CommandMode.POSITION, 0.1, -0.05)


def test_presets_are_visited_in_turn():
    presets = [(0.1, 0.0), (-0.1, 0.05)]
    controller = PanTiltController(
        ControllerConfig(search="presets", presets=presets, preset_dwell_time=1.0)
    )
    visited = [controller.step(k * 0.5, IdealUnit().pose(), None) for k in range(5)]
    assert [(c.pan, c.tilt) for c in visited] == [
        presets[0],
        presets[0],
        presets[1],
        presets[1],
        presets[0],
    ]


@pytest.mark.parametrize(
    ("change", "reason"),
    [
        ({"mode": "fast"}, "mode"),
        ({"search": "presets"}, "preset"),
        ({"pan_limits": (1.0, -1.0)}, "increasing"),
    ],
)
def test_bad_configurations_are_rejected(change, reason):
    with pytest.raises(ValueError, match=reason):
        PanTiltController(ControllerConfig(**change))


def test_reentering_track_resets_integral():
    controller = PanTiltController(
        ControllerConfig(mode="servo", ki=1.0, kp=0.0, feed_forward=False)
    )
    unit = IdealUnit()
    for k in range(10):
        controller.step(k * DT, unit.pose(), target_at(CX + 100.0, CY))
    controller.step(1.0, unit.pose(), None)
    command = controller.step(1.1, unit.pose(), target_at(CX + 100.0, CY))
    assert math.isclose(command.pan_rate, 0.0, abs_tol=1e-12)


def test_zoom_keeps_the_target_within_the_fill_band():
    """A person walking towards the camera grows from 60 to 240 px in a view 264 px tall at zoom 1:
    the controller zooms out, a step of at most zoom_step at a time, once the person fills more than
    fill_high, until they fill fill_target; when they are small again it zooms back in, and
    without a target it returns to home_zoom."""
    config = ControllerConfig(
        zoom_control=True, fill_low=0.2, fill_high=0.8, fill_target=0.5, max_zoom=2.0
    )
    controller = PanTiltController(config)
    zoom, fills, commands = 1.0, [], []
    for k in range(60):
        height = 60.0 + 4.0 * min(k, 45)  # then stands still at 240 px
        target = TargetEstimate(CX, CY, 0.0, 0.0, CX, CY, height=height)
        pose = CameraPose(0.0, 0.0, CX, CY, F, zoom, 264.0 / zoom)
        command = controller.step(k * DT, pose, target)
        commands.append(command.zoom)
        if command.zoom:
            assert 1 / config.zoom_step - 1e-9 <= command.zoom / zoom <= config.zoom_step + 1e-9
            zoom = command.zoom
        fills.append(height * zoom / 264.0)
    assert max(fills) <= config.fill_high * config.zoom_step  # never long out of the band
    assert fills[-1] == pytest.approx(config.fill_target, abs=0.1)
    assert zoom == pytest.approx(0.55, abs=0.06)  # 240 px in a 264 px view: zoomed out
    assert all(c == 0.0 for c in commands[:30])  # 60..176 px fill 0.23..0.67: kept
    small = TargetEstimate(CX, CY, 0.0, 0.0, CX, CY, height=20.0)
    command = controller.step(6.1, CameraPose(0.0, 0.0, CX, CY, F, zoom, 264.0 / zoom), small)
    assert command.zoom == pytest.approx(zoom * config.zoom_step)  # zooms in again
    at_limit = CameraPose(0.0, 0.0, CX, CY, F, 2.0, 132.0)
    assert controller.step(6.15, at_limit, small).zoom == 0.0  # ... up to max_zoom
    lost = controller.step(6.2, CameraPose(0.0, 0.0, CX, CY, F, 1.0, 264.0), None)
    assert lost.zoom == 0.0  # already at home_zoom
    away = controller.step(6.3, CameraPose(0.0, 0.0, CX, CY, F, 0.6, 440.0), None)
    assert away.zoom == pytest.approx(0.6 * config.zoom_step)  # back towards home_zoom 1
    assert PanTiltController(ControllerConfig()).step(0.0, pose, target).zoom == 0.0  # off
    with pytest.raises(ValueError, match="fill_low"):
        PanTiltController(ControllerConfig(fill_low=0.6, fill_target=0.5))


def test_commands_stay_within_the_units_limits():
    config = ControllerConfig(mode="direct", pan_limits=(-0.3, 0.3), tilt_limits=(-0.1, 0.2))
    controller = PanTiltController(config)
    far_left_and_high = TargetEstimate(CX - F * 1.0, CY - F * 0.5, 0.0, 0.0, CX - F, CY - F * 0.5)
    command = controller.step(0.0, CameraPose(0.0, 0.0, CX, CY, F), far_left_and_high)
    assert command.mode is CommandMode.POSITION
    assert (command.pan, command.tilt) == (0.3, -0.1)


def test_a_rate_that_would_drive_past_a_limit_is_stopped():
    config = ControllerConfig(pan_limits=(-0.3, 0.3), tilt_limits=(-0.1, 0.2))
    controller = PanTiltController(config)
    at_left_limit = CameraPose(0.3, 0.0, CX - F * 0.3, CY, F)
    further_left = TargetEstimate(CX - F * 0.6, CY + F * 0.1, 0.0, 0.0, CX - F * 0.6, CY + F * 0.1)
    command = controller.step(0.0, at_left_limit, further_left)
    assert command.mode is CommandMode.VELOCITY
    assert command.pan_rate == 0.0  # pan would leave the range
    assert command.tilt_rate > 0.0  # tilt is free to follow

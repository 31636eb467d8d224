"""The ONVIF PTZ path against the tests' own ONVIF camera (a SOAP service built on the client
package's WSDLs): generic spaces, what a camera supports, credentials, MoveStatus that never
returns to IDLE, and a timed move's response."""

from __future__ import annotations

import asyncio
import math

import pytest

pytest.importorskip("onvif")

from onvif_camera import OnvifCamera  # noqa: E402

from tracker_ptz_sim.control.onvif_ptz import (  # noqa: E402
    GenericRange,
    OnvifError,
    OnvifPtz,
    PtzStatus,
    StillJudge,
    fit_response,
)


def test_generic_spaces_map_to_rep103_angles_and_rates():
    spaces = GenericRange(pan=(math.pi, -math.pi), tilt=(0.5, -0.5), top_rates=(2.0, 1.0))
    assert spaces.angles(0.0, 0.0) == (0.0, 0.0)
    assert spaces.angles(0.5, 1.0) == pytest.approx((-math.pi / 2, -0.5))  # x + = right
    assert spaces.generic(*spaces.angles(0.3, -0.7)) == pytest.approx((0.3, -0.7))
    assert spaces.generic(10.0, 0.0)[0] == -1.0  # beyond the range: its end
    assert spaces.velocity(1.0, 0.5) == pytest.approx((-0.5, -0.5))  # left and down
    assert spaces.velocity(-9.0, 0.0) == (1.0, 0.0)
    with pytest.raises(ValueError, match="two different ends"):
        GenericRange(pan=(1.0, 1.0))


def test_a_move_status_that_never_idles_is_judged_by_the_position():
    judge = StillJudge(polls=3, tolerance=1e-3)
    statuses = [(0.0, "MOVING"), (0.1, "MOVING"), (0.2, "MOVING"), (0.2, "MOVING"),
                (0.2, "MOVING"), (0.2, "MOVING")]  # fmt: skip
    moving = [judge.moving(PtzStatus(x, 0.0, move, 0.0)) for x, move in statuses]
    assert moving == [True, True, True, True, False, False]
    honest = StillJudge()
    assert not honest.moving(PtzStatus(0.0, 0.0, "IDLE", 0.0))
    assert honest.moving(PtzStatus(0.0, 0.0, "MOVING", 0.0))  # it has idled: believed


def test_a_timed_moves_response_gives_latency_and_rate():
    times = [0.1 * k for k in range(20)]
    positions = [0.0 if t < 0.35 else 0.4 * (t - 0.3) for t in times]
    latency, rate = fit_response(times, positions, commanded_at=0.0)
    assert latency == pytest.approx(0.3, abs=0.02) and rate == pytest.approx(0.4)
    with pytest.raises(ValueError, match="did not move"):
        fit_response(times, [0.0] * 20, 0.0)


def connect(camera, user="admin", password="secret"):
    async def run():
        ptz = OnvifPtz("127.0.0.1", camera.port, user, password)
        try:
            return await ptz.connect()
        finally:
            await ptz.close()

    return asyncio.run(run())


def test_what_the_camera_supports_is_read_at_start():
    with OnvifCamera(user="admin", password="secret") as camera:
        support = connect(camera)
    assert support.continuous and support.absolute and support.relative_fov
    assert support.presets == ("home",) and support.position_in_status
    assert "not supported" not in support.describe()
    with OnvifCamera(fov_moves=False, status_position=False) as camera:
        line = connect(camera, "", "").describe()
    assert line.endswith("not supported: FOV-relative moves, a position in GetStatus"), line


def test_bad_credentials_and_no_camera_are_one_clear_line():
    with OnvifCamera(user="admin", password="secret") as camera:
        with pytest.raises(OnvifError, match="refused the user name or password"):
            connect(camera, password="wrong")
        port = camera.port
    with pytest.raises(OnvifError, match="refused the connection"):
        asyncio.run(OnvifPtz("127.0.0.1", port, "", "").connect())


def test_moves_reach_the_head_and_its_status_comes_back():
    async def run(camera):
        ptz = OnvifPtz("127.0.0.1", camera.port, "", "")
        await ptz.connect()
        await ptz.continuous_move(0.5, -0.5, timeout=0.3)
        await asyncio.sleep(0.6)  # past its timeout: the camera stopped by itself
        moved = await ptz.status()
        await ptz.absolute_move(-0.2, 0.1)
        await asyncio.sleep(1.2)
        there = await ptz.status()
        await ptz.close()
        return moved, there

    with OnvifCamera(top_speed=(0.5, 0.5)) as camera:
        moved, there = asyncio.run(run(camera))
    assert moved.x == pytest.approx(0.5 * 0.5 * 0.3, abs=0.02)  # 0.3 s at half its top speed
    assert moved.y == pytest.approx(-0.5 * 0.5 * 0.3, abs=0.02)
    assert (there.x, there.y) == pytest.approx((-0.2, 0.1)) and there.move_status == "IDLE"

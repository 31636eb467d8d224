"""The pan-tilt unit's kinematic tree (no rclpy): its URDF and the transforms of its frames at a
pan and tilt, REP-103 axes and REP-105-style names under a prefix.

    {p}ptz_base ──pan_joint (z)──► {p}ptz_pan_link ──tilt_joint (y)──► {p}ptz_tilt_link
        ──fixed──► {p}ptz_camera_link (x forward, y left, z up)
        ──fixed──► {p}ptz_camera_optical (z forward, x right, y down: the images' frame)

Pan + turns left (about +z), tilt + looks down (about +y), as the suite's joint states and
commands say. The link offsets are a small unit's (`Geometry`); a real unit's URDF replaces this
one, keeping the joint and optical frame names.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

Quaternion = tuple[float, float, float, float]  # x, y, z, w
Vector = tuple[float, float, float]


@dataclass(frozen=True)
class Transform:
    """`child` in `parent`: its origin and orientation."""

    parent: str
    child: str
    translation: Vector
    rotation: Quaternion


@dataclass(frozen=True)
class Geometry:
    """Where each joint sits on the link before it [m]."""

    pan_height: float = 0.05  # base -> pan axis
    tilt_height: float = 0.08  # pan axis -> tilt axis
    camera_forward: float = 0.03  # tilt axis -> camera centre, along the view


OPTICAL_FROM_CAMERA_RPY = (-math.pi / 2, 0.0, -math.pi / 2)  # REP-103's optical convention


@dataclass(frozen=True)
class PanTiltFrames:
    prefix: str = ""
    geometry: Geometry = Geometry()

    def name(self, frame: str) -> str:
        return f"{self.prefix}{frame}"

    @property
    def base(self) -> str:
        return self.name("ptz_base")

    @property
    def optical(self) -> str:
        return self.name("ptz_camera_optical")

    def moving(self, pan: float, tilt: float) -> list[Transform]:
        """The joints' transforms at `pan`, `tilt` [rad] (what /tf carries)."""
        g = self.geometry
        return [
            Transform(
                self.base, self.name("ptz_pan_link"), (0.0, 0.0, g.pan_height), from_rpy(0, 0, pan)
            ),
            Transform(
                self.name("ptz_pan_link"),
                self.name("ptz_tilt_link"),
                (0.0, 0.0, g.tilt_height),
                from_rpy(0, tilt, 0),
            ),
        ]

    def fixed(self) -> list[Transform]:
        """The fixed links' transforms (what /tf_static carries)."""
        return [
            Transform(
                self.name("ptz_tilt_link"),
                self.name("ptz_camera_link"),
                (self.geometry.camera_forward, 0.0, 0.0),
                (0.0, 0.0, 0.0, 1.0),
            ),
            Transform(
                self.name("ptz_camera_link"),
                self.optical,
                (0.0, 0.0, 0.0),
                from_rpy(*OPTICAL_FROM_CAMERA_RPY),
            ),
        ]

    def optical_in_base(self, pan: float, tilt: float) -> Transform:
        """The optical frame in the base at `pan`, `tilt` (what a TF lookup resolves)."""
        tree = self.moving(pan, tilt) + self.fixed()
        result = tree[0]
        for transform in tree[1:]:
            result = compose(result, transform)
        return result

    def ray(self, pan: float, tilt: float, right: float, down: float) -> Vector:
        """The unit direction, in the optical frame at `pan`, `tilt`, of what lies `right` rad
        right of and `down` rad below the view's centre in the scene's equiangular mapping (at
        pan - right, tilt + down: scene x follows pan, scene y tilt)."""
        rotation = self.optical_in_base(pan, tilt).rotation
        return rotate(conjugate(rotation), view_direction(pan - right, tilt + down))

    def urdf(self) -> str:
        """The unit as a URDF (what robot_state_publisher reads as `robot_description`)."""
        g = self.geometry
        links = ["ptz_base", "ptz_pan_link", "ptz_tilt_link", "ptz_camera_link"]
        links.append("ptz_camera_optical")
        roll, pitch, yaw = OPTICAL_FROM_CAMERA_RPY
        joints = [
            self._joint("pan_joint", "revolute", "ptz_base", "ptz_pan_link", (0, 0, g.pan_height),
                        (0, 0, 0), "0 0 1"),
            self._joint("tilt_joint", "revolute", "ptz_pan_link", "ptz_tilt_link",
                        (0, 0, g.tilt_height), (0, 0, 0), "0 1 0"),
            self._joint("camera_joint", "fixed", "ptz_tilt_link", "ptz_camera_link",
                        (g.camera_forward, 0, 0), (0, 0, 0), None),
            self._joint("camera_optical_joint", "fixed", "ptz_camera_link", "ptz_camera_optical",
                        (0, 0, 0), (roll, pitch, yaw), None),
        ]  # fmt: skip
        body = [f'  <link name="{self.name(link)}"/>' for link in links] + joints
        return (
            f'<?xml version="1.0"?>\n<robot name="{self.prefix}ptz">\n'
            + "\n".join(body)
            + ("\n</robot>\n")
        )

    def _joint(
        self,
        name: str,
        kind: str,
        parent: str,
        child: str,
        xyz: tuple[float, float, float],
        rpy: tuple[float, float, float],
        axis: str | None,
    ) -> str:
        lines = [
            f'  <joint name="{self.name(name)}" type="{kind}">',
            f'    <parent link="{self.name(parent)}"/>',
            f'    <child link="{self.name(child)}"/>',
            f'    <origin xyz="{_numbers(xyz)}" rpy="{_numbers(rpy)}"/>',
        ]
        if axis is not None:
            lines.append(f'    <axis xyz="{axis}"/>')
            lines.append('    <limit lower="-3.14159" upper="3.14159" effort="10" velocity="6"/>')
        return "\n".join([*lines, "  </joint>"])


def _numbers(values: tuple[float, float, float]) -> str:
    return " ".join(f"{v:.9g}" for v in values)


def from_rpy(roll: float, pitch: float, yaw: float) -> Quaternion:
    """URDF's fixed-axis roll, pitch, yaw (about x, then y, then z) as a quaternion."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return (
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
        cr * cp * cy + sr * sp * sy,
    )


def compose(first: Transform, second: Transform) -> Transform:
    """`second.child` in `first.parent`, where second.parent is first.child."""
    if first.child != second.parent:
        raise ValueError(f"{first.child} is not {second.parent}: the transforms do not chain")
    moved = rotate(first.rotation, second.translation)
    translation = tuple(a + b for a, b in zip(first.translation, moved, strict=True))
    rotation = multiply(first.rotation, second.rotation)
    return Transform(first.parent, second.child, translation, rotation)  # type: ignore[arg-type]


def multiply(a: Quaternion, b: Quaternion) -> Quaternion:
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    )


def rotate(q: Quaternion, v: Vector) -> Vector:
    """`v` rotated by the unit quaternion `q`."""
    x, y, z, w = multiply(multiply(q, (v[0], v[1], v[2], 0.0)), (-q[0], -q[1], -q[2], q[3]))
    return (x, y, z)


def view_direction(pan: float, tilt: float) -> Vector:
    """Where the unit looks at `pan` (left +) and `tilt` (down +), as a unit vector in its base
    (x forward at pan 0, y left, z up)."""
    return (math.cos(tilt) * math.cos(pan), math.cos(tilt) * math.sin(pan), -math.sin(tilt))


def conjugate(q: Quaternion) -> Quaternion:
    return (-q[0], -q[1], -q[2], q[3])

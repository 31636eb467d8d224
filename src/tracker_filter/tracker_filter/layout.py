"""Named state layouts: which elements of a track's state vector mean what (no rclpy).

Stone Soup's `mapping` idea: a tracker says where the position, the velocity and the box extent
sit in its state, and everything downstream (the Track message, the target's lead prediction,
the camera controller) reads them through the layout instead of assuming ``mean[:4]`` is
``x y vx vy``. Layouts are identified by their element names, the `state_layout` string of
tracker_msgs/Track (e.g. ``"x y vx vy"``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class StateLayout:
    """Element names of a state vector and the index maps of its parts.

    position: indices of x, y (px, scene); velocity: vx, vy (px/s), or () when the state has no
    velocity; extent: width, height of the box (px), or () when the box is not estimated.
    """

    names: tuple[str, ...]
    position: tuple[int, int] = (0, 1)
    velocity: tuple[int, ...] = ()
    extent: tuple[int, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "names", tuple(self.names))
        n = len(self.names)
        for part in ("position", "velocity", "extent"):
            indices = getattr(self, part)
            if len(indices) not in ((2,) if part == "position" else (0, 2)):
                raise ValueError(f"a state layout's {part} needs 2 indices, got {indices}")
            if not all(0 <= i < n for i in indices):
                raise ValueError(f"{part} indices {indices} outside a state of {n} elements")
        if len(set(self.names)) != n:
            raise ValueError(f"state element names repeat: {' '.join(self.names)}")

    @classmethod
    def from_names(cls, names: tuple[str, ...] | list[str] | str) -> StateLayout:
        """The layout with the conventional element names: x y, vx vy and w h wherever they are."""
        names = tuple(names.split()) if isinstance(names, str) else tuple(names)

        def pair(a: str, b: str) -> tuple[int, ...]:
            return (names.index(a), names.index(b)) if a in names and b in names else ()

        position = pair("x", "y")
        if not position:
            raise ValueError(f"state layout {' '.join(names)!r} has no x and y")
        return cls(names, (position[0], position[1]), pair("vx", "vy"), pair("w", "h"))

    @property
    def dim(self) -> int:
        return len(self.names)

    @property
    def text(self) -> str:
        """The layout as tracker_msgs/Track.state_layout writes it."""
        return " ".join(self.names)

    def positions(self, means: np.ndarray) -> np.ndarray:
        """Positions (..., 2) of states (..., n)."""
        return means[..., list(self.position)]

    def velocities(self, means: np.ndarray) -> np.ndarray:
        """Velocities (..., 2) of states (..., n); zero when the layout has none."""
        if not self.velocity:
            return np.zeros(means.shape[:-1] + (2,))
        return means[..., list(self.velocity)]

    def position_covariances(self, covariances: np.ndarray) -> np.ndarray:
        """Position blocks (..., 2, 2) of state covariances (..., n, n)."""
        index = list(self.position)
        return covariances[..., index, :][..., :, index]

"""Small vectorised linear-Gaussian helpers (no rclpy).

Every function takes stacks of states/covariances with any leading batch shape, so the same code
serves one filter and a bank of many. The measurement is always the position, the first two state
elements (H = [I 0]), which lets the helpers slice instead of multiplying by H.
"""

from __future__ import annotations

import numpy as np

from tracker_filter.models import AXES


def inverse_2x2(matrices: np.ndarray) -> np.ndarray:
    """Closed-form inverse of a stack of 2x2 matrices (..., 2, 2)."""
    a, b = matrices[..., 0, 0], matrices[..., 0, 1]
    c, d = matrices[..., 1, 0], matrices[..., 1, 1]
    det = a * d - b * c
    adjugate = np.stack((d, -b, -c, a), axis=-1).reshape(matrices.shape)
    inverse: np.ndarray = adjugate / det[..., None, None]
    return inverse


def innovation_covariance(
    covariances: np.ndarray, measurement_covariance: np.ndarray
) -> np.ndarray:
    """S = H P H^T + R for a stack of state covariances (..., n, n)."""
    s: np.ndarray = covariances[..., :AXES, :AXES] + measurement_covariance
    return s


def kalman_gain(covariances: np.ndarray, measurement_covariance: np.ndarray) -> np.ndarray:
    """K = P H^T S^-1, shape (..., n, 2)."""
    s_inverse = inverse_2x2(innovation_covariance(covariances, measurement_covariance))
    gain: np.ndarray = covariances[..., :, :AXES] @ s_inverse
    return gain


def fixed_gain(g: np.ndarray, h: np.ndarray, k: np.ndarray, dt: float, order: int) -> np.ndarray:
    """K (..., n, 2) of a g-h(-k) filter: x += g r, v += h r / dt, a += 2 k r / dt^2 per axis.

    With dt == 0 (a second measurement at the same time) only the position is corrected: the rate
    gains need an interval.
    """
    g = np.asarray(g, dtype=float)
    per_axis = [
        g,
        h / dt if dt > 0 else np.zeros_like(g),
        2.0 * k / dt**2 if dt > 0 else np.zeros_like(g),
    ]
    gain = np.zeros(g.shape + (AXES * (order + 1), AXES))
    for block in range(order + 1):
        for axis in range(AXES):
            gain[..., AXES * block + axis, axis] = per_axis[block]
    return gain


def joseph_update(
    covariances: np.ndarray, gains: np.ndarray, measurement_covariance: np.ndarray
) -> np.ndarray:
    """P' = (I - K H) P (I - K H)^T + K R K^T: the error covariance after a correction with ANY gain K.

    Exact for the Kalman gain and for fixed gains alike, which is why the alpha-beta filters use it to
    carry an honest covariance for gating.
    """
    n = covariances.shape[-1]
    i_kh = np.broadcast_to(np.eye(n), gains.shape[:-2] + (n, n)).copy()
    i_kh[..., :, :AXES] -= gains
    corrected: np.ndarray = i_kh @ covariances @ np.swapaxes(
        i_kh, -1, -2
    ) + gains @ measurement_covariance @ np.swapaxes(gains, -1, -2)
    return corrected


def correct(
    means: np.ndarray,
    covariances: np.ndarray,
    z: np.ndarray,
    gains: np.ndarray,
    measurement_covariance: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """The corrected means and covariances for measurements z (..., 2) with gains K (..., n, 2)."""
    residual = z - means[..., :AXES]
    new_means = means + (gains @ residual[..., None])[..., 0]
    return new_means, joseph_update(covariances, gains, measurement_covariance)

"""Region covariance descriptors (Porikli, Tuzel, Meer 2006) of many rectangles, and the Förstner
distance between them (seed 003's Ext 5), no rclpy.

Each pixel has the features f = [x y R G B] (position in px, colour 0-255). A rectangle's
descriptor is the covariance of its pixels' features,

    C_R = (1 / n) sum (f - mu)(f - mu)^T = (1 / n) (sum f f^T - (sum f)(sum f)^T / n),

computed for every rectangle from integral images of the 5 features and their 15 products (four
look-ups each, whatever the rectangle's size). Two descriptors are compared by

    rho(C_1, C_2) = sqrt(sum_k ln^2 lambda_k(C_1, C_2))   (Förstner; lambda_k: generalised eigenvalues)

A plain-coloured rectangle has zero colour variance, so RIDGE is added to the diagonal (one px^2 or
one grey level^2) to keep every descriptor positive definite.
"""

from __future__ import annotations

import numpy as np

FEATURES = ("x", "y", "R", "G", "B")
RIDGE = 1.0
_UPPER = np.triu_indices(len(FEATURES))


def integral_features(image: np.ndarray) -> np.ndarray:
    """Integral images (H+1, W+1, 20) of f and of the upper triangle of f f^T for a bgr8 image
    (I[y, x] sums the pixels above and left of (x, y)). Positions are the image's own: a
    covariance does not change when the rectangles and the image move together, and small
    coordinates keep sum f f^T - (sum f)^2 / n from losing digits."""
    height, width = image.shape[:2]
    ys, xs = np.mgrid[0:height, 0:width].astype(np.float64)
    f = np.stack([xs, ys, image[..., 2], image[..., 1], image[..., 0]], axis=-1).astype(np.float64)
    products = f[..., _UPPER[0]] * f[..., _UPPER[1]]
    channels = np.concatenate([f, products], axis=-1)
    integral = np.zeros((height + 1, width + 1, channels.shape[-1]))
    np.cumsum(np.cumsum(channels, axis=0), axis=1, out=integral[1:, 1:])
    return integral


def region_covariances(integral: np.ndarray, bounds: np.ndarray) -> np.ndarray:
    """C_R (N, 5, 5) of the rectangles [x0, y0, x1, y1) (integer, inside the integral's image,
    non-empty), with RIDGE on the diagonal."""
    x0, y0, x1, y1 = (bounds[:, i] for i in range(4))
    sums = integral[y1, x1] - integral[y0, x1] - integral[y1, x0] + integral[y0, x0]
    n = ((x1 - x0) * (y1 - y0)).astype(np.float64)[:, None]
    k = len(FEATURES)
    mean = sums[:, :k] / n
    second = np.zeros((len(bounds), k, k))
    second[:, _UPPER[0], _UPPER[1]] = sums[:, k:] / n
    second[:, _UPPER[1], _UPPER[0]] = sums[:, k:] / n
    covariance = second - mean[:, :, None] * mean[:, None, :]
    ridged: np.ndarray = covariance + RIDGE * np.eye(k)
    return ridged


def forstner_distances(covariances: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """rho(C_i, C_ref) for each C_i (N, 5, 5): the generalised eigenvalues of (C_i, C_ref) are the
    eigenvalues of W C_i W with W = C_ref^(-1/2)."""
    values, vectors = np.linalg.eigh(reference)
    whiten = vectors @ np.diag(values**-0.5) @ vectors.T
    eigenvalues = np.linalg.eigvalsh(whiten @ covariances @ whiten)
    distances: np.ndarray = np.sqrt((np.log(np.maximum(eigenvalues, 1e-300)) ** 2).sum(axis=1))
    return distances

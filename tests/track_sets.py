"""TrackSets for the selection and zone tests: tracks at given positions with square boxes."""

import numpy as np

from tracker_filter.tracking import TrackSet, TrackStatus

C, K, T, L = TrackStatus.CONFIRMED, TrackStatus.COASTING, TrackStatus.TENTATIVE, TrackStatus.LOST


def track_set(time, ids, positions, status=None, ages=None, areas=None, box=10.0, travel=None):
    n = len(ids)
    positions = np.asarray(positions, dtype=float).reshape(n, 2)
    means = np.column_stack([positions, np.zeros((n, 2))])
    return TrackSet(
        time=time,
        state_layout=("x", "y", "vx", "vy"),
        ids=np.asarray(ids),
        status=np.asarray(status if status is not None else [C] * n, dtype=np.uint8),
        means=means,
        covariances=np.tile(np.eye(4), (n, 1, 1)),
        bboxes=np.column_stack([positions - box / 2, np.full((n, 2), box)]),
        ages=np.asarray(ages if ages is not None else [1.0] * n, dtype=float),
        hits=np.ones(n, dtype=int),
        misses=np.zeros(n, dtype=int),
        existence=np.ones(n),
        areas=np.asarray(areas if areas is not None else [100.0] * n, dtype=float),
        detections=np.arange(n),
        travel=None if travel is None else np.asarray(travel, dtype=float),
    )

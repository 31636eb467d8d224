"""The suite's detections and tracks as vision_msgs/Detection2DArray, the ecosystem's common
currency for 2D detections (perception consumers, rviz / Foxglove panels read it).

Each blob or track is one Detection2D in the same frame and units as the suite's message (scene
pixels, `header.frame_id` "scene"): `bbox` its box (centre and sides, theta the blob's angle), one
hypothesis with its class (`label`: "person", or "motion" for an unclassified region) and score
(`Blob.score`), the hypothesis' pose at its centroid (a track: its estimated position with the
position covariance), and `id` empty for a detection, the tracking id for a track. Every track
of the TrackArray is included, tentative ones too (vision_msgs has no status: read TrackArray
for it).
"""

from __future__ import annotations

from typing import Any

from tracker_msgs_py.labels import MOTION


def detections_to_vision(msg: Any) -> Any:
    """A tracker_msgs/BlobArray as a vision_msgs/Detection2DArray (same header)."""
    from vision_msgs.msg import Detection2DArray

    out = Detection2DArray(header=msg.header)
    for blob in msg.blobs:
        box = blob.bbox
        detection = _detection(msg.header, box, blob.label, blob.score, "")
        detection.bbox.center.theta = float(blob.angle)
        pose = detection.results[0].pose.pose
        pose.position.x, pose.position.y = float(blob.centroid_x), float(blob.centroid_y)
        out.detections.append(detection)
    return out


def tracks_to_vision(msg: Any) -> Any:
    """A tracker_msgs/TrackArray as a Detection2DArray whose `id` is each track's id."""
    from vision_msgs.msg import Detection2DArray

    out = Detection2DArray(header=msg.header)
    for track in msg.tracks:
        detection = _detection(msg.header, track.bbox, track.label, track.score, str(track.id))
        pose = detection.results[0].pose
        pose.pose.position.x, pose.pose.position.y = float(track.x), float(track.y)
        xx, xy, yx, yy = (float(v) for v in track.position_covariance)
        covariance = [0.0] * 36  # (x, y, z, roll, pitch, yaw), row-major
        covariance[0], covariance[1], covariance[6], covariance[7] = xx, xy, yx, yy
        pose.covariance = covariance
        out.detections.append(detection)
    return out


def _detection(header: Any, box: Any, label: str, score: float, identity: str) -> Any:
    from vision_msgs.msg import Detection2D, ObjectHypothesisWithPose

    detection = Detection2D(header=header, id=identity)
    detection.bbox.center.position.x = float(box.x + box.width / 2)
    detection.bbox.center.position.y = float(box.y + box.height / 2)
    detection.bbox.size_x, detection.bbox.size_y = float(box.width), float(box.height)
    hypothesis = ObjectHypothesisWithPose()
    hypothesis.hypothesis.class_id = label or MOTION
    hypothesis.hypothesis.score = float(score)
    detection.results.append(hypothesis)
    return detection

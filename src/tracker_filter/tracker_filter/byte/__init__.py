"""Tracking on scored boxes in the manner of ByteTrack."""

"""OpenCV MOG2 background subtraction for a static camera (seed 004)."""

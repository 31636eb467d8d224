"""Motion detection for a moving pan-tilt camera: SSIM change detection with ego-motion
compensation (seed 000).
"""

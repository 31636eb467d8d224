"""SSIM against a background mosaic kept in scene coordinates."""

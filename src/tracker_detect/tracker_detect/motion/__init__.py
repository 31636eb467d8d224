"""Seed 000's SSIM motion detection between frames `gap` apart."""

"""The gated-Hungarian tracker (seed 000's filters, chi-square gating, M-of-N confirmation)."""

"""Example e2esim plug-in: an L-band SAR instrument."""

"""Ionospheric amplitude scintillation as an e2esim plug-in: a stage kind, a product, an error source."""

"""File formats and data-set layouts: everything that touches disk lives under ``voxelmocap.io``."""

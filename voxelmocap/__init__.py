"""voxelmocap: markerless multi-camera human motion capture.

Silhouettes from N calibrated, synchronised cameras are carved into a voxel occupancy grid, a
27-parameter truncated-cone body model is scored against the voxels, and an annealed particle
filter tracks the pose through a HumanEva-format sequence.

Conventions: millimetres, right-handed world with Z up and the floor at Z = 0; image pixels are
(u, v) = (column, row); synchronised frame numbers are HumanEva's 1-based numbers.
"""

__version__ = "0.1.0"

__all__ = ["__version__"]

"""Camera models, poses and 3D boxes (vectorised numpy)."""

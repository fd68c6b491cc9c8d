"""Camera models, poses and 3D boxes (vectorised numpy).

Layer: nvrq core, geometry.
"""

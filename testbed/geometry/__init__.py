"""Geometry in numpy, no Drake: exact box maths (boxes.py: separating axes, box-box and
box-slab signed distances, the pairwise query) and rotations (rotations.py: quaternions,
roll-pitch-yaw, angles between orientations)."""

"""What a scene is made of: the ISO container types (containers.py), generic boxes and
grounds (boxes.py) and the SDF models loaded into a MultibodyPlant (models.py)."""

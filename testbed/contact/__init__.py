"""Drake's contact answers, read: which body a geometry belongs to (body_index.py), the
geometry of a contact output (surfaces.py: centres of pressure, normals, force split),
per-step record rows (extraction.py) and a two-body plant for static queries (pair_plant.py)."""

"""Predictors behind one interface (learned_contact.interface): the shipped improved
(improved.py) and paper (paper.py) networks on their shared base (base.py), read from
weights files (loading.py: the one table of shipped kinds); models the testbed did not ship
(external.py; ONNX files, onnx_model.py; Python objects, python_model.py) under bounds
(limits.py and its limits_*.py; the vetting child is learned_contact.vet); the contract's pose helpers (poses.py).
learned_contact.sources is the one catalogue of sources."""

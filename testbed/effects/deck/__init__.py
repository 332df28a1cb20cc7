"""The `deck_motion` effect's law (testbed/effects/deck_motion.py registers the effect).

motion.py: the deck's prescribed motion relative to the world (roll, pitch, heave: harmonic
or a time series, ramped in) and its kinematics in the deck frame D.
law.py: DeckMotionLaw, the one statement of the inertial (fictitious) wrenches and the
twistlock springs that Drake's LeafSystem and the MuJoCo engines apply.
"""

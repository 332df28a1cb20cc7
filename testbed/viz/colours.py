"""Colours of the viewer: the error scale of overlays, layer markers, force arrows.

Arrows and error segments are coloured on a scale from green (agreement) to red
(point distance >= error_threshold [m] or normal angle >= angle_threshold_deg); a
truth arrow takes the colour of the learned comparison when there is one, else of the
shadow comparison, else it is light grey. Marker spheres have a fixed colour per layer
(truth cyan, shadow magenta, learned yellow). Colours cannot be animated in a Meshcat
recording, so the scale is cut into N_BINS bins (see overlays.py).
"""

from __future__ import annotations

import numpy as np

# Colour scale: N_BINS bins from green (agreement) to red (error >= threshold),
# then one neutral bin (no comparison available).
SCALE_RGB = np.array([[0.10, 0.85, 0.10], [0.95, 0.85, 0.10], [0.95, 0.10, 0.10]])
N_BINS = 5
NEUTRAL_RGB = (0.85, 0.85, 0.85)
MARKER_RGB = {"truth": (0.0, 0.85, 1.0), "shadow": (0.95, 0.0, 0.95), "learned": (1.0, 0.9, 0.0)}
# ContactVisualizer colours, chosen apart from the overlay scale's greens and reds.
POINT_FORCE_RGB = (1.0, 0.5, 0.0)
HYDRO_FORCE_RGB = (0.55, 0.25, 1.0)
HYDRO_MOMENT_RGB = (0.2, 0.35, 1.0)


def error_fraction(distance, angle_deg, error_threshold: float, angle_threshold_deg: float):
    """Position on the colour scale, 0 (agreement) to 1 (at or beyond a threshold).

    distance [m] between two contact points, angle_deg [deg] between two normals;
    scalars or arrays of the same shape."""
    return np.clip(np.maximum(np.asarray(distance) / error_threshold, np.asarray(angle_deg) / angle_threshold_deg), 0.0, 1.0)


def bin_of(fraction: float | None) -> int:
    """Colour bin of a scale position; None (nothing to compare with) -> the neutral bin."""
    if fraction is None or not np.isfinite(fraction):
        return N_BINS
    return int(round(float(fraction) * (N_BINS - 1)))


def bin_rgb(k: int) -> tuple[float, float, float]:
    """RGB in [0, 1] of colour bin k (0 green ... N_BINS-1 red; N_BINS neutral grey)."""
    if k >= N_BINS:
        return NEUTRAL_RGB
    s = k / (N_BINS - 1) * (len(SCALE_RGB) - 1)
    i = min(int(s), len(SCALE_RGB) - 2)
    w = s - i
    return tuple(float(x) for x in (1 - w) * SCALE_RGB[i] + w * SCALE_RGB[i + 1])

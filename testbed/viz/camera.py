"""What the viewer frames and when: the camera on a scene, and the frame period."""

from __future__ import annotations

import numpy as np


def frame_period(frame_rate: float, time_step: float) -> float:
    """The frame period [s]: a whole number of plant steps closest to 1 / frame_rate,
    so every frame shows one simulated state (30 Hz at h = 1 ms -> 33 ms)."""
    return time_step * max(1, round(1.0 / (frame_rate * time_step)))


def set_camera_for(meshcat, assembly) -> None:
    """Points the camera at the containers' bounding box from a 3/4 view."""
    p = np.array([c.pose().translation() for c in assembly.scenario.containers])
    r = np.array([np.linalg.norm(c.container_type().half_size) for c in assembly.scenario.containers])
    lo, hi = (p - r[:, None]).min(axis=0), (p + r[:, None]).max(axis=0)
    crane = assembly.effects.get("crane")
    if crane is not None:  # keep the trolley in view
        hi[2] = max(hi[2], float(crane.config.trolley_height))
    target = 0.5 * (lo + hi)
    radius = 0.5 * float(np.linalg.norm(hi - lo))
    direction = np.array([1.0, -1.4, 0.7])
    meshcat.SetCameraPose(target + 1.6 * radius * direction / np.linalg.norm(direction), target)

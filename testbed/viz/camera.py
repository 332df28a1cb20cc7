"""What the viewer frames and when: the camera on a scene, and the frame period."""

from __future__ import annotations

import numpy as np


def frame_period(frame_rate: float, time_step: float) -> float:
    """The frame period [s]: a whole number of plant steps closest to 1 / frame_rate,
    so every frame shows one simulated state (30 Hz at h = 1 ms -> 33 ms)."""
    return time_step * max(1, round(1.0 / (frame_rate * time_step)))


def set_camera_for(meshcat, assembly) -> None:
    """Points the camera at the containers' bounding box from a 3/4 view."""
    crane = assembly.effects.get("crane")
    set_camera_on(meshcat, assembly.scenario.containers,  # keep a crane's trolley in view
                  top=float(crane.config.trolley_height) if crane is not None else None)


def set_camera_on(meshcat, containers, top: float | None = None) -> None:
    """Points the camera at the bounding box of `containers` (scenario container specs, at
    their initial poses) from a 3/4 view; top [m]: a height to keep in view as well."""
    p = np.array([c.pose().translation() for c in containers])
    r = np.array([np.linalg.norm(c.container_type().half_size) for c in containers])
    lo, hi = (p - r[:, None]).min(axis=0), (p + r[:, None]).max(axis=0)
    if top is not None:
        hi[2] = max(hi[2], top)
    target = 0.5 * (lo + hi)
    radius = 0.5 * float(np.linalg.norm(hi - lo))
    direction = np.array([1.0, -1.4, 0.7])
    meshcat.SetCameraPose(target + 1.6 * radius * direction / np.linalg.norm(direction), target)

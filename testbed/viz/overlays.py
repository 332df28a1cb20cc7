"""Discrepancy overlays drawn into Meshcat: points, normals and error segments.

Scene tree (each top-level overlay path is a toggle in the viewer's "Scene" controls):

  /drake/visualizer          the scene's illustration geometry (containers coloured by
                             type from their SDF, the quay, and any geometry other
                             effects register), drawn by Drake's MeshcatVisualizer
  /drake/contact_forces      Drake's ContactVisualizer: contact forces (and moments)
                             and hydroelastic pressure patches
  /overlays/truth            per contacting pair: the driving model's contact point
                             (sphere) and unit normal a -> b (arrow)
  /overlays/shadow           the shadow_contact model's point and normal, if declared
  /overlays/shadow_error     segment from the truth point to the shadow point
  /overlays/learned          the learned_contact predictor's point and normal, if any
  /overlays/learned_error    segment from the truth point to the learned point
  /crane                     the `crane` effect's trolley and ropes, when declared

Colours: testbed/viz/colours.py. Replays: SetObject is not animated in a Meshcat
recording, so every overlay object is created once and then only moved
(SetTransform), stretched (the "scale" property) and shown or hidden (the "visible"
property), all with time_in_recording. Colours cannot be animated either (meshcat.js
binds a "color" track to nothing), so each arrow and segment exists once per colour
bin and only the bin in use is visible.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from testbed.viz.colours import MARKER_RGB, N_BINS, bin_of, bin_rgb, error_fraction

OVERLAY_ROOT = "/overlays"
LAYERS = ("truth", "shadow", "shadow_error", "learned", "learned_error")
OVERLAY_RENDER_ORDER = 10.0  # drawn after the (transparent) containers, without depth test


@dataclasses.dataclass
class GlyphSizes:
    """Overlay sizes [m] (scene scale: containers are 2.4-12 m long)."""

    marker_radius: float = 0.18
    arrow_length: float = 1.5
    shaft_radius: float = 0.04
    head_length: float = 0.35
    head_radius: float = 0.13
    segment_radius: float = 0.06


class _Glyph:
    """One overlay item at `path`, animated only by transform/scale/visible (replayable).

    kind "pointer": a marker sphere at the origin and an arrow along +z (frame G);
    kind "segment": a cylinder from the origin to z = 1, stretched by the scale property.
    Each coloured part exists once per colour bin; only one bin is visible.
    """

    def __init__(self, viewer: "OverlayPainter", path: str, kind: str, marker_rgb=None):
        from pydrake.geometry import Cylinder, MeshcatCone, Rgba, Sphere
        from pydrake.math import RigidTransform, RotationMatrix

        self.viewer, self.path, self.kind = viewer, path, kind
        mc, s = viewer.meshcat, viewer.sizes
        self.bin = None
        self.shown = None

        def add(sub, shape, rgb, X=None):
            full = f"{path}/{sub}"
            mc.SetObject(full, shape, Rgba(*rgb, 0.999))  # a < 1: drawn in three.js' transparent pass
            if X is not None:
                mc.SetTransform(full, X)
            mc.SetProperty(f"{full}/<object>", "material.depthTest", False)
            mc.SetProperty(f"{full}/<object>", "renderOrder", OVERLAY_RENDER_ORDER)

        if kind == "pointer":
            add("point", Sphere(s.marker_radius), marker_rgb)
            shaft = s.arrow_length - s.head_length
            for k in range(N_BINS + 1):
                rgb = bin_rgb(k)
                add(f"arrow/c{k}/shaft", Cylinder(s.shaft_radius, shaft), rgb, RigidTransform([0, 0, shaft / 2]))
                # MeshcatCone: apex at the origin, opening along +z; flip it to point along +z.
                add(f"arrow/c{k}/head", MeshcatCone(s.head_length, s.head_radius, s.head_radius), rgb,
                    RigidTransform(RotationMatrix.MakeXRotation(math.pi), [0, 0, s.arrow_length]))
        else:
            for k in range(N_BINS + 1):
                add(f"c{k}", Cylinder(s.segment_radius, 1.0), bin_rgb(k), RigidTransform([0, 0, 0.5]))

    def _bin_path(self, k: int) -> str:
        return f"{self.path}/arrow/c{k}" if self.kind == "pointer" else f"{self.path}/c{k}"

    def show(self, X_WG, k: int, length: float | None, t: float | None) -> None:
        """Places frame G at X_WG (RigidTransform), colour bin k, segment length [m]."""
        mc = self.viewer.meshcat
        mc.SetTransform(self.path, X_WG, t)
        if self.kind == "segment":
            mc.SetProperty(self.path, "scale", [1.0, 1.0, max(float(length), 1e-6)], t)
        if k != self.bin:
            for j in range(N_BINS + 1):
                if self.bin is None or j in (k, self.bin):
                    mc.SetProperty(self._bin_path(j), "visible", j == k, t)
            self.bin = k
        if self.shown is not True:
            if self.shown is None and t is not None and t > 0:
                mc.SetProperty(self.path, "visible", False, 0.0)  # created mid-recording: hidden before
            mc.SetProperty(self.path, "visible", True, t)
            self.shown = True

    def hide(self, t: float | None) -> None:
        if self.shown:
            self.viewer.meshcat.SetProperty(self.path, "visible", False, t)
            self.shown = False


def frame_along(p_W, z_W):
    """X_WG with origin p_W (3,) [m] and +z along the direction z_W (3,) (any length > 0)."""
    from pydrake.math import RigidTransform, RotationMatrix

    z = np.asarray(z_W, dtype=float)
    norm = np.linalg.norm(z)
    R = RotationMatrix() if not norm > 1e-12 else RotationMatrix.MakeFromOneVector(z / norm, 2)
    return RigidTransform(R, np.asarray(p_W, dtype=float))


def _angle_deg(n1, n2) -> float:
    c = float(np.dot(n1, n2) / max(np.linalg.norm(n1) * np.linalg.norm(n2), 1e-12))
    return math.degrees(math.acos(max(-1.0, min(1.0, c))))


def _slot_keys(a, b) -> list[tuple[int, int, int]]:
    """(a, b, k): k numbers repeated rows of the same pair in one step (0 for the first)."""
    seen: dict = {}
    keys = []
    for ai, bi in zip(np.asarray(a).tolist(), np.asarray(b).tolist()):
        k = seen.get((ai, bi), 0)
        seen[(ai, bi)] = k + 1
        keys.append((ai, bi, k))
    return keys


class OverlayPainter:
    """Draws one frame of discrepancy overlays; owns the glyphs (created on first use).

    meshcat: a pydrake Meshcat; body_names: names indexed by the rows' a/b;
    error_threshold [m], angle_threshold_deg [deg]: where the colour scale turns red.
    """

    def __init__(self, meshcat, body_names, *, error_threshold: float, angle_threshold_deg: float,
                 sizes: GlyphSizes | None = None):
        self.meshcat = meshcat
        self.body_names = list(body_names)
        self.error_threshold = error_threshold
        self.angle_threshold_deg = angle_threshold_deg
        self.sizes = sizes or GlyphSizes()
        self.glyphs: dict[tuple, _Glyph] = {}
        self.frames = 0

    def _slot_name(self, key) -> str:
        a, b, k = key
        name = f"{self.body_names[a]}+{self.body_names[b]}"
        return name if k == 0 else f"{name}.{k}"

    def _glyph(self, layer: str, key) -> _Glyph:
        g = self.glyphs.get((layer, key))
        if g is None:
            kind = "segment" if layer.endswith("_error") else "pointer"
            g = _Glyph(self, f"{OVERLAY_ROOT}/{layer}/{self._slot_name(key)}", kind, MARKER_RGB.get(layer))
            self.glyphs[(layer, key)] = g
        return g

    def draw(self, truth: dict | None, predictions: dict[str, dict | None], t: float | None) -> None:
        """One frame.

        truth: columns a, b (k,), p_W_cop (k, 3) [m], n_W (k, 3) (a -> b), or None;
        predictions: layer ('shadow' | 'learned') -> columns a, b, p_W (k, 3) [m],
        n_W (k, 3), or None when that model gave nothing for this state;
        t: time in the recording [s] (None when not recording).
        """
        drawn: set = set()
        truth_rows = {}
        if truth is not None and len(truth["a"]):
            truth_rows = dict(zip(_slot_keys(truth["a"], truth["b"]), zip(truth["p_W_cop"], truth["n_W"])))
        fractions: dict[str, dict] = {}
        for layer, rows in predictions.items():
            fractions[layer] = {}
            if rows is None or not len(rows["a"]):
                continue
            for key, p, n in zip(_slot_keys(rows["a"], rows["b"]), rows["p_W"], rows["n_W"]):
                fraction = None
                if key in truth_rows:
                    p_t, n_t = truth_rows[key]
                    d = p - p_t
                    fraction = float(error_fraction(np.linalg.norm(d), _angle_deg(n, n_t), self.error_threshold, self.angle_threshold_deg))
                    L = float(np.linalg.norm(d))
                    self._glyph(f"{layer}_error", key).show(frame_along(p_t, d if L > 1e-9 else n_t), bin_of(fraction), L, t)
                    drawn.add((f"{layer}_error", key))
                    fractions[layer][key] = fraction
                self._glyph(layer, key).show(frame_along(p, n), bin_of(fraction), None, t)
                drawn.add((layer, key))
        for key, (p, n) in truth_rows.items():
            fraction = fractions.get("learned", {}).get(key, fractions.get("shadow", {}).get(key))
            self._glyph("truth", key).show(frame_along(p, n), bin_of(fraction), None, t)
            drawn.add(("truth", key))
        for name, glyph in self.glyphs.items():
            if name not in drawn:
                glyph.hide(t)
        self.frames += 1


class CranePainter:
    """Draws a `crane` effect's trolley and its four ropes (the crane has no geometry).

    crane: the effect's CraneSystem (sheaves_W(t) -> (4, 3) [m], release_log [s]);
    half_size (3,) [m] of the carried container, whose top corners (+-x, +-y, +z in its
    frame B, in the crane's sheave order) the ropes hang from until the twistlocks open.
    Paths: /crane/trolley, /crane/ropes/<i>."""

    TROLLEY_SIZE = (4.0, 3.0, 1.0)  # [m]
    TROLLEY_RGB = (0.95, 0.75, 0.1)
    ROPE_RGB = (0.12, 0.12, 0.12)
    ROPE_RADIUS = 0.04  # [m]

    def __init__(self, meshcat, crane, half_size):
        from pydrake.geometry import Box, Cylinder, Rgba
        from pydrake.math import RigidTransform

        self.meshcat, self.crane = meshcat, crane
        hx, hy, hz = half_size
        self.p_BC = np.array([[sx * hx, sy * hy, hz] for sx in (-1, 1) for sy in (-1, 1)])  # (4, 3)
        meshcat.SetObject("/crane/trolley", Box(*self.TROLLEY_SIZE), Rgba(*self.TROLLEY_RGB, 1.0))
        for i in range(4):
            meshcat.SetObject(f"/crane/ropes/{i}/line", Cylinder(self.ROPE_RADIUS, 1.0), Rgba(*self.ROPE_RGB, 1.0))
            meshcat.SetTransform(f"/crane/ropes/{i}/line", RigidTransform([0, 0, 0.5]))
        self.ropes_shown = None

    def draw(self, t_state: float, X_WB, t: float | None) -> None:
        """Trolley and ropes for the state at t_state [s]; X_WB: the container's pose."""
        from pydrake.math import RigidTransform

        mc = self.meshcat
        sheaves = self.crane.sheaves_W(t_state)  # (4, 3)
        mc.SetTransform("/crane/trolley", RigidTransform(sheaves.mean(axis=0) + [0, 0, 0.5 * self.TROLLEY_SIZE[2]]), t)
        released = any(r <= t_state + 1e-9 for r in self.crane.release_log)
        if not released:
            corners = (X_WB.rotation().matrix() @ self.p_BC.T).T + X_WB.translation()
            for i, (c, s) in enumerate(zip(corners, sheaves)):
                mc.SetTransform(f"/crane/ropes/{i}", frame_along(c, s - c), t)
                mc.SetProperty(f"/crane/ropes/{i}", "scale", [1.0, 1.0, float(np.linalg.norm(s - c))], t)
        if self.ropes_shown != (not released):
            mc.SetProperty("/crane/ropes", "visible", not released, t)
            self.ropes_shown = not released

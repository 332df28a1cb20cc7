"""Meshcat viewer: discrepancy overlays, recordings and the `testbed view` command.

Everything here uses Drake's own Meshcat server (pydrake.geometry.Meshcat). Nothing
is started at import: a server exists only once `start_meshcat` is called, by the
`meshcat` effect (testbed/effects/meshcat.py) or by `view`.

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

Arrows and error segments are coloured on a scale from green (agreement) to red
(point distance >= error_threshold [m] or normal angle >= angle_threshold_deg);
a truth arrow takes the colour of the learned comparison when there is one, else
of the shadow comparison, else it is light grey. Marker spheres have a fixed colour
per layer (truth cyan, shadow magenta, learned yellow).

Replays: SetObject is not animated in a Meshcat recording, so every overlay object
is created once and then only moved (SetTransform), stretched (the "scale" property)
and shown or hidden (the "visible" property), all with time_in_recording. Colours
cannot be animated either (meshcat.js binds a "color" track to nothing), so each
arrow and segment exists once per colour bin and only the bin in use is visible.
"""

from __future__ import annotations

import dataclasses
import ipaddress
import json
import math
import os
import socket
import sys
import time
from pathlib import Path

import numpy as np

from testbed.errors import TestbedError

DEFAULT_PORT = 7000
REPLAY_NAME = "replay.html"  # the replay's file name in a run directory
OVERLAY_ROOT = "/overlays"
LAYERS = ("truth", "shadow", "shadow_error", "learned", "learned_error")
# Learned predictions: the `learned_contact` effect's `predictions` or `probe.table`
# (see `learned_source`): an object with .latest() -> (step, time [s], columns) | None.
LEARNED_EFFECT = "learned_contact"
LEARNED_ATTRIBUTE = "predictions"

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
OVERLAY_RENDER_ORDER = 10.0  # drawn after the (transparent) containers, without depth test


class MeshcatPortError(TestbedError, RuntimeError):
    """The Meshcat server could not listen on the requested host/port (usually: in use)."""

    def __init__(self, host: str, port: int | None, detail: str):
        self.host, self.port = host, port
        super().__init__(
            f"cannot start the Meshcat viewer on {host}:{port}: {detail}; the port is probably in use "
            f"(another viewer?). Choose another with --port P (e.g. --port {(port or DEFAULT_PORT) + 1}), "
            f"or --port 0 to let the system pick a free one"
        )


# ----------------------------------------------------------------------------- server


def is_loopback_host(host: str) -> bool:
    """True if `host` names only this machine's loopback interface ("localhost", 127.x, ::1)."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


def exposure_warning(host: str) -> str | None:
    """The warning to print for a non-loopback host, or None for loopback ones."""
    if is_loopback_host(host):
        return None
    where = "every network interface" if host in ("*", "0.0.0.0", "::") else f"the address {host}"
    return (f"WARNING: the viewer listens on {where}. Meshcat has no authentication: anyone who "
            f"can reach this machine on that port can watch the scene and send it commands. "
            f"Use the default --host localhost unless you trust the network.")


def start_meshcat(host: str = "localhost", port: int | None = DEFAULT_PORT):
    """Starts a Meshcat server. port None or 0 = any free port (0: the system's choice).

    Raises MeshcatPortError (a TestbedError) naming the port when it cannot listen.
    """
    from pydrake.geometry import Meshcat, MeshcatParams

    params = MeshcatParams(host=host, port=port if port else 0, show_stats_plot=False)
    try:
        return Meshcat(params)
    except RuntimeError as e:
        raise MeshcatPortError(host, port, str(e).strip().splitlines()[0]) from None


def listening_addresses(port: int) -> list[str]:
    """Local addresses ('127.0.0.1', '::1', '0.0.0.0', ...) with a TCP socket in LISTEN
    state on `port`, read from /proc/net/tcp and /proc/net/tcp6 (Linux only)."""
    out = []
    for name, family in (("/proc/net/tcp", socket.AF_INET), ("/proc/net/tcp6", socket.AF_INET6)):
        try:
            lines = Path(name).read_text().splitlines()[1:]
        except OSError:
            continue
        for line in lines:
            fields = line.split()
            local, state = fields[1], fields[3]
            address_hex, port_hex = local.split(":")
            if state != "0A" or int(port_hex, 16) != port:  # 0A = TCP_LISTEN
                continue
            raw = bytes.fromhex(address_hex)
            # /proc prints each 32-bit word in host (little-endian) byte order.
            raw = b"".join(raw[i:i + 4][::-1] for i in range(0, len(raw), 4))
            out.append(socket.inet_ntop(family, raw))
    return out


# ----------------------------------------------------------------------------- colours


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


# ----------------------------------------------------------------------------- glyphs


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


# ----------------------------------------------------------------------------- sources


class TableSource:
    """Rows of a TableBuilder-like object (`.latest() -> (step, time, columns) | None`) for
    one state time: `at(t)` returns the columns if the newest rows are of time t (within
    tol [s]), else None (no rows for that state). `point`/`normal` name the columns
    holding the point [m] and unit normal, renamed to p_W / n_W."""

    def __init__(self, get_table, point: str, normal: str, tol: float):
        self._get_table, self.point, self.normal, self.tol = get_table, point, normal, tol
        self._cache: dict[float, dict] = {}

    def _table(self):
        return self._get_table()

    def poll(self) -> None:
        """Remembers the newest rows (call at every event near a frame, see DiscrepancyOverlay)."""
        table = self._table()
        latest = table.latest() if table is not None else None
        if latest is None:
            return
        _, t, columns = latest
        if self.point not in columns or self.normal not in columns:
            return
        self._cache[round(t, 9)] = {"a": columns["a"], "b": columns["b"], "p_W": columns[self.point], "n_W": columns[self.normal]}
        if len(self._cache) > 4:
            self._cache.pop(next(iter(self._cache)))

    def at(self, t: float) -> dict | None:
        self.poll()
        for key, rows in self._cache.items():
            if abs(key - t) <= self.tol:
                return rows
        return None


def learned_source(effects: dict, tol: float) -> TableSource:
    """Source of the learned predictor's answer, resolved lazily from the effect named
    'learned_contact': its attribute `predictions`, else `probe.table` (a TableBuilder).
    Absent -> no rows. Columns used: a, b (k,) int; p_W_pred (k, 3) [m] contact point in
    W; n_W_pred (k, 3) unit normal a -> b in W; `time` is that of the state predicted for."""

    def table():
        effect = effects.get(LEARNED_EFFECT)
        if effect is None:
            return None
        found = getattr(effect, LEARNED_ATTRIBUTE, None)
        return found if found is not None else getattr(getattr(effect, "probe", None), "table", None)

    return TableSource(table, "p_W_pred", "n_W_pred", tol)


def frame_period(frame_rate: float, time_step: float) -> float:
    """The frame period [s]: a whole number of plant steps closest to 1 / frame_rate,
    so every frame shows one simulated state (30 Hz at h = 1 ms -> 33 ms)."""
    return time_step * max(1, round(1.0 / (frame_rate * time_step)))


def make_overlay_system(assembly, meshcat, painter: OverlayPainter, period: float, recording: bool):
    """Adds the `meshcat_overlays` LeafSystem to assembly.builder and returns it.

    It runs a cheap callback every plant step h and draws one frame every `period` [s]
    (a multiple of h, see frame_period). With the plant's sampled output ports (the
    default) the contact results seen at step k belong to the state of step k - 1, so
    the frame for state k - 1 is drawn at step k and recorded at that state's time.
    The shadow and learned answers are matched to that state by time.
    """
    from pydrake.common.value import AbstractValue
    from pydrake.geometry import QueryObject
    from pydrake.multibody.plant import ContactResults
    from pydrake.systems.framework import LeafSystem

    from testbed import contact_extraction

    plant = assembly.plant
    h = plant.time_step()
    lag = 1 if plant.has_sampled_output_ports() else 0
    frame_steps = max(1, round(period / h))
    effects = assembly.effects  # filled in as effects are added: resolved at the first frame
    tol = 0.25 * h

    def logger_table():
        e = effects.get("contact_log")
        return getattr(getattr(e, "logger", None), "contacts", None)

    def shadow_table():
        e = effects.get("shadow_contact")
        return getattr(getattr(e, "probe", None), "table", None)

    truth_log = TableSource(logger_table, "p_W_cop_static", "n_W", tol)
    sources = {"shadow": TableSource(shadow_table, "p_W_cop_static", "n_W", tol), "learned": learned_source(effects, tol)}
    declared = {"shadow": "shadow_contact", "learned": LEARNED_EFFECT}
    crane_painter, crane_body = None, None
    crane_effect = effects.get("crane")
    if crane_effect is not None and getattr(crane_effect, "crane", None) is not None:
        from testbed.containers import CONTAINER_TYPES

        spec = next(c for c in assembly.scenario.containers if c.name == crane_effect.config.container)
        crane_painter = CranePainter(meshcat, crane_effect.crane, CONTAINER_TYPES[spec.type].half_size)
        crane_body = int(assembly.bodies[spec.name].index())

    class DiscrepancyOverlay(LeafSystem):
        def __init__(self):
            super().__init__()
            self.set_name("meshcat_overlays")
            self._query = self.DeclareAbstractInputPort("query", AbstractValue.Make(QueryObject()))
            self._results = self.DeclareAbstractInputPort("contact_results", AbstractValue.Make(ContactResults()))
            self._poses = self.DeclareAbstractInputPort("body_poses", plant.get_body_poses_output_port().Allocate())
            self._owner = None
            self.painter = painter
            self.DeclarePeriodicPublishEvent(h, 0.0, self._on_step)

        def _on_step(self, context) -> None:
            k = round(context.get_time() / h)
            if k % frame_steps == 0:  # a frame's state: remember the answers given for it
                for source in sources.values():
                    source.poll()
            if k - lag >= 0 and (k - lag) % frame_steps == 0:
                self._draw(context, (k - lag) * h)

        def _draw(self, context, t_state: float) -> None:
            if self._owner is None:
                from testbed.builder import geometry_body_index

                self._owner = geometry_body_index(assembly, self._query.Eval(context))
            rows = truth_log.at(t_state)
            if rows is None:
                truth = contact_extraction.from_contact_results(self._results.Eval(context), {}, self._owner)
            else:
                truth = {"a": rows["a"], "b": rows["b"], "p_W_cop": rows["p_W"], "n_W": rows["n_W"]}
            predictions = {layer: source.at(t_state) for layer, source in sources.items() if declared[layer] in effects}
            painter.draw(truth, predictions, t_state if recording else None)
            if crane_painter is not None:
                crane_painter.draw(t_state, self._poses.Eval(context)[crane_body], t_state if recording else None)

    system = DiscrepancyOverlay()
    assembly.builder.AddSystem(system)
    assembly.builder.Connect(assembly.scene_graph.get_query_output_port(), system.get_input_port(0))
    assembly.builder.Connect(plant.get_contact_results_output_port(), system.get_input_port(1))
    assembly.builder.Connect(plant.get_body_poses_output_port(), system.get_input_port(2))
    return system


def set_camera_for(meshcat, assembly) -> None:
    """Points the camera at the containers' bounding box from a 3/4 view."""
    from testbed.containers import CONTAINER_TYPES

    p = np.array([c.pose().translation() for c in assembly.scenario.containers])
    r = np.array([np.linalg.norm(CONTAINER_TYPES[c.type].half_size) for c in assembly.scenario.containers])
    lo, hi = (p - r[:, None]).min(axis=0), (p + r[:, None]).max(axis=0)
    crane = assembly.effects.get("crane")
    if crane is not None:  # keep the trolley in view
        hi[2] = max(hi[2], float(crane.config.trolley_height))
    target = 0.5 * (lo + hi)
    radius = 0.5 * float(np.linalg.norm(hi - lo))
    direction = np.array([1.0, -1.4, 0.7])
    meshcat.SetCameraPose(target + 1.6 * radius * direction / np.linalg.norm(direction), target)


# ----------------------------------------------------------------------------- replays


def finish_recording(meshcat) -> str:
    """Stops the recording, sends it to connected browsers (their Animations controls
    replay it) and returns the self-contained replay HTML."""
    meshcat.StopRecording()
    meshcat.PublishRecording()
    return meshcat.StaticHtml()


def write_replay(html: str, path: str | Path) -> Path:
    """Writes the replay HTML to `path` atomically (temporary file + rename)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.partial")
    try:
        tmp.write_text(html, encoding="utf-8")
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return path


def viewer_cost(scene="five_stack", *, duration: float = 2.0, overrides=(), repeats: int = 3) -> dict:
    """Cost of the meshcat effect on one scene's simulation, measured in one process.

    Runs the scene without and with `effects.meshcat` (recording on, free port),
    alternating, `repeats` times each, and keeps the best of each: wall time [s] of
    simulate() and this process's CPU time [s] over it (which includes the Meshcat
    server's threads and is less disturbed by other load on a shared machine).
    Returns both, their ratios (with / without) and the replay size [bytes]."""
    from testbed.builder import build_scene
    from testbed.scenario import load_scenario
    from testbed.simulation import simulate

    wall = {"without": [], "with": []}
    cpu = {"without": [], "with": []}
    replay_bytes = None
    for _ in range(repeats):
        for label in ("without", "with"):
            extra = ["effects.meshcat.port=0", "effects.meshcat.record=true"] if label == "with" else ["effects.meshcat=null"]
            built = build_scene(load_scenario(scene, overrides=list(overrides) + extra))
            c0 = time.process_time()
            result = simulate(built, duration=duration)
            cpu[label].append(time.process_time() - c0)
            wall[label].append(result.summary["wall_time_s"])
            if label == "with":
                replay_bytes = result.summary.get("replay_bytes")
            del built, result
    w = {k: min(v) for k, v in wall.items()}
    c = {k: min(v) for k, v in cpu.items()}
    return {"scene": scene, "duration_s": duration, "repeats": repeats,
            "wall_without_s": w["without"], "wall_with_s": w["with"], "wall_ratio": w["with"] / w["without"],
            "cpu_without_s": c["without"], "cpu_with_s": c["with"], "cpu_ratio": c["with"] / c["without"],
            "replay_bytes": replay_bytes}


# ----------------------------------------------------------------------------- testbed view


def view(scene_path, *, port: int | None = DEFAULT_PORT, host: str = "localhost", rate: float | None = 1.0,
         overrides=(), duration: float | None = None, out=None, serve: bool = True, stream=None):
    """`testbed view`: simulate a scene live in Meshcat, write its replay, keep serving.

    scene_path: scene file or shipped scene name; port: 0/None = a free one; host: the
    interface to listen on ("localhost" by default; others print an authentication
    warning); rate: target real-time rate (1 = real time, 0/None = as fast as possible);
    overrides: --set strings; duration [s]: default the scene's; out: the run directory
    (default reports/runs/<scene>-view-<time>); serve: after the run, keep serving until
    Ctrl-C. Returns (RunResult, replay path). Raises TestbedError on bad input / busy port.
    """
    from testbed.scenario import load_scenario, resolve_scene_path
    from testbed.builder import build_scene
    from testbed.simulation import simulate, write_run

    stream = stream or sys.stdout
    if rate is not None and not (rate >= 0 and math.isfinite(rate)):
        raise TestbedError(f"--rate: expected a non-negative real-time rate, got {rate}")
    if duration is not None and not duration > 0:
        raise TestbedError(f"--duration: expected a positive number of seconds, got {duration}")
    if port is not None and not 0 <= port <= 65535:
        raise TestbedError(f"--port: expected 0 to 65535, got {port}")
    path = resolve_scene_path(scene_path)
    settings = [f"effects.meshcat.host={json.dumps(host)}", f"effects.meshcat.port={port if port else 0}", "effects.meshcat.record=true"]
    scenario = load_scenario(path, overrides=list(overrides) + settings)
    scenario.simulator.target_realtime_rate = float(rate or 0.0)
    warning = exposure_warning(host)
    if warning:
        print(warning, file=stream, flush=True)
    scene = build_scene(scenario, path)
    effect = scene.effects["meshcat"]
    print(f"Meshcat viewer: {effect.meshcat.web_url()}  (open it in a browser; Ctrl-C to stop)", file=stream, flush=True)
    if out is None:
        out = Path("reports") / "runs" / f"{scenario.name}-view-{time.strftime('%Y%m%d-%H%M%S')}"
    result = simulate(scene, duration=duration)
    write_run(result, out)
    replay = Path(out) / REPLAY_NAME
    if not replay.exists():  # write_run may already have written it (Effect.files hook)
        write_replay(effect.replay_html, replay)
    print(f"simulated {result.summary['duration_s']:g} s in {result.summary['wall_time_s']:.1f} s; "
          f"records: {out}\nreplay (opens from disk, no server needed): {replay} "
          f"({replay.stat().st_size / 1e6:.1f} MB); replay it live from the viewer's Animations controls",
          file=stream, flush=True)
    if serve:
        try:
            print(f"serving {effect.meshcat.web_url()} until Ctrl-C", file=stream, flush=True)
            while True:
                time.sleep(0.5)
        except KeyboardInterrupt:
            print("viewer stopped", file=stream, flush=True)
    return result, replay

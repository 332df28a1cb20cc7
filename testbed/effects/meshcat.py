"""`meshcat`: a live Meshcat viewer with discrepancy overlays, and an optional replay.

Starts Drake's Meshcat server when the scene is built (never at import), listening on
`host` (default localhost only: Meshcat has no authentication) and `port` (0 or null:
a free one; a busy port raises MeshcatPortError naming it). Adds three systems:

- `meshcat_visualizer`: the illustration geometry (containers coloured by type, the
  quay, and any other effect's geometry, e.g. a crane), at `container_opacity`;
- `meshcat_contact_forces`: Drake's ContactVisualizer (forces, moments and hydroelastic
  patches) scaled for container loads (`newtons_per_meter`; 2e5 N/m draws 1e4 N as
  5 cm and 1e6 N as 5 m);
- `meshcat_overlays`: ground truth / shadow / learned contact points, normals and
  error segments (testbed/viz/overlays.py describes the paths, testbed/viz/colours.py the colours).

With `record: true` every frame is also recorded; after the run the effect holds the
self-contained replay HTML (`replay_html`) and offers it as the run file replay.html
(`files()`). Do not declare this effect for cases run in parallel worker processes.

    effects:
      meshcat: {port: 7000, record: true, error_threshold: 0.5}
"""


import dataclasses
import math
import multiprocessing
import sys
import typing

from testbed import viz
from testbed.contact import extraction as contact_extraction
from testbed.contact.body_index import geometry_body_index
from testbed.effects import register
from testbed.effects.base import Effect, Role


@dataclasses.dataclass
class MeshcatConfig:
    host: str = "localhost"  # interface to listen on; anything but loopback warns (no authentication)
    port: typing.Optional[int] = 7000  # TCP port; 0 or null = any free port
    frame_rate: float = 30.0  # [Hz] viewer/overlay/recording frames (rounded to whole plant steps)
    record: bool = False  # record the run; the replay goes to replay.html next to the records
    error_threshold: float = 0.5  # [m] contact-point distance drawn fully red
    angle_threshold_deg: float = 15.0  # [deg] normal angle drawn fully red
    newtons_per_meter: float = 2e5  # [N/m] force arrow scale (1e4..1e6 N -> 0.05..5 m)
    newton_meters_per_meter: float = 2e5  # [N m/m] moment arrow scale
    container_opacity: float = 0.45  # [0..1] so the overlays inside a stack stay visible
    contact_forces: bool = True  # add Drake's ContactVisualizer


# The replay's legend (testbed/viz/colours.py, testbed/viz/overlays.py)
CAPTION_LEGEND = (
    "boxes: the containers (translucent, so the contacts inside a stack show)",
    "spheres: contact points of the driving model (cyan), the shadow model (magenta), the learned predictor (yellow)",
    "segments between them and arrows: green = agreement ... red = the error threshold",
    "orange arrows: point-contact forces; violet: hydroelastic forces, blue: their moments",
)


@register
class MeshcatEffect(Effect):
    name = "meshcat"
    Config = MeshcatConfig
    role = Role.VIEWER
    forkable = False  # its server and recording live in this process
    order = 90  # after every effect whose records it draws

    @classmethod
    def study_config(cls, *, replay: bool = False) -> MeshcatConfig:
        return MeshcatConfig(port=0, record=replay)  # any free port; never a fixed one in a study

    meshcat = None
    replay_html: typing.Optional[str] = None
    _caption_title = ""  # the replay caption's title, set when the scene is built

    def check(self, effects) -> None:
        super().check(effects)
        c = self.config
        if not isinstance(c.host, str) or not c.host.strip():
            raise self.fail("host", f"expected a host name or address, e.g. localhost, got {c.host!r}")
        if c.port is not None and not 0 <= c.port <= 65535:
            raise self.fail("port", f"expected a TCP port 1..65535, or 0/null for any free port, got {c.port}")
        for field in ("frame_rate", "error_threshold", "angle_threshold_deg", "newtons_per_meter", "newton_meters_per_meter"):
            value = getattr(c, field)
            if not (math.isfinite(value) and value > 0):
                raise self.fail(field, f"expected a positive number, got {value}")
        if not 0 <= c.container_opacity <= 1:
            raise self.fail("container_opacity", f"expected a number in [0, 1], got {c.container_opacity}")

    def add_systems(self, assembly) -> list:
        from pydrake.geometry import MeshcatVisualizer, MeshcatVisualizerParams, Rgba, Role
        from pydrake.multibody.meshcat import ContactVisualizer, ContactVisualizerParams

        if multiprocessing.parent_process() is not None:
            raise self.fail("", "Meshcat must not be started inside a parallel worker process; "
                                "run this case in the main process or remove effects.meshcat")
        c = self.config
        warning = viz.exposure_warning(c.host)
        if warning:
            print(f"testbed: {warning}", file=sys.stderr)
        self.meshcat = meshcat = viz.start_meshcat(c.host, c.port)
        period = viz.frame_period(c.frame_rate, assembly.plant.time_step())
        systems = []
        vis = MeshcatVisualizer.AddToBuilder(assembly.builder, assembly.scene_graph, meshcat, MeshcatVisualizerParams(
            publish_period=period, role=Role.kIllustration, prefix="visualizer",
            enable_alpha_slider=True, initial_alpha_slider_value=c.container_opacity,
        ))
        vis.set_name("meshcat_visualizer")
        systems.append(vis)
        if assembly.plan.collision:
            if c.contact_forces:
                contact = ContactVisualizer.AddToBuilder(assembly.builder, assembly.plant, meshcat, ContactVisualizerParams(
                    publish_period=period, prefix="contact_forces",
                    color=Rgba(*viz.POINT_FORCE_RGB, 1.0), hydro_force_color=Rgba(*viz.HYDRO_FORCE_RGB, 1.0),
                    hydro_moment_color=Rgba(*viz.HYDRO_MOMENT_RGB, 1.0),
                    newtons_per_meter=c.newtons_per_meter, newton_meters_per_meter=c.newton_meters_per_meter,
                    radius=0.06, force_threshold=1.0, moment_threshold=1.0,
                ))
                contact.set_name("meshcat_contact_forces")
                systems.append(contact)
            self.painter = viz.OverlayPainter(
                meshcat, assembly.body_names, error_threshold=c.error_threshold, angle_threshold_deg=c.angle_threshold_deg,
            )
            systems.append(make_overlay_system(assembly, meshcat, self.painter, period, recording=c.record))
        viz.set_camera_for(meshcat, assembly)
        self._caption_title = (f"{assembly.scenario.name}: {assembly.plan.contact_model} contact"
                               if assembly.plan.collision else assembly.scenario.name)
        if c.record:
            meshcat.StartRecording(frames_per_second=1.0 / period, set_visualizations_while_recording=True)
        return systems

    def collect(self, tables) -> None:
        if self.config.record and self.meshcat is not None:
            self.replay_html = viz.with_caption(viz.finish_recording(self.meshcat), self._caption_title, CAPTION_LEGEND)

    def summarize(self, tables) -> dict:
        out = {"meshcat_url": self.meshcat.web_url() if self.meshcat is not None else None}
        if self.replay_html is not None:
            out["replay_bytes"] = len(self.replay_html.encode())
        return out

    def files(self) -> dict[str, str]:
        """Run files this effect produced: {'replay.html': html} after a recorded run."""
        return {viz.REPLAY_NAME: self.replay_html} if self.replay_html is not None else {}


def make_overlay_system(assembly, meshcat, painter, period: float, recording: bool):
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

    truth_log = viz.TableSource(logger_table, "p_W_cop_static", "n_W", tol)
    sources = {"shadow": viz.TableSource(shadow_table, "p_W_cop_static", "n_W", tol), "learned": viz.learned_source(effects, tol)}
    declared = {"shadow": "shadow_contact", "learned": viz.LEARNED_EFFECT}
    crane_painter, crane_body = None, None
    crane_effect = effects.get("crane")
    if crane_effect is not None and getattr(crane_effect, "crane", None) is not None:
        spec = next(c for c in assembly.scenario.containers if c.name == crane_effect.config.container)
        crane_painter = viz.CranePainter(meshcat, crane_effect.crane, spec.container_type().half_size)
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

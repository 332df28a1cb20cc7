"""Meshcat viewing: server, colours, overlays, replays (no command, no scene building).

Sits below the effects: the `meshcat` effect (testbed/effects/meshcat.py) owns the
systems that draw with these parts, and `testbed view` (testbed/commands/view.py)
runs a scene with that effect. Importing this package starts nothing.
"""

from testbed.viz.camera import frame_period, set_camera_for, set_camera_on
from testbed.viz.colours import HYDRO_FORCE_RGB, HYDRO_MOMENT_RGB, MARKER_RGB, N_BINS, NEUTRAL_RGB, POINT_FORCE_RGB, bin_of, bin_rgb, error_fraction
from testbed.viz.overlays import LAYERS, OVERLAY_ROOT, CranePainter, GlyphSizes, OverlayPainter, frame_along
from testbed.viz.replay import CAPTION_ID, REPLAY_NAME, TIME_ID, finish_recording, with_caption, write_replay
from testbed.viz.server import DEFAULT_PORT, MeshcatPortError, exposure_warning, is_loopback_host, listening_addresses, start_meshcat
from testbed.viz.sources import LEARNED_EFFECT, TableSource, learned_source

__all__ = ["CAPTION_ID", "CranePainter", "DEFAULT_PORT", "GlyphSizes", "HYDRO_FORCE_RGB", "HYDRO_MOMENT_RGB", "LAYERS",
           "LEARNED_EFFECT", "MARKER_RGB", "MeshcatPortError", "N_BINS", "NEUTRAL_RGB", "OVERLAY_ROOT",
           "OverlayPainter", "POINT_FORCE_RGB", "REPLAY_NAME", "TIME_ID", "TableSource", "bin_of", "bin_rgb",
           "error_fraction", "exposure_warning", "finish_recording", "frame_along", "frame_period",
           "is_loopback_host", "learned_source", "listening_addresses", "set_camera_for", "set_camera_on", "start_meshcat",
           "with_caption", "write_replay"]

"""Meshcat replays: a recording turned into one self-contained HTML file, with a caption
(title, legend, the replay's simulated time) laid over the viewer."""

from __future__ import annotations

import html as html_lib
from pathlib import Path

from testbed.records import write_atomic

REPLAY_NAME = "replay.html"  # the replay's file name in a run directory
CAPTION_ID = "testbed-caption"  # the caption's element id (tests find it by this)
TIME_ID = "testbed-time"  # the time readout's element id

# Reads the animation's clock (Meshcat's Animator: its first action's local time [s], which a
# recording made at the plant's time keeps in simulated seconds) ten times a second.
_TIME_SCRIPT = """<script>
setInterval(function () {
  var out = document.getElementById("%(id)s"), a = window.viewer && window.viewer.animator;
  if (!out || !a || !a.actions || !a.actions.length) return;
  var t = a.actions[0].time, d = a.duration || 0;
  out.textContent = "t = " + t.toFixed(2) + " s of " + d.toFixed(2) + " s simulated" + (a.playing ? "" : " (paused)");
}, 100);
</script>"""


def finish_recording(meshcat) -> str:
    """Stops the recording, sends it to connected browsers (their Animations controls
    replay it) and returns the self-contained replay HTML."""
    meshcat.StopRecording()
    meshcat.PublishRecording()
    return meshcat.StaticHtml()


def with_caption(page: str, title: str, legend) -> str:
    """The replay page with a caption in its top-left corner: the title, one line per
    legend entry, and the replay's simulated time (updated while it plays; the Animations
    folder of Meshcat's controls plays, pauses and scrubs it). Text is escaped."""
    lines = "".join(f"<div>{html_lib.escape(line)}</div>" for line in legend)
    caption = (f"<div id='{CAPTION_ID}' style='position:fixed;left:8px;top:8px;z-index:10;max-width:48vw;"
               "background:rgba(255,255,255,0.88);color:#222;font:13px/1.35 sans-serif;padding:6px 10px;"
               f"border-radius:4px'><div style='font-weight:bold;font-size:15px'>{html_lib.escape(title)}</div>"
               f"{lines}<div id='{TIME_ID}'>t = 0.00 s simulated</div>"
               "<div style='color:#666'>Open Controls &gt; Animations: play, pause, scrub</div></div>")
    insert = caption + _TIME_SCRIPT % {"id": TIME_ID}
    at = page.rfind("</body>")
    return page[:at] + insert + page[at:] if at >= 0 else page + insert


def write_replay(html: str, path: str | Path) -> Path:
    """Writes the replay HTML to `path` atomically (temporary file + rename)."""
    return write_atomic(path, html)

"""Meshcat replays: a recording turned into one self-contained HTML file."""

from __future__ import annotations

from pathlib import Path

from testbed.records import write_atomic

REPLAY_NAME = "replay.html"  # the replay's file name in a run directory


def finish_recording(meshcat) -> str:
    """Stops the recording, sends it to connected browsers (their Animations controls
    replay it) and returns the self-contained replay HTML."""
    meshcat.StopRecording()
    meshcat.PublishRecording()
    return meshcat.StaticHtml()

def write_replay(html: str, path: str | Path) -> Path:
    """Writes the replay HTML to `path` atomically (temporary file + rename)."""
    return write_atomic(path, html)

"""Headless Chromium opens (a) a live Meshcat server started here and (b) a written replay
file, checks the overlay objects in the viewer's scene tree, and screenshots them.

Needs Debian's `chromium` (/usr/bin/chromium) and the `playwright` Python package (its
bundled driver only; no browser download). Without a browser the tests are skipped,
unless the CI environment variable is set: then they fail.
Screenshots are kept under the test's temporary directory (pytest --basetemp=DIR keeps them).
"""

import os
import shutil
import struct
import zlib
from pathlib import Path

import numpy as np
import pytest

from testbed import build_scene, load_scenario, simulate, viz as viewer

CHROMIUM_FLAGS = [
    "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
]
# The scene: a container dropped 0.3 m lands at ~0.25 s; overlays appear then.
SCENE = "single_drop"
DURATION = 0.5  # [s]
PAIR = "quay_ground+box"


def _browser_path() -> str | None:
    for candidate in (os.environ.get("TESTBED_CHROMIUM"), "/usr/bin/chromium", shutil.which("chromium"),
                      shutil.which("chromium-browser")):
        if candidate and Path(candidate).exists():
            return candidate
    return None


def _require_browser():
    browser = _browser_path()
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        missing = "the Python package playwright (pip install playwright==1.65.2)"
    else:
        missing = None if browser else "a Chromium browser (apt-get install chromium)"
    if missing:
        if os.environ.get("CI"):
            pytest.fail(f"CI is set but the browser tests cannot run: missing {missing}")
        pytest.skip(f"no headless browser: missing {missing}")
    return browser


@pytest.fixture(scope="module")
def browser_page(tmp_path_factory):
    """A function opening a URL in a fresh headless Chromium profile; yields pages."""
    executable = _require_browser()
    from playwright.sync_api import sync_playwright

    profile = tmp_path_factory.mktemp("chromium-profile")
    with sync_playwright() as p:
        context = p.chromium.launch_persistent_context(
            str(profile), executable_path=executable, headless=True, args=CHROMIUM_FLAGS,
            viewport={"width": 960, "height": 720},
        )
        try:
            yield context
        finally:
            context.close()


@pytest.fixture(scope="module")
def recorded_run():
    """single_drop for 0.5 s with shadow overlays, recorded; errors drawn green (wide thresholds)."""
    scene = build_scene(load_scenario(SCENE, overrides=[
        "effects.meshcat.port=0", "effects.meshcat.record=true",
        "effects.meshcat.error_threshold=100", "effects.meshcat.angle_threshold_deg=180",
    ]))
    simulate(scene, duration=DURATION)
    return scene


# ----------------------------------------------------------------------------- helpers

_HAS_PATH_JS = """(path) => {
    let node = window.viewer && viewer.scene_tree;
    for (const name of path) { if (!node || !node.children) return false; node = node.children[name]; }
    return !!node;
}"""

_WORLD_VISIBLE_JS = """(path) => {
    let node = viewer.scene_tree;
    for (const name of path) node = node.children[name];
    let o = node.object;
    while (o) { if (!o.visible) return false; o = o.parent; }
    return true;
}"""


def _has(page, path: str) -> bool:
    return page.evaluate(_HAS_PATH_JS, [p for p in path.split("/") if p])


def _decode_png(data: bytes) -> np.ndarray:
    """(h, w, 3) uint8 from an 8-bit RGB/RGBA non-interlaced PNG (what Chromium writes)."""
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    pos, idat, width = 8, b"", None
    while pos < len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + length]
        if kind == b"IHDR":
            width, height, depth, color, _, _, interlace = struct.unpack(">IIBBBBB", body)
            assert depth == 8 and color in (2, 6) and interlace == 0
            channels = 3 if color == 2 else 4
        elif kind == b"IDAT":
            idat += body
        pos += 12 + length
    raw = np.frombuffer(zlib.decompress(idat), dtype=np.uint8).reshape(height, 1 + width * channels)
    out = np.zeros((height, width * channels), dtype=np.int32)
    prev = np.zeros(width * channels, dtype=np.int32)
    for y in range(height):
        f, line = raw[y, 0], raw[y, 1:].astype(np.int32)
        if f == 0:
            cur = line
        elif f == 2:
            cur = (line + prev) & 0xFF
        else:  # Sub (1), Average (3), Paeth (4): sequential along the row
            cur = np.zeros_like(line)
            for x in range(len(line)):
                a = cur[x - channels] if x >= channels else 0
                b = prev[x]
                c = prev[x - channels] if x >= channels else 0
                if f == 1:
                    pred = a
                elif f == 3:
                    pred = (a + b) // 2
                else:
                    p = a + b - c
                    pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                    pred = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
                cur[x] = (line[x] + pred) & 0xFF
        out[y] = prev = cur
    return out.reshape(height, width, channels)[:, :, :3].astype(np.uint8)


def _colour_pixels(image: np.ndarray, rgb, tol: float = 0.25) -> int:
    """How many pixels are close in hue to `rgb` (in [0, 1]): the channels that are high
    in rgb are bright and the low ones dark (shading scales the whole colour)."""
    x = image.astype(float) / 255.0
    rgb = np.asarray(rgb)
    high, low = rgb > 0.5, rgb <= 0.5
    peak = x.max(axis=2)
    ok = peak > 0.35
    ok &= np.all(x[:, :, high] > 0.55 * peak[:, :, None], axis=2)
    ok &= np.all(x[:, :, low] < tol * peak[:, :, None] + 0.02, axis=2)
    return int(ok.sum())


def _check_screenshot(page, path: Path) -> None:
    page.wait_for_timeout(300)  # a few animation frames for the renderer
    png = page.screenshot(path=str(path))
    image = _decode_png(png)
    assert image.std() > 10 and len(np.unique(image.reshape(-1, 3), axis=0)) > 200, "blank screenshot"
    counts = {
        "truth marker (cyan)": _colour_pixels(image, viewer.MARKER_RGB["truth"]),
        "shadow marker (magenta)": _colour_pixels(image, viewer.MARKER_RGB["shadow"]),
        "agreement arrows (green)": _colour_pixels(image, viewer.bin_rgb(0)),
    }
    for what, n in counts.items():
        assert n >= 10, f"no {what} pixels in {path} ({counts})"


def _check_overlay_tree(page) -> None:
    for layer in ("truth", "shadow", "shadow_error"):
        assert _has(page, f"/overlays/{layer}/{PAIR}"), layer
    assert _has(page, f"/overlays/truth/{PAIR}/point")
    assert _has(page, f"/overlays/truth/{PAIR}/arrow/c0/head")
    assert _has(page, "/drake/visualizer/box")
    assert _has(page, "/drake/contact_forces")
    assert not _has(page, "/overlays/learned")


# ----------------------------------------------------------------------------- tests


def test_live_server_shows_overlays(browser_page, recorded_run, tmp_path):
    meshcat = recorded_run.effects["meshcat"].meshcat
    page = browser_page.new_page()
    try:
        page.goto(meshcat.web_url())
        page.wait_for_function(_HAS_PATH_JS, arg=["overlays", "truth", PAIR, "point"], timeout=30_000)
        _check_overlay_tree(page)
        assert meshcat.GetNumActiveConnections() >= 1
        # The live scene shows the final state: in contact, so the overlay is visible.
        page.evaluate("() => { if (viewer.animator) viewer.animator.pause(); }")
        assert page.evaluate(_WORLD_VISIBLE_JS, ["overlays", "truth", PAIR])
        _check_screenshot(page, tmp_path / "live.png")
    finally:
        page.close()


def test_replay_file_animates_overlays(browser_page, recorded_run, tmp_path):
    html = recorded_run.effects["meshcat"].replay_html
    replay = viewer.write_replay(html, tmp_path / "replay.html")
    page = browser_page.new_page()
    try:
        page.goto(replay.as_uri())
        page.wait_for_function("() => window.viewer && viewer.animator && viewer.animator.actions.length > 0",
                               timeout=30_000)
        _check_overlay_tree(page)
        duration = page.evaluate("() => viewer.animator.duration")
        assert duration == pytest.approx(DURATION, abs=0.05)
        # The overlays are animated: hidden before the landing, shown after it.
        page.evaluate("() => { viewer.animator.pause(); viewer.animator.seek(0.05); }")
        assert not page.evaluate(_WORLD_VISIBLE_JS, ["overlays", "truth", PAIR])
        page.evaluate(f"() => viewer.animator.seek({DURATION - 0.05})")
        assert page.evaluate(_WORLD_VISIBLE_JS, ["overlays", "truth", PAIR])
        assert page.evaluate(_WORLD_VISIBLE_JS, ["overlays", "truth", PAIR, "arrow", "c0"])
        z_truth = page.evaluate(f"() => viewer.scene_tree.find(['overlays', 'truth', '{PAIR}']).object.position.z")
        assert abs(z_truth) < 0.05  # the contact point lies on the quay (z = 0)
        # the caption names the scene and the colours, and its clock follows the replay (read every 0.1 s)
        caption = page.inner_text(f"#{viewer.CAPTION_ID}")
        assert SCENE in caption and "cyan" in caption and "magenta" in caption
        page.wait_for_function(f"() => document.getElementById('{viewer.TIME_ID}').textContent"
                               f".startsWith('t = {DURATION - 0.05:.2f} s of')", timeout=5_000)
        _check_screenshot(page, tmp_path / "replay.png")
    finally:
        page.close()

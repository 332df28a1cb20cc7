"""The `meshcat` effect and testbed/viewer.py without a browser: systems, overlay paths,
colours, learned-predictor hook, busy port, loopback-only listening, `view`."""

import io
import socket

import numpy as np
import pytest

from testbed import ScenarioError, TestbedError, build_scene, load_scenario, simulate, viz as viewer
from testbed.commands.view import view
from testbed.viz import MeshcatPortError

MESHCAT_SYSTEMS = {"meshcat_visualizer", "meshcat_contact_forces", "meshcat_overlays"}


def _scene(name="two_stack", *overrides):
    return build_scene(load_scenario(name, overrides=["effects.meshcat.port=0", *overrides]))


@pytest.fixture(scope="module")
def two_stack_run():
    scene = _scene("two_stack")
    result = simulate(scene, duration=0.1)
    return scene, result


def test_effect_adds_its_systems(two_stack_run):
    scene, _ = two_stack_run
    assert MESHCAT_SYSTEMS <= set(scene.system_names())
    assert {s.get_name() for s in scene.effects["meshcat"].systems} == MESHCAT_SYSTEMS


def test_overlay_paths_exist(two_stack_run):
    scene, result = two_stack_run
    mc = scene.effects["meshcat"].meshcat
    for path in ("/drake/visualizer", "/drake/contact_forces", "/overlays/truth", "/overlays/shadow", "/overlays/shadow_error"):
        assert mc.HasPath(path), path
    for layer in ("truth", "shadow"):
        for pair in ("quay_ground+bottom", "bottom+top"):
            assert mc.HasPath(f"/overlays/{layer}/{pair}/point")
            assert mc.HasPath(f"/overlays/{layer}/{pair}/arrow/c0/head")
            assert mc.HasPath(f"/overlays/{layer}/{pair}/arrow/c{viewer.N_BINS}/shaft")
    assert mc.HasPath("/overlays/shadow_error/bottom+top/c0")
    assert not mc.HasPath("/overlays/learned")  # no learned_contact effect
    assert result.summary["meshcat_url"].startswith("http://localhost:")
    assert "replay_bytes" not in result.summary  # record defaults to false
    # 0.1 s at one frame per 33 steps of 1 ms
    assert scene.effects["meshcat"].painter.frames == 4  # states 0, 33, 66, 99 ms


def test_no_shadow_layer_without_shadow_effect():
    scene = _scene("single_drop", "effects.shadow_contact=null", "containers[0].X_WC={translation: [0, 0, 1.2955]}")
    simulate(scene, duration=0.05)
    mc = scene.effects["meshcat"].meshcat
    assert mc.HasPath("/overlays/truth/quay_ground+box/point")
    assert not mc.HasPath("/overlays/shadow")
    glyph = scene.effects["meshcat"].painter.glyphs[("truth", (0, 1, 0))]
    assert glyph.bin == viewer.N_BINS  # nothing to compare with: neutral colour


def test_scene_without_contact_has_only_the_visualizer():
    scene = _scene("defaults", "effects.friction=null", "effects.contact=null")
    assert set(scene.system_names()) - {"plant", "scene_graph"} == {"meshcat_visualizer"}


def test_recorded_run_offers_the_replay(tmp_path):
    scene = _scene("single_drop", "effects.meshcat.record=true", "effects.shadow_contact=null", "effects.contact_log=null")
    result = simulate(scene, duration=0.05)
    effect = scene.effects["meshcat"]
    html = effect.files()["replay.html"]
    assert html.startswith("<!DOCTYPE html>") and "meshcat" in html.lower()
    assert f"id='{viewer.CAPTION_ID}'" in html and "single_drop: hydroelastic_with_fallback contact" in html
    assert result.summary["replay_bytes"] == len(html.encode())
    path = viewer.write_replay(html, tmp_path / "run" / "replay.html")
    assert path.read_text() == html
    assert [p.name for p in path.parent.iterdir()] == ["replay.html"]  # no partial file left


# ----------------------------------------------------------------------------- overlays


class _FakeTable:
    def __init__(self, t, columns):
        self.value = (0, t, columns)

    def latest(self):
        return self.value


def _rows(points, normals, pairs=((0, 1),)):
    a, b = np.array(pairs).T
    return {"a": a, "b": b, "p_W_cop": np.array(points, float), "n_W": np.array(normals, float)}


def test_colour_scale_ends_and_bins():
    assert viewer.bin_rgb(0)[1] > 0.8 and viewer.bin_rgb(0)[0] < 0.2  # green
    red = viewer.bin_rgb(viewer.N_BINS - 1)
    assert red[0] > 0.9 and red[1] < 0.2
    assert viewer.bin_of(None) == viewer.N_BINS
    assert viewer.bin_of(0.0) == 0 and viewer.bin_of(1.0) == viewer.N_BINS - 1
    f = viewer.error_fraction([0.0, 0.25, 2.0], [0.0, 0.0, 0.0], 0.5, 10.0)
    np.testing.assert_allclose(f, [0.0, 0.5, 1.0])
    assert viewer.error_fraction(0.0, 5.0, 0.5, 10.0) == pytest.approx(0.5)


def test_painter_colours_hides_and_compares_learned():
    meshcat = viewer.start_meshcat("localhost", 0)
    painter = viewer.OverlayPainter(meshcat, ["quay_ground", "box"], error_threshold=1.0, angle_threshold_deg=90.0)
    truth = _rows([[0, 0, 0]], [[0, 0, 1]])
    shadow = {"a": np.array([0]), "b": np.array([1]), "p_W": np.array([[0.5, 0, 0]]), "n_W": np.array([[0, 0, 1.0]])}
    painter.draw(truth, {"shadow": shadow}, None)
    key = (0, 1, 0)
    assert painter.glyphs[("shadow", key)].bin == 2  # 0.5 m of 1.0 m: the middle of 5 bins
    assert painter.glyphs[("shadow_error", key)].bin == 2
    assert painter.glyphs[("truth", key)].bin == 2  # truth takes the shadow comparison's colour
    assert meshcat.HasPath("/overlays/shadow_error/quay_ground+box/c2")

    # learned_contact hook: effects['learned_contact'].predictions.latest() with p_W_pred / n_W_pred
    class Learned:
        predictions = _FakeTable(0.2, {"a": np.array([0]), "b": np.array([1]),
                                       "p_W_pred": np.array([[0.0, 0.05, 0.0]]), "n_W_pred": np.array([[0.0, 0.0, 1.0]])})

    source = viewer.learned_source({"learned_contact": Learned()}, tol=1e-4)
    assert source.at(0.1) is None  # rows of another state are not used
    learned = source.at(0.2)
    np.testing.assert_allclose(learned["p_W"], [[0.0, 0.05, 0.0]])
    painter.draw(truth, {"shadow": shadow, "learned": learned}, None)
    assert painter.glyphs[("learned", key)].bin == 0
    assert painter.glyphs[("truth", key)].bin == 0  # learned comparison wins when present
    assert meshcat.HasPath("/overlays/learned/quay_ground+box/point")
    assert meshcat.HasPath("/overlays/learned_error/quay_ground+box/c0")
    assert viewer.learned_source({}, 1e-4).at(0.2) is None  # no learned effect: nothing

    painter.draw(None, {"shadow": None}, None)  # contact lost: everything hidden
    assert not any(g.shown for g in painter.glyphs.values())


def test_frame_along_points_z_at_the_direction():
    X = viewer.frame_along([1, 2, 3], [0, 3.0, 0])
    np.testing.assert_allclose(X.rotation().matrix()[:, 2], [0, 1, 0], atol=1e-12)
    np.testing.assert_allclose(X.translation(), [1, 2, 3])


# ----------------------------------------------------------------------------- server


def test_busy_port_gives_a_clear_error():
    first = viewer.start_meshcat("localhost", 0)
    with pytest.raises(MeshcatPortError) as info:
        viewer.start_meshcat("localhost", first.port())
    message = str(info.value)
    assert str(first.port()) in message and "--port" in message
    assert isinstance(info.value, TestbedError)
    # through a scene: the builder raises the same error
    with pytest.raises(MeshcatPortError):
        build_scene(load_scenario("defaults", overrides=[f"effects.meshcat.port={first.port()}"]))


def test_busy_port_taken_by_another_program():
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        s.listen(1)
        port = s.getsockname()[1]
        with pytest.raises(MeshcatPortError, match=str(port)):
            viewer.start_meshcat("localhost", port)


def test_default_server_listens_on_loopback_only():
    effect_config = load_scenario("defaults", overrides=["effects.meshcat={}"]).effects.meshcat
    assert effect_config.host == "localhost"
    meshcat = viewer.start_meshcat(effect_config.host, 0)
    addresses = viewer.listening_addresses(meshcat.port())
    assert addresses, "no listening socket found in /proc/net/tcp*"
    for address in addresses:
        assert viewer.is_loopback_host(address), f"Meshcat listens on {address}, not loopback only"
    assert meshcat.web_url().startswith("http://localhost:")


def test_listening_addresses_reads_proc_net():
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        s.listen(1)
        assert viewer.listening_addresses(s.getsockname()[1]) == ["127.0.0.1"]


@pytest.mark.parametrize("host, loopback", [("localhost", True), ("127.0.0.1", True), ("::1", True),
                                            ("*", False), ("0.0.0.0", False), ("192.168.1.5", False)])
def test_non_loopback_hosts_get_a_warning(host, loopback):
    assert viewer.is_loopback_host(host) == loopback
    warning = viewer.exposure_warning(host)
    assert (warning is None) == loopback
    if warning:
        assert "no authentication" in warning


@pytest.mark.parametrize("override, field", [
    ("effects.meshcat.port=70000", "effects.meshcat.port"),
    ("effects.meshcat.error_threshold=0", "effects.meshcat.error_threshold"),
    ("effects.meshcat.container_opacity=2", "effects.meshcat.container_opacity"),
    ("effects.meshcat.host=''", "effects.meshcat.host"),
])
def test_bad_config_names_the_field(override, field):
    with pytest.raises(ScenarioError) as info:
        load_scenario("defaults", overrides=[override])
    assert info.value.field == field


def test_view_writes_records_and_replay(tmp_path):
    out = io.StringIO()
    result, replay = view("single_drop", port=0, rate=0, duration=0.05, out=tmp_path / "run",
                          overrides=["effects.shadow_contact=null"], serve=False, stream=out)
    text = out.getvalue()
    assert "http://localhost:" in text and "WARNING" not in text
    assert replay == tmp_path / "run" / "replay.html" and replay.stat().st_size > 100_000
    assert (tmp_path / "run" / "summary.json").exists() and (tmp_path / "run" / "contacts.npz").exists()
    assert result.summary["replay_bytes"] == replay.stat().st_size


def test_view_rejects_bad_options():
    with pytest.raises(TestbedError, match="--rate"):
        view("defaults", port=0, rate=-1, serve=False)
    with pytest.raises(TestbedError, match="--port"):
        view("defaults", port=70000, serve=False)


def test_view_serves_until_ctrl_c(tmp_path):
    import signal
    import subprocess
    import sys
    import time

    code = (
        "import signal; signal.signal(signal.SIGINT, signal.default_int_handler)\n"
        "from testbed.commands.view import view\n"
        f"view('single_drop', port=0, rate=0, duration=0.02, out={str(tmp_path / 'run')!r},"
        " overrides=['effects.shadow_contact=null', 'effects.contact_log=null'])\n"
    )
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        lines = []
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline:
            line = proc.stdout.readline()
            lines.append(line)
            if "until Ctrl-C" in line or not line:
                break
        assert any("until Ctrl-C" in line for line in lines), "".join(lines)
        assert proc.poll() is None, "view() should keep serving after the run"
        proc.send_signal(signal.SIGINT)
        rest, _ = proc.communicate(timeout=30)
        assert proc.returncode == 0, "".join(lines) + rest
        assert "viewer stopped" in rest
        assert (tmp_path / "run" / "replay.html").exists()
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def test_learned_overlay_from_the_learned_contact_effect():
    from testbed.effects import registry

    if "learned_contact" not in registry():
        pytest.skip("no learned_contact effect in this tree")
    scene = _scene("two_stack", "effects.learned_contact={}")
    simulate(scene, duration=0.04)
    mc = scene.effects["meshcat"].meshcat
    assert mc.HasPath("/overlays/learned/bottom+top/point")
    assert mc.HasPath("/overlays/learned_error/bottom+top")
    assert not mc.HasPath("/overlays/learned/quay_ground+bottom")  # the predictor skips the ground
    painter = scene.effects["meshcat"].painter
    # the truth arrow of a container pair takes the learned comparison's colour
    assert painter.glyphs[("truth", (1, 2, 0))].bin == painter.glyphs[("learned", (1, 2, 0))].bin


def test_crane_trolley_and_ropes_are_drawn():
    from testbed.effects import registry

    if "crane" not in registry():
        pytest.skip("no crane effect in this tree")
    scene = _scene("crane_landing_sway", "effects.meshcat.record=true")
    simulate(scene, duration=0.04)
    mc = scene.effects["meshcat"].meshcat
    assert mc.HasPath("/crane/trolley")
    for i in range(4):
        assert mc.HasPath(f"/crane/ropes/{i}/line")

"""`testbed validate --executor ray --address ...` against a real Ray cluster started as a
separate process (`ray start --head`), the way a user with a cluster runs it.

Ray never advertises a loopback node address while the machine has another interface, so
the cluster and its clients run in a network namespace of their own that holds only the
loopback interface: every connection stays on 127.0.0.1 (needs root and iproute2; skipped
otherwise). The head is started with token authentication (RAY_AUTH_MODE=token, Ray 2.60's
recommended mode) and its own HOME, where it writes its token.
"""

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("ray", reason="Ray is in the test extra: pip install -e '.[test]'")

BIN = Path(sys.executable).parent
PORT = 6390 + os.getpid() % 50


def _can_make_namespaces() -> bool:
    return hasattr(os, "geteuid") and os.geteuid() == 0 and shutil.which("ip") is not None


# once: the executor plumbing over the same cases (the cases' physics runs in both suites elsewhere)
pytestmark = [pytest.mark.skipif(not _can_make_namespaces(), reason="needs root and iproute2 (ip netns)"), pytest.mark.once]


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    """(namespace, head HOME) of a token-authenticated Ray head on 127.0.0.1:PORT."""
    ns = f"testbed-ray-{os.getpid()}"
    home = tmp_path_factory.mktemp("head_home")
    subprocess.run(["ip", "netns", "add", ns], check=True)
    try:
        subprocess.run(["ip", "netns", "exec", ns, "ip", "link", "set", "lo", "up"], check=True)
        env = {**_base_env(home), "RAY_AUTH_MODE": "token"}
        subprocess.run([str(BIN / "ray"), "get-auth-token", "--generate"], env=env, check=True,
                       capture_output=True, timeout=120)  # writes HOME/.ray/auth_token
        start = subprocess.run(
            ["ip", "netns", "exec", ns, str(BIN / "ray"), "start", "--head", f"--port={PORT}", "--num-cpus=2",
             "--include-dashboard=false", "--disable-usage-stats"],
            env=env, capture_output=True, text=True, timeout=180)
        assert start.returncode == 0, start.stderr[-2000:]
        assert "127.0.0.1" in start.stdout + start.stderr  # the node address is loopback
        yield ns, home
    finally:
        subprocess.run(["ip", "netns", "exec", ns, str(BIN / "ray"), "stop", "--force"],
                       env=_base_env(home), capture_output=True, timeout=120)
        subprocess.run(["ip", "netns", "delete", ns], capture_output=True)


def _base_env(home) -> dict:
    env = {k: v for k, v in os.environ.items() if not k.startswith("RAY_")}
    env["HOME"] = str(home)
    return env


def _validate(ns, env, out):
    return subprocess.run(
        ["ip", "netns", "exec", ns, sys.executable, "-m", "testbed.cli", "validate", "--suite", "smoke",
         "--executor", "ray", "--address", f"127.0.0.1:{PORT}", "--quiet", "--out", str(out)],
        env=env, capture_output=True, text=True, timeout=900)


def test_missing_token_gives_one_clear_line_and_exit_2(cluster, tmp_path):
    ns, _ = cluster
    client_home = tmp_path / "client_home"  # no token here, RAY_AUTH_MODE unset
    client_home.mkdir()
    out = _validate(ns, _base_env(client_home), tmp_path / "reports")
    assert out.returncode == 2, out.stderr[-2000:]
    lines = [ln for ln in out.stderr.splitlines() if ln.startswith("testbed: error:")]
    assert len(lines) == 1, out.stderr[-2000:]
    assert f"127.0.0.1:{PORT}" in lines[0] and "RAY_AUTH_MODE=token" in lines[0]
    assert "Traceback" not in out.stderr
    # nothing written: the run directory made before connecting is removed again
    assert not (tmp_path / "reports").exists() or not list((tmp_path / "reports").iterdir())


def test_with_the_token_the_suite_runs_on_the_cluster(cluster, tmp_path):
    ns, home = cluster
    out = _validate(ns, {**_base_env(home), "RAY_AUTH_MODE": "token"}, tmp_path / "reports")
    assert out.returncode == 0, (out.stdout[-2000:], out.stderr[-2000:])
    (metrics_path,) = (tmp_path / "reports").glob("*/metrics.json")
    metrics = json.loads(metrics_path.read_text())
    assert metrics["passed"] is True
    assert all(c["status"] == "ok" for c in metrics["cases"].values())

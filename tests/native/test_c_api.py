"""The C API's conventions that simulators' integrators expect: an export macro with hidden visibility, a run-time version and
ABI check, and defaults functions, on the library `make -C native` builds.

- The shared library exports exactly the functions the two headers declare CC_API, all named cc_*:
  none of the core's internal cci_ / ccs_ / ccz_ functions (31 of them were exported before).
- cc_version() / cc_abi_version() are the header's CC_VERSION / CC_ABI_VERSION, CC_VERSION is the
  package's version, and CC_CHECK_VERSION() refuses a library whose ABI differs from the program's.
- cc_step_default_params / cc_step_default_sleep are the testbed's own defaults (LearnedDynamicsConfig,
  SleepingConfig, the candidate margin and the fitted stiffness), so a C simulator gets the judged law.
"""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest

import testbed
from testbed.effects.learned_dynamics.effect import LearnedDynamicsConfig
from testbed.effects.learned_dynamics.force_law import FITTED_KAPPA
from testbed.effects.learned_dynamics.step import NEAR, SleepingConfig

REPO = Path(__file__).resolve().parents[2]
NATIVE = REPO / "native"
PROBE = Path(__file__).resolve().parent / "api_probe.c"
CC = next((c for c in ("cc", "gcc", "clang") if shutil.which(c)), None)
pytestmark = pytest.mark.skipif(CC is None or shutil.which("make") is None or shutil.which("nm") is None,
                                reason="needs a C compiler, make and nm (CI has gcc, make and binutils)")


def _run(args, **kw):
    return subprocess.run([str(a) for a in args], capture_output=True, text=True, timeout=600, **kw)


@pytest.fixture(scope="module")
def build(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("capi")
    done = _run(["make", "-C", NATIVE, f"BUILD={out}", f"CC={CC}", "lib", "shared", "-j2"])
    assert done.returncode == 0, done.stdout + done.stderr
    return out


def _declared() -> set[str]:
    """The CC_API functions of the two public headers."""
    text = "".join((NATIVE / "include" / h).read_text() for h in ("container_contact.h", "container_contact_step.h"))
    return set(re.findall(r"(?m)^CC_API [^(;]*?\b(cc_[a-z0-9_]+)\(", text))


def test_the_library_exports_the_api_and_nothing_else(build):
    listed = _run(["nm", "-D", "--defined-only", build / "libcontainer_contact.so"])
    assert listed.returncode == 0, listed.stderr
    exported = {line.split()[-1] for line in listed.stdout.splitlines() if line.split()[1:2] == ["T"]}
    declared = _declared()
    assert len(declared) >= 30 and "cc_step_default_params" in declared and "cc_version" in declared
    assert exported == declared, (sorted(exported - declared), sorted(declared - exported))


def _probe(build, tmp_path, *flags) -> tuple[int, dict]:
    exe = tmp_path / "probe"
    built = _run([CC, "-std=c11", "-Wall", "-Wextra", "-Werror", *flags, f"-I{NATIVE / 'include'}", PROBE,
                  build / "libcontainer_contact.a", "-lm", "-o", exe])
    assert built.returncode == 0, built.stderr
    ran = _run([exe])
    return ran.returncode, {k: float(v) for k, v in (line.split() for line in ran.stdout.splitlines())}


def test_versions_and_the_check(build, tmp_path):
    rc, got = _probe(build, tmp_path)
    assert rc == 0 and got["check"] == 1
    assert got["status_names"] == 1  # cc_status_name spells every enumerator as the header does
    assert got["version_library"] == got["version_header"] and got["abi_library"] == got["abi_header"]
    major, minor, patch = (int(x) for x in testbed.__version__.split(".")[:3])
    assert got["version_header"] == major * 10000 + minor * 100 + patch  # the C library is the package's
    rc, got = _probe(build, tmp_path, "-DPROBE_OTHER_ABI")
    assert rc == 3 and got["check"] == 0 and got["abi_header"] == 9999 != got["abi_library"]


def test_the_defaults_are_the_testbeds(build, tmp_path):
    _, got = _probe(build, tmp_path)
    c, s = LearnedDynamicsConfig(), SleepingConfig()
    want = {"margin": NEAR, "h": 0.001, "dissipation": c.dissipation, "mu": 0.4, "stick_hw": c.stick_hw,
            "stick_zeta": c.stick_damping, "slip": c.slip_speed, "stiction": c.stiction,
            "torsional": int(c.torsional_friction), "grid": c.grid, "sweeps": c.normal_sweeps, "n_types": 1,
            "kappa": FITTED_KAPPA[frozenset(("1CC", "1AA"))], "sleep_enabled": int(s.enabled), "v_sleep": s.v_sleep,
            "w_sleep": s.w_sleep, "t_sleep": s.t_sleep, "eps_p": s.eps_p, "eps_R": s.eps_R,
            "pair_reuse": int(s.pair_reuse)}
    assert got.keys() >= want.keys()
    assert {k: got[k] for k in want} == pytest.approx(want, rel=1e-15, abs=0)
    # one kappa for every pair of full-height boxes: the default's (half heights have their own)
    assert len({v for k, v in FITTED_KAPPA.items() if not any(t.endswith("X") for t in k)}) == 1


def test_the_python_binding_checks_the_abi():
    """The extension carries its header's and its core's ABI (cc_abi_version()); the binding refuses one
    built from other sources (a stale build) instead of calling into it, and says what to run."""
    import types

    from learned_contact import _native
    from learned_contact.compiled.kernels import ABI_VERSION, stale

    assert _native.ABI_VERSION == _native.LIBRARY_ABI_VERSION == ABI_VERSION
    assert stale(_native) is None and stale(None) is None
    old = types.SimpleNamespace(ABI_VERSION=2)  # built before the library's ABI was exposed
    assert f"ABI 2, this code needs {ABI_VERSION}" in stale(old) and "pip install -e ." in stale(old)
    assert stale(types.SimpleNamespace(ABI_VERSION=3, LIBRARY_ABI_VERSION=2)) is not None

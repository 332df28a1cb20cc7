"""The judged model in simulators beyond C and C++ on Linux: the Windows DLL that MinGW-w64
builds (`make -C native dll`), its export table and its answers run under Wine, and the C# binding
(native/examples/csharp: P/Invoke with Cdecl, UTF-8 paths, opaque model handles, mirrored step structs,
Unity's frame conversion) compiled with Mono's mcs and run with mono against the Linux library.

Measured 2026-12-07 (MinGW-w64 gcc 12, Wine 8.0, Mono 6.8): the DLL exports the CC_API functions (33)
alone; its answers on three poses (cc_predict and cc_static_contact) are bit for bit the Linux
library's; the C# program's predictions equal the Python predictor's to the last bit, its landing rests
at 3e-14 m/s carrying the weight to 1e-13, and the Unity conversion matches S R S to 0 (det 1 to 2e-15).
CI installs the tools (.ci/run: gcc-mingw-w64-x86-64, wine64, mono-mcs, mono-runtime); each test
skips, naming what is missing, where they are not.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from learned_contact import load_predictor
from learned_contact.compiled.kernels import ABI_VERSION
from testbed.effects.learned_dynamics.step import SleepingConfig
from testbed.geometry.rotations import rotation_from_rpy

REPO = Path(__file__).resolve().parents[2]
NATIVE = REPO / "native"
PROBE = Path(__file__).resolve().parent / "api_probe.c"
CSHARP = NATIVE / "examples" / "csharp"
WEIGHTS = REPO / "learned_contact" / "shipped" / "weights.npz"
MINGW = shutil.which("x86_64-w64-mingw32-gcc")
OBJDUMP = shutil.which("x86_64-w64-mingw32-objdump")
WINE = shutil.which("wine") or shutil.which("wine64")
MCS, MONO = shutil.which("mcs"), shutil.which("mono")
CC = next((c for c in ("cc", "gcc") if shutil.which(c)), None)
pytestmark = pytest.mark.once  # no Drake in it: suite 2 leaves it to suite 1
POSES = [([0.01, 0.0, 2.589], (0, 0, 0)), ([0.3, -0.1, 2.588], (0.004, -0.002, 0.03)), ([1.2, 0.4, 2.585], (0.02, 0.03, 0.6))]
SIZE = np.array([6.058, 2.438, 2.591])


def _run(args, **kw):
    return subprocess.run([str(a) for a in args], capture_output=True, text=True, timeout=600, **kw)


def _declared() -> set[str]:
    text = "".join((NATIVE / "include" / h).read_text() for h in ("container_contact.h", "container_contact_step.h"))
    return set(re.findall(r"(?m)^CC_API [^(;]*?\b(cc_[a-z0-9_]+)\(", text))


def _lines(text: str) -> dict[str, list[str]]:
    return {parts[0]: parts[1:] for parts in (line.split() for line in text.splitlines()) if parts}


@pytest.fixture(scope="module")
def dll(tmp_path_factory) -> Path:
    if MINGW is None or shutil.which("make") is None:
        pytest.skip("needs MinGW-w64 gcc (Debian gcc-mingw-w64-x86-64) and make")
    out = tmp_path_factory.mktemp("win")
    done = _run(["make", "-C", NATIVE, "dll", f"BUILD={out}", f"CC={MINGW}", "-j2"])
    assert done.returncode == 0, done.stdout + done.stderr
    assert (out / "container_contact.dll").is_file() and (out / "libcontainer_contact.dll.a").is_file()
    return out


def test_the_windows_dll_exports_the_api_and_nothing_else(dll):
    if OBJDUMP is None:
        pytest.skip("needs x86_64-w64-mingw32-objdump (Debian binutils-mingw-w64-x86-64)")
    table = _run([OBJDUMP, "-p", dll / "container_contact.dll"]).stdout
    names = set(re.findall(r"^\s*\[\s*\d+\] (\w+)$", table.split("[Ordinal/Name Pointer] Table")[1], re.M))
    assert names == _declared(), (sorted(names - _declared()), sorted(_declared() - names))


def _linux_probe(tmp_path) -> str:
    if CC is None or shutil.which("make") is None:
        pytest.skip("needs a C compiler and make")
    build = tmp_path / "linux"
    assert _run(["make", "-C", NATIVE, f"BUILD={build}", f"CC={CC}", "lib", "-j2"]).returncode == 0
    exe = tmp_path / "probe"
    built = _run([CC, "-std=c11", f"-I{NATIVE / 'include'}", PROBE, build / "libcontainer_contact.a", "-lm", "-o", exe])
    assert built.returncode == 0, built.stderr
    ran = _run([exe, WEIGHTS])
    assert ran.returncode == 0, ran.stderr
    return ran.stdout


def test_the_windows_dll_answers_as_the_linux_library(dll, tmp_path):
    if WINE is None:
        pytest.skip("needs Wine (Debian wine64) to run the DLL")
    exe = dll / "probe.exe"
    built = _run([MINGW, "-std=c11", "-Wall", "-Wextra", "-Werror", f"-I{NATIVE / 'include'}", PROBE, "-o", exe, f"-L{dll}",
                  "-lcontainer_contact.dll"])
    assert built.returncode == 0, built.stderr
    shutil.copy(WEIGHTS, dll / "weights.npz")  # a relative path: no drive-letter mapping to depend on
    env = {**os.environ, "WINEDEBUG": "-all", "WINEPREFIX": str(tmp_path / "wineprefix")}
    ran = _run([WINE, exe, "weights.npz"], cwd=dll, env=env)
    assert ran.returncode == 0, ran.stdout + ran.stderr
    windows, linux = _lines(ran.stdout), _lines(_linux_probe(tmp_path))
    assert windows["check"] == ["1"] and windows["abi_library"] == linux["abi_header"]
    for key in [f"{kind}{i}" for kind in ("predict", "static") for i in range(3)]:
        got, want = np.array(windows[key], dtype=float), np.array(linux[key], dtype=float)
        assert np.allclose(got, want, rtol=1e-12, atol=1e-12 * np.abs(want).max()), (key, got, want)


@pytest.fixture(scope="module")
def csharp(tmp_path_factory) -> dict[str, list[str]]:
    if MCS is None or MONO is None:
        pytest.skip("needs Mono's compiler and runtime (Debian mono-mcs, mono-runtime)")
    if CC is None or shutil.which("make") is None:
        pytest.skip("needs a C compiler and make for the library")
    work = tmp_path_factory.mktemp("csharp")
    done = _run(["make", "-C", NATIVE, f"BUILD={work}", f"CC={CC}", "shared", "-j2"])
    assert done.returncode == 0, done.stdout + done.stderr
    exe = work / "crane_pair_cs.exe"
    built = _run([MCS, "-warnaserror+", f"-out:{exe}", CSHARP / "ContainerContact.cs", CSHARP / "CranePair.cs"])
    assert built.returncode == 0, built.stdout + built.stderr
    ran = _run([MONO, exe, WEIGHTS], env={**os.environ, "LD_LIBRARY_PATH": str(work)})
    assert ran.returncode == 0, ran.stdout + ran.stderr
    return _lines(ran.stdout)


def test_csharp_checks_the_version_and_predicts_as_python(csharp):
    # "version V abi A": the library's ABI, which CheckVersion compared with its declarations' AbiVersion
    assert csharp["version"][2] == str(ABI_VERSION)
    assert csharp["status_names"] == ["CC_OK", "CC_SIZE_A_UNSUPPORTED", "CC_UNKNOWN_STATUS"]  # the library's strings
    predictor = load_predictor("improved")
    for i, (p, rpy) in enumerate(POSES):
        R = rotation_from_rpy(np.array([rpy]))[0]
        point, normal = predictor.predict(np.array(p), R, size_A=SIZE, size_B=SIZE)
        got = np.array(_row(csharp, i), dtype=float)
        assert np.allclose(got[:3], point, rtol=0, atol=1e-12) and np.allclose(got[3:6], normal, rtol=0, atol=1e-12), i


def _row(lines: dict, i: int) -> list[str]:
    """The C# program's "predict i ..." line's values (its keys repeat: they are kept per index)."""
    return lines[f"predict{i}"]


def test_csharp_lands_a_box_and_reads_the_defaults(csharp):
    height, stacked, speed, spin, fn, weight = (float(x) for x in csharp["rest"])
    assert abs(height - stacked) < 1e-4 and speed < 1e-9 and spin < 1e-9, csharp["rest"]
    assert fn == pytest.approx(weight, rel=1e-9)  # the contact carries the box's weight at rest
    s = SleepingConfig()
    enabled, v, w, t, eps_p, eps_R, reuse = csharp["sleep"]
    assert (int(enabled), float(v), float(w), float(t), float(eps_p), float(eps_R), int(reuse)) == (
        int(s.enabled), s.v_sleep, s.w_sleep, s.t_sleep, s.eps_p, s.eps_R, int(s.pair_reuse))


def test_unitys_frame_conversion(csharp):
    worst, det = (float(x) for x in csharp["unity"])
    assert worst < 1e-12 and det < 1e-12, csharp["unity"]

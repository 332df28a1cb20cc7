"""The integrator's kit (native/Makefile, native/examples/crane_pair.cpp, docs/integrate.md), built
and run as a C++ simulator's engineer would: `make -C native BUILD=<tmp>`, then the example.

- The weights reader (native/src/weights.c, on native/src/npz.c) reads the shipped files bit for bit, refuses a
  malformed one with one line naming the file, the entry and what was expected, and survives
  truncation and corruption at every tested offset (a driver compiled with AddressSanitizer
  where the compiler has it: tests/native/load_dump.c).
- The example's stepping mode lands a container on a fixed one at 1 kHz and it comes to rest.
- The example's batch mode answers every held-out pose set the accuracy gates use
  (learned_contact/evaluation/gates.py: stacking, general, outside, resting, resting_wider,
  resting_wider_level; the gates' sampling seeds, placed at their separating-axis depth without
  Drake) within 1e-12 of the numpy reference, for the shipped improved and paper weights.
- A refused weights file makes the example exit 2 with one line naming the file.

Everything is built under pytest's tmp_path; nothing is written into the repository.
"""

from __future__ import annotations

import os
import shutil
import struct
import subprocess
import types
import zipfile
from pathlib import Path

import numpy as np
import pytest

from learned_contact import load_predictor
from learned_contact.data.sampling import sample
from learned_contact.evaluation.gates import N_HELD_OUT, OUTSIDE_RANGES, exactly_level, outside_training
from learned_contact.predictors.loading import SHIPPED, load_weights
from testbed.geometry.boxes import sat_normal

REPO = Path(__file__).resolve().parents[2]
NATIVE = REPO / "native"
DRIVER = Path(__file__).resolve().parent / "load_dump.c"
# 1e-12 m (points, depths) and 1e-12 (unit-normal components): the bound. Both paths
# evaluate the same operations in the same order without fused multiply-adds, so they differ by
# rounding (~1e-16 m); any real disagreement (a wrong branch, a wrong weight) is >= 1e-9.
TOL = 1e-12
# The gates' held-out seeds: `testbed validate` (evaluate_gates' default, 0) and the pytest gates
# (tests/learned/test_learned_gates.py GATE_SEED); sets drawn with sampling seeds 10 * seed + k.
GATE_SEEDS = (0, 98_765)
SETS = ("stacking", "general", "outside", "resting", "resting_wider", "resting_wider_level")
KINDS = ("improved", "paper")


def _compiler(env_name: str, names: tuple[str, ...]) -> str | None:
    given = os.environ.get(env_name)
    if given:
        return shutil.which(given.split()[0]) and given
    return next((n for n in names if shutil.which(n)), None)


CC = _compiler("CC", ("cc", "gcc", "clang"))
CXX = _compiler("CXX", ("c++", "g++", "clang++"))
pytestmark = pytest.mark.skipif(
    CC is None or CXX is None or shutil.which("make") is None,
    reason="the integrator's kit needs a C compiler, a C++17 compiler and make (CI has gcc, g++ and make)")


def _run(args, **kw):
    return subprocess.run([str(a) for a in args], capture_output=True, text=True, timeout=600, **kw)


@pytest.fixture(scope="module")
def kit(tmp_path_factory) -> Path:
    """The kit built out of tree: libcontainer_contact.a / .so and crane_pair under a tmp dir."""
    build = tmp_path_factory.mktemp("kit")
    done = _run(["make", "-C", NATIVE, f"BUILD={build}", f"CC={CC}", f"CXX={CXX}", "-j2"])
    assert done.returncode == 0, done.stdout + done.stderr
    for name in ("libcontainer_contact.a", "libcontainer_contact.so", "crane_pair"):
        assert (build / name).is_file(), f"make built no {name}"
    return build


def _sanitizer_flags(workdir: Path) -> list[str]:
    """-fsanitize=address,undefined where the C compiler can build and run with it, else []."""
    flags = ["-fsanitize=address,undefined", "-fno-sanitize-recover=all", "-fno-omit-frame-pointer"]
    probe = workdir / "probe.c"
    probe.write_text("int main(void) { return 0; }\n")
    built = _run([CC, *flags, probe, "-o", workdir / "probe"])
    return flags if built.returncode == 0 and _run([workdir / "probe"]).returncode == 0 else []


@pytest.fixture(scope="module")
def driver(kit, tmp_path_factory) -> Path:
    """tests/native/load_dump.c on the reader alone (weights.c and npz.c depend on libc only), with
    AddressSanitizer and UBSan where available."""
    work = tmp_path_factory.mktemp("driver")
    out = work / "load_dump"
    built = _run([CC, "-std=c11", "-O1", "-g", "-Wall", "-Wextra", *_sanitizer_flags(work), f"-I{NATIVE / 'include'}",
                  f"-I{NATIVE / 'src'}", NATIVE / "src" / "weights.c", NATIVE / "src" / "npz.c", DRIVER, "-o", out, "-lm"])
    assert built.returncode == 0, built.stderr
    return out


# ---------------------------------------------------------------------- the weights reader

def _expected_doubles(arrays) -> np.ndarray:
    """The float64 values load_dump writes, in its order, from the arrays as numpy reads them."""
    parts = [arrays["supported_sizes"]] + ([arrays["size_range"]] if "size_range" in arrays else [])
    for prefix in ("mlp/", "expert/"):
        if f"{prefix}W0" not in arrays:
            continue
        parts += [arrays[f"{prefix}x_mean"], arrays[f"{prefix}x_std"]]
        i = 0
        while f"{prefix}W{i}" in arrays:
            parts += [arrays[f"{prefix}W{i}"], arrays[f"{prefix}b{i}"]]
            i += 1
    if "expert/domain" in arrays:
        parts.append(arrays["expert/domain"])
    return np.concatenate([np.ascontiguousarray(a, dtype=float).ravel() for a in parts])


def _dump(driver, path, tmp_path):
    out = tmp_path / "dump.bin"
    done = _run([driver, path, out])
    return done, (np.fromfile(out, dtype="<f8") if done.returncode == 0 else None)


@pytest.mark.parametrize("kind", KINDS)
def test_reader_loads_the_shipped_files_bit_for_bit(driver, kind, tmp_path):
    path = SHIPPED[kind]
    with zipfile.ZipFile(path) as z:
        assert {i.compress_type for i in z.infolist()} == {zipfile.ZIP_STORED}, "shipped files are numpy.savez's"
    done, got = _dump(driver, path, tmp_path)
    assert done.returncode == 0, done.stderr
    arrays = dict(np.load(path))
    want = _expected_doubles(arrays)
    assert got.shape == want.shape and np.array_equal(got.view(np.uint64), want.view(np.uint64))
    lines = dict(line.split(" ", 1) for line in done.stdout.splitlines())
    assert int(lines["format_version"]) == int(arrays["format_version"])
    assert int(lines["n_sizes"]) == len(arrays["supported_sizes"])
    assert int(lines["has_expert"]) == ("expert/W0" in arrays)
    assert int(lines["n_domain"]) == (len(arrays["expert/domain"]) if "expert/domain" in arrays else 0)
    assert int(lines["has_size_range"]) == ("size_range" in arrays) == (kind == "improved")
    dims = [arrays["mlp/W0"].shape[0]] + [arrays[f"mlp/W{i}"].shape[1] for i in range(int(lines["main"].split()[1]))]
    assert lines["main"].split()[5:] == [str(d) for d in dims]


def _arrays(kind="improved") -> dict:
    return {k: v for k, v in np.load(SHIPPED[kind]).items()}


def _format3(a):
    """The shipped improved arrays as a format_version 3 file: 11 gate bounds (fractions)."""
    a = dict(a, format_version=np.array(3))
    a["expert/domain"] = np.array([5.5e-4, 1e-3, 1.2e-3, 1.7e-3, 0.035, 0.052, 0.1, 0.2, 0.1, 0.2, 0.01])
    return a


# (name, arrays edit, entry the message names, words it must hold, whether learned_contact's own
# loader refuses the same file too)
MALFORMED = [
    ("W1 shape", lambda a: dict(a, **{"mlp/W1": a["mlp/W1"][:5]}), "mlp/W1", "has shape", True),
    ("bias of W1", lambda a: dict(a, **{"mlp/W1": a["mlp/W1"][:, :5]}), "mlp/b1", "has shape", True),
    ("bias shape", lambda a: dict(a, **{"mlp/b0": a["mlp/b0"][:-1]}), "mlp/b0", "has shape", True),
    ("outputs", lambda a: dict(a, **{"mlp/W2": a["mlp/W2"][:, :5], "mlp/b2": a["mlp/b2"][:5]}), "mlp/W2",
     "outputs", True),
    ("x_std length", lambda a: dict(a, **{"mlp/x_std": a["mlp/x_std"][:90]}), "mlp/x_std", "has shape", True),
    ("kind", lambda a: dict(a, kind=np.array("banana")), "kind", "'banana'", True),
    ("version", lambda a: dict(a, format_version=np.array(9)), "format_version", "is 9", True),
    ("activation", lambda a: dict(a, **{"mlp/activation": np.array("gelu")}), "mlp/activation", "'gelu'", True),
    ("domain length", lambda a: dict(a, format_version=np.array(3)), "expert/domain", "has shape", True),
    ("domain order", lambda a: dict(a, **{"expert/domain": a["expert/domain"][[1, 0, *range(2, 9)]]}),
     "expert/domain", "in < out", True),
    ("NaN", lambda a: dict(a, **{"mlp/b0": np.where(np.arange(64) == 3, np.nan, a["mlp/b0"])}), "mlp/b0", "NaN",
     True),
    ("missing x_std", lambda a: {k: v for k, v in a.items() if k != "mlp/x_std"}, "mlp/x_std", "missing", True),
    ("missing expert", lambda a: {k: v for k, v in a.items() if not k.startswith("expert/")}, "expert/W0",
     "missing", True),
    ("version 1 with expert", lambda a: dict(a, format_version=np.array(1)), "format_version", "resting expert", True),
    ("sizes shape", lambda a: dict(a, supported_sizes=a["supported_sizes"][0]), "supported_sizes", "has shape", True),
    ("size range shape", lambda a: dict(a, size_range=a["size_range"][0]), "size_range", "has shape", True),
    ("size range order", lambda a: dict(a, size_range=a["size_range"][::-1]), "size_range", "lowest <= highest", True),
    # (learned_contact's loader refuses it too, but with numpy's bare ValueError, not a WeightsError)
    ("string sizes", lambda a: dict(a, supported_sizes=np.array("1CC")), "supported_sizes", "dtype", False),
    # stricter than numpy's reader (which converts): the C reader takes float64 little-endian only
    ("big-endian", lambda a: dict(a, **{"mlp/W0": a["mlp/W0"].astype(">f8")}), "mlp/W0", "'>f8'", False),
    ("float32", lambda a: dict(a, **{"mlp/x_mean": a["mlp/x_mean"].astype("<f4")}), "mlp/x_mean", "'<f4'", False),
]


@pytest.mark.parametrize("name, edit, entry, words, python_refuses", MALFORMED, ids=[m[0] for m in MALFORMED])
def test_reader_refuses_a_malformed_file_naming_the_entry(driver, tmp_path, name, edit, entry, words,
                                                          python_refuses):
    path = tmp_path / f"{name.replace(' ', '_')}.npz"
    np.savez(path, **edit(_arrays()))
    done, _ = _dump(driver, path, tmp_path)
    assert done.returncode == 2, done.stdout
    lines = done.stderr.splitlines()
    assert len(lines) == 1, done.stderr
    assert lines[0].startswith(f"weights file {path}: ") and f"'{entry}" in lines[0] and words in lines[0], lines[0]
    assert "expected" in lines[0]
    if python_refuses:  # the same file is refused by learned_contact's own loader
        with pytest.raises(Exception, match="weights file"):
            load_weights(path, compiled=False)


def test_reader_names_a_compressed_entry(driver, tmp_path):
    path = tmp_path / "compressed.npz"
    np.savez_compressed(path, **_arrays("paper"))
    done, _ = _dump(driver, path, tmp_path)
    assert done.returncode == 2
    (line,) = done.stderr.splitlines()
    assert line.startswith(f"weights file {path}: compressed entry 'format_version.npy'")
    assert "save with numpy.savez, not savez_compressed" in line


def test_reader_loads_format_3_and_files_without_kind(driver, tmp_path):
    """A format_version 3 file (11 gate bounds), a file from before `kind` existed (told by its
    arrays, as learned_contact.predictors.loading.infer_kind does) and a paper file without a
    format_version (version 1, as loading.load_weights reads it) load with every value intact."""
    cases = {"format3": _format3(_arrays()), "no_kind": {k: v for k, v in _arrays().items() if k != "kind"},
             "paper_no_version": {k: v for k, v in _arrays("paper").items() if k != "format_version"}}
    for name, arrays in cases.items():
        path = tmp_path / f"{name}.npz"
        np.savez(path, **arrays)
        done, got = _dump(driver, path, tmp_path)
        assert done.returncode == 0, (name, done.stderr)
        want = _expected_doubles(arrays)
        assert np.array_equal(got.view(np.uint64), want.view(np.uint64)), name
        load_weights(path, compiled=False)  # and learned_contact's own loader takes it too
    assert "n_domain 11" in _run([driver, tmp_path / "format3.npz", tmp_path / "x.bin"]).stdout
    assert "format_version 1" in _run([driver, tmp_path / "paper_no_version.npz", tmp_path / "x.bin"]).stdout


@pytest.mark.parametrize("kind, stride", [("paper", 1), ("improved", 61)])
def test_reader_survives_truncation_and_corruption(driver, tmp_path, kind, stride):
    """Every stride-th offset: the file cut there, the byte there inverted, the byte there replaced.
    Each is refused with one line naming the file, or (a byte the format does not read: a zip
    timestamp, a local header's copy of a size) loads exactly the original model; never a crash
    (under AddressSanitizer where the compiler has it). The zip's CRC-32 guards every array byte."""
    done = _run([driver, "--fuzz", SHIPPED[kind], stride, tmp_path / "scratch.npz"])
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    counts = {line.split()[0]: [int(x) for x in line.split()[2::2]] for line in done.stdout.splitlines()[1:]}
    size = SHIPPED[kind].stat().st_size
    offsets = len(range(0, size, stride))
    assert counts["cut"] == [offsets, 0, 0]  # every truncation refused
    for what in ("inverted", "replaced"):
        refused, same, bad = counts[what]
        assert bad == 0 and refused > 0.9 * offsets  # the few accepted ones loaded the same model


# ---------------------------------------------------------------- the example, stepping mode

def _result(stdout: str) -> dict:
    (line,) = [x for x in stdout.splitlines() if x.startswith("result ")]
    return {k: float(v) for k, v in (f.split("=") for f in line.split()[1:])}


def test_example_lands_a_container_that_comes_to_rest(kit):
    """crane_pair with its built-in default weights (the shipped improved file): a 20 ft box
    dropped 10 cm onto a fixed one, off-centre, tilted and yawed, stepped 3 s at 1 kHz."""
    done = _run([kit / "crane_pair"], cwd=kit)
    assert done.returncode == 0, done.stdout + done.stderr
    r = _result(done.stdout)
    assert r["finite"] == 1
    # within 1 cm of the stacked height (the tops touch): the static sink under the box's weight
    # is tens of micrometres (kappa A d = m g), so 1 cm only catches a box that did not land,
    # sank through or bounced off
    assert abs(r["height_m"] - r["stacked_m"]) < 0.01
    # at rest after ~2.8 s on the other box: 1 mm/s and 1 mrad/s are far below the landing speed
    # (1.4 m/s) and above any residue of a damped contact; a box still rocking moves cm/s
    assert r["speed_mps"] < 1e-3 and r["spin_radps"] < 1e-3
    # level on the other box (it started tilted 0.5 deg), carried by the contact: the normal force
    # is its weight to 1 %
    assert r["tilt_deg"] < 0.05
    assert abs(r["fn_N"] - r["weight_N"]) < 0.01 * r["weight_N"]
    # the costs are printed (measured, never asserted in time): positive and finite
    for key in ("step_median_us", "step_p99_us", "predict_median_us", "predict_p99_us"):
        assert 0.0 < r[key] < float("inf")
    assert r["step_median_us"] <= r["step_p99_us"]
    assert "cost per cc_contact_step call [us]: median" in done.stdout


@pytest.mark.parametrize("damage", ["truncated", "compressed", "not a zip", "missing", "directory"])
def test_example_refuses_bad_weights_with_exit_2_and_one_line(kit, tmp_path, damage):
    path = tmp_path / "bad.npz"
    if damage == "truncated":
        path.write_bytes(SHIPPED["improved"].read_bytes()[:50_000])
    elif damage == "compressed":
        np.savez_compressed(path, **_arrays())
    elif damage == "not a zip":
        path.write_text("weights\n")
    elif damage == "directory":
        path.mkdir()
    done = _run([kit / "crane_pair", path])
    assert done.returncode == 2, done.stdout + done.stderr
    lines = done.stderr.splitlines()
    assert len(lines) == 1, done.stderr
    assert lines[0].startswith(f"weights file {path}: ")
    assert ("save with numpy.savez, not savez_compressed" if damage == "compressed" else "expected") in lines[0]
    assert done.stdout == ""


# ------------------------------------------------------------------ the example, batch mode

def _place(base, direction, R, h_A, h_B, depth):
    """B's centre p = base + t direction whose separating-axis depth is `depth` [m] (bisection on
    t; what the labeller does with Drake's signed distance, learned_contact/data/labels.py)."""
    lo, hi = np.zeros(len(base)), np.full(len(base), 40.0)
    for _ in range(64):
        mid = 0.5 * (lo + hi)
        deeper = sat_normal(base + mid[:, None] * direction, R, h_A, h_B)[1] > depth
        lo, hi = np.where(deeper, mid, lo), np.where(deeper, hi, mid)
    return base + hi[:, None] * direction


def held_out_poses(seed: int, n: int = N_HELD_OUT) -> dict:
    """{set: (p_AB, R_AB, size_A, size_B)}: the gates' held-out sets (gates.held_out) from the
    pose samplers alone, each proposal placed at its target depth by the separating axis."""

    def draw(distribution, k, **ranges):
        s = sample(distribution, n, 10 * seed + k, **ranges)
        size_A, size_B = s.sizes()
        p = _place(s.base, s.direction, s.R_AB, 0.5 * size_A, 0.5 * size_B, s.depth)
        return p, s.R_AB, size_A, size_B

    sets = {"stacking": draw("stacking", 5), "general": draw("general", 6)}
    p, R, sA, sB = draw("stacking", 7, **OUTSIDE_RANGES)
    depth = sat_normal(p, R, 0.5 * sA, 0.5 * sB)[1]
    keep = outside_training(types.SimpleNamespace(R_AB=R, depth=depth))
    sets["outside"] = (p[keep], R[keep], sA[keep], sB[keep])
    sets["resting"] = draw("resting", 8)
    sets["resting_wider"] = draw("resting_wider", 9)
    level = exactly_level(types.SimpleNamespace(R_AB=sets["resting_wider"][1]))
    sets["resting_wider_level"] = tuple(a[level] for a in sets["resting_wider"])
    return sets


def write_poses(path: Path, p, R, size_A, size_B):
    """The example's batch input (crane_pair.cpp): uint64 n, rows_A, rows_B; float64 p (n, 3),
    R (n, 3, 3), size_A (rows_A, 3), size_B (rows_B, 3), little-endian."""
    n = len(p)
    with open(path, "wb") as f:
        f.write(struct.pack("<3Q", n, len(size_A), len(size_B)))
        for a in (p, R, size_A, size_B):
            f.write(np.ascontiguousarray(a, dtype="<f8").tobytes())


def read_answers(path: Path, n: int):
    raw = np.fromfile(path, dtype="<f8")
    assert raw.shape == (7 * n,)
    return raw[:3 * n].reshape(n, 3), raw[3 * n:6 * n].reshape(n, 3), raw[6 * n:]


@pytest.fixture(scope="module")
def pose_sets() -> dict:
    return {seed: held_out_poses(seed) for seed in GATE_SEEDS}


@pytest.mark.parametrize("kind", KINDS)
def test_example_batch_matches_the_numpy_reference_on_every_held_out_set(kit, pose_sets, kind, tmp_path):
    reference = load_predictor(kind, compiled=False)
    worst = {}
    for seed, sets in pose_sets.items():
        assert set(sets) == set(SETS)
        for name, (p, R, sA, sB) in sets.items():
            assert len(p) > 0, f"{name} (seed {seed}) drew no poses"
            poses, out = tmp_path / f"{name}_{seed}.bin", tmp_path / f"{name}_{seed}.out"
            write_poses(poses, p, R, sA, sB)
            done = _run([kit / "crane_pair", SHIPPED[kind], "--poses", poses, "--out", out])
            assert done.returncode == 0, done.stdout + done.stderr
            point, normal, depth = read_answers(out, len(p))
            ref_point, ref_normal = reference.predict(p, R, size_A=sA, size_B=sB)
            ref_depth = reference.depth(p, R, size_A=sA, size_B=sB)
            worst[f"{name} (seed {seed}, {len(p)} poses)"] = (
                float(np.max(np.abs(point - ref_point))), float(np.max(np.abs(normal - ref_normal))),
                float(np.max(np.abs(depth - ref_depth))))
    print(f"\n{kind}: worst |C++ example - numpy reference| (point [m], normal, depth [m]):")
    for name, w in worst.items():
        print(f"  {name}: {w[0]:.2e}, {w[1]:.2e}, {w[2]:.2e}")
    bad = {name: w for name, w in worst.items() if max(w) > TOL}
    assert not bad, f"beyond {TOL}: {bad}"


def test_example_batch_broadcasts_one_size_row(kit, pose_sets, tmp_path):
    """rows_A = rows_B = 1 (one size for every pose) answers as the per-pose rows do."""
    p, R, sA, sB = pose_sets[GATE_SEEDS[0]]["stacking"]
    same = np.all(sA == sA[0], axis=1) & np.all(sB == sB[0], axis=1)
    p, R = p[same], R[same]
    answers = []
    for rows in ("one", "each"):
        poses, out = tmp_path / f"{rows}.bin", tmp_path / f"{rows}.out"
        sizes = (sA[:1], sB[:1]) if rows == "one" else (sA[same], sB[same])
        write_poses(poses, p, R, *sizes)
        done = _run([kit / "crane_pair", SHIPPED["improved"], "--poses", poses, "--out", out])
        assert done.returncode == 0, done.stderr
        answers.append(out.read_bytes())
    assert len(p) > 0 and answers[0] == answers[1]


# ------------------------------------------------------------------- docs/integrate.md

def test_the_documented_cpp_snippet_builds_and_runs(kit, tmp_path):
    """docs/integrate.md's C++ snippet, compiled against the kit as its first line says: the
    predictor answers the resting pair and the step pushes B up (its 0.1 mm overlap)."""
    text = (REPO / "docs" / "integrate.md").read_text(encoding="utf-8")
    snippet = text.split("### A C++ snippet", 1)[1].split("```cpp\n", 1)[1].split("```", 1)[0]
    source = tmp_path / "snippet.cpp"
    source.write_text(snippet)
    built = _run([CXX, "-std=c++17", "-Wall", "-Wextra", f"-I{NATIVE / 'include'}", source,
                  kit / "libcontainer_contact.a", "-lm", "-o", tmp_path / "snippet"])
    assert built.returncode == 0, built.stderr
    done = _run([tmp_path / "snippet", SHIPPED["improved"]])
    assert done.returncode == 0, done.stdout + done.stderr
    predict, step = done.stdout.splitlines()
    assert predict.startswith("predict 0: ") and step.startswith("step 0: ")
    force_z = float(step.split("(")[1].split(")")[0].split(",")[2])
    assert force_z > 0.0
    bad = _run([tmp_path / "snippet", tmp_path / "missing.npz"])
    assert bad.returncode == 2 and bad.stderr.startswith(f"weights file {tmp_path / 'missing.npz'}: ")

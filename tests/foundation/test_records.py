"""Run records: columns, conventions, files, and the shadow model's answer."""

import json

import numpy as np
import pytest
from conftest import G, cached_run, last_step

from testbed.contact.extraction import HYDRO, POINT
from testbed.records import load_table
from testbed.scenario import load_scenario
from testbed.simulation import run_scenario, write_run

CONTACT_COLUMNS = {"step", "time", "a", "b", "kind", "p_W_centroid", "p_W_cop", "p_W_cop_static", "p_W_cop_one_point", "n_W", "f_W", "fn", "ft_W",
                   "area", "phi", "static_age", "p_WA", "q_WA", "p_WB", "q_WB"}


@pytest.fixture(scope="module")
def two_stack(tmp_path_factory):
    result = run_scenario(load_scenario("two_stack"), duration=0.3)
    out = write_run(result, tmp_path_factory.mktemp("runs") / "two_stack")
    return result, out


def test_run_directory_files(two_stack):
    _, out = two_stack
    assert {p.name for p in out.iterdir()} == {
        "scenario.yaml", "steps.npz", "contacts.npz", "shadow.npz", "shadow_disagreement.npz", "summary.json"}
    summary = json.loads((out / "summary.json").read_text())
    assert summary["steps"] == 300 and summary["body_names"] == ["quay_ground", "bottom", "top"]
    assert set(load_table(out / "contacts.npz")) == CONTACT_COLUMNS


def test_contact_rows_follow_the_conventions(two_stack):
    result, out = two_stack
    c = load_table(out / "contacts.npz")
    assert np.all(c["a"] < c["b"])
    assert np.allclose(np.linalg.norm(c["n_W"], axis=1), 1.0)
    assert np.allclose(np.einsum("ij,ij->i", c["f_W"], c["n_W"]), c["fn"])
    assert np.allclose(c["f_W"], c["fn"][:, None] * c["n_W"] + c["ft_W"])
    assert np.all(c["kind"] == HYDRO)
    # resting stack: normals point up (from the lower body into the upper), forces push up
    rows = last_step(c)
    assert np.all(c["n_W"][rows, 2] > 0.999) and np.all(c["fn"][rows] > 0)
    # with a 0.8 m eccentricity (< L/6 = 1.01 m) the pressure stays positive along the
    # whole length, so the surface covers most of the 14.77 m^2 footprint
    assert np.all(c["phi"][rows] < 0) and np.all(c["area"][rows] > 12.0)
    # the top box (payload 0.8 m off centre) puts its centre of pressure under its COM;
    # the area centroid does not follow the pressure (measured ~0.2 m): both are recorded
    top = rows & (c["b"] == 2)
    assert c["p_W_cop"][top][0, 0] == pytest.approx(0.8, abs=0.02)
    assert c["p_W_cop"][top][0, 0] - c["p_W_centroid"][top][0, 0] > 0.4
    # static columns: read from the faces every static_every_steps (10) steps per pair, held
    # in between; static_age counts the steps since (0 = this row's state)
    every = result.scenario.effects.contact_log.static_every_steps
    assert c["static_age"].min() == 0 and c["static_age"].max() == every - 1
    for pair in (1, 2):
        rows_b = c["b"] == pair
        fresh = c["step"][rows_b][c["static_age"][rows_b] == 0]
        assert np.all(np.diff(fresh) == every)  # a resting pair is read every `every` steps
        held = rows_b & (c["static_age"] > 0)
        # a held row carries exactly the static answer of the row `static_age` steps earlier
        src = {s: i for i, s in enumerate(c["step"][rows_b])}
        idx = np.flatnonzero(rows_b)
        for i in np.flatnonzero(held)[:20]:
            j = idx[src[c["step"][i] - c["static_age"][i]]]
            assert np.array_equal(c["p_W_cop_static"][i], c["p_W_cop_static"][j])
            assert np.array_equal(c["n_W"][i], c["n_W"][j])
    # poses are those of the bodies named by a and b
    steps = load_table(out / "steps.npz")
    k = c["step"][top][0]
    assert np.allclose(c["p_WB"][top][0], steps["p_WB"][k, 1])


def test_shadow_is_point_contact_on_the_same_states(two_stack):
    result, out = two_stack
    shadow = load_table(out / "shadow.npz")
    assert np.all(shadow["kind"] == POINT) and np.all(shadow["a"] < shadow["b"])
    assert np.allclose(np.linalg.norm(shadow["n_W"], axis=1), 1.0)
    d = load_table(out / "shadow_disagreement.npz")
    assert len(d["step"]) > 0
    # point contact answers with one corner of the 6.058 x 2.438 m face: ~3 m from the CoP
    assert 2.5 < result.summary["shadow_cop_distance_max_m"] < 3.5
    assert result.summary["shadow_normal_angle_max_deg"] < 5.0


def test_shadow_of_point_contact_is_hydroelastic():
    result = run_scenario(load_scenario("two_stack", overrides=["effects.contact.model=point"]), duration=0.2)
    shadow = result.tables["shadow"]
    assert result.summary["shadow_model"] == "hydroelastic"
    assert np.all(shadow["kind"] == HYDRO) and np.all(shadow["area"] > 0)
    rows = last_step(shadow)
    weight = sum(c.total_mass() for c in result.scenario.containers) * G
    ground = rows & (shadow["a"] == 0)
    # the static hydroelastic force at the point model's penetration is not the weight
    # (different stiffness), but it must push up
    assert np.all(shadow["fn"][ground] > 0) and np.all(shadow["n_W"][ground, 2] > 0.99)
    # ...and of the expected order: at the point model's ~0.45 mm the hydroelastic ground
    # pressure E d / (h/2) over the 6.1 x 2.4 m face (E = 1e9 Pa) is ~18x the weight (measured
    # 14x); a factor-ten band around that catches a unit or sign slip, not the stiffness difference
    assert 1.4 * weight < shadow["fn"][ground].sum() < 140.0 * weight


def test_energy_is_not_created_in_a_drop():
    result = cached_run("single_drop", "effects.contact.model=hydroelastic")
    s, c = result.tables["steps"], result.tables["contacts"]
    energy = s["kinetic_energy"] + s["potential_energy"]  # (n,) [J] gravity + kinetic
    first = int(np.searchsorted(s["step"], c["step"].min()))  # row of the first step with a contact
    mass = result.scenario.containers[0].total_mass()
    h = result.scenario.plant.time_step
    # Free fall: the discrete scheme (q uses v_{n+1}) loses exactly m g^2 h^2 / 2 per
    # step; it must never gain.
    free = np.diff(energy[: first - 1])
    assert np.all(free <= 1e-6 * energy[0])
    assert np.allclose(free, -0.5 * mass * 9.81**2 * h**2, rtol=1e-3)
    # After the first contact the energy may not exceed its value at first contact;
    # 1e-3 of the drop energy (59 J) allows the elastic energy stored in the contact
    # compression (~25 J at rest: 0.5 x 196 kN x 0.25 mm) to reappear as motion.
    drop_energy = mass * 9.81 * 0.3
    assert np.max(energy[first:]) <= energy[first] + 1e-3 * drop_energy
    assert energy[-1] < energy[0] - 0.9 * drop_energy  # the landing dissipated it


def test_to_frame_reads_a_table_file_and_the_body_indices_are_as_documented(two_stack):
    """to_frame takes a table's path (it used to fail with AttributeError); steps' container j
    is body_names[j + 1] in contacts (two_stack has no welded box), checked on the poses."""
    pytest.importorskip("pandas", reason="to_frame needs pandas: pip install -e '.[frames]'")
    from testbed.records import to_frame

    _, out = two_stack
    contacts = to_frame(out / "contacts.npz")
    steps = to_frame(str(out / "steps.npz"))
    assert len(contacts) == len(load_table(out / "contacts.npz")["a"]) and {"p_WB_0", "p_WB_2", "static_age"} <= set(contacts)
    assert list(steps.columns[:2]) == ["step", "time"] and "p_WB_5" in steps and "p_WB_6" not in steps  # (n, 2, 3)
    pair = contacts[(contacts.a == 1) & (contacts.b == 2)].iloc[-1]  # bottom (a) under top (b)
    row = steps[steps.step == pair.step].iloc[0]
    # contacts record the poses of the same state: exact equality, not a tolerance
    assert [row[f"p_WB_{i}"] for i in range(3)] == [pair[f"p_WA_{i}"] for i in range(3)]  # container 0 = bottom
    assert [row[f"p_WB_{3 + i}"] for i in range(3)] == [pair[f"p_WB_{i}"] for i in range(3)]  # container 1 = top


def test_run_prints_the_disagreement_in_mm_with_its_reason(two_stack):
    """`testbed run`'s lines: the shadow disagreement in mm (the unit of compare and the
    report), why point contact's reads metres, and what the real-time factor is."""
    from testbed.commands.run import format_summary

    result, _ = two_stack
    s = result.summary
    text = format_summary(s)
    assert s["shadow_model"] == "point" and s["shadow_cop_distance_max_m"] > 1.0  # a corner, metres away (measured 3.3 m)
    assert f"disagreement {s['shadow_cop_distance_max_m'] * 1e3:.1f} mm at step" in text
    assert "a corner of the contact face for face-on-face contact" in text
    assert "real-time factor" in text and "simulated time / wall time" in text

"""`testbed compare`'s report (testbed/compare/report.py, report_plots.py): report.html's first
screen read back and held to compare.json and trajectories.npz, the energy net of the external
actors' work as the energy gate reads it, plots whose legends stay short at 2 and at 36
containers, and a PASS held only within pinned known limits. Each run is 0.1 s of simulated time
(two_stack: 2 containers; ship_bay_roll: 36 on a rolling deck, whose motion does work on them)."""

import json
from html.parser import HTMLParser

import numpy as np
import pytest

from testbed.cli import main
from testbed.compare import report
from testbed.compare.verdict import PASS, judge
from testbed.gates import KNOWN_LIMIT
from testbed.gates.closed_loop import KNOWN_LIMITS
from testbed.scenario import load_scenario

MAX_LEGEND_ENTRIES = 6  # what the report promises of every legend, whatever the number of containers
HEADERS = [header for _, header in report.COLUMNS]


def _compare(out, scene: str, *argv) -> dict:
    assert main(["compare", scene, "--duration", "0.1", "--no-replay", *argv, "--out", str(out)]) == 0
    return json.loads((out / "compare.json").read_text())


@pytest.fixture(scope="module")
def two_stack(tmp_path_factory):
    out = tmp_path_factory.mktemp("two_stack") / "cmp"
    return "two_stack", out, _compare(out, "two_stack")


@pytest.fixture(scope="module")
def ship_bay(tmp_path_factory):
    out = tmp_path_factory.mktemp("ship_bay_roll") / "cmp"
    return "ship_bay_roll", out, _compare(out, "ship_bay_roll")


class _Tables(HTMLParser):
    """Every <table> of a page as rows of cell texts, and the page's <h1>."""

    def __init__(self):
        super().__init__()
        self.tables, self.h1, self._cell, self._in_h1 = [], "", None, False

    def handle_starttag(self, tag, attrs):
        if tag == "table":
            self.tables.append([])
        elif tag == "tr":
            self.tables[-1].append([])
        elif tag in ("td", "th"):
            self._cell = ""
        self._in_h1 = self._in_h1 or tag == "h1"

    def handle_endtag(self, tag):
        if tag in ("td", "th"):
            self.tables[-1][-1].append(self._cell)
            self._cell = None
        self._in_h1 = self._in_h1 and tag != "h1"

    def handle_data(self, data):
        if self._cell is not None:
            self._cell += data
        if self._in_h1:
            self.h1 += data


def _page(out) -> _Tables:
    page = _Tables()
    page.feed((out / report.HTML).read_text())
    return page


def _first_screen(out) -> list[dict]:
    """The first table of report.html as {header: cell} per row."""
    head, *body = _page(out).tables[0]
    assert head == HEADERS
    return [dict(zip(head, row)) for row in body]


def _markdown_rows(out) -> list[list[str]]:
    """The first pipe table of report.md, its rows (header and separator left out)."""
    lines = [line for line in (out / report.MARKDOWN).read_text().splitlines() if line.startswith("|")]
    cells = [[c.strip().replace("\\|", "|") for c in line.strip().strip("|").split(" | ")] for line in lines]
    end = next(i for i in range(2, len(cells) + 1) if i == len(cells) or len(cells[i]) != len(HEADERS))
    return cells[2:end]


def _series(out) -> dict:
    with np.load(out / "trajectories.npz") as d:
        return {k: d[k] for k in d.files}


@pytest.mark.parametrize("run", ["two_stack", "ship_bay"])
def test_the_first_screen_is_compare_jsons(run, request):
    """Every candidate's verdict, real-time factor and window, cost per step and final-pose figures
    in report.html's first table are compare.json's; Drake's truth closes the table; report.md
    holds the same cells; the table comes before the plots."""
    scene, out, f = request.getfixturevalue(run)
    rows = _first_screen(out)
    assert [r["candidate"] for r in rows] == [*f["candidates"], report.TRUTH]
    h = f["time_step_s"]
    for row, (label, c) in zip(rows, f["candidates"].items()):
        expected = report.NOT_GATED if c.get("verdict") is None else c["verdict"]
        assert not c.get("gates_known_limits") and row["verdict"] == expected, (label, row["verdict"])
        wall = c["wall_per_sim_s_learned"]
        assert float(row["real-time factor [x]"]) == pytest.approx(1.0 / wall, rel=5e-3)
        assert row["measured over t [s]"] == f"0-{c['simulated_s_learned']:g}"
        assert float(row["cost per step [us]"]) == pytest.approx(1e6 * wall * h, rel=5e-3, abs=0.5)
        assert float(row["final position error [mm]"]) == pytest.approx(c["final_position_error_max_m"] * 1e3, rel=1e-3)
        assert float(row["final angle error [deg]"]) == pytest.approx(c["final_angle_error_max_deg"], rel=1e-3)
        assert float(row["worst penetration [mm]"]) == pytest.approx(c["max_penetration_m"] * 1e3, rel=1e-3)
        assert float(row["energy raw [J]"]) == pytest.approx(c["energy_gain_max_J"], rel=1e-3, abs=1e-6)
    truth = rows[-1]
    assert float(truth["real-time factor [x]"]) == pytest.approx(1.0 / f["wall_per_sim_s_truth"], rel=5e-3)
    assert truth["measured over t [s]"] == f"0-{f['duration_s']:g}"
    assert f["verdict"] == PASS and _page(out).h1.endswith(f["verdict"])  # the title carries the primary's verdict
    assert _markdown_rows(out) == [list(r.values()) for r in rows]
    page = (out / report.HTML).read_text()
    assert page.index("<table") < page.index("<img")


def test_net_energy_is_raw_less_the_decks_work_as_the_gate_reads_it(ship_bay):
    """ship_bay_roll's deck does work on the containers: the report's net energy is the gate's
    figure, max over t of E(t) - E(0) - W(t) beyond the truth's where positive, computed here from
    trajectories.npz; the raw column is max E(t) - E(0); the plot draws both curves, labelled, and
    marks the gate's figure."""
    scene, out, f = ship_bay
    d = _series(out)
    E, W, E_T, W_T = d["learned_energy"], d["learned_external_work"], d["truth_energy"], d["truth_external_work"]
    raw, net = E - E[0], E - E[0] - W
    assert np.max(np.abs(W)) > 1.0  # the deck's work is there to be taken off (J)
    by_hand = float(np.max(net - np.maximum(0.0, E_T - E_T[0] - W_T)))
    gate = next(g for g in f["gates"] if g["name"] == "energy")
    assert gate["value"] == pytest.approx(by_hand, abs=1e-9) and f["energy_created_J"] == gate["value"]
    learned = _first_screen(out)[0]
    assert float(learned["energy net of external work [J]"]) == pytest.approx(gate["value"], rel=1e-3, abs=1e-9)
    assert float(learned["energy raw [J]"]) == pytest.approx(float(np.max(raw)), rel=1e-3)
    assert float(learned["external work max |W| [J]"]) == pytest.approx(float(np.max(np.abs(W))), rel=1e-3)
    gates = {row[0]: row for row in _page(out).tables[1][1:]}  # the primary's gates table: gate, result, value, threshold
    assert float(gates["energy"][2].split()[0]) == pytest.approx(gate["value"], rel=1e-3, abs=1e-9)
    figure = report.plots(d, "learned", scene)[report.DIVERGENCE]
    lines = [line for ax in figure.axes for line in ax.get_lines()]

    def labelled_line(y):
        found = [line for line in lines if len(line.get_ydata()) == len(y) and np.allclose(line.get_ydata(), y)]
        assert found and all(line.get_label() and not line.get_label().startswith("_") for line in found)
        return found

    labelled_line(raw)
    labelled_line(net)
    marker = [line for line in lines if len(line.get_ydata()) == 1]
    assert len(marker) == 1 and marker[0].get_ydata()[0] == pytest.approx(gate["value"], abs=1e-9)


@pytest.mark.parametrize("run", ["two_stack", "ship_bay"])
def test_the_plots_read_at_2_and_at_36_containers(run, request):
    """The legends stay short whatever the number of containers: the error plot names the worst
    containers (by their largest error) beside the median and the max over all of them; the map
    draws every container at the truth's final pose, the worst last (on top), and numbers the
    worst by final error."""
    scene, out, f = request.getfixturevalue(run)
    d = _series(out)
    figures = report.plots(d, "learned", scene, layout=report.layout_of(load_scenario(scene)))
    legends = [ax.get_legend() for fig in figures.values() for ax in fig.axes if ax.get_legend() is not None]
    assert legends and all(len(legend.get_texts()) <= MAX_LEGEND_ENTRIES for legend in legends)
    err = d["position_error"]
    names = [str(n) for n in d["names"]]
    assert len(names) == err.shape[1] == len([c for c in load_scenario(scene).containers if not c.fixed])
    errors = figures[report.DIVERGENCE].axes[0]
    named = [line.get_label() for line in errors.get_lines() if line.get_label() in names]
    peak = err.max(axis=0)
    assert 0 < len(named) <= 5 and sorted(peak[[names.index(n) for n in named]]) == sorted(
        np.sort(peak)[::-1][:len(named)])
    curves = [line.get_ydata() for line in errors.get_lines()]
    for summary in (np.median(err, axis=1) * 1e3, err.max(axis=1) * 1e3):
        assert any(np.allclose(y, summary) for y in curves)
    drawn = figures[report.ERROR_MAP].axes[0]
    boxes = [c for c in drawn.collections if len(c.get_paths()) == len(names)]
    assert len(boxes) == 1
    worst = int(np.argmax(err[-1]))
    centre = boxes[0].get_paths()[-1].vertices[:4].mean(axis=0)
    np.testing.assert_allclose(centre, d["truth_p_WB"][-1, worst, :2], atol=1e-6)
    badges = [t for t in drawn.texts if t.get_text().isdigit()]
    assert len(badges) == min(5, len(names))
    key = "\n".join(t.get_text() for ax in figures[report.ERROR_MAP].axes for t in ax.texts)
    assert all(names[i] in key for i in np.argsort(-err[-1], kind="stable")[:len(badges)])


def test_a_pass_within_pinned_known_limits_does_not_read_pass(two_stack, tmp_path):
    """corner_drop's pinned known limits judged on a synthetic twin run (verdict.judge, as
    tests/engines/test_compare_verdict.py does): a PASS that holds only within them shows as such
    in the verdict cell, the gates' result cells and the title, naming the pinned gates; the same
    run outside any pin reads PASS."""
    _, _, base = two_stack
    pins = KNOWN_LIMITS["corner_drop"][1]
    t = np.linspace(0.0, 5.0, 11)
    still = np.tile([1.0, 0.0, 0.0, 0.0], (11, 5, 1))
    np.savez(tmp_path / "trajectories.npz", position_error=np.zeros((11, 5)), learned_time=t,
             learned_energy=np.zeros(11), truth_energy=np.zeros(11), learned_q_WB=still, truth_q_WB=still)
    figures = {"scene": "corner_drop", "duration_s": 5.0, "time_step_s": 1e-3, "potential_drop_max_J": 1e6,
               "diverged": False, "pair_steps_learned": 1000, "final_angle_error_max_deg": pins["final angle"][0],
               "max_penetration_m": 0.0457, "max_penetration_truth_m": 0.0395,
               "final_position_error_max_m": pins["final position"][0]}
    pinned = judge(figures, tmp_path)
    plain = judge({**figures, "scene": "two_stack", "final_angle_error_max_deg": 0.01, "drift_m_per_min_learned": 0.0,
                   "final_position_error_max_m": 0.001, "max_penetration_m": 0.001}, tmp_path)
    assert pinned["verdict"] == plain["verdict"] == PASS and pinned["gates_known_limits"] and not plain["gates_known_limits"]
    primary = base["primary"]
    for verdict, out in ((pinned, tmp_path / "pinned"), (plain, tmp_path / "plain")):
        out.mkdir()
        f = {**base, **figures, **verdict, "candidates": {**base["candidates"], primary: {
            **base["candidates"][primary], **figures, **verdict}}}
        report.write_report(out, f)
        cell = _first_screen(out)[0]["verdict"]
        page = _page(out)
        results = [row[1] for row in page.tables[1][1:] if row[0] in verdict["gates_known_limits"]]
        if verdict["gates_known_limits"]:
            assert cell != PASS and not page.h1.endswith(PASS)
            assert all(name.replace(KNOWN_LIMIT, "").strip() in cell for name in verdict["gates_known_limits"])
            assert len(results) == len(verdict["gates_known_limits"]) and PASS not in set(results)
        else:
            assert cell == PASS and page.h1.endswith(PASS) and not results


def test_no_truth_reports_the_timing_alone(tmp_path):
    """--no-truth: no Drake run, so nothing to be off from: the report's one row per candidate is
    its verdict (no reference run), its real-time factor and window as compare.json's."""
    out = tmp_path / "cmp"
    f = _compare(out, "two_stack", "--no-truth")
    rows = _first_screen(out)
    assert [r["candidate"] for r in rows] == list(f["candidates"])
    for row, c in zip(rows, f["candidates"].values()):
        assert row["verdict"] == f["verdict"]
        assert float(row["real-time factor [x]"]) == pytest.approx(1.0 / c["wall_per_sim_s"], rel=5e-3)
        assert row["measured over t [s]"] == f"0-{c['simulated_s']:g}"
    assert not (out / report.DIVERGENCE).exists()

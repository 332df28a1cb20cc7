"""Validation report: gates, metrics.json, summary.md, index.html (and figures/*.png).

The gates are judged by the case kinds; every kind contributes its report sections as
structured data, and testbed.document renders the whole as Markdown (summary.md, the
brief sections) and as one self-contained HTML page (index.html, all sections).
`metrics.json` follows testbed/validation/report_schema.json (version SCHEMA_VERSION).
"""

from __future__ import annotations

import datetime
import json
import os
import platform
from pathlib import Path

from testbed.document import Bullets, Link, Section, Text, figures, table, to_html, to_markdown
from testbed.engines import engines
from testbed.provenance import commit
from testbed.records import json_default, write_atomic
from testbed.validation import gates as gate_lib
from testbed.validation.cases import ok_records, registry
from testbed.validation.gates import Gate, is_known_limit, shown
from testbed.validation.replays import replay_links
from testbed.validation.summary import gate_counts, head_sections

SCHEMA_VERSION = "testbed.validate/1"

# Result fields that measure time: they differ between runs, everything else is
# deterministic (the resume test compares reports without them). Each case kind adds
# its own names (CaseKind.timing_keys).
TIMING_KEYS = ("wall_s", "created")
_TIMING_FRAGMENTS = ("time_us", "_ms", "_us", "wall")


def is_timing_key(key: str) -> bool:
    """Whether a result field measures time (so may differ between two identical runs)."""
    if key in TIMING_KEYS or any(fragment in key for fragment in _TIMING_FRAGMENTS):
        return True
    return any(key in kind.timing_keys for kind in registry().values())


def evaluate_gates(records: list[dict]) -> list[Gate]:
    """Every gate of every record: `ran` for failed cases, else the kind's own gates."""
    kinds = registry()
    out = []
    for r in records:
        if r["status"] != "ok":
            out.append(gate_lib.ran(r))
        elif r["kind"] in kinds:
            out += kinds[r["kind"]].gates(r)
    return out


def _environment() -> dict:
    from importlib import metadata

    import numpy
    import pydrake

    try:  # pydrake has no __version__; the installed distribution knows it
        drake_version = metadata.version("drake")
    except metadata.PackageNotFoundError:
        drake_version = getattr(pydrake, "__version__", "unknown")
    engine_versions = {}
    for name, e in engines().items():  # every engine's version, or why it cannot run here
        if name in ("drake", "learned"):
            continue
        reason = e.unavailable()
        engine_versions[name] = (e.version() or "-") if reason is None else "not installed"
    return {"python": platform.python_version(), "platform": platform.platform(), "numpy": numpy.__version__,
            "drake": drake_version, "engines": engine_versions, "cpus": os.cpu_count(), "commit": commit()}


def build_metrics(spec: dict, records: list[dict], replays: dict[str, str] | None = None) -> dict:
    """metrics.json's content (JSON-able; no tracebacks)."""
    gates = [g.to_dict() for g in evaluate_gates(records)]
    cases = {}
    for r in records:
        case = {k: v for k, v in r.items() if k != "id"}
        if isinstance(case.get("result"), dict) and "traceback" in case["result"]:
            case["result"] = {k: v for k, v in case["result"].items() if k != "traceback"}
        cases[r["id"]] = case
    metrics = {
        "schema": SCHEMA_VERSION,
        "suite": spec.get("suite", "custom"),
        "created": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "environment": _environment(),
        "passed": all(g["passed"] for g in gates),
        "counts": gate_counts(gates),
        "gates": gates,
        "cases": cases,
        "replays": replays or {},
    }
    return json.loads(json.dumps(metrics, default=json_default))


def sections(metrics: dict, records: list[dict]) -> list[Section]:
    """The report: the verdict (passes and pinned known limits counted apart, the limits
    listed), the candidates' summary table, replays, then each kind's sections, then every
    gate (failures and known limits first) and the environment (the last two in index.html
    only)."""
    gates = metrics["gates"]
    out = head_sections(metrics, records)
    if metrics["replays"]:
        out.append(Section(None, [
            Text("Meshcat replays of the worst learned cases (self-contained, open from disk; overlays: truth cyan, "
                 "shadow magenta, learned yellow, errors green to red):"),
            Bullets(tuple(Link(k, v) if v.endswith(".html") else f"{k}: no replay ({v})"
                          for k, v in metrics["replays"].items()))], order=6))
    for name, kind in registry().items():
        out += kind.sections(ok_records(records, name))
    ordered = sorted(gates, key=lambda g: 0 if not g["passed"] else 1 if is_known_limit(g) else 2)
    out.append(Section("All gates", [
        Text("Failures first, then the pinned known limits (the threshold is the band the figure is pinned to), then "
             "the gates that pass within their own bound."),
        table(["gate", "passed", "value", "threshold", "what"], [
            (g["name"], ("yes (known limit)" if is_known_limit(g) else "yes") if g["passed"] else "NO",
             shown(g["value"], g["unit"]), shown(g["threshold"], g["unit"]), g["description"]) for g in ordered])],
        order=90, brief=False))
    env = metrics["environment"]
    engines_text = "".join(f", {name} {version}" for name, version in env.get("engines", {}).items())
    out.append(Section(None, [Text(f"{metrics['created']}, commit {env.get('commit', 'unknown')}; Drake {env['drake']}"
                                   f"{engines_text}, Python {env['python']}, {env['cpus']} CPUs ({env.get('platform', 'unknown')}). "
                                   "Timings are indicative: compare ratios within this report, not absolute "
                                   "times across machines.")], order=0.5, brief=True))  # first screen: which code, Drake and machine
    return out


def write_report(run_dir: Path, spec: dict, records: list[dict]) -> dict:
    """Writes metrics.json, summary.md, index.html and figures/ into run_dir; returns the metrics."""
    metrics = build_metrics(spec, records, replay_links(run_dir))
    parts = sections(metrics, records)
    title = f"Validation ({metrics['suite']} suite): {'PASS' if metrics['passed'] else 'FAIL'}"
    for figure in figures(parts):
        write_atomic(run_dir / figure.file, figure.png)
    write_atomic(run_dir / "metrics.json", json.dumps(metrics, indent=1))
    write_atomic(run_dir / "summary.md", to_markdown(title, parts, brief=True))
    write_atomic(run_dir / "index.html", to_html(title, parts))
    return metrics

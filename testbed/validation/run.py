"""`validate`: run (or resume) a suite and write its report.

Run directory layout:
  suite.json     the suite's cases and options (what --resume reads)
  cases/*.json   one result record per case
  replays/<id>/  Meshcat replays of the worst learned cases
  figures/*.png  the report's charts
  metrics.json   all results + gate verdicts (schema: testbed/validation/report_schema.json)
  summary.md     for terminals and CI logs
  index.html     self-contained report (charts embedded)
"""

from __future__ import annotations

import json
import shutil
import time
from pathlib import Path

from learned_contact import sources
from testbed.errors import TestbedError
from testbed.records import write_atomic
from testbed.safe_files import InputFileError, load_json
from testbed.validation import suites
from testbed.validation.cases import Case
from testbed.validation.executors import MAX_RECORD_BYTES, RayConnectionError, execute, load_record
from testbed.validation.replays import write_worst_replays
from testbed.validation.report import SCHEMA_VERSION, write_report


def validate(*, suite_name: str = "default", workers: int = 2, executor: str = "local", address=None,
             resume: str | Path | None = None, out_root: str | Path = "reports", progress: bool = True,
             cases: list[Case] | None = None, replays: int = 2, predictors=()) -> tuple[Path, dict]:
    """Runs (or resumes) a suite and writes the report, with Meshcat replays of the
    `replays` worst learned cases. predictors: more predictors (learned_contact.sources
    strings) added to the learned, closed-loop and query sections, reported beside the
    shipped ones (each is loaded and checked first: a bad one writes nothing). Returns
    (run_dir, metrics)."""
    if predictors and resume is not None:
        raise TestbedError("--predictor with --resume: the resumed run keeps the predictors it started with")
    predictors = _checked_predictors(predictors)
    if resume is not None:
        run_dir = Path(resume)
        spec_path = run_dir / "suite.json"
        if not spec_path.exists():
            raise TestbedError(f"--resume {run_dir}: no suite.json there; expected a run directory made by testbed validate")
        spec = load_json(spec_path, MAX_RECORD_BYTES, "suite file written by testbed validate")
        cases = _cases_of(spec, spec_path)
    else:
        cases = cases if cases is not None else suites.suite(suite_name)
        if predictors:
            cases = suites.with_predictors(cases, predictors)
        run_dir = _new_run_dir(Path(out_root))
        spec = {"schema": SCHEMA_VERSION, "suite": suite_name, "cases": [c.to_dict() for c in cases]}
        write_atomic(run_dir / "suite.json", json.dumps(spec, indent=1))
    if workers < 1:
        raise TestbedError(f"--workers: expected at least 1, got {workers}")
    try:
        execute(cases, run_dir, executor=executor, workers=workers, address=address, progress=progress)
    except RayConnectionError:
        if resume is None:  # nothing ran: leave no half-made run directory behind
            shutil.rmtree(run_dir, ignore_errors=True)
        raise
    records = [load_record(run_dir, c) for c in cases]
    write_worst_replays(run_dir, records, replays)
    metrics = write_report(run_dir, spec, records)
    return run_dir, metrics


def _checked_predictors(predictors) -> list[str]:
    """The predictors as learned_contact.sources strings that workers can load (files as
    absolute paths), each loaded once here so that a bad one fails before anything runs."""
    out = []
    for spec in predictors:
        spec = str(spec)
        if sources.source_of(spec).key in ("onnx", "weights"):
            spec = str(Path(spec).resolve())
        sources.load_predictor(spec)
        out.append(spec)
    labels = [sources.label(p) for p in out]
    if len(set(labels)) != len(labels) or set(labels) & set(sources.SHIPPED_NAMES):
        raise TestbedError(f"--predictor {list(predictors)}: labels {labels} repeat or name a shipped predictor; "
                           "give the files distinct names")
    return out


def _cases_of(spec, path: Path) -> list[Case]:
    """The cases of a suite.json, or InputFileError naming the field that is not a case list."""
    if not isinstance(spec, dict) or not isinstance(spec.get("cases"), list):
        raise InputFileError(path, "cases", "expected a JSON object with a list of cases (a run directory made by testbed validate)")
    cases = []
    for i, c in enumerate(spec["cases"]):
        try:
            cases.append(Case(**c))
        except TypeError as e:
            raise InputFileError(path, f"cases[{i}]", f"expected a case with id, kind and params ({e})") from None
        params = cases[-1].params if isinstance(cases[-1].params, dict) else {}
        named = params.get("predictors") if isinstance(params.get("predictors"), list) else [params.get("predictor")]
        for spec_ in named:
            if isinstance(spec_, str) and sources.source_of(spec_).key == "python":
                raise InputFileError(path, f"cases[{i}].params", f"names the Python model {spec_!r}; a file is data, never "
                                                                 "code: a Python model is accepted only from --predictor "
                                                                 "(run the suite again instead of --resume)")
    return cases


def _new_run_dir(out_root: Path) -> Path:
    """out_root/<time>, or <time>-1, -2, ... when taken; made empty."""
    stamp = time.strftime("%Y%m%d-%H%M%S")
    run_dir = out_root / stamp
    suffix = 1
    while run_dir.exists():
        run_dir = out_root / f"{stamp}-{suffix}"
        suffix += 1
    run_dir.mkdir(parents=True)
    return run_dir

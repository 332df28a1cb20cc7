"""Executors: run cases in worker processes (local pool) or on a Ray cluster.

Each result is written to `<run>/cases/<id>.json` (atomically) as soon as it arrives,
so a killed run loses nothing. Cases of kinds marked `main_process` run after the
pool, in this process, alone on the machine.
"""

from __future__ import annotations

import json
import os
import sys
import time
import traceback
from pathlib import Path

from testbed.errors import OptionalDependencyError, TestbedError
from testbed.progress import progress as progress_bar
from testbed.records import json_default, write_atomic
from testbed.safe_files import InputFileError, check_regular_file, load_json
from testbed.validation.cases import Case, registry

EXECUTORS = ("local", "ray")
MAX_RECORD_BYTES = 64 * 2**20  # [bytes] one cases/<id>.json or suite.json read by --resume (records are kilobytes)


def run_case(case: dict) -> dict:
    """Runs one case (Case.to_dict()) in the current process; never raises (errors
    become results). Returns the result record (see cases/base.py)."""
    start = time.perf_counter()
    try:
        result = registry()[case["kind"]].run(**case["params"])
        status = "ok"
    except Exception as e:  # reported per case; the suite goes on
        result = {"error": f"{type(e).__name__}: {e}".splitlines()[0], "traceback": traceback.format_exc()}
        status = "error"
    return {**case, "status": status, "result": result, "wall_s": time.perf_counter() - start}


def case_path(run_dir: Path, case_id: str) -> Path:
    """Where a case's result record is written."""
    return run_dir / "cases" / f"{case_id}.json"


RECORD_KEYS = ("id", "kind", "params", "status", "result", "wall_s")


def _as_json(value):
    """value as it reads back from a JSON file (tuples become lists)."""
    return json.loads(json.dumps(value, default=json_default))


def load_record(run_dir: Path, case: Case) -> dict | None:
    """The case's saved result record, or None when there is none to use. A file that
    is not a complete record of this case (truncated, corrupt, another case's) is
    reported on stderr and removed, so the case is recomputed."""
    path = case_path(run_dir, case.id)
    if not path.exists():
        return None
    what = "case result record (JSON written by testbed validate)"
    check_regular_file(path, MAX_RECORD_BYTES, what)  # a directory, device, FIFO or huge file: refused, kept
    try:
        record = load_json(path, MAX_RECORD_BYTES, what)
        problem = None
        if not isinstance(record, dict) or any(k not in record for k in RECORD_KEYS):
            problem = f"expected a result record with keys {', '.join(RECORD_KEYS)}"
        elif record["id"] != case.id or record["kind"] != case.kind or record["params"] != _as_json(case.params):
            problem = "it holds another case's result"
    except InputFileError as e:  # not UTF-8, not JSON, a key twice, nested too deeply
        problem = e.problem[:160]
    if problem is None:
        return record
    print(f"testbed: note: {path}: {problem}; recomputing case {case.id}", file=sys.stderr)
    path.unlink()
    return None


def execute(cases: list[Case], run_dir: Path, *, executor: str = "local", workers: int = 2,
            address: str | None = None, progress: bool = True) -> None:
    """Runs the cases without a result file in run_dir/cases/, writing each as it finishes."""
    (run_dir / "cases").mkdir(parents=True, exist_ok=True)
    pending = [c for c in cases if load_record(run_dir, c) is None]
    if not pending:
        return
    bar = None
    if progress:

        bar = progress_bar(total=len(cases), initial=len(cases) - len(pending), desc="validate", unit="case")

    def done(result: dict) -> None:
        write_atomic(case_path(run_dir, result["id"]), json.dumps(result, indent=1, default=json_default))
        if bar is not None:
            bar.set_postfix_str(result["id"])
            bar.update(1)

    if executor not in EXECUTORS:
        raise TestbedError(f"--executor: unknown executor {executor!r}; expected one of: {', '.join(EXECUTORS)}")
    kinds = registry()
    here = [c for c in pending if c.kind in kinds and kinds[c.kind].main_process]
    pooled = [c for c in pending if c not in here]
    map_calls(run_case, [c.to_dict() for c in pooled], done, executor=executor, workers=workers, address=address)
    for case in here:  # after the pool, alone on the machine: their timings are not disturbed
        done(run_case(case.to_dict()))
    if bar is not None:
        bar.close()


def map_calls(fn, items, done, *, executor: str = "local", workers: int = 2, address: str | None = None) -> None:
    """Calls `fn(item)` for every item and `done(result)` as each result arrives (in any order):
    executor 'local', a spawn process pool of `workers` (1: in this process, in order), or 'ray',
    one task of 1 CPU per item on the cluster at `address` (None: a local one, started and
    stopped here). `fn` is a module-level function (workers import it by name); items and
    results are picklable. Validate's cases run through it (run_case); so do other studies' cells."""
    if executor not in EXECUTORS:
        raise TestbedError(f"--executor: unknown executor {executor!r}; expected one of: {', '.join(EXECUTORS)}")
    if executor == "local":
        _execute_local(fn, items, workers, done)
    else:
        _execute_ray(fn, items, address, done)


def _execute_local(fn, items, workers, done) -> None:
    if workers <= 1:
        for item in items:
            done(fn(item))
        return
    import concurrent.futures
    import multiprocessing

    context = multiprocessing.get_context("spawn")  # no fork of a process holding Drake state
    with concurrent.futures.ProcessPoolExecutor(max_workers=workers, mp_context=context) as pool:
        futures = [pool.submit(fn, item) for item in items]
        for future in concurrent.futures.as_completed(futures):
            done(future.result())


class RayConnectionError(TestbedError):
    """`--executor ray --address A` could not reach (or was refused by) the cluster."""

    def __init__(self, address, cause: Exception):
        first = str(cause).strip().splitlines()[0] if str(cause).strip() else type(cause).__name__
        token = os.environ.get("RAY_AUTH_MODE", "") == "token"
        hint = ("the cluster refused this process's token: check RAY_AUTH_TOKEN / ~/.ray/auth_token against the head's"
                if token else
                "if the cluster was started with token authentication (Ray >= 2.60 `ray start --head` with "
                "RAY_AUTH_MODE=token), set RAY_AUTH_MODE=token here too, with the head's token in ~/.ray/auth_token, "
                "RAY_AUTH_TOKEN_PATH or RAY_AUTH_TOKEN")
        super().__init__(f"--address {address}: cannot connect to the Ray cluster ({type(cause).__name__}: {first}); "
                         f"check host:port against what `ray start --head` printed (default port 6379); {hint}")


def _execute_ray(fn, items, address, done) -> None:
    try:
        import ray
    except ImportError:
        raise OptionalDependencyError("ray", "--executor ray", "ray") from None
    started_here = not ray.is_initialized()
    if started_here:
        try:
            ray.init(address=address, include_dashboard=False, log_to_driver=False, ignore_reinit_error=True)
        except (ConnectionError, RuntimeError, ValueError) as e:
            raise RayConnectionError(address, e) from None
    try:
        remote = ray.remote(num_cpus=1)(fn)
        futures = [remote.remote(item) for item in items]
        while futures:
            ready, futures = ray.wait(futures, num_returns=1)
            done(ray.get(ready[0]))
    finally:
        if started_here:
            ray.shutdown()

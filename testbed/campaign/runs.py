"""A campaign's sample runs, random samples or a worst-case search's generations alike: each sample's record
kept in the out dir where one is there (the same overrides, candidate and duration), the others run through
the executor (`map_calls`, validate's testbed.validation.executors.map_calls handed in by the command, a
layer above: a local process pool or Ray; each one checked as a scene file and refused with its field and
drawn value, else judged: sample.run_sample) and written as it arrives; and the search's loop over them (search.maximise proposing, these runs answering)."""

from __future__ import annotations

import json
from pathlib import Path

from testbed.campaign import search
from testbed.campaign.family import Family, as_sample
from testbed.campaign.sample import run_sample
from testbed.campaign.verdict import WORST, summarise
from testbed.records import json_default, write_atomic
from testbed.safe_files import load_json

MAX_RECORD_BYTES = 2**20  # [bytes] one sample's record read back (they are a few kilobytes)
# summarise()'s figures that read the samples as a random draw: not a searched set's
RANDOM_ONLY = ("agreement", "interval_95", "required_lower", "needed", "verdict", "worst")


class SampleRuns:
    """runs(samples) -> {index: record} (module docstring); `what` names a sample in the progress lines."""

    def __init__(self, folder: Path, family_file: Path, candidate: str, duration: float, *, total: int, what: str,
                 executor: str, workers: int, address: str | None, quiet: bool, map_calls):
        self.folder, self.family_file, self.candidate, self.duration = folder, family_file, candidate, duration
        self.total, self.what, self.quiet = total, what, quiet
        self.executor = {"executor": executor, "workers": workers, "address": address}
        self.map_calls = map_calls  # map_calls(fn, items, done, executor=, workers=, address=)
        self.finished: set = set()
        self.reused = 0  # records found in the folder, not rerun

    def saved(self, sample: dict):
        """The sample's record in the folder, or None (none, torn, or another sample's or setting's)."""
        f = self.folder / f"{sample['index']:05d}.json"
        if not f.exists():
            return None
        try:
            record = load_json(f, MAX_RECORD_BYTES, "campaign sample record")
        except Exception:  # noqa: BLE001 - a torn record is recomputed
            return None
        same = (record.get("overrides") == sample["overrides"] and record.get("candidate") == self.candidate
                and record.get("duration_s", self.duration) == self.duration)
        return record if same else None

    def __call__(self, samples: list[dict]) -> dict:
        self.folder.mkdir(parents=True, exist_ok=True)
        records = {s["index"]: r for s in samples if (r := self.saved(s)) is not None}
        self.reused += len(records)
        self.finished.update(records)
        todo = [{"family": str(self.family_file), "sample": s, "candidate": self.candidate, "duration": self.duration}
                for s in samples if s["index"] not in records]

        def done(record: dict) -> None:
            record["candidate"], record["duration_s"] = self.candidate, self.duration
            write_atomic(self.folder / f"{record['index']:05d}.json", json.dumps(record, indent=1, default=json_default))
            records[record["index"]] = record
            self.finished.add(record["index"])
            if not self.quiet:
                state = record["status"] if record["status"] != "ok" else ("agrees" if record["agree"] else "DISAGREES")
                error = f", final error {1e3 * record['final_error_m']:.3g} mm" if record["status"] == "ok" else ""
                print(f"  {self.what} {record['index']}: {state}{error} ({len(self.finished)} of {self.total})", flush=True)

        self.map_calls(run_sample, todo, done, **self.executor)
        return records


def run_search(runs: SampleRuns, family: Family, budget: int, population: int, seed: int) -> tuple[list, dict, dict]:
    """The worst-case search over the family's fields, each generation's samples run by `runs` ({"generation"}
    in each record). Returns (every record in order, the summary: summarise()'s counts without its
    random-draw figures, with the search's verdict, and {"history", "worst": indices, worst first})."""

    def evaluate(vectors: list[dict], first: int, generation: int) -> list[dict]:
        samples = [as_sample(first + j, values, generation=generation) for j, values in enumerate(vectors)]
        got = runs(samples)
        return [got[s["index"]] for s in samples]

    def progress(step: dict) -> None:
        if not runs.quiet:
            best, mean = (f"{1e3 * step[k]:.3g} mm" if step[k] is not None else "-" for k in ("best_so_far", "elite_mean"))
            print(f"  generation {step['generation']}: worst so far {best}, elite mean {mean}", flush=True)

    _, records, history = search.maximise(evaluate, family.varied, budget, seed, population, on_generation=progress)
    summary = {k: v for k, v in summarise(records).items() if k not in RANDOM_ONLY}
    summary["disagree"] = summary["judged"] - summary["agree"]
    # FAIL: a counterexample (a run disagreeing with the truth) or a run that failed; else none was found
    summary["verdict"] = "FAIL" if summary["disagree"] or summary["errors"] else "NONE FOUND"
    return records, summary, {"history": history, "worst": search.worst(records, WORST)}

"""The `defaults` study: container contact settings judged over hard cases, shipped scenes and
real cube tosses (judging.py states each criterion).

`from testbed.studies.defaults import sweep, grid, ...` keeps working: the names of judging.py
are read from it on first use (this `__init__` stays light for the CLI's parser).
"""

from __future__ import annotations

import dataclasses
import json
import time
import typing
from pathlib import Path

from testbed.calibration.data import load_tosses
from testbed.document import to_html, to_markdown
from testbed.drake_support import missing_approximation
from testbed.effects.contact import APPROXIMATIONS as CONTACT_APPROXIMATIONS
from testbed.errors import TestbedError
from testbed.records import write_atomic
from testbed.studies import register
from testbed.studies.base import Study, choices, floats

# The cube tosses shipped in the package (testbed/calibration/cube_tosses/, BSD-3-Clause, DAIRLab);
# the same path as testbed.calibration.data.SHIPPED_TOSSES, spelled out so the CLI's start imports no numpy.
DEFAULT_TOSS_DATA = Path(__file__).resolve().parents[2] / "calibration" / "cube_tosses" / "even.npz"


@dataclasses.dataclass
class DefaultsConfig:
    """The sweep's axes (None: judging.py's full axis): moduli [Pa], approximations (Drake's
    names), margins [m], time_steps [s], stiction_tolerances [m/s]; cases (None: all, or
    near_parallel alone with quick); quick: the small grid and 0.3 s runs; workers: processes;
    toss_data: the real tosses of the cube_tosses case (.npz)."""

    moduli: typing.Optional[typing.List[float]] = None
    approximations: typing.Optional[typing.List[str]] = None
    margins: typing.Optional[typing.List[float]] = None
    time_steps: typing.Optional[typing.List[float]] = None
    stiction_tolerances: typing.Optional[typing.List[float]] = None
    cases: typing.Optional[typing.List[str]] = None
    quick: bool = False
    workers: int = 2
    toss_data: str = str(DEFAULT_TOSS_DATA)


def _code():
    """judging.py, imported on first use (it imports pydrake)."""
    from testbed.studies.defaults import judging

    return judging


def _names(text: str | None) -> list[str] | None:
    return [x.strip() for x in text.split(",")] if text else None


@register
class DefaultsStudy(Study):
    name = "defaults"
    help = "contact settings (modulus, approximation, margin, step, stiction) judged over hard cases and real tosses"
    order = 40
    Config = DefaultsConfig

    def add_arguments(self, group) -> None:
        group.add_argument("--moduli", help="hydroelastic moduli [Pa], comma-separated, e.g. 1e8,1e9 (default: the full grid)")
        group.add_argument("--approximations", help="discrete approximations, e.g. sap,similar")
        group.add_argument("--margins", help="hydroelastic margins [m], e.g. 0,1e-4")
        group.add_argument("--time-steps", help="plant time steps [s], e.g. 1e-3")
        group.add_argument("--stiction-tolerances", help="plant stiction tolerances [m/s] (not SAP's), e.g. 1e-4,1e-6")
        group.add_argument("--cases", help="cases to run (default all: stress cases, shipped scenes, cube_tosses)")
        group.add_argument("--toss-data", default=str(DEFAULT_TOSS_DATA),
                           help="real cube tosses for the toss criterion (default: the shipped even-numbered "
                                "DAIR Lab tosses, testbed/calibration/cube_tosses/even.npz)")

    def configure(self, args) -> DefaultsConfig:
        def numbers(text, option, minimum=None):
            return list(floats(text, option, (), minimum)) if text else None

        return DefaultsConfig(moduli=numbers(args.moduli, "--moduli"), approximations=_names(args.approximations),
                              margins=numbers(args.margins, "--margins", 0.0), time_steps=numbers(args.time_steps, "--time-steps"),
                              stiction_tolerances=numbers(args.stiction_tolerances, "--stiction-tolerances"),
                              cases=_names(args.cases), quick=bool(args.quick), workers=args.workers, toss_data=args.toss_data)

    def run(self, config: DefaultsConfig, out: Path, map_calls=None) -> dict:
        """Checks the axes, the cases and the toss data (TestbedError, nothing written), then
        sweeps, each (setting, case) row appended to <out>/defaults_rows.jsonl as it arrives."""
        d = _code()
        axes = {"moduli": config.moduli or d.MODULI,
                "approximations": choices(",".join(config.approximations or ()), "--approximations",
                                          CONTACT_APPROXIMATIONS, d.APPROXIMATIONS),
                "margins": config.margins if config.margins is not None else d.MARGINS,
                "time_steps": config.time_steps or d.TIME_STEPS,
                "stiction_tolerances": config.stiction_tolerances or d.STICTION_TOLERANCES}
        axes = {k: tuple(v) for k, v in axes.items()}
        missing = [m for m in map(missing_approximation, axes["approximations"]) if m]
        if missing:  # 'tamsi' under Drake >= 1.57: say so before anything runs
            raise TestbedError(f"--approximations: {missing[0]}")
        cases = choices(",".join(config.cases or ()), "--cases", d.CASE_NAMES,
                        ("near_parallel",) if config.quick else d.CASE_NAMES)
        toss_data = Path(config.toss_data) if d.TOSS_CASE in cases else None
        if toss_data is not None:
            load_tosses(toss_data)  # CalibrationDataError (exit 2) before anything is written
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        start, partial = time.perf_counter(), out / "defaults_rows.jsonl"
        partial.write_text("")
        with partial.open("a") as f:  # each (setting, case) row as it arrives: a cut-short sweep keeps its rows
            rows = d.sweep(d.grid(config.quick, **axes), cases, workers=config.workers, toss_data=toss_data,
                           duration=0.3 if config.quick else None,
                           on_row=lambda r: (f.write(json.dumps(r, default=float) + "\n"), f.flush()))
        return {"rows": rows, "summary": d.summarize(rows), "wall_s": time.perf_counter() - start}

    def report(self, result: dict, out: Path) -> list[Path]:
        """defaults.json (rows and summary), defaults.md and defaults.html."""
        out = Path(out)
        sections = _code().report_sections(result["summary"], result["wall_s"])
        return [write_atomic(out / "defaults.json", json.dumps({"rows": result["rows"], "summary": result["summary"]},
                                                               indent=1, default=float)),
                write_atomic(out / "defaults.md", to_markdown("Contact defaults sweep", sections)),
                write_atomic(out / "defaults.html", to_html("Contact defaults sweep", sections))]

    def summary(self, result: dict) -> list[str]:
        sections = _code().report_sections(result["summary"], result["wall_s"])
        return to_markdown("Contact defaults sweep", sections).splitlines()


def __getattr__(name):
    if name.startswith("__") or name == "judging":  # the submodule itself: imported, not forwarded
        raise AttributeError(name)
    return getattr(_code(), name)

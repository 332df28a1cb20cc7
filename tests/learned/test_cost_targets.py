"""The cost targets (learned_contact.evaluation.benchmark.TARGETS): each is met, or it fails
as a pinned known limit within its band (KNOWN_COST_LIMITS), so that a slower predictor
fails here as surely as a faster one that should drop its pin.

The figures are ratios, timed side by side in this process by the benchmark script's own
code (our compiled predictors against Drake's point-pair query, best-of-5 minima), never
absolute times: a shared machine slows both sides alike. Fewer poses than the script's
defaults (512 labelled per distribution, 150 one per call, batches of 2,048) keep it to
seconds; the ratios measured so agree with the script's defaults within the run-to-run
spread the bands allow for.

Both sides are timed in the process's CPU time (time.process_time_ns), not wall time: the calls
are single-threaded (one BLAS thread), so on an idle machine the two clocks agree, and on a
loaded one the time other processes take from the shared cores inflates no side. Measured on
the 2-core development machine with three busy loops beside it, six measurements each: wall
time gave batched paper / kernel 0.14-0.37, batched improved / kernel 1.6-3.9 and the centred
core in C / kernel 0.49-2.8 (two modes: outside both pins' bands, one side descheduled in every
round); CPU time gave 0.32-0.37, 2.27-2.41 and 1.13-1.26, as wall time does on the idle machine
(0.33-0.37, 2.24-2.89, 1.23-1.36). The suite beside the main job and a third CPU job had failed
two of these pins "better than pinned" so. CPU time does not remove every effect of load: beside a
fresh-clone suite and the main job it still measured batched improved / kernel at 1.45-1.54
(idle: 1.98-2.51), the shared core's caches slowing Drake's kernel more than the network; the pins
(learned_contact.evaluation.benchmark.KNOWN_COST_LIMITS, re-pinned to the idle figures) keep their
2x bands for that.

Each ratio judged is also the median of REPEATS independent measurements (under 1 s each): one
that a burst of other work lands on is outvoted by the other two, and a median is as likely to
err high as low, so it favours neither a target nor a pin's lower edge; a change that makes a
predictor slower moves all three.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import pytest

from learned_contact.evaluation import benchmark
from learned_contact.evaluation.benchmark import KNOWN_COST_LIMITS, TARGETS

pytestmark = pytest.mark.timing  # CPU-time ratios: serially, alone on the machine (tests/tiers.py)

REPEATS = 3  # independent measurements per ratio; their median is judged (odd: a median is one of them)


@pytest.fixture(scope="module")
def measured() -> dict:
    """{ratio name: (median, [each measurement])}."""
    from learned_contact.evaluation.cost import one_blas_thread

    args = argparse.Namespace(n=512, single=150, batch=2048)
    with one_blas_thread():
        runs = [benchmark.ratios(benchmark.measure(args, numpy_paths=False, clock=time.process_time_ns), args.batch)
                for _ in range(REPEATS)]
    return {name: (float(np.median([r[name] for r in runs])), [r[name] for r in runs]) for name in runs[0]}


def test_the_judged_ratio_is_the_median_of_the_measurements(measured):
    for name, (ratio, each) in measured.items():
        assert len(each) == REPEATS and ratio == sorted(each)[REPEATS // 2], name


@pytest.mark.parametrize("name", list(TARGETS))
def test_cost_target_is_met_or_within_its_pin(measured, name):
    (ratio, each), target = measured[name], TARGETS[name]
    seen = f"median of {', '.join(f'{r:.3g}' for r in each)}"
    if name not in KNOWN_COST_LIMITS:
        assert ratio <= target, f"{name}: {ratio:.3g} ({seen}), target <= {target:g}"
        return
    figure, (low, high), why = KNOWN_COST_LIMITS[name]
    assert ratio <= high, f"{name}: {ratio:.3g} ({seen}), worse than its pin ({figure:g}, band {low:g}-{high:g})"
    assert ratio >= low, (f"{name}: {ratio:.3g} ({seen}), better than its pin ({figure:g}, band {low:g}-{high:g}): "
                          f"re-pin it, or drop it where the target ({target:g}) is met")
    this_run = " (below the target in this run, within the pin's spread)" if ratio <= target else ""
    pytest.xfail(f"known limit: {name} = {ratio:.3g}{this_run} against the target {target:g} "
                 f"(pinned at {figure:g}): {why}")


def target_missed(name: str, figure: float) -> bool:
    return name in TARGETS and figure > TARGETS[name]


def test_cost_pins_name_unmet_targets_and_bracket_their_figures():
    for name, (figure, (low, high), why) in KNOWN_COST_LIMITS.items():
        assert target_missed(name, figure) and low <= figure <= high, name
        assert high <= 2.0 * figure + 1e-12 and low >= 0.5 * figure - 1e-12, name  # the stated factor of 2
        assert why.strip(), name


def test_verdicts_read_the_pins():
    """verdicts() on synthetic ratios: every target's verdict as the pins say (the script prints these)."""
    rat = {name: 0.5 * target for name, target in TARGETS.items()}
    assert set(benchmark.verdicts(rat).values()) <= {"met", "better than pinned"}
    for name, (figure, (low, high), _) in KNOWN_COST_LIMITS.items():
        assert benchmark.verdicts({**rat, name: figure})[name] == "known limit"
        assert benchmark.verdicts({**rat, name: 1.01 * high})[name] == "worse than pinned"
        assert benchmark.verdicts({**rat, name: 0.99 * low})[name] == "better than pinned"
    free = [name for name in TARGETS if name not in KNOWN_COST_LIMITS]
    for name in free:
        assert benchmark.verdicts({**rat, name: 2.0 * TARGETS[name]})[name] == "NOT met"


def test_side_by_side_reads_the_clock_it_is_given():
    """fastest_side_by_side times each call with the given clock (the CPU-time clock above), its
    rounds interleaved: two functions, two rounds, a clock that reads out a script of ticks."""
    from learned_contact.evaluation.cost import fastest_side_by_side

    ticks = iter([0, 5, 5, 9, 10, 11, 11, 20])  # round 1: f0 5, f1 4; round 2: f0 1, f1 9
    assert fastest_side_by_side([lambda: None, lambda: None], rounds=2, clock=lambda: next(ticks)) == [1.0, 4.0]

"""The paper's own figures (Pentium IV, 1.5 GHz, RAPID, gprof), quoted from its text."""

# The paper's figures (Pentium IV, 1.5 GHz, RAPID, gprof), quoted from its text.
# Table 3: N, "Triangles/face" (the values are per box: 12 N^2), average time [ms].
PAPER_TABLE_3 = {8: (768, 1.10), 10: (1200, 1.47), 12: (1728, 1.85), 14: (2352, 1.94),
                 16: (3072, 2.13), 18: (3888, 2.31), 20: (4800, 2.72), 22: (5808, 2.90)}
# Table 4: N, "Max. test", time of the pattern with the most tests [ms].
PAPER_TABLE_4 = {8: (11233, 11.52), 10: (14323, 15.47), 12: (17911, 19.2), 14: (21789, 23.13),
                 16: (24667, 24.63), 18: (26517, 28.0), 20: (30475, 32.44), 22: (35411, 36.77)}
PAPER_MLP_MS = 0.5  # Section 5: "it takes around 0.5 milliseconds"
HARDWARE = "Pentium IV 1.5 GHz, RAPID, timed with gprof"


def as_metrics() -> dict:
    """The figures as the query study's metrics["paper"]."""
    return {"table3": {str(k): {"triangles": v[0], "avg_ms": v[1]} for k, v in PAPER_TABLE_3.items()},
            "table4": {str(k): {"max_tests": v[0], "worst_ms": v[1]} for k, v in PAPER_TABLE_4.items()},
            "mlp_ms": PAPER_MLP_MS, "hardware": HARDWARE}

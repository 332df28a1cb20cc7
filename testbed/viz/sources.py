"""Where the overlays read each model's answer for one state: the effects' record tables.

A source polls a TableBuilder-like object (`.latest() -> (step, time [s], columns) |
None`) and hands back the rows of the state being drawn.
"""

from __future__ import annotations

# Learned predictions: the `learned_contact` effect's `predictions` or `probe.table`
# (see `learned_source`): an object with .latest() -> (step, time [s], columns) | None.
LEARNED_EFFECT = "learned_contact"
LEARNED_ATTRIBUTE = "predictions"


class TableSource:
    """Rows of a TableBuilder-like object (`.latest() -> (step, time, columns) | None`) for
    one state time: `at(t)` returns the columns if the newest rows are of time t (within
    tol [s]), else None (no rows for that state). `point`/`normal` name the columns
    holding the point [m] and unit normal, renamed to p_W / n_W."""

    def __init__(self, get_table, point: str, normal: str, tol: float):
        self._get_table, self.point, self.normal, self.tol = get_table, point, normal, tol
        self._cache: dict[float, dict] = {}

    def _table(self):
        return self._get_table()

    def poll(self) -> None:
        """Remembers the newest rows (call at every event near a frame, see DiscrepancyOverlay)."""
        table = self._table()
        latest = table.latest() if table is not None else None
        if latest is None:
            return
        _, t, columns = latest
        if self.point not in columns or self.normal not in columns:
            return
        self._cache[round(t, 9)] = {"a": columns["a"], "b": columns["b"], "p_W": columns[self.point], "n_W": columns[self.normal]}
        if len(self._cache) > 4:
            self._cache.pop(next(iter(self._cache)))

    def at(self, t: float) -> dict | None:
        self.poll()
        for key, rows in self._cache.items():
            if abs(key - t) <= self.tol:
                return rows
        return None


def learned_source(effects: dict, tol: float) -> TableSource:
    """Source of the learned predictor's answer, resolved lazily from the effect named
    'learned_contact': its attribute `predictions`, else `probe.table` (a TableBuilder).
    Absent -> no rows. Columns used: a, b (k,) int; p_W_pred (k, 3) [m] contact point in
    W; n_W_pred (k, 3) unit normal a -> b in W; `time` is that of the state predicted for."""

    def table():
        effect = effects.get(LEARNED_EFFECT)
        if effect is None:
            return None
        found = getattr(effect, LEARNED_ATTRIBUTE, None)
        return found if found is not None else getattr(getattr(effect, "probe", None), "table", None)

    return TableSource(table, "p_W_pred", "n_W_pred", tol)

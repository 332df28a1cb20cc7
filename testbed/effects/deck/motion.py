"""The deck's prescribed motion relative to the world and its kinematics in the deck frame D.

Frames. W: the inertial world. D: the deck, the frame the plant is simulated in (the plant's
"world" is D: its ground is the deck). At rest D coincides with W. The ship rolls by phi about
D's x axis and pitches by theta about D's y axis, both about the pivot P (a point fixed in D,
p_DP = `pivot` [m]: the roll centre, e.g. a few metres below the deck), and heaves by h along
W's z:

    R_WD = Rx(phi) Ry(theta),    p_WP = p_DP + h e_z,    p_WDo = p_WP - R_WD p_DP.

Each of phi, theta, h is either a harmonic a sin(2 pi t / T + phase) or a time series
(cubic spline through the samples; held at its end values, with zero rates, outside them),
multiplied by the smooth ramp s(t) = 10 u^3 - 15 u^4 + 6 u^5, u = t / ramp_time (0 before,
1 after): s, s' and s'' are 0 at t = 0, so neither the deck's rate nor its acceleration jumps,
and the ramp's derivatives enter the rates (q' = s' f + s f', q'' = s'' f + 2 s' f' + s f'').
A ramp much shorter than the period is a violent start: with phase 0 it reaches the roll rate
A w within ramp_time, an angular acceleration up to 2 max(s') A w = 3.75 A w / ramp_time, i.e.
0.6 rad/s^2 for 18 deg, 12 s, 1 s ramp (seven times the steady A w^2), 4-9 m/s^2 sideways
10 m above the roll centre. A ship's motion can start instead at the end of a roll (phase
90 deg, ramp_time 0): the deck at rest, so containers at rest on it are at rest in W too.

What the law needs at time t (DeckState): R_WD, the deck's angular velocity Omega_D and
angular acceleration alpha_D (of D in W, expressed in D), and the acceleration of the pivot
a_P_D (of P in W, expressed in D). With R = Rx(phi) Ry(theta):
    Omega_D = Ry^T phi' e_x + theta' e_y,
    alpha_D = Ry^T phi'' e_x + phi' theta' (Ry^T e_x) x e_y + theta'' e_y,
    a_P_D   = R_WD^T h'' e_z.
"""


import dataclasses
import math
import typing

import numpy as np

from testbed.safe_files import load_npz, read_bounded

SERIES_COLUMNS = ("t", "roll", "pitch", "heave")  # [s], [deg], [deg], [m]
MAX_SERIES_BYTES = 16 << 20  # a time-series file is at most 16 MiB (about 400,000 CSV rows)


@dataclasses.dataclass
class Harmonic:
    """a sin(2 pi t / period + phase): amplitude [deg] for roll and pitch, [m] for heave."""

    amplitude: float = 0.0
    period: float = 10.0  # [s]
    phase_deg: float = 0.0  # [deg]


@dataclasses.dataclass(frozen=True)
class DeckState:
    """The deck's kinematics at one time: R_WD (3, 3); Omega_D, alpha_D (3,) [rad/s, rad/s^2]
    (D in W, expressed in D); a_P_D (3,) [m/s^2] the pivot's acceleration in W, expressed in D;
    p_WDo (3,) [m] D's origin in W."""

    R_WD: np.ndarray
    Omega_D: np.ndarray
    alpha_D: np.ndarray
    a_P_D: np.ndarray
    p_WDo: np.ndarray


def smooth_ramp(t: float, ramp_time: float) -> tuple[float, float, float]:
    """(s, s', s'') of the quintic ramp (module docstring) at t [s]; a step to 1 when ramp_time <= 0."""
    if ramp_time <= 0 or t >= ramp_time:
        return 1.0, 0.0, 0.0
    if t <= 0:
        return 0.0, 0.0, 0.0
    u = t / ramp_time
    s = u**3 * (10 - 15 * u + 6 * u * u)
    ds = 30 * u * u * (1 - u) ** 2 / ramp_time
    dds = 60 * u * (1 - u) * (1 - 2 * u) / ramp_time**2
    return s, ds, dds


class TimeSeries:
    """A cubic spline through samples t (n,) [s] (strictly increasing, n >= 2) of
    q (n, 3) = [roll rad, pitch rad, heave m]."""

    def __init__(self, t, q):
        from scipy.interpolate import CubicSpline  # a core dependency (pyproject.toml)

        self.t0, self.t1 = float(t[0]), float(t[-1])
        self._spline = CubicSpline(np.asarray(t, float), np.asarray(q, float), axis=0)

    def __call__(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(q, q', q'') (3,) each at t [s]: held, with zero rates, outside [t0, t1]."""
        if t < self.t0 or t > self.t1:
            q = self._spline(min(max(t, self.t0), self.t1))
            return q, np.zeros(3), np.zeros(3)
        return self._spline(t), self._spline(t, 1), self._spline(t, 2)


def _rx(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _ry(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


class DeckMotion:
    """The prescribed motion (module docstring). harmonics: (roll, pitch, heave) Harmonic;
    series: a TimeSeries replacing them, or None; pivot (3,) p_DP [m]; ramp_time [s]."""

    def __init__(self, harmonics: typing.Sequence[Harmonic], pivot, ramp_time: float, series: TimeSeries | None = None):
        scale = (math.pi / 180.0, math.pi / 180.0, 1.0)  # amplitudes to rad, rad, m
        self._amp = np.array([h.amplitude * k for h, k in zip(harmonics, scale)])
        self._omega = np.array([2 * math.pi / h.period for h in harmonics])  # [rad/s]
        self._phase = np.array([math.radians(h.phase_deg) for h in harmonics])
        self.pivot = np.asarray(pivot, float).reshape(3)
        self.ramp_time = float(ramp_time)
        self.series = series

    @property
    def at_rest(self) -> bool:
        """True when the deck never moves (every amplitude 0, no series)."""
        return self.series is None and not np.any(self._amp)

    def coordinates(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(q, q', q'') (3,) each: [roll rad, pitch rad, heave m] and their rates at t [s], ramp included."""
        if self.series is not None:
            f, df, ddf = self.series(t)
        else:
            arg = self._omega * t + self._phase
            f = self._amp * np.sin(arg)
            df = self._amp * self._omega * np.cos(arg)
            ddf = -self._amp * self._omega**2 * np.sin(arg)
        s, ds, dds = smooth_ramp(t, self.ramp_time)
        return s * f, ds * f + s * df, dds * f + 2 * ds * df + s * ddf

    def state(self, t: float) -> DeckState:
        """The deck's kinematics at t [s] (module docstring for the formulas)."""
        (phi, theta, h), (dphi, dtheta, _), (ddphi, ddtheta, ddh) = self.coordinates(t)
        Ry = _ry(theta)
        R_WD = _rx(phi) @ Ry
        ex_D = Ry.T[:, 0]  # e_x of the roll axis, expressed in D
        e_y = np.array([0.0, 1.0, 0.0])
        Omega_D = dphi * ex_D + dtheta * e_y
        alpha_D = ddphi * ex_D + dphi * dtheta * np.cross(ex_D, e_y) + ddtheta * e_y
        a_P_D = R_WD.T @ np.array([0.0, 0.0, ddh])
        p_WDo = self.pivot + np.array([0.0, 0.0, h]) - R_WD @ self.pivot
        return DeckState(R_WD=R_WD, Omega_D=Omega_D, alpha_D=alpha_D, a_P_D=a_P_D, p_WDo=p_WDo)


def load_series(path, error) -> tuple[np.ndarray, np.ndarray]:
    """(t (n,) [s], q (n, 3) [roll rad, pitch rad, heave m]) from a time-series file: a CSV of
    the columns t [s], roll [deg], pitch [deg], heave [m] (comma separated, '#' comment lines,
    an optional header line of those names) or a .npz holding one 1-D array per column name.
    The file is untrusted data: read bounded (MAX_SERIES_BYTES), parsed by numpy only (no
    pickles). Every problem raises error(problem) (one line; the caller names file and field)."""

    def fail(path_, field, problem):
        return error(f"{field + ': ' if field else ''}{problem}")

    if str(path).lower().endswith(".npz"):
        arrays = load_npz(path, MAX_SERIES_BYTES, 4 * MAX_SERIES_BYTES, "deck time series (.npz)", fail)
        missing = [c for c in SERIES_COLUMNS if c not in arrays]
        if missing:
            raise error(f"has no array {', '.join(missing)}; expected arrays {', '.join(SERIES_COLUMNS)}")
        try:
            columns = [np.asarray(arrays[c], dtype=float) for c in SERIES_COLUMNS]
        except (TypeError, ValueError):
            raise error(f"expected numeric arrays {', '.join(SERIES_COLUMNS)}") from None
        if any(c.ndim != 1 or c.shape != columns[0].shape for c in columns):
            raise error(f"expected 1-D arrays {', '.join(SERIES_COLUMNS)} of one length, got shapes "
                        f"{[list(c.shape) for c in columns]}")
        data = np.column_stack(columns) if columns[0].size else np.zeros((0, 4))
    else:
        raw = read_bounded(path, MAX_SERIES_BYTES, "deck time series (CSV)", fail)
        rows = []
        for number, line in enumerate(raw.decode("utf-8", errors="replace").splitlines(), start=1):
            text = line.split("#", 1)[0].strip()
            if not text:
                continue
            cells = [c.strip() for c in text.split(",")]
            if not rows and [c.lower() for c in cells] == list(SERIES_COLUMNS):
                continue  # the header line
            if len(cells) != 4:
                raise error(f"line {number}: expected 4 comma-separated numbers (t, roll, pitch, heave), got {len(cells)} fields")
            try:
                rows.append([float(c) for c in cells])
            except ValueError:
                raise error(f"line {number}: expected numbers, got {text[:60]!r}") from None
        data = np.array(rows, dtype=float).reshape(-1, 4)
    if len(data) < 2:
        raise error(f"holds {len(data)} samples; expected at least 2 rows of t, roll, pitch, heave")
    bad = ~np.isfinite(data)
    if bad.any():
        row, col = np.argwhere(bad)[0]
        raise error(f"{SERIES_COLUMNS[col]} of sample {row} is {data[row, col]}; expected finite numbers")
    if not np.all(np.diff(data[:, 0]) > 0):
        raise error("t: expected strictly increasing times [s]")
    return data[:, 0], data[:, 1:] * np.array([math.pi / 180.0, math.pi / 180.0, 1.0])

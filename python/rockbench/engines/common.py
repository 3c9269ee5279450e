"""What the MuJoCo and PyBullet engines share: settings tables, the time grid, ground
excitation and the trajectory they return.

Sign conventions are the crate's (``src/lib.rs``): x horizontal, z up, rotations
counter-clockwise positive in the x-z plane (a rotation about -y in a right-handed x-y-z frame),
a positive horizontal ground acceleration moves the ground towards +x. Both engines apply the
ground motion as inertial forces ``-m a_g`` on every block (a time-varying gravity vector), so
the trajectory is relative to the ground as in ``src/trajectory.rs``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np
import numpy.typing as npt

FIELDS = ("x", "z", "phi", "vx", "vz", "omega")


class SettingsError(ValueError):
    """A bad ``[mujoco]`` / ``[pybullet]`` setting: one line naming the field."""


class EngineFailure(RuntimeError):
    """A run the engine cannot go on with (the worker's exit code 4): one line saying why."""


@dataclass(frozen=True)
class Setting:
    """One named engine setting: default, check and meaning."""

    default: Any
    check: Callable[[str, Any], Any]
    doc: str


def positive(name: str, v: Any) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
        raise SettingsError(f"{name}: must be a positive number (got {v!r})")
    return float(v)


def non_negative(name: str, v: Any) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0:
        raise SettingsError(f"{name}: must be a number >= 0 (got {v!r})")
    return float(v)


def fraction(name: str, v: Any) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not 0 <= v <= 1:
        raise SettingsError(f"{name}: must be a number in [0, 1] (got {v!r})")
    return float(v)


# The largest value of a C ``int``: iteration and sub-step counts are passed to the engines as
# one (a larger Python int is an OverflowError in PyBullet, an XML error in MuJoCo).
MAX_C_INT = 2**31 - 1


def positive_int(name: str, v: Any) -> int:
    if isinstance(v, bool) or not isinstance(v, int) or not 1 <= v <= MAX_C_INT:
        raise SettingsError(
            f"{name}: must be a whole number from 1 to {MAX_C_INT} (a C int) (got {v!r})"
        )
    return v


def residual_tolerance(allow_zero: bool) -> Callable[[str, Any], float]:
    """A solver tolerance, a relative residual: below 1 (a tolerance of 1 or more accepts the
    first iterate, whatever its error), above 0 (or at least 0 with ``allow_zero``)."""
    low = ">= 0" if allow_zero else "> 0"

    def check(name: str, v: Any) -> float:
        if (
            isinstance(v, bool)
            or not isinstance(v, (int, float))
            or not math.isfinite(v)
            or v < 0
            or (v == 0 and not allow_zero)
            or v >= 1
        ):
            raise SettingsError(
                f"{name}: must be a relative residual, {low} and < 1 (got {v!r})"
            )
        return float(v)

    return check


def one_of(*choices: str) -> Callable[[str, Any], str]:
    def check(name: str, v: Any) -> str:
        if v not in choices:
            raise SettingsError(f"{name}: must be one of {', '.join(choices)} (got {v!r})")
        return str(v)

    return check


def optional(check: Callable[[str, Any], Any]) -> Callable[[str, Any], Any]:
    def inner(name: str, v: Any) -> Any:
        return None if v is None else check(name, v)

    return inner


def numbers(*lengths: int) -> Callable[[str, Any], list[float]]:
    """A list of finite numbers (or a string of numbers separated by spaces, MuJoCo style)."""

    def check(name: str, v: Any) -> list[float]:
        items = v.split() if isinstance(v, str) else v
        try:
            out = [float(x) for x in items]
        except (TypeError, ValueError):
            raise SettingsError(f"{name}: must be a list of numbers (got {v!r})") from None
        if isinstance(v, (int, float)) or len(out) not in lengths or not all(map(math.isfinite, out)):
            want = " or ".join(str(n) for n in lengths)
            raise SettingsError(f"{name}: must be {want} finite numbers (got {v!r})")
        return out

    return check


def given_or_default(given: bool) -> str:
    """How a setting's value came: written in the scene or the default."""
    return "" if given else ", the default"


def block_dimensions(spec: dict[str, Any]) -> tuple[float, float]:
    """The smallest and the largest in-plane dimension (width or height) of the scene's blocks."""
    dims = [d for b in spec["blocks"] for d in (float(b["width"]), float(b["height"]))]
    return min(dims), max(dims)


def farthest_corner(spec: dict[str, Any], layout: list[dict[str, Any]]) -> float:
    """The largest |x| of a block corner at the start (``layout``: ``Scene.layout()``)."""
    far = 0.0
    for b, st in zip(spec["blocks"], layout):
        c, s = math.cos(st["phi"]), math.sin(st["phi"])
        for dx in (-0.5 * b["width"], 0.5 * b["width"]):
            for dz in (-0.5 * b["height"], 0.5 * b["height"]):
                far = max(far, abs(st["x"] + c * dx - s * dz))
    return far


def check_depth(
    s: dict[str, Any], name: str, given: bool, low: float, low_why: str, high: float, high_why: str
) -> None:
    """``s["depth"]`` (the setting ``name``) within ``[low, high]`` (each bound described): a
    given depth is checked; the default one is brought to the nearer bound when it lies outside
    (the planar motion does not depend on the depth within them)."""
    if not given:
        s["depth"] = min(max(s["depth"], low), high)
    depth = s["depth"]
    if not low <= depth <= high:
        raise SettingsError(
            f"{name}: must be from {low_why} ({low:.6g} m) to {high_why} ({high:.6g} m) "
            f"(got {depth!r}{given_or_default(given)})"
        )


def read_settings(table: str, given: Any, spec: dict[str, Setting]) -> dict[str, Any]:
    """Check a scene's ``[table]`` against ``spec``; return every setting with defaults filled."""
    if given is None:
        given = {}
    if not isinstance(given, dict):
        raise SettingsError(f"{table}: must be a table of settings (got {given!r})")
    unknown = sorted(set(given) - set(spec))
    if unknown:
        raise SettingsError(
            f"{table}.{unknown[0]}: unknown setting (known: {', '.join(sorted(spec))})"
        )
    out = {}
    for name, s in spec.items():
        v = given.get(name, s.default)
        out[name] = s.check(f"{table}.{name}", v) if name in given else v
    return out


# Settings every external engine has: how the harness runs the worker.
HARNESS_SETTINGS = {
    "timeout": Setting(
        600.0,
        positive,
        "Wall-clock limit of one worker run, s: past it the harness kills the worker and "
        "reports a failed run (read by the Rust harness, recorded here).",
    ),
}


@dataclass
class TimeGrid:
    """Engine steps of length ``step``: sample and excitation-update boundaries as step indices.

    Step ``k`` (from boundary ``k - 1`` to ``k``) is ``step`` long, except the last one
    (``n_steps``) when the duration is not a whole number of steps: it is ``last_step`` long
    and ends at the duration, as the native engine's last step does."""

    step: float
    sample_steps: list[int]
    boundaries: list[int]
    duration: float
    last_step: float

    @property
    def n_steps(self) -> int:
        return self.sample_steps[-1]

    @property
    def partial(self) -> bool:
        """Whether the last step is shorter than ``step``."""
        return self.last_step != self.step

    def time(self, k: int) -> float:
        """Time of boundary ``k``: ``k * step``, the duration at the end of a shorter last step."""
        return self.duration if self.partial and k == self.n_steps else k * self.step

    def times(self, ks: Any) -> npt.NDArray[np.float64]:
        """``time`` of each boundary of ``ks``."""
        k = np.asarray(ks)
        t: npt.NDArray[np.float64] = k.astype(float) * self.step
        if self.partial:
            t[k == self.n_steps] = self.duration
        return t

    def step_length(self, k: int) -> float:
        """Length of step ``k`` (ending at boundary ``k``)."""
        return self.last_step if k == self.n_steps else self.step

    @property
    def sample_times(self) -> npt.NDArray[np.float64]:
        return self.times(self.sample_steps)


# At most this many steps in a run (the Rust harness's MAX_STEPS).
MAX_STEPS = 1e9

# A duration within this fraction of a step of a whole number of steps is that whole number
# (the native engine's rule, src/engines/native.rs).
WHOLE_STEP_TOLERANCE = 1e-9


def check_step_resolves(spec: dict[str, Any], step: float, step_name: str) -> None:
    """A step longer than the time scale ``1/p`` of the scene's fastest block (Housner's
    ``p = sqrt(3 g / (4 R))``, ``R`` the half-diagonal) steps over its motion, most likely ms
    given for s: a ``SettingsError`` (the Rust harness's rule, ``check_step`` in
    src/scene/validate.rs)."""
    g = float(spec["gravity"])
    fastest = max(
        (
            (b["name"], math.sqrt(1.5 * g / math.hypot(b["width"], b["height"])))
            for b in spec["blocks"]
        ),
        key=lambda named: named[1],
        default=None,
    )
    if fastest is not None and fastest[1] * step > 1.0:
        name, p = fastest
        raise SettingsError(
            f"{step_name}: {step!r} s is longer than the time scale 1/p = {1.0 / p:.4g} s of block "
            f"`{name}` (p = sqrt(3 g / 4R)): a step would step over its motion (ms given for s?)"
        )


def time_grid(
    duration: float,
    output_interval: float,
    step: float,
    update_interval: float | None,
    step_name: str,
) -> TimeGrid:
    """Samples every ``output_interval`` (rounded to whole steps, at least one step) and at
    ``duration``; excitation updates every ``update_interval`` too (None: only at samples).
    A duration that is not a whole number of steps ends with one shorter step, whose end is
    the duration (``TimeGrid.last_step``); a whole number of steps (within
    ``WHOLE_STEP_TOLERANCE`` of a step) ends at ``n * step``. A ``step`` (the setting
    ``step_name``) longer than the duration, or of more than ``MAX_STEPS`` steps, is a
    ``SettingsError``."""
    if step > duration:
        raise SettingsError(
            f"{step_name}: {step!r} s is larger than the duration ({duration!r} s): "
            "not a single step fits"
        )
    if duration / step > MAX_STEPS:
        raise SettingsError(
            f"{step_name}: duration / step = {duration / step:e} steps; at most {MAX_STEPS:e} "
            "are allowed (a unit slip?)"
        )
    n_total = max(1, math.ceil(duration / step - WHOLE_STEP_TOLERANCE))
    last = duration - (n_total - 1) * step
    if abs(last / step - 1.0) <= WHOLE_STEP_TOLERANCE:
        last = step
    every = max(1, round(output_interval / step))
    samples = list(range(0, n_total, every)) + [n_total]
    bounds = set(samples)
    if update_interval is not None:
        chunk = max(1, round(update_interval / step))
        bounds.update(range(0, n_total, chunk))
    return TimeGrid(step, samples, sorted(bounds), duration, last)


def mean_ground_acceleration(
    scene: Any, times: npt.NDArray[np.float64]
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Exact mean ground acceleration (x, z) over each interval ``[times[k], times[k+1]]``: the
    change of the ground velocity divided by the interval, so the velocity the blocks receive
    over each interval is exact whatever the pulse shape or record (``src/excitation``)."""
    gm = scene.ground_motion(np.ascontiguousarray(times, dtype=float))
    dt = np.diff(times)
    return np.diff(gm["vx"]) / dt, np.diff(gm["vz"]) / dt


def excitation_notes(spec: dict[str, Any]) -> list[str]:
    """Notes on how the scene's excitation was applied."""
    exc = spec.get("excitation") or {}
    if exc.get("applied_as") == "moving-ground":
        return [
            "excitation.applied_as = moving-ground was applied as inertial forces on every "
            "block (the same motion relative to the ground)"
        ]
    return []


@dataclass
class EngineResult:
    """What an engine run produced: samples, settings as used, and provenance."""

    t: npt.NDArray[np.float64]
    names: list[str]
    # shape (samples, blocks, 6): x, z, phi, vx, vz, omega
    states: npt.NDArray[np.float64]
    settings: dict[str, Any]
    engine_version: str
    steps: int
    notes: list[str] = field(default_factory=list)
    extra: dict[str, Any] = field(default_factory=dict)

    def write_csv(self, path: str) -> None:
        """``trajectory.csv`` with the columns of ``src/trajectory.rs``."""
        header = ["t"] + [f"{n}_{f}" for n in self.names for f in FIELDS]
        data = np.column_stack([self.t, self.states.reshape(len(self.t), -1)])
        np.savetxt(path, data, delimiter=",", header=",".join(header), comments="", fmt="%.17g")


def first_non_finite(t: npt.NDArray[np.float64], states: npt.NDArray[np.float64]) -> float | None:
    """Time of the first sample with a NaN or infinite value, if any."""
    bad = ~np.isfinite(states.reshape(len(t), -1)).all(axis=1)
    return float(t[np.argmax(bad)]) if bad.any() else None


class EarlyStop:
    """The early-stop rule of a fragility run (``src/fragility/early.rs``, ``EarlyStopSpec``,
    read from the worker's ``--early-stop`` JSON), checked by the engine after every excitation
    update with the blocks' states relative to the ground.

    Overturned: a block's rotation relative to its support reaches ``on_side``. At rest: every
    block still (``|vx|``, ``|vz|``, ``|omega| size`` below ``rest_speed``) and upright (rotation
    relative to its support below ``upright``) for ``rest_window`` without a break, and the rest of
    the record below the static threshold of the stack where it rests (``stack``; without one,
    the end of the record). ``Monitor`` in ``src/fragility/early.rs`` is the same rule.
    """

    def __init__(self, spec: dict[str, Any]) -> None:
        self.spec = spec
        self.supports = [-1 if s is None else int(s) for s in spec["supports"]]
        self.size = np.asarray(spec["size"], dtype=float)
        self.quiet_from = self.quiet(spec["upright_x"])
        self.moving_at = 0.0
        self.rested = False

    def threshold(self, xs: Any) -> float:
        """Static threshold (fraction of g) of the column stack with centres ``xs``."""
        st = self.spec["stack"]
        w, h, m, mu = st["width"], st["height"], st["mass"], st["friction"]
        n = len(w)
        base = [0.0] * n
        for i in range(1, n):
            base[i] = base[i - 1] + h[i - 1]
        thr = math.inf
        for i in range(n):
            lo, hi = xs[i] - 0.5 * w[i], xs[i] + 0.5 * w[i]
            if i > 0:
                lo = max(lo, xs[i - 1] - 0.5 * w[i - 1])
                hi = min(hi, xs[i - 1] + 0.5 * w[i - 1])
            mt = mx = mz = 0.0
            for k in range(i, n):
                mt += m[k]
                mx += m[k] * xs[k]
                mz += m[k] * (base[k] + 0.5 * h[k] - base[i])
            xc, zc = mx / mt, mz / mt
            d = min(xc - lo, hi - xc)
            if d <= 0.0:
                return 0.0
            thr = min(thr, d / zc, mu[i])
        return thr

    def quiet_after(self, a: float) -> float:
        """The time after which the rest of the record stays below ``a`` (m/s^2)."""
        for peak, t in self.spec["load"]:
            if peak >= a:
                return float(t)
        return 0.0

    def quiet(self, xs: Any) -> float:
        s = self.spec
        if s["stack"] is None:
            return float(s["record_end"])
        return min(self.quiet_after(self.threshold(xs) * s["gravity"]), float(s["record_end"]))

    def check(self, t: float, states: npt.NDArray[np.float64]) -> str | None:
        """``"overturned"``, ``"at-rest"`` or None for the states (blocks x 6) at time ``t``."""
        s = self.spec
        phi = states[:, 2]
        rel = np.array([phi[i] - (0.0 if j < 0 else phi[j]) for i, j in enumerate(self.supports)])
        if (np.abs(rel) >= s["on_side"]).any():
            return "overturned"
        v = s["rest_speed"]
        calm = (
            (np.abs(states[:, 3]) < v).all()
            and (np.abs(states[:, 4]) < v).all()
            and (np.abs(states[:, 5] * self.size) < v).all()
            and (np.abs(rel) < s["upright"]).all()
        )
        if not calm:
            self.moving_at = t
            self.rested = False
            return None
        if t - self.moving_at >= s["rest_window"] - 1e-9:
            if not self.rested and t <= s["record_end"]:
                # Resting where it is now (it may have slid): the threshold of that layout.
                self.quiet_from = self.quiet(states[:, 0])
            self.rested = True
            if t > self.quiet_from:
                return "at-rest"
        return None

"""Type stubs of tandem's native module (the Rust part of the package)."""

from os import PathLike
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

class ScenarioError(ValueError):
    """Bad input: a scenario, a field override, a sweep, an argument.

    ``str(e)`` is the command line's message (file, line, column and an excerpt where the input
    is a file); ``path`` is the scenario field it concerns (``"controller.nn.k1"``) or None;
    ``file`` how the input is named (a path, ``"embedded scenario `paper`"``,
    ``"scenario text"``) or None.
    """

    message: str
    path: Optional[str]
    file: Optional[str]

class ScenarioWarning(UserWarning):
    """A set-up warning of a scenario (the command line prints the same text)."""

TomlValue = Union[bool, int, float, str, Sequence[Any], Mapping[str, Any], np.ndarray, np.generic]

class Scenario:
    """What one run simulates: arms, object, path, controller, timing, seed.

    Planar (the paper's arms in the plane) or spatial (``kind == "spatial"``: arms with robot
    models carrying a box on six outputs, e.g. ``"dual-ur5"``); the API is the same for both.
    Immutable (``with_`` returns a new one), comparable (same name and resolved scenario) and
    picklable (as its resolved TOML).
    """

    @staticmethod
    def preset(name: str) -> Scenario:
        """An embedded scenario by name (see :func:`presets`), e.g. ``"paper"``, ``"dual-ur5"``."""
    @staticmethod
    def from_toml(text: str, name: Optional[str] = None) -> Scenario:
        """A scenario from TOML text (planar or spatial: a spatial file's arms name a robot
        model), the format of ``tandem scenario show paper`` or ``Scenario.to_toml()``."""
    @staticmethod
    def load(path: Union[str, PathLike[str]]) -> Scenario:
        """A scenario file (TOML); named after the file's stem unless it has ``name``."""
    def with_(
        self, overrides: Optional[Mapping[str, TomlValue]] = None, /, **fields: TomlValue
    ) -> Scenario:
        """A new scenario with fields set by path (``"controller.nn.k1"``, ``"object.mass"``,
        ``"arms[0].links[1].mass"``; spatial: ``"controller.nn.design.k1"``,
        ``"arms[0].base.position"``), each checked by every validation of a run; a rejected
        value raises :exc:`ScenarioError` with its ``path``."""
    def get(self, path: str) -> Any:
        """The value of a field of the resolved scenario; KeyError if there is none."""
    def run(
        self,
        duration: Optional[float] = None,
        seed: Optional[int] = None,
        controller: Optional[Any] = None,
    ) -> Run:
        """Simulate (GIL released); ``duration``/``seed`` override ``run.duration``/``run.seed``.

        ``controller``: your law in tandem's loop, ``f(t, q, qd, wrenches) -> tau`` or an object
        with ``tick(t, q, qd, wrenches) -> tau`` (and optionally ``start(t0, q, qd, wrenches)``),
        e.g. a :class:`Controller` or a :class:`JointPD`. It reads what ``Controller.tick`` reads
        (tandem's sensors), in arrays reused every tick and read-only (copy what you keep). The
        run is scored on the true state (summary ``controller = "external"``). An exception it
        raises is raised here, with a note of the time; non-finite torques are ``Run.fault``."""
    def plant(self) -> Plant:
        """The scenario's plant (true arms and object, start pose at rest, sensors, seed,
        disturbance, timing), to step with your own torques: see :class:`Plant`."""
    def controller(self, law: Optional[str] = None) -> Controller:
        """The scenario's controller, built exactly as ``tandem run`` builds it (every
        validation; the spatial NN law's design-inertia probe), to step with your own
        measurements. ``law``: ``"nn"``, ``"pd"`` (the file's ``controller.pd`` as it is, as
        ``--controller pd``), ``"pd-gravity"`` (PD with the model's gravity), ``"ctc"``; None:
        the scenario's. A torque replay is not a controller (:exc:`ScenarioError`)."""
    def to_toml(self) -> str:
        """The resolved scenario as TOML (every default written out; re-runnable)."""
    @property
    def name(self) -> str: ...
    @property
    def kind(self) -> str:
        """``"planar"`` or ``"spatial"``."""
    @property
    def description(self) -> str: ...
    @property
    def duration(self) -> float:
        """``run.duration``, s."""
    @property
    def seed(self) -> int:
        """``run.seed``."""
    @property
    def label(self) -> str:
        """The controller label, e.g. ``"NN (tuned)"`` (spatial: ``"NN"``, ``"PD + gravity"``)."""
    @property
    def warnings(self) -> List[str]: ...
    def __eq__(self, other: object) -> bool: ...

class Controller:
    """A scenario's controller (:meth:`Scenario.controller`), stepped by you.

    Loop: ``start(t0, q, qd, wrenches)`` once with the first readings, then
    ``tick(t, q, qd, wrenches)`` once per ``control_period`` from ``t0`` on (the first tick at
    ``t0`` itself); the controller integrates its own states over ``control_period`` per tick.
    Inputs are float64: ``q`` (rad) and ``qd`` (rad/s) of shape ``(n_q,)``, stacked over arms in
    the scenario's order; ``wrenches`` of shape ``wrench_shape``: planar ``(n_arms, 2)``, the
    object's force on each end effector in world axes (N); spatial ``(n_arms, 6)``, the
    object's wrench ``[fx, fy, fz, tx, ty, tz]`` on each tool, about the tool origin, in the
    tool's axes (N, N m), as a wrist force/torque sensor at the tool reads it. A wrong shape,
    NaN or infinity raises ValueError naming the argument and the shape expected; ``tick``
    before ``start`` raises RuntimeError; a time that goes back raises ValueError.
    """

    @property
    def n_q(self) -> int:
        """Joints, all arms."""
    @property
    def n_arms(self) -> int: ...
    @property
    def wrench_shape(self) -> Tuple[int, int]:
        """``(n_arms, 2)`` planar, ``(n_arms, 6)`` spatial."""
    @property
    def control_period(self) -> float:
        """The scenario's ``run.control_period``, s: tick once per period."""
    @property
    def law(self) -> str:
        """``"nn"``, ``"pd"``, ``"pd-gravity"`` or ``"ctc"`` (the scenario's when none was given)."""
    def start_state(self) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """``(q, qd, wrenches)`` where the scenario's run starts (at rest on the start pose,
        zero torque held) and what its sensors read there: what ``tandem run`` starts with."""
    def start(self, t: float, q: npt.ArrayLike, qd: npt.ArrayLike, wrenches: npt.ArrayLike) -> None:
        """Start (or restart) at ``t``: admittance at rest, wrench filters at the expected
        wrenches, the pose estimate from ``q``. Adaptive weights are kept (``reset()``).
        Sensor sanity check: readings whose forces do not sum (world axes) to the object's
        weight within 25 % (a robot holding it at rest), other than tandem's own start
        (``start_state()``), give a :class:`ScenarioWarning` naming the arms, their readings and
        the hold's, and an arm whose sign looks flipped or whose reading looks in world axes."""
    def tick(
        self,
        t: float,
        q: npt.ArrayLike,
        qd: npt.ArrayLike,
        wrenches: npt.ArrayLike,
        out: Optional[npt.NDArray[np.float64]] = None,
    ) -> npt.NDArray[np.float64]:
        """One tick: the joint torques (N m, ``(n_q,)``), written into ``out`` (writeable,
        contiguous float64 of shape ``(n_q,)``) and returned when given, else a new array.
        Never NaN."""
    @property
    def record(self) -> Dict[str, Any]:
        """The last tick's internals: arrays (3 outputs planar, 6 spatial) ``x_hat``,
        ``xd_hat``, ``x_d``, ``x_r``, ``xd_r``, ``z1``, ``z2``, ``alpha``, ``alpha_dot``,
        ``wrench`` (the object wrench commanded, the log's ``tau.*``), ``w_norm``; floats ``Q``,
        ``margin`` (spatial also ``angle_error``); spatial ``internal`` ``(n_arms, 6)``; bools
        ``barrier_hit``, ``torque_clipped``, ``non_finite``; ``events`` (counts since start)."""
    def reset(self) -> None:
        """Back to the controller as built (weights zeroed); ``start`` again before ``tick``."""

class Plant:
    """A scenario's plant (:meth:`Scenario.plant`), stepped by you.

    Loop: ``q, qd, w = plant.sensors()``; your law; ``plant.step(tau)``. ``step`` holds the
    torques over ``dt`` (whole control periods, default one) with the scenario's plant step;
    the readings are taken with the previous torques held, as in a run. Numerical trouble
    raises :exc:`PlantFault` (time and last good state); the plant then refuses to step."""

    @property
    def n_q(self) -> int: ...
    @property
    def n_arms(self) -> int: ...
    @property
    def wrench_shape(self) -> Tuple[int, int]: ...
    @property
    def control_period(self) -> float: ...
    @property
    def time(self) -> float:
        """Simulated time, s."""
    @property
    def state(self) -> Dict[str, npt.NDArray[np.float64]]:
        """True ``q``, ``qd``, ``object_pose`` (planar ``(x, y, θ)``; spatial ``(x, y, z, qw,
        qx, qy, qz)``), ``object_twist`` (planar ``(ẋ, ẏ, θ̇)``; spatial ``(v, ω)``, world)."""
    def sensors(self) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """``(q, qd, wrenches)`` as the sensors read them now: the arguments of ``Controller.tick``."""
    @property
    def wrenches(self) -> npt.NDArray[np.float64]:
        """True grasp wrenches (the object's on each arm), world axes, ``wrench_shape``."""
    @property
    def residual(self) -> Tuple[float, float]:
        """Grasp-constraint residual: spatial ``(m, rad)``; planar ``(m, m/s)``."""
    @property
    def energy(self) -> Dict[str, float]:
        """``kinetic``, ``potential``, ``total`` (J)."""
    def holding_torques(self) -> npt.NDArray[np.float64]:
        """Spatial: torques that hold the current configuration at rest (gravity, equal share of
        the object's weight). Planar: NotImplementedError."""
    def step(self, tau: npt.ArrayLike, dt: Optional[float] = None) -> None:
        """Hold ``tau`` (N m, ``(n_q,)``, finite) over ``dt`` s (a whole number of control
        periods; default one). ValueError naming ``tau`` or ``dt``; :exc:`PlantFault`."""
    def hold(self, tau: npt.ArrayLike) -> None:
        """Hold ``tau`` from now on without stepping (a robot holding its pose before your
        loop); ``sensors()`` reads again with it held."""
    def reset(self) -> None:
        """Back to the start."""

class JointPD:
    """``tau = kp * (q_ref - q) - kd * qd + tau_ff`` per joint, in Rust: a baseline law for
    ``Scenario.run(controller=...)``."""

    def __init__(self, kp: npt.ArrayLike, kd: npt.ArrayLike, q_ref: npt.ArrayLike, tau_ff: npt.ArrayLike) -> None: ...

class PlantFault(RuntimeError):
    """The plant failed numerically; ``t`` is the time (s)."""

    t: float

class Run:
    """One finished run; picklable (the summary and the samples travel)."""

    @property
    def summary(self) -> Dict[str, Any]:
        """The command line's ``summary.json``, planar or spatial (``timing`` holds the loop's
        wall time)."""
    @property
    def timeseries(self) -> Dict[str, npt.NDArray[np.float64]]:
        """Column name -> read-only float64 array (views of the run's memory, no copy), the
        columns of ``timeseries.csv`` (spatial: the log's, then ``x_1.*`` and ``F_tool{i}.*``)."""
    @property
    def units(self) -> Dict[str, str]:
        """Column name -> unit."""
    @property
    def scenario(self) -> Scenario:
        """The scenario as run (duration and seed overrides applied)."""
    @property
    def fault(self) -> Optional[str]:
        """Why the run stopped early, or None."""
    @property
    def ok(self) -> bool:
        """True when the run completed without a fault."""
    def to_pandas(self) -> Any:
        """The time series as a pandas DataFrame (units in ``df.attrs["units"]``)."""
    def write(
        self, dir: Union[str, PathLike[str]], force: bool = False, figures: bool = True
    ) -> str:
        """Write the command line's output folder (atomically); returns its path."""
    def __len__(self) -> int:
        """Logged rows."""
    @staticmethod
    def _from_state(
        scenario_toml: str, summary: str, names: List[str], units: List[str], data: bytes
    ) -> Run: ...

def rollout(
    scenarios: Union[Scenario, Sequence[Scenario]],
    seeds: Optional[Sequence[int]] = None,
    threads: Optional[int] = None,
    duration: Optional[float] = None,
) -> List[Run]:
    """Closed-loop runs in Rust on ``threads`` threads with the GIL released, in input order
    (planar and spatial scenarios may be mixed)."""

def presets() -> List[str]:
    """The embedded scenarios' names: the planar ones, then the spatial ones."""

def _sweep_csv(
    spec: Union[str, PathLike[str], Mapping[str, Any]],
    shard: Union[None, str, Tuple[int, int]] = None,
    threads: Optional[int] = None,
) -> Tuple[str, List[str]]: ...

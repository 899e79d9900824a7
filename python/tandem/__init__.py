"""tandem: cooperative manipulation from Python.

Several planar arms hold one rigid object and carry it along a path, under the paper's admittance
+ adaptive neural-network controller (or PD, computed torque, a torque replay); or, in a spatial
scenario (``"dual-ur5"``, ``"dual-franka"``), arms with robot models carry a box on six outputs. This package binds
the same Rust code as the ``tandem`` command line: a scenario means the same thing, runs to the
same numbers and gets the same error messages.

>>> import tandem
>>> sc = tandem.Scenario.preset("paper").with_(**{"controller.nn.k1": [6, 6, 6]})
>>> run = sc.run(duration=2.0)
>>> run.summary["rms_z1"] < 0.01, run.timeseries["x_o.x"].shape, run.summary["gains"]
(True, (67,), 'tuned+overrides')

* :class:`Scenario` -- ``preset``, ``from_toml``, ``load``, ``with_`` (field paths, as in
  sweeps), ``run``, ``to_toml``; picklable.
* :class:`Controller` -- ``Scenario.controller(law)``: the run's controller, stepped by you
  (``start``, ``tick(t, q, qd, wrenches, out=)``, ``record``, ``reset``, ``start_state``).
* :class:`Plant` -- ``Scenario.plant()``: the run's plant, stepped by you (``step(tau, dt)``,
  ``sensors()``, ``state``, ``wrenches``, ``residual``, ``energy``); :exc:`PlantFault`.
* ``Scenario.run(controller=f)`` -- your law ``f(t, q, qd, wrenches) -> tau`` (or an object with
  ``tick``, e.g. a :class:`Controller`, or a :class:`JointPD`) in tandem's loop, scored as a run.
* :class:`Run` -- ``summary`` (dict), ``timeseries`` (dict of NumPy arrays), ``to_pandas()``,
  ``write(dir)``; picklable.
* :func:`rollout` -- many closed-loop runs in Rust, in parallel, with the GIL released.
* :func:`sweep` -- a sweep file (or dict) run as ``tandem sweep`` runs it; a DataFrame.
* :exc:`ScenarioError` -- bad input, with the command line's message and the field ``path``.
"""

from __future__ import annotations

import csv
import io
import os
from typing import Any, Dict, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from ._tandem import (
    Controller,
    JointPD,
    Plant,
    PlantFault,
    Run,
    Scenario,
    ScenarioError,
    ScenarioWarning,
    __version__,
    _sweep_csv,
    presets,
    rollout,
)

__all__ = [
    "Controller",
    "JointPD",
    "Plant",
    "PlantFault",
    "Run",
    "Scenario",
    "ScenarioError",
    "ScenarioWarning",
    "__version__",
    "presets",
    "rollout",
    "sweep",
]


def sweep(
    spec: Union[str, "os.PathLike[str]", Mapping[str, Any]],
    shard: Union[None, str, Tuple[int, int]] = None,
    threads: Optional[int] = None,
    frame: Optional[bool] = None,
) -> Any:
    """Run a parameter sweep, as ``tandem sweep`` does, and return its table (``runs.csv``).

    ``spec`` is the path of a sweep file (see ``docs/sweeps.md``) or its content as a dict, e.g.
    ``{"base": "paper", "duration": 10, "vary": {"controller.nn.k1": {"grid": [[4, 4, 4],
    [8, 8, 8]]}}}``. ``shard`` runs one shard: ``"I/N"``, ``(I, N)`` or ``"slurm"`` (from the
    ``SLURM_ARRAY_TASK_*`` variables). ``threads`` defaults to every core.

    Returns a pandas DataFrame (the same as ``pandas.read_csv`` of the command line's
    ``runs.csv``: one row per run, index, seed, the varied values, status, message, metrics) when
    pandas is installed and ``frame`` is not False; otherwise a dict of column name -> NumPy array
    (integer, float, or str columns; an empty cell -- a metric a run does not have -- is NaN in a
    float column). Bad input raises :exc:`ScenarioError` with the command line's message.
    """
    text, header = _sweep_csv(spec, shard, threads)
    if frame is not False:
        try:
            import pandas as pd
        except ImportError:
            if frame:
                raise
        else:
            # Text columns (status, message, vector values) stay text even when empty.
            return pd.read_csv(io.StringIO(text), keep_default_na=True)
    rows = list(csv.reader(io.StringIO(text)))[1:]
    columns: Dict[str, np.ndarray] = {}
    for j, name in enumerate(header):
        columns[name] = _column([r[j] for r in rows])
    return columns


def _column(cells: Sequence[str]) -> np.ndarray:
    """Typed NumPy array of CSV cells: int64, float64 (empty -> NaN), else str."""
    try:
        return np.array([int(c) for c in cells], dtype=np.int64)
    except ValueError:
        pass
    try:
        return np.array([float(c) if c != "" else np.nan for c in cells], dtype=np.float64)
    except ValueError:
        return np.array(list(cells), dtype=str)


def _restore_scenario(text: str) -> Scenario:
    """Unpickle a Scenario (its resolved TOML)."""
    return Scenario.from_toml(text)


def _restore_run(
    scenario_toml: str, summary: str, names: list, units: list, data: bytes
) -> Run:
    """Unpickle a Run (scenario TOML, summary JSON, columns and their samples)."""
    return Run._from_state(scenario_toml, summary, names, units, data)


def _restore_controller(scenario: Scenario, law: Optional[str]) -> Controller:
    """Unpickle a Controller: the scenario's, as built (not started)."""
    return scenario.controller(law)

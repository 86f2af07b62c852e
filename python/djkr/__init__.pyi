"""djkr: dynamic JKR adhesion of a sphere on a vibrating viscoelastic substrate.

Every function gives what the command of the same name reports, in SI units: ``cycle``,
``pulloff`` and ``validate`` the object of ``--json``; ``resonance`` and ``sweep`` the columns
of ``resonance.csv`` and ``sweep.csv``; ``run`` the datasets of ``run.h5`` and the content of
``summary.json``.

A *scenario* is a path (``str`` without a line break, or ``os.PathLike``), a TOML string, or a
dict with the file's structure (``{"version": 1, "material": {...}, "stage": [{...}]}``).
``set`` is a dict of ``--set`` overrides, ``{"base.amplitude": "30um", "stage[3].speed": 1e-3}``.
Quantities are SI floats or strings with units (``"400Hz"``, ``"0.5mm"``).

Bad input raises ``ScenarioError`` (a ``ValueError``) with the command line's message, an
argument of the wrong type ``ScenarioTypeError`` (both a ``ScenarioError`` and a ``TypeError``).
No input takes the interpreter down: a scenario dict or TOML string larger than a scenario file
may be (1 MiB, once written as TOML), nested more than 80 deep (the TOML parser's limit) or
containing itself is refused with ``ScenarioError``, and so is ``set=`` or ``grid=`` of more
than 1 MiB of text. A run that a budget stopped (``solver.max_steps``, ``max_wall_s``,
``max_events``, ``max_memory``) or that failed mid-way raises ``RuntimeError`` whose ``run``
attribute is the ``Run`` up to there (``e.run.summary["status"]`` is ``"stopped"`` or
``"failed"``, with ``"reason"`` and ``"message"``). Long calls release the interpreter lock and
stop within a fraction of a second on Ctrl-C (``KeyboardInterrupt``; with ``out``, the folder is
written with reason ``SIGINT``).
"""

import os
from typing import Any, Dict, List, Literal, Mapping, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str
__all__: List[str]

Quantity = Union[float, int, str]
Scenario = Union[str, "os.PathLike[str]", Mapping[str, Any]]
SetValue = Union[float, int, str, bool]

class ScenarioError(ValueError):
    """Bad input: a scenario, an override, an argument or a grid that djkr refuses."""

class ScenarioTypeError(ScenarioError, TypeError):
    """Bad input of the wrong type (a list where a number goes, an int where a dict goes):
    caught by ``except ScenarioError`` and by ``except TypeError``."""

class Run:
    """A time-domain run held in memory: the datasets of ``run.h5`` value for value."""

    t: npt.NDArray[np.float64]
    """Time (s)."""
    x_s: npt.NDArray[np.float64]
    """Sphere position, down positive (m)."""
    v_s: npt.NDArray[np.float64]
    """Sphere velocity, down positive (m/s)."""
    x_b: npt.NDArray[np.float64]
    """Base displacement, up positive (m)."""
    x_k: npt.NDArray[np.float64]
    """Far end of the holding spring, down positive (m)."""
    delta: npt.NDArray[np.float64]
    """Indentation x_s + x_b, positive compresses (m)."""
    a: npt.NDArray[np.float64]
    """Contact radius, 0 out of contact (m)."""
    a_dot: npt.NDArray[np.float64]
    """Contact-radius rate, healing positive (m/s)."""
    F: npt.NDArray[np.float64]
    """Contact force on the sphere, compressive positive (N)."""
    G: npt.NDArray[np.float64]
    """Energy release rate, signed (J/m^2)."""
    w: npt.NDArray[np.float64]
    """Work of adhesion w(a_dot) (J/m^2)."""
    stage: npt.NDArray[np.int64]
    """Index of the protocol stage, from 0."""
    segment: npt.NDArray[np.int64]
    """Index of the gap-free stretch each sample belongs to: 0 from the start, +1 after each
    gap (a span envelope following skipped). Never join samples of different segments."""
    gaps: Dict[str, npt.NDArray[Any]]
    """The gaps of the time series, the HDF5 ``gaps/`` group: ``t_start`` and ``t_end`` (s, the
    samples either side) and ``periods`` (base periods skipped), one entry per gap."""
    cycles: Dict[str, npt.NDArray[Any]]
    """Per-period records: the datasets of the HDF5 ``cycles/`` group (``index``, ``stage``,
    ``t_start``, ``t_end``, ``force_mean``, ...)."""
    @property
    def events(self) -> List[Dict[str, Any]]:
        """Every event in time order: ``kind``, ``time`` (s), ``stage`` and ``state`` (the
        time-series values at the event)."""
    @property
    def summary(self) -> Dict[str, Any]:
        """The content of ``summary.json`` (without ``out=``: ``files`` and ``file_bytes``
        empty)."""
    def to_pandas(self) -> Any:
        """The time series as a ``pandas.DataFrame``, columns ``t`` ... ``w``, ``stage``,
        ``segment`` (needs pandas)."""
    def __len__(self) -> int: ...

def run(
    scenario: Scenario,
    set: Optional[Mapping[str, SetValue]] = None,
    out: Optional[Union[str, "os.PathLike[str]"]] = None,
) -> Run:
    """Run a scenario (``djkr run``); with ``out``, also write the run folder ``djkr run --out``
    writes (``run.h5``, ``summary.json``, and the CSV files and figure its ``[output]`` asks
    for).

    The run is held in memory. Where its sample count is known before it starts
    (``[output] sample_rate`` > 0 over the stages with a ``duration``), a run whose samples
    would take more than ``solver.max_memory`` (default 2 GiB, at 216 bytes a sample) is refused
    at once with ``ScenarioError`` naming ``output.sample_rate``, the durations and the
    estimate; lower the rate or raise ``solver.max_memory``. Otherwise the samples, events and
    period records held are capped at ``solver.max_memory`` while it runs: a run that would pass
    it stops with reason ``"memory"``. A run stopped by a budget or failed mid-way raises
    ``RuntimeError`` with the partial ``Run`` as its ``run`` attribute (and, with ``out``, its
    folder written with the status)."""

def cycle(
    freq: Quantity,
    a_mean: Quantity,
    a_amp: Quantity,
    material: Optional[Scenario] = None,
) -> Dict[str, Any]:
    """One imposed-area cycle a(t) = a_mean + a_amp sin(2 pi freq t) (``djkr cycle --json``):
    ``a_mean``, ``a_mean_imposed``, ``a_amp``, ``delta_mean``, ``delta_amp``, ``delta_sin``,
    ``delta_cos``, ``force_mean``, ``contact_fraction``, ``notes``. ``material``: a scenario
    whose ``[material]`` and ``[adhesion]`` are used (default: the paper's Fig. 2 set)."""

def pulloff(
    freq: Quantity,
    a_amp: Quantity,
    method: Literal["exact", "approx", "yi"] = "exact",
    beta: Optional[Quantity] = None,
    material: Optional[Scenario] = None,
) -> Dict[str, Any]:
    """The pull-off for a vibration (``djkr pulloff --json``): ``method``, ``a_mean``,
    ``delta_mean``, ``delta_amp``, ``force``, ``amplification``, ``notes``. ``beta`` (approx
    only) defaults to 2.5."""

def validate(
    scenario: Scenario,
    set: Optional[Mapping[str, SetValue]] = None,
) -> Dict[str, Any]:
    """The periodic steady state compared with the imposed-area method, the linear transfer,
    the printed equations and harmonic balance (``djkr validate --json``)."""

def resonance(
    scenario: Scenario,
    freq: Union[Tuple[Quantity, Quantity, int], Sequence[Any], str],
    sweep: Literal["up", "down", "both"] = "both",
    set: Optional[Mapping[str, SetValue]] = None,
) -> Dict[str, npt.NDArray[Any]]:
    """The frequency response by continuation over ``freq = (start, stop, n)``
    (``djkr resonance``): the columns of ``resonance.csv`` by name (``direction``,
    ``frequency``, ``delta_amp_over_xb``, ...)."""

def fit(
    data: Any,
    scenario: Scenario,
    free: Union[str, Sequence[str]],
    observable: Optional[str] = None,
    set: Optional[Mapping[str, SetValue]] = None,
    ensemble: Optional[int] = None,
    seed: int = 0,
    jobs: Optional[int] = None,
) -> Dict[str, Any]:
    """Fit scenario keys to measured data (``djkr fit``): the content of ``fit.json``
    (``parameters`` with ``key``, ``value``, ``sigma``, ``unit``, ``initial``; ``correlation``,
    ``chi2``, ``dof``, ``reduced_chi2``, ``aic``, ``bic``, ``converged``, ``iterations``,
    ``forward_runs``, ``observable``, ``notes``). ``data`` is a path to a CSV file or a pandas
    DataFrame with the same column names (``base.amplitude [um]``,
    ``pull_off_amplification [1]``, ``sigma [1]``); ``free`` a list of ``"adhesion.n"`` or
    ``"adhesion.v_sat=0.01:100"``; ``set`` values for every row (a free key's is its start)."""
    ...

def sweep(
    scenario: Scenario,
    grid: Optional[Mapping[str, Union[str, Sequence[SetValue], SetValue]]] = None,
    ensemble: Optional[int] = None,
    seed: int = 0,
    jobs: Optional[int] = None,
) -> Dict[str, npt.NDArray[Any]]:
    """A study (``djkr sweep``): the Cartesian grid of ``grid`` (a list of values, or a SPEC
    string ``"10um:60um:6"``, ``"1um:100um:5log"``, per key; the first key varies slowest),
    ``ensemble`` members per point with the base phase drawn from ``seed``, on ``jobs`` threads
    (default: every core). The columns of ``sweep.csv`` by name, one row per run sorted by
    (point, member)."""

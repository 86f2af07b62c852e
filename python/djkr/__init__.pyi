"""djkr: dynamic JKR adhesion of a sphere on a vibrating viscoelastic substrate.

Each function gives what the ``djkr`` command of the same name reports, in SI units:

- ``run(scenario, set=, out=, force=)``: a time-domain run, a ``Run`` holding the datasets of
  ``run.h5`` as numpy arrays and the content of ``summary.json``;
- ``cycle`` and ``pulloff``: the imposed-area cycle and the pull-off (``--json``'s dict);
- ``validate``: the periodic steady state compared with the predictors (``--json``'s dict);
- ``resonance``: the frequency response, the columns of ``resonance.csv`` as numpy arrays, and
  ``resonance_peak``: its peak as ``djkr resonance`` finds it (or that there is none in range);
- ``sweep``: a study over scenario keys, the columns of ``sweep.csv`` (one value per run), and
  ``points``: the per-point statistics of its rows, the columns of ``points.csv``;
- ``fit``: scenario keys estimated from measured data (a ``Fit``: ``fit.json`` and the
  residuals), and ``predict``: the model with its uncertainty bands from a fit over a grid of
  conditions (a ``Prediction``: ``prediction.json`` and the columns of ``prediction.csv``),
  and ``design``: the new measurements that would pin a fit's keys down best (a ``Design``:
  ``design.json`` and the columns of ``design.csv``).

``Run.pieces()`` splits a run's arrays at the gaps envelope following left, and ``djkr.plot``
(``import djkr.plot``; needs matplotlib) draws a run as ``djkr plot`` does.

A *scenario* is a path (``str`` without a line break, or ``os.PathLike``), a TOML string, or a
dict with the file's structure (``{"version": 1, "material": {...}, "stage": [{...}]}``).
``set`` is a dict of overrides, as the command line's ``--set``: ``{"base.amplitude": "30um",
"stage[3].speed": 1e-3}``. Quantities are SI floats or strings with units (``"400Hz"``,
``"0.5mm"``). ``help(djkr.run)`` and the others say each argument's unit and what comes back.

Bad input raises ``ScenarioError`` (a ``ValueError``) with the command line's message in
Python's words (``set={'base.amplitud': ...}: unknown key; ...``); an argument of the wrong
type ``ScenarioTypeError`` (both a ``ScenarioError`` and a ``TypeError``). No input takes the
interpreter down: a scenario dict or TOML string larger than a scenario file may be (1 MiB,
once written as TOML), nested more than 80 deep or containing itself is refused, and so is
``set=`` or ``grid=`` of more than 1 MiB of text. An ``out=`` folder that refuses a run before
it starts (a file djkr did not write at a name it publishes, without ``force=True``; output that
would not fit the free disk space) raises ``OutputFolderError``, a ``ScenarioError``. A run that
a budget stopped or that failed mid-way raises ``RuntimeError`` whose ``run`` attribute is the
``Run`` up to there. Long calls
release the interpreter lock and stop within a fraction of a second on Ctrl-C
(``KeyboardInterrupt``).

Examples
--------
>>> import djkr, pandas as pd
>>> r = djkr.run("scenarios/paper-protocol-300hz.toml")
>>> r.summary["pull_off"]["amplification"]
>>> rows = djkr.sweep("scenarios/paper-protocol-300hz.toml",
...                   grid={"base.amplitude": ["10um", "30um"]}, ensemble=4)
>>> pd.DataFrame(djkr.points(rows))
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
    """Bad input: a scenario, an override, an argument or a grid that djkr refuses.

    A ValueError. The message is the command line's, in Python's words: it names the file or the
    argument (``set={'base.amplitude': '-1um'}``, ``grid=``, ``freq``), the key, the value and what is
    allowed. Every function raises it before any work starts when it can: a sweep checks every
    point first.

    Examples
    --------
    >>> try:
    ...     djkr.run("scenarios/impacts.toml", set={"base.amplitud": "30um"})
    ... except djkr.ScenarioError as e:
    ...     print(e)   # set={'base.amplitud': ...}: unknown key; ...
    """

class OutputFolderError(ScenarioError):
    """The ``out=`` folder refused the run before it started (a ScenarioError).

    As the command line, which exits with status 2 for these: a file djkr did not write at a name the
    run publishes (``run.h5``, ``summary.json``, ...: pass ``force=True`` to overwrite it, nothing
    else in the folder is touched), a name there that is not a regular file, a path that is not a
    folder, another djkr run or sweep writing into it, or output that would not fit the free disk
    space. Nothing has run and no result was written. A failure to write once the run has started
    is a ``RuntimeError``.

    Examples
    --------
    >>> try:
    ...     djkr.run("scenarios/impacts.toml", out="results")
    ... except djkr.OutputFolderError as e:
    ...     print(e)   # out: results: summary.json is already there and not written by djkr: ...
    """

class ScenarioTypeError(ScenarioError, TypeError):
    """Bad input of the wrong type (a list where a number goes, an int where a dict goes):
    caught by ``except ScenarioError`` and by ``except TypeError``.
    """

class Run:
    """A time-domain run held in memory: what ``djkr run`` writes into ``run.h5``.

    Made by ``djkr.run``. The time series are numpy arrays of one value per sample, in SI units,
    equal value for value to the datasets of ``run.h5``: ``t`` (s), ``x_s``, ``v_s``, ``x_b``,
    ``x_k``, ``delta``, ``a`` (m or m/s), ``a_dot`` (m/s), ``F`` (N), ``G``, ``w`` (J/m^2) as
    float64, ``stage`` and ``segment`` as int64 (each attribute's help says its sign convention).
    ``events`` is a list of dicts (``kind``, ``time``, ``stage``, ``state``), ``cycles`` and
    ``gaps`` dicts of numpy arrays (the ``cycles/`` and ``gaps/`` groups), ``summary`` the
    content of ``summary.json``. ``len(run)`` is the number of samples.

    Examples
    --------
    >>> import djkr
    >>> r = djkr.run("scenarios/paper-protocol-300hz.toml")
    >>> r.t.shape, r.F.dtype                     # (samples,), float64
    >>> r.summary["pull_off"]["force"]           # N
    >>> r.to_pandas().plot(x="t", y="F")
    """

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
    gap (a span envelope following skipped). Never join samples of different segments.
    """
    gaps: Dict[str, npt.NDArray[Any]]
    """The gaps of the time series, the HDF5 ``gaps/`` group: ``t_start`` and ``t_end`` (s, the
    samples either side) and ``periods`` (base periods skipped), one entry per gap.
    """
    cycles: Dict[str, npt.NDArray[Any]]
    """Per-period records: the datasets of the HDF5 ``cycles/`` group (``index``, ``stage``,
    ``t_start``, ``t_end``, ``force_mean``, ...).
    """
    @property
    def events(self) -> List[Dict[str, Any]]:
        """Every event of the run, in time order: dicts with ``kind`` (str), ``time`` (s),
        ``stage`` (int, from 0) and ``state`` (the time-series values at the event, as in
        ``summary.json``).
        """
    @property
    def summary(self) -> Dict[str, Any]:
        """The content of ``summary.json`` as a dict (without ``out=``: ``files`` and
        ``file_bytes`` empty). ``summary["pull_off"]`` has ``force`` (N), ``amplification`` (1)
        and ``time`` (s) when the sphere detached; a run that never detached had no pull-off
        (``pull_off`` empty, ``summary["most_tensile"]`` the most tensile force it saw);
        ``summary["status"]`` is ``"ok"``, ``"stopped"`` or ``"failed"``.
        """
    def to_pandas(self) -> Any:
        """The time series as a ``pandas.DataFrame``: columns ``t``, ``x_s``, ``v_s``, ``x_b``,
        ``x_k``, ``delta``, ``a``, ``a_dot``, ``F``, ``G``, ``w``, ``stage``, ``segment``, one row per
        sample (needs pandas).
        """
    def pieces(self) -> List[Dict[str, npt.NDArray[Any]]]:
        """The gap-free stretches of the time series, in time order: one dict per piece with every
        array of the run (``t``, ``x_s``, ..., ``F``, ``G``, ``w``, ``stage``, ``segment``)
        restricted to it, as numpy views (no copy). Between two pieces envelope following
        skipped whole base periods (``gaps``: piece k ends at ``gaps["t_start"][k]``, piece k + 1
        starts at ``gaps["t_end"][k]``), so a plot draws each piece as its own line and never
        joins two, as ``djkr plot`` does. One piece for a run without gaps.

        >>> for p in r.pieces():
        ...     ax.plot(p["t"], p["F"], color="C0")
        """
    def __len__(self) -> int: ...

def run(
    scenario: Scenario,
    set: Optional[Mapping[str, SetValue]] = None,
    out: Optional[Union[str, "os.PathLike[str]"]] = None,
    force: bool = False,
) -> Run:
    """Run a scenario with the time-domain simulator, as ``djkr run`` does.

    The run is held in memory; with ``out`` it is also written into a run folder, file for file
    the one ``djkr run FILE --out DIR`` writes.

    Parameters
    ----------
    scenario : str, os.PathLike or dict
        A scenario file's path (a ``str`` without a line break), a TOML string, or a dict with the
        file's structure, ``{"version": 1, "material": {...}, "stage": [{...}]}``.
    set : dict, optional
        Overrides of scenario keys, as ``--set KEY=VALUE``: ``{"base.amplitude": "30um",
        "stage[3].speed": 1e-3}``. A value is a number (SI units), a string with a unit or a bool.
    out : str or os.PathLike, optional
        A folder for ``run.h5``, ``summary.json`` and the CSV files and figure the scenario's
        ``[output]`` asks for.
    force : bool, optional
        With ``out``: overwrite files of those names that djkr did not write (``djkr run
        --force``); without it (the default) such a file stops the run before it starts
        (``OutputFolderError``). Nothing else in the folder is touched.

    Returns
    -------
    Run
        One value per sample in each time-series array (``t`` in s, ``x_s`` and ``delta`` in m,
        ``F`` in N, ...), the ``events``, the per-period records ``cycles`` and ``summary``, the
        content of ``summary.json`` (``summary["pull_off"]["force"]`` in N).

    Raises
    ------
    ScenarioError
        Bad input: the message names the file or argument, the key, the value and what is allowed.
        Also a run whose known sample count (``[output] sample_rate`` > 0 over stages with a
        ``duration``) would take more than ``solver.max_memory`` (default 2 GiB, 216 bytes a
        sample): lower the rate or raise ``solver.max_memory``. A run whose sample count is not
        known before it starts stops with reason ``"memory"`` when it would pass that budget.
    RuntimeError
        The run stopped on a budget (``solver.max_steps``, ``max_wall_s``, ``max_events``,
        ``max_memory``), with ``out`` on low disk space (reason ``"disk"``), or failed
        mid-way: the exception's ``run`` attribute is the ``Run`` up to there
        (``e.run.summary["status"]``, ``["reason"]``, ``["message"]``); with ``out``, the folder
        is written with that status.
    OutputFolderError
        A ``ScenarioError``: the ``out`` folder refused the run before it started (a file djkr
        did not write at a name it publishes, without ``force``; another run writing into it; not
        a folder; output that would not fit the free disk space). No result was written.
    KeyboardInterrupt
        Ctrl-C stops the run within a fraction of a second (with ``out``, the folder is written
        with reason ``SIGINT``).

    Examples
    --------
    >>> import djkr
    >>> r = djkr.run("scenarios/paper-protocol-300hz.toml", set={"base.amplitude": "30um"})
    >>> r.summary["pull_off"]["amplification"]   # F_po / (-3/2 pi R w0)
    >>> df = r.to_pandas()                        # columns t, x_s, ..., stage, segment
    """

def cycle(
    freq: Quantity,
    a_mean: Quantity,
    a_amp: Quantity,
    material: Optional[Scenario] = None,
) -> Dict[str, Any]:
    """One imposed-area cycle a(t) = a_mean + a_amp sin(2 pi freq t), as ``djkr cycle --json``.

    The contact radius is imposed; the indentation and force follow from the adhesion law over one
    period (the paper's Sec. 2.1, the imposed-area method).

    Parameters
    ----------
    freq : float or str
        Frequency (Hz, > 0): ``400`` or ``"400Hz"``, ``"0.4kHz"``.
    a_mean : float or str
        Imposed mean contact radius (m): ``0.002`` or ``"2mm"``. May be smaller than ``a_amp``
        (the contact is then lost for part of the cycle) or negative.
    a_amp : float or str
        Amplitude of the contact radius (m, >= 0): ``"0.5mm"``.
    material : str, os.PathLike or dict, optional
        A scenario whose ``[material]`` and ``[adhesion]`` are used (default: the paper's Fig. 2
        set, K 9.33 MPa, R 51 mm, w0 240 mJ/m^2, Gent-Schultz v0 0.0445 mm/s, n 0.531).

    Returns
    -------
    dict
        ``a_mean`` (m, the mean of max(a, 0), the paper's a posteriori a_m), ``a_mean_imposed``
        (m), ``a_amp`` (m), ``delta_mean`` (m), ``delta_amp`` (m, first-harmonic amplitude
        hypot(delta_sin, delta_cos)), ``delta_sin`` and ``delta_cos`` (m, its coefficients),
        ``force_mean`` (N, compressive positive), ``contact_fraction`` (1, of the period in
        contact) and ``notes`` (list of str: where the answer leaves the model's range; each is
        also issued as a ``RuntimeWarning``).

    Raises
    ------
    ScenarioError
        An argument out of range or malformed (named as in Python: ``freq = -400: ...``).

    Examples
    --------
    >>> import djkr
    >>> c = djkr.cycle("400Hz", "2mm", "0.5mm")
    >>> c["force_mean"], c["delta_amp"]           # N, m
    """

def pulloff(
    freq: Quantity,
    a_amp: Quantity,
    method: Literal["exact", "approx", "yi"] = "exact",
    beta: Optional[Quantity] = None,
    material: Optional[Scenario] = None,
) -> Dict[str, Any]:
    """The pull-off force under a vibration of the contact radius, as ``djkr pulloff --json``.

    Parameters
    ----------
    freq : float or str
        Vibration frequency (Hz, > 0): ``400`` or ``"400Hz"``.
    a_amp : float or str
        Amplitude of the contact radius (m, >= 0): ``"0.5mm"``.
    method : {"exact", "approx", "yi"}, optional
        ``"exact"`` (default): the minimum over a_m of the imposed-area cycle's mean force;
        ``"approx"``: the paper's closed form with exponent ``beta``; ``"yi"``: Yi et al.'s
        comparator. (``"shui"`` needs the rig: use the command line.)
    beta : float, optional
        The closed form's exponent (``method="approx"`` only; default 2.5, the paper's).
    material : str, os.PathLike or dict, optional
        A scenario whose ``[material]`` and ``[adhesion]`` are used (default: the paper's Fig. 2
        set).

    Returns
    -------
    dict
        ``method`` (str, in words), ``a_mean`` (m, mean contact radius at pull-off),
        ``delta_mean`` and ``delta_amp`` (m, mean indentation and its first-harmonic amplitude at
        pull-off), ``force`` (N, negative: tensile), ``amplification`` (1, force over the JKR
        pull-off -3/2 pi R w0) and ``notes`` (list of str; warnings are also issued as
        ``RuntimeWarning``).

    Raises
    ------
    ScenarioError
        An argument out of range, an unknown method, or ``beta`` with a method other than
        ``"approx"``.

    Examples
    --------
    >>> import djkr
    >>> p = djkr.pulloff(400, "0.5mm")
    >>> p["force"], p["amplification"]            # N, 1
    >>> djkr.pulloff(400, "0.5mm", method="approx", beta=3.0)["amplification"]
    """

def validate(
    scenario: Scenario,
    set: Optional[Mapping[str, SetValue]] = None,
) -> Dict[str, Any]:
    """The periodic steady state compared with the predictors, as ``djkr validate --json``.

    Finds the steady state of the scenario's vibrating contact (shooting on the time-domain model,
    integrated at rtol 1e-10) and compares it with the imposed-area method, the linear transfer,
    the paper's printed equations and harmonic balance.

    Parameters
    ----------
    scenario : str, os.PathLike or dict
        A scenario (path, TOML string or dict, as for ``run``) with a ``[base]`` vibration and a
        mean load.
    set : dict, optional
        Overrides of scenario keys, as for ``run``. ``solver.rtol`` is refused (the steady state is
        integrated at rtol 1e-10).

    Returns
    -------
    dict
        The object of ``djkr validate --json``: ``frequency`` (Hz), ``amplitude`` (m, X_b),
        ``linear_resonance_frequency`` (Hz), and one dict per method, ``steady``,
        ``time_domain``, ``imposed_area``, ``linear_transfer``, ``paper_transfer``,
        ``paper_far_from_resonance``, ``harmonic_balance``, with ``relative_difference`` between
        them and the ``force_balance`` check (SI units throughout).

    Raises
    ------
    ScenarioError
        Bad input, or a scenario that has no periodic steady state to find (no ``[base]``).
    RuntimeError
        The steady-state search failed.

    Examples
    --------
    >>> import djkr
    >>> v = djkr.validate("scenarios/resonance-400hz.toml", set={"base.amplitude": "0.3um"})
    >>> v["relative_difference"]
    """

def resonance(
    scenario: Scenario,
    freq: Union[Tuple[Quantity, Quantity, int], Sequence[Any], str],
    sweep: Literal["up", "down", "both"] = "both",
    set: Optional[Mapping[str, SetValue]] = None,
) -> Dict[str, npt.NDArray[Any]]:
    """The frequency response by continuation, as ``djkr resonance``.

    Steady states at ``n`` evenly spaced frequencies, each started from the last (up, down or
    both sweeps), with the linear transfer and harmonic balance beside them.

    Parameters
    ----------
    scenario : str, os.PathLike or dict
        A scenario with a ``[base]`` vibration and a mean load (as for ``validate``).
    freq : (start, stop, n) or str
        Frequencies (Hz): ``(380, 420, 41)``, ``("0.38kHz", "420Hz", 41)`` or ``"380:420:41"``;
        ``stop >= start``, ``1 <= n <= 2001``.
    sweep : {"up", "down", "both"}, optional
        Direction (default ``"both"``, the two in parallel).
    set : dict, optional
        Overrides of scenario keys, as for ``run`` (``solver.rtol`` and ``base.frequency`` are
        refused: the call sets them).

    Returns
    -------
    dict of numpy arrays
        The columns of ``resonance.csv``, one value per (direction, frequency): ``direction``
        (str), ``frequency`` (Hz), ``delta_amp_over_xb`` (1, |delta_A / X_b|), ``phase`` (rad),
        ``delta_mean``, ``delta_sin``, ``delta_cos`` (m), ``force_mean``, ``force_amp`` (N),
        ``a_mean``, ``a_amp`` (m), ``cycles``, ``residual``, ``contact_lost``, ``method``, the
        linear transfer's ``linear_delta_amp_over_xb`` and ``linear_phase``, harmonic balance's
        ``hb_*``, and ``error`` (str, empty when the point converged).

    Raises
    ------
    ScenarioError
        Bad input (``freq`` out of order or too long, an unknown ``sweep``, ...).

    Examples
    --------
    >>> import djkr, pandas as pd
    >>> r = pd.DataFrame(djkr.resonance("scenarios/resonance-400hz.toml", freq=(380, 420, 21)))
    >>> up = r[r.direction == "up"]
    >>> djkr.resonance_peak(up.frequency, up.delta_amp_over_xb)   # as djkr resonance finds it
    """

class Fit:
    """The result of ``djkr.fit``: the content of ``fit.json`` and the residuals' table.

    ``r["chi2"]``, ``r["parameters"]``, ... read ``fit.json`` as a dict does (``r.report`` is
    that dict). ``r.parameters`` maps each key to its estimate and ``r.sigma`` to its standard
    deviation (``None`` where the fit gives none: not converged, a bound hit, a key the data do
    not fix, a model that is not linear over one sigma), both in the key's SI unit;
    ``r.keys`` is their order, ``r.covariance`` the covariance matrix in that order (a numpy
    array in the keys' units, NaN where a key has no sigma), ``r.intervals`` each key's 68 %
    interval ``(lo, hi)`` (the profile likelihood's where ``fit.json`` says so).
    ``r.residuals`` holds the columns of ``residuals.csv`` (numpy arrays; text conditions as
    lists): ``pandas.DataFrame(r.residuals)`` is its table, as is ``r.to_pandas()``.

    Examples
    --------
    >>> r = djkr.fit("measured.csv", "scenarios/paper-protocol-300hz.toml",
    ...              free=["adhesion.v0", "adhesion.n"])
    >>> r.parameters["adhesion.n"], r.sigma["adhesion.n"], r.covariance
    >>> r.to_pandas()[["fitted [1]", "normalized_residual [1]"]]
    """

    report: Dict[str, Any]
    """The content of ``fit.json`` (a dict)."""
    keys: List[str]
    """The keys, in the order of ``covariance``."""
    parameters: Dict[str, float]
    """Each key's estimate (its SI unit)."""
    sigma: Dict[str, Optional[float]]
    """Each key's standard deviation (its SI unit), ``None`` where the fit gives none."""
    intervals: Dict[str, Optional[Tuple[float, float]]]
    """Each key's 68 % interval ``(lo, hi)``, ``None`` without one."""
    covariance: npt.NDArray[np.float64]
    """The covariance in the keys' units (numpy array, NaN where a key has no sigma)."""
    residuals: Dict[str, Any]
    """The columns of ``residuals.csv`` (dict of numpy arrays)."""
    def __getitem__(self, key: str) -> Any:
        """Return self[key]."""
        ...
    def __contains__(self, key: str) -> bool:
        """Return key in self."""
        ...
    def to_pandas(self) -> Any:
        """The residuals' table as a ``pandas.DataFrame`` (needs pandas)."""
        ...

def fit(
    data: Any,
    scenario: Scenario,
    free: Union[str, Sequence[str]],
    observable: Optional[str] = None,
    set: Optional[Mapping[str, SetValue]] = None,
    ensemble: Optional[int] = None,
    seed: int = 0,
    jobs: Optional[int] = None,
    max_iterations: int = 30,
    starts: int = 1,
    profile: bool = False,
    out: Optional[Union[str, "os.PathLike[str]"]] = None,
    force: bool = False,
) -> "Fit":
    """Estimate scenario keys from measured data, as ``djkr fit``: weighted least squares by
    Levenberg-Marquardt, each data row predicted by a run of the scenario with that row's
    conditions set (all cores).

    Parameters
    ----------
    data : str, os.PathLike or pandas.DataFrame
        The measurements: one column per condition named by its scenario key with its unit
        (``"base.frequency [Hz]"``, ``"base.amplitude [um]"``), one observable column named as in
        ``sweep.csv`` (``"pull_off_amplification [1]"``, ``"pull_off_force [mN]"``, ...) and
        optionally ``"sigma [unit of the observable]"``. Without sigma every row weighs the same
        and the parameters' sigma are scaled by the reduced chi-squared.
    scenario : str, os.PathLike or dict
        The scenario every row starts from (path, TOML string or dict, as for ``run``); the free
        keys start from its values.
    free : str or list of str
        The keys to estimate, as on the command line: ``"adhesion.n"`` or bounded
        ``"adhesion.v_sat=0.01:100"`` (bounds in the key's unit or with units). A positive scale
        (``adhesion.v0``, ``material.K``) is fitted in log space.
    observable : str, optional
        The column to fit when ``data`` has several observables.
    set : dict, optional
        Fixed overrides of the scenario, as for ``run``.
    ensemble : int, optional
        Members per row (>= 1): a row's prediction is the mean over that many base phases, the
        same phases (from ``seed``) at every evaluation; the ensemble's standard error joins
        sigma. For chaotic rigs.
    seed : int, optional
        Seed of the ensemble's phases (default 0).
    jobs : int, optional
        Runs at a time (default: one per core).
    max_iterations : int, optional
        Most iterations (Jacobians) of each run of the optimiser (default 30).
    starts : int, optional
        Starting points (default 1): the given one and ``starts - 1`` drawn by Latin hypercube
        (between a key's bounds, or a factor 10 either side of the start in log space, +-50 %
        for a linear key); ``r["starts"]`` lists them and the minimum each reached.
    profile : bool, optional
        Give every key its profile-likelihood interval (default: only where the model is not
        linear over one sigma).
    out : str or os.PathLike, optional
        A folder for the fit's files, as ``djkr fit --out``: ``fit.json``, ``residuals.csv``,
        ``fitted.toml``, ``fit.png``, ``fit.svg``.
    force : bool, optional
        Overwrite files of those names in ``out`` that djkr did not write (``--force``).

    Returns
    -------
    Fit
        ``r["parameters"]``, ``r["chi2"]``, ... are the content of ``fit.json`` (``r.report``):
        ``parameters`` (list of dicts with ``key``, ``value``, ``sigma``, ``interval``,
        ``interval_from``, in the key's own unit, ``unit``, ``initial``), ``covariance`` and
        ``correlation`` (matrices in the order of ``parameters``), ``chi2``, ``dof``,
        ``reduced_chi2``, ``aic`` (chi2 + 2k), ``bic`` (chi2 + k ln n), ``converged``,
        ``termination``, ``iterations``, ``forward_runs``, ``rhs_evals``, ``starts``,
        ``tolerances``, ``observable``, ``ensemble`` (``members`` and ``seed``, or None) and
        ``notes``. ``r.parameters``, ``r.sigma``, ``r.intervals`` (dicts by key),
        ``r.covariance`` (numpy array) and ``r.residuals`` (the columns of ``residuals.csv``;
        ``r.to_pandas()`` as a DataFrame) are the same as arrays. ``djkr.predict(r, ...)``
        carries the fit into predictions with uncertainty bands.

    Raises
    ------
    ScenarioError
        Bad data (naming the line and column), unknown or non-numeric free keys, an observable
        djkr does not produce.
    KeyboardInterrupt
        Ctrl-C: no new run starts.

    Examples
    --------
    >>> import djkr
    >>> r = djkr.fit("measured.csv", "scenarios/paper-protocol-300hz.toml",
    ...              free=["adhesion.v0", "adhesion.n"])
    >>> r.parameters, r.sigma, r.covariance
    >>> r.to_pandas()                      # the residuals' table
    >>> r["aic"], r["notes"]
    """
    ...

class Prediction:
    """The result of ``djkr.predict``: the content of ``prediction.json`` and the columns of
    ``prediction.csv``.

    ``p["rows"]``, ``p["notes"]``, ``p["observable"]``, ... read ``prediction.json`` as a dict
    does (``p.report`` is that dict). ``p.columns`` holds the columns of ``prediction.csv``
    (numpy arrays named ``"name [unit]"``, SI; NaN where a sigma is null; text conditions as
    lists): ``pandas.DataFrame(p.columns)`` is its table, as is ``p.to_pandas()``.

    Examples
    --------
    >>> p = djkr.predict("out/fit", grid={"base.amplitude": ["10um", "30um"]})
    >>> p.columns["value [1]"], p.columns["sigma [1]"], p["notes"]
    """

    report: Dict[str, Any]
    """The content of ``prediction.json`` (a dict)."""
    columns: Dict[str, Any]
    """The columns of ``prediction.csv`` (dict of numpy arrays)."""
    def __getitem__(self, key: str) -> Any:
        """Return self[key]."""
        ...
    def __contains__(self, key: str) -> bool:
        """Return key in self."""
        ...
    def __len__(self) -> int:
        """Return len(self)."""
        ...
    def to_pandas(self) -> Any:
        """The table of ``prediction.csv`` as a ``pandas.DataFrame`` (needs pandas)."""
        ...

def predict(
    fit: Union["Fit", str, "os.PathLike[str]"],
    grid: Optional[Mapping[str, Any]] = None,
    samples: int = 0,
    ensemble: Optional[int] = None,
    seed: Optional[int] = None,
    observable: Optional[str] = None,
    jobs: Optional[int] = None,
    out: Optional[Union[str, "os.PathLike[str]"]] = None,
    force: bool = False,
) -> "Prediction":
    """Predictions from a fit with their uncertainty, as ``djkr predict``.

    For each point of the grid: the model at the fit's estimate, its standard deviation from the
    fitted keys' covariance by linear propagation through the fit's own finite-difference
    Jacobian, with an ensemble the standard error of the members' mean, the 68 % and 95 % bands,
    and with ``samples`` the spread over parameter draws. The numbers are those of
    ``djkr predict --json`` for the same fit and arguments, to the bit.

    Parameters
    ----------
    fit : Fit, str or os.PathLike
        What ``djkr.fit`` returned, or the folder a fit wrote (``djkr fit --out``, or
        ``djkr.fit(out=...)``: ``fit.json``, ``fitted.toml``, ``residuals.csv``).
    grid : dict, optional
        The conditions to predict at, as ``djkr.sweep``'s ``grid``: each scenario key (not one
        the fit estimated) with its values, a list (``["10um", "30um"]``, floats in SI) or a
        range string (``"200:500:7"``); several keys make the Cartesian grid, the first
        slowest. Default: the fit's data's own conditions.
    samples : int, optional
        Parameter draws (0, the default: none; else 2 to 100000) from the fit's distribution in
        its coordinates (log space keys stay positive): the column ``sigma_samples``.
    ensemble : int, optional
        Members per point (>= 2): each value is the mean over that many base phases drawn from
        ``seed`` (chaotic rigs), ``sigma_ensemble`` its standard error. Default: the fit's
        ensemble, if it had one (so that at the data's conditions the values are the fit's).
    seed : int, optional
        Seed of the draws of ``samples`` and of the phases of ``ensemble`` (default 0).
    observable : str, optional
        The quantity to predict, as named in ``sweep.csv`` (``"pull_off_force"``,
        ``"pull_off_amplification"``, ``"pull_off_time"``, ``"force_mean"``, ``"delta_mean"``,
        ``"delta_amp"``). Default: the fit's.
    jobs : int, optional
        Runs at a time (default: one per core).
    out : str or os.PathLike, optional
        A folder for ``prediction.csv``, ``prediction.json``, ``prediction.png`` and
        ``prediction.svg``, as ``djkr predict --out``.
    force : bool, optional
        Overwrite files of those names in ``out`` that djkr did not write (``--force``).

    Returns
    -------
    Prediction
        ``p["rows"]``, ``p["notes"]``, ... are the content of ``prediction.json``
        (``p.report``); ``p.columns`` holds the columns of ``prediction.csv`` as numpy arrays
        (``"base.amplitude [m]"``, ``"value [1]"``, ``"sigma_parameters [1]"``,
        ``"sigma_ensemble [1]"``, ``"sigma [1]"``, ``"lo68 [1]"``, ``"hi68 [1]"``,
        ``"lo95 [1]"``, ``"hi95 [1]"``, with samples ``"sigma_samples [1]"``; NaN where a
        sigma is null; text conditions as lists); ``p.to_pandas()`` is that table.

    Raises
    ------
    ScenarioError
        A folder without a fit, a grid key the fit estimated, an observable djkr does not
        produce, ``samples=1``, ``ensemble=1``, ``seed`` without ``samples`` or ``ensemble``.
    KeyboardInterrupt
        Ctrl-C: no new run starts, nothing is written.

    Examples
    --------
    >>> import djkr
    >>> r = djkr.fit("measured.csv", "scenarios/paper-protocol-300hz.toml",
    ...              free=["adhesion.v0", "adhesion.n"])
    >>> p = djkr.predict(r, grid={"base.frequency": "250Hz",
    ...                           "base.amplitude": "10um:60um:6"}, samples=100)
    >>> p.to_pandas()[["base.amplitude [m]", "value [1]", "lo95 [1]", "hi95 [1]"]]
    """
    ...

class Design:
    """The result of ``djkr.design``: the content of ``design.json`` and the columns of
    ``design.csv``.

    ``d["chosen"]``, ``d["expected_sigma"]``, ``d["notes"]``, ... read ``design.json`` as a dict
    does (``d.report`` is that dict). ``d.columns`` holds the columns of ``design.csv`` (numpy
    arrays named ``"name [unit]"``, SI; ``repeats`` and ``uniform_repeats`` as int64; text
    conditions as lists): ``pandas.DataFrame(d.columns)`` is its table, as is ``d.to_pandas()``.

    Examples
    --------
    >>> d = djkr.design("out/fit", {"base.amplitude": "0um:20um:5"}, add=4)
    >>> d["chosen"], d.columns["information [1]"], d["notes"]
    """

    report: Dict[str, Any]
    """The content of ``design.json`` (a dict)."""
    columns: Dict[str, Any]
    """The columns of ``design.csv`` (dict of numpy arrays)."""
    def __getitem__(self, key: str) -> Any:
        """Return self[key]."""
        ...
    def __contains__(self, key: str) -> bool:
        """Return key in self."""
        ...
    def to_pandas(self) -> Any:
        """The table of ``design.csv`` as a ``pandas.DataFrame`` (needs pandas)."""
        ...

def design(
    fit: Union["Fit", str, "os.PathLike[str]"],
    candidates: Mapping[str, Any],
    add: int,
    sigma: Optional[Union[float, str]] = None,
    criterion: str = "D",
    repeats: bool = True,
    jobs: Optional[int] = None,
    out: Optional[Union[str, "os.PathLike[str]"]] = None,
    force: bool = False,
) -> "Design":
    """New measurements chosen from a fit, as ``djkr design``.

    Of the candidates (a grid of conditions one could measure), the ``add`` new measurements
    that, added to the fit's data, minimise the expected covariance of the fitted keys: the
    model's sensitivities at the estimate (the fit's own finite-difference Jacobian) over the
    expected noise of a measurement, a greedy choice then exchanges (Fedorov). Reported beside
    them: the same number spread uniformly over the candidates. The numbers are those of
    ``djkr design --json`` for the same fit and arguments, to the bit.

    Parameters
    ----------
    fit : Fit, str or os.PathLike
        What ``djkr.fit`` returned, or the folder a fit wrote (``djkr fit --out``, or
        ``djkr.fit(out=...)``: ``fit.json``, ``fitted.toml``, ``residuals.csv``).
    candidates : dict
        The conditions one could measure, as ``djkr.sweep``'s ``grid``: each scenario key (not
        one the fit estimated) with its values, a list (``["10um", "30um"]``, floats in SI) or a
        range string (``"200:500:7"``, ``"30um/s:3mm/s:5log"``); several keys make the
        Cartesian grid, the first slowest. 2 to 10000 candidates.
    add : int
        New measurements to choose (1 to 10000).
    sigma : float or str, optional
        The expected standard deviation of a new measurement: a number in the observable's SI
        unit (or a string with a unit), or a percentage of the prediction (``"2%"``). Default:
        the median relative sigma of the fit's data.
    criterion : str, optional
        What the design minimises: ``"D"`` (the default: the determinant of the keys'
        covariance), ``"A"`` (the sum of their variances, in the fit coordinates) or a free key
        of the fit (``"adhesion.n"``: its variance).
    repeats : bool, optional
        Whether a candidate may be chosen more than once (default True; ``False`` is
        ``--no-repeats``).
    jobs : int, optional
        Runs at a time (default: one per core).
    out : str or os.PathLike, optional
        A folder for ``design.csv``, ``design.json``, ``design.png`` and ``design.svg``, as
        ``djkr design --out``.
    force : bool, optional
        Overwrite files of those names in ``out`` that djkr did not write (``--force``).

    Returns
    -------
    Design
        ``d["chosen"]`` (a list of ``{"conditions": {key: value in SI}, "repeats": n, "row":
        i}``), ``d["current_sigma"]``, ``d["expected_sigma"]``, ``d["uniform_sigma"]`` (each
        ``{key: sigma}`` in the keys' SI units), ``d["criterion"]``, ``d["notes"]``, ... are the
        content of ``design.json`` (``d.report``); ``d.columns`` holds the columns of
        ``design.csv`` as numpy arrays (``"base.amplitude [m]"``, ``"value [1]"``,
        ``"sigma_measurement [1]"``, ``"sigma_prediction [1]"``, ``"information [1]"``, and the
        int64 ``"repeats [1]"``, ``"uniform_repeats [1]"``; text conditions as lists);
        ``d.to_pandas()`` is that table.

    Raises
    ------
    ScenarioError
        A folder without a fit, a candidate key that is not a condition (unknown, or a key the
        fit estimated), candidates that vary nothing (one point), ``add=0``, ``add`` above the
        candidates with ``repeats=False``, a criterion that is not D, A or a free key, a sigma
        that is not positive, no sigma where the fit's data carry none, a fit that gave a key no
        sigma.
    KeyboardInterrupt
        Ctrl-C: no new run starts, nothing is written.

    Examples
    --------
    >>> import djkr
    >>> r = djkr.fit("measured.csv", "scenarios/paper-protocol-300hz.toml",
    ...              free=["adhesion.v0", "adhesion.n"])
    >>> d = djkr.design(r, {"base.amplitude": "0um:20um:5",
    ...                     "stage[3].speed": "30um/s:3000um/s:5log"}, add=6)
    >>> d["chosen"], d["expected_sigma"]["adhesion.n"], d["uniform_sigma"]["adhesion.n"]
    """
    ...

def resonance_peak(
    frequency: Sequence[float],
    height: Sequence[float],
) -> Dict[str, Any]:
    """The resonance peak of sampled data, as ``djkr resonance`` finds it (the ``peak`` of its
    ``--json``): the highest sample, refined by a parabola through it and its neighbours where
    the five samples around it lie on one concave branch (never across the jump of a folded
    curve). A maximum at the first or the last frequency is no peak: the resonance lies beyond
    the range.

    Parameters
    ----------
    frequency : sequence of float
        Frequencies (Hz), in any order (sorted here).
    height : sequence of float
        The response at each, e.g. ``delta_amp_over_xb`` of one sweep direction; non-finite
        values (points that did not converge) are left out.

    Returns
    -------
    dict
        ``{"frequency": f, "height": h}`` for a peak inside the range, or
        ``{"no_peak_in_range": {"largest_at": "low" or "high", "frequency": f, "height": h}}``;
        ``{}`` without finite data.

    Examples
    --------
    >>> res = djkr.resonance("scenarios/resonance-400hz.toml", freq=(300, 500, 21))
    >>> up = res["direction"] == "up"
    >>> djkr.resonance_peak(res["frequency"][up], res["delta_amp_over_xb"][up])
    {'frequency': 405.96..., 'height': 13.66...}
    """

def sweep(
    scenario: Scenario,
    grid: Optional[Mapping[str, Union[str, Sequence[SetValue], SetValue]]] = None,
    ensemble: Optional[int] = None,
    seed: Optional[int] = None,
    jobs: Optional[int] = None,
    set: Optional[Mapping[str, SetValue]] = None,
) -> Dict[str, npt.NDArray[Any]]:
    """A study over scenario keys, as ``djkr sweep``: one run per grid point and ensemble member.

    The grid is the Cartesian product of ``grid``'s values (the first key varies slowest). The
    keys of ``set`` keep one value each, beside the grid: ``djkr.sweep(F, grid={"K": SPEC},
    set={"K2": V})`` runs what ``djkr sweep F --set K2=V --set K=SPEC`` runs, rows and columns.

    Parameters
    ----------
    scenario : str, os.PathLike or dict
        The scenario every run starts from (path, TOML string or dict, as for ``run``).
    grid : dict, optional
        The swept keys and their values: a list (``["10um", "30um"]``, ``[1e-5, 3e-5]``, a numpy
        array) or a SPEC string, ``"10um,30um"``, ``"10um:60um:6"`` (linear, ends included) or
        ``"1um:100um:5log"``. Any key ``set`` takes (``base.frequency``, ``stage[3].speed``,
        ``adhesion.n``, ``solver.method``, ...).
    ensemble : int, optional
        Members per point (>= 1), each with the base phase at shaker-on drawn uniformly in
        ``[0, 2 pi)`` from (seed, point, member).
    seed : int, optional
        Seed of the ensemble's phases (default 0; only with ``ensemble``).
    jobs : int, optional
        Runs at a time (default: one per core).
    set : dict, optional
        Fixed overrides (one value per key, not in ``grid``), as for ``run``; each is also a
        column of the rows, as on the command line.

    Returns
    -------
    dict of numpy arrays
        The columns of ``sweep.csv``, one value per run, sorted by (point, member): ``point``,
        ``member``, one column per ``set`` key then per ``grid`` key (SI value, or text),
        ``phase`` (rad), ``status`` (``"ok"``, ``"stopped"``, ``"error"``), ``error`` (str),
        ``pull_off_force`` (N), ``pull_off_amplification`` (1), ``pull_off_time`` (s),
        ``detached``, ``steps``, ``rhs_evals``, ``wall_s`` (s), and the last cycle's
        ``force_mean`` (N), ``delta_mean`` and ``delta_amp`` (m). NaN where a run failed.
        ``pandas.DataFrame(rows)`` makes a table of it; ``djkr.points(rows)`` the per-point
        statistics.

    Raises
    ------
    ScenarioError
        Bad input, named by its argument: ``grid={'base.amplitude': [..., '-1um', ...]} (point 1):
        must be a finite number >= 0 (m)``. Every point is checked before any run starts.
    KeyboardInterrupt
        Ctrl-C: no new run starts, running ones are abandoned.

    Examples
    --------
    >>> import djkr, pandas as pd
    >>> rows = djkr.sweep("scenarios/paper-protocol-300hz.toml",
    ...                   grid={"base.amplitude": ["10um", "30um", "60um"]},
    ...                   set={"stage[2].duration": 0.2}, ensemble=4, seed=1)
    >>> pd.DataFrame(rows).groupby("base.amplitude").pull_off_amplification.mean()
    >>> djkr.points(rows)["pull_off_amplification_std"]
    """

def points(
    rows: Union[Mapping[str, Any], Any],
) -> Dict[str, npt.NDArray[Any]]:
    """The per-point statistics of a sweep's rows: the columns of ``points.csv``.

    The same names and values as the ``points.csv`` that ``djkr sweep`` writes for the same sweep:
    for each point, the statistics of the pull-off force and amplification over its members that
    ran (status ``"ok"``, finite values).

    Parameters
    ----------
    rows : dict of arrays or pandas.DataFrame
        What ``djkr.sweep`` returned (or a selection of its rows, or ``pandas.DataFrame`` of it).
        Read: ``point``, ``member``, the swept keys (the columns between ``member`` and
        ``phase``; numeric or text by dtype), ``status``, ``pull_off_force`` and
        ``pull_off_amplification``.

    Returns
    -------
    dict of numpy arrays
        One value per point, in point order: ``point``, the swept keys, ``members`` (rows of the
        point), ``failed`` (of them, runs that did not end ``"ok"``), then for
        ``pull_off_force`` (N) and ``pull_off_amplification`` (1) each ``_mean``, ``_std``
        (sample standard deviation, n - 1; NaN below two members), ``_min``, ``_max``, ``_q05``,
        ``_q50``, ``_q95`` (quantiles as numpy's default, linear). The standard error of the mean
        is ``_std / sqrt(members - failed)``.

    Raises
    ------
    ScenarioError
        ``rows`` lacks a column, or its columns differ in length or hold the wrong kind of value.

    Examples
    --------
    >>> import djkr, numpy as np
    >>> rows = djkr.sweep("scenarios/paper-protocol-300hz.toml",
    ...                   grid={"base.amplitude": ["10um", "30um"]}, ensemble=4)
    >>> p = djkr.points(rows)
    >>> sem = p["pull_off_amplification_std"] / np.sqrt(p["members"] - p["failed"])
    >>> # plt.errorbar(p["base.amplitude"], p["pull_off_amplification_mean"], yerr=sem)
    """

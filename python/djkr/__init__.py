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

from ._djkr import (
    Design,
    Fit,
    OutputFolderError,
    Prediction,
    Run,
    ScenarioError,
    ScenarioTypeError,
    __version__,
    cycle,
    design,
    fit,
    points,
    predict,
    pulloff,
    resonance,
    resonance_peak,
    run,
    sweep,
    validate,
)

__all__ = [
    "Design",
    "Fit",
    "OutputFolderError",
    "Prediction",
    "Run",
    "ScenarioError",
    "ScenarioTypeError",
    "cycle",
    "design",
    "fit",
    "points",
    "predict",
    "pulloff",
    "resonance",
    "resonance_peak",
    "run",
    "sweep",
    "validate",
]

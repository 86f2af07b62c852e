"""djkr: dynamic JKR adhesion of a sphere on a vibrating viscoelastic substrate.

``run``, ``cycle``, ``pulloff``, ``validate``, ``resonance`` and ``sweep`` give what the djkr
commands of the same names report, in SI units: ``cycle``, ``pulloff`` and ``validate`` the
object of ``--json``, ``resonance`` and ``sweep`` the columns of ``resonance.csv`` and
``sweep.csv`` as numpy arrays, ``run`` a ``Run`` with the datasets of ``run.h5`` as numpy arrays
and the content of ``summary.json``. Bad input raises ``ScenarioError`` (a ``ValueError``) with
the command line's message (``ScenarioTypeError``, also a ``TypeError``, for a wrong type). Long calls release the interpreter lock and stop on Ctrl-C.
"""

from ._djkr import (
    Run,
    ScenarioError,
    ScenarioTypeError,
    __version__,
    cycle,
    fit,
    pulloff,
    resonance,
    run,
    sweep,
    validate,
)

__all__ = [
    "Run",
    "ScenarioError",
    "ScenarioTypeError",
    "cycle",
    "fit",
    "pulloff",
    "resonance",
    "run",
    "sweep",
    "validate",
]

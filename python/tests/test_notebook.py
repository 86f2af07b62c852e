"""The example notebooks, executed with nbclient, their key numbers compared with the command
line's for the same input and with the outputs committed in them, so that a committed notebook
shows what djkr computes today:

- examples/notebooks/first-study.ipynb (issue 27): ``djkr run``, ``djkr sweep``,
  ``djkr resonance``;
- examples/notebooks/plan-an-experiment.ipynb (issue 34): ``djkr fit``, ``djkr predict``,
  ``djkr design`` on the bundled data file, and its closing answer against its own numbers.

Needs nbclient, nbformat and ipykernel: tests/cli/python.rs installs them into its venv with
DJKR_TEST_INSTALL=1; without them these tests skip (and fail when installing was allowed).
After a change that moves these numbers on purpose, re-execute the notebooks in place with

    python python/tests/test_notebook.py --write [first-study|plan-an-experiment ...]

(all of them without a name).
"""

import json
import os
import sys
import time
from pathlib import Path

import pandas as pd
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from conftest import ROOT, cli  # noqa: E402

NOTEBOOK = ROOT / "examples" / "notebooks" / "first-study.ipynb"
PLAN = ROOT / "examples" / "notebooks" / "plan-an-experiment.ipynb"
PROTOCOL = "scenarios/paper-protocol-300hz.toml"
RESONANCE = "scenarios/resonance-400hz.toml"


def need(module):
    try:
        return __import__(module)
    except ImportError:
        why = f"the notebook test needs {module} (tests/cli/python.rs installs it with DJKR_TEST_INSTALL=1)"
        if os.environ.get("DJKR_TEST_INSTALL") == "1":
            pytest.fail(why)
        pytest.skip(why)


def execute(path):
    """The notebook at `path`, executed from its own folder (as a user opens it)."""
    nbformat, nbclient = need("nbformat"), need("nbclient")
    need("ipykernel")
    nb = nbformat.read(path, as_version=4)
    for cell in nb.cells:  # no timings in the committed file
        cell.metadata.pop("execution", None)
    nbclient.NotebookClient(
        nb, timeout=300, kernel_name="python3", record_timing=False, resources={"metadata": {"path": str(path.parent)}}
    ).execute()
    return nb


def key_numbers(nb):
    """The JSON the notebook's last code cell prints."""
    cell = [c for c in nb.cells if c.cell_type == "code"][-1]
    text = "".join(o.get("text", "") for o in cell.get("outputs", []) if o.get("output_type") == "stream")
    assert text, "the notebook's last code cell printed nothing (key numbers)"
    return json.loads(text)


def images(nb):
    """The figures among a notebook's outputs."""
    return [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])
            if "image/png" in o.get("data", {})]


def floats(column):
    return [float(x) for x in column]


def cli_key_numbers(tmp):
    """The notebook's key numbers computed by the command line."""
    cli("run", PROTOCOL, "--out", tmp / "run")
    summary = json.loads((tmp / "run" / "summary.json").read_text())
    cli("sweep", PROTOCOL, "--set", "base.amplitude=10um,30um,60um", "--ensemble", "4", "--seed", "1",
        "--out", tmp / "slow")
    slow = pd.read_csv(tmp / "slow" / "points.csv", dtype=str)
    cli("sweep", PROTOCOL, "--set", "stage[3].speed=2mm/s", "--set", "base.amplitude=10um,30um,60um",
        "--ensemble", "4", "--seed", "1", "--out", tmp / "fast")
    fast = pd.read_csv(tmp / "fast" / "points.csv", dtype=str)
    # The peak as djkr resonance reports it: on the 10 Hz grid the largest point (the parabola
    # is refused there), then 0.5 Hz steps within 10 Hz of it.
    coarse = json.loads(cli("resonance", RESONANCE, "--freq", "300:500:21", "--out", tmp / "res",
                            "--json").stdout)["sweep_up"]["peak"]["frequency"]
    fine = json.loads(cli("resonance", RESONANCE, "--freq", f"{coarse - 10}:{coarse + 10}:41", "--sweep", "up",
                          "--out", tmp / "fine", "--json").stdout)
    peak = fine["sweep_up"]["peak"]
    return {
        "run_pull_off_force": summary["pull_off"]["force"],
        "run_amplification": summary["pull_off"]["amplification"],
        "sweep_amplification_mean": floats(slow["pull_off_amplification_mean [1]"]),
        "sweep_amplification_std": floats(slow["pull_off_amplification_std [1]"]),
        "fast_sweep_amplification_mean": floats(fast["pull_off_amplification_mean [1]"]),
        "resonance_peak_frequency": peak["frequency"],
        "resonance_peak_delta_amp_over_xb": peak["height"],
    }


def test_the_notebook_runs_and_its_numbers_are_the_command_lines(tmp_path):
    t0 = time.monotonic()
    nb = execute(NOTEBOOK)
    seconds = time.monotonic() - t0
    got = key_numbers(nb)
    assert got == cli_key_numbers(tmp_path)
    # The committed outputs are today's: the same numbers, and the three figures.
    committed = need("nbformat").read(NOTEBOOK, as_version=4)
    assert key_numbers(committed) == got, (
        "the notebook's committed outputs are stale: re-execute it with "
        "`python python/tests/test_notebook.py --write` and commit it"
    )
    assert len(images(committed)) == 3
    assert seconds < 120, f"the notebook took {seconds:.0f} s: keep it to seconds"


# The plan notebook's inputs, as the command line takes them.
PLAN_DATA = "examples/data/pull-off-300hz.csv"
PLAN_SET = ["--set", "stage[1].duration=0.05", "--set", "stage[2].duration=0.1"]
PLAN_GRID = ["--set", "stage[3].speed=30um/s,100um/s,300um/s,3000um/s", "--set", "base.amplitude=0um:20um:9"]
PLAN_CANDIDATES = ["--candidates", "base.amplitude=0um:20um:5", "stage[3].speed=30um/s:3000um/s:5log"]


def cli_plan_numbers(tmp):
    """The plan notebook's key numbers computed by the command line, and the fit's correlation."""
    cli("fit", PLAN_DATA, "--scenario", PROTOCOL, *PLAN_SET, "--free", "adhesion.v0", "--free", "adhesion.n",
        "--out", tmp / "fit")
    fit = json.loads((tmp / "fit" / "fit.json").read_text())
    pred = json.loads(cli("predict", "--fit", tmp / "fit", *PLAN_GRID, "--out", tmp / "predict", "--json").stdout)
    design = json.loads(cli("design", "--fit", tmp / "fit", *PLAN_CANDIDATES, "--add", "6", "--out", tmp / "design",
                            "--json").stdout)
    rows = pred["rows"]
    return {
        "fit_parameters": {p["key"]: p["value"] for p in fit["parameters"]},
        "fit_sigma": {p["key"]: p["sigma"] for p in fit["parameters"]},
        "predict_value": [r["value"] for r in rows],
        "predict_sigma": [r["sigma"] for r in rows],
        "predict_lo95": [r["lo95"] for r in rows],
        "predict_hi95": [r["hi95"] for r in rows],
        "design_chosen": [{"conditions": c["conditions"], "repeats": c["repeats"]} for c in design["chosen"]],
        "current_sigma": design["current_sigma"],
        "expected_sigma": design["expected_sigma"],
        "uniform_sigma": design["uniform_sigma"],
    }, fit["correlation"][0][1]


def plan_answer(got, correlation):
    """The phrases the plan notebook's text must hold, made from its numbers."""
    um = 1e6
    chosen = ", and ".join(
        f"{c['repeats']} × at X_b = {c['conditions']['base.amplitude'] * um:.3g} µm unloading at "
        f"{c['conditions']['stage[3].speed'] * um:.4g} µm/s" for c in got["design_chosen"])
    now, exp, uni = got["current_sigma"], got["expected_sigma"], got["uniform_sigma"]
    n, v0 = "adhesion.n", "adhesion.v0"
    rel = [100 * s / v for s, v in zip(got["predict_sigma"], got["predict_value"])]
    # The grid's last point (3 mm/s, 20 um) is the least certain.
    assert max(rel) == rel[-1], rel
    return [
        f"**Measure {chosen}**",
        f"σ of adhesion.n from {now[n]:.3g} to {exp[n]:.3g} (a factor {now[n] / exp[n]:.2g})",
        f"σ of adhesion.v0 from {now[v0] * um:.3g} to {exp[v0] * um:.3g} µm/s (a factor {now[v0] / exp[v0]:.2g})",
        f"would give {uni[n]:.3g} and {uni[v0] * um:.3g} µm/s (factors {now[n] / uni[n]:.2g} and "
        f"{now[v0] / uni[v0]:.2g})",
        f"({got['fit_parameters'][v0] * um:.3g} µm/s and {got['fit_parameters'][n]:.3g}, where the truth is",
        f"({rel[-1]:.2g} % at 3 mm/s and 20 µm)",
        f"(they are {correlation:.2g} correlated)",
    ]


def test_the_planning_notebook_runs_and_answers_with_the_command_lines_numbers(tmp_path):
    t0 = time.monotonic()
    nb = execute(PLAN)
    seconds = time.monotonic() - t0
    got = key_numbers(nb)
    want, correlation = cli_plan_numbers(tmp_path)
    assert got == want
    assert got["design_chosen"] and sum(c["repeats"] for c in got["design_chosen"]) == 6
    # The closing answer (and the text before it) states the numbers the notebook computed.
    text = " ".join(" ".join(c.source.split()) for c in nb.cells if c.cell_type == "markdown")
    assert nb.cells[-1].cell_type == "markdown" and "What to measure next" in nb.cells[-1].source
    for phrase in plan_answer(got, correlation):
        assert phrase in text, f"the notebook's text does not say {phrase!r}"
    committed = need("nbformat").read(PLAN, as_version=4)
    assert key_numbers(committed) == got, (
        "the notebook's committed outputs are stale: re-execute it with "
        "`python python/tests/test_notebook.py --write plan-an-experiment` and commit it"
    )
    assert len(images(committed)) == 2
    assert seconds < 60, f"the notebook took {seconds:.0f} s: keep it well under a minute"


if __name__ == "__main__":
    notebooks = {p.stem: p for p in [NOTEBOOK, PLAN]}
    names = sys.argv[2:] or list(notebooks)
    if sys.argv[1:2] != ["--write"] or not set(names) <= set(notebooks):
        sys.exit("usage: python python/tests/test_notebook.py --write [first-study|plan-an-experiment ...]  "
                 "(re-execute the notebooks in place; all without a name)")
    for name in names:
        nb = execute(notebooks[name])
        need("nbformat").write(nb, notebooks[name])
        print(f"wrote {notebooks[name]}")

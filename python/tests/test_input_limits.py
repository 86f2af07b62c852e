"""Inputs that took the interpreter down (issue 24, defects 1 and 2) now raise ScenarioError:
a run too large for memory (refused before it starts), dicts and strings larger than a
scenario file, dicts nested deeper than the TOML parser allows or containing themselves.

The reproducers run in a child process, so that a regression (SIGSEGV, SIGABRT) fails the
test with the signal's name instead of killing pytest."""

import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import djkr
from conftest import ROOT

TINY = "tests/sweep/tiny.toml"
MIB = 1 << 20


@pytest.fixture(autouse=True)
def at_root(monkeypatch):
    monkeypatch.chdir(ROOT)


def in_child(code):
    """Run `code` (after `import djkr`) in a child Python; its stdout. A signal death fails."""
    p = subprocess.run([sys.executable, "-c", "import djkr, time\n" + code], cwd=ROOT,
                       capture_output=True, text=True, timeout=120)
    if p.returncode < 0:
        pytest.fail(f"killed by {signal.Signals(-p.returncode).name}: {p.stderr[-2000:]}")
    assert p.returncode == 0, p.stderr
    return p.stdout


def raises_scenario_error(code):
    """`code` (an expression) raises djkr.ScenarioError in a child: its message and seconds."""
    out = in_child(f"""
t0 = time.monotonic()
try:
    {code}
    print("RETURNED")
except djkr.ScenarioError as e:
    print(f"{{time.monotonic() - t0:.3f}}")
    print(e)
""")
    assert not out.startswith("RETURNED"), out
    seconds, message = out.split("\n", 1)
    return message.strip(), float(seconds)


def test_a_run_too_large_for_memory_is_refused_at_once():
    message, seconds = raises_scenario_error(
        f'djkr.run("{TINY}", set={{"stage[0].duration": 1e3, "output.sample_rate": 1e7}})')
    assert seconds < 1.0, seconds
    for needle in ["output.sample_rate = 10000000 1/s", "stage[0].duration = 1000 s",
                   "1.000e10 samples", "2.160e12 bytes", "2.0 TiB",
                   "solver.max_memory = 2147483648 bytes (2.0 GiB)", "raise solver.max_memory",
                   "lower output.sample_rate"]:
        assert needle in message, (needle, message)


def test_max_memory_is_the_budget():
    # The 0.05 s hold at 9e4/s: 4501 samples known, 972 216 bytes at 216 bytes a sample,
    # under 1 MiB (1 048 576 bytes); at 1.1e5/s, 5501 samples, 1 188 216 bytes: over.
    # Under the budget the run is not refused up front; its unload, whose length is not known
    # before it runs, then meets the cap while running (reason "memory") or ends first.
    budget = {"solver.max_memory": MIB}
    try:
        djkr.run(TINY, set={**budget, "output.sample_rate": 9e4})
    except RuntimeError as e:
        assert not isinstance(e, djkr.ScenarioError)
        assert e.run.summary["reason"] == "memory", e.run.summary
    with pytest.raises(djkr.ScenarioError, match=r"solver\.max_memory = 1048576 bytes"):
        djkr.run(TINY, set={**budget, "output.sample_rate": 1.1e5})


def test_a_dict_that_contains_itself_is_refused():
    message, _ = raises_scenario_error('d = {"version": 1}; d["self"] = d; djkr.run(d)')
    assert message == "<dict>: self: contains itself (a cycle): a scenario is a tree of dicts and lists"
    message, _ = raises_scenario_error(
        'l = [1]; l.append(l); djkr.run({"version": 1, "stage": l})')
    assert "stage[1]: contains itself" in message
    # A dict used twice side by side is no cycle.
    stage = {"kind": "hold", "duration": 0.01}
    djkr.run({**_tiny(), "stage": [stage, stage]}, set={"solver.max_steps": 3000})


def _tiny():
    import tomllib

    return tomllib.loads((ROOT / TINY).read_text())


@pytest.mark.parametrize("kind", ["dict", "list"])
def test_nesting_10000_deep_is_refused(kind):
    build = 'v = {"a": v}' if kind == "dict" else "v = [v]"
    message, _ = raises_scenario_error(f"""v = 1
    for _ in range(10_000): {build}
    djkr.run({{"version": 1, "x": v}})""")
    assert "nested more than 80 deep, the limit of a scenario file" in message, message


def test_the_depth_limit_is_the_toml_parsers():
    def nested(n):
        v = 1
        for _ in range(n):
            v = {"a": v}
        return v

    # 80 levels below the top, as a file may have them (a table header of 80 keys), pass the
    # conversion and the parser (and are refused as the unknown section they are); 81 do not.
    with pytest.raises(djkr.ScenarioError, match=r"^<dict>: \[x\]: unknown section"):
        djkr.run({"version": 1, "x": nested(80)})
    with pytest.raises(djkr.ScenarioError, match="nested more than 80 deep"):
        djkr.run({"version": 1, "x": nested(81)})
    with pytest.raises(djkr.ScenarioError, match="unknown top-level key"):
        djkr.run({"version": 1, "x": [nested(79)]})


def test_a_million_stages_are_refused_quickly():
    message, seconds = raises_scenario_error(
        'djkr.run({"version": 1, "stage": [{"kind": "hold", "duration": 0.1} for _ in range(10**6)]})')
    assert message == "<dict>: larger than 1048576 bytes (1 MiB), the limit for a scenario file"
    assert seconds < 2.0, seconds


def test_dicts_and_strings_are_held_to_the_file_limit():
    text = (ROOT / TINY).read_text()
    # Exactly 1 MiB with a comment: runs, like a file of that size; a byte more does not.
    pad = MIB - len(text.encode()) - 2
    djkr.run(text + "#" + "x" * pad + "\n")
    with pytest.raises(djkr.ScenarioError,
                       match=r"^<string>: 1048577 characters: larger than 1048576 bytes \(1 MiB\)"):
        djkr.run(text + "#" + "x" * (pad + 1) + "\n")
    # Counted in bytes (UTF-8), as in a file: µ is two.
    wide = text + "#" + "µ" * (pad // 2 + 1) + "\n"
    assert len(wide) <= MIB < len(wide.encode())
    with pytest.raises(djkr.ScenarioError,
                       match=rf"^<string>: {len(wide.encode())} bytes: larger than 1048576"):
        djkr.run(wide)
    # A dict under the limit by its values but over it once written as TOML.
    d = _tiny()
    d["stage"] = [{"kind": "hold", "duration": 1e-3}] * 30_000
    with pytest.raises(djkr.ScenarioError, match="larger than 1048576 bytes"):
        djkr.run(d)
    with pytest.raises(djkr.ScenarioError, match="^set: larger than 1048576"):
        djkr.run(TINY, set={"base.amplitude": "1" * MIB})
    with pytest.raises(djkr.ScenarioError, match="^grid: larger than 1048576"):
        djkr.sweep(TINY, grid={"base.amplitude": list(range(10**6))})


def test_wrong_types_are_scenario_errors_and_type_errors():
    calls = [
        lambda: djkr.run(42),
        lambda: djkr.run(TINY, set=[("base.amplitude", 1)]),
        lambda: djkr.run(TINY, set={1: 2}),
        lambda: djkr.run(TINY, out=5),
        lambda: djkr.run({"version": 1, "x": object()}),
        lambda: djkr.sweep(TINY, grid=5),
        lambda: djkr.sweep(TINY, jobs="2"),
        lambda: djkr.pulloff(400, "0.5mm", method=5),
        lambda: djkr.cycle([400], "1mm", "1mm"),
    ]
    for call in calls:
        with pytest.raises(djkr.ScenarioTypeError) as e:
            call()
        assert isinstance(e.value, djkr.ScenarioError)
        assert isinstance(e.value, TypeError)


def test_values_python_has_and_toml_has_not_are_scenario_errors():
    for call, match in [
        (lambda: djkr.run({"version": 10**400}), "version: an integer beyond the range"),
        (lambda: djkr.cycle(10**400, "1mm", "1mm"), "freq: an integer beyond the range"),
        (lambda: djkr.run({"version": "\ud800"}), "not valid Unicode text"),
        (lambda: djkr.run(TINY, set={"base.amplitude": "\ud800"}), "not valid Unicode text"),
        (lambda: djkr.sweep(TINY, seed=-1), r"seed = -1: must be a whole number"),
        (lambda: djkr.sweep(TINY, ensemble=2**70), r"ensemble = \d+: must be a whole number"),
    ]:
        with pytest.raises(djkr.ScenarioError, match=match):
            call()


def test_an_endless_iterator_is_not_read_forever():
    import itertools

    with pytest.raises(djkr.ScenarioError, match="expected \\(start, stop, n\\), got 4 values"):
        djkr.resonance("scenarios/resonance-400hz.toml", freq=itertools.count(1))

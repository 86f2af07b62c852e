"""Issue 35 in Python: long values quoted by their beginning (item 5), subnormal arguments
refused (item 10), and an ``out=`` folder that refuses a run raising ``OutputFolderError``, a
``ScenarioError``, in Python's words (item 13)."""

import inspect
import json

import pytest

import djkr
from conftest import ROOT, cli

TINY = "tests/sweep/tiny.toml"


@pytest.fixture(autouse=True)
def at_root(monkeypatch):
    monkeypatch.chdir(ROOT)


# -------------------------------------------------------------------------------------------
# Item 5: every message quotes at most ~80 characters of any value.

WORD = "x" * 100_000
NUM = "1" + WORD


def test_a_long_value_is_quoted_by_its_beginning_in_every_function(tmp_path):
    data = tmp_path / "data.csv"
    data.write_text("base.frequency [Hz],pull_off_amplification [1]\n300,1\n")
    calls = [
        # The reproducer.
        lambda: djkr.pulloff(400, 1e-3, method="x" * 10_000),
        lambda: djkr.pulloff(400, 1e-3, method=WORD),
        lambda: djkr.pulloff(NUM, 1e-3),
        lambda: djkr.pulloff(400, NUM),
        lambda: djkr.pulloff(400, 1e-3, method="approx", beta=NUM),
        lambda: djkr.cycle(400, NUM, "1mm"),
        lambda: djkr.cycle(400, "1mm", NUM),
        lambda: djkr.run(TINY, set={"base.amplitude": NUM}),
        lambda: djkr.run(TINY, set={WORD: 1}),
        lambda: djkr.run(TINY, set={f"stage[{WORD}].speed": 1}),
        lambda: djkr.run(TINY, out=tmp_path / WORD),
        lambda: djkr.run(WORD),
        lambda: djkr.validate(TINY, set={"base.frequency": NUM}),
        lambda: djkr.resonance(TINY, freq=(300, NUM, 3)),
        lambda: djkr.resonance(TINY, freq=(300, 400, 3), sweep=WORD),
        lambda: djkr.sweep(TINY, grid={"base.amplitude": ["1um", NUM]}),
        lambda: djkr.sweep(TINY, grid={"base.amplitude": ["1um", WORD]}),
        lambda: djkr.sweep(TINY, set={"base.amplitude": NUM}),
        lambda: djkr.sweep(TINY, grid={WORD: ["1um", "2um"]}),
        lambda: djkr.fit(data, TINY, free=f"adhesion.n={WORD}:1"),
        lambda: djkr.fit(data, TINY, free=f"adhesion.n=0.1:{NUM}"),
        lambda: djkr.fit(data, TINY, free=WORD),
        lambda: djkr.fit(data, TINY, free="adhesion.n", observable=WORD),
    ]
    for i, call in enumerate(calls):
        with pytest.raises(djkr.ScenarioError) as e:
            call()
        message = str(e.value)
        assert len(message) < 1000, (i, len(message), message[:300])
        assert "xxxxxxxxxx" in message and "bytes in all" in message, (i, message)


# -------------------------------------------------------------------------------------------
# Item 10: subnormal arguments are refused, as for every key.


@pytest.mark.parametrize(
    "call, name",
    [
        (lambda: djkr.pulloff(400, 5e-324), "a_amp = 5e-324"),
        (lambda: djkr.cycle(200, 1e-310, "1mm"), "a_mean = 1e-310"),
        (lambda: djkr.cycle(200, -1e-310, "1mm"), "a_mean = -1e-310"),
        (lambda: djkr.cycle(200, "1mm", 1e-310), "a_amp = 1e-310"),
    ],
)
def test_subnormal_arguments_are_refused(call, name):
    with pytest.raises(djkr.ScenarioError, match="is subnormal") as e:
        call()
    assert str(e.value).startswith(name), str(e.value)


def test_zero_and_normal_radii_still_run():
    assert djkr.pulloff(400, 0)["amplification"] > 0
    assert djkr.cycle(200, 0, "1mm")["a_amp"] == 1e-3
    assert djkr.cycle(200, "1mm", 2.3e-308)["a_mean_imposed"] == 1e-3


# -------------------------------------------------------------------------------------------
# Item 13: the out= folder refuses a run with OutputFolderError; force=True overwrites.


def test_output_folder_error_is_a_documented_scenario_error():
    assert issubclass(djkr.OutputFolderError, djkr.ScenarioError)
    assert issubclass(djkr.OutputFolderError, ValueError)
    assert "OutputFolderError" in djkr.__all__
    assert "force=True" in djkr.OutputFolderError.__doc__
    assert "OutputFolderError" in djkr.run.__doc__
    assert str(inspect.signature(djkr.run)) == "(scenario, set=None, out=None, force=False)"


def test_a_clash_in_out_is_refused_with_python_arguments_and_force_overwrites(tmp_path):
    out = tmp_path / "run"
    out.mkdir()
    mine = out / "summary.json"
    mine.write_text("my own notes\n")
    with pytest.raises(djkr.OutputFolderError) as e:
        djkr.run(TINY, out=out)
    message = str(e.value)
    assert "summary.json is already there and not written by djkr" in message, message
    assert "force=True" in message and "--force" not in message, message
    assert "out=" in message and "--out" not in message, message
    # Refused before it started: the user's file is as it was, nothing else written.
    assert mine.read_text() == "my own notes\n"
    assert not (out / "run.h5").exists()
    # The command line refuses the same folder with exit status 2.
    p = cli("run", TINY, "--out", out, check=False)
    assert p.returncode == 2, p.stderr
    assert "summary.json is already there" in p.stderr
    # force=True overwrites it, as --force does.
    r = djkr.run(TINY, out=out, force=True)
    assert r.summary["status"] == "ok"
    assert json.loads(mine.read_text()) == r.summary


def test_force_is_a_bool_and_needs_out(tmp_path):
    with pytest.raises(djkr.ScenarioError, match="force=True has no effect without out="):
        djkr.run(TINY, force=True)
    with pytest.raises(djkr.ScenarioTypeError, match="force: expected True or False, got str"):
        djkr.run(TINY, out=tmp_path / "r", force="no")
    assert not (tmp_path / "r").exists()
    # force=False is the default.
    assert djkr.run(TINY, out=tmp_path / "r", force=False).summary["status"] == "ok"


def test_the_disk_space_refusal_is_an_output_folder_error(tmp_path):
    # 1e13 samples of a hold of known duration: about a petabyte, more than any test disk holds;
    # the memory budget raised so that the disk's check is the one that refuses.
    out = tmp_path / "big"
    sets = {"stage[0].duration": 1e6, "output.sample_rate": 1e7, "solver.max_memory": 2**62}
    with pytest.raises(djkr.OutputFolderError) as e:
        djkr.run(TINY, out=out, set=sets)
    message = str(e.value)
    assert "the run's output would take about" in message and "free" in message, message
    assert "out=" in message and "--out" not in message, message
    assert not (out / "run.h5").exists() and not (out / "summary.json").exists()
    # The command line: exit status 2, the same refusal.
    args = [f"--set={k}={v}" for k, v in sets.items()]
    p = cli("run", TINY, "--out", tmp_path / "big-cli", *args, check=False)
    assert p.returncode == 2, p.stderr
    assert "the run's output would take about" in p.stderr


def test_a_failure_after_the_start_is_not_an_output_folder_error():
    # A run that a budget stops is a RuntimeError with its run, not a refusal.
    with pytest.raises(RuntimeError) as e:
        djkr.run(TINY, set={"solver.max_steps": 10})
    assert not isinstance(e.value, djkr.ScenarioError)
    assert e.value.run.summary["status"] == "stopped"

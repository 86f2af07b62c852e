"""Issue 35 in Python: long values quoted by their beginning (item 5), subnormal arguments
refused (item 10)."""

import pytest

import djkr
from conftest import ROOT

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

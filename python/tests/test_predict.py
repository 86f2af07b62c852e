"""`djkr.predict` (issue 34) against `djkr predict --json` for the same fit: the same numbers to
the bit, from the object `djkr.fit` returns as from the folder it wrote, the columns of
`prediction.csv` as arrays, and every refusal in Python's words.

The fit: adhesion.n of the paper protocol with short dwells (a run takes about 0.03 s) on three
rows whose amplifications djkr made at n = 0.5, moved by -1.5 %, +1 % and +0.5 % (sigma 2 %)."""

import math

import pytest

import djkr
from conftest import ROOT, cli, cli_error, cli_json

HEAVY = "scenarios/paper-protocol-300hz.toml"
SHORT = {"stage[1].duration": 0.05, "stage[2].duration": 0.1, "stage[3].speed": "100um/s"}
AMPLITUDES = ["5um", "10um", "20um"]


@pytest.fixture(autouse=True)
def at_root(monkeypatch):
    monkeypatch.chdir(ROOT)


@pytest.fixture(scope="module")
def made(tmp_path_factory):
    """(the Fit, its folder, the folder for outputs)."""
    tmp = tmp_path_factory.mktemp("predict")
    true = djkr.sweep(HEAVY, grid={"base.amplitude": AMPLITUDES},
                      set={**SHORT, "adhesion.n": 0.5})["pull_off_amplification"]
    lines = ["base.amplitude [um],pull_off_amplification [1],sigma [1]"]
    for a, v, moved in zip(AMPLITUDES, true, [-0.015, 0.01, 0.005]):
        v = float(v)
        lines.append(f"{a[:-2]},{v * (1 + moved)!r},{0.02 * v!r}")
    data = tmp / "data.csv"
    data.write_text("\n".join(lines) + "\n")
    folder = tmp / "fit"
    r = djkr.fit(data, HEAVY, free="adhesion.n", set=SHORT, out=folder)
    assert r["converged"] and r.sigma["adhesion.n"] > 0, r
    return r, folder, tmp


GRID = {"base.amplitude": ["7um", "15um"], "base.frequency": "250Hz"}
GRID_CLI = ["--set", "base.amplitude=7um,15um", "--set", "base.frequency=250Hz"]


def test_predict_equals_the_command_line_to_the_bit(made):
    r, folder, tmp = made
    want = cli_json("predict", "--fit", folder, *GRID_CLI, "--samples", "4", "--seed", "2",
                    "--out", tmp / "cli")
    # Python's json reads the shortest round-trip digits exactly: == is to the bit.
    from_object = djkr.predict(r, grid=GRID, samples=4, seed=2)
    from_folder = djkr.predict(str(folder), grid=GRID, samples=4, seed=2, out=tmp / "py")
    assert from_object.report == want
    assert from_folder.report == want
    assert len(from_object) == 2
    assert want["rows"][0]["sigma_parameters"] > 0 and want["rows"][0]["sigma_samples"] > 0
    # The files are the command line's too.
    for name in ["prediction.csv", "prediction.json"]:
        assert (tmp / "py" / name).read_bytes() == (tmp / "cli" / name).read_bytes(), name
    # The columns are prediction.csv's, parsed exactly.
    text = (tmp / "cli" / "prediction.csv").read_text().splitlines()
    head = text[0].split(",")
    assert list(from_object.columns) == head
    assert head[:3] == ["base.amplitude [m]", "base.frequency [Hz]", "value [1]"]
    assert head[-1] == "sigma_samples [1]"
    for j, name in enumerate(head):
        got = [float(x) for x in from_object.columns[name]]
        assert got == [float(line.split(",")[j]) for line in text[1:]], name
    df = from_object.to_pandas()
    assert list(df.columns) == head and len(df) == 2


def test_the_datas_own_conditions_and_another_observable(made):
    r, folder, tmp = made
    own = djkr.predict(r)
    assert list(own.columns["value [1]"]) == list(r.residuals["fitted [1]"])
    force = djkr.predict(r, grid=GRID, observable="pull_off_force")
    want = cli_json("predict", "--fit", folder, *GRID_CLI, "--observable", "pull_off_force",
                    "--out", tmp / "force")
    assert force.report == want
    assert force["unit"] == "N" and "value [N]" in force.columns
    assert any("pull_off_force predicted from a fit of pull_off_amplification" in n
               for n in force["notes"])


def test_refusals_are_in_pythons_words(made):
    r, folder, tmp = made
    cases = [
        (dict(samples=1), ["--samples", "1"], "samples = 1: must be 0 (none) or from 2 to 100000"),
        (dict(observable="pull_off_forc"), ["--observable", "pull_off_forc"],
         "observable = pull_off_forc: not an observable djkr produces; one of pull_off_force [N]"),
        (dict(ensemble=1), ["--ensemble", "1"], "ensemble = 1: must be a whole number >= 2"),
        (dict(seed=3), ["--seed", "3"],
         "seed = 3: seeds the draws of samples= and the phases of ensemble=; give one of them"),
    ]
    for kwargs, flags, words in cases:
        with pytest.raises(djkr.ScenarioError) as e:
            djkr.predict(r, **kwargs)
        message = str(e.value)
        assert message.startswith(words), message
        assert "--" not in message, message
        # The command line's message, its flags in Python's words.
        line = cli_error("predict", "--fit", folder, *flags, "--out", tmp / "bad")
        flag, value = flags
        line = line.replace(f"{flag} {value}", f"{flag[2:]} = {value}", 1)
        assert line.replace("--samples", "samples=").replace("--ensemble", "ensemble=") == message
    with pytest.raises(djkr.ScenarioError, match=r"^grid=\{'adhesion.n': \.\.\.\}: adhesion.n is "
                                                 r"a key the fit estimated, not a condition"):
        djkr.predict(r, grid={"adhesion.n": [0.4, 0.5]})
    with pytest.raises(djkr.ScenarioError, match=r"holds no fit \(no fit.json\): give the folder "
                                                 r"a fit wrote \(its out=\)"):
        djkr.predict(tmp)
    with pytest.raises(djkr.ScenarioTypeError, match="fit: expected what djkr.fit returned"):
        djkr.predict(3)
    with pytest.raises(djkr.ScenarioError, match="force=True has no effect without out="):
        djkr.predict(r, force=True)
    assert not (tmp / "bad").exists()
    # A nan sigma never appears where the fit has one.
    assert not any(math.isnan(x) for x in djkr.predict(r).columns["sigma [1]"])

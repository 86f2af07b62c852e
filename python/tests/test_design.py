"""`djkr.design` (issue 34) against `djkr design --json` for the same fit: the same numbers to
the bit, from the object `djkr.fit` returns as from the folder it wrote, the columns of
`design.csv` as arrays, and every refusal in one line of Python's words.

The fit: adhesion.v0 and adhesion.n of the cheap rig (the paper's protocol with 50 ms of preload
and 100 ms of vibration) to the bundled examples/data/pull-off-300hz.csv (made with v0 = 60 um/s,
n = 0.5 and 2 % noise; examples/data/README.md), as tests/cli/design.rs fits its CHEAP_DATA."""

import numpy as np
import pytest

import djkr
from conftest import ROOT, cli_error, cli_json

DATA = "examples/data/pull-off-300hz.csv"
SCENARIO = "scenarios/paper-protocol-300hz.toml"
SHORT = {"stage[1].duration": 0.05, "stage[2].duration": 0.1}
FREE = ["adhesion.v0", "adhesion.n"]
CANDIDATES = {"base.amplitude": "0um:20um:5", "stage[3].speed": "30um/s:3000um/s:5log"}
CANDIDATES_CLI = ["--candidates", "base.amplitude=0um:20um:5", "stage[3].speed=30um/s:3000um/s:5log"]


@pytest.fixture(autouse=True)
def at_root(monkeypatch):
    monkeypatch.chdir(ROOT)


@pytest.fixture(scope="module")
def made(tmp_path_factory):
    """(the Fit, the folder it wrote, a folder for outputs)."""
    tmp = tmp_path_factory.mktemp("design")
    folder = tmp / "fit"
    r = djkr.fit(DATA, SCENARIO, free=FREE, set=SHORT, out=folder)
    assert r["converged"], r
    return r, folder, tmp


def test_design_equals_the_command_line_to_the_bit(made):
    r, folder, tmp = made
    want = cli_json("design", "--fit", folder, *CANDIDATES_CLI, "--add", "6", "--out", tmp / "cli")
    # Python's json reads the shortest round-trip digits exactly: == is to the bit.
    from_object = djkr.design(r, CANDIDATES, add=6)
    from_folder = djkr.design(str(folder), CANDIDATES, add=6, out=tmp / "py")
    assert from_object.report == want
    assert from_folder.report == want
    # What the issue asks design.json to hold, in SI and the keys' units.
    assert want["criterion"] == "D" and want["sigma_measurement_from"] == "data"
    assert sum(c["repeats"] for c in want["chosen"]) == 6
    assert set(want["chosen"][0]["conditions"]) == {"base.amplitude", "stage[3].speed"}
    for name in ["current_sigma", "expected_sigma", "uniform_sigma"]:
        assert set(from_object[name]) == set(FREE), name
    assert from_object["expected_sigma"]["adhesion.n"] < from_object["uniform_sigma"]["adhesion.n"]
    # The files are the command line's too.
    for name in ["design.csv", "design.json"]:
        assert (tmp / "py" / name).read_bytes() == (tmp / "cli" / name).read_bytes(), name
    assert (tmp / "py" / "design.png").is_file()
    # The columns are design.csv's, parsed exactly; the repeats whole numbers.
    text = (tmp / "cli" / "design.csv").read_text().splitlines()
    head = text[0].split(",")
    assert list(from_object.columns) == head
    assert head[:3] == ["base.amplitude [m]", "stage[3].speed [m/s]", "value [1]"]
    for j, name in enumerate(head):
        got = [float(x) for x in from_object.columns[name]]
        assert got == [float(line.split(",")[j]) for line in text[1:]], name
    for name in ["repeats [1]", "uniform_repeats [1]"]:
        assert from_object.columns[name].dtype == np.int64, name
    df = from_object.to_pandas()
    assert list(df.columns) == head and len(df) == 25
    assert df["repeats [1]"].sum() == 6


def test_the_options_are_the_command_lines(made):
    """An absolute sigma, one key's variance, no repeats; a relative sigma as a string."""
    r, folder, tmp = made
    want = cli_json("design", "--fit", folder, *CANDIDATES_CLI, "--add", "4", "--sigma", "0.08",
                    "--criterion", "adhesion.n", "--no-repeats", "--out", tmp / "options")
    got = djkr.design(r, CANDIDATES, add=4, sigma=0.08, criterion="adhesion.n", repeats=False)
    assert got.report == want
    assert want["sigma_measurement"] == {"absolute": 0.08} and want["criterion"] == "adhesion.n"
    assert want["repeats"] is False and all(c["repeats"] == 1 for c in want["chosen"])
    want = cli_json("design", "--fit", folder, "--candidates", "base.amplitude=5um,10um,20um",
                    "--add", "3", "--sigma", "3%", "--criterion", "A", "--out", tmp / "relative")
    got = djkr.design(str(folder), {"base.amplitude": ["5um", "10um", 2e-5]}, add=3, sigma="3%",
                      criterion="A")
    assert got.report == want
    assert want["sigma_measurement"] == {"relative": 0.03}


def one_line(call, exc=djkr.ScenarioError):
    with pytest.raises(exc) as e:
        call()
    message = str(e.value)
    assert "\n" not in message and "--" not in message, message
    return message


def test_refusals_are_one_line_in_pythons_words(made):
    r, folder, tmp = made
    bad = tmp / "bad"
    grid = {"base.amplitude": "0um:20um:5"}
    # Each with the command line's message for the same input, its flags in Python's words.
    cases = [
        (dict(candidates=grid, add=0), ["--candidates", "base.amplitude=0um:20um:5", "--add", "0"],
         "add = 0: must be a whole number from 1 to 10000"),
        (dict(candidates={"adhesion.n": [0.4, 0.5]}, add=2),
         ["--candidates", "adhesion.n=0.4,0.5", "--add", "2"],
         "candidates={'adhesion.n': ...}: adhesion.n is a key the fit estimated, not a condition"),
        (dict(candidates={"base.amplitude": "10um"}, add=2),
         ["--candidates", "base.amplitude=10um", "--add", "2"],
         "candidates={'base.amplitude': ...}: the candidates are one point"),
        (dict(candidates={"base.amplitude": "10um", "base.frequency": 300}, add=2),
         ["--candidates", "base.amplitude=10um", "base.frequency=300", "--add", "2"],
         "candidates={'base.amplitude': ..., 'base.frequency': ...}: the candidates are one point"),
        (dict(candidates=grid, add=6, repeats=False),
         ["--candidates", "base.amplitude=0um:20um:5", "--add", "6", "--no-repeats"],
         "add = 6: with repeats=False at most the 5 candidates"),
        (dict(candidates=grid, add=2, criterion="adhesion.w0"),
         ["--candidates", "base.amplitude=0um:20um:5", "--add", "2", "--criterion", "adhesion.w0"],
         "criterion = adhesion.w0: must be D, A or a free key of the fit (adhesion.v0, adhesion.n)"),
        (dict(candidates=grid, add=2, sigma="0%"),
         ["--candidates", "base.amplitude=0um:20um:5", "--add", "2", "--sigma=0%"],
         "sigma = 0%: a relative sigma must be a percentage above 0 and at most 1000 %"),
        (dict(candidates=grid, add=2, sigma=-0.1),
         ["--candidates", "base.amplitude=0um:20um:5", "--add", "2", "--sigma=-0.1"],
         "sigma = -0.1: must be a positive value in the unit of pull_off_amplification"),
    ]
    for kwargs, flags, words in cases:
        message = one_line(lambda: djkr.design(r, **kwargs))
        assert message.startswith(words), message
        line = cli_error("design", "--fit", folder, *flags, "--out", bad)
        python = (line.replace("--add ", "add = ").replace("--criterion ", "criterion = ")
                  .replace("--sigma ", "sigma = ").replace("--no-repeats", "repeats=False"))
        if line.startswith("--candidates "):
            # The command line quotes the axes as typed; Python names their keys.
            python = words[:words.index("}: ") + 1] + line[line.index(": "):]
        assert python == message, (line, message)
    # A candidate key that is no scenario key: as sweep's grid= words it.
    message = one_line(lambda: djkr.design(r, {"foo.bar": [1, 2]}, add=2))
    assert message.startswith("candidates={'foo.bar': ...}: unknown section 'foo'"), message
    # A folder without a fit, and what is neither a fit nor a folder.
    message = one_line(lambda: djkr.design(tmp, grid, add=2))
    assert f"fit = {tmp}: holds no fit (no fit.json): give the folder a fit wrote (its out=)" \
        == message, message
    message = one_line(lambda: djkr.design(3, grid, add=2), djkr.ScenarioTypeError)
    assert message.startswith("fit: expected what djkr.fit returned or a fit's folder"), message
    # No candidates at all, and candidates that are not a dict.
    message = one_line(lambda: djkr.design(r, {}, add=2))
    assert message.startswith("candidates: give the conditions one could measure as a dict")
    one_line(lambda: djkr.design(r, ["base.amplitude=1um,2um"], add=2), djkr.ScenarioTypeError)
    one_line(lambda: djkr.design(r, grid, add=2, force=True))
    assert not bad.exists()


def test_data_without_sigma_ask_for_sigma(made, tmp_path):
    """A fit whose data carry no sigma (its residuals.csv without them): the noise of a new
    measurement is not known, and sigma= gives it."""
    r, folder, tmp = made
    bare = tmp_path / "fit"
    bare.mkdir()
    for name in ["fit.json", "fitted.toml"]:
        (bare / name).write_bytes((folder / name).read_bytes())
    lines = (folder / "residuals.csv").read_text().splitlines()
    j = lines[0].split(",").index("sigma [1]")
    (bare / "residuals.csv").write_text("\n".join(
        ",".join(c if i != j or n == 0 else "" for i, c in enumerate(line.split(",")))
        for n, line in enumerate(lines)) + "\n")
    grid = {"base.amplitude": "0um:20um:5"}
    message = one_line(lambda: djkr.design(bare, grid, add=2))
    assert message == (
        f"fit = {bare}: the fit's data carry no sigma, so the noise of a new measurement is not "
        "known: give it with sigma= (e.g. 2% of the prediction, or a value in 1)"), message
    d = djkr.design(bare, grid, add=2, sigma="2%")
    assert d["sigma_measurement_from"] == "sigma" and d["sigma_measurement"] == {"relative": 0.02}
    want = cli_json("design", "--fit", folder, "--candidates", "base.amplitude=0um:20um:5",
                    "--add", "2", "--sigma", "2%", "--out", tmp / "bare")
    assert d.report == want

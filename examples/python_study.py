"""djkr from Python: the README's amplification study and a resonance curve, with matplotlib.

    pip install ./python matplotlib
    python examples/python_study.py OUT_DIR [--full]

1. The paper protocol at 300 Hz (scenarios/paper-protocol-300hz.toml) swept over the base
   amplitude X_b: the pull-off amplification grows faster than linearly with X_b (README,
   "A worked study"; the `djkr sweep` of the same grid gives the same numbers bit for bit).
   The default runs X_b = 10, 30 and 60 um; `--full` the README's six amplitudes at 200, 300
   and 400 Hz.
2. The frequency response of scenarios/resonance-400hz.toml, up and down sweeps by
   continuation, with the harmonic-balance prediction (README, `djkr resonance`).

Writes OUT_DIR/amplification.png and OUT_DIR/resonance.png and prints the tables. Run from the
repository root (the scenario paths are relative to it). `python/tests` runs it.
"""

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only, no display
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import djkr  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
PROTOCOL = ROOT / "scenarios" / "paper-protocol-300hz.toml"
RESONANCE = ROOT / "scenarios" / "resonance-400hz.toml"


def amplification_study(out: Path, full: bool) -> None:
    amplitudes = ["10um", "20um", "30um", "40um", "50um", "60um"] if full else ["10um", "30um", "60um"]
    frequencies = [200, 300, 400] if full else [300]
    rows = djkr.sweep(
        PROTOCOL,
        grid={"base.frequency": frequencies, "base.amplitude": amplitudes},
    )
    assert all(s == "ok" for s in rows["status"]), rows["error"]
    fig, ax = plt.subplots(figsize=(6, 4))
    print("pull-off amplification of the paper protocol (F_po / (-3/2 pi R w0))")
    print("X_b [um]   " + "  ".join(f"{f:>7.0f} Hz" for f in frequencies))
    table = {}
    for f in frequencies:
        sel = rows["base.frequency"] == f
        xb, amp = rows["base.amplitude"][sel], rows["pull_off_amplification"][sel]
        table[f] = amp
        ax.plot(xb * 1e6, amp, "o-", label=f"{f:.0f} Hz")
    for i, xb in enumerate(rows["base.amplitude"][rows["base.frequency"] == frequencies[0]]):
        print(f"{xb * 1e6:8.0f}   " + "  ".join(f"{table[f][i]:10.3f}" for f in frequencies))
    ax.set_xlabel("base amplitude X_b (um)")
    ax.set_ylabel("pull-off amplification")
    ax.set_title("paper protocol: amplification against X_b")
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "amplification.png", dpi=120)
    plt.close(fig)


def resonance_curve(out: Path) -> None:
    res = djkr.resonance(RESONANCE, freq=(300, 500, 41), sweep="both")
    fig, ax = plt.subplots(figsize=(6, 4))
    for direction, style in (("up", "o-"), ("down", "x")):
        sel = res["direction"] == direction
        order = np.argsort(res["frequency"][sel])
        f = res["frequency"][sel][order]
        ax.plot(f, res["delta_amp_over_xb"][sel][order], style, label=f"time domain, sweep {direction}")
        if direction == "up":
            ax.plot(f, res["hb_delta_amp_over_xb"][sel][order], "--", label="harmonic balance")
            ax.plot(f, res["linear_delta_amp_over_xb"][sel][order], ":", label="linear transfer")
    up = res["direction"] == "up"
    # The peak as djkr resonance finds it, between the 5 Hz steps (not the highest grid point).
    peak = djkr.resonance_peak(res["frequency"][up], res["delta_amp_over_xb"][up])
    if "no_peak_in_range" in peak:
        print(f"resonance of {RESONANCE.name}: no peak in range, {peak['no_peak_in_range']}")
    else:
        print(
            f"resonance of {RESONANCE.name}: peak |delta_A/X_b| = "
            f"{peak['height']:.3f} at {peak['frequency']:.2f} Hz (sweep up)"
        )
        ax.plot(peak["frequency"], peak["height"], "k+", ms=12, label="peak")
    ax.set_xlabel("frequency f (Hz)")
    ax.set_ylabel("|delta_A / X_b|")
    ax.set_title("frequency response, resonance-400hz")
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "resonance.png", dpi=120)
    plt.close(fig)


def main() -> None:
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    out = Path(sys.argv[1])
    out.mkdir(parents=True, exist_ok=True)
    amplification_study(out, full="--full" in sys.argv[2:])
    resonance_curve(out)
    print(f"wrote {out / 'amplification.png'} and {out / 'resonance.png'}")


if __name__ == "__main__":
    main()

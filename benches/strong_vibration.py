#!/usr/bin/env python3
"""Release-build benchmarks of the strong-vibration engine (issue 11), in one run.

    cargo build --release
    python3 benches/strong_vibration.py [--peer PATH/TO/peer] [--repeats N] [--pair-repeats N]
                                        [--skip-reference] [--only table|full|peer]

1. The 18-point table: scenarios/paper-protocol-{200,300,400}hz.toml with [base] amplitude
   10, 20, 60, 80, 100, 150 um and the unload's max_duration 400 s, `auto`, rtol 1e-8, two
   runs at a time (2 cores); wall time of the whole table (median of the passes) and every
   pull-off against a converged implicit run (rtol 1e-9, computed here unless --skip-reference).
2. The paper's protocol at full length (60 s dwells, 300 Hz, 12 kHz samples): wall time and
   peak RSS of `djkr run` (median of the repeats).
3. With --peer: `djkr run benches/scenes/vib400.toml` against `peer rk8pd RTOL vib400` (the
   compiled C/GSL peer) at rtol 1e-6, 1e-8, 1e-10, and djkr at 1e-7 against the peer at 1e-8
   (equal accuracy): each program's self-error (a(1 s) against its own run at rtol 1e-12),
   whole-process wall and CPU times (median of interleaved runs, each started with
   posix_spawn, so that the fork of this Python process is not counted; every djkr run
   replaces the previous one's files in the same directory), their ratio, and each program's
   own integration time.

Prints a markdown report. Nothing is written into the repository; run outputs go to a
temporary directory. Timings on a shared machine are noisy: the report gives medians and the
load average.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# DJKR_BIN: another build to measure (e.g. a copy, so that rebuilding does not disturb a run).
DJKR = os.environ.get("DJKR_BIN", os.path.join(ROOT, "target", "release", "djkr"))


def run_child(argv):
    """Run argv for its output: (wall s, stdout)."""
    t0 = time.perf_counter()
    p = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    out, err = p.communicate()
    wall = time.perf_counter() - t0
    if p.returncode != 0:
        raise RuntimeError(f"{' '.join(argv)} failed: {err.decode()[-500:]}")
    return wall, out.decode()


def _finish(argv, pid, r, t0):
    """Read the child's stdout from pipe `r` to its end and reap it: (wall s, rusage, stdout)."""
    chunks = []
    while True:
        b = os.read(r, 65536)
        if not b:
            break
        chunks.append(b)
    _, status, ru = os.wait4(pid, 0)
    wall = time.perf_counter() - t0
    os.close(r)
    if status != 0:
        raise RuntimeError(f"{' '.join(argv)} failed with status {status}")
    return wall, ru, b"".join(chunks).decode()


def run_measured(argv):
    """Run argv with os.wait4: (wall s, cpu s, peak RSS bytes, stdout)."""
    r, w = os.pipe()
    t0 = time.perf_counter()
    pid = os.fork()
    if pid == 0:
        os.dup2(w, 1)
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, 2)
        os.close(r)
        os.execv(argv[0], argv)
    os.close(w)
    wall, ru, text = _finish(argv, pid, r, t0)
    return wall, ru.ru_utime + ru.ru_stime, ru.ru_maxrss * 1024, text


def run_timed(argv):
    """Run argv for its times: (wall s, cpu s, stdout). posix_spawn (glibc: clone with
    CLONE_VM | CLONE_VFORK) starts the program without copying this Python process, whose
    fork alone costs milliseconds and would be counted in the child's CPU time and wall time
    alike for both programs, compressing their ratio towards 1. (Peak RSS is not reported:
    a vforked child's maxrss is the parent's.)"""
    r, w = os.pipe()
    t0 = time.perf_counter()
    pid = os.posix_spawn(argv[0], argv, os.environ, file_actions=[
        (os.POSIX_SPAWN_DUP2, w, 1),
        (os.POSIX_SPAWN_OPEN, 2, os.devnull, os.O_WRONLY, 0),
        (os.POSIX_SPAWN_CLOSE, r),
    ])
    os.close(w)
    wall, ru, text = _finish(argv, pid, r, t0)
    return wall, ru.ru_utime + ru.ru_stime, text


def djkr_json(args, out):
    _, text = run_child([DJKR, "run", *args, "--out", out, "--json"])
    return json.loads(text)


def table18(tmp, passes, reference):
    freqs = [200, 300, 400]
    amps = [10, 20, 60, 80, 100, 150]
    points = [(f, a) for f in freqs for a in amps]

    def one(p, extra, tag):
        f, a = p
        out = os.path.join(tmp, f"t18-{tag}-{f}-{a}")
        return djkr_json(
            [os.path.join(ROOT, f"scenarios/paper-protocol-{f}hz.toml"),
             "--set", f"base.amplitude={a}um", "--set", "stage[3].max_duration=400", *extra],
            out)

    walls = []
    results = None
    for k in range(passes):
        t0 = time.perf_counter()
        with ThreadPoolExecutor(2) as ex:
            results = list(ex.map(lambda p: one(p, [], f"p{k}"), points))
        walls.append(time.perf_counter() - t0)
    refs = None
    if reference:
        with ThreadPoolExecutor(2) as ex:
            refs = list(ex.map(lambda p: one(p, ["--set", "solver.method=implicit",
                                                 "--set", "solver.rtol=1e-9",
                                                 "--set", "solver.envelope=off"], "ref"), points))
    print("## 1. The 18-point table (auto, rtol 1e-8, 2 runs at a time)\n")
    print(f"Whole table: median {statistics.median(walls):.2f} s over {passes} passes "
          f"({', '.join(f'{w:.2f}' for w in walls)} s).\n")
    print("| f (Hz) | X_b (um) | amplification | run wall (s) | periods skipped |"
          + (" vs implicit rtol 1e-9 |" if refs else ""))
    print("|---|---|---|---|---|" + ("---|" if refs else ""))
    worst = 0.0
    for i, (f, a) in enumerate(points):
        r = results[i]
        row = (f"| {f} | {a} | {r['pull_off']['amplification']:.4f} | "
               f"{r['stats']['wall_s']:.3f} | {r['envelope']['periods_skipped']} |")
        if refs:
            rel = abs(r["pull_off"]["force"] / refs[i]["pull_off"]["force"] - 1)
            worst = max(worst, rel)
            row += f" {rel:.1e} |"
        print(row)
    if refs:
        print(f"\nWorst pull-off difference from the implicit reference: {worst:.1e}.\n")


def full_length(tmp, repeats):
    argv = [DJKR, "run", os.path.join(ROOT, "scenarios/paper-protocol-300hz.toml"),
            "--set", "stage[1].duration=60", "--set", "stage[2].duration=60",
            "--out", os.path.join(tmp, "full"), "--json"]
    rows = [run_measured(argv) for _ in range(repeats)]
    j = json.loads(rows[-1][3])
    print("## 2. The paper's protocol at full length (60 s dwells, 300 Hz, 12 kHz samples)\n")
    print(f"Wall {statistics.median(r[0] for r in rows):.3f} s, CPU "
          f"{statistics.median(r[1] for r in rows):.3f} s, peak RSS "
          f"{statistics.median(r[2] for r in rows) / 2**20:.1f} MiB (medians of {repeats}); "
          f"{j['samples']} samples, run.h5 {j['file_bytes']['run.h5'] / 1e6:.0f} MB, "
          f"{j['envelope']['periods_skipped']} periods skipped, amplification "
          f"{j['pull_off']['amplification']:.4f}.\n")


def peer_compare(tmp, peer, repeats, pair_repeats):
    scene = os.path.join(ROOT, "benches/scenes/vib400.toml")
    out = os.path.join(tmp, "vib400")

    def djkr_argv(rtol):
        return [DJKR, "run", scene, "--set", f"solver.rtol={rtol}", "--out", out]

    def peer_argv(rtol):
        return [peer, "rk8pd", f"{rtol}", "vib400"]

    def integration_ms(text_or_none):
        # djkr: the run's own integration time from summary.json (stats.wall_s: the simulation
        # with its samples and period records, without start-up and file writing).
        if text_or_none is None:
            with open(os.path.join(out, "summary.json")) as f:
                return json.load(f)["stats"]["wall_s"] * 1e3
        # peer: its monotonic clock around the integration.
        return json.loads(text_or_none)["wall_integration_s"] * 1e3

    ref_d = djkr_json([scene, "--set", "solver.rtol=1e-12", "--set", "solver.envelope=off"], out)
    a_ref_d = ref_d["final_state"]["a"]
    a_ref_p = json.loads(run_child(peer_argv(1e-12))[1])["y_end"][2]
    print("## 3. djkr against the compiled peer on vib400 (1 s at 400 Hz)\n")
    print("Self-error: |a(1 s) − a_ref(1 s)| / a_ref against each program's own rtol 1e-12 run "
          "(djkr's reference without envelope following). Whole-process medians of "
          f"{repeats} interleaved runs ({pair_repeats} for the last row); integration: djkr's "
          "`stats.wall_s` (the simulation with "
          "its samples and period records, without start-up and files), the peer's "
          "`wall_integration_s`. The last row pairs the two at equal accuracy (djkr's error "
          "below the peer's).\n")
    print("| rtol djkr / peer | djkr self-error | peer self-error | djkr wall (ms) | "
          "peer wall (ms) | wall ratio | djkr CPU (ms) | peer CPU (ms) | CPU ratio | "
          "djkr integration (ms) | peer integration (ms) | djkr rhs evals | peer nfev |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for rd, rp in [(1e-6, 1e-6), (1e-8, 1e-8), (1e-10, 1e-10), (1e-7, 1e-8)]:
        dj = djkr_json([scene, "--set", f"solver.rtol={rd}"], out)
        pj = json.loads(run_child(peer_argv(rp))[1])
        e_d = abs(dj["final_state"]["a"] - a_ref_d) / a_ref_d
        e_p = abs(pj["y_end"][2] - a_ref_p) / a_ref_p
        d_runs, p_runs, d_int, p_int = [], [], [], []
        for _ in range(pair_repeats if (rd, rp) == (1e-7, 1e-8) else repeats):
            d_runs.append(run_timed(djkr_argv(rd)))
            d_int.append(integration_ms(None))
            p_runs.append(run_timed(peer_argv(rp)))
            p_int.append(integration_ms(p_runs[-1][2]))
        dw = statistics.median(r[0] for r in d_runs)
        pw = statistics.median(r[0] for r in p_runs)
        dc = statistics.median(r[1] for r in d_runs)
        pc = statistics.median(r[1] for r in p_runs)
        wr = statistics.median(d[0] / p[0] for d, p in zip(d_runs, p_runs))
        cr = statistics.median(d[1] / max(p[1], 1e-6) for d, p in zip(d_runs, p_runs))
        print(f"| {rd:.0e} / {rp:.0e} | {e_d:.1e} | {e_p:.1e} | {dw * 1e3:.1f} | "
              f"{pw * 1e3:.1f} | {wr:.2f} | {dc * 1e3:.1f} | {pc * 1e3:.1f} | {cr:.2f} | "
              f"{statistics.median(d_int):.2f} | {statistics.median(p_int):.2f} | "
              f"{dj['stats']['rhs_evals']} | {pj['nfev']} |")
    print()


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--peer", help="path to the compiled peer (../shared/peers/c-gsl/peer)")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--pair-repeats", type=int,
                    help="interleaved runs of the equal-accuracy pair (default: --repeats)")
    ap.add_argument("--passes", type=int, default=2)
    ap.add_argument("--skip-reference", action="store_true")
    ap.add_argument("--only", choices=["table", "full", "peer"])
    a = ap.parse_args()
    if not os.path.exists(DJKR):
        sys.exit(f"{DJKR} missing: run `cargo build --release` first")
    print("# Strong-vibration benchmarks\n")
    print(f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, {os.cpu_count()} CPUs, "
          f"load average {' '.join(f'{x:.2f}' for x in os.getloadavg())}.\n")
    with tempfile.TemporaryDirectory() as tmp:
        if a.only in (None, "table"):
            table18(tmp, a.passes, not a.skip_reference)
        if a.only in (None, "full"):
            full_length(tmp, a.repeats)
        if a.only in (None, "peer"):
            if a.peer:
                peer_compare(tmp, os.path.abspath(a.peer), a.repeats,
                             a.pair_repeats or a.repeats)
            else:
                print("(peer comparison skipped: give --peer PATH)\n")


if __name__ == "__main__":
    main()

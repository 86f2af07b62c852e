//! Continuation of periodic orbits (`djkr continue`, [`djkr_core::continuation`]) against independent
//! references: the jumps of up and down sweeps bracket the folds, the multiplier at a fold is 1,
//! a linear system reproduces the linear transfer and e^{λT}, the branch is the same traced
//! either way, and the fold curves agree with the branches they summarise.

use djkr::scenario::family::parameter;
use djkr::scenario::overrides::Override;
use djkr::scenario::parse::ScenarioSource;
use djkr_core::continuation::branch::{self, Branch, PointKind, Settings};
use djkr_core::continuation::family::{Family, Parameter};
use djkr_core::continuation::folds;
use djkr_core::continuation::ContinuationError;
use djkr_core::describing::{self, Setup};
use djkr_core::steady::sweep::{self as fsweep, Direction};
use djkr_core::steady::{Options, Problem};
use djkr_core::transfer;
use nalgebra::Complex;
use std::path::{Path, PathBuf};
use std::process::Command;

fn resonance_file() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/resonance-400hz.toml")
}

fn source() -> ScenarioSource {
    ScenarioSource::read(&resonance_file()).unwrap_or_else(|e| panic!("{e}"))
}

fn set(text: &str) -> Override {
    Override::parse(text).unwrap_or_else(|e| panic!("{e}"))
}

/// The family of a scenario file with fixed overrides and free keys (the scene `djkr continue`
/// builds).
fn new_family(
    src: ScenarioSource,
    fixed: Vec<Override>,
    params: Vec<Parameter>,
    rtol: f64,
) -> Result<Family, ContinuationError> {
    djkr::scenario::family::family(&src, &fixed, params, rtol)
}

fn param(key: &str) -> Parameter {
    parameter("--param", key).unwrap_or_else(|e| panic!("{e}"))
}

/// The bundled resonance scene at X_b = `xb` continued in frequency over `range`.
fn frequency_branch(xb: &str, range: (f64, f64)) -> Branch {
    let fam = new_family(
        source(),
        vec![set(&format!("base.amplitude={xb}"))],
        vec![param("base.frequency")],
        1e-10,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    branch::continue_branch(&fam, range, &Settings::default(), &mut |_| {})
        .unwrap_or_else(|e| panic!("{e}"))
}

fn folds_of(b: &Branch) -> Vec<f64> {
    b.of_kind(PointKind::Fold).map(|p| p.value).collect()
}

/// The sweep's (frequency, |δ1|/X_b or NaN) in the order swept.
fn swept(p: &Problem, freqs: &[f64], dir: Direction) -> Vec<(f64, f64)> {
    let sw = fsweep::sweep(
        p,
        &djkr_core::dynamics::protocol::Initial::Preload(0.05),
        freqs,
        dir,
        &Options::default(),
        None,
        &|_, _| {},
    );
    sw.points
        .iter()
        .map(|pt| {
            (
                pt.frequency,
                pt.steady
                    .as_ref()
                    .map_or(f64::NAN, |s| s.transfer_magnitude()),
            )
        })
        .collect()
}

/// The first jump of a sweep: the last frequency before |δ1|/X_b changes by more than 20 %
/// (or goes missing), and the next frequency.
fn first_jump(v: &[(f64, f64)]) -> (f64, f64) {
    v.windows(2)
        .find(|w| !(w[1].1.is_finite() && (w[1].1 - w[0].1).abs() < 0.2 * w[0].1))
        .map(|w| (w[0].0, w[1].0))
        .unwrap_or_else(|| panic!("no jump in {v:?}"))
}

#[test]
fn folds_sit_between_the_jumps_of_fine_sweeps_and_have_multiplier_one() {
    // X_b = 1.5 µm: the README's hysteretic resonance (up-sweep jump near 448 Hz, down-sweep
    // jump near 440 Hz).
    let b = frequency_branch("1.5um", (340.0, 600.0));
    let f = folds_of(&b);
    assert_eq!(f.len(), 2, "folds {f:?}");
    let (upper, lower) = (f[0].max(f[1]), f[0].min(f[1]));

    let scn = source().scenario(&[]).unwrap_or_else(|e| panic!("{e}"));
    let (p, _) = Problem::from_plan(&scn.plan()).unwrap_or_else(|e| panic!("{e}"));
    let p = p.at(440.0, 1.5e-6).unwrap_or_else(|e| panic!("{e}"));
    // Up from 440 Hz (only the upper branch exists there) in 0.2 Hz steps.
    let up = swept(&p, &fsweep::frequencies(440.0, 451.0, 56), Direction::Up);
    let (a, c) = first_jump(&up);
    assert!(
        a < upper && upper < c,
        "up sweep jumps between {a} and {c}, fold at {upper}"
    );
    // Down from 444 Hz on the lower branch (the scene's start lands on it) in 0.1 Hz steps.
    let down = swept(&p, &fsweep::frequencies(439.0, 444.0, 51), Direction::Down);
    assert!(
        down[0].1 < 8.0,
        "444 Hz should start on the lower branch: {:?}",
        down[0]
    );
    let (a, c) = first_jump(&down);
    assert!(
        c < lower && lower < a,
        "down sweep jumps between {a} and {c}, fold at {lower}"
    );

    for p in b.of_kind(PointKind::Fold) {
        // The branch turns back (tangent's parameter component through 0) and one real
        // multiplier is +1, to the corrector tolerance.
        assert!(p.tangent_parameter.abs() < 1e-8, "{p:?}");
        let mu = p.multipliers[0];
        assert!(
            (mu - Complex::new(1.0, 0.0)).norm() < 1e-8,
            "largest multiplier at the fold {}: {mu}",
            p.value
        );
        assert!(p.multipliers[1].norm() < 0.9);
    }
    // Stable, unstable, stable: the middle branch between the folds is unstable (a real
    // multiplier above 1), the outer ones stable.
    let unstable: Vec<f64> = b
        .points
        .iter()
        .filter(|p| !p.stable())
        .map(|p| p.value)
        .collect();
    assert!(unstable.len() > 5, "{unstable:?}");
    assert!(unstable
        .iter()
        .all(|&f| f > lower - 1e-6 && f < upper + 1e-6));
    for p in &b.points {
        if p.kind == PointKind::Regular {
            let between = p.value > lower && p.value < upper;
            if !between {
                assert!(
                    p.stable(),
                    "{} Hz outside the folds: {:?}",
                    p.value,
                    p.multipliers
                );
            }
        }
    }
    assert!(b.points.first().is_some_and(|p| p.stable()));
    assert_eq!(b.end, branch::BranchEnd::Range);
    // The whole branch, unstable part included, in well under a second (release; the
    // benchmark `cargo bench --bench continuation` measures it).
    eprintln!(
        "branch: {} points, {} periods, {:.3} s; folds {f:?}",
        b.points.len(),
        b.periods,
        b.wall_s
    );
}

#[test]
fn the_branch_is_the_same_traced_up_and_down() {
    let up = frequency_branch("1.5um", (340.0, 600.0));
    let down = frequency_branch("1.5um", (600.0, 340.0));
    let (mut fu, mut fd) = (folds_of(&up), folds_of(&down));
    fu.sort_by(f64::total_cmp);
    fd.sort_by(f64::total_cmp);
    assert_eq!(fu.len(), 2);
    assert_eq!(fd.len(), 2);
    for (a, b) in fu.iter().zip(&fd) {
        assert!((a - b).abs() < 1e-9 * a, "folds up {fu:?} down {fd:?}");
    }
    // The ends agree (each branch's start is the other's end).
    let ends = |b: &Branch, f: f64| {
        b.points
            .iter()
            .find(|p| (p.value - f).abs() < 1e-9)
            .map(|p| p.delta_amp_over_xb())
            .unwrap_or(f64::NAN)
    };
    for f in [340.0, 600.0] {
        let (a, b) = (ends(&up, f), ends(&down, f));
        assert!((a - b).abs() < 1e-8 * a, "{f} Hz: {a} vs {b}");
    }
    // Every fifth point of the down branch is the orbit shooting finds at its frequency from
    // the nearest point of the up branch (the unstable middle branch included: Newton does not
    // care about stability).
    let fam = new_family(
        source(),
        vec![set("base.amplitude=1.5um")],
        vec![param("base.frequency")],
        1e-10,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let near = |f: f64, y: f64| {
        up.points
            .iter()
            .min_by(|a, b| {
                let d = |p: &branch::BranchPoint| {
                    ((p.value - f) / 260.0).hypot((p.delta_amp_over_xb() - y) / 15.0)
                };
                d(a).total_cmp(&d(b))
            })
            .unwrap_or_else(|| panic!("empty branch"))
    };
    let mut worst = 0.0f64;
    // (Not at the folds themselves, where P − I is singular and shooting at fixed f cannot
    // converge.)
    for d in down
        .points
        .iter()
        .step_by(5)
        .filter(|p| p.kind == PointKind::Regular)
    {
        let u = near(d.value, d.delta_amp_over_xb());
        let setup = fam.setup(&[d.value]).unwrap_or_else(|e| panic!("{e}"));
        let start = djkr_core::dynamics::protocol::Initial::State {
            x_s: u.state[0],
            v_s: u.state[1],
            a: u.state[2],
            a_dot: 0.0,
            x_k: setup.x_k,
        };
        let opts = Options {
            tol: 1e-10,
            ..Options::default()
        };
        let s = setup
            .problem
            .shoot(&start, &opts)
            .unwrap_or_else(|e| panic!("{} Hz: {}", d.value, e.reason));
        let e = (s.transfer_magnitude() / d.delta_amp_over_xb() - 1.0).abs();
        worst = worst.max(e);
    }
    assert!(
        worst < 1e-7,
        "down branch vs shooting from the up branch: {worst:e}"
    );
    // Same stability pattern: stable, unstable, stable (in opposite orders).
    let pattern = |b: &Branch| {
        let mut v: Vec<bool> = Vec::new();
        for p in b.points.iter().filter(|p| p.kind == PointKind::Regular) {
            if v.last() != Some(&p.stable()) {
                v.push(p.stable());
            }
        }
        v
    };
    assert_eq!(pattern(&up), vec![true, false, true]);
    assert_eq!(pattern(&down), vec![true, false, true]);
}

/// The resonance rig with a constant work of adhesion (no rate dependence): the contact radius
/// follows the JKR curve, and at small amplitude the system is a linear oscillator with the JKR
/// tangent stiffness.
const CONSTANT_W: &str = r#"
version = 1
[material]
K = 9.33e6
R = 0.051
w0 = 0.240
[sphere]
mass = 2.71e-3
gravity = 9.807
[spring]
stiffness = 200.0
[damping]
c = 0.5
[base]
amplitude = 3e-9
frequency = 300.0
[initial]
preload = 0.05
[[stage]]
kind = "hold"
duration = 1.0
vibration = true
"#;

#[test]
fn a_linear_system_reproduces_the_linear_transfer_and_exp_lambda_t() {
    let src =
        ScenarioSource::parse(CONSTANT_W, "constant-w", None).unwrap_or_else(|e| panic!("{e}"));
    let scn = src.scenario(&[]).unwrap_or_else(|e| panic!("{e}"));
    let fam = new_family(src, vec![], vec![param("base.frequency")], 1e-10)
        .unwrap_or_else(|e| panic!("{e}"));
    let b = branch::continue_branch(&fam, (300.0, 500.0), &Settings::default(), &mut |_| {})
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(folds_of(&b).is_empty());
    let setup = Setup::new(&scn.rig, &scn.initial).unwrap_or_else(|e| panic!("{e}"));
    let st = describing::static_state(&setup.rig, setup.support).unwrap_or_else(|e| panic!("{e}"));
    let kt = describing::tangent_stiffness(&scn.rig.material, st.a, 0.24);
    let (m, c, k) = (2.71e-3, 0.5, 200.0);
    // m λ² + c λ + (k + k_t) = 0.
    let disc = Complex::new(c * c - 4.0 * m * (k + kt), 0.0).sqrt();
    let lambda = (Complex::new(-c, 0.0) + disc) / (2.0 * m);
    let (mut worst_t, mut worst_mu) = (0.0f64, 0.0f64);
    for p in &b.points {
        let omega = 2.0 * std::f64::consts::PI * p.value;
        let t = transfer::linear(&scn.rig, kt, omega);
        let e = (p.cycle.delta_sin / p.amplitude - t.sin)
            .hypot(p.cycle.delta_cos / p.amplitude - t.cos)
            / t.magnitude();
        worst_t = worst_t.max(e);
        // Two unknowns (x_s, v_s): a is algebraic under a constant law.
        assert_eq!(p.multipliers.len(), 2);
        assert!(p.multiplier_abs(2).is_nan());
        let exact = (lambda / p.value).exp();
        let err = p
            .multipliers
            .iter()
            .map(|z| (z - exact).norm().min((z - exact.conj()).norm()))
            .fold(0.0f64, f64::max);
        worst_mu = worst_mu.max(err);
        assert!(p.stable());
    }
    eprintln!("worst transfer error {worst_t:e}, worst multiplier error {worst_mu:e}");
    // At X_b = 3 nm the nonlinear correction is ~1e-5 (it grows with the amplitude: 2.6e-5 in
    // the multipliers at 10 nm); below ~1 nm the implicit integrator's stage-solve noise (the
    // constant law's radius is root-solved) reaches the finite differences.
    assert!(worst_t < 2e-4, "transfer error {worst_t:e}");
    assert!(worst_mu < 3e-5, "multiplier error {worst_mu:e}");
}

#[test]
fn a_pinned_gent_schultz_contact_has_the_oscillator_pair_and_a_creep_multiplier_near_one() {
    // At X_b = 10 nm the Gent-Schultz contact line is pinned (tests/it/steady.rs): the mechanics is
    // the linear oscillator with k_c = (3/2) K a_m, and the mean radius creeps: one real
    // multiplier just below 1, the nearly neutral direction of the one-period map.
    let fam = new_family(
        source(),
        vec![set("base.amplitude=10nm")],
        vec![param("base.frequency")],
        1e-10,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let b = branch::continue_branch(&fam, (300.0, 500.0), &Settings::default(), &mut |_| {})
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(folds_of(&b).is_empty());
    let (m, c, k) = (2.71e-3, 0.5, 200.0);
    let mut worst = 0.0f64;
    for p in &b.points {
        let kc = 1.5 * 9.33e6 * p.cycle.a_mean;
        let disc = Complex::new(c * c - 4.0 * m * (k + kc), 0.0).sqrt();
        let exact = ((Complex::new(-c, 0.0) + disc) / (2.0 * m) / p.value).exp();
        let pair: Vec<_> = p.multipliers.iter().filter(|z| z.im.abs() > 1e-6).collect();
        assert_eq!(pair.len(), 2, "{:?}", p.multipliers);
        let err = pair
            .iter()
            .map(|z| (*z - exact).norm().min((*z - exact.conj()).norm()))
            .fold(0.0f64, f64::max);
        worst = worst.max(err);
        let creep = p.multipliers.iter().find(|z| z.im.abs() <= 1e-6);
        assert!(
            creep.is_some_and(|z| z.re > 0.99 && z.re < 1.0),
            "{} Hz: {:?}",
            p.value,
            p.multipliers
        );
    }
    eprintln!("worst oscillator-pair error {worst:e}");
    assert!(worst < 1e-3, "{worst:e}");
}

#[test]
fn fold_curves_end_on_the_folds_of_the_branch_at_their_far_end() {
    // The folds of the 1.5 µm branch followed in X_b down to 1.25 µm end where the folds of the
    // branch computed at 1.25 µm are.
    let b15 = frequency_branch("1.5um", (400.0, 480.0));
    let fam2 = new_family(
        source(),
        vec![],
        vec![param("base.frequency"), param("base.amplitude")],
        1e-10,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let set = Settings::default().engine;
    let curves = folds::continue_folds(&fam2, &b15, (1.5e-6, 1.25e-6), &set, &mut |_, _| {})
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(curves.len(), 2, "one curve per fold: no cusp above 1.25 µm");
    let mut ends: Vec<f64> = curves
        .iter()
        .map(|c| {
            let e = c.points.last().unwrap_or_else(|| panic!("empty curve"));
            assert!((e.values[1] - 1.25e-6).abs() < 1e-18, "{:?}", e.values);
            e.values[0]
        })
        .collect();
    ends.sort_by(f64::total_cmp);
    let mut f125 = folds_of(&frequency_branch("1.25um", (400.0, 480.0)));
    f125.sort_by(f64::total_cmp);
    assert_eq!(f125.len(), 2);
    for (a, b) in ends.iter().zip(&f125) {
        assert!(
            (a - b).abs() < 1e-6 * b,
            "fold curves end at {ends:?}, branch folds {f125:?}"
        );
    }
}

#[test]
fn the_bistable_region_is_born_at_a_cusp_between_the_amplitudes_with_and_without_folds() {
    let b15 = frequency_branch("1.5um", (400.0, 480.0));
    let fam2 = new_family(
        source(),
        vec![],
        vec![param("base.frequency"), param("base.amplitude")],
        1e-10,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let set = Settings::default().engine;
    let curves = folds::continue_folds(&fam2, &b15, (1.5e-6, 0.5e-6), &set, &mut |_, _| {})
        .unwrap_or_else(|e| panic!("{e}"));
    // One curve: from the upper fold through the cusp back to the lower fold.
    assert_eq!(curves.len(), 1);
    let cusps: Vec<_> = curves[0].cusps().collect();
    assert_eq!(cusps.len(), 1);
    let (fc, xc) = (cusps[0].values[0], cusps[0].values[1]);
    let end = curves[0].points.last().map_or(f64::NAN, |p| p.values[0]);
    let lower = folds_of(&b15).into_iter().fold(f64::INFINITY, f64::min);
    assert!((end - lower).abs() < 1e-6 * lower, "{end} vs {lower}");
    // Independent check: just above a cusp the folds are Δf ∝ (X_b − X_c)^{3/2} apart, so
    // Δf^{2/3} is linear in X_b and vanishes at X_c. Branches at X_c (1 + k 1e-4), k = 1, 2, 4
    // (small steps: the S is a few 1e-5 Hz wide), then a line through (X_b, Δf^{2/3}).
    let narrow = |xb: f64| {
        let fam = new_family(
            source(),
            vec![Override::new("base.amplitude", xb).unwrap_or_else(|e| panic!("{e}"))],
            vec![param("base.frequency")],
            1e-10,
        )
        .unwrap_or_else(|e| panic!("{e}"));
        let mut s = Settings::default();
        s.engine.h_max = 0.02;
        let b = branch::continue_branch(&fam, (fc - 1.5, fc + 1.5), &s, &mut |_| {})
            .unwrap_or_else(|e| panic!("{e}"));
        folds_of(&b)
    };
    let mut pts = Vec::new();
    for k in [1.0, 2.0, 4.0] {
        let xb = xc * (1.0 + k * 1e-4);
        let f = narrow(xb);
        assert_eq!(f.len(), 2, "X_b = {xb}: folds {f:?}");
        pts.push((xb, (f[0] - f[1]).abs().powf(2.0 / 3.0), 0.5 * (f[0] + f[1])));
    }
    let slope = (pts[2].1 - pts[0].1) / (pts[2].0 - pts[0].0);
    let x_ref = pts[0].0 - pts[0].1 / slope;
    let f_slope = (pts[2].2 - pts[0].2) / (pts[2].0 - pts[0].0);
    let f_ref = pts[0].2 + f_slope * (x_ref - pts[0].0);
    eprintln!("cusp: fold curve ({fc} Hz, {xc:e} m), fold separation ({f_ref} Hz, {x_ref:e} m)");
    assert!((xc / x_ref - 1.0).abs() < 2e-5, "{xc:e} vs {x_ref:e}");
    assert!((fc / f_ref - 1.0).abs() < 2e-6, "{fc} vs {f_ref}");
    // Below the cusp amplitude the branch has no fold.
    assert!(narrow(xc * (1.0 - 1e-3)).is_empty());
}

#[test]
fn keys_that_do_not_change_a_periodic_orbit_are_refused_with_the_list() {
    for key in [
        "stage[0].duration",
        "solver.rtol",
        "output.csv",
        "adhesion.law",
        "version",
    ] {
        let e = parameter("--param", key)
            .map(|_| ())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains(key) && e.contains("base.frequency") && e.contains("initial.preload"),
            "{key}: {e}"
        );
    }
    let e = parameter("--param", "base.frequenc")
        .map(|_| ())
        .unwrap_err()
        .to_string();
    assert!(e.contains("unknown key") && e.contains("damping.c"), "{e}");
    // The continuation parameter cannot also be set.
    let e = new_family(
        source(),
        vec![set("base.frequency=400")],
        vec![param("base.frequency")],
        1e-10,
    )
    .map(|_| ())
    .unwrap_err()
    .to_string();
    let e = djkr::error::render(&e, &djkr::error::Plain);
    assert!(
        e.starts_with("set base.frequency=400: base.frequency is the continuation parameter"),
        "{e}"
    );
}

fn djkr(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_djkr"))
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn continue_command_writes_the_contract_columns_and_json() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let out = dir.path().to_string_lossy().to_string();
    let file = resonance_file().to_string_lossy().to_string();
    let o = djkr(&[
        "continue",
        &file,
        "--param",
        "base.frequency",
        "--range",
        "400:470",
        "--fold-param",
        "base.amplitude",
        "--fold-range",
        "1.5um:0.8um",
        "--sweep",
        "8",
        "--json",
        "--out",
        &out,
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap_or_else(|e| panic!("{e}"));
    let folds = v["folds"].as_array().cloned().unwrap_or_default();
    assert_eq!(folds.len(), 2, "{v}");
    for f in &folds {
        assert!(
            f["base.frequency"].is_f64() && f["delta_amp_over_xb"].is_f64() && f["a_mean"].is_f64(),
            "{f}"
        );
    }
    assert!(v["period_doublings"]
        .as_array()
        .is_some_and(|a| a.is_empty()));
    assert!(v["neimark_sacker"].as_array().is_some_and(|a| a.is_empty()));
    assert!(v["fold_curves"].as_array().is_some_and(|a| a.len() == 1));
    assert!(
        v["cusp"]["base.amplitude"].is_f64() && v["cusp"]["base.frequency"].is_f64(),
        "{v}"
    );
    let csv = std::fs::read_to_string(dir.path().join("branch.csv")).unwrap_or_default();
    let header = csv.lines().next().unwrap_or_default();
    assert_eq!(
        header,
        "arclength [1],base.frequency [Hz],delta_amp_over_xb [1],phase [rad],delta_mean [m],\
         force_mean [N],a_mean [m],a_amp [m],stable [1],multiplier_1_abs [1],\
         multiplier_2_abs [1],multiplier_3_abs [1]"
    );
    // The HDF5 file holds the same columns, bit for bit.
    let h5 = hdf5_pure::File::open(dir.path().join("branch.h5")).unwrap_or_else(|e| panic!("{e}"));
    let freq = h5
        .dataset("branch/base.frequency")
        .and_then(|d| d.read_f64())
        .unwrap_or_else(|e| panic!("{e}"));
    let from_csv: Vec<f64> = csv
        .lines()
        .skip(1)
        .filter_map(|l| l.split(',').nth(1).and_then(|x| x.parse().ok()))
        .collect();
    assert_eq!(freq, from_csv);
    let stable = h5
        .dataset("branch/stable")
        .and_then(|d| d.read_i64())
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(stable.iter().all(|&x| x == 0 || x == 1));
    // Stable rows 1, unstable rows 0, and both occur.
    let stable: Vec<&str> = csv
        .lines()
        .skip(1)
        .filter_map(|l| l.split(',').nth(8))
        .collect();
    assert!(stable.contains(&"1") && stable.contains(&"0"));
    for f in [
        "branch.h5",
        "branch.png",
        "branch.svg",
        "fold_curves.csv",
        "fold_curves.png",
        "sweep.csv",
        "bifurcations.csv",
    ] {
        assert!(dir.path().join(f).exists(), "{f}");
    }
    // A key that is not a constant of the orbit: exit 2, one line naming the flag and the list.
    let o = djkr(&[
        "continue",
        &file,
        "--param",
        "stage[0].duration",
        "--range",
        "1:2",
    ]);
    assert_eq!(o.status.code(), Some(2));
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        e.contains("--param stage[0].duration") && e.contains("base.frequency"),
        "{e}"
    );
    let o = djkr(&[
        "continue",
        &file,
        "--param",
        "base.frequency",
        "--range",
        "395:405",
        "--set",
        "base.amplitude=-1um",
    ]);
    assert_eq!(o.status.code(), Some(2));
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        e.starts_with("error: --set base.amplitude=-1um: must be a finite number >= 0 (m)"),
        "{e}"
    );
    let o = djkr(&[
        "continue",
        &file,
        "--param",
        "base.amplitude",
        "--range",
        "1um:-1um",
    ]);
    assert_eq!(o.status.code(), Some(2));
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        e.contains("--range = 1um:-1um: base.amplitude = -1e-6: must be a finite number >= 0"),
        "{e}"
    );
}

fn scene(name: &str) -> ScenarioSource {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenarios")
        .join(name);
    ScenarioSource::read(&p).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn a_period_that_loses_contact_ends_the_branch_as_grazing_not_a_fold() {
    // scenarios/impacts.toml (m = 0.25 kg, 300 Hz) continued in X_b: the in-contact orbit folds
    // at 380 µm; its unstable continuation soon loses contact within the period.
    let fam = new_family(
        scene("impacts.toml"),
        vec![],
        vec![param("base.amplitude")],
        1e-10,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let b = branch::continue_branch(&fam, (300e-6, 400e-6), &Settings::default(), &mut |_| {})
        .unwrap_or_else(|e| panic!("{e}"));
    let f = folds_of(&b);
    assert_eq!(f.len(), 1, "{f:?}");
    assert!((f[0] - 380.1e-6).abs() < 0.1e-6, "{f:?}");
    let fold = b.of_kind(PointKind::Fold).next().map(|p| p.multipliers[0]);
    assert!(fold.is_some_and(|z| (z - Complex::new(1.0, 0.0)).norm() < 1e-8));
    assert!(
        matches!(&b.end, branch::BranchEnd::Grazing(k) if k.contains("contact loss")),
        "{:?}",
        b.end
    );
    let last = b.points.last().unwrap_or_else(|| panic!("empty branch"));
    assert_eq!(last.kind, PointKind::Grazing);
    assert!(!last.stable() && last.value < f[0]);
}

#[test]
fn a_scene_with_earlier_stages_keeps_the_spring_end_they_leave() {
    // The paper protocol approaches to 0.05 N and dwells before the shaker starts. Rerun for
    // every damping value, the approach would leave the spring end 2.1 µm elsewhere past
    // c = 3.1019 N s/m; run once at START, the branch in c is smooth down to 2 N s/m.
    let fam = new_family(
        scene("paper-protocol-400hz.toml"),
        vec![],
        vec![param("damping.c")],
        1e-10,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let b = branch::continue_branch(&fam, (10.0, 2.0), &Settings::default(), &mut |_| {})
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(b.end, branch::BranchEnd::Range);
    assert_eq!(b.work.rejected, 0);
    let xk: Vec<f64> = [10.0, 3.1, 2.0]
        .iter()
        .map(|&c| fam.setup(&[c]).map(|s| s.x_k).unwrap_or(f64::NAN))
        .collect();
    assert!(xk.iter().all(|x| x.to_bits() == xk[0].to_bits()), "{xk:?}");
    // Far below the rig's 44 Hz resonance the damping barely matters; the multipliers of the
    // light oscillator approach the unit circle as c falls: |μ| = e^{−cT/2m}.
    let last = b.points.last().unwrap_or_else(|| panic!("empty branch"));
    let exact = (-2.0 / 400.0 / (2.0 * 0.25f64)).exp();
    assert!(
        last.multipliers
            .iter()
            .any(|z| (z.norm() - exact).abs() < 1e-3),
        "{:?} vs {exact}",
        last.multipliers
    );
}

/// The rig of issue 25, item 4: m = 3 g, k = 200 N/m, c = 0.5 N s/m on the sphere, 20 mN
/// preload, the paper's material, X_b = 5 µm, with the adhesion section `law`.
fn rig_with_law(law: &str) -> String {
    format!(
        "version = 1\n\
         [material]\nK = 9.33e6\nR = 0.051\nw0 = 0.240\n\
         [adhesion]\n{law}\n\
         [sphere]\nmass = 3e-3\n\
         [spring]\nstiffness = 200.0\n\
         [damping]\nc = 0.5\non = \"sphere\"\n\
         [base]\namplitude = 5e-6\nfrequency = 400.0\n\
         [initial]\npreload = 0.02\n\
         [[stage]]\nkind = \"hold\"\nduration = 0.5\nvibration = true\n"
    )
}

/// `djkr continue --json` of `file` in frequency over 340–600 Hz with default settings: the folds
/// (Hz) and the periods integrated.
fn continue_folds(file: &Path, out: &Path) -> (Vec<f64>, u64) {
    let o = djkr(&[
        "continue",
        file.to_str().unwrap(),
        "--param",
        "base.frequency",
        "--range",
        "340:600",
        "--json",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let folds = v["folds"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f["base.frequency"].as_f64().unwrap())
        .collect();
    (folds, v["periods"].as_u64().unwrap())
}

#[test]
fn a_densely_tabulated_law_continues_like_the_law_it_samples() {
    // Issue 25, item 4: the paper's Gent–Schultz law sampled at 55 000 rows evenly spaced in
    // asinh(ȧ/v0). Interpolated piecewise-linearly, this continuation stopped over 340–600 Hz
    // ("step size fell below its minimum") after minutes; the monotone C¹ interpolant must find
    // the analytic law's folds (near 472.8 and 560.2 Hz) within 1e-3 Hz, with no more than 5× the
    // analytic law's work (periods integrated; the wall time is measured in the closing note of
    // issue 25, not here).
    let dir = tempfile::tempdir().unwrap();
    let gs = djkr_core::adhesion::GentSchultz::PAPER;
    let s_max = (999.0 / gs.v0).asinh();
    let n = 55_000;
    let mut rows: Vec<f64> = (0..n)
        .map(|i| gs.v0 * (-s_max + 2.0 * s_max * i as f64 / (n - 1) as f64).sinh())
        .filter(|&v| v != 0.0)
        .chain([0.0])
        .collect();
    rows.sort_by(f64::total_cmp);
    let mut csv = String::from("speed,w\n");
    for v in rows {
        use djkr_core::adhesion::AdhesionLaw;
        csv.push_str(&format!("{v:?},{:?}\n", gs.work_of_adhesion(v)));
    }
    std::fs::write(dir.path().join("law.csv"), csv).unwrap();
    let analytic = dir.path().join("analytic.toml");
    let tabulated = dir.path().join("tabulated.toml");
    std::fs::write(
        &analytic,
        rig_with_law("law = \"gent-schultz\"\nv0 = 4.45e-5\nn = 0.531"),
    )
    .unwrap();
    std::fs::write(
        &tabulated,
        rig_with_law("law = \"tabulated\"\nfile = \"law.csv\""),
    )
    .unwrap();
    let (fa, pa) = continue_folds(&analytic, &dir.path().join("a"));
    let (ft, pt) = continue_folds(&tabulated, &dir.path().join("t"));
    assert_eq!(fa.len(), 2, "the analytic law's folds: {fa:?}");
    assert!(
        (fa[0] - 560.18).abs() < 0.1 && (fa[1] - 472.80).abs() < 0.1,
        "{fa:?}"
    );
    assert_eq!(ft.len(), fa.len(), "tabulated {ft:?}, analytic {fa:?}");
    for (t, a) in ft.iter().zip(&fa) {
        assert!((t - a).abs() < 1e-3, "fold at {t} Hz, analytic {a} Hz");
    }
    assert!(pt <= 5 * pa, "{pt} periods, analytic {pa}");
}

#[test]
fn a_range_without_a_fold_says_so() {
    // Issue 25: a range with no fold printed nothing about folds.
    let dir = tempfile::tempdir().unwrap();
    let o = djkr(&[
        "continue",
        resonance_file().to_str().unwrap(),
        "--param",
        "base.frequency",
        "--range",
        "300:350",
        "--sweep",
        "0",
        "--out",
        dir.path().to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("  no fold in range\n"), "{text}");
    assert!(!text.contains("  fold "), "{text}");
}

//! Periodic steady state (shooting and time-stepping), its invariants, and the references it is
//! compared with: the force balance, the linear transfer at small amplitude, reproducible sweeps
//! through a nonlinear resonance, and the `validate` / `resonance` / `shortcut-map` commands.

use crate::catalogue;
use crate::catalogue::Bundled;
use djkr::scenario::Scenario;
use djkr_core::adhesion::{ConstantW, Law};
use djkr_core::describing::{self, Setup};
use djkr_core::dynamics::protocol::Initial;
use djkr_core::material::Material;
use djkr_core::steady::sweep::{self, Direction};
use djkr_core::steady::{crosscheck, Options, Problem, Steady, SteadyMethod, Strategy};
use djkr_core::transfer;
use std::process::Command;

/// A bundled scenario, by file name, through the catalogue (`crate::catalogue::Bundled`).
fn scene(name: &str) -> Scenario {
    let b = Bundled::ALL
        .into_iter()
        .find(|b| b.path().ends_with(name))
        .unwrap_or_else(|| panic!("{name} is not a bundled scenario"));
    b.scenario().unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn solve(p: &Problem, start: &Initial, strategy: Strategy) -> Steady {
    let o = Options {
        strategy,
        ..Options::default()
    };
    p.solve(start, &o)
        .unwrap_or_else(|e| panic!("{strategy:?}: {e}"))
}

/// The force balance over a cycle: ⟨F⟩ − (m g + ⟨holder force⟩) = ⟨m ẍ + c ẋ⟩ = (m Δv + c Δx)/T
/// with Δ the change of the state over the cycle, bounded by the scaled once-per-cycle residual
/// (Δx ≤ r L, Δv ≤ r ωL). Returns (mismatch, bound + quadrature floor).
fn balance(scn: &Scenario, s: &Steady) -> (f64, f64) {
    let c = &s.cycle;
    let weight = scn.rig.sphere.mass * scn.rig.sphere.gravity;
    let mismatch = (c.force_mean - (weight + c.spring_mean)).abs();
    let c_damp = scn.rig.damping.map(|d| d.c).unwrap_or(0.0);
    let r = s.residual.max(s.distance.min(1.0));
    let bound = (scn.rig.sphere.mass * r * s.scales[1] + c_damp * r * s.scales[0]) * s.frequency;
    let scale = c.force_mean.abs().max(weight).max(c.spring_mean.abs());
    (mismatch, 2.0 * bound + 1e-12 * scale)
}

#[test]
fn shooting_and_long_time_stepping_agree_on_the_same_orbit() {
    // The bundled resonance scene at 400 Hz: lightly damped, and the mean contact radius creeps
    // (the Gent–Schultz rate is flat near G = w0), so plain time-stepping needs ~10⁴ periods.
    let scn = scene("resonance-400hz.toml");
    let (p, start) = Problem::from_plan(&scn.plan()).unwrap_or_else(|e| panic!("{e}"));
    let sh = solve(&p, &start, Strategy::Shooting);
    let ts = solve(&p, &start, Strategy::TimeStepping);
    assert_eq!(sh.method, SteadyMethod::Shooting);
    assert_eq!(ts.method, SteadyMethod::TimeStepping);
    assert!(sh.residual < 1e-8 && sh.distance < 1e-8, "{sh:?}");
    assert!(ts.distance < 1e-8, "{ts:?}");
    // Both are fixed points of the period map integrated at rtol 1e-10; they differ by the
    // integration error (a restarted period vs one long run), amplified by 1/(1 − ρ) along the
    // slow direction: the tolerances below are that level, not the steady-state tolerance.
    let (a, b) = (&sh.cycle, &ts.cycle);
    let rel = |x: f64, y: f64| (x - y).abs() / y.abs();
    assert!(rel(a.force_mean, b.force_mean) < 1e-7, "{a:?}\n{b:?}");
    assert!(rel(a.a_mean, b.a_mean) < 1e-7, "{a:?}\n{b:?}");
    assert!(rel(sh.delta_amp(), ts.delta_amp()) < 1e-6);
    assert!((a.delta_sin - b.delta_sin).abs() < 1e-6 * ts.delta_amp());
    assert!((a.delta_cos - b.delta_cos).abs() < 1e-6 * ts.delta_amp());
    let (x, y) = (sh.state, ts.state);
    assert!((x.x_s - y.x_s).abs() < 1e-6 * sh.scales[0], "{x:?}\n{y:?}");
    assert!((x.v_s - y.v_s).abs() < 1e-6 * sh.scales[1], "{x:?}\n{y:?}");
    assert!((x.a - y.a).abs() < 1e-7 * sh.scales[2], "{x:?}\n{y:?}");
    // The point of shooting: far fewer periods.
    assert!(
        ts.cycles > 100 * sh.cycles,
        "shooting {} periods, time-stepping {}",
        sh.cycles,
        ts.cycles
    );
}

#[test]
fn force_balance_holds_to_integration_accuracy() {
    // Shooting on the resonance scene; shooting after pre-vibration stages (approach, dwell) on
    // the paper protocol; time-stepping (shooting refuses: contact is lost every cycle) on the
    // impact scene.
    for (name, method) in [
        ("resonance-400hz.toml", SteadyMethod::Shooting),
        ("paper-protocol-400hz.toml", SteadyMethod::Shooting),
        ("impacts.toml", SteadyMethod::TimeStepping),
    ] {
        let scn = scene(name);
        let (p, start) = Problem::from_plan(&scn.plan()).unwrap_or_else(|e| panic!("{e}"));
        let s = solve(&p, &start, Strategy::Auto);
        assert_eq!(s.method, method, "{name}");
        assert_eq!(s.contact_lost, name == "impacts.toml", "{name}");
        let (mismatch, bound) = balance(&scn, &s);
        assert!(
            mismatch <= bound,
            "{name}: <F> - (m g + <spring>) = {mismatch:e} N, bound {bound:e} N"
        );
        // The library's check agrees.
        let fb = crosscheck::force_balance(&scn.rig, &s);
        assert!(fb.holds, "{name}: {fb:?}");
    }
}

/// The resonance scene with a constant work of adhesion w0 (N·m⁻¹ per m²).
fn constant_w_scene(w0: f64) -> Scenario {
    let mut s = scene("resonance-400hz.toml");
    s.rig.material = Material {
        w0,
        ..s.rig.material
    };
    s.rig.law = Law::Constant(ConstantW { w0 });
    s
}

/// |δ1/X_b − T| / |T| of the steady state at `f` against the transfer `t`.
fn transfer_error(s: &Steady, t: transfer::Transfer) -> f64 {
    let (ds, dc) = (
        s.cycle.delta_sin / s.amplitude,
        s.cycle.delta_cos / s.amplitude,
    );
    (ds - t.sin).hypot(dc - t.cos) / t.magnitude()
}

#[test]
fn small_amplitude_without_rate_dependence_matches_the_linear_transfer() {
    // Adhesion "switched off": w0 → 1 µJ/m² with a constant law, a nearly Hertzian contact.
    // For a rate-independent law the contact radius follows the JKR curve, so the small-signal
    // stiffness is the JKR tangent stiffness k_t = dF/dδ along it
    // ([`describing::tangent_stiffness`]), which tends to (3/2) K a as w → 0. A normal w0 =
    // 240 mJ/m² with a constant law is the same check with k_t well below (3/2) K a.
    for (w0, f) in [(1e-6, 390.0), (1e-6, 300.0), (0.24, 380.0), (0.24, 500.0)] {
        let scn = constant_w_scene(w0);
        let xb = 1e-9; // δ1/δ_m ~ 1e-3 near resonance: nonlinear terms ~1e-3 relative
        let (p, start) = Problem::from_plan(&scn.plan()).unwrap_or_else(|e| panic!("{e}"));
        let p = p.at(f, xb).unwrap_or_else(|e| panic!("{e}"));
        let s = solve(&p, &start, Strategy::Auto);
        assert_eq!(s.method, SteadyMethod::Shooting);
        let setup = Setup::new(&scn.rig, &scn.initial).unwrap_or_else(|e| panic!("{e}"));
        let st =
            describing::static_state(&setup.rig, setup.support).unwrap_or_else(|e| panic!("{e}"));
        let kt = describing::tangent_stiffness(&scn.rig.material, st.a, w0);
        let kc = 1.5 * scn.rig.material.k * st.a;
        let omega = 2.0 * std::f64::consts::PI * f;
        let tangent = transfer::linear(&scn.rig, kt, omega);
        let pinned = transfer::linear(&scn.rig, kc, omega);
        let e_t = transfer_error(&s, tangent);
        let e_c = transfer_error(&s, pinned);
        eprintln!(
            "w0 {w0} f {f}: tangent error {e_t:e}, pinned error {e_c:e}, |T| {}",
            s.transfer_magnitude()
        );
        assert!(
            e_t < 2e-3,
            "w0 {w0}, {f} Hz: |T| time {} vs tangent {} (error {e_t:e})",
            s.transfer_magnitude(),
            tangent.magnitude()
        );
        if w0 > 1e-3 {
            // With real adhesion the pinned-line stiffness (3/2) K a is the wrong reference.
            assert!(e_c > 10.0 * e_t, "w0 {w0}, {f} Hz: {e_c} vs {e_t}");
        }
        // The contact radius moves with δ along the JKR curve (not pinned).
        assert!(s.a_amp() > 0.0);
    }
}

#[test]
fn small_amplitude_gent_schultz_contact_is_pinned_and_matches_eq_37() {
    // With the Gent–Schultz law (n < 1) the contact line barely moves at small amplitude
    // (w − w0 ∝ |ȧ|^n: δ1 ∝ a_A^n ≫ a_A), so F1/δ1 → k_c = (3/2) K a_m and the corrected
    // eq. (37) holds. The adhesion hysteresis damping c_eff ∝ a_A^(1−n) fades with amplitude:
    // at resonance (400 Hz, most sensitive to damping) the error falls from 10 nm to 1 nm, and
    // then reaches the integration floor: rtol·δ_m ≈ 1e-15 m is ~1e-6 of δ1 at X_b = 1 nm.
    let scn = scene("resonance-400hz.toml");
    let (p0, start) = Problem::from_plan(&scn.plan()).unwrap_or_else(|e| panic!("{e}"));
    for f in [300.0, 400.0] {
        let omega = 2.0 * std::f64::consts::PI * f;
        let mut errors = Vec::new();
        for xb in [1e-8, 1e-9] {
            let p = p0.at(f, xb).unwrap_or_else(|e| panic!("{e}"));
            let s = solve(&p, &start, Strategy::Auto);
            let kc = 1.5 * scn.rig.material.k * s.cycle.a_mean;
            let t = transfer::linear(&scn.rig, kc, omega);
            let e = transfer_error(&s, t);
            assert!(
                s.a_amp() < 1e-3 * s.delta_amp(),
                "{f} Hz, X_b {xb}: contact line not pinned: a_A {} vs δ_A {}",
                s.a_amp(),
                s.delta_amp()
            );
            assert!(e < 2e-5, "{f} Hz, X_b {xb}: error {e}");
            errors.push(e);
        }
        if f > 350.0 {
            assert!(errors[1] < errors[0], "{f} Hz: {errors:?}");
        }
    }
}

#[test]
fn sweep_through_the_nonlinear_resonance_is_reproducible_with_hysteresis() {
    // At X_b = 1.5 µm the contact (hardening: the mean radius and k_c grow with amplitude) bends
    // the resonance to ~447 Hz on the way up; coming down the response stays on the low branch
    // until ~440 Hz.
    let scn = scene("resonance-400hz.toml");
    let (p, start) = Problem::from_plan(&scn.plan()).unwrap_or_else(|e| panic!("{e}"));
    let p = p.at(400.0, 1.5e-6).unwrap_or_else(|e| panic!("{e}"));
    let freqs = sweep::frequencies(400.0, 450.0, 26);
    let o = Options::default();
    let run = || sweep::sweep_both(&p, &start, &freqs, &o, None, &|_, _| {});
    let (u1, d1) = run();
    let (u2, d2) = run();
    let curve = |s: &sweep::Sweep| -> Vec<(u64, u64)> {
        s.points
            .iter()
            .map(|pt| {
                let st = pt
                    .steady
                    .as_ref()
                    .unwrap_or_else(|| panic!("{} Hz: {:?}", pt.frequency, pt.error));
                (pt.frequency.to_bits(), st.transfer_magnitude().to_bits())
            })
            .collect()
    };
    assert_eq!(curve(&u1), curve(&u2), "up sweeps differ between runs");
    assert_eq!(curve(&d1), curve(&d2), "down sweeps differ between runs");
    assert_eq!(u1.direction, Direction::Up);
    let at = |s: &sweep::Sweep, f: f64| {
        s.points
            .iter()
            .find(|p| (p.frequency - f).abs() < 1e-9)
            .and_then(|p| p.steady.as_ref())
            .map(|s| s.transfer_magnitude())
            .unwrap_or(f64::NAN)
    };
    // Single-valued below the fold region: up and down agree to the solver tolerance.
    for f in [400.0, 420.0, 430.0] {
        let (u, d) = (at(&u1, f), at(&d1, f));
        assert!((u - d).abs() < 1e-5 * u, "{f} Hz: up {u}, down {d}");
    }
    // Hysteresis: high branch on the way up, low branch on the way down.
    let (u, d) = (at(&u1, 446.0), at(&d1, 446.0));
    assert!(u > 12.0 && d < 8.0, "446 Hz: up {u}, down {d}");
    // Each frequency started from the previous steady state: mostly by shooting.
    let shot = u1
        .points
        .iter()
        .chain(&d1.points)
        .filter(|p| {
            p.steady
                .as_ref()
                .is_some_and(|s| s.method == SteadyMethod::Shooting)
        })
        .count();
    assert!(shot >= 48, "{shot} of 52 by shooting");
}

#[test]
fn bundled_resonance_scene_peaks_near_400_hz() {
    // 300–500 Hz, 41 frequencies, up only: a clear peak near the linear prediction.
    let scn = scene("resonance-400hz.toml");
    let (p, start) = Problem::from_plan(&scn.plan()).unwrap_or_else(|e| panic!("{e}"));
    let lin = sweep::Linearisation::for_problem(&p, &start).unwrap_or_else(|e| panic!("{e}"));
    let freqs = sweep::frequencies(300.0, 500.0, 41);
    let sw = sweep::sweep(
        &p,
        &start,
        &freqs,
        Direction::Up,
        &Options::default(),
        Some(&lin),
        &|_, _| {},
    );
    let (fp, h) = sweep::peak(&sw.points).unwrap_or((0.0, 0.0));
    assert!((395.0..415.0).contains(&fp), "peak at {fp} Hz");
    assert!(h > 10.0, "peak height {h}");
    let edge = sw.points[0]
        .steady
        .as_ref()
        .map(|s| s.transfer_magnitude())
        .unwrap_or(f64::NAN);
    assert!(h > 5.0 * edge, "peak {h} vs 300 Hz {edge}");
    // Far from resonance the linear transfer is accurate (the contact is pinned).
    let lin300 = lin.linear(300.0).magnitude();
    assert!((edge / lin300 - 1.0).abs() < 0.01, "{edge} vs {lin300}");
    assert!(sw.points.iter().all(|p| p.harmonic.is_some()));
}

/// The harmonic-balance curve of the resonance scene at X_b = 1.5 µm, continued downwards on
/// the 101-frequency grid of the README, folds between 432 and 434 Hz: its peak is the highest
/// sample, not the 15.18 at 431 Hz a parabola across the jump made up (`resonance --amp 1.5um`).
#[test]
fn harmonic_balance_peak_of_a_folded_curve_is_in_its_data() {
    let scn = scene("resonance-400hz.toml");
    let (p, start) = Problem::from_plan(&scn.plan()).unwrap_or_else(|e| panic!("{e}"));
    let p = p.at(p.frequency, 1.5e-6).unwrap_or_else(|e| panic!("{e}"));
    let lin = sweep::Linearisation::for_problem(&p, &start).unwrap_or_else(|e| panic!("{e}"));
    let mut guess = None;
    let mut curve = Vec::new();
    for f in sweep::frequencies(300.0, 500.0, 101).into_iter().rev() {
        if let Ok(h) = lin.setup.solve(f, p.amplitude, guess) {
            guess = Some(h.guess());
            curve.push((f, h.harmonics.delta_amp / p.amplitude));
        }
    }
    curve.reverse();
    let top = curve.iter().map(|c| c.1).fold(f64::MIN, f64::max);
    let (f, h) = sweep::peak_of(&curve).unwrap_or((0.0, 0.0));
    assert!(
        h <= top && curve.iter().any(|c| c.0 == f && c.1 == h),
        "{h} at {f}, top {top}"
    );
    assert!(
        (14.0..15.0).contains(&h) && (430.0..435.0).contains(&f),
        "{h} at {f}"
    );
    // The samples either side of the fold: a drop of a third from one step to the next.
    let i = curve.iter().position(|c| c.0 == f).unwrap_or(0);
    assert!(curve[i + 1].1 < 0.7 * h, "{:?}", &curve[i - 1..i + 3]);
}

fn djkr(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_djkr"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn validate_json_has_every_method_and_the_steady_block() {
    let out = djkr(&["validate", "scenarios/resonance-400hz.toml", "--json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value =
        serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("{e}"));
    for key in [
        "time_domain",
        "imposed_area",
        "linear_transfer",
        "paper_transfer",
        "harmonic_balance",
    ] {
        let m = &v[key];
        for f in [
            "delta_mean",
            "delta_sin",
            "delta_cos",
            "delta_amp",
            "force_mean",
        ] {
            assert!(m[f].is_number(), "{key}.{f} missing: {m}");
        }
    }
    assert!(v["time_domain"]["a_amp"].is_number());
    assert_eq!(v["steady"]["method"], "shooting");
    assert!(v["steady"]["cycles"].as_u64().is_some_and(|c| c > 0));
    assert!(v["steady"]["residual"].as_f64().is_some_and(|r| r < 1e-8));
    assert_eq!(v["force_balance"]["holds"], true);
    // The time domain's δ_A and the linear transfer agree to a few per cent here (X_b = 0.5 µm
    // at resonance: the adhesion hysteresis damps the peak).
    let rel = v["relative_difference"]["linear_transfer"]["delta_amp"]
        .as_f64()
        .unwrap_or(f64::NAN);
    assert!(rel.abs() < 0.1, "{rel}");
}

/// A sweep whose response is largest at an end of its range has no peak in it (issue 33): the
/// paper protocol's rig resonates at 43.6 Hz, far below 300–500 Hz. The text, the JSON and the
/// figure's title say "no peak in range" and quote no peak or shift; the CSV it wrote confirms
/// that the largest |δ_A/X_b| is at the low end.
#[test]
fn resonance_with_its_maximum_at_the_edge_reports_no_peak() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let d = dir.path().join("edge");
    let ds = d.to_string_lossy().into_owned();
    let args = [
        "resonance",
        "scenarios/paper-protocol-400hz.toml",
        "--freq",
        "300:500:21",
        "--out",
        &ds,
    ];
    let out = djkr(&args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(!text.contains("peak |δ_A/X_b|"), "{text}");
    assert!(!text.contains("shift"), "{text}");
    for line in text
        .lines()
        .filter(|l| l.contains("sweep up") || l.contains("sweep down"))
    {
        assert!(
            line.contains("no peak in range: largest |δ_A/X_b| = ")
                && line.ends_with("at 300.000 Hz, the low end"),
            "{line}"
        );
    }
    assert!(text.contains("no peak in 300–500 Hz"), "{text}");
    // The data: the largest |δ_A/X_b| of each sweep is its first row, at 300 Hz.
    let csv = std::fs::read_to_string(d.join("resonance.csv")).unwrap_or_default();
    for dir in ["up", "down"] {
        let rows: Vec<(f64, f64)> = csv
            .lines()
            .skip(1)
            .filter(|l| l.starts_with(dir))
            .map(|l| {
                let c: Vec<f64> = l
                    .split(',')
                    .skip(1)
                    .take(2)
                    .map(|v| v.parse().unwrap_or(f64::NAN))
                    .collect();
                (c[0], c[1])
            })
            .collect();
        assert_eq!(rows.len(), 21, "{csv}");
        let top =
            rows.iter().copied().fold(
                (f64::NAN, f64::NEG_INFINITY),
                |a, b| if b.1 > a.1 { b } else { a },
            );
        assert_eq!(top.0, 300.0, "{rows:?}");
    }
    let svg = std::fs::read_to_string(d.join("resonance.svg")).unwrap_or_default();
    assert!(
        svg.contains("no peak in range (largest at the low end)"),
        "title of resonance.svg"
    );

    let mut json_args = args.to_vec();
    json_args.extend(["--force", "--json"]);
    let out = djkr(&json_args);
    let v: serde_json::Value =
        serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("{e}"));
    assert!(
        v["linear_resonance_frequency"]
            .as_f64()
            .is_some_and(|f| f < 300.0),
        "{v}"
    );
    for key in ["sweep_up", "sweep_down"] {
        let s = &v[key];
        assert!(s.get("peak").is_none(), "{s}");
        assert_eq!(s["no_peak_in_range"]["largest_at"], "low", "{s}");
        assert_eq!(s["no_peak_in_range"]["frequency"], 300.0, "{s}");
        assert!(s.get("harmonic_balance_peak").is_none(), "{s}");
    }
    assert!(v.get("linear_peak").is_none(), "{v}");
    assert_eq!(v["linear_no_peak_in_range"]["largest_at"], "low", "{v}");
}

#[test]
fn resonance_and_map_commands_write_their_files() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let d = dir.path().join("res");
    let ds = d.to_string_lossy().into_owned();
    let out = djkr(&[
        "resonance",
        "scenarios/resonance-400hz.toml",
        "--freq",
        "396:416:5",
        "--out",
        &ds,
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value =
        serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("{e}"));
    // The peak near 406 Hz lies inside 396–416 Hz (at 390:410:3 the largest value was the
    // 410 Hz end, no peak).
    assert!(v["sweep_up"]["peak"]["frequency"].is_number(), "{v}");
    assert!(v["sweep_down"]["peak"]["frequency"].is_number(), "{v}");
    assert!(v["sweep_up"].get("no_peak_in_range").is_none(), "{v}");
    for f in [
        "resonance.csv",
        "resonance.h5",
        "resonance.png",
        "resonance.svg",
    ] {
        assert!(d.join(f).is_file(), "{f} missing");
    }
    let text = std::fs::read_to_string(d.join("resonance.csv")).unwrap_or_default();
    assert_eq!(text.lines().count(), 1 + 10, "{text}");
    assert!(text.starts_with("direction,frequency [Hz],delta_amp_over_xb [1]"));
    // No temporary files left behind.
    let leftovers: Vec<_> = std::fs::read_dir(&d)
        .map(|r| r.flatten().map(|e| e.file_name()).collect())
        .unwrap_or_default();
    assert!(
        leftovers
            .iter()
            .all(|n| !n.to_string_lossy().contains("partial")),
        "{leftovers:?}"
    );

    let m = dir.path().join("map");
    let ms = m.to_string_lossy().into_owned();
    let out = djkr(&[
        "shortcut-map",
        "scenarios/resonance-400hz.toml",
        "--freq",
        "300:400:2",
        "--amp",
        "0.1um:0.5um:2",
        "--out",
        &ms,
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for f in [
        "shortcut-map.csv",
        "shortcut-map.h5",
        "shortcut-map-force.png",
        "shortcut-map-delta.png",
    ] {
        assert!(m.join(f).is_file(), "{f} missing");
    }
}

#[test]
fn bad_flags_are_named_in_the_error() {
    for (args, needle) in [
        (
            vec![
                "resonance",
                "scenarios/resonance-400hz.toml",
                "--freq",
                "300:500",
            ],
            "--freq",
        ),
        (
            vec![
                "resonance",
                "scenarios/resonance-400hz.toml",
                "--freq",
                "500:300:5",
            ],
            "--freq",
        ),
        (
            vec![
                "resonance",
                "scenarios/resonance-400hz.toml",
                "--freq",
                "300:500:0",
            ],
            "--freq",
        ),
        (
            vec![
                "resonance",
                "scenarios/resonance-400hz.toml",
                "--freq",
                "300:500:3",
                "--amp",
                "-1um",
            ],
            "--amp",
        ),
        (
            vec!["validate", "scenarios/resonance-400hz.toml", "--tol", "2"],
            "--tol",
        ),
        (
            vec!["validate", "scenarios/quasi-static-jkr.toml"],
            "vibrat",
        ),
    ] {
        let out = djkr(&args);
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(needle), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
}

/// An edit of a catalogue scene.
type Edit = fn(&mut Scenario);

#[test]
fn reduced_models_have_fewer_unknowns() {
    // m = 0 (quasi-static sphere: only a is a state), a rigid link (only a), and m = 0 with a
    // constant law (no state at all: one period is the orbit) all find the orbit by shooting,
    // and it balances.
    let cases: [(&str, Edit); 3] = [
        ("m = 0", |s| {
            s.rig.sphere.mass = 0.0;
            s.rig.damping = None;
        }),
        ("rigid link", |s| {
            s.rig.holder = djkr_core::rig::Holder::Rigid;
            s.rig.damping = None;
        }),
        ("m = 0, constant w", |s| {
            s.rig.sphere.mass = 0.0;
            s.rig.damping = None;
            s.rig.law = Law::Constant(ConstantW {
                w0: s.rig.material.w0,
            });
        }),
    ];
    for (name, edit) in cases {
        let mut scn = catalogue::vibrating_hold(1e-6, 300.0, 1.0);
        edit(&mut scn);
        let (p, start) = Problem::from_plan(&scn.plan()).unwrap_or_else(|e| panic!("{name}: {e}"));
        let s = solve(&p, &start, Strategy::Auto);
        assert_eq!(s.method, SteadyMethod::Shooting, "{name}");
        assert!(s.residual < 1e-8, "{name}: {s:?}");
        let (mismatch, bound) = balance(&scn, &s);
        assert!(mismatch <= bound, "{name}: {mismatch} > {bound}");
    }
}

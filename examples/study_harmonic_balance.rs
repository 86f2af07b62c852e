//! Harmonic balance on the imposed-area cycle (`djkr_core::describing`): the transfer |δ1/X_b| and
//! the effective contact (stiffness and damping) against eq. (37)'s linear spring, on the light
//! rig of the catalogue and on the bundled resonance and impact scenes; the branches traced by
//! the contact amplitude; the loop area against the first-harmonic dissipation.
//!
//!   cargo run --release --example study_harmonic_balance   # about 10 s
//!
//! Writes `docs/studies/harmonic-balance.md`.

#[path = "../tests/catalogue/mod.rs"]
mod catalogue;
mod common;

use crate::catalogue::Bundled;
use common::{sci, Args, Table};
use djkr_core::adhesion::{ConstantW, GentSchultz, Law};
use djkr_core::describing::{self, Support};
use djkr_core::imposed_area::{self, indentation_at};
use djkr_core::jkr;
use djkr_core::material::Material;
use djkr_core::rig::Rig;
use djkr_core::transfer;
use std::f64::consts::PI;
use std::fmt::Write as _;

const M: Material = Material::PAPER;
/// The light rig's preload (N), as in `catalogue::vibrating_hold`.
const PRELOAD: f64 = 0.02;

/// Loop area ∮ F dδ over the imposed cycle by a fine midpoint rule in θ (J), all harmonics.
fn loop_area(law: &GentSchultz, omega: f64, a_m: f64, a_a: f64) -> f64 {
    let n = 400_000;
    let h = 2.0 * PI / n as f64;
    let d = |th: f64| indentation_at(&M, law, omega, a_m, a_a, th);
    (0..n)
        .map(|i| {
            let t0 = i as f64 * h;
            let (d0, d1) = (d(t0), d(t0 + h));
            let a = a_m + a_a * (t0 + 0.5 * h).sin();
            let f = if a > 0.0 {
                jkr::contact_force(&M, a, 0.5 * (d0 + d1))
            } else {
                0.0
            };
            f * (d1 - d0)
        })
        .sum()
}

fn main() {
    let args = Args::parse(
        "study_harmonic_balance",
        "docs/studies",
        "Harmonic balance vs eq. (37) on the light rig and the bundled scenes. Writes \
         harmonic-balance.md.",
    );
    let mut doc = args.header("Harmonic balance on the imposed-area cycle");
    let gs = GentSchultz::PAPER;
    let cw = ConstantW { w0: M.w0 };
    let rig = |law: Law| -> Rig { catalogue::light_rig(law) };
    let a0 = jkr::equilibrium_radius_for_force(&M, PRELOAD, M.w0).unwrap_or(f64::NAN);
    let kc = jkr::contact_stiffness(&M, a0);
    let kt = describing::tangent_stiffness(&M, a0, M.w0);
    let r0 = rig(Law::default());
    let (m, k) = (r0.mass(), r0.spring_stiffness());
    let _ = writeln!(
        doc,
        "## The light rig (`catalogue::light_rig`: 3 g, 200 N/m, c = 0.02 N s/m on the sphere)\n\n\
         Static load {PRELOAD} N: a0 = {:.4} mm, k_c = (3/2) K a0 = {kc:.0} N/m (eq. 37), JKR \
         tangent stiffness k_t = {kt:.0} N/m = {:.2} k_c; linear resonance f_r(k_c) = {:.1} Hz, \
         f_r(k_t) = {:.1} Hz.\n",
        a0 * 1e3,
        kt / kc,
        ((k + kc) / m).sqrt() / (2.0 * PI),
        ((k + kt) / m).sqrt() / (2.0 * PI),
    );
    let mut t = Table::new(&[
        "f (Hz)",
        "X_b (m)",
        "eq. 37 |T| (k_c)",
        "k_t |T|",
        "law",
        "|T|",
        "phase",
        "a_A (m)",
        "k_eff (N/m)",
        "c_eff (N s/m)",
        "F_m (N)",
        "contact fraction",
    ]);
    for &f in &[50.0, 200.0, 300.0, 400.0, 600.0] {
        let omega = 2.0 * PI * f;
        let lc = transfer::linear(&r0, kc, omega);
        let lt = transfer::linear(&r0, kt, omega);
        for &xb in &[1e-8, 1e-6, 1e-5, 3e-5] {
            for (name, law) in [
                ("constant w", Law::Constant(cw)),
                ("GS", Law::GentSchultz(gs)),
            ] {
                let mut row = vec![
                    format!("{f}"),
                    format!("{xb:.0e}"),
                    format!("{:.4}", lc.magnitude()),
                    format!("{:.4}", lt.magnitude()),
                    name.to_string(),
                ];
                match describing::solve(&rig(law), Support::StaticLoad(PRELOAD), xb, omega, None) {
                    Ok(h) => {
                        let tr = h.transfer();
                        let e = h.effective_contact();
                        row.extend([
                            format!("{:.4}", tr.magnitude()),
                            format!("{:.4}", tr.phase()),
                            format!("{:.3e}", h.a_amp),
                            e.map_or("—".into(), |e| format!("{:.0}", e.stiffness)),
                            e.map_or("—".into(), |e| sci(e.damping)),
                            format!("{:.5}", h.harmonics.force_mean),
                            format!("{:.3}", h.contact_fraction),
                        ]);
                    }
                    Err(e) => {
                        row.push(format!("no solution: {e}"));
                        row.extend(std::iter::repeat_n(String::new(), 6));
                    }
                }
                t.row(row);
            }
        }
    }
    doc += &t.markdown();

    doc += "\n## Gent–Schultz effective contact at a_m = a0\n\nThe contact's first-harmonic \
            force F1 = (k_eff + iω c_eff) δ1 of the imposed cycle a0 + a_A sin θ; W1 = π ω c_eff |δ1|² \
            is the energy the first harmonic dissipates per cycle, the loop area ∮ F dδ (all \
            harmonics, 400 000-point midpoint rule) the whole of it.\n\n";
    let mut t = Table::new(&[
        "f (Hz)",
        "a_A (m)",
        "k_eff (N/m)",
        "c_eff (N s/m)",
        "|δ1| (m)",
        "W1 (J)",
        "loop area (J)",
    ]);
    for &f in &[100.0, 300.0, 1000.0] {
        let omega = 2.0 * PI * f;
        for &aa in &[1e-9, 1e-8, 1e-7, 1e-6, 1e-5, 1e-4] {
            match (
                describing::effective_contact(&M, &gs, omega, a0, aa),
                imposed_area::cycle(&M, &gs, omega, a0, aa),
            ) {
                (Ok(e), Ok(c)) => {
                    let w1 = PI * omega * e.damping * c.harmonics.delta_amp * c.harmonics.delta_amp;
                    let la = if aa >= 1e-7 {
                        sci(loop_area(&gs, omega, a0, aa))
                    } else {
                        "—".into()
                    };
                    t.row([
                        format!("{f}"),
                        format!("{aa:.0e}"),
                        format!("{:.1}", e.stiffness),
                        sci(e.damping),
                        sci(c.harmonics.delta_amp),
                        sci(w1),
                        la,
                    ]);
                }
                _ => t.row([
                    format!("{f}"),
                    format!("{aa:.0e}"),
                    "failed".into(),
                    String::new(),
                    String::new(),
                    String::new(),
                    String::new(),
                ]),
            }
        }
    }
    doc += &t.markdown();

    doc += "\n## Branches traced by the contact amplitude a_A\n\n\
            `describing::at_contact_amplitude`: X_b as a function of a_A, which passes folds that \
            continuation in X_b cannot.\n\n";
    let mut t = Table::new(&[
        "law",
        "f (Hz)",
        "a_A (m)",
        "X_b (m)",
        "|T|",
        "phase",
        "a_m (m)",
        "k_eff (N/m)",
        "c_eff (N s/m)",
        "contact fraction",
    ]);
    for (name, law, f) in [
        ("GS", Law::GentSchultz(gs), 600.0),
        ("GS", Law::GentSchultz(gs), 400.0),
        ("constant w", Law::Constant(cw), 300.0),
        ("constant w", Law::Constant(cw), 600.0),
    ] {
        let omega = 2.0 * PI * f;
        let (mut aa, top) = if name == "GS" {
            (1e-12, 2e-5)
        } else {
            (1e-7, 1.1e-3)
        };
        while aa < top {
            match describing::at_contact_amplitude(
                &rig(law.clone()),
                Support::StaticLoad(PRELOAD),
                omega,
                aa,
            ) {
                Ok(h) => {
                    let e = h.effective_contact();
                    t.row([
                        name.to_string(),
                        format!("{f}"),
                        format!("{aa:.2e}"),
                        format!("{:.4e}", h.base_amplitude),
                        format!("{:.4}", h.transfer().magnitude()),
                        format!("{:.4}", h.transfer().phase()),
                        format!("{:.4e}", h.a_mean),
                        e.map_or("—".into(), |e| format!("{:.0}", e.stiffness)),
                        e.map_or("—".into(), |e| sci(e.damping)),
                        format!("{:.3}", h.contact_fraction),
                    ]);
                }
                Err(e) => t.row([
                    name.to_string(),
                    format!("{f}"),
                    format!("{aa:.2e}"),
                    format!("no solution: {e}"),
                    String::new(),
                    String::new(),
                    String::new(),
                    String::new(),
                    String::new(),
                    String::new(),
                ]),
            }
            aa *= 10f64.powf(0.5);
        }
    }
    doc += &t.markdown();

    doc += "\n## The bundled resonance and impact scenes\n\nEvery harmonic-balance solution \
            (`describing::solutions`) with the GS law, and the constant-w solution, at the scene's \
            frequency and static load.\n\n";
    let mut t = Table::new(&[
        "scene",
        "X_b (m)",
        "law",
        "|T|",
        "phase",
        "a_m (m)",
        "a_A (m)",
        "F_m (N)",
        "k_eff (N/m)",
        "c_eff (N s/m)",
    ]);
    for (b, amps) in [
        (Bundled::Resonance400, vec![1e-7, 5e-7, 1e-6, 2e-6, 5e-6]),
        (Bundled::Impacts, vec![1e-5, 5e-5, 1e-4, 2e-4, 4e-4]),
    ] {
        let Ok(sc) = b.scenario() else { continue };
        let Ok(setup) = describing::Setup::new(&sc.rig, &sc.initial) else {
            continue;
        };
        let omega = 2.0 * PI * sc.rig.base.map_or(400.0, |x| x.frequency);
        for xb in amps {
            let all =
                describing::solutions(&setup.rig, setup.support, xb, omega).unwrap_or_default();
            if all.is_empty() {
                t.row([
                    b.path().to_string(),
                    format!("{xb:.1e}"),
                    "GS".into(),
                    "no in-contact solution".into(),
                    String::new(),
                    String::new(),
                    String::new(),
                    String::new(),
                    String::new(),
                    String::new(),
                ]);
            }
            for h in &all {
                let e = h.effective_contact();
                t.row([
                    b.path().to_string(),
                    format!("{xb:.1e}"),
                    "GS".into(),
                    format!("{:.4}", h.transfer().magnitude()),
                    format!("{:.4}", h.transfer().phase()),
                    format!("{:.4e}", h.a_mean),
                    format!("{:.3e}", h.a_amp),
                    format!("{:.5}", h.harmonics.force_mean),
                    e.map_or("—".into(), |e| format!("{:.0}", e.stiffness)),
                    e.map_or("—".into(), |e| sci(e.damping)),
                ]);
            }
            let cw_rig = Rig {
                law: Law::Constant(ConstantW {
                    w0: sc.rig.material.w0,
                }),
                ..setup.rig.clone()
            };
            match describing::solve(&cw_rig, setup.support, xb, omega, None) {
                Ok(h) => t.row([
                    b.path().to_string(),
                    format!("{xb:.1e}"),
                    "constant w".into(),
                    format!("{:.4}", h.transfer().magnitude()),
                    format!("{:.4}", h.transfer().phase()),
                    format!("{:.4e}", h.a_mean),
                    format!("{:.3e}", h.a_amp),
                    format!("{:.5}", h.harmonics.force_mean),
                    String::new(),
                    String::new(),
                ]),
                Err(e) => t.row([
                    b.path().to_string(),
                    format!("{xb:.1e}"),
                    "constant w".into(),
                    format!("no solution: {e}"),
                    String::new(),
                    String::new(),
                    String::new(),
                    String::new(),
                    String::new(),
                    String::new(),
                ]),
            }
        }
    }
    doc += &t.markdown();
    print!("{doc}");
    args.write("harmonic-balance.md", &doc);
}

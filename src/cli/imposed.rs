//! `djkr cycle` and `djkr pulloff`: the imposed-area method, the closed form and the comparators.

use super::common::{
    beta_from, fmt_force, fmt_len, key_non_negative_quantity, key_positive_quantity,
    non_negative_quantity, omega_from, print_json, print_table, reject_unused, MaterialArgs,
};
use crate::api::{self, Arg, PullOffReport};
use anyhow::{bail, Result};
use clap::{Args, ValueEnum};
use djkr_core::units::Dimension;
use serde_json::json;

/// Flags of `djkr cycle`.
#[derive(Args, Debug)]
pub struct CycleArgs {
    /// Vibration frequency f = ω/2π, in [1e-6, 1e6] Hz as base.frequency. Units: Hz, kHz.
    #[arg(long, value_name = "HZ", allow_hyphen_values = true)]
    freq: String,
    /// Imposed mean contact radius a_m (≥ −a_A; below a_A the cycle is truncated at a = 0).
    #[arg(long, value_name = "M", allow_hyphen_values = true)]
    a_mean: String,
    /// Amplitude a_A of the contact-radius oscillation (≥ 0, a_m + a_A ≤ R).
    #[arg(long, value_name = "M", allow_hyphen_values = true)]
    a_amp: String,
    /// Print one JSON object of SI values instead of a table.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    material: MaterialArgs,
}

/// Run `djkr cycle`.
pub fn cycle(a: &CycleArgs) -> Result<()> {
    let (m, law) = a.material.resolve()?;
    let r = api::cycle_args(
        &m,
        &law,
        Arg::new("--freq", &a.freq),
        Arg::new("--a-mean", &a.a_mean),
        Arg::new("--a-amp", &a.a_amp),
    )?;
    let (omega, c, notes) = (r.omega, &r.cycle, &r.notes);
    for n in notes {
        eprintln!("warning: {n}");
    }
    if a.json {
        return print_json(&r.json());
    }
    print_table(
        &format!(
            "Imposed-area cycle at {:.6} Hz (a(t) = a_m + a_A sin ωt{})",
            omega / (2.0 * std::f64::consts::PI),
            if c.contact_fraction < 1.0 {
                ", truncated at a = 0"
            } else {
                ""
            }
        ),
        &[
            ("a_m imposed", fmt_len(c.a_mean_imposed)),
            ("a_A", fmt_len(c.a_amp)),
            ("a_m (mean of the cycle)", fmt_len(c.a_mean)),
            ("δ_m mean indentation", fmt_len(c.harmonics.delta_mean)),
            ("δ_s (sin harmonic, eq. 26)", fmt_len(c.harmonics.delta_sin)),
            ("δ_c (cos harmonic, eq. 25)", fmt_len(c.harmonics.delta_cos)),
            ("δ_A (eq. 27)", fmt_len(c.harmonics.delta_amp)),
            ("F_m mean force", fmt_force(c.harmonics.force_mean)),
            ("contact fraction", format!("{:.6}", c.contact_fraction)),
        ],
    )?;
    for n in notes {
        outln!("  note: {n}")?;
    }
    Ok(())
}

/// A value-enum flag's value as the user types it (`exact`, not `Exact`).
fn flag_value<T: ValueEnum>(v: T) -> String {
    v.to_possible_value()
        .map_or_else(String::new, |p| p.get_name().to_string())
}

/// Pull-off methods.
#[derive(ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum PulloffMethod {
    /// Imposed-area method (Sec. 2.1), minimised over a_m.
    Exact,
    /// Closed form, eqs. (20)–(24) with β.
    Approx,
    /// Shui et al. eq. (5), corrected (needs --mass, --damping, --base-amp).
    Shui,
    /// Yi et al. eq. (8) with δ_m = δ_A.
    Yi,
}

/// Flags of `djkr pulloff`.
#[derive(Args, Debug)]
pub struct PulloffArgs {
    /// Vibration frequency f = ω/2π, in [1e-6, 1e6] Hz as base.frequency. Units: Hz, kHz.
    #[arg(long, value_name = "HZ", allow_hyphen_values = true)]
    freq: String,
    /// Amplitude a_A of the contact-radius oscillation (≥ 0). For `yi` it sets δ_A = 2a_A²/R
    /// unless --delta-amp is given.
    #[arg(long, value_name = "M", allow_hyphen_values = true)]
    a_amp: Option<String>,
    /// Method.
    #[arg(long, value_enum, default_value_t = PulloffMethod::Exact)]
    method: PulloffMethod,
    /// Speed correction β of eq. (24) for `approx`, in [0.01, 100] [default: 2.5].
    #[arg(long, allow_hyphen_values = true)]
    beta: Option<String>,
    /// δ_A amplitude in the closed form (`approx`): as derived from eqs. (14)−(15)
    /// (docs/MODEL.md), or as printed in eq. (23) (for comparison with the paper)
    /// [default: derived].
    #[arg(long, value_enum)]
    delta_form: Option<DeltaForm>,
    /// Sphere mass m for `shui`, in [1e-20, 1e4] kg as sphere.mass. Units: kg, g.
    #[arg(long, value_name = "KG", allow_hyphen_values = true)]
    mass: Option<String>,
    /// Damping c for `shui`, in (0, 1e9] N s/m as damping.c. Units: Ns/m.
    #[arg(long, value_name = "C", allow_hyphen_values = true)]
    damping: Option<String>,
    /// Base amplitude X_b for `shui`, in [0, 1] m as base.amplitude.
    #[arg(long, value_name = "M", allow_hyphen_values = true)]
    base_amp: Option<String>,
    /// Indentation amplitude δ_A for `yi` (≥ 0).
    #[arg(long, value_name = "M", allow_hyphen_values = true)]
    delta_amp: Option<String>,
    /// Print one JSON object of SI values instead of a table.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    material: MaterialArgs,
}

/// Closed-form δ_A variants.
#[derive(ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum DeltaForm {
    /// δ_A derived from eqs. (14)−(15) (zero at a_A = 0).
    Derived,
    /// δ_A as printed in eq. (23).
    Printed,
}

/// Run `djkr pulloff`.
pub fn pulloff(a: &PulloffArgs) -> Result<()> {
    let method = a.method;
    let closed_form = [
        ("--beta", a.beta.is_some()),
        ("--delta-form", a.delta_form.is_some()),
    ];
    let shui = [
        ("--mass", a.mass.is_some()),
        ("--damping", a.damping.is_some()),
        ("--base-amp", a.base_amp.is_some()),
    ];
    let yi = [("--delta-amp", a.delta_amp.is_some())];
    let mode = format!("with --method {}", flag_value(method));
    match method {
        PulloffMethod::Exact => reject_unused(&[&closed_form[..], &shui, &yi].concat(), &mode)?,
        PulloffMethod::Approx => reject_unused(&[&shui[..], &yi].concat(), &mode)?,
        PulloffMethod::Shui => reject_unused(
            &[&closed_form[..], &yi, &[("--a-amp", a.a_amp.is_some())]].concat(),
            &format!("{mode} (its eq. 5 sets a_m itself from --mass, --damping, --base-amp)"),
        )?,
        PulloffMethod::Yi => {
            reject_unused(&[&closed_form[..], &shui].concat(), &mode)?;
            if a.delta_amp.is_some() {
                reject_unused(
                    &[("--a-amp", a.a_amp.is_some())],
                    "with --method yi and --delta-amp (--a-amp only sets delta_A = 2 a_A^2/R when --delta-amp is absent)",
                )?;
            }
        }
    }
    let (m, law) = a.material.resolve()?;
    let omega = omega_from("--freq", &a.freq)?;
    let a_amp = match &a.a_amp {
        Some(t) => {
            let v = non_negative_quantity("--a-amp", t, Dimension::Length)?;
            if let Some(e) = crate::scenario::checks::contact_radius_error(v, m.r) {
                bail!("--a-amp = {}: {e}", djkr_core::text::excerpt(t));
            }
            Some(v)
        }
        None => None,
    };
    let need_a_amp = || {
        a_amp.ok_or_else(|| {
            anyhow::anyhow!("--a-amp is required for --method {}", flag_value(a.method))
        })
    };
    let method = match a.method {
        PulloffMethod::Exact => api::PullOffMethod::Exact {
            a_amp: need_a_amp()?,
        },
        PulloffMethod::Approx => {
            let beta = match &a.beta {
                Some(t) => beta_from("--beta", t)?,
                None => djkr_core::closed_form::BETA_PAPER,
            };
            let form = match a.delta_form.unwrap_or(DeltaForm::Derived) {
                DeltaForm::Derived => djkr_core::closed_form::DeltaAmpForm::Derived,
                DeltaForm::Printed => djkr_core::closed_form::DeltaAmpForm::Printed,
            };
            api::PullOffMethod::Approx {
                a_amp: need_a_amp()?,
                beta,
                form,
            }
        }
        PulloffMethod::Shui | PulloffMethod::Yi => return comparators(a, &m, &law, omega, a_amp),
    };
    let r = api::pull_off_at(&m, &law, omega, method)?;
    pull_off_finite(a, &r)?;
    for w in &r.warnings {
        eprintln!("warning: {w}");
    }
    report(&r, a.json)
}

/// Refuse a pull-off that holds a non-finite number, naming the flags it came from.
fn pull_off_finite(a: &PulloffArgs, r: &PullOffReport) -> Result<()> {
    let mut inputs = vec![Arg::new("--freq", &a.freq)];
    for (name, t) in [("--a-amp", &a.a_amp), ("--delta-amp", &a.delta_amp)] {
        if let Some(t) = t {
            inputs.push(Arg::new(name, t));
        }
    }
    Ok(api::finite_result(
        &inputs,
        &[
            ("a_m", r.a_mean),
            ("delta_m", r.delta_mean),
            ("delta_A", r.delta_amp),
            ("F_m", r.force),
            ("amplification", r.amplification),
        ],
    )?)
}

fn report(r: &PullOffReport, json_out: bool) -> Result<()> {
    if json_out {
        return print_json(&r.json());
    }
    print_table(
        &format!("Pull-off, {}", r.method),
        &[
            ("a_m,po mean contact radius", fmt_len(r.a_mean)),
            ("δ_m,po mean indentation", fmt_len(r.delta_mean)),
            ("δ_A,po indentation amplitude", fmt_len(r.delta_amp)),
            ("F_m,po pull-off force", fmt_force(r.force)),
            (
                "amplification F/F0 (F0 = -3/2 π R w0)",
                format!("{:.6}", r.amplification),
            ),
        ],
    )?;
    for n in &r.notes {
        outln!("  note: {n}")?;
    }
    Ok(())
}

fn comparators(
    a: &PulloffArgs,
    m: &djkr_core::material::Material,
    law: &djkr_core::adhesion::Law,
    omega: f64,
    a_amp: Option<f64>,
) -> Result<()> {
    use djkr_core::comparators as cmp;
    let r = if a.method == PulloffMethod::Shui {
        let need = |flag: &str, v: &Option<String>| {
            v.clone()
                .ok_or_else(|| anyhow::anyhow!("--method shui needs {flag} (Shui et al.'s eq. 5 is a sphere/contact oscillator)"))
        };
        let s = cmp::ShuiSystem {
            mass: key_positive_quantity(
                "--mass",
                &need("--mass", &a.mass)?,
                Dimension::Mass,
                "sphere.mass",
            )?,
            damping: key_positive_quantity(
                "--damping",
                &need("--damping", &a.damping)?,
                Dimension::Damping,
                "damping.c",
            )?,
            base_amplitude: key_non_negative_quantity(
                "--base-amp",
                &need("--base-amp", &a.base_amp)?,
                Dimension::Length,
                "base.amplitude",
            )?,
            omega,
        };
        let p = cmp::shui_pull_off(m, &s)?;
        let eq6 = cmp::shui_pull_off_eq6(&s);
        let eq7 = cmp::shui_pull_off_eq7(&s);
        let inputs = [
            Arg::new("--freq", &a.freq),
            Arg::new("--mass", a.mass.as_deref().unwrap_or_default()),
            Arg::new("--damping", a.damping.as_deref().unwrap_or_default()),
            Arg::new("--base-amp", a.base_amp.as_deref().unwrap_or_default()),
        ];
        api::finite_result(
            &inputs,
            &[
                ("a_m", p.a_mean),
                ("F_m", p.force),
                ("amplification", p.amplification),
                ("eq. (6)", eq6),
                ("eq. (7)", eq7),
            ],
        )?;
        if a.json {
            return print_json(&json!({
                "method": "shui",
                "a_mean": p.a_mean,
                "force": p.force,
                "amplification": p.amplification,
                "force_eq6": eq6,
                "force_eq7": eq7,
            }));
        }
        print_table(
            "Pull-off, Shui et al. (2020) eq. (5) with the a_m^3 correction (no Gent-Schultz dependence)",
            &[
                ("a_m,po mean contact radius", fmt_len(p.a_mean)),
                ("F_m,po minimum of eq. (5)", fmt_force(p.force)),
                ("amplification F/F0", format!("{:.6}", p.amplification)),
                ("eq. (6), (mω/c)^2 corrected", fmt_force(eq6)),
                ("eq. (7), c → ∞", fmt_force(eq7)),
            ],
        )?;
        return Ok(());
    } else {
        let delta_amp = match (&a.delta_amp, a_amp) {
            (Some(t), _) => non_negative_quantity("--delta-amp", t, Dimension::Length)?,
            (None, Some(aa)) => cmp::yi_indentation_amplitude_from_area_amplitude(m, aa),
            (None, None) => bail!("--method yi needs --delta-amp or --a-amp (then δ_A = 2 a_A²/R)"),
        };
        let r = api::pull_off_at(m, law, omega, api::PullOffMethod::Yi { delta_amp })?;
        pull_off_finite(a, &r)?;
        r
    };
    report(&r, a.json)
}

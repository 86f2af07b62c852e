//! The fit's solver tolerances, chosen from the accuracy the data need.
//!
//! A forward run at the scenario's tolerances (the paper protocol's `rtol = 1e-8`,
//! `envelope_tol = 1e-6`) resolves the observable to about 1e-6 of itself, while measured data
//! carry percent errors. So a fit runs its model at looser tolerances: the model's error at
//! most [`ERROR_FRACTION`] of the smallest relative sigma of the data,
//! `ε = ERROR_FRACTION · minᵢ σᵢ/|yᵢ|`, from the measured relation of each tolerance to the
//! error it leaves in the observable ([`RTOL_GAIN`], [`ENVELOPE_GAIN`]): `rtol = ε / RTOL_GAIN`,
//! `envelope_tol = ε / ENVELOPE_GAIN`, never tighter than the scenario's nor looser than
//! [`RTOL_MAX`], [`ENVELOPE_TOL_MAX`]. A `--set` of a tolerance wins (it is kept). At the
//! estimate one parameter set is run again at the scenario's tolerances: where the model's
//! error exceeds `ERROR_FRACTION · σᵢ` in a row, the tolerances are tightened by the excess
//! (and a factor 2) and the fit goes on from the estimate; `fit.json`'s `tolerances` says what
//! was used and the error met. The files (residuals.csv, χ²) hold the prediction at the
//! scenario's tolerances, which `fitted.toml` reproduces.
//!
//! Not chosen (the scenario's kept): without a sigma column (no scale of the data's error),
//! with an ensemble (the members of a chaotic rig change entirely with any tolerance; the
//! ensemble's standard error, not the integration, limits the accuracy), and where both
//! tolerances are given by `--set`.
//!
//! The finite-difference steps follow from the same level: `h = √ε` ([`super::problem::fd_step`]).

use crate::scenario::overrides::{Override, SetKey};

/// The largest model error allowed, as a fraction of a row's sigma. At 1 % of σ in every row
/// an estimate moves by at most about 0.01 √n σ (0.04 σ for 18 rows) in the worst case of an
/// error that mimics a parameter, and χ² by about 0.02 √n.
pub const ERROR_FRACTION: f64 = 0.01;

/// The observable's relative error per unit of `solver.rtol` (measured on the paper protocol
/// at 10–80 µm: the pull-off amplification moves by at most this times `rtol` relative to its
/// value at `rtol = 1e-10`).
pub const RTOL_GAIN: f64 = 100.0;

/// The observable's relative error per unit of `solver.envelope_tol`, an upper bound (measured
/// on the 200–400 Hz paper protocols against `envelope = "off"`: at `envelope_tol = 1e-4` the
/// amplification moves by 3.2–4.4e-5 relative, at 1e-5 by 2.5–3.1e-6; 6e-5 and 2e-5 at 300 Hz
/// while the envelope's corrector read P(z) − z as the derivative at the new point).
pub const ENVELOPE_GAIN: f64 = 1.0;

/// The loosest `solver.rtol` a fit chooses. Not the estimate but the Jacobian sets it: a
/// column's change across the step `√ε` must stand [`super::stencil::TARGET_SNR`] times above
/// the model's error `ε`, so a key the data see weakly needs a small `ε`. On the heavy rig
/// with 2 % data (ε = 2e-4 from [`ERROR_FRACTION`]: rtol 2e-6, envelope_tol 2e-4) the
/// `adhesion.v0` column stood about once above the error: every Jacobian widened its step
/// (up to three rounds of 18 more runs), the last one a secant over ±3σ that put σ(v0) 13 %
/// off and failed the linear check of n, whose profile then cost 2 700 runs (3 400 in all
/// against 342 at the scenario's tolerances, 4x the CPU time). At rtol 1e-7 and envelope_tol
/// 1e-5 (an error level of 2e-5) the fit took 6 iterations without that, each run at 0.4 of
/// the scenario's RHS evaluations.
pub const RTOL_MAX: f64 = 1e-7;

/// The loosest `solver.envelope_tol` a fit chooses (see [`RTOL_MAX`]).
pub const ENVELOPE_TOL_MAX: f64 = 1e-5;

/// The scenario's solver settings that matter here.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scenario {
    /// `solver.rtol`.
    pub rtol: f64,
    /// `solver.envelope_tol`.
    pub envelope_tol: f64,
    /// Whether envelope following is on (`auto`).
    pub envelope: bool,
    /// Whether `--set` gives `solver.rtol`.
    pub rtol_set: bool,
    /// Whether `--set` gives `solver.envelope_tol`.
    pub envelope_tol_set: bool,
}

/// The fit's tolerances: rtol, envelope_tol, whether either was chosen (looser than the
/// scenario's), and why, for a model error `eps` relative (None: keep the scenario's, with
/// the reason).
pub fn choose(s: &Scenario, eps: Result<f64, String>) -> (f64, f64, bool, String) {
    let eps = match eps {
        Ok(e) if e.is_finite() && e > 0.0 => e,
        Ok(_) => {
            return (
                s.rtol,
                s.envelope_tol,
                false,
                "the scenario's: the data give no scale of their error".into(),
            )
        }
        Err(why) => return (s.rtol, s.envelope_tol, false, why),
    };
    let rtol = if s.rtol_set {
        s.rtol
    } else {
        (eps / RTOL_GAIN).clamp(s.rtol, RTOL_MAX.max(s.rtol))
    };
    let envelope_tol = if s.envelope_tol_set || !s.envelope {
        s.envelope_tol
    } else {
        (eps / ENVELOPE_GAIN).clamp(s.envelope_tol, ENVELOPE_TOL_MAX.max(s.envelope_tol))
    };
    let chosen = rtol > s.rtol || envelope_tol > s.envelope_tol;
    let capped = (!s.rtol_set && eps / RTOL_GAIN > RTOL_MAX.max(s.rtol))
        || (!s.envelope_tol_set && s.envelope && eps / ENVELOPE_GAIN > ENVELOPE_TOL_MAX);
    let why = if chosen {
        format!(
            "chosen from the data: a model error of at most {ERROR_FRACTION} of the smallest \
             relative sigma ({eps:.3e} relative){}{}",
            if capped {
                format!(
                    ", at most rtol {RTOL_MAX:e} and envelope_tol {ENVELOPE_TOL_MAX:e} (the \
                     Jacobian's columns must stand above the model's error)"
                )
            } else {
                String::new()
            },
            match (s.rtol_set, s.envelope_tol_set) {
                (true, true) => "",
                (true, false) => "; solver.rtol as overridden",
                (false, true) => "; solver.envelope_tol as overridden",
                (false, false) => "",
            }
        )
    } else if s.rtol_set && (s.envelope_tol_set || !s.envelope) {
        "the scenario's, or as overridden".into()
    } else {
        "the scenario's: the data are as precise as its tolerances resolve".into()
    };
    (rtol, envelope_tol, chosen, why)
}

/// The overrides of the fit's tolerances (those that differ from the scenario's).
pub fn overrides(s: &Scenario, rtol: f64, envelope_tol: f64) -> Vec<Override> {
    let mut out = Vec::new();
    let mut push = |key: &str, v: f64| {
        if let Ok(k) = SetKey::parse(key) {
            if let Ok(o) = Override::from_key(k, v) {
                out.push(o);
            }
        }
    };
    if rtol.to_bits() != s.rtol.to_bits() {
        push("solver.rtol", rtol);
    }
    if envelope_tol.to_bits() != s.envelope_tol.to_bits() {
        push("solver.envelope_tol", envelope_tol);
    }
    out
}

/// The tolerances tightened after a check met a model error of `error` (in units of sigma)
/// against the allowed [`ERROR_FRACTION`]: divided by twice the excess, never tighter than
/// the scenario's.
pub fn tighten(s: &Scenario, rtol: f64, envelope_tol: f64, error: f64) -> (f64, f64) {
    let f = (2.0 * error / ERROR_FRACTION).max(2.0);
    (
        (rtol / f).max(s.rtol),
        (envelope_tol / f).max(s.envelope_tol),
    )
}

/// The model error the data allow, relative: [`ERROR_FRACTION`] of the smallest relative sigma
/// of the rows (those observed non-zero); or why the scenario's tolerances are kept (an ensemble
/// of `members > 1`, or no sigma column).
pub fn data_error(data: &super::data::FitData, members: usize) -> Result<f64, String> {
    if members > 1 {
        Err(
            "the scenario's: with an ensemble its standard error, not the integration, limits \
             the accuracy (and a chaotic member changes entirely with any tolerance)"
                .to_string(),
        )
    } else if !data.has_sigma {
        Err("the scenario's: the data have no sigma column to scale the model's error".into())
    } else {
        Ok(ERROR_FRACTION
            * data
                .rows
                .iter()
                .filter(|r| r.observed != 0.0)
                .map(|r| r.sigma.unwrap_or(f64::INFINITY) / r.observed.abs())
                .fold(f64::INFINITY, f64::min))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const PAPER: Scenario = Scenario {
        rtol: 1e-8,
        envelope_tol: 1e-6,
        envelope: true,
        rtol_set: false,
        envelope_tol_set: false,
    };

    /// Data at 0.05 %: a model error of 5e-6 relative, so rtol 5e-8 and envelope_tol 5e-6;
    /// 2 % data (2e-4) are held at the caps, and say so; a --set tolerance is kept; data more
    /// precise than the scenario resolves keep the scenario's.
    #[test]
    fn tolerances_follow_the_data() {
        let (r, e, chosen, why) = choose(&PAPER, Ok(0.01 * 0.0005));
        assert!(
            (r - 5e-8).abs() < 1e-20 && (e - 5e-6).abs() < 1e-18,
            "{r} {e}"
        );
        assert!(chosen && !why.contains("at most rtol"), "{why}");
        let (r, e, chosen, why) = choose(&PAPER, Ok(0.01 * 0.02));
        assert_eq!((r, e), (RTOL_MAX, ENVELOPE_TOL_MAX));
        assert!(
            chosen && why.contains("at most rtol 1e-7 and envelope_tol 1e-5"),
            "{why}"
        );
        let set = Scenario {
            rtol_set: true,
            ..PAPER
        };
        let (r, e, _, why) = choose(&set, Ok(5e-6));
        assert_eq!(r.to_bits(), 1e-8f64.to_bits());
        assert!(
            (e - 5e-6).abs() < 1e-18 && why.contains("solver.rtol as overridden"),
            "{why}"
        );
        let (r, e, chosen, why) = choose(&PAPER, Ok(1e-9));
        assert_eq!(
            (r.to_bits(), e.to_bits(), chosen),
            (1e-8f64.to_bits(), 1e-6f64.to_bits(), false)
        );
        assert!(why.contains("as precise"), "{why}");
        // Very loose data: at most RTOL_MAX, ENVELOPE_TOL_MAX.
        let (r, e, _, _) = choose(&PAPER, Ok(0.5));
        assert_eq!(
            (r.to_bits(), e.to_bits()),
            (RTOL_MAX.to_bits(), ENVELOPE_TOL_MAX.to_bits())
        );
        let o = overrides(&PAPER, 2e-6, 1e-6);
        assert_eq!(o.len(), 1);
        assert_eq!(o[0].to_string(), "solver.rtol=2e-6");
        let (r, e) = tighten(&PAPER, 2e-6, 2e-4, 0.05);
        assert!(
            (r - 2e-7).abs() < 1e-20 && (e - 2e-5).abs() < 1e-18,
            "{r} {e}"
        );
        let (r, e) = tighten(&PAPER, 2e-8, 2e-6, 1.0);
        assert_eq!(
            (r.to_bits(), e.to_bits()),
            (1e-8f64.to_bits(), 1e-6f64.to_bits())
        );
    }

    /// 1 % of the smallest relative sigma: rows at 2 % and 5 % (an observed 0 has no relative
    /// sigma and is left out) give 2e-4; an ensemble or a file without sigma keeps the
    /// scenario's.
    #[test]
    fn the_error_follows_the_smallest_relative_sigma() {
        let csv = "base.amplitude [um],pull_off_amplification [1],sigma [1]\n\
                   10,2.0,0.04\n20,4.0,0.2\n30,0,0.01\n";
        let d = super::super::data::FitData::parse(csv, "d.csv", None).expect("data");
        let e = data_error(&d, 1).expect("an error level");
        assert!((e - 0.01 * 0.02).abs() < 1e-18, "{e}");
        assert!(data_error(&d, 8).is_err_and(|m| m.contains("ensemble")));
        let csv = "base.amplitude [um],pull_off_amplification [1]\n10,2.0\n20,4.0\n";
        let d = super::super::data::FitData::parse(csv, "d.csv", None).expect("data");
        assert!(data_error(&d, 1).is_err_and(|m| m.contains("no sigma column")));
    }
}

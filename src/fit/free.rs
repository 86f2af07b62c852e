//! The free keys of a fit (`--free KEY[=LO:HI]`) and the coordinates the optimiser moves them in.
//!
//! Three coordinates per key:
//! - `x`, the key's value in SI, as the scenario takes it;
//! - `y`, the *fit coordinate*: `ln x` for a positive scale (a key with a physical dimension,
//!   positive at the start and not bounded below by 0 or less), so that a step is relative and
//!   the estimate can never change sign; otherwise `x / s` with `s` the starting magnitude
//!   (`adhesion.n`, angles), so that every coordinate is of order one;
//! - `u`, the optimiser's unbounded coordinate: `y = u` without bounds, and with bounds the
//!   transforms of MINUIT (James & Roos 1975): `y = lo + (hi − lo)(sin u + 1)/2` for two bounds,
//!   `y = lo − 1 + √(u² + 1)` for a lower one, `y = hi + 1 − √(u² + 1)` for an upper one. They
//!   keep every trial inside the bounds without a constrained solver; at a bound `dy/du = 0`,
//!   which is how a bound that was hit is recognised (and no σ is claimed for it).
//!
//! Uncertainties are computed in `y` (the Jacobian with respect to `y`) and carried to `x` by
//! the derivative: `σ_x = x σ_y` in log space, `σ_x = s σ_y` otherwise.

use crate::scenario::overrides::SetKey;
use crate::scenario::parse::range_error;
use crate::sweep::spec::{key_kind, KeyKind};
use crate::words::input_value;
use djkr_core::text::excerpt;
use djkr_core::units::{parse_quantity, Dimension};

/// A free key as given on the command line, parsed.
#[derive(Debug, Clone, PartialEq)]
pub struct FreeKey {
    /// The key.
    pub key: SetKey,
    /// Its SI unit (`1` for a plain number).
    pub unit: &'static str,
    /// The units its values and bounds are read in.
    pub dim: Dimension,
    /// Lower bound (SI), if any.
    pub lo: Option<f64>,
    /// Upper bound (SI), if any.
    pub hi: Option<f64>,
    /// `KEY[=LO:HI]` as given.
    pub given: String,
}

impl FreeKey {
    /// Parse `KEY` or `KEY=LO:HI` (either bound may be left empty: `KEY=0.1:`, `KEY=:2`; units
    /// welcome). A key must be numeric.
    pub fn parse(arg: &str) -> Result<FreeKey, String> {
        let err = |m: String| format!("{}: {m}", input_value("free", &excerpt(arg)));
        let (k, range) = match arg.split_once('=') {
            Some((k, r)) => (k.trim(), Some(r.trim())),
            None => (arg.trim(), None),
        };
        let key = SetKey::parse(k).map_err(|e| err(e.message))?;
        if !physical(&key) {
            return Err(err(format!(
                "{key} is a numerical setting of the run, not a constant of the rig: only \
                 physical keys can be fitted (a numerical setting is given as an override; a fit \
                 chooses solver.rtol and solver.envelope_tol from the data's sigma). Keys that can be \
                 freed: {}",
                fittable_keys().join(", ")
            )));
        }
        let (dim, unit) = match key_kind(&key) {
            Some(KeyKind::Number { dim, unit }) => (dim.unwrap_or(Dimension::Dimensionless), unit),
            _ => {
                return Err(err(format!(
                    "{key} is not a numeric key: only numbers can be fitted"
                )))
            }
        };
        let (mut lo, mut hi) = (None, None);
        if let Some(r) = range {
            let Some((a, b)) = r.split_once(':') else {
                return Err(err(
                    "bounds are LO:HI (either may be empty), e.g. adhesion.v_sat=0.01:100".into(),
                ));
            };
            // A bound lies in the key's range or at its edge (0 for a key > 0, 2 pi for
            // base.phase): the value just inside it must be allowed. Beyond it, the fit would
            // try values every run refuses, and bounds such as -1e308:1e308 overflowed the
            // fit's coordinate to NaN, refused as a value nobody gave.
            let bound = |t: &str, which: &str, inward: f64| -> Result<Option<f64>, String> {
                let t = t.trim();
                if t.is_empty() {
                    return Ok(None);
                }
                let shown = excerpt(t);
                let x = parse_quantity(&key.to_string(), t, dim)
                    .map_err(|e| err(format!("{which} '{shown}': {}", e.allowed)))?;
                if !x.is_finite() {
                    return Err(err(format!("{which} '{shown}' is not finite")));
                }
                let inside = if x == 0.0 {
                    inward * f64::MIN_POSITIVE
                } else {
                    x + inward * x.abs() * 1e-12
                };
                if range_error(key, x).is_some() {
                    if let Some(why) = range_error(key, inside) {
                        return Err(err(format!(
                            "{which} '{shown}' lies outside the range of {key}: {why}"
                        )));
                    }
                }
                Ok(Some(x))
            };
            lo = bound(a, "LO", 1.0)?;
            hi = bound(b, "HI", -1.0)?;
            if let (Some(l), Some(h)) = (lo, hi) {
                if l >= h {
                    return Err(err(format!("LO must be below HI ({l} >= {h})")));
                }
            }
        }
        Ok(FreeKey {
            key,
            unit,
            dim,
            lo,
            hi,
            given: arg.trim().to_string(),
        })
    }

    /// Parse every `--free` argument, refusing a key given twice at the first repeat (before
    /// each key's starting value is read from the scenario: a list of a million copies of one
    /// key read the scenario a million times).
    pub fn parse_all<S: AsRef<str>>(args: &[S]) -> Result<Vec<FreeKey>, String> {
        let mut out: Vec<FreeKey> = Vec::new();
        for a in args {
            let f = FreeKey::parse(a.as_ref())?;
            if let Some(first) = out.iter().find(|g| g.key == f.key) {
                return Err(format!(
                    "{}: {} is already free by {}: give each key once",
                    input_value("free", &excerpt(&f.given)),
                    f.key,
                    input_value("free", &excerpt(&first.given))
                ));
            }
            out.push(f);
        }
        Ok(out)
    }

    /// Whether the key is fitted in log space when it starts at `x0`: a positive scale (a
    /// physical dimension other than an angle, a positive start and no bound at or below 0).
    pub fn log_space(&self, x0: f64) -> bool {
        !matches!(self.dim, Dimension::Dimensionless | Dimension::Angle)
            && x0 > 0.0
            && self.lo.is_none_or(|l| l > 0.0)
    }
}

/// The sections whose numeric keys describe the rig and its protocol, and so can be fitted:
/// the material, the adhesion law, the sphere, its holder, the damping, the base motion, the
/// contact's formation and the initial state; of a stage, its speed and its preload (what the
/// rig does, not when djkr stops it). Refused: `version`, `solver.*` (tolerances, budgets),
/// `output.*`, and a stage's `duration` and `max_duration` (a stage's end and a safety limit:
/// freeing `stage[0].max_duration` made every parameter lose its sigma, issue 36).
const PHYSICAL_SECTIONS: [&str; 8] = [
    "material", "adhesion", "sphere", "spring", "damping", "base", "contact", "initial",
];

/// A stage's keys that can be fitted.
const PHYSICAL_STAGE_KEYS: [&str; 2] = ["speed", "preload"];

/// Whether `key` is a physical key (see [`PHYSICAL_SECTIONS`]).
pub fn physical(key: &SetKey) -> bool {
    match key.section() {
        Some(crate::scenario::keys::STAGE_SECTION) => PHYSICAL_STAGE_KEYS.contains(&key.name()),
        Some(s) => PHYSICAL_SECTIONS.contains(&s),
        None => false,
    }
}

/// Every key a fit can free, as `--free` takes it (`stage[N].speed` for the stages' keys), in
/// the order of the scenario format: the numeric keys of [`physical`].
pub(crate) fn fittable_keys() -> Vec<String> {
    use crate::scenario::keys::{Kind, KEYS, STAGE_SECTION};
    KEYS.iter()
        .filter(|k| matches!(k.kind, Kind::Number(_)))
        .filter_map(|k| {
            if k.section == STAGE_SECTION {
                PHYSICAL_STAGE_KEYS
                    .contains(&k.name)
                    .then(|| format!("stage[N].{}", k.name))
            } else {
                PHYSICAL_SECTIONS
                    .contains(&k.section)
                    .then(|| format!("{}.{}", k.section, k.name))
            }
        })
        .collect()
}

/// How one key maps between `x`, `y` and `u` (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Transform {
    /// `y = ln x` (else `y = x / scale`).
    pub log: bool,
    /// The scale of a linear key.
    pub scale: f64,
    /// Bounds in `y`.
    pub lo: Option<f64>,
    /// Upper bound in `y`.
    pub hi: Option<f64>,
}

impl Transform {
    /// The transform of `free` starting at `x0`.
    pub fn new(free: &FreeKey, x0: f64) -> Transform {
        let log = free.log_space(x0);
        let scale = if x0 != 0.0 { x0.abs() } else { 1.0 };
        let to_y = |x: f64| if log { x.ln() } else { x / scale };
        Transform {
            log,
            scale,
            lo: free.lo.map(to_y),
            hi: free.hi.map(to_y),
        }
    }

    /// `x` from `y`.
    pub fn x(&self, y: f64) -> f64 {
        if self.log {
            y.exp()
        } else {
            y * self.scale
        }
    }

    /// `y` from `x`.
    pub fn y(&self, x: f64) -> f64 {
        if self.log {
            x.ln()
        } else {
            x / self.scale
        }
    }

    /// `dx/dy`.
    pub fn dx_dy(&self, y: f64) -> f64 {
        if self.log {
            y.exp()
        } else {
            self.scale
        }
    }

    /// `y` from `u`.
    pub fn y_of_u(&self, u: f64) -> f64 {
        match (self.lo, self.hi) {
            (None, None) => u,
            // The factor in [0, 1] first: (h - l)(sin u + 1) overflows for a span above half
            // the largest double, while halving is exact, so the value is otherwise the same.
            (Some(l), Some(h)) => l + (h - l) * ((u.sin() + 1.0) / 2.0),
            (Some(l), None) => l - 1.0 + (u * u + 1.0).sqrt(),
            (None, Some(h)) => h + 1.0 - (u * u + 1.0).sqrt(),
        }
    }

    /// `dy/du`.
    pub fn dy_du(&self, u: f64) -> f64 {
        match (self.lo, self.hi) {
            (None, None) => 1.0,
            (Some(l), Some(h)) => (h - l) * (u.cos() / 2.0),
            (Some(_), None) => u / (u * u + 1.0).sqrt(),
            (None, Some(_)) => -u / (u * u + 1.0).sqrt(),
        }
    }

    /// `u` from `y` (a `y` outside the bounds is brought to the nearest one).
    pub fn u_of_y(&self, y: f64) -> f64 {
        match (self.lo, self.hi) {
            (None, None) => y,
            (Some(l), Some(h)) => {
                let s = (2.0 * (y - l) / (h - l) - 1.0).clamp(-1.0, 1.0);
                s.asin()
            }
            (Some(l), None) => {
                let t = (y - l + 1.0).max(1.0);
                (t * t - 1.0).sqrt()
            }
            (None, Some(h)) => {
                let t = (h - y + 1.0).max(1.0);
                (t * t - 1.0).sqrt()
            }
        }
    }

    /// Whether `y` lies at a bound (within `tol` of the bounded range, or 1e-6 in `y` for a
    /// one-sided bound).
    pub fn at_bound(&self, y: f64) -> bool {
        let tol = match (self.lo, self.hi) {
            (Some(l), Some(h)) => 1e-4 * (h - l),
            _ => 1e-4,
        };
        self.lo.is_some_and(|l| y - l <= tol) || self.hi.is_some_and(|h| h - y <= tol)
    }

    /// Whether `y` lies within the bounds.
    pub fn inside(&self, y: f64) -> bool {
        self.lo.is_none_or(|l| y >= l) && self.hi.is_none_or(|h| y <= h)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn free_keys_parse_with_units_and_bounds() {
        let f = FreeKey::parse("adhesion.v_sat=10mm/s:100").unwrap();
        assert_eq!(f.lo, Some(0.01));
        assert_eq!(f.hi, Some(100.0));
        assert!(f.log_space(1.0));
        let f = FreeKey::parse("adhesion.n").unwrap();
        assert!(!f.log_space(0.5));
        assert!(FreeKey::parse("adhesion.law")
            .unwrap_err()
            .contains("not a numeric key"));
        assert!(FreeKey::parse("adhesion.wobble").is_err());
        assert!(FreeKey::parse("adhesion.n=2:1")
            .unwrap_err()
            .contains("below"));
        assert!(FreeKey::parse("adhesion.v0=1Hz:2Hz").is_err());
        let e = FreeKey::parse_all(&["adhesion.n", "adhesion.v0", "adhesion.n=0.1:2"]).unwrap_err();
        assert_eq!(
            crate::words::render(&e, &crate::words::TestFlags),
            "--free adhesion.n=0.1:2: adhesion.n is already free by --free adhesion.n: give each \
             key once"
        );
        assert_eq!(
            FreeKey::parse_all(&["adhesion.n", "adhesion.v0"])
                .unwrap()
                .len(),
            2
        );
    }

    /// Numerical settings are refused with the list of the keys that can be freed (issue 36,
    /// item 4: `--free solver.rtol` was fitted to 1e-8 ± 7e-4); physical keys are accepted.
    #[test]
    fn only_physical_keys_can_be_freed() {
        for bad in [
            "solver.rtol",
            "solver.envelope_tol",
            "solver.max_wall_s",
            "output.sample_rate",
            "stage[0].max_duration",
            "stage[1].duration",
            "version",
        ] {
            let e = FreeKey::parse(bad).unwrap_err();
            assert!(
                e.contains("not a constant of the rig")
                    && e.contains("Keys that can be freed: material.K, material.R")
                    && e.contains("stage[N].speed"),
                "{bad}: {e}"
            );
        }
        let list = fittable_keys();
        for good in [
            "adhesion.v0",
            "adhesion.n",
            "damping.c",
            "material.K",
            "spring.stiffness",
            "base.phase",
            "initial.gap",
            "stage[N].speed",
            "stage[N].preload",
        ] {
            assert!(list.iter().any(|k| k == good), "{good} not in {list:?}");
            let key = good.replace("[N]", "[0]");
            let f = FreeKey::parse(&key);
            assert!(f.is_ok(), "{key}: {f:?}");
        }
        assert!(!list
            .iter()
            .any(|k| k.starts_with("solver.") || k.contains("duration")));
    }

    /// Bounds are held to the key's range (issue 35, item 12: -1e308:1e308 overflowed the
    /// fit's coordinate and was refused as `adhesion.n=nan`, a value nobody gave); a bound at
    /// an open edge of the range (0 for a key > 0, 2 pi for the phase) is a bound.
    #[test]
    fn bounds_are_held_to_the_keys_range() {
        let e = FreeKey::parse("adhesion.n=-1e308:1e308").unwrap_err();
        let e = crate::words::render(&e, &crate::words::TestFlags);
        assert_eq!(
            e,
            "--free adhesion.n=-1e308:1e308: LO '-1e308' lies outside the range of adhesion.n: \
             must be a finite number > 0 (dimensionless)"
        );
        assert!(!e.contains("nan"));
        let e = FreeKey::parse("adhesion.n=0.1:1e308").unwrap_err();
        assert!(
            e.contains("HI '1e308' lies outside the range of adhesion.n: must not exceed 1e1"),
            "{e}"
        );
        let e = FreeKey::parse("adhesion.n=0:1").unwrap_err();
        assert!(e.contains("LO '0'") && e.contains("at least 1e-3"), "{e}");
        let e = FreeKey::parse("base.frequency=-5:400").unwrap_err();
        assert!(e.contains("LO '-5'") && e.contains("> 0 (Hz)"), "{e}");
        for ok in [
            "adhesion.v_sat=0:100",
            "base.phase=0:6.283185307179586",
            "damping.c=0:1e9",
            "adhesion.n=1e-3:10",
            "material.K=1:1e13",
        ] {
            assert!(FreeKey::parse(ok).is_ok(), "{ok}");
        }
        let e = FreeKey::parse("base.phase=0:7").unwrap_err();
        assert!(e.contains("HI '7'") && e.contains("[0, 2 pi)"), "{e}");
        // A long bound is cut in the message.
        let long = format!("adhesion.n={}:1", "9".repeat(10_000));
        let e = FreeKey::parse(&long).unwrap_err();
        assert!(e.len() < 400, "{e}");
    }

    /// A span of nearly the largest double stays finite in the transform (that such bounds far
    /// from the start are refused before anything runs: driver.rs's
    /// `a_start_too_far_inside_huge_bounds_is_refused`).
    #[test]
    fn wide_bounds_stay_finite_or_are_refused() {
        // (Only numerical settings such as solver.max_wall_s reach 1.7e308; physical keys have
        // an upper bound, and a start of 1e-300 against 1e9 still overflows.)
        let f = FreeKey::parse("damping.c=0:1e9").unwrap();
        let t = Transform::new(&f, 1.0);
        for u in [
            -3.0,
            -std::f64::consts::FRAC_PI_2,
            0.0,
            1.0,
            std::f64::consts::FRAC_PI_2,
            40.0,
        ] {
            assert!(t.y_of_u(u).is_finite() && t.dy_du(u).is_finite(), "{u}");
        }
    }

    #[test]
    fn transforms_invert_and_stay_inside_bounds() {
        let f = FreeKey::parse("adhesion.v_sat=0.01:100").unwrap();
        let t = Transform::new(&f, 0.5);
        for u in [-10.0, -1.0, 0.0, 0.3, 1.5, 7.0] {
            let y = t.y_of_u(u);
            assert!(t.inside(y), "{u} {y}");
            let x = t.x(y);
            assert!((0.01 * (1.0 - 1e-12)..=100.0 * (1.0 + 1e-12)).contains(&x));
        }
        let y0 = t.y(0.5);
        assert!((t.y_of_u(t.u_of_y(y0)) - y0).abs() < 1e-12);
        // dy/du against a central difference.
        for (f, x0) in [
            ("adhesion.n=0.1:", 0.5),
            ("adhesion.n=:2", 0.5),
            ("adhesion.n", 0.5),
        ] {
            let t = Transform::new(&FreeKey::parse(f).unwrap(), x0);
            let u = t.u_of_y(t.y(x0)) + 0.1;
            let h = 1e-6;
            let d = (t.y_of_u(u + h) - t.y_of_u(u - h)) / (2.0 * h);
            assert!((d - t.dy_du(u)).abs() < 1e-8, "{f}");
            assert!((t.y_of_u(t.u_of_y(t.y(x0))) - t.y(x0)).abs() < 1e-12, "{f}");
        }
    }
}

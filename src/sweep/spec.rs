//! `--set KEY=SPEC`: the values one key of a sweep takes, and the unit of each key.
//!
//! A SPEC is
//! - a list `10um,30um,60um` (any key; each item is written as after `--set KEY=`, units
//!   welcome): each item goes to the scenario exactly as typed, so the point equals
//!   `djkr run FILE --set KEY=ITEM`;
//! - a linear range `START:STOP:N` or a log range `START:STOP:Nlog` (numeric keys only; START
//!   and STOP with the key's units, N ≥ 2 values, both ends included, a log range needs
//!   0 < START, STOP): each value goes to the scenario as the SI number, so the point equals
//!   `djkr run FILE --set KEY=X` with X as the sweep's table prints it (shortest round-trip form).
//!
//! Every key of a scenario file is settable ([`crate::scenario::overrides`]); [`key_kind`] says
//! whether its values are numbers (with the key's SI unit, the unit of its column in the sweep's
//! tables) or text (`adhesion.law`, `solver.method`, `stage[2].vibration`, ...).

use std::fmt;

use crate::output::table::format_f64;
use crate::scenario::keys::Kind;
use crate::scenario::overrides::{SetKey, SetValue};
use djkr_core::text::excerpt;
use djkr_core::units::{parse_quantity, Dimension};

/// Most values one SPEC may give (a range's N): beyond it a sweep is a typo, not a study.
pub const MAX_SPEC_VALUES: usize = 1_000_000;

/// A SPEC that cannot be read, or a key that no file takes: `--set KEY=SPEC: what is wrong`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SpecError {
    /// `KEY=SPEC` as given.
    pub set: String,
    /// What is wrong, and what is allowed.
    pub message: String,
}

impl SpecError {
    /// The message in the words of a front end.
    pub fn in_words(&self, w: &dyn crate::error::Words) -> String {
        crate::error::render(
            &format!(
                "{}: {}",
                w.axis(&djkr_core::text::excerpt(&self.set)),
                self.message
            ),
            w,
        )
    }
}

impl std::fmt::Display for SpecError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.in_words(&crate::error::Plain))
    }
}

impl std::error::Error for SpecError {}

/// What a key's values are.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum KeyKind {
    /// A number: its dimension (`None`: bare numbers only) and its SI unit as the tables write
    /// it (`1` for dimensionless).
    Number {
        /// The units the key accepts.
        dim: Option<Dimension>,
        /// The SI unit of the key's column.
        unit: &'static str,
    },
    /// Text, booleans and names (`gent-schultz`, `true`, `pull-off`).
    Text,
}

/// The kind of the values of `key`, from the table of keys ([`crate::scenario::keys::KEYS`]:
/// the units as the scenario parser reads them; dimensionless numbers have unit `1` here).
pub fn key_kind(key: &SetKey) -> Option<KeyKind> {
    let info = crate::scenario::keys::find(key.section().unwrap_or(""), key.name())?;
    let unit = if info.unit.is_empty() { "1" } else { info.unit };
    Some(match info.kind {
        Kind::Number(dim) => KeyKind::Number { dim, unit },
        Kind::Whole => KeyKind::Number { dim: None, unit },
        Kind::Bool | Kind::Choice(_) | Kind::Text | Kind::Windows => KeyKind::Text,
    })
}

/// One value of a key in a sweep: what the scenario is given, and what its column holds.
#[derive(Debug, Clone, PartialEq)]
pub struct SpecValue {
    /// The override's value: the list item as typed, or a range's SI number.
    pub set: SetValue,
    /// The value as the tables hold it.
    pub cell: KeyCell,
}

/// A key's value in a table row: the SI number of a numeric key, the text of a text key.
#[derive(Debug, Clone, PartialEq)]
pub enum KeyCell {
    /// SI value.
    Num(f64),
    /// Text as given.
    Text(String),
}

impl KeyCell {
    /// The number, if numeric.
    pub fn num(&self) -> Option<f64> {
        match self {
            KeyCell::Num(x) => Some(*x),
            KeyCell::Text(_) => None,
        }
    }
}

impl fmt::Display for KeyCell {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            KeyCell::Num(x) => f.write_str(&format_f64(*x)),
            KeyCell::Text(t) => f.write_str(t),
        }
    }
}

/// Whether a SPEC was a list or a range (the plots put a log range on a log axis).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SpecForm {
    /// `A,B,C` (or one value).
    List,
    /// `START:STOP:N`.
    Linear,
    /// `START:STOP:Nlog`.
    Log,
}

/// Parse SPEC for `key` (`set` is `KEY=SPEC` as given, for messages).
pub fn parse_spec(
    key: &SetKey,
    spec: &str,
    set: &str,
) -> Result<(SpecForm, Vec<SpecValue>), SpecError> {
    let err = |message: String| SpecError {
        set: set.to_string(),
        message,
    };
    let kind = key_kind(key).ok_or_else(|| err(format!("{key} has no known unit")))?;
    let spec = spec.trim();
    if spec.is_empty() {
        return Err(err(
            "empty SPEC: give a list A,B,C, a range START:STOP:N or START:STOP:Nlog".into(),
        ));
    }
    match kind {
        KeyKind::Number { dim, .. } if spec.contains(':') => {
            if spec.contains(',') {
                return Err(err(
                    "a SPEC is either a list A,B,C or one range START:STOP:N, not both".into(),
                ));
            }
            range(key, dim, spec).map_err(err)
        }
        _ => {
            let mut values = Vec::new();
            for (i, item) in spec.split(',').enumerate() {
                let item = item.trim();
                if item.is_empty() {
                    return Err(err(format!(
                        "value {} of the list is empty: write A,B,C (no empty items)",
                        i + 1
                    )));
                }
                let cell = match kind {
                    KeyKind::Number { dim, .. } => {
                        let bare = item.trim_matches('"');
                        let x = parse_quantity(
                            &key.to_string(),
                            bare,
                            dim.unwrap_or(Dimension::Dimensionless),
                        )
                        .map_err(|e| {
                            err(format!(
                                "value {} '{}' of the list: {}",
                                i + 1,
                                excerpt(item),
                                e.allowed
                            ))
                        })?;
                        KeyCell::Num(x)
                    }
                    KeyKind::Text => KeyCell::Text(item.trim_matches('"').to_string()),
                };
                values.push(SpecValue {
                    set: SetValue::Text(item.to_string()),
                    cell,
                });
            }
            if values.len() > MAX_SPEC_VALUES {
                return Err(err(format!(
                    "{} values: at most {MAX_SPEC_VALUES} per key",
                    values.len()
                )));
            }
            Ok((SpecForm::List, values))
        }
    }
}

/// `START:STOP:N` or `START:STOP:Nlog`.
fn range(
    key: &SetKey,
    dim: Option<Dimension>,
    spec: &str,
) -> Result<(SpecForm, Vec<SpecValue>), String> {
    let parts: Vec<&str> = spec.split(':').map(str::trim).collect();
    let [start, stop, count] = parts[..] else {
        return Err(format!(
            "a range is START:STOP:N (linear) or START:STOP:Nlog (log), with {} parts here",
            parts.len()
        ));
    };
    let dim = dim.unwrap_or(Dimension::Dimensionless);
    let name = key.to_string();
    let end = |which: &str, t: &str| {
        parse_quantity(&name, t, dim)
            .map_err(|e| format!("range {which} '{}': {}", excerpt(t), e.allowed))
    };
    let (lo, hi) = (end("START", start)?, end("STOP", stop)?);
    let (form, digits) = match count.strip_suffix("log") {
        Some(d) => (SpecForm::Log, d.trim()),
        None => (SpecForm::Linear, count),
    };
    let n = digits
        .parse::<usize>()
        .ok()
        .filter(|n| (2..=MAX_SPEC_VALUES).contains(n) && digits.bytes().all(|b| b.is_ascii_digit()))
        .ok_or_else(|| {
            format!(
                "range count '{}': N must be a whole number from 2 to {MAX_SPEC_VALUES} \
                 (e.g. 10um:60um:6, or 1um:100um:5log); for one value write it alone",
                excerpt(count)
            )
        })?;
    if form == SpecForm::Log && !(lo > 0.0 && hi > 0.0) {
        return Err(format!(
            "a log range needs START > 0 and STOP > 0 (got {} and {})",
            format_f64(lo),
            format_f64(hi)
        ));
    }
    let last = (n - 1) as f64;
    let values = (0..n)
        .map(|i| {
            let frac = i as f64 / last;
            let x = if i == 0 {
                lo
            } else if i == n - 1 {
                hi
            } else if form == SpecForm::Log {
                to_15_digits(lo * (hi / lo).powf(frac))
            } else {
                to_15_digits(lo + (hi - lo) * frac)
            };
            SpecValue {
                set: SetValue::Float(x),
                cell: KeyCell::Num(x),
            }
        })
        .collect();
    Ok((form, values))
}

/// `x` rounded to 15 significant digits: an interior point of a range is the decimal the grid
/// means (20um of 10um:50um:5 is `2e-5`, not the `1.9999999999999998e-5` that the arithmetic
/// gives), so tables print it as such and it equals the value typed alone. The change is below
/// the arithmetic's own rounding (5e-16 relative).
fn to_15_digits(x: f64) -> f64 {
    format!("{x:.14e}").parse().unwrap_or(x)
}

#[cfg(test)]
#[allow(clippy::float_cmp)] // values written exactly, compared exactly
mod tests {
    use super::*;
    use crate::scenario::keys::{SECTIONS, STAGE_SECTION};

    fn key(t: &str) -> SetKey {
        SetKey::parse(t).unwrap()
    }

    trait Bits {
        fn map_bits(&self) -> Vec<u64>;
    }
    impl Bits for [f64] {
        fn map_bits(&self) -> Vec<u64> {
            self.iter().map(|x| x.to_bits()).collect()
        }
    }

    fn nums(t: &str, spec: &str) -> Vec<f64> {
        let (_, v) = parse_spec(&key(t), spec, &format!("{t}={spec}")).unwrap();
        v.iter().map(|v| v.cell.num().unwrap()).collect()
    }

    fn err(t: &str, spec: &str) -> String {
        parse_spec(&key(t), spec, &format!("{t}={spec}"))
            .unwrap_err()
            .in_words(&crate::error::TestFlags)
    }

    #[test]
    fn every_settable_key_has_a_kind() {
        assert!(key_kind(&key("version")).is_some());
        for section in SECTIONS {
            for k in crate::scenario::keys::section_keys(section).unwrap_or_default() {
                let t = if *section == STAGE_SECTION {
                    format!("{section}[0].{k}")
                } else {
                    format!("{section}.{k}")
                };
                assert!(key_kind(&key(&t)).is_some(), "{t}");
            }
        }
    }

    #[test]
    fn lists_keep_the_text_and_give_si_cells() {
        let (form, v) = parse_spec(
            &key("base.amplitude"),
            "10um, 3e-5,60um",
            "base.amplitude=10um, 3e-5,60um",
        )
        .unwrap();
        assert_eq!(form, SpecForm::List);
        assert_eq!(v[0].set, SetValue::Text("10um".into()));
        assert_eq!(v[1].set, SetValue::Text("3e-5".into()));
        assert_eq!(
            v.iter().map(|v| v.cell.num().unwrap()).collect::<Vec<_>>(),
            vec![10e-6, 3e-5, 60e-6]
        );
        let (_, t) = parse_spec(
            &key("solver.method"),
            "dp8,implicit",
            "solver.method=dp8,implicit",
        )
        .unwrap();
        assert_eq!(t[1].cell, KeyCell::Text("implicit".into()));
        assert_eq!(nums("stage[3].speed", "1mm/s"), vec![1e-3]);
    }

    #[test]
    fn ranges_include_both_ends() {
        assert_eq!(
            nums("base.frequency", "200:400:3"),
            vec![200.0, 300.0, 400.0]
        );
        // Every point is the decimal it means, bit for bit (issue 25: 10 and 20 µm printed as
        // 9.999999999999999e-6 and 1.9999999999999998e-5).
        let v = nums("base.amplitude", "10um:50um:5");
        let want = [10e-6, 20e-6, 30e-6, 40e-6, 50e-6];
        assert_eq!(v.map_bits(), want.map_bits());
        let v = nums("stage[3].speed", "1um/s:1mm/s:4log");
        assert_eq!(v.map_bits(), [1e-6, 1e-5, 1e-4, 1e-3].map_bits());
        assert_eq!(
            nums("adhesion.n", "0.1:0.7:7").map_bits(),
            [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7].map_bits()
        );
        assert_eq!(nums("adhesion.n", "0.2:0.8:4").len(), 4);
    }

    #[test]
    fn bad_specs_are_named() {
        for (k, spec, want) in [
            ("base.amplitude", "", "empty SPEC"),
            (
                "base.amplitude",
                "10um,,30um",
                "value 2 of the list is empty",
            ),
            (
                "base.amplitude",
                "10um,3Hz",
                "value 2 '3Hz' of the list: unknown unit 'Hz'",
            ),
            ("base.amplitude", "10um:30um", "with 2 parts here"),
            (
                "base.amplitude",
                "10um:30um:1",
                "N must be a whole number from 2",
            ),
            ("base.amplitude", "10um:30um:x", "range count 'x'"),
            ("base.amplitude", "10um:30um:2.5", "range count '2.5'"),
            (
                "base.amplitude",
                "0:30um:3log",
                "a log range needs START > 0",
            ),
            (
                "base.amplitude",
                "abc:30um:3",
                "range START 'abc': not a number",
            ),
            ("base.amplitude", "1um:2um:3,4um", "either a list"),
            ("base.frequency", "200:400:3Hz", "range count '3Hz'"),
        ] {
            let e = err(k, spec);
            assert!(e.starts_with(&format!("--set {k}={spec}: ")), "{e}");
            assert!(e.contains(want), "{k}={spec}: {e}");
        }
    }
}

//! Parsing of physical quantities typed by users: bare numbers are SI, or a number followed by a
//! unit (`51mm`, `9.33MPa`, `240mJ/m^2`, `0.0445mm/s`, `1.5kHz`). Each quantity kind accepts only
//! units of its own dimension, so `--radius 3Hz` is an error that names the allowed units.

use crate::error::ParamError;

/// The dimension of a quantity, which fixes the units it accepts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Dimension {
    /// Metres.
    Length,
    /// Pascals.
    Pressure,
    /// Joules per square metre (work of adhesion).
    EnergyPerArea,
    /// Metres per second.
    Speed,
    /// Hertz (cycles per second).
    Frequency,
    /// Seconds.
    Time,
    /// Kilograms.
    Mass,
    /// Newtons.
    Force,
    /// Newtons per metre.
    Stiffness,
    /// Metres per second squared (gravity).
    Acceleration,
    /// Newton seconds per metre.
    Damping,
    /// Radians (angles).
    Angle,
    /// Dimensionless.
    Dimensionless,
}

impl Dimension {
    /// The accepted unit spellings and their factor to SI.
    pub fn units(self) -> &'static [(&'static str, f64)] {
        match self {
            Dimension::Length => &[
                ("m", 1.0),
                ("cm", 1e-2),
                ("mm", 1e-3),
                ("um", 1e-6),
                ("µm", 1e-6),
                ("nm", 1e-9),
            ],
            Dimension::Pressure => &[("Pa", 1.0), ("kPa", 1e3), ("MPa", 1e6), ("GPa", 1e9)],
            Dimension::EnergyPerArea => &[
                ("J/m^2", 1.0),
                ("J/m2", 1.0),
                ("N/m", 1.0),
                ("mJ/m^2", 1e-3),
                ("mJ/m2", 1e-3),
                ("mN/m", 1e-3),
            ],
            Dimension::Speed => &[
                ("m/s", 1.0),
                ("mm/s", 1e-3),
                ("um/s", 1e-6),
                ("µm/s", 1e-6),
                ("nm/s", 1e-9),
            ],
            Dimension::Frequency => &[("Hz", 1.0), ("kHz", 1e3)],
            Dimension::Time => &[("s", 1.0), ("ms", 1e-3), ("us", 1e-6), ("µs", 1e-6)],
            Dimension::Mass => &[("kg", 1.0), ("g", 1e-3), ("mg", 1e-6)],
            Dimension::Force => &[("N", 1.0), ("mN", 1e-3), ("uN", 1e-6), ("µN", 1e-6)],
            Dimension::Stiffness => &[("N/m", 1.0), ("N/mm", 1e3), ("kN/m", 1e3)],
            Dimension::Acceleration => &[("m/s^2", 1.0), ("m/s2", 1.0), ("mm/s^2", 1e-3)],
            Dimension::Damping => &[("Ns/m", 1.0), ("N*s/m", 1.0), ("kg/s", 1.0)],
            Dimension::Angle => &[("rad", 1.0), ("deg", std::f64::consts::PI / 180.0)],
            Dimension::Dimensionless => &[],
        }
    }

    /// The SI unit symbol.
    pub fn si(self) -> &'static str {
        match self {
            Dimension::Length => "m",
            Dimension::Pressure => "Pa",
            Dimension::EnergyPerArea => "J/m^2",
            Dimension::Speed => "m/s",
            Dimension::Frequency => "Hz",
            Dimension::Time => "s",
            Dimension::Mass => "kg",
            Dimension::Force => "N",
            Dimension::Stiffness => "N/m",
            Dimension::Acceleration => "m/s^2",
            Dimension::Damping => "N s/m",
            Dimension::Angle => "rad",
            Dimension::Dimensionless => "",
        }
    }
}

/// Parse `text` as a quantity of dimension `dim`, returning its SI value. `name` (a flag or key)
/// is used in the error. The value is not range-checked here.
pub fn parse_quantity(name: &str, text: &str, dim: Dimension) -> Result<f64, ParamError> {
    let t = text.trim();
    // Split at the first character that cannot belong to a float literal's tail.
    let split = t
        .char_indices()
        .find(|&(i, c)| {
            !(c.is_ascii_digit()
                || c == '.'
                || c == '+'
                || c == '-'
                || ((c == 'e' || c == 'E')
                    && t[i + 1..]
                        .chars()
                        .next()
                        .is_some_and(|d| d.is_ascii_digit() || d == '-' || d == '+')))
        })
        .map(|(i, _)| i)
        .unwrap_or(t.len());
    let (num, unit) = t.split_at(split);
    // The micro prefix has two spellings in Unicode: the micro sign U+00B5 (what the tables
    // list) and the Greek small letter mu U+03BC (what a Greek keyboard or a copy from a paper
    // gives). Both are accepted.
    let unit = unit.trim().replace('\u{3bc}', "\u{b5}");
    let unit = unit.as_str();
    let allowed_units = || {
        let list: Vec<&str> = dim.units().iter().map(|(u, _)| *u).collect();
        if list.is_empty() {
            "a plain number (dimensionless)".to_string()
        } else {
            format!(
                "a number in SI ({}) or with one of the units {}",
                dim.si(),
                list.join(", ")
            )
        }
    };
    let value: f64 = num.parse().map_err(|_| {
        ParamError::new(
            name,
            text,
            format!("not a number: expected {}", allowed_units()),
        )
    })?;
    let si = if unit.is_empty() {
        value
    } else {
        match dim.units().iter().find(|(u, _)| *u == unit) {
            Some((_, f)) => scale_decimal(num, value, *f),
            None => {
                return Err(ParamError::new(
                    name,
                    text,
                    format!(
                        "unknown unit '{}': expected {}",
                        crate::text::excerpt(unit),
                        allowed_units()
                    ),
                ))
            }
        }
    };
    // After the unit: 1e310nm is 1e301 m.
    if !si.is_finite() {
        return Err(ParamError::new(name, text, "must be finite"));
    }
    Ok(si)
}

/// The exponent k when `factor` is the double nearest 10^k (|k| ≤ 30), else `None`.
fn power_of_ten(factor: f64) -> Option<i32> {
    let k = factor.log10().round();
    if !(-30.0..=30.0).contains(&k) {
        return None;
    }
    let k = k as i32;
    let exact: f64 = format!("1e{k}").parse().ok()?;
    #[allow(clippy::float_cmp)] // the same decimal parsed twice is the same double
    let is = exact == factor;
    is.then_some(k)
}

/// The SI value of the decimal `num` (its parsed value `value`) times a unit's `factor`.
///
/// A power-of-ten factor shifts the decimal's exponent and parses the result, so the value is the
/// double nearest the decimal the user spelled: `5um` is bit for bit `5e-6` (5 × 1e-6 in floating
/// point is 4.9999999999999996e-6, one ulp off, which on a chaotic rig moves a pull-off by
/// percent). Any other factor (`deg`) multiplies once.
fn scale_decimal(num: &str, value: f64, factor: f64) -> f64 {
    let Some(k) = power_of_ten(factor) else {
        return value * factor;
    };
    let (mantissa, exp) = match num.find(['e', 'E']) {
        Some(i) => (&num[..i], num[i + 1..].parse::<i64>().ok()),
        None => (num, Some(0)),
    };
    match exp.and_then(|e| e.checked_add(i64::from(k))) {
        Some(e) => format!("{mantissa}e{e}").parse().unwrap_or(value * factor),
        // An exponent beyond i64: the value is 0 or infinite either way.
        None => value * factor,
    }
}

#[cfg(test)]
#[allow(clippy::float_cmp)] // unit factors of 1 and exact decimal inputs
mod tests {
    use super::*;

    #[test]
    fn parses_si_and_units() {
        assert_eq!(
            parse_quantity("r", "0.051", Dimension::Length).unwrap(),
            0.051
        );
        assert!((parse_quantity("r", "51mm", Dimension::Length).unwrap() - 0.051).abs() < 1e-15);
        assert!(
            (parse_quantity("K", "9.33MPa", Dimension::Pressure).unwrap() - 9.33e6).abs() < 1e-6
        );
        assert!(
            (parse_quantity("w", "240 mJ/m^2", Dimension::EnergyPerArea).unwrap() - 0.24).abs()
                < 1e-15
        );
        assert!(
            (parse_quantity("v", "0.0445mm/s", Dimension::Speed).unwrap() - 4.45e-5).abs() < 1e-18
        );
        assert_eq!(
            parse_quantity("f", "1.5kHz", Dimension::Frequency).unwrap(),
            1500.0
        );
        assert_eq!(
            parse_quantity("x", "1e-3", Dimension::Length).unwrap(),
            1e-3
        );
        assert_eq!(
            parse_quantity("x", "2.5e-1mm", Dimension::Length).unwrap(),
            2.5e-4
        );
    }

    #[test]
    fn power_of_ten_units_give_the_decimal_they_spell_bit_for_bit() {
        // Issue 25: each equals its decimal literal exactly (5 × 1e-6 would be one ulp low).
        let cases: [(&str, Dimension, f64); 10] = [
            ("5um", Dimension::Length, 5e-6),
            ("20um", Dimension::Length, 20e-6),
            ("10 µm", Dimension::Length, 10e-6),
            ("0.0445mm/s", Dimension::Speed, 0.0445e-3),
            ("51mm", Dimension::Length, 51e-3),
            ("240mJ/m^2", Dimension::EnergyPerArea, 240e-3),
            ("1.5kHz", Dimension::Frequency, 1.5e3),
            ("2.5e-1mm", Dimension::Length, 2.5e-4),
            ("-3E+2mN", Dimension::Force, -3e-1),
            ("9.33MPa", Dimension::Pressure, 9.33e6),
        ];
        for (text, dim, want) in cases {
            let got = parse_quantity("x", text, dim).unwrap();
            assert_eq!(
                got.to_bits(),
                want.to_bits(),
                "{text}: {got:e} is not {want:e}"
            );
        }
        assert_ne!(
            (5.0 * 1e-6f64).to_bits(),
            5e-6f64.to_bits(),
            "the test needs a case that multiplication gets wrong"
        );
        // A factor that is not a power of ten multiplies once.
        let deg = parse_quantity("phase", "90deg", Dimension::Angle).unwrap();
        assert_eq!(deg, 90.0 * std::f64::consts::PI / 180.0);
        // Exponents at the edges stay finite where the value is, and overflow is refused.
        assert_eq!(
            parse_quantity("x", "1e310nm", Dimension::Length).unwrap(),
            1e301
        );
        assert!(parse_quantity("x", "1e400mm", Dimension::Length).is_err());
        assert_eq!(
            parse_quantity("x", "1e-99999999999999999999mm", Dimension::Length).unwrap(),
            0.0
        );
    }

    #[test]
    fn rejects_unknown_units_and_garbage() {
        let e = parse_quantity("radius", "3Hz", Dimension::Length).unwrap_err();
        assert!(e.to_string().contains("radius") && e.to_string().contains("unknown unit"));
        assert!(parse_quantity("n", "abc", Dimension::Dimensionless).is_err());
        assert!(parse_quantity("n", "1mm", Dimension::Dimensionless).is_err());
        assert!(parse_quantity("n", "inf", Dimension::Dimensionless).is_err());
    }

    #[test]
    fn both_micro_signs_and_accelerations_are_accepted() {
        let micro = "\u{b5}";
        let mu = "\u{3bc}";
        for (dim, unit, si) in [
            (Dimension::Length, "m", 1e-6),
            (Dimension::Speed, "m/s", 1e-6),
            (Dimension::Time, "s", 1e-6),
            (Dimension::Force, "N", 1e-6),
        ] {
            for prefix in [micro, mu, "u"] {
                let text = format!("3{prefix}{unit}");
                let v = parse_quantity("x", &text, dim).unwrap();
                assert!((v - 3.0 * si).abs() <= 1e-15 * si, "{text}: {v}");
            }
            // Every unit listed with the micro sign is there in ASCII too.
            for (u, _) in dim.units() {
                if let Some(rest) = u.strip_prefix(micro) {
                    assert!(dim.units().iter().any(|(a, _)| *a == format!("u{rest}")));
                }
            }
        }
        assert_eq!(
            parse_quantity("g", "9.81m/s^2", Dimension::Acceleration).unwrap(),
            9.81
        );
        assert_eq!(
            parse_quantity("g", "9.81 m/s2", Dimension::Acceleration).unwrap(),
            9.81
        );
        assert!(parse_quantity("g", "9.81m/s", Dimension::Acceleration).is_err());
    }
}

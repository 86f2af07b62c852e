//! Typed setting of a numeric scenario value on a parsed [`Scenario`]: what sweeps (a range's
//! values, an ensemble's phases) and continuation (each parameter value) do thousands of times,
//! without writing the number into the file's TOML and validating the whole file again.
//!
//! [`Scenario::set`] writes the value with the key's accessor from the table of keys
//! ([`super::keys::KEYS`]) and then runs the checks the parser would run on the file with
//! `KEY = value` written in it: the key's own range, and the cross-field checks that involve it
//! (base speed, seed radius, a start resting on the weight, the JKR physics, what the simulator
//! would refuse), with the parser's messages, attributed to the value as a `--set` is
//! (`--set base.amplitude=-1e-6: must be a finite number >= 0 (m)`). The scenario then equals,
//! bit for bit, the one the parser gives for the edited file (a test compares them key by key).
//!
//! Where the parsed structure cannot say what the file held (a section left out and the one
//! derived from it, e.g. a start resting on the weight), the value is taken as the derived one
//! would be; a key whose section the scenario lacks is refused with the parser's message.

use super::checks;
use super::keys::{self, Refused};
use super::overrides::SetKey;
use super::parse::{self, show_float, ScenarioError};
use super::{ContactFormation, Holder, Initial, Scenario, StageKind};
use crate::error::{input, set_item, Source};

impl Scenario {
    /// Set the numeric key `key` to `v` (SI), validated as the file parser validates the file
    /// with the value written in it; the value is recorded as an override (`source_name` gains
    /// ` --set KEY=V`). On error the scenario is left partly changed: discard it.
    pub fn set(&mut self, key: SetKey, v: f64) -> Result<(), ScenarioError> {
        let file = self.file_name().to_string();
        let shown = show_float(v);
        let set = format!("{key}={shown}");
        let over = |message: String| ScenarioError::Override {
            source: Source::file(&file),
            set: set.clone(),
            key: key.to_string(),
            message,
        };
        let info = keys::find(key.section().unwrap_or(""), key.name())
            .ok_or_else(|| over("unknown key".into()))?;
        let Some(put) = info.put else {
            return Err(over(format!(
                "{key} is not a number: give it as text ({})",
                set_item(&format!("{key}=VALUE"))
            )));
        };
        let prefix = format!("{key}=");
        if let Some(first) = self.overrides.iter().find(|o| o.starts_with(&prefix)) {
            return Err(over(format!(
                "{key} is already set by {}; set each key once",
                set_item(first)
            )));
        }
        let index = key.index().unwrap_or(0);
        if key.index().is_some() && index >= self.stages.len() {
            let n = self.stages.len();
            let range = match n {
                1 => "only stage[0]".to_string(),
                _ => format!("stage[0] to stage[{}]", n - 1),
            };
            return Err(over(format!(
                "no such stage: {file} has {n} stage(s) ({range}; stages count from 0); {} does not add stages",
                input("set")
            )));
        }
        self.overrides.push(set.clone());
        self.source_name.push_str(&format!(" --set {set}"));
        let source = self.source();
        let attribute = |r: Refused| {
            if r.key == key.to_string() {
                over(r.message)
            } else {
                match r.value {
                    Some(value) => ScenarioError::Value {
                        source: source.clone(),
                        key: r.key,
                        value,
                        allowed: r.message,
                    },
                    None => ScenarioError::Key {
                        source: source.clone(),
                        key: r.key,
                        message: r.message,
                    },
                }
            }
        };
        if let Some(e) = own_error(self, key, index, v) {
            return Err(over(e));
        }
        put(self, index, v).map_err(attribute)?;
        self.cross_check(&shown, key).map_err(attribute)?;
        checks::setup_check(self).map_err(|e| ScenarioError::Setup {
            source: source.clone(),
            message: e.to_string(),
        })
    }

    /// Where the scenario came from: its file and the overrides applied to it.
    pub fn source(&self) -> Source {
        Source {
            file: self.file_name().to_string(),
            set: self.overrides.clone().into(),
        }
    }

    /// The scenario file's name: `source_name` without its overrides.
    fn file_name(&self) -> &str {
        let suffix: String = self
            .overrides
            .iter()
            .map(|o| format!(" --set {o}"))
            .collect();
        self.source_name
            .strip_suffix(&suffix)
            .unwrap_or(&self.source_name)
    }

    /// The checks across keys that the parser runs after reading each section, on the values
    /// now held (`shown`: the set value as written, for a message about the key set).
    fn cross_check(&self, shown: &str, key: SetKey) -> Result<(), Refused> {
        let value_err = |k: &str, v: String, message: String| Refused {
            key: k.to_string(),
            message,
            value: Some(if k == key.to_string() {
                shown.to_string()
            } else {
                v
            }),
        };
        let rig = &self.rig;
        if let Some(b) = rig.base {
            if let Some(e) = checks::base_speed_error(b.amplitude, b.frequency) {
                return Err(value_err("base.amplitude", show_float(b.amplitude), e));
            }
        }
        if let ContactFormation::Seed(r) = rig.formation {
            if let Some(e) = parse::seed_error(r, &rig.material) {
                return Err(value_err("contact.seed_radius", show_float(r), e));
            }
        }
        let weight = rig.sphere.mass * rig.sphere.gravity;
        let resting = !has_spring_force(rig.holder);
        if let (true, Initial::Preload(p)) = (resting, self.initial) {
            if let Some(e) = parse::resting_preload_error(p, weight) {
                return Err(value_err("initial.preload", p.to_string(), e));
            }
        }
        match parse::physics_error(
            &rig.material,
            rig.holder,
            rig.sphere,
            &self.initial,
            &self.stages,
            !resting,
        ) {
            None => Ok(()),
            Some((k, v, message)) => Err(Refused {
                key: k,
                message,
                value: v,
            }),
        }
    }
}

/// The key's own range (the parser's check of the value read), before it is written.
/// Why `v` is outside the range of `key` on this scenario: [`range_error`], and a stage's speed
/// on a hold.
fn own_error(s: &Scenario, key: SetKey, index: usize, v: f64) -> Option<String> {
    match (key.section().unwrap_or(""), key.name()) {
        ("stage", "speed") if s.stages[index].kind == StageKind::Hold => (v != 0.0).then(|| {
            "a hold keeps the spring end still: leave speed out (or set it to 0)".to_string()
        }),
        _ => range_error(key, v),
    }
}

/// Why `v` (SI) lies outside the range of the numeric key `key`, or `None`: the checks of a
/// value alone that the parser runs (finite, its sign, not subnormal, the bounds of
/// [`checks::UPPER_BOUNDS`] and [`checks::LOWER_BOUNDS`], a frequency's, phase's or tolerance's
/// interval), worded as the parser words them (`must be a finite number > 0 (dimensionless)`).
/// What depends on the rest of the scenario (a speed on a hold stage, the physics across keys)
/// is not checked here; nor are whole-number keys, which their writer checks. `djkr fit` holds
/// the bounds of `--free` to this.
pub fn range_error(key: SetKey, v: f64) -> Option<String> {
    let info = keys::find(key.section().unwrap_or(""), key.name())?;
    let unit = if info.unit.is_empty() {
        "dimensionless"
    } else {
        info.unit
    };
    let k = key.to_string();
    match (key.section().unwrap_or(""), key.name()) {
        ("base", "frequency") => {
            parse::positive_error(&k, v, unit).or_else(|| parse::frequency_error(v))
        }
        ("base", "phase") => parse::phase_error(v),
        ("solver", "rtol") => parse::rtol_error(v),
        ("solver", "atol") => parse::atol_error(v),
        ("solver", "envelope_tol") => parse::envelope_tol_error(v),
        ("solver", "max_steps" | "max_events" | "max_memory") => None, // whole numbers: `put`
        ("output", "sample_rate") => {
            parse::non_negative_error(&k, v, "samples per second; 0 = every step")
        }
        _ => {
            if info.allowed.starts_with(">= 0") {
                parse::non_negative_error(&k, v, unit)
            } else {
                parse::positive_error(&k, v, unit)
            }
        }
    }
}

fn has_spring_force(h: Holder) -> bool {
    match h {
        Holder::None => false,
        Holder::Spring { stiffness } => stiffness > 0.0,
        Holder::Rigid => true,
    }
}

#[cfg(test)]
#[allow(clippy::float_cmp)] // values written exactly, compared exactly
mod tests {
    use super::super::parse::ScenarioSource;
    use super::*;

    const FILE: &str = r#"
version = 1
[material]
K = 9.33e6
R = 0.051
w0 = 0.240
[adhesion]
law = "gent-schultz"
v0 = 4.45e-5
n = 0.531
[sphere]
mass = 3e-3
[spring]
stiffness = 200
[damping]
c = 0.5
[base]
amplitude = 1e-5
frequency = 300
[initial]
preload = 0.02
[[stage]]
kind = "approach"
speed = 1e-4
preload = 0.05
max_duration = 10
[[stage]]
kind = "unload"
speed = 5e-6
until = "pull-off"
vibration = true
[solver]
rtol = 1e-9
[output]
sample_rate = 1000
"#;

    fn key(t: &str) -> SetKey {
        SetKey::parse(t).unwrap()
    }

    /// Every numeric key set to a value typed, and to values out of range: the scenario and the
    /// error message are those of the file with the value written in it (`--set` through the
    /// parser).
    #[test]
    fn typed_setting_equals_the_parser_on_the_edited_file() {
        let src = ScenarioSource::parse(FILE, "x.toml", None).unwrap();
        let base = src.scenario(&[]).unwrap();
        let cases: &[(&str, &[f64])] = &[
            ("material.K", &[1e7, -1.0, 0.5, 1e14, f64::NAN]),
            ("material.R", &[0.04, 0.0, 20.0, 1e-9]),
            ("material.w0", &[0.3, 0.0, 1e-12, 2e4]),
            ("adhesion.v0", &[1e-5, 0.0, 1e4]),
            ("adhesion.n", &[0.7, 0.0, 20.0]),
            ("adhesion.v_sat", &[1e-3]),
            ("sphere.mass", &[1e-3, 0.0, -1.0, 1e5, 1e3]),
            ("sphere.gravity", &[9.81, 0.0, 1e5]),
            ("spring.stiffness", &[300.0, 0.0, 1e13]),
            ("damping.c", &[0.1, 0.0, -0.1]),
            ("base.amplitude", &[2e-5, 0.0, -1e-6, 2.0, 0.5]),
            ("base.frequency", &[400.0, 0.0, 1e7, 1e-7]),
            ("base.phase", &[1.0, 7.0, -0.1]),
            ("contact.seed_radius", &[1e-6]),
            ("initial.preload", &[0.03, 0.0, 1e3]),
            ("initial.gap", &[1e-3]),
            ("stage[0].speed", &[2e-4, 0.0, 200.0]),
            ("stage[1].speed", &[1e-5]),
            ("stage[1].duration", &[2.0, 0.0]),
            ("stage[0].duration", &[2.0]),
            ("stage[0].preload", &[0.04, 1e3]),
            ("stage[1].preload", &[0.04]),
            ("stage[0].max_duration", &[20.0, 0.0]),
            ("stage[2].speed", &[1e-5]),
            ("solver.rtol", &[1e-8, 1.0]),
            ("solver.atol", &[1e-9, 2.0]),
            ("solver.max_steps", &[1e6, 0.5, 0.0]),
            ("solver.max_events", &[1e3]),
            ("solver.max_memory", &[1e8, 1e3]),
            ("solver.max_wall_s", &[10.0, 0.0]),
            ("solver.event_tol", &[1e-10, 1e-3]),
            ("solver.envelope_tol", &[1e-7, 1.0]),
            ("output.sample_rate", &[100.0, -1.0, 1e8]),
        ];
        let mut n = 0;
        for (k, values) in cases {
            for &v in *values {
                let via_file =
                    src.scenario(&[super::super::overrides::Override::new(k, v).unwrap()]);
                let mut typed = base.clone();
                let got = typed.set(key(k), v);
                match (via_file, got) {
                    (Ok(want), Ok(())) => {
                        assert_eq!(typed, want, "{k} = {v}");
                        n += 1;
                    }
                    (Err(want), Err(got)) => {
                        assert_eq!(got.to_string(), want.to_string(), "{k} = {v}");
                        n += 1;
                    }
                    (want, got) => panic!("{k} = {v}: the file gives {want:?}, typed {got:?}"),
                }
            }
        }
        assert!(n > 80, "{n}");
    }

    #[test]
    fn values_set_in_turn_are_recorded_as_overrides() {
        let src = ScenarioSource::parse(FILE, "x.toml", None).unwrap();
        let mut s = src.scenario(&[]).unwrap();
        s.set(key("base.frequency"), 350.0).unwrap();
        s.set(key("base.amplitude"), 2e-5).unwrap();
        let o = |t: &str| super::super::overrides::Override::parse(t).unwrap();
        let want = src
            .scenario(&[o("base.frequency=350.0"), o("base.amplitude=2e-5")])
            .unwrap();
        assert_eq!(s, want);
        assert_eq!(
            s.set(key("base.frequency"), 300.0).unwrap_err().in_words(&crate::error::TestFlags),
            "--set base.frequency=300.0: base.frequency is already set by --set base.frequency=350.0; set each key once"
        );
    }
}

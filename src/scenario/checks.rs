//! Checks beyond the ranges of single keys: what makes a scenario impossible to run (refused by
//! `djkr check` as by `djkr run`), and what makes a result leave the model's range (a warning
//! carried with the result).
//!
//! **Errors** (in the section walk of [`super::parse`], so every command refuses them):
//! - a value beyond its key's bounds ([`UPPER_BOUNDS`]: K ≤ 1e13 Pa, a stage speed ≤ 100 m/s,
//!   ...; [`LOWER_BOUNDS`]: w0 ≥ 1e-9 J/m², ...);
//! - the JKR jump-in radius (8πw0R²/3K)^(1/3) exceeds R: no contact of this material is small
//!   against the sphere, which JKR assumes (`R = 1e-9` with the paper's K and w0);
//! - a static load (the initial preload, the weight of a sphere resting without spring force, a
//!   stage's preload) whose JKR contact radius exceeds R;
//! - a weight m g beyond [`MAX_WEIGHT_OVER_ADHESION`] × (3/2)πRw0 when a spring carries it: the
//!   contact force is then the small difference of two huge forces, lost to rounding
//!   (`gravity = 1e20` gave a "pull-off" with the contact lost);
//! - a base frequency outside [[`MIN_FREQUENCY`], [`MAX_FREQUENCY`]] Hz: a period longer than
//!   any run (`frequency = 1e-300`), or shorter than the time resolution of a long run; a base
//!   whose peak speed 2πfX_b exceeds [`MAX_BASE_SPEED`].
//!
//! [`setup_check`] adds what the simulator refuses when it sets a run up (a massless sphere with
//! damping, an explicit method on a rate-independent law), so `check` refuses it too.
//!
//! **Warnings** ([`scenario_warnings`] before a run, [`result_warnings`] after it): a contact
//! radius beyond [`SMALL_CONTACT_LIMIT`] R, the rule `djkr pulloff` and `djkr cycle` use too
//! ([`small_contact_warning`]).

use djkr_core::adhesion::AdhesionLaw;
use djkr_core::dynamics::methods;
use djkr_core::dynamics::protocol::{initial_state, Initial, Until};
use djkr_core::dynamics::{model, RunResult, SimError};
use djkr_core::jkr;
use djkr_core::material::Material;

use super::{Holder, Scenario};

/// Largest contact radius, as a fraction of R, reported without a warning: JKR is a
/// small-contact theory (a ≪ R, half-space substrate).
pub const SMALL_CONTACT_LIMIT: f64 = 0.2;

/// Largest weight m g, in units of the static pull-off force (3/2)πRw0, that a spring may carry:
/// beyond it the contact force is lost to rounding in k(x_s − x_k) − m g.
pub const MAX_WEIGHT_OVER_ADHESION: f64 = 1e6;

/// Smallest base frequency (Hz): a period of 1e6 s, longer than any run.
pub const MIN_FREQUENCY: f64 = 1e-6;

/// Largest base frequency (Hz): a period of 1 µs is still 5e5 rounding steps of the time at the
/// default stage limit of 1e4 s.
pub const MAX_FREQUENCY: f64 = 1e6;

/// Upper bounds of scenario values, by dotted key (`stage[N]` as `stage`): the largest value the
/// model (a small, quasi-static JKR contact on a soft solid) and double precision carry. Far
/// beyond what any rig has, they keep absurd inputs (`K = 9.33e47`, a spring end moving at
/// 1e125 m/s) from reaching the simulator, where they produced no result in any budget.
pub const UPPER_BOUNDS: &[(&str, f64, &str)] = &[
    (
        "material.K",
        1e13,
        "stiffer than diamond; JKR is for soft solids",
    ),
    ("material.R", 10.0, "a sphere of more than 10 m"),
    ("material.w0", 1e4, "tougher than any adhesive interface"),
    ("adhesion.v0", 1e3, "faster than any crack in a soft solid"),
    (
        "adhesion.v_sat",
        1e3,
        "faster than any crack in a soft solid",
    ),
    (
        "adhesion.n",
        10.0,
        "Gent-Schultz exponents lie well below 10",
    ),
    ("sphere.mass", 1e4, "ten tonnes on an adhesive contact"),
    ("sphere.gravity", 1e4, "about 1000 g"),
    ("spring.stiffness", 1e12, "stiffer than any holder"),
    ("damping.c", 1e9, "beyond any damper"),
    ("base.amplitude", 1.0, "a shaker stroke of more than 1 m"),
    ("initial.gap", 1.0, "a start more than 1 m away"),
    (
        "stage.speed",
        100.0,
        "faster than elastic waves in a soft solid",
    ),
    (
        "output.sample_rate",
        1e7,
        "more than 1e7 samples per second of simulated time",
    ),
    (
        "solver.event_tol",
        MAX_EVENT_TOL,
        "coarser event location changes the answer (contacts lost that are not, \
         tests/sweep/tiny.toml's amplification 2.12 instead of 9.57 at 1e-3 s)",
    ),
];

/// Largest `solver.event_tol` (s). Measured on the bundled scenarios and the sweep tests: every
/// contact-loss count, and every pull-off but that of the chaotic light-protocol-300hz (13.3 to
/// 14.4 at any tolerance), is the same from 1e-12 s to 1e-5 s; from 3e-5 s spurious contact losses
/// appear (light-protocol-300hz: 6 instead of 1; gentle-unload-300hz: 3 instead of 1), from
/// 3e-4 s the pull-off moves by a factor of 4 (tiny: 2.29 instead of 9.57). A run with many
/// impacts (scenarios/impacts.toml, 151) loses digits earlier, hence the warning above
/// [`EVENT_TOL_WARN`].
pub const MAX_EVENT_TOL: f64 = 1e-6;

/// `solver.event_tol` (s) above which a scenario gets a warning: impacts.toml's mean-force
/// amplification moves by 7e-6 (relative) at 1e-8 s, 1.7e-4 at 1e-7 s and 4e-3 at 1e-6 s
/// against its value at the default 1e-12 s.
pub const EVENT_TOL_WARN: f64 = 1e-9;

/// Lower bounds of positive scenario values, by dotted key (0 stays allowed where a key may be
/// 0: `sphere.mass = 0` is the quasi-static balance): below them the relations of the
/// model underflow (`w0 = 2.4e-299` gives a jump-in radius of 1e-103 m, and the run never
/// ended).
pub const LOWER_BOUNDS: &[(&str, f64, &str)] = &[
    ("material.K", 1.0, "softer than any solid"),
    (
        "material.w0",
        1e-9,
        "below, the contact is Hertzian to double precision (use a tiny w0 no smaller)",
    ),
    ("adhesion.v0", 1e-15, "slower than any measurable crack"),
    (
        "adhesion.n",
        1e-3,
        "Gent-Schultz exponents lie well above 1e-3",
    ),
    (
        "sphere.mass",
        1e-20,
        "lighter than a 20 nm sphere: its time scale 2 pi sqrt(m/k) falls below the rounding of \
         the run's time, and the state overflows (0 = quasi-static force balance)",
    ),
];

/// A dotted key with a stage index dropped: `stage[3].speed` → `stage.speed` (borrowed when it
/// has none: the parser asks for every number it reads).
fn generic_key(key: &str) -> std::borrow::Cow<'_, str> {
    match key.strip_prefix("stage[") {
        Some(rest) => format!("stage{}", &rest[rest.find(']').map_or(0, |i| i + 1)..]).into(),
        None => key.into(),
    }
}

/// The bound of `table` at the generic key `key`, with why.
fn bound(table: &[(&str, f64, &'static str)], key: &str) -> Option<(f64, &'static str)> {
    table
        .iter()
        .find(|(k, _, _)| *k == key)
        .map(|&(_, b, why)| (b, why))
}

/// The upper bound of the value at dotted `key`, with why, if it has one.
pub fn upper_bound(key: &str) -> Option<(f64, &'static str)> {
    bound(UPPER_BOUNDS, &generic_key(key))
}

/// The lower bound of the positive value at dotted `key`, with why, if it has one.
pub fn lower_bound(key: &str) -> Option<(f64, &'static str)> {
    bound(LOWER_BOUNDS, &generic_key(key))
}

/// Why `v` (SI, finite) is outside the range of the scenario key `key` (`unit`: its SI unit, for
/// the message), or `None` within it: the bounds of [`UPPER_BOUNDS`] and [`LOWER_BOUNDS`], and
/// for `base.frequency` [[`MIN_FREQUENCY`], [`MAX_FREQUENCY`]]. The one range table, applied to
/// a scenario's values by the parser and to the commands' flags that set the same quantity
/// (`--modulus` is `material.K`, `--freq` is `base.frequency`, ...).
pub fn key_range_error(key: &str, v: f64, unit: &str) -> Option<String> {
    let key = generic_key(key);
    if key == "base.frequency" && !(MIN_FREQUENCY..=MAX_FREQUENCY).contains(&v) {
        return Some(format!(
            "must lie in [{MIN_FREQUENCY:e}, {MAX_FREQUENCY:e}] ({unit}): a period longer than 1e6 \
             s outlasts any run, one shorter than 1 us is below the time resolution of a long run"
        ));
    }
    if let Some((max, why)) = bound(UPPER_BOUNDS, &key) {
        if v > max {
            return Some(format!("must not exceed {max:e} ({unit}): {why}"));
        }
    }
    if let Some((min, why)) = bound(LOWER_BOUNDS, &key) {
        // 0 is the caller's to allow or refuse (allowed for the keys >= 0).
        if v != 0.0 && v < min {
            return Some(format!("must be at least {min:e} ({unit}): {why}"));
        }
    }
    None
}

/// Why a contact radius given to `djkr cycle` or `djkr pulloff` (`a`, m: a_A, or a_m + a_A) is
/// out of range on a sphere of radius `r`, or `None`: a contact wider than the sphere is not a
/// contact of it (JKR's own range, a << R, is warned about from [`SMALL_CONTACT_LIMIT`] R).
pub fn contact_radius_error(a: f64, r: f64) -> Option<String> {
    (a > r).then(|| {
        format!(
            "the contact radius would exceed the sphere's radius R = {r:e} m (a contact wider than \
             the sphere; JKR assumes a << R, warned above {SMALL_CONTACT_LIMIT} R)"
        )
    })
}

/// The warning for a contact radius `a` on a sphere of radius `r` beyond
/// [`SMALL_CONTACT_LIMIT`] R (`what` names the radius: "the contact reaches a_m + a_A"); `None`
/// within the range.
pub fn small_contact_warning(what: &str, a: f64, r: f64) -> Option<String> {
    (a > SMALL_CONTACT_LIMIT * r).then(|| {
        format!(
            "outside the model: {what} = {a:.4e} m = {:.3} R, but JKR assumes a contact small \
             against the sphere (a << R; warned above {SMALL_CONTACT_LIMIT} R)",
            a / r
        )
    })
}

/// Largest peak speed 2π f X_b of the base (m/s), the bound of the stage speeds: faster than
/// elastic waves in a soft solid.
pub const MAX_BASE_SPEED: f64 = 100.0;

/// Why a base motion is beyond the model: its peak speed exceeds [`MAX_BASE_SPEED`].
pub fn base_speed_error(amplitude: f64, frequency: f64) -> Option<String> {
    let v = 2.0 * std::f64::consts::PI * frequency * amplitude;
    (v > MAX_BASE_SPEED).then(|| {
        format!(
            "the base's peak speed 2 pi f X_b = {v:.4e} m/s exceeds {MAX_BASE_SPEED:e} m/s, faster \
             than elastic waves in a soft solid (the bound of stage speeds too)"
        )
    })
}

/// Why a material cannot be simulated by JKR at all: its jump-in radius at zero load exceeds R.
pub fn material_error(m: &Material) -> Option<String> {
    let a_jump = jkr::jump_in_radius(m, m.w0);
    (a_jump > m.r).then(|| {
        format!(
            "the JKR jump-in radius (8 pi w0 R^2/3K)^(1/3) = {a_jump:.4e} m exceeds R = {:e} m: \
             no contact of this sphere is small against its radius, as JKR assumes (R must \
             exceed 8 pi w0/3K = {:.4e} m)",
            m.r,
            8.0 * std::f64::consts::PI * m.w0 / (3.0 * m.k)
        )
    })
}

/// The static JKR contact radius under a compressive `load` (N) at w0 (`None` for a tensile
/// load beyond the pull-off force).
pub fn static_radius(m: &Material, load: f64) -> Option<f64> {
    jkr::equilibrium_radius_for_force(m, load, m.w0)
}

/// Why a static load cannot be carried within JKR: its contact radius exceeds R.
pub fn load_error(m: &Material, load: f64) -> Option<String> {
    let a = static_radius(m, load)?;
    (a > m.r).then(|| {
        format!(
            "the static JKR contact under this load has a = {a:.4e} m = {:.3} R > R: the sphere \
             cannot carry it as a small contact (a << R); JKR needs a load below K R^2 (about \
             {:.4e} N here)",
            a / m.r,
            m.k * m.r * m.r
        )
    })
}

/// Why a weight cannot be carried by a spring without losing the contact force to rounding.
pub fn weight_error(m: &Material, weight: f64) -> Option<String> {
    let limit = MAX_WEIGHT_OVER_ADHESION * jkr::load_controlled_pull_off_force(m, m.w0).abs();
    (weight > limit).then(|| {
        format!(
            "the weight m g = {weight:.4e} N exceeds {MAX_WEIGHT_OVER_ADHESION:e} x (3/2) pi R w0 \
             = {limit:.4e} N: the contact force would be the difference of two forces this large \
             and lost to rounding"
        )
    })
}

/// Warnings about a scenario before it runs: static contacts (initial state, stage preloads)
/// beyond the small-contact range.
pub fn scenario_warnings(s: &Scenario) -> Vec<String> {
    let m = &s.rig.material;
    let mut out = Vec::new();
    let mut loads = Vec::new();
    if let Initial::Preload(p) = s.initial {
        loads.push(("the initial static contact reaches a".to_string(), p));
    }
    for (i, st) in s.stages.iter().enumerate() {
        if let Until::Preload(p) = st.until {
            loads.push((
                format!("the preload of stage[{i}] gives a static contact a"),
                p,
            ));
        }
    }
    for (what, p) in loads {
        if let Some(w) = static_radius(m, p).and_then(|a| small_contact_warning(&what, a, m.r)) {
            out.push(w);
        }
    }
    if s.solver.event_tol > EVENT_TOL_WARN {
        out.push(format!(
            "solver.event_tol = {:e} s is above {EVENT_TOL_WARN:e} s: events are located \
             coarsely, and a run with many impacts loses digits (scenarios/impacts.toml: 2e-4 \
             relative at 1e-7 s, 4e-3 at 1e-6 s)",
            s.solver.event_tol
        ));
    }
    out
}

/// What the simulator refuses when it sets the run up (the model's resolution, the initial
/// state, a method that cannot integrate the law), without running it: what `djkr check` adds to
/// the file's validation.
pub fn setup_check(s: &Scenario) -> Result<(), SimError> {
    let plan = s.plan();
    let model = model::resolve(plan.rig, s.run_scales()).map_err(SimError::Setup)?;
    initial_state(plan.rig, &plan.initial, &model)?;
    let stepper = methods::build(plan.solver.method, plan.rig);
    if !stepper.capabilities().algebraic_radius && s.rig.law.is_rate_independent() {
        return Err(SimError::Setup(format!(
            "solver.method = \"{}\" ({}) cannot run a rate-independent adhesion law (the \
             contact radius is algebraic, G = w0, and has no explicit rate): use \"auto\" or \
             \"implicit\"",
            methods::method_name(plan.solver.method),
            stepper.name()
        )));
    }
    Ok(())
}

/// The largest contact radius a run reports: at the end of its steps, its events, and its
/// final state.
pub fn largest_contact_radius(r: &RunResult) -> f64 {
    r.events
        .iter()
        .map(|e| e.state.a)
        .chain([r.max_contact_radius, r.final_state.a])
        .filter(|a| a.is_finite())
        .fold(0.0, f64::max)
}

/// Whether the run recorded a pull-off force: a most tensile (cycle-averaged) force was seen. A
/// summary of exactly 0 N at t = 0 with no cycle recorded is the simulator's "nothing seen"
/// (a base period longer than the run, or a contact never loaded), not a result.
pub fn pull_off_recorded(r: &RunResult) -> bool {
    #[allow(clippy::float_cmp)] // the exact placeholder (0, 0)
    let placeholder = r.pull_off.force == 0.0 && r.pull_off.time == 0.0;
    !(placeholder && r.cycle_count == 0)
}

/// Warnings about a run's result: the scenario's own ([`scenario_warnings`]), a contact beyond
/// the small-contact range during the run, no pull-off force recorded.
pub fn result_warnings(s: &Scenario, r: &RunResult) -> Vec<String> {
    let mut out = scenario_warnings(s);
    let m = &s.rig.material;
    if out.is_empty() {
        if let Some(w) =
            small_contact_warning("the contact reaches a", largest_contact_radius(r), m.r)
        {
            out.push(w);
        }
    }
    if !pull_off_recorded(r) {
        out.push(
            "no pull-off force recorded: no base cycle completed (under vibration the pull-off \
             force is a cycle mean: is the base period longer than the stages?) and no contact \
             force was recorded instead; pull_off is left out"
                .into(),
        );
    } else if let Some(w) = no_tensile_pull_off(s, r) {
        out.push(w);
    }
    out
}

/// A run that detached although no cycle mean (without vibration: no contact force) was tensile
/// before: the sphere came off the substrate without an adhesive pull-off (it bounced off), and
/// `pull_off.force` is the least compressive mean, no pull-off force. Says so, with that mean
/// and when it came; `None` for a tensile pull-off or a run that did not detach.
pub fn no_tensile_pull_off(s: &Scenario, r: &RunResult) -> Option<String> {
    if !r.detached || r.pull_off.is_tensile() {
        return None;
    }
    let what = if s.rig.base.is_some() && r.cycle_count > 0 {
        "cycle mean"
    } else {
        "contact force"
    };
    Some(format!(
        "no tensile pull-off: no {what} was tensile before the sphere detached (the most \
         tensile, {} mN at t = {} s, is {}): it came off without an adhesive pull-off, so \
         pull_off.force is no pull-off force and pull_off.amplification is left out",
        djkr_core::text::format_sig(r.pull_off.force * 1e3, 4),
        djkr_core::text::format_sig(r.pull_off.time, 4),
        if r.pull_off.force > 0.0 {
            "compressive"
        } else {
            "zero"
        }
    ))
}

/// Whether a holder carries the sphere's weight with a spring (the case [`weight_error`] guards).
pub fn spring_carries_weight(h: Holder) -> bool {
    matches!(h, Holder::Spring { stiffness } if stiffness > 0.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn upper_bounds_by_key() {
        assert_eq!(upper_bound("stage[12].speed").map(|b| b.0), Some(100.0));
        assert_eq!(upper_bound("material.K").map(|b| b.0), Some(1e13));
        assert_eq!(upper_bound("stage[0].duration"), None);
        assert_eq!(upper_bound("version"), None);
        assert_eq!(lower_bound("material.w0").map(|b| b.0), Some(1e-9));
        for (k, _, _) in UPPER_BOUNDS.iter().chain(LOWER_BOUNDS) {
            let (section, key) = k.split_once('.').unwrap();
            let keys = crate::scenario::keys::section_keys(section).unwrap();
            assert!(keys.contains(&key), "{k}");
        }
    }
}

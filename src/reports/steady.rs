//! What `djkr validate`, `djkr resonance` and `djkr shortcut-map` report: the tables they write
//! ([`sweep_table`], [`map_table`]; CSV and HDF5 through [`crate::output::table`]) and the
//! summaries they print ([`ValidateReport`], [`ResonanceReport`], [`ShortcutMapReport`]), as
//! serde structs whose JSON keys are the commands' documented `--json` output. The text tables
//! are printed from the same structs.
//!
//! JSON has no NaN: a number that may be non-finite is an `Option` left out when missing, and the
//! printer refuses any that slips through.

use serde::Serialize;

use crate::output::{Column, Table};
use djkr_core::describing::HarmonicBalance;
use djkr_core::dynamics::CycleRecord;
use djkr_core::steady::crosscheck::{Comparison, ForceBalance, Prediction};
use djkr_core::steady::map::{MapCell, ShortcutMap};
use djkr_core::steady::sweep::{self, Linearisation, Sweep, SweepPoint};
use djkr_core::steady::{Steady, SteadyMethod};

/// The root attribute `missing` of `resonance.h5` and `shortcut-map.h5`.
pub const MISSING: &str =
    "NaN in a numeric dataset marks a value the method did not produce (see `error`)";

// ---------------------------------------------------------------------------------------------
// the columns of a periodic orbit, shared with `djkr continue`

/// A periodic orbit as the tables of `djkr resonance` and `djkr continue` print it: a steady
/// state ([`Steady`]), a point of a continued branch or of a fold curve. Each says how it
/// divides by the base amplitude (a steady state at X_b = 0 has |δ1|/X_b = 0, a branch point
/// NaN); phase and a_A follow from the cycle record alike.
pub trait Orbit {
    /// The orbit's cycle: exact means and first harmonics over one base period.
    fn record(&self) -> &CycleRecord;

    /// |δ1| / X_b.
    fn delta_amp_over_xb(&self) -> f64;

    /// Phase φ (rad) of δ1 with δ − δ_m ≈ |δ1| sin(ωt + φ).
    fn phase(&self) -> f64 {
        let c = self.record();
        c.delta_cos.atan2(c.delta_sin)
    }

    /// First-harmonic contact-radius amplitude a_A = |a1| (m).
    fn a_amp(&self) -> f64 {
        let c = self.record();
        c.a_sin.hypot(c.a_cos)
    }
}

impl Orbit for Steady {
    fn record(&self) -> &CycleRecord {
        &self.cycle
    }

    fn delta_amp_over_xb(&self) -> f64 {
        self.transfer_magnitude()
    }
}

/// A number of a periodic orbit that the steady-state and continuation tables print: its
/// column's name and SI unit, and how it is read off the [`Orbit`]. The description stays each
/// table's own (a resonance sweep says "time domain: ...").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OrbitQuantity {
    /// `delta_amp_over_xb` (1): |δ1| / X_b.
    DeltaAmpOverXb,
    /// `phase` (rad): φ of δ1.
    Phase,
    /// `delta_mean` (m): cycle-mean indentation.
    DeltaMean,
    /// `delta_sin` (m): coefficient of sin ωt in δ.
    DeltaSin,
    /// `delta_cos` (m): coefficient of cos ωt in δ.
    DeltaCos,
    /// `force_mean` (N): cycle-mean contact force.
    ForceMean,
    /// `force_amp` (N): first-harmonic contact-force amplitude.
    ForceAmp,
    /// `a_mean` (m): cycle-mean contact radius.
    AMean,
    /// `a_amp` (m): first-harmonic contact-radius amplitude.
    AAmp,
}

impl OrbitQuantity {
    /// The column name.
    pub fn name(self) -> &'static str {
        match self {
            Self::DeltaAmpOverXb => "delta_amp_over_xb",
            Self::Phase => "phase",
            Self::DeltaMean => "delta_mean",
            Self::DeltaSin => "delta_sin",
            Self::DeltaCos => "delta_cos",
            Self::ForceMean => "force_mean",
            Self::ForceAmp => "force_amp",
            Self::AMean => "a_mean",
            Self::AAmp => "a_amp",
        }
    }

    /// The SI unit.
    pub fn unit(self) -> &'static str {
        match self {
            Self::DeltaAmpOverXb => "1",
            Self::Phase => "rad",
            Self::DeltaMean | Self::DeltaSin | Self::DeltaCos | Self::AMean | Self::AAmp => "m",
            Self::ForceMean | Self::ForceAmp => "N",
        }
    }

    /// The value of orbit `o`.
    pub fn of(self, o: &(impl Orbit + ?Sized)) -> f64 {
        let c = o.record();
        match self {
            Self::DeltaAmpOverXb => o.delta_amp_over_xb(),
            Self::Phase => o.phase(),
            Self::DeltaMean => c.delta_mean,
            Self::DeltaSin => c.delta_sin,
            Self::DeltaCos => c.delta_cos,
            Self::ForceMean => c.force_mean,
            Self::ForceAmp => c.force_sin.hypot(c.force_cos),
            Self::AMean => c.a_mean,
            Self::AAmp => o.a_amp(),
        }
    }
}

/// The column of quantity `q` over `orbits`, one row each (NaN where an orbit is missing),
/// described by `description`.
pub fn orbit_column<'a, O: Orbit + 'a>(
    q: OrbitQuantity,
    description: impl Into<String>,
    orbits: impl IntoIterator<Item = Option<&'a O>>,
) -> Column {
    Column::f64_opt(
        q.name(),
        q.unit(),
        description,
        orbits.into_iter().map(|o| o.map(|o| q.of(o))),
    )
}

// ---------------------------------------------------------------------------------------------
// validate

/// `steady` of the validate report: how the steady state was found.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SteadySummary {
    /// "shooting" or "time-stepping".
    pub method: SteadyMethod,
    /// Base periods integrated.
    pub cycles: u64,
    /// Scaled once-per-cycle residual.
    pub residual: f64,
    /// Estimated scaled distance to the orbit (left out when not finite).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub distance: Option<f64>,
    /// Newton iterations.
    pub newton_iterations: usize,
    /// The cycle loses contact.
    pub contact_lost: bool,
    /// Wall-clock time (s).
    pub wall_s: f64,
}

impl From<&Steady> for SteadySummary {
    fn from(s: &Steady) -> Self {
        Self {
            method: s.method,
            cycles: s.cycles,
            residual: s.residual,
            distance: Some(s.distance).filter(|d| d.is_finite()),
            newton_iterations: s.newton_iterations,
            contact_lost: s.contact_lost,
            wall_s: s.wall_s,
        }
    }
}

/// The predictors of the validate report, keyed as in its JSON (missing ones left out).
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
pub struct Predictors {
    /// Imposed-area method at the simulated (ω, a_m, a_A).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub imposed_area: Option<Prediction>,
    /// Harmonic balance.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub harmonic_balance: Option<Prediction>,
    /// Corrected linear transfer.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub linear_transfer: Option<Prediction>,
    /// The paper's eqs. (36)–(37) as printed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub paper_transfer: Option<Prediction>,
    /// Eq. (39).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub paper_far_from_resonance: Option<Prediction>,
}

impl Predictors {
    /// (JSON key, label, prediction) in the order of the printed table.
    pub fn labelled(&self) -> [(&'static str, &'static str, Option<&Prediction>); 5] {
        [
            ("imposed_area", "imposed area", self.imposed_area.as_ref()),
            (
                "harmonic_balance",
                "harmonic balance",
                self.harmonic_balance.as_ref(),
            ),
            (
                "linear_transfer",
                "linear transfer",
                self.linear_transfer.as_ref(),
            ),
            (
                "paper_transfer",
                "paper (37) printed",
                self.paper_transfer.as_ref(),
            ),
            (
                "paper_far_from_resonance",
                "paper (39)",
                self.paper_far_from_resonance.as_ref(),
            ),
        ]
    }

    fn map(&self, f: impl Fn(&Prediction) -> Prediction) -> Self {
        let g = |p: &Option<Prediction>| p.as_ref().map(&f);
        Self {
            imposed_area: g(&self.imposed_area),
            harmonic_balance: g(&self.harmonic_balance),
            linear_transfer: g(&self.linear_transfer),
            paper_transfer: g(&self.paper_transfer),
            paper_far_from_resonance: g(&self.paper_far_from_resonance),
        }
    }
}

/// A prediction without its non-finite values (JSON has no NaN).
fn finite(p: &Prediction) -> Prediction {
    let f = |x: Option<f64>| x.filter(|v| v.is_finite());
    Prediction {
        a_mean: f(p.a_mean),
        a_amp: f(p.a_amp),
        delta_mean: f(p.delta_mean),
        delta_sin: f(p.delta_sin),
        delta_cos: f(p.delta_cos),
        delta_amp: f(p.delta_amp),
        force_mean: f(p.force_mean),
    }
}

/// `p` relative to `reference` ([`Prediction::relative_to`]), as a prediction of differences.
fn relative(p: &Prediction, reference: &Prediction) -> Prediction {
    let r = p.relative_to(reference).map(|(_, v)| v);
    finite(&Prediction {
        a_mean: r[0],
        a_amp: r[1],
        delta_mean: r[2],
        delta_sin: r[3],
        delta_cos: r[4],
        delta_amp: r[5],
        force_mean: r[6],
    })
}

/// What `djkr validate` reports (`--json`: this struct).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ValidateReport {
    /// Base frequency f (Hz).
    pub frequency: f64,
    /// Base amplitude X_b (m).
    pub amplitude: f64,
    /// Time-domain values.
    pub time_domain: Prediction,
    /// The predictors.
    #[serde(flatten)]
    pub predictors: Predictors,
    /// Each predictor relative to the time domain (δ_s, δ_c relative to δ_A).
    pub relative_difference: Predictors,
    /// How the steady state was found.
    pub steady: SteadySummary,
    /// The force-balance identity.
    pub force_balance: ForceBalance,
    /// Linear resonance f_r (Hz).
    #[serde(
        rename = "linear_resonance_frequency",
        skip_serializing_if = "Option::is_none"
    )]
    pub linear_resonance: Option<f64>,
    /// Why predictors are missing.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub notes: Vec<String>,
}

impl ValidateReport {
    /// The report of a comparison.
    pub fn new(c: &Comparison) -> Self {
        let predictors = Predictors {
            imposed_area: c.imposed_area,
            harmonic_balance: c.harmonic_balance,
            linear_transfer: c.linear_transfer,
            paper_transfer: c.paper_transfer,
            paper_far_from_resonance: c.paper_far_from_resonance,
        };
        let notes = c
            .imposed_area_error
            .iter()
            .map(|e| format!("imposed area: {e}"))
            .chain(c.predictor_error.iter().cloned())
            .collect();
        Self {
            frequency: c.frequency,
            amplitude: c.amplitude,
            time_domain: finite(&c.time_domain),
            relative_difference: predictors.map(|p| relative(p, &c.time_domain)),
            predictors: predictors.map(finite),
            steady: SteadySummary::from(&c.steady),
            force_balance: c.force_balance,
            linear_resonance: c.linear_resonance,
            notes,
        }
    }
}

// ---------------------------------------------------------------------------------------------
// resonance

/// A peak: (frequency, height).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Peak {
    /// Frequency (Hz).
    pub frequency: f64,
    /// Height |δ_A/X_b|.
    pub height: f64,
    /// Frequency minus the linear transfer's peak frequency (Hz).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub shift_from_linear: Option<f64>,
    /// Height over the linear transfer's peak height.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub height_over_linear: Option<f64>,
}

impl Peak {
    fn at((frequency, height): (f64, f64)) -> Self {
        Self {
            frequency,
            height,
            shift_from_linear: None,
            height_over_linear: None,
        }
    }

    fn against(mut self, linear: Option<Peak>) -> Self {
        if let Some(l) = linear {
            self.shift_from_linear = Some(self.frequency - l.frequency);
            self.height_over_linear = Some(self.height / l.height);
        }
        self
    }
}

/// One sweep direction of the resonance report.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SweepSummary {
    /// "up" or "down" (the JSON key `sweep_<direction>`).
    #[serde(skip)]
    pub direction: &'static str,
    /// Frequencies with a time-domain steady state.
    pub found: usize,
    /// Of those, found by shooting.
    pub by_shooting: usize,
    /// Base periods integrated.
    pub cycles: u64,
    /// Wall-clock time (s).
    pub wall_s: f64,
    /// Peak of the time-domain |δ_A/X_b| ([`sweep::peak`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub peak: Option<Peak>,
    /// Peak of the harmonic-balance |δ_A/X_b| along the sweep.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub harmonic_balance_peak: Option<Peak>,
}

impl SweepSummary {
    fn new(sw: &Sweep, linear: Option<Peak>) -> Self {
        let found = sw.points.iter().filter_map(|p| p.steady.as_ref());
        let (hx, hy) = sorted_by_frequency(&sw.points, |p| {
            p.harmonic.map(|h| h.harmonics.delta_amp / sw.amplitude)
        });
        let hb: Vec<(f64, f64)> = hx.into_iter().zip(hy).collect();
        Self {
            direction: sw.direction.name(),
            found: found.clone().count(),
            by_shooting: found.filter(|s| s.method == SteadyMethod::Shooting).count(),
            cycles: sw.cycles,
            wall_s: sw.wall_s,
            peak: sweep::peak(&sw.points).map(|p| Peak::at(p).against(linear)),
            harmonic_balance_peak: sweep::peak_of(&hb).map(Peak::at),
        }
    }
}

/// The largest up/down difference in |δ_A/X_b| at one frequency.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct UpDownDifference {
    /// Frequency (Hz).
    pub frequency: f64,
    /// |up − down| in |δ_A/X_b|.
    pub delta_amp_over_xb: f64,
}

/// What `djkr resonance` reports (`--json`: this struct).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ResonanceReport {
    /// Base amplitude X_b (m).
    pub amplitude: f64,
    /// Number of frequencies.
    pub frequencies: usize,
    /// Frequency range swept (Hz), for the printed header.
    #[serde(skip)]
    pub range: (f64, f64),
    /// Wall-clock time of the sweeps (s).
    pub wall_s: f64,
    /// Linear contact stiffness k_c = 3/2 K a_0 (N/m), for the printed header.
    #[serde(skip)]
    pub contact_stiffness: Option<f64>,
    /// Undamped linear resonance (Hz).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub linear_resonance_frequency: Option<f64>,
    /// Peak of the linear transfer over the range ([`linear_peak`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub linear_peak: Option<Peak>,
    /// The up sweep.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sweep_up: Option<SweepSummary>,
    /// The down sweep.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sweep_down: Option<SweepSummary>,
    /// With both sweeps: where they differ most (hysteresis).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_up_down_difference: Option<UpDownDifference>,
    /// Why the predictors are missing.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub notes: Vec<String>,
    /// Files written (set by the caller).
    pub files: Vec<String>,
}

impl ResonanceReport {
    /// The report of `sweeps` over [lo, hi] with `n` frequencies (`lin`: the predictors, or why
    /// they are missing), `wall_s` the sweeps' wall time. `files` is left empty.
    pub fn new(
        sweeps: &[Sweep],
        (lo, hi, n): (f64, f64, usize),
        lin: Result<&Linearisation, &str>,
        wall_s: f64,
    ) -> Self {
        let lin_ok = lin.as_ref().ok();
        let linear_peak = lin_ok.and_then(|l| linear_peak(l, lo, hi)).map(Peak::at);
        let summaries: Vec<SweepSummary> = sweeps
            .iter()
            .map(|s| SweepSummary::new(s, linear_peak))
            .collect();
        let pick = |d: &str| summaries.iter().find(|s| s.direction == d).cloned();
        Self {
            amplitude: sweeps.first().map_or(f64::NAN, |s| s.amplitude),
            frequencies: n,
            range: (lo, hi),
            wall_s,
            contact_stiffness: lin_ok.map(|l| l.contact_stiffness),
            linear_resonance_frequency: lin_ok.map(|l| l.resonance_frequency()),
            linear_peak,
            sweep_up: pick("up"),
            sweep_down: pick("down"),
            max_up_down_difference: match sweeps {
                [a, b] => up_down_difference(a, b),
                _ => None,
            },
            notes: lin.err().map(str::to_string).into_iter().collect(),
            files: Vec::new(),
        }
    }

    /// The sweeps, up first.
    pub fn sweeps(&self) -> impl Iterator<Item = &SweepSummary> {
        self.sweep_up.iter().chain(&self.sweep_down)
    }
}

/// The points' `f` against frequency, sorted by frequency, non-finite values left out.
pub fn sorted_by_frequency(
    points: &[SweepPoint],
    f: impl Fn(&SweepPoint) -> Option<f64>,
) -> (Vec<f64>, Vec<f64>) {
    let mut v: Vec<(f64, f64)> = points
        .iter()
        .filter_map(|p| f(p).filter(|y| y.is_finite()).map(|y| (p.frequency, y)))
        .collect();
    v.sort_by(|a, b| a.0.total_cmp(&b.0));
    v.into_iter().unzip()
}

/// Peak of the linear transfer |δ1/X_b| over [lo, hi] (Hz): 4001 samples, refined by
/// [`sweep::peak_of`].
pub fn linear_peak(lin: &Linearisation, lo: f64, hi: f64) -> Option<(f64, f64)> {
    let v: Vec<(f64, f64)> = sweep::frequencies(lo, hi, 4001)
        .into_iter()
        .map(|f| (f, lin.linear(f).magnitude()))
        .collect();
    sweep::peak_of(&v)
}

/// Where an up and a down sweep differ most in the time-domain |δ_A/X_b|, at frequencies both
/// computed (relative match 1e-9).
pub fn up_down_difference(up: &Sweep, down: &Sweep) -> Option<UpDownDifference> {
    let mut worst: Option<UpDownDifference> = None;
    for pu in &up.points {
        let pd = down
            .points
            .iter()
            .find(|p| (p.frequency - pu.frequency).abs() <= 1e-9 * pu.frequency);
        if let Some((su, sd)) = pd.and_then(|pd| pu.steady.as_ref().zip(pd.steady.as_ref())) {
            let d = (su.transfer_magnitude() - sd.transfer_magnitude()).abs();
            if worst.is_none_or(|w| d > w.delta_amp_over_xb) {
                worst = Some(UpDownDifference {
                    frequency: pu.frequency,
                    delta_amp_over_xb: d,
                });
            }
        }
    }
    worst
}

/// A sweep as a table (`resonance.csv` rows, one `resonance.h5` group): per frequency, the
/// time-domain steady state, the linear transfer and harmonic balance; NaN where missing.
pub fn sweep_table(sw: &Sweep) -> Table {
    let p = &sw.points;
    let mut columns = vec![
        Column::text(
            "direction",
            "sweep direction",
            p.iter().map(|_| sw.direction.name().to_string()).collect(),
        ),
        Column::f64(
            "frequency",
            "Hz",
            "base frequency",
            p.iter().map(|x| x.frequency).collect(),
        ),
    ];
    columns.extend(time_domain_columns(p));
    columns.extend(predictor_columns(p, sw.amplitude));
    columns.push(Column::text(
        "error",
        "why the time-domain steady state is missing (empty when found)",
        p.iter()
            .map(|x| x.error.clone().unwrap_or_default())
            .collect(),
    ));
    Table::from_fixed(columns)
}

/// The time-domain steady state's columns of [`sweep_table`].
fn time_domain_columns(p: &[SweepPoint]) -> Vec<Column> {
    use OrbitQuantity as Q;
    let st = |q: Q, description: &str| {
        orbit_column(
            q,
            format!("time domain: {description}"),
            p.iter().map(|x| x.steady.as_ref()),
        )
    };
    let plain = |name: &str, description: &str, f: &dyn Fn(&Steady) -> f64| {
        Column::f64_opt(
            name,
            "1",
            description,
            p.iter().map(|x| x.steady.as_ref().map(f)),
        )
    };
    vec![
        st(
            Q::DeltaAmpOverXb,
            "first-harmonic indentation amplitude |delta_1| / X_b",
        ),
        st(
            Q::Phase,
            "phase phi of delta_1, delta - delta_m ~ |delta_1| sin(wt + phi)",
        ),
        st(Q::DeltaMean, "cycle-mean indentation"),
        st(Q::DeltaSin, "coefficient of sin wt in delta"),
        st(Q::DeltaCos, "coefficient of cos wt in delta"),
        st(Q::ForceMean, "cycle-mean contact force"),
        st(Q::ForceAmp, "first-harmonic contact-force amplitude"),
        st(Q::AMean, "cycle-mean contact radius"),
        st(Q::AAmp, "first-harmonic contact-radius amplitude"),
        plain(
            "cycles",
            "base periods integrated for this frequency",
            &|s| s.cycles as f64,
        ),
        plain(
            "residual",
            "scaled once-per-cycle residual at the steady state",
            &|s| s.residual,
        ),
        plain(
            "contact_lost",
            "1 when the steady cycle loses contact",
            &|s| f64::from(u8::from(s.contact_lost)),
        ),
        Column::text(
            "method",
            "how the steady state was found: shooting or time-stepping",
            p.iter()
                .map(|x| {
                    x.steady
                        .as_ref()
                        .map(|s| s.method.name().to_string())
                        .unwrap_or_default()
                })
                .collect(),
        ),
    ]
}

/// The linear-transfer and harmonic-balance columns of [`sweep_table`] (X_b = `xb`).
fn predictor_columns(p: &[SweepPoint], xb: f64) -> Vec<Column> {
    let hb = |name: &str, unit: &str, description: &str, f: &dyn Fn(&HarmonicBalance) -> f64| {
        Column::f64_opt(
            name,
            unit,
            description,
            p.iter().map(|x| x.harmonic.as_ref().map(f)),
        )
    };
    vec![
        Column::f64_opt(
            "linear_delta_amp_over_xb",
            "1",
            "corrected linear transfer |delta_1|/X_b, k_c = 3/2 K a_0",
            p.iter().map(|x| x.linear.map(|t| t.magnitude())),
        ),
        Column::f64_opt(
            "linear_phase",
            "rad",
            "corrected linear transfer: phase",
            p.iter().map(|x| x.linear.map(|t| t.phase())),
        ),
        hb(
            "hb_delta_amp_over_xb",
            "1",
            "harmonic balance |delta_1|/X_b",
            &|h| h.harmonics.delta_amp / xb,
        ),
        hb(
            "hb_phase",
            "rad",
            "harmonic balance: phase of delta_1",
            &|h| h.harmonics.delta_cos.atan2(h.harmonics.delta_sin),
        ),
        hb(
            "hb_force_mean",
            "N",
            "harmonic balance: mean contact force",
            &|h| h.harmonics.force_mean,
        ),
        hb(
            "hb_a_mean",
            "m",
            "harmonic balance: mean contact radius",
            &|h| h.a_mean,
        ),
        hb(
            "hb_a_amp",
            "m",
            "harmonic balance: contact-radius amplitude",
            &|h| h.a_amp,
        ),
    ]
}

/// Several sweeps in one table (`resonance.csv`), in order.
pub fn sweeps_table(sweeps: &[Sweep]) -> Table {
    let mut all: Option<Table> = None;
    for sw in sweeps {
        let t = sweep_table(sw);
        match &mut all {
            None => all = Some(t),
            Some(a) => {
                // Same builder, same schema.
                let appended = a.append_rows(&t);
                debug_assert!(appended.is_ok(), "{appended:?}");
            }
        }
    }
    all.unwrap_or_else(|| {
        sweep_table(&Sweep {
            direction: sweep::Direction::Up,
            amplitude: f64::NAN,
            points: Vec::new(),
            cycles: 0,
            wall_s: 0.0,
        })
    })
}

// ---------------------------------------------------------------------------------------------
// shortcut map

/// The map as a table (`shortcut-map.csv`, the `cells` group of `shortcut-map.h5`): one row per
/// cell, row-major in amplitude; NaN where missing.
pub fn map_table(m: &ShortcutMap) -> Table {
    let c = &m.cells;
    let td = |name: &str, unit: &str, description: &str, f: fn(&Prediction) -> Option<f64>| {
        Column::f64_opt(
            name,
            unit,
            format!("time domain: {description}"),
            c.iter().map(|x| x.time_domain.as_ref().and_then(f)),
        )
    };
    let ia = |name: &str, unit: &str, description: &str, f: fn(&Prediction) -> Option<f64>| {
        Column::f64_opt(
            name,
            unit,
            format!("imposed area: {description}"),
            c.iter().map(|x| x.imposed_area.as_ref().and_then(f)),
        )
    };
    let cell = |name: &str, unit: &str, description: &str, f: fn(&MapCell) -> Option<f64>| {
        Column::f64_opt(name, unit, description, c.iter().map(f))
    };
    Table::from_fixed(vec![
        cell("frequency", "Hz", "base frequency", |x| Some(x.frequency)),
        cell("amplitude", "m", "base amplitude X_b", |x| {
            Some(x.amplitude)
        }),
        cell(
            "force_error",
            "1",
            "(F_m imposed - F_m time) / max(|F_m time|, 3/2 pi R w0)",
            |x| x.force_error,
        ),
        cell(
            "delta_amp_error",
            "1",
            "(delta_A imposed - delta_A time) / delta_A time",
            |x| x.delta_amp_error,
        ),
        td("time_force_mean", "N", "mean contact force", |p| {
            p.force_mean
        }),
        ia("imposed_force_mean", "N", "mean contact force", |p| {
            p.force_mean
        }),
        td("time_delta_amp", "m", "delta_A", |p| p.delta_amp),
        ia("imposed_delta_amp", "m", "delta_A", |p| p.delta_amp),
        td("time_delta_mean", "m", "mean indentation", |p| p.delta_mean),
        ia("imposed_delta_mean", "m", "mean indentation", |p| {
            p.delta_mean
        }),
        td("a_mean", "m", "mean contact radius", |p| p.a_mean),
        td(
            "a_amp",
            "m",
            "contact-radius first-harmonic amplitude",
            |p| p.a_amp,
        ),
        cell(
            "contact_lost",
            "1",
            "1 when the steady cycle loses contact",
            |x| Some(f64::from(u8::from(x.contact_lost))),
        ),
        cell("cycles", "1", "base periods integrated", |x| {
            Some(x.cycles as f64)
        }),
        Column::text(
            "method",
            "how the steady state was found",
            c.iter()
                .map(|x| x.method.map(|m| m.name().to_string()).unwrap_or_default())
                .collect(),
        ),
        Column::text(
            "error",
            "why a value is missing",
            c.iter()
                .map(|x| x.error.clone().unwrap_or_default())
                .collect(),
        ),
    ])
}

/// Statistics of |error| over the cells where it was found.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ErrorStats {
    /// Smallest |error| (0 when none was found).
    pub min_abs: f64,
    /// Largest |error| (0 when none was found).
    pub max_abs: f64,
    /// Cells with |error| < 1 %.
    pub below_1_percent: usize,
    /// Cells with |error| < 5 %.
    pub below_5_percent: usize,
}

impl ErrorStats {
    fn of(values: impl Iterator<Item = f64>) -> Self {
        let v: Vec<f64> = values.map(f64::abs).collect();
        let below = |t: f64| v.iter().filter(|x| **x < t).count();
        Self {
            min_abs: if v.is_empty() {
                0.0
            } else {
                v.iter().copied().fold(f64::INFINITY, f64::min)
            },
            max_abs: v.iter().copied().fold(0.0, f64::max),
            below_1_percent: below(0.01),
            below_5_percent: below(0.05),
        }
    }
}

/// What `djkr shortcut-map` reports (`--json`: this struct).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ShortcutMapReport {
    /// Frequencies (Hz).
    pub frequencies: Vec<f64>,
    /// Base amplitudes (m).
    pub amplitudes: Vec<f64>,
    /// Number of cells.
    pub cells: usize,
    /// Cells with a mean-force error (steady state and imposed-area cycle found).
    pub found: usize,
    /// Cells whose steady state needed time-stepping.
    pub by_time_stepping: usize,
    /// Cells whose steady cycle loses contact.
    pub contact_lost: usize,
    /// Base periods integrated.
    pub cycles: u64,
    /// Wall-clock time (s).
    pub wall_s: f64,
    /// Mean-force error statistics.
    pub force_error: ErrorStats,
    /// δ_A error statistics.
    pub delta_amp_error: ErrorStats,
    /// The mean-force error per cell, row-major in amplitude (for the printed grid).
    #[serde(skip)]
    pub force_error_grid: Vec<Option<f64>>,
    /// Files written (set by the caller).
    pub files: Vec<String>,
}

impl ShortcutMapReport {
    /// The report of a map. `files` is left empty.
    pub fn new(m: &ShortcutMap) -> Self {
        let found: Vec<&MapCell> = m.cells.iter().filter(|c| c.force_error.is_some()).collect();
        Self {
            frequencies: m.frequencies.clone(),
            amplitudes: m.amplitudes.clone(),
            cells: m.cells.len(),
            found: found.len(),
            by_time_stepping: m
                .cells
                .iter()
                .filter(|c| c.method == Some(SteadyMethod::TimeStepping))
                .count(),
            contact_lost: m.cells.iter().filter(|c| c.contact_lost).count(),
            cycles: m.cycles,
            wall_s: m.wall_s,
            force_error: ErrorStats::of(found.iter().filter_map(|c| c.force_error)),
            delta_amp_error: ErrorStats::of(found.iter().filter_map(|c| c.delta_amp_error)),
            force_error_grid: m.cells.iter().map(|c| c.force_error).collect(),
            files: Vec::new(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn empty_sweeps_and_maps_give_header_only_tables() {
        let t = sweeps_table(&[]);
        assert_eq!(t.rows(), 0);
        assert!(t
            .to_csv()
            .starts_with("direction,frequency [Hz],delta_amp_over_xb [1],phase [rad]"));
        let m = ShortcutMap {
            frequencies: vec![],
            amplitudes: vec![],
            cells: vec![],
            cycles: 0,
            wall_s: 0.0,
        };
        assert_eq!(map_table(&m).columns().len(), 16);
        let r = ShortcutMapReport::new(&m);
        assert_eq!(r.force_error.min_abs.to_bits(), 0f64.to_bits());
    }
}

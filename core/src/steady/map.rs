//! Where does the imposed-area shortcut hold? Over a grid of base frequency × base amplitude,
//! the time-domain steady state is compared with the imposed-area cycle at the simulated
//! (ω, a_m, a_A) ([`super::crosscheck::imposed`]): the relative error of the mean force and of δ_A.
//!
//! - force error: (F_m,imposed − F_m,time) / max(|F_m,time|, |F0|), F0 = −(3/2)πRw0 (the static
//!   pull-off force; the floor keeps the measure finite where the mean force crosses zero);
//! - δ_A error: (δ_A,imposed − δ_A,time) / δ_A,time.
//!
//! Columns (one frequency each) run in parallel (rayon); within a column the amplitudes are
//! visited in increasing order, each started from the previous amplitude's steady state.

use super::crosscheck::{self, Prediction};
use super::{Options, Problem, SteadyMethod};
use crate::dynamics::protocol::Initial;
use rayon::prelude::*;
use serde::Serialize;

/// One grid point.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MapCell {
    /// Base frequency f (Hz).
    pub frequency: f64,
    /// Base amplitude X_b (m).
    pub amplitude: f64,
    /// How the steady state was found (`None`: not found, see `error`).
    pub method: Option<SteadyMethod>,
    /// Base periods integrated.
    pub cycles: u64,
    /// The steady cycle loses (and regains) contact.
    pub contact_lost: bool,
    /// Time-domain values.
    pub time_domain: Option<Prediction>,
    /// Imposed-area values at the simulated (ω, a_m, a_A).
    pub imposed_area: Option<Prediction>,
    /// Relative error of the imposed-area mean force (see module doc).
    pub force_error: Option<f64>,
    /// Relative error of the imposed-area δ_A.
    pub delta_amp_error: Option<f64>,
    /// Why a value is missing.
    pub error: Option<String>,
}

/// The map: cells row-major in amplitude, `cells[ia * frequencies.len() + i_f]`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ShortcutMap {
    /// Frequencies (Hz), increasing.
    pub frequencies: Vec<f64>,
    /// Base amplitudes (m), increasing.
    pub amplitudes: Vec<f64>,
    /// Cells.
    pub cells: Vec<MapCell>,
    /// Base periods integrated in total.
    pub cycles: u64,
    /// Wall-clock time (s).
    pub wall_s: f64,
}

impl ShortcutMap {
    /// A field of every cell, row-major (NaN where missing: for plotting only).
    pub fn field(&self, f: impl Fn(&MapCell) -> Option<f64>) -> Vec<f64> {
        self.cells
            .iter()
            .map(|c| f(c).unwrap_or(f64::NAN))
            .collect()
    }
}

fn cell(problem: &Problem, from: &mut Initial, f: f64, xb: f64, opts: &Options) -> MapCell {
    let mut c = MapCell {
        frequency: f,
        amplitude: xb,
        method: None,
        cycles: 0,
        contact_lost: false,
        time_domain: None,
        imposed_area: None,
        force_error: None,
        delta_amp_error: None,
        error: None,
    };
    let p = match problem.at(f, xb) {
        Ok(p) => p,
        Err(e) => {
            c.error = Some(e.to_string());
            return c;
        }
    };
    let s = match p.solve(from, opts) {
        Ok(s) => s,
        Err(e) => {
            if let super::SteadyError::NotConverged { cycles, .. } = e {
                c.cycles = cycles;
            }
            c.error = Some(e.to_string());
            return c;
        }
    };
    *from = s.state.initial();
    c.method = Some(s.method);
    c.cycles = s.cycles;
    c.contact_lost = s.contact_lost;
    let td = crosscheck::time_domain(&s);
    c.time_domain = Some(td);
    match crosscheck::imposed(p.rig(), &s) {
        Ok(ia) => {
            let f0 = p.rig().material.static_pull_off_force().abs();
            if let (Some(fi), Some(ft)) = (ia.force_mean, td.force_mean) {
                c.force_error = Some((fi - ft) / ft.abs().max(f0));
            }
            if let (Some(di), Some(dt)) = (ia.delta_amp, td.delta_amp) {
                if dt > 0.0 {
                    c.delta_amp_error = Some((di - dt) / dt);
                }
            }
            c.imposed_area = Some(ia);
        }
        Err(e) => c.error = Some(format!("imposed area: {e}")),
    }
    c
}

/// Map the shortcut's error over `freqs` × `amps` (any order; sorted increasing), each column
/// started from `start` at its smallest amplitude. `progress` is called after each cell.
pub fn shortcut_map(
    problem: &Problem,
    start: &Initial,
    freqs: &[f64],
    amps: &[f64],
    opts: &Options,
    progress: &(dyn Fn(&MapCell) + Sync),
) -> ShortcutMap {
    let t0 = std::time::Instant::now();
    let mut fs = freqs.to_vec();
    fs.sort_by(f64::total_cmp);
    let mut xs = amps.to_vec();
    xs.sort_by(f64::total_cmp);
    let columns: Vec<Vec<MapCell>> = fs
        .par_iter()
        .map(|&f| {
            let mut from = *start;
            xs.iter()
                .map(|&xb| {
                    let c = cell(problem, &mut from, f, xb, opts);
                    progress(&c);
                    c
                })
                .collect()
        })
        .collect();
    let mut cells = Vec::with_capacity(fs.len() * xs.len());
    for ia in 0..xs.len() {
        for col in &columns {
            cells.push(col[ia].clone());
        }
    }
    ShortcutMap {
        cycles: cells.iter().map(|c| c.cycles).sum(),
        frequencies: fs,
        amplitudes: xs,
        cells,
        wall_s: t0.elapsed().as_secs_f64(),
    }
}

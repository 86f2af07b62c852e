//! `djkr continue`: continuation of the periodic orbit in one scenario key through its folds,
//! with Floquet stability, bifurcations, natural sweeps overlaid and, with `--fold-param`, the
//! fold curves in two parameters; writes `branch.csv`, `branch.h5`, `bifurcations.csv`,
//! `sweep.csv`, `fold_curves.csv` and plots, prints a summary.

use super::common::default_out;
use super::common::{print_json, write_atomic, SetArgs};
use super::steady::{progress_bar, stem};
use crate::output::hdf5_file::{hdf5_tables, Attr};
use crate::output::table::{format_f64, format_sig};
use crate::plot::{self, Figure, LegendPosition, Series, Style};
use crate::reports::continuation::{self as report, ContinuationReport};
use crate::scenario::family::{family as scenario_family, parameter};
use crate::scenario::parse::ScenarioSource;
use anyhow::{bail, Context, Result};
use clap::Args;
use djkr_core::continuation::branch::{self, Branch, BranchPoint, PointKind};
use djkr_core::continuation::family::{Family, Parameter};
use djkr_core::continuation::folds::{self, FoldCurve, FoldPointKind};
use djkr_core::continuation::sweep::{self, SweepPoint};
use djkr_core::steady::Options;
use djkr_core::units::parse_quantity;
use std::path::{Path, PathBuf};

/// Flags of `djkr continue`.
#[derive(Args, Debug)]
#[command(after_help = super::common::STEADY_UNUSED_KEYS)]
pub struct ContinueArgs {
    /// Scenario file (its first vibrating stage defines the periodic problem, as for `djkr
    /// validate`).
    file: PathBuf,
    /// The key to continue in, a constant of the periodic orbit: base.frequency,
    /// base.amplitude, initial.preload, damping.c, spring.stiffness, sphere.mass,
    /// sphere.gravity, material.K, material.R, material.w0, adhesion.v0, adhesion.n,
    /// adhesion.v_sat.
    #[arg(long, value_name = "KEY")]
    param: String,
    /// Range of KEY, START:STOP with units, e.g. 340:600 or 340Hz:0.6kHz. The branch starts at
    /// START (the steady state found there) and is followed until it leaves [START, STOP] at
    /// either end.
    #[arg(long, value_name = "START:STOP", allow_hyphen_values = true)]
    range: String,
    /// Follow each fold in this second key (e.g. base.amplitude): the region of bistability
    /// and its cusp. Needs --fold-range.
    #[arg(long, value_name = "KEY2", requires = "fold_range")]
    fold_param: Option<String>,
    /// Range of KEY2, START:STOP: the branch is computed at KEY2 = START, its folds followed
    /// towards STOP.
    #[arg(
        long,
        value_name = "START:STOP",
        allow_hyphen_values = true,
        requires = "fold_param"
    )]
    fold_range: Option<String>,
    /// Values of the up and down sweeps overlaid on the branch (0: no sweeps; at most 10000).
    #[arg(long, default_value = "41", value_name = "N")]
    sweep: usize,
    /// Relative tolerance of the time integration.
    #[arg(
        long,
        default_value = "1e-10",
        value_name = "RTOL",
        allow_hyphen_values = true
    )]
    rtol: String,
    /// Corrector tolerance (scaled unknowns) of the branch.
    #[arg(
        long,
        default_value = "1e-9",
        value_name = "TOL",
        allow_hyphen_values = true
    )]
    tol: String,
    /// Largest continuation step, in the scaled unknowns (state by its oscillation scale,
    /// KEY by the range's width). Two folds closer than one step (just above a cusp) can be
    /// stepped over: lower it to resolve them.
    #[arg(long, default_value = "0.1", value_name = "H")]
    max_step: String,
    /// Output directory [default: out/<scenario name>-continue].
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Overwrite files in --out that djkr did not write under the names this command writes;
    /// without it such a file stops the command before any work. Nothing else is touched.
    #[arg(long)]
    force: bool,
    /// Print a JSON summary (SI values) instead of a table.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    set: SetArgs,
}

/// Parse `START:STOP` of `key` (dimension of its values).
fn parse_range(flag: &str, text: &str, p: &Parameter) -> Result<(f64, f64)> {
    let parts: Vec<&str> = text.split(':').collect();
    if parts.len() != 2 {
        bail!(
            "{flag} = {shown_text}: expected START:STOP for {} ({}), e.g. 340:600",
            p.name(),
            p.info.unit,
            shown_text = djkr_core::text::excerpt(text)
        );
    }
    let a = parse_quantity(flag, parts[0].trim(), p.info.dimension)?;
    let b = parse_quantity(flag, parts[1].trim(), p.info.dimension)?;
    if !(a.is_finite() && b.is_finite()) || a.partial_cmp(&b) == Some(std::cmp::Ordering::Equal) {
        bail!(
            "{flag} = {shown_text}: START and STOP must be finite and differ ({} in {})",
            p.name(),
            p.info.unit,
            shown_text = djkr_core::text::excerpt(text)
        );
    }
    Ok((a, b))
}

/// A dimensionless tolerance flag in (lo, hi).
fn tolerance(flag: &str, text: &str, lo: f64, hi: f64) -> Result<f64> {
    let v = parse_quantity(flag, text, djkr_core::units::Dimension::Dimensionless)?;
    if !(v.is_finite() && v > lo && v < hi) {
        bail!(
            "{flag} = {shown_text}: must be in ({lo:e}, {hi:e})",
            shown_text = djkr_core::text::excerpt(text)
        );
    }
    Ok(v)
}

/// Check that every value of `range` is one the scenario accepts (its ends), naming the flag.
fn check_ends(flag: &str, text: &str, family: &Family, values: &[[f64; 2]]) -> Result<()> {
    for v in values {
        let n = family.params().len();
        if let Err(e) = family.setup(&v[..n]) {
            bail!(
                "{flag} = {shown_text}: {e}",
                shown_text = djkr_core::text::excerpt(text)
            );
        }
    }
    Ok(())
}

/// The checked flags of `djkr continue`, before the scenario is read.
struct Flags {
    /// `--param`.
    param: Parameter,
    /// `--range` (START, STOP).
    range: (f64, f64),
    /// `--rtol`.
    rtol: f64,
    /// `--tol`.
    tol: f64,
    /// `--fold-param` and its `--fold-range`.
    fold: Option<(Parameter, (f64, f64))>,
}

/// The scenario and the periodic problems continued in it.
struct Problem {
    /// The scenario file.
    source: ScenarioSource,
    /// Its name with the overrides.
    scenario_name: String,
    /// KEY free; with `--fold-param`, KEY2 held at the start of its range.
    family: Family,
    /// With `--fold-param`: KEY and KEY2 free.
    family2: Option<Family>,
}

/// What `djkr continue` computed.
struct Computed {
    /// The branch in KEY.
    branch: Branch,
    /// The natural sweeps up and down (empty with `--sweep 0`).
    up: Vec<SweepPoint>,
    down: Vec<SweepPoint>,
    /// With `--fold-param`: the fold curves and their wall time (s).
    curves: Option<(Vec<FoldCurve>, f64)>,
}

/// Run `djkr continue`.
pub fn continuation(a: &ContinueArgs) -> Result<()> {
    let flags = parse_flags(a)?;
    let problem = problem(a, &flags)?;
    let set = settings(a, &flags)?;
    let out = a
        .out
        .clone()
        .unwrap_or_else(|| default_out(&a.file, "-continue"));
    super::common::claim_out(&out, &["branch.png", "branch.svg"], a.force)?;
    let computed = compute(a, &flags, &problem, &set)?;
    let rep = write_outputs(a, &flags, &problem, &computed)?;
    if a.json {
        print_json(&rep)
    } else {
        print_report(&a.file, &rep)?;
        Ok(())
    }
}

/// Check the flags that need no scenario.
fn parse_flags(a: &ContinueArgs) -> Result<Flags> {
    let param = parameter("--param", &a.param)?;
    let range = parse_range("--range", &a.range, &param)?;
    let rtol = tolerance("--rtol", &a.rtol, 1e-14, 1e-6)?;
    if a.sweep > 10_000 {
        bail!("--sweep = {}: must be in 0..=10000", a.sweep);
    }
    let tol = tolerance("--tol", &a.tol, 1e-14, 1e-3)?;
    let fold = match (&a.fold_param, &a.fold_range) {
        (Some(k), Some(r)) => {
            let q = parameter("--fold-param", k)?;
            if q == param {
                bail!(
                    "--fold-param {k}: must differ from --param {}",
                    param.name()
                );
            }
            let range = parse_range("--fold-range", r, &q)?;
            Some((q, range))
        }
        _ => None,
    };
    Ok(Flags {
        param,
        range,
        rtol,
        tol,
        fold,
    })
}

/// Read the scenario with its overrides and set up the families, checking that the ends of the
/// ranges are values the scenario accepts.
fn problem(a: &ContinueArgs, flags: &Flags) -> Result<Problem> {
    let (param, (p0, p1), rtol) = (flags.param, flags.range, flags.rtol);
    let overrides = a.set.overrides()?;
    let source = ScenarioSource::read(&a.file)?;
    // The file with its overrides, before any value of KEY: a bad --set is named as such.
    let scenario_name = source.scenario(&overrides)?.source_name;
    let param_key = flags.param.name();
    a.set.refuse_replaced(
        "continue",
        &[
            ("solver.rtol", "--rtol"),
            (param_key, "--param with --range"),
        ],
    )?;
    // The branch: KEY free; with --fold-param, KEY2 held at the start of its range.
    let mut fixed = overrides.clone();
    if let Some((q, (q0, _))) = &flags.fold {
        if let Some(o) = overrides.iter().find(|o| o.key().to_string() == q.name()) {
            bail!(
                "--set {o}: {} is the --fold-param, whose values come from --fold-range; drop the --set",
                q.name()
            );
        }
        fixed.push(crate::scenario::overrides::Override::new(q.name(), *q0)?);
    }
    let family = scenario_family(&source, &fixed, vec![param], rtol)?;
    check_ends("--range", &a.range, &family, &[[p0, 0.0], [p1, 0.0]])?;
    let family2 = match &flags.fold {
        Some((q, (q0, q1))) => {
            let f2 = scenario_family(&source, &overrides, vec![param, *q], rtol)?;
            check_ends(
                "--fold-range",
                a.fold_range.as_deref().unwrap_or(""),
                &f2,
                &[[p0, *q0], [p0, *q1]],
            )?;
            Some(f2)
        }
        None => None,
    };
    Ok(Problem {
        source,
        scenario_name,
        family,
        family2,
    })
}

/// The continuation's settings from `--rtol`, `--tol` and `--max-step`.
fn settings(a: &ContinueArgs, flags: &Flags) -> Result<branch::Settings> {
    let mut set = branch::Settings {
        rtol: flags.rtol,
        ..branch::Settings::default()
    };
    set.engine.tol = flags.tol;
    set.engine.h_max = tolerance("--max-step", &a.max_step, 1e-6, 10.0)?;
    set.engine.h_start = set.engine.h_start.min(set.engine.h_max);
    set.steady.rtol = flags.rtol;
    Ok(set)
}

/// The branch, the sweeps and the fold curves, under one progress bar.
fn compute(
    a: &ContinueArgs,
    flags: &Flags,
    problem: &Problem,
    set: &branch::Settings,
) -> Result<Computed> {
    let (param, (p0, p1)) = (flags.param, flags.range);
    let family = &problem.family;
    let bar = progress_bar(0, "continuation");
    let branch = branch::continue_branch(family, (p0, p1), set, &mut |p| {
        bar.set_message(format!("{} = {p:.6e}", param.name()));
        bar.tick();
    })
    .with_context(|| format!("{}", a.file.display()))?;

    let (up, down) = if a.sweep > 0 {
        bar.set_message("sweeps up and down");
        let opts = Options {
            rtol: flags.rtol,
            ..Options::default()
        };
        sweep::sweep_both(family, (p0, p1), a.sweep, &opts)
    } else {
        (Vec::new(), Vec::new())
    };

    let curves = match (&flags.fold, &problem.family2) {
        (Some((q, range)), Some(f2)) => {
            let t0 = std::time::Instant::now();
            let c = folds::continue_folds(f2, &branch, *range, &set.engine, &mut |p, v| {
                bar.set_message(format!(
                    "fold curve: {} = {p:.6e}, {} = {v:.6e}",
                    param.name(),
                    q.name()
                ));
                bar.tick();
            })?;
            Some((c, t0.elapsed().as_secs_f64()))
        }
        _ => None,
    };
    bar.finish_and_clear();
    Ok(Computed {
        branch,
        up,
        down,
        curves,
    })
}

/// Write the tables and plots into the output folder; the report, listing them.
fn write_outputs(
    a: &ContinueArgs,
    flags: &Flags,
    problem: &Problem,
    c: &Computed,
) -> Result<ContinuationReport> {
    let (fold, branch, up, down) = (&flags.fold, &c.branch, &c.up, &c.down);
    let out = a
        .out
        .clone()
        .unwrap_or_else(|| default_out(&a.file, "-continue"));
    let fold_tables = c
        .curves
        .as_ref()
        .map(|c| (&c.0, fold.as_ref().map(|f| f.0)));
    let mut files = write_tables(
        &out,
        &problem.scenario_name,
        &problem.source,
        branch,
        (up, down),
        fold_tables,
    )?;
    let fig = branch_figure(&a.file, branch, up, down);
    let (png, svg) = plot::render(&fig, &out.join("branch"))?;
    files.extend([png, svg]);

    let mut rep = ContinuationReport::new(&problem.scenario_name, branch);
    add_sweep_jumps(&mut rep, &flags.param, c);
    if let (Some((q, range)), Some((curves, wall))) = (fold, &c.curves) {
        let fig = fold_figure(&a.file, branch, q, curves);
        let (png, svg) = plot::render(&fig, &out.join("fold_curves"))?;
        files.extend([png, svg]);
        rep = rep.with_folds(q.name(), *range, curves, *wall);
    }
    rep.files = files.iter().map(|p| p.display().to_string()).collect();
    Ok(rep)
}

/// The sweeps' jumps into the report, and a note for each sweep that found unstable orbits.
fn add_sweep_jumps(rep: &mut ContinuationReport, param: &Parameter, c: &Computed) {
    for (name, pts) in [("up", &c.up), ("down", &c.down)] {
        let (jumps, unstable) = report::jumps(name, pts, &c.branch);
        rep.sweep_jumps.extend(jumps);
        if !unstable.is_empty() {
            let v: Vec<String> = unstable.iter().map(|x| format_f64(*x)).collect();
            rep.notes.push(format!(
                "the {name} sweep found an unstable orbit at {} = {} {} (shooting converges to whichever orbit is near its start; the continuation says which are stable)",
                param.name(),
                v.join(", "),
                param.info.unit
            ));
        }
    }
}

/// `branch.csv`, `bifurcations.csv`, `sweep.csv`, `fold_curves.csv` and `branch.h5` (one group
/// per table).
fn write_tables(
    out: &Path,
    scenario_name: &str,
    source: &ScenarioSource,
    b: &Branch,
    (up, down): (&[SweepPoint], &[SweepPoint]),
    folds: Option<(&Vec<FoldCurve>, Option<Parameter>)>,
) -> Result<Vec<PathBuf>> {
    let info = b.parameter.info;
    let branch = report::branch_table(b);
    let special = report::special_table(b);
    let mut files = Vec::new();
    let path = out.join("branch.csv");
    branch.save_csv(&path)?;
    files.push(path);
    let path = out.join("bifurcations.csv");
    special.save_csv(&path)?;
    files.push(path);
    let up_t = report::sweep_table(info.key, info.unit, "up", up);
    let down_t = report::sweep_table(info.key, info.unit, "down", down);
    let mut groups: Vec<(&str, &str, &crate::output::Table)> = vec![
        (
            "branch",
            "branch of periodic orbits by pseudo-arclength continuation, in order of arclength",
            &branch,
        ),
        (
            "bifurcations",
            "special points of the branch: start, folds, period doublings, Neimark-Sacker points, grazing, end",
            &special,
        ),
    ];
    if !up.is_empty() || !down.is_empty() {
        let mut both = up_t.clone();
        both.append_rows(&down_t)?;
        let path = out.join("sweep.csv");
        both.save_csv(&path)?;
        files.push(path);
        groups.push(("sweep_up", "natural-parameter sweep, increasing", &up_t));
        groups.push(("sweep_down", "natural-parameter sweep, decreasing", &down_t));
    }
    let fold_t = folds.and_then(|(c, q)| {
        q.map(|q| report::fold_table([(info.key, info.unit), (q.info.key, q.info.unit)], c))
    });
    if let Some(t) = &fold_t {
        let path = out.join("fold_curves.csv");
        t.save_csv(&path)?;
        files.push(path);
        groups.push((
            "fold_curves",
            "fold curves in two parameters (curve numbers them; a cusp joins the two folds of a pair)",
            t,
        ));
    }
    let attrs = [
        (
            "missing",
            Attr::text("NaN marks a value not produced (see `error`)"),
        ),
        ("source", Attr::text(scenario_name)),
        ("scenario", Attr::text(source.text())),
        ("parameter", Attr::text(info.key)),
        ("range_start", Attr::F64(b.range.0)),
        ("range_stop", Attr::F64(b.range.1)),
        ("rtol", Attr::F64(b.map.rtol)),
    ];
    let h5 = out.join("branch.h5");
    let bytes = hdf5_tables(&attrs, None, &groups).map_err(|e| anyhow::anyhow!("HDF5: {e}"))?;
    write_atomic(&h5, &bytes)?;
    files.push(h5);
    Ok(files)
}

/// Runs of consecutive points with equal `flag`, as x, y with NaN between runs; each run
/// includes the first point of the next so the two styles meet.
fn runs(points: &[BranchPoint], want: bool) -> (Vec<f64>, Vec<f64>) {
    let (mut x, mut y) = (Vec::new(), Vec::new());
    for (i, w) in points.windows(2).enumerate() {
        // A segment is stable when both ends are.
        let stable = w[0].stable() && w[1].stable();
        if stable == want {
            let prev_same = i > 0 && {
                let v = &points[i - 1..=i];
                (v[0].stable() && v[1].stable()) == want
            };
            if !prev_same {
                if !x.is_empty() {
                    x.push(f64::NAN);
                    y.push(f64::NAN);
                }
                x.push(w[0].value);
                y.push(w[0].delta_amp_over_xb());
            }
            x.push(w[1].value);
            y.push(w[1].delta_amp_over_xb());
        }
    }
    (x, y)
}

fn branch_figure(file: &Path, b: &Branch, up: &[SweepPoint], down: &[SweepPoint]) -> Figure {
    let info = b.parameter.info;
    let amp = b.points.first().map_or(f64::NAN, |p| p.amplitude);
    let title = if info.key == "base.amplitude" {
        format!("periodic orbits vs {} ({})", info.key, stem(file))
    } else {
        format!(
            "periodic orbits vs {}, X_b = {:.3} µm ({})",
            info.key,
            amp * 1e6,
            stem(file)
        )
    };
    let values: Vec<f64> = b.points.iter().map(|p| p.value).collect();
    let (xf, x_label) = plot::axis_label(info.key, info.unit, &values);
    let in_unit = |x: Vec<f64>| -> Vec<f64> { x.iter().map(|v| v * xf).collect() };
    let mut fig =
        Figure::new(title, x_label, "|δ_A / X_b| (–)").with_legend(LegendPosition::UpperRight);
    let (xs, ys) = runs(&b.points, true);
    let (xu, yu) = runs(&b.points, false);
    let (xs, xu) = (in_unit(xs), in_unit(xu));
    fig = fig
        .with_series(Series::new("stable", xs, ys, Style::Line).with_color(0))
        .with_series(Series::new("unstable", xu, yu, Style::Dashed).with_color(0));
    // Up as rings, down as dots: where both sweeps found the same orbit, both stay visible.
    for (pts, name, color, style) in [
        (up, "sweep up", 1, Style::Rings),
        (down, "sweep down", 2, Style::Markers),
    ] {
        if pts.is_empty() {
            continue;
        }
        let (x, y): (Vec<f64>, Vec<f64>) = pts
            .iter()
            .filter_map(|p| {
                p.steady
                    .as_ref()
                    .map(|s| (p.value * xf, s.transfer_magnitude()))
            })
            .unzip();
        fig = fig.with_series(Series::new(name, x, y, style).with_color(color));
    }
    for (kind, name, color) in [
        (PointKind::Fold, "fold (multiplier +1)", 3),
        (PointKind::PeriodDoubling, "period doubling (−1)", 4),
        (PointKind::NeimarkSacker, "Neimark–Sacker", 5),
        (PointKind::BranchPoint, "branch point", 6),
        (PointKind::Grazing, "grazing", 7),
    ] {
        let (x, y): (Vec<f64>, Vec<f64>) = b
            .of_kind(kind)
            .map(|p| (p.value * xf, p.delta_amp_over_xb()))
            .unzip();
        if !x.is_empty() {
            fig = fig.with_series(Series::new(name, x, y, Style::Markers).with_color(color));
        }
    }
    fig
}

fn fold_figure(file: &Path, b: &Branch, q: &Parameter, curves: &[FoldCurve]) -> Figure {
    let info = b.parameter.info;
    // Both axes in the unit that suits their values (µm rather than 1e-6 m).
    let all = || curves.iter().flat_map(|c| c.points.iter());
    let xv: Vec<f64> = all().map(|p| p.values[0]).collect();
    let yv: Vec<f64> = all().map(|p| p.values[1]).collect();
    let (xf, x_label) = plot::axis_label(info.key, info.unit, &xv);
    let (yf, y_label) = plot::axis_label(q.name(), q.info.unit, &yv);
    // The title says what the figure holds: no curve, and why, when there is none.
    let title = match (
        curves.is_empty(),
        b.of_kind(PointKind::Fold).next().is_none(),
    ) {
        (false, _) => format!("fold curves: bistable between them ({})", stem(file)),
        (true, true) => format!(
            "no fold curve: the branch has no fold in range ({})",
            stem(file)
        ),
        (true, false) => format!("no fold curve could be followed ({})", stem(file)),
    };
    let mut fig = Figure::new(title, x_label, y_label).with_legend(LegendPosition::LowerRight);
    for (i, c) in curves.iter().enumerate() {
        let (x, y): (Vec<f64>, Vec<f64>) = c
            .points
            .iter()
            .map(|p| (p.values[0] * xf, p.values[1] * yf))
            .unzip();
        fig = fig
            .with_series(Series::new(format!("fold curve {i}"), x, y, Style::Line).with_color(i));
    }
    let (x, y): (Vec<f64>, Vec<f64>) = all()
        .filter(|p| p.kind == FoldPointKind::Cusp)
        .map(|p| (p.values[0] * xf, p.values[1] * yf))
        .unzip();
    if !x.is_empty() {
        fig = fig.with_series(Series::new("cusp", x, y, Style::Markers).with_color(3));
    }
    let q0 = curves
        .first()
        .and_then(|c| c.points.first())
        .map_or(f64::NAN, |p| p.values[1]);
    let (x, y): (Vec<f64>, Vec<f64>) = b
        .of_kind(PointKind::Fold)
        .map(|p| (p.value * xf, q0 * yf))
        .unzip();
    if !x.is_empty() {
        fig =
            fig.with_series(Series::new("folds of the branch", x, y, Style::Markers).with_color(4));
    }
    fig
}

fn print_report(file: &Path, r: &ContinuationReport) -> anyhow::Result<()> {
    outln!(
        "{}: branch of periodic orbits in {} over {}..{} {} — {} points, {} steps ({} refused), {} periods, {:.3} s",
        file.display(),
        r.parameter,
        format_f64(r.range[0]),
        format_f64(r.range[1]),
        r.unit,
        r.points,
        r.steps,
        r.rejected,
        r.periods,
        r.wall_s
    )?;
    let show = |label: &str, list: &[report::Marked]| {
        for m in list {
            let v = m.values.first().map_or(f64::NAN, |x| x.1);
            let mu = m
                .multipliers_abs
                .iter()
                .map(|x| format!("{x:.9}"))
                .collect::<Vec<_>>()
                .join(", ");
            outln!(
                "  {label:<16} {} = {} {}, |δ_A/X_b| = {:.5}, a_m = {:.6} mm, |μ| = {mu}",
                r.parameter,
                format_sig(v, 9),
                r.unit,
                m.delta_amp_over_xb,
                m.a_mean * 1e3
            )?;
        }
        Ok::<(), super::out::StdoutError>(())
    };
    show("fold", &r.folds)?;
    if r.folds.is_empty() {
        outln!("  no fold in range")?;
    }
    show("period doubling", &r.period_doublings)?;
    show("Neimark-Sacker", &r.neimark_sacker)?;
    show("branch point", &r.branch_points)?;
    show("grazing", &r.grazing)?;
    for j in &r.sweep_jumps {
        outln!(
            "  sweep {:<4} jumps between {} and {} {} (|δ_A/X_b| {:.4} → {})",
            j.direction,
            format_f64(j.from),
            format_f64(j.to),
            r.unit,
            j.delta_amp_over_xb_before,
            j.delta_amp_over_xb_after
                .map_or("missing".to_string(), |v| format!("{v:.4}"))
        )?;
    }
    if let (Some(k2), Some(curves)) = (&r.fold_parameter, &r.fold_curves) {
        outln!(
            "  {} fold curve(s) in ({}, {}), {:.3} s",
            curves.len(),
            r.parameter,
            k2,
            r.fold_wall_s.unwrap_or(f64::NAN)
        )?;
        if let Some(c) = &r.cusp {
            let v: Vec<String> = c
                .values
                .iter()
                .map(|(k, v)| format!("{k} = {}", format_sig(*v, 9)))
                .collect();
            outln!(
                "  cusp: {}, |δ_A/X_b| = {:.5}",
                v.join(", "),
                c.delta_amp_over_xb
            )?;
        }
    }
    for n in &r.notes {
        outln!("  {n}")?;
    }
    outln!("\nwrote:")?;
    for p in &r.files {
        outln!("  {p}")?;
    }
    Ok(())
}

//! `djkr accuracy`: speed versus accuracy. With a scenario FILE, a work-precision study of the
//! time-domain methods on that scene; with `--imposed-area`, quadrature nodes versus error of the
//! imposed-area cycle and the closed form's error map. Writes CSV, a markdown table and plots
//! into `--out`; prints the table.

use super::common::{
    limit_count, limits, load_scenario, out_name, positive_quantity, reject_unused, write_atomic,
    SetArgs,
};
use crate::accuracy::{self, Measure, StudyConfig};
use crate::plot;
use crate::scenario::checks;
use crate::scenario::Scenario;
use anyhow::{bail, Context, Result};
use clap::Args;
use djkr_core::beta_fit::log_space;
use djkr_core::dynamics::methods::method_name;
use djkr_core::dynamics::Method;
use djkr_core::error::ParamError;
use djkr_core::units::Dimension;
use std::path::{Path, PathBuf};

/// Flags of `djkr accuracy`.
#[derive(Args, Debug)]
pub struct AccuracyArgs {
    /// Scenario file (TOML) to study; not needed with --imposed-area.
    #[arg(required_unless_present = "imposed_area")]
    file: Option<PathBuf>,
    /// Methods, comma-separated: implicit, dp8, dopri5, dop853, auto
    /// [default: implicit,dp8,dopri5,dop853,auto].
    #[arg(long)]
    methods: Option<String>,
    /// Relative tolerances, comma-separated, each in (0, 1) (atol = --atol-ratio × rtol)
    /// [default: 1e-4,1e-6,1e-8,1e-10].
    #[arg(long)]
    tolerances: Option<String>,
    /// Timed runs per method and tolerance; the wall time reported is their median.
    #[arg(long, default_value = "3")]
    repeats: String,
    /// Tolerance of the reference run (implicit), checked by dp8 at the same tolerance
    /// [default: 1e-12].
    #[arg(long)]
    ref_rtol: Option<String>,
    /// atol / rtol for every run [default: 0.01].
    #[arg(long)]
    atol_ratio: Option<String>,
    /// Wall-clock budget of each studied run (a slower run is reported as failed)
    /// [default: 60s].
    #[arg(long, value_name = "TIME")]
    max_wall: Option<String>,
    /// Output directory [default: out/accuracy-<scenario name>, or out/accuracy-imposed-area].
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Overwrite files in --out that djkr did not write under the names this command writes;
    /// without it such a file stops the command before any work. Nothing else is touched.
    #[arg(long)]
    force: bool,
    /// Study the imposed-area method instead: quadrature nodes vs error, closed form vs exact.
    #[arg(long)]
    imposed_area: bool,
    /// With --imposed-area: tanh-sinh node counts, comma-separated (each 3..=2001)
    /// [default: 11,21,31,41,51,61,81,101,121,161].
    #[arg(long)]
    nodes: Option<String>,
    /// With --imposed-area: frequency of the closed-form map (sets a_A = v_max/ω)
    /// [default: 200].
    #[arg(long, value_name = "HZ")]
    freq: Option<String>,
    /// With --imposed-area: speed correction β of eq. (24) for the closed form [default: 2.5].
    #[arg(long)]
    beta: Option<String>,
    #[command(flatten)]
    set: SetArgs,
}

fn list<T>(flag: &str, text: &str, f: impl Fn(&str) -> Result<T, ParamError>) -> Result<Vec<T>> {
    let v: Vec<T> = text
        .split(',')
        .filter(|s| !s.trim().is_empty())
        .map(|s| f(s.trim()))
        .collect::<Result<_, _>>()?;
    if v.is_empty() {
        bail!(
            "{flag} = {}: needs at least one comma-separated value",
            djkr_core::text::excerpt(text)
        );
    }
    Ok(v)
}

fn count(flag: &str, text: &str, lo: usize, hi: usize) -> Result<usize, ParamError> {
    text.trim()
        .parse::<usize>()
        .ok()
        .filter(|n| (lo..=hi).contains(n))
        .ok_or_else(|| ParamError::new(flag, text, format!("must be an integer in {lo}..={hi}")))
}

/// Run `djkr accuracy`.
pub fn accuracy(a: &AccuracyArgs) -> Result<()> {
    if a.imposed_area {
        reject_scenario_flags(a)?;
        return imposed_area(a);
    }
    reject_unused(
        &[
            ("--nodes", a.nodes.is_some()),
            ("--freq", a.freq.is_some()),
            ("--beta", a.beta.is_some()),
        ],
        "without --imposed-area (they set the imposed-area study)",
    )?;
    let Some(file) = &a.file else {
        bail!("accuracy: give a scenario FILE, or --imposed-area");
    };
    let methods_text = a
        .methods
        .as_deref()
        .unwrap_or("implicit,dp8,dopri5,dop853,auto");
    let mut cfg = study_config(a, methods_text)?;
    cfg.validate().map_err(crate::error::Error::Param)?;
    let scn = load_scenario(file, &a.set)?;
    a.set.refuse_replaced(
        "accuracy",
        &[
            ("solver.rtol", "--tolerances"),
            ("solver.atol", "--atol-ratio"),
            ("solver.method", "--methods"),
            ("solver.max_wall_s", "--max-wall"),
        ],
    )?;
    cfg.methods = runnable_methods(&scn, &cfg.methods, methods_text, file)?;
    let out = a
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("out").join(format!("accuracy-{}", out_name(file))));
    super::common::claim_out(&out, &["work_precision.csv", "work_precision.md"], a.force)?;
    eprintln!(
        "reference: implicit at rtol {:e}, checked by dp8 …",
        cfg.reference_rtol
    );
    let study = accuracy::work_precision(&scn, &cfg, |i, n, m, rtol| {
        eprintln!("[{}/{}] {m} rtol {rtol:e}", i + 1, n);
    })
    .with_context(|| format!("{}", file.display()))?;
    write_study(&study, &out)
}

/// With `--imposed-area`: refuse the flags that set the study of a scenario FILE.
fn reject_scenario_flags(a: &AccuracyArgs) -> Result<()> {
    if !a.set.set.is_empty() {
        bail!("--set changes a scenario FILE's values; --imposed-area reads no scenario");
    }
    reject_unused(
        &[
            ("FILE", a.file.is_some()),
            ("--methods", a.methods.is_some()),
            ("--tolerances", a.tolerances.is_some()),
            ("--ref-rtol", a.ref_rtol.is_some()),
            ("--atol-ratio", a.atol_ratio.is_some()),
            ("--max-wall", a.max_wall.is_some()),
        ],
        "with --imposed-area (they set the study of a scenario FILE)",
    )
}

/// The study's settings from the flags (`methods_text`: `--methods` or its default), not yet
/// validated as a whole.
fn study_config(a: &AccuracyArgs, methods_text: &str) -> Result<StudyConfig> {
    let methods = list("--methods", methods_text, |s| {
        accuracy::parse_method("--methods", s)
    })?;
    limit_count(
        "--methods",
        methods_text,
        methods.len(),
        limits::ACCURACY_METHODS,
        "methods",
    )?;
    let tolerances_text = a.tolerances.as_deref().unwrap_or("1e-4,1e-6,1e-8,1e-10");
    let tolerances = list("--tolerances", tolerances_text, |s| {
        positive_quantity("--tolerances", s, Dimension::Dimensionless)
    })?;
    limit_count(
        "--tolerances",
        tolerances_text,
        tolerances.len(),
        limits::ACCURACY_TOLERANCES,
        "tolerances",
    )?;
    Ok(StudyConfig {
        methods,
        tolerances,
        repeats: count("--repeats", &a.repeats, 1, limits::ACCURACY_REPEATS)?,
        reference_rtol: positive_quantity(
            "--ref-rtol",
            a.ref_rtol.as_deref().unwrap_or("1e-12"),
            Dimension::Dimensionless,
        )?,
        atol_ratio: positive_quantity(
            "--atol-ratio",
            a.atol_ratio.as_deref().unwrap_or("0.01"),
            Dimension::Dimensionless,
        )?,
        max_wall_s: positive_quantity(
            "--max-wall",
            a.max_wall.as_deref().unwrap_or("60s"),
            Dimension::Time,
        )?,
        ..StudyConfig::default()
    })
}

/// The `methods` that can run the scene `scn` of `file`. The others are skipped, saying so (an
/// explicit method on a rate-independent law): a row per tolerance that can only fail is no
/// measurement. None left is an error.
fn runnable_methods(
    scn: &Scenario,
    methods: &[Method],
    methods_text: &str,
    file: &Path,
) -> Result<Vec<Method>> {
    let (runnable, skipped): (Vec<Method>, Vec<Method>) = methods.iter().partition(|&&m| {
        let mut s = scn.clone();
        s.solver.method = m;
        checks::setup_check(&s).is_ok()
    });
    if !skipped.is_empty() {
        let mut s = scn.clone();
        s.solver.method = skipped[0];
        let why = checks::setup_check(&s)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        let names: Vec<&str> = skipped.iter().map(|&m| method_name(m)).collect();
        eprintln!("skipping {} on {}: {why}", names.join(", "), file.display());
    }
    if runnable.is_empty() {
        bail!(
            "--methods = {}: none of them can run {} (see above)",
            methods_text,
            file.display()
        );
    }
    Ok(runnable)
}

/// Write the study's CSV, markdown table and plots into `out`; print the table and the files.
fn write_study(study: &accuracy::Study, out: &Path) -> Result<()> {
    let table = accuracy::study_table(study);
    std::fs::create_dir_all(out).with_context(|| format!("--out {}", out.display()))?;
    accuracy::work_precision_table(study).save_csv(&out.join("work_precision.csv"))?;
    write_atomic(&out.join("work_precision.md"), table.as_bytes())?;
    let (png, svg) = plot::render(
        &accuracy::study_figure(study, Measure::PullOffRelevant),
        &out.join("work_precision"),
    )?;
    let (png2, svg2) = plot::render(
        &accuracy::study_figure(study, Measure::PullOffForce),
        &out.join("work_precision_pull_off"),
    )?;
    outln!("{table}")?;
    print_written(
        out,
        &[png, svg, png2, svg2],
        &["work_precision.csv", "work_precision.md"],
    )?;
    Ok(())
}

fn print_written(out: &Path, plots: &[PathBuf], files: &[&str]) -> anyhow::Result<()> {
    outln!("wrote:")?;
    for f in files {
        outln!("  {}", out.join(f).display())?;
    }
    for p in plots {
        outln!("  {}", p.display())?;
    }
    Ok(())
}

fn imposed_area(a: &AccuracyArgs) -> Result<()> {
    let nodes_text = a
        .nodes
        .as_deref()
        .unwrap_or("11,21,31,41,51,61,81,101,121,161");
    let nodes = list("--nodes", nodes_text, |s| count("--nodes", s, 3, 2001))?;
    limit_count(
        "--nodes",
        nodes_text,
        nodes.len(),
        limits::ACCURACY_NODES,
        "node counts",
    )?;
    let repeats = count("--repeats", &a.repeats, 1, limits::ACCURACY_REPEATS)?;
    let freq = positive_quantity(
        "--freq",
        a.freq.as_deref().unwrap_or("200"),
        Dimension::Frequency,
    )?;
    let beta = positive_quantity(
        "--beta",
        a.beta.as_deref().unwrap_or("2.5"),
        Dimension::Dimensionless,
    )?;
    let out = a
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("out").join("accuracy-imposed-area"));
    super::common::claim_out(
        &out,
        &["quadrature.csv", "closed_form_map.csv", "imposed_area.md"],
        a.force,
    )?;

    eprintln!("quadrature study …");
    let q = accuracy::quadrature_study(&nodes, repeats);
    let mut table = format!(
        "Imposed-area cycle, tanh-sinh nodes vs worst error over {} cases (reference: graded \
         Gauss–Legendre, own uncertainty {:.1e})\n\n| nodes | worst F_m rel. error | worst δ \
         error / JKR scale | time per cycle | worst case |\n|---|---|---|---|---|\n",
        q.cases, q.reference_uncertainty
    );
    for r in &q.rows {
        table += &format!(
            "| {} | {:.1e} | {:.1e} | {} | {} |\n",
            r.nodes,
            r.worst_force_rel,
            r.worst_delta_scaled,
            accuracy::fmt_time(r.time_per_cycle_s),
            r.worst_case
        );
    }
    accuracy::quadrature_table(&q).save_csv(&out.join("quadrature.csv"))?;
    let (qp, qs) = plot::render(&accuracy::quadrature_figure(&q), &out.join("quadrature"))?;

    eprintln!("closed-form map …");
    let n_values: Vec<f64> = (1..=30).map(|i| 0.05 * i as f64).collect();
    let ratios = log_space(1e-2, 1e6, 33);
    let map = accuracy::closed_form_map(&n_values, &ratios, freq, beta)
        .map_err(crate::error::Error::Param)?;
    accuracy::closed_form_map_table(&map).save_csv(&out.join("closed_form_map.csv"))?;
    let (mp, ms) = plot::render_heatmap(
        &accuracy::closed_form_heatmap(&map, &n_values, &ratios, freq, beta),
        &out.join("closed_form_map"),
    )?;
    table += &format!(
        "\nClosed form (β = {beta}) vs exact pull-off at {freq} Hz: largest v_max/v0 with \
         |ln(A_exact/A_approx)| below 0.05 / 0.1 / 0.2 (all smaller speeds too), per n\n\n| n | \
         < 0.05 | < 0.1 | < 0.2 | worst |ln ratio| |\n|---|---|---|---|---|\n"
    );
    for &n in n_values.iter().step_by(2) {
        let row: Vec<_> = map.iter().filter(|p| (p.n - n).abs() < 1e-12).collect();
        let upto = |lim: f64| -> String {
            let mut best = None;
            for p in &row {
                match p.ln_ratio {
                    Some(v) if v.abs() < lim => best = Some(p.speed_ratio),
                    _ => break,
                }
            }
            best.map_or_else(|| "—".into(), |r| format!("{r:.1e}"))
        };
        let worst = row
            .iter()
            .filter_map(|p| p.ln_ratio)
            .map(f64::abs)
            .fold(0.0, f64::max);
        table += &format!(
            "| {n:.2} | {} | {} | {} | {worst:.2} |\n",
            upto(0.05),
            upto(0.1),
            upto(0.2)
        );
    }
    let failed = map.iter().filter(|p| p.ln_ratio.is_none()).count();
    if failed > 0 {
        table += &format!("\n{failed} grid points had no exact pull-off (grey in the map).\n");
    }
    write_atomic(&out.join("imposed_area.md"), table.as_bytes())?;
    outln!("{table}")?;
    print_written(
        &out,
        &[qp, qs, mp, ms],
        &["quadrature.csv", "closed_form_map.csv", "imposed_area.md"],
    )?;
    Ok(())
}

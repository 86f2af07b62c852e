//! The output reference's column tables (docs/guide/output.md, between its `GENERATED`
//! markers) come from the writers' own table builders: a unit test, since the builders are the
//! library's own. `DJKR_BLESS=1 cargo test --release docs_reference` rewrites them with the
//! other generated chapters (tests/it/docs_reference.rs).

use crate::output::table::Field;
use crate::output::test_tools::{check, root, splice};
use crate::output::{cycles, timeseries};
use crate::sweep::KeyColumn;

/// One Markdown table of columns: name, unit, type, description.
fn columns_table(title: &str, intro: &str, fields: &[Field]) -> String {
    let mut s = format!(
        "### {title}\n\n{intro}\n\n| column | unit | type | description |\n|---|---|---|---|\n"
    );
    for f in fields {
        let unit = if f.unit.is_empty() {
            "text".to_string()
        } else {
            format!("`{}`", f.unit)
        };
        s.push_str(&format!(
            "| `{}` | {} | {} | {} |\n",
            f.name,
            unit,
            format!("{:?}", f.kind).to_lowercase(),
            f.description.replace('|', "\\|")
        ));
    }
    s
}

/// The output reference's column tables, from the writers' own table builders.
fn output_columns() -> String {
    let amp = [KeyColumn {
        name: "base.amplitude".into(),
        unit: Some("m".into()),
    }];
    let map = djkr_core::steady::map::ShortcutMap {
        frequencies: Vec::new(),
        amplitudes: Vec::new(),
        cells: Vec::new(),
        cycles: 0,
        wall_s: 0.0,
    };
    let tables = [
        (
            "`run.h5` root datasets, `timeseries.csv`",
            "One row per sample (`djkr run`; `--csv` for the CSV). Header cells are `name [unit]`.",
            timeseries::series_schema(),
        ),
        (
            "`run.h5` `events/`, `events.csv`",
            "One row per event; the state at the event follows the time-series names.",
            timeseries::events_table(&[]).schema(),
        ),
        (
            "`run.h5` `cycles/`, `cycles.csv`",
            "One row per base period under vibration; the harmonic convention is above.",
            cycles::cycle_schema(),
        ),
        (
            "`run.h5` `gaps/`, `gaps.csv`",
            "One row per gap that envelope following left in the time series (see \"Gaps\").",
            timeseries::gaps_table(&[]).schema(),
        ),
        (
            "`sweep.csv`, `sweep.h5`",
            "One row per run of `djkr sweep`; one column per swept key (here `base.amplitude`) \
             after `point` and `member`.",
            crate::sweep::row::row_schema(&amp),
        ),
        (
            "`points.csv`",
            "One row per point of a sweep: statistics over its ensemble members (here a sweep of \
             `base.amplitude`).",
            crate::sweep::stats::points_table(&amp, &[]).schema(),
        ),
        (
            "`resonance.csv`, `resonance.h5`",
            "One row per frequency and direction of `djkr resonance`.",
            crate::reports::steady::sweeps_table(&[]).schema(),
        ),
        (
            "`shortcut-map.csv`, `shortcut-map.h5` `cells/`",
            "One row per cell of `djkr shortcut-map`, row-major in amplitude; NaN where missing.",
            crate::reports::steady::map_table(&map).schema(),
        ),
        (
            "`continue`: `sweep.csv`",
            "The up and down sweeps overlaid on a branch (here continued in `base.frequency`).",
            crate::reports::continuation::sweep_table("base.frequency", "Hz", "up", &[]).schema(),
        ),
        (
            "`continue --fold-param`: `fold_curves.csv`",
            "One row per point of a fold curve (here in `base.frequency` and `base.amplitude`).",
            crate::reports::continuation::fold_table(
                [("base.frequency", "Hz"), ("base.amplitude", "m")],
                &[],
            )
            .schema(),
        ),
    ];
    let branch = example_branch();
    let tables = tables.into_iter().chain([
        (
            "`continue`: `branch.csv`, `branch.h5`",
            "One row per point of the branch of periodic orbits (here continued in \
             `base.frequency`).",
            crate::reports::continuation::branch_table(&branch).schema(),
        ),
        (
            "`continue`: `bifurcations.csv`",
            "One row per special point of the branch (folds, period doublings, Neimark–Sacker \
             points, ends).",
            crate::reports::continuation::special_table(&branch).schema(),
        ),
    ]);
    let mut s = String::new();
    for (title, intro, fields) in tables {
        s.push('\n');
        s.push_str(&columns_table(title, intro, &fields));
    }
    s
}

/// A short branch of `scenarios/resonance-400hz.toml` in `base.frequency` (a fraction of a
/// second): the branch tables' columns depend on the parameter, so they come from a real one.
fn example_branch() -> djkr_core::continuation::branch::Branch {
    use crate::scenario::family::{family, parameter};
    use djkr_core::continuation::branch;
    let source = crate::scenario::parse::ScenarioSource::read(
        &root().join("scenarios/resonance-400hz.toml"),
    )
    .expect("bundled scenario");
    let param = parameter("--param", "base.frequency").expect("parameter");
    let family = family(&source, &[], vec![param], 1e-10).expect("family");
    branch::continue_branch(
        &family,
        (380.0, 390.0),
        &branch::Settings::default(),
        &mut |_| {},
    )
    .expect("a short branch")
}

#[test]
fn output_column_tables_are_generated_from_the_writers() {
    let rel = "docs/guide/output.md";
    let doc = std::fs::read_to_string(root().join(rel)).expect("output.md");
    check(rel, &splice(&doc, "output columns", &output_columns()));
}

//! The scenario side of a fit: a free key's starting value from the scenario file or its
//! `--set` ([`initial_value`]), and the scenario with the estimates written in (`fitted.toml`,
//! [`fitted_toml`]).

use super::free::FreeKey;
use crate::output::table::format_f64;
use crate::scenario::overrides::{Override, SetKey};
use crate::scenario::parse::ScenarioSource;
use crate::words::{input_value, set_item};
use djkr_core::units::{parse_quantity, Dimension};

/// A number from a TOML value as a scenario file holds it: a number (SI) or a string with
/// units.
fn toml_number(v: &toml::Value, key: &SetKey, dim: Dimension) -> Result<f64, String> {
    match v {
        toml::Value::Float(x) => Ok(*x),
        toml::Value::Integer(i) => Ok(*i as f64),
        toml::Value::String(s) => parse_quantity(&key.to_string(), s, dim)
            .map_err(|e| format!("{key} = '{}': {}", djkr_core::text::excerpt(s), e.allowed)),
        other => Err(format!(
            "{key} = {}: not a number",
            djkr_core::text::excerpt(&other.to_string())
        )),
    }
}

/// The starting value (SI) of a free key: the `--set` override's if one sets it, else the
/// scenario file's. A key the file does not give has no starting value (the parser's default is
/// not a measured value): the message says to give one with `--set`.
pub(crate) fn initial_value(
    source: &ScenarioSource,
    fixed: &[Override],
    free: &FreeKey,
) -> Result<f64, String> {
    let key = free.key;
    if let Some(o) = fixed.iter().find(|o| o.key() == key) {
        return toml_number(o.value(), &key, free.dim);
    }
    let table: toml::Table = source
        .text()
        .parse()
        .map_err(|e| format!("{}: {e}", source.name()))?;
    let section = match (key.section(), key.index()) {
        (None, _) => Some(&table),
        (Some(s), None) => table.get(s).and_then(toml::Value::as_table),
        (Some(s), Some(i)) => table
            .get(s)
            .and_then(toml::Value::as_array)
            .and_then(|a| a.get(i))
            .and_then(toml::Value::as_table),
    };
    let missing = || {
        format!(
            "{}: {} does not give {key}: give its starting value with {}",
            input_value("free", &free.given),
            source.name(),
            set_item(&format!("{key}=VALUE"))
        )
    };
    let v = section
        .and_then(|t| t.get(key.name()))
        .ok_or_else(missing)?;
    toml_number(v, &key, free.dim).map_err(|m| format!("{}: {m}", source.name()))
}

/// The scenario with the estimates: the file's text with the fixed `--set` overrides and the
/// free keys at `values` written in, headed by a comment saying where it came from. The file's
/// comments and layout are kept; a value written in gets a trailing comment saying so and what
/// the file had. A tabulated law's relative `adhesion.file` is written as the absolute path it
/// named (relative to the scenario file), so that the fitted file runs from any folder. `djkr run`
/// of it with a data row's conditions as `--set` reproduces that row's fitted value (the numbers
/// are written in shortest round-trip form).
pub(crate) fn fitted_toml(
    source: &ScenarioSource,
    fixed: &[Override],
    free: &[FreeKey],
    values: &[f64],
    header: &str,
) -> Result<String, String> {
    let mut all: Vec<Override> = fixed.to_vec();
    for (f, &x) in free.iter().zip(values) {
        all.push(Override::from_key(f.key, x).map_err(|e| e.to_string())?);
    }
    // The checks (a key set twice, a stage the file lacks) are the parser's.
    let mut table: toml::Table = source
        .text()
        .parse()
        .map_err(|e| format!("{}: {e}", source.name()))?;
    crate::scenario::overrides::apply(&mut table, &all, &crate::words::Source::file(source.name()))
        .map_err(|e| e.to_string())?;
    let mut doc: toml_edit::DocumentMut = source
        .text()
        .parse()
        .map_err(|e| format!("{}: {e}", source.name()))?;
    for (n, o) in all.iter().enumerate() {
        let how = if n < fixed.len() {
            "fixed by an override"
        } else {
            "fitted"
        };
        let text = match o.value() {
            toml::Value::Float(x) => toml_float(*x),
            v => v.to_string(),
        };
        let value: toml_edit::Value = text.parse().map_err(|e| format!("{o}: {e}"))?;
        write_key(&mut doc, o.key(), value, how)?;
    }
    // A relative law table, resolved as the parser resolves it.
    let file = table
        .get("adhesion")
        .and_then(|a| a.get("file"))
        .and_then(toml::Value::as_str);
    if let (Some(file), Some(dir)) = (file, source.base_dir()) {
        if std::path::Path::new(file).is_relative() {
            let path = dir.join(file);
            let path = std::fs::canonicalize(&path)
                .or_else(|_| std::path::absolute(&path))
                .map_err(|e| format!("adhesion.file = '{file}': {e}"))?;
            let shown = path.to_string_lossy().into_owned();
            let key = SetKey::parse("adhesion.file").map_err(|e| e.to_string())?;
            write_key(
                &mut doc,
                key,
                shown.into(),
                "resolved from the scenario's folder",
            )?;
        }
    }
    let mut out = String::new();
    for line in header.lines() {
        out.push_str("# ");
        out.push_str(line);
        out.push('\n');
    }
    out.push('\n');
    out.push_str(&doc.to_string());
    Ok(out)
}

/// Write `value` at `key` of `doc` (a section created if the file lacks it; the stage exists, as
/// [`crate::scenario::overrides::apply`] checked), with a trailing comment: `how`, and what the
/// file had.
fn write_key(
    doc: &mut toml_edit::DocumentMut,
    key: SetKey,
    mut value: toml_edit::Value,
    how: &str,
) -> Result<(), String> {
    let missing = || format!("{key}: no such place in the file");
    let target: &mut dyn toml_edit::TableLike = match (key.section(), key.index()) {
        (None, _) => doc.as_table_mut(),
        (Some(s), None) => doc
            .entry(s)
            .or_insert_with(toml_edit::table)
            .as_table_like_mut()
            .ok_or_else(missing)?,
        (Some(s), Some(i)) => match doc.get_mut(s).ok_or_else(missing)? {
            toml_edit::Item::ArrayOfTables(a) => a.get_mut(i).ok_or_else(missing)?,
            toml_edit::Item::Value(toml_edit::Value::Array(a)) => a
                .get_mut(i)
                .and_then(toml_edit::Value::as_inline_table_mut)
                .ok_or_else(missing)?,
            _ => return Err(missing()),
        },
    };
    let was = target.get(key.name()).and_then(toml_edit::Item::as_value);
    let note = match was {
        Some(w) => {
            // The file's own trailing comment, if any, follows.
            let comment = w
                .decor()
                .suffix()
                .and_then(|s| s.as_str())
                .map_or("", str::trim);
            let bare = w.clone().decorated("", "").to_string();
            format!("  # {how}; the file had {bare} {comment}")
                .trim_end()
                .to_string()
        }
        None => format!("  # {how}; the file did not give it"),
    };
    value.decor_mut().set_prefix(" ");
    value.decor_mut().set_suffix(note);
    // In place where the key exists, so that the key keeps its own decor (the comment lines
    // above it).
    match target.get_mut(key.name()) {
        Some(item) => *item = toml_edit::Item::Value(value),
        None => {
            target.insert(key.name(), toml_edit::Item::Value(value));
        }
    }
    Ok(())
}

/// A finite float as TOML text that parses back to the same bits ([`format_f64`]: `6.1e-5`,
/// not `0.000061`), with a point where it would otherwise read as an integer.
fn toml_float(x: f64) -> String {
    let t = format_f64(x);
    if t.contains(['.', 'e']) {
        t
    } else {
        format!("{t}.0")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    /// The fitted file keeps the scenario's comments and layout, carries the estimates and the
    /// `--set` values with a comment each, and means what `apply` of the same overrides means.
    #[test]
    fn fitted_toml_keeps_the_files_comments_and_means_the_overridden_table() {
        let text = "# The rig of the lab's run 12.\nversion = 1\n[material]\nK = 9.33e6\n\
                    R = 0.051\nw0 = 0.240\n[adhesion]\nlaw = \"gent-schultz\"\n\
                    # from the rate sweep\nv0 = \"44.5 um/s\"  # first guess\nn = 0.531\n\
                    [[stage]]\nkind = \"hold\"\nduration = 0.05\n";
        let source = ScenarioSource::parse(text, "lab.toml", None).unwrap();
        let fixed = vec![Override::parse("stage[0].duration=0.1").unwrap()];
        let free = vec![
            FreeKey::parse("adhesion.v0").unwrap(),
            FreeKey::parse("damping.c").unwrap(),
        ];
        let out = fitted_toml(&source, &fixed, &free, &[6.1e-5, 0.07], "fitted by a test").unwrap();
        for kept in [
            "# fitted by a test\n",
            "# The rig of the lab's run 12.\n",
            "# from the rate sweep\nv0 = 6.1e-5  # fitted; the file had \"44.5 um/s\" # first guess\n",
            "n = 0.531\n",
            "duration = 0.1  # fixed by an override; the file had 0.05\n",
            "c = 0.07  # fitted; the file did not give it\n",
        ] {
            assert!(out.contains(kept), "{kept:?} not in:\n{out}");
        }
        let mut expected: toml::Table = text.parse().unwrap();
        let mut all = fixed.clone();
        all.push(Override::from_key(free[0].key, 6.1e-5).unwrap());
        all.push(Override::from_key(free[1].key, 0.07).unwrap());
        crate::scenario::overrides::apply(
            &mut expected,
            &all,
            &crate::words::Source::file("lab.toml"),
        )
        .unwrap();
        let got: toml::Table = out.parse().unwrap();
        assert_eq!(got, expected);
    }

    /// A tabulated law's relative table is written as the absolute path the scenario named, so
    /// that the fitted file in another folder builds the same law.
    #[test]
    fn fitted_toml_resolves_a_relative_law_table() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/scenarios/good");
        let source = ScenarioSource::read(&dir.join("tabulated.toml")).unwrap();
        let free = vec![FreeKey::parse("damping.c").unwrap()];
        let out = fitted_toml(&source, &[], &free, &[0.05], "h").unwrap();
        let table = std::fs::canonicalize(dir.join("law-table.csv")).unwrap();
        let table: toml::Value = table.to_string_lossy().into_owned().into();
        assert!(
            out.contains(&format!(
                "file = {table}  # resolved from the scenario's folder; the file had \"law-table.csv\""
            )),
            "{out}"
        );
        let elsewhere = tempfile::tempdir().unwrap();
        let again = ScenarioSource::parse(&out, "fitted.toml", Some(elsewhere.path()))
            .unwrap()
            .scenario(&[])
            .unwrap();
        let original = source.scenario(&[]).unwrap();
        assert_eq!(again.rig.law, original.rig.law);
    }
}

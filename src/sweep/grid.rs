//! The points of a sweep: the Cartesian grid of its keys' values (the first key varies slowest,
//! as nested loops in the order the keys are given), or with `zip` the keys' values taken
//! together, the i-th point the i-th value of each.

use crate::scenario::overrides::{Override, SetKey};

use super::spec::{key_kind, parse_spec, KeyCell, KeyKind, SpecError, SpecForm, SpecValue};

/// Most runs (points × members) a sweep may have: the rows are held in memory until the final
/// tables are written (about 0.3 kB each).
pub const MAX_RUNS: usize = 10_000_000;

/// One swept key and its values.
#[derive(Debug, Clone, PartialEq)]
pub struct Axis {
    /// The key.
    pub key: SetKey,
    /// The SPEC as given.
    pub spec: String,
    /// List or range.
    pub form: SpecForm,
    /// The values, in order.
    pub values: Vec<SpecValue>,
}

impl Axis {
    /// Parse `KEY=SPEC` as typed after `--set`.
    pub fn parse(arg: &str) -> Result<Axis, SpecError> {
        let err = |message: String| SpecError {
            set: arg.to_string(),
            message,
        };
        let Some((k, spec)) = arg.split_once('=') else {
            return Err(err(
                "expected KEY=SPEC, e.g. base.amplitude=10um,30um,60um or base.frequency=200:400:3"
                    .into(),
            ));
        };
        let key = SetKey::parse(k.trim()).map_err(|e| err(e.message))?;
        let (form, values) = parse_spec(&key, spec, arg)?;
        Ok(Axis {
            key,
            spec: spec.trim().to_string(),
            form,
            values,
        })
    }

    /// The column's unit (`None`: a text column).
    pub fn unit(&self) -> Option<&'static str> {
        match key_kind(&self.key) {
            Some(KeyKind::Number { unit, .. }) => Some(unit),
            _ => None,
        }
    }

    /// `KEY=SPEC`.
    pub fn shown(&self) -> String {
        format!("{}={}", self.key, self.spec)
    }
}

/// The points of a sweep.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Grid {
    axes: Vec<Axis>,
    zip: bool,
    points: usize,
}

impl Grid {
    /// The grid of `axes` (Cartesian, or paired with `zip`). Without axes it has one point: the
    /// scenario as written. Each key may be swept once; zipped keys need as many values each.
    pub fn new(axes: Vec<Axis>, zip: bool) -> Result<Grid, SpecError> {
        for (i, a) in axes.iter().enumerate() {
            if let Some(first) = axes[..i].iter().find(|b| b.key == a.key) {
                return Err(SpecError {
                    set: a.shown(),
                    message: format!(
                        "{} is already swept by {}; give each key once",
                        a.key,
                        crate::words::axis_item(&first.shown())
                    ),
                });
            }
        }
        let points = if zip {
            let n = axes.first().map_or(1, |a| a.values.len());
            if let Some(a) = axes.iter().find(|a| a.values.len() != n) {
                return Err(SpecError {
                    set: a.shown(),
                    message: format!(
                        "«zip» pairs the keys' values, so each needs as many: {} has {}, {} has {n}",
                        a.key,
                        a.values.len(),
                        axes[0].key
                    ),
                });
            }
            n
        } else {
            axes.iter()
                .try_fold(1usize, |n, a| n.checked_mul(a.values.len()))
                .filter(|n| *n <= MAX_RUNS)
                .ok_or_else(|| SpecError {
                    set: axes[0].shown(),
                    message: if axes.len() > 1 {
                        format!(
                            "with {}: the grid has more than {MAX_RUNS} points",
                            axes[1..]
                                .iter()
                                .map(|a| crate::words::axis_item(&a.shown()))
                                .collect::<Vec<_>>()
                                .join(" ")
                        )
                    } else {
                        format!("the grid has more than {MAX_RUNS} points")
                    },
                })?
        };
        Ok(Grid { axes, zip, points })
    }

    /// The swept keys, in the order given.
    pub fn axes(&self) -> &[Axis] {
        &self.axes
    }

    /// True when the keys are paired (`--zip`).
    pub fn zip(&self) -> bool {
        self.zip
    }

    /// Number of points.
    pub fn points(&self) -> usize {
        self.points
    }

    /// The index of each axis's value at `point` (the last axis varies fastest).
    pub fn indices(&self, point: usize) -> Vec<usize> {
        if self.zip {
            return vec![point; self.axes.len()];
        }
        let mut rest = point;
        let mut idx = vec![0; self.axes.len()];
        for (i, a) in self.axes.iter().enumerate().rev() {
            let n = a.values.len().max(1);
            idx[i] = rest % n;
            rest /= n;
        }
        idx
    }

    /// The overrides that make `point` (one per key, in the order given).
    pub fn overrides(&self, point: usize) -> Vec<Override> {
        self.axes
            .iter()
            .zip(self.indices(point))
            .filter_map(|(a, i)| Override::from_key(a.key, a.values[i].set.clone()).ok())
            .collect()
    }

    /// The keys' values at `point`, as the tables hold them.
    pub fn cells(&self, point: usize) -> Vec<KeyCell> {
        self.axes
            .iter()
            .zip(self.indices(point))
            .map(|(a, i)| a.values[i].cell.clone())
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(sets: &[&str], zip: bool) -> Result<Grid, SpecError> {
        let axes = sets
            .iter()
            .map(|s| Axis::parse(s))
            .collect::<Result<_, _>>()?;
        Grid::new(axes, zip)
    }

    #[test]
    fn cartesian_in_the_order_given_and_zip() {
        let g = grid(
            &["base.frequency=200,300", "base.amplitude=1um:3um:3"],
            false,
        )
        .unwrap();
        assert_eq!(g.points(), 6);
        assert_eq!(g.indices(0), vec![0, 0]);
        assert_eq!(g.indices(1), vec![0, 1]);
        assert_eq!(g.indices(3), vec![1, 0]);
        let o: Vec<String> = g.overrides(4).iter().map(ToString::to_string).collect();
        assert_eq!(o[0], "base.frequency=300");
        assert!(o[1].starts_with("base.amplitude=2"), "{o:?}");
        let z = grid(
            &["base.frequency=200,300,400", "base.amplitude=1um,2um,3um"],
            true,
        )
        .unwrap();
        assert_eq!(z.points(), 3);
        assert_eq!(z.indices(2), vec![2, 2]);
        assert_eq!(grid(&[], false).unwrap().points(), 1);
    }

    #[test]
    fn bad_grids_are_named() {
        let e = grid(&["base.frequency=200,300", "base.frequency=400"], false).unwrap_err();
        assert!(e.to_string().contains("already swept"), "{e}");
        let e = grid(&["base.frequency=200,300", "base.amplitude=1um"], true).unwrap_err();
        let e = e.in_words(&crate::words::TestFlags);
        assert!(e.contains("--zip pairs"), "{e}");
        let e = Axis::parse("base.amplitud=1um")
            .unwrap_err()
            .in_words(&crate::words::TestFlags);
        assert!(
            e.starts_with("--set base.amplitud=1um: unknown key; [base] takes amplitude"),
            "{e}"
        );
        let e = Axis::parse("base.amplitude")
            .unwrap_err()
            .in_words(&crate::words::TestFlags);
        assert!(e.contains("expected KEY=SPEC"), "{e}");
        let e = grid(
            &[
                "material.K=1:2:1000",
                "material.R=1:2:1000",
                "material.w0=1:2:1000",
            ],
            false,
        )
        .unwrap_err();
        assert!(e.to_string().contains("more than"), "{e}");
    }
}

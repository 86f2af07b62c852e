//! One row per point (`points.csv`): the members' statistics of the pull-off force and
//! amplification.
//!
//! Columns: `point`, the swept keys, `members` (rows of the point), `failed` (of them, runs that
//! failed), then for `pull_off_force` (N) and `pull_off_amplification` (1) each `_mean`, `_std`
//! (sample standard deviation, n − 1; NaN below two members), `_min`, `_max`, `_q05`, `_q50`,
//! `_q95` (quantiles by linear interpolation between order statistics, numpy's default), over the
//! members that ran (finite values of rows with status ok; NaN when there are none). The
//! standard error of the mean is `_std / sqrt(members - failed)`.

use crate::output::table::{Column, Data, Table};

use super::row::{KeyColumn, Row};
use super::spec::KeyCell;

/// Statistics of one quantity over a point's members.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Summary {
    /// Number of values.
    pub n: usize,
    /// Mean.
    pub mean: f64,
    /// Sample standard deviation (n − 1; NaN for n < 2).
    pub std: f64,
    /// Smallest value.
    pub min: f64,
    /// Largest value.
    pub max: f64,
    /// 5 % quantile.
    pub q05: f64,
    /// Median.
    pub q50: f64,
    /// 95 % quantile.
    pub q95: f64,
}

impl Summary {
    /// The statistics of the finite values of `values` (NaN when there are none).
    pub fn of(values: impl IntoIterator<Item = f64>) -> Summary {
        let mut v: Vec<f64> = values.into_iter().filter(|x| x.is_finite()).collect();
        v.sort_by(f64::total_cmp);
        let n = v.len();
        let nan = f64::NAN;
        if n == 0 {
            return Summary {
                n,
                mean: nan,
                std: nan,
                min: nan,
                max: nan,
                q05: nan,
                q50: nan,
                q95: nan,
            };
        }
        let mean = v.iter().sum::<f64>() / n as f64;
        let std = if n < 2 {
            nan
        } else {
            (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
        };
        Summary {
            n,
            mean,
            std,
            min: v[0],
            max: v[n - 1],
            q05: quantile(&v, 0.05),
            q50: quantile(&v, 0.5),
            q95: quantile(&v, 0.95),
        }
    }

    /// Standard error of the mean, std/√n (NaN for n < 2).
    pub fn sem(&self) -> f64 {
        self.std / (self.n as f64).sqrt()
    }

    fn fields(&self) -> [f64; 7] {
        [
            self.mean, self.std, self.min, self.max, self.q05, self.q50, self.q95,
        ]
    }
}

/// Linear interpolation between order statistics (numpy's default): `sorted` non-empty.
fn quantile(sorted: &[f64], q: f64) -> f64 {
    let h = (sorted.len() - 1) as f64 * q;
    let lo = h.floor() as usize;
    let hi = (lo + 1).min(sorted.len() - 1);
    sorted[lo] + (h - lo as f64) * (sorted[hi] - sorted[lo])
}

/// One point's statistics.
#[derive(Debug, Clone, PartialEq)]
pub struct PointStats {
    /// Point index.
    pub point: usize,
    /// The swept keys' values.
    pub keys: Vec<KeyCell>,
    /// Rows of the point.
    pub members: usize,
    /// Of them, runs that failed.
    pub failed: usize,
    /// Pull-off force (N).
    pub force: Summary,
    /// Pull-off amplification.
    pub amplification: Summary,
}

/// The points of `rows` (any order), in point order.
pub fn point_stats(rows: &[Row]) -> Vec<PointStats> {
    let mut sorted: Vec<&Row> = rows.iter().collect();
    sorted.sort_by_key(|r| (r.point, r.member));
    let mut out = Vec::new();
    for chunk in sorted.chunk_by(|a, b| a.point == b.point) {
        let ok: Vec<_> = chunk
            .iter()
            .filter_map(|r| r.result.as_ref().ok())
            .collect();
        out.push(PointStats {
            point: chunk[0].point,
            keys: chunk[0].keys.clone(),
            members: chunk.len(),
            failed: chunk.len() - ok.len(),
            force: Summary::of(ok.iter().map(|n| n.pull_off_force)),
            amplification: Summary::of(ok.iter().map(|n| n.pull_off_amplification)),
        });
    }
    out
}

const STATS: [&str; 7] = ["mean", "std", "min", "max", "q05", "q50", "q95"];

/// The points as the `points.csv` table.
pub fn points_table(keys: &[KeyColumn], points: &[PointStats]) -> Table {
    let mut cols = vec![Column::i64(
        "point",
        "1",
        "point index (grid order, from 0)",
        points.iter().map(|p| p.point as i64).collect(),
    )];
    for (j, k) in keys.iter().enumerate() {
        cols.push(match &k.unit {
            Some(u) => Column::f64(
                &k.name,
                u,
                format!("swept key {} (SI)", k.name),
                points
                    .iter()
                    .map(|p| p.keys.get(j).and_then(KeyCell::num).unwrap_or(f64::NAN))
                    .collect(),
            ),
            None => Column::text(
                &k.name,
                format!("swept key {}", k.name),
                points
                    .iter()
                    .map(|p| p.keys.get(j).map(ToString::to_string).unwrap_or_default())
                    .collect(),
            ),
        });
    }
    cols.push(Column::i64(
        "members",
        "1",
        "runs of the point",
        points.iter().map(|p| p.members as i64).collect(),
    ));
    cols.push(Column::i64(
        "failed",
        "1",
        "runs of the point that failed",
        points.iter().map(|p| p.failed as i64).collect(),
    ));
    for (name, unit, get) in [
        (
            "pull_off_force",
            "N",
            (|p: &PointStats| p.force) as fn(&PointStats) -> Summary,
        ),
        ("pull_off_amplification", "1", |p: &PointStats| {
            p.amplification
        }),
    ] {
        for (s, stat) in STATS.iter().enumerate() {
            cols.push(Column::of(
                crate::output::table::Field::f64(
                    format!("{name}_{stat}"),
                    unit,
                    format!("{stat} of {name} over the members that ran"),
                ),
                Data::F64(points.iter().map(|p| get(p).fields()[s]).collect()),
            ));
        }
    }
    Table::from_fixed(cols)
}

#[cfg(test)]
#[allow(clippy::float_cmp)] // exact small sums
mod tests {
    use super::*;

    #[test]
    fn summary_matches_numpy() {
        let s = Summary::of([4.0, 1.0, 3.0, 2.0, f64::NAN, 5.0]);
        assert_eq!((s.n, s.mean, s.min, s.max, s.q50), (5, 3.0, 1.0, 5.0, 3.0));
        assert!((s.std - 2.5f64.sqrt()).abs() < 1e-15);
        // numpy.quantile([1,2,3,4,5], 0.05) = 1.2, 0.95 -> 4.8
        assert!((s.q05 - 1.2).abs() < 1e-12 && (s.q95 - 4.8).abs() < 1e-12);
        let one = Summary::of([2.0]);
        assert!(one.std.is_nan() && one.mean == 2.0 && one.q95 == 2.0);
        assert!(Summary::of([]).mean.is_nan());
    }
}

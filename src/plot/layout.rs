//! The pixel geometry of a figure's data, and where its legend goes.
//!
//! Every series is turned into primitives in pixel coordinates of the plotting area (origin at
//! its top left, y down) before anything is drawn: stroked paths, filled polygons and markers.
//! The same primitives are drawn and tested against candidate legend boxes, so the legend is
//! placed where it covers none of what is drawn ([`place_legend`]: the emptiest corner, and when
//! every corner covers data, outside the plotting area, on its right).
//!
//! A line denser than the pixels (more than two samples per pixel column it spans, abscissae in
//! order) is drawn as a band from the smallest to the largest value of each pixel column
//! ([`column_band`]), as an oscilloscope does: a polyline through thinned samples aliases into
//! moiré that reads as beating, a band shows every value the samples took.

use super::look::Shape;

/// A point in pixels of the plotting area.
pub type Px = (i32, i32);

/// What is drawn of a series, in pixels of the plotting area.
#[derive(Debug, Clone, PartialEq)]
pub enum Prim {
    /// A stroked open path (`width` px wide).
    Path {
        /// Vertices in order.
        points: Vec<Px>,
        /// Stroke width (px).
        width: u32,
    },
    /// A filled polygon (a dense line's band).
    Fill {
        /// Vertices in order (closed implicitly).
        points: Vec<Px>,
    },
    /// A marker centred at `at`, `size` px from centre to its outline.
    Marker {
        /// Centre.
        at: Px,
        /// Outline.
        shape: Shape,
        /// Half-width (px).
        size: i32,
        /// Filled (else an outline of `width` px).
        filled: bool,
        /// Outline width when not filled (px).
        width: u32,
    },
}

/// An axis-aligned box in pixels: left, top, right, bottom (inclusive).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Rect {
    /// Left edge.
    pub x0: i32,
    /// Top edge.
    pub y0: i32,
    /// Right edge.
    pub x1: i32,
    /// Bottom edge.
    pub y1: i32,
}

impl Rect {
    fn grow(self, d: i32) -> Self {
        Self {
            x0: self.x0 - d,
            y0: self.y0 - d,
            x1: self.x1 + d,
            y1: self.y1 + d,
        }
    }

    fn contains(self, (x, y): Px) -> bool {
        x >= self.x0 && x <= self.x1 && y >= self.y0 && y <= self.y1
    }

    fn overlaps(self, o: Rect) -> bool {
        self.x0 <= o.x1 && o.x0 <= self.x1 && self.y0 <= o.y1 && o.y0 <= self.y1
    }
}

/// True when the segment a–b meets `r` (Liang–Barsky clipping).
fn segment_meets(a: Px, b: Px, r: Rect) -> bool {
    let (x0, y0) = (f64::from(a.0), f64::from(a.1));
    let (dx, dy) = (f64::from(b.0) - x0, f64::from(b.1) - y0);
    let (mut t0, mut t1) = (0.0_f64, 1.0_f64);
    for (p, q) in [
        (-dx, x0 - f64::from(r.x0)),
        (dx, f64::from(r.x1) - x0),
        (-dy, y0 - f64::from(r.y0)),
        (dy, f64::from(r.y1) - y0),
    ] {
        if p == 0.0 {
            if q < 0.0 {
                return false;
            }
        } else {
            let t = q / p;
            if p < 0.0 {
                t0 = t0.max(t);
            } else {
                t1 = t1.min(t);
            }
            if t0 > t1 {
                return false;
            }
        }
    }
    true
}

/// True when `p` lies inside the polygon `poly` (even–odd rule).
fn inside_polygon(p: (f64, f64), poly: &[Px]) -> bool {
    let mut inside = false;
    let n = poly.len();
    for i in 0..n {
        let (a, b) = (poly[i], poly[(i + n - 1) % n]);
        let (ax, ay, bx, by) = (
            f64::from(a.0),
            f64::from(a.1),
            f64::from(b.0),
            f64::from(b.1),
        );
        if (ay > p.1) != (by > p.1) && p.0 < (bx - ax) * (p.1 - ay) / (by - ay) + ax {
            inside = !inside;
        }
    }
    inside
}

impl Prim {
    /// True when this primitive, as drawn, touches the box `r`.
    pub fn meets(&self, r: Rect) -> bool {
        match self {
            Prim::Path { points, width } => {
                let r = r.grow((*width as i32 + 1) / 2);
                match points.as_slice() {
                    [] => false,
                    [p] => r.contains(*p),
                    ps => ps.windows(2).any(|w| segment_meets(w[0], w[1], r)),
                }
            }
            Prim::Fill { points } => {
                let n = points.len();
                let centre = (0.5 * f64::from(r.x0 + r.x1), 0.5 * f64::from(r.y0 + r.y1));
                n > 0
                    && ((0..n).any(|i| segment_meets(points[i], points[(i + 1) % n], r))
                        || inside_polygon(centre, points))
            }
            Prim::Marker { at, size, .. } => Rect {
                x0: at.0 - size,
                y0: at.1 - size,
                x1: at.0 + size,
                y1: at.1 + size,
            }
            .overlaps(r),
        }
    }
}

/// The band of a dense line: for each pixel column the samples fall in, the smallest and
/// largest pixel row they reach, widened to join the previous column's last sample (the line
/// between two neighbouring columns crosses both) and by `half_width` px above and below (a
/// flat stretch is as thick as a line). `None` when the line is not dense (at most two samples
/// per column it spans) or its abscissae go back (a loop), when it is drawn as a path.
pub fn column_band(points: &[Px], half_width: i32) -> Option<Vec<Px>> {
    let (first, last) = (points.first()?, points.last()?);
    let span = i64::from(last.0) - i64::from(first.0) + 1;
    if points.windows(2).any(|w| w[1].0 < w[0].0) || (points.len() as i64) <= 2 * span {
        return None;
    }
    // (column, top, bottom) with top ≤ bottom in pixel rows.
    let mut cols: Vec<(i32, i32, i32)> = Vec::new();
    let mut prev_y: Option<i32> = None;
    for &(x, y) in points {
        match cols.last_mut() {
            Some(c) if c.0 == x => {
                c.1 = c.1.min(y);
                c.2 = c.2.max(y);
            }
            Some(c) => {
                let adjacent = x == c.0 + 1;
                let (mut top, mut bottom) = (y, y);
                if let (true, Some(py)) = (adjacent, prev_y) {
                    top = top.min(py);
                    bottom = bottom.max(py);
                }
                cols.push((x, top, bottom));
            }
            None => cols.push((x, y, y)),
        }
        prev_y = Some(y);
    }
    let mut poly: Vec<Px> = cols.iter().map(|c| (c.0, c.1 - half_width)).collect();
    poly.extend(cols.iter().rev().map(|c| (c.0, c.2 + half_width)));
    Some(poly)
}

/// Split the path `points` into the dashes of `pattern` (on, off, on, ... in px); an empty
/// pattern gives the path whole.
pub fn dashes(points: &[Px], pattern: &[f64]) -> Vec<Vec<Px>> {
    if pattern.is_empty() || pattern.iter().sum::<f64>() <= 0.0 || points.len() < 2 {
        return vec![points.to_vec()];
    }
    let mut out = Vec::new();
    let mut cur: Vec<Px> = Vec::new();
    let (mut k, mut left) = (0usize, pattern[0]);
    let round = |x: f64, y: f64| (x.round() as i32, y.round() as i32);
    for w in points.windows(2) {
        let (ax, ay) = (f64::from(w[0].0), f64::from(w[0].1));
        let (bx, by) = (f64::from(w[1].0), f64::from(w[1].1));
        let len = (bx - ax).hypot(by - ay);
        let mut at = 0.0;
        if k % 2 == 0 && cur.is_empty() {
            cur.push(w[0]);
        }
        while len - at > left {
            at += left;
            let p = round(ax + (bx - ax) * at / len, ay + (by - ay) * at / len);
            if k % 2 == 0 {
                cur.push(p);
                out.push(std::mem::take(&mut cur));
            } else {
                cur.push(p);
            }
            k = (k + 1) % pattern.len();
            left = pattern[k];
        }
        left -= len - at;
        if k % 2 == 0 {
            cur.push(w[1]);
        }
    }
    if cur.len() >= 2 {
        out.push(cur);
    }
    out
}

/// Where the legend box goes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Placement {
    /// Inside the plotting area, its top-left corner at this pixel.
    Inside(Px),
    /// Outside the plotting area, on its right: the plotting area is narrowed to make room.
    Outside,
}

/// A corner of the plotting area.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Corner {
    /// Top left.
    UpperLeft,
    /// Top right.
    UpperRight,
    /// Bottom left.
    LowerLeft,
    /// Bottom right.
    LowerRight,
}

/// The one rule for every figure's legend: of the four corners of the plotting area (`plot`:
/// its width and height in px), in the order of `preference`, the first where a box of `size`
/// px, `margin` px in from the edges, covers none of `prims`; of those, the one that covers the
/// least of `shades` (shaded spans, x0..x1 over the whole height: better left visible, but not
/// worth moving the legend out for). When every corner covers data, or the box does not fit,
/// [`Placement::Outside`] if the box and its margin take at most `room_outside` px of width;
/// else (a legend wider than a plot can give up) the corner that covers the fewest primitives.
pub fn place_legend(
    plot: (i32, i32),
    size: (i32, i32),
    margin: i32,
    prims: &[Prim],
    shades: &[(i32, i32)],
    preference: &[Corner],
    room_outside: i32,
) -> Placement {
    let (w, h) = plot;
    let (bw, bh) = size;
    let fits_outside = bw + margin <= room_outside;
    if bw + 2 * margin > w || bh + 2 * margin > h {
        return Placement::Outside;
    }
    let mut best: Option<(i32, Px)> = None;
    let mut least: Option<(usize, Px)> = None;
    for corner in preference {
        let x0 = match corner {
            Corner::UpperLeft | Corner::LowerLeft => margin,
            Corner::UpperRight | Corner::LowerRight => w - margin - bw,
        };
        let y0 = match corner {
            Corner::UpperLeft | Corner::UpperRight => margin,
            Corner::LowerLeft | Corner::LowerRight => h - margin - bh,
        };
        let rect = Rect {
            x0,
            y0,
            x1: x0 + bw,
            y1: y0 + bh,
        };
        // A few pixels of air between the box and the data.
        let probe = rect.grow(3);
        let covered = prims.iter().filter(|p| p.meets(probe)).count();
        if least.is_none_or(|(c, _)| covered < c) {
            least = Some((covered, (x0, y0)));
        }
        if covered > 0 {
            continue;
        }
        let shaded: i32 = shades
            .iter()
            .map(|&(a, b)| (b.min(rect.x1) - a.max(rect.x0)).max(0))
            .sum();
        if best.is_none_or(|(s, _)| shaded < s) {
            best = Some((shaded, (x0, y0)));
        }
    }
    match (best, least) {
        (Some((_, at)), _) => Placement::Inside(at),
        (None, Some((_, at))) if !fits_outside => Placement::Inside(at),
        _ => Placement::Outside,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const ALL: [Corner; 4] = [
        Corner::UpperRight,
        Corner::UpperLeft,
        Corner::LowerRight,
        Corner::LowerLeft,
    ];

    fn marker(at: Px) -> Prim {
        Prim::Marker {
            at,
            shape: Shape::Circle,
            size: 4,
            filled: true,
            width: 1,
        }
    }

    #[test]
    fn the_legend_takes_the_first_free_corner_else_goes_outside() {
        // A point in the upper right corner: the upper left is free.
        let prims = vec![marker((390, 10))];
        assert_eq!(
            place_legend((400, 300), (100, 50), 10, &prims, &[], &ALL, 200),
            Placement::Inside((10, 10))
        );
        // A line along the top and one along the bottom: no corner is free.
        let prims = vec![
            Prim::Path {
                points: vec![(0, 20), (400, 20)],
                width: 2,
            },
            Prim::Path {
                points: vec![(0, 280), (400, 280)],
                width: 2,
            },
        ];
        assert_eq!(
            place_legend((400, 300), (100, 50), 10, &prims, &[], &ALL, 200),
            Placement::Outside
        );
        // No room outside either: the corner that covers least (here the upper ones, one line
        // each, the preference's first).
        assert_eq!(
            place_legend((400, 300), (100, 50), 10, &prims, &[], &ALL, 50),
            Placement::Inside((290, 10))
        );
        // A segment that crosses the box without a vertex inside it still counts.
        let prims = vec![Prim::Path {
            points: vec![(250, 0), (400, 80)],
            width: 2,
        }];
        assert_eq!(
            place_legend((400, 300), (100, 50), 10, &prims, &[], &ALL, 200),
            Placement::Inside((10, 10))
        );
        // A box taller than the plot goes outside.
        assert_eq!(
            place_legend((400, 300), (100, 290), 10, &[], &[], &ALL, 200),
            Placement::Outside
        );
        // Free corners: the one shading least of the shaded spans.
        assert_eq!(
            place_legend((400, 300), (100, 50), 10, &[], &[(0, 150)], &ALL, 200),
            Placement::Inside((290, 10))
        );
    }

    #[test]
    fn a_band_covers_the_box_inside_it() {
        // A wide band whose outline stays far from the box: its inside still covers it.
        let band = Prim::Fill {
            points: vec![(0, 0), (400, 0), (400, 300), (0, 300)],
        };
        assert!(band.meets(Rect {
            x0: 100,
            y0: 100,
            x1: 150,
            y1: 150
        }));
        assert!(!Prim::Fill {
            points: vec![(0, 0), (50, 0), (50, 50), (0, 50)],
        }
        .meets(Rect {
            x0: 100,
            y0: 100,
            x1: 150,
            y1: 150
        }));
    }

    #[test]
    fn a_dense_line_becomes_the_band_of_its_columns() {
        // 10 samples per column over 5 columns, alternating between rows 10 and 50.
        let pts: Vec<Px> = (0..50)
            .map(|i| (i / 10, if i % 2 == 0 { 10 } else { 50 }))
            .collect();
        let band = column_band(&pts, 1).unwrap();
        assert_eq!(band.len(), 10);
        assert!(band[..5].iter().all(|p| p.1 == 9));
        assert!(band[5..].iter().all(|p| p.1 == 51));
        // Sparse or going back: a path.
        assert!(column_band(&[(0, 0), (1, 1), (2, 2)], 1).is_none());
        let mut back = pts.clone();
        back.push((0, 0));
        assert!(column_band(&back, 1).is_none());
        // A step between two columns: both columns reach across it.
        let mut step: Vec<Px> = (0..10).map(|_| (0, 10)).collect();
        step.extend((0..10).map(|_| (1, 40)));
        let band = column_band(&step, 0).unwrap();
        assert_eq!(band, vec![(0, 10), (1, 10), (1, 40), (0, 10)]);
    }

    #[test]
    fn dashes_follow_the_pattern() {
        let d = dashes(&[(0, 0), (30, 0)], &[5.0, 5.0]);
        assert_eq!(d.len(), 3);
        assert_eq!(d[0], vec![(0, 0), (5, 0)]);
        assert_eq!(d[1], vec![(10, 0), (15, 0)]);
        // Across a vertex.
        let d = dashes(&[(0, 0), (3, 0), (3, 10)], &[5.0, 5.0]);
        assert_eq!(d[0], vec![(0, 0), (3, 0), (3, 2)]);
        assert_eq!(dashes(&[(0, 0), (9, 0)], &[]), vec![vec![(0, 0), (9, 0)]]);
    }
}

//! Rate-dependent work of adhesion w(ȧ) and its inverse (docs/MODEL.md, "Gent–Schultz law").
//!
//! Convention: ȧ > 0 is healing (contact advancing), ȧ < 0 peeling (crack opening). Every law is
//! continuous and strictly decreasing in ȧ, with w(0) = w0 (a constant law is the degenerate,
//! rate-independent case). The time-domain model needs the inverse: the speed ȧ at which w(ȧ) = G.
//! Laws with a closed-form inverse override [`AdhesionLaw::crack_speed`]; the others use the
//! default, a bracketed Brent root solve (`roots` crate) in the variable asinh(ȧ / v_scale), which
//! keeps relative accuracy over many decades of speed.

use std::sync::Arc;

use crate::error::{positive, ParamError};
use crate::numerics::RelativeConvergency;

/// A work-of-adhesion law w(ȧ).
pub trait AdhesionLaw {
    /// Quasi-static work of adhesion w(0) (J/m²).
    fn w0(&self) -> f64;

    /// Work of adhesion at contact-radius rate ȧ (m/s; > 0 healing, < 0 peeling), in J/m².
    fn work_of_adhesion(&self, adot: f64) -> f64;

    /// A characteristic speed of the law (m/s), used to scale root solves.
    fn speed_scale(&self) -> f64;

    /// True when w does not depend on ȧ (elastic JKR): then the inverse does not exist and the
    /// contact radius is set by G = w0 directly.
    fn is_rate_independent(&self) -> bool {
        false
    }

    /// The speed ȧ at which w(ȧ) = g (m/s). Returns `f64::INFINITY` when g is at or below the
    /// infimum of w (healing without bound, e.g. g ≤ 0), `f64::NEG_INFINITY` when g is at or above
    /// its supremum. Never NaN for a non-NaN g.
    fn crack_speed(&self, g: f64) -> f64 {
        invert_by_root(self, g)
    }

    /// The infimum of w over healing speeds (J/m²): at G at or below it the contact heals
    /// without bound. 0 for the power laws (G ≤ 0); a saturated law's w at its saturation speed;
    /// a table's smallest w (it is held beyond the last row).
    fn healing_floor(&self) -> f64 {
        0.0
    }

    /// The rate factor of the closed forms (eq. 24): w(−v)/w0 − 1, the relative rise of the work
    /// of adhesion when peeling at speed v (m/s; the sign of v is ignored). (v/v0)^n for
    /// Gent–Schultz, 0 for a constant w.
    fn peel_rate_factor(&self, v: f64) -> f64 {
        self.work_of_adhesion(-v.abs()) / self.w0() - 1.0
    }

    /// The inverse of [`peel_rate_factor`](Self::peel_rate_factor): the peeling speed v ≥ 0
    /// (m/s) at which w(−v) = w0 (1 + x) for x ≥ 0 (negative x is taken as 0), or
    /// `f64::INFINITY` where no speed reaches it (a constant w for any x > 0, a saturated law
    /// beyond its plateau).
    fn peel_speed_for_rate_factor(&self, x: f64) -> f64 {
        let v = -self.crack_speed(self.w0() * (1.0 + x.max(0.0)));
        v.max(0.0)
    }
}

/// Invert a strictly decreasing law by bracketing and Brent's method in s = asinh(ȧ / v_scale).
pub fn invert_by_root<L: AdhesionLaw + ?Sized>(law: &L, g: f64) -> f64 {
    let w0 = law.w0();
    if g.is_nan() {
        return f64::NAN;
    }
    // Exactly w0 (the law's own value at rest) is exactly zero speed; no root solve needed.
    #[allow(clippy::float_cmp)]
    if g == w0 {
        return 0.0;
    }
    if law.is_rate_independent() {
        return if g < w0 {
            f64::INFINITY
        } else {
            f64::NEG_INFINITY
        };
    }
    let v = law.speed_scale();
    // Residual, relative to g, as a function of s; increasing in s means w decreasing... we use
    // f(s) = (g - w(adot(s))) / g, which is increasing in s.
    let f = |s: f64| (g - law.work_of_adhesion(v * s.sinh())) / g.abs().max(f64::MIN_POSITIVE);
    let sign = if g < w0 { 1.0 } else { -1.0 };
    // Expand the bracket outwards from 0 in the direction of the root.
    let mut lo = 0.0_f64;
    let mut hi = sign;
    let s_max = 745.0; // sinh(745) ~ 1e323: beyond, the speed is not representable.
    loop {
        let fh = f(hi);
        if (sign > 0.0 && fh >= 0.0) || (sign < 0.0 && fh <= 0.0) {
            break;
        }
        lo = hi;
        if hi.abs() >= s_max {
            return sign * f64::INFINITY;
        }
        hi = (hi * 2.0).clamp(-s_max, s_max);
    }
    let (a, b) = if lo < hi { (lo, hi) } else { (hi, lo) };
    let mut conv = RelativeConvergency {
        x_abs: 1e-15,
        ..RelativeConvergency::default()
    };
    match roots::find_root_brent(a, b, f, &mut conv) {
        Ok(s) => v * s.sinh(),
        // Brent only fails on a bad bracket or iteration limit; the bracket is valid by
        // construction, so fall back to its midpoint rather than NaN.
        Err(_) => v * (0.5 * (a + b)).sinh(),
    }
}

/// Rate-independent law w = w0: elastic JKR.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConstantW {
    /// Work of adhesion (J/m²).
    pub w0: f64,
}

impl AdhesionLaw for ConstantW {
    fn w0(&self) -> f64 {
        self.w0
    }
    fn work_of_adhesion(&self, _adot: f64) -> f64 {
        self.w0
    }
    fn speed_scale(&self) -> f64 {
        1.0
    }
    fn is_rate_independent(&self) -> bool {
        true
    }
}

/// Gent–Schultz power law, eqs. (1)–(2), with C = v0^(−n):
/// w = w0 (1 + (−ȧ/v0)^n) while peeling, w = w0 / (1 + (ȧ/v0)^n) while healing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GentSchultz {
    /// Quasi-static work of adhesion (J/m²).
    pub w0: f64,
    /// Reference speed v0 (m/s): w doubles at a peeling speed v0.
    pub v0: f64,
    /// Exponent n (> 0).
    pub n: f64,
}

impl GentSchultz {
    /// The paper's constants: w0 = 240 mJ/m², v0 = 0.0445 mm/s, n = 0.531.
    pub const PAPER: GentSchultz = GentSchultz {
        w0: 0.240,
        v0: 4.45e-5,
        n: 0.531,
    };

    /// Validated constructor.
    pub fn new(w0: f64, v0: f64, n: f64) -> Result<Self, ParamError> {
        positive("w0", w0, "J/m^2")?;
        positive("v0", v0, "m/s")?;
        positive("n", n, "(dimensionless)")?;
        Ok(Self { w0, v0, n })
    }

    /// The amplification factor C |ȧ|^n = (|ȧ|/v0)^n.
    #[inline]
    pub fn rate_factor(&self, speed: f64) -> f64 {
        (speed.abs() / self.v0).powf(self.n)
    }
}

impl AdhesionLaw for GentSchultz {
    fn w0(&self) -> f64 {
        self.w0
    }
    #[inline]
    fn work_of_adhesion(&self, adot: f64) -> f64 {
        let f = self.rate_factor(adot);
        if adot < 0.0 {
            self.w0 * (1.0 + f)
        } else {
            self.w0 / (1.0 + f)
        }
    }
    fn speed_scale(&self) -> f64 {
        self.v0
    }
    /// (v/v0)^n, without the rounding of w(−v)/w0 − 1 at small speeds.
    fn peel_rate_factor(&self, v: f64) -> f64 {
        self.rate_factor(v)
    }
    /// v0 x^(1/n).
    fn peel_speed_for_rate_factor(&self, x: f64) -> f64 {
        self.v0 * x.max(0.0).powf(1.0 / self.n)
    }
    /// Closed form: G ≥ w0: ȧ = −v0 (G/w0 − 1)^(1/n); 0 < G < w0: ȧ = v0 (w0/G − 1)^(1/n);
    /// G ≤ 0: +∞ (healing without bound: the contact races to the Hertz radius).
    #[inline]
    fn crack_speed(&self, g: f64) -> f64 {
        // x^(1/n) as 2^(log2(x)/n): the explicit simulators' hot path, a third faster than
        // `powf` (measured 10.6 against 15.4 ns) and within a few ulp of it.
        let root = |x: f64| {
            if x > 0.0 {
                (x.log2() / self.n).exp2()
            } else {
                0.0
            }
        };
        if g.is_nan() {
            f64::NAN
        } else if g >= self.w0 {
            -self.v0 * root(g / self.w0 - 1.0)
        } else if g > 0.0 {
            self.v0 * root(self.w0 / g - 1.0)
        } else {
            f64::INFINITY
        }
    }
}

/// Gent–Schultz law with a saturation speed v_sat: the speed inside the power law is replaced by
/// v_eff = |ȧ| / (1 + |ȧ|/v_sat), so w tends to w0 (1 + (v_sat/v0)^n) while peeling fast and to
/// w0 / (1 + (v_sat/v0)^n) while healing fast. One of the saturations the paper asks about.
/// Inverted in closed form: the power law's inverse gives v_eff, and |ȧ| = v_eff / (1 − v_eff/v_sat).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SaturatedGentSchultz {
    /// The underlying power law.
    pub base: GentSchultz,
    /// Saturation speed (m/s).
    pub v_sat: f64,
}

impl SaturatedGentSchultz {
    /// Validated constructor.
    pub fn new(w0: f64, v0: f64, n: f64, v_sat: f64) -> Result<Self, ParamError> {
        positive("v_sat", v_sat, "m/s")?;
        Ok(Self {
            base: GentSchultz::new(w0, v0, n)?,
            v_sat,
        })
    }
}

impl AdhesionLaw for SaturatedGentSchultz {
    fn w0(&self) -> f64 {
        self.base.w0
    }
    fn healing_floor(&self) -> f64 {
        // ȧ → ∞ saturates the effective speed at v_sat.
        self.base.work_of_adhesion(self.v_sat)
    }
    fn work_of_adhesion(&self, adot: f64) -> f64 {
        let v = adot.abs();
        let v_eff = v / (1.0 + v / self.v_sat);
        self.base.work_of_adhesion(v_eff.copysign(adot))
    }
    fn speed_scale(&self) -> f64 {
        self.base.v0
    }
    /// Closed form, as the power law's: its inverse gives the effective speed v_eff (with the
    /// sign of ȧ), and v_eff = |ȧ| / (1 + |ȧ|/v_sat) gives |ȧ| = v_eff / (1 − v_eff/v_sat), which
    /// is unbounded (±∞) for v_eff ≥ v_sat: G beyond the law's plateau. A root solve per call
    /// made the law ten times slower per right-hand side than the power law.
    fn crack_speed(&self, g: f64) -> f64 {
        let a = self.base.crack_speed(g);
        let v_eff = a.abs();
        if v_eff >= self.v_sat {
            f64::INFINITY.copysign(a)
        } else {
            a / (1.0 - v_eff / self.v_sat)
        }
    }
}

/// A tabulated law: points (ȧ_i, w_i) with ȧ strictly increasing (and spanning 0), w strictly
/// decreasing and positive, interpolated in w against ξ = asinh(ȧ / v_ref), with v_ref the
/// smallest non-zero |ȧ| of the table, so log-spaced tables interpolate smoothly over decades.
///
/// The interpolant is the monotone piecewise-cubic Hermite one of Fritsch and Carlson (PCHIP, as
/// SciPy's `PchipInterpolator`: slopes by the weighted harmonic mean of the neighbouring secants,
/// one-sided three-point slopes at the ends): continuous with its first derivative, and strictly
/// decreasing like the rows. A piecewise-linear interpolant has a kink at every row, which makes
/// the period map of the steady state non-smooth at ~1e-9 and stalls Newton's method in shooting
/// and continuation (a 55 000-row table of the Gent–Schultz law stopped a continuation that the
/// closed form completes in a second). The inverse (the crack speed at which w = G) solves the
/// same cubic, so forward and inverse agree to rounding. Outside the table w is held at its end
/// values, so the inverse returns ±∞ for G beyond them.
#[derive(Debug, Clone, PartialEq)]
pub struct TabulatedLaw {
    // Shared, not copied, by the clones of a law (a scenario rebuilt for every value of a
    // continuation or sweep clones its law; a 55 000-row table is 1.3 MB).
    xi: Arc<[f64]>,
    w: Arc<[f64]>,
    /// dw/dξ at each row (Fritsch–Carlson; ≤ 0).
    slope: Arc<[f64]>,
    v_ref: f64,
    w0: f64,
}

/// Fritsch–Carlson slopes of the monotone cubic Hermite interpolant through (x_i, y_i), x
/// strictly increasing (SciPy's `PchipInterpolator`): at an interior row the weighted harmonic
/// mean of the two secants (0 where they differ in sign or one is 0), at the ends the one-sided
/// three-point formula, limited so the cubic stays monotone. Two rows: the secant.
fn pchip_slopes(x: &[f64], y: &[f64]) -> Vec<f64> {
    let n = x.len();
    let h: Vec<f64> = x.windows(2).map(|p| p[1] - p[0]).collect();
    let del: Vec<f64> = (0..n - 1).map(|k| (y[k + 1] - y[k]) / h[k]).collect();
    if n == 2 {
        return vec![del[0]; 2];
    }
    let mut d = vec![0.0; n];
    for k in 1..n - 1 {
        let (a, b) = (del[k - 1], del[k]);
        if a * b > 0.0 {
            let w1 = 2.0 * h[k] + h[k - 1];
            let w2 = h[k] + 2.0 * h[k - 1];
            d[k] = (w1 + w2) / (w1 / a + w2 / b);
        }
    }
    let end = |h0: f64, h1: f64, m0: f64, m1: f64| {
        let d = ((2.0 * h0 + h1) * m0 - h0 * m1) / (h0 + h1);
        if d * m0 <= 0.0 {
            0.0
        } else if m0 * m1 < 0.0 && d.abs() > 3.0 * m0.abs() {
            3.0 * m0
        } else {
            d
        }
    };
    d[0] = end(h[0], h[1], del[0], del[1]);
    d[n - 1] = end(h[n - 2], h[n - 3], del[n - 2], del[n - 3]);
    d
}

/// Largest |speed| (m/s) of a tabulated law's rows: faster than any crack in a soft solid.
pub const TABLE_MAX_SPEED: f64 = 1e3;
/// Largest ratio of a tabulated law's w to its w(0), either way.
pub const TABLE_MAX_W_RATIO: f64 = 1e9;

impl TabulatedLaw {
    /// Build from (speed, w) pairs; `source` names the file in errors. The rows must be finite,
    /// with speeds increasing strictly and spanning 0, |speed| ≤ [`TABLE_MAX_SPEED`], and w
    /// decreasing strictly, > 0 and within a factor [`TABLE_MAX_W_RATIO`] of w(0).
    pub fn new(points: &[(f64, f64)], source: &str) -> Result<Self, ParamError> {
        if points.len() < 2 {
            return Err(ParamError::new(
                source,
                format!("{} rows", points.len()),
                "a tabulated law needs at least 2 rows of (speed m/s, w J/m^2)",
            ));
        }
        for (i, &(v, w)) in points.iter().enumerate() {
            if !v.is_finite() || !w.is_finite() || w <= 0.0 {
                return Err(ParamError::new(
                    format!("{source}: row {}", i + 1),
                    format!("({v:?}, {w:?})"),
                    "speed must be finite and w finite and > 0",
                ));
            }
            if i > 0 {
                let (vp, wp) = points[i - 1];
                if v <= vp || w >= wp {
                    return Err(ParamError::new(
                        format!("{source}: row {}", i + 1),
                        format!("({v:?}, {w:?})"),
                        format!(
                            "speeds must increase strictly and w decrease strictly (previous row ({vp}, {wp}))"
                        ),
                    ));
                }
            }
        }
        let (first, last) = (points[0].0, points[points.len() - 1].0);
        if first > 0.0 || last < 0.0 {
            return Err(ParamError::new(
                source,
                format!("speeds {first} .. {last}"),
                "the table must span speed 0 (peeling < 0 < healing) so that w0 = w(0) is defined",
            ));
        }
        let v_ref = points
            .iter()
            .map(|p| p.0.abs())
            .filter(|&v| v > 0.0)
            .fold(f64::INFINITY, f64::min);
        let v_ref = if v_ref.is_finite() { v_ref } else { 1.0 };
        let xi: Vec<f64> = points.iter().map(|p| (p.0 / v_ref).asinh()).collect();
        let w: Vec<f64> = points.iter().map(|p| p.1).collect();
        let slope = pchip_slopes(&xi, &w).into();
        let mut law = Self {
            xi: xi.into(),
            w: w.into(),
            slope,
            v_ref,
            w0: 0.0,
        };
        law.w0 = law.interpolate(0.0);
        // Bounded: speeds no faster than any crack in a soft solid, and w within a range of
        // w(0) that double precision carries through G = w(ȧ) (a row of w = 1e300 next to
        // w0 = 0.24 made the interpolation cancel to w ≈ 0).
        for (i, &(v, w)) in points.iter().enumerate() {
            let ratio = w / law.w0;
            if v.abs() > TABLE_MAX_SPEED
                || !(1.0 / TABLE_MAX_W_RATIO..=TABLE_MAX_W_RATIO).contains(&ratio)
            {
                return Err(ParamError::new(
                    format!("{source}: row {}", i + 1),
                    format!("({v:?}, {w:?})"),
                    format!(
                        "speeds must lie in [-{TABLE_MAX_SPEED:e}, {TABLE_MAX_SPEED:e}] m/s and w within a factor {TABLE_MAX_W_RATIO:e} of w(0) = {} J/m^2",
                        law.w0
                    ),
                ));
            }
        }
        Ok(law)
    }

    /// Parse a CSV text of two numeric columns (speed m/s, w J/m²); a non-numeric first line is a
    /// header; `#` starts a comment.
    pub fn from_csv_str(text: &str, source: &str) -> Result<Self, ParamError> {
        let mut pts = Vec::new();
        for (i, line) in text.lines().enumerate() {
            let line = line.split('#').next().unwrap_or("").trim();
            if line.is_empty() {
                continue;
            }
            let cols: Vec<&str> = line
                .split([',', ';', '\t', ' '])
                .filter(|s| !s.is_empty())
                .collect();
            let parsed: Option<Vec<f64>> = cols.iter().map(|c| c.parse().ok()).collect();
            match parsed {
                Some(v) if v.len() == 2 => pts.push((v[0], v[1])),
                _ if pts.is_empty() && i == 0 => continue, // header
                _ => {
                    return Err(ParamError::new(
                        format!("{source}: line {}", i + 1),
                        crate::text::unquoted_line(line),
                        "expected two numbers: speed (m/s, > 0 healing), w (J/m^2)",
                    ))
                }
            }
        }
        Self::new(&pts, source)
    }

    fn interpolate(&self, xi: f64) -> f64 {
        let n = self.xi.len();
        if xi <= self.xi[0] {
            return self.w[0];
        }
        if xi >= self.xi[n - 1] {
            return self.w[n - 1];
        }
        let j = self.xi.partition_point(|&x| x <= xi).clamp(1, n - 1);
        let t = (xi - self.xi[j - 1]) / (self.xi[j] - self.xi[j - 1]);
        self.hermite(j, t)
    }

    /// The cubic of segment `j` (rows j − 1 and j) at t ∈ [0, 1]: the weighted mean of the two
    /// rows' w (no cancellation between rows of very different w) plus the slopes' terms, which
    /// are bounded by the segment's own difference in w (monotone slopes are at most three
    /// secants).
    #[inline]
    fn hermite(&self, j: usize, t: f64) -> f64 {
        let h = self.xi[j] - self.xi[j - 1];
        let s = 1.0 - t;
        let h01 = t * t * (3.0 - 2.0 * t);
        let h00 = 1.0 - h01;
        let h10 = t * s * s;
        let h11 = -t * t * s;
        h00 * self.w[j - 1] + h01 * self.w[j] + h * (h10 * self.slope[j - 1] + h11 * self.slope[j])
    }

    /// dw/dt of segment `j` at t (t as in [`Self::hermite`]); ≤ 0.
    #[inline]
    fn hermite_dt(&self, j: usize, t: f64) -> f64 {
        let h = self.xi[j] - self.xi[j - 1];
        let s = 1.0 - t;
        let dh01 = 6.0 * t * s;
        h * (s * (s - 2.0 * t) * self.slope[j - 1] + t * (3.0 * t - 2.0) * self.slope[j])
            + dh01 * (self.w[j] - self.w[j - 1])
    }

    /// The t ∈ [0, 1] of segment `j` at which the (decreasing) cubic equals `g`, with
    /// w[j] ≤ g ≤ w[j − 1]: Newton's method from the linear guess, kept inside a bisection
    /// bracket, to the last bit the bracket resolves.
    fn solve_segment(&self, j: usize, g: f64) -> f64 {
        let (w_lo, w_hi) = (self.w[j], self.w[j - 1]);
        let (mut a, mut b) = (0.0_f64, 1.0_f64);
        let mut t = ((w_hi - g) / (w_hi - w_lo)).clamp(0.0, 1.0);
        for _ in 0..100 {
            let f = self.hermite(j, t) - g;
            if f == 0.0 {
                return t;
            }
            // Decreasing: f > 0 means the root lies above t.
            if f > 0.0 {
                a = t;
            } else {
                b = t;
            }
            let df = self.hermite_dt(j, t);
            let newton = t - f / df;
            let next = if df < 0.0 && newton > a && newton < b {
                newton
            } else {
                0.5 * (a + b)
            };
            // Done when the iteration stands still (exactly) or the bracket is one ulp wide.
            #[allow(clippy::float_cmp)]
            let still = next == t;
            if still || b - a <= f64::EPSILON * b.max(1e-300) {
                return next;
            }
            t = next;
        }
        t
    }
}

impl AdhesionLaw for TabulatedLaw {
    fn w0(&self) -> f64 {
        self.w0
    }
    fn healing_floor(&self) -> f64 {
        self.w[self.w.len() - 1]
    }
    fn work_of_adhesion(&self, adot: f64) -> f64 {
        self.interpolate((adot / self.v_ref).asinh())
    }
    fn speed_scale(&self) -> f64 {
        self.v_ref
    }
    fn crack_speed(&self, g: f64) -> f64 {
        let n = self.w.len();
        if g.is_nan() {
            return f64::NAN;
        }
        if g > self.w[0] {
            return f64::NEG_INFINITY;
        }
        if g < self.w[n - 1] {
            return f64::INFINITY;
        }
        // w is decreasing: find the segment, invert its cubic.
        let j = self.w.partition_point(|&w| w > g).clamp(1, n - 1);
        let t = self.solve_segment(j, g);
        let xi = (1.0 - t) * self.xi[j - 1] + t * self.xi[j];
        self.v_ref * xi.sinh()
    }
}

/// The laws a scene or a command can name, as one concrete type (static dispatch in hot loops).
#[derive(Debug, Clone, PartialEq)]
pub enum Law {
    /// w = w0 (elastic JKR).
    Constant(ConstantW),
    /// Gent–Schultz power law.
    GentSchultz(GentSchultz),
    /// Gent–Schultz with a saturation speed.
    Saturated(SaturatedGentSchultz),
    /// Tabulated w(ȧ).
    Tabulated(TabulatedLaw),
}

impl Default for Law {
    fn default() -> Self {
        Law::GentSchultz(GentSchultz::PAPER)
    }
}

/// The names of the laws as `[adhesion] law` spells them, in the order errors list them.
pub const LAW_NAMES: [&str; 4] = [
    "constant",
    "gent-schultz",
    "gent-schultz-saturated",
    "tabulated",
];

impl Law {
    /// The law's name as `[adhesion] law` spells it ([`LAW_NAMES`]).
    pub fn name(&self) -> &'static str {
        match self {
            Law::Constant(_) => LAW_NAMES[0],
            Law::GentSchultz(_) => LAW_NAMES[1],
            Law::Saturated(_) => LAW_NAMES[2],
            Law::Tabulated(_) => LAW_NAMES[3],
        }
    }
}

impl AdhesionLaw for Law {
    fn w0(&self) -> f64 {
        match self {
            Law::Constant(l) => l.w0(),
            Law::GentSchultz(l) => l.w0(),
            Law::Saturated(l) => l.w0(),
            Law::Tabulated(l) => l.w0(),
        }
    }
    #[inline]
    fn work_of_adhesion(&self, adot: f64) -> f64 {
        match self {
            Law::Constant(l) => l.work_of_adhesion(adot),
            Law::GentSchultz(l) => l.work_of_adhesion(adot),
            Law::Saturated(l) => l.work_of_adhesion(adot),
            Law::Tabulated(l) => l.work_of_adhesion(adot),
        }
    }
    fn speed_scale(&self) -> f64 {
        match self {
            Law::Constant(l) => l.speed_scale(),
            Law::GentSchultz(l) => l.speed_scale(),
            Law::Saturated(l) => l.speed_scale(),
            Law::Tabulated(l) => l.speed_scale(),
        }
    }
    fn is_rate_independent(&self) -> bool {
        matches!(self, Law::Constant(_))
    }
    fn healing_floor(&self) -> f64 {
        match self {
            Law::Constant(l) => l.healing_floor(),
            Law::GentSchultz(l) => l.healing_floor(),
            Law::Saturated(l) => l.healing_floor(),
            Law::Tabulated(l) => l.healing_floor(),
        }
    }
    #[inline]
    fn crack_speed(&self, g: f64) -> f64 {
        match self {
            Law::Constant(l) => l.crack_speed(g),
            Law::GentSchultz(l) => l.crack_speed(g),
            Law::Saturated(l) => l.crack_speed(g),
            Law::Tabulated(l) => l.crack_speed(g),
        }
    }
    fn peel_rate_factor(&self, v: f64) -> f64 {
        match self {
            Law::Constant(l) => l.peel_rate_factor(v),
            Law::GentSchultz(l) => l.peel_rate_factor(v),
            Law::Saturated(l) => l.peel_rate_factor(v),
            Law::Tabulated(l) => l.peel_rate_factor(v),
        }
    }
    fn peel_speed_for_rate_factor(&self, x: f64) -> f64 {
        match self {
            Law::Constant(l) => l.peel_speed_for_rate_factor(x),
            Law::GentSchultz(l) => l.peel_speed_for_rate_factor(x),
            Law::Saturated(l) => l.peel_speed_for_rate_factor(x),
            Law::Tabulated(l) => l.peel_speed_for_rate_factor(x),
        }
    }
}

#[cfg(test)]
#[allow(clippy::float_cmp)] // exact values (0, ±inf, w0) are exact by construction
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn gent_schultz_reference_points() {
        let l = GentSchultz::PAPER;
        assert_eq!(l.work_of_adhesion(0.0), l.w0);
        // Amplification 2 at peeling speed v0, halving at healing speed v0.
        assert!((l.work_of_adhesion(-l.v0) - 2.0 * l.w0).abs() < 1e-15);
        assert!((l.work_of_adhesion(l.v0) - 0.5 * l.w0).abs() < 1e-15);
        assert_eq!(l.crack_speed(0.0), f64::INFINITY);
        assert_eq!(l.crack_speed(-1.0), f64::INFINITY);
        assert_eq!(l.crack_speed(l.w0), 0.0);
    }

    /// Checks ȧ = inverse(w(ȧ)) to 1e-9 relative, or to what f64 can resolve: w is rounded to
    /// ~ε relative, and with w/w0 = 1 + f (or 1/(1 + f)) and f = (|ȧ|/v0)^n the inverse amplifies
    /// that error by dln|ȧ|/dln w = (1 + f)/(n f). `f` and `n` are the law's own (for a saturated
    /// law, those of its power law at the effective speed — an upper bound).
    fn identity_tolerance(adot: f64, f: f64, n: f64) -> f64 {
        let conditioning = (1.0 + f) / (n * f);
        1e-9_f64.max(8.0 * f64::EPSILON * conditioning) * adot.abs().max(1e-300)
    }

    fn check_identity<L: AdhesionLaw>(law: &L, adot: f64, f: f64, n: f64) {
        let w = law.work_of_adhesion(adot);
        let back = law.crack_speed(w);
        let tol = identity_tolerance(adot, f, n);
        assert!(
            (back - adot).abs() <= tol,
            "adot {adot:e}: w {w}, inverse gave {back:e}"
        );
    }

    proptest! {
        // law ∘ inverse = identity over 16 decades of speed, both signs, n from 0.05 to 1.5.
        #[test]
        fn gs_inverse_identity(log_v in -10.0f64..6.0, sign in prop::bool::ANY, n in 0.05f64..1.5) {
            let law = GentSchultz::new(0.24, 4.45e-5, n).unwrap();
            let v = 10f64.powf(log_v) * if sign { 1.0 } else { -1.0 };
            // Healing speeds so large that w/w0 underflows relative precision are not invertible
            // in f64: restrict to where w0/w − 1 is resolved.
            prop_assume!(law.rate_factor(v) < 1e12 && law.rate_factor(v) > 1e-12);
            check_identity(&law, v, law.rate_factor(v), n);
        }

        #[test]
        fn root_inverse_identity(log_v in -10.0f64..6.0, sign in prop::bool::ANY, n in 0.05f64..1.5) {
            // The generic root-solving inverse on the plain GS law, so it is checked against a
            // closed form too.
            struct ViaRoot(GentSchultz);
            impl AdhesionLaw for ViaRoot {
                fn w0(&self) -> f64 { self.0.w0 }
                fn work_of_adhesion(&self, adot: f64) -> f64 { self.0.work_of_adhesion(adot) }
                fn speed_scale(&self) -> f64 { self.0.v0 }
            }
            let law = ViaRoot(GentSchultz::new(0.24, 4.45e-5, n).unwrap());
            let v = 10f64.powf(log_v) * if sign { 1.0 } else { -1.0 };
            prop_assume!(law.0.rate_factor(v) < 1e12 && law.0.rate_factor(v) > 1e-12);
            check_identity(&law, v, law.0.rate_factor(v), n);
            let closed = law.0.crack_speed(law.0.work_of_adhesion(v));
            let tol = identity_tolerance(v, law.0.rate_factor(v), n);
            prop_assert!((law.crack_speed(law.0.work_of_adhesion(v)) - closed).abs() <= tol);
        }

        #[test]
        fn saturated_inverse_identity(log_v in -8.0f64..4.0, sign in prop::bool::ANY, n in 0.1f64..1.5) {
            let law = SaturatedGentSchultz::new(0.24, 4.45e-5, n, 1e-1).unwrap();
            let v = 10f64.powf(log_v) * if sign { 1.0 } else { -1.0 };
            prop_assume!(law.base.rate_factor(v) > 1e-10);
            let v_eff = v.abs() / (1.0 + v.abs() / law.v_sat);
            check_identity(&law, v, law.base.rate_factor(v_eff), n);
            // The closed form against the root solve of the same law.
            let g = law.work_of_adhesion(v);
            let tol = identity_tolerance(v, law.base.rate_factor(v_eff), n) / (1.0 - v_eff / law.v_sat);
            let root = invert_by_root(&law, g);
            prop_assert!((law.crack_speed(g) - root).abs() <= tol, "{} vs {root}", law.crack_speed(g));
        }
    }

    #[test]
    fn saturated_law_is_bounded() {
        let law = SaturatedGentSchultz::new(0.24, 4.45e-5, 0.5, 1e-2).unwrap();
        let wmax = 0.24 * (1.0 + (1e-2f64 / 4.45e-5).sqrt());
        assert!(law.work_of_adhesion(-1e6) < wmax);
        assert!(law.work_of_adhesion(-1e6) > 0.99 * wmax);
        assert_eq!(law.crack_speed(1.01 * wmax), f64::NEG_INFINITY);
        assert_eq!(law.crack_speed(0.0), f64::INFINITY);
    }

    #[test]
    fn tabulated_law_matches_its_points_and_inverts() {
        let gs = GentSchultz::PAPER;
        let speeds: Vec<f64> = (-30i32..=30)
            .map(|i| {
                if i == 0 {
                    0.0
                } else {
                    (i as f64).signum() * 1e-7 * 10f64.powf(i.abs() as f64 / 4.0)
                }
            })
            .collect();
        let pts: Vec<(f64, f64)> = speeds
            .iter()
            .map(|&v| (v, gs.work_of_adhesion(v)))
            .collect();
        let t = TabulatedLaw::new(&pts, "table.csv").unwrap();
        assert!((t.w0() - gs.w0).abs() < 1e-15);
        for &(v, w) in &pts {
            assert!((t.work_of_adhesion(v) - w).abs() < 1e-12);
            if v != 0.0 {
                assert!((t.crack_speed(w) - v).abs() < 1e-9 * v.abs());
            }
        }
        // Between points it stays within a few percent of the law it samples.
        for &v in &[-3e-4, -2e-6, 5e-6, 7e-3] {
            let rel = t.work_of_adhesion(v) / gs.work_of_adhesion(v) - 1.0;
            assert!(rel.abs() < 0.05, "v {v}: rel {rel}");
        }
    }

    /// The paper's law sampled at `n` rows evenly spaced in asinh(ȧ / v0) over |ȧ| < 1e3 m/s,
    /// with ȧ = 0 among them.
    fn dense_gs_table(n: usize) -> Vec<(f64, f64)> {
        let gs = GentSchultz::PAPER;
        let s_max = (999.0 / gs.v0).asinh();
        let mut pts: Vec<(f64, f64)> = (0..n)
            .map(|i| gs.v0 * (-s_max + 2.0 * s_max * i as f64 / (n - 1) as f64).sinh())
            .filter(|&v| v != 0.0)
            .chain([0.0])
            .map(|v| (v, gs.work_of_adhesion(v)))
            .collect();
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        pts
    }

    #[test]
    fn tabulated_law_is_c1_at_its_rows_where_a_linear_one_kinks() {
        // A coarse table, so that a kink of the linear interpolant would be large: the one-sided
        // slopes dw/dξ just left and right of each interior row agree to the rounding of the
        // difference quotient, while the secants on either side differ by a few percent.
        let t = TabulatedLaw::new(&dense_gs_table(61), "t").unwrap();
        let n = t.xi.len();
        let eps = 1e-7;
        for j in 1..n - 1 {
            let x = t.xi[j];
            let left = (t.interpolate(x) - t.interpolate(x - eps)) / eps;
            let right = (t.interpolate(x + eps) - t.interpolate(x)) / eps;
            let scale = left.abs().max(right.abs());
            assert!(
                (left - right).abs() <= 1e-5 * scale + 1e-12,
                "row {j}: dw/dξ {left} left, {right} right"
            );
            let secant_l = (t.w[j] - t.w[j - 1]) / (t.xi[j] - t.xi[j - 1]);
            let secant_r = (t.w[j + 1] - t.w[j]) / (t.xi[j + 1] - t.xi[j]);
            if j > 2 && j < n - 3 {
                assert!(
                    (secant_l - secant_r).abs() > 1e-3 * scale,
                    "row {j}: the test must see a kink the linear interpolant would have"
                );
            }
        }
    }

    #[test]
    fn tabulated_law_is_strictly_decreasing_between_rows_and_its_inverse_is_consistent() {
        let t = TabulatedLaw::new(&dense_gs_table(61), "t").unwrap();
        let n = t.xi.len();
        let mut prev = f64::INFINITY;
        for j in 1..n {
            for k in 0..=50 {
                let xi = t.xi[j - 1] + (t.xi[j] - t.xi[j - 1]) * k as f64 / 50.0;
                let w = t.interpolate(xi);
                assert!(w <= prev, "not decreasing at ξ = {xi}");
                prev = w;
                // Forward then inverse: the speed whose w is w, to rounding.
                let v = t.v_ref * xi.sinh();
                let back = t.crack_speed(w);
                let w_back = t.work_of_adhesion(back);
                // The round trip goes through the speed, ξ → v_ref sinh ξ → asinh: a few ulp of
                // ξ, times dw/dξ (at most three secants for a monotone cubic).
                let secant = (t.w[j - 1] - t.w[j]) / (t.xi[j] - t.xi[j - 1]);
                let tol = 4.0 * f64::EPSILON * (w + 3.0 * secant * xi.abs().max(1.0));
                assert!(
                    (w_back - w).abs() <= tol,
                    "w({back}) = {w_back}, not {w} (ξ = {xi}, v = {v})"
                );
                if k > 0 && k < 50 {
                    assert!(
                        (back - v).abs() <= 1e-9 * v.abs().max(t.v_ref),
                        "crack_speed(w({v})) = {back}"
                    );
                }
            }
        }
    }

    #[test]
    fn a_dense_table_reproduces_the_law_it_samples() {
        // 55 000 rows of the paper's law (issue 25). Where the law is smooth in ξ the cubic's
        // error is O(h^3) (h = 6.4e-4 in asinh(ȧ/v0)): measured 3.2e-13 relative. Near ȧ = 0 the
        // law itself has a cusp (w − w0 ∝ |ȧ|^n, n = 0.531: an infinite slope), which no
        // interpolant of samples follows closely: measured 3.2e-7 within |ȧ| < 4 v0 (1.4e-6 for
        // the inverse, judged as below). Both far below the integration's tolerances. The inverse is judged by the law's own w at the
        // speed it returns (near ȧ = 0 the speed is ill-conditioned in w).
        let gs = GentSchultz::PAPER;
        let t = TabulatedLaw::new(&dense_gs_table(55_000), "t").unwrap();
        assert_eq!(t.w0(), gs.w0);
        let (mut smooth, mut cusp) = (0.0_f64, 0.0_f64);
        for i in 0..4000 {
            let s = -17.0 + 34.0 * (i as f64 + 0.37) / 4000.0;
            let v = gs.v0 * s.sinh();
            let g = gs.work_of_adhesion(v);
            let fwd = (t.work_of_adhesion(v) / g - 1.0).abs();
            let inv = (gs.work_of_adhesion(t.crack_speed(g)) / g - 1.0).abs();
            let worst = if s.abs() > 2.1 {
                &mut smooth
            } else {
                &mut cusp
            };
            *worst = worst.max(fwd).max(inv);
        }
        assert!(
            smooth < 1e-12,
            "largest relative error where smooth {smooth:e}"
        );
        assert!(cusp < 1e-5, "largest relative error near the cusp {cusp:e}");
    }

    #[test]
    fn tabulated_law_rejects_bad_tables() {
        assert!(TabulatedLaw::new(&[(0.0, 0.2)], "t").is_err());
        assert!(TabulatedLaw::new(&[(-1.0, 0.2), (1.0, 0.3)], "t").is_err());
        assert!(TabulatedLaw::new(&[(1.0, 0.3), (2.0, 0.2)], "t").is_err());
        // Unbounded rows are refused, saying the bounds.
        for pts in [
            [(-1e300, 1e300), (0.0, 0.24), (1e300, 1e-300)],
            [(-1.0, 1e300), (0.0, 0.24), (1.0, 0.1)],
            [(-1e4, 1.0), (0.0, 0.24), (1.0, 0.1)],
        ] {
            let e = TabulatedLaw::new(&pts, "t").unwrap_err().to_string();
            assert!(e.contains("within a factor 1e9 of w(0)"), "{e}");
        }
        let e = TabulatedLaw::from_csv_str("speed,w\n-1,0.5\nx,0.1\n", "law.csv").unwrap_err();
        assert!(e.to_string().contains("law.csv: line 3"), "{e}");
        assert!(TabulatedLaw::from_csv_str("speed,w\n-1,0.5\n0,0.24\n1,0.1\n", "law.csv").is_ok());
    }

    #[test]
    fn constant_law_inverse_is_infinite() {
        let l = ConstantW { w0: 0.24 };
        assert_eq!(l.crack_speed(0.3), f64::NEG_INFINITY);
        assert_eq!(l.crack_speed(0.1), f64::INFINITY);
        assert_eq!(l.crack_speed(0.24), 0.0);
    }
}

//! The resolved model of a scene and the pure physics of one instant: positions of the drive
//! (spring end, base), the mechanical balance, quadrature integrands and the total energy.
//!
//! Everything here is allocation-free and SI. The simulator ([`super::Simulator`]) owns the time loop;
//! the steppers ([`super::Stepper`]) call these functions at their stages.

use crate::adhesion::{AdhesionLaw, Law};
use crate::jkr;
use crate::material::Material;
use crate::rig::{ContactFormation, DampingOn, Holder, Rig};
use std::f64::consts::PI;

/// Number of quadrature states carried along with the solution.
pub const NQ: usize = 17;

/// Indices of the quadrature states (each is ∫ … dt from the start of the run).
pub mod q {
    /// ∫ F dt.
    pub const F: usize = 0;
    /// ∫ F sin θ dt.
    pub const F_SIN: usize = 1;
    /// ∫ F cos θ dt.
    pub const F_COS: usize = 2;
    /// ∫ x_s sin θ dt. With δ = x_s + x_b and x_b = X_b sin θ known in closed form, δ's cycle harmonics are
    /// x_s's plus (X_b, 0) and its mean is ⟨x_s⟩: integrating the smooth x_s rather than the
    /// fast-oscillating δ keeps them accurate when steps are long (free flight between impacts).
    pub const XS_SIN: usize = 3;
    /// ∫ x_s cos θ dt.
    pub const XS_COS: usize = 4;
    /// ∫ a dt.
    pub const A: usize = 5;
    /// ∫ a sin θ dt.
    pub const A_SIN: usize = 6;
    /// ∫ a cos θ dt.
    pub const A_COS: usize = 7;
    /// ∫ x_s dt.
    pub const XS: usize = 8;
    /// ∫ x_k dt.
    pub const XK: usize = 9;
    /// ∫ holder force dt.
    pub const SPRING: usize = 10;
    /// ∫ holder force sin θ dt.
    pub const SPRING_SIN: usize = 11;
    /// ∫ holder force cos θ dt.
    pub const SPRING_COS: usize = 12;
    /// Work of the base: ∫ F_b ẋ_b dt with F_b the force transmitted through the contact.
    pub const W_BASE: usize = 13;
    /// Viscous dissipation ∫ c ẋ² dt (or c δ̇² for contact damping).
    pub const D_DAMP: usize = 14;
    /// Adhesive dissipation ∫ (w0 − w) 2πa ȧ dt.
    pub const D_ADH: usize = 15;
    /// Work of the moving spring end ∫ k (x_k − x_s) ẋ_k dt.
    pub const W_HOLDER: usize = 16;
}

/// How the sphere's position is determined.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mechanics {
    /// Inertia: eq. (30) integrated for (x_s, v_s).
    Dynamic,
    /// m = 0 without damping: the force balance k (x_k − x_s) = F(a, x_s + x_b) gives x_s in closed
    /// form at each a (F is linear in δ at fixed a); only a is integrated.
    QuasiStatic,
    /// Rigid link: x_s = x_k(t); only a is integrated.
    Rigid,
}

/// The scene's constants, resolved from a [`Rig`] and a protocol's scales.
#[derive(Debug, Clone)]
pub struct Model {
    /// Contact pair.
    pub mat: Material,
    /// Adhesion law.
    pub law: Law,
    /// w0 of the law (J/m²).
    pub w0: f64,
    /// True for a rate-independent law (a algebraic: G = w0).
    pub rate_independent: bool,
    /// Sphere mass m (kg).
    pub mass: f64,
    /// Gravitational acceleration g (m/s²).
    pub gravity: f64,
    /// Holding-spring stiffness k (N/m; 0 without a holder or for a rigid link): not the JKR
    /// constant K, which is `mat.k`.
    pub spring: f64,
    /// True without a holder (k = 0).
    pub free_holder: bool,
    /// Damping coefficient c (N s/m).
    pub damping: f64,
    /// Damping acts on δ̇ while in contact (otherwise on ẋ_s).
    pub contact_damping: bool,
    /// Mechanical model.
    pub mech: Mechanics,
    /// Base angular frequency ω (rad/s; 0 without base motion).
    pub omega: f64,
    /// Base amplitude X_b (m; 0 without base motion).
    pub xb_amp: f64,
    /// Delay φ/ω (s) from the stage that switches the shaker on to the start of the base motion
    /// (the base phase relative to the protocol's clock; 0 without base motion).
    pub shaker_delay: f64,
    /// JKR jump-in radius at w0 (m): the radius scale.
    pub a_jump: f64,
    /// Contact-loss radius (m): contact is lost when a falls to this value.
    pub a_floor: f64,
    /// Length scale for the error norm (m).
    pub len_scale: f64,
    /// Velocity scale for the error norm (m/s).
    pub vel_scale: f64,
    /// Characteristic time (s): the shortest of the base period and the free contact period.
    pub t_char: f64,
    /// Period of the free oscillation of sphere and spring on the jump-in contact stiffness (s;
    /// +∞ without inertia).
    pub t_free: f64,
    /// The explicit right-hand side's constants, so that its chain of dependent operations
    /// carries one division instead of four (see [`Model::signed_g`], [`Model::crack_speed`]).
    fast: FastConstants,
}

/// Precomputed reciprocals of the explicit right-hand side.
#[derive(Debug, Clone, Copy)]
struct FastConstants {
    /// 1/R (1/m).
    inv_r: f64,
    /// 3K/(8π) (Pa).
    g_coef: f64,
    /// 1/m (1/kg; 0 for m = 0).
    inv_m: f64,
    /// Gent–Schultz (v0, w0, 1/w0, 1/n), when that is the law.
    gs: Option<(f64, f64, f64, f64)>,
}

/// Scales of a run that the rig alone does not fix.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RunScales {
    /// An initial gap (m): the length scale of a flight.
    pub gap: Option<f64>,
    /// The fastest spring-end speed of the protocol (m/s): the time scale of a scene without
    /// inertia or vibration.
    pub max_speed: f64,
}

/// The mechanical model of a rig: (mechanics, k, free holder, c, damping on the contact).
fn mechanics(s: &Rig) -> Result<(Mechanics, f64, bool, f64, bool), String> {
    let ok = |v: f64| v.is_finite();
    let m = s.sphere.mass;
    let (k, free_holder, rigid) = match s.holder {
        Holder::None => (0.0, true, false),
        Holder::Spring { stiffness } => {
            if !(ok(stiffness) && stiffness > 0.0) {
                return Err(format!(
                    "spring stiffness = {stiffness} must be finite and > 0"
                ));
            }
            (stiffness, false, false)
        }
        Holder::Rigid => (0.0, false, true),
    };
    let (c, contact_damping) = match s.damping {
        Some(d) => {
            if !(ok(d.c) && d.c >= 0.0) {
                return Err(format!("damping c = {} must be finite and >= 0", d.c));
            }
            (d.c, d.on == DampingOn::Contact)
        }
        None => (0.0, false),
    };
    let mech = if rigid {
        Mechanics::Rigid
    } else if m == 0.0 {
        if free_holder {
            return Err(
                "mass = 0 with holder = none leaves the sphere undetermined: give it a mass or a holder"
                    .into(),
            );
        }
        if c > 0.0 {
            return Err(
                "mass = 0 with damping is not supported (the quasi-static balance is \
                 undamped): give the sphere a mass, or remove the damping"
                    .into(),
            );
        }
        Mechanics::QuasiStatic
    } else {
        Mechanics::Dynamic
    };
    Ok((mech, k, free_holder, c, contact_damping))
}

/// Resolve a rig's constants for the simulator; the error says why the rig cannot be
/// simulated as given.
pub fn resolve(s: &Rig, scales: RunScales) -> Result<Model, String> {
    let mat = s.material;
    let w0 = s.law.w0();
    let ok = |v: f64| v.is_finite();
    if !(ok(mat.k) && mat.k > 0.0 && ok(mat.r) && mat.r > 0.0 && ok(w0) && w0 > 0.0) {
        return Err(format!(
            "material K = {}, R = {} and law w0 = {} must be finite and > 0",
            mat.k, mat.r, w0
        ));
    }
    let m = s.sphere.mass;
    let g = s.sphere.gravity;
    if !(ok(m) && m >= 0.0 && ok(g)) {
        return Err(format!(
            "sphere mass = {m} (>= 0) and gravity = {g} must be finite"
        ));
    }
    let (mech, k, free_holder, c, contact_damping) = mechanics(s)?;
    let (omega, xb_amp) = match s.base {
        Some(b) => {
            if !(ok(b.amplitude) && b.amplitude >= 0.0 && ok(b.frequency) && b.frequency > 0.0) {
                return Err(format!(
                    "base amplitude = {} (>= 0) and frequency = {} (> 0) must be finite",
                    b.amplitude, b.frequency
                ));
            }
            (2.0 * PI * b.frequency, b.amplitude)
        }
        None => (0.0, 0.0),
    };
    let a_jump = jkr::jump_in_radius(&mat, w0);
    let seed = match s.formation {
        ContactFormation::JumpIn => a_jump,
        ContactFormation::Seed(r) => {
            if !(ok(r) && r > 0.0) {
                return Err(format!("contact seed radius = {r} must be finite and > 0"));
            }
            r
        }
    };
    let a_floor = (1e-3 * a_jump).min(0.1 * seed);
    let mut len_scale = (a_jump * a_jump / mat.r).max(xb_amp);
    if let Some(g0) = scales.gap {
        len_scale = len_scale.max(g0.abs());
    }
    let kc = jkr::contact_stiffness(&mat, a_jump);
    let mut t_free = f64::INFINITY;
    if mech == Mechanics::Dynamic {
        t_free = 2.0 * PI * (m / (k + kc)).sqrt();
    }
    let mut t_char = t_free;
    if omega > 0.0 {
        t_char = t_char.min(2.0 * PI / omega);
    }
    if !t_char.is_finite() {
        // Quasi-static scenes: the time scale of the protocol (spring-end motion).
        let v = scales.max_speed;
        t_char = if v > 0.0 { len_scale / v } else { 1.0 };
    }
    let vel_scale = len_scale * 2.0 * PI / t_char;
    Ok(Model {
        mat,
        law: s.law.clone(),
        w0,
        rate_independent: s.law.is_rate_independent(),
        mass: m,
        gravity: g,
        spring: k,
        free_holder,
        damping: c,
        contact_damping,
        mech,
        omega,
        xb_amp,
        shaker_delay: s
            .base
            .map_or(0.0, |b| if omega > 0.0 { b.phase / omega } else { 0.0 }),
        a_jump,
        a_floor,
        len_scale,
        vel_scale,
        t_char,
        t_free,
        fast: FastConstants {
            inv_r: 1.0 / mat.r,
            g_coef: 3.0 * mat.k / (8.0 * PI),
            inv_m: if m > 0.0 { 1.0 / m } else { 0.0 },
            gs: match &s.law {
                Law::GentSchultz(gs) => Some((gs.v0, gs.w0, 1.0 / gs.w0, 1.0 / gs.n)),
                _ => None,
            },
        },
    })
}

/// The prescribed motions during one stretch of a stage: the spring end moves linearly, the base
/// oscillates while the shaker is on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Drive {
    /// Spring-end position at `tk0` (m).
    pub xk0: f64,
    /// Reference time of the spring-end line (s).
    pub tk0: f64,
    /// Spring-end speed (m/s, signed: + towards the substrate).
    pub xk_speed: f64,
    /// Shaker on.
    pub shaker: bool,
    /// Time the shaker switched on (s).
    pub t_on: f64,
}

/// Prescribed quantities at one time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Kinematics {
    /// x_k (m).
    pub xk: f64,
    /// ẋ_k (m/s).
    pub vk: f64,
    /// x_b (m).
    pub xb: f64,
    /// ẋ_b (m/s).
    pub vb: f64,
    /// sin θ (0 with the shaker off).
    pub sin: f64,
    /// cos θ (0 with the shaker off).
    pub cos: f64,
}

impl Drive {
    /// The spring end held at `xk` (m), and the shaker on since t = 0 when `shaker`.
    pub fn held(xk: f64, shaker: bool) -> Self {
        Self {
            xk0: xk,
            tk0: 0.0,
            xk_speed: 0.0,
            shaker,
            t_on: 0.0,
        }
    }

    /// Spring-end position at t.
    #[inline]
    pub fn x_k(&self, t: f64) -> f64 {
        self.xk0 + self.xk_speed * (t - self.tk0)
    }

    /// Prescribed quantities at t (one sin_cos per call).
    #[inline]
    pub fn at(&self, m: &Model, t: f64) -> Kinematics {
        let (xb, vb, sin, cos) = if self.shaker && m.omega > 0.0 {
            let (s, c) = (m.omega * (t - self.t_on)).sin_cos();
            (m.xb_amp * s, m.xb_amp * m.omega * c, s, c)
        } else {
            (0.0, 0.0, 0.0, 0.0)
        };
        Kinematics {
            xk: self.x_k(t),
            vk: self.xk_speed,
            xb,
            vb,
            sin,
            cos,
        }
    }

    /// sin and cos of the base phase ω(t − t_on) at t ((0, 0) with the shaker off).
    #[inline]
    pub fn phase(&self, m: &Model, t: f64) -> (f64, f64) {
        if self.shaker && m.omega > 0.0 {
            (m.omega * (t - self.t_on)).sin_cos()
        } else {
            (0.0, 0.0)
        }
    }

    /// [`Drive::at`] for t = t0 + dt from the phase (sin, cos) at t0 ([`Drive::phase`]): the
    /// advance ω dt is applied by the angle-addition formulas with Taylor series of sin and cos
    /// (|ω dt| ≤ 1: error below 1e-16), so the stages of a step share one `sin_cos`.
    #[inline]
    pub fn at_advanced(&self, m: &Model, t: f64, phase0: (f64, f64), dt: f64) -> Kinematics {
        let d = m.omega * dt;
        if !(self.shaker && m.omega > 0.0) || d.abs() > 1.0 {
            return self.at(m, t);
        }
        let d2 = d * d;
        // Taylor series of sin and cos in Horner form, to d^17 and d^16 (|d| ≤ 1: the first
        // omitted terms are below 1/18! ≈ 1.6e-16).
        const S: [f64; 9] = [
            1.0,
            -1.0 / 6.0,
            1.0 / 120.0,
            -1.0 / 5040.0,
            1.0 / 362880.0,
            -1.0 / 39916800.0,
            1.0 / 6227020800.0,
            -1.0 / 1307674368000.0,
            1.0 / 355687428096000.0,
        ];
        const C: [f64; 9] = [
            1.0,
            -1.0 / 2.0,
            1.0 / 24.0,
            -1.0 / 720.0,
            1.0 / 40320.0,
            -1.0 / 3628800.0,
            1.0 / 479001600.0,
            -1.0 / 87178291200.0,
            1.0 / 20922789888000.0,
        ];
        // Horner's scheme in two halves evaluated side by side, the terms from d^8 on (below
        // 3e-6 of the first) joined to the first four at the end: as accurate as one Horner
        // chain, and a chain half as long for the stage to wait on.
        let d8 = (d2 * d2) * (d2 * d2);
        let poly = |c: &[f64; 9]| {
            let high = (((c[8] * d2 + c[7]) * d2 + c[6]) * d2 + c[5]) * d2 + c[4];
            let low = ((c[3] * d2 + c[2]) * d2 + c[1]) * d2 + c[0];
            low + high * d8
        };
        let (sd, cd) = (d * poly(&S), poly(&C));
        let (s0, c0) = phase0;
        let (s, c) = (s0 * cd + c0 * sd, c0 * cd - s0 * sd);
        Kinematics {
            xk: self.x_k(t),
            vk: self.xk_speed,
            xb: m.xb_amp * s,
            vb: m.xb_amp * m.omega * c,
            sin: s,
            cos: c,
        }
    }
}

impl Model {
    /// Contact stiffness and the a-only part of the force: F = kc δ − f0 with kc = 3Ka/2,
    /// f0 = K a³/(2R); both 0 out of contact.
    #[inline]
    fn contact_terms(&self, a: f64, contact: bool) -> (f64, f64) {
        if contact {
            (
                1.5 * self.mat.k * a,
                0.5 * self.mat.k * a * a * a * self.fast.inv_r,
            )
        } else {
            (0.0, 0.0)
        }
    }

    /// Damping coefficient on the sphere velocity and the one on the base velocity (the force is
    /// −c_v v − c_b ẋ_b).
    #[inline]
    fn damping_terms(&self, contact: bool) -> (f64, f64) {
        if self.contact_damping {
            if contact {
                (self.damping, self.damping)
            } else {
                (0.0, 0.0)
            }
        } else {
            (self.damping, 0.0)
        }
    }

    /// Total force on the sphere, down + (N): −c ẋ − k(x − x_k) − F + m g (eq. 30).
    #[inline]
    pub fn net_force(&self, kin: &Kinematics, x: f64, v: f64, a: f64, contact: bool) -> f64 {
        let (kc, f0) = self.contact_terms(a, contact);
        let (cv, cb) = self.damping_terms(contact);
        -cv * v - cb * kin.vb - self.spring * (x - kin.xk) - (kc * (x + kin.xb) - f0)
            + self.mass * self.gravity
    }

    /// Acceleration (Dynamic mechanics).
    #[inline]
    pub fn accel(&self, kin: &Kinematics, x: f64, v: f64, a: f64, contact: bool) -> f64 {
        self.net_force(kin, x, v, a, contact) * self.fast.inv_m
    }

    /// [`jkr::signed_energy_release_rate`] with precomputed 1/R and 3K/(8π).
    #[inline]
    pub fn signed_g(&self, a: f64, delta: f64) -> f64 {
        // c/a does not wait for u: the division overlaps the rest of the chain.
        let c_a = self.fast.g_coef / a;
        let u = a * a * self.fast.inv_r - delta;
        c_a * (u * u.abs())
    }

    /// dG/dt of [`Model::signed_g`] along a motion with rates ȧ and δ̇:
    /// G = c u|u|/a, u = a²/R − δ ⇒ Ġ = c (|u|/a)(2u̇ − u ȧ/a), u̇ = 2aȧ/R − δ̇.
    #[inline]
    pub fn signed_g_rate(&self, a: f64, delta: f64, adot: f64, delta_dot: f64) -> f64 {
        let u = a * a * self.fast.inv_r - delta;
        let udot = 2.0 * a * adot * self.fast.inv_r - delta_dot;
        self.fast.g_coef * u.abs() / a * (2.0 * udot - u * adot / a)
    }

    /// The law's crack speed ȧ(G) ([`crate::adhesion::AdhesionLaw::crack_speed`]); for
    /// Gent–Schultz in closed form with precomputed 1/w0 and 1/n (one division, for healing).
    #[inline]
    pub fn crack_speed(&self, g: f64) -> f64 {
        match self.fast.gs {
            Some((v0, w0, inv_w0, inv_n)) => {
                let root = |x: f64| {
                    if x > 0.0 {
                        (x.log2() * inv_n).exp2()
                    } else {
                        0.0
                    }
                };
                if g.is_nan() {
                    f64::NAN
                } else if g >= w0 {
                    -v0 * root(g * inv_w0 - 1.0)
                } else if g > 0.0 {
                    v0 * root(w0 / g - 1.0)
                } else {
                    f64::INFINITY
                }
            }
            None => self.law.crack_speed(g),
        }
    }

    /// The stiffness −∂ȧ/∂a (1/s, at fixed δ) of the contact-radius equation of a healing
    /// contact (0 < G < w0, ȧ > 0) under the Gent–Schultz law, from the state's G and ȧ:
    /// ∂ȧ/∂G = −ȧ w0/(n G (w0 − G)) and ∂G/∂a = 4c|u|/R − G/a with |u| = √(G a/c),
    /// c = 3K/(8π). It grows without bound as G → 0 (deep healing: ȧ ∝ G^(−1/n)); 0 for other
    /// laws, peeling, and where it is not defined.
    #[inline]
    pub fn healing_stiffness(&self, a: f64, g: f64, adot: f64) -> f64 {
        let Some((_, w0, _, inv_n)) = self.fast.gs else {
            return 0.0;
        };
        if !(adot > 0.0 && g > 0.0 && g < w0 && a > 0.0) {
            return 0.0;
        }
        let c = self.fast.g_coef;
        let u = (g * a / c).sqrt();
        let dg_da = 4.0 * c * u * self.fast.inv_r - g / a;
        let dadot_dg = adot * w0 * inv_n / (g * (w0 - g));
        (dadot_dg * dg_da).max(0.0)
    }

    /// Sphere position and velocity at a stage with known contact radius a.
    ///
    /// Dynamic: the implicit stage x = X + hγ v, m v = m V + hγ f(x, v) is linear in (x, v) at
    /// fixed a (F is linear in δ), solved in closed form. QuasiStatic: the force balance (with
    /// the velocity by the chain rule, using ȧ = `adot`). Rigid: x = x_k.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub fn position(
        &self,
        kin: &Kinematics,
        a: f64,
        adot: f64,
        contact: bool,
        xk_known: f64,
        vk_known: f64,
        hg: f64,
    ) -> (f64, f64) {
        match self.mech {
            Mechanics::Dynamic => {
                let (kc, f0) = self.contact_terms(a, contact);
                let (cv, cb) = self.damping_terms(contact);
                let b0 = -cb * kin.vb + self.spring * kin.xk - kc * kin.xb
                    + f0
                    + self.mass * self.gravity;
                let kt = self.spring + kc;
                let den = self.mass + hg * cv + hg * hg * kt;
                let v = (self.mass * vk_known + hg * (b0 - kt * xk_known)) / den;
                (xk_known + hg * v, v)
            }
            Mechanics::QuasiStatic => {
                if contact {
                    let kk = self.mat.k;
                    let r = self.mat.r;
                    let kc = 1.5 * kk * a;
                    let n = self.spring * kin.xk - kc * kin.xb + 0.5 * kk * a * a * a / r;
                    let d = self.spring + kc;
                    let x = n / d;
                    let dn = self.spring * kin.vk - kc * kin.vb
                        + adot * (-1.5 * kk * kin.xb + 1.5 * kk * a * a / r);
                    let dd = 1.5 * kk * adot;
                    (x, (dn - x * dd) / d)
                } else {
                    (kin.xk, kin.vk)
                }
            }
            Mechanics::Rigid => (kin.xk, kin.vk),
        }
    }

    /// Contact force F(a, δ) (0 out of contact).
    #[inline]
    pub fn force(&self, a: f64, delta: f64, contact: bool) -> f64 {
        // = jkr::contact_force (K a/2)(3δ − a²/R), without its division.
        let (kc, f0) = self.contact_terms(a, contact);
        kc * delta - f0
    }

    /// Force of the holder on the sphere, down +: k (x_k − x_s) for a spring; for a rigid link its
    /// reaction F − m g (quasi-static); 0 without a holder.
    #[inline]
    pub fn holder_force(&self, kin: &Kinematics, x: f64, force: f64) -> f64 {
        match self.mech {
            Mechanics::Rigid => force - self.mass * self.gravity,
            _ => self.spring * (kin.xk - x),
        }
    }

    /// Work of adhesion at rate ȧ (w0 for a rate-independent law).
    #[inline]
    pub fn work_of_adhesion(&self, adot: f64) -> f64 {
        if self.rate_independent {
            self.w0
        } else {
            self.law.work_of_adhesion(adot)
        }
    }

    /// w(ȧ) and its slope dw/dȧ in closed form, for the laws that have one (Gent–Schultz,
    /// constant); `None` for the others (their stages use the derivative-free root solve).
    /// Gent–Schultz with f = (|ȧ|/v0)^n: peeling w = w0 (1 + f), dw/dȧ = −w0 n f/|ȧ|; healing
    /// w = w0/(1 + f), dw/dȧ = −w0 n f/(|ȧ| (1 + f)²). At ȧ = 0 the slope is −∞ for n < 1 (the
    /// kink of the law), −w0/v0 for n = 1, 0 for n > 1. One `powf` per call.
    #[inline]
    pub fn work_and_slope(&self, adot: f64) -> Option<(f64, f64)> {
        match &self.law {
            Law::Constant(_) => Some((self.w0, 0.0)),
            Law::GentSchultz(gs) => {
                let s = adot.abs();
                if s == 0.0 {
                    let slope = if gs.n < 1.0 {
                        f64::NEG_INFINITY
                    } else if gs.n > 1.0 {
                        0.0
                    } else {
                        -gs.w0 / gs.v0
                    };
                    return Some((gs.w0, slope));
                }
                let f = (s / gs.v0).powf(gs.n);
                let nf = gs.n * f / s;
                if adot < 0.0 {
                    Some((gs.w0 * (1.0 + f), -gs.w0 * nf))
                } else {
                    let d = 1.0 + f;
                    Some((gs.w0 / d, -gs.w0 * nf / (d * d)))
                }
            }
            _ => None,
        }
    }

    /// True when [`Model::work_and_slope`] has a closed form for this law.
    #[inline]
    pub fn has_law_slope(&self) -> bool {
        matches!(self.law, Law::Constant(_) | Law::GentSchultz(_))
    }

    /// Sphere position at a stage with contact radius a (in contact) and its derivative dx/da,
    /// for the implicit stage's Newton iteration: the closed forms of [`Model::position`]
    /// differentiated in a (Dynamic: through kc = 3Ka/2 and f0 = Ka³/(2R) in the linear stage
    /// solve; QuasiStatic: x = n/d of the force balance; Rigid: x = x_k, dx/da = 0).
    #[inline]
    pub fn position_slope(
        &self,
        kin: &Kinematics,
        a: f64,
        xk_known: f64,
        vk_known: f64,
        hg: f64,
    ) -> (f64, f64) {
        let kk = self.mat.k;
        let r = self.mat.r;
        match self.mech {
            Mechanics::Dynamic => {
                let kc = 1.5 * kk * a;
                let f0 = 0.5 * kk * a * a * a / r;
                let (cv, cb) = self.damping_terms(true);
                let b0 = -cb * kin.vb + self.spring * kin.xk - kc * kin.xb
                    + f0
                    + self.mass * self.gravity;
                let kt = self.spring + kc;
                let den = self.mass + hg * cv + hg * hg * kt;
                let num = self.mass * vk_known + hg * (b0 - kt * xk_known);
                let v = num / den;
                let dkc = 1.5 * kk;
                let dnum = hg * (-dkc * kin.xb + 1.5 * kk * a * a / r - dkc * xk_known);
                let dv = (dnum - v * hg * hg * dkc) / den;
                (xk_known + hg * v, hg * dv)
            }
            Mechanics::QuasiStatic => {
                let kc = 1.5 * kk * a;
                let n = self.spring * kin.xk - kc * kin.xb + 0.5 * kk * a * a * a / r;
                let d = self.spring + kc;
                let x = n / d;
                let dn = -1.5 * kk * kin.xb + 1.5 * kk * a * a / r;
                (x, (dn - x * 1.5 * kk) / d)
            }
            Mechanics::Rigid => (kin.xk, 0.0),
        }
    }

    /// Integrands of the quadrature states at one instant; `w` is w(ȧ) (already known).
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub fn integrands(
        &self,
        kin: &Kinematics,
        x: f64,
        v: f64,
        a: f64,
        adot: f64,
        w: f64,
        contact: bool,
    ) -> [f64; NQ] {
        let delta = x + kin.xb;
        let f = self.force(a, delta, contact);
        let fs = self.holder_force(kin, x, f);
        let (s, c) = (kin.sin, kin.cos);
        let ddot = v + kin.vb;
        let (fb, diss) = if self.contact_damping {
            if contact {
                (f + self.damping * ddot, self.damping * ddot * ddot)
            } else {
                (0.0, 0.0)
            }
        } else {
            (f, self.damping * v * v)
        };
        let dadh = if contact && !self.rate_independent {
            (self.w0 - w) * 2.0 * PI * a * adot
        } else {
            0.0
        };
        let whold = match self.mech {
            Mechanics::Rigid => 0.0,
            _ => fs * kin.vk,
        };
        let a = if contact { a } else { 0.0 };
        [
            f,
            f * s,
            f * c,
            x * s,
            x * c,
            a,
            a * s,
            a * c,
            x,
            kin.xk,
            fs,
            fs * s,
            fs * c,
            fb * kin.vb,
            diss,
            dadh,
            whold,
        ]
    }
}

/// Elastic energy stored in a contact of radius a at indentation δ (J):
/// U = (3K/4) a δ² − (K/2) a³ δ / R + (3K/20) a⁵ / R², so that ∂U/∂δ = F and ∂U/∂a = 2πa G
/// (derivation: integrate F over δ at fixed a, fix the a-dependent constant by ∂U/∂a = (3K/4) u²).
pub fn elastic_energy(m: &Material, a: f64, delta: f64) -> f64 {
    let (k, r) = (m.k, m.r);
    0.75 * k * a * delta * delta - 0.5 * k * a * a * a * delta / r + 0.15 * k * a.powi(5) / (r * r)
}

/// Total mechanical energy (J): ½ m v² + ½ k (x − x_k)² − m g x + U(a, δ) − w0 π a². Its rate is
/// (base work) + (spring-end work) − (viscous dissipation) − (adhesive dissipation), which the
/// quadrature states integrate (see [`q`]).
pub fn total_energy(model: &Model, kin: &Kinematics, x: f64, v: f64, a: f64, contact: bool) -> f64 {
    let mut e = 0.5 * model.mass * v * v + 0.5 * model.spring * (x - kin.xk).powi(2)
        - model.mass * model.gravity * x;
    if contact {
        e += elastic_energy(&model.mat, a, x + kin.xb) - model.w0 * PI * a * a;
    }
    e
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The precomputed hot-path forms agree with the library's: G with jkr's, ȧ(G) with the law's
    /// (Gent–Schultz for n < 1, = 1, > 1, and a law without a closed form), over peeling, healing
    /// and the singular edge G ≤ 0.
    #[test]
    fn fast_forms_match_library() {
        use crate::adhesion::{GentSchultz, SaturatedGentSchultz};
        let laws = [
            Law::GentSchultz(GentSchultz::PAPER),
            Law::GentSchultz(GentSchultz {
                n: 1.0,
                ..GentSchultz::PAPER
            }),
            Law::GentSchultz(GentSchultz {
                n: 1.5,
                ..GentSchultz::PAPER
            }),
            Law::Saturated(SaturatedGentSchultz {
                base: GentSchultz::PAPER,
                v_sat: 1e-2,
            }),
        ];
        for law in laws {
            let (rig, _) = crate::dynamics::test_hold(law);
            let m = resolve(&rig, RunScales::default()).unwrap();
            for &a in &[1e-5, 1.2e-3, 3e-2] {
                for &d in &[-1e-5, 0.0, 1e-7, 2e-5, 1e-3] {
                    let (g0, g1) = (
                        jkr::signed_energy_release_rate(&m.mat, a, d),
                        m.signed_g(a, d),
                    );
                    assert!(
                        (g0 - g1).abs() <= 4.0 * f64::EPSILON * g0.abs(),
                        "{g0} vs {g1}"
                    );
                    // Ġ against a central difference of G along a(t) = a + ȧt, δ(t) = δ + δ̇t.
                    let (ad, dd, dt) = (3e-3, -2e-2, 1e-9);
                    let fd = (m.signed_g(a + ad * dt, d + dd * dt)
                        - m.signed_g(a - ad * dt, d - dd * dt))
                        / (2.0 * dt);
                    let gr = m.signed_g_rate(a, d, ad, dd);
                    assert!((gr - fd).abs() <= 1e-5 * gr.abs().max(1e-3), "{gr} vs {fd}");
                }
            }
            for k in -40..=40 {
                let g = m.w0 * (1.0 + f64::from(k) / 20.0).max(0.0) * (1.0 + 1e-3 * f64::from(k));
                let (v0, v1) = (m.law.crack_speed(g), m.crack_speed(g));
                let same = if v0.is_infinite() {
                    v1.is_infinite() && v1 > 0.0 && v0 > 0.0
                } else {
                    (v0 - v1).abs() <= 1e-13 * v0.abs()
                };
                assert!(same, "{:?}, G = {g}: {v0} vs {v1}", m.law);
            }
        }
    }

    /// The phase advance by Taylor series agrees with a direct `sin_cos` over the whole range it
    /// is used for (|ω dt| ≤ 1), and falls back to it beyond, to the rounding of the direct
    /// route's phase ω(t − t_on) (a few ulp of θ ≈ 10³ rad here, ~1e-13).
    #[test]
    fn advanced_kinematics_match_direct() {
        let (rig, _) = crate::dynamics::test_hold(crate::adhesion::Law::GentSchultz(
            crate::adhesion::GentSchultz::PAPER,
        ));
        let m = resolve(&rig, RunScales::default()).unwrap();
        // θ0 ≈ 10³ rad, and θ0 = 0.5 rad with t_on = 0, where the times round to far below the
        // series' error and it is tested alone (to ~1e-15).
        for (t0, t_on) in [(0.7123, 0.3), (0.5 / m.omega, 0.0)] {
            let drive = Drive {
                xk0: 1e-5,
                tk0: 0.0,
                xk_speed: -1e-4,
                shaker: true,
                t_on,
            };
            let p0 = drive.phase(&m, t0);
            let ulp_theta = f64::EPSILON * m.omega * (t0.abs() + t_on.abs() + 2.0 / m.omega);
            for k in 0..=200 {
                let dt = (k as f64 / 100.0 - 1.0) * 1.2 / m.omega;
                let (a, b) = (
                    drive.at(&m, t0 + dt),
                    drive.at_advanced(&m, t0 + dt, p0, dt),
                );
                for (x, y, scale) in [
                    (a.sin, b.sin, 1.0),
                    (a.cos, b.cos, 1.0),
                    (a.xb, b.xb, m.xb_amp),
                    (a.vb, b.vb, m.xb_amp * m.omega),
                    (a.xk, b.xk, 1e-5),
                ] {
                    assert!(
                        (x - y).abs() <= 4.0 * ulp_theta * scale,
                        "t0 {t0}, dt {dt:e}: {x} vs {y}"
                    );
                }
            }
        }
    }

    #[test]
    fn elastic_energy_derivatives() {
        let m = Material::PAPER;
        let (a, d) = (1e-3, 5e-6);
        let h = 1e-9;
        let df = (elastic_energy(&m, a, d + h) - elastic_energy(&m, a, d - h)) / (2.0 * h);
        let f = jkr::contact_force(&m, a, d);
        assert!((df - f).abs() < 1e-6 * f.abs());
        let ha = 1e-9;
        let da = (elastic_energy(&m, a + ha, d) - elastic_energy(&m, a - ha, d)) / (2.0 * ha);
        let g = jkr::energy_release_rate(&m, a, d);
        assert!((da - 2.0 * PI * a * g).abs() < 1e-6 * (2.0 * PI * a * g));
    }
}

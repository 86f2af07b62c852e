//! The physical rig: the contact pair and its adhesion law, the sphere, how it is held, the
//! damping, the shaker under the substrate and how contact forms at impact.
//!
//! This is the one definition of the mechanical system (eq. 30) that every model takes: the
//! time-domain simulator ([`crate::dynamics`]), the linear transfer ([`crate::transfer`]),
//! harmonic balance ([`crate::describing`]) and the periodic steady state ([`crate::steady`]).
//! A scenario file is a rig plus an initial state, a protocol, solver and output settings
//! (the `djkr` crate's `Scenario`).
//!
//! Coordinates (docs/MODEL.md): x_s sphere position (down +), x_b base displacement (up +), x_k
//! the far end of the holding spring (down +), δ = x_s + x_b the indentation (> 0 compresses).

use crate::adhesion::{AdhesionLaw, Law};
use crate::error::ParamError;
use crate::jkr;
use crate::material::Material;
use serde::Serialize;
use thiserror::Error;

/// The sphere.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sphere {
    /// Mass m (kg). Zero selects the quasi-static force balance (no inertia).
    pub mass: f64,
    /// Gravitational acceleration g (m/s²), acting downward (towards the substrate).
    pub gravity: f64,
}

/// How the sphere is held.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Holder {
    /// No spring: the sphere rests on its own weight (k = 0, x_k unused).
    None,
    /// A linear spring of stiffness k (N/m) whose far end x_k(t) the protocol moves.
    Spring {
        /// Stiffness k (N/m).
        stiffness: f64,
    },
    /// A rigid link: the sphere follows x_k(t) exactly; only a(t) is integrated (the paper's
    /// quasi-static test). δ(t) = x_k(t) + x_b(t) is prescribed.
    Rigid,
}

impl Holder {
    /// True when the holder can exert a force that the protocol controls: a spring with k > 0,
    /// or a rigid link. Without one the sphere's weight alone carries the start.
    pub fn exerts_force(self) -> bool {
        match self {
            Holder::None => false,
            Holder::Spring { stiffness } => stiffness > 0.0,
            Holder::Rigid => true,
        }
    }
}

/// Where viscous damping acts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum DampingOn {
    /// On the sphere's absolute velocity, eq. (30): c ẋ_s.
    Sphere,
    /// On the indentation rate, eq. (3) (Shui et al.): c δ̇, only while in contact.
    Contact,
}

/// Viscous damping.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Damping {
    /// Coefficient c (N s/m).
    pub c: f64,
    /// Where it acts.
    pub on: DampingOn,
}

/// Harmonic base motion x_b = X_b sin(2π f (t − t_on)) while the shaker is on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BaseMotion {
    /// Amplitude X_b (m).
    pub amplitude: f64,
    /// Frequency f (Hz).
    pub frequency: f64,
    /// Phase φ (rad, [0, 2π)) of the base motion relative to the protocol's clock: the shaker
    /// starts φ/ω after the stage that switches it on begins, at phase 0 of its own motion, so
    /// that x_b stays continuous (0 until then). Ensembles draw it to sample the relation
    /// between the vibration and the protocol.
    pub phase: f64,
}

/// How contact forms when the gap closes (impact).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ContactFormation {
    /// Instantly at the JKR jump-in radius a³ = 8πw0R²/(3K).
    JumpIn,
    /// From a small seed radius (m), then rate-limited by the healing law.
    Seed(f64),
}

/// The physical rig (SI).
#[derive(Debug, Clone, PartialEq)]
pub struct Rig {
    /// Contact pair.
    pub material: Material,
    /// Adhesion law (constant w0 when the scene declares none).
    pub law: Law,
    /// Sphere.
    pub sphere: Sphere,
    /// Spring, rigid link or none.
    pub holder: Holder,
    /// Damping (none when absent).
    pub damping: Option<Damping>,
    /// Base motion (no vibration when absent).
    pub base: Option<BaseMotion>,
    /// How contact forms at impact.
    pub formation: ContactFormation,
}

/// How the mean load of a static contact is set.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Support {
    /// The spring's far end sits at x_k (m, down +).
    SpringEnd(f64),
    /// x_k is placed so that the static JKR contact (w0, no vibration) carries this compressive
    /// force P (N): x_k = δ0 + (P − m g)/k, δ0 the static indentation under P. Without a spring
    /// the load must equal m g; with a rigid link x_k = δ0.
    StaticLoad(f64),
}

/// A static contact (no vibration, w = w0) and where the holder sits.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct StaticState {
    /// Contact radius a_0 (m).
    pub a: f64,
    /// Indentation δ_0 (m).
    pub delta: f64,
    /// Contact force F_0 (N, compressive +).
    pub force: f64,
    /// Spring end x_k (m).
    pub x_k: f64,
}

/// Why a rig has no static contact under a support.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum StaticError {
    /// An input is out of range.
    #[error(transparent)]
    Param(#[from] ParamError),
    /// The load is not carried by a JKR contact, or the spring does not hold the sphere.
    #[error("{0}")]
    NoContact(String),
}

impl Rig {
    /// Sphere mass m (kg).
    pub fn mass(&self) -> f64 {
        self.sphere.mass
    }

    /// Weight m g (N, towards the substrate).
    pub fn weight(&self) -> f64 {
        self.sphere.mass * self.sphere.gravity
    }

    /// Holding-spring stiffness k (N/m): 0 without a spring and for a rigid link.
    pub fn spring_stiffness(&self) -> f64 {
        match self.holder {
            Holder::Spring { stiffness } => stiffness,
            Holder::None | Holder::Rigid => 0.0,
        }
    }

    /// Damping coefficient c (N s/m; 0 without damping).
    pub fn damping_coefficient(&self) -> f64 {
        self.damping.map_or(0.0, |d| d.c)
    }

    /// Where the damping acts (on the sphere when there is none).
    pub fn damping_on(&self) -> DampingOn {
        self.damping.map_or(DampingOn::Sphere, |d| d.on)
    }

    /// Quasi-static work of adhesion w0 of the law (J/m²).
    pub fn w0(&self) -> f64 {
        self.law.w0()
    }

    /// The sphere has inertia: a mass and a holder that is not a rigid link.
    pub fn has_inertia(&self) -> bool {
        self.sphere.mass > 0.0 && !matches!(self.holder, Holder::Rigid)
    }

    /// Check the mechanical constants: m, k, c finite and ≥ 0, g finite.
    pub fn check_mechanics(&self) -> Result<(), ParamError> {
        let ok = |v: f64| v.is_finite() && v >= 0.0;
        let (m, k, c, g) = (
            self.mass(),
            self.spring_stiffness(),
            self.damping_coefficient(),
            self.sphere.gravity,
        );
        if !ok(m) {
            return Err(ParamError::new("mass", m, "must be finite and >= 0 kg"));
        }
        if !ok(k) {
            return Err(ParamError::new(
                "stiffness",
                k,
                "must be finite and >= 0 N/m",
            ));
        }
        if !ok(c) {
            return Err(ParamError::new(
                "damping",
                c,
                "must be finite and >= 0 N s/m",
            ));
        }
        if !g.is_finite() {
            return Err(ParamError::new("gravity", g, "must be finite (m/s^2)"));
        }
        Ok(())
    }

    /// The static contact under `support` at w0 (no vibration).
    ///
    /// StaticLoad(P): the JKR radius for P on the stable branch; x_k = δ0 + (P − m g)/k with a
    /// spring, δ0 with a rigid link; without a holder P must equal m g (within 1e-9) and x_k = 0.
    /// SpringEnd(x_k): the largest root a of F_eq(a) + k(δ_eq(a) − x_k) − m g = 0 (the root on
    /// the stable branch; without a spring the radius for the load m g).
    pub fn static_state(&self, support: Support) -> Result<StaticState, StaticError> {
        self.material.validate()?;
        self.check_mechanics()?;
        let m = &self.material;
        let w0 = self.w0();
        if !(w0.is_finite() && w0 >= 0.0) {
            return Err(ParamError::new("w0", w0, "must be finite and >= 0 J/m^2").into());
        }
        let weight = self.weight();
        let k = self.spring_stiffness();
        let load = match support {
            Support::StaticLoad(p) => {
                if !p.is_finite() {
                    return Err(ParamError::new("static load", p, "must be finite (N)").into());
                }
                if self.holder == Holder::None
                    && (p - weight).abs() > 1e-9 * p.abs().max(weight.abs())
                {
                    return Err(ParamError::new(
                        "static load",
                        p,
                        format!("without a spring must equal the weight m g = {weight} N"),
                    )
                    .into());
                }
                p
            }
            Support::SpringEnd(x_k) => {
                if !x_k.is_finite() {
                    return Err(ParamError::new("x_k", x_k, "must be finite (m)").into());
                }
                if k > 0.0 {
                    let a = spring_end_radius(m, w0, k, weight, x_k)?;
                    let d = jkr::equilibrium_indentation(m, a, w0);
                    return Ok(StaticState {
                        a,
                        delta: d,
                        force: weight - k * (d - x_k),
                        x_k,
                    });
                }
                weight
            }
        };
        let a = jkr::equilibrium_radius_for_force(m, load, w0)
            .filter(|a| a.is_finite() && *a > 0.0)
            .ok_or_else(|| {
                StaticError::NoContact(format!(
                    "load {load} N is not carried by a JKR contact (pull-off force {} N)",
                    jkr::load_controlled_pull_off_force(m, w0)
                ))
            })?;
        let delta = jkr::equilibrium_indentation(m, a, w0);
        let x_k = match (support, self.holder) {
            (Support::SpringEnd(x), _) => x,
            (Support::StaticLoad(_), Holder::Rigid) => delta,
            (Support::StaticLoad(_), Holder::None) => 0.0,
            (Support::StaticLoad(p), Holder::Spring { .. }) => delta + (p - weight) / k,
        };
        Ok(StaticState {
            a,
            delta,
            force: load,
            x_k,
        })
    }
}

/// The static radius for a spring end at x_k: the largest root of
/// F_eq(a) + k(δ_eq(a) − x_k) − m g = 0, bracketed by a geometric scan down from above the
/// jump-in radius and refined by bisection (f is continuous; 200 halvings reach the rounding
/// floor).
fn spring_end_radius(
    m: &Material,
    w0: f64,
    k: f64,
    weight: f64,
    x_k: f64,
) -> Result<f64, StaticError> {
    let f = |a: f64| {
        jkr::equilibrium_force(m, a, w0) + k * (jkr::equilibrium_indentation(m, a, w0) - x_k)
            - weight
    };
    // Upper end: f > 0 for large a.
    let mut hi = jkr::jump_in_radius(m, w0.max(1e-300)).max(1e-9 * m.r);
    let mut guard = 0;
    while f(hi) <= 0.0 {
        hi *= 2.0;
        guard += 1;
        if guard > 200 || !hi.is_finite() {
            return Err(StaticError::NoContact(format!(
                "no contact equilibrium for x_k = {x_k} m"
            )));
        }
    }
    let lo_limit = 1e-12 * hi;
    let mut lo = hi;
    loop {
        lo *= 0.9;
        if lo < lo_limit {
            return Err(StaticError::NoContact(format!(
                "x_k = {x_k} m: the spring does not hold the sphere in contact"
            )));
        }
        if f(lo) <= 0.0 {
            break;
        }
        hi = lo;
    }
    Ok(crate::numerics::bisect(lo, hi, 0.0, |a| f(a) <= 0.0).1)
}

/// The light rig: the paper's material with `law`, a 3 g sphere (g = 9.81 m/s²) held by a
/// 200 N/m spring, light sphere damping c = 0.02 N s/m, no base motion, jump-in contact
/// formation. (k_c = 3/2 K a ≈ 16 kN/m at 20 mN: resonance near 370 Hz.)
pub fn light_rig(law: Law) -> Rig {
    Rig {
        material: Material::PAPER,
        law,
        sphere: Sphere {
            mass: 3e-3,
            gravity: 9.81,
        },
        holder: Holder::Spring { stiffness: 200.0 },
        damping: Some(Damping {
            c: 0.02,
            on: DampingOn::Sphere,
        }),
        base: None,
        formation: ContactFormation::JumpIn,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::adhesion::{ConstantW, GentSchultz};

    fn rig(holder: Holder) -> Rig {
        Rig {
            material: Material::PAPER,
            law: Law::GentSchultz(GentSchultz::PAPER),
            sphere: Sphere {
                mass: 3e-3,
                gravity: 9.81,
            },
            holder,
            damping: None,
            base: None,
            formation: ContactFormation::JumpIn,
        }
    }

    /// Under a preload the contact carries it on the JKR curve, and the spring end balances it
    /// with the weight; a spring end found from that x_k gives the same contact back.
    #[test]
    fn preload_and_spring_end_agree() {
        let r = rig(Holder::Spring { stiffness: 200.0 });
        let s = r.static_state(Support::StaticLoad(0.02)).unwrap();
        let m = &r.material;
        assert!((jkr::equilibrium_force(m, s.a, r.w0()) - 0.02).abs() < 1e-14);
        assert!((0.02 - (r.weight() - 200.0 * (s.delta - s.x_k))).abs() < 1e-14);
        let back = r.static_state(Support::SpringEnd(s.x_k)).unwrap();
        assert!((back.a / s.a - 1.0).abs() < 1e-12, "{} vs {}", back.a, s.a);
        assert!((back.force - 0.02).abs() < 1e-12);
    }

    #[test]
    fn holders_and_refusals() {
        let rigid = rig(Holder::Rigid)
            .static_state(Support::StaticLoad(0.05))
            .unwrap();
        assert_eq!(rigid.x_k.to_bits(), rigid.delta.to_bits());
        let free = rig(Holder::None);
        assert!(free.static_state(Support::StaticLoad(0.05)).is_err());
        let s = free
            .static_state(Support::StaticLoad(free.weight()))
            .unwrap();
        assert_eq!(s.x_k.to_bits(), 0.0f64.to_bits());
        let mut c = rig(Holder::Spring { stiffness: 200.0 });
        c.law = Law::Constant(ConstantW { w0: 0.24 });
        let po = jkr::load_controlled_pull_off_force(&c.material, 0.24);
        assert!(matches!(
            c.static_state(Support::StaticLoad(1.01 * po)),
            Err(StaticError::NoContact(_))
        ));
    }
}

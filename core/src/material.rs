//! The contact pair: substrate modulus, sphere radius, quasi-static work of adhesion.

use crate::error::{positive, ParamError};
use serde::{Deserialize, Serialize};

/// Elastic and adhesive constants of the sphere/substrate pair (SI).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Material {
    /// JKR elastic constant K = 4E*/3 (Pa).
    #[serde(rename = "K")]
    pub k: f64,
    /// Sphere radius R (m).
    #[serde(rename = "R")]
    pub r: f64,
    /// Quasi-static work of adhesion w0 (J/m²).
    pub w0: f64,
}

impl Material {
    /// The paper's Fig. 2 set: K = 9.33 MPa, R = 51 mm, w0 = 240 mJ/m².
    pub const PAPER: Material = Material {
        k: 9.33e6,
        r: 51e-3,
        w0: 0.240,
    };

    /// Check that every constant is finite and positive.
    pub fn validate(&self) -> Result<(), ParamError> {
        positive("K", self.k, "Pa")?;
        positive("R", self.r, "m")?;
        positive("w0", self.w0, "J/m^2")?;
        Ok(())
    }

    /// Quasi-static load-controlled JKR pull-off force F0 = −(3/2) π R w0 (N), the reference of
    /// every amplification.
    pub fn static_pull_off_force(&self) -> f64 {
        -1.5 * std::f64::consts::PI * self.r * self.w0
    }
}

impl Default for Material {
    fn default() -> Self {
        Self::PAPER
    }
}

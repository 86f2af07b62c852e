//! What the benchmarks share: the scene single right-hand sides are timed on (the catalogue's
//! 400 Hz hold), and one explicit right-hand side as a DP8 stage evaluates it, the unit of
//! `Stats::rhs_evals` for DP8.

use crate::catalogue::hold_400hz_1s;
use djkr_core::dynamics::model::{resolve, Drive, Model, NQ};
use std::hint::black_box;

/// One DP8 stage evaluation in contact and healing (G < w0): G, ȧ = law⁻¹(G), the
/// acceleration and the 17 quadrature integrands into the stage sum, the base phase advanced
/// from the step start. Each call advances the time by 1e-12 s, so no two calls are alike.
pub struct OneRhs {
    model: Model,
    drive: Drive,
    phase0: (f64, f64),
    a0: f64,
    d0: f64,
    dt: f64,
    qacc: [f64; NQ],
}

/// The model of the catalogue's 400 Hz hold (`catalogue::hold_400hz_1s`) and its drive with
/// the shaker on from t = 0: where the single right-hand sides are timed.
pub fn hold_model_and_drive() -> (Model, Drive) {
    let s = hold_400hz_1s();
    let model = match resolve(&s.rig, s.run_scales()) {
        Ok(m) => m,
        Err(e) => panic!("catalogue scene does not resolve: {e}"),
    };
    (model, Drive::held(0.0, true))
}

impl OneRhs {
    /// On the 400 Hz hold of the catalogue ([`hold_model_and_drive`]).
    pub fn new() -> Self {
        let (model, drive) = hold_model_and_drive();
        let phase0 = drive.phase(&model, 1e-4);
        let a0 = 1.2e-3;
        let d0 = djkr_core::jkr::equilibrium_indentation(&model.mat, a0, model.w0);
        Self {
            model,
            drive,
            phase0,
            a0,
            d0,
            dt: 0.0,
            qacc: [0.0; NQ],
        }
    }

    /// Evaluate once; returns ȧ (the caller passes it to `black_box`).
    #[inline]
    pub fn call(&mut self) -> Result<f64, djkr_core::dynamics::StepFail> {
        self.dt += 1e-12;
        let kin =
            self.drive
                .at_advanced(&self.model, 1e-4 + self.dt, self.phase0, black_box(self.dt));
        djkr_core::dynamics::kernels::rates(
            &self.model,
            &kin,
            black_box(self.d0 - kin.xb + 1e-7),
            0.01,
            self.a0,
            true,
            0.3,
            &mut self.qacc,
            false,
        )
        .map(|r| r.fa)
    }
}

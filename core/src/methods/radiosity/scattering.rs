//! The scattering S of a translucent object through its own TransCut diffusion solve
//! (design/radiosity.md §1.5 (a), "S_diff"): the transmitted irradiance q at its boundary
//! vertices is the source of M φ = b (TransCut eq. 12), and the exitance leaving each boundary
//! vertex is B = (φ − 2q)/(2A), the hemispherical integral of eq. 3. Exact with respect to
//! TransCut (concavities and heterogeneous media included, no profile), O(tets) memory, each
//! solve warm-started from the last.

use super::super::transcut::Prepared;
use super::super::{ObjectStats, Target};
use crate::progress::Cancelled;
use crate::radiosity::Scattering;
use crate::scene::{SceneError, TransCutOptions};

/// S of one translucent object, borrowing its prepared TransCut state (module documentation).
pub(super) struct DiffusionScattering<'a> {
    prepared: &'a mut Prepared,
    target: &'a Target<'a>,
    options: &'a TransCutOptions,
    stats: &'a mut ObjectStats,
    /// Asked during each solve: `Err` cancels.
    poll: &'a (dyn Fn(f64) -> Result<(), Cancelled> + Sync),
}

impl<'a> DiffusionScattering<'a> {
    pub(super) fn new(
        prepared: &'a mut Prepared,
        target: &'a Target<'a>,
        options: &'a TransCutOptions,
        stats: &'a mut ObjectStats,
        poll: &'a (dyn Fn(f64) -> Result<(), Cancelled> + Sync),
    ) -> Self {
        Self { prepared, target, options, stats, poll }
    }

    /// The object's refractive index.
    pub(super) fn eta(&self) -> f64 {
        self.prepared.system().boundary_terms().eta
    }
}

impl Scattering for DiffusionScattering<'_> {
    type Error = SceneError;

    fn scatter(&mut self, q: &[[f64; 3]]) -> Result<Vec<[f64; 3]>, SceneError> {
        let poll = self.poll;
        let stage = |_: &str, _: f64| poll(0.0);
        let solve_ms = self.stats.solve_ms;
        let t = std::time::Instant::now();
        self.prepared.solve_fluence(self.target, q, self.options, self.stats, &stage)?;
        self.stats.solve_ms = solve_ms + crate::progress::ms(t);
        Ok(self.prepared.exitance())
    }
}

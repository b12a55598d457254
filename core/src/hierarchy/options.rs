//! The choices of the hierarchical dipole, each with the paper's reading kept for reproduction
//! and the measured better one as the default (design/hierarchical-dipole.md §0).

use crate::optics::{fdr, ft_out, transmittance_out, DipoleGeometry, EdgeRule};

use super::oracle::Oracle;

/// Where the radiance is evaluated (design note §1.7).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Receivers {
    /// At every vertex, its normal the area-weighted mean of its triangles': the contract's
    /// per-vertex radiance without a smoothing step; a vertex on a triangle sees it through the
    /// form factor's corner case.
    #[default]
    Vertices,
    /// At every triangle's centroid (the paper's), averaged onto the vertices by area
    /// (Gouraud).
    FaceCentroids,
}

/// When links are made (Mertens et al. 2003 §5.5).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum EvalMode {
    /// Every update traverses the cluster trees afresh and gathers as it goes, storing no
    /// links: the least memory, the paper's mode for deforming meshes.
    #[default]
    OnTheFly,
    /// Links and their form factors are made once and kept while the geometry and the medium
    /// stay: an update (a relight) only pulls, gathers and pushes. A deformation or a new
    /// medium rebuilds every link.
    Render,
    /// Links kept, and after a deformation only the receiver subtrees whose links it touched
    /// are relinked, reusing the analytic form factors of leaf pairs that did not move. With
    /// `budget`, an update relinks subtrees (oldest first) only until that many links were
    /// evaluated, keeping the rest as they were: the error decays to zero once motion stops.
    Incremental { budget: Option<usize> },
}

/// Which exitant radiance the diffuse exitance B is turned into (design note §1.1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum DipoleRadiance {
    /// Lo = Ft(η, n)·B/(π(1 − Fdr)), Ft = T/η²: the quantity TransCut returns, integrating to
    /// exitance B with the Fdr fit the tet solver uses (and pbrt-v3's normalisation).
    #[default]
    MatchTransCut,
    /// Lo = T(η, n)·B/π, Jensen et al. 2001 and the paper's eq. 3: brighter by 1/(η²(1 − Fdr)),
    /// 1.066 at η = 1.3.
    Jensen2001,
}

impl DipoleRadiance {
    /// Lo along the normal per unit B at index `eta`.
    #[must_use]
    pub fn per_exitance(&self, eta: f64) -> f64 {
        match self {
            Self::MatchTransCut => ft_out(eta, 1.0) / (std::f64::consts::PI * (1.0 - fdr(eta))),
            Self::Jensen2001 => transmittance_out(eta, 1.0) / std::f64::consts::PI,
        }
    }
}

/// How the hierarchical dipole bakes.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DipoleOptions {
    pub geometry: DipoleGeometry,
    /// The edge rule of the near field's triangle form factor.
    pub rule: EdgeRule,
    pub oracle: Oracle,
    pub receivers: Receivers,
    pub mode: EvalMode,
    pub radiance: DipoleRadiance,
}

impl DipoleOptions {
    /// Checks the options.
    ///
    /// # Errors
    /// A message naming the option out of range.
    pub fn validate(&self) -> Result<(), String> {
        self.oracle.validate()?;
        let l = self.rule.max_l_over_r();
        if !(l > 0.0 && l <= 2.0) {
            return Err(format!("the edge rule's max_l_over_r must lie in (0, 2], got {l}"));
        }
        if let EvalMode::Incremental { budget: Some(0) } = self.mode {
            return Err("an incremental budget must be at least 1 link".into());
        }
        Ok(())
    }
}

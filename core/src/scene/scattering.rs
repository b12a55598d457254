//! Which scattering operator S the radiosity method gives its translucent objects
//! (design/radiosity.md §1.5): their own TransCut diffusion solve, or the paper's profile matrix
//! (Sheng et al. 2014 eq. 8, S_ji = ∫_{Aᵢ} R(d(x_j, y)) dA_y).

pub use crate::radiosity::HetRule;

/// The scattering operator S of every translucent object of a radiosity bake.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[non_exhaustive]
pub enum TranslucentScattering {
    /// Each object's TransCut diffusion solve on its tets (q → φ → B): exact with respect to
    /// TransCut, concavities and heterogeneous media included; the accuracy default.
    #[default]
    Diffusion,
    /// A profile matrix on the object's own surface refined to the patch size: no tets; a
    /// heterogeneous medium (layers, voxels, veins) through [`ProfileScatteringOptions::het`].
    Profile(ProfileScatteringOptions),
}

impl TranslucentScattering {
    /// The names front ends use, in the order they list them.
    pub const NAMES: &'static [&'static str] = &["diffusion", "half-space", "dipole"];

    /// The profile S of `profile` with chord distances.
    #[must_use]
    pub fn profile(profile: ProfileKind) -> TranslucentScattering {
        TranslucentScattering::Profile(ProfileScatteringOptions { profile, ..ProfileScatteringOptions::default() })
    }

    /// The choice called `name` (any case): `diffusion`, `half-space`, `dipole` (chord distances).
    #[must_use]
    pub fn from_name(name: &str) -> Option<TranslucentScattering> {
        match name.trim().to_ascii_lowercase().as_str() {
            "diffusion" => Some(TranslucentScattering::Diffusion),
            "half-space" => Some(Self::profile(ProfileKind::HalfSpace)),
            "dipole" => Some(Self::profile(ProfileKind::Dipole)),
            _ => None,
        }
    }

    /// The choice's name ([`TranslucentScattering::NAMES`]).
    #[must_use]
    pub fn name(&self) -> &'static str {
        match self {
            TranslucentScattering::Diffusion => "diffusion",
            TranslucentScattering::Profile(p) => p.profile.name(),
        }
    }

    /// Checks the options.
    ///
    /// # Errors
    /// A message naming the option out of range.
    pub fn validate(&self) -> Result<(), String> {
        match self {
            TranslucentScattering::Diffusion => Ok(()),
            TranslucentScattering::Profile(p) => p.validate(),
        }
    }
}

/// How the profile matrix is made.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProfileScatteringOptions {
    /// The radial profile of each channel.
    pub profile: ProfileKind,
    /// How the distance between two patches of an object is measured.
    pub distance: OpticalDistance,
    /// Each channel's profile is cut where at most this fraction of its total lies beyond, in
    /// (0, 0.5] (design §1.5: 10⁻³, about 35 mm for marble's red).
    pub tail: f64,
    /// How a path through several media of a heterogeneous object is given a profile value
    /// (Sheng et al. 2014 eq. 16 or the consistent rule, design pitfall 4); unused for a
    /// homogeneous one. [`HetRule::Sheng2014`] needs a finite R(0): the dipole profile.
    pub het: HetRule,
}

impl Default for ProfileScatteringOptions {
    fn default() -> Self {
        Self { profile: ProfileKind::HalfSpace, distance: OpticalDistance::Chord, tail: 1e-3, het: HetRule::Consistent }
    }
}

impl ProfileScatteringOptions {
    /// Checks the options.
    ///
    /// # Errors
    /// A message naming `scattering.tail` or `scattering.voxel_mm` and the value out of range.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.tail > 0.0 && self.tail <= 0.5) {
            return Err(format!("scattering.tail must lie in (0, 0.5], got {}", self.tail));
        }
        if let OpticalDistance::Interior { voxel_mm: Some(h), .. } = self.distance {
            if !(h.is_finite() && h > 0.0) {
                return Err(format!("scattering.voxel_mm must be finite and > 0, got {h}"));
            }
        }
        Ok(())
    }
}

/// The radial profile R(r) of the profile matrix (design §1.5, "Profiles").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[non_exhaustive]
pub enum ProfileKind {
    /// TransCut's half-space Green's function R_tc with its local term: its total is TransCut's
    /// half-space exitance per unit q, so it approaches the diffusion S as the radius of
    /// curvature grows (design pitfall 2; the recommended profile).
    #[default]
    HalfSpace,
    /// The classical dipole (Jensen et al. 2001), the paper's profile.
    Dipole,
}

impl ProfileKind {
    /// `half-space` or `dipole`.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            ProfileKind::HalfSpace => "half-space",
            ProfileKind::Dipole => "dipole",
        }
    }
}

/// The optical distance between two patches of one object (design §1.5, "Optical distance").
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[non_exhaustive]
pub enum OpticalDistance {
    /// The chord |x_j − xᵢ|: exact on a convex object, an overestimate of S across a concavity.
    #[default]
    Chord,
    /// The shortest path inside: the chord when it stays inside the object, else a truncated
    /// Dijkstra over a 26-connected voxel grid of the inside.
    Interior {
        /// The voxel edge in mm; `None`: a quarter of the object's smallest diffusion length
        /// 1/σtr (pitfall 3), no finer than the voxel budget allows.
        voxel_mm: Option<f64>,
        /// The any-angle (Theta*) relaxation, which removes the grid's metrication error.
        any_angle: bool,
    },
}

impl OpticalDistance {
    /// The interior distance with the default voxels and the any-angle relaxation.
    pub const INTERIOR: OpticalDistance = OpticalDistance::Interior { voxel_mm: None, any_angle: true };

    /// `chord` or `interior`.
    #[must_use]
    pub fn name(&self) -> &'static str {
        match self {
            OpticalDistance::Chord => "chord",
            OpticalDistance::Interior { .. } => "interior",
        }
    }

    /// The distance called `name` (`chord`, `interior`; any case).
    #[must_use]
    pub fn from_name(name: &str) -> Option<OpticalDistance> {
        match name.trim().to_ascii_lowercase().as_str() {
            "chord" => Some(OpticalDistance::Chord),
            "interior" => Some(OpticalDistance::INTERIOR),
            _ => None,
        }
    }
}

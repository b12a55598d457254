//! Profiles along a path through several media (Sheng et al. 2014 §4, eq. 16; design/radiosity.md
//! §1.5 and pitfall 4): the profile value of a path of total length r = Σ_m r_m made of length
//! r_m in medium m, each medium with its own profile R_m.
//!
//! - [`HetRule::Sheng2014`], the paper's eq. 16 generalised to k media:
//!   S = (Σ_m R_m(0) r_m/r) · Π_m R_m(r_m)/R_m(0). The authors call it "not physically accurate".
//!   It is not consistent: a homogeneous 10 mm marble path split into 5 + 5 mm of the same
//!   medium is multiplied by R(5)²/(R(0)R(10)) ≈ 0.026 (the paper merges nothing; here the
//!   lengths are merged per distinct medium first, which removes that case but not the
//!   dependence on how two different media are ordered along the path), and it needs R_m(0)
//!   finite (not the half-space profile, ∝ 1/r).
//! - [`HetRule::Consistent`] (the default): the length-weighted geometric mean of the profiles
//!   at the whole length, S = Π_m R_m(r)^{r_m/r} = exp(Σ_m (r_m/r) ln R_m(r)). It is exact for
//!   identical media (any split gives R(r)), continuous in the fractions, defined for every
//!   profile kind, and for exponential profiles a e^{−b_m r} it is a·e^{−Σ b_m r_m}, the
//!   attenuation of each medium along its own length (as Sheng2014 for those). The design's
//!   alternative Rd[σ̄](r)·exp(−Σσtr,m r_m + σ̄tr r) needs a profile rebuilt from mean
//!   coefficients per path, so it cannot serve measured tables; this one can.

use super::error::RadiosityError;
use super::profile::Profile;

/// How a path through several media is given a profile value (module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum HetRule {
    /// The length-weighted geometric mean Π_m R_m(r)^{r_m/r}.
    #[default]
    Consistent,
    /// Sheng et al. 2014 eq. 16, (Σ_m R_m(0) r_m/r) · Π_m R_m(r_m)/R_m(0).
    Sheng2014,
}

/// The lengths `segments` (medium index, length in mm ≥ 0), summed per distinct medium, sorted by
/// medium: what every rule works on (pitfall 4: eq. 16 on unmerged pieces is inconsistent).
#[must_use]
pub fn merge_lengths(segments: &[(usize, f64)]) -> Vec<(usize, f64)> {
    let mut out: Vec<(usize, f64)> = Vec::new();
    let mut sorted = segments.to_vec();
    sorted.sort_by_key(|s| s.0);
    for (m, l) in sorted {
        match out.last_mut() {
            Some(last) if last.0 == m => last.1 += l,
            _ => out.push((m, l)),
        }
    }
    out
}

impl HetRule {
    /// The names front ends use (`consistent`, `sheng2014`), in the order they list them.
    pub const NAMES: &'static [&'static str] = &["consistent", "sheng2014"];

    /// The rule's name ([`HetRule::NAMES`]).
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            HetRule::Consistent => "consistent",
            HetRule::Sheng2014 => "sheng2014",
        }
    }

    /// The rule called `name` (any case; `sheng-2014` and `sheng` also name eq. 16).
    #[must_use]
    pub fn from_name(name: &str) -> Option<HetRule> {
        match name.trim().to_ascii_lowercase().as_str() {
            "consistent" => Some(HetRule::Consistent),
            "sheng2014" | "sheng-2014" | "sheng" => Some(HetRule::Sheng2014),
            _ => None,
        }
    }

    /// Checks that the rule can use `profile` (as a medium of a path).
    ///
    /// # Errors
    /// [`RadiosityError::HetRuleProfile`] under [`HetRule::Sheng2014`] for a profile whose R(0)
    /// is infinite or not > 0 (the half-space profile, ∝ 1/r at 0).
    pub fn check(self, profile: &Profile) -> Result<(), RadiosityError> {
        match self {
            HetRule::Consistent => Ok(()),
            HetRule::Sheng2014 => match profile.value_at_zero() {
                Some(v) if v.is_finite() && v > 0.0 => Ok(()),
                _ => Err(RadiosityError::HetRuleProfile { rule: self.name(), profile: profile.name() }),
            },
        }
    }

    /// The profile value (mm⁻²) of a path with lengths `segments` (medium index into `profiles`,
    /// length ≥ 0), merged per medium first ([`merge_lengths`]): the rule's formula (module
    /// documentation). A path of one medium gives that medium's R(r) under both rules.
    ///
    /// # Errors
    /// [`RadiosityError::InvalidOptions`] for a medium index out of range;
    /// [`RadiosityError::HetRuleProfile`] under [`HetRule::Sheng2014`] for a profile whose R(0)
    /// is infinite or 0 (the half-space profile).
    pub fn value(self, profiles: &[Profile], segments: &[(usize, f64)]) -> Result<f64, RadiosityError> {
        let merged = merge_lengths(segments);
        if let Some(&(m, _)) = merged.iter().find(|s| s.0 >= profiles.len()) {
            return Err(RadiosityError::InvalidOptions(format!("medium {m} of a path, but {} profiles", profiles.len())));
        }
        if merged.len() > 1 {
            for &(m, _) in &merged {
                self.check(&profiles[m])?;
            }
        }
        Ok(self.merged_value(|m| &profiles[m], &merged))
    }

    /// [`HetRule::value`] of lengths already merged per medium (distinct media), each medium's
    /// profile given by `profile`, with no check and no allocation: the profile matrix's inner
    /// loop. Under [`HetRule::Sheng2014`] every profile of a path of two media or more must
    /// pass [`HetRule::check`] (a NaN otherwise).
    pub(crate) fn merged_value<'p>(self, profile: impl Fn(usize) -> &'p Profile, merged: &[(usize, f64)]) -> f64 {
        let r: f64 = merged.iter().map(|s| s.1).sum();
        if let [(m, l)] = merged[..] {
            return profile(m).value(l);
        }
        match self {
            HetRule::Consistent => {
                if r == 0.0 {
                    return profile(merged[0].0).value(0.0);
                }
                let mut log = 0.0;
                for &(m, l) in merged {
                    if l > 0.0 {
                        let v = profile(m).value(r);
                        if v <= 0.0 {
                            return 0.0;
                        }
                        log += l / r * v.ln();
                    }
                }
                log.exp()
            }
            HetRule::Sheng2014 => {
                let mut mix = 0.0;
                let mut product = 1.0;
                for &(m, l) in merged {
                    let p = profile(m);
                    let at_zero = p.value_at_zero().unwrap_or(f64::NAN);
                    mix += if r > 0.0 { at_zero * l / r } else { at_zero / merged.len() as f64 };
                    product *= p.value(l) / at_zero;
                }
                mix * product
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::profile::Exponentials;
    use super::*;
    use crate::optics::Medium;

    fn marble(eta: f64) -> Profile {
        Profile::Dipole(Medium { eta, ..Medium::preset("marble").unwrap() }.dipole(0))
    }

    #[test]
    fn one_medium_gives_its_profile_under_both_rules() {
        let p = [marble(1.3), Profile::HalfSpace(super::super::profile::HalfSpace::new(0.0041, 2.62, 1.3))];
        for rule in [HetRule::Consistent, HetRule::Sheng2014] {
            // Split pieces of one medium are merged: exactly R(10).
            let v = rule.value(&p, &[(0, 5.0), (0, 5.0)]).unwrap();
            assert_eq!(v, p[0].value(10.0));
        }
        assert_eq!(HetRule::Consistent.value(&p, &[(1, 2.0), (1, 1.0)]).unwrap(), p[1].value(3.0));
        assert!(HetRule::Sheng2014.value(&p, &[(0, 2.0), (1, 1.0)]).is_err());
        assert!(HetRule::Consistent.value(&p, &[(2, 1.0)]).is_err());
    }

    #[test]
    fn unmerged_eq_16_is_inconsistent_as_the_design_says() {
        // Eq. 16 applied to two "different" media that are the same marble: R(5)²/(R(0)R(10)),
        // the design's 0.026 (pitfall 4), and R(1)²/(R(0)R(2)) ≈ 0.38 for 2 mm.
        let p = [marble(1.3), marble(1.3)];
        let ratio = HetRule::Sheng2014.value(&p, &[(0, 5.0), (1, 5.0)]).unwrap() / p[0].value(10.0);
        let expect = p[0].value(5.0).powi(2) / (p[0].value(0.0) * p[0].value(10.0));
        assert!((ratio - expect).abs() < 1e-12 * expect);
        assert!((ratio - 0.026).abs() < 0.003, "{ratio}");
        let short = HetRule::Sheng2014.value(&p, &[(0, 1.0), (1, 1.0)]).unwrap() / p[0].value(2.0);
        assert!((short - 0.38).abs() < 0.03, "{short}");
        // The consistent rule is exact for identical media however the path is labelled.
        let c = HetRule::Consistent.value(&p, &[(0, 5.0), (1, 5.0)]).unwrap();
        assert!((c / p[0].value(10.0) - 1.0).abs() < 1e-14);
    }

    #[test]
    fn exponential_profiles_attenuate_per_medium() {
        // a e^{−b₁r₁} and a e^{−b₂r₂}: both rules give a e^{−b₁r₁ − b₂r₂} (same a).
        let p = [
            Profile::Exponentials(Exponentials::new(vec![(0.4, 0.5)]).unwrap()),
            Profile::Exponentials(Exponentials::new(vec![(0.4, 2.0)]).unwrap()),
        ];
        let expect = 0.4 * (-0.5f64 * 3.0 - 2.0 * 1.5).exp();
        for rule in [HetRule::Consistent, HetRule::Sheng2014] {
            let v = rule.value(&p, &[(0, 3.0), (1, 1.5)]).unwrap();
            assert!((v - expect).abs() < 1e-15, "{rule:?}: {v} vs {expect}");
        }
        assert_eq!(merge_lengths(&[(1, 1.0), (0, 2.0), (1, 0.5)]), vec![(0, 2.0), (1, 1.5)]);
    }
}

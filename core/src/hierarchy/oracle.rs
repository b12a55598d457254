//! The refinement oracle: whether a receiver cluster R and an emitter cluster E may exchange
//! light through one sample of the dipole between their centres, and if not which to open
//! (Mertens et al. 2003 §3.2, §5.2; design/hierarchical-dipole.md §1.6).

use super::tree::ClusterNode;

/// How the hierarchy decides where a link may be made.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Oracle {
    /// Accept iff r_R + r_E < θ·d, the clusters' bounding radii against their centres'
    /// distance; otherwise open the larger. Purely geometric and two-sided: 3.4× lower error
    /// than the paper's at 1.1–1.2× the links (design note §3.2). θ in (0, 1]: 0.4 by default,
    /// 0.6 fast, 0.3 accurate.
    OpeningAngle { theta: f64 },
    /// The paper's (Jensen–Buhler's solid angle): open E while ω = A_E/d² > ε₂, then open R
    /// while its children see E under solid angles more than ε₁ from R's. The paper gives no
    /// values; 0.05/0.05 as pbrt-v2 and Blender 2.4x default. For reproduction.
    Paper { eps1: f64, eps2: f64 },
}

impl Default for Oracle {
    fn default() -> Self {
        Self::OpeningAngle { theta: 0.4 }
    }
}

/// What to do with a candidate pair.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Decision {
    /// A far link: one sample between the centres.
    Accept,
    /// Two leaves too close for one sample: the analytic triangle form factor.
    Near,
    OpenReceiver,
    OpenEmitter,
}

impl Oracle {
    /// Checks the oracle's parameters.
    ///
    /// # Errors
    /// A message naming the parameter out of range.
    pub fn validate(&self) -> Result<(), String> {
        match *self {
            Self::OpeningAngle { theta } if !(theta > 0.0 && theta <= 1.0) => {
                Err(format!("the opening angle theta must lie in (0, 1], got {theta}"))
            }
            Self::Paper { eps1, eps2 } if !(eps1 > 0.0 && eps1.is_finite() && eps2 > 0.0 && eps2.is_finite()) => {
                Err(format!("the paper oracle's eps1 and eps2 must be finite and > 0, got {eps1} and {eps2}"))
            }
            _ => Ok(()),
        }
    }

    /// The ratio r_E/d of an emitting triangle's bounding radius to its distance below which a
    /// near pair's form factor is the 7-point rule of degree 5 instead of the analytic one: the
    /// rule's error falls as (r_E/d)⁶, and at this bound it is below the oracle's own error
    /// against the O(n²) sum (design note §3.2). Twice θ (at most 1) for the opening angle, so a
    /// tighter oracle also integrates its near field more exactly; the paper's oracle has no
    /// angle and takes the default θ's 0.8 (its near pairs reach out to r_E/d ≈ 0.2, where the
    /// analytic form factor buys nothing).
    #[must_use]
    pub fn rule7_below(&self) -> f64 {
        match *self {
            Self::OpeningAngle { theta } => (2.0 * theta).min(1.0),
            Self::Paper { .. } => 0.8,
        }
    }

    /// The decision for receiver `r` (its children `r_children`, when inner) and emitter `e`.
    pub(crate) fn decide(&self, r: &ClusterNode, r_children: Option<[&ClusterNode; 2]>, e: &ClusterNode) -> Decision {
        let d = r.centre.distance(e.centre);
        let open_either = |receiver_first: bool| match (r.leaf, e.leaf) {
            (true, true) => Decision::Near,
            (true, false) => Decision::OpenEmitter,
            (false, true) => Decision::OpenReceiver,
            (false, false) if receiver_first => Decision::OpenReceiver,
            (false, false) => Decision::OpenEmitter,
        };
        match *self {
            Self::OpeningAngle { theta } => {
                if r.radius + e.radius < theta * d {
                    Decision::Accept
                } else {
                    open_either(r.radius >= e.radius)
                }
            }
            Self::Paper { eps1, eps2 } => {
                let omega = |at: &ClusterNode| e.weight / at.centre.distance_squared(e.centre);
                let here = omega(r);
                if !(here <= eps2) {
                    return open_either(e.leaf);
                }
                match r_children {
                    Some([a, b]) if (omega(a) - here).abs().max((omega(b) - here).abs()) > eps1 || !omega(a).is_finite() => {
                        Decision::OpenReceiver
                    }
                    _ => Decision::Accept,
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::*;

    fn node(x: f64, radius: f64, weight: f64, leaf: bool) -> ClusterNode {
        ClusterNode { centre: DVec3::new(x, 0.0, 0.0), weight, normal: DVec3::Z, radius, right_or_item: 0, leaf }
    }

    #[test]
    fn opening_angle_accepts_far_pairs_and_opens_the_larger() {
        let o = Oracle::OpeningAngle { theta: 0.4 };
        let r = node(0.0, 1.0, 1.0, false);
        assert_eq!(o.decide(&r, None, &node(10.0, 2.9, 1.0, false)), Decision::Accept);
        assert_eq!(o.decide(&r, None, &node(10.0, 3.1, 1.0, false)), Decision::OpenEmitter);
        assert_eq!(o.decide(&node(0.0, 3.5, 1.0, false), None, &node(10.0, 3.1, 1.0, false)), Decision::OpenReceiver);
        assert_eq!(o.decide(&node(0.0, 0.0, 1.0, true), None, &node(1.0, 0.5, 1.0, true)), Decision::Near);
        assert_eq!(o.decide(&node(0.0, 0.0, 1.0, true), None, &node(1.0, 0.5, 1.0, false)), Decision::OpenEmitter);
        assert!(Oracle::OpeningAngle { theta: 0.0 }.validate().is_err());
        assert!(Oracle::Paper { eps1: 0.05, eps2: f64::NAN }.validate().is_err());
        assert_eq!(Oracle::default().validate(), Ok(()));
    }

    #[test]
    fn paper_oracle_opens_by_solid_angle() {
        let o = Oracle::Paper { eps1: 0.05, eps2: 0.05 };
        let leaf = node(0.0, 0.0, 1.0, true);
        // ω = 4/100 = 0.04 ≤ ε₂: accepted; ω = 6/100 opens the emitter.
        assert_eq!(o.decide(&leaf, None, &node(10.0, 1.0, 4.0, false)), Decision::Accept);
        assert_eq!(o.decide(&leaf, None, &node(10.0, 1.0, 6.0, false)), Decision::OpenEmitter);
        assert_eq!(o.decide(&leaf, None, &node(10.0, 1.0, 6.0, true)), Decision::Near);
        // A receiver whose children see the emitter under solid angles 0.04 ± > 0.05 apart.
        let (a, b) = (node(-5.0, 0.0, 1.0, true), node(5.0, 0.0, 1.0, true));
        let r = node(0.0, 5.0, 2.0, false);
        assert_eq!(o.decide(&r, Some([&a, &b]), &node(10.0, 1.0, 4.0, false)), Decision::OpenReceiver);
        assert_eq!(o.decide(&r, Some([&a, &b]), &node(100.0, 1.0, 4.0, false)), Decision::Accept);
    }
}

//! What cuts a tet mesh (TransCut §5.1): a plane, a screen-space stroke swept along the view
//! rays, or a closed solid, each a signed distance (`> 0` on the side that is removed) and a
//! closest point on its surface, which [`super::cut::cut`] snaps the cut onto.

use glam::DVec3;

use super::EditError;
use crate::mesh::{TriMesh, TriangleBvh};
use crate::mesher::WindingNumber;

/// What cuts. Signed distance `> 0` on the side that is REMOVED.
#[derive(Debug, Clone)]
pub enum Cutter {
    /// Removes the half-space the normal points into: `{x : (x − point)·normal > 0}`. The normal
    /// need not be a unit vector.
    Plane { point: DVec3, normal: DVec3 },
    /// A screen-space stroke swept along the view rays (TransCut §5.1); see [`SweptStroke`].
    Stroke(SweptStroke),
    /// A closed triangle mesh (world space). An outward-oriented mesh (positive signed volume)
    /// removes what lies inside it (generalised winding number `w > ½`); an inward-oriented one
    /// (what [`Cutter::flipped`] makes) removes what lies outside (`w > −½`).
    Solid(TriMesh),
}

impl Cutter {
    /// Checks that the cutter is usable: finite numbers, a non-zero plane normal, a solid with
    /// at least one triangle and finite vertices (strokes are checked by [`SweptStroke::new`]).
    /// Nothing is normalised.
    ///
    /// # Errors
    /// [`EditError::InvalidCutter`] naming the field that is wrong.
    pub fn validate(&self) -> Result<(), EditError> {
        match self {
            Cutter::Plane { point, normal } => {
                if !point.is_finite() {
                    return Err(EditError::InvalidCutter(format!("plane point {point} is not finite")));
                }
                if !normal.is_finite() || !(normal.length_squared() > 0.0) || !normal.length().is_finite() {
                    return Err(EditError::InvalidCutter(format!("plane normal {normal} is zero or not finite")));
                }
                Ok(())
            }
            Cutter::Stroke(s) => SweptStroke::new(s.origins.clone(), s.directions.clone()).map(|_| ()),
            Cutter::Solid(m) => {
                if m.triangles().is_empty() {
                    return Err(EditError::InvalidCutter("solid cutter mesh has no triangles".into()));
                }
                if let Some(v) = m.positions().iter().position(|p| !p.is_finite()) {
                    return Err(EditError::InvalidCutter(format!("solid cutter vertex {v} is not finite")));
                }
                Ok(())
            }
        }
    }

    /// Signed distance from `p` to the cut surface, `> 0` on the removed side. For a solid this
    /// builds the cutter's search trees on every call; [`cut`] builds them once.
    #[must_use]
    pub fn signed_distance(&self, p: DVec3) -> f64 {
        self.prepare().signed_distance(p)
    }

    /// The point of the cut surface closest to `p`.
    #[must_use]
    pub fn closest_point(&self, p: DVec3) -> DVec3 {
        self.prepare().closest_point(p)
    }

    /// The cutter that removes the other side (a split keeps both): the plane with the opposite
    /// normal, the stroke drawn backwards, the solid with its triangles reversed.
    #[must_use]
    pub fn flipped(&self) -> Cutter {
        match self {
            Cutter::Plane { point, normal } => Cutter::Plane { point: *point, normal: -*normal },
            Cutter::Stroke(s) => {
                let mut origins = s.origins.clone();
                let mut directions = s.directions.clone();
                origins.reverse();
                directions.reverse();
                Cutter::Stroke(SweptStroke::build(origins, directions))
            }
            Cutter::Solid(m) => Cutter::Solid(TriMesh {
                positions: m.positions.clone(),
                triangles: m.triangles.iter().map(|&[a, b, c]| [a, c, b]).collect(),
                user_to_internal: m.user_to_internal.clone(),
                flipped_faces: m.flipped_faces,
            }),
        }
    }

    /// The cutter with its search structures built (solid: BVH and winding-number tree).
    pub(super) fn prepare(&self) -> Prepared<'_> {
        match self {
            Cutter::Plane { point, normal } => Prepared::Plane { point: *point, normal: *normal },
            Cutter::Stroke(s) => Prepared::Stroke(s),
            Cutter::Solid(m) => {
                let bvh = TriangleBvh::from_indexed(m.positions(), m.triangles());
                let threshold = if m.signed_volume() >= 0.0 { 0.5 } else { -0.5 };
                Prepared::Solid { winding: WindingNumber::new(bvh), threshold, bounds: m.bounds() }
            }
        }
    }
}

/// Signed distance to the plane through `point` with (not necessarily unit) `normal`:
/// `(x − point)·normal / |normal|`. Shared by planes and stroke quads so that a stroke with one
/// quad gives bit-for-bit the distances of the equivalent plane.
fn plane_distance(x: DVec3, point: DVec3, normal: DVec3) -> f64 {
    (x - point).dot(normal) / normal.length()
}

/// Orthogonal projection of `x` onto the plane (see [`plane_distance`]).
fn plane_project(x: DVec3, point: DVec3, normal: DVec3) -> DVec3 {
    x - plane_distance(x, point, normal) * (normal / normal.length())
}

/// A cutter ready for many queries.
pub(super) enum Prepared<'a> {
    Plane {
        point: DVec3,
        normal: DVec3,
    },
    Stroke(&'a SweptStroke),
    /// `threshold` is ±½ (the removed side is `w > threshold`); `bounds` the triangles' box.
    Solid {
        winding: WindingNumber,
        threshold: f64,
        bounds: (DVec3, DVec3),
    },
}

impl Prepared<'_> {
    /// Whether the kept side is convex (a plane's half-space): then no segment between two kept
    /// points reaches the removed side and no closest point lies across a thin removed part,
    /// so the cut's bridging and separation steps have nothing to find.
    pub(super) fn kept_side_is_convex(&self) -> bool {
        matches!(self, Prepared::Plane { .. })
    }

    /// A signed distance for the cut's classification, exact or, where that is cheap to know,
    /// a bound: for a solid cutter and a point more than `margin` outside the triangles' box,
    /// ±(distance to the box), closer to 0 than the true signed distance and of its sign.
    /// Outside the box every triangle lies beyond a plane through the point, so |w| < ½ there
    /// and the point is kept (threshold ½) or removed (threshold −½) without evaluating w, and
    /// its distance to the surface is at least its distance to the box. The cut's uses of the
    /// distances (the snap band, the Lipschitz bound of `segment_reaches`) stay correct with a
    /// value nearer 0, and with `margin` a few edges long the bound never changes them.
    pub(super) fn classifying_distance(&self, p: DVec3, margin: f64) -> f64 {
        if let Prepared::Solid { threshold, bounds: (lo, hi), .. } = self {
            let outside = (p.clamp(*lo, *hi) - p).length();
            if outside > margin {
                return if *threshold > 0.0 { -outside } else { outside };
            }
        }
        self.signed_distance(p)
    }

    pub(super) fn signed_distance(&self, p: DVec3) -> f64 {
        match self {
            Prepared::Plane { point, normal } => plane_distance(p, *point, *normal),
            Prepared::Stroke(s) => s.query(p).0,
            Prepared::Solid { winding, threshold, .. } => {
                let Some(sp) = winding.bvh().closest_point(p) else {
                    return f64::NEG_INFINITY;
                };
                if solid_removes(winding, *threshold, p) {
                    sp.distance
                } else {
                    -sp.distance
                }
            }
        }
    }

    pub(super) fn closest_point(&self, p: DVec3) -> DVec3 {
        match self {
            Prepared::Plane { point, normal } => plane_project(p, *point, *normal),
            Prepared::Stroke(s) => s.query(p).1,
            Prepared::Solid { winding, .. } => winding.bvh().closest_point(p).map_or(p, |sp| sp.point),
        }
    }
}

/// Whether a solid cutter removes `p`: winding number above the threshold, re-evaluated with the
/// accurate far field (β = 5, as the mesher does) within 0.05 of it.
fn solid_removes(winding: &WindingNumber, threshold: f64, p: DVec3) -> bool {
    let mut w = winding.at(p);
    if (w - threshold).abs() < 0.05 {
        w = winding.at_with_accuracy(p, 5.0);
    }
    w > threshold
}

/// A stroke drawn on screen, swept along the camera rays: ray `k` is `origins[k] + t·directions[k]`,
/// `t ≥ 0`. Consecutive rays span a planar quad of the cut surface (a half-strip for an
/// orthographic camera, a wedge from the eye for a perspective one); the first and last quads are
/// extended to infinity beyond the first and last ray, so the surface separates the space in
/// front of the stroke.
///
/// **Side convention.** Quad `k` has the normal
/// `m_k = (o_{k+1} − o_k) × d_k + d_{k+1} × d_k = (p_{k+1} − p_k) × d_k` with `p_k = o_k + d_k`
/// the points at `t = 1`, and the side `m_k` points to is REMOVED. Seen by a viewer looking along
/// the rays (screen x right, y up), that is the LEFT of the stroke's drawing direction, as in
/// TransCut §5.1 ("tetrahedra … on the left side of the stroke are deleted"): drawing from left to
/// right removes what is above the stroke. (This is `−(d_k × (p_{k+1} − p_k))`; the contract's
/// first draft wrote the cross product the other way round, which is the right-hand side.)
///
/// The signed distance of a point is its distance to the nearest quad, with the sign of that
/// quad's side; where the nearest point lies on a ray shared by two quads, the sign is taken
/// against the sum of the two unit normals (the edge pseudo-normal, exact for a polyhedral
/// surface). Points behind the stroke's origins (`t < 0`) get a well-defined but arbitrary side:
/// objects are expected in front of the camera.
#[derive(Debug, Clone)]
pub struct SweptStroke {
    origins: Vec<DVec3>,
    directions: Vec<DVec3>,
    quads: Vec<Quad>,
}

/// One planar piece of a swept stroke: the region `{q in the plane : (q − line.point)·line.inward
/// ≥ 0 for every line}` (rays k and k + 1 and the origin edge, minus those removed at the ends).
#[derive(Debug, Clone)]
struct Quad {
    anchor: DVec3,
    normal: DVec3,
    unit: DVec3,
    lines: Vec<Line>,
}

/// A boundary line of a quad; `neighbour` is the quad on its other side (a shared ray).
#[derive(Debug, Clone)]
struct Line {
    point: DVec3,
    dir: DVec3,
    inward: DVec3,
    neighbour: Option<usize>,
}

impl SweptStroke {
    /// A stroke from one ray per stroke point.
    ///
    /// # Errors
    /// [`EditError::InvalidStroke`] when there are fewer than 2 rays, the lengths differ, a value
    /// is not finite, a direction is zero, two consecutive rays span no quad (parallel and on one
    /// line, or both through the same origin in the same direction), or two consecutive rays are
    /// skew (their quad would not be planar; a perspective or an orthographic camera never gives
    /// that).
    pub fn new(origins: Vec<DVec3>, directions: Vec<DVec3>) -> Result<Self, EditError> {
        if origins.len() != directions.len() {
            return Err(EditError::InvalidStroke(format!("{} origins but {} directions", origins.len(), directions.len())));
        }
        if origins.len() < 2 {
            return Err(EditError::InvalidStroke(format!("a swept stroke needs at least 2 rays, got {}", origins.len())));
        }
        if let Some(k) = origins.iter().position(|o| !o.is_finite()) {
            return Err(EditError::InvalidStroke(format!("origin {k} is not finite")));
        }
        if let Some(k) = directions.iter().position(|d| !d.is_finite() || !(d.length_squared() > 0.0)) {
            return Err(EditError::InvalidStroke(format!("direction {k} is zero or not finite")));
        }
        for k in 0..origins.len() - 1 {
            let (o0, o1, d0, d1) = (origins[k], origins[k + 1], directions[k], directions[k + 1]);
            let m = quad_normal(o0, o1, d0, d1);
            let scale = ((o1 - o0).length() + d0.length()) * ((o1 - o0).length() + d1.length());
            if !(m.length() > 1e-12 * scale) {
                return Err(EditError::InvalidStroke(format!("rays {k} and {} span no quad (parallel or coincident)", k + 1)));
            }
            let skew = (o1 - o0).dot(d0.cross(d1)).abs();
            if skew > 1e-9 * (o1 - o0).length() * d0.length() * d1.length() {
                return Err(EditError::InvalidStroke(format!(
                    "rays {k} and {} are skew (their quad is not planar); use one eye or one direction",
                    k + 1
                )));
            }
        }
        Ok(Self::build(origins, directions))
    }

    /// A perspective stroke: every ray starts at `eye`.
    ///
    /// # Errors
    /// As [`SweptStroke::new`] (also for a non-finite eye).
    pub fn perspective(eye: DVec3, directions: Vec<DVec3>) -> Result<Self, EditError> {
        Self::new(vec![eye; directions.len()], directions)
    }

    /// Ray origins.
    #[must_use]
    pub fn origins(&self) -> &[DVec3] {
        &self.origins
    }

    /// Ray directions.
    #[must_use]
    pub fn directions(&self) -> &[DVec3] {
        &self.directions
    }

    /// Builds the quads of already validated rays.
    fn build(origins: Vec<DVec3>, directions: Vec<DVec3>) -> Self {
        let n = origins.len();
        let quads = (0..n - 1)
            .map(|k| {
                let (o0, o1, d0, d1) = (origins[k], origins[k + 1], directions[k], directions[k + 1]);
                let normal = quad_normal(o0, o1, d0, d1);
                let unit = normal / normal.length();
                let in_plane = |dir: DVec3, towards: DVec3| {
                    let e = unit.cross(dir).normalize_or_zero();
                    if e.dot(towards) < 0.0 {
                        -e
                    } else {
                        e
                    }
                };
                let mut lines = Vec::with_capacity(3);
                if k > 0 {
                    lines.push(Line { point: o0, dir: d0, inward: in_plane(d0, o1 + d1 - o0), neighbour: Some(k - 1) });
                }
                if k + 2 < n {
                    lines.push(Line { point: o1, dir: d1, inward: in_plane(d1, o0 + d0 - o1), neighbour: Some(k + 1) });
                }
                let edge = o1 - o0;
                if edge.length_squared() > 0.0 {
                    lines.push(Line { point: o0, dir: edge, inward: in_plane(edge, d0 + d1), neighbour: None });
                }
                Quad { anchor: o0, normal, unit, lines }
            })
            .collect();
        Self { origins, directions, quads }
    }

    /// Signed distance and closest point on the swept surface.
    fn query(&self, x: DVec3) -> (f64, DVec3) {
        let mut best: Option<(f64, f64, DVec3)> = None; // (distance², signed distance, point)
        for q in &self.quads {
            let (d2, signed, c) = q.query(x, &self.quads);
            if best.is_none_or(|b| d2 < b.0) {
                best = Some((d2, signed, c));
            }
        }
        best.map_or((0.0, x), |(_, s, c)| (s, c))
    }
}

/// `(o1 − o0) × d0 + d1 × d0`: the normal of the quad between two rays; for an orthographic pair
/// (`d1 = d0`) the second term is exactly zero, for a perspective pair (`o1 = o0`) the first is.
fn quad_normal(o0: DVec3, o1: DVec3, d0: DVec3, d1: DVec3) -> DVec3 {
    (o1 - o0).cross(d0) + d1.cross(d0)
}

impl Quad {
    /// `(distance², signed distance, closest point)` of `x` to this quad's region.
    fn query(&self, x: DVec3, quads: &[Quad]) -> (f64, f64, DVec3) {
        let signed = plane_distance(x, self.anchor, self.normal);
        let q = x - signed * self.unit;
        if self.lines.iter().all(|l| (q - l.point).dot(l.inward) >= 0.0) {
            return (signed * signed, signed, q);
        }
        // Outside: the nearest point lies on a boundary line, within the other lines' half-planes.
        let mut best: Option<(f64, DVec3, Option<usize>)> = None;
        for (i, l) in self.lines.iter().enumerate() {
            let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
            for (j, m) in self.lines.iter().enumerate() {
                if i == j {
                    continue;
                }
                // (l.point + u l.dir − m.point)·m.inward ≥ 0
                let a = l.dir.dot(m.inward);
                let b = (m.point - l.point).dot(m.inward);
                if a.abs() < 1e-300 {
                    if b > 0.0 {
                        lo = f64::INFINITY;
                    }
                } else if a > 0.0 {
                    lo = lo.max(b / a);
                } else {
                    hi = hi.min(b / a);
                }
            }
            if lo > hi {
                continue;
            }
            let u = ((q - l.point).dot(l.dir) / l.dir.length_squared()).clamp(lo, hi);
            let c = l.point + u * l.dir;
            let d2 = (x - c).length_squared();
            if best.is_none_or(|b| d2 < b.0) {
                best = Some((d2, c, l.neighbour));
            }
        }
        let Some((d2, c, neighbour)) = best else {
            return (signed * signed, signed, q);
        };
        let pseudo = match neighbour {
            Some(nb) => self.unit + quads[nb].unit,
            None => self.unit,
        };
        let side = (x - c).dot(pseudo);
        let dist = d2.sqrt();
        (
            d2,
            if side > 0.0 {
                dist
            } else if side < 0.0 {
                -dist
            } else {
                0.0
            },
            c,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bent_orthographic_stroke_signs_both_legs_and_the_corner() {
        // Looking along −z, drawn right along +x then up along +y: an "L" whose left side is the
        // upper-left region {y > 0 and x < 1}.
        let d = DVec3::new(0.0, 0.0, -1.0);
        let o = [DVec3::new(-1.0, 0.0, 5.0), DVec3::new(1.0, 0.0, 5.0), DVec3::new(1.0, 2.0, 5.0)];
        let c = Cutter::Stroke(SweptStroke::new(o.to_vec(), vec![d; 3]).unwrap());
        let at = |x: f64, y: f64| c.signed_distance(DVec3::new(x, y, 0.0));
        assert!((at(0.0, 0.5) - 0.5).abs() < 1e-12);
        assert!((at(0.0, -0.5) + 0.5).abs() < 1e-12);
        assert!((at(0.5, 1.0) - 0.5).abs() < 1e-12);
        assert!((at(1.5, 1.0) + 0.5).abs() < 1e-12);
        // Beyond the corner (x > 1, y < 0) the nearest point is the shared ray; the point is right
        // of both legs, so kept (signed by the edge pseudo-normal), at the distance to that ray.
        assert!((at(1.3, -0.4) + 0.5).abs() < 1e-12);
        // Extended ends: far left along the first leg, far up along the last.
        assert!((at(-10.0, 0.25) - 0.25).abs() < 1e-12);
        assert!((at(1.75, 10.0) + 0.75).abs() < 1e-12);
        assert!((c.closest_point(DVec3::new(1.3, -0.4, 0.0)) - DVec3::new(1.0, 0.0, 0.0)).length() < 1e-12);
        assert!((c.flipped().signed_distance(DVec3::new(0.5, 1.0, 0.0)) + 0.5).abs() < 1e-12);
    }

    #[test]
    fn invalid_cutters_and_strokes_name_the_problem() {
        let bad = Cutter::Plane { point: DVec3::ZERO, normal: DVec3::ZERO };
        assert!(matches!(bad.validate(), Err(EditError::InvalidCutter(m)) if m.contains("normal")));
        let nan = Cutter::Plane { point: DVec3::new(f64::NAN, 0.0, 0.0), normal: DVec3::Z };
        assert!(matches!(nan.validate(), Err(EditError::InvalidCutter(m)) if m.contains("point")));
        let d = DVec3::NEG_Z;
        let err = |r: Result<SweptStroke, EditError>| match r {
            Err(EditError::InvalidStroke(m)) => m,
            other => panic!("{other:?}"),
        };
        assert!(err(SweptStroke::new(vec![DVec3::ZERO], vec![d])).contains("at least 2"));
        assert!(err(SweptStroke::new(vec![DVec3::ZERO; 2], vec![d])).contains("directions"));
        assert!(err(SweptStroke::new(vec![DVec3::ZERO, DVec3::X], vec![d, DVec3::ZERO])).contains("direction 1"));
        assert!(err(SweptStroke::new(vec![DVec3::ZERO, DVec3::Z], vec![d, d])).contains("span no quad"));
        assert!(err(SweptStroke::new(vec![DVec3::ZERO, DVec3::X], vec![d, DVec3::new(0.0, 1.0, -1.0)])).contains("skew"));
        assert!(err(SweptStroke::perspective(DVec3::ZERO, vec![d, 2.0 * d])).contains("span no quad"));
    }

    #[test]
    fn far_from_a_solid_the_classifying_distance_is_a_bound_of_the_right_sign() {
        // A ball of radius 1 at the origin, as cut (removes inside) and flipped (removes
        // outside). Points on rays out to 5: within `margin` of the ball's box the exact signed
        // distance; beyond it a value of the same sign, no farther from 0 than the truth.
        let ball = Cutter::Solid(crate::mesh::icosphere(1.0, 3));
        for cutter in [ball.clone(), ball.flipped()] {
            let prepared = cutter.prepare();
            let mut bounded = 0;
            for k in 0..400 {
                let t = k as f64 * 0.37;
                let dir = DVec3::new(t.sin() * (1.3 * t).cos(), t.sin() * (1.3 * t).sin(), t.cos());
                let p = (0.2 + 4.8 * (k as f64 / 400.0)) * dir;
                let exact = prepared.signed_distance(p);
                let got = prepared.classifying_distance(p, 0.5);
                if got == exact {
                    continue;
                }
                bounded += 1;
                assert!(got.signum() == exact.signum() && got.abs() <= exact.abs() && got.abs() > 0.5, "{p}: {got} vs {exact}");
            }
            assert!(bounded > 100, "only {bounded} of 400 points used the bound");
        }
    }
}

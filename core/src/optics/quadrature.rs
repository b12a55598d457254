//! Adaptive Simpson quadrature for the smooth one-dimensional integrals of this module
//! (hemispherical Fresnel averages, dipole profile checks), and a fixed rule on triangles.

use glam::DVec3;

/// Deepest bisection level; 2⁻⁴⁰ of the interval is far below any feature of the integrands
/// used here, and it bounds the work for non-smooth or non-finite integrands.
const MAX_DEPTH: u32 = 40;

/// ∫ₐᵇ f(x) dx by adaptive Simpson with Richardson correction (Lyness 1969), to an absolute
/// tolerance `tol`.
///
/// The interval is first cut into 8 equal panels so that a feature narrower than the whole
/// interval is not missed by the first estimate.
pub(crate) fn integrate<F: Fn(f64) -> f64>(f: &F, a: f64, b: f64, tol: f64) -> f64 {
    const PANELS: usize = 8;
    let h = (b - a) / PANELS as f64;
    (0..PANELS)
        .map(|k| {
            let lo = a + h * k as f64;
            let hi = if k + 1 == PANELS { b } else { lo + h };
            let (flo, fmid, fhi) = (f(lo), f(0.5 * (lo + hi)), f(hi));
            let whole = simpson(lo, hi, flo, fmid, fhi);
            refine(f, lo, hi, flo, fmid, fhi, whole, tol / PANELS as f64, MAX_DEPTH)
        })
        .sum()
}

/// Simpson's rule on [a, b] from the end and midpoint values.
fn simpson(a: f64, b: f64, fa: f64, fm: f64, fb: f64) -> f64 {
    (b - a) / 6.0 * (fa + 4.0 * fm + fb)
}

/// One level of adaptive Simpson: accept when the two halves agree with the whole to 15·tol.
#[allow(clippy::too_many_arguments)]
fn refine<F: Fn(f64) -> f64>(f: &F, a: f64, b: f64, fa: f64, fm: f64, fb: f64, whole: f64, tol: f64, depth: u32) -> f64 {
    let m = 0.5 * (a + b);
    let (lm, rm) = (0.5 * (a + m), 0.5 * (m + b));
    let (flm, frm) = (f(lm), f(rm));
    let left = simpson(a, m, fa, flm, fm);
    let right = simpson(m, b, fm, frm, fb);
    let delta = left + right - whole;
    if depth == 0 || delta.abs() <= 15.0 * tol || !delta.is_finite() {
        return left + right + delta / 15.0;
    }
    refine(f, a, m, fa, flm, fm, left, 0.5 * tol, depth - 1) + refine(f, m, b, fm, frm, fb, right, 0.5 * tol, depth - 1)
}

/// ∫ f over the triangle `[a, b, c]` by the 7-point degree-5 rule (Radon 1948; Stroud T2:5-1):
/// exact for polynomials of degree ≤ 5. `T` is a scalar or a vector of them (three channels
/// as a `DVec3`).
pub(crate) fn triangle_rule7<T>(f: &impl Fn(DVec3) -> T, corners: [DVec3; 3]) -> T
where
    T: std::ops::Add<Output = T> + std::ops::Mul<f64, Output = T>,
{
    let [p0, p1, p2, p3, p4, p5, p6] = triangle_rule7_points(corners);
    let term = |(p, w): (DVec3, f64)| f(p) * w;
    term(p0) + term(p1) + term(p2) + term(p3) + term(p4) + term(p5) + term(p6)
}

/// The points of [`triangle_rule7`] on the triangle `[a, b, c]`, each with its weight times the
/// triangle's area (the weights sum to the area).
pub(crate) fn triangle_rule7_points([a, b, c]: [DVec3; 3]) -> [(DVec3, f64); 7] {
    let area = 0.5 * (b - a).cross(c - a).length();
    let s15 = 15f64.sqrt();
    let (a1, b1) = ((6.0 - s15) / 21.0, (9.0 + 2.0 * s15) / 21.0);
    let (a2, b2) = ((6.0 + s15) / 21.0, (9.0 - 2.0 * s15) / 21.0);
    let (w1, w2) = ((155.0 - s15) / 1200.0 * area, (155.0 + s15) / 1200.0 * area);
    let at = |l0: f64, l1: f64, l2: f64| a * l0 + b * l1 + c * l2;
    [
        (at(1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0), 9.0 / 40.0 * area),
        (at(b1, a1, a1), w1),
        (at(a1, b1, a1), w1),
        (at(a1, a1, b1), w1),
        (at(b2, a2, a2), w2),
        (at(a2, b2, a2), w2),
        (at(a2, a2, b2), w2),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integrates_polynomials_and_exponentials() {
        assert!((integrate(&|x: f64| x * x, 0.0, 3.0, 1e-12) - 9.0).abs() < 1e-12);
        let e = integrate(&|x: f64| (-x).exp(), 0.0, 50.0, 1e-13);
        assert!((e - (1.0 - (-50.0f64).exp())).abs() < 1e-11);
    }

    #[test]
    fn the_triangle_rule_is_exact_to_degree_five() {
        let t = [DVec3::ZERO, DVec3::new(2.0, 0.0, 0.0), DVec3::new(0.0, 1.0, 0.0)];
        // ∫ x^i y^j over the triangle x/2 + y ≤ 1: 2^{i+1} i! j!/(i + j + 2)!.
        let fact = |n: u32| (1..=n).map(f64::from).product::<f64>();
        for (i, j) in [(0, 0), (1, 0), (2, 3), (5, 0), (1, 4)] {
            let exact = 2f64.powi(i as i32 + 1) * fact(i) * fact(j) / fact(i + j + 2);
            let v = triangle_rule7(&|p: DVec3| p.x.powi(i as i32) * p.y.powi(j as i32), t);
            assert!((v - exact).abs() < 1e-13 * exact.max(1.0), "{i} {j}: {v} vs {exact}");
        }
    }

    #[test]
    fn handles_a_square_root_endpoint() {
        // ∫₀¹ √x dx = 2/3: the derivative is unbounded at 0, so this exercises deep refinement.
        let v = integrate(&|x: f64| x.sqrt(), 0.0, 1.0, 1e-12);
        assert!((v - 2.0 / 3.0).abs() < 1e-10, "{v}");
    }
}

//! Closed-form form factors between simple shapes (Howell's catalogue of radiation
//! configuration factors, cases C-11, C-14, C-40 and B-1), the values radiosity's form factors
//! are checked against (design/radiosity.md §3.1).

use std::f64::consts::PI;

/// Two directly opposed parallel rectangles a × b at distance c (Howell C-11).
#[must_use]
pub fn parallel_rectangles(a: f64, b: f64, c: f64) -> f64 {
    let (x, y) = (a / c, b / c);
    let (x1, y1) = ((1.0 + x * x).sqrt(), (1.0 + y * y).sqrt());
    let log = ((1.0 + x * x) * (1.0 + y * y) / (1.0 + x * x + y * y)).sqrt().ln();
    2.0 / (PI * x * y) * (log + x * y1 * (x / y1).atan() + y * x1 * (y / x1).atan() - x * x.atan() - y * y.atan())
}

/// From a rectangle of width `w` to a perpendicular one of height `h` sharing an edge of length
/// `l` (Howell C-14).
#[must_use]
pub fn perpendicular_rectangles(l: f64, w: f64, h: f64) -> f64 {
    let (w, h) = (w / l, h / l);
    let (w2, h2) = (w * w, h * h);
    let s = w2 + h2;
    let log = ((1.0 + w2) * (1.0 + h2) / (1.0 + s)).ln()
        + w2 * (w2 * (1.0 + s) / ((1.0 + w2) * s)).ln()
        + h2 * (h2 * (1.0 + s) / ((1.0 + h2) * s)).ln();
    (w * (1.0 / w).atan() + h * (1.0 / h).atan() - s.sqrt() * (1.0 / s.sqrt()).atan() + 0.25 * log) / (PI * w)
}

/// From a disc of radius `r1` to a coaxial parallel disc of radius `r2` at distance `h`
/// (Howell C-40).
#[must_use]
pub fn coaxial_discs(r1: f64, r2: f64, h: f64) -> f64 {
    let (a, b) = (r1 / h, r2 / h);
    let x = 1.0 + (1.0 + b * b) / (a * a);
    0.5 * (x - (x * x - 4.0 * (b / a).powi(2)).sqrt())
}

/// From a differential area to a coaxial parallel disc of radius `a` at distance `h`, facing it
/// (Howell B-1): sin² of the half-angle it subtends.
#[must_use]
pub fn point_to_disc(a: f64, h: f64) -> f64 {
    a * a / (a * a + h * h)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The values of the design note, computed there independently.
    #[test]
    fn the_closed_forms_give_the_tabulated_values() {
        for (got, want) in [
            (parallel_rectangles(1.0, 1.0, 1.0), 0.199825),
            (parallel_rectangles(1.0, 1.0, 0.5), 0.415253),
            (parallel_rectangles(1.0, 1.0, 2.0), 0.068590),
            (perpendicular_rectangles(1.0, 1.0, 1.0), 0.200044),
            (perpendicular_rectangles(1.0, 1.0, 2.0), 0.232853),
            (coaxial_discs(1.0, 1.0, 1.0), 0.381966),
            (coaxial_discs(1.0, 1.0, 0.5), 0.609612),
            (point_to_disc(1.0, 1.0) - point_to_disc(0.25, 0.5), 0.3),
        ] {
            assert!((got - want).abs() < 5e-7, "{got} against {want}");
        }
    }

    /// Reciprocity of the closed forms themselves: A₁F₁₂ = A₂F₂₁ for discs of different radii.
    #[test]
    fn the_disc_factors_are_reciprocal() {
        let (r1, r2, h) = (0.7, 1.9, 1.3);
        let lhs = r1 * r1 * coaxial_discs(r1, r2, h);
        let rhs = r2 * r2 * coaxial_discs(r2, r1, h);
        assert!((lhs - rhs).abs() < 1e-14, "{lhs} {rhs}");
    }
}

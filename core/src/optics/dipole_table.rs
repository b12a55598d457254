//! Rd(r) of three channels with its slope and curvature ([`Dipole::rd_with_derivatives`]) as
//! piecewise cubics in u = r², the squared distance: a table the hierarchical dipole reads for
//! every far link and every point of its 7-point near rule instead of evaluating two
//! exponentials, two square roots and a division per channel and function.
//!
//! In u the three functions are analytic on [0, ∞) (each source's distance √(u + z²) is, for
//! z > 0), so a cubic per cell needs neither the square root nor the exponential. The cells
//! follow the floating-point representation of u: [0, u₀) (u₀ the largest power of two at or
//! below the smallest z_r², where the nearest singularity u = −z_r² lies) is cut into 2ᵐ equal
//! cells, and each binade [u₀2ᵇ, u₀2ᵇ⁺¹) above it into 2^{m_b} equal cells, so a cell is found
//! from the bits of u (exponent and top m_b mantissa bits) and the position in it is the
//! remaining mantissa. Each cell interpolates at t = 0, ⅓, ⅔, 1 (shared ends: the table is
//! continuous), and each range gets as many cells as it takes for every function to be within
//! [`REL_TOLERANCE`] of its exact value, or [`ABS_TOLERANCE`] of its value at r = 0, at the
//! probes between the nodes. Beyond the table's top (past the distances it was built for) the
//! exact functions are evaluated.

use super::dipole::Dipole;

/// The interpolation error allowed relative to a function's value: a sixth of f32's
/// rounding, so links stored in f32 carry the table's values as if exact.
pub const REL_TOLERANCE: f64 = 1e-8;

/// The error allowed relative to a function's value at r = 0, where the relative bound would
/// ask for cells finer than the function's decay justifies (Rd at 10⁻¹² of its peak).
pub const ABS_TOLERANCE: f64 = 1e-12;

/// Mantissa bits of the cells of a range: at least and at most (2¹⁴ cells per binade is a
/// relative width of 6·10⁻⁵, finer than any dipole in the presets needs).
const MIN_BITS: u32 = 3;
const MAX_BITS: u32 = 14;

/// Where the error of a cell's cubic is checked, between its nodes 0, ⅓, ⅔ and 1.
const PROBES: [f64; 3] = [1.0 / 6.0, 0.5, 5.0 / 6.0];

/// The nine functions [Rd, Rd′/r, (Rd′/r)′/r] × [channel] at one u, in that order.
type Values = [f64; 9];

/// One cell: the cubic c₀ + c₁t + c₂t² + c₃t³ of each of the nine functions, t ∈ [0, 1].
type Cell = [[f64; 4]; 9];

/// One binade of u above u₀: its first cell, its cells' mantissa bits and 2^{−(52 − bits)}.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Binade {
    start: usize,
    bits: u32,
    scale: f64,
}

/// The table of three channels' dipoles up to a distance (module documentation).
#[derive(Debug, Clone, PartialEq)]
pub struct DipoleTable {
    dipoles: [Dipole; 3],
    /// u₀ and its biased exponent; 2ᵐ/u₀ for the uniform cells below it.
    low: f64,
    low_exponent: u64,
    low_scale: f64,
    low_cells: usize,
    /// u at and above which the functions are evaluated exactly.
    top: f64,
    binades: Vec<Binade>,
    cells: Vec<Cell>,
}

impl DipoleTable {
    /// The table of `dipoles` for distances up to at least `max_distance` (mm; beyond it the
    /// lookups evaluate exactly). Each dipole needs z_r > 0 and finite coefficients.
    #[must_use]
    pub fn new(dipoles: [Dipole; 3], max_distance: f64) -> Self {
        let z_min = dipoles.iter().map(|d| d.z_r).fold(f64::INFINITY, f64::min);
        let low = power_of_two_at_or_below(z_min * z_min);
        let top_target = (max_distance * max_distance).max(4.0 * low);
        let peak = exact(&dipoles, 0.0).map(f64::abs);
        let low_bits = cell_bits(&dipoles, &peak, |cells, i| (low * i as f64 / cells as f64, low / cells as f64));
        let low_cells = 1usize << low_bits;
        let mut cells: Vec<Cell> =
            (0..low_cells).map(|i| fit(&dipoles, low * i as f64 / low_cells as f64, low / low_cells as f64)).collect();
        let mut binades = Vec::new();
        let mut lo = low;
        while lo < top_target {
            let bits = cell_bits(&dipoles, &peak, |cells, i| (lo + lo * i as f64 / cells as f64, lo / cells as f64));
            let n = 1usize << bits;
            binades.push(Binade { start: cells.len(), bits, scale: 2f64.powi(-(52 - bits as i32)) });
            cells.extend((0..n).map(|i| fit(&dipoles, lo + lo * i as f64 / n as f64, lo / n as f64)));
            lo *= 2.0;
        }
        Self {
            dipoles,
            low,
            low_exponent: low.to_bits() >> 52,
            low_scale: low_cells as f64 / low,
            low_cells,
            top: lo,
            binades,
            cells,
        }
    }

    /// The dipoles tabulated.
    #[must_use]
    pub fn dipoles(&self) -> &[Dipole; 3] {
        &self.dipoles
    }

    /// The cells of the table (each holds 9 cubics).
    #[must_use]
    pub fn len(&self) -> usize {
        self.cells.len()
    }

    /// Whether the table has no cells (never: it always covers [0, u₀)).
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.cells.is_empty()
    }

    /// The distance (mm) up to which lookups read the table.
    #[must_use]
    pub fn max_distance(&self) -> f64 {
        self.top.sqrt()
    }

    /// Rd per channel at squared distance `u` (mm²).
    #[must_use]
    pub fn rd(&self, u: f64) -> [f64; 3] {
        match self.locate(u) {
            Some((cell, t)) => std::array::from_fn(|c| horner(&cell[c], t)),
            None => self.dipoles.map(|d| d.rd(u.sqrt())),
        }
    }

    /// [`Dipole::rd_with_derivatives`] per channel at squared distance `u` (mm²): Rd, its slope
    /// over r and its curvature, each per channel.
    #[must_use]
    pub fn rd_with_derivatives(&self, u: f64) -> [[f64; 3]; 3] {
        match self.locate(u) {
            Some((cell, t)) => std::array::from_fn(|f| std::array::from_fn(|c| horner(&cell[3 * f + c], t))),
            None => {
                let v = exact(&self.dipoles, u);
                std::array::from_fn(|f| std::array::from_fn(|c| v[3 * f + c]))
            }
        }
    }

    /// The cell holding `u` and the position t ∈ [0, 1) in it; `None` at or above the top (and
    /// for NaN).
    fn locate(&self, u: f64) -> Option<(&Cell, f64)> {
        if !(u < self.top) {
            return None;
        }
        if u < self.low {
            let x = u.max(0.0) * self.low_scale;
            let i = (x as usize).min(self.low_cells - 1);
            return Some((&self.cells[i], x - i as f64));
        }
        let bits = u.to_bits();
        let binade = self.binades[((bits >> 52) - self.low_exponent) as usize];
        let shift = 52 - binade.bits;
        let sub = (bits >> shift) & ((1 << binade.bits) - 1);
        let t = (bits & ((1 << shift) - 1)) as f64 * binade.scale;
        Some((&self.cells[binade.start + sub as usize], t))
    }
}

/// The largest power of two at or below a positive finite `x`.
fn power_of_two_at_or_below(x: f64) -> f64 {
    f64::from_bits(x.to_bits() & (0x7ff << 52))
}

/// The nine functions of `dipoles` at squared distance `u`, exactly.
fn exact(dipoles: &[Dipole; 3], u: f64) -> Values {
    let r = u.sqrt();
    let per_channel = dipoles.map(|d| d.rd_with_derivatives(r));
    std::array::from_fn(|i| per_channel[i % 3][i / 3])
}

/// The cubics through the functions at t = 0, ⅓, ⅔, 1 of the cell [u0, u0 + width].
fn fit(dipoles: &[Dipole; 3], u0: f64, width: f64) -> Cell {
    let samples: [Values; 4] = std::array::from_fn(|j| exact(dipoles, u0 + width * j as f64 / 3.0));
    std::array::from_fn(|f| {
        let [y0, y1, y2, y3] = [samples[0][f], samples[1][f], samples[2][f], samples[3][f]];
        // Newton's divided differences on the nodes 0, ⅓, ⅔, 1, expanded to monomials.
        let d1 = 3.0 * (y1 - y0);
        let d2 = 4.5 * (y2 - 2.0 * y1 + y0);
        let d3 = 4.5 * (y3 - 3.0 * y2 + 3.0 * y1 - y0);
        // y0 + d1 t + d2 t(t − ⅓) + d3 t(t − ⅓)(t − ⅔).
        [y0, d1 - d2 / 3.0 + 2.0 * d3 / 9.0, d2 - d3, d3]
    })
}

fn horner(c: &[f64; 4], t: f64) -> f64 {
    c[0] + t * (c[1] + t * (c[2] + t * c[3]))
}

/// The fewest mantissa bits (cells 2^bits) for which every cell of a range is within the
/// tolerances at the probes; `cell(n, i)` is cell i's (start, width) when the range has n.
fn cell_bits(dipoles: &[Dipole; 3], peak: &Values, cell: impl Fn(usize, usize) -> (f64, f64)) -> u32 {
    (MIN_BITS..MAX_BITS)
        .find(|&bits| {
            let n = 1usize << bits;
            (0..n).all(|i| {
                let (u0, width) = cell(n, i);
                let cubics = fit(dipoles, u0, width);
                PROBES.iter().all(|&t| {
                    let want = exact(dipoles, u0 + width * t);
                    (0..9).all(|f| {
                        (horner(&cubics[f], t) - want[f]).abs() <= REL_TOLERANCE * want[f].abs() + ABS_TOLERANCE * peak[f]
                    })
                })
            })
        })
        .unwrap_or(MAX_BITS)
}

#[cfg(test)]
mod tests {
    use super::super::medium::Medium;
    use super::*;

    fn table(name: &str, max_distance: f64) -> DipoleTable {
        let m = Medium::preset(name).expect("a preset");
        DipoleTable::new(std::array::from_fn(|c| m.dipole(c)), max_distance)
    }

    /// Independent of the fit: the exact functions at points the construction never probed
    /// (a geometric sweep with an irrational ratio, and the cells' edges), against the bound.
    #[test]
    fn agrees_with_the_exact_dipole_everywhere_it_covers() {
        for name in ["marble", "skin1", "wholemilk", "ketchup"] {
            let t = table(name, 60.0);
            assert!(t.max_distance() >= 60.0);
            let peak = exact(t.dipoles(), 0.0).map(f64::abs);
            let mut u = 1e-9;
            let mut worst = 0.0f64;
            while u < t.top {
                let want = exact(t.dipoles(), u);
                let got = t.rd_with_derivatives(u);
                for f in 0..9 {
                    let err = (got[f / 3][f % 3] - want[f]).abs();
                    worst = worst.max(err / (want[f].abs() + 1e-4 * peak[f]));
                    assert!(
                        err <= 4.0 * (REL_TOLERANCE * want[f].abs() + ABS_TOLERANCE * peak[f]),
                        "{name}: function {f} at u = {u}: {} against {}",
                        got[f / 3][f % 3],
                        want[f]
                    );
                }
                assert_eq!(t.rd(u), got[0]);
                u *= 1.0137;
            }
            assert!(worst > 0.0, "{name}: the table reproduced the exact values bit for bit, so it was not read");
        }
    }

    #[test]
    fn is_continuous_across_cells_and_exact_past_its_top() {
        let t = table("marble", 30.0);
        for i in 1..t.binades.len() {
            let edge = t.low * 2f64.powi(i as i32);
            let (below, above) = (t.rd(f64::from_bits(edge.to_bits() - 1)), t.rd(edge));
            for c in 0..3 {
                assert!((below[c] - above[c]).abs() <= 1e-12 * above[c], "binade edge {edge}: {below:?} {above:?}");
            }
        }
        let past = t.top * 1.5;
        assert_eq!(t.rd(past), t.dipoles().map(|d| d.rd(past.sqrt())));
        assert_eq!(t.rd(0.0), t.dipoles().map(|d| d.rd_with_derivatives(0.0)[0]));
        assert!(t.len() < 20_000, "{} cells", t.len());
    }
}

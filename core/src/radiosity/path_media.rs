//! The lengths of a straight path in each medium of a heterogeneous object (Sheng et al. 2014
//! §4, eq. 16; design/radiosity.md §1.5 and pitfall 4): what the rules of
//! [`super::HetRule`] work on.
//!
//! The object's media are a [`MediumIndex`]: a bounded set of distinct media (at most
//! [`MAX_MEDIA`]) and the medium at each point, in the millimetres of the patches. A segment
//! a → b of length L is cut into n = ⌈L/h⌉ equal pieces (at most [`MAX_STEPS`]; at least one),
//! h the index's spacing, and each piece is given the medium at its midpoint (the midpoint rule
//! of the indicator of each medium along the segment): the length in medium m is L·(pieces in
//! m)/n, merged per distinct medium and sorted by medium. A boundary crossing is placed within
//! h/2 of where it is, so a length is within h/2 per crossing of the exact one; the index
//! chooses h from its media's feature size (the thinnest layer, the voxel, the veins' period).
//!
//! Example: a 3 mm segment from depth 0 to 3 mm through a layer 1 mm thick over a deeper one,
//! h = 0.25 mm: 12 pieces, the first 4 in the layer, so [(0, 1/3), (1, 2/3)] as fractions.

use glam::DVec3;

/// The most distinct media a heterogeneous profile matrix indexes (each sample's path keeps its
/// media as 16-bit indices; each medium has its own three profiles).
pub const MAX_MEDIA: usize = 16;

/// The most pieces a segment is cut into: a longer segment gets a coarser spacing than the
/// index's (256 pieces of the 35 mm of marble's red cutoff are 0.14 mm each).
pub const MAX_STEPS: usize = 256;

/// A heterogeneous object's media as the profile matrix sees them (module documentation).
pub trait MediumIndex: Sync {
    /// The number of distinct media (1 to [`MAX_MEDIA`]).
    fn count(&self) -> usize;

    /// The medium (< [`MediumIndex::count`]) at `p`, in the millimetres of the patches.
    fn medium_at(&self, p: DVec3) -> usize;

    /// The spacing h (mm, finite and > 0) at which a segment is sampled.
    fn spacing(&self) -> f64;
}

/// The fraction of the segment `a` → `b` in each medium of `media` (module documentation),
/// merged per medium and sorted by medium, written to `out` (cleared first); `counts` is
/// scratch. A segment of length 0 is wholly in the medium at `a`.
pub fn path_fractions(media: &dyn MediumIndex, a: DVec3, b: DVec3, counts: &mut Vec<u32>, out: &mut Vec<(u16, f32)>) {
    out.clear();
    let length = (b - a).length();
    let n = if length > 0.0 { ((length / media.spacing()).ceil() as usize).clamp(1, MAX_STEPS) } else { 1 };
    if n == 1 {
        out.push((media.medium_at(a.lerp(b, 0.5)) as u16, 1.0));
        return;
    }
    counts.clear();
    counts.resize(media.count(), 0);
    for k in 0..n {
        let m = media.medium_at(a.lerp(b, (k as f64 + 0.5) / n as f64));
        counts[m] += 1;
    }
    out.extend(counts.iter().enumerate().filter(|c| *c.1 > 0).map(|(m, &c)| (m as u16, (f64::from(c) / n as f64) as f32)));
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Medium 0 above z = `split`, 1 below.
    struct Split {
        split: f64,
        h: f64,
    }

    impl MediumIndex for Split {
        fn count(&self) -> usize {
            2
        }
        fn medium_at(&self, p: DVec3) -> usize {
            usize::from(p.z < self.split)
        }
        fn spacing(&self) -> f64 {
            self.h
        }
    }

    #[test]
    fn the_module_example_and_a_segment_in_one_medium() {
        let media = Split { split: -1.0, h: 0.25 };
        let (mut counts, mut out) = (Vec::new(), Vec::new());
        path_fractions(&media, DVec3::ZERO, DVec3::new(0.0, 0.0, -3.0), &mut counts, &mut out);
        assert_eq!(out, vec![(0, (4.0f64 / 12.0) as f32), (1, (8.0f64 / 12.0) as f32)]);
        path_fractions(&media, DVec3::ZERO, DVec3::new(5.0, 0.0, -0.5), &mut counts, &mut out);
        assert_eq!(out, vec![(0, 1.0)]);
        path_fractions(&media, DVec3::new(0.0, 0.0, -2.0), DVec3::new(0.0, 0.0, -2.0), &mut counts, &mut out);
        assert_eq!(out, vec![(1, 1.0)]);
    }

    #[test]
    fn lengths_are_within_half_a_spacing_per_crossing() {
        // From z = 0.3 down to z = −1.9 across z = −0.4537: exactly 0.7537/2.2 of it above.
        let media = Split { split: -0.4537, h: 0.1 };
        let (mut counts, mut out) = (Vec::new(), Vec::new());
        let (a, b) = (DVec3::new(0.1, 0.2, 0.3), DVec3::new(1.0, -0.4, -1.9));
        path_fractions(&media, a, b, &mut counts, &mut out);
        let length = (b - a).length();
        let above = 0.7537 / 2.2 * length;
        let got = f64::from(out[0].1) * length;
        let n = (length / 0.1).ceil();
        assert!((got - above).abs() <= 0.5 * length / n + 1e-6, "{got} vs {above}");
        assert!((f64::from(out[0].1) + f64::from(out[1].1) - 1.0).abs() < 1e-6);
        // A long segment is cut into MAX_STEPS pieces, no more.
        let long = Split { split: -50.0, h: 1e-3 };
        path_fractions(&long, DVec3::ZERO, DVec3::new(0.0, 0.0, -100.0), &mut counts, &mut out);
        assert_eq!(out, vec![(0, 0.5), (1, 0.5)]);
    }
}

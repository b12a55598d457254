//! The lengths of a straight path in each medium of a heterogeneous object (Sheng et al. 2014
//! §4, eq. 16; design/radiosity.md §1.5 and pitfall 4): what the rules of
//! [`super::HetRule`] work on.
//!
//! The object's media are a [`MediumIndex`]: a bounded set of distinct media (at most
//! [`MAX_MEDIA`]) and the medium at each point, in the millimetres of the patches. A segment
//! a → b of length L is sampled at the midpoints of n = ⌈L/h⌉ equal pieces (at most
//! [`MAX_STEPS`]; at least one), h the index's spacing; where two neighbouring samples differ,
//! the change is found by [`BISECTIONS`] bisections between them, and the length in medium m is
//! the sum of its runs between changes (the first run from a, the last to b), as a fraction of
//! L, merged per distinct medium and sorted by medium. A crossing is so placed within
//! h/2^([`BISECTIONS`] + 1) of where it is, for a few more lookups per crossing, where the
//! midpoint rule alone (each piece its midpoint's medium) places it only within h/2. What the sampling
//! still misses is a feature thinner than h between two samples of one medium: the index
//! chooses h from its media's feature size (the thinnest layer, the voxel, the veins' period).
//!
//! Example: a 3 mm segment from depth 0 to 3 mm through a layer 1 mm thick over a deeper one,
//! h = 0.25 mm: 12 samples, the first 4 in the layer, the crossing found between the 4th and
//! the 5th, so [(0, 1/3), (1, 2/3)] as fractions.

use glam::DVec3;

/// The most distinct media a heterogeneous profile matrix indexes (each sample's path keeps its
/// media as 16-bit indices; each medium has its own three profiles).
pub const MAX_MEDIA: usize = 16;

/// The bisections that place a crossing between two samples of different media.
pub const BISECTIONS: u32 = 6;

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
/// merged per medium and sorted by medium, written to `out` (cleared first); `lengths` is
/// scratch. A segment of length 0 is wholly in the medium at `a`.
pub fn path_fractions(media: &dyn MediumIndex, a: DVec3, b: DVec3, lengths: &mut Vec<f64>, out: &mut Vec<(u16, f32)>) {
    out.clear();
    let length = (b - a).length();
    let n = if length > 0.0 { ((length / media.spacing()).ceil() as usize).clamp(1, MAX_STEPS) } else { 1 };
    let at = |t: f64| media.medium_at(a.lerp(b, t));
    let step = 1.0 / n as f64;
    let mut current = at(0.5 * step);
    if n == 1 {
        out.push((current as u16, 1.0));
        return;
    }
    lengths.clear();
    lengths.resize(media.count(), 0.0);
    let mut run_start = 0.0;
    for k in 1..n {
        let t = (k as f64 + 0.5) * step;
        let m = at(t);
        if m != current {
            let (mut inside, mut outside) = (t - step, t);
            for _ in 0..BISECTIONS {
                let mid = 0.5 * (inside + outside);
                if at(mid) == current {
                    inside = mid;
                } else {
                    outside = mid;
                }
            }
            let crossing = 0.5 * (inside + outside);
            lengths[current] += crossing - run_start;
            (run_start, current) = (crossing, m);
        }
    }
    lengths[current] += 1.0 - run_start;
    out.extend(lengths.iter().enumerate().filter(|l| *l.1 > 0.0).map(|(m, &l)| (m as u16, l as f32)));
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

    /// `inner`, counting its lookups.
    struct Counted {
        inner: Split,
        calls: std::sync::atomic::AtomicUsize,
    }

    impl MediumIndex for Counted {
        fn count(&self) -> usize {
            self.inner.count()
        }
        fn medium_at(&self, p: DVec3) -> usize {
            self.calls.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            self.inner.medium_at(p)
        }
        fn spacing(&self) -> f64 {
            self.inner.spacing()
        }
    }

    /// Half a piece of length `piece` after the bisections: how far a crossing may be placed.
    fn bisected(piece: f64) -> f64 {
        piece / f64::from(1u32 << (BISECTIONS + 1))
    }

    /// `got`'s media are `want`'s and each fraction within `tolerance` (and an f32 rounding).
    fn within(got: &[(u16, f32)], want: &[(u16, f64)], tolerance: f64) -> bool {
        got.len() == want.len()
            && got.iter().zip(want).all(|(g, w)| g.0 == w.0 && (f64::from(g.1) - w.1).abs() <= tolerance + 1e-7)
    }

    #[test]
    fn the_module_example_and_a_segment_in_one_medium() {
        let media = Split { split: -1.0, h: 0.25 };
        let (mut counts, mut out) = (Vec::new(), Vec::new());
        path_fractions(&media, DVec3::ZERO, DVec3::new(0.0, 0.0, -3.0), &mut counts, &mut out);
        // The crossing within half a bisected piece (a twelfth of the segment).
        assert!(within(&out, &[(0, 1.0 / 3.0), (1, 2.0 / 3.0)], bisected(1.0 / 12.0)), "{out:?}");
        path_fractions(&media, DVec3::ZERO, DVec3::new(5.0, 0.0, -0.5), &mut counts, &mut out);
        assert_eq!(out, vec![(0, 1.0)]);
        path_fractions(&media, DVec3::new(0.0, 0.0, -2.0), DVec3::new(0.0, 0.0, -2.0), &mut counts, &mut out);
        assert_eq!(out, vec![(1, 1.0)]);
    }

    #[test]
    fn lengths_are_within_a_bisected_spacing_per_crossing() {
        // From z = 0.3 down to z = −1.9 across z = −0.4537: exactly 0.7537/2.2 of it above.
        let media = Split { split: -0.4537, h: 0.1 };
        let (mut counts, mut out) = (Vec::new(), Vec::new());
        let (a, b) = (DVec3::new(0.1, 0.2, 0.3), DVec3::new(1.0, -0.4, -1.9));
        path_fractions(&media, a, b, &mut counts, &mut out);
        let length = (b - a).length();
        let above = 0.7537 / 2.2 * length;
        let got = f64::from(out[0].1) * length;
        let n = (length / 0.1).ceil();
        assert!((got - above).abs() <= bisected(length / n) + 1e-6, "{got} vs {above}");
        assert!((f64::from(out[0].1) + f64::from(out[1].1) - 1.0).abs() < 1e-6);
        // A long segment is cut into MAX_STEPS pieces, no more.
        let long = Split { split: -50.0, h: 1e-3 };
        path_fractions(&long, DVec3::ZERO, DVec3::new(0.0, 0.0, -100.0), &mut counts, &mut out);
        assert!(within(&out, &[(0, 0.5), (1, 0.5)], bisected(1.0 / MAX_STEPS as f64)), "{out:?}");
        // Counted in pieces: MAX_STEPS samples and BISECTIONS lookups, not 10⁵.
        let counted = Counted { inner: long, calls: std::sync::atomic::AtomicUsize::new(0) };
        path_fractions(&counted, DVec3::ZERO, DVec3::new(0.0, 0.0, -100.0), &mut counts, &mut out);
        assert_eq!(counted.calls.into_inner(), MAX_STEPS + BISECTIONS as usize);
    }
}

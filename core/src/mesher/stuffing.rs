//! Isosurface stuffing (Labelle & Shewchuk 2007) on the BCC tets of an octree: label the vertices
//! by the winding number, place cut points where tet edges cross the surface, warp vertices that
//! are too close to a cut point onto it, and fill every tet with the stencil of its labels.

use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use glam::DVec3;
use rayon::prelude::*;

use super::lattice::{edge_key, Lattice};
use super::octree::{self, Background, Octree};
use super::stencil::{fill, StencilContext, Vert};
use super::winding::WindingNumber;
use crate::progress::{Cancelled, Progress, ProgressCounter};

/// Warping thresholds of Labelle & Shewchuk (Table 1, one-sided): a cut point closer than
/// `α · |edge|` to a lattice vertex pulls the vertex onto it. With these the output dihedral
/// angles provably lie in about [10.7°, 164.8°].
const ALPHA_LONG: f64 = 0.24999;
const ALPHA_SHORT: f64 = 0.41189;

/// A tetrahedral mesh straight out of the stencils (unused vertices already removed).
pub(crate) struct Stuffed {
    pub positions: Vec<DVec3>,
    pub tets: Vec<[u32; 4]>,
    /// Cut points placed by bisection of the winding number (no surface crossing found: holes).
    pub bisected_cuts: usize,
    /// Whether each output vertex lies on the surface (warped lattice vertices and cut points);
    /// inside lattice vertices are interior to the mesh.
    pub on_surface: Vec<bool>,
    /// Background vertices evaluated (cube corners and centres).
    pub lattice_vertices: usize,
    /// Octrees built: 1, plus one per refinement where a coarse tet straddled the surface.
    pub octree_rounds: usize,
    /// Leaf cubes of each level (side `2ᵏ h`) of the final octree.
    pub leaves_per_level: Vec<usize>,
    /// Milliseconds in each phase.
    pub timings: PhaseTimings,
}

/// Milliseconds spent in each phase of one stuffing pass.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct PhaseTimings {
    /// Winding numbers at the lattice vertices.
    pub labels_ms: f64,
    /// Cut points on edges crossing the surface.
    pub cuts_ms: f64,
    /// Warping lattice vertices onto nearby cut points.
    pub warp_ms: f64,
    /// Filling BCC tets with stencils and renumbering.
    pub stencils_ms: f64,
}

fn ms_since(t: std::time::Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

/// The winding number, re-evaluated with a stricter far-field criterion (β = 5, errors about 4×
/// smaller) where its magnitude is within 0.05 of the ½ threshold, so that labels of points
/// close to the threshold do not depend on the far-field error.
pub(crate) fn accurate_winding(surface: &WindingNumber, p: DVec3) -> f64 {
    let w = surface.at(p);
    if (w.abs() - 0.5).abs() < 0.05 {
        surface.at_with_accuracy(p, 5.0)
    } else {
        w
    }
}

/// Labels of lattice vertices: +1 inside, 0 on the surface (warped), −1 outside. Inside is
/// `|w| ≥ ½`: the magnitude, so that an open shell wound inwards (whose winding the mesh's
/// orientation keeps, see [`crate::mesh::TriMesh::flipped_faces`]) encloses the same solid as
/// one wound outwards; a consistently outward surface has `w > −½` everywhere, where the
/// magnitude changes nothing.
fn label(w: f64) -> i8 {
    if inside(w) {
        1
    } else {
        -1
    }
}

/// Whether winding number `w` is inside the solid: `|w| ≥ ½`.
pub(crate) fn inside(w: f64) -> bool {
    w.abs() >= 0.5
}

/// Runs isosurface stuffing of the solid `|w| ≥ ½` on the octree of `lattice` (the finest
/// cubes): with `grading = None` every cube inside the solid is of the finest level (the uniform
/// BCC lattice); with `Some(layers)` only those near the surface are, and sizes double inwards
/// after `layers` cubes of each size. Where the surface is a cycle
/// ([`WindingNumber::is_cycle`]) the winding number is not evaluated inside the cubes whose value
/// is known from their coarse cube's centre ([`octree::Known`]).
pub(crate) fn stuff(
    surface: &WindingNumber,
    lattice: &Lattice,
    grading: Option<usize>,
    progress: &Progress,
) -> Result<Stuffed, Cancelled> {
    let mut timings = PhaseTimings::default();
    let t = std::time::Instant::now();
    // 1. The octree and the winding numbers at its vertices (the dominant cost), with progress
    //    and cancel. Where a coarse tet turns out to straddle the ½ contour (through a hole of an
    //    open surface, away from any triangle) the cubes around it are refined and the octree
    //    rebuilt.
    let (fine, levels) = octree::padded(lattice, true);
    let (mut needed, known) = octree::band(surface, &fine, levels, grading.is_none());
    // A refinement round keeps almost every vertex of the last: their winding numbers are
    // looked up by position (the octree computes a lattice point's coordinates the same way
    // every time), not evaluated again.
    let mut earlier: HashMap<[u64; 3], f64> = HashMap::new();
    let mut octree_rounds = 0;
    let (background, winding, mut labels) = loop {
        octree_rounds += 1;
        let background = Octree::new(fine, levels, &needed, grading.unwrap_or(1)).background();
        let known = |p: DVec3| earlier.get(&p.to_array().map(f64::to_bits)).copied().or_else(|| known.at(p));
        let winding = winding_numbers(surface, &background.positions, known, progress)?;
        let labels: Vec<i8> = winding.par_iter().map(|&w| label(w)).collect();
        let unresolved = unresolved(&background, &labels);
        if unresolved.is_empty() {
            break (background, winding, labels);
        }
        octree::mark_boxes(&mut needed, &fine, &unresolved);
        earlier = background.positions.iter().zip(&winding).map(|(p, &w)| (p.to_array().map(f64::to_bits), w)).collect();
    };
    let bg = &background;
    let nv = bg.positions.len();
    timings.labels_ms = ms_since(t);
    let t = std::time::Instant::now();

    // 2. Cut points on tet edges whose ends are labelled in and out.
    let mut crossing: Vec<u64> =
        bg.tets.par_iter().flat_map_iter(|tet| mixed_edges(tet, &labels).map(|(a, b)| edge_key(a, b))).collect();
    crossing.par_sort_unstable();
    crossing.dedup();
    let bisected = AtomicUsize::new(0);
    let cuts: Vec<(u64, DVec3)> = crossing
        .par_iter()
        .map_init(Vec::new, |hits, &key| {
            let (u, v) = ((key >> 32) as u32, key as u32);
            let (a, b) = if labels[u as usize] > 0 { (u, v) } else { (v, u) };
            let (p, by_bisection) =
                cut_point(surface, bg.positions[a as usize], bg.positions[b as usize], winding[a as usize], hits);
            if by_bisection {
                bisected.fetch_add(1, Ordering::Relaxed);
            }
            (key, p)
        })
        .collect();
    progress.report("cut points", 1.0)?;
    timings.cuts_ms = ms_since(t);
    let t = std::time::Instant::now();

    // 3. Warping: a vertex violated by a cut point (closer than α·|edge|) moves onto the closest
    //    violating cut point and is labelled 0; decided on the unwarped vertices, then applied.
    let mut violations: Vec<(u32, f64, DVec3)> = cuts
        .par_iter()
        .flat_map_iter(|&(key, c)| {
            let (a, b) = ((key >> 32) as u32, key as u32);
            let (pa, pb) = (bg.positions[a as usize], bg.positions[b as usize]);
            let long = bg.is_corner(a) == bg.is_corner(b);
            let alpha = if long { ALPHA_LONG } else { ALPHA_SHORT };
            let limit = alpha * (pb - pa).length();
            [(a, (c - pa).length()), (b, (c - pb).length())]
                .into_iter()
                .filter(move |&(_, d)| d < limit)
                .map(move |(v, d)| (v, d, c))
        })
        .collect();
    violations.par_sort_unstable_by(|x, y| x.0.cmp(&y.0).then(x.1.total_cmp(&y.1)));
    let mut positions = bg.positions.clone();
    for (i, &(v, _, c)) in violations.iter().enumerate() {
        if i == 0 || violations[i - 1].0 != v {
            positions[v as usize] = c;
            labels[v as usize] = 0;
        }
    }
    progress.report("warping", 1.0)?;
    timings.warp_ms = ms_since(t);
    let t = std::time::Instant::now();

    // 4. Output numbering: vertices in or on the surface, then surviving cut points (both ends
    //    still strictly in and out).
    let mut out_id = vec![u32::MAX; nv];
    let mut next = 0u32;
    for v in 0..nv {
        if labels[v] >= 0 {
            out_id[v] = next;
            next += 1;
        }
    }
    let mut cut_id = vec![u32::MAX; cuts.len()];
    for (i, (key, _)) in cuts.iter().enumerate() {
        let (a, b) = ((key >> 32) as usize, (*key & 0xffff_ffff) as usize);
        if labels[a] != 0 && labels[b] != 0 {
            cut_id[i] = next;
            next += 1;
        }
    }
    let mut out_positions = vec![DVec3::ZERO; next as usize];
    let mut out_surface = vec![false; next as usize];
    for v in 0..nv {
        if out_id[v] != u32::MAX {
            out_positions[out_id[v] as usize] = positions[v];
            out_surface[out_id[v] as usize] = labels[v] == 0;
        }
    }
    for (i, (_, p)) in cuts.iter().enumerate() {
        if cut_id[i] != u32::MAX {
            out_positions[cut_id[i] as usize] = *p;
        }
    }

    // 5. Stencils, chunk by chunk in parallel; the concatenation order is fixed (deterministic).
    let ctx = Context { background: bg, positions: &positions, cuts: &cuts };
    let resolve = |v: Vert| -> u32 {
        match v {
            Vert::Lattice(l) => out_id[l as usize],
            Vert::Cut(a, b) => {
                let key = edge_key(a, b);
                cuts.binary_search_by_key(&key, |c| c.0).map_or(u32::MAX, |i| cut_id[i])
            }
        }
    };
    const CHUNK: usize = 8192;
    let chunks_done = ProgressCounter::new(progress, "stencils", bg.tets.len().div_ceil(CHUNK));
    let chunks: Vec<Vec<[u32; 4]>> = bg
        .tets
        .par_chunks(CHUNK)
        .map(|chunk| {
            let mut local = Vec::new();
            let mut verts = Vec::new();
            for &ids in chunk {
                let l = ids.map(|v| labels[v as usize]);
                if l.iter().all(|&x| x < 0) {
                    continue;
                }
                verts.clear();
                let centroid = || {
                    let c = ids.iter().map(|&v| positions[v as usize]).sum::<DVec3>() / 4.0;
                    inside(accurate_winding(surface, c))
                };
                fill(&ctx, ids, l, centroid, &mut verts);
                for t in &verts {
                    let r = t.map(resolve);
                    if r.iter().all(|&x| x != u32::MAX) {
                        local.push(r);
                    }
                }
            }
            let _ = chunks_done.add(1);
            local
        })
        .collect();
    let tets: Vec<[u32; 4]> = chunks.concat();
    progress.report("stencils", 1.0)?;

    // 6. Drop vertices no tet uses (isolated surface vertices) and renumber.
    let mut used = vec![u32::MAX; out_positions.len()];
    let mut count = 0u32;
    for t in &tets {
        for &v in t {
            if used[v as usize] == u32::MAX {
                used[v as usize] = 0;
            }
        }
    }
    let mut final_positions = Vec::new();
    let mut on_surface = Vec::new();
    let first_cut = out_id.iter().filter(|&&i| i != u32::MAX).count();
    for (v, u) in used.iter_mut().enumerate() {
        if *u == 0 {
            *u = count;
            count += 1;
            final_positions.push(out_positions[v]);
            on_surface.push(v >= first_cut || out_surface[v]);
        }
    }
    let tets = tets.into_par_iter().map(|t| t.map(|v| used[v as usize])).collect();
    timings.stencils_ms = ms_since(t);
    Ok(Stuffed {
        positions: final_positions,
        tets,
        bisected_cuts: bisected.into_inner(),
        on_surface,
        lattice_vertices: nv,
        octree_rounds,
        leaves_per_level: background.leaves_per_level,
        timings,
    })
}

/// The winding numbers at `points`, in parallel, with progress and cancel; evaluated only where
/// `known` does not give them.
fn winding_numbers(
    surface: &WindingNumber,
    points: &[DVec3],
    known: impl Fn(DVec3) -> Option<f64> + Sync,
    progress: &Progress,
) -> Result<Vec<f64>, Cancelled> {
    let done = ProgressCounter::new(progress, "winding numbers", points.len());
    let cancelled = AtomicBool::new(false);
    let winding: Vec<f64> = points
        .par_chunks(4096)
        .flat_map_iter(|chunk| {
            if cancelled.load(Ordering::Relaxed) {
                return vec![0.0; chunk.len()];
            }
            let out: Vec<f64> = chunk.iter().map(|&p| known(p).unwrap_or_else(|| accurate_winding(surface, p))).collect();
            if done.add(out.len()).is_err() {
                cancelled.store(true, Ordering::Relaxed);
            }
            out
        })
        .collect();
    if cancelled.load(Ordering::Relaxed) {
        return Err(Cancelled);
    }
    Ok(winding)
}

/// The edges of `tet` whose ends are labelled differently.
fn mixed_edges<'a>(tet: &'a [u32; 4], labels: &'a [i8]) -> impl Iterator<Item = (u32, u32)> + 'a {
    const EDGES: [(usize, usize); 6] = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)];
    EDGES.iter().map(|&(i, j)| (tet[i], tet[j])).filter(|&(a, b)| labels[a as usize] != labels[b as usize])
}

/// Bounding boxes of the transition tets that the stencils must not see: those with vertices
/// on both sides of the surface, or with a vertex that ends a crossing edge (and may be warped).
/// Empty for closed surfaces, whose ½ contour keeps to the finest cubes near the triangles.
fn unresolved(bg: &Background, labels: &[i8]) -> Vec<(DVec3, DVec3)> {
    let mut ends_crossing = vec![false; bg.positions.len()];
    for tet in &bg.tets {
        for (a, b) in mixed_edges(tet, labels) {
            ends_crossing[a as usize] = true;
            ends_crossing[b as usize] = true;
        }
    }
    bg.tets
        .par_iter()
        .zip(&bg.standard)
        .filter(|&(tet, &standard)| !standard && tet.iter().any(|&v| ends_crossing[v as usize]))
        .map(|(tet, _)| {
            let p = tet.map(|v| bg.positions[v as usize]);
            (p.iter().fold(p[0], |a, &b| a.min(b)), p.iter().fold(p[0], |a, &b| a.max(b)))
        })
        .collect()
}

/// The background, warped positions and cut points, as the stencils see them.
struct Context<'a> {
    background: &'a Background,
    positions: &'a [DVec3],
    cuts: &'a [(u64, DVec3)],
}

impl StencilContext for Context<'_> {
    fn is_corner(&self, v: u32) -> bool {
        self.background.is_corner(v)
    }

    fn position(&self, v: Vert) -> DVec3 {
        match v {
            Vert::Lattice(l) => self.positions[l as usize],
            Vert::Cut(a, b) => {
                let key = edge_key(a, b);
                self.cuts.binary_search_by_key(&key, |c| c.0).map_or_else(
                    |_| 0.5 * (self.background.positions[a as usize] + self.background.positions[b as usize]),
                    |i| self.cuts[i].1,
                )
            }
        }
    }

    fn lattice_position(&self, v: u32) -> DVec3 {
        self.background.positions[v as usize]
    }
}

/// Where the surface crosses the lattice edge from `a` (inside, winding number `w_a`) to `b`
/// (outside). Walks the surface crossings along the edge, updating the winding number by ∓1 at
/// each (−1 leaving through an outward face), and returns the crossing where its magnitude drops below ½,
/// exactly on the input surface. Where no crossing explains the change (the edge passes through
/// a hole of an open surface) the point is found by bisection of the winding number; the flag
/// says so.
fn cut_point(surface: &WindingNumber, a: DVec3, b: DVec3, w_a: f64, hits: &mut Vec<(f64, u32)>) -> (DVec3, bool) {
    hits.clear();
    surface.bvh().segment_hits(a, b, hits);
    let d = b - a;
    let mut w = w_a;
    for &(t, tri) in hits.iter() {
        let [p0, p1, p2] = surface.bvh().corners[tri as usize];
        let n = (p1 - p0).cross(p2 - p0);
        w -= n.dot(d).signum();
        if !inside(w) {
            return (a + t.clamp(0.0, 1.0) * d, false);
        }
    }
    // Across a hole the ½-contour of the winding number is itself an interpolation: 12 halvings
    // (1/4096 of the edge) with the fast evaluation are plenty.
    let (mut lo, mut hi) = (0.0, 1.0);
    for _ in 0..12 {
        let mid = 0.5 * (lo + hi);
        if inside(surface.at(a + mid * d)) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let t = 0.5 * (lo + hi);
    // Inconsistently oriented faces break the ±1 walk, but the crossing is still on the surface:
    // take the surface crossing nearest to where the winding number drops below ½.
    match hits.iter().min_by(|x, y| (x.0 - t).abs().total_cmp(&(y.0 - t).abs())) {
        Some(&(th, _)) => (a + th.clamp(0.0, 1.0) * d, false),
        None => (a + t * d, true),
    }
}

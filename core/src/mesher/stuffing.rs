//! Isosurface stuffing on a uniform BCC lattice (Labelle & Shewchuk 2007): label lattice
//! vertices by the winding number, place cut points where lattice edges cross the surface, warp
//! lattice vertices that are too close to a cut point onto it, and fill every BCC tet with the
//! stencil of its labels.

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use glam::DVec3;
use rayon::prelude::*;

use super::lattice::{edge_key, Lattice};
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
    /// Lattice vertices evaluated.
    pub lattice_vertices: usize,
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

/// Runs isosurface stuffing of the solid `|w| ≥ ½` on `lattice`.
pub(crate) fn stuff(surface: &WindingNumber, lattice: &Lattice, progress: &Progress) -> Result<Stuffed, Cancelled> {
    let nv = lattice.vertex_count();
    let mut timings = PhaseTimings::default();
    let t = std::time::Instant::now();
    // 1. Winding numbers at every lattice vertex (the dominant cost), with progress and cancel.
    let done = ProgressCounter::new(progress, "winding numbers", nv);
    let cancelled = AtomicBool::new(false);
    let chunk = 4096;
    let winding: Vec<f64> = (0..nv)
        .into_par_iter()
        .chunks(chunk)
        .flat_map_iter(|ids| {
            if cancelled.load(Ordering::Relaxed) {
                return vec![0.0; ids.len()];
            }
            let out: Vec<f64> = ids.iter().map(|&v| accurate_winding(surface, lattice.position(v as u32))).collect();
            if done.add(out.len()).is_err() {
                cancelled.store(true, Ordering::Relaxed);
            }
            out
        })
        .collect();
    if cancelled.load(Ordering::Relaxed) {
        return Err(Cancelled);
    }
    let mut labels: Vec<i8> = winding.par_iter().map(|&w| label(w)).collect();
    timings.labels_ms = ms_since(t);
    let t = std::time::Instant::now();

    // 2. Cut points on edges whose ends are labelled in and out.
    let bisected = AtomicUsize::new(0);
    let mut cuts: Vec<(u64, DVec3)> = (0..nv as u32)
        .into_par_iter()
        .flat_map_iter(|u| {
            let mut nb = [(0u32, false); 14];
            let n = lattice.neighbours(u, &mut nb);
            let mut hits = Vec::new();
            let mut found = Vec::new();
            for &(v, _) in &nb[..n] {
                if v > u && labels[u as usize] != labels[v as usize] {
                    let (a, b) = if labels[u as usize] > 0 { (u, v) } else { (v, u) };
                    let (p, by_bisection) =
                        cut_point(surface, lattice.position(a), lattice.position(b), winding[a as usize], &mut hits);
                    if by_bisection {
                        bisected.fetch_add(1, Ordering::Relaxed);
                    }
                    found.push((edge_key(u, v), p));
                }
            }
            found
        })
        .collect();
    cuts.par_sort_unstable_by_key(|c| c.0);
    progress.report("cut points", 1.0)?;
    timings.cuts_ms = ms_since(t);
    let t = std::time::Instant::now();

    // 3. Warping: a vertex violated by a cut point (closer than α·|edge|) moves onto the closest
    //    violating cut point and is labelled 0; decided on the unwarped lattice, then applied.
    let lookup = |a: u32, b: u32| -> Option<DVec3> {
        let key = edge_key(a, b);
        cuts.binary_search_by_key(&key, |c| c.0).ok().map(|i| cuts[i].1)
    };
    let warps: Vec<Option<DVec3>> = (0..nv as u32)
        .into_par_iter()
        .map(|u| {
            let pu = lattice.position(u);
            let mut nb = [(0u32, false); 14];
            let n = lattice.neighbours(u, &mut nb);
            let mut best: Option<(f64, DVec3)> = None;
            for &(v, long) in &nb[..n] {
                if labels[v as usize] == labels[u as usize] {
                    continue;
                }
                let Some(c) = lookup(u, v) else { continue };
                let len = if long { lattice.h } else { lattice.h * 0.75f64.sqrt() };
                let d = (c - pu).length();
                let alpha = if long { ALPHA_LONG } else { ALPHA_SHORT };
                if d < alpha * len && best.is_none_or(|(bd, _)| d < bd) {
                    best = Some((d, c));
                }
            }
            best.map(|b| b.1)
        })
        .collect();
    let mut positions: Vec<DVec3> = (0..nv as u32).into_par_iter().map(|v| lattice.position(v)).collect();
    for (v, w) in warps.iter().enumerate() {
        if let Some(p) = w {
            positions[v] = *p;
            labels[v] = 0;
        }
    }
    progress.report("warping", 1.0)?;
    timings.warp_ms = ms_since(t);
    let t = std::time::Instant::now();

    // 4. Output numbering: lattice vertices in or on the surface, then surviving cut points
    //    (both ends still strictly in and out).
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

    // 5. Stencils, slab by slab in parallel; the concatenation order is fixed (deterministic).
    let ctx = Context { lattice, positions: &positions, cuts: &cuts };
    let resolve = |v: Vert| -> u32 {
        match v {
            Vert::Lattice(l) => out_id[l as usize],
            Vert::Cut(a, b) => {
                let key = edge_key(a, b);
                cuts.binary_search_by_key(&key, |c| c.0).map_or(u32::MAX, |i| cut_id[i])
            }
        }
    };
    let [nx, ny, nz] = lattice.n;
    let slabs_done = ProgressCounter::new(progress, "stencils", nz);
    let slabs: Vec<Vec<[u32; 4]>> = (0..nz)
        .into_par_iter()
        .map(|k| {
            let mut local = Vec::new();
            let mut verts = Vec::new();
            for j in 0..ny {
                for i in 0..nx {
                    lattice.tets_at([i, j, k], |ids| {
                        let l = ids.map(|v| labels[v as usize]);
                        if l.iter().all(|&x| x < 0) {
                            return;
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
                    });
                }
            }
            let _ = slabs_done.add(1);
            local
        })
        .collect();
    let tets: Vec<[u32; 4]> = slabs.concat();
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
        timings,
    })
}

/// The lattice, warped positions and cut points, as the stencils see them.
struct Context<'a> {
    lattice: &'a Lattice,
    positions: &'a [DVec3],
    cuts: &'a [(u64, DVec3)],
}

impl StencilContext for Context<'_> {
    fn is_corner(&self, v: u32) -> bool {
        self.lattice.is_corner(v)
    }

    fn position(&self, v: Vert) -> DVec3 {
        match v {
            Vert::Lattice(l) => self.positions[l as usize],
            Vert::Cut(a, b) => {
                let key = edge_key(a, b);
                self.cuts
                    .binary_search_by_key(&key, |c| c.0)
                    .map_or_else(|_| 0.5 * (self.lattice.position(a) + self.lattice.position(b)), |i| self.cuts[i].1)
            }
        }
    }

    fn lattice_position(&self, v: u32) -> DVec3 {
        self.lattice.position(v)
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

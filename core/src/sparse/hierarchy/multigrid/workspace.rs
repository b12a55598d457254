//! The vectors of the V-cycle and of the outer CG, allocated once per multigrid and reused.

use std::sync::{Mutex, TryLockError};

use super::Multigrid;
use crate::sparse::hierarchy::Hierarchy;

/// A vector of `n` zeros whose pages are touched now (not at first use inside a solve).
fn touched(n: usize) -> Vec<[f64; 3]> {
    let mut v = Vec::with_capacity(n);
    v.resize(n, [0.0; 3]);
    v
}

/// The vectors of one level: `r`, `z` the level's right-hand side and solution (not used at
/// level 0, whose are the caller's), `alt` the second buffer of `z`, `d` the Chebyshev
/// direction, `res` the residual (only above the coarsest).
#[derive(Default)]
pub(super) struct LevelWork {
    pub(super) r: Vec<[f64; 3]>,
    pub(super) z: Vec<[f64; 3]>,
    pub(super) alt: Vec<[f64; 3]>,
    pub(super) d: Vec<[f64; 3]>,
    pub(super) res: Vec<[f64; 3]>,
}

/// The vectors of the outer CG of [`mg_pcg`](super::mg_pcg).
pub(super) struct Outer {
    pub(super) x: Vec<[f64; 3]>,
    pub(super) r: Vec<[f64; 3]>,
    pub(super) z: Vec<[f64; 3]>,
    pub(super) p: Vec<[f64; 3]>,
    pub(super) q: Vec<[f64; 3]>,
}

/// Every vector of a V-cycle (per level) and of [`mg_pcg`](super::mg_pcg).
pub(super) struct Workspace {
    pub(super) levels: Vec<LevelWork>,
    pub(super) outer: Outer,
}

impl Workspace {
    pub(super) fn new(h: &Hierarchy) -> Self {
        let count = h.levels();
        let levels = (0..count)
            .map(|l| {
                let n = h.level(l).graph.n();
                let (nr, ns) = (if l == 0 { 0 } else { n }, if l + 1 < count { n } else { 0 });
                LevelWork { r: touched(nr), z: touched(nr), alt: touched(ns), d: touched(ns), res: touched(ns) }
            })
            .collect();
        let n = h.level(0).graph.n();
        Self { levels, outer: Outer { x: touched(n), r: touched(n), z: touched(n), p: touched(n), q: touched(n) } }
    }
}

/// The reusable workspace (a clone starts without one and allocates it on first use).
pub(super) struct WorkCell(Mutex<Option<Workspace>>);

impl WorkCell {
    /// A cell holding a workspace for `h`, allocated now.
    pub(super) fn new(h: &Hierarchy) -> Self {
        Self(Mutex::new(Some(Workspace::new(h))))
    }
}

impl Clone for WorkCell {
    fn clone(&self) -> Self {
        Self(Mutex::new(None))
    }
}

impl std::fmt::Debug for WorkCell {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("WorkCell")
    }
}

impl Multigrid {
    /// Runs `f` with the workspace: the stored one, or a fresh one while another thread holds it.
    pub(super) fn with_workspace<T>(&self, f: impl FnOnce(&mut Workspace) -> T) -> T {
        let guard = match self.work.0.try_lock() {
            Ok(g) => Some(g),
            // Every vector is written before it is read, so a panic elsewhere left nothing stale.
            Err(TryLockError::Poisoned(p)) => Some(p.into_inner()),
            Err(TryLockError::WouldBlock) => None,
        };
        match guard {
            Some(mut g) => f(g.get_or_insert_with(|| Workspace::new(&self.hierarchy))),
            None => f(&mut Workspace::new(&self.hierarchy)),
        }
    }
}

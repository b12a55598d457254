//! What only some methods can do after a bake: capability traits of a method's live state (for
//! TransCut, its [`crate::edit::Editor`]). [`crate::session::Session`] offers each capability
//! for every object and answers [`crate::session::SessionError::Unsupported`], naming the
//! method, where the object's method lacks it.
//!
//! Every capability keeps the state unchanged when it fails, so a caller's data is never left
//! half-edited; each reports its stages to a [`Progress`], whose cancel is one more failure.

use glam::DMat4;

use crate::edit::{Cutter, EditError, MediumEdit, PaintStroke, UpdateStats};
use crate::light::Light;
use crate::progress::Progress;

/// Solving again under new lights, warm-started, with the light-independent work kept.
pub(crate) trait Relight {
    /// What a relight replaced, so that a caller relighting several objects can undo the ones
    /// already relit when a later one fails.
    type Undo;

    /// Re-solves under `lights`.
    ///
    /// # Errors
    /// An invalid light or a failed solve; the state is then unchanged.
    fn relight(&mut self, lights: &[Light], progress: Progress) -> Result<(UpdateStats, Self::Undo), EditError>;

    /// Puts the state back as it was before the relight that returned `undo`.
    ///
    /// # Errors
    /// When the state changed since that relight; it is then unchanged.
    fn undo_relight(&mut self, undo: Self::Undo) -> Result<(), EditError>;

    /// The radiance at the user's vertices, while the object has them (not cut or moved).
    fn user_radiance(&self) -> Option<Vec<[f64; 3]>>;
}

/// Changing the medium: an operation on a region, or a painted stroke.
pub(crate) trait EditMedium {
    /// Applies `edit` and re-solves.
    ///
    /// # Errors
    /// An invalid region or operation, or a failed solve; the state is then unchanged.
    fn edit_medium(&mut self, edit: &MediumEdit, progress: Progress) -> Result<UpdateStats, EditError>;

    /// Blends `stroke`'s medium in along it and re-solves.
    ///
    /// # Errors
    /// An invalid stroke or a failed solve; the state is then unchanged.
    fn paint(&mut self, stroke: &PaintStroke, progress: Progress) -> Result<UpdateStats, EditError>;
}

/// Moving the vertices of the object's surface, its topology kept (an animated, deformed mesh).
pub(crate) trait Deform {
    /// Puts the surface's vertices at `positions` (object space, one per vertex of the mesh the
    /// object was baked from, in its order) and updates the radiance.
    ///
    /// # Errors
    /// Positions of another count or not finite, a cancellation; the state is then unchanged.
    fn set_positions(&mut self, positions: &[[f64; 3]], progress: Progress) -> Result<UpdateStats, EditError>;
}

/// Changing the topology: cuts, splits, fracture, rigid moves of pieces, recombination.
pub(crate) trait Cut {
    /// Removes what lies on the cutter's positive side and re-solves.
    ///
    /// # Errors
    /// An invalid cutter, a cut that leaves nothing, a failed solve; the state is then unchanged.
    fn cut(&mut self, cutter: &Cutter, progress: Progress) -> Result<UpdateStats, EditError>;
    /// Splits every piece by the cutter into the parts on its two sides.
    ///
    /// # Errors
    /// As [`Cut::cut`].
    fn split(&mut self, cutter: &Cutter, progress: Progress) -> Result<UpdateStats, EditError>;
    /// Separates every piece into its connected parts.
    ///
    /// # Errors
    /// A failed solve; the state is then unchanged.
    fn fracture(&mut self, progress: Progress) -> Result<UpdateStats, EditError>;
    /// Places piece `piece` by the rigid `transform` (rest → world) and re-solves it.
    ///
    /// # Errors
    /// A piece that does not exist, a transform that is not rigid, a failed solve; the state is
    /// then unchanged.
    fn set_piece_transform(&mut self, piece: usize, transform: DMat4, progress: Progress) -> Result<UpdateStats, EditError>;
    /// Welds pieces whose faces touch again.
    ///
    /// # Errors
    /// A failed weld or solve; the state is then unchanged.
    fn recombine(&mut self, progress: Progress) -> Result<UpdateStats, EditError>;
}

//! TransCut's capabilities (§5): its live state is the [`Editor`], which relights, edits and
//! paints the medium, and cuts, splits, fractures, moves and recombines pieces.

use glam::DMat4;

use crate::edit::{Cutter, EditError, Editor, MediumEdit, PaintStroke, RelightUndo, UpdateStats};
use crate::light::Light;
use crate::methods::capability::{Cut, EditMedium, Relight};
use crate::progress::Progress;

impl Relight for Editor {
    type Undo = RelightUndo;

    fn relight(&mut self, lights: &[Light], progress: Progress) -> Result<(UpdateStats, RelightUndo), EditError> {
        self.relight_with_undo(lights, progress)
    }

    fn undo_relight(&mut self, undo: RelightUndo) -> Result<(), EditError> {
        Editor::undo_relight(self, undo)
    }

    fn user_radiance(&self) -> Option<Vec<[f64; 3]>> {
        Editor::user_radiance(self)
    }
}

impl EditMedium for Editor {
    fn edit_medium(&mut self, edit: &MediumEdit, progress: Progress) -> Result<UpdateStats, EditError> {
        Editor::edit_medium_with_progress(self, edit, progress)
    }

    fn paint(&mut self, stroke: &PaintStroke, progress: Progress) -> Result<UpdateStats, EditError> {
        Editor::paint_with_progress(self, stroke, progress)
    }
}

impl Cut for Editor {
    fn cut(&mut self, cutter: &Cutter, progress: Progress) -> Result<UpdateStats, EditError> {
        Editor::cut_with_progress(self, cutter, progress)
    }

    fn split(&mut self, cutter: &Cutter, progress: Progress) -> Result<UpdateStats, EditError> {
        Editor::split_with_progress(self, cutter, progress)
    }

    fn fracture(&mut self, progress: Progress) -> Result<UpdateStats, EditError> {
        Editor::fracture_with_progress(self, progress)
    }

    fn set_piece_transform(&mut self, piece: usize, transform: DMat4, progress: Progress) -> Result<UpdateStats, EditError> {
        Editor::set_piece_transform_with_progress(self, piece, transform, progress)
    }

    fn recombine(&mut self, progress: Progress) -> Result<UpdateStats, EditError> {
        Editor::recombine_with_progress(self, progress)
    }
}

//! TransCut's capabilities (§5): its live state is the [`Editor`], which relights, edits and
//! paints the medium, and cuts, splits, fractures, moves and recombines pieces.

use glam::DMat4;

use crate::edit::{Cutter, EditError, Editor, MediumEdit, PaintStroke, RelightUndo, UpdateStats};
use crate::light::Light;
use crate::methods::capability::{Cut, EditMedium, Relight};

impl Relight for Editor {
    type Undo = RelightUndo;

    fn relight(&mut self, lights: &[Light]) -> Result<(UpdateStats, RelightUndo), EditError> {
        self.relight_with_undo(lights)
    }

    fn undo_relight(&mut self, undo: RelightUndo) -> Result<(), EditError> {
        Editor::undo_relight(self, undo)
    }

    fn user_radiance(&self) -> Option<Vec<[f64; 3]>> {
        Editor::user_radiance(self)
    }
}

impl EditMedium for Editor {
    fn edit_medium(&mut self, edit: &MediumEdit) -> Result<UpdateStats, EditError> {
        Editor::edit_medium(self, edit)
    }

    fn paint(&mut self, stroke: &PaintStroke) -> Result<UpdateStats, EditError> {
        Editor::paint(self, stroke)
    }
}

impl Cut for Editor {
    fn cut(&mut self, cutter: &Cutter) -> Result<UpdateStats, EditError> {
        Editor::cut(self, cutter)
    }

    fn split(&mut self, cutter: &Cutter) -> Result<UpdateStats, EditError> {
        Editor::split(self, cutter)
    }

    fn fracture(&mut self) -> Result<UpdateStats, EditError> {
        Editor::fracture(self)
    }

    fn set_piece_transform(&mut self, piece: usize, transform: DMat4) -> Result<UpdateStats, EditError> {
        Editor::set_piece_transform(self, piece, transform)
    }

    fn recombine(&mut self) -> Result<UpdateStats, EditError> {
        Editor::recombine(self)
    }
}

//! Interactive editing of a baked object (TransCut §5): relight, edit or paint the medium, cut,
//! split, fracture, move and recombine pieces; every update warm-starts from the last solution.

pub mod cut;
mod error;
pub mod paint;
pub mod pieces;
pub mod region;

pub use error::EditError;

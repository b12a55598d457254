//! placeholder
pub fn write_vtk() {}

//! placeholder
pub fn dihedral_angles() {} pub fn tet_volume() {} pub struct QualityReport;

//! Legacy VTK output of tetrahedral meshes (opens in ParaView and VisIt).

use std::io::{self, Write};

use super::TetMesh;

/// Writes `mesh` as a legacy-VTK unstructured grid (`BINARY`, big-endian as the format requires,
/// or `ASCII`), with per-tet cell data `material` (id) and `min_dihedral_deg`, and per-point data
/// `boundary` (1 on the boundary surface).
///
/// # Errors
/// Any I/O error of `out`.
pub fn write_vtk(mesh: &TetMesh, out: &mut impl Write, binary: bool) -> io::Result<()> {
    let n = mesh.vertex_count();
    let m = mesh.tet_count();
    writeln!(out, "# vtk DataFile Version 3.0")?;
    writeln!(out, "libtranscut tetrahedral mesh: {n} vertices, {m} tets")?;
    writeln!(out, "{}", if binary { "BINARY" } else { "ASCII" })?;
    writeln!(out, "DATASET UNSTRUCTURED_GRID")?;
    writeln!(out, "POINTS {n} double")?;
    let mut buf = Vec::with_capacity(if binary { 24 * n } else { 0 });
    for p in mesh.positions() {
        if binary {
            for c in p.to_array() {
                buf.extend_from_slice(&c.to_be_bytes());
            }
        } else {
            writeln!(out, "{} {} {}", p.x, p.y, p.z)?;
        }
    }
    flush_line(out, &mut buf, binary)?;
    writeln!(out, "CELLS {m} {}", 5 * m)?;
    for t in mesh.tets() {
        if binary {
            buf.extend_from_slice(&4i32.to_be_bytes());
            for &v in t {
                buf.extend_from_slice(&(v as i32).to_be_bytes());
            }
        } else {
            writeln!(out, "4 {} {} {} {}", t[0], t[1], t[2], t[3])?;
        }
    }
    flush_line(out, &mut buf, binary)?;
    writeln!(out, "CELL_TYPES {m}")?;
    write_ints(out, &mut buf, binary, (0..m).map(|_| 10))?;
    writeln!(out, "CELL_DATA {m}")?;
    writeln!(out, "SCALARS material int 1\nLOOKUP_TABLE default")?;
    write_ints(out, &mut buf, binary, mesh.materials().iter().map(|&x| x as i32))?;
    writeln!(out, "SCALARS min_dihedral_deg float 1\nLOOKUP_TABLE default")?;
    let angles = (0..m).map(|t| mesh.dihedral_angles(t).into_iter().fold(f64::INFINITY, f64::min).to_degrees() as f32);
    if binary {
        for a in angles {
            buf.extend_from_slice(&a.to_be_bytes());
        }
    } else {
        for a in angles {
            writeln!(out, "{a}")?;
        }
    }
    flush_line(out, &mut buf, binary)?;
    writeln!(out, "POINT_DATA {n}")?;
    writeln!(out, "SCALARS boundary int 1\nLOOKUP_TABLE default")?;
    write_ints(out, &mut buf, binary, mesh.boundary_flags().iter().map(|&b| i32::from(b)))?;
    Ok(())
}

fn write_ints(out: &mut impl Write, buf: &mut Vec<u8>, binary: bool, values: impl Iterator<Item = i32>) -> io::Result<()> {
    for v in values {
        if binary {
            buf.extend_from_slice(&v.to_be_bytes());
        } else {
            writeln!(out, "{v}")?;
        }
    }
    flush_line(out, buf, binary)
}

/// Writes a binary block followed by the newline that separates it from the next keyword.
fn flush_line(out: &mut impl Write, buf: &mut Vec<u8>, binary: bool) -> io::Result<()> {
    if binary {
        out.write_all(buf)?;
        buf.clear();
        writeln!(out)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    #[test]
    fn ascii_and_binary_have_the_declared_sizes() {
        let p = vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z];
        let mesh = TetMesh::new(p, vec![[0, 1, 2, 3]], vec![]).unwrap();
        let mut ascii = Vec::new();
        write_vtk(&mesh, &mut ascii, false).unwrap();
        let text = String::from_utf8(ascii).unwrap();
        assert!(text.contains("CELLS 1 5\n4 0 1 2 3\n"));
        assert!(text.contains("CELL_TYPES 1\n10\n"));
        let mut bin = Vec::new();
        write_vtk(&mesh, &mut bin, true).unwrap();
        // Points block: 4 × 3 doubles, big-endian; the first is 0.0, the 4th coordinate is 1.0.
        let start = bin.windows(20).position(|w| w == b"POINTS 4 double\n\0\0\0\0").unwrap() + 16;
        assert_eq!(&bin[start + 24..start + 32], &1.0f64.to_be_bytes());
    }
}

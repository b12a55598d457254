//! The mesher on every shared test mesh: orientation, dihedral bounds, closed manifold boundary,
//! size control, fidelity, the user-vertex map, invariance under similarity transforms, and bad
//! input.

use std::path::PathBuf;
use std::sync::OnceLock;

use glam::{DMat4, DQuat, DVec3};
use rand::{Rng, SeedableRng};
use transcut::mesh::{self, TriMesh};
use transcut::mesher::{tetrahedralize_with, Grading, MeshSize, MesherError, MesherOptions, Tetrahedralization};
use transcut::Progress;

const MESHES: [&str; 8] = ["cow", "suzanne", "stanford-bunny", "fandisk", "homer", "cheburashka", "spot", "rocker-arm"];

fn shared_mesh(name: &str) -> TriMesh {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../assets/meshes").join(format!("{name}.obj"));
    mesh::load(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Whether every edge of the input is shared by exactly two triangles.
fn is_closed(m: &TriMesh) -> bool {
    let mut edges: Vec<(u32, u32)> =
        m.triangles().iter().flat_map(|t| (0..3).map(move |k| (t[k].min(t[(k + 1) % 3]), t[k].max(t[(k + 1) % 3])))).collect();
    edges.sort_unstable();
    let mut i = 0;
    while i < edges.len() {
        let j = edges[i..].iter().take_while(|e| **e == edges[i]).count();
        if j != 2 {
            return false;
        }
        i += j;
    }
    true
}

fn mesh_to(m: &TriMesh, tets: usize) -> Tetrahedralization {
    tetrahedralize_with(m, &MesherOptions::with_tets(tets), Progress::none()).expect("meshing succeeds")
}

/// Each shared mesh meshed uniformly at 100k tets, once for the whole test binary (the checks
/// and the similarity test's reference).
fn at_100k(name: &str) -> &'static (TriMesh, Tetrahedralization) {
    static MESHED: [OnceLock<(TriMesh, Tetrahedralization)>; MESHES.len()] = [const { OnceLock::new() }; MESHES.len()];
    let i = MESHES.iter().position(|&n| n == name).expect("a shared mesh");
    MESHED[i].get_or_init(|| {
        let input = shared_mesh(name);
        let t = mesh_to(&input, 100_000);
        (input, t)
    })
}

fn mesh_graded(m: &TriMesh, tets: usize, layers: u32) -> Tetrahedralization {
    let options = MesherOptions { grading: Grading::Graded { layers }, ..MesherOptions::with_tets(tets) };
    tetrahedralize_with(m, &options, Progress::none()).expect("meshing succeeds")
}

/// Every property the issue asks of a mesh of about `target` tets.
fn check(name: &str, input: &TriMesh, t: &Tetrahedralization, target: usize) {
    let s = &t.stats;
    let m = &t.mesh;
    eprintln!(
        "{name} @ {target}: {} tets, {} verts, dihedral [{:.2}°, {:.2}°], hausdorff {:.3e} (h = {:.3e}), split {} filled {} removed {} projected {}, {:.0} ms",
        s.tets, s.vertices, s.quality.min_dihedral_deg, s.quality.max_dihedral_deg, s.hausdorff.max, s.spacing, s.split_vertices, s.filled_tets, s.removed_tets, s.projected_vertices, s.timings.total_ms
    );
    assert!((s.tets as f64 / target as f64 - 1.0).abs() <= 0.3, "{name}: {} tets for a target of {target}", s.tets);
    assert!(s.quality.min_dihedral_deg >= 10.0, "{name}: min dihedral {}", s.quality.min_dihedral_deg);
    assert!(s.quality.max_dihedral_deg <= 165.0, "{name}: max dihedral {}", s.quality.max_dihedral_deg);
    assert!((0..m.tet_count()).all(|i| m.tet_volume(i) > 0.0), "{name}: a tet is not positively oriented");
    let topo = m.boundary_topology();
    assert!(topo.is_closed_manifold(), "{name}: boundary {topo:?}");
    assert_eq!(m.surface_map().len(), input.user_vertex_count(), "{name}: every user vertex is mapped");
    assert!(m.surface_map().iter().all(|p| p.distance.is_finite() && (p.bary.iter().sum::<f64>() - 1.0).abs() < 1e-9));
    if is_closed(input) {
        assert!(
            s.hausdorff.boundary_to_input <= 0.01 * s.spacing,
            "{name}: boundary {:.3e} off the surface",
            s.hausdorff.boundary_to_input
        );
        assert_eq!(s.bisected_cuts, 0, "{name}: a closed input needs no bisected cut");
    }
}

#[test]
fn every_test_mesh_at_100k_tets() {
    for name in MESHES {
        let (input, t) = at_100k(name);
        check(name, input, t, 100_000);
    }
}

/// Graded meshes (one cube per size, the fastest grading) keep every property of the uniform
/// ones: the stuffing stencils only ever cut uniform BCC tets, and the transition tets' dihedral
/// angles lie in [45°, 120°]. They are graded: coarser cubes hold part of the interior.
#[test]
fn every_test_mesh_graded_at_100k_tets() {
    for name in MESHES {
        let input = shared_mesh(name);
        let t = mesh_graded(&input, 100_000, 1);
        check(name, &input, &t, 100_000);
        assert!(t.stats.cubes_per_level.len() >= 3 && t.stats.cubes_per_level[1] > 0, "{name}: {:?}", t.stats.cubes_per_level);
    }
}

/// The cheburashka at the default size: two non-manifold edges there are closed by the same
/// gap tet, which must be added once (twice, its faces were shared by three tets). Its repair
/// removes tets whose exposed vertices the quality bounds first keep off the surface; removing
/// the tets that block them puts every one on the surface in the first stuffing (it used to
/// take three stuffings at other lattice offsets, 2.5 times the median time per tet).
#[test]
fn cheburashka_at_the_default_size() {
    let input = shared_mesh("cheburashka");
    let target = MesherOptions::default();
    let MeshSize::Tets(tets) = target.size else { unreachable!("the default size is a tet count") };
    let t = mesh_to(&input, tets);
    check("cheburashka", &input, &t, tets);
    assert!(t.stats.removed_tets > 0 && t.stats.projected_vertices > 0, "{:?}", t.stats);
    assert_eq!((t.stats.passes, t.stats.off_surface_vertices), (1, 0), "one stuffing, every boundary vertex on the surface");
}

/// The open bunny graded at 700k tets: a coarse tet of the first octree straddles the surface
/// through a hole, so the octree is refined and built again (the winding numbers of the
/// vertices it keeps are reused, not evaluated again), and the mesh keeps every property.
#[test]
fn a_graded_octree_refined_through_a_hole_keeps_every_property() {
    let input = shared_mesh("stanford-bunny");
    let t = mesh_graded(&input, 700_000, 1);
    check("stanford-bunny graded", &input, &t, 700_000);
    assert!(t.stats.octree_rounds >= 2, "{} octree rounds", t.stats.octree_rounds);
    assert!(t.stats.bisected_cuts > 0, "the bunny is open");
}

/// The slow tier (`bash scripts/test.sh --slow`): every test mesh meshed at 500k and 1M tets.
#[test]
#[ignore = "slow tier: bash scripts/test.sh --slow"]
fn slow_every_test_mesh_at_500k_and_1m_tets() {
    for name in MESHES {
        let input = shared_mesh(name);
        for target in [500_000, 1_000_000] {
            check(name, &input, &mesh_to(&input, target), target);
        }
    }
}

/// Random rotations, translations and uniform scales (10⁻³ to 10³) change neither the tet count
/// (±2%) nor the quality bounds: the lattice spacing follows the enclosed volume, so only the
/// lattice's alignment with the surface changes.
#[test]
fn similarity_transforms_keep_counts_and_quality() {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    for name in MESHES {
        let (input, base) = at_100k(name);
        let base = &base.stats;
        for _ in 0..3 {
            let axis = DVec3::new(rng.random::<f64>() - 0.5, rng.random::<f64>() - 0.5, rng.random::<f64>() - 0.5).normalize();
            let scale = 10f64.powf(rng.random_range(-3.0..3.0));
            let shift = DVec3::new(rng.random(), rng.random(), rng.random()) * 100.0 - 50.0;
            let rotation = DQuat::from_axis_angle(axis, rng.random_range(0.0..std::f64::consts::TAU));
            let moved = input.transformed(&DMat4::from_scale_rotation_translation(DVec3::splat(scale), rotation, shift));
            let t = mesh_to(&moved, 100_000);
            let s = &t.stats;
            eprintln!("{name} scaled {scale:.3e}: {} tets vs {}", s.tets, base.tets);
            assert!(
                (s.tets as f64 / base.tets as f64 - 1.0).abs() <= 0.02,
                "{name}: {} tets after a similarity transform, {} before",
                s.tets,
                base.tets
            );
            assert!(s.quality.min_dihedral_deg >= 10.0 && s.quality.max_dihedral_deg <= 165.0, "{name}: {:?}", s.quality);
            assert!(t.mesh.boundary_topology().is_closed_manifold(), "{name}: {:?}", t.mesh.boundary_topology());
        }
    }
}

#[test]
fn a_single_open_sheet_has_no_interior() {
    let positions = vec![DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y];
    let sheet = TriMesh::from_polygons(positions, &[vec![0, 1, 2, 3]], &Default::default()).unwrap();
    let err = tetrahedralize_with(&sheet, &MesherOptions::with_tets(1000), Progress::none()).unwrap_err();
    assert!(matches!(err, MesherError::NoInterior { .. }), "{err}");
    assert!(err.to_string().contains("encloses no volume"));
}

#[test]
fn invalid_sizes_are_rejected_with_a_message() {
    let input = shared_mesh("spot");
    for size in [MeshSize::Tets(0), MeshSize::Spacing(0.0), MeshSize::Spacing(f64::NAN), MeshSize::Spacing(-1.0)] {
        let err = tetrahedralize_with(&input, &MesherOptions { size, ..Default::default() }, Progress::none()).unwrap_err();
        assert!(matches!(err, MesherError::InvalidOptions(_)), "{size:?}: {err}");
    }
    let err =
        tetrahedralize_with(&input, &MesherOptions { size: MeshSize::Spacing(1e-6), ..Default::default() }, Progress::none())
            .unwrap_err();
    assert!(matches!(err, MesherError::TooLarge { .. }), "{err}");
}

#[test]
fn cancelling_stops_meshing() {
    let input = shared_mesh("spot");
    let cancel = |_: &str, f: f64| f < 0.3;
    let err = tetrahedralize_with(&input, &MesherOptions::with_tets(50_000), Progress::new(&cancel)).unwrap_err();
    assert!(matches!(err, MesherError::Cancelled(_)));
}

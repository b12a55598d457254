//! A bake is a function of its input: the same scene gives the same radiance bit for bit on
//! every run and for every thread count. The octahedron at 2,000 tets is a sensitive case: its
//! faces pass through lattice points, so a last-bit change of the lattice spacing (as a float sum
//! grouped by rayon's work stealing gave) moves the mesh.

use transcut::gpu::Backend;
use transcut::light::{Environment, Light};
use transcut::mesh::TriMesh;
use transcut::optics::Medium;
use transcut::{bake, BakeOptions, Object, Scene, TransCutOptions};

#[test]
fn repeated_bakes_are_bit_identical_for_every_thread_count() {
    let positions: [[f32; 3]; 6] = [[5., 0., 0.], [-5., 0., 0.], [0., 5., 0.], [0., -5., 0.], [0., 0., 5.], [0., 0., -5.]];
    let indices: [u32; 24] = [0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5];
    let mesh = TriMesh::from_triangles(&positions, &indices).unwrap();
    let scene = Scene {
        objects: vec![Object::new("octahedron", mesh, Medium::preset("marble").unwrap(), 1.0)],
        lights: vec![Light::Environment(Environment::Constant([1.0; 3]))],
    };
    let mut options =
        BakeOptions::with_method(TransCutOptions { tets: 2000, backend: Some(Backend::Cpu), ..TransCutOptions::default() });
    let mut first: Option<(Vec<u64>, Vec<[f64; 3]>)> = None;
    for threads in [1, 2, 3] {
        options.threads = threads;
        for run in 0..12 {
            let baked = bake(&scene, &options).unwrap();
            let object = &baked.objects[0];
            let positions: Vec<u64> =
                object.transcut().unwrap().tet_mesh.positions().iter().flat_map(|p| p.to_array().map(f64::to_bits)).collect();
            match &first {
                None => first = Some((positions, object.radiance.clone())),
                Some((p, lo)) => {
                    assert!(*p == positions, "tet mesh moved on run {run} with {threads} threads");
                    assert_eq!(*lo, object.radiance, "radiance changed on run {run} with {threads} threads");
                }
            }
        }
    }
}

//! The PRT precompute saved and read back ([`transcut::prt::PrtCache`], `.tcprt` files): a bake
//! that reads it equals, bit for bit, the bake that wrote it; what the transfer depends on keys
//! the file; a damaged entry is replaced, a foreign file named.

use glam::{DMat4, DVec3};
use transcut::light::Light;
use transcut::mesh::icosphere;
use transcut::optics::Medium;
use transcut::prt::{io, PrecomputeFileError, PrtCache, PrtError, PrtOptions};
use transcut::{bake, BakeOptions, Object, Progress, Scene, SceneError, Session, TransCutOptions};

fn scene(medium: Medium, transform: DMat4) -> Scene {
    let mut object = Object::new("ball", icosphere(10.0, 3), medium, 1.0);
    object.transform = transform;
    Scene {
        objects: vec![object],
        lights: vec![Light::Directional {
            direction: DVec3::new(0.2, -0.3, -1.0),
            irradiance: [3.0; 3],
            angular_diameter_deg: 0.0,
        }],
    }
}

fn options(cache: Option<PrtCache>) -> BakeOptions {
    BakeOptions {
        method: PrtOptions { samples_log2: 11, terms_per_vertex: 600, cache, ..PrtOptions::default() }.into(),
        ..BakeOptions::default()
    }
}

fn temp_dir(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("transcut-prt-cache-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn files(dir: &std::path::Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().into_string().unwrap()).collect();
    names.sort();
    names
}

/// A folder cache: the first bake precomputes and writes `<key>.tcprt`, the second reads it and
/// gives the first bake's radiance bit for bit (and another medium's fresh bake, bit for bit);
/// a moved object is another surface in world space, another key, another file.
#[test]
fn a_folder_cache_is_read_back_exactly() {
    let dir = temp_dir("folder");
    let marble = Medium { eta: 1.3, ..Medium::preset("marble").unwrap() };
    let skin = Medium { eta: 1.3, ..Medium::preset("skin1").unwrap() };
    let cached = options(Some(PrtCache::Folder(dir.clone())));
    let uncached = bake(&scene(marble, DMat4::IDENTITY), &options(None)).unwrap().objects.remove(0);
    assert!(!uncached.stats.precompute_loaded);

    let first = bake(&scene(marble, DMat4::IDENTITY), &cached).unwrap().objects.remove(0);
    assert!(!first.stats.precompute_loaded);
    let key = first.prt().unwrap().key;
    assert_eq!(files(&dir), vec![format!("{key}.tcprt")], "one file, named by its key, no partial file left");
    assert_eq!(first.radiance, uncached.radiance, "writing the cache changes nothing");

    let second = bake(&scene(marble, DMat4::IDENTITY), &cached).unwrap().objects.remove(0);
    assert!(second.stats.precompute_loaded);
    assert_eq!(second.radiance, first.radiance);
    let fresh_skin = bake(&scene(skin, DMat4::IDENTITY), &options(None)).unwrap().objects.remove(0).radiance;
    let cached_skin = bake(&scene(skin, DMat4::IDENTITY), &cached).unwrap().objects.remove(0);
    assert!(cached_skin.stats.precompute_loaded, "the transfer does not depend on the medium");
    assert_eq!(cached_skin.radiance, fresh_skin);

    let moved = bake(&scene(marble, DMat4::from_translation(DVec3::new(5.0, 0.0, 0.0))), &cached).unwrap().objects.remove(0);
    assert!(!moved.stats.precompute_loaded);
    assert_ne!(moved.prt().unwrap().key, key);
    assert_eq!(files(&dir).len(), 2);
    std::fs::remove_dir_all(dir).unwrap();
}

/// A damaged entry of a folder cache is precomputed again and replaced; a damaged or foreign
/// file named as the cache is an error that names it, before any precompute is written over it.
#[test]
fn damaged_and_foreign_files() {
    let dir = temp_dir("damaged");
    let marble = Medium::preset("marble").unwrap();
    let cached = options(Some(PrtCache::Folder(dir.clone())));
    let first = bake(&scene(marble, DMat4::IDENTITY), &cached).unwrap().objects.remove(0);
    let path = dir.join(format!("{}.tcprt", first.prt().unwrap().key));
    let good = std::fs::read(&path).unwrap();
    let mut damaged = good.clone();
    let middle = damaged.len() / 2;
    damaged[middle] ^= 1;
    std::fs::write(&path, &damaged).unwrap();
    let again = bake(&scene(marble, DMat4::IDENTITY), &cached).unwrap().objects.remove(0);
    assert!(!again.stats.precompute_loaded, "a damaged entry is not used");
    assert_eq!(again.radiance, first.radiance);
    assert_eq!(std::fs::read(&path).unwrap(), good, "and is replaced by the precompute");

    // One file given by name: the file of another surface is refused by key, a damaged one by
    // its checksum; neither is overwritten.
    let other = dir.join("other.tcprt");
    let moved = scene(marble, DMat4::from_translation(DVec3::X));
    bake(&moved, &options(Some(PrtCache::File(other.clone())))).unwrap();
    let foreign = std::fs::read(&other).unwrap();
    let err = bake(&scene(marble, DMat4::IDENTITY), &options(Some(PrtCache::File(other.clone())))).unwrap_err();
    assert!(matches!(&err, SceneError::InvalidObject { message, .. } if message.contains("another surface")), "{err}");
    assert_eq!(std::fs::read(&other).unwrap(), foreign);
    std::fs::write(&other, &damaged).unwrap();
    let err = bake(&scene(marble, DMat4::IDENTITY), &options(Some(PrtCache::File(other.clone())))).unwrap_err();
    assert!(err.to_string().contains("checksum"), "{err}");
    std::fs::remove_dir_all(dir).unwrap();
}

/// `Session::save_prt` writes what the cache would, readable by key; a session of another
/// method has nothing to save.
#[test]
fn a_session_saves_its_precompute() {
    let dir = temp_dir("session");
    std::fs::create_dir_all(&dir).unwrap();
    let marble = Medium::preset("marble").unwrap();
    let session = Session::bake(&scene(marble, DMat4::IDENTITY), &options(None), Progress::none()).unwrap();
    let saved = dir.join("ball.tcprt");
    session.save_prt(0, &saved).unwrap();
    let state = session.prt_state(0).unwrap().unwrap();
    let header = io::read_header(&saved).unwrap();
    assert_eq!((header.key, header.vertices, header.samples), (state.key, state.transfer.vertices(), 1 << 11));
    assert_eq!(
        header.options,
        PrtOptions { cache: None, ..PrtOptions { samples_log2: 11, terms_per_vertex: 600, ..PrtOptions::default() } }
    );
    let read = io::read(&saved, state.key).unwrap();
    assert_eq!(read.stats(), state.transfer.stats());
    let wrong = transcut::prt::PrecomputeKey([1, 2]);
    assert!(matches!(io::read(&saved, wrong), Err(PrecomputeFileError::KeyMismatch { .. })));
    // Unwritable: the file's error, nothing left behind.
    let err = session.save_prt(0, &dir.join("missing").join("x.tcprt")).unwrap_err();
    assert!(err.to_string().contains("missing"), "{err}");
    assert!(matches!(PrtError::from(io::read(&dir.join("none"), state.key).unwrap_err()), PrtError::File(_)));

    let coarse =
        BakeOptions { method: TransCutOptions { tets: 5_000, ..TransCutOptions::default() }.into(), ..BakeOptions::default() };
    let transcut = Session::bake(&scene(marble, DMat4::IDENTITY), &coarse, Progress::none()).unwrap();
    assert!(transcut.prt_state(0).unwrap().is_none());
    assert!(transcut.save_prt(0, &saved).unwrap_err().to_string().contains("transcut"));
    std::fs::remove_dir_all(dir).unwrap();
}

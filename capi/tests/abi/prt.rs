//! The PRT method's own calls: medium, artist medium and scale edits without a new bake (each
//! against a fresh bake or the scale identity), the statistics, the saved precompute and the
//! cache folder, and every misuse named with nothing changed.

use std::ffi::CString;
use std::ptr;

use super::abi::*;
use super::common::*;

fn marble() -> TcMedium {
    let mut m = TcMedium { sigma_a: [0.0; 3], sigma_s_prime: [0.0; 3], eta: 0.0, g: 0.0 };
    // SAFETY: valid pointers.
    ok(unsafe { tc_medium_preset(cstr(c"marble"), &mut m) }, "preset");
    m
}

fn prt_options(cache: Option<&CString>) -> TcPrtOptions {
    // SAFETY: an all-zero struct is a valid value to overwrite.
    let mut p: TcPrtOptions = unsafe { std::mem::zeroed() };
    // SAFETY: a valid pointer and its size.
    ok(unsafe { tc_prt_options_init(&mut p, size_of::<TcPrtOptions>()) }, "prt options");
    p.samples_log2 = 12;
    p.terms_per_vertex = 400;
    p.cache_dir = cache.map_or(ptr::null(), |c| c.as_ptr());
    p
}

/// A 10 mm marble ball (`medium`, `mm_per_unit`) under a sun, baked by PRT with `prt`.
fn baked_ball(medium: &TcMedium, mm_per_unit: f64, prt: &TcPrtOptions) -> (*mut TcScene, u32) {
    let s = scene();
    let ball = add(s, &Mesh::uv_sphere(10.0, 24, 12));
    let mut o = options(0);
    o.method = TC_METHOD_PRT;
    o.method_options = (prt as *const TcPrtOptions).cast();
    // SAFETY: valid pointers.
    unsafe {
        ok(tc_object_set_scale(s, ball, mm_per_unit), "scale");
        ok(tc_object_set_medium(s, ball, medium), "medium");
        ok(tc_scene_add_sun(s, [0.2, -0.3, -1.0].as_ptr(), [3.0; 3].as_ptr(), 0.0), "sun");
        ok(tc_scene_bake(s, &o, None, ptr::null_mut()), "bake");
    }
    (s, ball)
}

fn stats(s: *mut TcScene, object: u32) -> TcPrtStats {
    // SAFETY: an all-zero struct is a valid value to overwrite.
    let mut st: TcPrtStats = unsafe { std::mem::zeroed() };
    st.size = size_of::<TcPrtStats>() as u32;
    // SAFETY: valid pointers.
    ok(unsafe { tc_object_prt_stats(s, object, &mut st) }, "tc_object_prt_stats");
    st
}

fn temp_dir(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("transcut-abi-prt-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

#[test]
fn edits_equal_fresh_bakes_and_the_cache_skips_the_precompute() {
    let dir = temp_dir("edits");
    let cache = CString::new(dir.to_str().unwrap()).unwrap();
    let prt = prt_options(Some(&cache));
    let (s, ball) = baked_ball(&marble(), 1.0, &prt);
    let first = stats(s, ball);
    assert_eq!((first.basis_terms, first.samples_log2, first.precompute_loaded), (16, 12, 0));
    assert_eq!(first.vertices, 24 * 11 + 2);
    assert_eq!(first.terms, 400 * first.vertices);
    assert!(first.bytes >= 3 * first.terms && first.dropped_mean > 0.0 && first.dropped_max >= first.dropped_mean);
    assert!(first.residual.iter().all(|r| *r > 0.0 && *r < 0.05), "{:?}", first.residual);
    let key = format!("{:016x}{:016x}", first.key[0], first.key[1]);
    assert!(dir.join(format!("{key}.tcprt")).is_file(), "the bake wrote its precompute into the cache folder");

    // A new medium (same η and g) without a new bake equals a fresh bake of that medium, which
    // reads the cached precompute.
    let mut denser = marble();
    denser.sigma_a = denser.sigma_a.map(|x| 2.0 * x);
    denser.sigma_s_prime = denser.sigma_s_prime.map(|x| 1.2 * x);
    // SAFETY: valid pointers.
    ok(unsafe { tc_object_prt_set_medium(s, ball, &denser) }, "set medium");
    let edited = radiance(s, ball);
    let (fresh, fresh_ball) = baked_ball(&denser, 1.0, &prt);
    let again = stats(fresh, fresh_ball);
    assert_eq!(again.precompute_loaded, 1, "the second bake read the cache");
    assert_eq!(again.key, first.key);
    assert_eq!(radiance(fresh, fresh_ball), edited, "an edit equals a fresh bake bit for bit");
    destroy(fresh);
    assert_eq!(stats(s, ball).medium.sigma_a, denser.sigma_a);

    // A scale change is the medium with every σ times the ratio, on the same transfer.
    // SAFETY: valid pointers.
    ok(unsafe { tc_object_prt_set_scale(s, ball, 1.25) }, "scale");
    let scaled = radiance(s, ball);
    let st = stats(s, ball);
    assert_eq!((st.mm_per_unit, st.transfer_mm_per_unit), (1.25, 1.0));
    let mut times = denser;
    times.sigma_a = times.sigma_a.map(|x| x * 1.25);
    times.sigma_s_prime = times.sigma_s_prime.map(|x| x * 1.25);
    // SAFETY: valid pointers.
    unsafe {
        ok(tc_object_prt_set_scale(s, ball, 1.0), "scale back");
        ok(tc_object_prt_set_medium(s, ball, &times), "σ × 1.25");
    }
    assert_eq!(radiance(s, ball), scaled, "Rd(s r; σ) s² = Rd(r; s σ)");
    assert_ne!(scaled, edited);

    // Artist parameters are the medium tc_medium_from_artist gives at the object's scale.
    let artist = TcArtistMedium {
        albedo: [0.8, 0.7, 0.6],
        radius: [1.0, 0.6, 0.4],
        scale: 1.0,
        ior: marble().eta,
        anisotropy: 0.0,
        // The object's η stays: the dipole mapping keeps the IOR (a random walk's is 1).
        mapping: TC_ARTIST_DIPOLE,
    };
    let mut converted = marble();
    // SAFETY: valid pointers.
    unsafe {
        ok(tc_object_prt_set_medium_artist(s, ball, &artist), "artist");
        let by_artist = radiance(s, ball);
        ok(tc_medium_from_artist(&artist, 1.0, &mut converted), "convert");
        ok(tc_object_prt_set_medium(s, ball, &converted), "converted");
        assert_eq!(radiance(s, ball), by_artist);
    }

    // tc_object_prt_save writes the same file the cache holds.
    let saved = dir.join("saved.tcprt");
    let path = CString::new(saved.to_str().unwrap()).unwrap();
    // SAFETY: valid pointers.
    ok(unsafe { tc_object_prt_save(s, ball, path.as_ptr()) }, "save");
    assert_eq!(std::fs::read(&saved).unwrap(), std::fs::read(dir.join(format!("{key}.tcprt"))).unwrap());
    destroy(s);
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn misuse_is_named_and_changes_nothing() {
    let prt = prt_options(None);
    let (s, ball) = baked_ball(&marble(), 1.0, &prt);
    let before = radiance(s, ball);
    let mut other_eta = marble();
    other_eta.eta = 1.3;
    let mut dense = marble();
    dense.sigma_s_prime = [400.0; 3];
    let bad_artist = TcArtistMedium {
        albedo: [1.5, 0.5, 0.5],
        radius: [1.0; 3],
        scale: 1.0,
        ior: marble().eta,
        anisotropy: 0.0,
        mapping: TC_ARTIST_RANDOM_WALK,
    };
    // SAFETY: valid or deliberately NULL pointers.
    unsafe {
        fails(tc_object_prt_set_medium(s, ball, &other_eta), TC_INVALID_ARGUMENT, &["eta = 1.3"]);
        fails(tc_object_prt_set_medium(s, ball, &dense), TC_INVALID_ARGUMENT, &["too dense", "samples"]);
        fails(tc_object_prt_set_medium(s, ball, ptr::null()), TC_NULL_POINTER, &["medium"]);
        fails(tc_object_prt_set_medium(s, 7, &marble()), TC_INVALID_HANDLE, &["object 7"]);
        fails(tc_object_prt_set_medium_artist(s, ball, &bad_artist), TC_INVALID_ARGUMENT, &["albedo"]);
        fails(tc_object_prt_set_scale(s, ball, -1.0), TC_INVALID_ARGUMENT, &["mm_per_unit"]);
        fails(tc_object_prt_set_scale(s, ball, 1e3), TC_INVALID_ARGUMENT, &["too dense"]);
        fails(tc_object_prt_save(s, ball, ptr::null()), TC_NULL_POINTER, &["path"]);
        fails(tc_object_prt_save(s, ball, cstr(c"/nonexistent-dir/x.tcprt")), TC_IO_ERROR, &["nonexistent-dir"]);
        let mut st: TcPrtStats = std::mem::zeroed();
        st.size = 8;
        fails(tc_object_prt_stats(s, ball, &mut st), TC_INVALID_ARGUMENT, &["sizeof(TcPrtStats)"]);
    }
    assert_eq!(radiance(s, ball), before, "failed calls change nothing");
    assert_eq!(stats(s, ball).mm_per_unit, 1.0);
    destroy(s);

    // An empty cache folder name is refused before any work.
    let empty = CString::new("").unwrap();
    let mut o = options(0);
    o.method = TC_METHOD_PRT;
    let with_empty = prt_options(Some(&empty));
    o.method_options = (&raw const with_empty).cast();
    let s = scene();
    add(s, &Mesh::uv_sphere(10.0, 12, 6));
    // SAFETY: valid pointers.
    fails(unsafe { tc_scene_bake(s, &o, None, ptr::null_mut()) }, TC_INVALID_ARGUMENT, &["cache_dir"]);
    // Before a bake, and for an object another method baked.
    // SAFETY: valid pointers.
    unsafe {
        fails(tc_object_prt_set_scale(s, 0, 2.0), TC_NOT_BAKED, &["bake"]);
        let mut transcut = options(3_000);
        transcut.backend = TC_BACKEND_CPU;
        ok(tc_scene_bake(s, &transcut, None, ptr::null_mut()), "transcut bake");
        fails(tc_object_prt_set_medium(s, 0, &marble()), TC_UNSUPPORTED, &["transcut"]);
        let mut st: TcPrtStats = std::mem::zeroed();
        st.size = size_of::<TcPrtStats>() as u32;
        fails(tc_object_prt_stats(s, 0, &mut st), TC_UNSUPPORTED, &["transcut"]);
    }
    destroy(s);
}

//! `include/transcut.h` is generated from the ABI sources by cbindgen and committed; this test
//! generates it afresh and fails when the committed file differs. Run with `TRANSCUT_BLESS=1` to
//! rewrite the committed header instead.
//!
//! On top of `capi/cbindgen.toml` the generator adds what only the build knows: the version
//! macros (from Cargo.toml) and, at the end, compile-time checks that the C compiler lays out
//! every struct exactly as Rust does (`sizeof` and `offsetof` of every field, the values taken
//! from this build), so a header/library mismatch fails to compile instead of corrupting memory.

use std::fmt::Write as _;
use std::mem::{offset_of, size_of};
use std::path::{Path, PathBuf};

use crate::abi::{
    TcAcquireOptions, TcAcquireStats, TcArtistMedium, TcBakeOptions, TcBakeStats, TcDipoleOptions, TcDipoleStats, TcEditStats,
    TcMedium, TcMediumEdit, TcPolygridOptions, TcPolygridStats, TcPrtOptions, TcPrtStats, TcRadiosityOptions, TcRadiosityStats,
    TcTransCutOptions,
};

fn crate_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn header_path() -> PathBuf {
    crate_dir().join("../include/transcut.h")
}

/// Version macros and portable helpers, placed right after the includes.
fn prelude() -> String {
    let (major, minor, patch) =
        (env!("CARGO_PKG_VERSION_MAJOR"), env!("CARGO_PKG_VERSION_MINOR"), env!("CARGO_PKG_VERSION_PATCH"));
    format!(
        "\n/** The version of the library this header was generated for (compare with tc_version()). */\n\
         #define TRANSCUT_VERSION_MAJOR {major}\n\
         #define TRANSCUT_VERSION_MINOR {minor}\n\
         #define TRANSCUT_VERSION_PATCH {patch}\n\
         #define TRANSCUT_VERSION ((TRANSCUT_VERSION_MAJOR << 16) | (TRANSCUT_VERSION_MINOR << 8) | TRANSCUT_VERSION_PATCH)\n\
         #define TRANSCUT_VERSION_STRING \"{major}.{minor}.{patch}\"\n"
    )
}

/// A struct's name, size and `(field, offset)` list.
type Layout = (&'static str, usize, Vec<(&'static str, usize)>);

/// The layout of every struct of the ABI.
fn layouts() -> Vec<Layout> {
    macro_rules! layout {
        ($t:ident { $($f:ident),+ $(,)? }) => {
            (stringify!($t), size_of::<$t>(), vec![$((stringify!($f), offset_of!($t, $f))),+])
        };
    }
    vec![
        layout!(TcMedium { sigma_a, sigma_s_prime, eta, g }),
        layout!(TcArtistMedium { albedo, radius, scale, ior, anisotropy, mapping }),
        layout!(TcBakeOptions {
            size,
            method,
            tets,
            tolerance,
            max_iterations,
            threads,
            shadows,
            area_samples,
            environment_samples,
            backend,
            method_options
        }),
        layout!(TcTransCutOptions { size, solver, edit_solver, grading, discretization }),
        layout!(TcDipoleOptions { size, oracle, theta, eps1, eps2, rule, receivers, mode, geometry, budget, radiance }),
        layout!(TcPrtOptions { size, samples_log2, basis_terms, terms_per_vertex, near_field, near_radius, seed, cache_dir }),
        layout!(TcPrtStats {
            size,
            basis_terms,
            samples_log2,
            precompute_loaded,
            vertices,
            terms,
            bytes,
            dropped_mean,
            dropped_max,
            residual,
            transfer_mm_per_unit,
            mm_per_unit,
            medium,
            key
        }),
        layout!(TcPolygridOptions { size, resolution, nodes, cube_mm, stencil, solver, edit_solver }),
        layout!(TcPolygridStats { size, resolution, cubes, cube_mm, nodes, cells, min_scaled_jacobian, mean_scaled_jacobian }),
        layout!(TcRadiosityOptions {
            size,
            iteration,
            patch_size_mm,
            rays_per_patch,
            max_iterations,
            seed,
            tolerance,
            covered_fraction,
            bounces,
            solver,
            grading,
            discretization
        }),
        layout!(TcRadiosityStats {
            size,
            patches,
            translucent_patches,
            covered_patches,
            nonzeros,
            form_factor_bytes,
            patch_size_mm,
            prepare_ms,
            patches_ms,
            form_factor_ms,
            direct_ms,
            solve_ms,
            iterations,
            scatterings,
            estimated_error,
            energy_defect
        }),
        layout!(TcDipoleStats {
            size,
            triangles,
            receivers,
            nodes,
            links,
            near_links,
            form_factors,
            stale_tasks,
            refit_ms,
            link_ms,
            gather_ms,
            push_ms
        }),
        layout!(TcBakeStats {
            size,
            tets,
            vertices,
            iterations,
            meshing_ms,
            assembly_ms,
            source_ms,
            solve_ms,
            total_ms,
            clamped_vertices,
            backend_used,
            flipped_faces,
            resolution,
            mesh_reused
        }),
        layout!(TcMediumEdit { size, region, center, radius, min_mm, max_mm, mask, mask_len, op, sigma_a, sigma_s_prime }),
        layout!(TcEditStats {
            size,
            pieces_solved,
            iterations,
            cut,
            rows_rebuilt,
            tets_changed,
            source_ms,
            assembly_ms,
            hierarchy_ms,
            solve_ms,
            total_ms,
            cut_removed_tets,
            cut_removed_vertices,
            cut_moved_vertices,
            cut_surface_vertices,
            cut_max_distance,
            cut_min_dihedral_degrees,
            cut_bound_degrees
        }),
        layout!(TcAcquireOptions {
            size,
            observe,
            nodes,
            method,
            spacing_mm,
            eta,
            margin_mm,
            pattern_grid,
            max_iterations,
            homogeneous_iterations,
            lambda,
            target_misfit_rms,
            solve_tolerance,
            initial_sigma_a,
            initial_sigma_s_prime,
            origin,
            units_per_mm,
            channels,
            coarse_levels,
            absorption_coarsening
        }),
        layout!(TcAcquireStats {
            size,
            iterations,
            dims,
            forward_solves,
            adjoint_solves,
            misfit_rms,
            homogeneous_sigma_a,
            homogeneous_sigma_s_prime,
            voxel_size
        }),
    ]
}

/// Compile-time layout checks (C99 has no `_Static_assert`: a negative array size fails).
fn trailer() -> String {
    let mut s = String::from(
        "\n/* Layout checks: sizes and field offsets of the library's build (64-bit targets). */\n\
         #ifdef __cplusplus\n\
         #define TC_LAYOUT_CHECK(name, cond) static_assert(cond, #name)\n\
         #else\n\
         #define TC_LAYOUT_CHECK(name, cond) typedef char tc_layout_check_##name[(cond) ? 1 : -1]\n\
         #endif\n",
    );
    for (name, size, fields) in layouts() {
        writeln!(s, "TC_LAYOUT_CHECK({name}__sizeof, sizeof({name}) == {size});").unwrap();
        for (field, offset) in fields {
            writeln!(s, "TC_LAYOUT_CHECK({name}_{field}, offsetof({name}, {field}) == {offset});").unwrap();
        }
    }
    s.push_str("#undef TC_LAYOUT_CHECK\n");
    s
}

fn generate() -> String {
    let config = cbindgen::Config::from_file(crate_dir().join("cbindgen.toml")).expect("capi/cbindgen.toml");
    let bindings = cbindgen::Builder::new()
        .with_config(config)
        .with_src(crate_dir().join("src/lib.rs"))
        .with_after_include(prelude())
        .with_trailer(trailer())
        .generate()
        .expect("cbindgen generates the header");
    let mut out = Vec::new();
    bindings.write(&mut out);
    String::from_utf8(out).expect("UTF-8 header")
}

#[test]
fn committed_header_is_current() {
    let fresh = generate();
    let path = header_path();
    if std::env::var_os("TRANSCUT_BLESS").is_some() {
        std::fs::write(&path, &fresh).expect("write include/transcut.h");
        return;
    }
    let committed = std::fs::read_to_string(&path).unwrap_or_default();
    if committed != fresh {
        let line = committed
            .lines()
            .zip(fresh.lines())
            .position(|(a, b)| a != b)
            .map_or(format!("(lengths {} and {} lines)", committed.lines().count(), fresh.lines().count()), |i| {
                format!("first difference at line {}", i + 1)
            });
        panic!(
            "{} is stale {line}; regenerate it with: TRANSCUT_BLESS=1 cargo test -p transcut-capi --test abi header::",
            display(&path)
        );
    }
}

/// Every exported function (except the test hook) is declared, and the header says what it is.
#[test]
fn header_declares_the_whole_api() {
    let header = generate();
    assert!(header.contains("DO NOT EDIT"));
    assert!(header.contains("#define TRANSCUT_VERSION_MAJOR"));
    assert!(!header.contains("tc_debug_panic"), "the test hook stays out of the header");
    let sources: String = std::fs::read_dir(crate_dir().join("src"))
        .unwrap()
        .map(|e| std::fs::read_to_string(e.unwrap().path()).unwrap())
        .collect();
    let mut count = 0;
    for line in sources.lines() {
        let Some(rest) = line.split("extern \"C\" fn ").nth(1) else {
            continue;
        };
        let name = rest.split('(').next().unwrap();
        if name == "tc_debug_panic" {
            continue;
        }
        count += 1;
        let declared = header.contains(&format!(" {name}(")) || header.contains(&format!("*{name}("));
        assert!(declared, "{name} is not declared in the header");
    }
    assert!(count >= 30, "found only {count} exported functions");
}

fn display(p: &Path) -> String {
    p.canonicalize().unwrap_or_else(|_| p.to_owned()).display().to_string()
}

//! The module layering of every crate of the workspace: each module may use only the modules
//! its row of the table allows, and the tables have no circle, so data flows one way
//! (docs/ARCHITECTURE.md, "Layers"). A `use crate::…` (or `super::…` between sibling files)
//! that the table does not list fails here, so a change cannot quietly add an arrow back up; a
//! new module fails until it has a row.
//!
//! Only code counts: comments (doc comments too) are stripped before the paths are read.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// One crate's table: module → the modules it may use.
type Table = &'static [(&'static str, &'static [&'static str])];

/// The core, bottom to top. A module's row names every module below it that it uses.
const CORE: Table = &[
    ("workers", &[]),
    ("progress", &[]),
    ("input", &[]),
    ("output", &[]),
    ("mesh", &["input"]),
    ("optics", &["input"]),
    ("mesher", &["mesh", "progress"]),
    ("volume", &["input", "mesh", "optics", "output"]),
    ("light", &["input", "mesh", "optics", "progress"]),
    ("hierarchy", &["mesh", "optics", "progress"]),
    ("prt", &["light", "mesh", "optics", "progress"]),
    ("sparse", &["input", "progress"]),
    ("radiosity", &["light", "mesh", "optics", "progress", "sparse"]),
    ("diffusion", &["input", "mesh", "optics", "sparse", "volume"]),
    ("polygrid", &["diffusion", "mesh", "mesher", "optics", "progress", "sparse", "volume"]),
    ("inverse", &["input", "optics", "output", "polygrid", "progress", "sparse", "volume"]),
    ("gpu", &["diffusion", "hierarchy", "optics", "progress", "prt", "radiosity", "sparse"]),
    ("render", &["input", "light", "mesh", "optics", "output"]),
    ("texture", &["render"]),
    (
        "scene",
        &[
            "diffusion",
            "gpu",
            "hierarchy",
            "light",
            "mesh",
            "mesher",
            "optics",
            "polygrid",
            "progress",
            "prt",
            "radiosity",
            "volume",
            "workers",
        ],
    ),
    (
        "edit",
        &["diffusion", "gpu", "hierarchy", "light", "mesh", "mesher", "optics", "progress", "prt", "scene", "sparse", "volume"],
    ),
    (
        "methods",
        &[
            "diffusion",
            "edit",
            "gpu",
            "hierarchy",
            "light",
            "mesh",
            "mesher",
            "optics",
            "polygrid",
            "progress",
            "prt",
            "radiosity",
            "scene",
            "sparse",
            "volume",
        ],
    ),
    ("bake", &["mesh", "methods", "progress", "scene", "workers"]),
    ("lit_face", &["bake", "gpu", "inverse", "light", "mesh", "scene", "volume"]),
    ("session", &["bake", "edit", "light", "mesh", "methods", "progress", "render", "scene", "texture"]),
];

/// The C ABI: the boundary, the leaves, the scene handle, then the entry points, which use
/// only the layers below them and never each other.
const CAPI: Table = &[
    ("status", &[]),
    ("ptr", &["status"]),
    ("convert", &["status"]),
    ("options", &["ptr", "status"]),
    ("progress", &[]),
    ("handle", &["convert", "progress", "status"]),
    ("acquire", &["options", "progress", "ptr", "status"]),
    ("bake", &["convert", "handle", "options", "progress", "ptr", "status"]),
    ("cut", &["convert", "handle", "ptr", "status"]),
    ("deform", &["handle", "ptr", "status"]),
    ("edit_stats", &["convert", "handle", "ptr", "status"]),
    ("light", &["handle", "ptr", "status"]),
    ("material", &["convert", "handle", "progress", "ptr", "status"]),
    ("medium", &["convert", "handle", "ptr", "status"]),
    ("method", &["ptr", "status"]),
    ("pieces", &["handle", "ptr", "status"]),
    ("prt", &["convert", "handle", "progress", "ptr", "status"]),
    ("relight", &["convert", "handle", "progress", "status"]),
    ("scene", &["convert", "handle", "ptr", "status"]),
    ("test_hooks", &["status"]),
    ("texture", &["handle", "ptr", "status"]),
    ("version", &["status"]),
    ("volume", &["convert", "handle", "ptr", "status"]),
];

/// The CLI: shared pieces, the scene file, the benchmarks, the commands, `main`.
const CLI: Table = &[
    ("progress", &[]),
    ("spec", &[]),
    ("method_args", &[]),
    ("object_args", &["method_args", "spec"]),
    ("scene_file/schema", &["method_args"]),
    ("scene_file/media", &["scene_file/schema"]),
    ("scene_file/edits", &["scene_file/media", "scene_file/schema"]),
    ("scene_file/apply", &["scene_file/edits"]),
    ("scene_file", &["scene_file/apply", "scene_file/edits", "scene_file/media", "scene_file/schema"]),
    ("bench/args", &["method_args"]),
    ("bench/stats", &[]),
    ("bench/fig7", &["bench/stats"]),
    ("bench/mesh", &["bench/args", "bench/stats"]),
    ("bench/bake", &["bench/args", "bench/stats"]),
    ("bench/solve", &["bench/args", "bench/stats"]),
    ("bench/multires", &["bench/args", "bench/fig7"]),
    ("bench/edit", &["bench/args", "bench/fig7", "bench/stats"]),
    ("bench/dipole", &["bench/args", "bench/stats"]),
    ("bench/polygrid", &["bench/args", "bench/stats"]),
    ("bench/prt", &["bench/args", "bench/stats"]),
    ("bench/sphere", &["bench/args", "bench/stats"]),
    ("bench/inverse_quality", &[]),
    ("bench/inverse", &["bench/args", "bench/inverse_quality"]),
    ("bench/radiosity_coupled", &["bench/stats", "method_args", "scene_file"]),
    ("bench/radiosity", &["bench/args", "bench/radiosity_coupled", "bench/stats"]),
    (
        "bench",
        &[
            "bench/args",
            "bench/bake",
            "bench/dipole",
            "bench/edit",
            "bench/inverse",
            "bench/mesh",
            "bench/multires",
            "bench/polygrid",
            "bench/prt",
            "bench/radiosity",
            "bench/solve",
            "bench/sphere",
        ],
    ),
    ("output", &[]),
    ("mesh_cmd", &["output", "progress"]),
    ("bake_cmd", &["method_args", "object_args", "output", "progress"]),
    ("animate_cmd", &["method_args", "object_args", "output", "progress"]),
    ("render_cmd", &["method_args", "output", "progress", "scene_file", "scene_file/apply", "scene_file/schema"]),
    ("prt_cmd", &["method_args", "object_args", "output", "progress"]),
    ("acquire_cmd", &["progress"]),
    ("main", &["acquire_cmd", "animate_cmd", "bake_cmd", "bench", "mesh_cmd", "prt_cmd", "render_cmd"]),
];

/// The source text without comments (`//` to the end of the line; the sources use no block
/// comments).
fn code(text: &str) -> String {
    text.lines().map(|l| l.find("//").map_or(l, |i| &l[..i])).collect::<Vec<_>>().join("\n")
}

/// The module paths that `text` names after `crate::` or `super::`: each a list of identifiers
/// (`crate::a::b::{c, d::e}` gives `[a, b, c]` and `[a, b, d, e]`), with `super` as the root of
/// the relative ones.
fn paths(text: &str) -> Vec<(bool, Vec<String>)> {
    let code = code(text);
    let bytes = code.as_bytes();
    let mut out = Vec::new();
    for root in ["crate::", "super::"] {
        let mut start = 0;
        while let Some(i) = code[start..].find(root) {
            let at = start + i;
            start = at + root.len();
            if at > 0 && (bytes[at - 1].is_ascii_alphanumeric() || bytes[at - 1] == b'_' || bytes[at - 1] == b':') {
                continue;
            }
            for p in expand(&code[start..]) {
                out.push((root == "super::", p));
            }
        }
    }
    out
}

/// The paths of a `use` tree starting at `rest` (after a `crate::` or `super::`).
fn expand(rest: &str) -> Vec<Vec<String>> {
    let rest = rest.trim_start();
    if let Some(group) = rest.strip_prefix('{') {
        let mut depth = 0;
        let mut items = Vec::new();
        let mut item = String::new();
        for c in group.chars() {
            match c {
                '{' => depth += 1,
                '}' if depth == 0 => break,
                '}' => depth -= 1,
                ',' if depth == 0 => {
                    items.push(std::mem::take(&mut item));
                    continue;
                }
                _ => {}
            }
            item.push(c);
        }
        items.push(item);
        return items.iter().filter(|i| !i.trim().is_empty()).flat_map(|i| expand(i)).collect();
    }
    let ident: String = rest.chars().take_while(|c| c.is_ascii_alphanumeric() || *c == '_').collect();
    if ident.is_empty() || ident == "self" {
        return vec![Vec::new()];
    }
    let after = &rest[ident.len()..];
    match after.strip_prefix("::") {
        Some(more) => expand(more)
            .into_iter()
            .map(|mut p| {
                p.insert(0, ident.clone());
                p
            })
            .collect(),
        None => vec![vec![ident]],
    }
}

/// How finely a crate's table names modules.
#[derive(Clone, Copy, PartialEq)]
enum Granularity {
    /// The top-level modules (a folder and all its files are one module).
    TopLevel,
    /// Every file (`foo/bar.rs` is `foo/bar`, `foo/mod.rs` is `foo`).
    File,
}

/// Every `.rs` file under `dir`, as (module, text): the module is the path below `src` without
/// `.rs`, `foo/mod.rs` is `foo`, and with [`Granularity::TopLevel`] only its first component;
/// `lib.rs` is left out (it only declares the modules).
fn modules(src: &Path, granularity: Granularity) -> Vec<(String, String)> {
    let mut out = Vec::new();
    let mut stack = vec![src.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display())) {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else if path.extension().is_some_and(|e| e == "rs") {
                let rel = path.strip_prefix(src).unwrap().with_extension("");
                let mut name = rel.to_string_lossy().replace('\\', "/");
                if name == "lib" {
                    continue;
                }
                if let Some(parent) = name.strip_suffix("/mod") {
                    name = parent.to_owned();
                }
                if granularity == Granularity::TopLevel {
                    name = name.split('/').next().unwrap_or_default().to_owned();
                }
                out.push((name, std::fs::read_to_string(&path).unwrap()));
            }
        }
    }
    out.sort();
    out
}

/// The module a path names, among `known`: the longest prefix of `base` + `path` that is a
/// module (`crate::scene_file::apply::apply` is `scene_file/apply`; `super::BenchArgs` from
/// `bench/edit` is `bench`).
fn resolve(known: &BTreeSet<String>, base: &[String], path: &[String]) -> Option<String> {
    let full: Vec<String> = base.iter().chain(path).cloned().collect();
    (1..=full.len()).rev().map(|n| full[..n].join("/")).find(|m| known.contains(m))
}

/// The dependencies of every module of the crate at `src`, with `extra` (a module name and a
/// text, to test the checker itself) as one more file.
fn dependencies(src: &Path, granularity: Granularity, extra: Option<(&str, &str)>) -> BTreeMap<String, BTreeSet<String>> {
    let mut files = modules(src, granularity);
    if let Some((m, text)) = extra {
        files.push((m.to_owned(), text.to_owned()));
    }
    let known: BTreeSet<String> = files.iter().map(|(m, _)| m.clone()).collect();
    let mut deps: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (module, text) in &files {
        let own: Vec<String> = module.split('/').map(str::to_owned).collect();
        for (relative, path) in paths(text) {
            // `super::` from a folder's file: the folder (a `mod.rs` is its folder itself).
            let base: Vec<String> = if relative {
                let is_folder = src.join(module).join("mod.rs").is_file();
                let up = if is_folder { own.len().saturating_sub(1) } else { own.len() - 1 };
                own[..up].to_vec()
            } else {
                Vec::new()
            };
            if let Some(target) = resolve(&known, &base, &path) {
                if target != *module && !module.starts_with(&format!("{target}/")) {
                    deps.entry(module.clone()).or_default().insert(target);
                }
            }
        }
        deps.entry(module.clone()).or_default();
    }
    deps
}

/// What is wrong with the crate at `src` against `table`: modules without a row, rows of
/// modules that do not exist, and dependencies the table does not allow.
fn violations(src: &Path, granularity: Granularity, table: Table, extra: Option<(&str, &str)>) -> Vec<String> {
    let allowed: BTreeMap<&str, BTreeSet<&str>> = table.iter().map(|(m, d)| (*m, d.iter().copied().collect())).collect();
    let deps = dependencies(src, granularity, extra);
    let mut out = Vec::new();
    for (module, uses) in &deps {
        let Some(row) = allowed.get(module.as_str()) else {
            out.push(format!("{module}: no row in the layering table"));
            continue;
        };
        for d in uses {
            if !row.contains(d.as_str()) {
                out.push(format!("{module} uses {d}, which its row does not allow"));
            }
        }
    }
    for m in allowed.keys() {
        if !deps.contains_key(*m) {
            out.push(format!("{m}: a row for a module that does not exist"));
        }
    }
    out
}

/// The table's rows name only earlier rows: no circle, and the order is the layering.
fn check_order(name: &str, table: Table) {
    for (i, (module, uses)) in table.iter().enumerate() {
        for d in *uses {
            let j = table.iter().position(|(m, _)| m == d);
            assert!(j.is_some_and(|j| j < i), "{name} table: {module} may use {d}, which is not a row above it");
        }
    }
}

fn src(krate: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(krate).join("src")
}

const CRATES: [(&str, Granularity, Table); 3] =
    [("core", Granularity::TopLevel, CORE), ("capi", Granularity::File, CAPI), ("cli", Granularity::File, CLI)];

#[test]
fn every_crate_uses_only_the_layers_below_each_module() {
    for (name, granularity, table) in CRATES {
        check_order(name, table);
        let found = violations(&src(name), granularity, table, None);
        assert!(found.is_empty(), "{name}:\n  {}", found.join("\n  "));
    }
}

#[test]
fn an_arrow_back_up_is_caught() {
    let core = |extra: &str| violations(&src("core"), Granularity::TopLevel, CORE, Some(("sparse", extra)));
    // sparse reaching the session and the diffusion solver, in a grouped use.
    let upward = "use crate::{progress::Cancelled, diffusion::solve, session::{Session, SessionError}};\n";
    assert_eq!(
        core(upward),
        ["sparse uses diffusion, which its row does not allow", "sparse uses session, which its row does not allow"]
    );
    // A comment alone is no arrow, nor is a path that only ends in `crate::`.
    assert!(core("//! see crate::session\nlet x = my_crate::session::f();\n").is_empty());
    // A new module without a row.
    let found = violations(&src("core"), Granularity::TopLevel, CORE, Some(("shading", "use crate::mesh::TriMesh;\n")));
    assert_eq!(found, ["shading: no row in the layering table"]);
    // One CLI benchmark suite using another through `super::`.
    let cli = violations(&src("cli"), Granularity::File, CLI, Some(("bench/mesh", "use super::edit::run;\n")));
    assert_eq!(cli, ["bench/mesh uses bench/edit, which its row does not allow"]);
}

#[test]
fn paths_are_read_from_use_trees() {
    let got: Vec<Vec<String>> =
        paths("use crate::a::{b, c::{d, e}, self};\nlet x = super::f::g(); my_crate::h;").into_iter().map(|(_, p)| p).collect();
    let s = |v: &[&str]| v.iter().map(|x| x.to_string()).collect::<Vec<_>>();
    assert_eq!(got, [s(&["a", "b"]), s(&["a", "c", "d"]), s(&["a", "c", "e"]), s(&["a"]), s(&["f", "g"])]);
}

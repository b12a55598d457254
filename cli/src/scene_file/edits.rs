//! The `[[edit]]` list of a scene file: edits applied in order after the bake, before rendering
//! (relight, medium edits, paint, cuts, fracture, moving and recombining pieces; TransCut §5;
//! a radiosity bake's albedos, emissions and whole media).
//!
//! ```toml
//! [[edit]]
//! kind = "cut_plane"        # relight | medium | paint | cut_plane | cut_stroke | fracture
//!                           # | move_piece | recombine | albedo | emission
//! object = "bunny"          # the object's name (default: the only object; not for relight)
//! point = [0, 0, 0]         # scene units (world space)
//! normal = [0, 0, 1]        # points to the side that is kept
//! keep = "front"            # front (default) | back | both (split into two pieces)
//! ```
//!
//! Keys per kind (coordinates in scene units, world space, where the object was baked;
//! colours and coefficients a number or [r, g, b]):
//! - `relight`: `lights` = a list of light tables, as `[[light]]` (an empty list: the white
//!   sky); replaces the scene's lights for every object and for the highlights. A radiosity
//!   bake is re-solved as a whole, every object shadowing and lighting every other.
//! - `medium`: `region` = `"all"` (default) | `{ kind = "sphere", center, radius }` |
//!   `{ kind = "depth", min_mm, max_mm }` (tets whose centroid lies that deep below the
//!   original surface); and exactly one of `assign` = a medium (a preset name or a table as for
//!   `[[object]]`), `scale = { sigma_a, sigma_s }` (factors, default 1) or
//!   `add = { sigma_a, sigma_s }` (mm⁻¹, default 0).
//! - `paint`: `points` (a list of [x, y, z] on the surface), `radius` (the Gaussian's σ),
//!   `medium` (a preset name or a table), `strength` (in (0, 1], default 1).
//! - `cut_plane`: `point`, `normal`, `keep` as above.
//! - `cut_stroke`: `stroke` = a list of ≥ 2 [u, v] pixel positions in the image of the scene's
//!   `[camera]` (as written in the file: `--width`/`--height` do not move the cut), swept along
//!   the camera's rays; `keep` = `"right"` (default: TransCut deletes the left) | `"left"` |
//!   `"both"`: the side of the stroke, as seen in the image while following it from its first
//!   point to its last (left of a stroke drawn left to right is above it).
//! - `fracture`: none (every piece splits into its connected parts).
//! - `move_piece`: `piece` (0-based index, in the editor's order), `translate` ([x, y, z],
//!   default 0), `axis` and `angle_deg` (a rotation about `axis` through `pivot`, default the
//!   piece's centroid); the rotation is applied first.
//! - `recombine`: none (pieces whose faces touch again are welded).
//! - `albedo`: `albedo` (a number or [r, g, b], each in [0, 1)) of a `kind = "diffuse"`
//!   object; `emission`: `emission` (finite, ≥ 0; the exitance, radiance emission/π). Only a
//!   radiosity bake has diffuse objects; the whole scene is re-solved.
//!
//! A radiosity bake takes `relight`, `albedo`, `emission` and, for a translucent object, a
//! `medium` edit of the whole object to a new medium (`region = "all"`, `assign`; the medium
//! taken whole, its η and g too): its objects are coupled through the whole scene, so the
//! other regions and operations, paint, cuts and pieces are refused by name.
//!
//! Every error names the edit (1-based, with its kind) and the key.

use anyhow::{anyhow, bail, Context};
use serde::Deserialize;
use transcut::input::{fmt_num, quote};
use transcut::light::{Environment, Light};
use transcut::optics::Medium;
use transcut::DVec3;

use super::media::medium;
use super::schema::{LightSpec, Rgb};

/// Which side of a cut stays.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Keep {
    /// Plane: the side the normal points to.
    Front,
    /// Plane: the other side.
    Back,
    /// Stroke: left of the stroke in the image, following it from first to last point.
    Left,
    /// Stroke: right of it.
    Right,
    /// Both sides, as separate pieces.
    Both,
}

/// Where a medium edit applies.
#[derive(Debug, Clone, PartialEq)]
pub enum RegionSpec {
    All,
    Sphere { center: DVec3, radius: f64 },
    Depth { min_mm: f64, max_mm: f64 },
}

/// What a medium edit does.
#[derive(Debug, Clone, PartialEq)]
pub enum OpSpec {
    Assign(Medium),
    Scale { sigma_a: [f64; 3], sigma_s: [f64; 3] },
    Add { sigma_a: [f64; 3], sigma_s: [f64; 3] },
}

/// One parsed edit (`Albedo` and `Emission`: a diffuse object's new albedo and emitted
/// exitance, of a radiosity bake).
#[derive(Debug, Clone)]
pub enum EditKind {
    Relight(Vec<Light>),
    Medium { region: RegionSpec, op: OpSpec },
    Paint { points: Vec<DVec3>, radius: f64, medium: Medium, strength: f64 },
    CutPlane { point: DVec3, normal: DVec3, keep: Keep },
    CutStroke { pixels: Vec<[f64; 2]>, keep: Keep },
    Fracture,
    MovePiece { piece: usize, translate: DVec3, axis: Option<DVec3>, angle_deg: f64, pivot: Option<DVec3> },
    Recombine,
    Albedo([f64; 3]),
    Emission([f64; 3]),
}

/// One `[[edit]]`, resolved: its 1-based position, kind name, target object and parameters.
#[derive(Debug, Clone)]
pub struct EditStep {
    /// 1-based position in the file.
    pub index: usize,
    /// The `kind` as written (lower case).
    pub kind_name: String,
    /// Index of the object it edits (`None` for relight, which applies to every object).
    pub object: Option<usize>,
    pub kind: EditKind,
}

const KINDS: &[&str] =
    &["relight", "medium", "paint", "cut_plane", "cut_stroke", "fracture", "move_piece", "recombine", "albedo", "emission"];

/// Parses and checks every `[[edit]]` table. `names` and `mm_per_unit` are the objects' names
/// and millimetres per scene unit (artist media depend on it).
///
/// # Errors
/// The first bad edit, naming its index, kind and key.
pub fn resolve(
    tables: &[toml::Table],
    names: &[String],
    mm_per_unit: &[f64],
    base: &std::path::Path,
) -> anyhow::Result<Vec<EditStep>> {
    tables
        .iter()
        .enumerate()
        .map(|(i, t)| {
            let kind = t.get("kind").and_then(toml::Value::as_str).map(str::to_ascii_lowercase);
            let label = match &kind {
                Some(k) => format!("edit {} (kind = \"{k}\")", i + 1),
                None => format!("edit {}", i + 1),
            };
            step(i + 1, kind, t, names, mm_per_unit, base).with_context(|| label)
        })
        .collect()
}

fn step(
    index: usize,
    kind: Option<String>,
    t: &toml::Table,
    names: &[String],
    mm_per_unit: &[f64],
    base: &std::path::Path,
) -> anyhow::Result<EditStep> {
    let kind = match (kind, t.get("kind")) {
        (Some(k), _) => k,
        (None, None) => bail!("missing key 'kind' ({})", KINDS.join(", ")),
        (None, Some(v)) => bail!("'kind' must be a string, got {}", v.type_str()),
    };
    let allowed: &[&str] = match kind.as_str() {
        "relight" => &["lights"],
        "medium" => &["region", "assign", "scale", "add"],
        "paint" => &["points", "radius", "medium", "strength"],
        "cut_plane" => &["point", "normal", "keep"],
        "cut_stroke" => &["stroke", "keep"],
        "fracture" | "recombine" => &[],
        "move_piece" => &["piece", "translate", "axis", "angle_deg", "pivot"],
        "albedo" => &["albedo"],
        "emission" => &["emission"],
        other => bail!("unknown edit kind {other} ({})", KINDS.join(", "), other = quote(other)),
    };
    if let Some(k) = t.keys().find(|k| !(k.as_str() == "kind" || k.as_str() == "object" || allowed.contains(&k.as_str()))) {
        let keys = if allowed.is_empty() { "only object".to_string() } else { format!("object, {}", allowed.join(", ")) };
        bail!("unknown key {k} for this kind of edit (its keys: {keys})", k = quote(k));
    }
    let object = if kind == "relight" {
        if t.contains_key("object") {
            bail!("key 'object' does not apply to relight: the lights belong to the scene and every object is relit");
        }
        None
    } else {
        Some(object_index(t, names)?)
    };
    let mm = object.map_or(1.0, |o| mm_per_unit[o]);
    let kind_value = match kind.as_str() {
        "relight" => {
            let list = t.get("lights").ok_or_else(|| anyhow!("missing key 'lights' (a list of light tables as [[light]])"))?;
            let list = list.as_array().ok_or_else(|| anyhow!("'lights' must be a list of light tables"))?;
            let mut lights = Vec::with_capacity(list.len());
            for (i, v) in list.iter().enumerate() {
                let spec = LightSpec::deserialize(v.clone())
                    .map_err(|e| anyhow!("'lights' entry {}: {}", i + 1, e.to_string().trim_end()))?;
                let light =
                    spec.to_light(base).with_context(|| format!("'lights' entry {} (kind = \"{}\")", i + 1, spec.kind))?;
                light.validate(i).map_err(|e| anyhow!("'lights' entry {} (kind = \"{}\"): {e}", i + 1, spec.kind))?;
                lights.push(light);
            }
            if lights.is_empty() {
                lights.push(Light::Environment(Environment::Constant([1.0; 3])));
            }
            EditKind::Relight(lights)
        }
        "medium" => {
            let region = match t.get("region") {
                None => RegionSpec::All,
                Some(v) => region(v).context("'region'")?,
            };
            let ops: Vec<&str> = ["assign", "scale", "add"].into_iter().filter(|k| t.contains_key(*k)).collect();
            let op = match ops.as_slice() {
                ["assign"] => OpSpec::Assign(medium(&t["assign"], mm).context("'assign'")?),
                ["scale"] => {
                    let (sigma_a, sigma_s) = coefficients(&t["scale"], 1.0).context("'scale'")?;
                    if sigma_a.iter().chain(&sigma_s).any(|&f| f < 0.0) {
                        bail!("'scale': the factors must not be negative");
                    }
                    OpSpec::Scale { sigma_a, sigma_s }
                }
                ["add"] => {
                    let (sigma_a, sigma_s) = coefficients(&t["add"], 0.0).context("'add'")?;
                    OpSpec::Add { sigma_a, sigma_s }
                }
                [] => bail!("missing the operation: give one of 'assign', 'scale', 'add'"),
                more => bail!("give one of 'assign', 'scale', 'add', not {}", more.join(" and ")),
            };
            EditKind::Medium { region, op }
        }
        "paint" => {
            let points = vec3_list(t, "points")?;
            if points.is_empty() {
                bail!("'points' must hold at least one point");
            }
            let radius = positive(t, "radius")?;
            let medium = medium(t.get("medium").ok_or_else(|| anyhow!("missing key 'medium'"))?, mm).context("'medium'")?;
            let strength = match t.get("strength") {
                None => 1.0,
                Some(_) => number(t, "strength")?,
            };
            if !(strength > 0.0 && strength <= 1.0) {
                bail!("'strength' must lie in (0, 1], got {}", fmt_num(strength));
            }
            EditKind::Paint { points, radius, medium, strength }
        }
        "cut_plane" => {
            let point = vec3(t, "point")?;
            let normal = vec3(t, "normal")?;
            if normal.length_squared() == 0.0 {
                bail!("'normal' must not be zero");
            }
            let keep = keep(t, &[("front", Keep::Front), ("back", Keep::Back), ("both", Keep::Both)])?;
            EditKind::CutPlane { point, normal, keep }
        }
        "cut_stroke" => {
            let v = t.get("stroke").ok_or_else(|| anyhow!("missing key 'stroke' (a list of [u, v] pixel positions)"))?;
            let pixels = <Vec<[f64; 2]>>::deserialize(v.clone())
                .map_err(|_| anyhow!("'stroke' must be a list of [u, v] pixel positions"))?;
            if pixels.len() < 2 {
                bail!("'stroke' must hold at least 2 points, got {}", pixels.len());
            }
            if let Some(k) = pixels.iter().position(|p| !(p[0].is_finite() && p[1].is_finite())) {
                bail!("'stroke' point {} is not finite", k + 1);
            }
            let keep = keep(t, &[("right", Keep::Right), ("left", Keep::Left), ("both", Keep::Both)])?;
            EditKind::CutStroke { pixels, keep }
        }
        "fracture" => EditKind::Fracture,
        "recombine" => EditKind::Recombine,
        "albedo" => {
            let albedo = rgb(t, "albedo")?;
            if !albedo.iter().all(|a| (0.0..1.0).contains(a)) {
                bail!("'albedo' must lie in [0, 1) in every channel, got {}", fmt_rgb(albedo));
            }
            EditKind::Albedo(albedo)
        }
        "emission" => {
            let emission = rgb(t, "emission")?;
            if !emission.iter().all(|&m| m >= 0.0) {
                bail!("'emission' must be ≥ 0 in every channel, got {}", fmt_rgb(emission));
            }
            EditKind::Emission(emission)
        }
        _ => {
            let piece = match t.get("piece") {
                None => bail!("missing key 'piece' (a 0-based piece index)"),
                Some(v) => v
                    .as_integer()
                    .and_then(|p| usize::try_from(p).ok())
                    .ok_or_else(|| anyhow!("'piece' must be a non-negative integer"))?,
            };
            let translate = if t.contains_key("translate") { vec3(t, "translate")? } else { DVec3::ZERO };
            let axis = if t.contains_key("axis") { Some(vec3(t, "axis")?) } else { None };
            let angle_deg = if t.contains_key("angle_deg") { number(t, "angle_deg")? } else { 0.0 };
            match axis {
                Some(a) if a.length_squared() == 0.0 => bail!("'axis' must not be zero"),
                None if angle_deg != 0.0 => bail!("'angle_deg' needs 'axis'"),
                _ => {}
            }
            let pivot = if t.contains_key("pivot") { Some(vec3(t, "pivot")?) } else { None };
            EditKind::MovePiece { piece, translate, axis, angle_deg, pivot }
        }
    };
    Ok(EditStep { index, kind_name: kind, object, kind: kind_value })
}

fn object_index(t: &toml::Table, names: &[String]) -> anyhow::Result<usize> {
    match t.get("object") {
        None if names.len() == 1 => Ok(0),
        None => bail!("missing key 'object': the scene has {} objects ({})", names.len(), names.join(", ")),
        Some(v) => {
            let name = v.as_str().ok_or_else(|| anyhow!("'object' must be an object's name"))?;
            let mut found = names.iter().enumerate().filter(|(_, n)| *n == name).map(|(i, _)| i);
            match (found.next(), found.next()) {
                (Some(i), None) => Ok(i),
                (Some(_), Some(_)) => {
                    bail!("'object': several objects are named {name} (give them distinct names)", name = quote(name))
                }
                (None, _) => bail!("'object': no object named {name} (the objects: {})", names.join(", "), name = quote(name)),
            }
        }
    }
}

fn number(t: &toml::Table, key: &str) -> anyhow::Result<f64> {
    let v = match t.get(key) {
        None => bail!("missing key {key}", key = quote(key)),
        Some(toml::Value::Float(v)) => *v,
        Some(toml::Value::Integer(v)) => *v as f64,
        Some(other) => bail!("{key} must be a number, got {}", other.type_str(), key = quote(key)),
    };
    if !v.is_finite() {
        bail!("{key} must be finite, got {}", fmt_num(v), key = quote(key));
    }
    Ok(v)
}

/// A colour `key`: a number or [r, g, b], finite.
fn rgb(t: &toml::Table, key: &str) -> anyhow::Result<[f64; 3]> {
    let v = t.get(key).ok_or_else(|| anyhow!("missing key {key} (a number or [r, g, b])", key = quote(key)))?;
    let c = Rgb::deserialize(v.clone())
        .map(Rgb::get)
        .map_err(|_| anyhow!("{key} must be a number or [r, g, b]", key = quote(key)))?;
    if !c.iter().all(|x| x.is_finite()) {
        bail!("{key} must be finite, got {}", fmt_rgb(c), key = quote(key));
    }
    Ok(c)
}

/// `[r, g, b]` with each channel as `fmt_num` writes it.
fn fmt_rgb(c: [f64; 3]) -> String {
    format!("[{}, {}, {}]", fmt_num(c[0]), fmt_num(c[1]), fmt_num(c[2]))
}

fn positive(t: &toml::Table, key: &str) -> anyhow::Result<f64> {
    let v = number(t, key)?;
    if v <= 0.0 {
        bail!("{key} must be positive, got {}", fmt_num(v), key = quote(key));
    }
    Ok(v)
}

fn vec3(t: &toml::Table, key: &str) -> anyhow::Result<DVec3> {
    let v = t.get(key).ok_or_else(|| anyhow!("missing key {key}", key = quote(key)))?;
    let a = <[f64; 3]>::deserialize(v.clone()).map_err(|_| anyhow!("{key} must be [x, y, z]", key = quote(key)))?;
    if !a.iter().all(|x| x.is_finite()) {
        bail!("{key} must be finite", key = quote(key));
    }
    Ok(DVec3::from(a))
}

fn vec3_list(t: &toml::Table, key: &str) -> anyhow::Result<Vec<DVec3>> {
    let v = t.get(key).ok_or_else(|| anyhow!("missing key {key}", key = quote(key)))?;
    let list =
        <Vec<[f64; 3]>>::deserialize(v.clone()).map_err(|_| anyhow!("{key} must be a list of [x, y, z]", key = quote(key)))?;
    if let Some(k) = list.iter().position(|p| !p.iter().all(|x| x.is_finite())) {
        bail!("{key} point {} is not finite", k + 1, key = quote(key));
    }
    Ok(list.into_iter().map(DVec3::from).collect())
}

fn keep(t: &toml::Table, options: &[(&str, Keep)]) -> anyhow::Result<Keep> {
    match t.get("keep") {
        None => Ok(options[0].1),
        Some(v) => {
            let names: Vec<&str> = options.iter().map(|o| o.0).collect();
            let s = v.as_str().ok_or_else(|| anyhow!("'keep' must be one of {}", names.join(", ")))?;
            options
                .iter()
                .find(|o| o.0.eq_ignore_ascii_case(s))
                .map(|o| o.1)
                .ok_or_else(|| anyhow!("'keep' must be one of {}, got {s}", names.join(", "), s = quote(s)))
        }
    }
}

fn region(v: &toml::Value) -> anyhow::Result<RegionSpec> {
    if let Some(s) = v.as_str() {
        return if s.eq_ignore_ascii_case("all") {
            Ok(RegionSpec::All)
        } else {
            bail!("expected \"all\" or a table with kind = \"sphere\" or \"depth\", got {s}", s = quote(s))
        };
    }
    let t = v.as_table().ok_or_else(|| anyhow!("expected \"all\" or a table, got {}", v.type_str()))?;
    let kind = t.get("kind").and_then(toml::Value::as_str).ok_or_else(|| anyhow!("missing key 'kind' (all, sphere, depth)"))?;
    let (allowed, region): (&[&str], _) = match kind.to_ascii_lowercase().as_str() {
        "all" => (&[], RegionSpec::All),
        "sphere" => (&["center", "radius"], RegionSpec::Sphere { center: vec3(t, "center")?, radius: positive(t, "radius")? }),
        "depth" => {
            let (min_mm, max_mm) = (number(t, "min_mm")?, number(t, "max_mm")?);
            if !(min_mm >= 0.0 && max_mm > min_mm) {
                bail!("need 0 ≤ min_mm < max_mm, got min_mm = {}, max_mm = {}", fmt_num(min_mm), fmt_num(max_mm));
            }
            (&["min_mm", "max_mm"], RegionSpec::Depth { min_mm, max_mm })
        }
        other => bail!("unknown region kind {other} (all, sphere, depth)", other = quote(other)),
    };
    if let Some(k) = t.keys().find(|k| !(k.as_str() == "kind" || allowed.contains(&k.as_str()))) {
        bail!("unknown key {k} in a {kind} region", k = quote(k));
    }
    Ok(region)
}

/// `{ sigma_a, sigma_s }`, each a number or [r, g, b], `default` where absent.
fn coefficients(v: &toml::Value, default: f64) -> anyhow::Result<([f64; 3], [f64; 3])> {
    let t = v.as_table().ok_or_else(|| anyhow!("expected a table {{ sigma_a = .., sigma_s = .. }}"))?;
    if let Some(k) = t.keys().find(|k| !["sigma_a", "sigma_s"].contains(&k.as_str())) {
        bail!("unknown key {k} (its keys: sigma_a, sigma_s)", k = quote(k));
    }
    let rgb = |key: &str| -> anyhow::Result<[f64; 3]> {
        match t.get(key) {
            None => Ok([default; 3]),
            Some(v) => {
                let c = Rgb::deserialize(v.clone())
                    .map(Rgb::get)
                    .map_err(|_| anyhow!("{key} must be a number or [r, g, b]", key = quote(key)))?;
                if c.iter().all(|x| x.is_finite()) {
                    Ok(c)
                } else {
                    bail!("{key} must be finite", key = quote(key))
                }
            }
        }
    };
    Ok((rgb("sigma_a")?, rgb("sigma_s")?))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str, names: &[&str]) -> anyhow::Result<Vec<EditStep>> {
        #[derive(Deserialize)]
        struct F {
            edit: Vec<toml::Table>,
        }
        let f: F = toml::from_str(text).unwrap();
        let names: Vec<String> = names.iter().map(|s| s.to_string()).collect();
        let mm = vec![1.0; names.len()];
        resolve(&f.edit, &names, &mm, std::path::Path::new("."))
    }

    fn err(text: &str, names: &[&str]) -> String {
        format!("{:#}", parse(text, names).unwrap_err())
    }

    #[test]
    fn every_kind_parses() {
        let text = r#"
[[edit]]
kind = "relight"
lights = [{ kind = "sun", dir = [0, 0, -1], irradiance = 2 }]
[[edit]]
kind = "medium"
object = "b"
region = { kind = "sphere", center = [1, 2, 3], radius = 4 }
scale = { sigma_a = [2, 2, 2] }
[[edit]]
kind = "medium"
object = "b"
region = { kind = "depth", min_mm = 0, max_mm = 1.5 }
assign = "marble"
[[edit]]
kind = "paint"
object = "a"
points = [[0, 0, 0], [1, 0, 0]]
radius = 2
medium = { sigma_a = 0.5, sigma_s = 2, eta = 1.5 }
strength = 0.5
[[edit]]
kind = "cut_plane"
object = "a"
point = [0, 0, 0]
normal = [0, 0, 2]
keep = "both"
[[edit]]
kind = "cut_stroke"
object = "a"
stroke = [[10, 20], [30.5, 40]]
[[edit]]
kind = "fracture"
object = "a"
[[edit]]
kind = "move_piece"
object = "a"
piece = 1
translate = [0, 5, 0]
axis = [0, 1, 0]
angle_deg = 30
[[edit]]
kind = "recombine"
object = "a"
[[edit]]
kind = "medium"
object = "a"
add = { sigma_s = 0.25 }
"#;
        let steps = parse(text, &["a", "b"]).unwrap();
        assert_eq!(steps.len(), 10);
        assert_eq!(steps.iter().map(|s| s.index).collect::<Vec<_>>(), (1..=10).collect::<Vec<_>>());
        assert!(matches!(&steps[0].kind, EditKind::Relight(l) if l.len() == 1) && steps[0].object.is_none());
        assert!(
            matches!(&steps[1].kind, EditKind::Medium { region: RegionSpec::Sphere { radius, .. }, op: OpSpec::Scale { sigma_a: [2.0, 2.0, 2.0], sigma_s: [1.0, 1.0, 1.0] } } if *radius == 4.0)
        );
        assert_eq!(steps[1].object, Some(1));
        assert!(
            matches!(&steps[2].kind, EditKind::Medium { region: RegionSpec::Depth { min_mm, max_mm }, op: OpSpec::Assign(m) } if *min_mm == 0.0 && *max_mm == 1.5 && m.eta == 1.5)
        );
        assert!(
            matches!(&steps[3].kind, EditKind::Paint { points, radius, strength, medium } if points.len() == 2 && *radius == 2.0 && *strength == 0.5 && medium.sigma_a == [0.5; 3])
        );
        assert!(
            matches!(&steps[4].kind, EditKind::CutPlane { keep: Keep::Both, normal, .. } if *normal == DVec3::new(0.0, 0.0, 2.0))
        );
        assert!(matches!(&steps[5].kind, EditKind::CutStroke { keep: Keep::Right, pixels } if pixels[1] == [30.5, 40.0]));
        assert!(matches!(steps[6].kind, EditKind::Fracture));
        assert!(
            matches!(&steps[7].kind, EditKind::MovePiece { piece: 1, angle_deg, axis: Some(_), pivot: None, .. } if *angle_deg == 30.0)
        );
        assert!(matches!(steps[8].kind, EditKind::Recombine));
        assert!(matches!(
            &steps[9].kind,
            EditKind::Medium {
                region: RegionSpec::All,
                op: OpSpec::Add { sigma_a: [0.0, 0.0, 0.0], sigma_s: [0.25, 0.25, 0.25] }
            }
        ));
    }

    #[test]
    fn albedo_and_emission_edits_parse_and_check_their_values() {
        let text = "[[edit]]\nkind = \"albedo\"\nobject = \"wall\"\nalbedo = [0.6, 0.3, 0.2]\n\
                    [[edit]]\nkind = \"emission\"\nobject = \"wall\"\nemission = 2\n";
        let steps = parse(text, &["block", "wall"]).unwrap();
        assert!(matches!(steps[0].kind, EditKind::Albedo([0.6, 0.3, 0.2])) && steps[0].object == Some(1));
        assert!(matches!(steps[1].kind, EditKind::Emission([2.0, 2.0, 2.0])) && steps[1].object == Some(1));
        let e = err("[[edit]]\nkind = \"albedo\"\nalbedo = 1\n", &["a"]);
        assert!(e.contains("edit 1 (kind = \"albedo\")") && e.contains("'albedo' must lie in [0, 1)"), "{e}");
        let e = err("[[edit]]\nkind = \"albedo\"\nalbedo = [0.5, nan, 0.5]\n", &["a"]);
        assert!(e.contains("'albedo' must be finite"), "{e}");
        let e = err("[[edit]]\nkind = \"albedo\"\n", &["a"]);
        assert!(e.contains("missing key 'albedo'"), "{e}");
        let e = err("[[edit]]\nkind = \"emission\"\nemission = [0, -1, 0]\n", &["a"]);
        assert!(e.contains("edit 1 (kind = \"emission\")") && e.contains("'emission' must be ≥ 0"), "{e}");
        let e = err("[[edit]]\nkind = \"emission\"\nemission = \"bright\"\n", &["a"]);
        assert!(e.contains("'emission' must be a number or [r, g, b]"), "{e}");
        let e = err("[[edit]]\nkind = \"emission\"\nemission = 1\nalbedo = 0.5\n", &["a"]);
        assert!(e.contains("unknown key 'albedo'") && e.contains("object, emission"), "{e}");
    }

    #[test]
    fn the_only_object_is_the_default() {
        let steps = parse("[[edit]]\nkind = \"fracture\"\n", &["bunny"]).unwrap();
        assert_eq!(steps[0].object, Some(0));
        let steps = parse("[[edit]]\nkind = \"cut_plane\"\npoint = [0,0,0]\nnormal = [1,0,0]\n", &["bunny"]).unwrap();
        assert!(matches!(steps[0].kind, EditKind::CutPlane { keep: Keep::Front, .. }));
    }

    #[test]
    fn errors_name_the_edit_and_the_key() {
        let ok = "[[edit]]\nkind = \"fracture\"\n";
        let e = err(&format!("{ok}[[edit]]\nkind = \"cut_plane\"\npoint = [0,0,0]\n"), &["a"]);
        assert!(e.contains("edit 2 (kind = \"cut_plane\")") && e.contains("'normal'"), "{e}");
        let e =
            err(&format!("{ok}{ok}[[edit]]\nkind = \"paint\"\npoints = [[0,0,0]]\nradius = -1\nmedium = \"marble\"\n"), &["a"]);
        assert!(e.contains("edit 3 (kind = \"paint\")") && e.contains("'radius' must be positive"), "{e}");
        let e = err("[[edit]]\nkind = \"cut_plane\"\npoint = [0,0,0]\nnormal = [0,0,1]\nradius = 2\n", &["a"]);
        assert!(e.contains("edit 1") && e.contains("unknown key 'radius'"), "{e}");
        let e = err("[[edit]]\nkind = \"explode\"\n", &["a"]);
        assert!(e.contains("edit 1") && e.contains("unknown edit kind 'explode'"), "{e}");
        let e = err("[[edit]]\nobject = \"a\"\n", &["a"]);
        assert!(e.contains("edit 1") && e.contains("missing key 'kind'"), "{e}");
        let e = err("[[edit]]\nkind = \"fracture\"\n", &["a", "b"]);
        assert!(e.contains("missing key 'object'") && e.contains("a, b"), "{e}");
        let e = err("[[edit]]\nkind = \"fracture\"\nobject = \"c\"\n", &["a", "b"]);
        assert!(e.contains("no object named 'c'"), "{e}");
        let e = err("[[edit]]\nkind = \"medium\"\nscale = { sigma_a = 2 }\nadd = { sigma_a = 1 }\n", &["a"]);
        assert!(e.contains("not scale and add"), "{e}");
        let e = err(
            "[[edit]]\nkind = \"medium\"\nregion = { kind = \"sphere\", center = [0,0,0] }\nscale = { sigma_a = 2 }\n",
            &["a"],
        );
        assert!(e.contains("'region'") && e.contains("'radius'"), "{e}");
        let e = err("[[edit]]\nkind = \"medium\"\nobject = \"a\"\n", &["a"]);
        assert!(e.contains("give one of 'assign', 'scale', 'add'"), "{e}");
        let e = err(
            "[[edit]]\nkind = \"medium\"\nregion = { kind = \"depth\", min_mm = 2, max_mm = 1 }\nscale = { sigma_a = 2 }\n",
            &["a"],
        );
        assert!(e.contains("'region'") && e.contains("min_mm < max_mm"), "{e}");
        let e = err("[[edit]]\nkind = \"medium\"\nscale = { sigma_a = -2 }\n", &["a"]);
        assert!(e.contains("'scale'") && e.contains("negative"), "{e}");
        let e = err("[[edit]]\nkind = \"medium\"\nassign = \"plutonium\"\n", &["a"]);
        assert!(e.contains("'assign'") && e.contains("plutonium"), "{e}");
        let e = err("[[edit]]\nkind = \"cut_stroke\"\nstroke = [[1, 2]]\n", &["a"]);
        assert!(e.contains("at least 2 points"), "{e}");
        let e = err("[[edit]]\nkind = \"cut_plane\"\npoint = [0,0,0]\nnormal = [0,0,1]\nkeep = \"left\"\n", &["a"]);
        assert!(e.contains("'keep' must be one of front, back, both"), "{e}");
        let e = err("[[edit]]\nkind = \"move_piece\"\npiece = -1\n", &["a"]);
        assert!(e.contains("'piece' must be a non-negative integer"), "{e}");
        let e = err("[[edit]]\nkind = \"move_piece\"\npiece = 0\nangle_deg = 10\n", &["a"]);
        assert!(e.contains("'angle_deg' needs 'axis'"), "{e}");
        let e = err("[[edit]]\nkind = \"relight\"\nobject = \"a\"\nlights = []\n", &["a"]);
        assert!(e.contains("'object' does not apply to relight"), "{e}");
        let e = err("[[edit]]\nkind = \"relight\"\nlights = [{ kind = \"sun\", dir = [0,0,-1] }]\n", &["a"]);
        assert!(e.contains("'lights' entry 1") && e.contains("irradiance"), "{e}");
        let e = err("[[edit]]\nkind = \"paint\"\npoints = [[0,0,0]]\nradius = 1\nmedium = \"marble\"\nstrength = 2\n", &["a"]);
        assert!(e.contains("'strength' must lie in (0, 1]"), "{e}");
    }
}

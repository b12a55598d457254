//! Media of the scene file: presets, coefficient and artist tables, and heterogeneous media
//! (layers, veins, voxel files).

use std::path::Path;
use transcut::input::quote;

use anyhow::{anyhow, bail, Context};
use serde::Deserialize;
use transcut::optics::{ArtistMapping, ArtistParams, Medium};
use transcut::volume::{Layers, VeinParams, Veins, VoxelGrid};
use transcut::{DVec3, MediumSource};

use super::schema::Rgb;

/// An object's medium: homogeneous ([`medium`]), or layered, veined or from a voxel file (see
/// the module documentation), told apart by the keys `layers`, `base` and `voxels`.
pub fn object_medium(value: &toml::Value, mm_per_unit: f64, base_dir: &Path) -> anyhow::Result<MediumSource> {
    let Some(table) = value.as_table() else {
        return medium(value, mm_per_unit).map(MediumSource::Homogeneous);
    };
    let check_keys = |what: &str, known: &[&str]| -> anyhow::Result<()> {
        match table.keys().find(|k| !known.contains(&k.as_str())) {
            Some(k) => bail!("unknown key {k} in the {what} medium (its keys: {})", known.join(", "), k = quote(k)),
            None => Ok(()),
        }
    };
    let number = |key: &str, default: f64| table_number(table, key, Some(default));
    let inner = |key: &str| -> anyhow::Result<Medium> {
        let v = table.get(key).ok_or_else(|| anyhow!("missing key {key}", key = quote(key)))?;
        medium(v, mm_per_unit).with_context(|| format!("'{key}'"))
    };
    if let Some(layers) = table.get("layers") {
        check_keys("layered", &["layers", "blend_mm"])?;
        let list = layers.as_array().ok_or_else(|| anyhow!("'layers' must be an array of tables"))?;
        let mut parsed = Vec::with_capacity(list.len());
        for (i, layer) in list.iter().enumerate() {
            let layer = layer.as_table().ok_or_else(|| anyhow!("layer {}: expected a table", i + 1))?;
            if let Some(k) = layer.keys().find(|k| !["depth_mm", "medium"].contains(&k.as_str())) {
                bail!("layer {}: unknown key {k} (its keys: depth_mm, medium)", i + 1, k = quote(k));
            }
            let depth = match layer.get("depth_mm") {
                None if i + 1 == list.len() => f64::INFINITY,
                None => bail!("layer {}: missing key 'depth_mm' (only the innermost layer may omit it)", i + 1),
                Some(_) => table_number(layer, "depth_mm", None).with_context(|| format!("layer {}", i + 1))?,
            };
            let m = layer.get("medium").ok_or_else(|| anyhow!("layer {}: missing key 'medium'", i + 1))?;
            parsed.push((depth, medium(m, mm_per_unit).with_context(|| format!("layer {}", i + 1))?));
        }
        return Ok(MediumSource::Layers(Layers::new(&parsed, number("blend_mm", 0.0)?).map_err(|e| anyhow!("{e}"))?));
    }
    if table.contains_key("base") {
        check_keys(
            "veined",
            &["base", "vein", "seed", "period", "direction", "turbulence", "noise_scale", "octaves", "sharpness"],
        )?;
        let d = VeinParams::default();
        let direction = match table.get("direction") {
            None => d.direction,
            Some(v) => DVec3::from(<[f64; 3]>::deserialize(v.clone()).map_err(|_| anyhow!("'direction' must be [x, y, z]"))?),
        };
        let integer = |key: &str, default: i64| -> anyhow::Result<i64> {
            match table.get(key) {
                None => Ok(default),
                Some(v) => v
                    .as_integer()
                    .filter(|x| *x >= 0)
                    .ok_or_else(|| anyhow!("{key} must be a non-negative integer", key = quote(key))),
            }
        };
        let params = VeinParams {
            direction,
            period: number("period", d.period)?,
            turbulence: number("turbulence", d.turbulence)?,
            noise_scale: number("noise_scale", d.noise_scale)?,
            octaves: u32::try_from(integer("octaves", i64::from(d.octaves))?).map_err(|_| anyhow!("'octaves' is too large"))?,
            sharpness: number("sharpness", d.sharpness)?,
        };
        let veins = Veins::new(inner("base")?, inner("vein")?, integer("seed", 0)? as u64, params).map_err(|e| anyhow!("{e}"))?;
        return Ok(MediumSource::Veins(veins));
    }
    if let Some(file) = table.get("voxels") {
        check_keys("voxel", &["voxels", "eta", "g"])?;
        let file = file.as_str().ok_or_else(|| anyhow!("'voxels' must be a file name"))?;
        let path = base_dir.join(file);
        let grid = VoxelGrid::read(&path).map_err(|e| anyhow!("{e}"))?;
        return Ok(MediumSource::Voxels { grid, eta: number("eta", 1.3)?, g: number("g", 0.0)? });
    }
    medium(value, mm_per_unit).map(MediumSource::Homogeneous)
}

/// The number under `key` (an integer is read as a float), or `default` when the key is absent.
fn table_number(table: &toml::Table, key: &str, default: Option<f64>) -> anyhow::Result<f64> {
    match table.get(key) {
        None => default.ok_or_else(|| anyhow!("missing key {key}", key = quote(key))),
        Some(toml::Value::Float(v)) => Ok(*v),
        Some(toml::Value::Integer(v)) => Ok(*v as f64),
        Some(other) => bail!("{key} must be a number, got {}", other.type_str(), key = quote(key)),
    }
}

/// A medium from a preset name or a table of coefficients or artist parameters.
pub fn medium(value: &toml::Value, mm_per_unit: f64) -> anyhow::Result<Medium> {
    let table = match value {
        toml::Value::String(name) => return Medium::preset(name).map_err(|e| anyhow!("{e}")),
        toml::Value::Table(t) => t,
        other => bail!("expected a preset name or a table, got {}", other.type_str()),
    };
    let number = |key: &str, default: Option<f64>| table_number(table, key, default);
    let rgb = |key: &str| -> anyhow::Result<[f64; 3]> {
        match table.get(key) {
            None => bail!("missing key {key}", key = quote(key)),
            Some(v) => Rgb::deserialize(v.clone())
                .map(Rgb::get)
                .map_err(|_| anyhow!("{key} must be a number or [r, g, b]", key = quote(key))),
        }
    };
    let artist = table.contains_key("albedo") || table.contains_key("radius");
    let known: &[&str] =
        if artist { &["albedo", "radius", "scale", "ior", "g", "mapping"] } else { &["sigma_a", "sigma_s", "eta", "g"] };
    if let Some(k) = table.keys().find(|k| !known.contains(&k.as_str())) {
        bail!(
            "unknown key '{k}' in the medium table ({} medium keys: {})",
            if artist { "artist" } else { "coefficient" },
            known.join(", ")
        );
    }
    if artist {
        let params = ArtistParams {
            albedo: rgb("albedo")?,
            radius: rgb("radius")?,
            scale: number("scale", Some(1.0))?,
            mm_per_unit,
            eta: number("ior", Some(1.4))?,
            g: number("g", Some(0.0))?,
            mapping: artist_mapping(table)?,
        };
        params.to_medium().map_err(|e| anyhow!("{e}"))
    } else {
        Medium::new(rgb("sigma_a")?, rgb("sigma_s")?, number("eta", Some(1.3))?, number("g", Some(0.0))?)
            .map_err(|e| anyhow!("{e}"))
    }
}

/// The artist table's `mapping` (default the random walk, as Cycles reads a Principled BSDF).
fn artist_mapping(table: &toml::Table) -> anyhow::Result<ArtistMapping> {
    let Some(value) = table.get("mapping") else { return Ok(ArtistMapping::default()) };
    let names = ArtistMapping::ALL.map(ArtistMapping::name).join(", ");
    let name = value.as_str().ok_or_else(|| anyhow!("'mapping' must be a string, one of {names}"))?;
    ArtistMapping::from_name(name).ok_or_else(|| anyhow!("unknown artist mapping '{name}' (one of {names})"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn media_from_tables() {
        let v: toml::Value = toml::from_str("m = { sigma_a = [0.01, 0.02, 0.03], sigma_s = 1, eta = 1.3 }").unwrap();
        let m = medium(&v["m"], 1.0).unwrap();
        assert_eq!(m.sigma_a, [0.01, 0.02, 0.03]);
        let v: toml::Value = toml::from_str("m = { albedo = [0.8, 0.6, 0.5], radius = [1, 0.5, 0.3] }").unwrap();
        assert!(medium(&v["m"], 1.0).is_ok());
        let v: toml::Value = toml::from_str("m = { albedo = [0.8, 0.6, 0.5], radius = 4, mapping = \"dipole\" }").unwrap();
        let dipole = medium(&v["m"], 1.0).unwrap();
        assert!((dipole.sigma_t_prime()[0] - 0.25).abs() < 1e-12 && dipole.eta == 1.4);
        let v: toml::Value = toml::from_str("m = { albedo = [0.8, 0.6, 0.5], radius = 4 }").unwrap();
        let walk = medium(&v["m"], 1.0).unwrap();
        assert!((walk.sigma_t_prime()[0] - std::f64::consts::PI).abs() < 1e-12 && walk.eta == 1.0);
        let v: toml::Value = toml::from_str("m = { albedo = 0.5, radius = 1, mapping = \"jensen\" }").unwrap();
        assert!(medium(&v["m"], 1.0).unwrap_err().to_string().contains("random-walk-skin"));
        let v: toml::Value = toml::from_str("m = { albedo = 0.5, radius = 1, colour = 2 }").unwrap();
        assert!(medium(&v["m"], 1.0).unwrap_err().to_string().contains("'colour'"));
        let v: toml::Value = toml::from_str("m = \"plutonium\"").unwrap();
        assert!(medium(&v["m"], 1.0).is_err());
    }

    #[test]
    fn heterogeneous_media_from_tables() {
        let parse = |text: &str| {
            let v: toml::Value = toml::from_str(text).unwrap();
            object_medium(&v["m"], 1.0, Path::new("."))
        };
        let layered =
            parse("m = { layers = [{ depth_mm = 1.5, medium = \"skin1\" }, { medium = \"skin2\" }], blend_mm = 0.3 }").unwrap();
        assert!(matches!(layered, MediumSource::Layers(_)));
        let veined =
            parse("m = { base = \"marble\", vein = { sigma_a = 0.05, sigma_s = 2, eta = 1.5 }, seed = 3, period = 8 }").unwrap();
        assert!(matches!(veined, MediumSource::Veins(_)));
        assert!(matches!(parse("m = \"marble\"").unwrap(), MediumSource::Homogeneous(_)));
        let err = |text: &str| format!("{:#}", parse(text).unwrap_err());
        let e = err("m = { layers = [{ medium = \"skin1\" }, { medium = \"skin2\" }] }");
        assert!(e.contains("layer 1: missing key 'depth_mm'"), "{e}");
        let e = err("m = { layers = [{ depth_mm = 1, medium = \"skin1\", colour = 1 }] }");
        assert!(e.contains("layer 1: unknown key 'colour'"), "{e}");
        let e = err("m = { base = \"marble\", vein = \"skin1\" }");
        assert!(e.contains("eta"), "marble (1.5) and skin1 (1.3) differ in eta: {e}");
        let e = err("m = { base = \"marble\", vein = \"marble\", octaves = -1 }");
        assert!(e.contains("'octaves'"), "{e}");
        let e = err("m = { voxels = \"missing.tcvox\" }");
        assert!(e.contains("missing.tcvox"), "{e}");
        let e = err("m = { voxels = \"a.tcvox\", sigma_a = 1 }");
        assert!(e.contains("unknown key 'sigma_a' in the voxel medium"), "{e}");
    }
}

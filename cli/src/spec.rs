//! Parsing the command line's light and medium specifications.
//!
//! A spec is `KIND:key=value,key=value,…` where a value may itself be a comma-separated vector:
//! tokens without `=` continue the previous key's value (`sun:dir=0,-1,-1,irradiance=3`).

use std::collections::BTreeMap;
use std::path::Path;
use transcut::input::quote;

use anyhow::{anyhow, bail, Context};
use transcut::light::{Environment, EquirectMap, Light};
use transcut::optics::Medium;
use transcut::DVec3;

/// `key → values` of a parameter list such as `dir=0,-1,-1,irradiance=3`.
fn parameters(text: &str) -> anyhow::Result<BTreeMap<String, Vec<String>>> {
    let mut out: BTreeMap<String, Vec<String>> = BTreeMap::new();
    let mut current: Option<String> = None;
    for token in text.split(',').map(str::trim).filter(|t| !t.is_empty()) {
        match token.split_once('=') {
            Some((k, v)) => {
                let key = k.trim().to_ascii_lowercase();
                if out.contains_key(&key) {
                    bail!("parameter {key} given twice", key = quote(&key));
                }
                out.insert(key.clone(), vec![v.trim().to_string()]);
                current = Some(key);
            }
            None => match &current {
                Some(k) => out.get_mut(k).map(|v| v.push(token.to_string())).unwrap_or_default(),
                None => bail!("{token} is not of the form key=value", token = quote(token)),
            },
        }
    }
    Ok(out)
}

fn numbers(key: &str, values: &[String]) -> anyhow::Result<Vec<f64>> {
    values.iter().map(|v| v.parse::<f64>().map_err(|_| anyhow!("{key}: {v} is not a number", v = quote(v)))).collect()
}

fn vec3(p: &BTreeMap<String, Vec<String>>, key: &str) -> anyhow::Result<DVec3> {
    let v = numbers(key, p.get(key).ok_or_else(|| anyhow!("missing {key}=X,Y,Z"))?)?;
    match v[..] {
        [x, y, z] => Ok(DVec3::new(x, y, z)),
        _ => bail!("{key} needs 3 numbers, got {}", v.len()),
    }
}

/// A colour: one number (grey) or three (RGB).
fn rgb(p: &BTreeMap<String, Vec<String>>, key: &str) -> anyhow::Result<[f64; 3]> {
    let v = numbers(key, p.get(key).ok_or_else(|| anyhow!("missing {key}=VALUE or {key}=R,G,B"))?)?;
    match v[..] {
        [g] => Ok([g; 3]),
        [r, g, b] => Ok([r, g, b]),
        _ => bail!("{key} needs 1 or 3 numbers, got {}", v.len()),
    }
}

fn scalar(p: &BTreeMap<String, Vec<String>>, key: &str, default: Option<f64>) -> anyhow::Result<f64> {
    match p.get(key) {
        Some(v) => match numbers(key, v)?[..] {
            [x] => Ok(x),
            _ => bail!("{key} needs one number"),
        },
        None => default.ok_or_else(|| anyhow!("missing {key}=VALUE")),
    }
}

fn reject_unknown(p: &BTreeMap<String, Vec<String>>, known: &[&str], kind: &str) -> anyhow::Result<()> {
    if let Some(k) = p.keys().find(|k| !known.contains(&k.as_str())) {
        bail!("{kind} light has no parameter {k} (known: {})", known.join(", "), k = quote(k));
    }
    Ok(())
}

/// Parses a `--light` spec (see the `bake --help` text for the forms).
pub fn light(spec: &str) -> anyhow::Result<Light> {
    let (kind, rest) = spec.split_once(':').ok_or_else(|| anyhow!("{spec}: expected KIND:key=value,…", spec = quote(spec)))?;
    let p = parameters(rest).with_context(|| format!("in --light {spec}"))?;
    let kind = kind.trim().to_ascii_lowercase();
    let light = match kind.as_str() {
        "sun" | "directional" => {
            reject_unknown(&p, &["dir", "irradiance", "angle"], "a sun")?;
            Light::Directional {
                direction: vec3(&p, "dir")?,
                irradiance: rgb(&p, "irradiance")?,
                angular_diameter_deg: scalar(&p, "angle", Some(0.0))?,
            }
        }
        "point" => {
            reject_unknown(&p, &["pos", "intensity"], "a point")?;
            Light::Point { position: vec3(&p, "pos")?, intensity: rgb(&p, "intensity")? }
        }
        "spot" => {
            reject_unknown(&p, &["pos", "dir", "intensity", "angle", "blend"], "a spot")?;
            Light::Spot {
                position: vec3(&p, "pos")?,
                direction: vec3(&p, "dir")?,
                intensity: rgb(&p, "intensity")?,
                cone_half_angle_deg: scalar(&p, "angle", Some(30.0))?,
                blend: scalar(&p, "blend", Some(0.15))?,
            }
        }
        "env" | "environment" => {
            reject_unknown(&p, &["radiance", "file", "strength"], "an environment")?;
            match p.get("file") {
                Some(file) => {
                    let path = file.join(",");
                    let strength = scalar(&p, "strength", Some(1.0))?;
                    let map = EquirectMap::load(Path::new(&path), strength).with_context(|| format!("loading {path}"))?;
                    Light::Environment(Environment::Equirect(map))
                }
                None => Light::Environment(Environment::Constant(rgb(&p, "radiance")?)),
            }
        }
        other => bail!("unknown light kind {other} (sun, point, spot, env)", other = quote(other)),
    };
    light.validate(0).map_err(|e| anyhow!("--light {spec}: {e}"))?;
    Ok(light)
}

/// Parses a `--medium` spec: a preset name, or `sigma_a=R,G,B:sigma_s=R,G,B:eta=E[:g=G]` in mm⁻¹
/// (σ′s, the reduced scattering coefficient).
pub fn medium(spec: &str) -> anyhow::Result<Medium> {
    if !spec.contains('=') {
        return Medium::preset(spec).map_err(|e| anyhow!("{e}"));
    }
    let mut p = BTreeMap::new();
    for part in spec.split(':') {
        for (k, v) in parameters(part)? {
            if p.insert(k.clone(), v).is_some() {
                bail!("parameter {k} given twice", k = quote(&k));
            }
        }
    }
    if let Some(k) = p.keys().find(|k| !["sigma_a", "sigma_s", "eta", "g"].contains(&k.as_str())) {
        bail!("a medium has no parameter {k} (sigma_a, sigma_s, eta, g)", k = quote(k));
    }
    let medium =
        Medium::new(rgb(&p, "sigma_a")?, rgb(&p, "sigma_s")?, scalar(&p, "eta", Some(1.3))?, scalar(&p, "g", Some(0.0))?)
            .map_err(|e| anyhow!("--medium {spec}: {e}"))?;
    Ok(medium)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sun_spec_with_vector_values() {
        let l = light("sun:dir=0,-1,-1,irradiance=3").unwrap();
        match l {
            Light::Directional { direction, irradiance, angular_diameter_deg } => {
                assert_eq!(direction, DVec3::new(0.0, -1.0, -1.0));
                assert_eq!(irradiance, [3.0; 3]);
                assert_eq!(angular_diameter_deg, 0.0);
            }
            _ => panic!("{l:?}"),
        }
        assert!(matches!(light("point:pos=0,0,100,intensity=1,2,3").unwrap(), Light::Point { intensity: [1.0, 2.0, 3.0], .. }));
        assert!(matches!(light("env:radiance=0.5").unwrap(), Light::Environment(Environment::Constant([0.5, 0.5, 0.5]))));
    }

    #[test]
    fn bad_light_specs_say_what_is_wrong() {
        for (spec, words) in [
            ("sun", "KIND:key=value"),
            ("laser:pos=0,0,0", "unknown light kind"),
            ("sun:dir=0,1,irradiance=1", "3 numbers"),
            ("sun:dir=0,0,-1,irradiance=x", "not a number"),
            ("sun:dir=0,0,-1,irradiance=1,colour=2", "no parameter 'colour'"),
            ("point:intensity=1", "missing pos"),
            ("sun:dir=0,0,0,irradiance=1", "dir"),
        ] {
            let err = format!("{:#}", light(spec).unwrap_err());
            assert!(err.contains(words), "{spec}: {err}");
        }
    }

    #[test]
    fn media_by_name_and_by_coefficients() {
        assert_eq!(medium("marble").unwrap(), Medium::preset("marble").unwrap());
        let m = medium("sigma_a=0.01,0.02,0.03:sigma_s=1,2,3:eta=1.4").unwrap();
        assert_eq!(m.sigma_a, [0.01, 0.02, 0.03]);
        assert_eq!(m.sigma_s_prime, [1.0, 2.0, 3.0]);
        assert_eq!(m.eta, 1.4);
        assert!(format!("{:#}", medium("sigma_a=-1:sigma_s=1").unwrap_err()).contains("sigma_a"));
        assert!(format!("{:#}", medium("jello").unwrap_err()).contains("marble"));
    }
}

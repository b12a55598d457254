//! A CPU rasteriser for headless images of baked objects: per-vertex radiance seen through the
//! Fresnel boundary, specular highlights, a ground plane, tone mapping, PNG and OpenEXR output.
//!
//! # What a pixel shows
//!
//! A bake returns, per vertex, the radiance Lo(x, n) leaving the surface along its normal
//! (ARCHITECTURE.md, "What a bake returns"). Towards a viewer in direction ωo the subsurface
//! radiance is Lo(x, ωo) = Lo(x, n) · Ft(η, ωo)/Ft(η, n), Ft(η, ω) = T(η, θ)/η² with T the exact
//! unpolarised Fresnel transmittance out of the medium ([`crate::optics::ft_out`]), so an object
//! darkens towards its silhouette exactly as the diffusion model says. Per sample the renderer
//! computes
//!
//! L = Lo(x, n) · Ft(η, n·ωo)/Ft(η, 1) + R(η, θo) L_env + Σ_l f_GGX(ωo, l) E_l (n·l),
//!
//! where Lo(x, n) and the normal n are interpolated from the vertices with perspective-correct
//! barycentrics, R = 1 − T is the exact Fresnel reflectance ([`crate::optics::fresnel_reflectance`]),
//! L_env an optional constant environment ([`RenderScene::environment`]), and f_GGX a
//! Cook–Torrance GGX lobe with Smith masking and the exact Fresnel term for each
//! [`SpecularLight`] ([`ggx_specular`]). An optional [`GroundPlane`] is a flat Lambertian floor
//! lit without shadows; everything else is the background colour.
//!
//! # How it is drawn
//!
//! Triangles are clipped against the near plane and a guard band, snapped to 1/256 pixel and
//! rasterised with exact integer edge functions and the top-left fill rule into a 1/w z-buffer
//! at every supersample ([`SamplePattern`]). Each triangle is shaded once per pixel at the
//! centroid of the samples it covers there, or at every sample ([`Shading`]), and the samples
//! are filtered into pixels ([`Filter`]). The image is cut into 32 × 32 tiles rendered in parallel with rayon;
//! every tile is a pure function of the inputs, and depth ties go to the triangle listed first,
//! so the image is bit-identical whatever the number of threads.
//!
//! [`Image`] holds linear RGB with the exposure 2^EV applied, plus alpha = coverage of the
//! objects. [`Image::save_exr`] writes it as it is (32-bit float RGBA); [`Image::save_png`]
//! applies the ACES fitted tone curve ([`aces_fitted`]) and the sRGB OETF ([`srgb_oetf`]).
//!
//! # Example
//!
//! A square of baked radiance 0.5 seen head-on: the centre pixel shows 0.5.
//!
//! ```
//! use transcut::render::{render, Camera, RenderObject, RenderOptions, RenderScene};
//! use transcut::DVec3;
//!
//! let positions = [
//!     DVec3::new(-1.0, -1.0, 0.0),
//!     DVec3::new(1.0, -1.0, 0.0),
//!     DVec3::new(1.0, 1.0, 0.0),
//!     DVec3::new(-1.0, 1.0, 0.0),
//! ];
//! let triangles = [[0, 1, 2], [0, 2, 3]];
//! let radiance = [[0.5; 3]; 4];
//! let camera = Camera::frame(
//!     DVec3::new(-1.0, -1.0, 0.0),
//!     DVec3::new(1.0, 1.0, 0.0),
//!     DVec3::NEG_Z, // looking down −z at the square
//!     DVec3::Y,
//!     40.0,
//!     64,
//!     48,
//! )?;
//! let scene = RenderScene {
//!     camera,
//!     objects: vec![RenderObject { positions: &positions, triangles: &triangles, radiance: &radiance, normals: None, eta: 1.3 }],
//!     lights: vec![],
//!     environment: None,
//!     ground: None,
//! };
//! let image = render(&scene, &RenderOptions::default())?;
//! let centre = image.pixel(32, 24).unwrap();
//! assert!((centre[0] - 0.5).abs() < 1e-3 && centre[3] == 1.0);
//! # Ok::<(), transcut::render::RenderError>(())
//! ```

mod camera;
mod error;
mod output;
mod raster;
mod scene;
mod shade;

use std::borrow::Cow;

use glam::DVec3;
use rayon::prelude::*;

pub use camera::Camera;
pub use error::RenderError;
pub use output::{aces_fitted, srgb_oetf, Image, ToneMap};
pub use scene::{
    area_weighted_normals, AlphaMode, Filter, GroundPlane, RenderObject, RenderOptions, RenderScene, SamplePattern, Shading,
    SpecularLight, MAX_GRID, MIN_ROUGHNESS,
};
pub use shade::{ggx_distribution, ggx_specular, view_factor};

use camera::CameraFrame;
use raster::{fixed_offsets, setup_triangle, SampleBuffer, ScreenTri, Viewport, GROUND, MAX_SAMPLES, NO_PRIM, ONE, TILE};
use shade::Lighting;

/// Largest image width or height, in pixels.
pub const MAX_DIMENSION: u32 = 16_384;

/// The near clipping plane sits at this fraction of the farthest view depth in the scene.
const NEAR_FRACTION: f64 = 1e-6;

/// Triangles per parallel work item in triangle setup.
const SETUP_CHUNK: usize = 4096;

/// An object ready to shade: its mesh, normals and the clip coordinates of its vertices.
struct Prepared<'a> {
    positions: &'a [DVec3],
    triangles: &'a [[u32; 3]],
    radiance: &'a [[f64; 3]],
    normals: Cow<'a, [DVec3]>,
    clip: Vec<DVec3>,
    eta: f64,
    /// 1/Ft(η, n) = η²/T(η, 0).
    inv_ft_normal: f64,
}

/// Everything a tile needs, shared read-only by all tiles.
struct TileContext<'a> {
    objects: &'a [Prepared<'a>],
    tris: &'a [ScreenTri],
    bins: &'a [Vec<u32>],
    offsets: &'a [[i64; 2]],
    /// Mean of the sample offsets in fixed-point units: where a pixel covered by one triangle
    /// is shaded (computed as the per-triangle centroids are).
    offset_mean: (f64, f64),
    /// Resolve weights: (dx, dy, sample, weight), normalised to sum to 1.
    weights: &'a [(i32, i32, usize, f64)],
    /// The distinct (dx, dy) of `weights`: the neighbouring pixels the filter reaches.
    neighbours: &'a [(i32, i32)],
    lighting: &'a Lighting,
    shading: Shading,
    eye: DVec3,
    background: DVec3,
    ground_radiance: DVec3,
    ground_alpha: f64,
    exposure: f64,
    width: i32,
    height: i32,
    apron: i32,
    tiles_x: i32,
}

/// Renders the scene.
///
/// # Errors
/// Any input problem, as the [`RenderError`] variant naming it: [`RenderError::InvalidSize`],
/// [`RenderError::InvalidCamera`], [`RenderError::InvalidOption`], [`RenderError::InvalidLight`],
/// [`RenderError::InvalidEta`], [`RenderError::LengthMismatch`], [`RenderError::InvalidVertex`],
/// [`RenderError::IndexOutOfRange`], or [`RenderError::TooManyTriangles`]. Nothing is drawn
/// when an input is invalid.
pub fn render(scene: &RenderScene<'_>, options: &RenderOptions) -> Result<Image, RenderError> {
    options.validate()?;
    let frame = scene.camera.derive()?;
    scene.validate_lighting()?;
    for (i, o) in scene.objects.iter().enumerate() {
        o.validate(i)?;
    }
    let too_many = |count: usize| RenderError::TooManyTriangles { count, max: NO_PRIM as usize - 1 };
    let total: usize = scene.objects.iter().map(|o| o.triangles.len()).sum();
    if scene.objects.len() >= GROUND as usize || total >= NO_PRIM as usize {
        return Err(too_many(total));
    }

    let to_clip = |p: DVec3| frame.view_to_clip(frame.world_to_view(p));
    let objects: Vec<Prepared<'_>> = scene
        .objects
        .iter()
        .map(|o| Prepared {
            positions: o.positions,
            triangles: o.triangles,
            radiance: o.radiance,
            normals: o.shading_normals(),
            clip: o.positions.par_iter().map(|&p| to_clip(p)).collect(),
            eta: o.eta,
            inv_ft_normal: 1.0 / crate::optics::ft_out(o.eta, 1.0),
        })
        .collect();
    let ground_clip = scene.ground.map(|g| g.corners().map(to_clip));

    // The near plane: a small fraction of the farthest depth, so that nothing visible is clipped
    // and 1/w stays well conditioned (no far plane is needed for a 1/w z-buffer).
    let max_depth =
        objects.iter().flat_map(|o| o.clip.iter()).chain(ground_clip.iter().flatten()).map(|c| c.z).fold(0.0f64, f64::max);
    let apron = match options.filter {
        Filter::Box => 0,
        Filter::Tent => 1,
    };
    let (width, height) = (scene.camera.width as i32, scene.camera.height as i32);
    let vp = Viewport {
        width,
        height,
        apron,
        near: if max_depth > 0.0 { NEAR_FRACTION * max_depth } else { 1.0 },
        cull_back_faces: options.cull_back_faces,
    };

    // Triangle setup, in parallel chunks collected in order: the list (and so every tie-break)
    // is the same whatever the number of threads.
    let mut tris: Vec<ScreenTri> = Vec::new();
    for (oi, o) in objects.iter().enumerate() {
        let chunks: Vec<Vec<ScreenTri>> = o
            .triangles
            .par_chunks(SETUP_CHUNK)
            .enumerate()
            .map(|(ci, chunk)| {
                let mut out = Vec::with_capacity(chunk.len());
                for (j, t) in chunk.iter().enumerate() {
                    let clip = t.map(|v| o.clip[v as usize]);
                    let index = (ci * SETUP_CHUNK + j) as u32;
                    setup_triangle(clip, oi as u32, index, &frame, &vp, &mut out);
                }
                out
            })
            .collect();
        for c in chunks {
            tris.extend(c);
        }
    }
    // The ground goes last, so an object resting on it wins depth ties.
    if let Some(c) = ground_clip {
        setup_triangle([c[0], c[1], c[2]], GROUND, 0, &frame, &vp, &mut tris);
        setup_triangle([c[0], c[2], c[3]], GROUND, 1, &frame, &vp, &mut tris);
    }
    if tris.len() >= NO_PRIM as usize {
        return Err(too_many(tris.len()));
    }

    let tiles_x = (width + TILE - 1) / TILE;
    let tiles_y = (height + TILE - 1) / TILE;
    let bins = bin_triangles(&tris, tiles_x, tiles_y, apron);

    let offsets_f = options.samples.offsets();
    let offsets = fixed_offsets(&offsets_f);
    let weights = resolve_weights(&offsets, options.filter);
    let mut neighbours: Vec<(i32, i32)> = weights.iter().map(|w| (w.0, w.1)).collect();
    neighbours.sort_unstable();
    neighbours.dedup();
    let lighting = Lighting {
        lights: scene.lights.iter().map(|l| (l.direction_to_light.normalize(), DVec3::from(l.irradiance))).collect(),
        environment: scene.environment.map(DVec3::from),
        alpha: options.specular_roughness * options.specular_roughness,
    };
    let ground_radiance = scene.ground.map_or(DVec3::ZERO, |g| DVec3::from(g.radiance(&scene.lights, scene.environment)));
    let ctx = TileContext {
        objects: &objects,
        tris: &tris,
        bins: &bins,
        offsets: &offsets,
        offset_mean: {
            let n = offsets.len() as f64;
            let sum = offsets.iter().fold((0i64, 0i64), |a, o| (a.0 + o[0], a.1 + o[1]));
            (sum.0 as f64 / n, sum.1 as f64 / n)
        },
        weights: &weights,
        neighbours: &neighbours,
        lighting: &lighting,
        shading: options.shading,
        eye: frame.position,
        background: DVec3::from(options.background),
        ground_radiance,
        ground_alpha: match options.alpha {
            AlphaMode::Objects => 0.0,
            AlphaMode::ObjectsAndGround => 1.0,
        },
        exposure: options.exposure_ev.exp2(),
        width,
        height,
        apron,
        tiles_x,
    };

    let tiles: Vec<Vec<[f32; 4]>> = (0..tiles_x * tiles_y)
        .into_par_iter()
        .map_init(TileScratch::default, |scratch, t| render_tile(&ctx, &frame, t, scratch))
        .collect();

    let mut rgba = vec![[0f32; 4]; width as usize * height as usize];
    for (t, pixels) in tiles.iter().enumerate() {
        let (x0, y0, tw, _) = tile_rect(t as i32, tiles_x, width, height);
        for (r, row) in pixels.chunks(tw as usize).enumerate() {
            let start = (y0 as usize + r) * width as usize + x0 as usize;
            rgba[start..start + row.len()].copy_from_slice(row);
        }
    }
    Ok(Image { width: scene.camera.width, height: scene.camera.height, rgba })
}

/// Pixel rectangle (x0, y0, w, h) of tile `t`.
fn tile_rect(t: i32, tiles_x: i32, width: i32, height: i32) -> (i32, i32, i32, i32) {
    let (x0, y0) = ((t % tiles_x) * TILE, (t / tiles_x) * TILE);
    (x0, y0, TILE.min(width - x0), TILE.min(height - y0))
}

/// For every tile, the indices of the screen triangles whose pixel bounds reach it (or its
/// apron), in ascending order.
fn bin_triangles(tris: &[ScreenTri], tiles_x: i32, tiles_y: i32, apron: i32) -> Vec<Vec<u32>> {
    let mut bins = vec![Vec::new(); (tiles_x * tiles_y) as usize];
    for (i, t) in tris.iter().enumerate() {
        let [x0, y0, x1, y1] = t.bounds;
        let tx0 = (x0 - apron).div_euclid(TILE).max(0);
        let ty0 = (y0 - apron).div_euclid(TILE).max(0);
        let tx1 = (x1 + apron).div_euclid(TILE).min(tiles_x - 1);
        let ty1 = (y1 + apron).div_euclid(TILE).min(tiles_y - 1);
        for ty in ty0..=ty1 {
            for tx in tx0..=tx1 {
                bins[(ty * tiles_x + tx) as usize].push(i as u32);
            }
        }
    }
    bins
}

/// The reconstruction weights: for each pixel, the samples of the pixels at (dx, dy) from it
/// that the filter reaches, with weights normalised to sum to 1.
fn resolve_weights(offsets: &[[i64; 2]], filter: Filter) -> Vec<(i32, i32, usize, f64)> {
    let mut w = Vec::new();
    match filter {
        Filter::Box => {
            for s in 0..offsets.len() {
                w.push((0, 0, s, 1.0));
            }
        }
        Filter::Tent => {
            let tent = |t: f64| (1.0 - t.abs()).max(0.0);
            for dy in -1..=1 {
                for dx in -1..=1 {
                    for (s, o) in offsets.iter().enumerate() {
                        // Offset of the sample from the pixel centre, in pixels.
                        let rx = f64::from(dx) + o[0] as f64 / ONE as f64 - 0.5;
                        let ry = f64::from(dy) + o[1] as f64 / ONE as f64 - 0.5;
                        let weight = tent(rx) * tent(ry);
                        if weight > 0.0 {
                            w.push((dx, dy, s, weight));
                        }
                    }
                }
            }
        }
    }
    let total: f64 = w.iter().map(|e| e.3).sum();
    for e in &mut w {
        e.3 /= total;
    }
    w
}

/// Per-thread buffers reused across tiles.
#[derive(Default)]
struct TileScratch {
    samples: SampleBuffer,
    /// Shaded sample radiance (linear, before exposure).
    colour: Vec<DVec3>,
    /// Per sample: 0 background, 1 ground, 2 object.
    kind: Vec<u8>,
    /// Per-pixel shading groups.
    groups: Vec<Group>,
    /// Per buffer pixel: the kind shared by all its samples if that is background or ground,
    /// else [`MIXED`].
    uniform: Vec<u8>,
}

const KIND_BACKGROUND: u8 = 0;
const KIND_GROUND: u8 = 1;
const KIND_OBJECT: u8 = 2;
/// A pixel whose samples are not all background or all ground.
const MIXED: u8 = u8::MAX;

/// Rasterises, shades and resolves one tile; returns its pixels row by row.
fn render_tile(ctx: &TileContext<'_>, frame: &CameraFrame, t: i32, scratch: &mut TileScratch) -> Vec<[f32; 4]> {
    let (x0, y0, tw, th) = tile_rect(t, ctx.tiles_x, ctx.width, ctx.height);
    let bin = &ctx.bins[t as usize];
    if bin.is_empty() {
        return vec![ctx.background_pixel(); (tw * th) as usize];
    }
    let a = ctx.apron;
    scratch.samples.reset(x0 - a, y0 - a, tw + 2 * a, th + 2 * a, ctx.offsets.len());
    for &id in bin {
        scratch.samples.rasterise(&ctx.tris[id as usize], id, ctx.offsets);
    }
    shade_tile(ctx, frame, scratch);
    resolve_tile(ctx, scratch, (x0, y0, tw, th))
}

/// Shades every covered sample of the tile's buffer into `scratch.colour` and `scratch.kind`.
/// Colours are read only where `kind` says something was drawn, so the colour buffer needs no
/// clearing.
#[inline(never)]
fn shade_tile(ctx: &TileContext<'_>, frame: &CameraFrame, scratch: &mut TileScratch) {
    let buf = &scratch.samples;
    let ns = buf.samples;
    let n = buf.prim.len();
    if scratch.colour.len() < n {
        scratch.colour.resize(n, DVec3::ZERO);
    }
    scratch.kind.clear();
    scratch.kind.resize(n, KIND_BACKGROUND);
    scratch.uniform.clear();
    for py in buf.y0..buf.y0 + buf.h {
        for px in buf.x0..buf.x0 + buf.w {
            let base = buf.index(px, py, 0);
            let prims = &buf.prim[base..base + ns];
            let colour = &mut scratch.colour[base..base + ns];
            let kind = &mut scratch.kind[base..base + ns];
            let origin = (i64::from(px) * ONE, i64::from(py) * ONE);
            match ctx.shading {
                Shading::PerSample => {
                    for (s, &prim) in prims.iter().enumerate() {
                        if prim == NO_PRIM {
                            continue;
                        }
                        let o = ctx.offsets[s];
                        let at = ((origin.0 + o[0]) as f64, (origin.1 + o[1]) as f64);
                        (colour[s], kind[s]) = shade_prim(ctx, frame, prim, at);
                    }
                }
                Shading::PerPixel => {
                    shade_pixel(ctx, frame, origin, prims, colour, kind, &mut scratch.groups);
                }
            }
            // Pixels wholly background or wholly ground have a constant colour.
            let k0 = kind[0];
            let uniform = k0 != KIND_OBJECT && kind.iter().all(|&k| k == k0);
            scratch.uniform.push(if uniform { k0 } else { MIXED });
        }
    }
}

/// Filters the shaded samples into the tile's pixels (rectangle `(x0, y0, w, h)`), summing the
/// weighted samples in a fixed order; applies the exposure.
#[inline(never)]
fn resolve_tile(ctx: &TileContext<'_>, scratch: &TileScratch, (x0, y0, tw, th): (i32, i32, i32, i32)) -> Vec<[f32; 4]> {
    let buf = &scratch.samples;
    let bg_pixel = ctx.background_pixel();
    // Sample index of each weight relative to the pixel's first sample.
    let origin = buf.index(x0, y0, 0) as isize;
    let rel: Vec<(isize, f64)> =
        ctx.weights.iter().map(|&(dx, dy, s, w)| (buf.index(x0 + dx, y0 + dy, s) as isize - origin, w)).collect();
    // Pixel index (in the buffer) of each neighbour the filter reaches, relative to the pixel.
    let neighbours: Vec<isize> = ctx.neighbours.iter().map(|&(dx, dy)| (dy * buf.w + dx) as isize).collect();
    let ground = ctx.ground_radiance * ctx.exposure;
    let ground_pixel = [ground.x as f32, ground.y as f32, ground.z as f32, ctx.ground_alpha as f32];
    let mut out = Vec::with_capacity((tw * th) as usize);
    for py in y0..y0 + th {
        for px in x0..x0 + tw {
            // Where every sample the filter reaches is background, or every one is ground, the
            // pixel is that constant exactly.
            let p = ((py - buf.y0) * buf.w + (px - buf.x0)) as isize;
            let u = scratch.uniform[(p + neighbours[0]) as usize];
            if u != MIXED && neighbours.iter().all(|&q| scratch.uniform[(p + q) as usize] == u) {
                out.push(if u == KIND_GROUND { ground_pixel } else { bg_pixel });
                continue;
            }
            let base = buf.index(px, py, 0) as isize;
            let mut sum = DVec3::ZERO;
            let mut alpha = 0.0;
            let (mut any_drawn, mut all_covered) = (false, true);
            for &(r, w) in &rel {
                let idx = (base + r) as usize;
                let kind = scratch.kind[idx];
                let (colour, covered) = match kind {
                    KIND_OBJECT => (scratch.colour[idx], 1.0),
                    KIND_GROUND => (ctx.ground_radiance, ctx.ground_alpha),
                    _ => (ctx.background, 0.0),
                };
                sum += colour * w;
                alpha += covered * w;
                any_drawn |= kind != KIND_BACKGROUND;
                all_covered &= covered == 1.0;
            }
            if !any_drawn {
                out.push(bg_pixel);
                continue;
            }
            // Exactly 1 where the filter saw only covered samples (and 0, above, where it saw
            // only background).
            let alpha = if all_covered { 1.0 } else { alpha.clamp(0.0, 1.0) };
            let c = sum * ctx.exposure;
            out.push([c.x as f32, c.y as f32, c.z as f32, alpha as f32]);
        }
    }
    out
}

impl TileContext<'_> {
    /// A background pixel: the exposed background colour with alpha 0.
    fn background_pixel(&self) -> [f32; 4] {
        let c = self.background * self.exposure;
        [c.x as f32, c.y as f32, c.z as f32, 0.0]
    }
}

/// Shades one pixel's samples once per triangle: the samples are grouped by the triangle that
/// covers them (in sample order), each group is shaded at the centroid of its samples, and the
/// value is written to every sample of the group. `groups` is scratch space.
fn shade_pixel(
    ctx: &TileContext<'_>,
    frame: &CameraFrame,
    origin: (i64, i64),
    prims: &[u32],
    colour: &mut [DVec3],
    kind: &mut [u8],
    groups: &mut Vec<Group>,
) {
    // The common case: one triangle (or the ground, or nothing) covers the whole pixel.
    let first = prims[0];
    if prims.iter().all(|&p| p == first) {
        if first == NO_PRIM {
            return;
        }
        if ctx.tris[first as usize].object == GROUND {
            // The resolve reads the ground's constant radiance; only the kind is needed.
            kind.fill(KIND_GROUND);
            return;
        }
        let at = (origin.0 as f64 + ctx.offset_mean.0, origin.1 as f64 + ctx.offset_mean.1);
        let (c, k) = shade_prim(ctx, frame, first, at);
        colour.fill(c);
        kind.fill(k);
        return;
    }
    groups.clear();
    let mut group_of = [0u8; MAX_SAMPLES];
    for (s, &prim) in prims.iter().enumerate() {
        if prim == NO_PRIM {
            continue;
        }
        let g = match groups.iter().position(|g| g.prim == prim) {
            Some(g) => g,
            None => {
                groups.push(Group { prim, sum_x: 0, sum_y: 0, count: 0, colour: DVec3::ZERO, kind: 0 });
                groups.len() - 1
            }
        };
        let o = ctx.offsets[s];
        let group = &mut groups[g];
        group.sum_x += o[0];
        group.sum_y += o[1];
        group.count += 1;
        group_of[s] = g as u8;
    }
    for g in groups.iter_mut() {
        let c = g.count as f64;
        let at = (origin.0 as f64 + g.sum_x as f64 / c, origin.1 as f64 + g.sum_y as f64 / c);
        (g.colour, g.kind) = shade_prim(ctx, frame, g.prim, at);
    }
    for (s, &prim) in prims.iter().enumerate() {
        if prim != NO_PRIM {
            let g = &groups[group_of[s] as usize];
            (colour[s], kind[s]) = (g.colour, g.kind);
        }
    }
}

/// The samples of one pixel covered by one screen triangle, and their shared shading.
struct Group {
    prim: u32,
    /// Sums of the samples' fixed-point offsets in the pixel.
    sum_x: i64,
    sum_y: i64,
    count: i64,
    colour: DVec3,
    kind: u8,
}

/// Radiance and kind of the surface of screen triangle `prim` at a point in fixed-point pixel
/// units.
fn shade_prim(ctx: &TileContext<'_>, frame: &CameraFrame, prim: u32, at: (f64, f64)) -> (DVec3, u8) {
    let tri = &ctx.tris[prim as usize];
    if tri.object == GROUND {
        return (ctx.ground_radiance, KIND_GROUND);
    }
    let o = &ctx.objects[tri.object as usize];
    let b = tri.barycentric_at(at.0, at.1);
    let [i0, i1, i2] = o.triangles[tri.triangle as usize].map(|v| v as usize);
    let p = o.positions[i0] * b.x + o.positions[i1] * b.y + o.positions[i2] * b.z;
    let n = o.normals[i0] * b.x + o.normals[i1] * b.y + o.normals[i2] * b.z;
    let n = n.try_normalize().unwrap_or_else(|| {
        // No usable vertex normals here: use the face normal.
        (o.positions[i1] - o.positions[i0]).cross(o.positions[i2] - o.positions[i0]).normalize_or_zero()
    });
    let r = |i: usize| DVec3::from(o.radiance[i]);
    let baked = r(i0) * b.x + r(i1) * b.y + r(i2) * b.z;
    let v = (ctx.eye - p).try_normalize().unwrap_or(-frame.forward);
    (ctx.lighting.shade(baked, n, v, o.eta, o.inv_ft_normal), KIND_OBJECT)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resolve_weights_sum_to_one() {
        for pattern in [SamplePattern::Centre, SamplePattern::RotatedGrid4, SamplePattern::Grid(3)] {
            let off = fixed_offsets(&pattern.offsets());
            for filter in [Filter::Box, Filter::Tent] {
                let w = resolve_weights(&off, filter);
                let total: f64 = w.iter().map(|e| e.3).sum();
                assert!((total - 1.0).abs() < 1e-12);
                assert!(w.iter().all(|e| e.3 > 0.0 && e.0.abs() <= 1 && e.1.abs() <= 1));
            }
        }
        // The box filter sees only the pixel's own samples.
        let w = resolve_weights(&fixed_offsets(&SamplePattern::Grid(2).offsets()), Filter::Box);
        assert_eq!(w.len(), 4);
        assert!(w.iter().all(|e| e.0 == 0 && e.1 == 0 && e.3 == 0.25));
    }

    #[test]
    fn binning_reaches_the_apron() {
        let tri = ScreenTri {
            x: [0; 3],
            y: [0; 3],
            area: 1,
            inv_w: [1.0; 3],
            bary: [DVec3::X, DVec3::Y, DVec3::Z],
            object: 0,
            triangle: 0,
            bounds: [TILE, 0, TILE + 2, 3],
        };
        let bins = bin_triangles(&[tri], 3, 2, 0);
        assert_eq!(bins.iter().map(Vec::len).collect::<Vec<_>>(), vec![0, 1, 0, 0, 0, 0]);
        let bins = bin_triangles(&[tri], 3, 2, 1);
        assert_eq!(bins.iter().map(Vec::len).collect::<Vec<_>>(), vec![1, 1, 0, 0, 0, 0]);
    }
}

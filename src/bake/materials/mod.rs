//! The `materials` stage: how each glossy material reflects (Bastos et al. §8.2, Luksch et
//! al. §3–7), baked for every material that has a glossy lobe and covers some triangle.
//!
//! Per lobe of such a material (`materials/<material>/lobe<k>-…`):
//! - `kernel.exr` (kind `kernel`): K, D·G over the reflected image, sums to 1 ([`kernel`]);
//! - `reflectance.exr` (kind `reflectance-sphere`): R and the albedo A as a sphere map;
//! - `reflectance-1d.exr` (kind `reflectance-1d`, isotropic lobes): the same as a 1D map
//!   dense at grazing angles ([`reflectance`]);
//! - `pattern.bin` (kind `sample-pattern`): the regular pattern closest to the sample budget
//!   ([`format`] specifies the file).
//!
//! Per `curved` reflector with a glossy material (`materials/env/<reflector>/mip<ℓ>.exr`,
//! kind `env-mip`): the cube map seen from its centroid, shaded with D, and its MIP levels
//! ([`envmap`]). These need the bundle's `radiosity` stage; without it they are skipped with
//! the reason and the rest of the stage is baked.
//!
//! `materials/index.json` (kind `materials-index`) lists everything with its parameters.
//! EXR channels are f32 for K and R (exact sums, large grazing values), half for env maps.
//! The bake is deterministic: every work item is a pure function of the scene and settings,
//! results are gathered in order, so the bytes do not depend on the thread count.

pub mod envmap;
pub mod format;
pub mod kernel;
pub mod reflectance;

use std::collections::BTreeMap;
use std::path::Path;
use std::time::Instant;

use glam::{DVec3, Vec3};
use rayon::prelude::*;
use serde::Serialize;

use crate::brdf::Lobe;
use crate::brdf::pattern::{Pattern, closest_pattern};
use crate::bundle::{Bundle, BundleError, StageInfo, StageRecord, StageWriter};
use crate::geometry::Hit;
use crate::image_io::{
    ChannelData, ExrCompression, ImageError, Precision, encode_exr, encode_rgb_exr,
};
use crate::progress::{Cancelled, Progress};
use crate::scene::desc::{MaterialsOverride, SettingError};
use crate::scene::{Quality, ReflectorKind, Scene};

use self::envmap::{CaptureSettings, MipFilter, MipPyramid, capture_cube};
use self::kernel::{Kernel, KernelSettings, kernel_for};
use self::reflectance::{ReflectanceMap, map_1d, sphere_map};
use super::{Stage, plan};

/// Settings of the materials stage (a preset, then the scene's `bake.materials` overrides).
#[derive(Clone, Debug, PartialEq, Serialize, serde::Deserialize)]
pub struct MaterialsSettings {
    /// Samples per lobe the regular pattern should come closest to.
    pub sample_budget: u32,
    /// Density threshold ξ₀ of the patterns (Eq. 11).
    pub xi0: f32,
    /// Most circles tried when matching the budget.
    pub max_circles: u32,
    /// Finest angle a kernel texel subtends, degrees.
    pub kernel_texel_deg: f32,
    /// Largest kernel radius in texels.
    pub kernel_max_radius: u32,
    /// Sphere-map size of R, texels.
    pub sphere_map_size: u32,
    /// 1D-map size of R, texels.
    pub map_1d_size: u32,
    /// Albedo channel: sample grid per axis.
    pub albedo_steps: u32,
    /// Environment-map face size, texels (a power of two).
    pub env_map_size: u32,
    /// MIP filter of environment maps.
    pub env_filter: MipFilter,
    /// Environment-map rays per texel and axis.
    pub env_supersample: u32,
}

impl MaterialsSettings {
    /// The preset's values. Pattern budgets follow Luksch §8 (about 20 samples per pixel
    /// are affordable; ξ₀ = 0.2 at 14–17 samples, smaller at larger budgets); kernel pitch
    /// and R-map sizes double with each preset.
    pub fn preset(quality: Quality) -> MaterialsSettings {
        match quality {
            Quality::Draft => MaterialsSettings {
                sample_budget: 14,
                xi0: 0.2,
                max_circles: 64,
                kernel_texel_deg: 0.5,
                kernel_max_radius: 7,
                sphere_map_size: 64,
                map_1d_size: 64,
                albedo_steps: 16,
                env_map_size: 64,
                env_filter: MipFilter::Box2,
                env_supersample: 1,
            },
            Quality::Default => MaterialsSettings {
                sample_budget: 20,
                xi0: 0.1,
                max_circles: 64,
                kernel_texel_deg: 0.25,
                kernel_max_radius: 15,
                sphere_map_size: 128,
                map_1d_size: 128,
                albedo_steps: 32,
                env_map_size: 128,
                env_filter: MipFilter::Gauss6,
                env_supersample: 2,
            },
            Quality::High => MaterialsSettings {
                sample_budget: 64,
                xi0: 0.05,
                max_circles: 64,
                kernel_texel_deg: 0.125,
                kernel_max_radius: 31,
                sphere_map_size: 256,
                map_1d_size: 256,
                albedo_steps: 48,
                env_map_size: 256,
                env_filter: MipFilter::Gauss6,
                env_supersample: 3,
            },
        }
    }

    /// The preset with the scene's overrides; an invalid override is `Err((field, why))`
    /// with the field as written in scene.json ([`MaterialsSettings::check`]).
    pub fn resolve(
        quality: Quality,
        over: &MaterialsOverride,
    ) -> Result<MaterialsSettings, (String, String)> {
        let mut s = Self::preset(quality);
        if let Some(b) = over.sample_budget {
            s.sample_budget = b;
        }
        if let Some(e) = over.env_map_size {
            s.env_map_size = e;
        }
        s.check()
            .map_err(|e| (format!("bake.materials.{}", e.field), e.message))?;
        Ok(s)
    }

    /// Checks every value: sizes and counts within their ranges, `env_map_size` a power of
    /// two, ξ₀ in (0, 1], kernel texels in (0°, 45°].
    pub fn check(&self) -> Result<(), SettingError> {
        let sizes = [
            ("sample_budget", self.sample_budget, 100_000),
            ("max_circles", self.max_circles, 4096),
            ("kernel_max_radius", self.kernel_max_radius, 1024),
            ("sphere_map_size", self.sphere_map_size, 4096),
            ("map_1d_size", self.map_1d_size, 65536),
            ("albedo_steps", self.albedo_steps, 4096),
            ("env_supersample", self.env_supersample, 16),
        ];
        for (name, v, hi) in sizes {
            if !(1..=hi).contains(&v) {
                return Err(SettingError::new(name, format!("{v} is not in 1 ..= {hi}")));
            }
        }
        let e = self.env_map_size;
        if !(4..=4096).contains(&e) || !e.is_power_of_two() {
            return Err(SettingError::new(
                "env_map_size",
                format!("{e} is not a power of two in 4 ..= 4096"),
            ));
        }
        if !(self.xi0 > 0.0 && self.xi0 <= 1.0) {
            return Err(SettingError::new(
                "xi0",
                format!("{} is not in (0, 1]", self.xi0),
            ));
        }
        if !(self.kernel_texel_deg > 0.0 && self.kernel_texel_deg <= 45.0) {
            return Err(SettingError::new(
                "kernel_texel_deg",
                format!("{} is not in (0, 45] degrees", self.kernel_texel_deg),
            ));
        }
        Ok(())
    }
}

/// Why the materials stage failed.
#[derive(Debug, thiserror::Error)]
pub enum MaterialsError {
    /// A setting in scene.json is out of range.
    #[error("{}: field `{field}`: {message}", path.display())]
    Setting {
        /// scene.json.
        path: std::path::PathBuf,
        /// Dotted field path.
        field: String,
        /// What is wrong.
        message: String,
    },
    /// Writing the bundle.
    #[error(transparent)]
    Bundle(#[from] BundleError),
    /// Encoding an image.
    #[error("{path}: {source}")]
    Image {
        /// Asset path.
        path: String,
        /// Cause.
        source: ImageError,
    },
    /// Stopped by the user.
    #[error(transparent)]
    Cancelled(#[from] Cancelled),
}

/// What the stage did.
#[derive(Debug)]
pub enum Outcome {
    /// Nothing to bake: the reason.
    Skipped(String),
    /// Baked.
    Baked(Box<Report>),
}

/// One lobe's assets, for reports.
#[derive(Clone, Debug, Serialize)]
pub struct LobeReport {
    /// Lobe index within the material.
    pub lobe: usize,
    /// Roughness along the tangent.
    pub mx: f32,
    /// Roughness along the bitangent.
    pub my: f32,
    /// Kernel width = height, texels (1: identity).
    pub kernel_size: u32,
    /// Angle per kernel texel, degrees.
    pub kernel_texel_deg: f32,
    /// Sphere-map size.
    pub sphere_map_size: u32,
    /// 1D-map size (isotropic lobes).
    pub map_1d_size: Option<u32>,
    /// Pattern samples.
    pub pattern_samples: usize,
    /// Pattern spacing (`s1`/`s2`).
    pub pattern_spacing: &'static str,
    /// Pattern circles.
    pub pattern_circles: u32,
}

/// One material's assets, for reports.
#[derive(Clone, Debug, Serialize)]
pub struct MaterialReport {
    /// Material name.
    pub name: String,
    /// Its folder in the stage.
    pub folder: String,
    /// Per lobe.
    pub lobes: Vec<LobeReport>,
    /// Files written.
    pub files: usize,
    /// Bytes written.
    pub bytes: u64,
}

/// One environment map, for reports.
#[derive(Clone, Debug, Serialize)]
pub struct EnvReport {
    /// Reflector name.
    pub reflector: String,
    /// Its material.
    pub material: String,
    /// Capture point (area-weighted centroid), metres.
    pub centre: [f32; 3],
    /// Face size of level 0.
    pub face_size: usize,
    /// MIP levels.
    pub levels: usize,
    /// Filter.
    pub filter: &'static str,
    /// Bytes written.
    pub bytes: u64,
}

/// What a bake wrote.
#[derive(Debug, Serialize)]
pub struct Report {
    /// The manifest record.
    #[serde(skip)]
    pub record: StageRecord,
    /// Why the stage is needed (the plan's reason).
    pub reason: String,
    /// Per material.
    pub materials: Vec<MaterialReport>,
    /// Per environment map.
    pub env_maps: Vec<EnvReport>,
    /// Why environment maps were not baked, if they were not.
    pub env_maps_skipped: Option<String>,
}

/// Shades an environment-map ray hit: the radiance leaving the hit point towards the capture
/// point (D, the diffuse radiosity, for glint's bakes).
pub type HitShader = Box<dyn Fn(&Hit) -> Vec3 + Send + Sync>;

/// A shader for environment maps with the identity of what it reads (recorded in the
/// stage's settings so a changed D makes the stage out of date).
pub struct EnvShading {
    /// The shader.
    pub shade: HitShader,
    /// Identity of its data (e.g. a hash of the radiosity stage's assets).
    pub source: String,
}

/// ════════════════════════════════════════════════════════════════════════════════════════
/// THE ONE PLACE WHERE D IS READ (the radiosity stage, issue 3).
///
/// Environment maps are shaded with D, the radiosity baked into the bundle's `radiosity`
/// stage: [`crate::radiosity::RadiosityMap`] at the hit (exitant radiance, emission
/// included; quad area lights are not geometry, so rays never see them, as in the radiance
/// stage). Returns the shader, or why environment maps cannot be baked: no radiosity stage,
/// one baked from another scene, or one that cannot be read. The stage then skips the
/// environment maps, says why, and bakes the rest. `source` (a hash of the radiosity
/// assets) goes into the stage's settings, so a re-baked D makes this stage out of date.
/// ════════════════════════════════════════════════════════════════════════════════════════
pub fn shade_with_d(bundle_dir: &Path, scene: &Scene) -> Result<EnvShading, String> {
    let missing = |dir: &Path| {
        format!(
            "{}: no `radiosity` stage (D) in the bundle: environment maps need it; bake it first (glint-radiosity), then re-run glint-materials",
            dir.display()
        )
    };
    let bundle = match Bundle::open(bundle_dir) {
        Ok(b) => b,
        Err(BundleError::MissingManifest { .. }) => return Err(missing(bundle_dir)),
        Err(e) => return Err(format!("cannot read the bundle for D: {e}")),
    };
    let Some(stage) = bundle.stage(Stage::Radiosity.name()) else {
        return Err(missing(bundle_dir));
    };
    if stage.scene_hash != scene.content_hash {
        return Err(format!(
            "{}: the `radiosity` stage was baked from another scene; re-bake it (glint-radiosity --force)",
            bundle_dir.display()
        ));
    }
    let source = stage_identity(stage);
    let map = crate::radiosity::RadiosityMap::load(&bundle)
        .map_err(|e| format!("cannot read D from the `radiosity` stage: {e}"))?
        .ok_or_else(|| missing(bundle_dir))?;
    Ok(EnvShading {
        shade: Box::new(move |hit: &Hit| map.radiance(hit.triangle, hit.bary)),
        source,
    })
}

/// A BLAKE3 over a stage's asset hashes, in manifest order: changes whenever any asset does.
fn stage_identity(stage: &StageRecord) -> String {
    stage.identity()
}

/// The identity of the D that [`shade_with_d`] would read from the bundle at `bundle_dir`:
/// the hash of its `radiosity` stage's assets, or `None` without a radiosity stage baked
/// from `scene`.
pub fn d_identity(bundle_dir: &Path, scene: &Scene) -> Option<String> {
    let bundle = Bundle::open(bundle_dir).ok()?;
    let stage = bundle.stage(Stage::Radiosity.name())?;
    (stage.scene_hash == scene.content_hash).then(|| stage_identity(stage))
}

/// The settings the stage records in the manifest: `settings` plus `d_source`, the identity
/// of the D its environment maps were shaded with (null: none). For an up-to-date check:
/// `recorded_settings(&settings, d_identity(dir, scene).as_deref())`.
pub fn recorded_settings(
    settings: &MaterialsSettings,
    d_source: Option<&str>,
) -> serde_json::Value {
    let mut v = serde_json::to_value(settings).expect("settings serialize");
    v["d_source"] = d_source.into();
    v
}

/// Bakes the materials stage of `scene` into the bundle at `bundle_dir`, shading environment
/// maps with D from the bundle ([`shade_with_d`]).
pub fn bake(
    scene: &Scene,
    bundle_dir: &Path,
    settings: &MaterialsSettings,
    force: bool,
    progress: &dyn Progress,
) -> Result<Outcome, MaterialsError> {
    let shading = shade_with_d(bundle_dir, scene);
    // The D read: the commit refuses if another baker replaced it meanwhile.
    let d_read = shading.as_ref().ok().map(|s| s.source.clone());
    bake_reading(
        scene, bundle_dir, settings, force, shading, d_read, progress,
    )
}

/// A file-name-safe form of a name: ASCII letters, digits, `-`, `_` and `.` kept, anything
/// else `_`; never empty, never starting with `.`.
pub fn folder_name(name: &str) -> String {
    let s: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' || c == '.' {
                c
            } else {
                '_'
            }
        })
        .collect();
    if s.is_empty() || s.starts_with('.') {
        format!("_{s}")
    } else {
        s
    }
}

/// Unique folder names for `names`, in order (a clash gets `-2`, `-3`, …).
fn unique_folders<'a>(names: impl Iterator<Item = &'a str>) -> Vec<String> {
    let mut used = std::collections::BTreeSet::new();
    names
        .map(|n| {
            let base = folder_name(n);
            let mut name = base.clone();
            let mut k = 2;
            while !used.insert(name.to_ascii_lowercase()) {
                name = format!("{base}-{k}");
                k += 1;
            }
            name
        })
        .collect()
}

/// Everything baked for one lobe.
struct LobeAssets {
    kernel: Kernel,
    sphere: ReflectanceMap,
    map_1d: Option<ReflectanceMap>,
    pattern: Pattern,
}

fn bake_lobe(lobe: &Lobe, s: &MaterialsSettings) -> LobeAssets {
    let (mx, my) = lobe.roughness();
    LobeAssets {
        kernel: kernel_for(
            lobe,
            &KernelSettings {
                min_texel_angle: s.kernel_texel_deg.to_radians(),
                max_radius: s.kernel_max_radius,
            },
        ),
        sphere: sphere_map(lobe, s.sphere_map_size, s.albedo_steps),
        map_1d: lobe
            .is_isotropic()
            .then(|| map_1d(lobe, s.map_1d_size, s.albedo_steps)),
        pattern: closest_pattern(mx, my, s.xi0, s.sample_budget, s.max_circles),
    }
}

fn exr_f32(
    path: &str,
    width: usize,
    height: usize,
    channels: &[(&str, &[f32])],
) -> Result<Vec<u8>, MaterialsError> {
    let list: Vec<ChannelData> = channels
        .iter()
        .map(|(name, samples)| ChannelData {
            name,
            precision: Precision::Float,
            samples,
        })
        .collect();
    encode_exr(width, height, &list, ExrCompression::Zip16).map_err(|source| {
        MaterialsError::Image {
            path: path.into(),
            source,
        }
    })
}

/// Area-weighted centroid of some triangles (f64 sums).
fn centroid(scene: &Scene, triangles: &[u32]) -> Vec3 {
    let (mut sum, mut area) = (DVec3::ZERO, 0.0f64);
    for &t in triangles {
        let tri = &scene.triangles[t as usize];
        let a = tri.area() as f64;
        sum += (tri.p[0] + tri.p[1] + tri.p[2]).as_dvec3() * (a / 3.0);
        area += a;
    }
    if area > 0.0 {
        (sum / area).as_vec3()
    } else {
        Vec3::ZERO
    }
}

/// [`bake`] with the environment-map shading given: `Ok` shades hits, `Err` is the reason
/// environment maps are skipped. Tests and tools use it with their own shaders.
pub fn bake_with(
    scene: &Scene,
    bundle_dir: &Path,
    settings: &MaterialsSettings,
    force: bool,
    shading: Result<EnvShading, String>,
    progress: &dyn Progress,
) -> Result<Outcome, MaterialsError> {
    bake_reading(scene, bundle_dir, settings, force, shading, None, progress)
}

/// [`bake_with`], where `d_read` is the identity of the radiosity stage the shading read
/// (checked again at the commit).
fn bake_reading(
    scene: &Scene,
    bundle_dir: &Path,
    settings: &MaterialsSettings,
    force: bool,
    shading: Result<EnvShading, String>,
    d_read: Option<String>,
    progress: &dyn Progress,
) -> Result<Outcome, MaterialsError> {
    let start = Instant::now();
    let step = plan(scene)
        .into_iter()
        .find(|p| p.stage == Stage::Materials)
        .expect("the plan lists every stage");
    if !step.needed {
        return Ok(Outcome::Skipped(step.reason));
    }
    // Before the compute: a bundle that cannot be written fails now.
    let mut w = StageWriter::begin(bundle_dir, Stage::Materials.name())?;
    if let Some(d) = &d_read {
        w.read_from(Stage::Radiosity.name(), d);
    }
    let used: Vec<bool> = {
        let mut u = vec![false; scene.materials.len()];
        for t in &scene.triangles {
            u[t.material as usize] = true;
        }
        u
    };
    let chosen: Vec<usize> = (0..scene.materials.len())
        .filter(|&i| scene.materials[i].is_glossy() && used[i])
        .collect();
    let folders = unique_folders(chosen.iter().map(|&i| scene.materials[i].name.as_str()));

    // Kernels, reflectance maps and patterns: one work item per lobe, gathered in order.
    let items: Vec<(usize, usize)> = chosen
        .iter()
        .enumerate()
        .flat_map(|(k, &m)| (0..scene.materials[m].lobes.len()).map(move |l| (k, l)))
        .collect();
    progress.phase("material lobes", items.len() as u64);
    let baked: Vec<Option<LobeAssets>> = items
        .par_iter()
        .map(|&(k, l)| {
            if progress.cancelled() {
                return None;
            }
            let lobe = Lobe::from(&scene.materials[chosen[k]].lobes[l]);
            let out = bake_lobe(&lobe, settings);
            progress.advance(1);
            Some(out)
        })
        .collect();
    if progress.cancelled() {
        return Err(Cancelled.into());
    }

    let mut index_materials = Vec::new();
    let mut reports = Vec::new();
    let mut stats: BTreeMap<String, serde_json::Value> = BTreeMap::new();
    let mut lobe_total = 0usize;
    for (k, &m) in chosen.iter().enumerate() {
        let mat = &scene.materials[m];
        let folder = &folders[k];
        let (mut files, mut bytes) = (0usize, 0u64);
        let mut lobe_reports = Vec::new();
        let mut lobe_index = Vec::new();
        for (l, desc) in mat.lobes.iter().enumerate() {
            let pos = items
                .iter()
                .position(|&it| it == (k, l))
                .expect("every lobe is an item");
            let a = baked[pos].as_ref().expect("not cancelled");
            let lobe = Lobe::from(desc);
            let mut put = |w: &mut StageWriter, rel: String, kind: &str, data: Vec<u8>| {
                files += 1;
                bytes += data.len() as u64;
                w.write(&rel, kind, &data).map(|_| rel)
            };
            let base = format!("{folder}/lobe{l}");
            let ks = a.kernel.size() as usize;
            let kernel_path = put(
                &mut w,
                format!("{base}-kernel.exr"),
                "kernel",
                exr_f32(
                    &format!("{base}-kernel.exr"),
                    ks,
                    ks,
                    &[("Y", &a.kernel.weights)],
                )?,
            )?;
            let sphere_rel = format!("{base}-reflectance.exr");
            let sphere_bytes = exr_f32(
                &sphere_rel,
                a.sphere.width as usize,
                a.sphere.height as usize,
                &[("R", &a.sphere.r), ("A", &a.sphere.albedo)],
            )?;
            let sphere_path = put(&mut w, sphere_rel, "reflectance-sphere", sphere_bytes)?;
            let map_1d_path = match &a.map_1d {
                Some(m1) => {
                    let rel = format!("{base}-reflectance-1d.exr");
                    let data = exr_f32(
                        &rel,
                        m1.width as usize,
                        1,
                        &[("R", &m1.r), ("A", &m1.albedo)],
                    )?;
                    Some(put(&mut w, rel, "reflectance-1d", data)?)
                }
                None => None,
            };
            let pattern_path = put(
                &mut w,
                format!("{base}-pattern.bin"),
                "sample-pattern",
                format::encode_pattern(&a.pattern),
            )?;
            lobe_index.push(serde_json::json!({
                "ks": desc.ks, "r0": desc.r0, "mx": desc.mx, "my": desc.my, "alpha": desc.alpha,
                "isotropic": lobe.is_isotropic(),
                "kernel": {
                    "path": kernel_path, "size": a.kernel.size(), "identity": a.kernel.identity,
                    "texel_angle_rad": a.kernel.texel_angle, "lobe_radius_rad": a.kernel.lobe_radius,
                    "cutoff_q": kernel::KERNEL_CUTOFF,
                },
                "reflectance_sphere": { "path": sphere_path, "size": a.sphere.width },
                "reflectance_1d": map_1d_path.as_ref().map(|p| serde_json::json!({
                    "path": p, "size": a.map_1d.as_ref().map(|m| m.width),
                })),
                "reflectance_grazing_cos": reflectance::C_GRAZING,
                "pattern": {
                    "path": pattern_path, "samples": a.pattern.len(), "spacing": a.pattern.spacing.name(),
                    "circles": a.pattern.circles, "xi0": a.pattern.xi0,
                    "theta_max_rad": a.pattern.theta_max, "pdf_constant": a.pattern.pdf_constant,
                },
            }));
            lobe_reports.push(LobeReport {
                lobe: l,
                mx: desc.mx,
                my: desc.my,
                kernel_size: a.kernel.size(),
                kernel_texel_deg: a.kernel.texel_angle.to_degrees(),
                sphere_map_size: a.sphere.width,
                map_1d_size: a.map_1d.as_ref().map(|m| m.width),
                pattern_samples: a.pattern.len(),
                pattern_spacing: a.pattern.spacing.name(),
                pattern_circles: a.pattern.circles,
            });
            lobe_total += 1;
        }
        stats.insert(
            format!("material {}", mat.name),
            serde_json::json!({
                "folder": folder,
                "lobes": mat.lobes.len(),
                "files": files,
                "bytes": bytes,
                "kernel": lobe_reports.iter().map(|r| format!("{0}x{0}", r.kernel_size)).collect::<Vec<_>>(),
                "pattern_samples": lobe_reports.iter().map(|r| r.pattern_samples).collect::<Vec<_>>(),
            }),
        );
        index_materials.push(serde_json::json!({
            "name": mat.name, "folder": folder, "albedo": mat.albedo.to_array(), "lobes": lobe_index,
        }));
        reports.push(MaterialReport {
            name: mat.name.clone(),
            folder: folder.clone(),
            lobes: lobe_reports,
            files,
            bytes,
        });
    }

    // Environment maps of glossy curved reflectors.
    let curved: Vec<usize> = (0..scene.reflectors.len())
        .filter(|&r| {
            let refl = &scene.reflectors[r];
            refl.kind == ReflectorKind::Curved
                && scene.materials[refl.material as usize].is_glossy()
        })
        .collect();
    let mut env_reports = Vec::new();
    let mut env_index = Vec::new();
    let d_source = shading.as_ref().ok().map(|s| s.source.clone());
    let env_skipped = if curved.is_empty() {
        Some("no `curved` reflector has a glossy material".to_string())
    } else {
        match shading {
            Err(reason) => Some(reason),
            Ok(shading) => {
                let bvh = scene.build_bvh();
                let capture = CaptureSettings {
                    face_size: settings.env_map_size as usize,
                    supersample: settings.env_supersample,
                };
                let env_folders =
                    unique_folders(curved.iter().map(|&r| scene.reflectors[r].name.as_str()));
                progress.phase(
                    "environment maps",
                    (curved.len() * 6 * capture.face_size) as u64,
                );
                for (k, &r) in curved.iter().enumerate() {
                    let refl = &scene.reflectors[r];
                    let centre = centroid(scene, &refl.triangles);
                    let cube = capture_cube(
                        scene,
                        &bvh,
                        centre,
                        &capture,
                        &refl.triangles,
                        &*shading.shade,
                        progress,
                    )?;
                    let pyramid = MipPyramid::build(cube, settings.env_filter);
                    let mut bytes = 0u64;
                    let mut paths = Vec::new();
                    for (l, level) in pyramid.levels.iter().enumerate() {
                        let rel = format!("env/{}/mip{l:02}.exr", env_folders[k]);
                        let data = encode_rgb_exr(6 * level.size, level.size, &level.strip())
                            .map_err(|source| MaterialsError::Image {
                                path: rel.clone(),
                                source,
                            })?;
                        bytes += data.len() as u64;
                        w.write(&rel, "env-mip", &data)?;
                        paths.push(rel);
                    }
                    let material = scene.materials[refl.material as usize].name.clone();
                    stats.insert(
                        format!("env {}", refl.name),
                        serde_json::json!({
                            "material": material, "face_size": capture.face_size,
                            "levels": pyramid.levels.len(), "filter": settings.env_filter.name(),
                            "files": paths.len(), "bytes": bytes,
                        }),
                    );
                    env_index.push(serde_json::json!({
                        "reflector": refl.name, "material": material, "centre": centre.to_array(),
                        "face_size": capture.face_size, "filter": settings.env_filter.name(),
                        "levels": paths, "layout": "faces +x -x +y -y +z -z side by side, row 0 at the top",
                    }));
                    env_reports.push(EnvReport {
                        reflector: refl.name.clone(),
                        material,
                        centre: centre.to_array(),
                        face_size: capture.face_size,
                        levels: pyramid.levels.len(),
                        filter: settings.env_filter.name(),
                        bytes,
                    });
                }
                None
            }
        }
    };

    let index = serde_json::json!({
        "format": "glint-materials-index",
        "version": 1,
        "settings": settings,
        "materials": index_materials,
        "env_maps": env_index,
        "env_maps_skipped": env_skipped,
    });
    let text = serde_json::to_string_pretty(&index).expect("index serializes") + "\n";
    w.write("index.json", "materials-index", text.as_bytes())?;

    stats.insert("materials".into(), chosen.len().into());
    stats.insert("lobes".into(), lobe_total.into());
    stats.insert("env_maps".into(), env_reports.len().into());
    if let Some(reason) = &env_skipped {
        stats.insert("env_maps_skipped".into(), reason.clone().into());
    }
    let settings_json = recorded_settings(settings, d_source.as_deref());
    let record = w.commit(StageInfo {
        scene_name: scene.name.clone(),
        scene_hash: scene.content_hash.clone(),
        settings: settings_json,
        stats,
        bake_seconds: start.elapsed().as_secs_f64(),
        force,
    })?;
    Ok(Outcome::Baked(Box::new(Report {
        record,
        reason: step.reason,
        materials: reports,
        env_maps: env_reports,
        env_maps_skipped: env_skipped,
    })))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn folder_names_are_safe_and_unique() {
        assert_eq!(folder_name("Glossy Floor/1"), "Glossy_Floor_1");
        assert_eq!(folder_name(""), "_");
        assert_eq!(folder_name(".hidden"), "_.hidden");
        assert_eq!(
            unique_folders(["a b", "a_b", "A_B"].into_iter()),
            ["a_b", "a_b-2", "A_B-3"]
        );
    }

    #[test]
    fn overrides_are_checked() {
        let over = MaterialsOverride {
            sample_budget: Some(0),
            env_map_size: None,
        };
        assert_eq!(
            MaterialsSettings::resolve(Quality::Default, &over)
                .unwrap_err()
                .0,
            "bake.materials.sample_budget"
        );
        let over = MaterialsOverride {
            sample_budget: Some(30),
            env_map_size: Some(100),
        };
        assert!(
            MaterialsSettings::resolve(Quality::Default, &over)
                .unwrap_err()
                .1
                .contains("power of two")
        );
        let over = MaterialsOverride {
            sample_budget: Some(30),
            env_map_size: Some(512),
        };
        let s = MaterialsSettings::resolve(Quality::Draft, &over).unwrap();
        assert_eq!((s.sample_budget, s.env_map_size), (30, 512));
    }
}

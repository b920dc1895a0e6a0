//! The per-lobe step of the materials stage: which materials are baked, their kernels,
//! reflectance maps and patterns (one parallel work item per lobe, gathered in order), and
//! their files and index entries.

use std::collections::BTreeMap;

use rayon::prelude::*;

use super::MaterialsError;
use super::report::{LobeReport, MaterialReport};
use crate::brdf::Lobe;
use crate::brdf::pattern::{Pattern, closest_pattern_for};
use crate::bundle::StageWriter;
use crate::image_io::{ChannelData, ExrCompression, Precision, encode_exr};
use crate::materials::MaterialsSettings;
use crate::materials::index::{
    IndexedKernel, IndexedLobe, IndexedMap, IndexedMap1d, IndexedMaterial, IndexedPattern,
};
use crate::materials::kernel::{self, Kernel, KernelSettings, kernel_for};
use crate::materials::pattern_format::encode_pattern;
use crate::materials::reflectance::{self, ReflectanceMap, map_1d, sphere_map};
use crate::progress::{Cancelled, Progress};
use crate::scene::Scene;
use crate::scene::desc::LobeDesc;

/// Everything baked for one lobe.
pub struct LobeAssets {
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
        pattern: closest_pattern_for(lobe.ndf(), mx, my, s.xi0, s.sample_budget, s.max_circles),
    }
}

/// The materials the stage bakes: glossy ones that cover some triangle, in scene order.
pub fn chosen_materials(scene: &Scene) -> Vec<usize> {
    let mut used = vec![false; scene.materials.len()];
    for t in &scene.triangles {
        used[t.material as usize] = true;
    }
    (0..scene.materials.len())
        .filter(|&i| scene.materials[i].is_glossy() && used[i])
        .collect()
}

/// Bakes every lobe of the `chosen` materials: `[material k][lobe l]`.
pub fn bake_lobes(
    scene: &Scene,
    chosen: &[usize],
    settings: &MaterialsSettings,
    progress: &dyn Progress,
) -> Result<Vec<Vec<LobeAssets>>, MaterialsError> {
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
    let mut out: Vec<Vec<LobeAssets>> = chosen.iter().map(|_| Vec::new()).collect();
    for ((k, _), a) in items.into_iter().zip(baked) {
        out[k].push(a.expect("not cancelled"));
    }
    Ok(out)
}

/// An EXR of f32 channels.
pub fn exr_f32(
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

/// A stage writer that counts files and bytes.
struct Counted<'w> {
    w: &'w mut StageWriter,
    files: usize,
    bytes: u64,
}

impl Counted<'_> {
    fn put(&mut self, rel: String, kind: &str, data: Vec<u8>) -> Result<String, MaterialsError> {
        self.files += 1;
        self.bytes += data.len() as u64;
        self.w.write(&rel, kind, &data)?;
        Ok(rel)
    }
}

/// Writes one lobe's files under `base` and returns its index entry.
fn write_lobe(
    w: &mut Counted<'_>,
    base: &str,
    desc: &LobeDesc,
    a: &LobeAssets,
) -> Result<IndexedLobe, MaterialsError> {
    let lobe = Lobe::from(desc);
    let ks = a.kernel.size() as usize;
    let kernel_rel = format!("{base}-kernel.exr");
    let kernel_bytes = exr_f32(&kernel_rel, ks, ks, &[("Y", &a.kernel.weights)])?;
    let kernel_path = w.put(kernel_rel, "kernel", kernel_bytes)?;
    let sphere_rel = format!("{base}-reflectance.exr");
    let sphere_bytes = exr_f32(
        &sphere_rel,
        a.sphere.width as usize,
        a.sphere.height as usize,
        &[("R", &a.sphere.r), ("A", &a.sphere.albedo)],
    )?;
    let sphere_path = w.put(sphere_rel, "reflectance-sphere", sphere_bytes)?;
    let map_1d_path = match &a.map_1d {
        Some(m1) => {
            let rel = format!("{base}-reflectance-1d.exr");
            let data = exr_f32(
                &rel,
                m1.width as usize,
                1,
                &[("R", &m1.r), ("A", &m1.albedo)],
            )?;
            Some(w.put(rel, "reflectance-1d", data)?)
        }
        None => None,
    };
    let pattern_path = w.put(
        format!("{base}-pattern.bin"),
        "sample-pattern",
        encode_pattern(&a.pattern),
    )?;
    Ok(IndexedLobe {
        model: desc.model,
        ks: desc.ks,
        r0: desc.r0,
        mx: desc.mx,
        my: desc.my,
        alpha: desc.alpha.unwrap_or(0.0),
        isotropic: lobe.is_isotropic(),
        kernel: IndexedKernel {
            path: kernel_path,
            size: a.kernel.size(),
            identity: a.kernel.identity,
            texel_angle_rad: a.kernel.texel_angle,
            lobe_radius_rad: a.kernel.lobe_radius,
            cutoff_q: kernel::KERNEL_CUTOFF,
        },
        reflectance_sphere: IndexedMap {
            path: sphere_path,
            size: a.sphere.width,
        },
        reflectance_1d: map_1d_path.map(|path| IndexedMap1d {
            path,
            size: a.map_1d.as_ref().map(|m| m.width),
        }),
        reflectance_grazing_cos: reflectance::C_GRAZING,
        pattern: IndexedPattern {
            path: pattern_path,
            samples: a.pattern.len(),
            spacing: a.pattern.spacing.name().into(),
            circles: a.pattern.circles,
            xi0: a.pattern.xi0,
            theta_max_rad: a.pattern.theta_max,
            pdf_constant: a.pattern.pdf_constant,
        },
    })
}

fn lobe_report(l: usize, desc: &LobeDesc, a: &LobeAssets) -> LobeReport {
    LobeReport {
        lobe: l,
        model: desc.model,
        mx: desc.mx,
        my: desc.my,
        kernel_size: a.kernel.size(),
        kernel_texel_deg: a.kernel.texel_angle.to_degrees(),
        sphere_map_size: a.sphere.width,
        map_1d_size: a.map_1d.as_ref().map(|m| m.width),
        pattern_samples: a.pattern.len(),
        pattern_spacing: a.pattern.spacing.name(),
        pattern_circles: a.pattern.circles,
    }
}

/// What [`write_materials`] wrote.
pub struct WrittenMaterials {
    /// Index entries, in order.
    pub index: Vec<IndexedMaterial>,
    /// Reports, in order.
    pub reports: Vec<MaterialReport>,
    /// Lobes written.
    pub lobes: usize,
}

/// Writes the files of every chosen material (`materials/<folder>/lobe<k>-…`, `folders` in
/// the order of `chosen`), adding a `material NAME` entry to `stats` for each.
pub fn write_materials(
    w: &mut StageWriter,
    scene: &Scene,
    chosen: &[usize],
    folders: &[String],
    baked: &[Vec<LobeAssets>],
    stats: &mut BTreeMap<String, serde_json::Value>,
) -> Result<WrittenMaterials, MaterialsError> {
    let mut out = WrittenMaterials {
        index: Vec::new(),
        reports: Vec::new(),
        lobes: 0,
    };
    for (k, &m) in chosen.iter().enumerate() {
        let mat = &scene.materials[m];
        let folder = &folders[k];
        let mut counted = Counted {
            w: &mut *w,
            files: 0,
            bytes: 0,
        };
        let mut lobe_reports = Vec::new();
        let mut lobe_index = Vec::new();
        for (l, desc) in mat.lobes.iter().enumerate() {
            let a = &baked[k][l];
            lobe_index.push(write_lobe(
                &mut counted,
                &format!("{folder}/lobe{l}"),
                desc,
                a,
            )?);
            lobe_reports.push(lobe_report(l, desc, a));
            out.lobes += 1;
        }
        let (files, bytes) = (counted.files, counted.bytes);
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
        out.index.push(IndexedMaterial {
            name: mat.name.clone(),
            folder: folder.clone(),
            albedo: mat.albedo.to_array(),
            lobes: lobe_index,
        });
        out.reports.push(MaterialReport {
            name: mat.name.clone(),
            folder: folder.clone(),
            lobes: lobe_reports,
            files,
            bytes,
        });
    }
    Ok(out)
}

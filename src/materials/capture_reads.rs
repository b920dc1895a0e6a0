//! What a cube-map capture's texels read of D ([`super::envmap::capture_recorded`]), kept so
//! that a bake after an edit that changes only D, or lobes the capture's rays did not meet,
//! evaluates a probe or an environment map from its records instead of capturing it again.
//!
//! A capture ray's radiance is a fixed sum over reads of D: at each surface it meets (the
//! first, then past each near-mirror and each pane of glass, weighted by their reflectance and
//! transmittance so far), D there; at a glossy surface that ends it, per lobe k_s/N times the
//! sum of its samples' weights times what each sample sees (the area lights it crosses and D
//! where it lands); and the area lights the ray crosses on each leg (times the weight so far).
//! Lights, weights and where the rays land are fixed by the geometry, the capture point and
//! settings, the lights and the lobes and transmission of the surfaces met. The capture writes
//! the sum as a record (bytes, one texel after another in a face row, [`crate::radiance::reads::MapReads`]
//! rows) and [`eval_texel`] evaluates it against D in the float operations of the capture, so
//! a cube evaluated from its records has the bytes of one captured with the same D. Every
//! recorded capture gives its texels through their records, traced or kept.
//!
//! A texel's record is its rays' records in order; a ray's, a list of operations ended by
//! [`END`]: [`LIGHTS`] (`3 × f32`: the weight times the lights crossed), [`SURFACE`] (a read
//! of D, weight one) or [`SURFACE_WEIGHTED`] (`3 × f32` weight, then a read), [`GLOSSY`] (`u8`
//! lobe count; per lobe its k_s (`3 × f32`), a `u32` sample count and per sample its weight
//! (`f32`), a `u8` of flags ([`SEES_LIGHTS`]: then `3 × f32`; [`SEES_SURFACE`]: then a read)),
//! weighted by the last surface's weight. A read is [`crate::radiance::reads::push_read`]'s,
//! untextured: the shading reads D through the textures itself. Little-endian.

use std::borrow::Cow;

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use crate::geometry::Triangle;
use crate::progress::Progress;
use crate::radiance::reads::{
    Cursor, Kept, MapReads, Read, Replay, push_read, push_vec3, replay_row,
};

/// The end of a ray's record.
pub const END: u8 = 0;
/// The area lights a ray crosses, times its weight.
pub const LIGHTS: u8 = 1;
/// D at a surface the ray meets, weight one.
pub const SURFACE: u8 = 2;
/// D at a surface the ray meets, times its weight.
pub const SURFACE_WEIGHTED: u8 = 3;
/// What a glossy surface's lobes reflect, times the last surface's weight.
pub const GLOSSY: u8 = 4;
/// A lobe sample's flag: it crosses area lights.
pub const SEES_LIGHTS: u8 = 1;
/// A lobe sample's flag: it lands on a surface.
pub const SEES_SURFACE: u8 = 2;

fn push_point(out: &mut Vec<u8>, triangle: u32, bary: Vec2) {
    push_read(
        out,
        &Read {
            triangle,
            bary,
            factors: None,
        },
    );
}

/// Whether `v` is +0 in every component (bits, not value: a −0 is recorded as it is).
pub fn is_positive_zero(v: Vec3) -> bool {
    v.to_array().iter().all(|c| c.to_bits() == 0)
}

/// Ends a ray's record.
pub fn push_end(out: &mut Vec<u8>) {
    out.push(END);
}

/// The lights a ray crosses on a leg, `weighted` by the weight so far.
pub fn push_lights(out: &mut Vec<u8>, weighted: Vec3) {
    out.push(LIGHTS);
    push_vec3(out, weighted);
}

/// D at `bary` of `triangle`, where the ray's weight is `weight`.
pub fn push_surface(out: &mut Vec<u8>, weight: Vec3, triangle: u32, bary: Vec2) {
    if weight == Vec3::ONE {
        out.push(SURFACE);
    } else {
        out.push(SURFACE_WEIGHTED);
        push_vec3(out, weight);
    }
    push_point(out, triangle, bary);
}

/// Begins what `lobes` glossy lobes reflect at the last surface.
pub fn push_glossy(out: &mut Vec<u8>, lobes: usize) {
    debug_assert!(lobes <= u8::MAX as usize);
    out.push(GLOSSY);
    out.push(lobes as u8);
}

/// Begins a lobe of reflectance `ks`; returns where its sample count is, for
/// [`push_sample`].
pub fn push_lobe(out: &mut Vec<u8>, ks: Vec3) -> usize {
    push_vec3(out, ks);
    let at = out.len();
    out.extend(0u32.to_le_bytes());
    at
}

/// A sample of the lobe whose count is at `count_at`: its weight, the lights it crosses
/// (recorded unless +0) and where it lands, if anywhere.
pub fn push_sample(
    out: &mut Vec<u8>,
    count_at: usize,
    weight: f32,
    lights: Vec3,
    lands: Option<(u32, Vec2)>,
) {
    let count = &mut out[count_at..count_at + 4];
    let n = u32::from_le_bytes(count.try_into().expect("four bytes")) + 1;
    count.copy_from_slice(&n.to_le_bytes());
    out.extend(weight.to_le_bytes());
    let sees_lights = !is_positive_zero(lights);
    let flags =
        if sees_lights { SEES_LIGHTS } else { 0 } | if lands.is_some() { SEES_SURFACE } else { 0 };
    out.push(flags);
    if sees_lights {
        push_vec3(out, lights);
    }
    if let Some((t, b)) = lands {
        push_point(out, t, b);
    }
}

/// Evaluates the record of one texel of `rays` rays at the start of `bytes` against D (`d`:
/// the stored value at barycentrics of a triangle, through any texture), where glossy lobes
/// took `glossy_samples` samples, in the float operations of the capture; `stale` is asked of
/// each surface a ray met (not of where lobe samples land: they read D alone). `None` for
/// bytes that are no whole record or read a triangle not below `triangles`.
pub fn eval_texel(
    bytes: &[u8],
    rays: usize,
    glossy_samples: u32,
    triangles: usize,
    stale: &dyn Fn(u32) -> bool,
    d: &dyn Fn(u32, Vec2) -> Vec3,
) -> Option<Kept<Vec3>> {
    let mut c = Cursor::new(bytes, triangles);
    let mut is_stale = false;
    let mut texel = Vec3::ZERO;
    for _ in 0..rays {
        let (mut sum, mut weight) = (Vec3::ZERO, Vec3::ONE);
        loop {
            match c.u8()? {
                END => break,
                LIGHTS => sum += c.vec3()?,
                op @ (SURFACE | SURFACE_WEIGHTED) => {
                    weight = if op == SURFACE { Vec3::ONE } else { c.vec3()? };
                    let r = c.read()?;
                    is_stale |= stale(r.triangle);
                    sum += weight * d(r.triangle, r.bary);
                }
                GLOSSY => {
                    let mut glossy = Vec3::ZERO;
                    for _ in 0..c.u8()? {
                        let ks = c.vec3()?;
                        let mut lobe_sum = Vec3::ZERO;
                        for _ in 0..c.u32()? {
                            let w = c.f32()?;
                            let flags = c.u8()?;
                            let mut seen = if flags & SEES_LIGHTS != 0 {
                                c.vec3()?
                            } else {
                                Vec3::ZERO
                            };
                            if flags & SEES_SURFACE != 0 {
                                let r = c.read()?;
                                seen += d(r.triangle, r.bary);
                            }
                            lobe_sum += seen * w;
                        }
                        glossy += ks * lobe_sum / glossy_samples as f32;
                    }
                    sum += weight * glossy;
                }
                _ => return None,
            }
        }
        texel += sum;
    }
    Some(Kept {
        len: c.at,
        stale: is_stale,
        value: texel / rays as f32,
    })
}

/// What a capture's texel records depend on besides their bytes.
#[derive(Clone, Copy, Debug)]
pub struct CubeShape {
    /// Texels per face edge.
    pub size: usize,
    /// Rays per texel.
    pub rays: usize,
    /// Samples per glossy lobe.
    pub glossy_samples: u32,
}

/// A D lookup (the stored value at barycentrics of a triangle), and a cube's kept records.
pub type Recorded<'d, 'a> = (&'d (dyn Fn(u32, Vec2) -> Vec3 + Sync), Option<Replay<'a>>);

/// Traces texel (x, y) of a face (`face, x, y, out`), appending its record to `out`, and gives
/// the value its trace summed.
pub type TraceTexel<'a> = dyn Fn(usize, usize, usize, &mut Vec<u8>) -> Vec3 + Sync + 'a;

/// A cube map's texels (`triangles`: the scene's), one face row per work item (deterministic):
/// `texel(face, x, y, out)` traces a texel, appends its record to `out` and gives the value its
/// trace summed. With `recorded`, each texel's value is its record evaluated against D
/// ([`eval_texel`]) instead, and with kept records a texel whose record is still valid is not
/// traced. The texels, their records (empty without `recorded`) and how many were traced;
/// `None` when cancelled.
pub fn texel_rows<'a>(
    shape: &CubeShape,
    triangles: &[Triangle],
    texel: &TraceTexel<'_>,
    recorded: Option<Recorded<'_, 'a>>,
    progress: &dyn Progress,
) -> Option<(Vec<Vec3>, MapReads<'a>, u64)> {
    let size = shape.size;
    let (d, replay) = match recorded {
        Some((d, replay)) => (Some(d), replay),
        None => (None, None),
    };
    let (old_rows, changed) = Replay::rows(replay, 6 * size);
    let eval = |at: &[u8], stale: &dyn Fn(u32) -> bool, d| {
        let (rays, samples) = (shape.rays, shape.glossy_samples);
        eval_texel(at, rays, samples, triangles.len(), stale, d)
    };
    let rows: Vec<(Vec<Vec3>, Cow<'a, [u8]>, u64)> = old_rows
        .into_par_iter()
        .zip(changed)
        .enumerate()
        // A row each task: rows that see a glossy surface cost many times the others.
        .with_max_len(1)
        .map(|(row, (old, changed))| {
            let stale = |t: u32| {
                let m = triangles[t as usize].material as usize;
                changed.get(m).copied().unwrap_or(true)
            };
            if progress.cancelled() {
                return (Vec::new(), Cow::Borrowed(&[][..]), 0);
            }
            let (face, y) = (row / size, row % size);
            let mut bytes = Vec::new();
            let out = match (d, old) {
                (None, _) => {
                    let values = (0..size)
                        .map(|x| {
                            bytes.clear();
                            texel(face, x, y, &mut bytes)
                        })
                        .collect();
                    (values, Cow::Borrowed(&[][..]), size as u64)
                }
                (Some(d), old) => {
                    let traced = |x: usize, out: &mut Vec<u8>| {
                        let from = out.len();
                        texel(face, x, y, out);
                        let e = eval(&out[from..], &|_| false, d);
                        e.expect("a record just written is whole").value
                    };
                    match old {
                        Some(old) => replay_row(old, size, |_, at| eval(at, &stale, d), traced),
                        None => {
                            let values = (0..size).map(|x| traced(x, &mut bytes)).collect();
                            (values, Cow::Owned(bytes), size as u64)
                        }
                    }
                }
            };
            progress.advance(1);
            out
        })
        .collect();
    if progress.cancelled() || rows.iter().any(|r| r.0.len() != size) {
        return None;
    }
    let traced = rows.iter().map(|r| r.2).sum();
    let mut texels = Vec::with_capacity(6 * size * size);
    let mut records = Vec::with_capacity(6 * size);
    for (values, bytes, _) in rows {
        texels.extend(values);
        records.push(bytes);
    }
    Some((texels, MapReads { rows: records }, traced))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// D of a made-up scene: a different value per triangle and point.
    fn d(t: u32, b: Vec2) -> Vec3 {
        Vec3::new(t as f32 + b.x, 1.0 + b.y, 0.5 * t as f32)
    }

    #[test]
    fn a_texel_evaluates_to_its_rays_mean_and_names_the_surfaces_met() {
        let (b, lights) = (Vec2::new(0.25, 0.5), Vec3::new(2.0, 1.0, 0.5));
        let mut out = Vec::new();
        // Ray 1: a light, a mirror, then a glossy surface with two lobe samples.
        push_lights(&mut out, lights);
        push_surface(&mut out, Vec3::ONE, 1, b);
        push_surface(&mut out, Vec3::splat(0.5), 2, b);
        push_glossy(&mut out, 1);
        let at = push_lobe(&mut out, Vec3::splat(0.25));
        push_sample(&mut out, at, 2.0, Vec3::ZERO, Some((0, b)));
        push_sample(&mut out, at, 4.0, lights, None);
        push_end(&mut out);
        // Ray 2: nothing.
        push_end(&mut out);
        let e = eval_texel(&out, 2, 16, 3, &|t| t == 2, &d).unwrap();
        assert_eq!(e.len, out.len());
        assert!(e.stale);
        let lobe = d(0, b) * 2.0 + lights * 4.0;
        let ray = lights
            + d(1, b)
            + Vec3::splat(0.5) * d(2, b)
            + Vec3::splat(0.5) * (Vec3::splat(0.25) * lobe / 16.0);
        assert_eq!(e.value, (ray + Vec3::ZERO) / 2.0);
        // Where lobe samples land is not a surface the ray met.
        assert!(!eval_texel(&out, 2, 16, 3, &|t| t == 0, &d).unwrap().stale);
        // A triangle the scene lacks, a cut record, a ray too many.
        assert!(eval_texel(&out, 2, 16, 2, &|_| false, &d).is_none());
        assert!(eval_texel(&out[..out.len() - 1], 2, 16, 3, &|_| false, &d).is_none());
        assert!(eval_texel(&out, 3, 16, 3, &|_| false, &d).is_none());
    }
}

//! The image-based source of M (Bastos §8.1.3) on the GPU: a reflector's baked radiance maps
//! as splats in storage buffers, and per frame the maps selected for the mirrored eye,
//! each quadtree node sized by Eq. 3, culled or skipped when minified ([`super::splats`]).
//!
//! All of a reflector's splats go in one buffer when the GPU can bind it whole; otherwise the
//! maps are split, whole, over as many buffers as that needs ([`chunk_maps`]), each drawn by
//! one call: a high-quality bake of glossy-room's mirror panel (256² maps) holds 216 MiB of
//! splats, and a storage binding may be limited to 128 MiB (wgpu's default, and lavapipe's).

use std::ops::Range;
use std::sync::Mutex;

use glam::Vec3;

use super::exact::ExactSurfaces;
use super::splats::{self, MapImage, MapSplats, NodeParams, SplatView};
use crate::bundle::Bundle;
use crate::camera::Camera;
use crate::radiance::index::{MapEntry, load_cameras, read_map};
use crate::view::gpu::Gpu;
use crate::view::gpu::build::{buffer, buffer_init};
use crate::view::reflections::radiance_maps::{Selection, select};

/// What the image-based mode drew for one reflector in the last prepared frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FrameStats {
    /// Maps selected (all elements).
    pub maps: usize,
    /// Splats of the selected maps.
    pub selected_splats: u64,
    /// Splats of the leaves left after culling, before Eq. 3's step skips some.
    pub visible_splats: u64,
    /// Splats drawn (after culling and minification skipping).
    pub drawn_splats: u64,
    /// Quadtree nodes culled.
    pub culled_nodes: usize,
    /// Draw calls (one for all drawn splats of each buffer of splats that has any).
    pub draws: usize,
    /// Ranges of contiguous splats drawn (what one draw call each would cost).
    pub ranges: usize,
}

/// A reflector's maps on the GPU: every map's splats in storage buffers ([`SplatChunk`]), in
/// quadtree order; the quadtrees stay on the CPU for per-frame culling and sizing, and each
/// frame's kept splats are listed by index, so they are one draw per buffer however many
/// ranges they form.
pub(super) struct SplatMaps {
    maps: Vec<MapEntry>,
    /// Per map: its quadtree and node ranges within its chunk (splats dropped after upload),
    /// node base, chunk.
    trees: Vec<(MapSplats, u32, usize)>,
    node_count: usize,
    /// The splats, in buffers a binding can hold whole, each with its kept list.
    pub(super) chunks: Vec<SplatChunk>,
    /// Per quadtree node, this frame's [`NodeParams`] (binding 6 of the splat pass).
    pub(super) nodes: wgpu::Buffer,
    /// Per map, its camera's [`SplatView`] (binding 10 of the splat pass).
    pub(super) views: wgpu::Buffer,
    /// The last prepared frame's kept splat count per chunk (`vs_splat` draws 6 vertices
    /// each) and statistics.
    pub(super) plan: Mutex<(Vec<u32>, FrameStats)>,
}

/// Some whole maps' splats and this frame's kept ones among them.
pub(super) struct SplatChunk {
    /// The maps' splats, in quadtree order (`splat_points`, binding 8 of the splat pass).
    pub(super) points: wgpu::Buffer,
    /// This frame's kept splats, indices into `points` (`splat_kept`, binding 9).
    pub(super) kept: wgpu::Buffer,
    /// The splat pass's group 1 for this chunk (set by the pass that binds `nodes`).
    pub(super) group: Option<wgpu::BindGroup>,
}

/// Consecutive maps of `bytes` each, grouped so that no group exceeds `limit` bytes (greedy,
/// in order): the ranges of map indices. `Err(i)`: map i alone is over the limit.
pub fn chunk_maps(bytes: &[u64], limit: u64) -> Result<Vec<Range<usize>>, usize> {
    let mut chunks = Vec::new();
    let (mut start, mut sum) = (0, 0u64);
    for (i, &b) in bytes.iter().enumerate() {
        if b > limit {
            return Err(i);
        }
        if sum + b > limit {
            chunks.push(start..i);
            start = i;
            sum = 0;
        }
        sum += b;
    }
    if start < bytes.len() || chunks.is_empty() {
        chunks.push(start..bytes.len());
    }
    Ok(chunks)
}

/// The most bytes one buffer of splats may hold: what the GPU binds in one storage buffer, or
/// less when `buffer_bytes` says so.
fn buffer_limit(gpu: &Gpu, buffer_bytes: Option<u64>) -> u64 {
    let limits = gpu.device.limits();
    let device_limit = limits
        .max_storage_buffer_binding_size
        .min(limits.max_buffer_size);
    buffer_bytes.map_or(device_limit, |b| b.min(device_limit))
}

/// Refuses reflector `reflector`'s maps (its `cameras.json` in `bundle`) when one could hold
/// more splats, one a pixel, than a buffer of at most `buffer_bytes` binds, before any map is
/// read (image mode reads a reflector's maps when a frame first sees it).
pub(super) fn check_map_sizes(
    gpu: &Gpu,
    bundle: &Bundle,
    reflector: &str,
    buffer_bytes: Option<u64>,
) -> Result<(), String> {
    let cams =
        load_cameras(bundle, reflector).map_err(|e| format!("reflector {reflector}: {e}"))?;
    let limit = buffer_limit(gpu, buffer_bytes);
    let splat_bytes = std::mem::size_of::<splats::Splat>() as u64;
    for m in &cams.maps {
        let most = u64::from(m.view.resolution).pow(2);
        if most * splat_bytes > limit {
            return Err(format!(
                "radiance/{}: up to {most} splats ({:.0} MiB), more than this GPU binds in one buffer ({:.0} MiB); bake reflector {reflector} at a lower `radiance.resolution`",
                crate::radiance::index::map_path(reflector, &m.file, "exr"),
                (most * splat_bytes) as f64 / (1u64 << 20) as f64,
                limit as f64 / (1u64 << 20) as f64,
            ));
        }
    }
    Ok(())
}

/// Reads reflector `reflector`'s radiance maps from `bundle` and uploads their splats, less
/// the points on `exact` surfaces, in buffers of at most `buffer_bytes` (`None`: what the GPU
/// binds in one storage buffer).
pub(super) fn load_splat_maps(
    gpu: &Gpu,
    bundle: &Bundle,
    reflector: &str,
    exact: &ExactSurfaces,
    buffer_bytes: Option<u64>,
) -> Result<SplatMaps, String> {
    let cams = load_cameras(bundle, reflector).map_err(|e| e.to_string())?;
    let mut per_map = Vec::new();
    let mut node_base = 0u32;
    for m in &cams.maps {
        let map_path = crate::radiance::index::map_path(reflector, &m.file, "exr");
        let at = |e: String| format!("radiance/{map_path}: {e}");
        let stored = read_map(bundle, reflector, m).map_err(|e| e.to_string())?;
        let (image, nodes) = (stored.image, stored.nodes);
        let ch = |n: &str| image.channel(n).map_err(|e| at(e.to_string()));
        let normal = match (image.channel("NX"), image.channel("NY")) {
            (Ok(x), Ok(y)) => Some([x, y]),
            _ => None,
        };
        let map_image = MapImage {
            rgb: [ch("R")?, ch("G")?, ch("B")?],
            hit: ch("A")?,
            z: ch("Z")?,
            normal,
        };
        let count = nodes.len() as u32;
        let tree = splats::map_splats(&m.view, &map_image, nodes, node_base, exact).map_err(at)?;
        per_map.push((tree, node_base));
        node_base += count;
    }
    let splat_bytes = std::mem::size_of::<splats::Splat>() as u64;
    let limit = buffer_limit(gpu, buffer_bytes);
    let bytes: Vec<u64> = per_map
        .iter()
        .map(|(t, _)| t.splats.len() as u64 * splat_bytes)
        .collect();
    let ranges = chunk_maps(&bytes, limit).map_err(|i| {
        format!(
            "radiance/{}: {} splats ({:.0} MiB), more than this GPU binds in one buffer ({:.0} MiB); bake reflector {reflector} at a lower `radiance.resolution`",
            crate::radiance::index::map_path(reflector, &cams.maps[i].file, "exr"),
            per_map[i].0.splats.len(),
            bytes[i] as f64 / (1u64 << 20) as f64,
            limit as f64 / (1u64 << 20) as f64,
        )
    })?;
    let mut trees = Vec::with_capacity(per_map.len());
    let mut chunks = Vec::with_capacity(ranges.len());
    let mut maps = per_map.into_iter();
    for (c, range) in ranges.iter().enumerate() {
        let mut all = Vec::new();
        for (mut tree, base) in maps.by_ref().take(range.len()) {
            let offset = all.len() as u32;
            for r in &mut tree.ranges {
                *r = r.start + offset..r.end + offset;
            }
            all.append(&mut tree.splats);
            trees.push((tree, base, c));
        }
        let points = buffer_init(
            gpu,
            "glint radiance-map splats",
            wgpu::BufferUsages::STORAGE,
            bytemuck::cast_slice(&all),
            32,
        );
        let kept = buffer(
            &gpu.device,
            "glint kept splats",
            (all.len() as u64 * 4).max(16),
            wgpu::BufferUsages::STORAGE,
        );
        chunks.push(SplatChunk {
            points,
            kept,
            group: None,
        });
    }
    let views: Vec<SplatView> = cams.maps.iter().map(|m| SplatView::new(&m.view)).collect();
    let views = buffer_init(
        gpu,
        "glint radiance-map views",
        wgpu::BufferUsages::STORAGE,
        bytemuck::cast_slice(&views),
        std::mem::size_of::<SplatView>() as u64,
    );
    let nodes = buffer(
        &gpu.device,
        "glint quadtree node params",
        (node_base as u64).max(1) * std::mem::size_of::<NodeParams>() as u64,
        wgpu::BufferUsages::STORAGE,
    );
    let chunk_count = chunks.len();
    Ok(SplatMaps {
        maps: cams.maps,
        trees,
        node_count: node_base as usize,
        chunks,
        nodes,
        views,
        plan: Mutex::new((vec![0; chunk_count], FrameStats::default())),
    })
}

impl SplatMaps {
    /// Bytes of its GPU buffers.
    pub(super) fn gpu_bytes(&self) -> u64 {
        self.chunks
            .iter()
            .map(|c| c.points.size() + c.kept.size())
            .sum::<u64>()
            + self.nodes.size()
            + self.views.size()
    }

    /// Plans the splats of the `count` maps per element best for the mirrored `eye` by
    /// `selection`, drawn from `mirrored` into a `width` × `height` map, each map's nodes
    /// culled by `cull` (to the screen window of its element): writes every node's [`NodeParams`] (the write lands before the next
    /// submission) and keeps the draws and statistics for the pass.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn plan(
        &self,
        gpu: &Gpu,
        mirrored: &Camera,
        cull: &splats::Cull,
        eye: Vec3,
        selection: Selection,
        count: usize,
        width: u32,
        height: u32,
        detail: &dyn Fn(Vec3) -> f32,
    ) {
        let chosen = select(&self.maps, eye, selection, count);
        let mut params = vec![NodeParams::default(); self.node_count];
        let mut draws = vec![Vec::new(); self.chunks.len()];
        let mut stats = FrameStats {
            maps: chosen.len(),
            ..FrameStats::default()
        };
        let mut rank = 0;
        for (k, &i) in chosen.iter().enumerate() {
            // `select` groups maps by element, best first.
            rank = if k > 0 && self.maps[chosen[k - 1]].element == self.maps[i].element {
                rank + 1
            } else {
                0
            };
            let (tree, base, chunk) = &self.trees[i];
            let planes = cull.planes(&tree.view);
            stats.selected_splats += tree
                .ranges
                .first()
                .map_or(0, |r| u64::from(r.end - r.start));
            let (culled, visible) = splats::plan_map(
                tree,
                *base,
                i as u32,
                rank,
                mirrored,
                &planes,
                width,
                height,
                detail,
                &mut params,
                &mut draws[*chunk],
            );
            stats.culled_nodes += culled;
            stats.visible_splats += visible;
        }
        let mut kept = Vec::new();
        let mut counts = Vec::with_capacity(self.chunks.len());
        for (chunk, draws) in self.chunks.iter().zip(&draws) {
            splats::kept_indices(draws, &mut kept);
            stats.ranges += draws.len();
            stats.draws += usize::from(!kept.is_empty());
            stats.drawn_splats += kept.len() as u64;
            if !kept.is_empty() {
                gpu.queue
                    .write_buffer(&chunk.kept, 0, bytemuck::cast_slice(&kept));
            }
            counts.push(kept.len() as u32);
        }
        gpu.queue
            .write_buffer(&self.nodes, 0, bytemuck::cast_slice(&params));
        if let Ok(mut plan) = self.plan.lock() {
            *plan = (counts, stats);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn maps_are_split_whole_and_in_order_under_the_limit() {
        assert_eq!(chunk_maps(&[40, 50, 10, 90, 5], 100), Ok(vec![0..3, 3..5]));
        // Exactly the limit fits.
        assert_eq!(chunk_maps(&[100, 100], 100), Ok(vec![0..1, 1..2]));
        assert_eq!(
            chunk_maps(&[30, 30, 30], 1000),
            Ok(std::iter::once(0..3).collect())
        );
        // A map over the limit by itself cannot be bound.
        assert_eq!(chunk_maps(&[10, 101, 10], 100), Err(1));
        // No maps: one empty chunk (a reflector's buffers always exist).
        assert_eq!(chunk_maps(&[], 100), Ok(std::iter::once(0..0).collect()));
        // Every map lands in exactly one chunk, none over the limit.
        let sizes: Vec<u64> = (0..50).map(|i| (i * 37 % 64) as u64 + 1).collect();
        let chunks = chunk_maps(&sizes, 128).unwrap();
        assert_eq!(chunks.first().unwrap().start, 0);
        assert_eq!(chunks.last().unwrap().end, sizes.len());
        for w in chunks.windows(2) {
            assert_eq!(w[0].end, w[1].start);
        }
        for c in &chunks {
            assert!(sizes[c.clone()].iter().sum::<u64>() <= 128);
        }
    }
}

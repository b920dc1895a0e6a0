//! The image-based source of M (Bastos §8.1.3) on the GPU: a reflector's baked radiance maps
//! as splats in one instance buffer, and per frame the maps selected for the mirrored eye,
//! each quadtree node sized by Eq. 3, culled or skipped when minified ([`super::splats`]).

use std::sync::Mutex;

use glam::{Mat4, Vec3};

use super::splats::{self, MapImage, MapSplats, NodeParams, SplatView};
use crate::camera::Camera;
use crate::radiance::index::{MapEntry, load_cameras, read_map};
use crate::view::build::{buffer, buffer_init};
use crate::view::gpu::Gpu;
use crate::view::load::ViewData;
use crate::view::radiance_maps::{Selection, select};

/// What the image-based mode drew for one reflector in the last prepared frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FrameStats {
    /// Maps selected (all elements).
    pub maps: usize,
    /// Splats of the selected maps.
    pub selected_splats: u64,
    /// Splats drawn (after culling and minification skipping).
    pub drawn_splats: u64,
    /// Quadtree nodes culled.
    pub culled_nodes: usize,
    /// Draw calls (one for all drawn splats).
    pub draws: usize,
    /// Ranges of contiguous splats drawn (what one draw call each would cost).
    pub ranges: usize,
}

/// A reflector's maps on the GPU: every map's splats in one storage buffer, in quadtree
/// order; the quadtrees stay on the CPU for per-frame culling and sizing, and each frame's
/// kept splats are listed by index, so they are one draw however many ranges they form.
pub(super) struct SplatMaps {
    maps: Vec<MapEntry>,
    /// Per map: its quadtree and node ranges (splats dropped after upload), node base.
    trees: Vec<(MapSplats, u32)>,
    node_count: usize,
    /// Every map's splats, in quadtree order (`splat_points`, binding 8 of the splat pass).
    pub(super) points: wgpu::Buffer,
    /// This frame's kept splats, indices into `points` (`splat_kept`, binding 9).
    pub(super) kept: wgpu::Buffer,
    /// Per quadtree node, this frame's [`NodeParams`] (binding 6 of the splat pass).
    pub(super) nodes: wgpu::Buffer,
    /// Per map, its camera's [`SplatView`] (binding 10 of the splat pass).
    pub(super) views: wgpu::Buffer,
    /// The splat pass's group 1 (set by the pass that binds `nodes`).
    pub(super) group: Option<wgpu::BindGroup>,
    /// The last prepared frame's kept splat count (`vs_splat` draws 6 vertices each) and
    /// statistics.
    pub(super) plan: Mutex<(u32, FrameStats)>,
}

/// Reads reflector `reflector`'s radiance maps from the bundle and uploads their splats.
pub(super) fn load_splat_maps(
    gpu: &Gpu,
    data: &ViewData,
    reflector: &str,
) -> Result<SplatMaps, String> {
    let cams = load_cameras(&data.bundle, reflector).map_err(|e| e.to_string())?;
    let mut all = Vec::new();
    let mut trees = Vec::new();
    let mut node_base = 0u32;
    for m in &cams.maps {
        let map_path = crate::radiance::index::map_path(reflector, &m.file, "exr");
        let at = |e: String| format!("radiance/{map_path}: {e}");
        let stored = read_map(&data.bundle, reflector, m).map_err(|e| e.to_string())?;
        let (image, nodes) = (stored.image, stored.nodes);
        let ch = |n: &str| image.channel(n).map_err(|e| at(e.to_string()));
        // Bundles baked before the facet normals were stored have none: their splats keep
        // Eq. 3's size parallel to the reflector.
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
        let mut tree = splats::map_splats(&m.view, &map_image, nodes, node_base).map_err(at)?;
        let offset = all.len() as u32;
        for r in &mut tree.ranges {
            *r = r.start + offset..r.end + offset;
        }
        all.append(&mut tree.splats);
        trees.push((tree, node_base));
        node_base += count;
    }
    let points = buffer_init(
        gpu,
        "glint radiance-map splats",
        wgpu::BufferUsages::STORAGE,
        bytemuck::cast_slice(&all),
        32,
    );
    let views: Vec<SplatView> = cams.maps.iter().map(|m| SplatView::new(&m.view)).collect();
    let views = buffer_init(
        gpu,
        "glint radiance-map views",
        wgpu::BufferUsages::STORAGE,
        bytemuck::cast_slice(&views),
        std::mem::size_of::<SplatView>() as u64,
    );
    let kept = buffer(
        &gpu.device,
        "glint kept splats",
        (all.len() as u64 * 4).max(16),
        wgpu::BufferUsages::STORAGE,
    );
    let nodes = buffer(
        &gpu.device,
        "glint quadtree node params",
        (node_base as u64).max(1) * std::mem::size_of::<NodeParams>() as u64,
        wgpu::BufferUsages::STORAGE,
    );
    Ok(SplatMaps {
        maps: cams.maps,
        trees,
        node_count: node_base as usize,
        points,
        kept,
        nodes,
        views,
        group: None,
        plan: Mutex::new((0, FrameStats::default())),
    })
}

impl SplatMaps {
    /// Plans the splats of the `count` maps per element best for the mirrored `eye` by
    /// `selection`, drawn from `mirrored` (view-projection `view_proj`) into a `width` ×
    /// `height` map: writes every node's [`NodeParams`] (the write lands before the next
    /// submission) and keeps the draws and statistics for the pass.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn plan(
        &self,
        gpu: &Gpu,
        mirrored: &Camera,
        view_proj: &Mat4,
        eye: Vec3,
        selection: Selection,
        count: usize,
        width: u32,
        height: u32,
        detail: &dyn Fn(Vec3) -> f32,
    ) {
        let planes = splats::frustum_planes(view_proj);
        let chosen = select(&self.maps, eye, selection, count);
        let mut params = vec![NodeParams::default(); self.node_count];
        let mut draws = Vec::new();
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
            let (tree, base) = &self.trees[i];
            stats.selected_splats += tree
                .ranges
                .first()
                .map_or(0, |r| u64::from(r.end - r.start));
            stats.culled_nodes += splats::plan_map(
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
                &mut draws,
            );
        }
        let mut kept = Vec::new();
        splats::kept_indices(&draws, &mut kept);
        stats.ranges = draws.len();
        stats.draws = usize::from(!kept.is_empty());
        stats.drawn_splats = kept.len() as u64;
        gpu.queue
            .write_buffer(&self.nodes, 0, bytemuck::cast_slice(&params));
        if !kept.is_empty() {
            gpu.queue
                .write_buffer(&self.kept, 0, bytemuck::cast_slice(&kept));
        }
        if let Ok(mut plan) = self.plan.lock() {
            *plan = (kept.len() as u32, stats);
        }
    }
}

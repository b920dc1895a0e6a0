//! Reprojection and reconstruction of radiance maps with depth (Bastos et al. 1999 §8.1.3),
//! pure math: no wgpu.
//!
//! - [`map_splats`]: a map's hit pixels as splats, stored in the order of its quadtree's
//!   leaves (depth first), so that every node's points are one contiguous range, and within a
//!   leaf in reversed Morton order, so that every prefix is an evenly spread subset (the first
//!   quarter is every other pixel on both axes, and so on).
//! - [`point_size`]: Eq. 3 at a node's representative point: the screen extent, in pixels of
//!   the reflected view, of one map pixel.
//! - [`plan_map`]: per frame and selected map, the quadtree walked from the root: nodes
//!   outside the reflected view culled, each visible leaf drawn with its Eq. 3 size, and when
//!   minified (a map pixel smaller than the detail M needs there: a screen pixel, or the
//!   footprint of the sharpest tap of a glossy reflector's M*K filter,
//!   [`super::filter::detail_pixels`]) only the prefix of its points that Eq. 3's step keeps,
//!   each splat grown by the step.
//!
//! - [`fill_hole`]: what the composite reads where no splat covered M's texel.
//!
//! Holes are filled rather than only avoided by bigger splats because, at grazing views, most
//! are not gaps between splats: they are directions no selected map saw. The maps' cameras
//! stop at 80° from the normal, a few per ring, so a mirror seen at 80° reflects directions
//! 50–60° from the nearest map's axis, past the edge of its frustum; no splat size reaches
//! them. The fill runs in the composite, only at the reflector's uncovered pixels, so it adds
//! no pass (a pull-push pyramid needs a pass per level per reflector;
//! docs/tuning.md#hole-fill).
//!
//! Several maps per element, by priority: a lower-ranked map is thinned by Eq. 3's step to
//! every 2^rank-th point where it is minified ([`rank_step`]) and its splats
//! have their depth scaled by [`RANK_DEPTH_SCALE`] per rank (reverse Z: pushed back to
//! 1/0.7 of their distance), so they fill what the better maps leave empty (holes between
//! splats, disocclusions) and do not paint their coarser or more oblique samples over the
//! best map's samples of the same surface, yet a surface the better map saw past wins
//! where it lies well in front. Without a rank order every map's splats would compete by
//! depth alone, and more maps would give a higher error (docs/tuning.md#rank-depth-scale).
//!
//! Kept in one file: each function is the CPU twin of a step of `vs_splat` or the composite in
//! `shaders/reflect.wgsl`, side by side so they stay in step; about 520 of its lines are tests.

use std::ops::Range;

use glam::{Mat4, Vec2, Vec3, Vec4};

use super::exact::ExactSurfaces;
use crate::camera::Camera;
use crate::radiance::normals;
use crate::radiance::quadtree::Node;
use crate::radiance::sampling::MapCamera;

/// Splat size over Eq. 3's point size: > 1 so neighbouring splats overlap and leave no holes
/// where the reflected view sees a surface more obliquely than the map did.
pub const SPLAT_OVERLAP: f32 = 1.5;

/// Clip-z scale of the part of a splat's patch outside its squeezed [`footprint`] (the gap
/// fill, reverse Z: pushed about 5% of its distance back): it loses to any splat's own extent
/// within that distance (a panel's spill onto the wall it hangs on) but wins over what lies
/// far behind (a wall seen between the rows of a model's splats);
/// docs/tuning.md#gap-fill-depth.
pub const GAP_FILL_DEPTH: f32 = 0.95;

/// Clip-z scale per rank of a lower-ranked map (depth × this^rank, reverse Z): rank r + 1
/// loses to rank r unless it is nearer than 0.7 of its distance, so a second map that sees a
/// nearer surface than the best one wins there (docs/tuning.md#rank-depth-scale).
pub const RANK_DEPTH_SCALE: f32 = 0.7;

/// One splat (32 bytes): a point of a radiance map, an element of `splat_points` (WGSL
/// `SplatPoint`, read by `vs_splat` through the frame's kept indices).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Splat {
    /// Scene point.
    pub position: [f32; 3],
    /// Index of its quadtree leaf in the reflector's node table (per-frame size and depth
    /// bias, [`NodeParams`]).
    pub node: u32,
    /// Radiance (D at the point).
    pub color: [f32; 3],
    /// The surface's facet normal there, octahedral, as `pack2x16snorm`
    /// ([`crate::radiance::normals`]); the map's own normal when the bundle has none, which
    /// gives Eq. 3's patch parallel to the reflector ([`footprint`]).
    pub normal: u32,
}

/// Per-frame parameters of one quadtree node (32 bytes, WGSL `SplatNode`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct NodeParams {
    /// A splat's size in map pixels: Eq. 3's step k between the node's kept points ×
    /// [`SPLAT_OVERLAP`].
    pub spacing: f32,
    /// Multiplies clip z: 1 for the best map, smaller (farther, reverse Z) for lower ranks.
    pub depth_scale: f32,
    /// Index of the node's map in the reflector's [`SplatView`]s.
    pub view: u32,
    /// Padding.
    pub _pad: f32,
    /// Half a screen pixel in NDC units: 1 / width, 1 / height.
    pub pixel_ndc: [f32; 2],
    /// Padding.
    pub _pad2: [f32; 2],
}

/// What `vs_splat` needs of a map's camera (80 bytes, WGSL `SplatView`), fixed at load: a
/// map pixel's edges on the element, and the centre of projection and normal to scale them
/// to a point's depth ([`footprint`]).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct SplatView {
    /// Centre of projection; w: the element's depth from it (the image plane's).
    pub centre: [f32; 4],
    /// The reflector's normal (w unused).
    pub normal: [f32; 4],
    /// One map pixel's edge along x on the element (w unused).
    pub pixel_u: [f32; 4],
    /// One map pixel's edge along y on the element (w unused).
    pub pixel_v: [f32; 4],
    /// The element's corner; w: the map's resolution (pixels along each edge).
    pub corner: [f32; 4],
}

impl SplatView {
    /// The parameters of `view`.
    pub fn new(view: &MapCamera) -> SplatView {
        let v = |a: Vec3| a.extend(0.0).to_array();
        let r = view.resolution.max(1) as f32;
        SplatView {
            centre: view.centre.extend(view.depth(view.corner)).to_array(),
            normal: v(view.normal),
            pixel_u: v(view.edge_u / r),
            pixel_v: v(view.edge_v / r),
            corner: view.corner.extend(r).to_array(),
        }
    }
}

/// How far beyond its element's edges, in map pixels, a map's splats keep their depth
/// ([`off_element`]): a splat straddles the edge, and near it the neighbour's map sees
/// much the same (docs/tuning.md#element-margin).
pub const ELEMENT_MARGIN: f32 = 8.0;

/// The clip-z scale of a splat whose point the mirrored eye sees through another element
/// than its map's ([`off_element`]): far back (a 1000 times farther), so it fills holes only.
pub const OFF_ELEMENT_DEPTH_SCALE: f32 = 1e-3;

/// Whether the mirrored eye `eye` sees `p` through another element than the one `view`'s map
/// was taken through (by more than [`ELEMENT_MARGIN`] map pixels). A map holds what its
/// element sees (Bastos §8.1.1: the frusta pass through the element's corners); its points
/// seen through a neighbouring element are seen from far off its centre of projection, with
/// patches stretched and parallax wrong. Such splats are drawn pushed back, so they only fill
/// what the right element's map leaves empty (docs/tuning.md#off-element-depth-scale).
pub fn off_element(view: &SplatView, eye: Vec3, p: Vec3) -> bool {
    let v3 = |a: [f32; 4]| Vec3::new(a[0], a[1], a[2]);
    let (corner, n) = (v3(view.corner), v3(view.normal));
    let (pu, pv) = (v3(view.pixel_u), v3(view.pixel_v));
    let d = p - eye;
    let t = (corner - eye).dot(n) / d.dot(n);
    // Where the eye's ray to p crosses the plane, in map pixels from the corner.
    let x = eye + d * t - corner;
    let a = Vec2::new(
        x.dot(pu) / pu.length_squared(),
        x.dot(pv) / pv.length_squared(),
    );
    let (lo, hi) = (-ELEMENT_MARGIN, view.corner[3] + ELEMENT_MARGIN);
    !(a.cmpge(Vec2::splat(lo)).all() && a.cmple(Vec2::splat(hi)).all())
}

/// The least |cos| between a map's ray and the surface it hit that [`footprint`] uses: a
/// surface the map sees edge-on would stretch a pixel's patch without limit (here, to at most
/// 3.3× its size facing the map), so grazing silhouettes throw no streaks across the
/// reflection (docs/tuning.md#min-slant-cosine).
pub const MIN_SLANT_COSINE: f32 = 0.3;

/// The least fraction of a map pixel's patch, per screen axis, that [`footprint`] keeps when
/// it squeezes the patch into Eq. 3's box.
pub const MIN_SQUEEZE: f32 = 0.25;

/// The screen-space (NDC) image of the world vector `a` at the point whose clip position is
/// `c`, for world-to-clip `view_proj`: the Jacobian of the perspective divide applied to `a`.
pub fn ndc_differential(view_proj: &Mat4, c: Vec4, a: Vec3) -> Vec2 {
    let ac = *view_proj * a.extend(0.0);
    (Vec2::new(ac.x, ac.y) * c.w - Vec2::new(c.x, c.y) * ac.w) / (c.w * c.w)
}

/// A map pixel's patch around a point, on screen: its two edges in NDC ([`footprint`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Footprint {
    /// The patch's edge along the map's x.
    pub u: Vec2,
    /// The patch's edge along the map's y.
    pub v: Vec2,
}

impl Footprint {
    /// Width and height of the patch's bounding box (what Eq. 3 measures).
    pub fn extent(&self) -> Vec2 {
        self.u.abs() + self.v.abs()
    }
}

/// Eq. 3 on the surface's own plane, at one point: map `view`'s pixel patch around `p`, seen
/// through `view_proj`. Eq. 3 ([`point_size`]) takes the patch parallel to the reflector,
/// edges a = the element's pixel edges × z/h (DistanceScale); here the patch is where the
/// pixel's ray pyramid meets the surface through `p` with normal `n` (either sign): edges
/// a′ = a − w (n·a) / (n·w), w the ray from the map's centre to `p`, both projected exactly at
/// `p`. A point on a plane parallel to the reflector (n the reflector's normal, the fallback
/// of bundles without normals) gets Eq. 3's patch; a surface the map sees obliquely but the
/// eye face-on, a larger one; a thin lamp under a ceiling, which map and mirrored eye both
/// see nearly edge-on, a flatter one, so its splats no longer spill over what lies behind it.
/// The patch is then squeezed, per screen axis, to fit in Eq. 3's box: where it is larger
/// (a surface the map sees obliquely and the eye face-on), its half-pixel reach past the
/// surface's edge would draw over what lies beside it (docs/tuning.md#footprint-squeeze),
/// while Eq. 3's smaller splats leave those gaps to the overlap ring, which a neighbour's own
/// splat wins.
/// It keeps at least [`MIN_SQUEEZE`] of its extent, so a splat does not vanish where the eye
/// sees the element's plane edge-on and Eq. 3's box has no height.
/// `None` when `p` is behind the eye. `vs_splat` computes the same and draws the patch itself
/// (a parallelogram), not its bounding box: where a′ is long and skewed on screen, the box
/// would widen a thin feature by most of its length.
pub fn footprint(view: &SplatView, p: Vec3, n: Vec3, view_proj: &Mat4) -> Option<Footprint> {
    let (whole, s) = patch(view, p, n, view_proj)?;
    Some(Footprint {
        u: whole.u * s,
        v: whole.v * s,
    })
}

/// The map pixel's whole patch on the surface ([`footprint`] before the squeeze), which
/// `vs_splat` draws: the squeezed footprint's inscribed ellipse at the point's depth, the rest
/// of the patch's ellipse at [`GAP_FILL_DEPTH`] × it, and the remaining overlap ring far back
/// (× 10⁻³). The squeeze alone left gaps between the rows of a curved model's
/// splats, which the wall behind filled: stripes.
pub fn whole_patch(view: &SplatView, p: Vec3, n: Vec3, view_proj: &Mat4) -> Option<Footprint> {
    patch(view, p, n, view_proj).map(|(whole, _)| whole)
}

/// The patch on the surface and its squeeze per screen axis ([`footprint`]).
fn patch(view: &SplatView, p: Vec3, n: Vec3, view_proj: &Mat4) -> Option<(Footprint, Vec2)> {
    let c = *view_proj * p.extend(1.0);
    // Also refuses a NaN w.
    if c.w.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    let centre = Vec4::from(view.centre);
    let ray = p - centre.truncate();
    let scale = ray.dot(Vec4::from(view.normal).truncate()) / centre.w;
    let (au, av) = (
        Vec4::from(view.pixel_u).truncate() * scale,
        Vec4::from(view.pixel_v).truncate() * scale,
    );
    let w = ray.normalize_or_zero();
    let nw = n.dot(w);
    let slanted = |a: Vec3| {
        if n == Vec3::ZERO || !nw.is_finite() {
            return a;
        }
        let nw = if nw >= 0.0 {
            nw.max(MIN_SLANT_COSINE)
        } else {
            nw.min(-MIN_SLANT_COSINE)
        };
        a - w * (n.dot(a) / nw)
    };
    let d = |a: Vec3| ndc_differential(view_proj, c, slanted(a));
    let (u, v) = (d(au), d(av));
    // Never wider or taller than Eq. 3's box, nor squeezed below MIN_SQUEEZE: see the docs.
    let box_extent =
        ndc_differential(view_proj, c, au).abs() + ndc_differential(view_proj, c, av).abs();
    let s = (box_extent / (u.abs() + v.abs()).max(Vec2::splat(1e-30)))
        .clamp(Vec2::splat(MIN_SQUEEZE), Vec2::ONE);
    Some((Footprint { u, v }, s))
}

/// A splat's half edges in NDC: its [`footprint`]'s edges × half the node's spacing, grown,
/// keeping its shape, until the major axis of its bounding box spans one screen pixel, so
/// that it covers a pixel centre. Not a pixel along both: where a surface is seen obliquely
/// its points lie far closer than a pixel across the view, their splats already overlap
/// there, and a one-pixel minimum would fatten thin bright features by up to half a pixel
/// per side. The quad's corners are the point ± u ± v.
pub fn splat_half_edges(node: &NodeParams, footprint: Footprint) -> Footprint {
    let k = 0.5 * node.spacing;
    let half = footprint.extent() * k;
    let pixels = half / Vec2::from(node.pixel_ndc).max(Vec2::splat(1e-30));
    let k = k * (1.0 / pixels.max_element().max(1e-6)).max(1.0);
    Footprint {
        u: footprint.u * k,
        v: footprint.v * k,
    }
}

/// A map's splats and its quadtree, each node with its range of splats.
#[derive(Clone, Debug, PartialEq)]
pub struct MapSplats {
    /// The map's camera.
    pub view: MapCamera,
    /// Quadtree nodes, root first (as decoded).
    pub nodes: Vec<Node>,
    /// Per node, its splats (indices into `splats`, contiguous).
    pub ranges: Vec<Range<u32>>,
    /// The splats; `Splat::node` is `node_base` + the leaf's index in `nodes`.
    pub splats: Vec<Splat>,
}

/// The map's image channels (row-major, `resolution`² each): radiance, hit mask, depth and,
/// in bundles baked since it was added, the facet normal.
pub struct MapImage<'a> {
    /// Red, green, blue.
    pub rgb: [&'a [f32]; 3],
    /// Hit (> ½) or not.
    pub hit: &'a [f32],
    /// Depth along the map's normal.
    pub z: &'a [f32],
    /// The hit surface's facet normal, octahedral x and y ([`crate::radiance::normals`]).
    pub normal: Option<[&'a [f32]; 2]>,
}

/// Reversed Morton code of a pixel offset within a leaf: sorting by it puts every
/// power-of-two subsampled grid first (even–even pixels, then the rest of every other
/// pixel, …).
pub fn progressive_key(dx: u32, dy: u32) -> u32 {
    let spread = |mut v: u32| {
        v &= 0xffff;
        v = (v | (v << 8)) & 0x00ff_00ff;
        v = (v | (v << 4)) & 0x0f0f_0f0f;
        v = (v | (v << 2)) & 0x3333_3333;
        (v | (v << 1)) & 0x5555_5555
    };
    (spread(dx) | (spread(dy) << 1)).reverse_bits()
}

/// The splats of one map in quadtree order (see the module docs). `node_base` offsets the
/// node indices written into the splats. Pixels that are not hit, or have no valid depth, are
/// left out, and so are points on `exact` surfaces (drawn as geometry instead,
/// [`super::exact`]); a map whose quadtree is empty has no splats.
pub fn map_splats(
    view: &MapCamera,
    image: &MapImage,
    nodes: Vec<Node>,
    node_base: u32,
    exact: &ExactSurfaces,
) -> Result<MapSplats, String> {
    let res = view.resolution as usize;
    let n = res * res;
    if image.hit.len() != n
        || image.z.len() != n
        || image.rgb.iter().any(|c| c.len() != n)
        || image.normal.is_some_and(|e| e.iter().any(|c| c.len() != n))
    {
        return Err(format!("map channels are not {res}² pixels"));
    }
    let mut ranges = vec![0..0; nodes.len()];
    let mut splats = Vec::new();
    if !nodes.is_empty() {
        fill(
            0,
            view,
            image,
            &nodes,
            node_base,
            exact,
            &mut ranges,
            &mut splats,
        )?;
    }
    Ok(MapSplats {
        view: *view,
        nodes,
        ranges,
        splats,
    })
}

#[allow(clippy::too_many_arguments)]
fn fill(
    i: usize,
    view: &MapCamera,
    image: &MapImage,
    nodes: &[Node],
    node_base: u32,
    exact: &ExactSurfaces,
    ranges: &mut [Range<u32>],
    out: &mut Vec<Splat>,
) -> Result<(), String> {
    let node = &nodes[i];
    let start = out.len() as u32;
    if node.is_leaf() {
        let [x0, y0, x1, y1] = node.rect;
        if x1 > view.resolution || y1 > view.resolution {
            return Err(format!("quadtree node {i} lies outside the map"));
        }
        let mut pixels: Vec<(u32, u32, u32)> = (y0..y1)
            .flat_map(|y| (x0..x1).map(move |x| (progressive_key(x - x0, y - y0), x, y)))
            .collect();
        pixels.sort_unstable();
        let res = view.resolution as usize;
        for (_, x, y) in pixels {
            let k = y as usize * res + x as usize;
            let z = image.z[k];
            if image.hit[k] < 0.5 || z.is_nan() || z <= 0.0 {
                continue;
            }
            let p = view.unproject(x as f32 + 0.5, y as f32 + 0.5, z);
            if exact.contains(view.centre, p) {
                continue;
            }
            let oct = match image.normal {
                Some([ex, ey]) => Vec2::new(ex[k], ey[k]),
                None => normals::encode(view.normal),
            };
            out.push(Splat {
                position: p.to_array(),
                node: node_base + i as u32,
                color: image.rgb.map(|c| c[k].max(0.0)),
                normal: normals::pack_snorm2x16(oct),
            });
        }
    } else {
        let first = node.first_child as usize;
        let end = first + node.children as usize;
        if first <= i || end > nodes.len() {
            return Err(format!("quadtree node {i} has children out of order"));
        }
        for c in first..end {
            fill(c, view, image, nodes, node_base, exact, ranges, out)?;
        }
    }
    ranges[i] = start..out.len() as u32;
    Ok(())
}

/// Pixel pitch, in radians of tangent, of a `height`-pixel image with vertical field of view
/// `fov_y` (square pixels): one pixel spans this × depth at that depth.
pub fn pixel_tangent(fov_y: f32, height: u32) -> f32 {
    2.0 * (0.5 * fov_y).tan() / height.max(1) as f32
}

/// Eq. 3, point size: the screen extent (x, y) in pixels of one pixel of the map `view` at
/// the representative point `p`, seen by `camera` (the reflected view) on a `height`-pixel
/// image; `None` when `p` is behind the camera.
///
/// PointSize = DistanceScale · Angular / Window: the map pixel's edges at `p` are the image
/// plane's pixel edges × z/h (DistanceScale, from the map's depth z of `p` and its image
/// plane depth h), each projected on the reflected view's right and up axes (Angular: the
/// dot products with the reference axes), over the reflected view's pixel pitch at `p`'s
/// depth (Window). The extent is that of the bounding box of the projected pixel.
pub fn point_size(view: &MapCamera, p: Vec3, camera: &Camera, height: u32) -> Option<Vec2> {
    let d = (p - camera.position).dot(camera.forward);
    let h = view.depth(view.corner);
    let z = view.depth(p);
    if !(d > 0.0 && h > 0.0 && z > 0.0) {
        return None;
    }
    let r = view.resolution.max(1) as f32;
    let scale = z / h; // DistanceScale (map side)
    let (au, av) = (view.edge_u / r * scale, view.edge_v / r * scale);
    let window = d * pixel_tangent(camera.fov_y, height);
    let x = (au.dot(camera.right).abs() + av.dot(camera.right).abs()) / window;
    let y = (au.dot(camera.up).abs() + av.dot(camera.up).abs()) / window;
    Some(Vec2::new(x, y))
}

/// Eq. 3, step: the power-of-two skip k ≥ 1 between kept points of a node whose map pixels
/// are `size` screen pixels: 1 when magnified, else the largest 2^j ≤ 1 / max(size) (the
/// progressive order keeps exactly every k-th pixel on both axes for a prefix of 1/k² of
/// the points).
pub fn step(size: Vec2) -> u32 {
    let s = size.max_element();
    if s.is_nan() || s <= 0.0 || s >= 0.5 {
        return 1;
    }
    let k = (1.0 / s).log2().floor().clamp(0.0, 15.0) as u32;
    1 << k
}

/// Eq. 3's step for a node of a map of `rank` (0: its element's best) whose map pixels span
/// `size` pixels of the detail M keeps there. A lower-ranked map only fills what the better
/// ones leave empty, so where it is minified its points are at least 2^rank apart (a quarter
/// of them per rank, each splat grown to match). Where it is magnified it is not thinned: it
/// fills disocclusions, the parts of an object the best map's camera does not see, and
/// there its sparse splats alternated with the wall that camera sees past the object, a
/// torn reflection in a mirror (docs/tuning.md#rank-thinning).
pub fn rank_step(size: Vec2, rank: usize) -> u32 {
    let k = step(size);
    if size.max_element() < 1.0 {
        k.max(1 << rank.min(2))
    } else {
        k
    }
}

/// The number of a leaf's `count` points kept at step `k` (its prefix in progressive order).
pub fn kept(count: u32, k: u32) -> u32 {
    count.div_ceil(k.max(1) * k.max(1))
}

/// Frustum planes of a world-to-clip matrix (reverse Z, infinite far): left, right, bottom,
/// top, near, each (a, b, c, d) with a·x + b·y + c·z + d ≥ 0 inside.
pub fn frustum_planes(view_proj: &Mat4) -> [Vec4; 5] {
    let r = |i| view_proj.row(i);
    [
        r(3) + r(0),
        r(3) - r(0),
        r(3) + r(1),
        r(3) - r(1),
        r(3) - r(2),
    ]
}

/// The part of the screen (NDC, lower and upper corners, within [−1, 1]²) that `points`
/// cover under `view_proj`, grown by `margin` (NDC units per axis); `None` when a point lies
/// on or behind the eye's plane (its projection is unbounded) or there are no points.
pub fn screen_window(points: &[Vec3], view_proj: &Mat4, margin: Vec2) -> Option<(Vec2, Vec2)> {
    if points.is_empty() {
        return None;
    }
    let mut lo = Vec2::INFINITY;
    let mut hi = Vec2::NEG_INFINITY;
    for &p in points {
        let c = *view_proj * p.extend(1.0);
        if c.w <= 1e-6 {
            return None;
        }
        let ndc = c.truncate().truncate() / c.w;
        lo = lo.min(ndc);
        hi = hi.max(ndc);
    }
    let lo = (lo - margin).max(Vec2::NEG_ONE);
    let hi = (hi + margin).min(Vec2::ONE);
    Some((lo, hi.max(lo)))
}

/// The corners of the element `view`'s map was taken through, grown by [`ELEMENT_MARGIN`]
/// map pixels (the part of the reflector through which its splats are not [`off_element`]).
pub fn element_corners(view: &MapCamera) -> [Vec3; 4] {
    let m = ELEMENT_MARGIN / view.resolution.max(1) as f32;
    [(-m, -m), (1.0 + m, -m), (1.0 + m, 1.0 + m), (-m, 1.0 + m)]
        .map(|(a, b)| view.corner + view.edge_u * a + view.edge_v * b)
}

/// Where a frame's splats can show: the mirrored view (M's pixels are the frame's), and per
/// map the part of the screen through which the real eye sees the map's element, grown by
/// `margin` (NDC per axis: the composite's reach and the gap fill's). A map's nodes outside
/// that window are culled: there its splats would be [`off_element`], drawn only behind the
/// right element's, and beyond the margin not read at all.
#[derive(Clone, Copy, Debug)]
pub struct Cull {
    /// The mirrored view's view-projection.
    pub mirrored: Mat4,
    /// The real eye's view-projection.
    pub frame: Mat4,
    /// NDC grown around each element's window.
    pub margin: Vec2,
}

impl Cull {
    /// The frustum planes that cull the nodes of the map taken from `view`.
    pub fn planes(&self, view: &MapCamera) -> [Vec4; 5] {
        match screen_window(&element_corners(view), &self.frame, self.margin) {
            Some((lo, hi)) => frustum_planes(&crop_to_window(&self.mirrored, lo, hi)),
            None => frustum_planes(&self.mirrored),
        }
    }
}

/// `view_proj` cropped to the NDC window `lo`–`hi`: the window maps to [−1, 1]², so
/// [`frustum_planes`] of the result bound the part of the view inside the window.
pub fn crop_to_window(view_proj: &Mat4, lo: Vec2, hi: Vec2) -> Mat4 {
    let size = (hi - lo).max(Vec2::splat(1e-6));
    let scale = Vec2::splat(2.0) / size;
    let shift = -(lo + hi) / size;
    let crop = Mat4::from_cols(
        Vec4::new(scale.x, 0.0, 0.0, 0.0),
        Vec4::new(0.0, scale.y, 0.0, 0.0),
        Vec4::new(0.0, 0.0, 1.0, 0.0),
        Vec4::new(shift.x, shift.y, 0.0, 1.0),
    );
    crop * *view_proj
}

/// Whether the box [min, max] lies wholly outside one of `planes`.
pub fn box_outside(planes: &[Vec4], min: Vec3, max: Vec3) -> bool {
    planes.iter().any(|p| {
        let corner = Vec3::select(p.truncate().cmpge(Vec3::ZERO), max, min);
        p.truncate().dot(corner) + p.w < 0.0
    })
}

/// Offsets of the 8 directions [`fill_hole`] samples (axes and diagonals).
pub const FILL_RING: [(i32, i32); 8] = [
    (1, 0),
    (1, 1),
    (0, 1),
    (-1, 1),
    (-1, 0),
    (-1, -1),
    (0, -1),
    (1, -1),
];

/// The value of an M texel no splat covered (alpha 0): the mean of the covered texels
/// (positive alpha) among the [`FILL_RING`] directions on the nearest ring, of radius 1, 2,
/// 4, … pixels, that has any; zero when nothing in the `width` × `height` image `m`
/// (row-major) is covered along them. The composite's `fill_hole` (`shaders/reflect.wgsl`)
/// on the CPU.
pub fn fill_hole(m: &[Vec4], width: u32, height: u32, x: i32, y: i32) -> Vec4 {
    let (w, h) = (width as i32, height as i32);
    let mut r = 1;
    while r < 2 * w.max(h) {
        let (mut sum, mut n) = (Vec4::ZERO, 0.0f32);
        for (dx, dy) in FILL_RING {
            let (qx, qy) = (x + dx * r, y + dy * r);
            if (0..w).contains(&qx) && (0..h).contains(&qy) {
                let t = m[(qy * w + qx) as usize];
                if t.w > 0.0 {
                    sum += t;
                    n += 1.0;
                }
            }
        }
        if n > 0.0 {
            return sum / n;
        }
        r *= 2;
    }
    Vec4::ZERO
}

/// One draw: a range of splats.
pub type Draw = Range<u32>;

/// The splat indices of `draws`, in order: the frame's kept points as `vs_splat` reads them
/// (one draw call for all ranges, however many the thinning leaves unmerged).
pub fn kept_indices(draws: &[Draw], out: &mut Vec<u32>) {
    out.clear();
    out.reserve(draws.iter().map(|d| (d.end - d.start) as usize).sum());
    for d in draws {
        out.extend(d.clone());
    }
}

/// What one selected map contributes to a frame: its draws (appended to `draws`, adjacent
/// ranges merged) and its visible leaves' parameters (written into `params` at
/// `node_base` + leaf index). `rank` is the map's place in its element's selection (0: best).
/// `detail` gives, at a scene point, the finest detail of M in screen pixels that the
/// composite keeps (≥ 1; 1 everywhere for a mirror): Eq. 3's step thins a leaf's points to
/// it. `view` is the map's index among the reflector's [`SplatView`]s. Returns the number of
/// nodes culled and the splats of the leaves left (before Eq. 3's step thins them).
#[allow(clippy::too_many_arguments)]
pub fn plan_map(
    map: &MapSplats,
    node_base: u32,
    view: u32,
    rank: usize,
    camera: &Camera,
    planes: &[Vec4],
    width: u32,
    height: u32,
    detail: &dyn Fn(Vec3) -> f32,
    params: &mut [NodeParams],
    draws: &mut Vec<Draw>,
) -> (usize, u64) {
    let mut culled = 0;
    let mut visible = 0u64;
    if map.nodes.is_empty() {
        return (0, 0);
    }
    let depth_scale = RANK_DEPTH_SCALE.powi(rank.min(8) as i32);
    let mut stack = vec![0usize];
    while let Some(i) = stack.pop() {
        let node = &map.nodes[i];
        let range = map.ranges[i].clone();
        if range.is_empty() {
            continue;
        }
        if box_outside(planes, node.min, node.max) {
            culled += 1;
            continue;
        }
        if !node.is_leaf() {
            // Children pushed in reverse so they pop in storage order (ranges then ascend).
            let first = node.first_child as usize;
            stack.extend((first..first + node.children as usize).rev());
            continue;
        }
        let Some(size) = point_size(&map.view, node.mean, camera, height) else {
            culled += 1;
            continue;
        };
        let k = rank_step(size / detail(node.mean).max(1.0), rank);
        // Eq. 3: the kept points' spacing is k map pixels. Each point's splat is that many of
        // its own footprints, on its surface, grown to a pixel in `vs_splat`
        // ([`footprint`], [`splat_half_edges`]).
        params[(node_base as usize) + i] = NodeParams {
            spacing: k as f32 * SPLAT_OVERLAP,
            depth_scale,
            view,
            _pad: 0.0,
            pixel_ndc: [1.0 / width.max(1) as f32, 1.0 / height.max(1) as f32],
            _pad2: [0.0; 2],
        };
        visible += u64::from(range.end - range.start);
        let n = kept(range.end - range.start, k);
        let draw = range.start..range.start + n;
        match draws.last_mut() {
            Some(last) if last.end == draw.start => last.end = draw.end,
            _ => draws.push(draw),
        }
    }
    (culled, visible)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splat_matches_the_wgsl_struct() {
        crate::assert_wgsl_layout!(
            super::super::shader_source(),
            "SplatPoint",
            Splat {
                position,
                node,
                color,
                normal
            }
        );
        // `splat_points: array<SplatPoint>`: one Splat per element.
        let (stride, element) = crate::view::gpu::wgsl_layout::wgsl_array(
            &super::super::shader_source(),
            "splat_points",
        )
        .unwrap_or_else(|e| panic!("splat_points: {e}"));
        assert_eq!(stride as usize, std::mem::size_of::<Splat>());
        assert!(element.starts_with("Struct"), "splat_points of {element}");
    }

    #[test]
    fn node_params_and_views_match_the_wgsl_structs() {
        crate::assert_wgsl_layout!(
            super::super::shader_source(),
            "SplatNode",
            NodeParams {
                spacing,
                depth_scale,
                view,
                _pad,
                pixel_ndc,
                _pad2
            }
        );
        crate::assert_wgsl_layout!(
            super::super::shader_source(),
            "SplatView",
            SplatView {
                centre,
                normal,
                pixel_u,
                pixel_v,
                corner
            }
        );
        for (array, size) in [
            ("splat_nodes", std::mem::size_of::<NodeParams>()),
            ("splat_views", std::mem::size_of::<SplatView>()),
        ] {
            let (stride, element) =
                crate::view::gpu::wgsl_layout::wgsl_array(&super::super::shader_source(), array)
                    .unwrap_or_else(|e| panic!("{array}: {e}"));
            assert_eq!(stride as usize, size, "{array}");
            assert!(element.starts_with("Struct"), "{array} of {element}");
        }
    }

    fn floor_map(res: u32) -> MapCamera {
        MapCamera {
            centre: Vec3::new(0.0, -1.0, 0.0),
            corner: Vec3::new(-0.5, 0.0, 0.5),
            edge_u: Vec3::X,
            edge_v: -Vec3::Z,
            normal: Vec3::Y,
            resolution: res,
        }
    }

    #[test]
    fn a_map_is_culled_to_its_elements_window() {
        use crate::scene::Plane;
        use crate::view::passes::renderer::view_projection;
        use crate::view::reflections::mirror_camera;
        // The floor element x, z in [−0.5, 0.5]; the eye 2 m above the floor, 3 m back.
        let map = floor_map(64);
        let eye = Camera::look_at(
            Vec3::new(0.0, 2.0, 3.0),
            Vec3::ZERO,
            Vec3::Y,
            60f32.to_radians(),
        );
        let plane = Plane {
            normal: Vec3::Y,
            point: Vec3::ZERO,
        };
        let mirrored = mirror_camera(&eye, &plane);
        let cull = Cull {
            mirrored: view_projection(&mirrored, 1.5, 0.01),
            frame: view_projection(&eye, 1.5, 0.01),
            margin: Vec2::ZERO,
        };
        let planes = cull.planes(&map);
        // A point 0.5 m above the floor, seen in the mirror where the floor point q is.
        let above = |q: Vec3| {
            let from = mirrored.position;
            from + (q - from) * ((0.5 - from.y) / (q.y - from.y))
        };
        let kept = |q: Vec3| {
            let p = above(q);
            !box_outside(&planes, p - 0.01, p + 0.01)
        };
        assert!(kept(Vec3::ZERO));
        assert!(kept(Vec3::new(0.4, 0.0, -0.4)));
        // Seen through the floor beyond the element (and its 8-pixel margin): culled, though
        // the whole mirrored view sees it.
        let beside = above(Vec3::new(1.5, 0.0, 0.0));
        assert!(!box_outside(
            &frustum_planes(&cull.mirrored),
            beside - 0.01,
            beside + 0.01
        ));
        assert!(!kept(Vec3::new(1.5, 0.0, 0.0)));
        assert!(!kept(Vec3::new(0.0, 0.0, 1.2)));
        // The element's corners grow by ELEMENT_MARGIN map pixels.
        let c = element_corners(&map);
        let m = ELEMENT_MARGIN / 64.0;
        assert!((c[0] - Vec3::new(-0.5 - m, 0.0, 0.5 + m)).length() < 1e-6);
        assert!((c[2] - Vec3::new(0.5 + m, 0.0, -0.5 - m)).length() < 1e-6);
    }

    #[test]
    fn a_splat_seen_through_another_element_is_off_its_element() {
        // Element x, z in [−0.5, 0.5] at 64 pixels; the mirrored eye below the floor at +z.
        let view = SplatView::new(&floor_map(64));
        let eye = Vec3::new(0.0, -2.0, 3.0);
        // Points 0.5 m above the floor: the eye's ray to them crosses it at 0.8 of the way.
        let at = |x: f32, z: f32| Vec3::new(x / 0.8, 0.5, 3.0 - (3.0 - z) / 0.8);
        assert!(!off_element(&view, eye, at(0.16, 0.2)));
        assert!(!off_element(&view, eye, at(-0.49, -0.49)));
        // Within the margin, and beyond it.
        let px = 1.0 / 64.0;
        let m = ELEMENT_MARGIN;
        assert!(!off_element(&view, eye, at(0.5 + (m - 0.5) * px, 0.0)));
        assert!(off_element(&view, eye, at(0.5 + (m + 1.0) * px, 0.0)));
        assert!(off_element(&view, eye, at(0.0, -0.5 - (m + 1.0) * px)));
        assert!(off_element(&view, eye, at(0.0, 0.8)));
        assert!(off_element(&view, eye, at(-1.4, 0.0)));
    }

    /// The NDC bounding-box extent of the map pixel around `p` where its four corner rays
    /// meet the plane through `p` with normal `n`, projected exactly by `vp`.
    fn patch_extent(view: &MapCamera, p: Vec3, n: Vec3, vp: &Mat4) -> Vec2 {
        let (px, _) = view.project(p).unwrap();
        let ndc = |q: Vec3| {
            let c = *vp * q.extend(1.0);
            Vec2::new(c.x, c.y) / c.w
        };
        let corners = [(-0.5, -0.5), (0.5, -0.5), (-0.5, 0.5), (0.5, 0.5)].map(|(dx, dy)| {
            let q = view.image_point(px.x + dx, px.y + dy);
            let w = (q - view.centre).normalize();
            // Ray from the centre through q meets the plane n·(x − p) = 0.
            let t = n.dot(p - view.centre) / n.dot(w);
            ndc(view.centre + w * t)
        });
        let lo = corners.iter().fold(Vec2::MAX, |a, &b| a.min(b));
        let hi = corners.iter().fold(Vec2::MIN, |a, &b| a.max(b));
        hi - lo
    }

    #[test]
    fn a_footprint_is_the_map_pixels_patch_on_the_surface() {
        // A floor mirror's map (normal +y), looking up into the room from below.
        let map = floor_map(512);
        let view = SplatView::new(&map);
        let vp_of = |eye: Vec3, at: Vec3| {
            crate::view::passes::renderer::view_projection(
                &Camera::look_at(eye, at, Vec3::Z, 1.0),
                1.5,
                0.01,
            )
        };
        let p = Vec3::new(0.3, 2.5, -0.2);
        // A ceiling (parallel to the reflector, either side), walls and slopes at several
        // angles: the exact patch where the pixel's corner rays meet the surface, projected,
        // squeezed per axis into Eq. 3's box (the patch parallel to the reflector).
        for (eye, n) in [
            (Vec3::new(2.0, 0.5, 3.0), Vec3::Y),
            (Vec3::new(-1.0, 1.0, 2.0), -Vec3::Y),
            (Vec3::new(2.0, 0.5, 3.0), Vec3::new(1.0, 0.4, 0.0)),
            (Vec3::new(2.0, 0.5, 3.0), Vec3::new(0.0, 0.5, 1.0)),
            (Vec3::new(-3.0, 0.2, 0.5), Vec3::new(1.0, 1.0, 0.5)),
            (Vec3::new(0.5, 0.8, 4.0), Vec3::new(-0.2, 0.5, -1.0)),
        ] {
            let n = n.normalize();
            assert!(n.dot((p - map.centre).normalize()).abs() > MIN_SLANT_COSINE);
            let vp = vp_of(eye, p);
            let exact = patch_extent(&map, p, n, &vp);
            let want = exact
                .min(patch_extent(&map, p, Vec3::Y, &vp))
                .max(exact * MIN_SQUEEZE);
            let got = footprint(&view, p, n, &vp).unwrap().extent();
            assert!(
                ((got - want) / want).abs().max_element() < 5e-3,
                "n {n}: {got} vs {want}"
            );
            // The whole patch, drawn to fill gaps, is the exact one, and the squeezed
            // footprint lies within it.
            let whole = whole_patch(&view, p, n, &vp).unwrap().extent();
            assert!(
                ((whole - exact) / exact).abs().max_element() < 5e-3,
                "n {n}: whole {whole} vs {exact}"
            );
            assert!(got.cmple(whole * (1.0 + 1e-6)).all(), "{got} vs {whole}");
        }
        // A wall the map sees 5° from edge-on: stretched no further than at 1 / 0.3.
        let vp = vp_of(Vec3::new(2.0, 0.5, 3.0), p);
        let bounded = footprint(&view, p, Vec3::X, &vp).unwrap().extent();
        let exact = patch_extent(&map, p, Vec3::X, &vp);
        assert!(bounded.cmplt(exact).all(), "{bounded} vs {exact}");
        // Parallel to the reflector it is Eq. 3's point size (in NDC: 2 / height per pixel),
        // for an eye looking straight at the point.
        let eye = Vec3::new(0.3, 0.5, -0.2);
        let cam = Camera::look_at(eye, p, Vec3::Z, 1.0);
        let vp = crate::view::passes::renderer::view_projection(&cam, 1.0, 0.01);
        let eq3 = point_size(&map, p, &cam, 400).unwrap() * (2.0 / 400.0);
        let got = footprint(&view, p, Vec3::Y, &vp).unwrap().extent();
        assert!(
            ((got - eq3) / eq3).abs().max_element() < 1e-3,
            "{got} vs {eq3}"
        );
        // A thin lamp under a ceiling, in a wall mirror's map: the map sees it 20° from
        // edge-on, the eye 3°, so its patch is about tan 3° / tan 20° as tall as Eq. 3's.
        let wall_map = MapCamera {
            centre: Vec3::new(0.0, 1.0, 3.0),
            corner: Vec3::new(-0.5, 2.0, 0.0),
            edge_u: Vec3::X,
            edge_v: -Vec3::Y,
            normal: -Vec3::Z,
            resolution: 256,
        };
        let wall_view = SplatView::new(&wall_map);
        let lamp = Vec3::new(0.0, 2.9, -2.22);
        let vp = vp_of(Vec3::new(0.0, 2.7, 1.5), lamp);
        let thin = footprint(&wall_view, lamp, -Vec3::Y, &vp).unwrap().extent();
        let flat = footprint(&wall_view, lamp, -Vec3::Z, &vp).unwrap().extent();
        assert!(thin.y < 0.3 * flat.y && thin.y > 0.0, "{thin} vs {flat}");
        assert!(
            (thin.x - flat.x).abs() < 1e-3 * flat.x,
            "its width is unchanged"
        );
        // Seen from below, face-on, the same lamp's patch is taller than the box facing the
        // map, which the eye sees edge-on (no height at all): squeezed, to a quarter.
        let vp = vp_of(Vec3::new(0.0, -2.0, -2.22), lamp);
        let up = footprint(&wall_view, lamp, -Vec3::Y, &vp).unwrap().extent();
        let edge_on = footprint(&wall_view, lamp, -Vec3::Z, &vp).unwrap().extent();
        let exact = patch_extent(&wall_map, lamp, -Vec3::Y, &vp);
        assert!(edge_on.y < 1e-6 * exact.y, "{exact} vs {edge_on}");
        let want = exact.min(edge_on).max(exact * MIN_SQUEEZE);
        assert!(
            ((up - want) / want).abs().max_element() < 5e-3,
            "{up} vs {want}"
        );
        // A surface the map sees exactly edge-on stretches 3.3× at most; no normal: Eq. 3's.
        let grazing = footprint(&wall_view, lamp, Vec3::X, &vp).unwrap().extent();
        assert!(grazing.is_finite() && grazing.max_element() < 1e3);
        assert_eq!(
            footprint(&view, p, Vec3::ZERO, &vp_of(eye, p)),
            footprint(&view, p, Vec3::Y, &vp_of(eye, p))
        );
        // Behind the eye: none.
        assert!(footprint(&view, p, Vec3::X, &vp_of(p + Vec3::Z, p + 2.0 * Vec3::Z)).is_none());
    }

    #[test]
    fn a_splat_spans_at_least_a_pixel_along_its_major_axis() {
        let node = NodeParams {
            spacing: 2.0,
            pixel_ndc: [0.01, 0.005],
            ..NodeParams::default()
        };
        let f = |u: Vec2, v: Vec2| Footprint { u, v };
        // Footprint × spacing / 2, a box of 2 × 2 pixels: kept.
        let big = f(Vec2::new(0.015, 0.0), Vec2::new(0.005, -0.01));
        assert_eq!(splat_half_edges(&node, big), big);
        // Below a pixel on both axes: grown, shape kept, to one pixel on the major axis.
        let small = f(Vec2::new(0.002, 0.001), Vec2::new(-0.001, 0.0005));
        let h = splat_half_edges(&node, small);
        let px = h.extent() / Vec2::new(0.01, 0.005);
        assert!((px.max_element() - 1.0).abs() < 1e-6, "{h:?}");
        assert!((h.u.perp_dot(small.u) as f64).abs() < 1e-12 && h.u.x / small.u.x > 1.0);
        assert!((h.v.perp_dot(small.v) as f64).abs() < 1e-12);
    }

    #[test]
    fn holes_take_the_nearest_covered_ring() {
        let (w, h) = (32u32, 16u32);
        let mut m = vec![Vec4::ZERO; (w * h) as usize];
        let at = |x: i32, y: i32| (y * w as i32 + x) as usize;
        // A one-pixel gap between two covered texels: their mean.
        m[at(4, 4)] = Vec4::new(1.0, 0.0, 0.0, 0.5);
        m[at(6, 4)] = Vec4::new(0.0, 1.0, 0.0, 1.0);
        assert_eq!(fill_hole(&m, w, h, 5, 4), Vec4::new(0.5, 0.5, 0.0, 0.75));
        // Far from both: the ring of radius 8 reaches (6, 4) first (from (14, 12), diagonally).
        assert_eq!(fill_hole(&m, w, h, 14, 12), m[at(6, 4)]);
        // Nothing covered: zero; covered texels outside the frame are never read.
        let empty = vec![Vec4::ZERO; (w * h) as usize];
        assert_eq!(fill_hole(&empty, w, h, 0, 0), Vec4::ZERO);
        assert_eq!(
            fill_hole(&m, w, h, 31, 0),
            Vec4::ZERO,
            "no ring direction meets them"
        );
    }

    #[test]
    fn progressive_order_puts_subsampled_grids_first() {
        let mut px: Vec<(u32, u32, u32)> = (0..8)
            .flat_map(|y| (0..8).map(move |x| (progressive_key(x, y), x, y)))
            .collect();
        px.sort_unstable();
        // First 16: every other pixel; first 4: every fourth.
        assert!(px[..16].iter().all(|&(_, x, y)| x % 2 == 0 && y % 2 == 0));
        assert!(px[..4].iter().all(|&(_, x, y)| x % 4 == 0 && y % 4 == 0));
        assert_eq!(kept(64, 2), 16);
        assert_eq!(kept(65, 2), 17);
    }

    #[test]
    fn eq3_point_size_scales_with_distance_and_resolution() {
        let map = floor_map(64);
        // Looking straight up at the ceiling point p from below the floor's mirror image.
        let p = Vec3::new(0.0, 3.0, 0.0);
        let cam = |y: f32| Camera::look_at(Vec3::new(0.0, y, 0.0), p, Vec3::Z, 1.0);
        let near = point_size(&map, p, &cam(1.0), 400).unwrap();
        let far = point_size(&map, p, &cam(-5.0), 400).unwrap();
        // Map pixel at depth 4 (image plane at 1): 4/64 m; camera 2 m away: pitch 2·2tan(½)/400.
        let want = (4.0 / 64.0) / (2.0 * pixel_tangent(1.0, 400));
        assert!((near.x - want).abs() < 1e-3 * want, "{near} vs {want}");
        assert!((near.y - want).abs() < 1e-3 * want);
        // Four times as far: a quarter of the size; twice the map resolution: half.
        assert!((far.x - want / 4.0).abs() < 1e-3 * want);
        let fine = point_size(&floor_map(128), p, &cam(1.0), 400).unwrap();
        assert!((fine.x - want / 2.0).abs() < 1e-3 * want);
        // Behind the camera: none.
        assert!(point_size(&map, Vec3::new(0.0, -9.0, 0.0), &cam(1.0), 400).is_none());
        assert_eq!(step(Vec2::splat(3.0)), 1);
        assert_eq!(step(Vec2::splat(0.3)), 2);
        assert_eq!(step(Vec2::new(0.1, 0.2)), 4);
    }

    #[test]
    fn lower_ranks_are_thinned_only_where_minified() {
        // The best map: Eq. 3's step alone.
        assert_eq!(rank_step(Vec2::splat(0.3), 0), 2);
        assert_eq!(rank_step(Vec2::splat(0.7), 0), 1);
        // Minified: every 2^rank-th point at least (rank 2 and beyond alike).
        assert_eq!(rank_step(Vec2::splat(0.7), 1), 2);
        assert_eq!(rank_step(Vec2::splat(0.7), 3), 4);
        assert_eq!(rank_step(Vec2::new(0.1, 0.2), 1), 4);
        // Magnified along either axis: every point, whatever the rank.
        assert_eq!(rank_step(Vec2::new(0.5, 1.0), 1), 1);
        assert_eq!(rank_step(Vec2::splat(3.0), 2), 1);
    }

    #[test]
    fn frustum_culls_boxes_outside_the_view() {
        let cam = Camera::look_at(Vec3::ZERO, -Vec3::Z, Vec3::Y, 1.0);
        let vp = crate::view::passes::renderer::view_projection(&cam, 1.5, 0.01);
        let planes = frustum_planes(&vp);
        let inside = |c: Vec3| !box_outside(&planes, c - 0.1, c + 0.1);
        assert!(inside(Vec3::new(0.0, 0.0, -5.0)));
        assert!(!inside(Vec3::new(0.0, 0.0, 5.0)), "behind");
        assert!(!inside(Vec3::new(20.0, 0.0, -5.0)), "right");
        assert!(!inside(Vec3::new(0.0, -20.0, -5.0)), "below");
        // Straddling an edge: kept.
        assert!(!box_outside(
            &planes,
            Vec3::new(-100.0, -0.1, -5.0),
            Vec3::new(0.0, 0.1, -4.0)
        ));
    }

    #[test]
    fn a_window_crops_the_frustum_to_the_screen_it_covers() {
        let cam = Camera::look_at(Vec3::ZERO, -Vec3::Z, Vec3::Y, 60f32.to_radians());
        let vp = crate::view::passes::renderer::view_projection(&cam, 1.0, 0.01);
        // A square 1 m wide at 5 m: its window, half-width 0.5 · cot 30° / 5 = 0.173.
        let quad = [(-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5)]
            .map(|(x, y)| Vec3::new(x, y, -5.0));
        let (lo, hi) = screen_window(&quad, &vp, Vec2::ZERO).expect("in front");
        let h = 0.5 / 30f32.to_radians().tan() / 5.0;
        assert!((hi - Vec2::splat(h)).abs().max_element() < 1e-5, "{hi}");
        assert!((lo + Vec2::splat(h)).abs().max_element() < 1e-5, "{lo}");
        // The margin grows it, the screen's edge bounds it.
        let (lo2, hi2) = screen_window(&quad, &vp, Vec2::splat(2.0)).unwrap();
        assert_eq!((lo2, hi2), (Vec2::NEG_ONE, Vec2::ONE));
        // A point behind the eye: no window.
        assert_eq!(
            screen_window(&[Vec3::new(0.0, 0.0, 1.0)], &vp, Vec2::ZERO),
            None
        );
        assert_eq!(screen_window(&[], &vp, Vec2::ZERO), None);
        // The cropped frustum keeps what projects inside the window and culls what does not.
        let planes = frustum_planes(&crop_to_window(&vp, lo, hi));
        let seen = |c: Vec3| !box_outside(&planes, c - 0.01, c + 0.01);
        assert!(seen(Vec3::new(0.0, 0.0, -5.0)));
        assert!(seen(Vec3::new(0.45, -0.45, -5.0)));
        // Far behind the quad, along the same rays: still inside.
        assert!(seen(Vec3::new(0.9, 0.9, -10.0)));
        // Beside it, in view of the whole frame but not of the window.
        assert!(!seen(Vec3::new(1.0, 0.0, -5.0)));
        assert!(!seen(Vec3::new(0.0, -1.0, -5.0)));
        assert!(!box_outside(
            &frustum_planes(&vp),
            Vec3::new(0.99, 0.0, -5.0),
            Vec3::new(1.01, 0.0, -5.0)
        ));
    }

    #[test]
    fn plan_draws_visible_leaves_and_skips_when_minified() {
        let res = 16u32;
        let map = floor_map(res);
        let n = (res * res) as usize;
        let z = vec![4.0f32; n];
        let hit = vec![1.0f32; n];
        let c = vec![0.5f32; n];
        let leaf = |rect: [u32; 4], x: f32| Node {
            rect,
            first_child: u32::MAX,
            children: 0,
            count: 128,
            z: [4.0, 4.0],
            min: Vec3::new(x - 1.0, 3.9, -2.0),
            max: Vec3::new(x + 1.0, 4.1, 2.0),
            mean: Vec3::new(x, 4.0, 0.0),
        };
        let nodes = vec![
            Node {
                rect: [0, 0, 16, 16],
                first_child: 1,
                children: 2,
                count: 256,
                z: [4.0, 4.0],
                min: Vec3::new(-2.0, 3.9, -2.0),
                max: Vec3::new(2.0, 4.1, 2.0),
                mean: Vec3::new(0.0, 4.0, 0.0),
            },
            leaf([0, 0, 8, 16], -1.0),
            leaf([8, 0, 16, 16], 1.0),
        ];
        let image = MapImage {
            rgb: [&c, &c, &c],
            hit: &hit,
            z: &z,
            normal: None,
        };
        let m = map_splats(
            &map,
            &image,
            nodes,
            10,
            &ExactSurfaces::new(&[], Vec::new(), 1e-3, 1e-2),
        )
        .unwrap();
        assert_eq!(m.splats.len(), n);
        assert_eq!(m.ranges[1], 0..128);
        assert_eq!(m.ranges[2], 128..256);
        assert!(m.splats[..128].iter().all(|s| s.node == 11));
        let mut params = vec![NodeParams::default(); 13];
        let plan_with = |cam: &Camera, detail: f32, rank: usize, params: &mut [NodeParams]| {
            let vp = crate::view::passes::renderer::view_projection(cam, 1.0, 0.01);
            let mut draws = Vec::new();
            let (culled, _) = plan_map(
                &m,
                10,
                0,
                rank,
                cam,
                &frustum_planes(&vp),
                100,
                100,
                &|_| detail,
                params,
                &mut draws,
            );
            (draws, culled)
        };
        let plan = |cam: &Camera, params: &mut [NodeParams]| plan_with(cam, 1.0, 0, params);
        // Close, looking at the whole map: both leaves in one merged draw, magnified.
        let up = Camera::look_at(
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(0.0, 4.0, 0.0),
            Vec3::Z,
            1.5,
        );
        let (draws, culled) = plan(&up, &mut params);
        assert_eq!(draws.len(), 1, "{draws:?}");
        assert_eq!((draws[0].clone(), culled), (0..256, 0));
        assert_eq!(params[11].spacing, SPLAT_OVERLAP, "magnified: every point");
        assert_eq!(params[11].pixel_ndc, [0.01, 0.01]);
        assert_eq!(params[11].depth_scale, 1.0);
        // The second-ranked map of the same view, magnified: every point, pushed back.
        let (draws, _) = plan_with(&up, 1.0, 1, &mut params);
        assert_eq!(draws.len(), 1, "{draws:?}");
        assert_eq!(draws[0], 0..256);
        assert!(params[11].depth_scale < 1.0, "rank 1 is pushed back");
        // Where the composite keeps coarser detail than its map pixels (minified), it keeps a
        // quarter of the points.
        let size = point_size(&map, Vec3::new(0.0, 4.0, 0.0), &up, 100)
            .unwrap()
            .max_element();
        assert!(size > 1.0, "magnified: {size}");
        let (draws, _) = plan_with(&up, 1.5 * size, 1, &mut params);
        let total: u32 = draws.iter().map(|d| d.end - d.start).sum();
        assert_eq!(total, 64, "{draws:?}");
        // Its thinned ranges no longer merge, yet they are one list of kept splats (one draw):
        // each leaf's prefix, in order.
        assert_eq!(draws.len(), 2, "{draws:?}");
        let mut kept = vec![7];
        kept_indices(&draws, &mut kept);
        let want: Vec<u32> = (0..32).chain(128..160).collect();
        assert_eq!(kept, want);
        assert!(params[11].depth_scale < 1.0, "rank 1 is pushed back");
        let (_, _) = plan(&up, &mut params);
        // The same view where the composite keeps only 64-pixel detail (a rough lobe's
        // filter): thinned as if minified, the kept splats grown by the step.
        let magnified = params[11].spacing;
        let (draws, _) = plan_with(&up, 64.0, 0, &mut params);
        let total: u32 = draws.iter().map(|d| d.end - d.start).sum();
        assert!(total > 0 && total <= 64, "{draws:?}");
        assert!(params[11].spacing >= 2.0 * magnified);
        // Far away: minified, a quarter (or less) of each leaf.
        let far = Camera::look_at(
            Vec3::new(0.0, -400.0, 0.0),
            Vec3::new(0.0, 4.0, 0.0),
            Vec3::Z,
            1.5,
        );
        let (draws, _) = plan(&far, &mut params);
        let total: u32 = draws.iter().map(|d| d.end - d.start).sum();
        assert!(total <= 64 && total > 0, "{draws:?}");
        // Looking away from the +x leaf: it is culled.
        let side = Camera::look_at(
            Vec3::new(-1.0, 3.0, 0.0),
            Vec3::new(-1.5, 4.0, 0.0),
            Vec3::Z,
            0.5,
        );
        let (draws, culled) = plan(&side, &mut params);
        assert_eq!(draws.len(), 1, "{draws:?}");
        assert_eq!((draws[0].clone(), culled), (0..128, 1));
    }
}

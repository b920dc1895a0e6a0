//! The quadtree over a radiance map's points (Bastos et al. §8.1.3, "Reconstruction"):
//! nodes split until their points span less than a depth range or are fewer than a minimum
//! count. The depth range is relative (z max − z min ≤ r · z min): Eq. 3's distance scale is a
//! ratio of depths, so a node within r shares one point size to within r, at any scene scale; each node keeps its pixel rectangle, its points' bounds and their mean, the
//! representative point for Eq. 3 point sizes and for frustum culling.
//!
//! File format (`*.qtree`), little-endian:
//! | bytes | field |
//! |---|---|
//! | 8 | magic `GLNTQTRE` |
//! | u16 | version (1) |
//! | u16 | reserved (0) |
//! | u32 | node count N |
//! | u32 | map resolution (pixels per side) |
//! | N × 72 | nodes, root first, each node's children consecutive: u32 x0, y0, x1, y1 (pixel rectangle, end exclusive); u32 first child (index of the first of its consecutive children, `u32::MAX` for a leaf); u32 child count; u32 point count; f32 z min, z max; f32 × 3 bounds min; f32 × 3 bounds max; f32 × 3 mean point |
//!
//! Children with no points are not stored; the leaves partition the map's hit pixels.

use glam::Vec3;

/// A quadtree node.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Node {
    /// Pixel rectangle [x0, x1) × [y0, y1).
    pub rect: [u32; 4],
    /// Index of the first child, `u32::MAX` for a leaf.
    pub first_child: u32,
    /// Number of children (0 for a leaf).
    pub children: u32,
    /// Points (hit pixels) inside.
    pub count: u32,
    /// Depth range of its points.
    pub z: [f32; 2],
    /// Bounds of its points.
    pub min: Vec3,
    /// Bounds of its points.
    pub max: Vec3,
    /// Mean of its points: the representative point.
    pub mean: Vec3,
}

impl Node {
    /// Whether the node is a leaf.
    pub fn is_leaf(&self) -> bool {
        self.first_child == u32::MAX
    }
}

/// Split limits.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct QuadtreeLimits {
    /// A node whose points span less than this fraction of their nearest depth is a leaf.
    pub relative_depth_range: f32,
    /// A node with fewer points than this is a leaf.
    pub min_points: u32,
}

/// The version of what [`build`] gives for given inputs: a quadtree kept beside a map's
/// records (`bake::read_cache`) is used only under the version it was built with, so a
/// change to [`build`] must raise it.
pub const BUILD_VERSION: u32 = 1;

/// Builds the quadtree of a `res × res` map. `points[i]` is the scene point of pixel i
/// (row-major) and `depth[i]` its depth; `hit[i]` says whether the pixel saw anything.
pub fn build(
    res: u32,
    points: &[Vec3],
    depth: &[f32],
    hit: &[bool],
    limits: &QuadtreeLimits,
) -> Vec<Node> {
    let mut nodes = Vec::new();
    if let Some(root) = summarize(res, [0, 0, res, res], points, depth, hit) {
        nodes.push(root);
        split(0, res, points, depth, hit, limits, &mut nodes);
    }
    nodes
}

fn summarize(
    res: u32,
    rect: [u32; 4],
    points: &[Vec3],
    depth: &[f32],
    hit: &[bool],
) -> Option<Node> {
    let mut n = Node {
        rect,
        first_child: u32::MAX,
        children: 0,
        count: 0,
        z: [f32::INFINITY, f32::NEG_INFINITY],
        min: Vec3::INFINITY,
        max: Vec3::NEG_INFINITY,
        mean: Vec3::ZERO,
    };
    let mut sum = glam::DVec3::ZERO;
    for y in rect[1]..rect[3] {
        for x in rect[0]..rect[2] {
            let i = (y * res + x) as usize;
            if !hit[i] {
                continue;
            }
            n.count += 1;
            n.z = [n.z[0].min(depth[i]), n.z[1].max(depth[i])];
            n.min = n.min.min(points[i]);
            n.max = n.max.max(points[i]);
            sum += points[i].as_dvec3();
        }
    }
    if n.count == 0 {
        return None;
    }
    n.mean = (sum / n.count as f64).as_vec3();
    Some(n)
}

/// Splits node `i`: its children are appended together, then each is split in turn.
fn split(
    i: usize,
    res: u32,
    points: &[Vec3],
    depth: &[f32],
    hit: &[bool],
    limits: &QuadtreeLimits,
    nodes: &mut Vec<Node>,
) {
    let n = nodes[i];
    let [x0, y0, x1, y1] = n.rect;
    let small = x1 - x0 <= 1 && y1 - y0 <= 1;
    if small
        || n.count < limits.min_points
        || n.z[1] - n.z[0] <= limits.relative_depth_range * n.z[0]
    {
        return;
    }
    let (xm, ym) = ((x0 + x1).div_ceil(2), (y0 + y1).div_ceil(2));
    let quads = [
        [x0, y0, xm, ym],
        [xm, y0, x1, ym],
        [x0, ym, xm, y1],
        [xm, ym, x1, y1],
    ];
    let kids: Vec<Node> = quads
        .iter()
        .filter(|r| r[0] < r[2] && r[1] < r[3])
        .filter_map(|r| summarize(res, *r, points, depth, hit))
        .collect();
    let first = nodes.len();
    nodes[i].first_child = first as u32;
    nodes[i].children = kids.len() as u32;
    nodes.extend(kids);
    for k in first..nodes.len().min(first + nodes[i].children as usize) {
        split(k, res, points, depth, hit, limits, nodes);
    }
}

/// File magic.
pub const MAGIC: &[u8; 8] = b"GLNTQTRE";

/// Serializes nodes (see the module docs for the layout).
pub fn encode(res: u32, nodes: &[Node]) -> Vec<u8> {
    let mut out = Vec::with_capacity(20 + nodes.len() * 72);
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&1u16.to_le_bytes());
    out.extend_from_slice(&0u16.to_le_bytes());
    out.extend_from_slice(&(nodes.len() as u32).to_le_bytes());
    out.extend_from_slice(&res.to_le_bytes());
    for n in nodes {
        for v in n.rect.iter().chain([&n.first_child, &n.children, &n.count]) {
            out.extend_from_slice(&v.to_le_bytes());
        }
        for v in
            n.z.iter()
                .chain(n.min.as_ref())
                .chain(n.max.as_ref())
                .chain(n.mean.as_ref())
        {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    out
}

/// Reads nodes written by [`encode`]: (resolution, nodes), or why not. The nodes are checked
/// to form the tree readers walk from the root: every rectangle non-empty and inside the
/// map, every child after its parent, inside it and apart from its siblings, every node but
/// the root the child of exactly one node. Together these bound the leaves' pixels by the
/// map's.
pub fn decode(bytes: &[u8]) -> Result<(u32, Vec<Node>), String> {
    if bytes.len() < 20 || &bytes[..8] != MAGIC {
        return Err("not a glint quadtree (bad magic)".into());
    }
    let u32_at = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().expect("4 bytes"));
    let f32_at = |o: usize| f32::from_le_bytes(bytes[o..o + 4].try_into().expect("4 bytes"));
    let version = u16::from_le_bytes([bytes[8], bytes[9]]);
    if version != 1 {
        return Err(format!(
            "quadtree format version {version}, this glint reads version 1"
        ));
    }
    let (count, res) = (u32_at(12) as usize, u32_at(16));
    if bytes.len() != 20 + count * 72 {
        return Err(format!(
            "{} bytes, the header implies {}",
            bytes.len(),
            20 + count * 72
        ));
    }
    let nodes: Vec<Node> = (0..count)
        .map(|k| {
            let o = 20 + k * 72;
            let v3 = |o: usize| Vec3::new(f32_at(o), f32_at(o + 4), f32_at(o + 8));
            Node {
                rect: [u32_at(o), u32_at(o + 4), u32_at(o + 8), u32_at(o + 12)],
                first_child: u32_at(o + 16),
                children: u32_at(o + 20),
                count: u32_at(o + 24),
                z: [f32_at(o + 28), f32_at(o + 32)],
                min: v3(o + 36),
                max: v3(o + 48),
                mean: v3(o + 60),
            }
        })
        .collect();
    check_tree(res, &nodes)?;
    Ok((res, nodes))
}

/// The structure [`decode`] promises (see there).
fn check_tree(res: u32, nodes: &[Node]) -> Result<(), String> {
    let mut parents = vec![0u8; nodes.len()];
    for (i, n) in nodes.iter().enumerate() {
        let [x0, y0, x1, y1] = n.rect;
        if !(x0 < x1 && x1 <= res && y0 < y1 && y1 <= res) {
            return Err(format!(
                "node {i}: pixel rectangle [{x0}, {x1}) × [{y0}, {y1}) is empty or outside the {res}² map"
            ));
        }
        if n.is_leaf() {
            continue;
        }
        let (first, count) = (n.first_child as usize, n.children as usize);
        if !(1..=4).contains(&count) || first <= i || first + count > nodes.len() {
            return Err(format!(
                "node {i}: children {first}…{} are not 1 to 4 nodes after it among {}",
                first as u64 + count as u64,
                nodes.len()
            ));
        }
        let kids = &nodes[first..first + count];
        for (k, c) in kids.iter().enumerate() {
            let [cx0, cy0, cx1, cy1] = c.rect;
            if cx0 < x0 || cy0 < y0 || cx1 > x1 || cy1 > y1 {
                return Err(format!("node {}: outside its parent {i}", first + k));
            }
            let overlaps =
                |o: &Node| cx0 < o.rect[2] && o.rect[0] < cx1 && cy0 < o.rect[3] && o.rect[1] < cy1;
            if kids[..k].iter().any(overlaps) {
                return Err(format!("node {}: overlaps a sibling", first + k));
            }
            parents[first + k] = parents[first + k].saturating_add(1);
        }
    }
    if let Some(i) = parents.iter().skip(1).position(|&p| p != 1) {
        return Err(format!(
            "node {}: the child of {}{} nodes, not of one",
            i + 1,
            parents[i + 1],
            if parents[i + 1] == u8::MAX {
                " or more"
            } else {
                ""
            }
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    /// A map with a step in depth and some misses.
    fn map(res: u32) -> (Vec<Vec3>, Vec<f32>, Vec<bool>) {
        let mut rng = Rng::new(3, 0);
        let n = (res * res) as usize;
        let mut pts = Vec::with_capacity(n);
        let mut z = Vec::with_capacity(n);
        let mut hit = Vec::with_capacity(n);
        for i in 0..n {
            let (x, y) = ((i as u32 % res) as f32, (i as u32 / res) as f32);
            let d = if x < res as f32 / 3.0 {
                1.0
            } else {
                5.0 + 0.01 * y
            } + 0.001 * rng.uniform();
            pts.push(Vec3::new(x, y, d));
            z.push(d);
            hit.push(rng.uniform() > 0.1);
        }
        (pts, z, hit)
    }

    #[test]
    fn every_point_in_exactly_one_leaf_and_leaves_respect_their_bounds() {
        let res = 37; // odd: uneven halves
        let (pts, z, hit) = map(res);
        let limits = QuadtreeLimits {
            relative_depth_range: 0.05,
            min_points: 8,
        };
        let nodes = build(res, &pts, &z, &hit, &limits);
        let mut owner = vec![0u32; pts.len()];
        for n in nodes.iter().filter(|n| n.is_leaf()) {
            assert!(
                n.z[1] - n.z[0] <= limits.relative_depth_range * n.z[0]
                    || n.count < limits.min_points
                    || (n.rect[2] - n.rect[0] <= 1 && n.rect[3] - n.rect[1] <= 1),
                "{n:?}"
            );
            for y in n.rect[1]..n.rect[3] {
                for x in n.rect[0]..n.rect[2] {
                    owner[(y * res + x) as usize] += 1;
                }
            }
        }
        for (i, &h) in hit.iter().enumerate() {
            if h {
                assert_eq!(owner[i], 1, "hit pixel {i} in {} leaves", owner[i]);
            }
        }
        // Counts add up; the mean lies inside the bounds.
        assert_eq!(nodes[0].count as usize, hit.iter().filter(|&&h| h).count());
        for n in &nodes {
            assert!(n.mean.cmpge(n.min - 1e-4).all() && n.mean.cmple(n.max + 1e-4).all());
            if !n.is_leaf() {
                let kids = &nodes[n.first_child as usize..(n.first_child + n.children) as usize];
                assert_eq!(kids.iter().map(|k| k.count).sum::<u32>(), n.count);
            }
        }
        let bytes = encode(res, &nodes);
        assert_eq!(decode(&bytes).unwrap(), (res, nodes));
    }

    #[test]
    fn decode_refuses_nodes_that_do_not_form_the_tree() {
        let res = 16;
        let (pts, z, hit) = map(res);
        let limits = QuadtreeLimits {
            relative_depth_range: 0.001,
            min_points: 2,
        };
        let nodes = build(res, &pts, &z, &hit, &limits);
        assert!(nodes.len() > 5 && !nodes[0].is_leaf());
        assert!(decode(&encode(res, &nodes)).is_ok());
        let broken = |edit: &dyn Fn(&mut Vec<Node>)| {
            let mut n = nodes.clone();
            edit(&mut n);
            decode(&encode(res, &n)).unwrap_err()
        };
        let e = broken(&|n| n[0].first_child = 0);
        assert!(e.contains("node 0: children"), "{e}");
        let e = broken(&|n| n[0].children = u32::MAX);
        assert!(e.contains("node 0: children"), "{e}");
        let e = broken(&|n| n[1].rect[2] = res + 1);
        assert!(e.contains("node 1") && e.contains("outside"), "{e}");
        let e = broken(&|n| n[1].rect[0] = n[1].rect[2]);
        assert!(e.contains("is empty"), "{e}");
        let e = broken(&|n| {
            let r = n[1].rect;
            n[2].rect = r;
        });
        assert!(
            e.contains("overlaps a sibling") || e.contains("outside its parent"),
            "{e}"
        );
        // Two parents sharing children: the second internal node points at the first's.
        let e = broken(&|n| {
            let k = (1..n.len()).find(|&k| !n[k].is_leaf()).unwrap();
            let m = (k + 1..n.len()).find(|&m| !n[m].is_leaf() && n[m].first_child > k as u32);
            if let Some(m) = m {
                n[m].first_child = n[k].first_child;
                n[m].children = n[k].children;
                n[m].rect = n[k].rect;
            } else {
                n[k].first_child = 1;
            }
        });
        assert!(e.contains("node"), "{e}");
    }

    #[test]
    fn all_miss_map_has_no_nodes() {
        let res = 8;
        let nodes = build(
            res,
            &vec![Vec3::ZERO; 64],
            &[0.0; 64],
            &[false; 64],
            &QuadtreeLimits {
                relative_depth_range: 0.1,
                min_points: 4,
            },
        );
        assert!(nodes.is_empty());
        assert_eq!(decode(&encode(res, &nodes)).unwrap().1.len(), 0);
    }
}

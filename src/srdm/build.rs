//! SRDM construction (Popescu §4.1–4.2): every row of every rotated domain, read from the
//! depth map and simplified greedily to at most `m` points.

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use rayon::prelude::*;

use super::depth_map::{BACKGROUND, FIX, MIN_DEPTH};
use super::{DepthMap, Domain, ImpostorCamera, SrdmError};
use crate::progress::{Cancelled, Progress};

pub use crate::settings::srdm::{MAX_DOMAINS, MAX_POINTS};

/// Segments whose worst sample is at most this far (in normalized 1/z, a millionth of the
/// depth range, ~16 f32 ulps at 1) are not split: a point there would buy nothing but
/// rounding. A planar span therefore keeps 2 points whatever `m` is.
pub const SPLIT_TOLERANCE: f32 = 1e-6;

/// The two knobs of §4: domains n and points per row m.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SrdmParams {
    /// Number of rotated domains n (θᵢ = πi/n), 1…[`MAX_DOMAINS`].
    pub domains: u32,
    /// Points per simplified row m, 2…[`MAX_POINTS`].
    pub points: u32,
}

impl SrdmParams {
    /// Checks the ranges.
    pub fn validate(&self) -> Result<(), SrdmError> {
        if !(1..=MAX_DOMAINS).contains(&self.domains) {
            return Err(SrdmError::Invalid(format!(
                "{} rotated domains is outside 1…{MAX_DOMAINS}",
                self.domains
            )));
        }
        if !(2..=MAX_POINTS).contains(&self.points) {
            return Err(SrdmError::Invalid(format!(
                "{} points per row is outside 2…{MAX_POINTS} (a span needs two)",
                self.points
            )));
        }
        Ok(())
    }
}

/// Simplified rotated depth maps of one depth map, with its camera: `n × w` rows of `m`
/// points (u, z) each (§4.2: "an array of n·w·m 2D points").
///
/// A row's points are in increasing u; z is the normalized depth, negated on a point that
/// opens a span (no surface joins it to the point before). A row uses `count` points; the
/// rest repeat its last point as an opener (or are (0, −1) in an empty row), so a shader can
/// walk all `m − 1` segments and skip every segment whose end point has z < 0.
#[derive(Clone, Debug, PartialEq)]
pub struct Srdm {
    pub(crate) camera: ImpostorCamera,
    pub(crate) domains: u32,
    pub(crate) points_per_row: u32,
    pub(crate) points: Vec<[f32; 2]>,
    pub(crate) counts: Vec<u16>,
    pub(crate) errors: Vec<f32>,
}

impl Srdm {
    /// Builds the SRDMs of `map` (captured by `camera`): for i in 0…n−1, θᵢ = πi/n; for every
    /// row j, SimplifyRow(j, DM, θᵢ, m) (§4.1). Rows are read straight from the map; no
    /// rotated map is materialized. Domains are built in parallel and the result does not
    /// depend on the thread count. Checks `progress` between domains.
    pub fn build(
        map: &DepthMap,
        camera: ImpostorCamera,
        params: SrdmParams,
        progress: &dyn Progress,
    ) -> Result<Srdm, SrdmError> {
        params.validate()?;
        camera.validate().map_err(SrdmError::Invalid)?;
        if camera.resolution != map.size() {
            return Err(SrdmError::Invalid(format!(
                "the camera is {0}×{0} texels, the depth map {1}×{1}",
                camera.resolution,
                map.size()
            )));
        }
        let (n, w, m) = (
            params.domains as usize,
            map.size() as usize,
            params.points as usize,
        );
        let mut points = vec![[0.0f32; 2]; n * w * m];
        let mut counts = vec![0u16; n * w];
        let mut errors = vec![0.0f32; n * w];
        progress.phase("SRDM domains", n as u64);
        let outcome: Result<(), Cancelled> = points
            .par_chunks_mut(w * m)
            .zip(counts.par_chunks_mut(w))
            .zip(errors.par_chunks_mut(w))
            .enumerate()
            .try_for_each(|(i, ((pts, cnt), err))| {
                if progress.cancelled() {
                    return Err(Cancelled);
                }
                let reader = RowReader::new(map, i as u32, n as u32);
                let mut samples = vec![BACKGROUND; w];
                let mut simplifier = RowSimplifier::default();
                for j in 0..w {
                    reader.read(j as u32, &mut samples, &mut simplifier.spans);
                    let r = simplifier.run(&samples, m, &mut pts[j * m..(j + 1) * m]);
                    cnt[j] = r.count as u16;
                    err[j] = r.error;
                }
                progress.advance(1);
                Ok(())
            });
        outcome?;
        Ok(Srdm {
            camera,
            domains: n as u32,
            points_per_row: m as u32,
            points,
            counts,
            errors,
        })
    }

    /// The capture camera.
    pub fn camera(&self) -> &ImpostorCamera {
        &self.camera
    }

    /// Number of rotated domains n.
    pub fn domains(&self) -> u32 {
        self.domains
    }

    /// Depth-map resolution w: rows per domain and samples per row.
    pub fn resolution(&self) -> u32 {
        self.camera.resolution
    }

    /// Points per row m.
    pub fn points_per_row(&self) -> u32 {
        self.points_per_row
    }

    /// All points, row (i, j) at `[(i·w + j)·m, (i·w + j + 1)·m)`.
    pub fn points(&self) -> &[[f32; 2]] {
        &self.points
    }

    /// Points used per row, row (i, j) at i·w + j.
    pub fn counts(&self) -> &[u16] {
        &self.counts
    }

    /// Largest |depth − polyline| over each row's foreground samples (1 when the row dropped
    /// a span for lack of points), row (i, j) at i·w + j.
    pub fn errors(&self) -> &[f32] {
        &self.errors
    }

    /// The `m` stored points of row `j` of domain `i` (padding included).
    pub fn row(&self, i: u32, j: u32) -> &[[f32; 2]] {
        let (w, m) = (self.resolution() as usize, self.points_per_row as usize);
        let r = i as usize * w + j as usize;
        &self.points[r * m..(r + 1) * m]
    }

    /// The used points of row `j` of domain `i`.
    pub fn row_used(&self, i: u32, j: u32) -> &[[f32; 2]] {
        let w = self.resolution() as usize;
        let count = self.counts[i as usize * w + j as usize] as usize;
        &self.row(i, j)[..count]
    }

    /// The recorded error of row `j` of domain `i`.
    pub fn row_error(&self, i: u32, j: u32) -> f32 {
        self.errors[i as usize * self.resolution() as usize + j as usize]
    }

    /// Bytes of the point array alone (n·w·m·2 f32, the paper's figure).
    pub fn point_bytes(&self) -> u64 {
        self.points.len() as u64 * 8
    }
}

/// The `w` samples of row `j` of domain `i` of `n`: the field ([`DepthMap::sample`]) at
/// u = k + ½, k = 0…w−1, [`BACKGROUND`] where there is none.
pub fn row_samples(map: &DepthMap, n: u32, i: u32, j: u32) -> Vec<f32> {
    let mut out = vec![BACKGROUND; map.size() as usize];
    RowReader::new(map, i, n).read(j, &mut out, &mut Vec::new());
    out
}

/// Reads the rows of one domain from a depth map (§4.1: "no rotated depth maps are actually
/// computed"), visiting only the stretch of each row that can hold foreground.
pub(crate) struct RowReader<'a> {
    map: &'a DepthMap,
    dom: Domain,
    /// Per row, the smallest and largest u of a boundary texel centre within one texel of it.
    extent: Vec<(f32, f32)>,
}

impl<'a> RowReader<'a> {
    /// Domain `i` of `n` over `map`.
    pub fn new(map: &'a DepthMap, i: u32, n: u32) -> RowReader<'a> {
        let w = map.size();
        let dom = Domain::new(i, n, w);
        let mut extent = vec![(f32::INFINITY, f32::NEG_INFINITY); w as usize];
        // A run of foreground samples starts and ends in a boundary texel (the sample before
        // or after it lies in a background or off-map texel, an 8-neighbour), or at the row's
        // ends. A sample lies within √½ texel of its texel's centre, so a boundary texel
        // matters to the rows whose centre line passes within 1 of its centre.
        for &c in map.boundary() {
            let q = dom.coords(c);
            let j0 = (q.y - 1.5).ceil().max(0.0) as usize;
            let j1 = ((q.y + 0.5).floor().max(-1.0) + 1.0) as usize;
            for e in extent.iter_mut().take(j1.min(w as usize)).skip(j0) {
                e.0 = e.0.min(q.x);
                e.1 = e.1.max(q.x);
            }
        }
        RowReader { map, dom, extent }
    }

    /// Fills `out` with the samples of row `j` (the field at u = k + ½; background elsewhere)
    /// and `spans` with its foreground runs (first and last sample).
    pub fn read(&self, j: u32, out: &mut [f32], spans: &mut Vec<(u32, u32)>) {
        out.fill(BACKGROUND);
        spans.clear();
        let w = out.len();
        // Exact integer steps (see depth_map::FIX): sample k at (x0, y0) + k·(dx, dy).
        let base = self.dom.pixel(0.5, j as f32 + 0.5);
        let fixed = |v: f64| (v * FIX) as i64;
        let (x0, y0) = (fixed(base.x as f64 - 0.5), fixed(base.y as f64 - 0.5));
        let (dx, dy) = (fixed(self.dom.e.x as f64), fixed(self.dom.e.y as f64));
        let at = |k: usize| {
            self.map
                .sample_fixed(x0 + k as i64 * dx, y0 + k as i64 * dy)
        };
        // Boundary texels bound the runs inside the row; the row's own ends bound the others.
        let (umin, umax) = self.extent[j as usize];
        let mut k0 = if umin.is_finite() {
            ((umin - 1.5).floor().max(0.0) as usize).min(w)
        } else {
            w
        };
        let mut k1 = if umax.is_finite() {
            ((umax + 0.5).ceil().max(-1.0) + 1.0) as usize
        } else {
            0
        }
        .min(w);
        if at(0) >= 0.0 {
            k0 = 0;
            k1 = k1.max(1);
        }
        if at(w - 1) >= 0.0 {
            k1 = w;
            k0 = k0.min(w - 1);
        }
        if k0 >= k1 {
            return;
        }
        let mut open: Option<u32> = None;
        for (k, o) in out.iter_mut().enumerate().take(k1).skip(k0) {
            let v = at(k);
            *o = v;
            match (v >= 0.0, open) {
                (true, None) => open = Some(k as u32),
                (false, Some(s)) => {
                    spans.push((s, k as u32 - 1));
                    open = None;
                }
                _ => {}
            }
        }
        if let Some(s) = open {
            spans.push((s, k1 as u32 - 1));
        }
    }
}

/// The foreground runs (first and last sample) of a row.
fn find_spans(samples: &[f32], spans: &mut Vec<(u32, u32)>) {
    spans.clear();
    let mut k = 0usize;
    while k < samples.len() {
        if samples[k] >= 0.0 {
            let k0 = k;
            while k < samples.len() && samples[k] >= 0.0 {
                k += 1;
            }
            spans.push((k0 as u32, k as u32 - 1));
        } else {
            k += 1;
        }
    }
}

/// A simplified row: its points and recorded error.
#[derive(Clone, Debug, PartialEq)]
pub struct SimplifiedRow {
    /// The used points (u, z), z negated on span openers.
    pub points: Vec<[f32; 2]>,
    /// Largest |sample − polyline| over the row's foreground samples; 1 if a span was dropped.
    pub error: f32,
    /// Spans left out because 2 points each did not fit in m.
    pub dropped_spans: u32,
}

/// Simplifies one row of samples ([`BACKGROUND`] or depth, sample k at u = k + ½) to at most
/// `m` points (§4.2). See `RowSimplifier::run` for the algorithm.
pub fn simplify_row(samples: &[f32], m: usize) -> SimplifiedRow {
    let mut out = vec![[0.0f32; 2]; m];
    let mut simplifier = RowSimplifier::default();
    find_spans(samples, &mut simplifier.spans);
    let r = simplifier.run(samples, m, &mut out);
    out.truncate(r.count);
    SimplifiedRow {
        points: out,
        error: r.error,
        dropped_spans: r.dropped_spans,
    }
}

/// A polyline vertex: its position code (2k: the left edge of sample k; 2k + 1: sample k
/// itself, so u = code / 2 exactly) and its depth.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Vertex {
    code: u32,
    z: f32,
}

impl Vertex {
    fn u(self) -> f32 {
        self.code as f32 * 0.5
    }
}

/// A segment in the priority queue with its largest error and where it is (§4.2).
#[derive(Clone, Copy, Debug)]
struct Segment {
    error: f32,
    worst: u32,
    a: Vertex,
    b: Vertex,
}

impl PartialEq for Segment {
    fn eq(&self, o: &Self) -> bool {
        self.cmp(o) == Ordering::Equal
    }
}
impl Eq for Segment {}
impl PartialOrd for Segment {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Segment {
    /// Larger error first; on a tie the segment further left, so the order is total.
    fn cmp(&self, o: &Self) -> Ordering {
        self.error
            .total_cmp(&o.error)
            .then_with(|| o.a.code.cmp(&self.a.code))
    }
}

/// What a row came to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct RowResult {
    pub count: usize,
    pub error: f32,
    pub dropped_spans: u32,
}

/// Scratch buffers reused across the rows of a domain.
#[derive(Default)]
pub(crate) struct RowSimplifier {
    /// The row's foreground runs, set before [`RowSimplifier::run`].
    pub spans: Vec<(u32, u32)>,
    order: Vec<usize>,
    heap: BinaryHeap<Segment>,
    initial: Vec<Vertex>,
    inserted: Vec<Vertex>,
    merged: Vec<(Vertex, bool)>,
}

impl RowSimplifier {
    /// §4.2 on one row, writing exactly `out.len() = m` points.
    ///
    /// 1. The samples are read from the map by the caller (step 1).
    /// 2. Each foreground span k0…k1 starts as two points at u = k0 and u = k1 + 1, the outer
    ///    edges of its end samples, at depths extrapolated linearly from the two end samples
    ///    (flat for a one-sample span) and clamped to [MIN_DEPTH, 1] (step 2, Figure 12).
    ///    If 2 points per span do not fit in m, the longest spans are kept and the row's
    ///    error is 1, the whole depth range.
    /// 3. The segment with the largest error (the largest |sample − segment| over the samples
    ///    strictly inside it) is split at that sample, using a priority queue, until the row
    ///    has m points or no segment is worse than [`SPLIT_TOLERANCE`] (step 3).
    ///
    /// Splitting a segment at its worst sample can raise the error of its neighbours (a depth
    /// step inside a span: the diagonal across the step errs by half the step, the first
    /// split by nearly all of it, the second by nothing). The row therefore keeps the best
    /// of the greedy sequence's states with at most m points (the first with the smallest
    /// error). The sequence does not depend on m, so a row's error never grows with m.
    /// `self.spans` must hold the row's foreground runs.
    pub fn run(&mut self, samples: &[f32], m: usize, out: &mut [[f32; 2]]) -> RowResult {
        debug_assert!(m >= 2 && out.len() == m);
        if self.spans.is_empty() {
            out.fill([0.0, -1.0]);
            return RowResult {
                count: 0,
                error: 0.0,
                dropped_spans: 0,
            };
        }
        // Spans that fit: the longest first, then back in row order.
        let kept = self.spans.len().min(m / 2);
        let dropped_spans = (self.spans.len() - kept) as u32;
        if dropped_spans > 0 {
            self.order.clear();
            self.order.extend(0..self.spans.len());
            let spans = &self.spans;
            self.order
                .sort_by_key(|&s| (u32::MAX - (spans[s].1 - spans[s].0), spans[s].0));
            self.order.truncate(kept);
            self.order.sort_unstable();
            let picked: Vec<(u32, u32)> = self.order.iter().map(|&s| self.spans[s]).collect();
            self.spans = picked;
        }

        self.heap.clear();
        self.initial.clear();
        self.inserted.clear();
        for &(k0, k1) in &self.spans {
            let (d0, d1) = (samples[k0 as usize], samples[k1 as usize]);
            let (left, right) = if k1 > k0 {
                let d0n = samples[k0 as usize + 1];
                let d1p = samples[k1 as usize - 1];
                (d0 - 0.5 * (d0n - d0), d1 + 0.5 * (d1 - d1p))
            } else {
                (d0, d1)
            };
            let a = Vertex {
                code: 2 * k0,
                z: left.clamp(MIN_DEPTH, 1.0),
            };
            let b = Vertex {
                code: 2 * (k1 + 1),
                z: right.clamp(MIN_DEPTH, 1.0),
            };
            self.initial.push(a);
            self.initial.push(b);
            if let Some(s) = segment(samples, a, b) {
                self.heap.push(s);
            }
        }
        let current = |heap: &BinaryHeap<Segment>| heap.peek().map_or(0.0, |s| s.error);
        let mut best = (current(&self.heap), 0usize);
        let budget = m - self.initial.len();
        while self.inserted.len() < budget {
            let Some(&top) = self.heap.peek() else { break };
            if top.error <= SPLIT_TOLERANCE {
                break;
            }
            self.heap.pop();
            let v = Vertex {
                code: 2 * top.worst + 1,
                z: samples[top.worst as usize],
            };
            self.inserted.push(v);
            for (a, b) in [(top.a, v), (v, top.b)] {
                if let Some(s) = segment(samples, a, b) {
                    self.heap.push(s);
                }
            }
            let e = current(&self.heap);
            if e < best.0 {
                best = (e, self.inserted.len());
            }
        }

        // The best state: the initial points and the first best.1 splits, in u order.
        self.merged.clear();
        for (n, v) in self.initial.iter().enumerate() {
            self.merged.push((*v, n % 2 == 0));
        }
        self.merged
            .extend(self.inserted[..best.1].iter().map(|v| (*v, false)));
        self.merged.sort_unstable_by_key(|(v, _)| v.code);
        for (o, (v, opens)) in out.iter_mut().zip(&self.merged) {
            *o = [v.u(), if *opens { -v.z } else { v.z }];
        }
        let count = self.merged.len();
        let last = out[count - 1];
        out[count..].fill([last[0], -last[1].abs()]);
        RowResult {
            count,
            error: if dropped_spans > 0 { 1.0 } else { best.0 },
            dropped_spans,
        }
    }
}

/// The segment a–b with its worst interior sample, `None` when no sample lies strictly
/// inside it.
#[inline]
fn segment(samples: &[f32], a: Vertex, b: Vertex) -> Option<Segment> {
    let (k_lo, k_hi) = (a.code.div_ceil(2), b.code / 2);
    if k_lo >= k_hi {
        return None;
    }
    let slope = (b.z - a.z) / (b.u() - a.u());
    // Sample k + i sits at u = k + i + ½: its offset from a is x0 + i.
    let x0 = k_lo as f32 + 0.5 - a.u();
    let span = &samples[k_lo as usize..k_hi as usize];
    let err = |i: usize, d: f32| (d - (a.z + (x0 + i as f32) * slope)).abs();
    // Eight independent running maxima with where each first occurred, which the compiler
    // turns into vector instructions; then the largest, the earliest on a tie, which is the
    // first sample with the largest error whatever the grouping.
    let mut lanes = [0.0f32; 8];
    let mut at = [0u32; 8];
    let mut chunks = span.chunks_exact(8);
    let mut i0 = 0u32;
    for c in &mut chunks {
        for j in 0..8 {
            let e = err(i0 as usize + j, c[j]);
            let better = e > lanes[j];
            lanes[j] = if better { e } else { lanes[j] };
            at[j] = if better { i0 + j as u32 } else { at[j] };
        }
        i0 += 8;
    }
    for (j, &d) in chunks.remainder().iter().enumerate() {
        let e = err(i0 as usize + j, d);
        if e > lanes[j] {
            lanes[j] = e;
            at[j] = i0 + j as u32;
        }
    }
    let (mut error, mut worst) = (0.0f32, 0u32);
    for j in 0..8 {
        if lanes[j] > error || (lanes[j] == error && at[j] < worst) {
            error = lanes[j];
            worst = at[j];
        }
    }
    Some(Segment {
        error,
        worst: k_lo + worst,
        a,
        b,
    })
}

/// Accuracy of an SRDM against the map it simplifies, over every foreground sample of every
/// row of every domain ("computed over all depth map texels and all SRDMs", §5.2).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct ErrorStats {
    /// Foreground row samples, all domains.
    pub samples: u64,
    /// Of those, the ones the rows represent (the rest lie in dropped spans).
    pub represented: u64,
    /// Mean |Δd| in normalized 1/z over represented samples.
    pub mean_depth_error: f64,
    /// Mean |z' − z| / z over represented samples (z along the view direction): the figure of §5.2.
    pub mean_relative_z_error: f64,
    /// Mean |z' − z| / (yon − hither): the same error relative to the object's depth range.
    pub mean_range_error: f64,
    /// Mean of the recorded per-row errors over rows with foreground.
    pub mean_row_error: f64,
    /// Largest recorded per-row error.
    pub max_row_error: f32,
    /// Rows that dropped a span for lack of points.
    pub rows_dropping_spans: u64,
    /// Points in use over all rows (the rest is padding).
    pub points_used: u64,
}

/// Measures `srdm` against `map`: each row is read again and compared with its polyline.
/// Sums are in f64 and reduced in domain order, so the figures do not depend on threads.
pub fn error_stats(map: &DepthMap, srdm: &Srdm) -> ErrorStats {
    let (n, w) = (srdm.domains, srdm.resolution());
    let cam = srdm.camera;
    let per_domain: Vec<(ErrorStats, u64)> = (0..n)
        .into_par_iter()
        .map(|i| {
            let reader = RowReader::new(map, i, n);
            let mut s = ErrorStats::default();
            let mut rows_fg = 0u64;
            let mut samples = vec![BACKGROUND; w as usize];
            let mut spans = Vec::new();
            for j in 0..w {
                reader.read(j, &mut samples, &mut spans);
                let used = srdm.row_used(i, j);
                s.points_used += used.len() as u64;
                let mut fg = false;
                let mut seg = 0usize;
                for (k, &d) in samples.iter().enumerate() {
                    if d < 0.0 {
                        continue;
                    }
                    fg = true;
                    s.samples += 1;
                    let u = k as f32 + 0.5;
                    while seg + 1 < used.len() && used[seg + 1][0] < u {
                        seg += 1;
                    }
                    if seg + 1 >= used.len() {
                        continue;
                    }
                    let (p, q) = (used[seg], used[seg + 1]);
                    if q[1] < 0.0 || u < p[0] || u > q[0] {
                        continue; // a gap: the sample's span was dropped
                    }
                    let (za, zb) = (p[1].abs(), q[1]);
                    let g = za + (u - p[0]) * (zb - za) / (q[0] - p[0]);
                    s.represented += 1;
                    s.mean_depth_error += (g - d).abs() as f64;
                    let (zt, zg) = (cam.z_of_depth(d) as f64, cam.z_of_depth(g) as f64);
                    s.mean_relative_z_error += (zg - zt).abs() / zt;
                    s.mean_range_error += (zg - zt).abs() / (cam.yon - cam.hither) as f64;
                }
                if fg {
                    let e = srdm.row_error(i, j);
                    s.mean_row_error += e as f64;
                    s.max_row_error = s.max_row_error.max(e);
                    // Only a row that dropped a span records 1 (see RowSimplifier::run).
                    s.rows_dropping_spans += u64::from(e >= 1.0);
                    rows_fg += 1;
                }
            }
            (s, rows_fg)
        })
        .collect();
    let mut t = ErrorStats::default();
    let mut rows_fg = 0u64;
    for (s, fg) in per_domain {
        rows_fg += fg;
        t.samples += s.samples;
        t.represented += s.represented;
        t.mean_depth_error += s.mean_depth_error;
        t.mean_relative_z_error += s.mean_relative_z_error;
        t.mean_range_error += s.mean_range_error;
        t.mean_row_error += s.mean_row_error;
        t.max_row_error = t.max_row_error.max(s.max_row_error);
        t.points_used += s.points_used;
        t.rows_dropping_spans += s.rows_dropping_spans;
    }
    let per = |v: f64, n: u64| if n > 0 { v / n as f64 } else { 0.0 };
    t.mean_depth_error = per(t.mean_depth_error, t.represented);
    t.mean_relative_z_error = per(t.mean_relative_z_error, t.represented);
    t.mean_range_error = per(t.mean_range_error, t.represented);
    t.mean_row_error = per(t.mean_row_error, rows_fg);
    t
}

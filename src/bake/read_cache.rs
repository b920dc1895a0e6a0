//! The radiance maps' records of what their pixels read of D ([`crate::radiance::reads`]),
//! and the cube-map captures' of what their texels read ([`crate::materials::capture_reads`]),
//! kept between bakes of a reflector's, a probe's or an environment map's work unit by the
//! plain `glint-bake`, in a folder beside its shard in the unit cache
//! (`B.units/radiance.NAME.reads/`, one file per map and its quadtree, [`read_quadtree`];
//! `B.units/probe.NAME.reads/`, `B.units/envmap.NAME.reads/`, one file per cube face); a job
//! engine's shards keep none.
//!
//! A record is evaluated only under the key it was written with: everything its reads and
//! weights depend on but D (so not the albedos) and the lobes and transmission of the
//! materials met (the geometry and textures, every other material field, the map's camera,
//! the glossy sample count, the ray offset, the code's version; for a capture, the area
//! lights, the reflectors, its point and settings); the file carries the prints of those lobes
//! ([`MaterialPrints`]), so that only the pixels that met a changed material are shaded
//! again. A file that is missing, of another key or damaged (BLAKE3 over its body) is not
//! used: the map is traced. A unit's records are bounded by [`READS_BUDGET`]: past it the
//! folder is removed and the unit keeps none. Files are written whole (a temporary file, then
//! a rename) and not flushed: a torn one fails its hash.

use std::borrow::Cow;
use std::io::Write;
use std::ops::Range;
use std::path::{Path, PathBuf};

use crate::bundle::BundleError;
use crate::materials::envmap::CaptureSettings;
use crate::radiance::quadtree::{self, QuadtreeLimits};
use crate::radiance::reads::MapReads;
use crate::radiance::sampling::MapCamera;
use crate::scene::{Material, Scene};

/// First bytes of a record file, with its format's version.
const MAGIC: &[u8; 13] = b"glint-reads-1";

/// Most bytes of records one reflector's unit keeps.
pub const READS_BUDGET: u64 = 1 << 30;

/// The folder of the records of the shard at `shard` (`radiance.NAME.glint` →
/// `radiance.NAME.reads`).
pub fn reads_dir(shard: &Path) -> PathBuf {
    shard.with_extension("reads")
}

/// Per material, a hash of what shapes the rays cast from its surfaces and the weights of
/// their reads: its lobes and its transmission.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MaterialPrints(pub Vec<[u8; 32]>);

impl MaterialPrints {
    /// The prints of `materials`.
    pub fn of(materials: &[Material]) -> MaterialPrints {
        MaterialPrints(
            materials
                .iter()
                .map(|m| {
                    // Debug prints every float so that it reads back exactly.
                    let text = format!("{:?} {:?}", m.lobes, m.transmission);
                    *blake3::hash(text.as_bytes()).as_bytes()
                })
                .collect(),
        )
    }

    /// Per material of `self`, whether `earlier` (the prints a record was made with) differs:
    /// every material when the counts differ.
    pub fn changed_since(&self, earlier: &MaterialPrints) -> Vec<bool> {
        if self.0.len() != earlier.0.len() {
            return vec![true; self.0.len()];
        }
        self.0.iter().zip(&earlier.0).map(|(a, b)| a != b).collect()
    }
}

/// What every record's key of a bake of `scene` shares: the code's version, the geometry and
/// textures, and every material field but the albedo, lobes and transmission.
fn materials_key(scene: &Scene) -> blake3::Hasher {
    let mut h = blake3::Hasher::new();
    h.update(MAGIC);
    h.update(crate::bundle::manifest::generator().as_bytes());
    // The geometry's hash covers the glTF's buffers and images: the textures.
    h.update(scene.geometry_hash.as_bytes());
    for m in &scene.materials {
        let mut rest = m.clone();
        // D carries the albedo; the prints carry the lobes and transmission.
        rest.albedo = glam::Vec3::ZERO;
        rest.lobes.clear();
        rest.transmission = crate::scene::material::Transmission::NONE;
        h.update(format!("{rest:?}").as_bytes());
    }
    h
}

/// What every map's key of a bake of `scene` shares (module comment).
pub fn scene_key(scene: &Scene, normal_offset: f32) -> blake3::Hasher {
    let mut h = materials_key(scene);
    h.update(&crate::radiance::shading::GLOSSY_SAMPLES.to_le_bytes());
    h.update(&normal_offset.to_bits().to_le_bytes());
    h
}

/// The key of one cube-map capture's records ([`crate::materials::capture_reads`]): besides
/// what every key shares (module comment), the area lights (which its rays collect), the
/// reflectors (which of them are near-mirrors its rays follow), the capture's settings, its
/// point and the triangles it sees through.
pub fn capture_key(
    scene: &Scene,
    settings: &CaptureSettings,
    centre: glam::Vec3,
    see_through: &[u32],
) -> [u8; 32] {
    let mut h = materials_key(scene);
    h.update(b"capture");
    // Debug prints every float so that it reads back exactly.
    h.update(format!("{:?} {:?} {settings:?}", scene.lights, scene.reflectors).as_bytes());
    for c in centre.to_array() {
        h.update(&c.to_bits().to_le_bytes());
    }
    for t in see_through {
        h.update(&t.to_le_bytes());
    }
    *h.finalize().as_bytes()
}

/// The key of one map: [`scene_key`] with its camera.
pub fn map_key(scene_key: &blake3::Hasher, cam: &MapCamera) -> [u8; 32] {
    let mut h = scene_key.clone();
    h.update(format!("{cam:?}").as_bytes());
    *h.finalize().as_bytes()
}

/// A record file read whole and checked ([`read`]): the prints its records were made with,
/// and the records, which borrow its bytes.
#[derive(Clone, Debug, PartialEq)]
pub struct RecordFile {
    /// The prints of the materials when the records were made.
    pub prints: MaterialPrints,
    bytes: Vec<u8>,
    /// Where the records' encoding starts in `bytes`.
    reads_at: usize,
}

impl RecordFile {
    /// The records, borrowing the file's bytes.
    pub fn reads(&self) -> MapReads<'_> {
        MapReads::decode(&self.bytes[self.reads_at..]).expect("checked when read")
    }

    /// The BLAKE3 of its body (prints and records), as its head gives it.
    pub fn sum(&self) -> [u8; 32] {
        let at = MAGIC.len() + 32;
        self.bytes[at..at + 32]
            .try_into()
            .expect("checked when read")
    }
}

/// Where one row of records held for a later write lies ([`HeldRows`]).
#[derive(Clone, Debug)]
enum HeldRow {
    /// Bytes of the record file the records were read from.
    Kept(Range<usize>),
    /// The row's own bytes (traced again).
    Fresh(Vec<u8>),
}

/// Per row of a map's records, where its bytes lie: rows kept as they were borrow the file
/// they were read from, so the records can be held past that borrow ([`HeldRows::with`]) and
/// written later without copying them.
#[derive(Clone, Debug)]
pub struct HeldRows {
    rows: Vec<HeldRow>,
    /// Address of the file's bytes the kept rows lie in (0 without a file).
    base: usize,
}

impl HeldRows {
    /// The rows of `reads`, those borrowed from `file` by their place in its bytes.
    pub fn of(file: Option<&RecordFile>, reads: MapReads<'_>) -> HeldRows {
        let (base, len) = file.map_or((0, 0), |f| (f.bytes.as_ptr() as usize, f.bytes.len()));
        let rows = reads
            .rows
            .into_iter()
            .map(|row| match row {
                Cow::Owned(v) => HeldRow::Fresh(v),
                Cow::Borrowed(s) => {
                    let at = (s.as_ptr() as usize).wrapping_sub(base);
                    if file.is_some() && at <= len && s.len() <= len - at {
                        HeldRow::Kept(at..at + s.len())
                    } else {
                        HeldRow::Fresh(s.to_vec())
                    }
                }
            })
            .collect();
        HeldRows { rows, base }
    }

    /// The records, holding `file`: the one [`HeldRows::of`] was given.
    pub fn with(self, file: Option<RecordFile>) -> HeldReads {
        let base = file.as_ref().map_or(0, |f| f.bytes.as_ptr() as usize);
        assert_eq!(base, self.base, "the rows' own file");
        HeldReads {
            file,
            rows: self.rows,
        }
    }
}

/// A map's records held to be written later ([`HeldRows`]).
#[derive(Clone, Debug)]
pub struct HeldReads {
    file: Option<RecordFile>,
    rows: Vec<HeldRow>,
}

impl HeldReads {
    /// The records, borrowing what holds them.
    pub fn reads(&self) -> MapReads<'_> {
        let bytes = self.file.as_ref().map_or(&[][..], |f| &f.bytes[..]);
        let rows = self
            .rows
            .iter()
            .map(|r| match r {
                HeldRow::Kept(at) => Cow::Borrowed(&bytes[at.clone()]),
                HeldRow::Fresh(v) => Cow::Borrowed(&v[..]),
            })
            .collect();
        MapReads { rows }
    }
}

/// Reads the record `name` in `dir` written under `key`: the prints it was made with and the
/// records; `None` when missing, of another key or damaged.
pub fn read(dir: &Path, name: &str, key: &[u8; 32]) -> Option<RecordFile> {
    let bytes = std::fs::read(dir.join(name)).ok()?;
    let rest = bytes.strip_prefix(MAGIC.as_slice())?;
    let (k, rest) = rest.split_first_chunk::<32>()?;
    let (sum, rest) = rest.split_first_chunk::<32>()?;
    if k != key || blake3::hash(rest).as_bytes() != sum {
        return None;
    }
    let (n, mut rest) = rest.split_first_chunk::<4>()?;
    let mut prints = Vec::new();
    for _ in 0..u32::from_le_bytes(*n) {
        let (p, r) = rest.split_first_chunk::<32>()?;
        prints.push(*p);
        rest = r;
    }
    MapReads::decode(rest)?;
    let reads_at = bytes.len() - rest.len();
    Some(RecordFile {
        prints: MaterialPrints(prints),
        bytes,
        reads_at,
    })
}

/// The records `name` in `dir` kept under `key` ([`read`]; none without `dir`), and per
/// material whether its print in `prints` differs from theirs (empty without records).
pub fn kept(
    dir: Option<&Path>,
    name: &str,
    key: &[u8; 32],
    prints: &MaterialPrints,
) -> (Option<RecordFile>, Vec<bool>) {
    match dir.and_then(|dir| read(dir, name, key)) {
        Some(file) => {
            let changed = prints.changed_since(&file.prints);
            (Some(file), changed)
        }
        None => (None, Vec::new()),
    }
}

/// The head of a record file's body: the prints, then [`MapReads::head`] (the rows follow).
fn body_head(prints: &MaterialPrints, reads: &MapReads) -> Vec<u8> {
    let mut head = Vec::with_capacity(4 + 32 * prints.0.len() + 4 + 4 * reads.rows.len());
    head.extend((prints.0.len() as u32).to_le_bytes());
    for p in &prints.0 {
        head.extend(p);
    }
    head.extend(reads.head());
    head
}

/// The BLAKE3 of the body of a record file of `prints` and `reads` (the prints and
/// [`MapReads::encode`]'s bytes; [`RecordFile::sum`] of the file written), the rows hashed
/// where they lie: a probe's records run to a hundred megabytes.
pub fn record_sum(prints: &MaterialPrints, reads: &MapReads) -> [u8; 32] {
    // Rows are hashed a batch at a time: BLAKE3 hashes a long run of whole 1 KiB chunks at
    // once on every SIMD lane, and a map's rows of a few kilobytes apiece, hashed one by one,
    // leave most lanes idle (docs/measurements.md#the-edit-loop).
    const BATCH: usize = 1 << 20;
    let mut h = blake3::Hasher::new();
    let mut batch = body_head(prints, reads);
    batch.reserve(BATCH);
    for r in &reads.rows {
        if batch.len() + r.len() > BATCH {
            h.update(&batch);
            batch.clear();
        }
        if r.len() >= BATCH {
            h.update(r);
        } else {
            batch.extend_from_slice(r);
        }
    }
    h.update(&batch);
    *h.finalize().as_bytes()
}

/// Writes a record file to `out`: magic, key, `sum` (the body's [`record_sum`]), then the
/// body, the rows from where they lie.
fn put_record(
    out: &mut impl std::io::Write,
    key: &[u8; 32],
    sum: &[u8; 32],
    prints: &MaterialPrints,
    reads: &MapReads,
) -> std::io::Result<()> {
    let mut top = Vec::with_capacity(MAGIC.len() + 64);
    top.extend(MAGIC);
    top.extend(key);
    top.extend(sum);
    top.extend(body_head(prints, reads));
    out.write_all(&top)?;
    for r in &reads.rows {
        out.write_all(r)?;
    }
    Ok(())
}

/// Bytes of a record file of `prints` and `reads` ([`put_record`]).
fn record_len(prints: &MaterialPrints, reads: &MapReads) -> u64 {
    (MAGIC.len() + 64 + 4 + 32 * prints.0.len() + reads.size()) as u64
}

/// The bytes of a record file: key, hash, prints and records.
pub fn encode(key: &[u8; 32], prints: &MaterialPrints, reads: &MapReads) -> Vec<u8> {
    let mut bytes = Vec::with_capacity(record_len(prints, reads) as usize);
    let sum = record_sum(prints, reads);
    put_record(&mut bytes, key, &sum, prints, reads).expect("writing to memory");
    bytes
}

/// Writes a record file's `bytes` as `name` into `dir` (created if need be): a temporary
/// file, then a rename.
pub fn write(dir: &Path, name: &str, bytes: &[u8]) -> Result<(), BundleError> {
    write_with(dir, name, |f| f.write_all(bytes))
}

/// Writes the file `name` into `dir` (created if need be) with `fill`: a temporary file,
/// then a rename.
fn write_with(
    dir: &Path,
    name: &str,
    fill: impl FnOnce(&mut std::fs::File) -> std::io::Result<()>,
) -> Result<(), BundleError> {
    let io = |path: &Path| {
        let path = path.to_owned();
        move |source| BundleError::Io { path, source }
    };
    std::fs::create_dir_all(dir).map_err(io(dir))?;
    let path = dir.join(name);
    let tmp = dir.join(format!(".{name}.tmp"));
    let mut file = std::fs::File::create(&tmp).map_err(io(&tmp))?;
    fill(&mut file).map_err(io(&tmp))?;
    drop(file);
    std::fs::rename(&tmp, &path).map_err(io(&path))
}

/// Keeps `reads` as the records `name` in `dir` under `key`, adding their bytes to `spent`
/// (what the unit keeps so far): the BLAKE3 of the file's body ([`RecordFile::sum`]). Once a
/// unit's records pass [`READS_BUDGET`] its folder is removed and `None` returned: none of
/// them are kept, and the unit writes no more.
pub fn keep(
    dir: &Path,
    name: &str,
    key: &[u8; 32],
    prints: &MaterialPrints,
    reads: &MapReads,
    spent: &mut u64,
) -> Result<Option<[u8; 32]>, BundleError> {
    if !charge(dir, name, record_len(prints, reads), spent)? {
        return Ok(None);
    }
    let sum = record_sum(prints, reads);
    write_with(dir, name, |f| put_record(f, key, &sum, prints, reads))?;
    Ok(Some(sum))
}

/// First bytes of a map's kept quadtree file, with its format's version.
const QUADTREE_MAGIC: &[u8; 13] = b"glint-qtree-1";

/// The file of the quadtree kept beside a map's records `record` (`M.e0_0_c0.reads` →
/// `M.e0_0_c0.qtree`).
pub fn quadtree_name(record: &str) -> String {
    format!("{}.qtree", record.strip_suffix(".reads").unwrap_or(record))
}

/// The key of the quadtree of a map whose records, kept under `map_key`, have the body hash
/// `records` ([`RecordFile::sum`]): the tree is a function of its pixels' hits alone (the
/// camera's rays and each record's distance), so of these, the `limits` and the code that
/// builds it ([`quadtree::BUILD_VERSION`]).
pub fn quadtree_key(map_key: &[u8; 32], records: &[u8; 32], limits: &QuadtreeLimits) -> [u8; 32] {
    let mut h = blake3::Hasher::new();
    h.update(QUADTREE_MAGIC);
    h.update(map_key);
    h.update(records);
    h.update(format!("{limits:?}").as_bytes());
    h.update(&quadtree::BUILD_VERSION.to_le_bytes());
    *h.finalize().as_bytes()
}

/// The quadtree `name` in `dir` kept under `key` ([`quadtree::encode`]'s bytes); `None` when
/// missing, of another key or damaged.
pub fn read_quadtree(dir: &Path, name: &str, key: &[u8; 32]) -> Option<Vec<u8>> {
    let bytes = std::fs::read(dir.join(name)).ok()?;
    let rest = bytes.strip_prefix(QUADTREE_MAGIC.as_slice())?;
    let (k, rest) = rest.split_first_chunk::<32>()?;
    let (sum, rest) = rest.split_first_chunk::<32>()?;
    (k == key && blake3::hash(rest).as_bytes() == sum).then(|| rest.to_vec())
}

/// Keeps a map's quadtree (`tree`: [`quadtree::encode`]'s bytes) as `name` in `dir` under
/// `key`, counted against the unit's budget as its records are ([`keep`]): `false` past it.
pub fn keep_quadtree(
    dir: &Path,
    name: &str,
    key: &[u8; 32],
    tree: &[u8],
    spent: &mut u64,
) -> Result<bool, BundleError> {
    let len = (QUADTREE_MAGIC.len() + 64 + tree.len()) as u64;
    if !charge(dir, name, len, spent)? {
        return Ok(false);
    }
    write_with(dir, name, |f| {
        f.write_all(QUADTREE_MAGIC)?;
        f.write_all(key)?;
        f.write_all(blake3::hash(tree).as_bytes())?;
        f.write_all(tree)
    })?;
    Ok(true)
}

/// [`keep`]'s count against the budget alone, before the record is encoded: `true` when it
/// is to be written ([`write_record`]), which may then wait (the radiance stage writes a map's
/// record while the next map renders).
pub fn charge_record(
    dir: &Path,
    name: &str,
    prints: &MaterialPrints,
    reads: &MapReads,
    spent: &mut u64,
) -> Result<bool, BundleError> {
    charge(dir, name, record_len(prints, reads), spent)
}

/// Writes the record `name` in `dir` under `key` ([`encode`]'s bytes, written as
/// [`write()`] does), its rows from where they lie; `sum` is its [`record_sum`].
pub fn write_record(
    dir: &Path,
    name: &str,
    key: &[u8; 32],
    sum: &[u8; 32],
    prints: &MaterialPrints,
    reads: &MapReads,
) -> Result<(), BundleError> {
    write_with(dir, name, |f| put_record(f, key, sum, prints, reads))
}

/// Adds a record's `len` bytes to the unit's `spent`; past [`READS_BUDGET`] removes the
/// unit's folder `dir` and returns `false` (none of its records is kept).
fn charge(dir: &Path, name: &str, len: u64, spent: &mut u64) -> Result<bool, BundleError> {
    *spent += len;
    if *spent > READS_BUDGET {
        log::info!(
            "{}: the records pass {READS_BUDGET} bytes at {name}: none kept",
            dir.display()
        );
        remove(dir)?;
        return Ok(false);
    }
    Ok(true)
}

/// Counts the record `name` kept in `dir` as it is (none of its pixels traced again) against
/// the unit's budget as [`keep`] counts one written: a unit's records are bounded whatever
/// share of them this bake wrote. Past [`READS_BUDGET`] the folder is removed and `false`
/// returned.
pub fn count_kept(dir: &Path, name: &str, spent: &mut u64) -> Result<bool, BundleError> {
    let len = std::fs::metadata(dir.join(name)).map_or(0, |m| m.len());
    charge(dir, name, len, spent)
}

/// Removes the file `name` in `dir`, if there is one.
pub fn remove_file(dir: &Path, name: &str) -> Result<(), BundleError> {
    let path = dir.join(name);
    match std::fs::remove_file(&path) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
        Err(source) => Err(BundleError::Io { path, source }),
    }
}

/// Removes the folder `dir` and what it holds (a unit over its budget keeps no records).
pub fn remove(dir: &Path) -> Result<(), BundleError> {
    match std::fs::remove_dir_all(dir) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
        Err(source) => Err(BundleError::Io {
            path: dir.to_owned(),
            source,
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn records_kept_as_they_are_count_against_the_budget() {
        let dir = tempfile::tempdir().unwrap();
        let folder = dir.path().join("radiance.M.reads");
        write(&folder, "m.reads", &[0u8; 100]).unwrap();
        let mut spent = 0;
        assert!(count_kept(&folder, "m.reads", &mut spent).unwrap());
        assert_eq!(spent, 100);
        // What was written before this record brings the unit past its budget: none kept.
        let mut spent = READS_BUDGET - 50;
        assert!(!count_kept(&folder, "m.reads", &mut spent).unwrap());
        assert!(!folder.exists());
    }

    #[test]
    fn a_kept_quadtree_is_read_under_its_records_key_alone_and_whole() {
        let dir = tempfile::tempdir().unwrap();
        let reads = MapReads {
            rows: vec![vec![0, 0].into(), vec![0].into()],
        };
        let prints = MaterialPrints(vec![[1; 32]]);
        let mut spent = 0;
        let sum = keep(dir.path(), "m.reads", &[7; 32], &prints, &reads, &mut spent)
            .unwrap()
            .unwrap();
        // The sum `keep` gives is the one the file holds.
        assert_eq!(read(dir.path(), "m.reads", &[7; 32]).unwrap().sum(), sum);
        let limits = QuadtreeLimits {
            relative_depth_range: 0.1,
            min_points: 64,
        };
        let key = quadtree_key(&[7; 32], &sum, &limits);
        let name = quadtree_name("m.reads");
        assert_eq!(name, "m.qtree");
        assert!(keep_quadtree(dir.path(), &name, &key, b"tree", &mut spent).unwrap());
        assert_eq!(
            read_quadtree(dir.path(), &name, &key),
            Some(b"tree".to_vec())
        );
        // Records of other bytes, or other limits: another key.
        for other in [
            quadtree_key(&[7; 32], &[0; 32], &limits),
            quadtree_key(
                &[7; 32],
                &sum,
                &QuadtreeLimits {
                    min_points: 32,
                    ..limits
                },
            ),
        ] {
            assert_eq!(read_quadtree(dir.path(), &name, &other), None);
        }
        let path = dir.path().join(&name);
        let mut torn = std::fs::read(&path).unwrap();
        *torn.last_mut().unwrap() ^= 1;
        std::fs::write(&path, torn).unwrap();
        assert_eq!(read_quadtree(dir.path(), &name, &key), None);
    }

    #[test]
    fn a_record_is_read_under_its_own_key_alone_and_whole() {
        let dir = tempfile::tempdir().unwrap();
        let reads = MapReads {
            rows: vec![vec![0, 0].into(), vec![0].into()],
        };
        let prints = MaterialPrints(vec![[1; 32], [2; 32]]);
        let key = [7u8; 32];
        let bytes = encode(&key, &prints, &reads);
        write(dir.path(), "m.reads", &bytes).unwrap();
        let file = read(dir.path(), "m.reads", &key).unwrap();
        assert_eq!((&file.prints, file.reads()), (&prints, reads));
        assert_eq!(read(dir.path(), "m.reads", &[8u8; 32]), None);
        let mut torn = bytes.clone();
        *torn.last_mut().unwrap() ^= 1;
        write(dir.path(), "m.reads", &torn).unwrap();
        assert_eq!(read(dir.path(), "m.reads", &key), None);
        assert_eq!(
            MaterialPrints(vec![[1; 32], [3; 32]]).changed_since(&prints),
            vec![false, true]
        );
        assert_eq!(
            MaterialPrints(vec![[1; 32]]).changed_since(&prints),
            vec![true]
        );
    }

    #[test]
    fn records_held_past_their_file_borrow_write_the_same_file() {
        let dir = tempfile::tempdir().unwrap();
        let prints = MaterialPrints(vec![[1; 32]]);
        let key = [7u8; 32];
        let old = MapReads {
            rows: vec![vec![1, 2, 3].into(), vec![4].into(), vec![5, 6].into()],
        };
        write(dir.path(), "m.reads", &encode(&key, &prints, &old)).unwrap();
        let file = read(dir.path(), "m.reads", &key);
        // Row 1 traced again; rows 0 and 2 kept as they were, borrowing the file.
        let mut rows = file.as_ref().unwrap().reads().rows;
        rows[1] = Cow::Owned(vec![9, 9]);
        let new = MapReads { rows };
        let (sum, expected) = (record_sum(&prints, &new), encode(&key, &prints, &new));
        let held = HeldRows::of(file.as_ref(), new);
        // The kept rows are places in the file, not copies.
        let kept = held.rows.iter().filter(|r| matches!(r, HeldRow::Kept(_)));
        assert_eq!(kept.count(), 2);
        let held = held.with(file);
        write_record(dir.path(), "n.reads", &key, &sum, &prints, &held.reads()).unwrap();
        assert_eq!(std::fs::read(dir.path().join("n.reads")).unwrap(), expected);
        assert_eq!(read(dir.path(), "n.reads", &key).unwrap().sum(), sum);
    }

    #[test]
    fn a_records_sum_is_the_blake3_of_its_body_whatever_its_rows_sizes() {
        let prints = MaterialPrints(vec![[3; 32]]);
        let sizes = [0usize, 5, 600_000, 700_000, 2_100_000, 3, 1 << 20, 7];
        let rows = sizes
            .iter()
            .enumerate()
            .map(|(i, &n)| {
                (0..n)
                    .map(|j| (j * 31 + i) as u8)
                    .collect::<Vec<u8>>()
                    .into()
            })
            .collect();
        let reads = MapReads { rows };
        let bytes = encode(&[1; 32], &prints, &reads);
        let body = &bytes[MAGIC.len() + 64..];
        assert_eq!(record_sum(&prints, &reads), *blake3::hash(body).as_bytes());
    }
}

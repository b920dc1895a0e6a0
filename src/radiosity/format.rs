//! `radiosity/atlas.bin`: per-triangle lightmap coordinates.
//!
//! Little-endian:
//! | bytes | field |
//! |---|---|
//! | 8 | magic `GLNTATLS` |
//! | u16 | version: 1, or 2 when some triangles' back sides have texels of their own |
//! | u16 | flags: bit 0 = coordinates come from the glTF's TEXCOORD_1 |
//! | u32 | page count P |
//! | u32 | triangle count T (the scene's triangles, in the order the scene stage loads them, then the back sides) |
//! | f32 | texel density requested, texels per metre |
//! | P × (u32, u32) | page width and height in texels |
//! | T × (u32, 6 × f32) | page of the triangle, then (x, y) of its three vertices in texel units of that page (texel (i, j) spans [i, i+1) × [j, j+1); divide by the page size for UVs) |
//! | u32 | version 2 only: back-side count B |
//! | B × u32 | version 2 only: the scene triangles whose back sides are the last B triangles, ascending |

use glam::Vec2;

use super::atlas::{Atlas, PageSize};

/// File magic.
pub const MAGIC: &[u8; 8] = b"GLNTATLS";
/// Format version written for an atlas without back sides (every shipped scene's but
/// breakfast-room's): such atlases keep the bytes they had before back sides existed.
pub const VERSION: u16 = 1;
/// Format version written for an atlas with back sides, and the newest read.
pub const VERSION_BACKS: u16 = 2;

/// Why an atlas file cannot be read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum AtlasFormatError {
    /// Not an atlas file.
    #[error("not a glint atlas (bad magic)")]
    Magic,
    /// A version this build does not read.
    #[error(
        "atlas format version {found}, this glint reads versions {VERSION} and {VERSION_BACKS}"
    )]
    Version {
        /// Version in the file.
        found: u16,
    },
    /// The file ends early or has bytes left over.
    #[error("atlas file is truncated or has trailing bytes ({0})")]
    Size(String),
    /// A field holds a value no atlas has.
    #[error("corrupt atlas: {0}")]
    Invalid(String),
}

/// Serializes the atlas (chart ids of texels are a bake-time detail and are not stored).
pub fn encode(atlas: &Atlas) -> Vec<u8> {
    let mut out = Vec::with_capacity(28 + atlas.pages.len() * 8 + atlas.tri_page.len() * 28);
    out.extend_from_slice(MAGIC);
    let version = if atlas.backs.is_empty() {
        VERSION
    } else {
        VERSION_BACKS
    };
    out.extend_from_slice(&version.to_le_bytes());
    out.extend_from_slice(&(atlas.from_uv1 as u16).to_le_bytes());
    out.extend_from_slice(&(atlas.pages.len() as u32).to_le_bytes());
    out.extend_from_slice(&(atlas.tri_page.len() as u32).to_le_bytes());
    out.extend_from_slice(&atlas.texel_density.to_le_bytes());
    for p in &atlas.pages {
        out.extend_from_slice(&p.width.to_le_bytes());
        out.extend_from_slice(&p.height.to_le_bytes());
    }
    for (page, c) in atlas.tri_page.iter().zip(&atlas.tri_coords) {
        out.extend_from_slice(&page.to_le_bytes());
        for v in c {
            out.extend_from_slice(&v.x.to_le_bytes());
            out.extend_from_slice(&v.y.to_le_bytes());
        }
    }
    if !atlas.backs.is_empty() {
        out.extend_from_slice(&(atlas.backs.len() as u32).to_le_bytes());
        for t in &atlas.backs {
            out.extend_from_slice(&t.to_le_bytes());
        }
    }
    out
}

/// Reads an atlas written by [`encode`].
pub fn decode(bytes: &[u8]) -> Result<Atlas, AtlasFormatError> {
    let mut r = Reader { bytes, at: 0 };
    if r.take(8)? != MAGIC {
        return Err(AtlasFormatError::Magic);
    }
    let version = r.u16()?;
    if version != VERSION && version != VERSION_BACKS {
        return Err(AtlasFormatError::Version { found: version });
    }
    let flags = r.u16()?;
    let pages = r.u32()? as usize;
    let tris = r.u32()? as usize;
    let density = r.f32()?;
    let mut expected = 24 + pages * 8 + tris * 28;
    let backs_at = expected;
    let backs = if version == VERSION_BACKS {
        let n = bytes.get(backs_at..backs_at + 4).map_or(0, |b| {
            u32::from_le_bytes(b.try_into().expect("4 bytes")) as usize
        });
        expected += 4 + 4 * n;
        n
    } else {
        0
    };
    if bytes.len() != expected {
        return Err(AtlasFormatError::Size(format!(
            "{} bytes, the header implies {expected}",
            bytes.len()
        )));
    }
    let pages = (0..pages)
        .map(|_| {
            Ok(PageSize {
                width: r.u32()?,
                height: r.u32()?,
            })
        })
        .collect::<Result<Vec<_>, AtlasFormatError>>()?;
    let mut tri_page = Vec::with_capacity(tris);
    let mut tri_coords = Vec::with_capacity(tris);
    for _ in 0..tris {
        tri_page.push(r.u32()?);
        let mut c = [Vec2::ZERO; 3];
        for v in &mut c {
            *v = Vec2::new(r.f32()?, r.f32()?);
        }
        tri_coords.push(c);
    }
    let backs = if version == VERSION_BACKS {
        r.u32()?;
        (0..backs).map(|_| r.u32()).collect::<Result<Vec<_>, _>>()?
    } else {
        Vec::new()
    };
    let scene_tris = tris.checked_sub(backs.len()).ok_or_else(|| {
        AtlasFormatError::Invalid(format!("{} back sides of {tris} triangles", backs.len()))
    })?;
    if backs.windows(2).any(|w| w[0] >= w[1])
        || backs.last().is_some_and(|&t| t as usize >= scene_tris)
    {
        return Err(AtlasFormatError::Invalid(format!(
            "the back sides' triangles are not ascending scene triangles (below {scene_tris})"
        )));
    }
    if let Some((i, p)) = pages
        .iter()
        .enumerate()
        .find(|(_, p)| p.width == 0 || p.height == 0)
    {
        return Err(AtlasFormatError::Invalid(format!(
            "page {i} is {}×{} texels",
            p.width, p.height
        )));
    }
    if let Some(&bad) = tri_page.iter().find(|&&p| p as usize >= pages.len()) {
        return Err(AtlasFormatError::Invalid(format!(
            "a triangle refers to page {bad} of {}",
            pages.len()
        )));
    }
    Ok(Atlas {
        texel_density: density,
        pages,
        tri_page,
        tri_coords,
        texel_chart: Vec::new(),
        charts: 0,
        from_uv1: flags & 1 != 0,
        backs,
    })
}

struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn take(&mut self, n: usize) -> Result<&[u8], AtlasFormatError> {
        let s = self
            .bytes
            .get(self.at..self.at + n)
            .ok_or_else(|| AtlasFormatError::Size(format!("ends at byte {}", self.bytes.len())))?;
        self.at += n;
        Ok(s)
    }
    fn u16(&mut self) -> Result<u16, AtlasFormatError> {
        Ok(u16::from_le_bytes(
            self.take(2)?.try_into().expect("2 bytes"),
        ))
    }
    fn u32(&mut self) -> Result<u32, AtlasFormatError> {
        Ok(u32::from_le_bytes(
            self.take(4)?.try_into().expect("4 bytes"),
        ))
    }
    fn f32(&mut self) -> Result<f32, AtlasFormatError> {
        Ok(f32::from_le_bytes(
            self.take(4)?.try_into().expect("4 bytes"),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_corruption() {
        let atlas = Atlas {
            texel_density: 16.0,
            pages: vec![
                PageSize {
                    width: 64,
                    height: 32,
                },
                PageSize {
                    width: 8,
                    height: 8,
                },
            ],
            tri_page: vec![0, 1],
            tri_coords: vec![
                [
                    Vec2::new(1.0, 2.0),
                    Vec2::new(3.5, 2.0),
                    Vec2::new(1.0, 9.25)
                ];
                2
            ],
            texel_chart: Vec::new(),
            charts: 0,
            from_uv1: true,
            backs: Vec::new(),
        };
        let bytes = encode(&atlas);
        assert_eq!(decode(&bytes).unwrap(), atlas);
        let err = decode(&bytes[..bytes.len() - 1]).unwrap_err().to_string();
        assert!(err.contains("truncated"), "{err}");
        let mut bad = bytes.clone();
        bad[8] = 9;
        assert_eq!(
            decode(&bad).unwrap_err(),
            AtlasFormatError::Version { found: 9 }
        );
        bad[0] = b'X';
        assert_eq!(decode(&bad).unwrap_err(), AtlasFormatError::Magic);
        // A page without texels would make every lookup on it index nothing.
        let mut empty = atlas.clone();
        empty.pages[1].height = 0;
        let e = decode(&encode(&empty)).unwrap_err().to_string();
        assert!(e.contains("page 1 is 8×0 texels"), "{e}");
        let mut far = atlas.clone();
        far.tri_page[1] = 2;
        let e = decode(&encode(&far)).unwrap_err().to_string();
        assert!(e.contains("refers to page 2 of 2"), "{e}");
        // Back sides: version 2, the list after the triangles.
        let mut two = atlas.clone();
        two.tri_page.push(0);
        two.tri_coords.push(atlas.tri_coords[0]);
        two.backs = vec![1];
        let b2 = encode(&two);
        assert_eq!(u16::from_le_bytes([b2[8], b2[9]]), VERSION_BACKS);
        assert_eq!(b2.len(), bytes.len() + 28 + 8);
        assert_eq!(decode(&b2).unwrap(), two);
        assert!(
            decode(&b2[..b2.len() - 2])
                .unwrap_err()
                .to_string()
                .contains("truncated")
        );
        two.backs = vec![2];
        let e = decode(&encode(&two)).unwrap_err().to_string();
        assert!(e.contains("not ascending scene triangles"), "{e}");
    }
}

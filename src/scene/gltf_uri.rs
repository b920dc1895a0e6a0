//! glTF URIs as relative paths, shared by the geometry and texture imports.

use std::path::PathBuf;

/// The relative path a buffer's URI names, relative to the glTF file's folder: the URI with
/// its percent-escapes decoded (glTF 2.0 §3.9.2: URIs are RFC 3986 references, so `../x.bin`
/// and `my%20mesh.bin` are legal).
pub fn uri_path(uri: &str) -> PathBuf {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        let hex = |b: u8| (b as char).to_digit(16);
        if bytes[i] == b'%'
            && i + 2 < bytes.len()
            && let (Some(h), Some(l)) = (hex(bytes[i + 1]), hex(bytes[i + 2]))
        {
            out.push((h * 16 + l) as u8);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    PathBuf::from(String::from_utf8_lossy(&out).into_owned())
}

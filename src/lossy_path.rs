//! Paths in JSON reports. serde refuses a path that is not UTF-8 (and `json!` panics on one),
//! so every report writes its paths lossily: each byte that is not UTF-8 becomes U+FFFD.

use std::path::Path;

/// Serializes a path field of a report: `#[serde(serialize_with = "crate::lossy_path::serialize")]`.
pub fn serialize<S: serde::Serializer>(path: &Path, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(&path.to_string_lossy())
}

/// A path as a JSON string, for `json!`.
pub fn json(path: &Path) -> serde_json::Value {
    path.to_string_lossy().into()
}

#[cfg(test)]
mod tests {
    use std::ffi::OsStr;
    use std::os::unix::ffi::OsStrExt;

    #[test]
    fn a_path_that_is_not_utf8_is_written_lossily() {
        let path = std::path::Path::new(OsStr::from_bytes(b"out/\xff.glint"));
        assert_eq!(super::json(path), "out/\u{fffd}.glint");
    }
}

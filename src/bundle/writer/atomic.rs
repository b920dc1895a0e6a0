//! One file written whole or not at all ([`write_atomic`]): a temporary file beside it,
//! flushed, then renamed.

use std::fs::{self, File};
use std::io::Write;
use std::path::Path;

use super::{io, sync_dir, unique_suffix};
use crate::bundle::BundleError;

/// Writes `bytes` to `path` atomically: a temporary file beside it, flushed, then renamed.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), BundleError> {
    write_atomic_with(path, |f| f.write_all(bytes))
}

/// [`write_atomic`] of what `fill` writes, through a buffer: a large file need not be held
/// whole in memory first.
pub fn write_atomic_with(
    path: &Path,
    fill: impl FnOnce(&mut std::io::BufWriter<File>) -> std::io::Result<()>,
) -> Result<(), BundleError> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = path.with_file_name(format!(".{name}.tmp-{}", unique_suffix()));
    let result = (|| {
        let mut f = std::io::BufWriter::new(File::create(&tmp)?);
        fill(&mut f)?;
        let f = f.into_inner().map_err(|e| e.into_error())?;
        f.sync_all()?;
        fs::rename(&tmp, path)?;
        match path.parent() {
            Some(p) if !p.as_os_str().is_empty() => sync_dir(p),
            _ => Ok(()),
        }
    })();
    if result.is_err() {
        let _ = fs::remove_file(&tmp);
    }
    result.map_err(io(path))
}

//! Output folders (bundles, frames, shards): creating one, and where that fails because
//! something stands in its way, saying what (the bare OS error is "File exists").

use std::io;
use std::path::Path;

/// [`std::fs::create_dir_all`], whose error says what stands in the way ([`in_the_way`]).
pub fn create_dir_all(dir: &Path) -> io::Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| match in_the_way(dir) {
        Some(why) => io::Error::new(e.kind(), why),
        None => e,
    })
}

/// What stands where folder `dir` should be: `dir` itself, or the nearest of its ancestors
/// that exists, being a file or a symbolic link to nothing or to a file. `None` where that
/// is a folder (or `dir` cannot be examined).
pub fn in_the_way(dir: &Path) -> Option<String> {
    for p in dir.ancestors().filter(|p| !p.as_os_str().is_empty()) {
        let Ok(meta) = std::fs::symlink_metadata(p) else {
            continue; // missing: the folder above decides
        };
        let what = if p == dir {
            "it".to_string()
        } else {
            format!("{} (above it)", p.display())
        };
        if meta.is_symlink() {
            let to = std::fs::read_link(p).map_or_else(|_| "?".into(), |t| t.display().to_string());
            return match std::fs::metadata(p) {
                Err(_) => Some(format!(
                    "{what} is a symbolic link to {to}, which does not exist: remove the link or create its target"
                )),
                Ok(m) if !m.is_dir() => Some(format!(
                    "{what} is a symbolic link to {to}, a file, not a folder"
                )),
                Ok(_) => None,
            };
        }
        return (!meta.is_dir()).then(|| format!("{what} is a file, not a folder"));
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn says_what_stands_in_the_way() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("file");
        std::fs::write(&file, b"x").unwrap();
        let e = create_dir_all(&file).unwrap_err().to_string();
        assert_eq!(e, "it is a file, not a folder");
        let e = create_dir_all(&file.join("a/b")).unwrap_err().to_string();
        assert!(
            e.ends_with("file (above it) is a file, not a folder"),
            "{e}"
        );
        let link = dir.path().join("link");
        std::os::unix::fs::symlink(dir.path().join("nowhere"), &link).unwrap();
        let e = create_dir_all(&link).unwrap_err().to_string();
        assert!(
            e.starts_with("it is a symbolic link to ")
                && e.contains("nowhere, which does not exist"),
            "{e}"
        );
        std::os::unix::fs::symlink(&file, dir.path().join("to-file")).unwrap();
        let e = create_dir_all(&dir.path().join("to-file"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("a file, not a folder"), "{e}");
        create_dir_all(&dir.path().join("new/folder")).unwrap();
        assert_eq!(in_the_way(&dir.path().join("new/folder")), None);
        assert_eq!(in_the_way(&dir.path().join("missing/x")), None);
    }
}

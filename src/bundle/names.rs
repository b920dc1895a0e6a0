//! File-name-safe folder names for scene objects (materials, reflectors) inside a stage. The
//! stage that writes a folder and the reader that finds it both derive the name here.

/// A file-name-safe form of a name: ASCII letters, digits, `-`, `_` and `.` kept, anything
/// else `_`; never empty, never starting with `.`.
pub fn folder_name(name: &str) -> String {
    let s: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' || c == '.' {
                c
            } else {
                '_'
            }
        })
        .collect();
    if s.is_empty() || s.starts_with('.') {
        format!("_{s}")
    } else {
        s
    }
}

/// Unique folder names for `names`, in order (a clash, ignoring case, gets `-2`, `-3`, …).
pub fn unique_folders<'a>(names: impl Iterator<Item = &'a str>) -> Vec<String> {
    let mut used = std::collections::BTreeSet::new();
    names
        .map(|n| {
            let base = folder_name(n);
            let mut name = base.clone();
            let mut k = 2;
            while !used.insert(name.to_ascii_lowercase()) {
                name = format!("{base}-{k}");
                k += 1;
            }
            name
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn folder_names_are_safe_and_unique() {
        assert_eq!(folder_name("Glossy Floor/1"), "Glossy_Floor_1");
        assert_eq!(folder_name(""), "_");
        assert_eq!(folder_name(".hidden"), "_.hidden");
        assert_eq!(
            unique_folders(["a b", "a_b", "A_B"].into_iter()),
            ["a_b", "a_b-2", "A_B-3"]
        );
    }
}

//! Summaries of a bundle for `glint-bundle stats` and `ls`: plain data, formatted as text
//! tables or serialized as JSON by the caller.

use std::collections::BTreeMap;

use serde::Serialize;

use super::{Bundle, BundleError};

/// Bytes and file count of a group of assets.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Tally {
    /// Number of files.
    pub files: u64,
    /// Total bytes.
    pub bytes: u64,
}

impl Tally {
    fn add(&mut self, bytes: u64) {
        self.files += 1;
        self.bytes += bytes;
    }
}

/// One stage's summary.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct StageStats {
    /// Stage name.
    pub name: String,
    /// glint version that baked it.
    pub generator: String,
    /// Bake time, seconds.
    pub bake_seconds: f64,
    /// All its files.
    pub total: Tally,
    /// Its files by asset kind.
    pub kinds: BTreeMap<String, Tally>,
    /// The stage's own figures, as recorded.
    pub stats: BTreeMap<String, serde_json::Value>,
}

/// A bundle's summary.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BundleStats {
    /// Bundle folder.
    pub bundle: String,
    /// Format version of the manifest.
    pub format_version: String,
    /// Scene name.
    pub scene_name: String,
    /// Scene content hash.
    pub scene_hash: String,
    /// Per stage, in name order.
    pub stages: Vec<StageStats>,
    /// Every file of every stage.
    pub total: Tally,
    /// Assets that are missing, not a regular file inside the bundle or whose size differs
    /// from the manifest's (hashes are checked by `verify`), and scene files naming files
    /// outside their stage; empty when every file is there with its size.
    pub damaged: Vec<Damage>,
}

/// An asset found missing or of the wrong size.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Damage {
    /// Logical path, as in the manifest.
    pub path: String,
    /// Where it should be on disk.
    pub file: String,
    /// `missing`, not a regular file, a symbolic link, or the size found against the size
    /// recorded.
    pub problem: String,
}

/// The scene stage's references that leave it ([`Bundle::check_scene_references`]), as
/// damage of the file holding each, once its assets are all present.
fn scene_reference_damage(bundle: &Bundle) -> Vec<Damage> {
    let present = bundle.stage("scene").is_some_and(|s| {
        s.assets
            .iter()
            .all(|a| bundle.asset_metadata(a).is_ok_and(|m| m.is_some()))
    });
    if !present {
        return Vec::new();
    }
    bundle
        .check_scene_references()
        .into_iter()
        .map(|e| match e {
            BundleError::BadReference {
                file,
                field,
                reference,
                why,
            } => Damage {
                path: field.clone(),
                file: file.display().to_string(),
                problem: format!("field `{field}` is {reference:?}: {why}"),
            },
            BundleError::Asset { path, problem } => Damage {
                path: path.display().to_string(),
                file: path.display().to_string(),
                problem,
            },
            e => Damage {
                path: String::new(),
                file: bundle.dir().display().to_string(),
                problem: e.to_string(),
            },
        })
        .collect()
}

impl BundleStats {
    /// Summarizes the manifest of `bundle` (sizes as recorded), and checks that every asset
    /// exists with its recorded size ([`BundleStats::damaged`]; `verify` checks hashes).
    pub fn of(bundle: &Bundle) -> BundleStats {
        let m = bundle.manifest();
        let damaged = m
            .assets()
            .filter_map(|(_, a)| {
                let file = bundle.asset_path(a);
                let problem = match bundle.asset_metadata(a) {
                    Ok(None) => format!("missing (the manifest records {} bytes)", a.bytes),
                    Err(BundleError::Asset { problem, .. }) => problem,
                    Err(e) => e.to_string(),
                    Ok(Some(meta)) if meta.len() != a.bytes => format!(
                        "size is {} bytes, the manifest records {}",
                        meta.len(),
                        a.bytes
                    ),
                    Ok(Some(_)) => return None,
                };
                Some(Damage {
                    path: a.path.clone(),
                    file: file.display().to_string(),
                    problem,
                })
            })
            .chain(scene_reference_damage(bundle))
            .collect();
        let mut total = Tally::default();
        let stages = m
            .stages
            .iter()
            .map(|(name, rec)| {
                let mut t = Tally::default();
                let mut kinds: BTreeMap<String, Tally> = BTreeMap::new();
                for a in &rec.assets {
                    t.add(a.bytes);
                    total.add(a.bytes);
                    kinds.entry(a.kind.clone()).or_default().add(a.bytes);
                }
                StageStats {
                    name: name.clone(),
                    generator: rec.generator.clone(),
                    bake_seconds: rec.bake_seconds,
                    total: t,
                    kinds,
                    stats: rec.stats.clone(),
                }
            })
            .collect();
        BundleStats {
            bundle: bundle.dir().display().to_string(),
            format_version: m.format_version.clone(),
            scene_name: m.scene_name.clone(),
            scene_hash: m.scene_hash.clone(),
            stages,
            total,
            damaged,
        }
    }

    /// A readable report: a header, a table per stage and per asset kind, and each stage's figures.
    pub fn to_table(&self) -> String {
        let mut rows = vec![[
            "stage".to_string(),
            "kind".to_string(),
            "files".to_string(),
            "bytes".to_string(),
            "size".to_string(),
            "bake time".to_string(),
        ]];
        for s in &self.stages {
            rows.push([
                s.name.clone(),
                "(all)".into(),
                s.total.files.to_string(),
                s.total.bytes.to_string(),
                human_bytes(s.total.bytes),
                format!("{:.2} s", s.bake_seconds),
            ]);
            for (kind, t) in &s.kinds {
                rows.push([
                    String::new(),
                    kind.clone(),
                    t.files.to_string(),
                    t.bytes.to_string(),
                    human_bytes(t.bytes),
                    String::new(),
                ]);
            }
        }
        rows.push([
            "total".into(),
            String::new(),
            self.total.files.to_string(),
            self.total.bytes.to_string(),
            human_bytes(self.total.bytes),
            String::new(),
        ]);
        let mut out = format!(
            "bundle  {}\nformat  {}\nscene   {} ({:.16}…)\n\n",
            self.bundle, self.format_version, self.scene_name, self.scene_hash
        );
        if self.stages.is_empty() {
            out += "no stages baked yet\n";
            return out;
        }
        out += &format_table(&rows, &[false, false, true, true, true, true]);
        for s in self.stages.iter().filter(|s| !s.stats.is_empty()) {
            out += &format!("\n{}:\n", s.name);
            for (k, v) in &s.stats {
                match object_rows(v) {
                    Some(table) => out += &format!("  {k}:\n{}", indent(&table, "  ")),
                    None => out += &format!("  {k:<24} {v}\n"),
                }
            }
        }
        out
    }
}

/// A JSON array of flat objects as a table (columns in the first object's key order;
/// `bytes` columns also shown in binary units), or `None` for any other value.
fn object_rows(v: &serde_json::Value) -> Option<String> {
    let rows = v.as_array()?;
    let first = rows.first()?.as_object()?;
    let keys: Vec<&String> = first.keys().collect();
    let cell = |v: Option<&serde_json::Value>| match v {
        Some(serde_json::Value::String(s)) => s.clone(),
        Some(v) => v.to_string(),
        None => String::new(),
    };
    let mut table = vec![keys.iter().map(|k| k.to_string()).collect::<Vec<_>>()];
    for r in rows {
        let r = r.as_object()?;
        table.push(
            keys.iter()
                .map(|k| match (k.as_str(), r.get(*k).and_then(|v| v.as_u64())) {
                    ("bytes", Some(b)) => format!("{b} ({})", human_bytes(b)),
                    _ => cell(r.get(*k)),
                })
                .collect(),
        );
    }
    let mut width = vec![0usize; keys.len()];
    for r in &table {
        for (i, c) in r.iter().enumerate() {
            width[i] = width[i].max(c.chars().count());
        }
    }
    let mut out = String::new();
    for (n, r) in table.iter().enumerate() {
        let line: Vec<String> = r
            .iter()
            .enumerate()
            .map(|(i, c)| format!("{c:<w$}", w = width[i]))
            .collect();
        out += line.join("  ").trim_end();
        out.push('\n');
        if n == 0 {
            out += &"-".repeat(width.iter().sum::<usize>() + 2 * (keys.len() - 1));
            out.push('\n');
        }
    }
    Some(out)
}

fn indent(text: &str, by: &str) -> String {
    text.lines().map(|l| format!("{by}{l}\n")).collect()
}

/// Bytes in binary units with one decimal (`12.3 KiB`).
pub fn human_bytes(bytes: u64) -> String {
    const UNITS: [&str; 5] = ["B", "KiB", "MiB", "GiB", "TiB"];
    let mut v = bytes as f64;
    let mut u = 0;
    while v >= 1024.0 && u + 1 < UNITS.len() {
        v /= 1024.0;
        u += 1;
    }
    if u == 0 {
        format!("{bytes} B")
    } else {
        format!("{v:.1} {}", UNITS[u])
    }
}

/// Aligns rows into columns; `right[i]` right-aligns column i. The first row is a header,
/// underlined.
pub fn format_table<const N: usize>(rows: &[[String; N]], right: &[bool; N]) -> String {
    let mut width = [0usize; N];
    for r in rows {
        for (i, c) in r.iter().enumerate() {
            width[i] = width[i].max(c.chars().count());
        }
    }
    let mut out = String::new();
    for (n, r) in rows.iter().enumerate() {
        let cells: Vec<String> = r
            .iter()
            .enumerate()
            .map(|(i, c)| {
                if right[i] {
                    format!("{c:>w$}", w = width[i])
                } else {
                    format!("{c:<w$}", w = width[i])
                }
            })
            .collect();
        out += cells.join("  ").trim_end();
        out.push('\n');
        if n == 0 {
            let total: usize = width.iter().sum::<usize>() + 2 * (N - 1);
            out += &"-".repeat(total);
            out.push('\n');
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn human_bytes_units() {
        assert_eq!(human_bytes(0), "0 B");
        assert_eq!(human_bytes(1023), "1023 B");
        assert_eq!(human_bytes(1536), "1.5 KiB");
        assert_eq!(human_bytes(3 * 1024 * 1024), "3.0 MiB");
    }

    #[test]
    fn table_aligns_columns() {
        let rows = [
            ["a".to_string(), "bytes".to_string()],
            ["long name".to_string(), "7".to_string()],
        ];
        let t = format_table(&rows, &[false, true]);
        let lines: Vec<&str> = t.lines().collect();
        assert_eq!(lines[0], "a          bytes");
        assert_eq!(lines[1], "----------------");
        assert_eq!(lines[2], "long name      7");
    }
}

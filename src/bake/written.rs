//! What a bake tool wrote before Ctrl-C stopped it, for its last message: the stages whose
//! record changed in each bundle it writes, found by reading the manifests before and after
//! (stages commit whole, so a stage is either in the new manifest or as it was).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::SystemTime;

use super::shard::MARKER;
use crate::bundle::Bundle;
use crate::progress::{Interrupted, is_interruption};

/// The stages of some bundles, by name, each with its record's identity before the work; and
/// the complete shards of a unit cache, when the work bakes through one.
pub struct Written {
    before: Vec<(PathBuf, BTreeMap<String, String>)>,
    cache: Option<(PathBuf, BTreeMap<String, SystemTime>)>,
}

/// The complete shards in `dir` (those with their marker), by unit ID, with the marker's time.
fn finished_units(dir: &Path) -> BTreeMap<String, SystemTime> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return BTreeMap::new();
    };
    entries
        .flatten()
        .filter_map(|e| {
            let name = e.file_name().into_string().ok()?;
            let id = name.strip_suffix(".glint")?.to_owned();
            let marked = std::fs::metadata(e.path().join(MARKER))
                .ok()?
                .modified()
                .ok()?;
            Some((id, marked))
        })
        .collect()
}

/// Each stage's identity and settings, or nothing where no bundle is (yet).
fn stages(bundle: &Path) -> BTreeMap<String, String> {
    let Ok(b) = Bundle::open(bundle) else {
        return BTreeMap::new();
    };
    b.manifest()
        .stages
        .iter()
        .map(|(name, r)| (name.clone(), format!("{} {}", r.identity(), r.settings)))
        .collect()
}

impl Written {
    /// The stages `bundles` hold now.
    pub fn snapshot(bundles: &[&Path]) -> Written {
        Written {
            before: bundles
                .iter()
                .map(|b| (b.to_path_buf(), stages(b)))
                .collect(),
            cache: None,
        }
    }

    /// Also says which work units finished in the unit cache `dir` (kept for the next bake).
    pub fn with_unit_cache(mut self, dir: PathBuf) -> Written {
        let now = finished_units(&dir);
        self.cache = Some((dir, now));
        self
    }

    /// The units that finished in the cache since the snapshot, and the cache.
    fn finished(&self) -> Option<(Vec<String>, &Path)> {
        let (dir, before) = self.cache.as_ref()?;
        let ids: Vec<String> = finished_units(dir)
            .into_iter()
            .filter(|(id, t)| before.get(id) != Some(t))
            .map(|(id, _)| id)
            .collect();
        (!ids.is_empty()).then_some((ids, dir.as_path()))
    }

    /// What was written, in words.
    pub fn words(&self) -> String {
        let mut words = self.stage_words();
        if let Some((ids, dir)) = self.finished() {
            words.push_str(&format!(
                "; finished work unit(s) {} kept in {} (the next bake does not redo them)",
                ids.join(", "),
                dir.display()
            ));
        }
        words
    }

    /// Per bundle, the stages written (or removed) since the snapshot.
    pub fn changed(&self) -> Vec<(PathBuf, Vec<String>)> {
        self.before
            .iter()
            .filter_map(|(path, before)| {
                let now = stages(path);
                let names: Vec<String> = before
                    .keys()
                    .chain(now.keys())
                    .filter(|n| before.get(*n) != now.get(*n))
                    .cloned()
                    .collect::<std::collections::BTreeSet<_>>()
                    .into_iter()
                    .collect();
                (!names.is_empty()).then(|| (path.clone(), names))
            })
            .collect()
    }

    /// The stages written, in words.
    fn stage_words(&self) -> String {
        const WHOLE: &str = "a stage is committed whole or not at all";
        let changed = self.changed();
        let all: Vec<String> = self
            .before
            .iter()
            .map(|(p, _)| p.display().to_string())
            .collect();
        if changed.is_empty() {
            return format!(
                "nothing was written; {} {} as before ({WHOLE})",
                all.join(", "),
                if all.len() == 1 { "is" } else { "are" }
            );
        }
        let wrote: Vec<String> = changed
            .iter()
            .map(|(p, names)| {
                let s = if names.len() == 1 { "" } else { "s" };
                format!("stage{s} {} of {}", names.join(", "), p.display())
            })
            .collect();
        format!(
            "wrote {} (complete); any stage under way was not written, and its bundle holds what it held before for it ({WHOLE})",
            wrote.join("; ")
        )
    }

    /// `e` when it is not a stop at the user's request; else an [`Interrupted`] saying what
    /// was written.
    pub fn explain(&self, e: anyhow::Error) -> anyhow::Error {
        if is_interruption(&e) {
            Interrupted {
                written: self.words(),
            }
            .into()
        } else {
            e
        }
    }
}

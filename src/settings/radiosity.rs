//! The radiosity stage's settings: [`RadiosityOverride`] (scene.json's `bake.radiosity`, the
//! flags of `glint-radiosity`, one field each) and [`RadiositySettings`], what the stage runs
//! with and records, from [`RadiositySettings::resolve`].

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use super::{Quality, SettingError, check_count};

/// Radiosity settings that override the preset: scene.json's `bake.radiosity`, then
/// `glint-radiosity`'s flags. Each field sets the resolved setting of its name.
#[derive(
    clap::Args, Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema,
)]
#[serde(deny_unknown_fields)]
pub struct RadiosityOverride {
    /// Lightmap texels per metre.
    #[arg(long, value_name = "T")]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub texel_density: Option<f32>,
    /// Texels across each chart's longer side, at least: small charts get a higher density (by at most 16×); 0 uses `texel_density` everywhere.
    #[arg(long, value_name = "N")]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_chart_texels: Option<u32>,
    /// Texels across the scene's longest side, at least: a small scene gets a higher density than `texel_density` everywhere; 0: off.
    #[arg(long, value_name = "N")]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_scene_texels: Option<u32>,
    /// Largest factor by which a chart's density is raised where other geometry comes within two texels of it (contacts, near occluders; the atlas grows by at most 2×); 0 or 1: off.
    #[arg(long, value_name = "F")]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub contact_boost: Option<f32>,
    /// Texels across a curved chart per radian its surface turns (a chart whose normals spread by 1 rad, 57°, gets at least this many texels across; by at most 16× the density); 0: off.
    #[arg(long, value_name = "N")]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub texels_per_radian: Option<f32>,
    /// Gathering rays per texel and bounce.
    #[arg(long, value_name = "N")]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rays: Option<u32>,
    /// Emitter samples per texel, per area light and for the emissive triangles (with more than 8 emitters: 8 × this many, drawn from all of them by their weight).
    #[arg(long, value_name = "N")]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub light_samples: Option<u32>,
    /// Largest number of indirect bounces (at most 256).
    #[arg(long, value_name = "B")]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bounces: Option<u32>,
    /// Largest number of glossy reflections a gathering ray follows, so that D holds the light that arrives via glossy and mirror surfaces (at most 64); 0: diffuse interreflection only.
    #[arg(long, value_name = "K")]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub glossy_depth: Option<u32>,
    /// Stop when a bounce changes the total reflected radiance by less than this fraction; 0: run every bounce.
    #[arg(long, value_name = "F")]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tolerance: Option<f32>,
    /// Relative standard error each texel's D should reach (e.g. 0.02): texels above it get more rays or emitter samples (whichever part of their error is above it), in up to 4 rounds; 0 turns refinement off.
    #[arg(long, value_name = "REL")]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target_error: Option<f32>,
    /// Make D agree across the chart seams of smooth surfaces (least-squares stitching of the solved texels): true or false (default: on, except at draft).
    #[arg(long, value_name = "BOOL")]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stitch_seams: Option<bool>,
    /// MiB of refinement rays the gather cache holds at most (default 2048): rays beyond it are read once and kept as sums, so memory stops growing with rays × texels; 0 caches none.
    #[arg(long, value_name = "MIB")]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cache_budget_mib: Option<u32>,
    /// Most elements (lightmap texels with a sample) the atlas may hold, as estimated before baking (default: 1M at draft, 2M at default, 8M at high): a larger scene gets every density scaled down by one factor until it fits; 0: no limit.
    #[arg(long, value_name = "N")]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_elements: Option<u64>,
}

/// Largest `glossy_depth` of the radiosity stage.
pub const MAX_GLOSSY_DEPTH: u32 = 64;

/// Bytes of cached rays ([`RadiositySettings::cache_budget`]) a bake holds at most by default:
/// enough for every shipped scene at every preset (the largest, cornell-box at high, holds
/// under 400 MB), a bound for a building.
pub const CACHE_BUDGET: u64 = 2 << 30;

/// Largest `bounces`: each bounce passes on at most the albedo's share of the light (< 1), so
/// after 256 even an albedo of 0.95 leaves 2·10⁻⁶ of it, and `tolerance` stops long before.
pub const MAX_BOUNCES: u32 = 256;

/// Largest `rays` and `light_samples` per texel: 64× and 512× the high preset's first batch,
/// which refinement already raises by up to 8× where a texel needs it.
pub const MAX_SAMPLES: u32 = 65_536;

/// Largest `min_chart_texels`: a chart's density is raised by at most 16× for it anyway.
pub const MAX_CHART_TEXELS: u32 = 4096;

/// Largest `min_scene_texels`: 16384 texels across a scene is 2.7·10⁸ texels on each side
/// of a cube, beyond any bake's memory.
pub const MAX_SCENE_TEXELS: u32 = 16_384;

/// Largest `cache_budget_mib`: 1 TiB, more memory than a machine has.
pub const MAX_CACHE_BUDGET_MIB: u32 = 1 << 20;

/// Largest `max_elements` (0: no limit): 10⁹ elements need far more memory than a machine
/// has before one ray is cast.
pub const MAX_ELEMENT_LIMIT: u64 = 1_000_000_000;

/// Largest [`RadiositySettings::texels_per_radian`]: 256 texels across a hemisphere's
/// quarter turn is far past any shading a texel shows.
pub const MAX_TEXELS_PER_RADIAN: f32 = 160.0;

/// Resolved radiosity settings (preset, then scene overrides, then command line).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct RadiositySettings {
    /// Lightmap texels per metre.
    pub texel_density: f32,
    /// Texels across each chart's longer side, at least: small charts get a higher density
    /// than `texel_density` (by at most 16×), so that small scenes and small parts are not
    /// a handful of texels across. 0: `texel_density` everywhere.
    #[serde(default)]
    pub min_chart_texels: u32,
    /// Texels across the scene's longest side, at least: a scene smaller than
    /// `min_scene_texels / texel_density` metres gets a higher density everywhere, so that a
    /// model's shading does not depend on its units or its size. 0: off.
    #[serde(default)]
    pub min_scene_texels: u32,
    /// Largest factor by which a chart's density is raised where other geometry comes within
    /// two texels of it: contacts and near occluders, where D changes within a texel
    /// (`radiosity::contacts`; the atlas grows by at most 2×). 0 or 1: off.
    #[serde(default)]
    pub contact_boost: f32,
    /// Texels across a curved chart per radian its surface turns: a chart whose face normals
    /// spread by θ (`radiosity::atlas::chart_turn`) gets at least θ × this many
    /// texels across (by at most 16× `texel_density`), so that D follows the shading of a
    /// curved mesh; flat charts get nothing from it. 0: off. Records without it read as off.
    #[serde(default)]
    pub texels_per_radian: f32,
    /// Gathering rays per texel and bounce.
    pub rays: u32,
    /// Emitter samples per texel, per area light and for the emissive triangles (in a scene
    /// with more than 8 emitters, 8 × this many drawn from all of them by their weight).
    pub light_samples: u32,
    /// Largest number of bounces, at most [`MAX_BOUNCES`].
    pub bounces: u32,
    /// Largest number of glossy reflections a gathering ray follows, so that D holds the light
    /// that arrives via glossy and mirror surfaces; 0 gathers diffuse interreflection only.
    pub glossy_depth: u32,
    /// Stop when a bounce changes the total reflected radiance by less than this fraction
    /// (0: every one of `bounces` runs).
    pub tolerance: f32,
    /// Relative standard error each texel's D should reach: texels whose estimate is above it
    /// get more rays or emitter samples (`rays` and `light_samples` are the first batch).
    /// `None`: one batch.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target_error: Option<f32>,
    /// Stitch the solved texels so that D agrees across the chart seams of smooth surfaces
    /// (`radiosity::seams`). On in the default and high presets (whose
    /// `min_chart_texels` keeps charts wide enough that stitching keeps their shading).
    #[serde(default)]
    pub stitch_seams: bool,
    /// MiB of refinement rays the gather cache holds at most
    /// (`radiosity::solve::SolveSettings::cache_budget`): rays beyond it are read
    /// once, against the radiance of that moment, and kept as sums per element, so memory
    /// stops growing with rays × texels (they then do not follow later bounces). 0: no
    /// refinement ray cached. Records without it read as the default, 2048.
    #[serde(default = "default_cache_budget_mib")]
    pub cache_budget_mib: u32,
    /// Most elements (lightmap texels with a sample) the atlas may hold, as estimated before
    /// baking with the contact boosts' most: a scene that would have more at these densities
    /// gets every density (`texel_density`, `min_chart_texels`, `texels_per_radian`) scaled
    /// down by one factor until it fits, so that a building bakes in bounded time and memory
    /// with the proportions of a room. 0: no limit. Records without it read as no limit.
    #[serde(default)]
    pub max_elements: u64,
}

/// [`RadiositySettings::max_elements`] of the presets (estimated elements, an upper bound of
/// what the atlas gets). Every shipped scene is below them, so they change nothing there; a
/// building of 2M triangles is not: at default it would have about 8M elements (25,000 CPU
/// seconds of gathering) and is baked at about a third of the density instead.
pub const MAX_ELEMENTS_DRAFT: u64 = 1_000_000;
/// See [`MAX_ELEMENTS_DRAFT`].
pub const MAX_ELEMENTS_DEFAULT: u64 = 2_000_000;
/// See [`MAX_ELEMENTS_DRAFT`].
pub const MAX_ELEMENTS_HIGH: u64 = 8_000_000;

/// [`RadiositySettings::cache_budget_mib`] of every preset: 2 GiB
/// ([`CACHE_BUDGET`]).
fn default_cache_budget_mib() -> u32 {
    (CACHE_BUDGET >> 20) as u32
}

impl RadiositySettings {
    /// The preset's values.
    pub fn preset(quality: Quality) -> Self {
        // The target error is what a preset promises; rays and light samples are the first
        // batch, refined where a texel's estimate is above the target.
        // Density follows the surfaces' sizes too: each chart gets `min_chart_texels` across,
        // enough for seams to be stitched without flattening a curved mesh's shading (on
        // bunny-mirror at 16 texels/m the bunny's charts are 1–2 texels wide). Draft leaves
        // seams unstitched: it is the quick look. And a small scene gets `min_scene` texels
        // across its longest side: a 2 m Cornell box is 36 texels per metre at default (shadow
        // and contact edges are where D's error is; docs/tuning.md#min-scene-texels).
        #[rustfmt::skip]
        let (texel_density, min_chart, min_scene, rays, light_samples, bounces, glossy_depth, tolerance, target, stitch) =
            match quality {
                Quality::Draft => (8.0, 4, 32, 64, 8, 8, 2, 1e-2, 0.05, false),
                Quality::Default => (16.0, 8, 72, 256, 128, 16, 4, 3e-3, 0.015, true),
                Quality::High => (32.0, 12, 96, 1024, 128, 32, 8, 1e-3, 0.01, true),
            };
        RadiositySettings {
            texel_density,
            min_chart_texels: min_chart,
            min_scene_texels: min_scene,
            contact_boost: match quality {
                // Contacts and shadow edges a texel cannot resolve (see `contacts`): off at
                // draft, the quick look.
                Quality::Draft => 0.0,
                Quality::Default | Quality::High => 8.0,
            },
            // A curved mesh's shading changes with its normal, so its charts get texels per
            // radian of curvature (docs/tuning.md#texels-per-radian). Off at draft, the quick look.
            texels_per_radian: match quality {
                Quality::Draft => 0.0,
                Quality::Default => 24.0,
                Quality::High => 36.0,
            },
            rays,
            light_samples,
            bounces,
            glossy_depth,
            tolerance,
            target_error: Some(target),
            stitch_seams: stitch,
            cache_budget_mib: default_cache_budget_mib(),
            max_elements: match quality {
                Quality::Draft => MAX_ELEMENTS_DRAFT,
                Quality::Default => MAX_ELEMENTS_DEFAULT,
                Quality::High => MAX_ELEMENTS_HIGH,
            },
        }
    }

    /// [`Self::cache_budget_mib`] in bytes.
    pub fn cache_budget(&self) -> u64 {
        u64::from(self.cache_budget_mib) << 20
    }

    /// Checks every value: every count within its bound (the `MAX_*` constants, each with its
    /// reason), rays and light samples ≥ 1, tolerance in [0, 1), texel density finite and > 0
    /// (how high it may go is a question of memory, which the radiosity stage estimates); with `scene_size` (the scene's bounding-box diagonal, metres), a density so
    /// low that the scene spans less than a thousandth of a texel (no element would be made,
    /// and D would be black) is refused too.
    pub fn check(&self, scene_size: Option<f32>) -> Result<(), SettingError> {
        let d = self.texel_density;
        if !(d.is_finite() && d > 0.0) {
            return Err(SettingError::new(
                "texel_density",
                format!("{d:?} is not a finite density > 0 in texels per metre"),
            ));
        }
        // Charts are projected to texel units: a scene spanning less than this many texels
        // collapses to a point in f32 and the atlas has no element (D would be black). Any
        // span above it gives every triangle its texel.
        const MIN_SPAN_TEXELS: f64 = 1e-3;
        if let Some(size) = scene_size
            && (size as f64) * (d as f64) < MIN_SPAN_TEXELS
        {
            return Err(SettingError::new(
                "texel_density",
                format!(
                    "{d:?} texels per metre gives no element: the scene, {size:.3} m across, spans less than {MIN_SPAN_TEXELS} texel; use at least {:.3e}",
                    MIN_SPAN_TEXELS / size as f64
                ),
            ));
        }
        let b = self.contact_boost;
        if !(b.is_finite() && (0.0..=16.0).contains(&b)) {
            return Err(SettingError::new(
                "contact_boost",
                format!("{b} is not a factor in [0, 16] (0 or 1: off)"),
            ));
        }
        let r = self.texels_per_radian;
        if !(r.is_finite() && (0.0..=MAX_TEXELS_PER_RADIAN).contains(&r)) {
            return Err(SettingError::new(
                "texels_per_radian",
                format!("{r} is not in [0, {MAX_TEXELS_PER_RADIAN}] (0: off)"),
            ));
        }
        let counts: [(&'static str, u64, u64, u64, &str); 8] = [
            (
                "rays",
                self.rays.into(),
                1,
                MAX_SAMPLES.into(),
                "64 × the high preset's; refinement adds more where a texel needs it",
            ),
            (
                "light_samples",
                self.light_samples.into(),
                1,
                MAX_SAMPLES.into(),
                "512 × the high preset's; refinement adds more where a texel needs it",
            ),
            (
                "bounces",
                self.bounces.into(),
                0,
                MAX_BOUNCES.into(),
                "each bounce passes on at most the albedo's share of the light: after 256 even an albedo of 0.95 leaves 2·10⁻⁶ of it",
            ),
            (
                "glossy_depth",
                self.glossy_depth.into(),
                0,
                MAX_GLOSSY_DEPTH.into(),
                "Russian roulette ends paths long before",
            ),
            (
                "min_chart_texels",
                self.min_chart_texels.into(),
                0,
                MAX_CHART_TEXELS.into(),
                "a chart's density is raised by at most 16× for it",
            ),
            (
                "min_scene_texels",
                self.min_scene_texels.into(),
                0,
                MAX_SCENE_TEXELS.into(),
                "that many texels across a scene is beyond any bake's memory",
            ),
            (
                "cache_budget_mib",
                self.cache_budget_mib.into(),
                0,
                MAX_CACHE_BUDGET_MIB.into(),
                "1 TiB, more memory than a machine has",
            ),
            (
                "max_elements",
                self.max_elements,
                0,
                MAX_ELEMENT_LIMIT,
                "that many elements need more memory than a machine has; 0: no limit",
            ),
        ];
        for (field, v, lo, hi, why) in counts {
            check_count(field, v, lo, hi, why)?;
        }
        let t = self.tolerance;
        if !(t.is_finite() && (0.0..1.0).contains(&t)) {
            return Err(SettingError::new(
                "tolerance",
                format!("{t} is not a fraction in [0, 1)"),
            ));
        }
        if let Some(e) = self.target_error
            && !(e.is_finite() && e > 0.0 && e < 1.0)
        {
            return Err(SettingError::new(
                "target_error",
                format!("{e} is not a relative error in (0, 1), e.g. 0.02 for 2%"),
            ));
        }
        Ok(())
    }

    /// The density a scene whose bounding box's longest side is `scene_side` metres gets:
    /// `texel_density`, raised to `min_scene_texels` across that side.
    pub fn scene_density(&self, scene_side: f32) -> f32 {
        let raised = self.min_scene_texels as f32 / scene_side;
        if self.min_scene_texels > 0 && raised.is_finite() && raised > self.texel_density {
            raised
        } else {
            self.texel_density
        }
    }

    /// The preset `quality`, then each of `overrides` in turn (scene.json's, then the flags'),
    /// checked ([`Self::check`], with `scene_size` when known).
    pub fn resolve(
        quality: Quality,
        overrides: &[&RadiosityOverride],
        scene_size: Option<f32>,
    ) -> Result<Self, SettingError> {
        let mut s = Self::preset(quality);
        for over in overrides {
            over.apply(&mut s);
        }
        s.check(scene_size)?;
        Ok(s)
    }
}

impl RadiosityOverride {
    /// Sets every field that is given: the one place an override meets the settings.
    fn apply(&self, s: &mut RadiositySettings) {
        let RadiosityOverride {
            texel_density,
            min_chart_texels,
            min_scene_texels,
            contact_boost,
            texels_per_radian,
            rays,
            light_samples,
            bounces,
            glossy_depth,
            tolerance,
            target_error,
            stitch_seams,
            cache_budget_mib,
            max_elements,
        } = *self;
        s.texel_density = texel_density.unwrap_or(s.texel_density);
        s.min_chart_texels = min_chart_texels.unwrap_or(s.min_chart_texels);
        s.min_scene_texels = min_scene_texels.unwrap_or(s.min_scene_texels);
        s.contact_boost = contact_boost.unwrap_or(s.contact_boost);
        s.texels_per_radian = texels_per_radian.unwrap_or(s.texels_per_radian);
        s.rays = rays.unwrap_or(s.rays);
        s.light_samples = light_samples.unwrap_or(s.light_samples);
        s.bounces = bounces.unwrap_or(s.bounces);
        s.glossy_depth = glossy_depth.unwrap_or(s.glossy_depth);
        s.tolerance = tolerance.unwrap_or(s.tolerance);
        s.cache_budget_mib = cache_budget_mib.unwrap_or(s.cache_budget_mib);
        s.max_elements = max_elements.unwrap_or(s.max_elements);
        match target_error {
            // 0 turns refinement off: one batch of `rays` and `light_samples`.
            Some(0.0) => s.target_error = None,
            Some(t) => s.target_error = Some(t),
            None => {}
        }
        s.stitch_seams = stitch_seams.unwrap_or(s.stitch_seams);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn refused(over: RadiosityOverride) -> SettingError {
        RadiositySettings::resolve(Quality::Draft, &[&over], None).unwrap_err()
    }

    #[test]
    fn every_radiosity_setting_can_be_overridden_and_is_checked() {
        let over: RadiosityOverride = serde_json::from_str(
            r#"{ "texel_density": 4, "rays": 9, "light_samples": 7, "bounces": 3,
                 "glossy_depth": 5, "tolerance": 0.5, "target_error": 0.03 }"#,
        )
        .unwrap();
        let s = RadiositySettings::resolve(Quality::Draft, &[&over], None).unwrap();
        assert_eq!(
            (
                s.texel_density,
                s.rays,
                s.light_samples,
                s.bounces,
                s.glossy_depth
            ),
            (4.0, 9, 7, 3, 5)
        );
        assert_eq!((s.tolerance, s.target_error), (0.5, Some(0.03)));
        // Presets promise an error; 0 turns refinement off.
        assert_eq!(
            RadiositySettings::preset(Quality::Default).target_error,
            Some(0.015)
        );
        let off = RadiosityOverride {
            target_error: Some(0.0),
            ..Default::default()
        };
        let s = RadiositySettings::resolve(Quality::High, &[&off], None).unwrap();
        assert_eq!(s.target_error, None);
        // A later override wins.
        let rays = |n| RadiosityOverride {
            rays: Some(n),
            ..Default::default()
        };
        let s = RadiositySettings::resolve(Quality::Draft, &[&rays(9), &rays(11)], None).unwrap();
        assert_eq!(s.rays, 11);
        for (field, bad) in [
            (
                "target_error",
                RadiosityOverride {
                    target_error: Some(1.5),
                    ..Default::default()
                },
            ),
            (
                "target_error",
                RadiosityOverride {
                    target_error: Some(f32::NAN),
                    ..Default::default()
                },
            ),
            (
                "glossy_depth",
                RadiosityOverride {
                    glossy_depth: Some(65),
                    ..Default::default()
                },
            ),
            (
                "light_samples",
                RadiosityOverride {
                    light_samples: Some(0),
                    ..Default::default()
                },
            ),
        ] {
            assert_eq!(refused(bad).field, field);
        }
    }

    /// Every count has an upper bound, and its error says why (issue 48, item 8: 4·10⁹
    /// bounces would have run for years).
    #[test]
    fn every_count_is_bounded_with_its_reason() {
        let cases = [
            ("bounces", "4000000000", MAX_BOUNCES as u64),
            ("rays", "4000000000", MAX_SAMPLES as u64),
            ("light_samples", "4000000000", MAX_SAMPLES as u64),
            ("min_chart_texels", "4000000000", MAX_CHART_TEXELS as u64),
            ("min_scene_texels", "4000000000", MAX_SCENE_TEXELS as u64),
            (
                "cache_budget_mib",
                "4000000000",
                MAX_CACHE_BUDGET_MIB as u64,
            ),
            ("max_elements", "18000000000000000000", MAX_ELEMENT_LIMIT),
        ];
        for (field, huge, max) in cases {
            let over: RadiosityOverride =
                serde_json::from_str(&format!(r#"{{ "{field}": {huge} }}"#)).unwrap();
            let e = refused(over);
            assert_eq!(e.field, field);
            assert!(
                e.message.contains(&format!("is more than {max} (")),
                "{field}: {e}"
            );
            // The bound itself is accepted.
            let over: RadiosityOverride =
                serde_json::from_str(&format!(r#"{{ "{field}": {max} }}"#)).unwrap();
            RadiositySettings::resolve(Quality::Draft, &[&over], None)
                .unwrap_or_else(|e| panic!("{field} = {max}: {e}"));
        }
        // Every preset is well inside them.
        for q in Quality::ALL {
            RadiositySettings::preset(q).check(None).unwrap();
        }
    }
}

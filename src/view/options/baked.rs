//! [`Baked`]: what a bundle holds for the viewer's reflection modes, and the modes
//! `glint-view` turns on for it when the command line leaves them unset ([`Defaults`]).

use super::{CurvedMode, ReflectionMode};

/// What a bundle was baked for, as far as the default reflection modes go (filled in by
/// `view::defaults::baked`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Baked {
    /// Glossy planar reflectors with the `radiance` stage baked: image-based reflections.
    pub radiance_maps: bool,
    /// Glossy curved reflectors in the scene: their cube maps are rendered at load time.
    pub curved_reflectors: usize,
    /// Impostor objects with the `srdm` stage baked: depth maps to reflect.
    pub impostor_captures: bool,
    /// Reflection probes in the materials stage.
    pub probes: usize,
    /// The materials stage's regular samples a glossy lobe (its `sample_budget`), where it
    /// baked the MIP environment maps that the curved reflectors' glossy term reads.
    pub glossy_samples: Option<u32>,
}

/// The reflection modes the command line asked for (`None`: not given).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Asked {
    /// `--reflections`.
    pub reflections: Option<ReflectionMode>,
    /// `--curved`.
    pub curved: Option<CurvedMode>,
    /// `--impostors`.
    pub impostors: Option<bool>,
    /// `--probes`.
    pub probes: Option<bool>,
}

/// The reflection modes a view starts with, each with why.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Defaults {
    /// Planar reflections.
    pub reflections: ReflectionMode,
    /// Curved reflectors.
    pub curved: CurvedMode,
    /// Impostor reflections in planar reflectors.
    pub impostors: bool,
    /// Reflection probes.
    pub probes: bool,
    asked: Asked,
    baked: Baked,
}

impl Defaults {
    /// The modes for `asked` on a bundle holding `baked`: what was asked, else image-based
    /// planar reflections where radiance maps are baked, cube maps for curved reflectors, and
    /// impostor reflections where depth maps are baked but no radiance maps (radiance maps
    /// already show the impostor objects, so both would add their reflection twice).
    pub fn resolve(asked: Asked, baked: Baked) -> Defaults {
        let reflections = asked.reflections.unwrap_or(if baked.radiance_maps {
            ReflectionMode::Image
        } else {
            ReflectionMode::Off
        });
        let curved = asked.curved.unwrap_or(if baked.curved_reflectors > 0 {
            CurvedMode::Cubemap
        } else {
            CurvedMode::Off
        });
        let impostors = asked.impostors.unwrap_or(
            baked.impostor_captures && asked.reflections.is_none() && !baked.radiance_maps,
        );
        let probes = asked.probes.unwrap_or(baked.probes > 0);
        Defaults {
            reflections,
            curved,
            impostors,
            probes,
            asked,
            baked,
        }
    }

    /// One line naming each mode and where it came from, e.g. `reflections image (radiance
    /// maps baked), curved cubemap (1 curved reflector), impostors off (radiance maps show
    /// the impostor objects)`.
    pub fn describe(&self) -> String {
        let b = &self.baked;
        let reflections = match (self.asked.reflections, b.radiance_maps) {
            (Some(_), _) => "--reflections".to_string(),
            (None, true) => "radiance maps baked".to_string(),
            (None, false) => "no radiance maps baked".to_string(),
        };
        let curved = match (self.asked.curved, b.curved_reflectors) {
            (Some(_), _) => "--curved".to_string(),
            (None, 0) => "no curved reflectors".to_string(),
            (None, 1) => "1 curved reflector".to_string(),
            (None, n) => format!("{n} curved reflectors"),
        };
        let impostors = if self.asked.impostors.is_some() {
            "--impostors"
        } else if !b.impostor_captures {
            "no impostor depth maps baked"
        } else if self.impostors {
            "impostor depth maps baked, no radiance maps"
        } else if b.radiance_maps {
            "radiance maps show the impostor objects"
        } else {
            "--reflections given"
        };
        let probes = match (self.asked.probes, b.probes) {
            (Some(_), _) => "--probes".to_string(),
            (None, 0) => "no probes baked".to_string(),
            (None, 1) => "1 probe baked".to_string(),
            (None, n) => format!("{n} probes baked"),
        };
        let on = |b: bool| if b { "on" } else { "off" };
        format!(
            "reflections {} ({reflections}), curved {} ({curved}), impostors {} ({impostors}), probes {} ({probes})",
            self.reflections,
            self.curved,
            on(self.impostors),
            on(self.probes)
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const EVERYTHING: Baked = Baked {
        radiance_maps: true,
        curved_reflectors: 1,
        impostor_captures: true,
        probes: 2,
        glossy_samples: Some(20),
    };

    fn modes(d: Defaults) -> (ReflectionMode, CurvedMode, bool) {
        (d.reflections, d.curved, d.impostors)
    }

    #[test]
    fn nothing_baked_turns_nothing_on() {
        let d = Defaults::resolve(Asked::default(), Baked::default());
        assert_eq!(modes(d), (ReflectionMode::Off, CurvedMode::Off, false));
        assert_eq!(
            d.describe(),
            "reflections off (no radiance maps baked), curved off (no curved reflectors), \
             impostors off (no impostor depth maps baked), probes off (no probes baked)"
        );
    }

    #[test]
    fn a_fully_baked_bundle_turns_on_image_reflections_and_cube_maps() {
        let d = Defaults::resolve(Asked::default(), EVERYTHING);
        assert_eq!(
            modes(d),
            (ReflectionMode::Image, CurvedMode::Cubemap, false)
        );
        assert_eq!(
            d.describe(),
            "reflections image (radiance maps baked), curved cubemap (1 curved reflector), \
             impostors off (radiance maps show the impostor objects), probes on (2 probes baked)"
        );
    }

    #[test]
    fn impostors_stand_in_where_only_depth_maps_are_baked() {
        let baked = Baked {
            impostor_captures: true,
            ..Baked::default()
        };
        let d = Defaults::resolve(Asked::default(), baked);
        assert_eq!(modes(d), (ReflectionMode::Off, CurvedMode::Off, true));
        assert!(
            d.describe()
                .contains("impostors on (impostor depth maps baked, no radiance maps)")
        );
        // Planar reflections asked for draw the impostor objects themselves.
        let asked = Asked {
            reflections: Some(ReflectionMode::Geometry),
            ..Asked::default()
        };
        let d = Defaults::resolve(asked, baked);
        assert_eq!(modes(d), (ReflectionMode::Geometry, CurvedMode::Off, false));
        assert!(d.describe().contains("impostors off (--reflections given)"));
    }

    #[test]
    fn flags_override_what_was_baked() {
        let asked = Asked {
            reflections: Some(ReflectionMode::Off),
            curved: Some(CurvedMode::Off),
            impostors: Some(true),
            probes: Some(false),
        };
        let d = Defaults::resolve(asked, EVERYTHING);
        assert_eq!(modes(d), (ReflectionMode::Off, CurvedMode::Off, true));
        assert_eq!(
            d.describe(),
            "reflections off (--reflections), curved off (--curved), impostors on (--impostors), \
             probes off (--probes)"
        );
        let d = Defaults::resolve(
            Asked {
                curved: Some(CurvedMode::Impostor),
                ..Asked::default()
            },
            Baked {
                curved_reflectors: 3,
                ..Baked::default()
            },
        );
        assert_eq!(d.curved, CurvedMode::Impostor);
        let d = Defaults::resolve(
            Asked::default(),
            Baked {
                curved_reflectors: 3,
                ..Baked::default()
            },
        );
        assert!(
            d.describe()
                .contains("curved cubemap (3 curved reflectors)")
        );
    }
}

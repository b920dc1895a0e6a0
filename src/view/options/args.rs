//! [`ViewArgs`]: `glint-view`'s command-line form of [`ViewOptions`], and
//! [`ViewOptions::from_args`], the same parser for tests and tools.

use super::baked::{Asked, Baked, Defaults};
use super::{
    CurvedMode, CurvedSettings, DEFAULT_FACE_SIZE, DEFAULT_GENERATIONS, DEFAULT_WEIGHT_CUTOFF,
    Exposure, ImpostorKind, RecursionSettings, ReflectanceChannel, ReflectanceLayout,
    ReflectanceSettings, ReflectionMode, Selection, Tonemap, ViewOptions, parse_depth,
    parse_samples,
};

/// The command-line form of [`ViewOptions`] (`#[command(flatten)]` in `glint-view`).
#[derive(clap::Args, Clone, Debug)]
pub struct ViewArgs {
    /// Exposure of the 8-bit frames (PNG, the window): `auto` (from the log-average
    /// luminance of the bundle's radiosity textures, mapped to mid-grey 0.18; one value for
    /// every frame) or an exposure value in stops (radiance × 2^EV; 0: as baked). HDR frames
    /// (`--hdr`) are linear radiance, never exposed. In the window, - and = change it, 0
    /// returns to auto.
    #[arg(
        long,
        value_name = "auto|EV",
        default_value = "auto",
        allow_hyphen_values = true
    )]
    pub exposure: Exposure,
    /// Tone curve of the 8-bit frames after exposure: `neutral` (Khronos PBR Neutral: base
    /// colours kept up to 0.8, highlights compressed to white) or `none` (clamped). In the
    /// window, M switches it.
    #[arg(long, value_name = "CURVE", default_value = "neutral")]
    pub tonemap: Tonemap,
    /// Glossy planar reflections: `geometry` (the mirrored scene re-rendered per reflector,
    /// ks·R·M added to D), `image` (the baked radiance maps splatted; needs the radiance
    /// stage) or `off`. Default: `image` when the bundle has radiance maps, else `off`.
    #[arg(long, value_name = "MODE")]
    pub reflections: Option<ReflectionMode>,
    /// Image-based reflections: radiance maps selected per reflector element.
    #[arg(long, value_name = "N", default_value_t = 2,
          value_parser = clap::value_parser!(u8).range(1..=16))]
    pub maps: u8,
    /// Image-based reflections: select maps by `angle` (Bastos's default) or `distance`.
    #[arg(long, value_name = "HOW", default_value = "angle")]
    pub selection: Selection,
    /// Reflections: read R from the `sphere` map (by reflected direction) or the `1d`
    /// grazing-dense map (by view angle).
    #[arg(long, value_name = "MAP", default_value = "1d")]
    pub reflectance: ReflectanceLayout,
    /// Reflections: R's channel, `albedo` (directional albedo, matches the path tracer) or
    /// `bastos` (F/(π cos²θ) as printed).
    #[arg(long, value_name = "CHANNEL", default_value = "albedo")]
    pub reflectance_channel: ReflectanceChannel,
    /// Reflections of impostors in planar reflectors (Popescu §3–4): `on` or `off`. Curved
    /// reflectors reflect impostors with `--curved impostor` instead. Default: `on` when the
    /// bundle has impostor depth maps (srdm stage) but no radiance maps and `--reflections`
    /// is not given (radiance maps and geometry reflections show the impostor objects already).
    #[arg(long, value_name = "on|off", value_parser = parse_on_off,
          action = clap::ArgAction::Set)]
    pub impostors: Option<bool>,
    /// What stands for impostor objects in reflections (`--impostors on`, `--curved
    /// impostor`): `srdm` (depth maps through their SRDM rows, §4.3; needs the srdm stage) or
    /// `billboard` (one billboard per object and reflector, §3, made at load time; misses
    /// read the reflector's baked environment map when the materials stage has one).
    #[arg(long, value_name = "KIND", default_value = "srdm")]
    pub impostor_kind: ImpostorKind,
    /// Curved reflectors: `cubemap` (a view-independent cube map per reflector, Nielsen §3.2),
    /// `impostor` (reflected rays against the impostors only, Popescu §3–4) or `off`.
    /// Default: `cubemap` when the scene has glossy curved reflectors, else `off`.
    #[arg(long, value_name = "MODE")]
    pub curved: Option<CurvedMode>,
    /// Curved reflectors: regular samples per pixel and lobe (Luksch §6–7; the pattern
    /// closest to N); 0: one mirror lookup. The glossy term reads the baked MIP environment
    /// map when the bundle's materials stage has one, else the live cube map.
    /// Default: the materials stage's sample budget where it baked those maps, else 0.
    #[arg(long, value_name = "N")]
    pub glossy_samples: Option<u32>,
    /// Curved reflectors: face size of the live cube maps, texels.
    #[arg(long, value_name = "N", default_value_t = DEFAULT_FACE_SIZE,
          value_parser = clap::value_parser!(u32).range(1..=8192))]
    pub cube_size: u32,
    /// Curved reflectors: generations of cube maps (1: no interreflection between them).
    #[arg(long, value_name = "N", default_value_t = DEFAULT_GENERATIONS,
          value_parser = clap::value_parser!(u32).range(1..=8))]
    pub cube_generations: u32,
    /// Curved reflectors: distance-corrected cube-map lookups (`on`): each point looks up where
    /// its own reflected ray meets the room, found from the distances the live cube map
    /// stores; `off`: Nielsen's lookup from the map's centre (right for a distant room only).
    #[arg(long, value_name = "on|off", default_value = "on", value_parser = parse_on_off,
          action = clap::ArgAction::Set)]
    pub cube_parallax: bool,
    /// Curved reflectors: reflected rays cast at the reflector's own triangles first (`on`),
    /// so a teapot's body shows its spout, handle, lid and knob where its rays meet them;
    /// `off`: every ray sees the room (Nielsen's maps are taken without the reflector).
    #[arg(long, value_name = "on|off", default_value = "on", value_parser = parse_on_off,
          action = clap::ArgAction::Set)]
    pub cube_self_occlusion: bool,
    /// Curved reflectors and probes: specular anti-aliasing (`on`): each lobe widened by the
    /// spread of the shading normal across the pixel, so a highlight narrower than a pixel
    /// does not fill it; `off`: every pixel shades its centre's normal only.
    #[arg(long, value_name = "on|off", default_value = "on", value_parser = parse_on_off,
          action = clap::ArgAction::Set)]
    pub specular_aa: bool,
    /// Geometry reflections: recursion depth 0–4 (Nielsen & Christensen 2002 §3.1): 0 draws
    /// no reflections (as `--reflections off`), 1 mirrors the scene once per reflector (the
    /// default), 2–4 also draw the reflectors seen in each reflection, one reflection map per
    /// level. Needs `--reflections geometry`. In the window, \[ and \] change it.
    #[arg(long, value_name = "N", value_parser = parse_depth)]
    pub recursion_depth: Option<u8>,
    /// Recursive reflections: a branch stops when its accumulated specular weight (the product
    /// of max ks·R along the path) falls below this.
    #[arg(long, value_name = "W", default_value_t = DEFAULT_WEIGHT_CUTOFF, value_parser = parse_cutoff)]
    pub reflection_cutoff: f32,
    /// Reflections: a near-mirror seen in another reflector's map (geometry mode: of the
    /// last level) shows what it reflects from a cube map taken at its centre
    /// (distance-corrected, as `--cube-parallax`, with `--glossy-samples` and `--cube-size`;
    /// made once, six renders of the scene per near-mirror); `off`: geometry mode draws its
    /// kd·D alone (Nielsen's recursion), image mode splats it as the radiance maps saw it. A
    /// mirror seen in a glossy floor then shows the room at depth 1 too.
    #[arg(long, value_name = "on|off", default_value = "on", value_parser = parse_on_off,
          action = clap::ArgAction::Set)]
    pub terminal_cubemaps: bool,
    /// Reflection probes (`on`/`off`): every glossy surface that no reflector declares adds
    /// ks·R × the prefiltered radiance of the probe the bake placed for it, in both
    /// reflection modes. Default: `on` when the bundle's materials stage holds probes.
    #[arg(long, value_name = "on|off", value_parser = parse_on_off,
          action = clap::ArgAction::Set)]
    pub probes: Option<bool>,
    /// Anti-aliasing: samples per pixel, 1 (off), 2, 4 or 8: the frame's geometry is
    /// multisampled and resolved before the exposure and tone curve, and planar reflections
    /// are drawn at the side of that sample grid squared (2×2 texels a pixel at 4 and 8) and
    /// box-filtered. A GPU that cannot multisample that many draws the most it can (1 with
    /// none), with a warning.
    #[arg(long, value_name = "N", default_value_t = super::DEFAULT_SAMPLES,
          value_parser = parse_samples)]
    pub samples: u32,
    /// Planar reflections: anti-aliased with the frame (`on`: in a multisampled frame the
    /// reflected image is drawn at 2×2 texels a pixel and box-filtered; `off`: one texel a
    /// pixel, cheaper, reflected edges stair-stepped).
    #[arg(long, value_name = "on|off", default_value = "on", value_parser = parse_on_off,
          action = clap::ArgAction::Set)]
    pub reflection_aa: bool,
}

/// `glint-view`'s view arguments alone, for [`ViewOptions::from_args`].
#[derive(clap::Parser)]
#[command(name = "glint-view")]
struct ViewCli {
    #[command(flatten)]
    view: ViewArgs,
}

impl ViewOptions {
    /// The options `glint-view` renders with for these view arguments (e.g. `["--maps",
    /// "4"]`) on a bundle with nothing baked for reflections: the same parser, defaults and
    /// checks.
    pub fn from_args<I, S>(args: I) -> Result<ViewOptions, String>
    where
        I: IntoIterator<Item = S>,
        S: Into<std::ffi::OsString> + Clone,
    {
        ViewOptions::from_args_for(args, &Baked::default())
    }

    /// [`ViewOptions::from_args`] on a bundle holding `baked`: the modes left unset are the
    /// ones it was baked for ([`Defaults::resolve`]).
    pub fn from_args_for<I, S>(args: I, baked: &Baked) -> Result<ViewOptions, String>
    where
        I: IntoIterator<Item = S>,
        S: Into<std::ffi::OsString> + Clone,
    {
        use clap::Parser;
        let argv = std::iter::once(std::ffi::OsString::from("glint-view"))
            .chain(args.into_iter().map(Into::into));
        let cli = ViewCli::try_parse_from(argv).map_err(|e| e.to_string())?;
        cli.view.options_for(baked)
    }
}

impl ViewArgs {
    /// The options these arguments ask for with nothing baked for reflections (every mode
    /// left unset is off); `--recursion-depth` without `--reflections geometry` is an error.
    pub fn options(&self) -> Result<ViewOptions, String> {
        self.options_for(&Baked::default())
    }

    /// The reflection modes these arguments give on a bundle holding `baked`.
    pub fn defaults(&self, baked: &Baked) -> Defaults {
        Defaults::resolve(
            Asked {
                reflections: self.reflections,
                curved: self.curved,
                impostors: self.impostors,
                probes: self.probes,
            },
            *baked,
        )
    }

    /// The options these arguments ask for on a bundle holding `baked`: modes left unset
    /// are what it was baked for ([`ViewArgs::defaults`]); `--recursion-depth` without
    /// `--reflections geometry` is an error.
    pub fn options_for(&self, baked: &Baked) -> Result<ViewOptions, String> {
        let modes = self.defaults(baked);
        if let Some(d) = self.recursion_depth
            && modes.reflections != ReflectionMode::Geometry
        {
            let why = if self.reflections.is_some() {
                ""
            } else {
                ", the default for this bundle"
            };
            return Err(format!(
                "--recursion-depth {d} needs --reflections geometry (reflections are {}{why})",
                modes.reflections
            ));
        }
        let options = ViewOptions {
            exposure: self.exposure,
            tonemap: self.tonemap,
            reflections: modes.reflections,
            selection: self.selection,
            maps: usize::from(self.maps),
            reflectance: ReflectanceSettings {
                layout: self.reflectance,
                channel: self.reflectance_channel,
            },
            impostors: modes.impostors,
            impostor_kind: self.impostor_kind,
            curved: modes.curved,
            curved_settings: CurvedSettings {
                glossy_samples: self.glossy_samples.or(baked.glossy_samples).unwrap_or(0),
                face_size: self.cube_size,
                generations: self.cube_generations,
                parallax: self.cube_parallax,
                self_occlusion: self.cube_self_occlusion,
                specular_aa: self.specular_aa,
            },
            recursion: RecursionSettings {
                depth: self.recursion_depth.unwrap_or(1),
                cutoff: self.reflection_cutoff,
                terminal: self.terminal_cubemaps,
            },
            probes: modes.probes,
            splat_buffer_bytes: None,
            samples: self.samples,
            reflection_aa: self.reflection_aa,
        };
        options.check()?;
        Ok(options)
    }
}

/// `on` or `off`.
pub fn parse_on_off(s: &str) -> Result<bool, String> {
    match s {
        "on" => Ok(true),
        "off" => Ok(false),
        _ => Err(format!("{s:?} is not one of on, off")),
    }
}

fn parse_cutoff(s: &str) -> Result<f32, String> {
    match s.parse::<f32>() {
        Ok(v) if (0.0..=1.0).contains(&v) => Ok(v),
        _ => Err(format!("{s:?} is not a weight from 0 to 1")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn options(args: &[&str]) -> Result<ViewOptions, String> {
        ViewOptions::from_args(args.iter().copied())
    }

    #[test]
    fn no_arguments_are_the_default_options() {
        assert_eq!(options(&[]).unwrap(), ViewOptions::default());
    }

    #[test]
    fn every_argument_reaches_its_option() {
        let o = options(&[
            "--exposure",
            "-2",
            "--tonemap",
            "none",
            "--reflections",
            "geometry",
            "--maps",
            "4",
            "--selection",
            "distance",
            "--reflectance",
            "sphere",
            "--reflectance-channel",
            "bastos",
            "--impostors",
            "on",
            "--impostor-kind",
            "billboard",
            "--curved",
            "impostor",
            "--glossy-samples",
            "8",
            "--cube-size",
            "64",
            "--cube-generations",
            "3",
            "--cube-parallax",
            "off",
            "--cube-self-occlusion",
            "off",
            "--specular-aa",
            "off",
            "--recursion-depth",
            "3",
            "--reflection-cutoff",
            "0.5",
            "--terminal-cubemaps",
            "off",
            "--probes",
            "on",
            "--samples",
            "2",
            "--reflection-aa",
            "off",
        ])
        .unwrap();
        assert_eq!(
            o,
            ViewOptions {
                exposure: Exposure::Ev(-2.0),
                tonemap: Tonemap::None,
                reflections: ReflectionMode::Geometry,
                selection: Selection::Distance,
                maps: 4,
                reflectance: ReflectanceSettings {
                    layout: ReflectanceLayout::Sphere,
                    channel: ReflectanceChannel::Bastos,
                },
                impostors: true,
                impostor_kind: ImpostorKind::Billboard,
                curved: CurvedMode::Impostor,
                curved_settings: CurvedSettings {
                    glossy_samples: 8,
                    face_size: 64,
                    generations: 3,
                    parallax: false,
                    self_occlusion: false,
                    specular_aa: false,
                },
                recursion: RecursionSettings {
                    depth: 3,
                    cutoff: 0.5,
                    terminal: false,
                },
                probes: true,
                splat_buffer_bytes: None,
                samples: 2,
                reflection_aa: false,
            }
        );
        assert!(o.recursive() && o.shows_reflections());
    }

    #[test]
    fn unset_modes_are_what_the_bundle_was_baked_for() {
        let baked = Baked {
            radiance_maps: true,
            curved_reflectors: 1,
            impostor_captures: true,
            probes: 1,
            glossy_samples: Some(20),
        };
        let o = ViewOptions::from_args_for(["--maps", "4"], &baked).unwrap();
        assert_eq!(
            (o.reflections, o.curved, o.impostors, o.probes, o.maps),
            (ReflectionMode::Image, CurvedMode::Cubemap, false, true, 4)
        );
        // The glossy curved reflectors read the baked environment maps at the bake's budget,
        // unless told otherwise; without those maps, one mirror lookup.
        assert_eq!(o.curved_settings.glossy_samples, 20);
        let o = ViewOptions::from_args_for(["--glossy-samples", "4"], &baked).unwrap();
        assert_eq!(o.curved_settings.glossy_samples, 4);
        let o = ViewOptions::from_args_for(std::iter::empty::<&str>(), &Baked::default()).unwrap();
        assert_eq!(o.curved_settings.glossy_samples, 0);
        let o = ViewOptions::from_args_for(["--probes", "off"], &baked).unwrap();
        assert!(!o.probes);
        let o = ViewOptions::from_args_for(
            [
                "--reflections",
                "off",
                "--curved",
                "impostor",
                "--impostors",
                "on",
            ],
            &baked,
        )
        .unwrap();
        assert_eq!(
            (o.reflections, o.curved, o.impostors),
            (ReflectionMode::Off, CurvedMode::Impostor, true)
        );
        let e = ViewOptions::from_args_for(["--recursion-depth", "2"], &baked).unwrap_err();
        assert!(
            e.contains(
                "needs --reflections geometry (reflections are image, the default for this bundle)"
            ),
            "{e}"
        );
    }

    #[test]
    fn bad_arguments_name_the_option() {
        let e = options(&["--recursion-depth", "2"]).unwrap_err();
        assert!(
            e.contains("--recursion-depth 2 needs --reflections geometry"),
            "{e}"
        );
        let e = options(&["--maps", "17"]).unwrap_err();
        assert!(e.contains("--maps"), "{e}");
        let e = options(&["--selection", "near"]).unwrap_err();
        assert!(e.contains("angle, distance"), "{e}");
        for bad in ["3", "0", "16", "x"] {
            let e = options(&["--samples", bad]).unwrap_err();
            assert!(
                e.contains("--samples") && e.contains("give 1 (no anti-aliasing), 2, 4 or 8"),
                "{e}"
            );
        }
        let o = ViewOptions {
            maps: 0,
            ..ViewOptions::default()
        };
        assert!(o.check().unwrap_err().contains("maps 0"));
        let o = ViewOptions {
            samples: 3,
            ..ViewOptions::default()
        };
        assert!(o.check().unwrap_err().contains("samples 3"));
    }
}

//! What a viewer frame shows: [`ViewOptions`], the one set of switches the window, headless
//! replay and `glint-eval sweep` all render with, and [`ViewArgs`], its command-line form.
//!
//! Always compiled (no `view` feature needed), so the evaluation tools and the bake-only
//! build name the same modes the viewer draws. The passes are built from these options by
//! `view::frame::FramePasses` (feature `view`).

mod args;
mod baked;

pub use args::{ViewArgs, parse_on_off};
pub use baked::{Asked, Baked, Defaults};
use serde::Serialize;

pub use super::exposure::{Exposure, ExposureKey, MAX_EV};
pub use super::tonemap::Tonemap;

/// How the viewer draws glossy planar reflections (`--reflections`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ReflectionMode {
    /// Diffuse D only.
    #[default]
    Off,
    /// The mirrored scene re-rendered per reflector (render to texture).
    Geometry,
    /// From the baked radiance maps (Bastos §8.1.3), splatted.
    Image,
}

impl ReflectionMode {
    /// The next mode in the window's cycle (off → geometry → image → off).
    pub fn next(self) -> ReflectionMode {
        match self {
            ReflectionMode::Off => ReflectionMode::Geometry,
            ReflectionMode::Geometry => ReflectionMode::Image,
            ReflectionMode::Image => ReflectionMode::Off,
        }
    }
}

impl std::str::FromStr for ReflectionMode {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "off" => Ok(ReflectionMode::Off),
            "geometry" => Ok(ReflectionMode::Geometry),
            "image" => Ok(ReflectionMode::Image),
            _ => Err(format!("{s:?} is not one of image, geometry, off")),
        }
    }
}

impl std::fmt::Display for ReflectionMode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            ReflectionMode::Off => "off",
            ReflectionMode::Geometry => "geometry",
            ReflectionMode::Image => "image",
        })
    }
}

/// How the image-based mode selects radiance maps for the reflected view (`--selection`,
/// Bastos §8.1.3).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Selection {
    /// Smallest angle, at the element's centre, between the map's centre of projection and
    /// the mirrored eye (Bastos's default).
    #[default]
    Angle,
    /// Smallest distance from the map's centre of projection to the mirrored eye.
    Distance,
}

impl std::str::FromStr for Selection {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "angle" => Ok(Selection::Angle),
            "distance" => Ok(Selection::Distance),
            _ => Err(format!("{s:?} is not one of angle, distance")),
        }
    }
}

impl std::fmt::Display for Selection {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Selection::Angle => "angle",
            Selection::Distance => "distance",
        })
    }
}

/// Which reflectance map R is read from (`--reflectance`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub enum ReflectanceLayout {
    /// The 1D map, texels dense towards grazing (isotropic lobes; Bastos §9).
    #[default]
    #[serde(rename = "1d")]
    OneD,
    /// The sphere map, indexed by the reflected direction (Bastos §8.2.2).
    #[serde(rename = "sphere")]
    Sphere,
}

impl ReflectanceLayout {
    /// The other layout (the window's T key).
    pub fn other(self) -> ReflectanceLayout {
        match self {
            ReflectanceLayout::OneD => ReflectanceLayout::Sphere,
            ReflectanceLayout::Sphere => ReflectanceLayout::OneD,
        }
    }
}

impl std::str::FromStr for ReflectanceLayout {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "1d" => Ok(ReflectanceLayout::OneD),
            "sphere" => Ok(ReflectanceLayout::Sphere),
            _ => Err(format!("{s:?} is not one of sphere, 1d")),
        }
    }
}

impl std::fmt::Display for ReflectanceLayout {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            ReflectanceLayout::OneD => "1d",
            ReflectanceLayout::Sphere => "sphere",
        })
    }
}

/// Which channel of the reflectance maps modulates the reflection (`--reflectance-channel`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ReflectanceChannel {
    /// `A`, the directional albedo: energy-consistent with a kernel normalized to 1.
    #[default]
    Albedo,
    /// `R` = F/(π cos²θ), Bastos's modulation as printed (grows as 1/cos²θ towards grazing).
    Bastos,
}

impl ReflectanceChannel {
    /// The EXR channel name.
    pub fn exr_channel(self) -> &'static str {
        match self {
            ReflectanceChannel::Albedo => "A",
            ReflectanceChannel::Bastos => "R",
        }
    }
}

impl std::str::FromStr for ReflectanceChannel {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "albedo" => Ok(ReflectanceChannel::Albedo),
            "bastos" => Ok(ReflectanceChannel::Bastos),
            _ => Err(format!("{s:?} is not one of albedo, bastos")),
        }
    }
}

/// Where R comes from and which of its channels.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct ReflectanceSettings {
    /// Sphere map or 1D map.
    pub layout: ReflectanceLayout,
    /// `A` (directional albedo, the default) or `R` (Bastos's F/(π cos²θ)).
    pub channel: ReflectanceChannel,
}

/// What stands for an impostor object in reflections (`--impostor-kind`, Popescu §3–4).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ImpostorKind {
    /// Depth-map impostors through their SRDM rows (§4.3; the bundle's `srdm` stage).
    #[default]
    Srdm,
    /// Reflected billboards, one per object and reflector (§3), made at load time.
    Billboard,
}

impl ImpostorKind {
    /// The other kind (the window's K key).
    pub fn other(self) -> ImpostorKind {
        match self {
            ImpostorKind::Srdm => ImpostorKind::Billboard,
            ImpostorKind::Billboard => ImpostorKind::Srdm,
        }
    }
}

impl std::str::FromStr for ImpostorKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "srdm" => Ok(ImpostorKind::Srdm),
            "billboard" => Ok(ImpostorKind::Billboard),
            _ => Err(format!("{s:?} is not one of srdm, billboard")),
        }
    }
}

impl std::fmt::Display for ImpostorKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            ImpostorKind::Srdm => "srdm",
            ImpostorKind::Billboard => "billboard",
        })
    }
}

/// How the viewer draws curved reflectors (`--curved`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum CurvedMode {
    /// kd·D only.
    #[default]
    Off,
    /// View-independent cube maps per reflector (Nielsen §3.2).
    Cubemap,
    /// The impostor pass (Popescu §3–4): reflected rays of curved reflectors against the
    /// impostors (depth maps or billboards, `--impostor-kind`), misses reading the baked
    /// environment map with billboards. The rest of the scene is not reflected.
    Impostor,
}

impl CurvedMode {
    /// The next mode in the window's cycle (off → cubemap → impostor → off).
    pub fn next(self) -> CurvedMode {
        match self {
            CurvedMode::Off => CurvedMode::Cubemap,
            CurvedMode::Cubemap => CurvedMode::Impostor,
            CurvedMode::Impostor => CurvedMode::Off,
        }
    }
}

impl std::str::FromStr for CurvedMode {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "off" => Ok(CurvedMode::Off),
            "cubemap" => Ok(CurvedMode::Cubemap),
            "impostor" => Ok(CurvedMode::Impostor),
            _ => Err(format!("{s:?} is not one of cubemap, impostor, off")),
        }
    }
}

impl std::fmt::Display for CurvedMode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            CurvedMode::Off => "off",
            CurvedMode::Cubemap => "cubemap",
            CurvedMode::Impostor => "impostor",
        })
    }
}

/// Settings of the curved-reflector passes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct CurvedSettings {
    /// Regular samples per pixel and lobe (closest pattern, Luksch §6–7); 0: one mirror
    /// lookup.
    pub glossy_samples: u32,
    /// Face size of the live cube maps, texels.
    pub face_size: u32,
    /// Generations of cube maps (1: no interreflection between curved reflectors).
    pub generations: u32,
    /// Distance-corrected lookups ([`crate::view::curved::parallax_direction`]): each point
    /// of the reflector looks up where its own reflected ray meets the room, not where a
    /// ray from the map's centre does (Nielsen's maps assume a distant environment).
    pub parallax: bool,
    /// Reflected rays cast at the reflector's own triangles first
    /// ([`crate::view::curved::own_mesh`]): a concave reflector (a teapot) shows its own
    /// spout, handle, lid or knob where its rays meet them, not the room behind.
    pub self_occlusion: bool,
    /// Specular anti-aliasing of the curved reflectors' and the probe-lit surfaces' pixels:
    /// each lobe widened by the spread of the shading normal across the pixel
    /// (`kernel_roughness2` in `shaders/view.wgsl`, which both passes call), so
    /// a highlight narrower than a pixel does not fill it.
    pub specular_aa: bool,
}

/// Face size of live cube maps unless set.
pub const DEFAULT_FACE_SIZE: u32 = 128;

/// Generations unless set: one bounce between curved reflectors.
pub const DEFAULT_GENERATIONS: u32 = 2;

impl Default for CurvedSettings {
    fn default() -> Self {
        CurvedSettings {
            glossy_samples: 0,
            face_size: DEFAULT_FACE_SIZE,
            generations: DEFAULT_GENERATIONS,
            parallax: true,
            self_occlusion: true,
            specular_aa: true,
        }
    }
}

/// The deepest recursion the viewer draws (Nielsen & Christensen 2002, Table 1 goes to 4).
pub const MAX_RECURSION_DEPTH: u8 = 4;

/// Default specular-weight cutoff: a branch whose accumulated max(ks·R) falls below 1 % adds
/// at most ~2.5 steps of an 8-bit channel at full white, so its map is not rendered.
pub const DEFAULT_WEIGHT_CUTOFF: f32 = 0.01;

/// Recursive planar reflections (Nielsen & Christensen 2002 §3.1).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct RecursionSettings {
    /// Recursion depth d (0–[`MAX_RECURSION_DEPTH`]); 0 draws no reflections, 1 mirrors the
    /// scene once (the single mirror pass).
    pub depth: u8,
    /// A branch stops when its accumulated specular weight falls below this.
    pub cutoff: f32,
    /// Near-mirrors seen in a map of the last level (no map of their own; in image mode, in
    /// any map) get a cube map's specular term ([`crate::view::reflections::terminal`]);
    /// off: their kd·D alone (image mode: their map points splatted).
    pub terminal: bool,
}

impl Default for RecursionSettings {
    fn default() -> Self {
        RecursionSettings {
            depth: 1,
            cutoff: DEFAULT_WEIGHT_CUTOFF,
            terminal: true,
        }
    }
}

/// Parses a recursion depth for the command line: an integer 0–4.
pub fn parse_depth(s: &str) -> Result<u8, String> {
    match s.parse::<u8>() {
        Ok(d) if d <= MAX_RECURSION_DEPTH => Ok(d),
        _ => Err(format!(
            "{s:?} is not a recursion depth: give an integer from 0 to {MAX_RECURSION_DEPTH}"
        )),
    }
}

/// Samples per pixel `--samples` accepts: 1 (no anti-aliasing) or a multisample count.
pub const SAMPLE_COUNTS: [u32; 4] = [1, 2, 4, 8];

/// Samples per pixel unless set: 4× multisampling, which every WebGPU adapter offers for the
/// frame's formats.
pub const DEFAULT_SAMPLES: u32 = 4;

/// Parses a sample count for the command line: one of [`SAMPLE_COUNTS`].
pub fn parse_samples(s: &str) -> Result<u32, String> {
    match s.parse::<u32>() {
        Ok(n) if SAMPLE_COUNTS.contains(&n) => Ok(n),
        _ => Err(format!(
            "{s:?} is not a sample count: give 1 (no anti-aliasing), 2, 4 or 8"
        )),
    }
}

/// Everything that decides what a viewer frame shows, apart from the camera and the size.
/// The window starts with these (its keys change them), headless replay and the sweep's
/// viewer render with them.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ViewOptions {
    /// Exposure of the 8-bit frames (`auto` or EV); HDR output is never exposed.
    pub exposure: Exposure,
    /// Tone curve of the 8-bit frames.
    pub tonemap: Tonemap,
    /// Glossy planar reflections.
    pub reflections: ReflectionMode,
    /// Image-based mode: how radiance maps are selected.
    pub selection: Selection,
    /// Image-based mode: maps selected per reflector element.
    pub maps: usize,
    /// Reflections: where R is read from (sphere or 1D map) and which channel.
    pub reflectance: ReflectanceSettings,
    /// Reflections of impostors in planar reflectors (Popescu §3–4).
    pub impostors: bool,
    /// What stands for impostors: depth maps (SRDM) or billboards.
    pub impostor_kind: ImpostorKind,
    /// Curved reflectors.
    pub curved: CurvedMode,
    /// Curved reflectors: samples per pixel and lobe, cube-map size and generations.
    pub curved_settings: CurvedSettings,
    /// Geometry mode's recursion: depth 1 is the single mirror pass, any other depth the
    /// recursive passes. Ignored in the other modes.
    pub recursion: RecursionSettings,
    /// Reflection probes: the specular term of glossy surfaces no reflector declares.
    pub probes: bool,
    /// Image-based mode: the most bytes of splats one storage buffer holds (`None`: what the
    /// GPU binds in one, its `max_storage_buffer_binding_size`); a reflector's maps are split
    /// over as many buffers as that needs. Lower it to exercise the split.
    #[serde(skip)]
    pub splat_buffer_bytes: Option<u64>,
    /// Anti-aliasing: samples per pixel of the frame's geometry (multisampled, resolved before
    /// the display pass), one of [`SAMPLE_COUNTS`]; 1 is off. A GPU that cannot multisample
    /// the frame's formats that many times draws fewer (`view::gpu::target::frame_samples`).
    pub samples: u32,
    /// Planar reflections anti-aliased with the frame: M drawn at the side of the frame's
    /// sample grid texels a pixel (2 × 2 at 4 samples) and box-filtered
    /// (`reflections::downsample`); off, one texel a pixel.
    pub reflection_aa: bool,
}

impl Default for ViewOptions {
    fn default() -> Self {
        ViewOptions {
            exposure: Exposure::Auto,
            tonemap: Tonemap::Neutral,
            reflections: ReflectionMode::Off,
            selection: Selection::Angle,
            maps: 2,
            reflectance: ReflectanceSettings::default(),
            impostors: false,
            impostor_kind: ImpostorKind::Srdm,
            curved: CurvedMode::Off,
            curved_settings: CurvedSettings::default(),
            recursion: RecursionSettings::default(),
            probes: false,
            splat_buffer_bytes: None,
            samples: DEFAULT_SAMPLES,
            reflection_aa: true,
        }
    }
}

impl ViewOptions {
    /// These options with the identity display mapping: 0 EV and no tone curve, so an 8-bit
    /// frame is its radiance clamped to [0, 1] and sRGB-encoded (what CPU references of a
    /// frame compute).
    pub fn linear_display(self) -> ViewOptions {
        ViewOptions {
            exposure: Exposure::Ev(0.0),
            tonemap: Tonemap::None,
            ..self
        }
    }

    /// The recursion depth the frame draws: the set depth in geometry mode, 1 (the single
    /// pass, or none when reflections are off) otherwise.
    pub fn recursion_depth(&self) -> u8 {
        match self.reflections {
            ReflectionMode::Geometry => self.recursion.depth,
            _ => 1,
        }
    }

    /// Whether geometry reflections use the recursive passes (a depth other than 1).
    pub fn recursive(&self) -> bool {
        self.recursion_depth() != 1
    }

    /// Whether the frame shows glossy reflections anywhere (planar, impostor or curved).
    pub fn shows_reflections(&self) -> bool {
        self.reflections != ReflectionMode::Off || self.impostors || self.curved != CurvedMode::Off
    }

    /// Checks every value's range; the error names the option and what was expected.
    pub fn check(&self) -> Result<(), String> {
        if let Exposure::Ev(ev) = self.exposure
            && !(ev.is_finite() && ev.abs() <= MAX_EV)
        {
            return Err(format!(
                "exposure {ev} is not an exposure value in stops within ±{MAX_EV}"
            ));
        }
        if !(1..=16).contains(&self.maps) {
            return Err(format!("maps {} is not in 1 ..= 16", self.maps));
        }
        if self.recursion.depth > MAX_RECURSION_DEPTH {
            return Err(format!(
                "recursion depth {} is not in 0 ..= {MAX_RECURSION_DEPTH}",
                self.recursion.depth
            ));
        }
        if !(0.0..=1.0).contains(&self.recursion.cutoff) {
            return Err(format!(
                "reflection cutoff {} is not a weight from 0 to 1",
                self.recursion.cutoff
            ));
        }
        let c = &self.curved_settings;
        if c.glossy_samples > 256 {
            return Err(format!(
                "glossy samples {} is not in 0 ..= 256",
                c.glossy_samples
            ));
        }
        if !(1..=8192).contains(&c.face_size) {
            return Err(format!("cube size {} is not in 1 ..= 8192", c.face_size));
        }
        if !(1..=8).contains(&c.generations) {
            return Err(format!(
                "cube generations {} is not in 1 ..= 8",
                c.generations
            ));
        }
        if !SAMPLE_COUNTS.contains(&self.samples) {
            return Err(format!(
                "samples {} is not a sample count: give 1 (no anti-aliasing), 2, 4 or 8",
                self.samples
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recursion_applies_to_geometry_reflections_only() {
        let mut o = ViewOptions::default();
        o.recursion.depth = 3;
        assert_eq!(o.recursion_depth(), 1);
        assert!(!o.recursive());
        o.reflections = ReflectionMode::Geometry;
        assert_eq!(o.recursion_depth(), 3);
        assert!(o.recursive());
        o.recursion.depth = 1;
        assert!(!o.recursive());
    }

    #[test]
    fn modes_print_as_they_parse() {
        for m in [
            ReflectionMode::Off,
            ReflectionMode::Geometry,
            ReflectionMode::Image,
        ] {
            assert_eq!(m.to_string().parse::<ReflectionMode>().unwrap(), m);
            assert_eq!(json(&m), format!("\"{m}\""));
        }
        for m in [CurvedMode::Off, CurvedMode::Cubemap, CurvedMode::Impostor] {
            assert_eq!(m.to_string().parse::<CurvedMode>().unwrap(), m);
            assert_eq!(json(&m), format!("\"{m}\""));
        }
        for s in [Selection::Angle, Selection::Distance] {
            assert_eq!(s.to_string().parse::<Selection>().unwrap(), s);
        }
        for k in [ImpostorKind::Srdm, ImpostorKind::Billboard] {
            assert_eq!(k.to_string().parse::<ImpostorKind>().unwrap(), k);
            assert_eq!(k.other().other(), k);
        }
        for l in [ReflectanceLayout::OneD, ReflectanceLayout::Sphere] {
            assert_eq!(l.to_string().parse::<ReflectanceLayout>().unwrap(), l);
            assert_eq!(json(&l), format!("\"{l}\""));
        }
    }

    fn json<T: Serialize>(v: &T) -> String {
        serde_json::to_string(v).unwrap()
    }
}

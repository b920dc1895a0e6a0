//! One frame recipe: [`FramePasses`] builds every pass of a viewer frame from one
//! [`ViewOptions`], rebuilds only the passes a change of options (or of size) touches, and
//! records them in one fixed order. The window (into its surface), the offscreen target
//! (headless replay, screenshots, the sweep's viewer) and every test draw through it, so the
//! same options give the same image everywhere.
//!
//! The order ([`FramePasses::record`]):
//! 1. the scene pass: kd·D (clears colour and depth), then the reflection probes' specular
//!    term of glossy surfaces that no reflector declares ([`super::probes`]);
//! 2. the single planar reflection pass of geometry depth 1 or the image mode (ks·(M*K)·R,
//!    Bastos §8);
//! 3. impostor reflections in planar reflectors (Popescu §3–4);
//! 4. impostor reflections in curved reflectors (`--curved impostor`);
//! 5. curved reflectors by cube maps (Nielsen §3.2, Luksch §6–7);
//! 6. the recursive planar reflections (geometry depth ≠ 1, Nielsen §3.1), which draw the
//!    curved reflectors seen in their maps with the cube maps of step 5;
//! 7. thin glass ([`super::passes::glass`]), over everything opaque: what lies behind it is
//!    multiplied by its transmittance, then its own D is added;
//! 8. the display pass ([`super::passes::display`]): steps 1–7 add linear radiance into the
//!    radiance target (the HDR output, never exposed); this maps it to the 8-bit target with the
//!    options' exposure and tone curve.
//!
//! With anti-aliasing (`--samples` above 1) steps 1–7 draw into the passes' own
//! [`MultisampleTarget`] (radiance and depth), resolved into the radiance target before step 8.
//!
//! Steps 2–6 are each a [`FramePass`], prepared and recorded from one list in this order.

use super::curved::gpu::CurvedReflections;
use super::exposure::auto_ev;
use super::gpu::target::{FrameViews, MultisampleTarget, TargetFormats, frame_samples};
use super::gpu::{Gpu, RenderError};
use super::impostors::{ImpostorReflections, ReflectorSet, impostor_pass};
use super::load::ViewData;
use super::options::{CurvedMode, Exposure, ReflectionMode, Tonemap, ViewOptions};
use super::passes::display::{DisplayMapping, DisplayPass, RADIANCE_FORMAT};
use super::passes::glass::GlassPasses;
use super::passes::renderer::Renderer;
use super::passes::{FrameContext, FramePass};
use super::probes::gpu::ProbeReflections;
use super::reflections::{GeometryReflections, RecursiveReflections, Source};
use crate::camera::Camera;

/// Groups of passes that are built together: a change of options rebuilds the groups whose
/// inputs changed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Rebuild {
    /// The single or recursive planar reflection passes (also on a change of size).
    pub planar: bool,
    /// Impostor reflections in planar reflectors.
    pub impostors: bool,
    /// Curved reflectors: cube maps, or impostors in `--curved impostor`.
    pub curved: bool,
    /// Reflection probes.
    pub probes: bool,
}

impl Rebuild {
    /// Every group.
    pub const ALL: Rebuild = Rebuild {
        planar: true,
        impostors: true,
        curved: true,
        probes: true,
    };

    /// The groups whose inputs differ between `old` and `new`.
    pub fn between(old: &ViewOptions, new: &ViewOptions) -> Rebuild {
        let planar = |o: &ViewOptions| {
            (
                o.reflections,
                o.selection,
                o.maps,
                o.reflectance,
                o.reflection_aa,
                o.recursion_depth(),
                o.recursive().then_some(o.recursion.cutoff.to_bits()),
                // Geometry mode's terminal cube maps read the curved settings.
                (o.reflections == ReflectionMode::Geometry && o.recursion.terminal)
                    .then_some(o.curved_settings),
            )
        };
        let impostors = |o: &ViewOptions| (o.impostors, o.impostors.then_some(o.impostor_kind));
        let curved = |o: &ViewOptions| {
            (
                o.curved,
                (o.curved == CurvedMode::Cubemap).then_some(o.curved_settings),
                (o.curved == CurvedMode::Impostor).then_some(o.impostor_kind),
            )
        };
        let probes = |o: &ViewOptions| (o.probes, o.probes.then_some(o.reflectance));
        Rebuild {
            planar: planar(old) != planar(new),
            impostors: impostors(old) != impostors(new),
            curved: curved(old) != curved(new),
            probes: probes(old) != probes(new),
        }
    }
}

/// Every pass of a frame, built from [`ViewOptions`] for a target size.
pub struct FramePasses {
    renderer: Renderer,
    display: DisplayPass,
    /// The EV `--exposure auto` stands for: from the bundle's D, once.
    auto_ev: f32,
    options: ViewOptions,
    size: (u32, u32),
    /// What the geometry passes draw into when the frame is multisampled.
    multisample: Option<MultisampleTarget>,
    planar: Option<GeometryReflections>,
    recursive: Option<RecursiveReflections>,
    impostors: Option<ImpostorReflections>,
    curved_impostors: Option<ImpostorReflections>,
    curved: Option<CurvedReflections>,
    probes: Option<ProbeReflections>,
    /// Transmissive triangles, drawn last.
    glass: Option<GlassPasses>,
}

impl FramePasses {
    /// The scene pass of `data` at `size`, every pass `options` asks for (building curved
    /// reflectors renders their cube maps) and the display pass writing `display_format`.
    pub fn new(
        gpu: &Gpu,
        data: &ViewData,
        display_format: wgpu::TextureFormat,
        size: (u32, u32),
        options: &ViewOptions,
    ) -> Result<FramePasses, RenderError> {
        let mut frame = FramePasses::scene_only(gpu, data, display_format, size, options.samples)?;
        frame.options = *options;
        frame.rebuild(gpu, data, Rebuild::ALL)?;
        Ok(frame)
    }

    /// The scene pass alone, with the default options (no reflections) but `samples` samples
    /// a pixel ([`ViewOptions::samples`]), and the display pass writing `display_format`.
    pub fn scene_only(
        gpu: &Gpu,
        data: &ViewData,
        display_format: wgpu::TextureFormat,
        size: (u32, u32),
        samples: u32,
    ) -> Result<FramePasses, RenderError> {
        let (renderer, multisample) = scene_pass(gpu, data, size, samples)?;
        let glass = GlassPasses::new(gpu, &data.scene, &renderer)?;
        let display =
            crate::view::gpu::error_scoped(&gpu.device, "creating the display pass", || {
                DisplayPass::new(&gpu.device, display_format)
            })?;
        Ok(FramePasses {
            renderer,
            display,
            auto_ev: auto_ev(&data.scene.triangles, &data.map),
            options: ViewOptions {
                samples,
                ..ViewOptions::default()
            },
            size,
            multisample,
            planar: None,
            recursive: None,
            impostors: None,
            curved_impostors: None,
            curved: None,
            probes: None,
            glass,
        })
    }

    /// Switches to `options`, rebuilding the passes whose inputs changed. On an error the
    /// failed group is off and the options keep the new values.
    pub fn set_options(
        &mut self,
        gpu: &Gpu,
        data: &ViewData,
        options: &ViewOptions,
    ) -> Result<(), RenderError> {
        self.set_options_rebuilding(gpu, data, options, Rebuild::default())
    }

    /// Switches to `options` and rebuilds the groups in `groups` whether or not they changed.
    /// A new sample count rebuilds every pass: their pipelines are built for it.
    pub fn set_options_rebuilding(
        &mut self,
        gpu: &Gpu,
        data: &ViewData,
        options: &ViewOptions,
        groups: Rebuild,
    ) -> Result<(), RenderError> {
        let changed = Rebuild::between(&self.options, options);
        let resample = options.samples != self.options.samples;
        self.options = *options;
        if resample {
            (self.renderer, self.multisample) = scene_pass(gpu, data, self.size, options.samples)?;
            self.glass = GlassPasses::new(gpu, &data.scene, &self.renderer)?;
            return self.rebuild(gpu, data, Rebuild::ALL);
        }
        self.rebuild(
            gpu,
            data,
            Rebuild {
                planar: changed.planar || groups.planar,
                impostors: changed.impostors || groups.impostors,
                curved: changed.curved || groups.curved,
                probes: changed.probes || groups.probes,
            },
        )
    }

    /// A new target size: the planar passes (their maps are of the frame's size) are rebuilt.
    pub fn resize(
        &mut self,
        gpu: &Gpu,
        data: &ViewData,
        size: (u32, u32),
    ) -> Result<(), RenderError> {
        if size == self.size {
            return Ok(());
        }
        self.size = size;
        if let Some(m) = &self.multisample {
            self.multisample = Some(MultisampleTarget::new(gpu, size.0, size.1, m.samples)?);
        }
        self.rebuild(
            gpu,
            data,
            Rebuild {
                planar: true,
                ..Rebuild::default()
            },
        )
    }

    /// Builds the passes of `groups` for the current options (each group off first, so a
    /// failure leaves it off).
    fn rebuild(&mut self, gpu: &Gpu, data: &ViewData, groups: Rebuild) -> Result<(), RenderError> {
        let o = self.options;
        let (w, h) = self.size;
        if groups.planar {
            self.planar = None;
            self.recursive = None;
            let source = match o.reflections {
                ReflectionMode::Off => None,
                ReflectionMode::Geometry => Some(Source::Geometry),
                ReflectionMode::Image => Some(Source::Image {
                    selection: o.selection,
                    count: o.maps,
                }),
            };
            if o.recursive() {
                let r = RecursiveReflections::new(
                    gpu,
                    &self.renderer,
                    data,
                    w,
                    h,
                    o.reflectance,
                    o.recursion,
                    o.recursion.terminal.then_some(o.curved_settings),
                )?;
                self.recursive = Some(r);
            } else if let Some(source) = source {
                let r = GeometryReflections::with_reflectance(
                    gpu,
                    &self.renderer,
                    data,
                    w,
                    h,
                    source,
                    o.reflectance,
                    o.splat_buffer_bytes,
                    o.recursion.terminal.then_some(o.curved_settings),
                    o.reflection_aa,
                )?;
                self.planar = Some(r);
            }
        }
        if groups.impostors {
            self.impostors = None;
            if o.impostors {
                let pass = impostor_pass(
                    gpu,
                    &self.renderer,
                    data,
                    o.impostor_kind,
                    ReflectorSet::Planar,
                )?;
                self.impostors = Some(pass);
            }
        }
        if groups.curved {
            self.curved = None;
            self.curved_impostors = None;
            match o.curved {
                CurvedMode::Off => {}
                CurvedMode::Cubemap => {
                    let c = CurvedReflections::new(gpu, &self.renderer, data, o.curved_settings)?;
                    self.curved = Some(c);
                }
                CurvedMode::Impostor => {
                    let pass = impostor_pass(
                        gpu,
                        &self.renderer,
                        data,
                        o.impostor_kind,
                        ReflectorSet::Curved,
                    )?;
                    self.curved_impostors = Some(pass);
                }
            }
        }
        if groups.probes {
            self.probes = None;
            if o.probes {
                self.probes = ProbeReflections::new(
                    gpu,
                    &self.renderer,
                    data,
                    o.reflectance,
                    o.curved_settings.specular_aa,
                )?;
            }
        }
        Ok(())
    }

    /// Uses `pass` for impostor reflections in planar reflectors (benchmarks build it with
    /// other tables); the next rebuild of that group replaces it.
    pub fn set_impostor_pass(&mut self, pass: Option<ImpostorReflections>) {
        self.impostors = pass;
    }

    /// The options the passes were built from.
    pub fn options(&self) -> &ViewOptions {
        &self.options
    }

    /// The EV `--exposure auto` stands for (from the bundle's D).
    pub fn auto_ev(&self) -> f32 {
        self.auto_ev
    }

    /// How the display pass maps radiance to the 8-bit target under the current options.
    pub fn display_mapping(&self) -> DisplayMapping {
        DisplayMapping {
            exposure: self.options.exposure,
            auto_ev: self.auto_ev,
            tonemap: self.options.tonemap,
        }
    }

    /// Switches the exposure and tone curve (the display pass's uniforms; nothing is rebuilt).
    pub fn set_display(&mut self, exposure: Exposure, tonemap: Tonemap) {
        self.options.exposure = exposure;
        self.options.tonemap = tonemap;
    }

    /// The target size the passes were built for.
    pub fn size(&self) -> (u32, u32) {
        self.size
    }

    /// Samples per pixel the frame draws with: [`ViewOptions::samples`], or fewer where the
    /// GPU cannot multisample that many ([`frame_samples`]).
    pub fn samples(&self) -> u32 {
        self.renderer.formats().samples
    }

    /// The scene pass.
    pub fn renderer(&self) -> &Renderer {
        &self.renderer
    }

    /// The single planar reflection pass (geometry depth 1 or image mode), if any.
    pub fn planar(&self) -> Option<&GeometryReflections> {
        self.planar.as_ref()
    }

    /// The recursive planar reflection passes (geometry depth ≠ 1), if any.
    pub fn recursive(&self) -> Option<&RecursiveReflections> {
        self.recursive.as_ref()
    }

    /// Impostor reflections in planar reflectors, if on.
    pub fn impostors(&self) -> Option<&ImpostorReflections> {
        self.impostors.as_ref()
    }

    /// Impostor reflections in curved reflectors (`--curved impostor`), if on.
    pub fn curved_impostors(&self) -> Option<&ImpostorReflections> {
        self.curved_impostors.as_ref()
    }

    /// Curved reflectors by cube maps, if on.
    pub fn curved(&self) -> Option<&CurvedReflections> {
        self.curved.as_ref()
    }

    /// Reflection probes, if on and baked.
    pub fn probes(&self) -> Option<&ProbeReflections> {
        self.probes.as_ref()
    }

    /// The passes drawn over the scene that are on, in the module's fixed order (steps 2–6).
    fn over_scene(&self) -> impl Iterator<Item = &dyn FramePass> {
        [
            self.probes.as_ref().map(|p| p as &dyn FramePass),
            self.planar.as_ref().map(|p| p as &dyn FramePass),
            self.impostors.as_ref().map(|p| p as &dyn FramePass),
            self.curved_impostors.as_ref().map(|p| p as &dyn FramePass),
            self.curved.as_ref().map(|p| p as &dyn FramePass),
            self.recursive.as_ref().map(|p| p as &dyn FramePass),
        ]
        .into_iter()
        .flatten()
    }

    /// What the passes over the scene are given for a frame seen by `camera`.
    fn context<'a>(&'a self, camera: &'a Camera) -> FrameContext<'a> {
        FrameContext {
            renderer: &self.renderer,
            camera,
            curved: self.curved.as_ref(),
        }
    }

    /// Writes every pass's uniforms for `camera` (the writes land before the next
    /// submission; each pass writes its own buffers). Call before [`FramePasses::record`].
    pub fn prepare(&self, gpu: &Gpu, camera: &Camera) {
        let (w, h) = self.size;
        self.renderer.prepare(gpu, camera, w, h);
        self.display.prepare(&gpu.queue, &self.display_mapping());
        let frame = self.context(camera);
        for pass in self.over_scene() {
            pass.prepare(gpu, &frame);
        }
    }

    /// Records every pass into `views` in the module's fixed order (a multisampled frame's
    /// geometry into its own target, resolved into `views.radiance`). With `timestamps`, the
    /// scene pass writes index 0 at its beginning and the display pass, the last, index 1 at
    /// its end, so the span holds every pass.
    pub fn record(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        camera: &Camera,
        views: FrameViews<'_>,
        timestamps: Option<&wgpu::QuerySet>,
    ) {
        let stamp = |begin, end| {
            timestamps.map(|query_set| wgpu::RenderPassTimestampWrites {
                query_set,
                beginning_of_pass_write_index: begin,
                end_of_pass_write_index: end,
            })
        };
        let drawn = match &self.multisample {
            Some(m) => m.views(views),
            None => views,
        };
        self.renderer
            .draw(encoder, drawn.radiance, drawn.depth, stamp(Some(0), None));
        let frame = self.context(camera);
        for pass in self.over_scene() {
            pass.draw(encoder, &frame, drawn);
        }
        if let Some(glass) = &self.glass {
            glass.draw(encoder, &self.renderer, drawn.radiance, drawn.depth);
        }
        if let Some(m) = &self.multisample {
            m.resolve(encoder, views.radiance);
        }
        self.display.record(
            device,
            encoder,
            views.radiance,
            views.display,
            stamp(None, Some(1)),
        );
    }
}

/// The scene pass of `data` drawing `samples` samples a pixel (or the most the GPU offers
/// below that, [`frame_samples`]), and the multisampled target it draws into at `size` when
/// that is more than one.
fn scene_pass(
    gpu: &Gpu,
    data: &ViewData,
    (width, height): (u32, u32),
    samples: u32,
) -> Result<(Renderer, Option<MultisampleTarget>), RenderError> {
    let samples = frame_samples(gpu, samples);
    let formats = TargetFormats {
        color: RADIANCE_FORMAT,
        samples,
    };
    let renderer = Renderer::new(gpu, &data.scene, &data.map, formats)?;
    let multisample = if samples > 1 {
        Some(MultisampleTarget::new(gpu, width, height, samples)?)
    } else {
        None
    };
    Ok((renderer, multisample))
}

// Each technique's passes take what they need; the frame hands every pass the same context.

impl FramePass for GeometryReflections {
    fn prepare(&self, gpu: &Gpu, frame: &FrameContext<'_>) {
        GeometryReflections::prepare(self, gpu, frame.renderer, frame.camera, frame.curved);
    }

    fn draw(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        frame: &FrameContext<'_>,
        views: FrameViews<'_>,
    ) {
        GeometryReflections::draw(
            self,
            encoder,
            frame.renderer,
            frame.camera,
            views.radiance,
            views.depth,
            frame.curved,
        );
    }
}

impl FramePass for RecursiveReflections {
    fn prepare(&self, gpu: &Gpu, frame: &FrameContext<'_>) {
        RecursiveReflections::prepare(self, gpu, frame.renderer, frame.camera, frame.curved);
    }

    fn draw(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        frame: &FrameContext<'_>,
        views: FrameViews<'_>,
    ) {
        RecursiveReflections::draw(
            self,
            encoder,
            frame.renderer,
            views.radiance,
            views.depth,
            frame.curved,
        );
    }
}

impl FramePass for ImpostorReflections {
    fn prepare(&self, gpu: &Gpu, frame: &FrameContext<'_>) {
        ImpostorReflections::prepare(self, gpu, frame.camera);
    }

    fn draw(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        _frame: &FrameContext<'_>,
        views: FrameViews<'_>,
    ) {
        ImpostorReflections::draw(self, encoder, views.radiance, views.depth);
    }
}

impl FramePass for ProbeReflections {
    /// Nothing per frame: the probe shader reads the eye from the frame's uniforms.
    fn prepare(&self, _gpu: &Gpu, _frame: &FrameContext<'_>) {}

    fn draw(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        _frame: &FrameContext<'_>,
        views: FrameViews<'_>,
    ) {
        ProbeReflections::draw(self, encoder, views.radiance, views.depth);
    }
}

impl FramePass for CurvedReflections {
    fn prepare(&self, gpu: &Gpu, frame: &FrameContext<'_>) {
        CurvedReflections::prepare(self, gpu, frame.camera);
    }

    fn draw(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        _frame: &FrameContext<'_>,
        views: FrameViews<'_>,
    ) {
        CurvedReflections::draw(self, encoder, views.radiance, views.depth);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::view::options::{ImpostorKind, ReflectionMode, Selection};

    #[test]
    fn a_change_rebuilds_only_the_passes_it_feeds() {
        let base = ViewOptions::default();
        assert_eq!(Rebuild::between(&base, &base), Rebuild::default());
        let mut o = base;
        o.exposure = Exposure::Ev(3.0);
        o.tonemap = Tonemap::None;
        assert_eq!(Rebuild::between(&base, &o), Rebuild::default());

        let mut image = base;
        image.reflections = ReflectionMode::Image;
        let mut more = image;
        more.maps = 4;
        let mut distance = image;
        distance.selection = Selection::Distance;
        let mut aliased = image;
        aliased.reflection_aa = false;
        for (a, b) in [
            (&base, &image),
            (&image, &more),
            (&image, &distance),
            (&image, &aliased),
        ] {
            let r = Rebuild::between(a, b);
            assert!(r.planar && !r.impostors && !r.curved, "{r:?}");
        }

        // The depth only matters in geometry mode.
        let mut deep_image = image;
        deep_image.recursion.depth = 3;
        assert_eq!(Rebuild::between(&image, &deep_image), Rebuild::default());
        let mut geometry = base;
        geometry.reflections = ReflectionMode::Geometry;
        let mut deep = geometry;
        deep.recursion.depth = 2;
        assert!(Rebuild::between(&geometry, &deep).planar);

        // The impostor kind feeds the impostor passes that are on.
        let mut kind = base;
        kind.impostor_kind = ImpostorKind::Billboard;
        assert_eq!(Rebuild::between(&base, &kind), Rebuild::default());
        let mut on = base;
        on.impostors = true;
        let mut on_kind = on;
        on_kind.impostor_kind = ImpostorKind::Billboard;
        let r = Rebuild::between(&on, &on_kind);
        assert!(r.impostors && !r.curved && !r.planar, "{r:?}");
        let mut curved = base;
        curved.curved = CurvedMode::Impostor;
        let mut curved_kind = curved;
        curved_kind.impostor_kind = ImpostorKind::Billboard;
        let r = Rebuild::between(&curved, &curved_kind);
        assert!(r.curved && !r.impostors, "{r:?}");
        let mut cube = base;
        cube.curved = CurvedMode::Cubemap;
        let mut glossy = cube;
        glossy.curved_settings.glossy_samples = 4;
        assert!(Rebuild::between(&cube, &glossy).curved);

        // Probes: on/off, and R's source while on.
        let mut probes = base;
        probes.probes = true;
        let r = Rebuild::between(&base, &probes);
        assert!(r.probes && !r.planar && !r.curved && !r.impostors, "{r:?}");
        let mut sphere = probes;
        sphere.reflectance.layout = crate::view::options::ReflectanceLayout::Sphere;
        assert!(Rebuild::between(&probes, &sphere).probes);
        let mut sphere_off = base;
        sphere_off.reflectance.layout = crate::view::options::ReflectanceLayout::Sphere;
        assert!(!Rebuild::between(&base, &sphere_off).probes);
    }
}

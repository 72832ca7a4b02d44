//! One viewer frame from start to finish, shared by the headless loop, the window and the
//! tests: tessellate → overlay → draw → (read back).
//!
//! # Examples
//!
//! ```no_run
//! use lamina_viewer::app::{HeadlessViewer, Hud, ViewerOptions};
//! use lamina_viewer::source::{FrameSource, SourceEvent, SyntheticSource};
//! use core::time::Duration;
//!
//! # fn main() -> Result<(), Box<dyn core::error::Error>> {
//! let mut viewer = HeadlessViewer::new(ViewerOptions::default())?;
//! let mut source = SyntheticSource::default();
//! let SourceEvent::Model(model) = source.next_event(Duration::ZERO) else { unreachable!() };
//! viewer.set_model(model);
//! let SourceEvent::Frame(frame) = source.next_event(Duration::ZERO) else { unreachable!() };
//! viewer.render(&frame, &Hud::default())?;
//! assert_eq!(viewer.pixels().len(), 320 * 240 * 4);
//! # Ok(())
//! # }
//! ```

use std::time::Instant;

use crate::camera::{Camera, Focus, bounds, default_view};
use crate::controls::{CUT_STEP_FRACTION, ViewState, key_list_lines};
use crate::cut::CutPlane;
use crate::mesh_build::{MeshBuilder, MeshOptions, SpringDisplay};
use crate::overlay::{FlatVertex, Overlay, rgba};
use crate::render::{
    DrawInput, FrameReadError, GpuContext, OFFSCREEN_FORMAT, Offscreen, Renderer, RendererCreateError, wait_idle,
};
use crate::scene_mesh::SceneMesh;
use crate::timing::{FrameTiming, elapsed_ns};
use crate::view_model::{Frame, TissueSet, ViewModel};
use crate::volume::{PROCEDURAL_VOXELS, VolumeImage, bake_procedural};
use crate::volume_file::read_volume;

/// How the viewer draws. `Default`: 320 × 240, 4× MSAA, paper's φ, cut on, springs on the
/// removed side, overlay on, volume texture on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViewerOptions {
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Samples per pixel (1 or 4).
    pub samples: u32,
    /// Tessellation and display choices.
    pub mesh: MeshOptions,
    /// Whether to cut the model open (the cross-section).
    pub cut: bool,
    /// Whether to draw the text overlay and legend.
    pub overlay: bool,
    /// A close view of one spot instead of the default view of the whole model (the cut
    /// plane stays the default one).
    pub focus: Option<Focus>,
    /// Whether to draw the volume texture on the tissue (the model's volume, else a
    /// procedural one baked at the first frame); off: each tissue's flat colour.
    pub texture: bool,
}

impl Default for ViewerOptions {
    fn default() -> Self {
        Self {
            width: 320,
            height: 240,
            samples: 4,
            mesh: MeshOptions::default(),
            cut: true,
            overlay: true,
            focus: None,
            texture: true,
        }
    }
}

/// The text lines of the overlay panel.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Hud {
    /// Lines, top to bottom (upper case reads best in the built-in font).
    pub lines: Vec<String>,
}

/// The CPU side of a frame: model, fixed view, mesh builder and 2-D layer.
#[derive(Debug, Default)]
pub struct Composer {
    model: Option<ViewModel>,
    view: Option<(Camera, Option<CutPlane>)>,
    /// The default cut plane (whether or not it is on) and the model's extent along its
    /// normal, `(min, max)` of `normal · p`, metres.
    plane: Option<(CutPlane, f32, f32)>,
    /// The cut plane of the last composed frame.
    cut: Option<CutPlane>,
    builder: MeshBuilder,
    /// The volume texture (read at [`Composer::set_model`] or baked when first drawn).
    volume: Option<VolumeImage>,
    /// Why the model's volume file could not be used (the procedural volume is drawn).
    volume_error: Option<String>,
    /// How long baking the procedural volume took, ns (0: not baked).
    bake_ns: u64,
    /// Whether the last composed frame draws the volume texture.
    texture: bool,
    /// The last tessellated mesh.
    pub mesh: SceneMesh,
    /// Background triangles of the last frame.
    pub background: Vec<FlatVertex>,
    /// Overlay triangles of the last frame.
    pub overlay: Vec<FlatVertex>,
}

impl Composer {
    /// Uses `model` from now on; the view is fixed again from its next frame.
    /// Reads the model's volume file, if it names one; when that fails the error is kept
    /// ([`Composer::volume_error`]) and the procedural volume is drawn instead.
    pub fn set_model(&mut self, model: ViewModel) {
        (self.volume, self.volume_error, self.bake_ns) = (None, None, 0);
        if let Some(spec) = &model.volume {
            match read_volume(spec) {
                Ok(v) => self.volume = Some(v),
                Err(e) => self.volume_error = Some(e.to_string()),
            }
        }
        self.model = Some(model);
        self.view = None;
        self.plane = None;
    }

    /// Why the model's volume file could not be used, if it could not.
    pub fn volume_error(&self) -> Option<&str> {
        self.volume_error.as_deref()
    }

    /// The volume texture the last composed frame draws (`None`: texture off).
    pub fn drawn_volume(&self) -> Option<&VolumeImage> {
        self.volume.as_ref().filter(|_| self.texture)
    }

    /// How long baking the procedural volume took, ns (0 if it was not baked).
    pub fn volume_bake_ns(&self) -> u64 {
        self.bake_ns
    }

    /// The current model.
    pub fn model(&self) -> Option<&ViewModel> {
        self.model.as_ref()
    }

    /// The fixed camera and cut plane (after the first frame of a model).
    pub fn view(&self) -> Option<(Camera, Option<CutPlane>)> {
        self.view
    }

    /// Tessellates `frame` and builds the 2-D layer for a `width × height` image; returns
    /// the tessellation time, ns.
    pub fn compose(&mut self, frame: &Frame, options: &ViewerOptions, width: u32, height: u32, hud: &Hud) -> u64 {
        self.compose_with(frame, options, width, height, hud, None)
    }

    /// As [`Composer::compose`], with the user's choices (`None`: `options` alone): layers
    /// hidden, cut plane on or off and moved, wireframe, key list.
    pub fn compose_with(
        &mut self,
        frame: &Frame,
        options: &ViewerOptions,
        width: u32,
        height: u32,
        hud: &Hud,
        state: Option<&ViewState>,
    ) -> u64 {
        let start = Instant::now();
        let aspect = width as f32 / height.max(1) as f32;
        if let Some(model) = &mut self.model {
            let nodes = &frame.positions[..model.node_count.min(frame.positions.len())];
            if model.rest_positions.len() < model.node_count && nodes.len() == model.node_count {
                // No rest positions given: the first frame's are the rest.
                model.rest_positions = nodes.to_vec();
            }
            self.texture = options.texture != state.is_some_and(|s| s.texture_toggled);
            if self.texture && self.volume.is_none() && !model.rest_positions.is_empty() {
                let start = Instant::now();
                let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
                self.volume = bake_procedural(model, &model.rest_positions, PROCEDURAL_VOXELS, threads);
                self.bake_ns = elapsed_ns(start);
            }
            if self.view.is_none()
                && let Some((min, max)) = bounds(nodes)
            {
                let (camera, cut) = default_view(min, max, aspect);
                let camera = options.focus.map_or(camera, |f| f.camera());
                self.view = Some((camera, options.cut.then_some(cut)));
                let along = nodes.iter().map(|&p| cut.normal.dot(p));
                let (lo, hi) = along.fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), d| (lo.min(d), hi.max(d)));
                self.plane = Some((cut, lo, hi));
            }
            let mut mesh_options = options.mesh;
            self.cut = match state {
                None => self.view.and_then(|v| v.1),
                Some(state) => self.plane.filter(|_| state.cut).map(|(plane, lo, hi)| {
                    let step = (hi - lo) * CUT_STEP_FRACTION;
                    let offset = (plane.offset + step * state.cut_steps as f32).clamp(lo, hi);
                    CutPlane { normal: plane.normal, offset }
                }),
            };
            mesh_options.cut = self.cut;
            if let Some(state) = state {
                let mut hidden = TissueSet::default();
                for (k, tissue) in model.layers().into_iter().enumerate() {
                    if state.layer_hidden(k) {
                        hidden.toggle(tissue);
                    }
                }
                mesh_options.hidden = hidden;
                mesh_options.wireframe = state.wireframe;
            }
            if mesh_options.cut.is_none() && mesh_options.springs == SpringDisplay::RemovedSide {
                mesh_options.springs = SpringDisplay::Off;
            }
            self.builder.build(model, frame, &mesh_options, &mut self.mesh);
        }
        let tessellate_ns = elapsed_ns(start);
        let mut layer = Overlay::new(width, height);
        layer.background(rgba([0.20, 0.24, 0.29], 1.0), rgba([0.05, 0.06, 0.08], 1.0));
        self.background.clone_from(&layer.vertices);
        layer.vertices.clear();
        if options.overlay {
            layer.panel(&hud.lines);
            layer.legend();
        }
        if state.is_some_and(|s| s.help) {
            layer.centred_panel(&key_list_lines());
        }
        self.overlay.clone_from(&layer.vertices);
        tessellate_ns
    }

    /// The cut plane of the last composed frame (`None`: no cut).
    pub fn cut(&self) -> Option<CutPlane> {
        self.cut
    }

    /// The inputs of [`Renderer::draw`] for the last composed frame (`None` before a view).
    pub fn draw_input(&self) -> Option<(Camera, Option<CutPlane>)> {
        self.view
    }
}

/// A viewer that renders offscreen and reads every frame back.
#[derive(Debug)]
pub struct HeadlessViewer {
    gpu: GpuContext,
    renderer: Renderer,
    target: Offscreen,
    options: ViewerOptions,
    composer: Composer,
    pixels: Vec<u8>,
}

impl HeadlessViewer {
    /// Opens the GPU (software on a machine without one) and builds the pipelines.
    pub fn new(options: ViewerOptions) -> Result<Self, RendererCreateError> {
        let gpu = GpuContext::headless()?;
        let renderer = Renderer::new(&gpu, OFFSCREEN_FORMAT, options.width, options.height, options.samples);
        let target = Offscreen::new(&gpu, options.width, options.height);
        Ok(Self { gpu, renderer, target, options, composer: Composer::default(), pixels: Vec::new() })
    }

    /// The adapter in use, e.g. "llvmpipe (LLVM 15.0.6, 256 bits) (Vulkan, Cpu)".
    pub fn adapter(&self) -> String {
        self.gpu.describe()
    }

    /// Uses `model` from now on.
    pub fn set_model(&mut self, model: ViewModel) {
        self.composer.set_model(model);
    }

    /// The composer (model, view, last mesh).
    pub fn composer(&self) -> &Composer {
        &self.composer
    }

    /// Draws `frame` and reads it back into [`HeadlessViewer::pixels`].
    pub fn render(&mut self, frame: &Frame, hud: &Hud) -> Result<FrameTiming, FrameReadError> {
        let (w, h) = (self.options.width, self.options.height);
        let tessellate_ns = self.composer.compose(frame, &self.options, w, h, hud);
        let start = Instant::now();
        let fallback =
            Camera::framing(glam::Vec3::splat(-1.0), glam::Vec3::splat(1.0), glam::Vec3::Z, w as f32 / h as f32);
        let (camera, cut) = self.composer.draw_input().unwrap_or((fallback, None));
        let input = DrawInput {
            mesh: &self.composer.mesh,
            camera: &camera,
            cut,
            background: &self.composer.background,
            overlay: &self.composer.overlay,
            volume: self.composer.drawn_volume(),
        };
        self.renderer.draw(&self.gpu, self.target.view(), &input);
        wait_idle(&self.gpu);
        let render_ns = elapsed_ns(start);
        let start = Instant::now();
        self.target.read(&self.gpu, &mut self.pixels)?;
        Ok(FrameTiming { tessellate_ns, render_ns, readback_ns: elapsed_ns(start) })
    }

    /// The last frame: RGBA8 sRGB, rows top to bottom.
    pub fn pixels(&self) -> &[u8] {
        &self.pixels
    }

    /// Image width and height, pixels.
    pub fn size(&self) -> (u32, u32) {
        (self.options.width, self.options.height)
    }
}

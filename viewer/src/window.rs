//! The on-screen viewer: a winit window whose surface the [`Renderer`] draws into, fed by any
//! [`FrameSource`], moved and toggled by the mouse and keys of [`crate::controls`]. The
//! surface is reconfigured when it is outdated or lost and never resized to zero (a minimised
//! window keeps its last size).
//!
//! Screenshots (`S`, or `--screenshot-after-frames`) draw the window's current view (model,
//! camera, cut, layers, overlay) once more at the window's size into an offscreen sRGB
//! target with the same renderer code, and write it as PNG.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use lamina_bridge::ToolKind;
use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{Key, NamedKey};
use winit::window::{Window, WindowId};

use crate::app::{Composer, Hud, ViewerOptions};
use crate::camera::OrbitCamera;
use crate::controls::{Button, Controls, Effect, Input, ScriptStep};
use crate::grab::{cursor_ray, on_plane, pick_node};
use crate::png_io::write_png;
use crate::render::{DrawInput, GpuContext, OFFSCREEN_FORMAT, Offscreen, Renderer, wait_idle};
use crate::source::{FrameSource, SourceEvent};
use crate::timing::{Samples, elapsed_ns, ms};
use crate::view_model::Frame;

/// Why the window could not run.
#[derive(Debug, thiserror::Error)]
pub enum WindowRunError {
    /// No event loop (no display).
    #[error("cannot open a window: {}", short_reason(&.0.to_string()))]
    EventLoop(winit::error::EventLoopError),
    /// Window, surface or GPU setup failed.
    #[error("cannot set up the window: {0}")]
    Setup(WindowSetupError),
    /// The model's volume texture could not be read.
    #[error("{0}")]
    Volume(String),
    /// A screenshot could not be written.
    #[error("cannot write the screenshot: {}: {error}", .path.display())]
    Screenshot {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        error: ScreenshotError,
    },
}

/// Why the window, its surface or its GPU could not be set up.
#[derive(Debug, thiserror::Error)]
pub enum WindowSetupError {
    /// The window could not be created.
    #[error("{0}")]
    Window(winit::error::OsError),
    /// The window's drawing surface could not be created.
    #[error("{0}")]
    Surface(wgpu::CreateSurfaceError),
    /// No GPU adapter or device for the surface.
    #[error("{0}")]
    Gpu(crate::render::RendererCreateError),
    /// The surface has no configuration the adapter supports.
    #[error("the surface does not suit the adapter")]
    UnsuitedSurface,
}

/// Why a screenshot could not be written.
#[derive(Debug, thiserror::Error)]
pub enum ScreenshotError {
    /// The window is not open yet.
    #[error("no window yet")]
    NoWindow,
    /// No frame has been drawn yet (no camera).
    #[error("nothing drawn yet")]
    NothingDrawn,
    /// The offscreen target could not be made.
    #[error("no offscreen target")]
    NoTarget,
    /// The pixels could not be read back from the GPU.
    #[error("{0}")]
    Read(crate::render::FrameReadError),
    /// The folder could not be created.
    #[error("{}: {error}", .dir.display())]
    Folder {
        /// The folder.
        dir: PathBuf,
        /// The operating system's error.
        error: std::io::Error,
    },
    /// The PNG could not be written.
    #[error("{0}")]
    Png(crate::png_io::PngIoError),
}

/// Why the grab's tool port could not be opened.
#[derive(Debug, thiserror::Error)]
enum ToolPortError {
    #[error("bridge: {0}")]
    Bridge(lamina_bridge::BridgeOpenError),
    #[error("tool service: {0}")]
    Service(lamina_bridge::PortCreateError),
    #[error("thread: {0}")]
    Thread(std::io::Error),
    #[error("the tool thread stopped")]
    Stopped,
}

/// What the window does besides drawing.
#[derive(Debug, Clone, Default)]
pub struct WindowOptions {
    /// Close after this many frames drawn.
    pub frames: Option<u64>,
    /// Where `S` writes screenshots (`screenshot_NNN.png`). Default: the current directory.
    pub out_dir: Option<PathBuf>,
    /// Write a screenshot to this path once this many frames were drawn, then close.
    pub screenshot_after: Option<(u64, PathBuf)>,
    /// Scripted inputs, applied before drawing frame `step.frame` (see
    /// [`crate::controls::parse_script`]).
    pub script: Vec<ScriptStep>,
    /// The live core's service prefix, for mouse grabs (`None`: no core, no grab).
    pub prefix: Option<String>,
}

/// Depth of the scalpel's tip below the picked skin point in a ctrl + shift + left drag, m:
/// the blade's edge, straight up from the tip, crosses the skin.
const INCISION_DEPTH_M: f32 = 0.004;

/// Length of the scalpel's edge the viewer sends, m.
const INCISION_BLADE_M: f64 = 0.01;

/// A grasp held with ctrl + left drag, or the scalpel drawn with ctrl + shift + left drag.
#[derive(Debug, Clone, Copy)]
struct Grab {
    /// The scalpel (an incision) rather than the grasp.
    scalpel: bool,
    node: u32,
    /// Where the node was when picked, m.
    anchor: glam::Vec3,
    /// Normal of the drag plane (the view direction when picked).
    normal: glam::Vec3,
    /// Where the grasp point is now, m.
    target: glam::Vec3,
}

impl Grab {
    /// The tool this drag holds.
    fn kind(&self) -> ToolKind {
        if self.scalpel { ToolKind::Scalpel } else { ToolKind::Sphere }
    }

    /// Where the tool goes: the grasp point, or the scalpel's tip [`INCISION_DEPTH_M`] below
    /// it, its edge up through the skin.
    fn tool_point(&self) -> glam::Vec3 {
        if self.scalpel { self.target - glam::Vec3::Y * INCISION_DEPTH_M } else { self.target }
    }
}

/// The viewer's publisher on the core's `tool` service, opened on the first grab. A thread
/// owns it and sends the held grasp every [`ToolPort::PERIOD`], so the core (which parks a
/// tool whose commands stop for the scene's `timeout_ms`, 100 ms by default) keeps the grasp
/// however slowly the window draws.
struct ToolPort {
    shared: Arc<std::sync::Mutex<PortState>>,
    thread: Option<std::thread::JoinHandle<(u64, u64)>>,
}

#[derive(Default)]
struct PortState {
    /// The grasp point while button 0 is held, or the scalpel's tip while it cuts.
    held: Option<(glam::Vec3, ToolKind)>,
    /// Where to send the tool, button up, once (a release).
    release: Option<glam::Vec3>,
    stop: bool,
}

impl ToolPort {
    /// How often the held grasp is re-sent (5 ms: 200 Hz).
    const PERIOD: Duration = Duration::from_millis(5);

    fn open(prefix: &str) -> Result<Self, ToolPortError> {
        let shared = Arc::new(std::sync::Mutex::new(PortState::default()));
        let (ready_tx, ready_rx) = std::sync::mpsc::channel();
        let prefix = prefix.to_string();
        let state = shared.clone();
        let thread = std::thread::Builder::new()
            .name("viewer-tool".into())
            .spawn(move || {
                let opened = lamina_bridge::Bridge::open(&lamina_bridge::BridgeConfig::with_prefix(&prefix))
                    .map_err(ToolPortError::Bridge)
                    .and_then(|bridge| {
                        let publisher =
                            lamina_bridge::ToolPublisher::create(&bridge).map_err(ToolPortError::Service)?;
                        Ok((bridge, publisher))
                    });
                let (_bridge, publisher) = match opened {
                    Ok(ports) => {
                        let _ = ready_tx.send(Ok(()));
                        ports
                    }
                    Err(e) => {
                        let _ = ready_tx.send(Err(e));
                        return (0, 0);
                    }
                };
                let (mut sequence, mut sent, mut failures) = (0u64, 0u64, 0u64);
                let mut send = |position: glam::Vec3, held: Option<ToolKind>| {
                    // The scalpel's edge straight up from its tip (identity orientation); a
                    // release puts the sphere back, out of the tissue.
                    let scalpel = held == Some(ToolKind::Scalpel);
                    let command = lamina_bridge::ToolCommand {
                        sequence,
                        time_ns: lamina_bridge::now_ns(),
                        position: position.as_dvec3().to_array(),
                        buttons: u32::from(held == Some(ToolKind::Sphere)),
                        kind: held.unwrap_or(ToolKind::Sphere).code(),
                        blade_length_m: if scalpel { INCISION_BLADE_M } else { 0.0 },
                        ..Default::default()
                    };
                    sequence += 1;
                    match publisher.publish(&command) {
                        Ok(_) => sent += 1,
                        Err(_) => failures += 1,
                    }
                };
                loop {
                    let (held, release, stop) = match state.lock() {
                        Ok(mut s) => (s.held, s.release.take(), s.stop),
                        Err(_) => (None, None, true),
                    };
                    if let Some(p) = release {
                        send(p, None);
                    }
                    if stop {
                        break;
                    }
                    if let Some((p, kind)) = held {
                        send(p, Some(kind));
                    }
                    std::thread::sleep(Self::PERIOD);
                }
                (sent, failures)
            })
            .map_err(ToolPortError::Thread)?;
        match ready_rx.recv() {
            Ok(Ok(())) => Ok(Self { shared, thread: Some(thread) }),
            Ok(Err(e)) => Err(e),
            Err(_) => Err(ToolPortError::Stopped),
        }
    }

    fn update(&self, f: impl FnOnce(&mut PortState)) {
        if let Ok(mut s) = self.shared.lock() {
            f(&mut s);
        }
    }

    /// Holds the grasp (sphere) or the scalpel's tip at `position` (sent now and every period).
    fn hold(&self, position: glam::Vec3, kind: ToolKind) {
        self.update(|s| s.held = Some((position, kind)));
    }

    /// Lets go and sends the tool to `position` (button up).
    fn release(&self, position: glam::Vec3) {
        self.update(|s| (s.held, s.release) = (None, Some(position)));
    }

    /// Stops the thread (a pending release is still sent); returns (sent, failed) commands.
    fn close(&mut self) -> (u64, u64) {
        self.update(|s| s.stop = true);
        self.thread.take().and_then(|t| t.join().ok()).unwrap_or((0, 0))
    }
}

/// winit's OS errors read `os error at FILE.rs:LINE: REASON`; the user needs the reason.
fn short_reason(text: &str) -> &str {
    text.find(".rs:")
        .and_then(|i| text[i + 4..].find(": ").map(|j| &text[i + 4 + j + 2..]))
        .filter(|r| !r.is_empty())
        .unwrap_or(text)
}

/// Connects to the display. Fails without one (no X11 or Wayland server reachable).
pub fn event_loop() -> Result<EventLoop<()>, WindowRunError> {
    EventLoop::new().map_err(WindowRunError::EventLoop)
}

struct Surface {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    gpu: GpuContext,
    renderer: Renderer,
    /// Offscreen renderer and target for screenshots, made on first use (and per size).
    shot: Option<(Renderer, Offscreen)>,
}

struct App<'a> {
    source: &'a mut dyn FrameSource,
    options: ViewerOptions,
    window: WindowOptions,
    drawn: u64,
    composer: Composer,
    controls: Controls,
    surface: Option<Surface>,
    frame: Option<Frame>,
    /// `frame` arrived and has not been drawn yet (then the source is not read, so every
    /// frame received is drawn once, unless paused).
    undrawn: bool,
    frame_times: Samples,
    latency: Samples,
    screenshots: u64,
    error: Option<WindowRunError>,
    quit: bool,
    grab: Option<Grab>,
    tool: Option<ToolPort>,
    grabs: u64,
    /// Shift is held (with ctrl + left drag: the scalpel instead of the grasp).
    shift: bool,
}

impl App<'_> {
    fn setup(&mut self, event_loop: &ActiveEventLoop) -> Result<Surface, WindowSetupError> {
        let attributes = Window::default_attributes()
            .with_title("Lamina viewer (? for keys)")
            .with_inner_size(PhysicalSize::new(self.options.width, self.options.height));
        let window = Arc::new(event_loop.create_window(attributes).map_err(WindowSetupError::Window)?);
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let surface = instance.create_surface(window.clone()).map_err(WindowSetupError::Surface)?;
        let gpu = GpuContext::with_instance(instance, Some(&surface)).map_err(WindowSetupError::Gpu)?;
        let size = window.inner_size();
        let mut config = surface
            .get_default_config(&gpu.adapter, size.width.max(1), size.height.max(1))
            .ok_or(WindowSetupError::UnsuitedSurface)?;
        let caps = surface.get_capabilities(&gpu.adapter);
        if let Some(srgb) = caps.formats.iter().copied().find(wgpu::TextureFormat::is_srgb) {
            config.format = srgb;
        }
        surface.configure(&gpu.device, &config);
        let renderer = Renderer::new(&gpu, config.format, config.width, config.height, self.options.samples);
        Ok(Surface { window, surface, config, gpu, renderer, shot: None })
    }

    fn pump_source(&mut self) {
        if self.undrawn {
            return;
        }
        // Take everything available without blocking the event loop for long.
        let deadline = Instant::now() + Duration::from_millis(8);
        while Instant::now() < deadline {
            match self.source.next_event(Duration::from_millis(2)) {
                SourceEvent::Model(model) => {
                    self.composer.set_model(model);
                    if let Some(e) = self.composer.volume_error() {
                        self.error = Some(WindowRunError::Volume(e.to_string()));
                        self.quit = true;
                    }
                    // A new model gets its own default view.
                    self.controls.state.camera = None;
                }
                SourceEvent::Frame(frame) => {
                    if frame.publish_time_ns > 0 {
                        self.latency.push(lamina_bridge::now_ns().saturating_sub(frame.publish_time_ns));
                    }
                    // Paused: the drawn frame stays; the source is still drained.
                    if !self.controls.state.paused || self.frame.is_none() {
                        self.frame = Some(frame);
                        self.undrawn = true;
                    }
                    break;
                }
                SourceEvent::Idle(_) => break,
            }
        }
    }

    fn viewport(&self) -> (f32, f32) {
        self.surface.as_ref().map_or((self.options.width as f32, self.options.height as f32), |s| {
            (s.config.width as f32, s.config.height as f32)
        })
    }

    /// Applies one input; acts on its effect.
    fn apply(&mut self, input: &Input) {
        let layers = self.composer.model().map_or(0, |m| m.layers().len());
        match self.controls.handle(input, self.viewport(), layers) {
            Some(Effect::Quit) => self.quit = true,
            Some(Effect::Screenshot) => {
                let dir = self.window.out_dir.clone().unwrap_or_else(|| PathBuf::from("."));
                let path = next_screenshot_path(&dir, &mut self.screenshots);
                match self.screenshot(&path) {
                    Ok(()) => tracing::info!("screenshot: {}", path.display()),
                    Err(e) => tracing::error!("screenshot {}: {e}", path.display()),
                }
            }
            Some(Effect::GrabStart(x, y)) => self.grab_start(x, y),
            Some(Effect::GrabMove(x, y)) => {
                let ray = self.ray_at(x, y);
                if let (Some(g), Some(ray)) = (self.grab.as_mut(), ray) {
                    g.target = on_plane(&ray, g.anchor, g.normal).unwrap_or(g.target);
                    if let Some(port) = self.tool.as_ref() {
                        port.hold(g.tool_point(), g.kind());
                    }
                }
            }
            Some(Effect::GrabEnd) => {
                if let Some(g) = self.grab.take() {
                    // Let go and take the tool out of the tissue (to the eye); without further
                    // commands the core parks it after the scene's timeout.
                    let eye = self.controls.state.camera.map_or(g.anchor, |c| c.camera().eye);
                    if let Some(port) = self.tool.as_ref() {
                        port.release(eye);
                    }
                    let what = if g.scalpel { "incision: lifted the scalpel" } else { "grab: released node" };
                    let how = if g.scalpel { "drawing" } else { "pulling" };
                    println!("{what} {} after {how} it {:.1} mm", g.node, 1e3 * (g.target - g.anchor).length());
                }
            }
            None => {}
        }
    }

    /// The ray under pixel `(x, y)` of the current view.
    fn ray_at(&self, x: f32, y: f32) -> Option<crate::grab::Ray> {
        let camera = self.controls.state.camera?.camera();
        let (w, h) = self.viewport();
        Some(cursor_ray(&camera, w, h, x, y))
    }

    /// Picks the skin node under `(x, y)` and grasps it (tool command, button 0 held).
    fn grab_start(&mut self, x: f32, y: f32) {
        let Some(prefix) = self.window.prefix.clone() else {
            println!("grab: needs a live core (this is the synthetic limb)");
            return;
        };
        let (Some(ray), Some(frame), Some(model), Some(camera)) =
            (self.ray_at(x, y), self.frame.as_ref(), self.composer.model(), self.controls.state.camera)
        else {
            return;
        };
        let skin: Vec<u32> = match model.grids.first() {
            Some(grid) => grid.nodes.clone(),
            None => model.triangle_surfaces.iter().flat_map(|s| s.triangles.iter().flatten().copied()).collect(),
        };
        let camera = camera.camera();
        let Some(node) = pick_node(&ray, camera.fov_y, self.viewport().1, &frame.positions, &skin) else {
            println!("grab: no skin node within {} px of ({x:.0}, {y:.0})", crate::grab::PICK_RADIUS_PX);
            return;
        };
        if self.tool.is_none() {
            match ToolPort::open(&prefix) {
                Ok(port) => self.tool = Some(port),
                Err(e) => {
                    tracing::error!("grab: cannot publish tool commands: {e}");
                    return;
                }
            }
        }
        let anchor = frame.positions[node as usize];
        // The grasp moves in the plane facing the eye; the scalpel along the skin, in the
        // level plane through the picked point (the shipped limbs' skin faces +y on top).
        let scalpel = self.shift;
        let normal = if scalpel { glam::Vec3::Y } else { (camera.target - camera.eye).normalize() };
        let grab = Grab { scalpel, node, anchor, normal, target: anchor };
        self.grab = Some(grab);
        self.grabs += 1;
        if let Some(port) = self.tool.as_ref() {
            port.hold(grab.tool_point(), grab.kind());
        }
        let what = if scalpel { "incision: scalpel at" } else { "grab:" };
        println!("{what} skin node {node} at ({:.1}, {:.1}, {:.1}) mm", 1e3 * anchor.x, 1e3 * anchor.y, 1e3 * anchor.z);
    }

    fn hud(&self, frame: &Frame) -> Hud {
        let fps = self.frame_times.summary_of_last(30);
        let lat = self.latency.summary_of_last(100);
        let mut lines =
            vec![format!("LAMINA  {}", self.composer.model().map_or("NO MODEL".into(), |m| m.name.to_uppercase()))];
        lines.push(format!("FRAME {:.1} MS", ms(fps.p50)));
        if !self.latency.is_empty() {
            lines.push(format!("LATENCY P50 {:.2} P99 {:.2} MS", ms(lat.p50), ms(lat.p99)));
        }
        if let Some(st) = frame.stats {
            lines.push(format!("CORE {:.0} HZ  MISSES {}", st.rate_hz, st.misses));
        }
        lines.push(if self.controls.state.paused { "PAUSED  ? KEYS".into() } else { "? KEYS".into() });
        Hud { lines }
    }

    fn redraw(&mut self) {
        let start = Instant::now();
        self.pump_source();
        while self.window.script.first().is_some_and(|s| s.frame <= self.drawn) {
            let step = self.window.script.remove(0);
            for input in &step.inputs {
                self.apply(input);
            }
        }
        let Some(frame) = self.frame.take() else {
            if let Some(s) = self.surface.as_ref() {
                s.window.request_redraw();
            }
            return;
        };
        let hud = self.hud(&frame);
        let Some(s) = self.surface.as_mut() else { return };
        let texture = match s.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(t) | wgpu::CurrentSurfaceTexture::Suboptimal(t) => t,
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                s.surface.configure(&s.gpu.device, &s.config);
                s.window.request_redraw();
                self.frame = Some(frame);
                return;
            }
            _ => {
                s.window.request_redraw();
                self.frame = Some(frame);
                return;
            }
        };
        let (w, h) = (s.config.width, s.config.height);
        self.composer.compose_with(&frame, &self.options, w, h, &hud, Some(&self.controls.state));
        self.frame = Some(frame);
        if self.controls.state.camera.is_none()
            && let Some((camera, _)) = self.composer.view()
        {
            self.controls.state.camera = Some(OrbitCamera::new(camera));
        }
        let mut drew = false;
        if let Some(camera) = self.controls.state.camera.map(|c| c.camera()) {
            let view = texture.texture.create_view(&Default::default());
            let input = DrawInput {
                mesh: &self.composer.mesh,
                camera: &camera,
                cut: self.composer.cut(),
                background: &self.composer.background,
                overlay: &self.composer.overlay,
                volume: self.composer.drawn_volume(),
            };
            s.renderer.draw(&s.gpu, &view, &input);
            drew = true;
        }
        s.window.pre_present_notify();
        s.gpu.queue.present(texture);
        s.window.request_redraw();
        if drew {
            self.undrawn = false;
            self.drawn += 1;
            self.frame_times.push(elapsed_ns(start));
            if let Some((n, path)) = self.window.screenshot_after.clone()
                && self.drawn >= n
            {
                match self.screenshot(&path) {
                    Ok(()) => tracing::info!("screenshot after {} frames: {}", self.drawn, path.display()),
                    Err(error) => self.error = Some(WindowRunError::Screenshot { path, error }),
                }
                self.quit = true;
            }
        }
    }

    /// Draws the current view offscreen at the window's size and writes it to `path`.
    fn screenshot(&mut self, path: &Path) -> Result<(), ScreenshotError> {
        let s = self.surface.as_mut().ok_or(ScreenshotError::NoWindow)?;
        let camera = self.controls.state.camera.ok_or(ScreenshotError::NothingDrawn)?.camera();
        let (w, h) = (s.config.width, s.config.height);
        if s.shot.as_ref().is_none_or(|(r, _)| r.size() != (w, h)) {
            let renderer = Renderer::new(&s.gpu, OFFSCREEN_FORMAT, w, h, self.options.samples);
            s.shot = Some((renderer, Offscreen::new(&s.gpu, w, h)));
        }
        let (renderer, target) = s.shot.as_mut().ok_or(ScreenshotError::NoTarget)?;
        let input = DrawInput {
            mesh: &self.composer.mesh,
            camera: &camera,
            cut: self.composer.cut(),
            background: &self.composer.background,
            overlay: &self.composer.overlay,
            volume: self.composer.drawn_volume(),
        };
        renderer.draw(&s.gpu, target.view(), &input);
        wait_idle(&s.gpu);
        let mut pixels = Vec::new();
        target.read(&s.gpu, &mut pixels).map_err(ScreenshotError::Read)?;
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|error| ScreenshotError::Folder { dir: dir.to_path_buf(), error })?;
        }
        write_png(path, w, h, &pixels).map_err(ScreenshotError::Png)
    }
}

/// `dir/screenshot_NNN.png`, the first such name not yet taken, counting from `*next`.
fn next_screenshot_path(dir: &Path, next: &mut u64) -> PathBuf {
    loop {
        let path = dir.join(format!("screenshot_{:03}.png", *next));
        *next += 1;
        if !path.exists() {
            return path;
        }
    }
}

/// The controls' name of a key (`"1"`, `"c"`, `"?"`, `"space"`, `"escape"`), if it has one.
fn key_name(key: &Key) -> Option<String> {
    match key {
        Key::Named(NamedKey::Escape) => Some("escape".into()),
        Key::Named(NamedKey::Space) => Some("space".into()),
        Key::Character(c) => Some(c.to_lowercase()),
        _ => None,
    }
}

impl ApplicationHandler for App<'_> {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.surface.is_some() {
            return;
        }
        match self.setup(event_loop) {
            Ok(s) => {
                s.window.request_redraw();
                self.surface = Some(s);
            }
            Err(e) => {
                self.error = Some(WindowRunError::Setup(e));
                event_loop.exit();
            }
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        let input = match event {
            WindowEvent::CloseRequested => {
                event_loop.exit();
                None
            }
            WindowEvent::Resized(size) => {
                if let Some(s) = self.surface.as_mut()
                    && size.width > 0
                    && size.height > 0
                {
                    (s.config.width, s.config.height) = (size.width, size.height);
                    s.surface.configure(&s.gpu.device, &s.config);
                    s.renderer.resize(&s.gpu, size.width, size.height);
                }
                None
            }
            WindowEvent::KeyboardInput { event, .. } if event.state == ElementState::Pressed => {
                let toggle = !matches!(event.logical_key.as_ref(), Key::Character("[" | "]"));
                // Held keys repeat only for moving the cut plane.
                if event.repeat && toggle { None } else { key_name(&event.logical_key).map(Input::Key) }
            }
            WindowEvent::ModifiersChanged(m) => {
                self.shift = m.state().shift_key();
                Some(Input::Modifiers { shift: m.state().shift_key(), ctrl: m.state().control_key() })
            }
            WindowEvent::MouseInput { state, button, .. } => {
                let button = match button {
                    MouseButton::Left => Some(Button::Left),
                    MouseButton::Right => Some(Button::Right),
                    MouseButton::Middle => Some(Button::Middle),
                    _ => None,
                };
                button.map(|b| Input::Button(b, state == ElementState::Pressed))
            }
            WindowEvent::CursorMoved { position, .. } => Some(Input::Cursor(position.x as f32, position.y as f32)),
            WindowEvent::MouseWheel { delta, .. } => Some(Input::Wheel(match delta {
                MouseScrollDelta::LineDelta(_, y) => y,
                // Touchpads: about 40 px per notch.
                MouseScrollDelta::PixelDelta(p) => p.y as f32 / 40.0,
            })),
            WindowEvent::RedrawRequested => {
                self.redraw();
                None
            }
            _ => None,
        };
        if let Some(input) = input {
            self.apply(&input);
        }
        let frames_done = self.window.frames.is_some_and(|n| self.drawn >= n);
        if self.quit || frames_done || lamina_rt::caught_stop_signal().is_some() {
            event_loop.exit();
        }
    }
}

/// Opens a window on `event_loop` and draws frames from `source` until it is closed (`Esc`,
/// `Q`, the window's close button), `options.frames` frames were drawn, a requested
/// screenshot was written, or SIGINT/SIGTERM arrives.
pub fn run(
    event_loop: EventLoop<()>,
    source: &mut dyn FrameSource,
    options: ViewerOptions,
    window: WindowOptions,
) -> Result<(), WindowRunError> {
    event_loop.set_control_flow(ControlFlow::Poll);
    let mut app = App {
        source,
        options,
        window,
        drawn: 0,
        composer: Composer::default(),
        controls: Controls::default(),
        surface: None,
        frame: None,
        undrawn: false,
        frame_times: Samples::default(),
        latency: Samples::default(),
        screenshots: 0,
        error: None,
        quit: false,
        grab: None,
        tool: None,
        grabs: 0,
        shift: false,
    };
    event_loop.run_app(&mut app).map_err(WindowRunError::EventLoop)?;
    if let Some(e) = app.error {
        return Err(e);
    }
    let adapter = app.surface.as_ref().map_or_else(String::new, |s| format!(" on {}", s.gpu.describe()));
    println!(
        "window{adapter}: {} frames shown on screen, frame time {}",
        app.drawn,
        app.frame_times.summary().to_ms_string()
    );
    if !app.latency.is_empty() {
        println!("core-to-viewer latency (publish -> received): {}", app.latency.summary().to_ms_string());
    }
    if let Some(port) = app.tool.as_mut() {
        if let Some(g) = app.grab.take() {
            port.release(app.controls.state.camera.map_or(g.anchor, |c| c.camera().eye));
        }
        let (sent, failed) = port.close();
        println!("mouse grab: {} grab(s), {sent} tool commands sent, {failed} failed", app.grabs);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn os_error_reason_is_kept_works() {
        let text =
            "os error at /a/winit-0.30.13/src/platform_impl/linux/mod.rs:788: Failed to open connection to X server";
        assert_eq!(short_reason(text), "Failed to open connection to X server");
        assert_eq!(short_reason("the event loop was already created"), "the event loop was already created");
    }

    #[test]
    fn key_names_follow_the_controls_works() {
        assert_eq!(key_name(&Key::Named(NamedKey::Escape)).as_deref(), Some("escape"));
        assert_eq!(key_name(&Key::Named(NamedKey::Space)).as_deref(), Some("space"));
        assert_eq!(key_name(&Key::Character("W".into())).as_deref(), Some("w"));
        assert_eq!(key_name(&Key::Character("?".into())).as_deref(), Some("?"));
        assert_eq!(key_name(&Key::Named(NamedKey::Tab)), None);
    }
}

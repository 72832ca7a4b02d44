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

use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{Key, NamedKey};
use winit::window::{Window, WindowId};

use crate::app::{Composer, Hud, ViewerOptions};
use crate::camera::OrbitCamera;
use crate::controls::{Button, Controls, Effect, Input, ScriptStep};
use crate::png_io::write_png;
use crate::render::{DrawInput, GpuContext, OFFSCREEN_FORMAT, Offscreen, Renderer, wait_idle};
use crate::source::{FrameSource, SourceEvent};
use crate::timing::{Samples, elapsed_ns, ms};
use crate::view_model::Frame;

/// Why the window could not run.
#[derive(Debug)]
pub enum WindowRunError {
    /// No event loop (no display).
    EventLoop(winit::error::EventLoopError),
    /// Window, surface or GPU setup failed.
    Setup(String),
    /// A screenshot could not be written.
    Screenshot(String),
}

impl core::fmt::Display for WindowRunError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::EventLoop(e) => write!(f, "cannot open a window: {}", short_reason(&e.to_string())),
            Self::Setup(e) => write!(f, "cannot set up the window: {e}"),
            Self::Screenshot(e) => write!(f, "cannot write the screenshot: {e}"),
        }
    }
}

impl core::error::Error for WindowRunError {}

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
}

impl App<'_> {
    fn setup(&mut self, event_loop: &ActiveEventLoop) -> Result<Surface, String> {
        let attributes = Window::default_attributes()
            .with_title("Lamina viewer (? for keys)")
            .with_inner_size(PhysicalSize::new(self.options.width, self.options.height));
        let window = Arc::new(event_loop.create_window(attributes).map_err(|e| e.to_string())?);
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let surface = instance.create_surface(window.clone()).map_err(|e| e.to_string())?;
        let gpu = GpuContext::with_instance(instance, Some(&surface)).map_err(|e| e.to_string())?;
        let size = window.inner_size();
        let mut config = surface
            .get_default_config(&gpu.adapter, size.width.max(1), size.height.max(1))
            .ok_or("the surface does not suit the adapter")?;
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
                    Ok(()) => println!("screenshot: {}", path.display()),
                    Err(e) => eprintln!("lamina-viewer: screenshot {}: {e}", path.display()),
                }
            }
            None => {}
        }
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
                    Ok(()) => println!("screenshot after {} frames: {}", self.drawn, path.display()),
                    Err(e) => self.error = Some(WindowRunError::Screenshot(format!("{}: {e}", path.display()))),
                }
                self.quit = true;
            }
        }
    }

    /// Draws the current view offscreen at the window's size and writes it to `path`.
    fn screenshot(&mut self, path: &Path) -> Result<(), String> {
        let s = self.surface.as_mut().ok_or("no window yet")?;
        let camera = self.controls.state.camera.ok_or("nothing drawn yet")?.camera();
        let (w, h) = (s.config.width, s.config.height);
        if s.shot.as_ref().is_none_or(|(r, _)| r.size() != (w, h)) {
            let renderer = Renderer::new(&s.gpu, OFFSCREEN_FORMAT, w, h, self.options.samples);
            s.shot = Some((renderer, Offscreen::new(&s.gpu, w, h)));
        }
        let (renderer, target) = s.shot.as_mut().ok_or("no offscreen target")?;
        let input = DrawInput {
            mesh: &self.composer.mesh,
            camera: &camera,
            cut: self.composer.cut(),
            background: &self.composer.background,
            overlay: &self.composer.overlay,
        };
        renderer.draw(&s.gpu, target.view(), &input);
        wait_idle(&s.gpu);
        let mut pixels = Vec::new();
        target.read(&s.gpu, &mut pixels).map_err(|e| e.to_string())?;
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        }
        write_png(path, w, h, &pixels).map_err(|e| e.to_string())
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
    };
    event_loop.run_app(&mut app).map_err(WindowRunError::EventLoop)?;
    if let Some(e) = app.error {
        return Err(e);
    }
    let adapter = app.surface.as_ref().map_or_else(String::new, |s| format!(" on {}", s.gpu.describe()));
    println!(
        "window{adapter}: {} frames, frame time {}",
        app.frame_times.len(),
        app.frame_times.summary().to_ms_string()
    );
    if !app.latency.is_empty() {
        println!("core-to-viewer latency (publish -> received): {}", app.latency.summary().to_ms_string());
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

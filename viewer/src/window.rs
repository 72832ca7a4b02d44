//! The on-screen viewer (feature `window`): a winit window whose surface the [`Renderer`]
//! draws into, fed by any [`FrameSource`]. The surface is reconfigured when it is outdated or
//! lost and never resized to zero (a minimised window keeps its last size).

use std::sync::Arc;
use std::time::{Duration, Instant};

use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::event::WindowEvent;
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::window::{Window, WindowId};

use crate::app::{Composer, Hud, ViewerOptions};
use crate::render::{DrawInput, GpuContext, Renderer};
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
}

impl core::fmt::Display for WindowRunError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::EventLoop(e) => write!(f, "cannot open a window: {e}"),
            Self::Setup(e) => write!(f, "cannot set up the window: {e}"),
        }
    }
}

impl core::error::Error for WindowRunError {}

struct Surface {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    gpu: GpuContext,
    renderer: Renderer,
}

struct App {
    source: Box<dyn FrameSource>,
    options: ViewerOptions,
    frames_left: Option<u64>,
    composer: Composer,
    surface: Option<Surface>,
    frame: Option<Frame>,
    frame_times: Samples,
    latency: Samples,
    error: Option<String>,
}

impl App {
    fn setup(&mut self, event_loop: &ActiveEventLoop) -> Result<Surface, String> {
        let attributes = Window::default_attributes()
            .with_title("Lamina viewer")
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
        Ok(Surface { window, surface, config, gpu, renderer })
    }

    fn pump_source(&mut self) {
        // Take everything available without blocking the event loop for long.
        let deadline = Instant::now() + Duration::from_millis(8);
        while Instant::now() < deadline {
            match self.source.next_event(Duration::from_millis(2)) {
                SourceEvent::Model(model) => self.composer.set_model(model),
                SourceEvent::Frame(frame) => {
                    if frame.publish_time_ns > 0 {
                        self.latency.push(lamina_bridge::now_ns().saturating_sub(frame.publish_time_ns));
                    }
                    self.frame = Some(frame);
                    break;
                }
                SourceEvent::Idle(_) => break,
            }
        }
    }

    fn redraw(&mut self) {
        let start = Instant::now();
        self.pump_source();
        let Some(s) = self.surface.as_mut() else { return };
        let Some(frame) = self.frame.as_ref() else {
            s.window.request_redraw();
            return;
        };
        let texture = match s.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(t) | wgpu::CurrentSurfaceTexture::Suboptimal(t) => t,
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                s.surface.configure(&s.gpu.device, &s.config);
                s.window.request_redraw();
                return;
            }
            _ => {
                s.window.request_redraw();
                return;
            }
        };
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
        let (w, h) = (s.config.width, s.config.height);
        self.composer.compose(frame, &self.options, w, h, &Hud { lines });
        if let Some((camera, cut)) = self.composer.view() {
            let view = texture.texture.create_view(&Default::default());
            let input = DrawInput {
                mesh: &self.composer.mesh,
                camera: &camera,
                cut,
                background: &self.composer.background,
                overlay: &self.composer.overlay,
            };
            s.renderer.draw(&s.gpu, &view, &input);
        }
        s.window.pre_present_notify();
        s.gpu.queue.present(texture);
        self.frame_times.push(elapsed_ns(start));
        if let Some(n) = self.frames_left.as_mut() {
            *n = n.saturating_sub(1);
        }
        s.window.request_redraw();
    }
}

impl ApplicationHandler for App {
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
                self.error = Some(e);
                event_loop.exit();
            }
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(size) => {
                if let Some(s) = self.surface.as_mut()
                    && size.width > 0
                    && size.height > 0
                {
                    (s.config.width, s.config.height) = (size.width, size.height);
                    s.surface.configure(&s.gpu.device, &s.config);
                    s.renderer.resize(&s.gpu, size.width, size.height);
                }
            }
            WindowEvent::RedrawRequested => {
                self.redraw();
                if self.frames_left == Some(0) || lamina_rt::caught_stop_signal().is_some() {
                    event_loop.exit();
                }
            }
            _ => {}
        }
    }
}

/// Opens a window and draws frames from `source` until it is closed, `frames` frames were
/// drawn, or SIGINT/SIGTERM arrives.
pub fn run(source: Box<dyn FrameSource>, options: ViewerOptions, frames: Option<u64>) -> Result<(), WindowRunError> {
    let event_loop = EventLoop::new().map_err(WindowRunError::EventLoop)?;
    event_loop.set_control_flow(ControlFlow::Poll);
    let mut app = App {
        source,
        options,
        frames_left: frames,
        composer: Composer::default(),
        surface: None,
        frame: None,
        frame_times: Samples::default(),
        latency: Samples::default(),
        error: None,
    };
    event_loop.run_app(&mut app).map_err(WindowRunError::EventLoop)?;
    if let Some(e) = app.error {
        return Err(WindowRunError::Setup(e));
    }
    println!("window: {} frames, frame time {}", app.frame_times.len(), app.frame_times.summary().to_ms_string());
    if !app.latency.is_empty() {
        println!("core-to-viewer latency (publish -> received): {}", app.latency.summary().to_ms_string());
    }
    Ok(())
}

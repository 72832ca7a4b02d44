//! `lamina-viewer`: the renderer process. See the library docs for how a frame is made.
//!
//! ```text
//! lamina-viewer --headless --synthetic --frames 60 --out frames/      # no core needed
//! lamina-viewer --headless --frames 300 --every 10 --out frames/      # live core, prefix lamina
//! lamina-viewer --synthetic                                           # window (headless without a display)
//! ```

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::{Context, bail};
use clap::{Parser, ValueEnum};
use lamina_viewer::app::{HeadlessViewer, Hud, ViewerOptions};
use lamina_viewer::mesh_build::{MeshOptions, SpringDisplay};
use lamina_viewer::png_io::write_png;
use lamina_viewer::source::{FrameSource, LiveSource, SourceEvent, SyntheticSource};
use lamina_viewer::timing::{FrameTimes, Samples, elapsed_ns, ms};
use lamina_viewer::view_model::{Frame, ViewModel};

/// Which springs the wireframe shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum Springs {
    /// None.
    Off,
    /// Those on the side the cut removes.
    Removed,
    /// All.
    All,
}

/// Lamina's viewer: draws the layered tissue published by the core (or a built-in limb).
#[derive(Debug, Parser)]
#[command(name = "lamina-viewer", version)]
struct Args {
    /// iceoryx2 service prefix of the simulation (as given to the core).
    #[arg(long, default_value = lamina_bridge::DEFAULT_PREFIX)]
    prefix: String,
    /// Render offscreen and write PNG frames instead of opening a window (the default when
    /// there is no display or no window can be opened).
    #[arg(long)]
    headless: bool,
    /// Stop after this many frames (default: run until SIGINT/SIGTERM).
    #[arg(long)]
    frames: Option<u64>,
    /// Directory for PNG frames (headless; without it no frames are written), with
    /// `frames.csv` listing each frame's core sequence, time, tool and camera, and for the
    /// window's screenshots (key S; default: the current directory).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Once this many frames were drawn, write the image to --screenshot and exit.
    #[arg(long, requires = "screenshot")]
    screenshot_after_frames: Option<u64>,
    /// PNG file for --screenshot-after-frames.
    #[arg(long, requires = "screenshot_after_frames")]
    screenshot: Option<PathBuf>,
    /// Scripted mouse and key input for the window, through the same code as real input:
    /// steps `FRAME:key:NAME`, `FRAME:wheel:NOTCHES` or `FRAME:drag:BUTTON:DX:DY` separated by
    /// `;` (BUTTON left, right, middle or shift-left), applied once FRAME frames were drawn.
    /// Example: `2:key:1;3:drag:left:120:-40;4:wheel:2`.
    #[arg(long)]
    script: Option<String>,
    /// Image size, WIDTHxHEIGHT pixels.
    #[arg(long, default_value = "1280x720", value_parser = parse_size)]
    size: (u32, u32),
    /// Draw the built-in animated limb instead of subscribing to a core.
    #[arg(long)]
    synthetic: bool,
    /// Play back a recording (`lamina run --record DIR`): DIR/run.pvd, over the model of
    /// --scene (default: the built-in default scene), at its simulated pace.
    #[arg(long, value_name = "PVD", conflicts_with = "synthetic")]
    replay: Option<PathBuf>,
    /// Write every Nth frame to --out.
    #[arg(long, default_value_t = 1)]
    every: u64,
    /// With --replay: the scene the recording was made with (TOML), whose grids and springs
    /// are drawn. Default: the built-in default scene. A live core needs none: its topology
    /// message carries the whole model.
    #[arg(long, requires = "replay")]
    scene: Option<PathBuf>,
    /// Samples per pixel: 1 or 4.
    #[arg(long, default_value_t = 4, value_parser = parse_samples)]
    samples: u32,
    /// Angle threshold φ of the adaptive patching, degrees, from 0.1 to 180 (the paper: 10).
    #[arg(long, default_value_t = 10.0, value_parser = parse_phi_deg)]
    phi_deg: f64,
    /// Spring wireframe.
    #[arg(long, value_enum, default_value_t = Springs::Removed)]
    springs: Springs,
    /// Look closely at one spot: `X,Y,Z,SPAN` (metres, model frame: the point looked at and
    /// the height of the view there), from the direction of --focus-from. Default: the whole
    /// model from above and in front of the cut.
    #[arg(long, value_parser = parse_focus)]
    focus: Option<[f32; 4]>,
    /// Direction from the --focus point toward the eye, `X,Y,Z` (model frame, y up).
    #[arg(long, default_value = "1,0.9,0.3", value_parser = parse_direction, requires = "focus")]
    focus_from: [f32; 3],
    /// Do not cut the model open.
    #[arg(long)]
    no_cut: bool,
    /// No text overlay.
    #[arg(long)]
    no_overlay: bool,
    /// No volume texture: each tissue in its flat colour (key T switches it in the window).
    #[arg(long)]
    no_texture: bool,
    /// Volume texture: a NIfTI-1 file (.nii or .nii.gz) or a NRRD file (.nrrd, or .nhdr with
    /// its data file), placed by its header's origin and spacing, drawn through its full intensity range (a scene's [visual] table can say more).
    /// Default: the scene's [visual] volume, else a procedural one.
    #[arg(long, value_name = "FILE")]
    volume: Option<PathBuf>,
    /// Give up after waiting this long for the core without receiving anything, seconds,
    /// above 0 and at most 1e9 (default: wait forever).
    #[arg(long, value_parser = parse_wait_limit)]
    wait_limit_s: Option<f64>,
    /// Print a timing line for every frame (default: every frame when --frames ≤ 100, else
    /// once per second).
    #[arg(long)]
    verbose: bool,
    /// Diagnostics shown on stderr: error, warn, info, debug or trace.
    #[arg(long, value_name = "LEVEL", default_value = "info")]
    log_level: tracing::Level,
}

fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or("expected WIDTHxHEIGHT, e.g. 1280x720")?;
    let parse = |v: &str| v.trim().parse::<u32>().map_err(|e| format!("{v}: {e}"));
    let (w, h) = (parse(w)?, parse(h)?);
    if w == 0 || h == 0 || w > 8192 || h > 8192 {
        return Err("width and height must be 1..=8192".into());
    }
    Ok((w, h))
}

fn parse_numbers<const N: usize>(s: &str, what: &str) -> Result<[f32; N], String> {
    let v: Vec<f32> =
        s.split(',').map(|p| p.trim().parse::<f32>().map_err(|e| format!("'{p}': {e}"))).collect::<Result<_, _>>()?;
    match <[f32; N]>::try_from(v) {
        Ok(a) if a.iter().all(|c| c.is_finite()) => Ok(a),
        _ => Err(format!("'{s}': expected {what}")),
    }
}

fn parse_focus(s: &str) -> Result<[f32; 4], String> {
    let f = parse_numbers::<4>(s, "four finite numbers X,Y,Z,SPAN (metres)")?;
    if f[3] > 0.0 { Ok(f) } else { Err(format!("'{s}': the span (the fourth number) must be positive, metres")) }
}

fn parse_direction(s: &str) -> Result<[f32; 3], String> {
    let d = parse_numbers::<3>(s, "three finite numbers X,Y,Z")?;
    if d.iter().any(|c| *c != 0.0) { Ok(d) } else { Err(format!("'{s}': the direction must not be zero")) }
}

/// Smallest and largest `--phi-deg`, degrees: below 0.1 a patch would be cut into more than
/// the subdivision cap anyway; above 180 no two normals differ by φ.
const PHI_DEG_RANGE: [f64; 2] = [0.1, 180.0];

fn parse_phi_deg(s: &str) -> Result<f64, String> {
    let phi: f64 = s.trim().parse().map_err(|e| format!("{e}"))?;
    let [lo, hi] = PHI_DEG_RANGE;
    if (lo..=hi).contains(&phi) { Ok(phi) } else { Err(format!("φ must be from {lo} to {hi} degrees")) }
}

fn parse_wait_limit(s: &str) -> Result<f64, String> {
    let seconds: f64 = s.trim().parse().map_err(|e| format!("{e}"))?;
    lamina_rt::seconds_option("--wait-limit-s", seconds, 1e9).map(|_| seconds).map_err(|e| e.to_string())
}

fn parse_samples(s: &str) -> Result<u32, String> {
    match s {
        "1" => Ok(1),
        "4" => Ok(4),
        _ => Err("samples per pixel must be 1 or 4".into()),
    }
}

fn options(args: &Args) -> ViewerOptions {
    ViewerOptions {
        width: args.size.0,
        height: args.size.1,
        samples: args.samples,
        mesh: MeshOptions {
            phi: args.phi_deg.to_radians(),
            springs: match args.springs {
                Springs::Off => SpringDisplay::Off,
                Springs::Removed => SpringDisplay::RemovedSide,
                Springs::All => SpringDisplay::All,
            },
            ..MeshOptions::default()
        },
        cut: !args.no_cut,
        overlay: !args.no_overlay,
        texture: !args.no_texture,
        focus: args.focus.map(|[x, y, z, span_m]| lamina_viewer::camera::Focus {
            target: glam::Vec3::new(x, y, z),
            from: glam::Vec3::from_array(args.focus_from),
            span_m,
        }),
    }
}

/// The model a recording was made with: the scene's.
fn replay_model(args: &Args) -> anyhow::Result<ViewModel> {
    use lamina_core::scene::Scene;
    let scene = match &args.scene {
        Some(path) => Scene::load(path)?,
        None => Scene::builtin_default(),
    };
    let model = scene.build_model()?;
    let mut view = ViewModel::from_core_model(&model);
    view.volume = lamina_viewer::view_model::VolumeSpec::from_scene(&scene);
    Ok(view)
}

fn open_source(args: &Args) -> anyhow::Result<Box<dyn FrameSource>> {
    let source = open_model_source(args)?;
    let Some(path) = &args.volume else { return Ok(source) };
    lamina_viewer::volume_file::read_volume_header(path).map_err(anyhow::Error::msg)?;
    let spec = lamina_viewer::view_model::VolumeSpec { path: path.clone(), ..Default::default() };
    Ok(Box::new(lamina_viewer::volume::WithVolume::new(source, spec)))
}

fn open_model_source(args: &Args) -> anyhow::Result<Box<dyn FrameSource>> {
    if args.synthetic {
        return Ok(Box::new(SyntheticSource::default()));
    }
    if let Some(pvd) = &args.replay {
        let model = replay_model(args)?;
        return Ok(Box::new(lamina_viewer::replay::ReplaySource::open(pvd, model)?));
    }
    Ok(Box::new(LiveSource::open(&args.prefix)?))
}

/// Rolling figures for the overlay and the exit report.
#[derive(Default)]
struct Figures {
    times: FrameTimes,
    latency_receive: Samples,
    latency_drawn: Samples,
    frame_starts: Vec<Instant>,
}

impl Figures {
    fn view_rate(&self) -> f64 {
        let n = self.frame_starts.len();
        if n < 2 {
            return 0.0;
        }
        let k = n.min(30);
        let span = self.frame_starts[n - 1].duration_since(self.frame_starts[n - k]).as_secs_f64();
        if span > 0.0 { (k - 1) as f64 / span } else { 0.0 }
    }

    fn hud(&self, source: &str, frame: &Frame, model: &str) -> Hud {
        let mut lines = vec![format!("LAMINA  {}", model.to_uppercase())];
        let last = self.times.total.summary_of_last(30);
        lines.push(format!("VIEW {:.1} FPS  FRAME {:.1} MS", self.view_rate(), ms(last.p50)));
        if frame.publish_time_ns > 0 {
            let lat = self.latency_receive.summary_of_last(100);
            lines.push(format!("LATENCY P50 {:.2} P99 {:.2} MS", ms(lat.p50), ms(lat.p99)));
        } else {
            lines.push(format!("LATENCY -  ({source})"));
        }
        match frame.stats {
            Some(s) => lines.push(format!("CORE {:.0} HZ  MISSES {}", s.rate_hz, s.misses)),
            None => lines.push("CORE -  MISSES -".into()),
        }
        lines.push(format!("T {:.3} S  SEQ {}", frame.sim_time_s, frame.sequence));
        Hud { lines }
    }
}

fn run_headless(args: &Args, source: &mut dyn FrameSource) -> anyhow::Result<()> {
    if let Some(dir) = &args.out {
        std::fs::create_dir_all(dir).with_context(|| format!("creating the frame folder {}", dir.display()))?;
    }
    if args.script.is_some() {
        bail!("--script drives the window; it needs a display");
    }
    let mut viewer = HeadlessViewer::new(options(args))?;
    println!("lamina-viewer: {} on {}, {}x{}", source.describe(), viewer.adapter(), args.size.0, args.size.1);
    let mut index = match &args.out {
        Some(dir) => Some(FrameIndex::create(&dir.join(FrameIndex::FILE))?),
        None => None,
    };
    let every = args.every.max(1);
    let verbose = args.verbose || args.frames.is_some_and(|n| n <= 100);
    let mut figures = Figures::default();
    let mut model_name = String::from("no model");
    let mut rendered = 0u64;
    let mut idle_since: Option<Instant> = None;
    let mut last_report = Instant::now();
    let run_start = Instant::now();
    while args.frames.is_none_or(|n| rendered < n) && lamina_rt::caught_stop_signal().is_none() {
        match source.next_event(Duration::from_millis(500)) {
            SourceEvent::Model(model) => {
                println!(
                    "model '{}': {} nodes, {} grids, {} springs",
                    model.name,
                    model.node_count,
                    model.grids.len(),
                    model.springs.len()
                );
                model_name.clone_from(&model.name);
                viewer.set_model(model);
                if let Some(e) = viewer.composer().volume_error() {
                    return Err(anyhow::anyhow!("{e}"));
                }
            }
            SourceEvent::Idle(what) => {
                let since = *idle_since.get_or_insert_with(Instant::now);
                if last_report.elapsed() >= Duration::from_secs(2) || since.elapsed() < Duration::from_millis(600) {
                    tracing::info!("{what}");
                    last_report = Instant::now();
                }
                if args.wait_limit_s.is_some_and(|s| since.elapsed().as_secs_f64() > s) {
                    tracing::warn!("gave up waiting after {:.1} s", since.elapsed().as_secs_f64());
                    break;
                }
            }
            SourceEvent::Frame(frame) => {
                idle_since = None;
                let start = Instant::now();
                if frame.publish_time_ns > 0 {
                    figures.latency_receive.push(lamina_bridge::now_ns().saturating_sub(frame.publish_time_ns));
                }
                figures.frame_starts.push(start);
                let hud = figures.hud(
                    if args.synthetic {
                        "NO CORE"
                    } else if args.replay.is_some() {
                        "REPLAY"
                    } else {
                        "LIVE"
                    },
                    &frame,
                    &model_name,
                );
                let timing = viewer.render(&frame, &hud)?;
                if frame.publish_time_ns > 0 {
                    figures.latency_drawn.push(lamina_bridge::now_ns().saturating_sub(frame.publish_time_ns));
                }
                if let Some(dir) = &args.out
                    && rendered.is_multiple_of(every)
                {
                    let (w, h) = viewer.size();
                    let path = dir.join(format!("frame_{rendered:05}.png"));
                    write_png(&path, w, h, viewer.pixels()).with_context(|| format!("writing {}", path.display()))?;
                    if let Some(index) = index.as_mut() {
                        index.row(&path, &frame, viewer.composer().view().map(|v| v.0))?;
                    }
                }
                if let (Some(n), Some(path)) = (args.screenshot_after_frames, &args.screenshot)
                    && rendered + 1 >= n
                {
                    let (w, h) = viewer.size();
                    write_png(path, w, h, viewer.pixels()).with_context(|| format!("writing {}", path.display()))?;
                    tracing::info!("screenshot after {} frames: {}", rendered + 1, path.display());
                    rendered += 1;
                    break;
                }
                figures.times.push(&timing, elapsed_ns(start));
                let stats = viewer.composer().mesh.stats;
                if verbose || last_report.elapsed() >= Duration::from_secs(1) {
                    println!(
                        "frame {rendered:5} seq {:6}: tessellate {:6.2} ms  render {:6.2} ms  readback {:6.2} ms  ({} patches, {} triangles, {} lines)",
                        frame.sequence,
                        ms(timing.tessellate_ns),
                        ms(timing.render_ns),
                        ms(timing.readback_ns),
                        stats.patches,
                        stats.triangles,
                        stats.lines
                    );
                    last_report = Instant::now();
                }
                rendered += 1;
            }
        }
    }
    report(&figures, rendered, run_start.elapsed());
    Ok(())
}

/// `frames.csv` beside the headless PNG frames: one row per frame written, with what it
/// shows (core sequence and time, the tool) and the camera it was drawn with, so a frame can
/// be matched to the run and a model point to its pixel (`Camera::view_proj`).
struct FrameIndex {
    file: std::fs::File,
    path: PathBuf,
}

impl FrameIndex {
    const FILE: &str = "frames.csv";
    const HEADER: &str = "file,sequence,sim_time_s,tool_x_m,tool_y_m,tool_z_m,tool_radius_m,\
                          eye_x_m,eye_y_m,eye_z_m,target_x_m,target_y_m,target_z_m,up_x,up_y,up_z,fov_y_rad";

    fn create(path: &std::path::Path) -> anyhow::Result<Self> {
        use std::io::Write;
        let mut file = std::fs::File::create(path).with_context(|| format!("creating {}", path.display()))?;
        writeln!(file, "{}", Self::HEADER).with_context(|| format!("writing {}", path.display()))?;
        Ok(Self { file, path: path.to_path_buf() })
    }

    /// Empty tool columns: no tool; empty camera columns: no model drawn yet.
    fn row(
        &mut self,
        png: &std::path::Path,
        frame: &Frame,
        camera: Option<lamina_viewer::camera::Camera>,
    ) -> anyhow::Result<()> {
        use std::io::Write;
        let name = png.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        let tool = frame.tool.map_or_else(
            || ",,,".to_string(),
            |t| format!("{},{},{},{}", t.center.x, t.center.y, t.center.z, t.radius),
        );
        let cam = camera.map_or_else(
            || ",,,,,,,,,".to_string(),
            |c| {
                format!(
                    "{},{},{},{},{},{},{},{},{},{}",
                    c.eye.x, c.eye.y, c.eye.z, c.target.x, c.target.y, c.target.z, c.up.x, c.up.y, c.up.z, c.fov_y
                )
            },
        );
        writeln!(self.file, "{name},{},{},{tool},{cam}", frame.sequence, frame.sim_time_s)
            .with_context(|| format!("writing {}", self.path.display()))
    }
}

fn report(f: &Figures, rendered: u64, wall: Duration) {
    println!("== lamina-viewer: {rendered} frames in {:.2} s", wall.as_secs_f64());
    println!("tessellate: {}", f.times.tessellate.summary().to_ms_string());
    println!("render:     {}", f.times.render.summary().to_ms_string());
    println!("readback:   {}", f.times.readback.summary().to_ms_string());
    println!("frame:      {}", f.times.total.summary().to_ms_string());
    if !f.latency_receive.is_empty() {
        println!("core-to-viewer latency (publish -> received): {}", f.latency_receive.summary().to_ms_string());
        println!("core-to-viewer latency (publish -> frame drawn): {}", f.latency_drawn.summary().to_ms_string());
    }
}

/// Set by the SIGINT/SIGTERM handler (lamina-rt's signal module).
static STOP: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

fn main() -> ExitCode {
    let args = Args::parse();
    lamina_rt::init_logging(args.log_level);
    let _ = lamina_rt::install_stop_handler(&STOP);
    match run(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("lamina-viewer: {e:#}");
            ExitCode::FAILURE
        }
    }
}

/// Where headless frames go, for the one line that says the viewer runs headless.
fn frames_destination(args: &Args) -> String {
    match &args.out {
        Some(dir) => format!("PNG frames into {}", dir.display()),
        None => "no frames written (no --out)".into(),
    }
}

/// A window when there is a display and one can be opened, else headless (saying why).
fn run(args: &Args) -> anyhow::Result<()> {
    use lamina_viewer::window::{self, WindowOptions, WindowRunError};
    if args.headless {
        return run_headless(args, open_source(args)?.as_mut());
    }
    let no_display = std::env::var_os("DISPLAY").is_none_or(|d| d.is_empty())
        && std::env::var_os("WAYLAND_DISPLAY").is_none_or(|d| d.is_empty());
    if no_display {
        tracing::warn!("no display (DISPLAY and WAYLAND_DISPLAY unset): headless, {}", frames_destination(args));
        return run_headless(args, open_source(args)?.as_mut());
    }
    let event_loop = match window::event_loop() {
        Ok(event_loop) => event_loop,
        Err(e) => {
            tracing::warn!("{e}: headless, {}", frames_destination(args));
            return run_headless(args, open_source(args)?.as_mut());
        }
    };
    let script = match &args.script {
        Some(text) => {
            lamina_viewer::controls::parse_script(text, (args.size.0 as f32, args.size.1 as f32)).context("--script")?
        }
        None => Vec::new(),
    };
    let window_options = WindowOptions {
        frames: args.frames,
        out_dir: args.out.clone(),
        screenshot_after: args.screenshot_after_frames.zip(args.screenshot.clone()),
        script,
        prefix: (!args.synthetic).then(|| args.prefix.clone()),
    };
    let mut source = open_source(args)?;
    match window::run(event_loop, source.as_mut(), options(args), window_options) {
        Err(WindowRunError::Setup(e)) => {
            tracing::warn!("cannot set up the window ({e}): headless, {}", frames_destination(args));
            run_headless(args, source.as_mut())
        }
        other => Ok(other?),
    }
}

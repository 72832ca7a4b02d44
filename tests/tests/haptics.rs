//! The core and the haptics process as real processes, with a scripted device pressing into
//! (and pulling) the default scene's skin: the force reaching the device against the same
//! press computed offline; the force falling to zero when the core goes quiet; a device that
//! disappears; corrupt tool commands. Timing bounds here are safety requirements (force to
//! zero within 5 ms of the core's last message), measured on the device loop's own trace.
//! The haptics process gets no scene and no mapping flags: it maps the device onto the model
//! as the core's model message says, which the offline comparison checks against the scene.
//! A core running a model file (not the built-in scene) is felt the same way.

use lamina_bridge::wire::ToolCommand;
use lamina_bridge::{Bridge, BridgeConfig, FeedbackSubscriber, ToolPublisher};
use lamina_core::hand_tool::HandTool;
use lamina_core::scene::{Scene, ToolSource};
use lamina_haptics::DeviceMapping;
use lamina_tests::{unique_prefix, wait_with_watchdog, workspace_bin};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::Duration;

/// One scenario at a time: each loads both CPUs of a small machine.
static SERIAL: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// A press in the device frame (z up, 0 = the tool just touching the undeformed skin):
/// 1 cm above, down to `depth` over 1 s, held until 4 s, back up by 5 s.
fn press(depth: f64) -> Vec<(f64, [f64; 3], u32)> {
    vec![
        (0.0, [0.0, 0.0, 0.01], 0),
        (1.0, [0.0, 0.0, -depth], 0),
        (4.0, [0.0, 0.0, -depth], 0),
        (5.0, [0.0, 0.0, 0.01], 0),
    ]
}

/// The trajectory's position at script time `t` (linear between points, held after the end).
fn position_at(traj: &[(f64, [f64; 3], u32)], t: f64) -> [f64; 3] {
    let i = traj.iter().rposition(|p| p.0 <= t).unwrap_or(0);
    if i + 1 >= traj.len() {
        return traj[traj.len() - 1].1;
    }
    let (a, b) = (&traj[i], &traj[i + 1]);
    let s = ((t - a.0) / (b.0 - a.0)).clamp(0.0, 1.0);
    [0, 1, 2].map(|c| a.1[c] + s * (b.1[c] - a.1[c]))
}

fn write_trajectory(dir: &Path, traj: &[(f64, [f64; 3], u32)]) -> PathBuf {
    let mut text = String::from("# device frame: x toward the operator, y right, z up; m\nt_s,x_m,y_m,z_m,buttons\n");
    for (t, p, b) in traj {
        text.push_str(&format!("{t},{},{},{},{b}\n", p[0], p[1], p[2]));
    }
    let path = dir.join("trajectory.csv");
    std::fs::write(&path, text).unwrap();
    path
}

fn scratch(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(unique_prefix(tag));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The default scene's device origin (model frame, m).
fn device_origin() -> [f64; 3] {
    match Scene::builtin_default().tool.expect("default scene has a tool").source {
        ToolSource::Haptics { device_origin, .. } => device_origin,
        ToolSource::Scripted { .. } => panic!("the default scene's tool follows the haptics process"),
    }
}

fn start_core(prefix: &str, seconds: f64) -> Child {
    Command::new(workspace_bin("lamina"))
        .args(["run", "--quiet", "--prefix", prefix, "--seconds", &seconds.to_string()])
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .expect("starting lamina run")
}

/// `lamina-haptics` with no scene and no mapping flags: it takes the device mapping from the
/// core's model message.
fn haptics(prefix: &str, device: &str, dir: &Path, extra: &[&str]) -> Command {
    let mut cmd = Command::new(workspace_bin("lamina-haptics"));
    cmd.args(["--prefix", prefix, "--device", device])
        .args(["--quiet", "--cpu", "0", "--report"])
        .arg(dir.join("haptics.json"))
        .arg("--trace-csv")
        .arg(dir.join("trace.csv"))
        .args(extra)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    cmd
}

/// Runs the scripted `trajectory` through `lamina-haptics` against `core` (started a second
/// before), both to their end; the core's output.
fn press_against(core: Child, prefix: &str, trajectory: &Path, dir: &Path) -> String {
    std::thread::sleep(Duration::from_millis(1000));
    let device = format!("scripted:{}", trajectory.display());
    let h = haptics(prefix, &device, dir, &["--seconds", "5.3"]).spawn().expect("starting lamina-haptics");
    let (status, out, err) = output(h, Duration::from_secs(60), "lamina-haptics");
    assert!(status.success(), "lamina-haptics failed: {out}\n{err}");
    let (status, core_out, _) = output(core, Duration::from_secs(60), "lamina run");
    assert!(status.success(), "lamina run failed: {core_out}");
    core_out
}

/// One row of the haptics trace.
struct Row {
    time_ns: u64,
    gain: f64,
    z: f64,
    force: [f64; 3],
    core_tick: u64,
}

fn read_trace(path: &Path) -> Vec<Row> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    text.lines()
        .skip(1)
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            let n = |i: usize| f[i].parse::<f64>().unwrap();
            Row {
                time_ns: f[0].parse().unwrap(),
                gain: n(7),
                z: n(3),
                force: [n(4), n(5), n(6)],
                core_tick: f[9].parse().unwrap(),
            }
        })
        .collect()
}

fn output(child: Child, limit: Duration, what: &str) -> (std::process::ExitStatus, String, String) {
    let mut child = child;
    let status = wait_with_watchdog(&mut child, limit, what);
    let mut out = String::new();
    let mut err = String::new();
    use std::io::Read;
    if let Some(mut s) = child.stdout.take() {
        let _ = s.read_to_string(&mut out);
    }
    if let Some(mut s) = child.stderr.take() {
        let _ = s.read_to_string(&mut err);
    }
    (status, out, err)
}

/// The same press computed offline with the physics library: the default scene, the tool
/// parked for the core's 1 s head start, then moved along the trajectory frame by frame
/// exactly as the core moves it, until the end of the hold. Returns the contact force on
/// the tool in the device frame, N.
fn offline_press_force(traj: &[(f64, [f64; 3], u32)], hold_end_s: f64) -> [f64; 3] {
    let scene = Scene::builtin_default();
    let model = scene.build_model().unwrap();
    let (mut sim, mut tool) =
        HandTool::simulation::<f32>(&model, scene.solver.clone(), scene.effects.clone(), scene.tool.unwrap()).unwrap();
    let mapping = DeviceMapping::y_up_model(device_origin());
    let dt = 1.0 / scene.rate_hz as f64;
    for _ in 0..scene.rate_hz {
        sim.step();
    }
    let frames = (hold_end_s / dt).round() as usize;
    for k in 0..frames {
        let centre = mapping.to_model(position_at(traj, k as f64 * dt));
        tool.move_to(&mut sim, centre, None);
        sim.step();
    }
    let fb = tool.feedback(&sim);
    assert!(fb.in_contact, "the offline press touches the skin");
    mapping.force_to_device(fb.force)
}

fn mean_force(rows: &[&Row]) -> [f64; 3] {
    let n = rows.len() as f64;
    [0, 1, 2].map(|c| rows.iter().map(|r| r.force[c]).sum::<f64>() / n)
}

#[test]
fn press_force_at_device_matches_offline_static_contact_works() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let dir = scratch("hap_press");
    let prefix = unique_prefix("press");
    let traj = press(0.008);
    let file = write_trajectory(&dir, &traj);
    let core_out = press_against(start_core(&prefix, 8.0), &prefix, &file, &dir);
    assert!(core_out.contains("0 refused"), "{core_out}");

    let rows = read_trace(&dir.join("trace.csv"));
    let t0 = rows[0].time_ns;
    let at = |a: f64, b: f64| -> Vec<&Row> {
        rows.iter().filter(|r| (a..b).contains(&((r.time_ns - t0) as f64 * 1e-9))).collect()
    };
    // Free space before the press: no force at all.
    assert!(at(0.0, 0.3).iter().all(|r| r.force == [0.0; 3]), "no force in free space");
    // The hold's last half second, the tissue settled. Ticks where the core was late by more
    // than the renderer's quiet limit render a faded force on purpose (safety, tested below):
    // they are left out here. How many there are depends on how the host schedules the core
    // (a shared VM stalled it for ~40 ms once, fading 147 of 1,374 ticks), so it is not
    // asserted; enough unfaded ticks to average over are.
    let all_hold = at(3.5, 3.95);
    let hold: Vec<&Row> = all_hold.iter().copied().filter(|r| r.gain == 1.0).collect();
    assert!(
        hold.len() > 1000,
        "the device loop rendered unfaded through the hold ({} of {} rows)",
        hold.len(),
        all_hold.len()
    );
    let online = mean_force(&hold);
    let offline = offline_press_force(&traj, 3.95);
    // Tolerance: both runs step the same f32 model with the same sub-steps and the tool at
    // the same final position; what differs is the core's timing of the approach (1 kHz
    // ticks against the 4 kHz script, up to a tick apart) and how settled the tissue is after
    // 2.5-3 s of hold (its slowest mode decays ~10x per 0.25 s under the scene's spring
    // damping). 3 % of the force plus 5 mN covers both with margin.
    let err = (0..3).map(|c| (online[c] - offline[c]).powi(2)).sum::<f64>().sqrt();
    let mag = (0..3).map(|c| offline[c].powi(2)).sum::<f64>().sqrt();
    eprintln!("hold force at the device: online {online:?} N, offline static {offline:?} N, difference {err:.4} N");
    assert!(offline[2] > 0.03, "the tissue pushes the tool up (device +z): {offline:?}");
    assert!(err <= 0.03 * mag + 0.005, "online {online:?} N vs offline {offline:?} N");
    // The force is steady during the hold (no oscillation rendered by the device loop).
    let spread = hold.iter().map(|r| (r.force[2] - online[2]).abs()).fold(0.0, f64::max);
    assert!(spread < 0.02 * mag + 0.002, "force varies by {spread} N during the hold");
    assert!(rows.iter().all(|r| r.force.iter().all(|f| f.is_finite())));
    assert!(hold.iter().all(|r| (r.z + 0.008).abs() < 1e-9), "the scripted device held its depth");
}

#[test]
fn core_gone_quiet_force_falls_to_zero_within_5_ms_works() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let dir = scratch("hap_quiet");
    let prefix = unique_prefix("quiet");
    let file = write_trajectory(&dir, &press(0.008));
    let core = start_core(&prefix, 8.0);
    let core_pid = core.id();
    std::thread::sleep(Duration::from_millis(1000));
    let device = format!("scripted:{}", file.display());
    let bridge = Bridge::open(&BridgeConfig::with_prefix(&prefix)).unwrap();
    let feedback = FeedbackSubscriber::create(&bridge).unwrap();
    let h = haptics(&prefix, &device, &dir, &["--seconds", "4.0"]).spawn().expect("starting lamina-haptics");
    // Freeze the core mid-press for half a second, then let it go on. The moment is taken from
    // the core's own feedback (the tool pressing with more than 0.04 N, about 60 % of the
    // hold's 0.07 N on the soft default limb), not from a wall-clock
    // guess: on a loaded machine the processes start late by an unknown amount.
    let waited = std::time::Instant::now();
    let mut pressing = false;
    while !pressing && waited.elapsed() < Duration::from_secs(30) {
        while let Some(s) = feedback.try_receive().unwrap() {
            let f = s.message().force;
            pressing |= f.iter().map(|c| c * c).sum::<f64>().sqrt() > 0.04;
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    assert!(pressing, "the scripted press reached 0.04 N within 30 s");
    let stop_ns = lamina_bridge::now_ns();
    unsafe { libc::kill(core_pid as i32, libc::SIGSTOP) };
    std::thread::sleep(Duration::from_millis(500));
    unsafe { libc::kill(core_pid as i32, libc::SIGCONT) };
    let (status, out, err) = output(h, Duration::from_secs(60), "lamina-haptics");
    assert!(status.success(), "lamina-haptics failed: {out}\n{err}");
    let (status, core_out, _) = output(core, Duration::from_secs(60), "lamina run");
    assert!(status.success(), "the core survived the stop: {core_out}");
    assert!(err.contains("core quiet") || out.contains("episode"), "the quiet core is logged: {err}");

    let rows = read_trace(&dir.join("trace.csv"));
    // The last feedback before the stop: the last change of core tick before the gap.
    let idx_stop = rows.iter().position(|r| r.time_ns >= stop_ns).expect("trace covers the stop");
    let mut last_change = idx_stop;
    while last_change > 0 && rows[last_change - 1].core_tick == rows[idx_stop].core_tick {
        last_change -= 1;
    }
    let last_feedback_ns = rows[last_change].time_ns;
    // Pressing when the core stopped: more than 0.02 N before the renderer's gain. On a loaded
    // machine a late core tick can open a quiet episode earlier in the press, after which the
    // force ramps back in over the 20 ms onset, so the commanded force is the gain times that.
    let at_stop = &rows[last_change];
    assert!(
        at_stop.gain > 0.0 && at_stop.force[2] > 0.02 * at_stop.gain,
        "pressing when the core stopped: {:?} N at gain {}",
        at_stop.force,
        at_stop.gain
    );
    let resumed = rows[idx_stop..].iter().position(|r| r.core_tick != rows[idx_stop].core_tick).map(|i| i + idx_stop);
    let resumed = resumed.expect("the core came back");
    let quiet_rows: Vec<&Row> = rows[last_change..resumed].iter().collect();
    let zero_at = quiet_rows.iter().position(|r| r.force == [0.0; 3]).expect("force reached zero");
    let since_feedback_ms = |r: &Row| (r.time_ns - last_feedback_ns) as f64 / 1e6;
    let delay_ms = since_feedback_ms(quiet_rows[zero_at]);
    // The last non-zero command and the device loop's gap before the first zero one.
    let last_force_ms = since_feedback_ms(quiet_rows[zero_at - 1]);
    let gap_ms = delay_ms - last_force_ms;
    eprintln!(
        "last feedback at the device -> last non-zero force {last_force_ms:.3} ms, zero force {delay_ms:.3} ms \
         (device-loop gap {gap_ms:.3} ms)"
    );
    // The renderer's rule, end to end, on the device loop's own time stamps: no force is
    // commanded 4.5 ms or more after the last feedback (one device period, 0.25 ms, allowed
    // between the render's clock reading and the write's time stamp). A device loop stalled
    // across that moment writes its first command after the stall, and that one is zero too.
    // The workspace's one timed bound, on purpose (ARCHITECTURE.md, Testing): two real
    // processes share no injectable clock; the rule itself runs on injected time in
    // haptics/tests/haptics_renderer.rs.
    assert!(last_force_ms < 4.75, "a force was still commanded {last_force_ms} ms after the last feedback");
    assert!(
        quiet_rows.iter().filter(|r| r.time_ns >= last_feedback_ns + 4_750_000).all(|r| r.force == [0.0; 3]),
        "zero from 4.75 ms after the last feedback and while the core is quiet"
    );
    let max_after = rows[resumed..].iter().take(4000).map(|r| r.force[2]).fold(0.0, f64::max);
    assert!(max_after > 0.03, "force comes back with the core");
}

#[test]
fn non_finite_tool_commands_are_refused_by_the_core_works() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let prefix = unique_prefix("nan");
    let core = start_core(&prefix, 3.0);
    let bridge = Bridge::open(&BridgeConfig::with_prefix(&prefix)).unwrap();
    let tool = ToolPublisher::create(&bridge).unwrap();
    let feedback = FeedbackSubscriber::create(&bridge).unwrap();
    std::thread::sleep(Duration::from_millis(1200));
    let origin = device_origin();
    let good = ToolCommand { position: [origin[0], origin[1] - 0.006, origin[2]], ..ToolCommand::default() };
    let mut sent_bad = 0;
    let mut seen = 0;
    for k in 0..1000u64 {
        let mut c = good;
        c.sequence = k;
        match k % 4 {
            1 => c.position[1] = f64::NAN,
            2 => c.position[0] = f64::INFINITY,
            3 => c.tool_radius_m = f64::NAN,
            _ => {}
        }
        sent_bad += u64::from(k % 4 != 0);
        tool.publish(&c).unwrap();
        std::thread::sleep(Duration::from_micros(1500));
        while let Some(s) = feedback.try_receive().unwrap() {
            let m = *s.message();
            assert!(m.force.iter().chain(m.stiffness.iter().flatten()).all(|v| v.is_finite()), "finite feedback");
            seen += 1;
        }
    }
    let (status, core_out, _) = output(core, Duration::from_secs(30), "lamina run");
    assert!(status.success(), "{core_out}");
    assert!(seen > 500, "feedback flowed ({seen} messages)");
    let line = core_out.lines().find(|l| l.starts_with("haptic link")).expect("haptic link summary");
    let refused: u64 = line.split(" refused").next().unwrap().rsplit(' ').next().unwrap().parse().unwrap();
    // Newest wins: the core refuses every bad command it reads, and it reads most of them.
    assert!(refused > 0 && refused <= sent_bad, "{line}");
    assert!(core_out.contains("state finite: true"), "{core_out}");
}

#[test]
fn device_that_disappears_gives_clear_error_and_core_keeps_running_works() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let dir = scratch("hap_gone");
    let prefix = unique_prefix("gone");
    let file = write_trajectory(&dir, &press(0.008));
    let core = start_core(&prefix, 4.0);
    std::thread::sleep(Duration::from_millis(800));
    let device = format!("scripted:{}", file.display());
    // The device vanishes 1.5 s into its script, in the middle of the press.
    let h = haptics(&prefix, &device, &dir, &["--seconds", "3.0", "--device-args", "disconnect_after_s=1.5"])
        .spawn()
        .expect("starting lamina-haptics");
    let (status, out, err) = output(h, Duration::from_secs(60), "lamina-haptics");
    assert_eq!(status.code(), Some(3), "a lost device is its own exit code: {out}\n{err}");
    assert!(err.contains("device 'scripted' failed") && err.contains("disconnected"), "clear error: {err}");
    assert!(err.contains("the core keeps running"), "{err}");
    let report = lamina_tests::read_json(&dir.join("haptics.json"));
    assert!(report["device_error"].as_str().is_some_and(|e| e.contains("disconnected")), "{report}");
    // The core never noticed beyond parking the tool: it ran its full time with finite state.
    let (status, core_out, _) = output(core, Duration::from_secs(60), "lamina run");
    assert!(status.success(), "{core_out}");
    assert!(core_out.contains("state finite: true"), "{core_out}");
    let link = core_out.lines().find(|l| l.starts_with("haptic link")).expect("haptic link summary");
    assert!(link.contains("parked 1 time(s)"), "the silent tool was parked: {link}");
    let frames: u64 = core_out
        .lines()
        .find_map(|l| l.strip_prefix("published ").and_then(|r| r.split(' ').next()).and_then(|n| n.parse().ok()))
        .expect("published frame count");
    // Every tick publishes one frame, or sheds it when the tick is already past the frame
    // cutoff (a loaded machine); a loaded machine may also skip periods, which the monitor
    // counts, so ticks plus skipped periods cover the whole 4 s run.
    let field = |key: &str| -> u64 {
        core_out
            .split(key)
            .nth(1)
            .and_then(|r| r.split(|c: char| !c.is_ascii_digit()).find(|t| !t.is_empty()))
            .and_then(|n| n.parse().ok())
            .unwrap_or_else(|| panic!("'{key}' in the core's summary: {core_out}"))
    };
    let (ticks, skipped, shed) = (field("\nticks "), field("skipped periods "), field("late and "));
    assert!(
        frames + shed + 2 >= ticks,
        "the core published every tick after the device was lost ({frames} frames, {shed} shed, {ticks} ticks)"
    );
    assert!(ticks + skipped >= 3900, "the core ran its whole 4 s ({ticks} ticks, {skipped} skipped periods)");
}

#[test]
fn grasp_and_pull_lifts_skin_and_device_feels_it_works() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let dir = scratch("hap_pull");
    let prefix = unique_prefix("pull");
    // Touch the skin, close the grasp (button 0), pull up 1.5 cm, hold, let go.
    let traj = vec![
        (0.0, [0.0, 0.0, 0.01], 0),
        (0.8, [0.0, 0.0, -0.003], 0),
        (1.0, [0.0, 0.0, -0.003], 1),
        (2.0, [0.0, 0.0, 0.012], 1),
        (3.0, [0.0, 0.0, 0.012], 1),
        (3.1, [0.0, 0.0, 0.012], 0),
        (3.6, [0.0, 0.0, 0.02], 0),
    ];
    let file = write_trajectory(&dir, &traj);
    let core = start_core(&prefix, 5.5);
    std::thread::sleep(Duration::from_millis(1000));
    let device = format!("scripted:{}", file.display());
    let h = haptics(&prefix, &device, &dir, &["--seconds", "3.8"]).spawn().expect("starting lamina-haptics");
    let (status, out, err) = output(h, Duration::from_secs(60), "lamina-haptics");
    assert!(status.success(), "{out}\n{err}");
    let (status, core_out, _) = output(core, Duration::from_secs(60), "lamina run");
    assert!(status.success(), "{core_out}");
    let link = core_out.lines().find(|l| l.starts_with("haptic link")).expect("haptic link summary");
    assert!(link.contains(" 1 grasp(s)"), "one grasp: {link}");
    let rows = read_trace(&dir.join("trace.csv"));
    let t0 = rows[0].time_ns;
    let at = |a: f64, b: f64| -> Vec<&Row> {
        rows.iter().filter(|r| (a..b).contains(&((r.time_ns - t0) as f64 * 1e-9)) && r.gain == 1.0).collect()
    };
    // Pulled up 1.5 cm, the skin pulls the hand back down (device -z), more the higher it is.
    let mid = mean_force(&at(1.45, 1.55));
    let held = mean_force(&at(2.5, 2.95));
    eprintln!("grasp: force at 1.0 cm pull {mid:?} N, at 1.5 cm {held:?} N");
    assert!(held[2] < -0.05, "the tissue pulls the tool down: {held:?}");
    assert!(held[2] < mid[2], "more pull, more force: {mid:?} then {held:?}");
    // Released: the tool lets go, no force once it is clear of the skin.
    let after = at(3.45, 3.6);
    assert!(after.iter().all(|r| r.force == [0.0; 3]), "released: no force");
}

#[test]
fn core_on_a_model_file_is_felt_without_scene_or_mapping_flags_works() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let dir = scratch("hap_file");
    let prefix = unique_prefix("file");
    // A 30 x 8 limb written by the generator, run from a scene that names the file and keeps
    // the built-in scene's haptic tool (device origin one tool radius above the skin's top).
    let out = Command::new(workspace_bin("lamina"))
        .current_dir(&dir)
        .args(["generate", "--cylinder", "30x8", "--length", "0.24", "--out", "limb30x8.xml"])
        .output()
        .expect("running lamina generate");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = lamina_core::scene::DEFAULT_SCENE_TOML;
    let (start, end) = (text.find("[model]").unwrap(), text.find("[solver]").unwrap());
    let scene = format!("{}[model]\nkind = \"file\"\npath = \"limb30x8.xml\"\n\n{}", &text[..start], &text[end..]);
    std::fs::write(dir.join("scene.toml"), scene).unwrap();
    let file = write_trajectory(&dir, &press(0.006));
    let core = Command::new(workspace_bin("lamina"))
        .args(["run", "--quiet", "--prefix", &prefix, "--seconds", "8", "--scene"])
        .arg(dir.join("scene.toml"))
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .expect("starting lamina run");
    press_against(core, &prefix, &file, &dir);
    let rows = read_trace(&dir.join("trace.csv"));
    // Contact begins where the scene puts the skin: the device at its workspace centre
    // (z = 0) is the tool just touching. The core is up to a tick behind the 4 kHz script,
    // and the skin's point shell is sampled at half the tool radius, so within 1.5 mm.
    let first = rows.iter().find(|r| r.force[2] > 0.0).expect("the press touched the skin");
    eprintln!("file model: first contact at device z {:.4} m", first.z);
    assert!((-0.0015..=0.0005).contains(&first.z), "first contact at device z {} m", first.z);
    // Deeper, more force: half depth against the hold.
    let mean_z_force = |lo: f64, hi: f64| {
        let r: Vec<&Row> = rows.iter().filter(|r| r.gain == 1.0 && (lo..hi).contains(&r.z)).collect();
        assert!(!r.is_empty(), "no unfaded rows with device z in {lo}..{hi}");
        mean_force(&r)[2]
    };
    let (half, full) = (mean_z_force(-0.0032, -0.0028), mean_z_force(-0.00601, -0.00599));
    eprintln!("file model: force {half:.4} N at 3 mm, {full:.4} N at 6 mm");
    assert!(half > 0.0 && full > 1.5 * half, "force rises with depth: {half} N at 3 mm, {full} N at 6 mm");
}

#[test]
fn scalpel_commands_park_the_sphere_and_unknown_kinds_are_refused_works() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let prefix = unique_prefix("scalpel");
    let core = start_core(&prefix, 3.0);
    let bridge = Bridge::open(&BridgeConfig::with_prefix(&prefix)).unwrap();
    let tool = ToolPublisher::create(&bridge).unwrap();
    let feedback = FeedbackSubscriber::create(&bridge).unwrap();
    std::thread::sleep(Duration::from_millis(1200));
    let origin = device_origin();
    // 6 mm below the device origin: a sphere there presses the skin.
    let deep = ToolCommand { position: [origin[0], origin[1] - 0.018, origin[2]], ..ToolCommand::default() };
    let scalpel = ToolCommand { kind: lamina_bridge::ToolKind::Scalpel.code(), blade_length_m: 0.01, ..deep };
    let mut contact = [0u64; 2];
    let (mut sent_scalpel, mut sent_unknown) = (0u64, 0u64);
    for k in 0..900u64 {
        // 300 sphere commands, 300 scalpel commands, then the scalpel with unknown kinds
        // in between (every other command kind 2 or 7).
        let mut c = if k < 300 { deep } else { scalpel };
        if k >= 600 && k % 2 == 1 {
            c.kind = if k % 4 == 1 { 2 } else { 7 };
            sent_unknown += 1;
        } else if k >= 300 {
            sent_scalpel += 1;
        }
        c.sequence = k;
        tool.publish(&c).unwrap();
        std::thread::sleep(Duration::from_micros(1500));
        while let Some(s) = feedback.try_receive().unwrap() {
            // The last 100 commands of each of the first two phases.
            if (200..300).contains(&k) || (500..600).contains(&k) {
                contact[usize::from(k >= 300)] += u64::from(s.message().is_in_contact());
            }
        }
    }
    let (status, core_out, _) = output(core, Duration::from_secs(30), "lamina run");
    assert!(status.success(), "{core_out}");
    assert!(contact[0] > 50, "the sphere presses the skin ({} feedback messages in contact)", contact[0]);
    assert_eq!(contact[1], 0, "the sphere is parked while the scalpel is in use");
    let line = core_out.lines().find(|l| l.starts_with("haptic link")).expect("haptic link summary");
    let count = |what: &str| -> u64 {
        let before = line.split(what).next().unwrap_or_default();
        before.trim_end().rsplit([' ', ',', '(', ';']).next().and_then(|n| n.parse().ok()).unwrap_or(u64::MAX)
    };
    let (scalpels, unknown) = (count(" scalpel commands"), count(" of an unknown tool kind"));
    // Newest wins: the core reads most commands, never more than were sent.
    assert!(scalpels > 0 && scalpels <= sent_scalpel, "{line}");
    assert!(unknown > 0 && unknown <= sent_unknown, "{line}");
    assert!(count(" refused") >= unknown, "unknown kinds are among the refused: {line}");
}

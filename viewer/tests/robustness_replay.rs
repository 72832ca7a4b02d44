//! Replays that a user may hand `lamina-viewer --replay`: frame times far beyond any run
//! are refused at open, naming the collection, the frame and the bound; a frame of NaN
//! positions is warned about once, naming the frame.

use std::path::{Path, PathBuf};
use std::time::Duration;

use lamina_core::io::VtuRecorder;
use lamina_core::scene::Scene;
use lamina_viewer::replay::{MAX_RECORDED_TIME_S, ReplayOpenError, ReplaySource};
use lamina_viewer::source::{FrameSource, SourceEvent};
use lamina_viewer::view_model::ViewModel;

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("lamina_robust_replay_{name}_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// A recording of the default model in `dir`: one frame per entry of `frames`, each at rest
/// (or all NaN where `nan` is set). Returns the view model and the collection's path.
fn record(dir: &Path, frames: &[(f64, bool)]) -> (ViewModel, PathBuf) {
    let model = Scene::builtin_default().build_model().unwrap();
    let mut rec = VtuRecorder::create(&model, dir).unwrap();
    let still = vec![[0.0; 3]; model.nodes.len()];
    let nan = vec![[f64::NAN; 3]; model.nodes.len()];
    for &(t, is_nan) in frames {
        rec.write_frame(t, if is_nan { &nan } else { &model.nodes.position }, &still).unwrap();
    }
    (ViewModel::from_core_model(&model), rec.finish().unwrap())
}

/// The collection rewritten with these timesteps, in order, for its frames.
fn retime(pvd: &Path, times: &[&str]) {
    let text = std::fs::read_to_string(pvd).unwrap();
    let mut out = String::new();
    let mut k = 0;
    for line in text.lines() {
        if let Some(rest) = line.trim_start().strip_prefix("<DataSet timestep=\"") {
            let after = &rest[rest.find('"').unwrap()..];
            out.push_str(&format!("    <DataSet timestep=\"{}{after}\n", times[k]));
            k += 1;
        } else {
            out.push_str(line);
            out.push('\n');
        }
    }
    assert_eq!(k, times.len(), "one timestep per frame");
    std::fs::write(pvd, out).unwrap();
}

#[test]
fn robustness_replay_timestep_beyond_a_run_fail() {
    // ±1e300 s panicked in Duration::from_secs_f64 when the frame came due.
    let dir = scratch("time");
    let (view, pvd) = record(&dir, &[(0.0, false), (0.02, false)]);
    for (times, index, shown) in
        [(["0", "1e300"], 1, "1e300"), (["-1e300", "0"], 0, "-1e300"), (["0", "1.5e9"], 1, "1.5e9")]
    {
        retime(&pvd, &times);
        let err = ReplaySource::open(&pvd, view.clone()).unwrap_err();
        assert!(matches!(err, ReplayOpenError::Time { index: i, .. } if i == index), "{err:?}");
        let text = err.to_string();
        assert!(text.starts_with(&pvd.display().to_string()), "{text}");
        assert!(
            text.contains(&format!("DataSet {index} ("))
                && text.contains(&format!("timestep {shown} s is beyond the ±1e9 s")),
            "{text}"
        );
    }
    // At the bound the recording opens and plays both frames.
    retime(&pvd, &["-1e9", "-999999999.99"]);
    let mut source = ReplaySource::open(&pvd, view).expect("times within ±1e9 s open");
    let mut frames = 0;
    for _ in 0..200 {
        if let SourceEvent::Frame(_) = source.next_event(Duration::from_millis(50)) {
            frames += 1;
        }
        if frames == 2 {
            break;
        }
    }
    assert_eq!(frames, 2);
    assert_eq!(MAX_RECORDED_TIME_S, 1e9);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn robustness_replay_nan_frame_is_warned_about_once_fail() {
    let dir = scratch("nan");
    let (view, pvd) = record(&dir, &[(0.0, false), (0.001, true), (0.002, false), (0.003, true)]);
    let mut source = ReplaySource::open(&pvd, view).unwrap();
    let mut frames = Vec::new();
    for _ in 0..400 {
        if let SourceEvent::Frame(f) = source.next_event(Duration::from_millis(50)) {
            frames.push(f);
        }
        if frames.len() == 4 {
            break;
        }
    }
    assert_eq!(frames.len(), 4, "every frame is handed on, NaN or not");
    assert!(frames[1].positions.iter().all(|p| p.is_nan()));
    assert!(frames[0].positions.iter().all(|p| p.is_finite()));
    assert_eq!(source.non_finite_frames(), &[1, 3], "frames 1 and 3, each once");
    // Idle after the last frame: no further warning.
    assert!(matches!(source.next_event(Duration::from_millis(1)), SourceEvent::Idle(_)));
    assert_eq!(source.non_finite_frames(), &[1, 3]);
    std::fs::remove_dir_all(&dir).unwrap();
}

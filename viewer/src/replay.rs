//! A recorded run (`lamina run --record DIR`, `docs/recording.md`) played back:
//! `lamina-viewer --replay DIR/run.pvd [--scene F]`.
//!
//! The recording holds positions only; the model drawn (grids, springs, layers) is the
//! scene's, which must have as many nodes as the recording. Frames come at their simulated
//! times, one simulated second per wall second, from the first [`FrameSource::next_event`]
//! on; after the last frame the source stays idle, so the picture keeps the last state.

use core::time::Duration;
use std::path::{Path, PathBuf};
use std::time::Instant;

use glam::Vec3;
use lamina_core::io::{RecordReadError, RecordedFrame, read_recorded_points, read_recording};

use crate::source::{FrameSource, SourceEvent};
use crate::view_model::{Frame, ViewModel};

/// Frames of a recording, paced by their simulated times.
#[derive(Debug)]
pub struct ReplaySource {
    model: ViewModel,
    frames: Vec<RecordedFrame>,
    source: String,
    model_sent: bool,
    next: usize,
    /// Wall clock and simulated time of the first frame handed out.
    origin: Option<(Instant, f64)>,
    /// Frames handed out with NaN or infinite positions (each warned about once).
    non_finite_frames: Vec<usize>,
}

/// Largest simulated time a recording may list, in magnitude, s (as `lamina run --seconds`):
/// frames are paced by these times, so one beyond it could never be waited for.
pub const MAX_RECORDED_TIME_S: f64 = 1e9;

/// Why a recording could not be opened for replay.
#[derive(Debug, thiserror::Error)]
pub enum ReplayOpenError {
    /// The collection or its first frame could not be read.
    #[error(transparent)]
    Read(#[from] RecordReadError),
    /// A frame's `timestep` is beyond [`MAX_RECORDED_TIME_S`].
    #[error(
        "{}: DataSet {index} ({}): timestep {} s is beyond the ±1e9 s a recording may list",
        .pvd.display(), .file.display(), lamina_rt::format_value(*.time_s)
    )]
    Time {
        /// The collection.
        pvd: PathBuf,
        /// The frame's position in time order, from 0.
        index: usize,
        /// The frame's file.
        file: PathBuf,
        /// The timestep given, s.
        time_s: f64,
    },
    /// The recording's point count differs from the model's node count.
    #[error(
        "{}: the recording has {recorded} nodes, the scene's model '{model}' {nodes}: give the scene it was recorded from with --scene",
        .pvd.display()
    )]
    NodeCount {
        /// The collection.
        pvd: PathBuf,
        /// Points per recorded frame.
        recorded: usize,
        /// The model's name.
        model: String,
        /// The model's node count.
        nodes: usize,
    },
}

impl ReplaySource {
    /// Opens the collection `pvd` to draw over `model`.
    ///
    /// # Errors
    /// The collection cannot be read or lists no frame, a frame's time is beyond
    /// [`MAX_RECORDED_TIME_S`], the first frame cannot be read, or its point count differs
    /// from the model's node count (the message says which scene to give with `--scene`).
    pub fn open(pvd: &Path, model: ViewModel) -> Result<Self, ReplayOpenError> {
        let frames = read_recording(pvd)?;
        if let Some((index, f)) = frames.iter().enumerate().find(|(_, f)| f.time.abs() > MAX_RECORDED_TIME_S) {
            return Err(ReplayOpenError::Time { pvd: pvd.to_path_buf(), index, file: f.path.clone(), time_s: f.time });
        }
        let first = read_recorded_points(&frames[0].path)?;
        if first.len() != model.node_count {
            return Err(ReplayOpenError::NodeCount {
                pvd: pvd.to_path_buf(),
                recorded: first.len(),
                model: model.name,
                nodes: model.node_count,
            });
        }
        Ok(Self {
            model,
            frames,
            source: pvd.display().to_string(),
            model_sent: false,
            next: 0,
            origin: None,
            non_finite_frames: Vec::new(),
        })
    }

    /// The frames handed out so far whose positions hold NaN or infinite values (drawn as
    /// nothing), by their index in time order; each was warned about once.
    pub fn non_finite_frames(&self) -> &[usize] {
        &self.non_finite_frames
    }
}

impl FrameSource for ReplaySource {
    fn next_event(&mut self, timeout: Duration) -> SourceEvent {
        if !self.model_sent {
            self.model_sent = true;
            return SourceEvent::Model(self.model.clone());
        }
        let Some(recorded) = self.frames.get(self.next) else {
            std::thread::sleep(timeout);
            return SourceEvent::Idle("replay finished (last frame shown)");
        };
        let (start, t0) = *self.origin.get_or_insert((Instant::now(), recorded.time));
        // Within ±1e9 s (checked at open): the difference is at most 2e9 s.
        let due = Duration::try_from_secs_f64((recorded.time - t0).max(0.0)).unwrap_or(Duration::MAX);
        let wait = due.saturating_sub(start.elapsed());
        if wait > timeout {
            std::thread::sleep(timeout);
            return SourceEvent::Idle("replaying (next frame not yet due)");
        }
        std::thread::sleep(wait);
        let sequence = self.next as u64;
        self.next += 1;
        match read_recorded_points(&recorded.path) {
            Ok(points) if points.len() == self.model.node_count => {
                let bad = points.iter().filter(|p| !p.iter().all(|c| c.is_finite())).count();
                if bad > 0 {
                    tracing::warn!(
                        "{}: frame {sequence} (t = {} s): {bad} of {} nodes have NaN or infinite positions, \
                         which cannot be drawn",
                        recorded.path.display(),
                        recorded.time,
                        points.len()
                    );
                    self.non_finite_frames.push(sequence as usize);
                }
                SourceEvent::Frame(Frame {
                    sequence,
                    sim_time_s: recorded.time,
                    publish_time_ns: 0,
                    positions: points.into_iter().map(Vec3::from).collect(),
                    tool: None,
                    stats: None,
                })
            }
            Ok(points) => {
                tracing::warn!("{}: {} points, skipped", recorded.path.display(), points.len());
                SourceEvent::Idle("replaying (a frame was skipped)")
            }
            Err(e) => {
                tracing::warn!("{e}; skipped");
                SourceEvent::Idle("replaying (a frame was skipped)")
            }
        }
    }

    fn describe(&self) -> String {
        let span = self.frames.last().map_or(0.0, |f| f.time) - self.frames[0].time;
        format!("replay of {} frames ({span:.2} s simulated) from {}", self.frames.len(), self.source)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use lamina_core::io::VtuRecorder;
    use lamina_core::scene::Scene;

    /// A recording of the default model, each frame moving every node by its frame number in
    /// millimetres along +x, plays back in order at its times, then stays idle; a recording
    /// of another model is refused, naming both node counts.
    #[test]
    fn replay_plays_recorded_frames_in_order_works() {
        let model = Scene::builtin_default().build_model().unwrap();
        let dir = std::env::temp_dir().join(format!("lamina_viewer_replay_{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let mut rec = VtuRecorder::create(&model, &dir).unwrap();
        let still = vec![[0.0; 3]; model.nodes.len()];
        for k in 0..4 {
            let moved: Vec<[f64; 3]> =
                model.nodes.position.iter().map(|p| [p[0] + 1e-3 * k as f64, p[1], p[2]]).collect();
            rec.write_frame(0.02 * k as f64, &moved, &still).unwrap();
        }
        let pvd = rec.finish().unwrap();
        let view = ViewModel::from_core_model(&model);
        let mut source = ReplaySource::open(&pvd, view.clone()).unwrap();
        assert!(source.describe().starts_with("replay of 4 frames (0.06 s simulated)"), "{}", source.describe());
        assert_eq!(source.next_event(Duration::from_secs(1)), SourceEvent::Model(view));
        let mut seen = 0;
        while seen < 4 {
            match source.next_event(Duration::from_secs(1)) {
                SourceEvent::Frame(f) => {
                    assert_eq!(f.sequence, seen);
                    assert!((f.sim_time_s - 0.02 * seen as f64).abs() < 1e-12);
                    let p = model.nodes.position[7];
                    let expect = Vec3::new((p[0] + 1e-3 * seen as f64) as f32, p[1] as f32, p[2] as f32);
                    assert!((f.positions[7] - expect).length() < 1e-7, "{:?} vs {expect:?}", f.positions[7]);
                    seen += 1;
                }
                SourceEvent::Idle(_) => {}
                SourceEvent::Model(_) => panic!("the model comes once"),
            }
        }
        assert!(matches!(source.next_event(Duration::from_millis(1)), SourceEvent::Idle(_)));
        let block = lamina_core::scene::layered_block(&lamina_core::scene::BlockSpec::default());
        let err = ReplaySource::open(&pvd, ViewModel::from_core_model(&block)).unwrap_err().to_string();
        assert!(err.contains("the recording has 1032 nodes") && err.contains("1728"), "{err}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

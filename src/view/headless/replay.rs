//! Replaying a camera path: which frames, at which times, which of them are written, and the
//! per-frame timings with their summary (`timings.json`). No GPU here: the headless renderer
//! ([`crate::view::headless`]) fills these in.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::camera::{Camera, Keyframe, MAX_FRAMES, frame_count, frame_time, pose_at};
use crate::scene::CameraPath;

/// File name of the timings written next to the frames.
pub const TIMINGS_FILE: &str = "timings.json";

/// Value of `format` in timings.json.
pub const TIMINGS_FORMAT: &str = "glint-view-timings";

/// Version of the timings.json layout.
pub const TIMINGS_VERSION: u32 = 1;

/// One frame of a replay.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScheduledFrame {
    /// Frame number, from 0.
    pub index: usize,
    /// Path time of the frame, seconds.
    pub time: f32,
    /// The camera at that time.
    pub camera: Camera,
}

/// Every frame of `path` at its fps ([`frame_count`], [`frame_time`], [`pose_at`]), or why
/// not: a path of more than [`MAX_FRAMES`] frames is refused before anything is allocated.
pub fn schedule(path: &CameraPath) -> Result<Vec<ScheduledFrame>, String> {
    let count = frame_count(path);
    if count > MAX_FRAMES {
        return Err(format!(
            "camera path `{}` has {count} frames at {} fps; a replay renders at most {MAX_FRAMES}",
            path.name, path.fps
        ));
    }
    Ok((0..count)
        .map(|index| {
            let time = frame_time(path, index);
            ScheduledFrame {
                index,
                time,
                camera: pose_at(path, time),
            }
        })
        .collect())
}

/// Whether frame `index` is written to disk when writing every `every`-th frame (frame 0 is
/// always written; `every` = 0 writes none).
pub fn is_written(index: usize, every: usize) -> bool {
    every != 0 && index.is_multiple_of(every)
}

/// Which frames a replay renders (`rendered` in timings.json; `frames` lists each by number).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Rendered {
    /// Every frame of the path (`--every 1`; `--every 0` times them all and writes none).
    #[default]
    All,
    /// Frames 0, K, 2K, … of the path (`--every K`, K > 1), each written.
    Every(usize),
    /// Frame K of the path alone (`--frame K`).
    Frame(usize),
    /// One frame from a camera given on the command line, not from a path.
    Camera(Keyframe),
}

impl Rendered {
    /// The frames of a replay writing every `every`-th frame: those it writes (all of them
    /// with `every` = 0, which writes none and times every frame).
    pub fn every(every: usize) -> Rendered {
        if every > 1 {
            Rendered::Every(every)
        } else {
            Rendered::All
        }
    }

    /// The frames of `frames` (a path's [`schedule`]) to render, or why there are none
    /// (`--frame` past the path's end).
    pub fn pick(
        &self,
        path: &str,
        frames: Vec<ScheduledFrame>,
    ) -> Result<Vec<ScheduledFrame>, String> {
        match *self {
            Rendered::All | Rendered::Camera(_) => Ok(frames),
            Rendered::Every(k) => Ok(frames
                .into_iter()
                .filter(|f| f.index.is_multiple_of(k))
                .collect()),
            Rendered::Frame(k) => {
                let n = frames.len();
                frames.into_iter().nth(k).map(|f| vec![f]).ok_or_else(|| {
                    format!(
                        "--frame {k}: camera path `{path}` has {n} frame(s), numbered 0 to {}",
                        n - 1
                    )
                })
            }
        }
    }
}

/// File name of frame `index` with extension `ext` (`png`, `exr`): `frame_00042.png`.
pub fn frame_file_name(index: usize, ext: &str) -> String {
    format!("frame_{index:05}.{ext}")
}

/// Where the GPU time of a frame comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum GpuTimeSource {
    /// Timestamp queries written at the start and end of the frame's render pass.
    TimestampQuery,
    /// The adapter has no timestamp queries: wall time from submitting the frame's commands
    /// until the GPU reports them complete (an upper bound of the GPU time).
    SubmitToComplete,
}

/// Timings of one frame, milliseconds.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrameTiming {
    /// Frame number.
    pub frame: usize,
    /// Path time, seconds.
    pub time: f32,
    /// GPU time of the frame's render pass (see [`Timings::gpu_time_source`]).
    pub gpu_ms: f64,
    /// CPU time to update the uniforms, record and submit the frame's commands.
    pub cpu_ms: f64,
    /// Wall time from the start of the frame until the GPU finished it (CPU + queueing + GPU);
    /// readback and file writing are not included.
    pub frame_ms: f64,
    /// Files written for this frame, relative to the output folder.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub files: Vec<String>,
}

/// Median, 95th percentile and maximum of a series.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Stats {
    /// 50th percentile.
    pub median: f64,
    /// 95th percentile.
    pub p95: f64,
    /// Largest value.
    pub max: f64,
}

impl Stats {
    /// Statistics of `values` (non-finite values are ignored; all zero for an empty series).
    /// Percentiles interpolate linearly between the two nearest ranks (numpy's default).
    pub fn of(values: &[f64]) -> Stats {
        let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
        if v.is_empty() {
            return Stats {
                median: 0.0,
                p95: 0.0,
                max: 0.0,
            };
        }
        v.sort_by(f64::total_cmp);
        Stats {
            median: percentile(&v, 0.5),
            p95: percentile(&v, 0.95),
            max: v[v.len() - 1],
        }
    }
}

/// The `q`-quantile (0..=1) of sorted values, linear between closest ranks.
/// `supersample`'s value in a timings.json written before it was recorded.
fn one() -> u32 {
    1
}

fn percentile(sorted: &[f64], q: f64) -> f64 {
    let pos = q.clamp(0.0, 1.0) * (sorted.len() - 1) as f64;
    let lo = pos.floor() as usize;
    let hi = pos.ceil() as usize;
    sorted[lo] + (sorted[hi] - sorted[lo]) * (pos - lo as f64)
}

/// Summary of a replay's frame times.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    /// Of [`FrameTiming::gpu_ms`].
    pub gpu_ms: Stats,
    /// Of [`FrameTiming::cpu_ms`].
    pub cpu_ms: Stats,
    /// Of [`FrameTiming::frame_ms`].
    pub frame_ms: Stats,
}

impl Summary {
    /// The summary of `frames`.
    pub fn of(frames: &[FrameTiming]) -> Summary {
        let col = |f: fn(&FrameTiming) -> f64| Stats::of(&frames.iter().map(f).collect::<Vec<_>>());
        Summary {
            gpu_ms: col(|f| f.gpu_ms),
            cpu_ms: col(|f| f.cpu_ms),
            frame_ms: col(|f| f.frame_ms),
        }
    }
}

/// Root of `timings.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Timings {
    /// Always [`TIMINGS_FORMAT`].
    pub format: String,
    /// [`TIMINGS_VERSION`].
    pub version: u32,
    /// The bundle replayed.
    #[serde(serialize_with = "crate::lossy_path::serialize")]
    pub bundle: PathBuf,
    /// Its scene's name.
    pub scene: String,
    /// The camera path replayed (empty for a camera given on the command line).
    pub path: String,
    /// Frames in that path at its fps (1 for a camera given on the command line).
    #[serde(default)]
    pub path_frames: usize,
    /// Which of them were rendered and timed: each is in `frames`.
    #[serde(default)]
    pub rendered: Rendered,
    /// Frame width and height in pixels.
    pub size: [u32; 2],
    /// Samples a pixel along each axis (`--supersample`): the GPU drew `size` × this, and
    /// the times are that frame's.
    #[serde(default = "one")]
    pub supersample: u32,
    /// The adapter: name, backend, device type, driver.
    pub adapter: String,
    /// How `gpu_ms` was measured.
    pub gpu_time_source: GpuTimeSource,
    /// One untimed frame rendered before the first timed one (pipeline and shader
    /// compilation, first uploads), milliseconds of wall time.
    pub warmup_ms: f64,
    /// Median, p95 and max of each column.
    pub summary: Summary,
    /// Every rendered frame, in order.
    pub frames: Vec<FrameTiming>,
}

impl Timings {
    /// Writes `dir/timings.json` (atomically: temp file + rename).
    pub fn write(&self, dir: &Path) -> Result<PathBuf, crate::bundle::BundleError> {
        let path = dir.join(TIMINGS_FILE);
        let json = serde_json::to_string_pretty(self).expect("timings serialize");
        crate::bundle::write_atomic(&path, json.as_bytes())?;
        Ok(path)
    }

    /// The summary as a small table for the terminal.
    pub fn summary_table(&self) -> String {
        let source = match self.gpu_time_source {
            GpuTimeSource::TimestampQuery => "timestamp queries",
            GpuTimeSource::SubmitToComplete => "submit to complete, no timestamp queries",
        };
        let row = |name: &str, s: &Stats| {
            format!(
                "{name:<10} {:>10.3} {:>10.3} {:>10.3}\n",
                s.median, s.p95, s.max
            )
        };
        let which = match self.rendered {
            Rendered::All => String::new(),
            Rendered::Every(k) => format!(" (one in {k} of {})", self.path_frames),
            Rendered::Frame(k) => format!(" (frame {k} of {})", self.path_frames),
            Rendered::Camera(_) => " (camera from the command line)".into(),
        };
        let samples = match self.supersample {
            0 | 1 => String::new(),
            k => format!(" ({k}x{k} samples a pixel)"),
        };
        let mut out = format!(
            "{} frames of {}/{}{which} at {}x{}{samples} on {}\n{:<10} {:>10} {:>10} {:>10}\n",
            self.frames.len(),
            self.scene,
            self.path,
            self.size[0],
            self.size[1],
            self.adapter,
            "ms",
            "median",
            "p95",
            "max"
        );
        out += &row("gpu", &self.summary.gpu_ms);
        out += &row("cpu", &self.summary.cpu_ms);
        out += &row("frame", &self.summary.frame_ms);
        out += &format!(
            "gpu time: {source}; warm-up frame {:.1} ms (not counted)\n",
            self.warmup_ms
        );
        out
    }
}

pub use crate::cli::parse_size;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Keyframe;

    fn path(fps: f32, end: f32) -> CameraPath {
        let key = |time: f32, x: f32| Keyframe {
            time,
            position: [x, 1.0, 5.0],
            target: [x, 1.0, 0.0],
            up: [0.0, 1.0, 0.0],
            fov_y_deg: 50.0,
        };
        CameraPath {
            name: "p".into(),
            fps,
            keyframes: vec![key(0.0, 0.0), key(end, 1.0)],
        }
    }

    #[test]
    fn schedule_covers_the_path_at_its_fps() {
        let frames = schedule(&path(9.0, 1.0)).unwrap();
        assert_eq!(frames.len(), 10);
        assert_eq!(frames[0].time, 0.0);
        assert!((frames[9].time - 1.0).abs() < 1e-6);
        assert!((frames[9].camera.position.x - 1.0).abs() < 1e-5);
        assert!(
            frames
                .iter()
                .enumerate()
                .all(|(i, f)| f.index == i && f.camera.position.x >= 0.0)
        );
    }

    #[test]
    fn absurd_paths_are_refused_before_allocating() {
        // 1e12 s (999999995904 in f32) at 30 fps: 3e13 frames, 1.9 PB of scheduled frames.
        let e = schedule(&path(30.0, 1e12)).unwrap_err();
        assert!(
            e.contains("`p` has 29999999877121 frames") && e.contains("at most 1000000"),
            "{e}"
        );
        let e = schedule(&path(1e9, 1e12)).unwrap_err();
        assert!(e.contains(&format!("at most {MAX_FRAMES}")), "{e}");
        // The largest allowed path is scheduled in full.
        assert_eq!(
            schedule(&path(1.0, (MAX_FRAMES - 1) as f32)).unwrap().len(),
            MAX_FRAMES
        );
    }

    #[test]
    fn every_k_writes_frame_zero_and_multiples() {
        let written: Vec<usize> = (0..10).filter(|&i| is_written(i, 3)).collect();
        assert_eq!(written, [0, 3, 6, 9]);
        assert!((0..10).all(|i| is_written(i, 1)));
        assert!((0..10).all(|i| !is_written(i, 0)));
        assert_eq!(frame_file_name(42, "png"), "frame_00042.png");
    }

    #[test]
    fn rendered_picks_the_frames_it_names() {
        let frames = || schedule(&path(9.0, 1.0)).unwrap();
        let indices = |r: Rendered| -> Vec<usize> {
            r.pick("p", frames())
                .unwrap()
                .iter()
                .map(|f| f.index)
                .collect()
        };
        assert_eq!(indices(Rendered::every(4)), [0, 4, 8]);
        assert_eq!(indices(Rendered::every(1)), (0..10).collect::<Vec<_>>());
        assert_eq!(indices(Rendered::every(0)), (0..10).collect::<Vec<_>>());
        assert_eq!(indices(Rendered::Frame(9)), [9]);
        let e = Rendered::Frame(10).pick("p", frames()).unwrap_err();
        assert_eq!(
            e,
            "--frame 10: camera path `p` has 10 frame(s), numbered 0 to 9"
        );
        let json = |r: Rendered| serde_json::to_string(&r).unwrap();
        assert_eq!(json(Rendered::All), "\"all\"");
        assert_eq!(json(Rendered::Every(40)), r#"{"every":40}"#);
        assert_eq!(json(Rendered::Frame(3)), r#"{"frame":3}"#);
        let key = path(1.0, 1.0).keyframes[0];
        let camera: Rendered = serde_json::from_str(&json(Rendered::Camera(key))).unwrap();
        assert_eq!(camera, Rendered::Camera(key));
    }

    #[test]
    fn stats_median_p95_max() {
        let v: Vec<f64> = (1..=100).map(f64::from).collect();
        let s = Stats::of(&v);
        assert_eq!(s.median, 50.5);
        assert!((s.p95 - 95.05).abs() < 1e-9);
        assert_eq!(s.max, 100.0);
        // Order does not matter; NaN is ignored; one value is its own everything.
        let s = Stats::of(&[3.0, f64::NAN, 1.0, 2.0]);
        assert_eq!((s.median, s.max), (2.0, 3.0));
        assert_eq!(
            Stats::of(&[7.0]),
            Stats {
                median: 7.0,
                p95: 7.0,
                max: 7.0
            }
        );
        assert_eq!(Stats::of(&[]).max, 0.0);
    }

    #[test]
    fn timings_round_trip_through_json() {
        let frames: Vec<FrameTiming> = (0..3)
            .map(|i| FrameTiming {
                frame: i,
                time: i as f32 / 30.0,
                gpu_ms: 1.0 + i as f64,
                cpu_ms: 0.5,
                frame_ms: 2.0 + i as f64,
                files: if i == 0 {
                    vec![frame_file_name(0, "png")]
                } else {
                    vec![]
                },
            })
            .collect();
        let t = Timings {
            format: TIMINGS_FORMAT.into(),
            version: TIMINGS_VERSION,
            bundle: "out/x.glint".into(),
            scene: "x".into(),
            path: "orbit".into(),
            path_frames: 3,
            rendered: Rendered::All,
            size: [720, 486],
            supersample: 1,
            adapter: "llvmpipe".into(),
            gpu_time_source: GpuTimeSource::SubmitToComplete,
            warmup_ms: 40.0,
            summary: Summary::of(&frames),
            frames,
        };
        let json = serde_json::to_string(&t).unwrap();
        assert!(json.contains("\"gpu_time_source\":\"submit-to-complete\""));
        assert_eq!(serde_json::from_str::<Timings>(&json).unwrap(), t);
        assert_eq!(t.summary.gpu_ms.median, 2.0);
        assert!(t.summary_table().contains("3 frames of x/orbit at 720x486"));
    }
}

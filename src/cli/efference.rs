//! `loomlab detect --efference`: the robot's own motion for a video, from a CSV of its planar poses
//! (the `truth.csv` that `loomlab render` writes, or any CSV with time, x, y and yaw columns).
//!
//! Each video frame gets the efference copy of the camera period that ended with it, built by the
//! same [`CameraMotionSensor`] as in the scenario runner and the Gymnasium env, from the camera pose: the
//! robot's planar pose and the camera's mount: how far ahead of the robot's origin it sits, its
//! height above the ground and its pitch (`--camera-forward-m`, `--camera-height-m`,
//! `--camera-pitch-deg`). Without a height the pose above the ground stays unknown and a
//! compensating detector removes the rotation only.

use std::io::{BufRead, BufReader};
use std::path::Path;

use anyhow::{Context, bail};
use loomlab_agents::{CameraMotionSensor, VelocityCommand};
use loomlab_detector::EfferenceCopy;
use loomlab_sim::glam::{DQuat, DVec3};
use loomlab_sim::trajectory::Pose64;

/// Accepted names of each column, in order of preference; yaw in degrees or radians.
const TIME: [&str; 2] = ["t_s", "t"];
const X: [&str; 3] = ["robot_x_m", "x_m", "x"];
const Y: [&str; 3] = ["robot_y_m", "y_m", "y"];
const YAW_DEG: [&str; 2] = ["robot_yaw_deg", "yaw_deg"];
const YAW_RAD: [&str; 2] = ["yaw_rad", "yaw"];

/// The robot's planar pose at one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlanarPose {
    /// Time (s).
    pub t_s: f64,
    /// Position on the ground (m, world axes).
    pub x_m: f64,
    /// Position on the ground (m, world axes).
    pub y_m: f64,
    /// Heading (rad, counter-clockwise from the world x axis).
    pub yaw_rad: f64,
}

/// How the camera sits on the robot.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CameraMount {
    /// How far ahead of the robot's origin (the point its pose gives) the camera sits (m).
    pub forward_m: f64,
    /// Height of the camera above the ground (m; `None`: unknown).
    pub height_m: Option<f64>,
    /// Pitch of the optical axis above the horizontal (rad, positive = up).
    pub pitch_rad: f64,
}

/// Reads one pose per video frame from `path`: rows with the same time (truth.csv has one row per
/// object and frame) are one pose; there must be exactly `frames` of them, in increasing time.
pub fn read_poses(path: &Path, frames: usize) -> anyhow::Result<Vec<PlanarPose>> {
    let shown = path.display();
    let file = std::fs::File::open(path).with_context(|| format!("cannot read the efference CSV {shown}"))?;
    let mut lines = BufReader::new(file).lines();
    let header = match lines.next() {
        Some(line) => line.with_context(|| format!("cannot read {shown}"))?,
        None => bail!("{shown} is empty: it needs a header with t_s, x, y and yaw columns"),
    };
    // a byte-order mark (spreadsheets write one) is not part of the first column's name
    let names: Vec<&str> = header
        .trim_start_matches('\u{feff}')
        .split(',')
        .map(str::trim)
        .collect();
    let shown_name = shown.to_string();
    let columns = Columns::of(&names, &shown_name)?;
    let time = columns.one("time", &TIME)?;
    let x = columns.one("x position", &X)?;
    let y = columns.one("y position", &Y)?;
    let yaw_names = [&YAW_DEG[..], &YAW_RAD[..]].concat();
    let yaw = columns.one("yaw", &yaw_names)?;
    let yaw_scale = if YAW_DEG.contains(&names[yaw]) {
        1f64.to_radians()
    } else {
        1.0
    };
    let mut poses: Vec<PlanarPose> = Vec::with_capacity(frames.min(1 << 20));
    for (i, line) in lines.enumerate() {
        let line_no = i + 2;
        let line = line.with_context(|| format!("cannot read {shown}"))?;
        if line.trim().is_empty() {
            continue;
        }
        let cells: Vec<&str> = line.split(',').collect();
        let value = |c: usize| -> anyhow::Result<f64> {
            let cell = cells.get(c).map_or("", |s| s.trim());
            match cell.parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(v),
                _ => bail!(
                    "{shown}, line {line_no}, column {}: {cell:?} is not a finite number",
                    names[c]
                ),
            }
        };
        let pose = PlanarPose {
            t_s: value(time)?,
            x_m: value(x)?,
            y_m: value(y)?,
            yaw_rad: value(yaw)? * yaw_scale,
        };
        match poses.last() {
            Some(last) if last.t_s == pose.t_s => continue,
            Some(last) if pose.t_s < last.t_s => bail!(
                "{shown}, line {line_no}: time {} s comes after {} s; the rows must be in increasing time",
                pose.t_s,
                last.t_s
            ),
            _ => {}
        }
        if poses.len() == frames {
            bail!("{shown} has more poses (distinct times) than the video has frames ({frames}); trim it to the video");
        }
        poses.push(pose);
    }
    if poses.len() != frames {
        bail!(
            "{shown} has {} poses (distinct times) but the video has {frames} frames; give one pose per frame \
             (a truth.csv of a scene without objects has no rows: write t_s, x, y, yaw_deg columns yourself)",
            poses.len()
        );
    }
    Ok(poses)
}

/// A CSV header's column names, each checked to appear once.
struct Columns<'a> {
    names: &'a [&'a str],
    shown: &'a str,
}

impl<'a> Columns<'a> {
    /// Refuses a header that names a column twice (which of them would be read is a guess).
    fn of(names: &'a [&'a str], shown: &'a str) -> anyhow::Result<Self> {
        for (i, name) in names.iter().enumerate() {
            if let Some(j) = names[i + 1..].iter().position(|n| n == name) {
                bail!(
                    "{shown} has two columns named `{name}` (columns {} and {}); rename or remove one",
                    i + 1,
                    i + j + 2
                );
            }
        }
        Ok(Self { names, shown })
    }

    /// The index of the one column holding `what`, named one of `accepted`; refuses none or several.
    fn one(&self, what: &str, accepted: &[&str]) -> anyhow::Result<usize> {
        let found: Vec<usize> = accepted
            .iter()
            .filter_map(|a| self.names.iter().position(|n| n == a))
            .collect();
        match found.as_slice() {
            [c] => Ok(*c),
            [] => bail!(
                "{} has no {what} column (its columns: {}); name it one of {}",
                self.shown,
                self.names.join(", "),
                accepted.join(", ")
            ),
            several => {
                let named: Vec<String> = several.iter().map(|&c| format!("`{}`", self.names[c])).collect();
                bail!(
                    "{} has several {what} columns ({}); it is ambiguous which one to read: keep one of them",
                    self.shown,
                    named.join(" and ")
                )
            }
        }
    }
}

/// The efference copy of each frame (the first knows the pose, not the motion).
pub fn efference_copies(poses: &[PlanarPose], mount: CameraMount) -> Vec<EfferenceCopy> {
    let mut sensor = CameraMotionSensor::default();
    let height = mount.height_m.unwrap_or(0.0);
    let mut previous: Option<PlanarPose> = None;
    poses
        .iter()
        .map(|p| {
            // the command that moved the robot from the previous pose, in its own axes
            let command = match previous {
                Some(q) if p.t_s > q.t_s => {
                    let dt = p.t_s - q.t_s;
                    let (s, c) = q.yaw_rad.sin_cos();
                    let (dx, dy) = (p.x_m - q.x_m, p.y_m - q.y_m);
                    VelocityCommand {
                        forward_mps: (c * dx + s * dy) / dt,
                        lateral_mps: (-s * dx + c * dy) / dt,
                        yaw_rate_rps: wrap(p.yaw_rad - q.yaw_rad) / dt,
                    }
                }
                _ => VelocityCommand::STOP,
            };
            previous = Some(*p);
            let (s, c) = p.yaw_rad.sin_cos();
            let camera = Pose64 {
                position: DVec3::new(p.x_m + c * mount.forward_m, p.y_m + s * mount.forward_m, height),
                rotation: DQuat::from_rotation_z(p.yaw_rad) * DQuat::from_rotation_y(-mount.pitch_rad),
            };
            // a height of 0 leaves the pose above the ground unknown
            sensor.sense(command, p.t_s, &camera)
        })
        .collect()
}

/// An angle difference wrapped into (−π, π].
fn wrap(a: f64) -> f64 {
    let t = a.rem_euclid(std::f64::consts::TAU);
    if t > std::f64::consts::PI {
        t - std::f64::consts::TAU
    } else {
        t
    }
}

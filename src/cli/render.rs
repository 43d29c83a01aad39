//! `loomlab render SCENE.toml --out DIR`: render the robot's egocentric view of a simulated world.
//!
//! Writes `DIR/frames/frame_00000.png…` (frame 0 is the view at t = 0, frame k the view after k camera
//! periods), `DIR/view.gif` (every `--gif-stride`-th frame) and `DIR/truth.csv` (per-frame ground truth for
//! every object, see `loomlab_sim::io::TRUTH_CSV_HEADER`). With an event camera (`[world.camera]
//! kind = "events"`, `--sensor events`) also `DIR/events.gif` (per GIF frame the events since the
//! previous one: ON brighter, OFF darker than mid-grey) and `DIR/events.csv` (`frame,t_s,x,y,polarity`).
//!
//! The scene file is TOML with the tables `[world]` (a `loomlab_sim::WorldDesc`), optional `[episode]`
//! (`duration_s`, `seed`) and optional `[robot_command]` (a constant `forward_mps`, `yaw_rate_rps`,
//! `lateral_mps`). Unknown keys are errors. Examples: `scenarios/scenes/*.toml`.

use std::path::{Path, PathBuf};

use anyhow::{Context, anyhow, bail};
use clap::Args;
use loomlab_sim::io::{GifWriter, TruthCsv, write_png};
use loomlab_sim::{
    Command, MAX_N, MIN_FRAME_SIZE, PhysicsMode, Sim, SimError, WorldDesc, check_frame_count, episode_frames,
};
use serde::Deserialize;

/// Arguments of `loomlab render`.
#[derive(Debug, Args)]
pub struct RenderArgs {
    /// Scene file (TOML with `[world]`, optional `[episode]` and `[robot_command]`).
    #[arg(value_name = "SCENE.toml")]
    pub scene: PathBuf,
    /// Output folder (created if missing).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Number of steps to simulate (overrides `episode.duration_s`); at most
    /// `loomlab_sim::MAX_EPISODE_FRAMES` (432000).
    #[arg(long, conflicts_with = "seconds")]
    pub frames: Option<u64>,
    /// Simulated duration in seconds (overrides `episode.duration_s`): finite, > 0 and at most
    /// `loomlab_sim::MAX_EPISODE_FRAMES` camera frames.
    #[arg(long, allow_negative_numbers = true)]
    pub seconds: Option<f64>,
    /// Seed (camera shake, noise textures); overrides `episode.seed`.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Frame size n (overrides `world.camera.n`), 20..=2048 (`loomlab_sim::MIN_FRAME_SIZE`..=`MAX_N`).
    #[arg(long)]
    pub size: Option<u32>,
    /// Render under this sensor profile (`ideal`, `robot`: blur, noise, quantisation and the
    /// perception latency; the actuation latency delays `robot_command`; `events`: an event
    /// camera beside the frames), overriding the file's `[world.camera.sensor]` and latencies.
    #[arg(long, value_name = "PROFILE")]
    pub sensor: Option<String>,
    /// Do not write the animated GIF.
    #[arg(long)]
    pub no_gif: bool,
    /// Do not write the PNG frames.
    #[arg(long)]
    pub no_frames: bool,
    /// Physics and ground truth only: no rendering, no images (no GPU needed).
    #[arg(long)]
    pub no_render: bool,
    /// Put every k-th frame into the GIF (default: about 40 frames per second of simulated time).
    #[arg(long, value_name = "K")]
    pub gif_stride: Option<u64>,
    /// Stop at the first contact with the robot.
    #[arg(long)]
    pub stop_on_contact: bool,
    /// Physics model (overrides `world.physics`): `dynamic` (rapier integrates the robot within its
    /// drive limits and the bouncing projectiles) or `analytic` (closed-form paths).
    #[arg(long, value_enum)]
    pub physics: Option<PhysicsArg>,
}

/// `--physics` values.
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
pub enum PhysicsArg {
    /// rapier integrates the robot and the projectiles.
    Dynamic,
    /// Closed-form paths; rapier only detects contacts.
    Analytic,
}

/// `[episode]` of a scene file.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct EpisodeSection {
    /// Simulated duration (s), > 0 and at most `loomlab_sim::MAX_EPISODE_FRAMES` camera frames. Default 3.
    #[serde(default = "default_duration")]
    duration_s: f64,
    /// Seed (camera shake, noise textures). Default 0.
    #[serde(default)]
    seed: u64,
}

fn default_duration() -> f64 {
    3.0
}

impl Default for EpisodeSection {
    fn default() -> Self {
        EpisodeSection {
            duration_s: default_duration(),
            seed: 0,
        }
    }
}

/// A scene file: a world plus how to drive through it.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneFile {
    world: WorldDesc,
    #[serde(default)]
    episode: EpisodeSection,
    #[serde(default)]
    robot_command: Command,
}

fn load_scene(path: &Path) -> anyhow::Result<SceneFile> {
    let text = std::fs::read_to_string(path).with_context(|| format!("reading scene file {}", path.display()))?;
    let scene: SceneFile = toml::from_str(&text).with_context(|| format!("parsing scene file {}", path.display()))?;
    Ok(scene)
}

/// A simulator error about the scene file, naming the file; keys the simulator reports under its own
/// name (`command.forward_mps`) are renamed to the key path of the scene file (`robot_command.forward_mps`).
fn scene_error(path: &Path, e: SimError) -> anyhow::Error {
    match e {
        SimError::InvalidDesc { key, value, reason } => {
            let key = match key.strip_prefix("command.") {
                Some(rest) => format!("robot_command.{rest}"),
                None => key,
            };
            anyhow!("{}: {key} = {value}: {reason}", path.display())
        }
        SimError::Duration { .. } => anyhow!("{}: {e}", path.display()),
        other => anyhow::Error::new(other).context(format!("in scene file {}", path.display())),
    }
}

/// Everything `render` needs, validated: nothing is written before this succeeds.
struct Plan {
    scene: SceneFile,
    seed: u64,
    steps: u64,
}

/// Reads the scene file and checks it and every flag; the errors name the file (for keys of the
/// file) or the flag, the value and the fix.
fn plan(args: &RenderArgs) -> anyhow::Result<Plan> {
    let mut scene = load_scene(&args.scene)?;
    let file = &args.scene;
    let dt = scene.world.dt();
    // The file's duration is checked even when a flag overrides it: the file is wrong either way.
    let file_steps =
        episode_frames("episode.duration_s", scene.episode.duration_s, dt).map_err(|e| scene_error(file, e))?;
    if let Some(n) = args.size {
        if !(MIN_FRAME_SIZE..=MAX_N).contains(&n) {
            bail!(
                "--size = {n}: the frame size must be in {MIN_FRAME_SIZE}..={MAX_N} pixels (the detectors need \
                 frames of at least {MIN_FRAME_SIZE}×{MIN_FRAME_SIZE})"
            );
        }
        scene.world.camera.n = n;
    }
    if let Some(name) = &args.sensor {
        loomlab_sim::SensorProfile::named(name)
            .map_err(|e| anyhow::anyhow!("--sensor: {e}"))?
            .apply(&mut scene.world);
    }
    if let Some(p) = args.physics {
        scene.world.physics = match p {
            PhysicsArg::Dynamic => PhysicsMode::Dynamic,
            PhysicsArg::Analytic => PhysicsMode::Analytic,
        };
    }
    scene.world.validate().map_err(|e| scene_error(file, e))?;
    scene.robot_command.validate().map_err(|e| scene_error(file, e))?;
    let c = scene.robot_command;
    let exceeded = scene
        .world
        .robot
        .exceeded_limit(c.forward_mps.into(), c.yaw_rate_rps.into(), c.lateral_mps.into());
    if let (PhysicsMode::Dynamic, Some((name, value, limit_key, limit))) = (scene.world.physics, exceeded) {
        bail!(
            "{}: robot_command.{name} = {value} exceeds world.robot.{limit_key} ({limit}), the drive's limit: the \
             dynamic physics would run the robot at {limit} instead; lower it, raise world.robot.{limit_key} or \
             use --physics analytic",
            file.display()
        );
    }
    let steps = match (args.frames, args.seconds) {
        (Some(f), _) => check_frame_count("--frames", f)?,
        (None, Some(s)) => episode_frames("--seconds", s, dt)?,
        (None, None) => file_steps,
    };
    let seed = args.seed.unwrap_or(scene.episode.seed);
    Ok(Plan { scene, seed, steps })
}

/// Runs `loomlab render`; returns the exit code.
pub fn run(args: RenderArgs) -> anyhow::Result<i32> {
    let Plan { scene, seed, steps } = plan(&args)?;
    let dt = scene.world.dt();
    let mut sim = if args.no_render {
        Sim::new_physics_only(&scene.world, seed)?
    } else {
        Sim::new(&scene.world, seed)?
    };
    let render = sim.renders();
    std::fs::create_dir_all(&args.out).with_context(|| format!("creating {}", args.out.display()))?;
    let frames_dir = args.out.join("frames");
    if render && !args.no_frames {
        std::fs::create_dir_all(&frames_dir).with_context(|| format!("creating {}", frames_dir.display()))?;
    }
    let n = sim.n();
    let stride = args
        .gif_stride
        .unwrap_or_else(|| ((1.0 / dt) / 40.0).round().max(1.0) as u64)
        .max(1);
    let delay_cs = ((stride as f64 * dt) * 100.0).round().clamp(2.0, 65535.0) as u16;
    let mut gif = if render && !args.no_gif {
        Some(GifWriter::create(&args.out.join("view.gif"), n, delay_cs)?)
    } else {
        None
    };
    let mut csv = TruthCsv::create(&args.out.join("truth.csv"))?;
    let mut events = match sim.event_stream().filter(|_| render) {
        Some(_) => Some(EventOutputs::create(&args.out, n, delay_cs, !args.no_gif)?),
        None => None,
    };
    if let Some(adapter) = sim.adapter() {
        errln!("rendering {n}x{n} on {adapter}");
    }
    let bar = super::progress(steps + 1, "render");
    let command = scene.robot_command;
    let mut contacts = Vec::new();
    for k in 0..=steps {
        let out = if k == 0 { sim.observe()? } else { sim.step(&command)? };
        if render {
            if !args.no_frames {
                write_png(&frames_dir.join(format!("frame_{k:05}.png")), &out.frame, n)?;
            }
            if let Some(g) = gif.as_mut().filter(|_| k % stride == 0) {
                g.add(&out.frame)?;
            }
            if let (Some(e), Some(packet)) = (events.as_mut(), sim.events()) {
                e.add(k, packet, k % stride == 0)?;
            }
        }
        let ids: Vec<usize> = out.contacts.iter().map(|c| c.object_id).collect();
        csv.write_frame(k, &out.robot, &out.truth, &ids)?;
        contacts.extend(out.contacts);
        bar.inc(1);
        if args.stop_on_contact && !contacts.is_empty() {
            break;
        }
    }
    bar.finish_and_clear();
    csv.finish()?;
    drop(gif);
    if let Some(e) = events {
        e.finish()?;
    }
    for c in &contacts {
        let exact = c.exact_t_s.map(|t| format!(" (exact {t:.4} s)")).unwrap_or_default();
        let impulse = c
            .impulse_ns
            .map(|j| format!(", impulse {j:.3} N s"))
            .unwrap_or_default();
        let harmless = if c.harmless { " [harmless]" } else { "" };
        outln!(
            "contact: {} ({}) at t = {:.4} s{exact}, impact speed {:.2} m/s{impulse}{harmless}",
            c.name,
            c.kind,
            c.t_s,
            c.impact_speed_mps
        );
    }
    outln!("wrote {}", args.out.display());
    Ok(0)
}

/// The event camera's outputs of `loomlab render`: `events.gif` (the events accumulated since the
/// last GIF frame: mid-grey, ON events brighter, OFF darker, saturating at 4 of a kind) and
/// `events.csv` (every event).
struct EventOutputs {
    gif: Option<GifWriter>,
    csv: std::io::BufWriter<std::fs::File>,
    path: PathBuf,
    /// Net events (ON − OFF) per pixel since the last GIF frame.
    net: Vec<f32>,
}

impl EventOutputs {
    fn create(dir: &Path, n: u32, delay_cs: u16, gif: bool) -> anyhow::Result<EventOutputs> {
        use std::io::Write;
        let path = dir.join("events.csv");
        let file = std::fs::File::create(&path).with_context(|| format!("creating {}", path.display()))?;
        let mut csv = std::io::BufWriter::new(file);
        writeln!(csv, "frame,t_s,x,y,polarity").with_context(|| format!("writing {}", path.display()))?;
        Ok(EventOutputs {
            gif: if gif {
                Some(GifWriter::create(&dir.join("events.gif"), n, delay_cs)?)
            } else {
                None
            },
            csv,
            path,
            net: vec![0.0; (n as usize) * (n as usize)],
        })
    }

    /// Frame `k`'s events; `show`: write a GIF frame (and start accumulating again).
    fn add(&mut self, k: u64, packet: &loomlab_sim::EventPacket, show: bool) -> anyhow::Result<()> {
        use std::io::Write;
        for e in &packet.events {
            writeln!(self.csv, "{k},{:.7},{},{},{}", e.t_s, e.x, e.y, e.polarity)
                .with_context(|| format!("writing {}", self.path.display()))?;
        }
        for ((v, &on), &off) in self.net.iter_mut().zip(&packet.on_counts).zip(&packet.off_counts) {
            *v += f32::from(on) - f32::from(off);
        }
        if show {
            if let Some(gif) = self.gif.as_mut() {
                gif.add(&loomlab_report::exemplar::event_image(&self.net))?;
            }
            self.net.iter_mut().for_each(|v| *v = 0.0);
        }
        Ok(())
    }

    fn finish(mut self) -> anyhow::Result<()> {
        use std::io::Write;
        self.csv
            .flush()
            .with_context(|| format!("writing {}", self.path.display()))
    }
}

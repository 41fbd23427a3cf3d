//! `glint-scene`: renders a preset scene to a raw YUYV dump plus its ground-truth CSV (a fleet
//! preset, several robots: one truth CSV per robot).
//!
//! The dump has exactly the layout of `v4l2-ctl --stream-mmap --stream-to=FILE` or
//! `ffmpeg -f rawvideo -pix_fmt yuyv422`: headerless frames back to back.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{bail, Context, Result};
use clap::Parser;
use glint_tools::scene::{
    write_truth_csv, Arena, ArenaConfig, Bump, Fleet, Knock, Range, Scene, SceneConfig, Spot,
    SweepPoint, Trajectory, Truth, Visibility,
};

/// Render a synthetic glint scene with ground truth.
#[derive(Parser, Debug)]
#[command(version, about)]
pub(crate) struct Args {
    /// List the presets and exit.
    #[arg(long)]
    list: bool,
    /// Preset name (see --list).
    #[arg(long, required_unless_present_any = ["list", "sweep", "arena"])]
    scene: Option<String>,
    /// Render one arena through two cameras a third of a view apart (`glint fuse`'s scene):
    /// NAME-a.yuv and NAME-b.yuv with sidecars carrying each camera's capture times.
    #[arg(long, conflicts_with_all = ["scene", "sweep"])]
    arena: bool,
    /// With --arena: camera b's frames end this long after camera a's, ms.
    #[arg(long, value_name = "MS", default_value_t = 0.0, requires = "arena")]
    phase_ms: f64,
    /// With --arena: camera b's clock reads this much more than camera a's, ms.
    #[arg(
        long,
        value_name = "MS",
        default_value_t = 0.0,
        requires = "arena",
        allow_negative_numbers = true
    )]
    clock_offset_ms: f64,
    /// Render point N of the accuracy sweep instead of a preset (named sweep-N).
    #[arg(long, value_name = "N", conflicts_with = "scene")]
    sweep: Option<usize>,
    /// Seed of the sweep the point is drawn from.
    #[arg(long, default_value_t = 11)]
    sweep_seed: u64,
    /// The LED's spot profile: disk, gaussian or bloom (a Gaussian core in a wide glow).
    #[arg(long, value_parser = ["disk", "gaussian", "bloom"])]
    spot: Option<String>,
    /// Spot width: the disk's radius or the Gaussian core's σ (default: the scene's).
    #[arg(long)]
    spot_px: Option<f64>,
    /// Bloom only: the glow's σ in multiples of the core's.
    #[arg(long, default_value_t = 4.0)]
    glow_width: f64,
    /// Bloom only: the glow's centre radiance relative to the core's.
    #[arg(long, default_value_t = 0.05)]
    glow_ratio: f64,
    /// The spot's centre radiance in multiples of the clip level.
    #[arg(long)]
    peak: Option<f64>,
    /// The camera's tone-curve exponent (1 is linear; webcams use 1.8–2.4).
    #[arg(long)]
    gamma: Option<f64>,
    /// Read noise, in luma levels of a linear full-range camera.
    #[arg(long)]
    noise_luma: Option<f64>,
    /// Noise after the clip, in luma levels: processing after the sensor (compression,
    /// sharpening) that leaves saturated pixels white give or take this.
    #[arg(long)]
    post_noise_luma: Option<f64>,
    /// Output range: full (white 255) or studio (white 235).
    #[arg(long, value_parser = ["full", "studio"])]
    range: Option<String>,
    /// A rolling shutter's time from one row's exposure to the next, µs (0, the default, is a
    /// global shutter); scenes without a camera view or companion LEDs.
    #[arg(long, value_name = "MICROSECONDS")]
    row_time_us: Option<f64>,
    /// Directory for NAME.yuv and NAME.truth.csv (created if missing).
    #[arg(long, required_unless_present = "list")]
    out_dir: Option<PathBuf>,
    /// Number of frames (default: the preset's).
    #[arg(long)]
    frames: Option<usize>,
    /// Seed of the floor texture and noise (default: the preset's).
    #[arg(long)]
    seed: Option<u64>,
    /// Lens distortion `K1,K2,K3,P1,P2` (OpenCV's Brown–Conrady coefficients) for a preset
    /// with a camera view (marker, marker-map, lens-*, led-mast, knocked).
    #[arg(long, value_name = "K1,K2,K3,P1,P2", value_parser = parse_distortion,
          allow_hyphen_values = true)]
    distortion: Option<[f64; 5]>,
    /// Height of the LED above the floor, cm (presets with a camera view).
    #[arg(long, value_name = "CM")]
    led_height_cm: Option<f64>,
    /// Knock the camera at this frame: `FRAME:TILT_DEG` (presets with a camera view).
    #[arg(long, value_name = "FRAME:TILT_DEG", value_parser = parse_knock,
          allow_hyphen_values = true)]
    knock: Option<(usize, f64)>,
    /// Move one marker on the floor at this frame, as if kicked: `FRAME:ID:DX_CM,DY_CM` (the
    /// map printed for `glint calibrate` stays as it was; presets with markers in view).
    #[arg(long = "move-marker", value_name = "FRAME:ID:DX_CM,DY_CM", value_parser = parse_move,
          allow_hyphen_values = true)]
    move_marker: Option<(usize, u16, f64, f64)>,
}

fn parse_distortion(s: &str) -> Result<[f64; 5], String> {
    let values: Vec<f64> = s
        .split(',')
        .map(|v| v.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("{s:?} is not five numbers K1,K2,K3,P1,P2"))?;
    let values: [f64; 5] = values
        .try_into()
        .map_err(|_| format!("{s:?} is not five numbers K1,K2,K3,P1,P2"))?;
    if values.iter().any(|v| !v.is_finite() || v.abs() > 10.0) {
        return Err(format!(
            "{s:?}: coefficients must be finite, at most 10 in size"
        ));
    }
    Ok(values)
}

fn parse_knock(s: &str) -> Result<(usize, f64), String> {
    let usage = || format!("{s:?} is not FRAME:TILT_DEG, e.g. 60:0.8");
    let (frame, deg) = s.split_once(':').ok_or_else(usage)?;
    let frame: usize = frame.trim().parse().map_err(|_| usage())?;
    let deg: f64 = deg.trim().parse().map_err(|_| usage())?;
    if !(deg.is_finite() && deg.abs() <= 30.0) {
        return Err(format!("{s:?}: the tilt must be at most 30°"));
    }
    Ok((frame, deg))
}

fn parse_move(s: &str) -> Result<(usize, u16, f64, f64), String> {
    let usage = || format!("{s:?} is not FRAME:ID:DX_CM,DY_CM, e.g. 40:2:2.5,0");
    let mut parts = s.splitn(3, ':');
    let (Some(frame), Some(id), Some(offset)) = (parts.next(), parts.next(), parts.next()) else {
        return Err(usage());
    };
    let (dx, dy) = offset.split_once(',').ok_or_else(usage)?;
    let frame: usize = frame.trim().parse().map_err(|_| usage())?;
    let id: u16 = id.trim().parse().map_err(|_| usage())?;
    let dx: f64 = dx.trim().parse().map_err(|_| usage())?;
    let dy: f64 = dy.trim().parse().map_err(|_| usage())?;
    if !(dx.is_finite() && dy.is_finite() && dx.hypot(dy) <= 100.0) {
        return Err(format!("{s:?}: the move must be at most 100 cm"));
    }
    Ok((frame, id, dx, dy))
}

fn main() -> ExitCode {
    match run(Args::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("glint-scene: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn run(args: Args) -> Result<()> {
    if args.list {
        for &name in Scene::names() {
            if let Some(config) = Scene::preset_config(name) {
                println!("{name:<14} {}", config.summary);
            }
        }
        for &name in Fleet::names() {
            if let Some((config, _)) = Fleet::preset_config(name) {
                println!("{name:<14} {}", config.summary);
            }
        }
        return Ok(());
    }
    let Some(out_dir) = args.out_dir.clone() else {
        bail!("--out-dir is required (or --list)");
    };
    if args.arena {
        return render_arena(&args, &out_dir);
    }
    if let Some((config, trajectories)) = args.scene.as_deref().and_then(Fleet::preset_config) {
        return write_fleet(&args, config, &trajectories, &out_dir);
    }
    let mut config = match (&args.scene, args.sweep) {
        (_, Some(index)) => SweepPoint::new(args.sweep_seed, index).config(),
        (Some(name), None) => match Scene::preset_config(name) {
            Some(config) => config,
            None => bail!(
                "unknown scene {name:?}; known: {}",
                Scene::names().join(", ")
            ),
        },
        (None, None) => bail!("--scene or --sweep is required (or --list)"),
    };
    let name = config.name.clone();
    override_optics(&args, &mut config);
    if let Some(frames) = args.frames {
        config.frame_count = frames;
    }
    if let Some(seed) = args.seed {
        config.seed = seed;
    }
    let view_flags = args.distortion.is_some()
        || args.led_height_cm.is_some()
        || args.knock.is_some()
        || args.move_marker.is_some();
    match config.view.as_mut() {
        Some(view) => {
            if let Some([k1, k2, k3, p1, p2]) = args.distortion {
                view.lens = view.lens.with_distortion(k1, k2, k3, p1, p2);
            }
            if let Some(h) = args.led_height_cm {
                view.led_height_cm = h;
            }
            if let Some((frame, tilt_deg)) = args.knock {
                view.knock = Some(Knock {
                    frame,
                    pan_deg: 0.0,
                    tilt_deg,
                    roll_deg: 0.0,
                });
            }
            if let Some((frame, id, dx_cm, dy_cm)) = args.move_marker {
                let Some(marker) = view.markers.iter().position(|m| m.id == id) else {
                    bail!("--move-marker: the scene has no marker {id}");
                };
                view.bump = Some(Bump {
                    frame,
                    marker,
                    dx_cm,
                    dy_cm,
                    turn_deg: 0.0,
                });
            }
        }
        None if view_flags => bail!(
            "--distortion, --led-height-cm, --knock and --move-marker need a preset with a \
             camera view \
             (marker, marker-map, lens-wide, lens-mild, led-mast, knocked)"
        ),
        None => {}
    }
    let scene = Scene::new(config).with_context(|| format!("scene {name}"))?;

    std::fs::create_dir_all(&out_dir)
        .with_context(|| format!("cannot create {}", out_dir.display()))?;
    let dump_path = out_dir.join(format!("{name}.yuv"));
    let truth_path = out_dir.join(format!("{name}.truth.csv"));

    let started = Instant::now();
    let truths = write_dump(&scene, &dump_path)?;
    let elapsed = started.elapsed();
    let truth_file = File::create(&truth_path)
        .with_context(|| format!("cannot create {}", truth_path.display()))?;
    write_truth_csv(BufWriter::new(truth_file), &truths)
        .with_context(|| format!("cannot write {}", truth_path.display()))?;

    let visible = truths
        .iter()
        .filter(|t| t.visible == Visibility::Visible)
        .count();
    println!(
        "{name}: {}x{} YUYV, {} fps, exposure {} us, {} frames ({visible} visible)",
        scene.width_px(),
        scene.height_px(),
        scene.fps(),
        scene.exposure_us(),
        truths.len()
    );
    println!("wrote {} and {}", dump_path.display(), truth_path.display());
    if let Some(view) = &scene.config().view {
        let floor_path = out_dir.join(format!("{name}.floor.csv"));
        write_floor_truth(&scene, &floor_path)?;
        println!(
            "wrote {} (the floor point under the LED, cm)",
            floor_path.display()
        );
        let markers: Vec<String> = view
            .marker_args()
            .iter()
            .map(|m| format!("--marker {m}"))
            .collect();
        // One marker cannot show how the lens bends the picture: say the lens is ideal.
        let lens = if view.markers.len() < 2 {
            " --lens ideal"
        } else {
            ""
        };
        println!(
            "calibrate with: glint calibrate --input {} --size {}x{} {}{lens} --out calib.toml",
            dump_path.display(),
            scene.width_px(),
            scene.height_px(),
            markers.join(" ")
        );
    }
    eprintln!(
        "rendered in {:.1} ms ({:.2} ms/frame)",
        elapsed.as_secs_f64() * 1e3,
        elapsed.as_secs_f64() * 1e3 / truths.len().max(1) as f64
    );
    Ok(())
}

/// Renders a fleet preset: NAME.yuv, and NAME.robotK.truth.csv for each robot K = 1, 2, ...
/// (the robots in the preset's order; glint's ids are its own).
fn write_fleet(
    args: &Args,
    mut config: SceneConfig,
    trajectories: &[Trajectory],
    out_dir: &Path,
) -> Result<()> {
    let name = config.name.clone();
    override_optics(args, &mut config);
    if let Some(frames) = args.frames {
        config.frame_count = frames;
    }
    if let Some(seed) = args.seed {
        config.seed = seed;
    }
    let fleet = Fleet::new(&config, trajectories).with_context(|| format!("scene {name}"))?;
    std::fs::create_dir_all(out_dir)
        .with_context(|| format!("cannot create {}", out_dir.display()))?;
    let dump_path = out_dir.join(format!("{name}.yuv"));
    let file = File::create(&dump_path)
        .with_context(|| format!("cannot create {}", dump_path.display()))?;
    let mut out = BufWriter::new(file);
    let mut frame = vec![0u8; fleet.robot(0).map_or(0, Scene::frame_len_bytes)];
    let mut truths: Vec<Vec<Truth>> = vec![Vec::new(); fleet.robots()];
    for i in 0..config.frame_count {
        for (all, truth) in truths.iter_mut().zip(fleet.render(i, &mut frame)?) {
            all.push(truth);
        }
        out.write_all(&frame)
            .with_context(|| format!("cannot write {}", dump_path.display()))?;
    }
    out.flush()
        .with_context(|| format!("cannot write {}", dump_path.display()))?;
    for (k, robot) in truths.iter().enumerate() {
        let path = out_dir.join(format!("{name}.robot{}.truth.csv", k + 1));
        let file =
            File::create(&path).with_context(|| format!("cannot create {}", path.display()))?;
        write_truth_csv(BufWriter::new(file), robot)
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    println!(
        "{name}: {}x{} YUYV, {} robots, {} frames; wrote {} and {name}.robot1..{}.truth.csv",
        config.width_px,
        config.height_px,
        fleet.robots(),
        config.frame_count,
        dump_path.display(),
        fleet.robots()
    );
    Ok(())
}

/// Applies the spot, brightness and camera flags to `config`.
fn override_optics(args: &Args, config: &mut SceneConfig) {
    let led = &mut config.led;
    if let Some(width) = args.spot_px {
        led.radius_px = width;
        led.spot = match led.spot {
            Spot::Disk => Spot::Disk,
            Spot::Gaussian { .. } | Spot::Bloom { .. } => Spot::Gaussian { sigma_px: width },
        };
    }
    if let Some(kind) = &args.spot {
        let sigma_px = led.radius_px;
        led.spot = match kind.as_str() {
            "gaussian" => Spot::Gaussian { sigma_px },
            "bloom" => Spot::Bloom {
                sigma_px,
                glow_sigma_px: args.glow_width * sigma_px,
                glow_ratio: args.glow_ratio,
            },
            _ => Spot::Disk,
        };
        if kind != "disk" {
            // The old lens glow is the bloom's job now.
            led.glow_peak = 0.0;
        }
    }
    if let Some(peak) = args.peak {
        led.peak = peak;
    }
    if let Some(row_time_us) = args.row_time_us {
        config.row_time_us = row_time_us;
    }
    if let Some(gamma) = args.gamma {
        config.camera.gamma = gamma;
    }
    if let Some(noise) = args.noise_luma {
        config.camera.noise_sigma = noise / 255.0;
    }
    if let Some(noise) = args.post_noise_luma {
        config.camera.post_noise_luma = noise;
    }
    match args.range.as_deref() {
        Some("studio") => config.camera.range = Range::Studio,
        Some("full") => config.camera.range = Range::Full,
        _ => {}
    }
}

/// The floor truth of a scene with a camera view: `frame,floor_x_cm,floor_y_cm`, empty cells
/// where the LED is over no floor.
fn write_floor_truth(scene: &Scene, path: &PathBuf) -> Result<()> {
    let mut text = String::from("frame,floor_x_cm,floor_y_cm\n");
    for frame in 0..scene.frame_count() {
        match scene.floor_truth_cm(frame) {
            Some(p) => text.push_str(&format!("{frame},{:?},{:?}\n", p.x, p.y)),
            None => text.push_str(&format!("{frame},,\n")),
        }
    }
    std::fs::write(path, text).with_context(|| format!("cannot write {}", path.display()))
}

/// Streams the frames to `path` one at a time (an HD dump would not fit comfortably in memory).
fn write_dump(scene: &Scene, path: &PathBuf) -> Result<Vec<Truth>> {
    let file = File::create(path).with_context(|| format!("cannot create {}", path.display()))?;
    let mut out = BufWriter::new(file);
    let mut frame = vec![0u8; scene.frame_len_bytes()];
    let mut truths = Vec::new();
    for index in 0..scene.frame_count() {
        truths.push(scene.render(index, &mut frame)?);
        out.write_all(&frame)
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    out.flush()
        .with_context(|| format!("cannot write {}", path.display()))?;
    Ok(truths)
}

/// `--arena`: both cameras' dumps with their sidecars, the floor truth at every capture time,
/// and the commands that calibrate, track and fuse them.
fn render_arena(args: &Args, out_dir: &std::path::Path) -> Result<()> {
    let standard = ArenaConfig::standard();
    let config = ArenaConfig {
        frame_count: args.frames.unwrap_or(standard.frame_count),
        seed: args.seed.unwrap_or(standard.seed),
        led_height_cm: args.led_height_cm.unwrap_or(standard.led_height_cm),
        phase_s: args.phase_ms * 1e-3,
        clock_offset_us: (args.clock_offset_ms * 1e3).round() as i64,
        ..standard
    };
    let arena = Arena::new(config).context("the arena")?;
    std::fs::create_dir_all(out_dir)
        .with_context(|| format!("cannot create {}", out_dir.display()))?;
    let mut truth = String::from("camera,frame,t_us,floor_x_cm,floor_y_cm\n");
    let mut commands = Vec::new();
    for cam in &arena.cameras {
        let dump = cam
            .write_dump(out_dir)
            .with_context(|| format!("cannot write {}'s dump", cam.name))?;
        for frame in 0..cam.scene.frame_count() {
            let p = arena.floor_truth_cm(cam.true_time_s(frame));
            truth.push_str(&format!(
                "{},{frame},{},{:?},{:?}\n",
                cam.name,
                cam.capture_time_us(frame),
                p.x,
                p.y
            ));
        }
        let size = format!("{}x{}", cam.scene.width_px(), cam.scene.height_px());
        let markers: Vec<String> = cam
            .marker_args()
            .iter()
            .map(|m| format!("--marker {m}"))
            .collect();
        let calib = out_dir.join(format!("{}.toml", cam.name));
        commands.push(format!(
            "glint calibrate --input {} --size {size} --lens ideal {} --out {}",
            dump.display(),
            markers.join(" "),
            calib.display()
        ));
        commands.push(format!(
            "glint track --input {} --size {size} --exposure-us {} --calib {} --led-height-cm {} > {}",
            dump.display(),
            cam.scene.exposure_us(),
            calib.display(),
            arena.config.led_height_cm,
            out_dir.join(format!("{}.jsonl", cam.name)).display()
        ));
        println!("wrote {} and its sidecar", dump.display());
    }
    let truth_path = out_dir.join(format!("{}.floor.csv", arena.config.name));
    std::fs::write(&truth_path, truth)
        .with_context(|| format!("cannot write {}", truth_path.display()))?;
    println!(
        "wrote {} (the floor point under the LED at each capture time, cm)",
        truth_path.display()
    );
    let [a, b] = &arena.cameras;
    commands.push(format!(
        "glint fuse --input {} --input {} --size {}x{}",
        out_dir.join(format!("{}.jsonl", a.name)).display(),
        out_dir.join(format!("{}.jsonl", b.name)).display(),
        a.scene.width_px(),
        a.scene.height_px()
    ));
    println!("then:");
    for c in commands {
        println!("  {c}");
    }
    Ok(())
}

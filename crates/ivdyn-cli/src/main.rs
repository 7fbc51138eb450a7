//! The `ivdyn` command line: `identify`, `payload`, `gains`, `simulate`, `diagnose`, `excite`
//! (see `docs/cli.md`). Arguments become an `ivdyn::app` job; the job reads, runs and
//! writes; this binary prints its summary and draws the progress bars.

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::{Arc, Mutex};

use clap::{Args, Parser, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};

use ivdyn::Robot;
use ivdyn::app::{
    self, Effort, IdentifyJob, IdentifyOptions, LogInput, LogSource, Method, PayloadOptions, PerJoint, RobotSource,
    SimulateOptions, TorqueConstants, Trajectory,
};
use ivdyn::progress::Progress;
use ivdyn::report::PayloadSpec;

mod signals;
mod stdout;
use stdout::say;

#[derive(Parser)]
#[command(name = "ivdyn", version, about = "Robot-arm dynamics identification from motion logs")]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
    /// No progress bars.
    #[arg(long, global = true)]
    quiet: bool,
}

#[derive(Subcommand)]
enum Cmd {
    /// Identify base parameters from a log (MCAP or CSV) with measured torques.
    #[command(allow_negative_numbers = true)]
    Identify(IdentifyArgs),
    /// Estimate a payload on the last link from a log after the grasp.
    #[command(allow_negative_numbers = true)]
    Payload(PayloadArgs),
    /// Drive gains (torque constants at the joint, N m/A) from a log without and a log
    /// with a payload of known mass, both with the drive currents.
    #[command(allow_negative_numbers = true)]
    Gains(gains_cmd::GainsArgs),
    /// Write a synthetic log (inverse dynamics along a trajectory, with noise).
    #[command(allow_negative_numbers = true)]
    Simulate(SimulateArgs),
    /// Find what the nominal model misses in a log, name it, add it (docs/diagnose.md).
    #[command(allow_negative_numbers = true)]
    Diagnose(diagnose_cmd::DiagnoseArgs),
    /// Design an excitation trajectory (finite Fourier series, optimised base regressor).
    #[command(allow_negative_numbers = true)]
    Excite(ExciteArgs),
    /// Identify a fleet from a manifest of logs on Ray, and name what changed (docs/fleet.md;
    /// runs the Python driver `python -m ivdyn.fleet`).
    Fleet(fleet_cmd::FleetArgs),
}

#[derive(Args)]
struct RobotArgs {
    /// URDF file.
    #[arg(long)]
    urdf: PathBuf,
    /// Base link of the chain (default: the URDF's root).
    #[arg(long)]
    base: Option<String>,
    /// Tip link of the chain (default: the end of an unbranched chain, with the rigid
    /// tool below it fused). A tip given ends the chain: the bodies below it are dropped.
    #[arg(long)]
    tip: Option<String>,
    /// Fuse the bodies below --tip (a hand, a tool the arm carries) into the last link
    /// instead of dropping them; their movable joints are locked at 0.
    #[arg(long)]
    fuse_beyond_tip: bool,
    /// Parameter file (written by `identify --out-params`) replacing the URDF's values.
    #[arg(long)]
    params: Option<PathBuf>,
}

#[derive(Args)]
struct LogArgs {
    /// JointState topic of MCAP logs.
    #[arg(long, default_value = "/joint_states")]
    topic: String,
    /// Use MCAP log times instead of header stamps.
    #[arg(long)]
    log_time: bool,
    /// JointState topic whose effort field is the motor current in A (may be --topic itself).
    #[arg(long)]
    current_topic: Option<String>,
    /// Which effort is the joint torque: the measured torque, the motor current times the
    /// torque constants, or auto (the torque when the log has one, else the current).
    #[arg(long, value_enum, default_value = "auto")]
    effort: EffortArg,
    /// Torque constant at the joint (N m/A) turning currents into torques: V (every joint),
    /// V1,V2,... (one per joint, base to tip) or JOINT=V,... (every joint by name).
    #[arg(long, allow_hyphen_values = true)]
    torque_constant: Option<String>,
    /// Gear ratio per joint (same forms as --torque-constant); with --motor-constant,
    /// k_t = ratio x motor constant.
    #[arg(long, allow_hyphen_values = true)]
    gear_ratio: Option<String>,
    /// Motor torque constant (N m/A at the motor) per joint, with --gear-ratio.
    #[arg(long, allow_hyphen_values = true)]
    motor_constant: Option<String>,
    /// Velocity source: `auto` (the log's velocity on each joint where it agrees with the
    /// differentiated positions), `log`, or `positions`.
    #[arg(long, value_enum, default_value = "auto")]
    velocity: VelocityArg,
    /// Use only START:END seconds from the log's first sample (`5:` from 5 s on, `:30` the first 30 s).
    #[arg(long, value_name = "START:END", allow_hyphen_values = true)]
    window: Option<String>,
    /// Leave out START:END seconds (from the log's first sample); repeat for several spans.
    /// The log is cut there like at a gap.
    #[arg(long, value_name = "START:END", allow_hyphen_values = true)]
    exclude: Vec<String>,
}

/// The differentiation filter and decimation of identify, payload and gains (diagnose
/// chooses its cut-off itself and does not decimate).
#[derive(Args)]
struct FilterArgs {
    /// Zero-phase cut-off (Hz) of the differentiation filter (default: 20 Hz, at most 0.2 fs).
    #[arg(long)]
    cutoff: Option<f64>,
    /// Decimation factor after the parallel filter (0: automatic, output rate ~2.5x the cut-off; 1: none).
    #[arg(long, default_value_t = 0)]
    decimate: usize,
}

#[derive(Clone, Copy, PartialEq, ValueEnum)]
enum VelocityArg {
    Auto,
    Log,
    Positions,
}

#[derive(Clone, Copy, ValueEnum)]
enum EffortArg {
    Auto,
    Torque,
    Current,
}

#[derive(Clone, Copy, ValueEnum)]
enum MethodArg {
    Ols,
    Wls,
    Iv,
    #[value(name = "idim-iv")]
    IdimIv,
}

#[derive(Args)]
struct IdentifyArgs {
    #[command(flatten)]
    robot: RobotArgs,
    /// Log file (.mcap or .csv); repeat for several logs of the same arm, identified
    /// together (the held-out tail is the last one's).
    #[arg(long, required = true)]
    log: Vec<PathBuf>,
    #[command(flatten)]
    log_args: LogArgs,
    #[command(flatten)]
    filter: FilterArgs,
    /// Optional JointState topic carrying the actuator command u (its effort field): the
    /// instrument of `--method iv` is then the model driven by u.
    #[arg(long)]
    command_topic: Option<String>,
    /// Estimation method.
    #[arg(long, value_enum, default_value = "wls")]
    method: MethodArg,
    /// Validation log (default: the last --holdout fraction of the log).
    #[arg(long)]
    validate: Option<PathBuf>,
    /// Fraction of the log held out for validation when no --validate log is given.
    #[arg(long, default_value_t = 0.25)]
    holdout: f64,
    /// JSON report.
    #[arg(long)]
    json: Option<PathBuf>,
    /// HTML report: one self-contained page (fit quality per joint, base parameters with
    /// their std, physical consistency, measured vs predicted torque and residual plots).
    #[arg(long, value_name = "FILE.html")]
    report: Option<PathBuf>,
    /// Identified full parameters (JSON, reloadable with --params).
    #[arg(long)]
    out_params: Option<PathBuf>,
    /// Also fit physically consistent parameters (log-Cholesky); --out-params, --write-urdf and --write-mjcf then use them.
    #[arg(long)]
    consistent: bool,
    /// Write a copy of the URDF with the identified inertials and friction (+ OUT.json side file).
    #[arg(long)]
    write_urdf: Option<PathBuf>,
    /// Write an MJCF (MuJoCo) model of the chain with the identified inertials, armature,
    /// damping and frictionloss (+ OUT.json side file with the torque offsets); refused for
    /// physically impossible parameters (use --consistent).
    #[arg(long)]
    write_mjcf: Option<PathBuf>,
    /// Friction terms to identify: `none`, or a comma list of `coulomb`, `viscous`
    /// (terms left out keep their nominal values).
    #[arg(long, value_delimiter = ',', default_value = "coulomb,viscous")]
    friction: Vec<FrictionArg>,
    /// Shape of the Coulomb friction: `auto` chooses per joint, by held-out validation,
    /// between sign(qd), a smooth tanh(qd / v) with its velocity scale and their
    /// direction-dependent variants; `sign` keeps the paper's sign(qd) on every joint;
    /// `model` keeps the shapes the model has (from --params).
    #[arg(long, default_value = "auto")]
    coulomb: String,
    /// Do not identify the armature (rotor inertia) of the joints.
    #[arg(long)]
    no_armature: bool,
    /// Do not identify a constant torque offset per joint.
    #[arg(long)]
    no_offset: bool,
    /// Write the measured torques, the identified model's predicted torques and the
    /// residuals as JointState topics (/joint_states, /ivdyn/predicted, /ivdyn/residual)
    /// on the same stamps to this MCAP file.
    #[arg(long)]
    out_mcap: Option<PathBuf>,
    /// Read the whole log into memory instead of streaming it (MCAP logs of more than
    /// 1 M values are streamed with bounded memory when the options allow).
    #[arg(long, conflicts_with = "stream")]
    in_memory: bool,
    /// Stream an MCAP log block by block even when it is small (bounded memory; velocities
    /// from positions, no resampling).
    #[arg(long)]
    stream: bool,
}

#[derive(Clone, Copy, PartialEq, ValueEnum)]
enum FrictionArg {
    None,
    Coulomb,
    Viscous,
}

impl FrictionArg {
    fn name(&self) -> &'static str {
        match self {
            FrictionArg::None => "none",
            FrictionArg::Coulomb => "coulomb",
            FrictionArg::Viscous => "viscous",
        }
    }
}

#[derive(Args)]
struct PayloadArgs {
    #[command(flatten)]
    robot: RobotArgs,
    /// Log after the grasp.
    #[arg(long)]
    log: PathBuf,
    /// Log before the grasp (same arm without payload): cancels nominal-model errors.
    #[arg(long)]
    before: Option<PathBuf>,
    #[command(flatten)]
    log_args: LogArgs,
    #[command(flatten)]
    filter: FilterArgs,
    /// JSON report.
    #[arg(long)]
    json: Option<PathBuf>,
    /// HTML report: one self-contained page (the estimate with std and 95 % intervals,
    /// physical validity, fit quality per joint, residual plots).
    #[arg(long, value_name = "FILE.html")]
    report: Option<PathBuf>,
    /// Write a copy of the URDF with the payload (+ OUT.json side file).
    #[arg(long)]
    write_urdf: Option<PathBuf>,
    /// Write an MJCF (MuJoCo) model of the arm as loaded with the payload welded to the last
    /// link (+ OUT.json side file).
    #[arg(long)]
    write_mjcf: Option<PathBuf>,
    /// How the payload goes into the URDF: a fixed child link of the tip, or merged into it.
    #[arg(long, value_enum, default_value = "link")]
    payload_as: PayloadAsArg,
    /// Standard deviation of each torque constant (N m/A; the forms of --torque-constant):
    /// added to the payload's uncertainty (independent errors).
    #[arg(long, allow_hyphen_values = true)]
    torque_constant_std: Option<String>,
    /// An `ivdyn gains --json` report: the gains it determined are the torque constants, and
    /// their covariance goes into the payload's uncertainty; the other joints take
    /// --torque-constant and --torque-constant-std.
    #[arg(long)]
    gains: Option<PathBuf>,
}

#[derive(Clone, Copy, ValueEnum)]
enum PayloadAsArg {
    Link,
    Merge,
}

#[derive(Args)]
struct SimulateArgs {
    #[command(flatten)]
    robot: RobotArgs,
    /// Trajectory CSV (columns t, <joint>.q; uniform times). Default: random Fourier excitation.
    #[arg(long)]
    traj: Option<PathBuf>,
    /// Duration of the built-in excitation (s).
    #[arg(long, default_value_t = 20.0)]
    duration: f64,
    /// Sample rate of the built-in excitation (Hz).
    #[arg(long, default_value_t = 500.0)]
    rate: f64,
    /// Seed of the excitation and the noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Peak amplitude of the excitation per joint (rad).
    #[arg(long, default_value_t = 0.8)]
    amplitude: f64,
    /// Output log (.mcap or .csv).
    #[arg(long)]
    out: PathBuf,
    /// Payload mass (kg) on the last link.
    #[arg(long)]
    payload_mass: Option<f64>,
    /// Payload COM x,y,z (m) in the last link's frame.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    payload_com: Option<Vec<f64>>,
    /// Payload inertia about its COM Ixx,Ixy,Ixz,Iyy,Iyz,Izz (kg m^2, URDF attribute order).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    payload_inertia: Option<Vec<f64>>,
    /// Coulomb friction per joint (comma separated).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    fc: Option<Vec<f64>>,
    /// Viscous friction per joint (comma separated).
    #[arg(long, value_delimiter = ',')]
    fv: Option<Vec<f64>>,
    /// Torque noise standard deviation (N m).
    #[arg(long, default_value_t = 0.0)]
    noise: f64,
    /// Position noise standard deviation (rad).
    #[arg(long, default_value_t = 0.0)]
    noise_q: f64,
    /// Encoder resolution in bits per turn (position quantisation).
    #[arg(long)]
    encoder_bits: Option<u32>,
    /// Torque quantisation step (N m).
    #[arg(long)]
    tau_resolution: Option<f64>,
    /// Leave the velocity arrays empty (as drives that publish positions only).
    #[arg(long)]
    no_velocity: bool,
    /// Record the noise-free torque as the actuator command (MCAP topic /ivdyn/command, CSV <joint>.u).
    #[arg(long)]
    command: bool,
    /// JSON summary of what was simulated.
    #[arg(long)]
    json: Option<PathBuf>,
}

#[path = "cmd/diagnose.rs"]
mod diagnose_cmd;
#[path = "cmd/fleet.rs"]
mod fleet_cmd;
#[path = "cmd/gains.rs"]
mod gains_cmd;
#[derive(Args)]
struct ExciteArgs {
    #[command(flatten)]
    robot: RobotArgs,
    /// Duration of the written trajectory (s).
    #[arg(long, default_value_t = 20.0)]
    duration: f64,
    /// Number of harmonics (>= 2).
    #[arg(long, default_value_t = 5)]
    harmonics: usize,
    /// Fundamental frequency (Hz); the trajectory repeats every 1/f0 s.
    #[arg(long, default_value_t = 0.1)]
    f0: f64,
    /// Sample rate of the written trajectory (Hz).
    #[arg(long, default_value_t = 100.0)]
    rate: f64,
    /// Criterion: minimise the condition number, or maximise log det of the information matrix.
    #[arg(long, value_enum, default_value = "cond")]
    criterion: CriterionArg,
    /// Acceleration limit (rad/s^2), one value or one per joint (URDF has none).
    #[arg(long, value_delimiter = ',', default_value = "5")]
    acc_limit: Vec<f64>,
    /// Velocity limit (rad/s) replacing the URDF's, one value or one per joint.
    #[arg(long, value_delimiter = ',')]
    vel_limit: Option<Vec<f64>>,
    /// Safety margin: fraction by which every limit is shrunk.
    #[arg(long, default_value_t = 0.01)]
    margin: f64,
    /// Random starts of the optimiser.
    #[arg(long, default_value_t = 6)]
    starts: usize,
    /// L-BFGS iterations per start.
    #[arg(long, default_value_t = 150)]
    iterations: usize,
    /// Random trajectories for the comparison.
    #[arg(long, default_value_t = 20)]
    random: usize,
    /// Seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Output CSV (t, <joint>.q, .qd, .qdd).
    #[arg(long)]
    out: PathBuf,
    /// Output MCAP (/joint_states: position and velocity).
    #[arg(long)]
    out_mcap: Option<PathBuf>,
    /// JSON report (criteria, random comparison, coefficients).
    #[arg(long)]
    json: Option<PathBuf>,
}

#[derive(Clone, Copy, ValueEnum)]
enum CriterionArg {
    Cond,
    Logdet,
}

type R<T> = Result<T, String>;

fn main() -> ExitCode {
    let cli = Cli::parse();
    signals::install();
    let bars = Bars::new(cli.quiet);
    let r = match cli.cmd {
        Cmd::Identify(a) => identify(a, &bars),
        Cmd::Payload(a) => payload(a, &bars),
        Cmd::Gains(a) => gains_cmd::run(a, &bars),
        Cmd::Simulate(a) => simulate(a, &bars),
        Cmd::Diagnose(a) => diagnose_cmd::run(a, &bars),
        Cmd::Excite(a) => excite(a, &bars),
        Cmd::Fleet(a) => fleet_cmd::run(a),
    };
    if signals::stopping() {
        // the handler removes the staged files and exits with 130/143
        loop {
            std::thread::park();
        }
    }
    // the job has written its files by now; a closed or full stdout only changes the code
    let out_failed = stdout::finish();
    match r {
        Ok(code) => match out_failed {
            // a job's own failure code (2: not identifiable) says more than a lost summary
            Some(_) if code != ExitCode::SUCCESS => code,
            None => code,
            Some(m) => {
                if !m.is_empty() {
                    eprintln!("{m}");
                }
                ExitCode::from(stdout::EXIT_STDOUT)
            }
        },
        Err(e) => {
            let line = e.replace('\n', " ");
            eprintln!("ivdyn: error: {line}");
            ExitCode::from(1)
        }
    }
}

// ------------------------------------------------------------------------ progress

#[derive(Clone)]
struct Bars {
    quiet: bool,
    cur: Arc<Mutex<Option<ProgressBar>>>,
}

impl Bars {
    fn new(quiet: bool) -> Self {
        Bars { quiet, cur: Arc::new(Mutex::new(None)) }
    }
    fn sink(&self) -> ivdyn::progress::ProgressSink {
        if self.quiet { None } else { Some(Arc::new(self.clone())) }
    }
}

impl Progress for Bars {
    fn begin(&self, stage: &str, total: u64) {
        let pb = if total > 0 {
            let pb = ProgressBar::new(total);
            pb.set_style(
                ProgressStyle::with_template("{msg:24} [{bar:30}] {pos}/{len} samples ({per_sec}, eta {eta})")
                    .unwrap_or_else(|_| ProgressStyle::default_bar())
                    .progress_chars("=> "),
            );
            pb
        } else {
            let pb = ProgressBar::new_spinner();
            pb.enable_steady_tick(std::time::Duration::from_millis(120));
            pb
        };
        pb.set_message(stage.to_string());
        if let Ok(mut c) = self.cur.lock() {
            *c = Some(pb);
        }
    }
    fn advance(&self, n: u64) {
        if let Ok(c) = self.cur.lock()
            && let Some(pb) = c.as_ref()
        {
            pb.inc(n);
        }
    }
    fn end(&self) {
        if let Ok(mut c) = self.cur.lock()
            && let Some(pb) = c.take()
        {
            pb.finish_and_clear();
        }
    }
}

// ------------------------------------------------------------------------ helpers

/// An `ivdyn` error as the command line says it: options by their flag (`--payload-mass`).
fn msg(e: ivdyn::Error) -> String {
    match e {
        ivdyn::Error::Option { option, msg } => {
            let flags: Vec<String> = option.split('/').map(|o| format!("--{}", o.replace('_', "-"))).collect();
            format!("{} {msg}", flags.join("/"))
        }
        ivdyn::Error::InFile { file, source } => format!("{}: {}", file.display(), msg(*source)),
        ivdyn::Error::During { step, source } => format!("{step}: {}", msg(*source)),
        e => e.to_string(),
    }
}

fn robot_source(a: &RobotArgs) -> RobotSource {
    RobotSource {
        urdf: a.urdf.clone(),
        base: a.base.clone(),
        tip: a.tip.clone(),
        fuse_beyond_tip: a.fuse_beyond_tip,
        params: a.params.clone(),
    }
}

fn load_robot(a: &RobotArgs) -> R<Robot> {
    let src = robot_source(a);
    let robot = src.load().map_err(msg)?;
    if let Some(side) = src.side_file() {
        eprintln!("note: applied the side file {}", side.display());
    }
    // on stdout with the results: stderr is for the one-line error
    for n in robot.chain_notes() {
        say!("note: {n}");
    }
    Ok(robot)
}

fn log_source(la: &LogArgs, command_topic: Option<&str>) -> R<LogSource> {
    let per_joint = |option: &str, v: &Option<String>| v.as_deref().map(|t| PerJoint::parse(option, t)).transpose();
    let torque_constants = TorqueConstants {
        torque_constant: per_joint("torque_constant", &la.torque_constant).map_err(msg)?,
        gear_ratio: per_joint("gear_ratio", &la.gear_ratio).map_err(msg)?,
        motor_constant: per_joint("motor_constant", &la.motor_constant).map_err(msg)?,
    };
    Ok(LogSource {
        topic: la.topic.clone(),
        command_topic: command_topic.map(str::to_string),
        log_time: la.log_time,
        current_topic: la.current_topic.clone(),
        effort: match la.effort {
            EffortArg::Auto => Effort::Auto,
            EffortArg::Torque => Effort::Torque,
            EffortArg::Current => Effort::Current,
        },
        torque_constants,
    })
}

fn condition_opts(la: &LogArgs, cutoff: Option<f64>) -> R<ivdyn::prep::ConditionOptions> {
    use ivdyn::prep::VelocitySource;
    let mut c = ivdyn::prep::ConditionOptions::default();
    if let Some(fc) = cutoff {
        c.diff = ivdyn::dsp::DiffMethod::Butterworth { order: ivdyn::dsp::DEFAULT_ORDER, cutoff_hz: Some(fc) };
    }
    c.velocity = match la.velocity {
        VelocityArg::Auto => VelocitySource::Auto,
        VelocityArg::Log => VelocitySource::Log,
        VelocityArg::Positions => VelocitySource::Positions,
    };
    c.window = la.window.as_deref().map(ivdyn::prep::hygiene::parse_window).transpose().map_err(msg)?;
    c.exclude = la
        .exclude
        .iter()
        .map(|s| ivdyn::prep::hygiene::parse_span(s, "exclude"))
        .collect::<ivdyn::error::Result<_>>()
        .map_err(msg)?;
    Ok(c)
}

/// `--payload-inertia` is given in URDF attribute order (Ixx,Ixy,Ixz,Iyy,Iyz,Izz, as the JSON
/// reports write it); the library takes ivdyn's order. A list that is not 6 long is passed on
/// unchanged for the library to refuse with its message.
fn payload_inertia_arg(urdf: Option<&[f64]>) -> Option<Vec<f64>> {
    urdf.map(|v| <[f64; 6]>::try_from(v).map_or_else(|_| v.to_vec(), |u| ivdyn::core::inertia_from_urdf(u).to_vec()))
}

fn fmt_list(v: &[f64], prec: usize) -> String {
    v.iter().map(|x| format!("{x:.prec$}")).collect::<Vec<_>>().join(", ")
}

fn print_written(lines: &[String]) {
    for l in lines {
        say!("{l}");
    }
}

// ------------------------------------------------------------------------ identify

fn identify(a: IdentifyArgs, bars: &Bars) -> R<ExitCode> {
    let robot = load_robot(&a.robot)?;
    let friction: Vec<&str> = a.friction.iter().map(|f| f.name()).collect();
    let drive = ivdyn::ident::DriveTerms::from_names(&friction, !a.no_armature, !a.no_offset).map_err(msg)?;
    let opts = IdentifyOptions {
        method: match a.method {
            MethodArg::Ols => Method::Ols,
            MethodArg::Wls => Method::Wls,
            MethodArg::Iv => Method::Iv,
            MethodArg::IdimIv => Method::IdimIv,
        },
        condition: condition_opts(&a.log_args, a.filter.cutoff)?,
        decimate: a.filter.decimate,
        validation_fraction: a.holdout,
        drive,
        coulomb: ivdyn::app::identify::CoulombMode::from_name(&a.coulomb).map_err(msg)?,
        progress: bars.sink(),
        consistent: a.consistent,
        ..Default::default()
    };
    let job = IdentifyJob {
        log: LogInput::File(a.log[0].clone()),
        also: a.log[1..].iter().cloned().map(LogInput::File).collect(),
        validate: a.validate.clone().map(LogInput::File),
        source: log_source(&a.log_args, a.command_topic.as_deref())?,
        in_memory: a.in_memory,
        stream: a.stream,
        opts,
        outputs: app::IdentifyOutputs {
            json: a.json.clone(),
            params: a.out_params.clone(),
            urdf: a.write_urdf.clone().map(|o| (a.robot.urdf.clone(), o)),
            mcap: a.out_mcap.clone(),
            mjcf: a.write_mjcf.clone(),
            report: a.report.clone(),
        },
    };
    let out = app::identify_job(&robot, &job).map_err(msg)?;
    print_identify(&robot, &out.report);
    print_written(&out.written);
    Ok(ExitCode::SUCCESS)
}

fn print_identify(robot: &Robot, rep: &app::IdentifyReport) {
    if let Some(fit) = &rep.fit_report {
        say!(
            "robot '{}', {} joints, {} samples at {:.1} Hz (filter {:.1} Hz), method {}",
            robot.name,
            robot.dof(),
            rep.fit.samples,
            rep.sample_rate_hz,
            rep.filter_cutoff_hz,
            rep.method
        );
        if let Some(i) = &rep.instrument {
            say!("instrument: {i}");
        }
        say!();
        say!(
            "{} fit: {} rows, rank {}/{}, sigma2 = {:.4e}, cond = {:.3e}",
            fit.method,
            fit.rows,
            fit.rank,
            fit.theta.len(),
            fit.sigma2,
            fit.condition_number
        );
        say!("  {:>3}  {:>13}  {:>10}  {:>8}  {:>13}  base parameter", "#", "value", "std", "rel %", "nominal");
        for (i, b) in rep.base.iter().enumerate() {
            let name = if b.name.chars().count() > 70 {
                format!("{}...", b.name.chars().take(67).collect::<String>())
            } else {
                b.name.clone()
            };
            say!(
                "  {i:>3}  {:>13.6e}  {:>10.3e}  {:>8.2}  {:>13.6e}  {name}",
                b.value,
                b.std,
                b.rel_std_pct,
                b.nominal
            );
        }
        if !rep.unexcited.is_empty() {
            say!("  not excited (left at nominal): {}", rep.unexcited.join(", "));
        }
    }
    say!();
    say!("fit quality per joint ({}):", rep.fit.data);
    print_quality(&rep.joints, &rep.fit);
    if let Some(v) = &rep.validation {
        say!("validation ({}, {} samples):", v.data, v.samples);
        print_quality(&rep.joints, v);
    }
    match &rep.dwh {
        Some(d) => say!("LS vs IV (Durbin-Wu-Hausman): H = {:.3}, dof {}: {}", d.statistic, d.dof, d.verdict),
        None => say!("LS vs IV: not tested"),
    }
    for n in &rep.notes {
        say!("note: {n}");
    }
    if rep.physical.consistent {
        say!("identified full parameters (nominal + base correction) are physically consistent");
    } else {
        say!("identified full parameters (nominal + base correction) are NOT physically consistent:");
        for l in rep.physical.lines() {
            say!("  {l}");
        }
    }
    if let Some(c) = &rep.consistent {
        print_consistent(&rep.joints, c);
    }
}

fn print_consistent(joints: &[String], c: &ivdyn::ident::consistent::ConsistentReport) {
    let (r, k) = (&c.result, &c.result.cost);
    let verdict = if r.check.consistent {
        "physically consistent".to_string()
    } else {
        format!("still inconsistent: {}", r.check.lines().join("; "))
    };
    say!(
        "consistent fit ({} LM iterations{}): weighted RSS {:.6e} -> {:.6e} (+{:.3}%), {}",
        k.iterations,
        if k.converged { "" } else { ", NOT converged" },
        k.rss_ls,
        k.rss,
        100.0 * k.rss_increase,
        verdict
    );
    say!("  {} unidentifiable directions pulled toward the nominal parameters", k.regularised_directions);
    say!("fit quality per joint with the consistent parameters:");
    print_quality(joints, &c.fit);
    if let Some(v) = &c.validation {
        say!("validation with the consistent parameters ({}):", v.data);
        print_quality(joints, v);
    }
}

fn print_quality(joints: &[String], q: &ivdyn::report::Quality) {
    let w = joints.iter().map(|j| j.len()).max().unwrap_or(5).max(5);
    say!("  {:<w$}  {:>12}  {:>12}  {:>8}", "joint", "rms [N m]", "tau rms", "R^2");
    for (i, j) in joints.iter().enumerate() {
        say!("  {:<w$}  {:>12.4e}  {:>12.4e}  {:>8.5}", j, q.rms[i], q.tau_rms[i], q.r2[i]);
    }
}

// ------------------------------------------------------------------------ payload

fn payload(a: PayloadArgs, bars: &Bars) -> R<ExitCode> {
    let robot = load_robot(&a.robot)?;
    let mode = match a.payload_as {
        PayloadAsArg::Link => app::PayloadMode::Link,
        PayloadAsArg::Merge => app::PayloadMode::Merge,
    };
    let job = app::PayloadJob {
        log: LogInput::File(a.log.clone()),
        before: a.before.clone().map(LogInput::File),
        source: log_source(&a.log_args, None)?,
        opts: PayloadOptions {
            condition: condition_opts(&a.log_args, a.filter.cutoff)?,
            decimate: a.filter.decimate,
            progress: bars.sink(),
            ..Default::default()
        },
        json: a.json.clone(),
        report: a.report.clone(),
        urdf: a.write_urdf.clone().map(|o| (a.robot.urdf.clone(), o, mode)),
        mjcf: a.write_mjcf.clone(),
        torque_constant_prior: torque_constant_prior(&a)?,
    };
    let out = app::payload_job(&robot, &job).map_err(msg)?;
    let rep = &out.report;
    print_payload(rep);
    print_written(&out.written);
    if !rep.identifiable {
        let names: Vec<&str> = rep.not_identifiable.iter().map(|h| h.parameter.as_str()).collect();
        eprintln!("ivdyn: error: payload not identifiable from {}: {}", a.log.display(), names.join(", "));
        return Ok(ExitCode::from(2));
    }
    Ok(ExitCode::SUCCESS)
}

/// `--torque-constant-std` and `--gains` of `payload`.
fn torque_constant_prior(a: &PayloadArgs) -> R<app::TorqueConstantPrior> {
    let std = a.torque_constant_std.as_deref().map(|t| PerJoint::parse("torque_constant_std", t)).transpose();
    let gains_report = match &a.gains {
        Some(p) => Some(std::fs::read_to_string(p).map_err(|e| format!("--gains {}: {e}", p.display()))?),
        None => None,
    };
    Ok(app::TorqueConstantPrior { std: std.map_err(msg)?, gains_report })
}

fn print_payload(rep: &app::PayloadReport) {
    say!(
        "payload on link '{}' (COM and inertia in its frame), nominal model: {}, {} samples",
        rep.link,
        rep.nominal,
        rep.samples
    );
    if rep.identifiable {
        let (m, ms) = (rep.mass.unwrap_or(f64::NAN), rep.mass_std.unwrap_or(f64::NAN));
        let (c, cs) = (rep.com.unwrap_or([f64::NAN; 3]), rep.com_std.unwrap_or([f64::NAN; 3]));
        // printed in URDF order, as the JSON report has it
        let urdf = |x: Option<[f64; 6]>| ivdyn::core::inertia_to_urdf(x.unwrap_or([f64::NAN; 6]));
        let (i, is) = (urdf(rep.inertia), urdf(rep.inertia_std));
        say!("  mass     {m:.4} kg  (std {ms:.2e})");
        say!(
            "  com      [{}] m  (std [{}])",
            fmt_list(&c, 4),
            cs.iter().map(|x| format!("{x:.1e}")).collect::<Vec<_>>().join(", ")
        );
        say!("  inertia  [{}] kg m^2 about the COM (Ixx, Ixy, Ixz, Iyy, Iyz, Izz)", fmt_list(&i, 5));
        say!("           std [{}]", fmt_list(&is, 5));
        say!("  the std cover: {}", rep.uncertainty_sources.join(", "));
        match &rep.physical {
            Some(ph) if ph.ls_possible => {
                say!("  physical the least-squares payload is a rigid body (reported as fitted)")
            }
            Some(ph) => say!(
                "  physical the least-squares payload is NOT a rigid body; reported: the nearest one (squared Mahalanobis distance {:.3}, p = {:.3})",
                ph.mahalanobis2,
                ph.p_value
            ),
            None => {}
        }
    } else {
        say!("  the payload is NOT identifiable from this log:");
        for h in &rep.not_identifiable {
            say!("    {} (part of: {})", h.parameter, h.combined_in);
        }
    }
    say!(
        "  residual rms per joint before [{}] N m, after [{}] N m",
        fmt_list(&rep.rms_before, 4),
        fmt_list(&rep.rms_after, 4)
    );
    if let Some(c) = &rep.before_check {
        say!(
            "  before log fits this log: {} (variance ratio after/before per joint [{}], critical {:.3})",
            if c.fits { "yes" } else { "NO" },
            fmt_list(&c.variance_ratio, 3),
            c.critical_ratio
        );
    }
    for n in &rep.notes {
        say!("note: {n}");
    }
}

// ------------------------------------------------------------------------ simulate

fn simulate(a: SimulateArgs, bars: &Bars) -> R<ExitCode> {
    let robot = load_robot(&a.robot)?;
    let payload = PayloadSpec::from_parts(
        a.payload_mass,
        a.payload_com.as_deref(),
        payload_inertia_arg(a.payload_inertia.as_deref()).as_deref(),
    )
    .map_err(msg)?;
    let opts = SimulateOptions {
        rate_hz: a.rate,
        duration_s: a.duration,
        seed: a.seed,
        amplitude: a.amplitude,
        payload,
        fc: a.fc.clone(),
        fv: a.fv.clone(),
        noise_tau: a.noise,
        noise_q: a.noise_q,
        encoder_bits: a.encoder_bits,
        tau_resolution: a.tau_resolution,
        write_velocity: !a.no_velocity,
        write_command: a.command,
        ..Default::default()
    };
    let traj = match &a.traj {
        None => Trajectory::Fourier,
        Some(p) => Trajectory::from_csv(p, &robot).map_err(msg)?,
    };
    let job = app::SimulateJob { opts, traj, out: Some(a.out.clone()), json: a.json.clone() };
    let out = app::simulate_job(&robot, &job, &bars.sink()).map_err(msg)?;
    print_written(&out.written);
    Ok(ExitCode::SUCCESS)
}

// ------------------------------------------------------------------------ excite

fn excite(a: ExciteArgs, bars: &Bars) -> R<ExitCode> {
    use ivdyn::excite::{Criterion, ExciteOptions};
    let robot = load_robot(&a.robot)?;
    let opts = ExciteOptions {
        duration_s: a.duration,
        harmonics: a.harmonics,
        f0_hz: a.f0,
        rate_hz: a.rate,
        criterion: match a.criterion {
            CriterionArg::Cond => Criterion::Cond,
            CriterionArg::Logdet => Criterion::Logdet,
        },
        acc_limit: a.acc_limit.clone(),
        vel_limit: a.vel_limit.clone(),
        margin: a.margin,
        starts: a.starts,
        iterations: a.iterations,
        random_draws: a.random,
        seed: a.seed,
        progress: bars.sink(),
        ..Default::default()
    };
    let job = app::ExciteJob { opts, csv: Some(a.out.clone()), mcap: a.out_mcap.clone(), json: a.json.clone() };
    let out = app::excite_job(&robot, &job).map_err(|e| format!("{}: {}", a.robot.urdf.display(), msg(e)))?;
    let rep = &out.report;
    say!(
        "robot '{}', {} joints, {} base parameters, {} harmonics of {} Hz, {} s at {} Hz",
        rep.robot,
        rep.joints.len(),
        rep.base_count,
        rep.harmonics,
        rep.f0_hz,
        rep.duration_s,
        rep.rate_hz
    );
    say!("  optimised ({:?}): cond = {:.4e}, log det = {:.4}", rep.criterion, rep.optimised.cond, rep.optimised.logdet);
    say!(
        "  random Fourier ({} draws, same harmonics and bounds): median cond = {:.4e} (best {:.4e}), median log det = {:.4}",
        rep.random.draws,
        rep.random.cond_median,
        rep.random.cond_min,
        rep.random.logdet_median
    );
    say!("  condition number {:.1}x better than the random median", rep.cond_improvement);
    say!(
        "  peak |qd| / limit per joint [{}], peak |qdd| / limit [{}]",
        fmt_list(&rep.velocity_use, 3),
        fmt_list(&rep.acceleration_use, 3)
    );
    for n in &rep.notes {
        say!("note: {n}");
    }
    print_written(&out.written);
    Ok(ExitCode::SUCCESS)
}

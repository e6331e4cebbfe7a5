//! drive-bench: compares commutation strategies on the built-in motor (see the README).

use bldc_drive::DriveConfig;
use bldc_drive::bench::{self, Plan, calibrate, pool, range, report};
use bldc_drive::scenario::{self, Scenario, TraceRow, TraceSpec};
use bldc_drive::strategies::{PluginLibrary, StrategyName};
use clap::{Args, Parser, Subcommand};
use std::io::{BufWriter, IsTerminal, Write};
use std::path::{Path, PathBuf};

/// Compares sensorless commutation strategies on a simulated BLDC drive. Without a
/// subcommand it runs the standard comparison and writes a report folder.
#[derive(Parser)]
#[command(name = "drive-bench", version)]
struct Cli {
    #[command(subcommand)]
    cmd: Option<Cmd>,
    /// Loads a strategy plugin (a shared library built against strategy-abi); its
    /// strategy is listed, runnable by name, and added to the comparison. Repeatable.
    #[arg(long, global = true)]
    plugin: Vec<PathBuf>,
    #[command(flatten)]
    compare: CompareArgs,
}

#[derive(Args)]
struct CompareArgs {
    /// Report folder to write [default: drive-bench-report].
    #[arg(long)]
    out: Option<PathBuf>,
    /// TOML config overriding the built-in motor, power stage, sensing and control.
    #[arg(long)]
    config: Option<PathBuf>,
    /// Worker threads (default: every core).
    #[arg(long, value_parser = clap::value_parser!(u16).range(1..=256))]
    threads: Option<u16>,
    /// A short comparison: one grid speed, no range search (for smoke tests).
    #[arg(long)]
    quick: bool,
}

#[derive(Subcommand)]
enum Cmd {
    /// Runs one scenario from standstill and prints its verdict and summary.
    ///
    /// The verdict is judged from the true rotor, not from what the controller believes,
    /// and sets the exit status: 0 running, 3 off-speed, 4 lost-sync, 5 stalled,
    /// 6 not-started, 7 gave-up, 8 non-finite (1: an error, 2: a bad command line).
    Run(RunArgs),
    /// Finds the lowest speed a strategy holds after being turned down and the highest it
    /// reaches from standstill, each judged by the verdict, with a 24-bit speed meter (one
    /// that does not bind) and with the published 15-bit one.
    Range {
        /// Strategy name (see `drive-bench list`).
        #[arg(long)]
        strategy: String,
        /// TOML config.
        #[arg(long)]
        config: Option<PathBuf>,
        /// Writes the result as JSON.
        #[arg(long)]
        json: Option<PathBuf>,
    },
    /// Calibrates the LM guard's speeds for the config's motor: ωm, the lowest speed a 1°
    /// window holds, and ωM, the speed from which the full window (strategy.linear_region_deg)
    /// is needed, each found with fixed-window (ND) runs judged by the verdict; prints the
    /// `[strategy]` lines to paste.
    CalibrateLm {
        /// TOML config (its motor and drive; the strategy name is ignored).
        #[arg(long)]
        config: Option<PathBuf>,
        /// Writes the result, with every run, as JSON.
        #[arg(long)]
        json: Option<PathBuf>,
    },
    /// Lists the strategies.
    List,
    /// Prints the default config (every key, documented in the crate docs).
    Config,
}

#[derive(Args)]
#[command(allow_negative_numbers = true)]
struct RunArgs {
    /// Strategy name (see `drive-bench list`).
    #[arg(long)]
    strategy: String,
    /// Speed command \[rpm\].
    #[arg(long)]
    speed_rpm: f64,
    /// Simulated time \[s\]; steady state is the last third.
    #[arg(long, default_value_t = 3.0)]
    duration_s: f64,
    /// Load torque on the shaft from t = 0 [N·m].
    #[arg(long, default_value_t = 0.0)]
    load_nm: f64,
    /// TOML config.
    #[arg(long)]
    config: Option<PathBuf>,
    /// Seed of the comparator noise (overrides `sensing.seed`).
    #[arg(long)]
    seed: Option<u64>,
    /// Writes a trace (CSV) of the whole run.
    #[arg(long)]
    trace: Option<PathBuf>,
    /// Trace sampling period \[µs\].
    #[arg(long, default_value_t = 10.0)]
    trace_every_us: f64,
    /// Writes the summary as JSON.
    #[arg(long)]
    json: Option<PathBuf>,
}

fn main() {
    let cli = Cli::parse();
    match run(cli) {
        Ok(0) => {}
        Ok(code) => std::process::exit(code),
        Err(e) => {
            eprintln!("drive-bench: error: {e}");
            std::process::exit(1);
        }
    }
}

/// A strategy chosen by name: built in, or from a loaded plugin.
enum Chosen {
    Builtin(StrategyName),
    Plugin(PluginLibrary),
}

fn load_plugins(paths: &[PathBuf]) -> Result<Vec<PluginLibrary>, String> {
    paths
        .iter()
        .map(|p| PluginLibrary::load(p).map_err(|e| e.to_string()))
        .collect()
}

fn choose(name: &str, plugins: &[PluginLibrary]) -> Result<Chosen, String> {
    if let Some(p) = plugins.iter().find(|p| p.name() == name) {
        return Ok(Chosen::Plugin(p.clone()));
    }
    name.parse().map(Chosen::Builtin).map_err(|_| {
        let mut known: Vec<String> = StrategyName::ALL.iter().map(|n| n.to_string()).collect();
        known.extend(plugins.iter().map(|p| p.name().to_string()));
        format!(
            "unknown strategy `{name}` (rule: one of {})",
            known.join(", ")
        )
    })
}

/// Applies the choice to `cfg`, returning the plugin if there is one.
fn apply(chosen: Chosen, cfg: &mut DriveConfig) -> Option<PluginLibrary> {
    match chosen {
        Chosen::Builtin(n) => {
            cfg.strategy.name = n;
            None
        }
        Chosen::Plugin(p) => Some(p),
    }
}

fn run(cli: Cli) -> Result<i32, String> {
    let c = &cli.compare;
    if cli.cmd.is_some()
        && (c.out.is_some() || c.config.is_some() || c.threads.is_some() || c.quick)
    {
        return Err(
            "--out, --config, --threads and --quick before a subcommand belong to the comparison (rule: give a subcommand's own options after its name)".into(),
        );
    }
    let plugins = load_plugins(&cli.plugin)?;
    match cli.cmd {
        None => compare(cli.compare, plugins).map(|()| 0),
        Some(Cmd::Run(a)) => run_one(a, &plugins),
        Some(Cmd::Range {
            strategy,
            config,
            json,
        }) => {
            let mut cfg = load_config(config.as_deref())?;
            let plugin = apply(choose(&strategy, &plugins)?, &mut cfg);
            cfg.validate().map_err(|e| e.to_string())?;
            let mut found = Vec::new();
            for m in [range::Meter::WIDE, range::Meter::AS_PUBLISHED] {
                let r = range::search(&m.apply(&cfg), plugin.as_ref(), &strategy, m.label)
                    .map_err(|e| e.to_string())?;
                let bound = |rpm: Option<f64>, l: &Option<range::Limit>| {
                    let at = rpm.map_or("none".into(), |x| format!("{x:.0} rpm"));
                    match l {
                        Some(l) => {
                            format!("{at} (at {:.0} rpm: {}: {})", l.rpm, l.verdict, l.reason)
                        }
                        None => at,
                    }
                };
                println!(
                    "{}, meter {}: ({} runs)\n  floor {}\n  top {}",
                    r.strategy,
                    r.meter,
                    r.tried.len(),
                    bound(r.min_rpm, &r.min_limit),
                    bound(r.max_rpm, &r.max_limit),
                );
                if !r.gaps_rpm.is_empty() {
                    println!(
                        "  failed inside the range (not one interval): {:?} rpm",
                        r.gaps_rpm
                    );
                }
                found.push(r);
            }
            println!("criterion: {}", range::CRITERION);
            let r = found;
            if let Some(p) = json {
                write(&p, &to_json(&r)?)?;
            }
            Ok(0)
        }
        Some(Cmd::CalibrateLm { config, json }) => {
            let cfg = load_config(config.as_deref())?;
            calibrate_lm(&cfg, json.as_deref())
        }
        Some(Cmd::List) => {
            for n in StrategyName::ALL {
                println!("{n}");
            }
            for p in &plugins {
                println!(
                    "{}\t(plugin {}: {})",
                    p.name(),
                    p.path().display(),
                    p.description()
                );
            }
            Ok(0)
        }
        Some(Cmd::Config) => {
            print!("{}", DriveConfig::default().to_toml());
            Ok(0)
        }
    }
}

fn compare(a: CompareArgs, plugins: Vec<PluginLibrary>) -> Result<(), String> {
    let cfg = load_config(a.config.as_deref())?;
    let mut plan = Plan::default();
    if a.quick {
        plan.grid_rpm = vec![plan.trace_rpm];
        plan.ranges = false;
        plan.startup.0 = 0;
    }
    let threads = a.threads.map_or_else(pool::default_threads, usize::from);
    let mut variants = bench::standard_variants(&cfg.strategy);
    variants.extend(
        plugins
            .into_iter()
            .map(|p| bench::Variant::plugin(&cfg.strategy, p)),
    );
    let cmp = bench::compare(
        &cfg,
        variants,
        plan,
        threads,
        std::io::stderr().is_terminal(),
    )
    .map_err(|e| e.to_string())?;
    print!("{}", report::terminal_table(&cmp));
    let out = a.out.unwrap_or_else(|| PathBuf::from("drive-bench-report"));
    let files = report::write_folder(&cmp, &cfg, &out)
        .map_err(|e| format!("writing the report to {}: {e}", out.display()))?;
    println!(
        "report: {} ({} files)",
        out.join("report.md").display(),
        files.len()
    );
    Ok(())
}

fn run_one(a: RunArgs, plugins: &[PluginLibrary]) -> Result<i32, String> {
    let mut cfg = load_config(a.config.as_deref())?;
    let plugin = apply(choose(&a.strategy, plugins)?, &mut cfg);
    if let Some(seed) = a.seed {
        cfg.sensing.seed = seed;
    }
    let mut sc = Scenario::hold(cfg, a.speed_rpm, a.duration_s);
    sc.plugin = plugin;
    if a.load_nm != 0.0 || !a.load_nm.is_finite() {
        sc.load_steps.push((0.0, a.load_nm));
    }
    if a.trace.is_some() {
        sc.trace = Some(TraceSpec {
            every_s: a.trace_every_us * 1e-6,
            from_s: 0.0,
            to_s: a.duration_s,
        });
    }
    let mut trace = match &a.trace {
        Some(p) => {
            let f = std::fs::File::create(p).map_err(|e| format!("{}: {e}", p.display()))?;
            let mut w = BufWriter::new(f);
            writeln!(w, "{}", TraceRow::HEADER).map_err(|e| format!("{}: {e}", p.display()))?;
            Some((p, w))
        }
        None => None,
    };
    let mut write_err = None;
    let out = scenario::run(&sc, |row| {
        if let Some((_, w)) = trace.as_mut()
            && write_err.is_none()
            && let Err(e) = row.write_csv(w).and_then(|()| w.write_all(b"\n"))
        {
            write_err = Some(e);
        }
    })
    .map_err(|e| e.to_string())?;
    if let Some((p, mut w)) = trace {
        if let Some(e) = write_err.take().or_else(|| w.flush().err()) {
            return Err(format!("{}: {e}", p.display()));
        }
    }
    let s = &out.summary;
    let figures = format!(
        "mean {:.1} rpm, ripple {:.2} rpm, torque {:.4} mN·m ± {:.4}, I rms {:.4} A, commutation error {:+.2}° mean / {:.2}° max over {} commutations, {} restarts ({:.1}× real time)",
        s.speed_mean_rpm,
        s.speed_ripple_rpm,
        s.torque_mean_nm * 1e3,
        s.torque_ripple_nm * 1e3,
        s.current_rms_a,
        s.commutation_error_deg_mean,
        s.commutation_error_deg_max,
        s.commutations,
        s.restarts,
        s.realtime_factor
    );
    let figures = if s.verdict.is_running() {
        figures
    } else {
        format!("not a valid measurement (the drive failed): {figures}")
    };
    let text = format!(
        "{} at {:.0} rpm: {}: {}\n  {figures}\n",
        s.strategy, s.speed_ref_rpm, s.verdict, s.verdict_reason
    );
    // A reader that went away (`| head`) is not an error of the run: the verdict still
    // sets the exit status.
    let _ = std::io::stdout().lock().write_all(text.as_bytes());
    if let Some(p) = a.json {
        write(&p, &to_json(s)?)?;
    }
    Ok(s.verdict.exit_code())
}

fn calibrate_lm(cfg: &DriveConfig, json: Option<&Path>) -> Result<i32, String> {
    let c = calibrate::calibrate_lm(cfg, pool::default_threads()).map_err(|e| e.to_string())?;
    let limit = |l: &Option<range::Limit>| match l {
        Some(l) => format!("at {:.0} rpm: {}: {}", l.rpm, l.verdict, l.reason),
        None => "no failure on record".into(),
    };
    println!(
        "ωm = {} rpm: lowest speed held with a 1° window (limited {})",
        c.min_rpm,
        limit(&c.min_limit)
    );
    if c.full_window_needed {
        let full = match c.full_window_holds_at_limit {
            Some(true) => format!("; {}° keeps synchronism there", c.theta_max_deg),
            Some(false) => format!(
                "; {}° fails there too, so the width is not what fails",
                c.theta_max_deg
            ),
            None => String::new(),
        };
        println!(
            "ωM = {} rpm: highest speed a {}° window keeps in synchronism (limited {}{full})",
            c.max_rpm,
            c.narrower_deg,
            limit(&c.max_limit)
        );
    } else {
        println!(
            "ωM = {} rpm: a {}° window keeps synchronism up to the top speed the voltage allows (the true speed at a {:.0} rpm command), so {}° is never needed below it; ωM is that top speed",
            c.max_rpm,
            c.narrower_deg,
            range::SEARCH_MAX_RPM,
            c.theta_max_deg
        );
    }
    println!(
        "{} runs, {:.1} s; meter {}\ncriterion: {}",
        c.runs.len(),
        c.wall_s,
        c.meter,
        c.criterion
    );
    if let Some(p) = json {
        write(p, &to_json(&c)?)?;
    }
    match c.apply(cfg) {
        Ok(_) => {
            print!("\npaste into the config:\n{}", c.toml_lines());
            Ok(0)
        }
        Err(e) => Err(format!("the calibrated values cannot be used: {e}")),
    }
}

fn load_config(path: Option<&Path>) -> Result<DriveConfig, String> {
    let Some(p) = path else {
        return Ok(DriveConfig::default());
    };
    let text = std::fs::read_to_string(p).map_err(|e| format!("{}: {e}", p.display()))?;
    DriveConfig::from_toml(&text).map_err(|e| format!("{}: {e}", p.display()))
}

fn to_json<T: serde::Serialize>(v: &T) -> Result<String, String> {
    serde_json::to_string_pretty(v).map_err(|e| e.to_string())
}

fn write(p: &Path, text: &str) -> Result<(), String> {
    std::fs::write(p, text).map_err(|e| format!("{}: {e}", p.display()))
}

//! drive-bench: compares commutation strategies on the built-in motor (see the README).

use bldc_drive::DriveConfig;
use bldc_drive::bench::{
    self, Plan, calibrate, pool, range, report, sensitivity, sensitivity_report,
};
use bldc_drive::case::{Case, apply, choose};
use bldc_drive::plots;
use bldc_drive::scenario::{self, Outcome, Scenario, Summary, TraceRow, TraceSpec};
use bldc_drive::scenario_file::RunRecord;
use bldc_drive::strategies::{PluginLibrary, StrategyName};
use bldc_drive::sweep;
use bldc_drive::tune;
use bldc_drive::verdict::Verdict;
use clap::{Args, Parser, Subcommand};
use std::io::{BufWriter, IsTerminal, Write};
use std::path::{Path, PathBuf};

#[path = "drive-bench/outputs.rs"]
mod outputs;
use outputs::Output;

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
    /// holds after being turned up, each judged by the verdict, with a 24-bit speed meter (one
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
    /// Runs the cases of a sweep file on local threads and writes one row per case, in the
    /// file's order: its index, seed, inputs, verdict and summary. The file is a JSON list
    /// of case objects whose keys are this program's `run` options (strategy, speed_rpm,
    /// duration_s, load_nm, config, scenario, seed; config and scenario a path or a
    /// table). Case k runs with its own seed, else with seed k. Every case is checked
    /// before any runs.
    Sweep {
        /// The sweep file (JSON).
        file: PathBuf,
        /// Writes the rows as CSV (without --csv or --json: CSV on stdout).
        #[arg(long)]
        csv: Option<PathBuf>,
        /// Writes the rows as JSON: a list of objects with the CSV's columns.
        #[arg(long)]
        json: Option<PathBuf>,
        /// Worker threads (default: every core).
        #[arg(long, value_parser = clap::value_parser!(u16).range(1..=256))]
        threads: Option<u16>,
    },
    /// Picks the speed and current PI gains for the config's motor by the loop-design
    /// criterion (docs/chip.md, "Loop design": a phase margin of 50° and a gain margin of
    /// 10 dB at every speed of the range, the current loop's pole at 0.6), prints the
    /// margins per speed and the `[control]` lines; --write saves the whole config with them.
    Tune {
        /// TOML config (its motor, supply and control options; its gains are replaced).
        #[arg(long)]
        config: Option<PathBuf>,
        /// Lowest speed the gains must hold, in rpm.
        #[arg(long, default_value_t = 250.0)]
        from_rpm: f64,
        /// Highest speed, in rpm (default: 80 % of the motor's no-load speed).
        #[arg(long)]
        to_rpm: Option<f64>,
        /// Writes the config with the tuned gains (TOML) to this file.
        #[arg(long)]
        write: Option<PathBuf>,
        /// Writes the gains and margins as JSON.
        #[arg(long)]
        json: Option<PathBuf>,
    },
    /// The sensitivity study alone: for six-step-120, twelve-step-lm and twelve-step-df,
    /// each factor (PWM frequency, comparator filter mismatch and hysteresis, DF samples, LM
    /// ωm, meter periods and width, loop gains, friction) at a low and a high level, the
    /// floor (24-bit meter) and the low-band ripple at 1000 rpm; writes report.md,
    /// report.html, sensitivity.json and a tornado chart per strategy and measure.
    Sensitivity {
        /// TOML config: the baseline.
        #[arg(long)]
        config: Option<PathBuf>,
        /// Report folder to write (made if missing).
        #[arg(long, default_value = "drive-bench-sensitivity")]
        out: PathBuf,
        /// Worker threads (default: every core).
        #[arg(long, value_parser = clap::value_parser!(u16).range(1..=256))]
        threads: Option<u16>,
    },
    /// Lists the strategies.
    List,
    /// Prints the default config as TOML, every key with its unit, bounds and meaning as a
    /// comment (the FMU's variable table; the rules in full: the crate docs).
    Config,
}

#[derive(Args)]
#[command(allow_negative_numbers = true)]
struct RunArgs {
    /// A scenario file (TOML): duration, profiles of speed, load and supply, load model,
    /// config overrides (see examples/scenarios/). Replaces --speed-rpm, --duration-s and
    /// --load-nm; --strategy, --config and --seed still apply.
    #[arg(long, conflicts_with_all = ["speed_rpm", "duration_s", "load_nm"])]
    scenario: Option<PathBuf>,
    /// Strategy name (see `drive-bench list`; default: the config's `strategy.name`); with
    /// --scenario, overrides its strategy.
    #[arg(long)]
    strategy: Option<String>,
    /// Constant speed command, in rpm (default: the config's `control.speed_ref_rpm`).
    #[arg(long)]
    speed_rpm: Option<f64>,
    /// Simulated time, in s; steady state is the last third (default 3).
    #[arg(long)]
    duration_s: Option<f64>,
    /// A passive (Coulomb) load on the shaft, opposing motion, from t = 0, in N·m.
    #[arg(long)]
    load_nm: Option<f64>,
    /// TOML config: the drive the scenario runs on.
    #[arg(long)]
    config: Option<PathBuf>,
    /// Seed of the comparator noise (overrides `sensing.seed`).
    #[arg(long)]
    seed: Option<u64>,
    /// Writes a trace (CSV) to this file.
    #[arg(long)]
    trace: Option<PathBuf>,
    /// Trace sampling period, in µs.
    #[arg(long, default_value_t = 10.0)]
    trace_every_us: f64,
    /// First traced instant, in s.
    #[arg(long, default_value_t = 0.0)]
    trace_from_s: f64,
    /// Last traced instant, in s (default: the end of the run).
    #[arg(long)]
    trace_to_s: Option<f64>,
    /// Allows a trace larger than 1 GB (its expected size is printed before the run).
    #[arg(long)]
    large_trace: bool,
    /// Writes overview.svg (speeds with the command, duty, torque, current over the whole
    /// run) and zoom.svg (currents, voltages, commutation state, Z_d raw and guarded over
    /// the last electrical turns) into this folder, made if missing. Runs the scenario
    /// twice more, traced over each figure's window.
    #[arg(long)]
    plot: Option<PathBuf>,
    /// Writes the run as JSON: tool version, schema, the complete scenario (config
    /// included) and the summary.
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

fn load_plugins(paths: &[PathBuf]) -> Result<Vec<PluginLibrary>, String> {
    paths
        .iter()
        .map(|p| PluginLibrary::load(p).map_err(|e| e.to_string()))
        .collect()
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
        }) => range_cmd(&strategy, config.as_deref(), json, &plugins),
        Some(Cmd::CalibrateLm { config, json }) => {
            let cfg = load_config(config.as_deref())?;
            check_outputs(json.iter().map(|p| Output::file("--json", p)))?;
            calibrate_lm(&cfg, json.as_deref())
        }
        Some(Cmd::Sweep {
            file,
            csv,
            json,
            threads,
        }) => run_sweep(&file, csv, json, threads, &plugins).map(|()| 0),
        Some(Cmd::Sensitivity {
            config,
            out,
            threads,
        }) => sensitivity(config.as_deref(), &out, threads).map(|()| 0),
        Some(Cmd::List) => {
            list(&plugins);
            Ok(0)
        }
        Some(Cmd::Tune {
            config,
            from_rpm,
            to_rpm,
            write: out,
            json,
        }) => tune_cmd(config.as_deref(), from_rpm, to_rpm, out, json),
        Some(Cmd::Config) => {
            print!("{}", DriveConfig::default().to_toml_documented());
            Ok(0)
        }
    }
}

/// `drive-bench range`: the strategy's speed range with each meter, printed, and saved
/// as JSON if asked.
fn range_cmd(
    strategy: &str,
    config: Option<&Path>,
    json: Option<PathBuf>,
    plugins: &[PluginLibrary],
) -> Result<i32, String> {
    let mut cfg = load_config(config)?;
    let plugin = apply(choose(strategy, plugins).map_err(|e| e.0)?, &mut cfg);
    cfg.validate().map_err(|e| e.to_string())?;
    check_outputs(json.iter().map(|p| Output::file("--json", p)))?;
    let mut found = Vec::new();
    // The two meters' searches side by side.
    let meters = [range::Meter::WIDE, range::Meter::AS_PUBLISHED];
    let searched = pool::map(&meters, pool::default_threads(), Some("range"), |m| {
        range::search(&m.apply(&cfg), plugin.as_ref(), strategy, m.label)
    });
    for r in searched {
        let r = r.map_err(|e| e.to_string())?;
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

/// `drive-bench tune`: the speed loop's margins over the range, the tuned gains printed,
/// written as a config and saved as JSON if asked.
fn tune_cmd(
    config: Option<&Path>,
    from_rpm: f64,
    to_rpm: Option<f64>,
    out: Option<PathBuf>,
    json: Option<PathBuf>,
) -> Result<i32, String> {
    let cfg = load_config(config)?;
    check_outputs(
        (out.iter().map(|p| Output::file("--write", p)))
            .chain(json.iter().map(|p| Output::file("--json", p))),
    )?;
    let to_rpm = match to_rpm {
        Some(r) => r,
        None => {
            0.8 * tune::LoopModel::new(&cfg)
                .map_err(|e| e.to_string())?
                .no_load_rpm()
        }
    };
    let t = tune::tune(&cfg, from_rpm, to_rpm).map_err(|e| e.to_string())?;
    // A closed stdout (a pager quit) ends the listing, not the program.
    let mut o = std::io::stdout().lock();
    let _ = writeln!(
        o,
        "    rpm   duty  k'  current pole  crossover rad/s  phase margin °  gain margin dB"
    );
    for m in &t.margins {
        let opt = |x: Option<f64>| x.map_or("-".into(), |v| format!("{v:.1}"));
        let _ = writeln!(
            o,
            "{:7.0} {:6.3} {:3} {:13.3} {:>16} {:>15} {:>15}",
            m.rpm,
            m.duty,
            m.meter_periods,
            m.current_pole,
            opt(m.crossover_rad_s),
            opt(m.phase_margin_deg),
            opt(m.gain_margin_db)
        );
    }
    let _ = write!(o, "{}", t.to_toml());
    if let Some(p) = &out {
        write(p, &t.apply(&cfg).to_toml())?;
    }
    if let Some(p) = &json {
        write(p, &to_json(&t)?)?;
    }
    Ok(0)
}

/// `drive-bench list`: the built-in strategies, then the plugins'.
fn list(plugins: &[PluginLibrary]) {
    for n in StrategyName::ALL {
        println!("{n}");
    }
    for p in plugins {
        println!(
            "{}\t(plugin {}: {})",
            p.name(),
            p.path().display(),
            p.description()
        );
    }
}

fn compare(a: CompareArgs, plugins: Vec<PluginLibrary>) -> Result<(), String> {
    let cfg = load_config(a.config.as_deref())?;
    let mut plan = Plan::default();
    if a.quick {
        plan.grid_rpm = vec![plan.trace_rpm];
        plan.ranges = false;
        plan.startup.0 = 0;
        plan.spectrum_rpm = vec![plan.trace_rpm];
        plan.drift = false;
        plan.sensitivity.clear();
    }
    let threads = a.threads.map_or_else(pool::default_threads, usize::from);
    // The report folder is made before minutes of work, not after.
    let out = a.out.unwrap_or_else(|| PathBuf::from("drive-bench-report"));
    let folder = Output::folder("--out", &out);
    let report = folder.inside("report.md");
    check_outputs([folder, report])?;
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
    let files = report::write_folder(&cmp, &cfg, &out)
        .map_err(|e| format!("writing the report to {}: {e}", out.display()))?;
    println!(
        "report: {} ({} files)",
        out.join("report.md").display(),
        files.len()
    );
    Ok(())
}

fn sensitivity(config: Option<&Path>, out: &Path, threads: Option<u16>) -> Result<(), String> {
    let cfg = load_config(config)?;
    let threads = threads.map_or_else(pool::default_threads, usize::from);
    let studied = sensitivity::strategies(&cfg.strategy, &sensitivity::STRATEGIES);
    // Every level's config checked before anything is made or run.
    sensitivity::jobs(&cfg, &studied).map_err(|e| e.to_string())?;
    let folder = Output::folder("--out", out);
    let report = folder.inside("report.md");
    check_outputs([folder, report])?;
    let wall = std::time::Instant::now();
    let points = sensitivity::study(&cfg, &studied, threads, std::io::stderr().is_terminal())?;
    let labels: Vec<String> = studied.into_iter().map(|s| s.0).collect();
    let files = sensitivity_report::write_folder(&points, &labels, &cfg, out)
        .map_err(|e| format!("writing the report to {}: {e}", out.display()))?;
    println!(
        "sensitivity: {} jobs in {:.1} s on {threads} threads; report: {} ({} files)",
        points.len(),
        wall.elapsed().as_secs_f64(),
        out.join("report.md").display(),
        files.len()
    );
    Ok(())
}

fn run_one(a: RunArgs, plugins: &[PluginLibrary]) -> Result<i32, String> {
    // Everything is checked before any file is touched or any time simulated.
    let sc = run_scenario(&a, plugins)?;
    check_run_outputs(&a)?;
    let out = simulate(&sc, a.trace.as_deref())?;
    let s = &out.summary;
    let text = run_text(&sc, s);
    // A reader that went away (`| head`) is not an error of the run: the verdict still
    // sets the exit status.
    let _ = std::io::stdout().lock().write_all(text.as_bytes());
    if let Some(p) = a.json {
        write(&p, &RunRecord::of(&sc, s.clone()).to_json())?;
    }
    if let Some(d) = &a.plot {
        let mut untraced = sc.clone();
        untraced.trace = None;
        for (name, svg) in plots::scenario_plots(&untraced, s).map_err(|e| e.to_string())? {
            write(&d.join(name), &svg)?;
        }
    }
    Ok(s.verdict.exit_code())
}

/// The scenario `drive-bench run` asks for, checked, with its trace's size.
fn run_scenario(a: &RunArgs, plugins: &[PluginLibrary]) -> Result<Scenario, String> {
    let path = |p: &Option<PathBuf>| {
        p.as_ref()
            .map(|p| serde_json::Value::String(p.to_string_lossy().into_owned()))
    };
    let case = Case {
        strategy: a.strategy.clone(),
        speed_rpm: a.speed_rpm,
        duration_s: a.duration_s,
        load_nm: a.load_nm,
        config: path(&a.config),
        scenario: path(&a.scenario),
        seed: a.seed,
        trace_every_us: None,
    };
    let mut sc = case.scenario(plugins).map_err(|e| e.0)?;
    if a.trace.is_some() {
        sc.trace = Some(TraceSpec {
            every_s: a.trace_every_us * 1e-6,
            from_s: a.trace_from_s,
            to_s: a.trace_to_s.unwrap_or(sc.duration_s),
        });
    }
    sc.validate().map_err(|e| e.to_string())?;
    if let Some(t) = &sc.trace {
        let bytes = t.expected_bytes();
        eprintln!(
            "trace: {} rows, about {} → {}",
            t.rows(),
            human_bytes(bytes),
            a.trace.as_deref().unwrap_or(Path::new("-")).display()
        );
        if bytes > LARGE_TRACE_BYTES && !a.large_trace {
            return Err(format!(
                "the trace would take about {} (rule: at most 1 GB unless --large-trace; shorten it with --trace-every-us, --trace-from-s, --trace-to-s)",
                human_bytes(bytes)
            ));
        }
    }
    Ok(sc)
}

/// `drive-bench run`'s output files checked before the run: the trace, the JSON, the
/// plots' folder and files.
fn check_run_outputs(a: &RunArgs) -> Result<(), String> {
    let plot = a.plot.iter().map(|d| Output::folder("--plot", d));
    let plot: Vec<Output> = plot
        .flat_map(|f| {
            let files = [f.inside("overview.svg"), f.inside("zoom.svg")];
            std::iter::once(f).chain(files)
        })
        .collect();
    check_outputs(
        (a.trace.iter().map(|p| Output::file("--trace", p)))
            .chain(a.json.iter().map(|p| Output::file("--json", p)))
            .chain(plot),
    )
}

/// Runs `sc`, its trace rows written as CSV to `trace` if given, with a progress bar.
fn simulate(sc: &Scenario, trace: Option<&Path>) -> Result<Outcome, String> {
    let mut trace = match trace {
        Some(p) => {
            let f = std::fs::File::create(p).map_err(|e| format!("{}: {e}", p.display()))?;
            let mut w = BufWriter::new(f);
            writeln!(w, "{}", TraceRow::HEADER).map_err(|e| format!("{}: {e}", p.display()))?;
            Some((p, w))
        }
        None => None,
    };
    let mut write_err = None;
    let bar = bench::pool::bar("run", (sc.duration_s * 1e3).round() as u64, "ms simulated");
    let out = scenario::run_observed(
        sc,
        |row| {
            if let Some((_, w)) = trace.as_mut()
                && write_err.is_none()
                && let Err(e) = row.write_csv(w).and_then(|()| w.write_all(b"\n"))
            {
                write_err = Some(e);
            }
        },
        |t| bar.set_position((t * 1e3) as u64),
    )
    .map_err(|e| e.to_string())?;
    bar.finish_and_clear();
    if let Some((p, mut w)) = trace {
        if let Some(e) = write_err.take().or_else(|| w.flush().err()) {
            return Err(format!("{}: {e}", p.display()));
        }
    }
    Ok(out)
}

/// The run's verdict and figures (the figures only as such when the verdict judges a
/// drive that settled), and where the rotor was lost.
fn run_text(sc: &Scenario, s: &Summary) -> String {
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
    let figures = match s.verdict {
        v if v.is_success() => figures,
        Verdict::Unsettled => {
            format!("not a valid measurement (the window is in the start-up): {figures}")
        }
        _ => format!("not a valid measurement (the drive failed): {figures}"),
    };
    let mut text = format!(
        "{} at {:.0} rpm: {}: {}\n  {figures}\n",
        s.strategy, s.speed_ref_rpm, s.verdict, s.verdict_reason
    );
    if let Some((t, rpm)) = plots::lost_at(s) {
        text.push_str(&format!(
            "  the rotor was lost at t = {t:.4} s, at {rpm:.0} rpm (the first commutation beyond ±{:.0}° of the true angle)\n",
            sc.verdict_rule.sync_error_deg
        ));
    }
    text
}

fn run_sweep(
    file: &Path,
    csv: Option<PathBuf>,
    json: Option<PathBuf>,
    threads: Option<u16>,
    plugins: &[PluginLibrary],
) -> Result<(), String> {
    // Every case is checked, and the outputs, before the first run.
    let named = |e: String| format!("{}: {e}", file.display());
    let text = std::fs::read_to_string(file).map_err(|e| named(e.to_string()))?;
    let mut cases = sweep::parse(&text).map_err(|e| named(e.0))?;
    sweep::resolve_paths(&mut cases, file.parent().unwrap_or(Path::new("")));
    let scenarios = sweep::scenarios(&cases, plugins).map_err(|e| named(e.0))?;
    check_outputs(
        (csv.iter().map(|p| Output::file("--csv", p)))
            .chain(json.iter().map(|p| Output::file("--json", p))),
    )?;
    let threads = threads.map_or_else(pool::default_threads, usize::from);
    let index: Vec<usize> = (0..cases.len()).collect();
    let rows = pool::map(&index, threads, Some("sweep"), |&k| {
        sweep::run_row(k, &cases[k], &scenarios[k]).map_err(|e| format!("case {k}: {e}"))
    })
    .into_iter()
    .collect::<Result<Vec<_>, _>>()?;
    let mut counts: Vec<(&str, usize)> = Vec::new();
    for r in &rows {
        let v = r.summary.verdict.as_str();
        match counts.iter_mut().find(|c| c.0 == v) {
            Some(c) => c.1 += 1,
            None => counts.push((v, 1)),
        }
    }
    let counts: Vec<String> = counts.iter().map(|(v, n)| format!("{v} {n}")).collect();
    eprintln!("{} cases: {}", rows.len(), counts.join(", "));
    if let Some(p) = &csv {
        write(p, &sweep::to_csv(&rows))?;
    }
    if let Some(p) = &json {
        write(p, &to_json(&rows)?)?;
    }
    if csv.is_none() && json.is_none() {
        let _ = std::io::stdout()
            .lock()
            .write_all(sweep::to_csv(&rows).as_bytes());
    }
    Ok(())
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
    path.map_or_else(|| Ok(DriveConfig::default()), DriveConfig::from_file)
}

/// Above this a trace needs --large-trace \[bytes\].
const LARGE_TRACE_BYTES: u64 = 1_000_000_000;

fn human_bytes(b: u64) -> String {
    match b {
        b if b >= 1_000_000_000 => format!("{:.1} GB", b as f64 / 1e9),
        b if b >= 1_000_000 => format!("{:.1} MB", b as f64 / 1e6),
        b => format!("{:.1} kB", b as f64 / 1e3),
    }
}

/// Checks every output of a command by the one rule of [`outputs::check`].
fn check_outputs(outputs: impl IntoIterator<Item = Output>) -> Result<(), String> {
    outputs::check(&outputs.into_iter().collect::<Vec<_>>())
}

fn to_json<T: serde::Serialize>(v: &T) -> Result<String, String> {
    serde_json::to_string_pretty(v).map_err(|e| e.to_string())
}

fn write(p: &Path, text: &str) -> Result<(), String> {
    std::fs::write(p, text).map_err(|e| format!("{}: {e}", p.display()))
}

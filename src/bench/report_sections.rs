//! The Markdown report's own sections (the other modules write theirs), in report
//! order: [`super::report`] strings them together.

use super::Comparison;
use super::range::holds;
use super::report::opt;
use crate::config::DriveConfig;
use std::fmt::Write as _;

/// The title and what was compared, on what, how long it took.
pub(super) fn intro(s: &mut String, c: &Comparison, config: &DriveConfig) {
    let m = &config.motor;
    let _ = writeln!(s, "# drive-bench report\n");
    let _ = writeln!(
        s,
        "Every built-in commutation strategy on the same motor ({} poles, R = {} Ω, supply {} V, PWM scheme `{}`), each started from standstill by its own start-up sequence. The chip's speed meter is the {} one ({} FG periods) in every run but the range searches, which use each of: {}. Wall time {:.1} s on {} threads.\n",
        m.poles,
        m.resistance_ohm,
        config.power_stage.supply_v,
        config.power_stage.pwm_scheme.name(),
        c.plan.meter.label,
        c.plan.meter.periods,
        c.plan
            .range_meters
            .iter()
            .map(|m| m.label)
            .collect::<Vec<_>>()
            .join(", "),
        c.wall_s,
        c.threads
    );
}

/// Each strategy's speed range, with what limits it at either end.
pub(super) fn ranges(s: &mut String, c: &Comparison) {
    let _ = writeln!(
        s,
        "\n## Speed range\n\nJudged by the verdict ({}). Each bound is followed by what stops it: the verdict of the failed run just beyond it. Why the guarded strategies lose the rotor where they do (the commutation drifting early as the back-EMF shrinks toward the comparator front end's PWM-edge spike) is shown in \"What sets the floors\" below.\n\n| strategy | meter | floor rpm | limited by | top rpm | limited by | runs |\n|---|---|---:|---|---:|---|---:|",
        super::range::CRITERION
    );
    let lim = |l: &Option<super::range::Limit>| {
        l.as_ref().map_or("–".to_string(), |l| {
            format!("{:.0} rpm: **{}**: {}", l.rpm, l.verdict, l.reason)
        })
    };
    for r in &c.ranges {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | {} |",
            r.strategy,
            r.meter,
            opt(r.min_rpm, 1.0, 0),
            lim(&r.min_limit),
            opt(r.max_rpm, 1.0, 0),
            lim(&r.max_limit),
            r.tried.len(),
        );
    }
    let gaps: Vec<String> = c
        .ranges
        .iter()
        .filter(|r| !r.gaps_rpm.is_empty())
        .map(|r| format!("{} ({}): {:?} rpm", r.strategy, r.meter, r.gaps_rpm))
        .collect();
    let _ = writeln!(
        s,
        "\nThe top-speed search is a bisection from the first of 3000, 2000, 4500, 1000, 6000 rpm that passes from standstill, each top run turned up from it; it assumes the controllable speeds form one interval. Failed inside the range: {}.",
        if gaps.is_empty() {
            "none".to_string()
        } else {
            gaps.join("; ")
        }
    );
}

/// The grid: every strategy at every speed, or why it failed there.
pub(super) fn steady_state(s: &mut String, c: &Comparison) {
    let _ = writeln!(
        s,
        "\n## Steady state\n\nEvery run is judged from the true rotor (verdicts below); only runs judged `running` show figures, the others show why they failed.\n\n| strategy | command rpm | verdict | mean rpm | ripple rpm | torque mN·m | ripple mN·m | LF ripple mN·m | I rms A | I peak A | commutation peak A | err mean ° | err max ° | forced | restarts |\n|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
    );
    for g in &c.grid {
        let x = &g.summary;
        if !holds(x) {
            let _ = writeln!(
                s,
                "| {} | {:.0} | **{}**: {} | – | – | – | – | – | – | – | – | – | – | – | {} |",
                g.variant, x.speed_ref_rpm, x.verdict, x.verdict_reason, x.restarts
            );
            continue;
        }
        let _ = writeln!(
            s,
            "| {} | {:.0} | {} | {:.0} | {:.1} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:+.2} | {:.2} | {} | {} |",
            g.variant,
            x.speed_ref_rpm,
            x.verdict,
            x.speed_mean_rpm,
            x.speed_ripple_rpm,
            x.torque_mean_nm * 1e3,
            x.torque_ripple_nm * 1e3,
            x.torque_ripple_lf_nm * 1e3,
            x.current_rms_a,
            x.current_peak_a,
            x.commutation_peak_a,
            x.commutation_error_deg_mean,
            x.commutation_error_deg_max,
            x.forced_crossings,
            x.restarts
        );
    }
}

/// The anti-windup comparison, a table per case.
pub(super) fn anti_windup(s: &mut String, c: &Comparison) {
    let _ = writeln!(
        s,
        "\n## Anti-windup\n\nEach case drives a PI into saturation; it runs with anti-windup off, on the current PI only (the chip's) and on both PIs (the speed PI's is a model option). The current PI saturates only where the current limit needs more than full voltage (near top speed); below that the speed PI is the one that saturates, at the current limit, and the chip's anti-windup cannot act. At the lower limits (a step down: no current asked, no duty given) both integrators are clamped at zero, so there is nothing to wind up and anti-windup cannot act after the step (the chip's back-calculation acts on the upper limit only, strategies/src/pi.rs): what differs between its rows comes from the start-up and the step up before it. Where the rotor comes back below the command, the shipped chip presets both integrators to the current held before the fall (`control.speed_resume`, docs/chip.md), whatever the anti-windup setting. Peak: beyond the command in the direction of the change (an undershoot after a step down). The chip has no braking state: after a step down the rotor coasts on friction.\n"
    );
    for (k, case) in c.plan.step.cases.iter().enumerate() {
        let _ = writeln!(
            s,
            "### {}\n\nSaturates: {}. Measured from {} s.\n\n| strategy | anti-windup | from rpm | load dip rpm | full duty after ms | peak {} rpm | peak % {} | settling s | restarts |\n|---|---|---:|---:|---:|---:|---:|---:|---:|",
            case.name,
            case.saturates,
            case.at_s,
            if case.is_step_down() { "under" } else { "over" },
            case.peak_pct_of()
        );
        for x in c.steps.iter().filter(|x| x.case == k) {
            if !x.verdict.is_running() {
                let _ = writeln!(
                    s,
                    "| {} | {} | **{}** at the end | – | – | – | – | – | {} |",
                    x.variant,
                    x.anti_windup.as_str(),
                    x.verdict,
                    x.restarts
                );
                continue;
            }
            let _ = writeln!(
                s,
                "| {} | {} | {:.0} | {} | {:.1} | {:.0} | {:.1} | {} | {} |",
                x.variant,
                x.anti_windup.as_str(),
                x.from_rpm,
                opt(x.dip_rpm, 1.0, 0),
                x.full_duty_after_s * 1e3,
                x.peak_beyond_rpm,
                case.peak_pct(x),
                opt(x.response.settling_s, 1.0, 3),
                x.restarts
            );
        }
        let _ = writeln!(s);
    }
}

/// The load step's dip and recovery.
pub(super) fn load_step(s: &mut String, c: &Comparison) {
    let _ = writeln!(
        s,
        "\n## Load step {:.2} mN·m at {:.0} rpm\n\n| strategy | dip rpm | recovery s | restarts |\n|---|---:|---:|---:|",
        c.plan.load.1 * 1e3,
        c.plan.load.0
    );
    for x in &c.loads {
        if !x.verdict.is_running() {
            let _ = writeln!(
                s,
                "| {} | **{}** at the end | – | {} |",
                x.variant, x.verdict, x.restarts
            );
            continue;
        }
        let _ = writeln!(
            s,
            "| {} | {:.0} | {} | {} |",
            x.variant,
            x.response.dip,
            opt(x.response.recovery_s, 1.0, 3),
            x.restarts
        );
    }
}

/// The start-up Monte-Carlo: success over tolerances.
pub(super) fn startup(s: &mut String, c: &Comparison) {
    let Some(first) = c.startups.first() else {
        return;
    };
    let sp = first.spread;
    let _ = writeln!(
        s,
        "\n## Start-up over tolerances\n\nEach strategy started {} times from standstill (seed {}), every start on a drive drawn with R, L_self, M, λr, J, both frictions and V_DD each scaled uniformly within ±{:.0} % and each comparator offset within ±{:.0} mV, with a fresh noise seed. A start succeeds when the run's verdict has the commutation following the true rotor to the end (running or off-speed), the controller never restarted (the first hand-over held), and the true mean speed over the last {} s of a {} s run is within {:.0} % of the command; the verdict's 2 % is for settled runs, and the default speed loop still rings 1.75 s after the hand-over. The starts that also meet 2 % (verdict running) are counted beside.\n\n| strategy | command rpm | success | verdict running | hand-over s (mean) | within 5 % s (mean / max) | failed starts (R Ω, V_DD V, restarts, verdict, mean rpm) |\n|---|---:|---:|---:|---:|---:|---|",
        c.plan.startup.0,
        c.plan.startup.1,
        100.0 * sp.relative,
        1e3 * sp.offset_v,
        super::startup::STEADY_S,
        super::startup::RUN_S,
        100.0 * super::startup::TOLERANCE,
    );
    let mean = |v: &[f64]| {
        if v.is_empty() {
            "–".to_string()
        } else {
            format!("{:.3}", v.iter().sum::<f64>() / v.len() as f64)
        }
    };
    for x in &c.startups {
        let st = &x.stats;
        let failed: Vec<String> = st
            .failures
            .iter()
            .map(|f| {
                format!(
                    "{:.2} Ω, {:.1} V, {}, {}, {:.0}",
                    f.sampled.resistance_ohm, f.sampled.supply_v, f.restarts, f.verdict, f.mean_rpm
                )
            })
            .collect();
        // A row run under other conditions says why on the row.
        let command = match x.command_note {
            Some(why) => format!("{:.0} ({why})", x.command_rpm),
            None => format!("{:.0}", x.command_rpm),
        };
        let _ = writeln!(
            s,
            "| {} | {command} | {}/{} ({:.1} %) | {}/{} | {} | {} / {} | {} |",
            x.variant,
            st.successes,
            st.runs,
            100.0 * st.successes as f64 / st.runs.max(1) as f64,
            st.verdict_running,
            st.runs,
            mean(&st.handover_s),
            mean(&st.within_s),
            st.within_s
                .iter()
                .copied()
                .fold(None, |m: Option<f64>, t| Some(m.map_or(t, |m| m.max(t))))
                .map_or("–".into(), |t| format!("{t:.3}")),
            if failed.is_empty() {
                "–".to_string()
            } else {
                failed.join("; ")
            }
        );
    }
}

/// Each figure not shown by the sections above, once.
pub(super) fn plots(s: &mut String, crossings: &[String]) {
    // Each figure once: those the chapters above did not show.
    let rest: Vec<&str> = [
        "speed_step.svg",
        "load_step.svg",
        "ripple_vs_speed.svg",
        "phase_current.svg",
    ]
    .into_iter()
    .chain(crossings.iter().map(String::as_str))
    .filter(|f| !s.contains(&format!("]({f})")))
    .collect();
    if !rest.is_empty() {
        let _ = writeln!(s, "\n## Plots\n");
    }
    for f in rest {
        let _ = writeln!(s, "![{f}]({f})\n");
    }
}

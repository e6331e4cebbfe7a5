//! The digital phase shifter (docs/chip.md): from zero crossings to commutation instants.
//!
//! The chip's two counters C_p, C_n time how long Z_d stays high and low, each 60° of
//! rotation; the finished one, t_60, fixes the next commutation. Here t_60 is the number of
//! 0.64 µs clocks between the last two accepted crossings (15-bit, saturating), which is what
//! the finished counter holds when Z_d is clean. At a crossing the drive applies the
//! sector's post pattern (for twelve-step: the 3-phase state at once); when t_60·num/den
//! clocks have elapsed it commutates to the pre pattern (30° for six-step and 150°).
//!
//! **Not being fooled after a commutation.** Right after the pre pattern floats a phase,
//! that phase still carries current, which freewheels through a diode and clamps the
//! terminal to a rail: its comparator shows the *post*-crossing level for a while. A
//! crossing is therefore accepted only once the detector is *armed*: it has seen the
//! pre-crossing level either begin later than the blanking time after the commutation (the
//! freewheel ended) or last longer than the blanking time (there was no freewheel, and the
//! level it saw was not left over from before the commutation). A pre level beginning
//! sooner proves nothing: the newly selected comparator's input filter still settles from
//! the phase's driven voltage, and the digital filter still holds the previous phase's
//! samples, for a few µs after the switch.
//!
//! **Plausibility.** A crossing earlier than ¾·t_60 after the last one is not accepted:
//! the rotor cannot shorten its 60° time by a quarter within one sector, so such an edge is
//! interference (at low speed the comparator's PWM-edge glitches outlast any filter), and
//! accepting it would shorten t_60 and make the next false crossing likelier still.
//!
//! **Confirmation at low speed (start-up).** Below a few hundred rpm the back-EMF is
//! smaller than the comparator's PWM-edge glitches, which outlast any short filter; a glitch
//! to the post level at the earliest plausible instant is then taken as a crossing, t_60
//! shrinks by a quarter, and the next glitch repeats it: a geometric runaway (Σ 0.75^k
//! converges, so commutation reaches any speed within 3·t_60) that leaves the rotor behind
//! while FG keeps toggling, so no step miss is seen. While confirmation is on, an up/down
//! counter integrates the level at every clock (+1 post, −1 pre, floored at 0), and a
//! crossing needs it to reach N_c = t_60·θc/60° clocks. A glitch adds a few counts per
//! PWM edge and the pre level between edges removes them; a real crossing fills the
//! counter in ≈ N_c clocks. The crossing is dated back to where the counter last left 0,
//! so the confirmation delays the detection but not the commutation instants.
//!
//! **Demagnetisation timeout.** With a long freewheel (high current, low duty) the crossing
//! can pass while the terminal is still clamped, so the pre level is never seen. Once the
//! expected crossing instant (last crossing + t_60) has passed with the post level showing,
//! the shifter takes it as a late crossing, like production sensorless firmware does; such
//! crossings are counted ([`PhaseShifter::forced_crossings`]). Also several in a row: at
//! high speed and current (six-step at 6–8 krpm on the built-in motor) the freewheel after
//! every other commutation lasts 25–32° against a pre part of 30°, and a forced crossing,
//! dated at the constant-speed instant, is late while the rotor accelerates, which shortens
//! the next pre part further; refusing the second timeout left the bridge in one state
//! until the rotor had turned 180° (loss of synchronism). A stalled rotor is not stepped
//! forever by this: once the freewheel has ended its terminal holds one level, which is the
//! pre level of every other sector (the expected slope alternates), so that sector arms and
//! waits for a crossing that never comes, and FG stops (step miss). A crossing taken this
//! way measures t_60 as the interval it was dated from, so a long run of them free-runs the
//! commutation at a frozen rate; the plausibility supervisor ends such a run.

use crate::table::{Sector, Table};
use drive_core::{Abc, Pattern, Phase, Ticks, clocks};

/// The 15-bit counters' limit \[clocks\].
pub const COUNTER_MAX: u64 = (1 << 15) - 1;

/// What [`PhaseShifter::poll`] and [`PhaseShifter::observe`] did.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum ShiftEvent {
    /// Nothing.
    None,
    /// A crossing was accepted: the post pattern applies from now.
    Crossing,
    /// The post part ended: the pre pattern applies from now.
    Commutation,
}

/// Sector sequencing, t_60 measurement and crossing acceptance.
#[derive(Clone, Debug)]
pub struct PhaseShifter {
    table: Table,
    /// `table.post_fraction()`, kept since the clock asks at every edge (it rounds a float).
    post: (u64, u64),
    /// `table.sectors()`, kept since the shifter reads its sector several times an edge.
    sectors: &'static [Sector; 6],
    blank: Ticks,
    sector: usize,
    in_pre: bool,
    entered_pre: Ticks,
    last_cross: Ticks,
    t60: u64,
    measured: bool,
    crossings_seen: u32,
    post_end: Ticks,
    armed: bool,
    pre_run: Option<Ticks>,
    forced: u64,
    /// Confirmation angle θc [whole electrical degrees], when on.
    confirm: Option<u32>,
    /// Confirmation counter \[clocks\] and the level it integrates since `integ_at`.
    integ: u64,
    integ_at: Ticks,
    integ_level: bool,
    /// Where the counter last left 0.
    integ_from: Ticks,
}

const CLK: u64 = clocks::COMMUTATION.0;

impl PhaseShifter {
    /// A shifter for `table` with the given blanking time, idle in sector 0.
    pub fn new(table: Table, blank: Ticks) -> Self {
        PhaseShifter {
            table,
            post: table.post_fraction(),
            sectors: table.sectors(),
            blank,
            sector: 0,
            in_pre: true,
            entered_pre: Ticks::ZERO,
            last_cross: Ticks::ZERO,
            t60: COUNTER_MAX,
            measured: false,
            crossings_seen: 0,
            post_end: Ticks::NEVER,
            armed: false,
            pre_run: None,
            forced: 0,
            confirm: None,
            integ: 0,
            integ_at: Ticks::ZERO,
            integ_level: false,
            integ_from: Ticks::ZERO,
        }
    }

    /// Turns crossing confirmation on over θc = `deg` electrical degrees (N_c = t_60·θc/60
    /// clocks, see the module doc), or off with `None` or 0.
    pub fn set_confirmation(&mut self, deg: Option<u32>) {
        self.confirm = deg.filter(|&d| d > 0);
    }

    /// N_c \[clocks\] while confirmation is on.
    fn confirm_counts(&self) -> Option<u64> {
        self.confirm.map(|d| (self.t60 * u64::from(d) / 60).max(1))
    }

    fn clear_confirmation(&mut self, now: Ticks) {
        self.integ = 0;
        self.integ_at = now;
        self.integ_level = !self.sector().rising;
        self.integ_from = now;
    }

    /// Integrates the level held since the last observation up to clock edge `now`.
    fn integrate(&mut self, now: Ticks, level: bool) {
        let n = now.0.saturating_sub(self.integ_at.0) / CLK;
        if n > 0 {
            if self.integ_level == self.sector().rising {
                if self.integ == 0 {
                    self.integ_from = self.integ_at;
                }
                self.integ += n;
            } else {
                self.integ = self.integ.saturating_sub(n);
            }
        }
        self.integ_at = now;
        self.integ_level = level;
    }

    /// While confirmation is on and the post level is held: the instant the counter
    /// reaches N_c (the controller must be woken there).
    pub fn confirmation_due(&self) -> Option<Ticks> {
        let nc = self.confirm_counts()?;
        (self.in_pre && self.integ_level == self.sector().rising)
            .then(|| Ticks(self.integ_at.0 + nc.saturating_sub(self.integ) * CLK))
    }

    /// Replaces the table (same sectors, another post fraction), effective from the next
    /// crossing.
    pub fn set_table(&mut self, table: Table) {
        self.table = table;
        self.post = table.post_fraction();
        self.sectors = table.sectors();
    }

    /// Starts closed-loop operation at `now` in the pre part of `sector`; t_60 is assumed
    /// to be `t60_counts` until two crossings have been measured. `armed`: the floating
    /// phase has floated long enough to carry no current, so the detector is armed at
    /// once; otherwise it arms as after any commutation.
    pub fn hand_over(&mut self, sector: usize, now: Ticks, t60_counts: u64, armed: bool) {
        self.sector = sector % 6;
        self.in_pre = true;
        self.entered_pre = now;
        self.last_cross = now;
        self.t60 = t60_counts.clamp(1, COUNTER_MAX);
        self.measured = false;
        self.crossings_seen = 0;
        self.post_end = Ticks::NEVER;
        self.armed = armed;
        self.pre_run = None;
        self.clear_confirmation(now);
    }

    /// Runs the post → pre commutation if it is due at `now`.
    pub fn poll(&mut self, now: Ticks) -> ShiftEvent {
        if !self.in_pre && now >= self.post_end {
            self.enter_pre(now);
            return ShiftEvent::Commutation;
        }
        ShiftEvent::None
    }

    fn enter_pre(&mut self, now: Ticks) {
        self.in_pre = true;
        self.entered_pre = now;
        self.armed = false;
        self.pre_run = None;
        self.clear_confirmation(now);
    }

    /// Feeds the detection level (after the guard's filter) seen at clock edge `now`.
    pub fn observe(&mut self, now: Ticks, level: bool) -> ShiftEvent {
        if !self.in_pre {
            return ShiftEvent::None;
        }
        let post_level = self.sector().rising;
        self.integrate(now, level);
        if level != post_level {
            if self.pre_run.is_none() {
                self.pre_run = Some(now);
            }
            return ShiftEvent::None;
        }
        // A pre level that begins within the blanking time after the commutation may be
        // the newly selected comparator (or the filter holding the previous phase's
        // samples) settling, not the end of a freewheel: it arms only by lasting.
        if let Some(start) = self.pre_run.take()
            && (start.0 >= self.entered_pre.0 + self.blank.0 || now.0 - start.0 >= self.blank.0)
        {
            self.armed = true;
        }
        let overdue = self.demag_timeout().is_some_and(|e| now >= e);
        let plausible = now >= self.earliest_crossing();
        let (confirmed, at) = match self.confirm_counts() {
            // Dated back to where the counter left 0, but not before it was plausible.
            Some(nc) => (
                self.integ >= nc,
                self.integ_from.max(self.earliest_crossing()).min(now),
            ),
            None => (true, now),
        };
        if (self.armed || overdue) && plausible && confirmed {
            self.forced += u64::from(!self.armed);
            self.cross(at, now);
            return ShiftEvent::Crossing;
        }
        ShiftEvent::None
    }

    /// A crossing dated `at`, accepted at clock edge `now` (`at` ≤ `now`).
    fn cross(&mut self, at: Ticks, now: Ticks) {
        self.crossings_seen = self.crossings_seen.saturating_add(1);
        if self.crossings_seen >= 2 {
            self.t60 = (at.0.saturating_sub(self.last_cross.0) / CLK).clamp(1, COUNTER_MAX);
            self.measured = true;
        }
        self.last_cross = at;
        self.sector = (self.sector + 1) % 6;
        let (num, den) = self.post;
        let post = self.t60 * num / den;
        // A crossing dated back may leave less than its post part, or none.
        self.post_end = Ticks(at.0 + post * CLK).max(now);
        self.in_pre = false;
        if self.post_end <= now {
            self.enter_pre(now);
        }
    }

    /// The sector in force.
    pub fn sector(&self) -> Sector {
        self.sectors[self.sector]
    }

    /// Sector index 0..5.
    pub fn sector_index(&self) -> usize {
        self.sector
    }

    /// Whether the pre (floating, sensing) part is in force.
    pub fn in_pre(&self) -> bool {
        self.in_pre
    }

    /// The pattern in force.
    pub fn pattern(&self) -> Pattern {
        let s = self.sector();
        if self.in_pre { s.pre } else { s.post }
    }

    /// State number in force (1..12 twelve-step, 1..6 six-step).
    pub fn state(&self) -> u8 {
        let s = self.sector();
        if self.in_pre { s.states.1 } else { s.states.0 }
    }

    /// The phase whose comparator forms Z_d: the floating one in the pre part, the one
    /// that just crossed in the post part (so Z_d is 60° high, 60° low).
    pub fn zd_phase(&self) -> Phase {
        if self.in_pre {
            self.sector().sensed
        } else {
            self.sectors[(self.sector + 5) % 6].sensed
        }
    }

    /// From which instant Z_d may select each phase's comparator at the coming clock edges
    /// while nothing else changes the shifter (see [`Command::reads`]): the phase it
    /// selects now; in the post part, the sector's sensed phase from the commutation on;
    /// in the pre part, the next sector's if a crossing could leave the post part empty
    /// (its pre part then begins at once).
    ///
    /// [`Command::reads`]: drive_core::Command::reads
    pub fn zd_reads(&self) -> Abc<Ticks> {
        let mut r = Abc::splat(Ticks::NEVER);
        *r.get_mut(self.zd_phase()) = Ticks::ZERO;
        let (x, from) = if self.in_pre {
            if !self.post_may_be_empty() {
                return r;
            }
            (self.sectors[(self.sector + 1) % 6].sensed, Ticks::ZERO)
        } else {
            (self.sector().sensed, self.post_end)
        };
        let e = r.get_mut(x);
        *e = (*e).min(from);
        r
    }

    /// Whether the next crossing could leave an empty post part: its t_60 is the present
    /// one (fewer than two crossings measured) or at least ¾ of it (an earlier crossing is
    /// not plausible), and at least one clock; or confirmation is on.
    fn post_may_be_empty(&self) -> bool {
        let (num, den) = self.post;
        // A confirmed crossing is dated back and may have used up its post part.
        self.confirm.is_some() || (self.t60 * 3 / 4).max(1) * num / den == 0
    }

    /// Last t_60 [0.64 µs clocks] and whether it was measured (else the hand-over value).
    pub fn t60(&self) -> (u64, bool) {
        (self.t60, self.measured)
    }

    /// The instant of the last accepted crossing (or of the hand-over).
    pub fn last_crossing(&self) -> Ticks {
        self.last_cross
    }

    /// Where the next crossing is expected: one t_60 after the last, once t_60 is measured.
    pub fn expected_crossing(&self) -> Option<Ticks> {
        self.measured
            .then(|| Ticks(self.last_cross.0 + self.t60 * CLK))
    }

    /// When the post part ends (`None` in the pre part).
    pub fn post_end(&self) -> Option<Ticks> {
        (!self.in_pre).then_some(self.post_end)
    }

    /// The earliest instant a crossing is plausible: ¾·t_60 after the last one.
    pub fn earliest_crossing(&self) -> Ticks {
        Ticks(self.last_cross.0 + self.t60 * 3 / 4 * CLK)
    }

    /// Crossings accepted by the demagnetisation timeout (never armed).
    pub fn forced_crossings(&self) -> u64 {
        self.forced
    }

    /// The instant from which a post level is accepted without arming, while in the pre
    /// part and not armed (the controller must be woken there).
    pub fn demag_timeout(&self) -> Option<Ticks> {
        if self.in_pre && !self.armed {
            self.expected_crossing()
        } else {
            None
        }
    }

    /// Whether the detector is armed.
    pub fn armed(&self) -> bool {
        self.armed
    }
}

impl PhaseShifter {
    /// A restored shifter's instants against the engine's instant `now`: the commutation,
    /// the crossing, the confirmation counter's and the pre level's instants passed by
    /// `now`, and the post part's end within a t_60 after it (a crossing's post part is at
    /// most t_60), or none.
    pub(crate) fn check_at(&self, now: Ticks) -> Result<(), String> {
        let passed = [
            ("entered_pre", Some(self.entered_pre)),
            ("last_cross", Some(self.last_cross)),
            ("integ_at", Some(self.integ_at)),
            ("integ_from", Some(self.integ_from)),
            ("pre_run", self.pre_run),
        ];
        for (name, t) in passed {
            drive_core::state::check(t.is_none_or(|t| t <= now), || {
                format!(
                    "shifter.{name} = {} (rule: an instant by now = {})",
                    t.unwrap_or(now).0,
                    now.0
                )
            })?;
        }
        let last = now.0.saturating_add(self.t60 * CLK);
        drive_core::state::check(
            self.post_end == Ticks::NEVER || self.post_end.0 <= last,
            || {
                format!(
                    "shifter.post_end = {} (rule: within a t_60 after now, by {last}, or none)",
                    self.post_end.0
                )
            },
        )
    }

    /// The confirmation angle in force, for the chip's check against its parameter.
    pub(crate) fn confirmation(&self) -> Option<u32> {
        self.confirm
    }
}

// Everything but the blanking time, a parameter, and the post fraction and sectors, derived
// from the table.
drive_core::persist_fields!(PhaseShifter {
    table,
    sector,
    in_pre,
    entered_pre,
    last_cross,
    t60,
    measured,
    crossings_seen,
    post_end,
    armed,
    pre_run,
    forced,
    confirm,
    integ,
    integ_at,
    integ_level,
    integ_from
} then rederive);

/// Checks the sector index (read from it directly) and restores what derives from the
/// restored fields: the post fraction and the sectors of the table.
fn rederive(s: &mut PhaseShifter) -> Result<(), String> {
    if s.sector >= 6 {
        return Err(format!("sector = {} (rule: 0..=5)", s.sector));
    }
    // The counter's range, as a hand-over and every crossing clamp it.
    drive_core::state::check((1..=COUNTER_MAX).contains(&s.t60), || {
        format!(
            "t60 = {} (rule: the 60° counter's range 1..={COUNTER_MAX})",
            s.t60
        )
    })?;
    drive_core::state::check_count("forced", s.forced)?;
    drive_core::state::check_count("integ", s.integ)?;
    s.post = s.table.post_fraction();
    s.sectors = s.table.sectors();
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::table::Table;

    #[test]
    fn a_restored_counter_and_instants_keep_their_rules() {
        use drive_core::Persist;
        let mut s = PhaseShifter::new(Table::SixStep, Ticks(320));
        s.hand_over(0, Ticks(6400), 1000, true);
        let fresh = || PhaseShifter::new(Table::SixStep, Ticks(320));
        fresh().restore_from(&s.to_bytes().unwrap()).unwrap();
        s.check_at(Ticks(6400)).unwrap();
        for t60 in [0, COUNTER_MAX + 1] {
            let forged = PhaseShifter { t60, ..s.clone() };
            let e = fresh()
                .restore_from(&forged.to_bytes().unwrap())
                .unwrap_err();
            assert!(e.starts_with(&format!("t60 = {t60} (rule:")), "{e}");
        }
        let e = s.check_at(Ticks(6399)).unwrap_err();
        assert!(e.starts_with("shifter.entered_pre = 6400"), "{e}");
        let far = PhaseShifter {
            post_end: Ticks(6400 + 1000 * CLK + 1),
            ..s.clone()
        };
        assert!(
            far.check_at(Ticks(6400))
                .unwrap_err()
                .starts_with("shifter.post_end = ")
        );
    }

    /// Drives a shifter with a clean Z_d of 60° period `t60` clocks: the sensed phase is at
    /// its pre level until the crossing at 60°·k, then at its post level. Returns the
    /// (instant, event, state) of every event over `n` sectors.
    fn run_clean(table: Table, t60: u64, n: u64) -> Vec<(u64, ShiftEvent, u8)> {
        let mut s = PhaseShifter::new(table, Ticks(320));
        // Hand over in sector 0 at t = 0, before the crossing at 60° = t60 clocks.
        s.hand_over(0, Ticks(0), t60, true);
        let mut log = Vec::new();
        let mut crossed = 0u64;
        let mut t = 0;
        while t <= n * t60 * CLK {
            let now = Ticks(t);
            if s.poll(now) == ShiftEvent::Commutation {
                log.push((t, ShiftEvent::Commutation, s.state()));
            }
            let post_level = s.sector().rising;
            let past = t >= (crossed + 1) * t60 * CLK;
            let level = if past { post_level } else { !post_level };
            if s.observe(now, level) == ShiftEvent::Crossing {
                crossed += 1;
                log.push((t, ShiftEvent::Crossing, s.state()));
            }
            t += CLK;
        }
        log
    }

    /// Every phase Z_d selects at a clock edge (before and after a crossing there, as the
    /// chip reads it) was declared by [`PhaseShifter::zd_reads`] at the edge before, from
    /// an instant not after it; and only with a post part does the pre part declare one
    /// phase alone.
    #[test]
    fn zd_reads_declares_every_phase_the_next_edge_selects() {
        let t60 = 200;
        for table in [
            Table::SixStep,
            Table::TwelveStep {
                conduction_deg: 120.0,
            },
            Table::TwelveStep {
                conduction_deg: 150.0,
            },
        ] {
            let mut s = PhaseShifter::new(table, Ticks(320));
            s.hand_over(0, Ticks(0), t60, true);
            let mut declared = s.zd_reads();
            let (mut crossed, mut single) = (0u64, 0u32);
            for k in 1..=8 * t60 {
                let now = Ticks(k * CLK);
                let read = |s: &PhaseShifter| {
                    let x = s.zd_phase();
                    assert!(
                        declared.get(x) <= now,
                        "{table:?} at {now:?}: {x:?} undeclared"
                    );
                };
                s.poll(now);
                read(&s);
                let post_level = s.sector().rising;
                let level = if now.0 >= (crossed + 1) * t60 * CLK {
                    post_level
                } else {
                    !post_level
                };
                if s.observe(now, level) == ShiftEvent::Crossing {
                    crossed += 1;
                    read(&s);
                }
                declared = s.zd_reads();
                let n = Phase::ALL
                    .iter()
                    .filter(|&&x| declared.get(x) != Ticks::NEVER);
                single += u32::from(n.count() == 1);
            }
            assert!(crossed >= 6, "{table:?}: {crossed} crossings");
            let empty_post = table.post_fraction().0 == 0;
            assert_eq!(single > 0, !empty_post, "{table:?}");
        }
    }

    #[test]
    fn six_step_commutates_30_degrees_after_each_crossing() {
        let t60 = 1000;
        let log = run_clean(Table::SixStep, t60, 8);
        let crossings: Vec<u64> = log
            .iter()
            .filter(|e| e.1 == ShiftEvent::Crossing)
            .map(|e| e.0)
            .collect();
        // Crossings at k·t60 clocks, exactly (clean signal, sampled on the clock grid).
        for (i, &c) in crossings.iter().enumerate() {
            assert_eq!(c, (i as u64 + 1) * t60 * CLK, "crossing {i}");
        }
        // Each commutation follows its crossing by 30° (t_60 / 2).
        let coms: Vec<(u64, u8)> = log
            .iter()
            .filter(|e| e.1 == ShiftEvent::Commutation)
            .map(|e| (e.0, e.2))
            .collect();
        for &(t, _) in &coms {
            assert_eq!((t / CLK) % t60, t60 / 2, "commutation at {t} not 30° after");
        }
        assert!(coms.len() >= 6);
        // States advance 1..6 in order.
        for w in coms.windows(2) {
            assert_eq!(w[1].1, w[0].1 % 6 + 1);
        }
    }

    #[test]
    fn twelve_step_switches_at_the_crossing_and_30_degrees_later() {
        let t60 = 1200;
        let log = run_clean(
            Table::TwelveStep {
                conduction_deg: 150.0,
            },
            t60,
            8,
        );
        let mut last_state = 2; // hand-over in sector 0's pre part = state 2
        for &(t, ev, state) in &log {
            let phase = (t / CLK) % t60;
            match ev {
                ShiftEvent::Crossing => {
                    assert_eq!(phase, 0, "crossing at {t}");
                    assert_eq!(state % 2, 1, "3-phase state after a crossing");
                }
                ShiftEvent::Commutation => {
                    assert_eq!(phase, t60 / 2, "2-phase state 30° later, at {t}");
                    assert_eq!(state % 2, 0);
                }
                ShiftEvent::None => unreachable!(),
            }
            assert_eq!(state, last_state % 12 + 1, "states in order");
            last_state = state;
        }
        assert!(log.len() >= 14);
    }

    #[test]
    fn wider_conduction_shortens_the_floating_window() {
        let t60 = 1200;
        let log = run_clean(
            Table::TwelveStep {
                conduction_deg: 165.0,
            },
            t60,
            6,
        );
        let mut commutations = 0;
        for &(t, ev, _) in &log {
            if ev == ShiftEvent::Commutation {
                // (165 − 120)/60 = 3/4 of t60 after the crossing.
                assert_eq!((t / CLK) % t60, 900, "at {t}");
                commutations += 1;
            }
        }
        // Six sectors run: a commutation after (nearly) every crossing.
        assert!(commutations >= 5, "{commutations} commutations: {log:?}");
    }

    #[test]
    fn freewheel_after_a_commutation_is_not_taken_for_a_crossing() {
        let mut s = handed_over_150();
        // First crossing (armed by the hand-over), then the 30° post part.
        let post = s.sector().rising; // sector 0: w falling → post level 0
        assert_eq!(s.observe(Ticks(32_000), post), ShiftEvent::Crossing);
        let t_com = s.post_end().unwrap();
        assert_eq!(s.poll(t_com), ShiftEvent::Commutation);
        let post = s.sector().rising;
        // At the commutation edge the comparator still shows the pre level (left over);
        // 1 µs later the freewheel clamp shows the post level: not armed, no crossing.
        assert_eq!(s.observe(t_com, !post), ShiftEvent::None);
        assert_eq!(s.observe(Ticks(t_com.0 + 64), post), ShiftEvent::None);
        assert!(!s.armed());
        // Freewheel ends (pre level), then the real crossing.
        assert_eq!(s.observe(Ticks(t_com.0 + 3200), !post), ShiftEvent::None);
        assert_eq!(s.observe(Ticks(t_com.0 + 9600), post), ShiftEvent::Crossing);
        // No freewheel at all: the pre level held past the blanking time also arms. (t_60
        // is now measured, 800 clocks, so the next crossing is plausible from ¾ of it.)
        let t_com = s.post_end().unwrap();
        s.poll(t_com);
        let post = s.sector().rising;
        s.observe(t_com, !post);
        let at = Ticks(s.earliest_crossing().0 + 64);
        assert!(at.0 - t_com.0 >= 320, "past the blanking time");
        assert_eq!(s.observe(at, post), ShiftEvent::Crossing);
    }

    /// The pre level appearing within the blanking time after a commutation (the newly
    /// selected comparator settling) does not arm the detector: the freewheel clamp that
    /// follows is not a crossing.
    #[test]
    fn a_pre_level_settling_right_after_the_commutation_does_not_arm() {
        let mut s2 = handed_over_150();
        // Reach a fresh commutation: crossing at 32 000, post part of 500 clocks.
        let post = s2.sector().rising;
        s2.observe(Ticks(32_000), post);
        let tc = s2.post_end().unwrap();
        s2.poll(tc);
        let post = s2.sector().rising;
        // Clamped (post) at the commutation, pre for 2 clocks 1.3 µs later (settling), then
        // clamped again well after the plausible instant: no crossing.
        assert_eq!(s2.observe(tc, post), ShiftEvent::None);
        assert_eq!(s2.observe(Ticks(tc.0 + 64), !post), ShiftEvent::None);
        let late = Ticks(s2.earliest_crossing().0 + 3200);
        assert_eq!(s2.observe(Ticks(tc.0 + 128), post), ShiftEvent::None);
        assert_eq!(s2.observe(late, post), ShiftEvent::None);
        assert!(!s2.armed());
    }

    /// With confirmation on (θc = 2°: N_c = 1000·2/60 = 33 clocks), post-level glitches of
    /// 5 clocks once per 125 clocks (one 80 µs PWM period) never make a crossing, and a
    /// lasting post level makes one dated where it began, with the commutation half a t_60
    /// after that.
    #[test]
    fn confirmation_rejects_edge_glitches_and_dates_a_real_crossing_back() {
        let mut s = measured();
        s.set_confirmation(Some(2));
        let t_com = s.last_crossing().0 + 500 * CLK;
        let post = s.sector().rising;
        let mut k = t_com / CLK + 20;
        let real = (s.last_crossing().0 + 1000 * CLK) / CLK;
        while k < real {
            let level = if k % 125 < 5 { post } else { !post };
            assert_eq!(
                s.observe(Ticks(k * CLK), level),
                ShiftEvent::None,
                "clock {k}"
            );
            k += 1;
        }
        let mut crossed = None;
        while crossed.is_none() {
            if s.observe(Ticks(k * CLK), post) == ShiftEvent::Crossing {
                crossed = Some(k);
            }
            k += 1;
        }
        assert_eq!(
            crossed,
            Some(real + 33),
            "detected N_c clocks after it began"
        );
        assert_eq!(s.last_crossing(), Ticks(real * CLK), "dated back");
        assert_eq!(s.post_end(), Some(Ticks((real + 500) * CLK)));
    }

    /// A 150° shifter handed over in sector 0 at t = 0 with t_60 = 1000 clocks.
    fn handed_over_150() -> PhaseShifter {
        let mut s = PhaseShifter::new(
            Table::TwelveStep {
                conduction_deg: 150.0,
            },
            Ticks(320),
        );
        s.hand_over(0, Ticks(0), 1000, true);
        s
    }

    /// Crossing after the hand-over, then a measured t_60 of 1000 clocks.
    fn measured() -> PhaseShifter {
        let mut s = handed_over_150();
        for k in 1..=2u64 {
            let post = s.sector().rising;
            let t = Ticks(k * 32_000);
            assert_eq!(s.observe(t, post), ShiftEvent::Crossing);
            let tc = s.post_end().unwrap();
            s.poll(tc);
            s.observe(tc, !s.sector().rising);
        }
        assert_eq!(s.t60(), (1000, true));
        s
    }

    #[test]
    fn crossings_earlier_than_three_quarters_of_t60_are_not_plausible() {
        let mut s = measured();
        let post = s.sector().rising;
        // Armed (pre level since the commutation, past blanking), post level at 0.7·t60:
        // interference; at 0.75·t60 it is accepted.
        assert_eq!(s.observe(Ticks(64_000 + 22_400), post), ShiftEvent::None);
        assert_eq!(s.observe(Ticks(64_000 + 23_968), !post), ShiftEvent::None);
        assert_eq!(
            s.observe(Ticks(64_000 + 24_000), post),
            ShiftEvent::Crossing
        );
    }

    #[test]
    fn a_crossing_hidden_by_the_freewheel_is_taken_at_the_timeout_also_twice_in_a_row() {
        let mut s = handed_over_150();
        for k in 1..=2u64 {
            let post = s.sector().rising;
            s.observe(Ticks(k * 32_000), post);
            let tc = s.post_end().unwrap();
            s.poll(tc);
            if k == 1 {
                s.observe(tc, !s.sector().rising);
            }
        }
        // Sector entered at 80 000 with the post level only (clamped, never armed).
        let post = s.sector().rising;
        assert_eq!(s.observe(Ticks(80_032), post), ShiftEvent::None);
        assert_eq!(s.demag_timeout(), Some(Ticks(96_000)));
        assert_eq!(s.observe(Ticks(96_000), post), ShiftEvent::Crossing);
        assert_eq!(s.forced_crossings(), 1);
        // The next sector shows the post level only as well (the freewheel outlasts the
        // pre part again): forced again at its timeout, one t_60 later.
        let tc = s.post_end().unwrap();
        s.poll(tc);
        let post = s.sector().rising;
        assert_eq!(s.observe(Ticks(tc.0 + 32), post), ShiftEvent::None);
        assert_eq!(s.demag_timeout(), Some(Ticks(128_000)));
        assert_eq!(s.observe(Ticks(127_968), post), ShiftEvent::None);
        assert_eq!(s.observe(Ticks(128_000), post), ShiftEvent::Crossing);
        assert_eq!(s.forced_crossings(), 2);
        // A stalled rotor's terminal holds one level once the freewheel ends: it is the pre
        // level of the next sector (the slope alternates), which then waits for a crossing
        // that never comes (the timeout takes a post level only), so FG stops and the step
        // miss is not hidden.
        let level = post;
        let tc = s.post_end().unwrap();
        s.poll(tc);
        assert_eq!(level, !s.sector().rising);
        for t in [tc.0 + 32, 160_000, 300_000, 1_000_000] {
            assert_eq!(s.observe(Ticks(t), level), ShiftEvent::None);
        }
        assert_eq!(s.forced_crossings(), 2);
    }
}

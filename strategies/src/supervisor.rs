//! Plausibility supervisor: catches the lost synchronism the published step-miss detector
//! cannot see. Not part of the published chip; `control.supervisor = false` removes it.
//!
//! **Why step-miss is not enough.** With a stopped or crawling rotor the floating phase
//! carries no back-EMF, and its comparator follows what the bridge does to it: the
//! freewheel clamp after each commutation and the transients at PWM edges. The phase
//! shifter takes those for crossings and commutates on; FG keeps toggling, so FG is never
//! stuck for 50 ms, and the speed meter reports the rate of the false crossings (several
//! krpm) while the rotor stands still.
//!
//! **What gives it away.** A rotor at speed ω has a line-to-line back-EMF
//! E(ω) = V_DD·ω/ω₀, ω₀ the motor's no-load speed at full voltage. The bridge applies an
//! average d_eff·V_DD across the conducting pair, and motoring current can only flow while
//! d_eff·V_DD > E. d_eff is the PWM duty, or 1 when a linear region (full voltage) was in
//! force since the last update: the sampled current may come from that window, whose
//! length the guard does not fix (it lasts until the crossing is seen). So a measured current of at least `i_min` while
//! d_eff < f·ω_est/ω₀ says the rotor turns much slower than the chip believes (f < 1
//! leaves room for the resistive and switch drops, which only make the true requirement
//! larger, and for a wrong ω₀). With twelve-step a current there must also be a real share
//! of what the duty would drive into a locked rotor, at least `locked_share`·d_eff·I_lr
//! (I_lr = V_DD/(2R), the locked-rotor current at full voltage): its 3-phase states conduct
//! where a phase's back-EMF is near zero, so a decelerating drive still passes a trickle
//! (≈ 1.5 % of d·I_lr measured at 10 krpm) at a duty below half the believed back-EMF,
//! while a rotor that stands still draws 3–30 %. Six-step conducts only within ±30° of the
//! line-to-line peak, where the back-EMF is at least 0.87 of its peak, so the trickle
//! cannot flow there.
//! Coasting after a step down does not trip it: there the current is zero. ω_est is the phase shifter's, 60°/t_60: it exists two crossings after
//! the hand-over, where the FG meter needs ten electrical turns.
//!
//! The ADC takes one sample per PI update of a chopped current, so a single update can read
//! the on-time or the off-time; the supervisor trips when at least half of the last
//! `updates` updates were implausible, not on one sample.
//!
//! **A coast does not speed up.** At a low duty the false crossings draw too little current
//! to measure, and the speed loop, believing the rotor too fast, asks for none. The chip
//! then believes it coasts. A real coast only slows down (friction and load brake it, the
//! bridge adds no torque), so once the speed loop asks for no current and two successive
//! current samples read below `i_min`, an FG speed measurement more than `coast_rise`
//! above the lowest of the coast so far trips the supervisor. Ten FG periods average
//! the measurement, so a genuine coast stays far below that; false crossings jump by tens
//! of percent between measurements. An overhauling load that drives the rotor faster with
//! no current asked would trip it too: switch the supervisor off for such studies.
//!
//! **A rotor the comparator no longer shows.** At high speed and current the freewheel
//! after a commutation can outlast the pre part, so the crossing passes while the floating
//! terminal is still clamped; the phase shifter then takes it by its demagnetisation
//! timeout, dated where the last 60° interval predicts it. Such a crossing says nothing
//! about the rotor, and it measures t_60 as exactly the interval it was dated from: once
//! every crossing is taken that way the commutation free-runs at a frozen rate, while the
//! torque the speed loop asks for changes the rotor's speed. Under the current limit the
//! built-in motor gains ≈ 100 rpm per PI update near 7 krpm, and a commutation frozen
//! there falls 30° behind in ≈ 40 sectors (the gap grows as a·t²/2: n ≈ ω·√(3/(π·a)) sectors
//! for an electrical speed ω and acceleration a); a loaded rotor falls behind the same
//! way. This is what loses six-step's rotor at full duty on the way to top speed: there
//! the voltage covers any back-EMF and the speed loop asks for current, so the back-EMF
//! rule cannot see it. So `blind_sectors` crossings in a row that the comparator never
//! showed trip the supervisor. A healthy drive sees its crossings again within a few
//! sectors: runs of up to 5 occur after the hand-over and with six-step accelerating under
//! the current limit at 6–7 krpm, where every other freewheel lasts about the 30° pre part;
//! the default, two electrical turns (12), sits above them and well below the ≈ 40 in
//! which the rotor slips. n shrinks with the speed, so at low speed the slip may come
//! first; the trip then follows within 12 sectors (13 ms at 1500 rpm).

use crate::params::ControlParams;

/// The supervisor's state: which of the last updates were implausible.
#[derive(Clone, Debug, PartialEq)]
pub struct Supervisor {
    enabled: bool,
    no_load_rpm: f64,
    fraction: f64,
    current_a: f64,
    locked_rotor_a: f64,
    locked_share: f64,
    updates: u32,
    coast_rise: f64,
    history: u32,
    quiet: u32,
    coast_min: Option<f64>,
    blind_sectors: u32,
    blind: u32,
    trips: u32,
}

/// One PI update as the supervisor sees it.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Update {
    /// Believed speed from the last 60° interval \[rpm\].
    pub shifter_rpm: f64,
    /// An FG speed measurement completed since the last update \[rpm\].
    pub meter_rpm: Option<f64>,
    /// Effective duty in force while the current was sampled (0..1).
    pub duty_eff: f64,
    /// Measured current \[A\].
    pub current_a: f64,
    /// Whether the speed loop asks for current.
    pub torque_asked: bool,
    /// Whether the table is twelve-step (3-phase states conduct near a back-EMF zero).
    pub twelve_step: bool,
}

impl Supervisor {
    /// The supervisor configured by `control` (validated: `updates` ≤ 32).
    pub fn new(control: &ControlParams) -> Self {
        Supervisor {
            enabled: control.supervisor,
            no_load_rpm: control.supervisor_no_load_rpm,
            fraction: control.supervisor_emf_fraction,
            current_a: control.supervisor_current_a,
            locked_rotor_a: control.supervisor_locked_rotor_a,
            locked_share: control.supervisor_locked_share,
            updates: control.supervisor_updates.clamp(1, 32),
            coast_rise: control.supervisor_coast_rise,
            history: 0,
            quiet: 0,
            coast_min: None,
            blind_sectors: control.supervisor_blind_sectors.max(1),
            blind: 0,
            trips: 0,
        }
    }

    /// Forgets the history (after a restart or hand-over).
    pub fn reset(&mut self) {
        self.history = 0;
        self.quiet = 0;
        self.coast_min = None;
        self.blind = 0;
    }

    /// Whether one PI update is implausible: `current_a` measured while an effective duty
    /// `duty_eff` (0..1) was applied and the meter read `speed_rpm`.
    pub fn implausible(
        &self,
        speed_rpm: f64,
        duty_eff: f64,
        current_a: f64,
        twelve_step: bool,
    ) -> bool {
        let trickle = if twelve_step {
            self.locked_share * duty_eff * self.locked_rotor_a
        } else {
            0.0
        };
        current_a >= self.current_a.max(trickle)
            && duty_eff < self.fraction * speed_rpm / self.no_load_rpm
    }

    /// Records one PI update; true when the supervisor trips (it then starts afresh).
    pub fn update(&mut self, u: &Update) -> bool {
        if !self.enabled {
            return false;
        }
        let mask = if self.updates >= 32 {
            u32::MAX
        } else {
            (1u32 << self.updates) - 1
        };
        let bad = self.implausible(u.shifter_rpm, u.duty_eff, u.current_a, u.twelve_step);
        self.history = ((self.history << 1) | u32::from(bad)) & mask;
        let mut trip = 2 * self.history.count_ones() >= self.updates;
        if u.torque_asked || u.current_a >= self.current_a {
            self.quiet = 0;
            self.coast_min = None;
        } else {
            // Saturating: only its reaching 2 matters (16 days of quiet updates overflow).
            self.quiet = self.quiet.saturating_add(1);
        }
        if self.quiet >= 2
            && let Some(rpm) = u.meter_rpm
        {
            let min = self.coast_min.map_or(rpm, |m| m.min(rpm));
            trip |= rpm > (1.0 + self.coast_rise) * min;
            self.coast_min = Some(min);
        }
        if trip {
            self.reset();
            self.trips = self.trips.saturating_add(1);
        }
        trip
    }

    /// Records one accepted crossing: `seen` when the comparator showed it, false when the
    /// demagnetisation timeout took it. True when the supervisor trips (it then starts
    /// afresh): `blind_sectors` crossings in a row were not seen.
    pub fn crossing(&mut self, seen: bool) -> bool {
        if !self.enabled {
            return false;
        }
        self.blind = if seen { 0 } else { self.blind + 1 };
        let trip = self.blind >= self.blind_sectors;
        if trip {
            self.reset();
            self.trips = self.trips.saturating_add(1);
        }
        trip
    }

    /// Times it tripped.
    pub fn trips(&self) -> u32 {
        self.trips
    }
}

// The history of implausible updates and the trips; the thresholds are parameters.
drive_core::persist_fields!(Supervisor {
    history,
    quiet,
    coast_min,
    blind,
    trips
});

impl Supervisor {
    /// As the updates leave it: the history within its `updates` bits, fewer than half of
    /// them implausible (half trip it, and a trip clears it), fewer blind crossings in a
    /// row than trip it, and the lowest coasting reading one the meter gives (a whole
    /// number of rpm, `max_rpm` at most). Disabled, it keeps nothing.
    pub(crate) fn check_restored_with(&self, max_rpm: u64) -> Result<(), String> {
        use drive_core::state::check;
        let n = self.updates;
        let ones = self.history.count_ones();
        check((n >= 32 || self.history >> n == 0) && 2 * ones < n, || {
            format!(
                "supervisor.history = {:#x} (rule: within its {n} bits, fewer than half set, else it trips)",
                self.history
            )
        })?;
        check(self.blind < self.blind_sectors, || {
            format!(
                "supervisor.blind = {} (rule: fewer than the {} blind crossings that trip it)",
                self.blind, self.blind_sectors
            )
        })?;
        check(
            self.coast_min
                .is_none_or(|m| m.fract() == 0.0 && (0.0..=max_rpm as f64).contains(&m)),
            || {
                format!(
                    "supervisor.coast_min = {:?} (rule: a meter reading, a whole number of rpm up to {max_rpm})",
                    self.coast_min
                )
            },
        )?;
        check(
            self.enabled
                || (self.history, self.quiet, self.blind, self.coast_min) == (0, 0, 0, None),
            || "supervisor (rule: disabled, it keeps no history)".to_string(),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sup() -> Supervisor {
        Supervisor::new(&ControlParams {
            supervisor_no_load_rpm: 15000.0,
            supervisor_emf_fraction: 0.5,
            supervisor_current_a: 0.01,
            supervisor_updates: 8,
            supervisor_coast_rise: 0.25,
            supervisor_locked_rotor_a: 2.7,
            supervisor_locked_share: 0.03,
            ..ControlParams::default()
        })
    }

    #[test]
    fn a_restored_history_is_one_the_updates_leave() {
        let s = sup();
        s.check_restored_with(40_000).unwrap();
        let refused = |f: Supervisor, want: &str| {
            let e = f.check_restored_with(40_000).unwrap_err();
            assert!(e.starts_with(want), "{e}");
        };
        // 8 updates: 4 implausible trip it (and clear it), and bits beyond 8 are none.
        refused(
            Supervisor {
                history: 0b1111,
                ..s.clone()
            },
            "supervisor.history = 0xf",
        );
        refused(
            Supervisor {
                history: 1 << 8,
                ..s.clone()
            },
            "supervisor.history = 0x100",
        );
        Supervisor {
            history: 0b0111,
            ..s.clone()
        }
        .check_restored_with(40_000)
        .unwrap();
        refused(
            Supervisor {
                blind: 12,
                ..s.clone()
            },
            "supervisor.blind = 12 (rule: fewer than the 12",
        );
        refused(
            Supervisor {
                coast_min: Some(1e30),
                ..s.clone()
            },
            "supervisor.coast_min = Some(1e30)",
        );
        refused(
            Supervisor {
                coast_min: Some(2999.5),
                ..s.clone()
            },
            "supervisor.coast_min = Some(2999.5)",
        );
        let off = Supervisor {
            enabled: false,
            quiet: 3,
            ..s.clone()
        };
        assert!(
            off.check_restored_with(40_000)
                .unwrap_err()
                .contains("disabled")
        );
    }

    #[test]
    fn current_below_the_back_emf_of_the_believed_speed_is_implausible() {
        let s = sup();
        // Believed 6000 rpm: E = 0.4·V_DD, half of it 0.2. Duty 0.15 with 0.05 A: impossible.
        assert!(s.implausible(6000.0, 0.15, 0.05, false));
        // Duty 0.25 covers half the back-EMF: plausible (drops and ω₀ may be off).
        assert!(!s.implausible(6000.0, 0.25, 0.05, false));
        // No current (coasting after a step down, E > d·V_DD): plausible.
        assert!(!s.implausible(6000.0, 0.0, 0.0, false));
        // Twelve-step: a trickle below 3 % of the locked-rotor current at that duty
        // (0.03·0.15·2.7 = 12.15 mA) is what it passes near a phase's EMF zero; plausible.
        assert!(!s.implausible(6000.0, 0.15, 0.0115, true));
        assert!(s.implausible(6000.0, 0.15, 0.0125, true));
        assert!(
            s.implausible(6000.0, 0.15, 0.0115, false),
            "six-step has no trickle"
        );
    }

    fn at(rpm: f64, duty_eff: f64, current_a: f64) -> Update {
        Update {
            shifter_rpm: rpm,
            meter_rpm: None,
            duty_eff,
            current_a,
            torque_asked: true,
            twelve_step: false,
        }
    }

    #[test]
    fn trips_when_half_of_the_last_updates_are_implausible() {
        let mut s = sup();
        // Alternating samples (on-time, off-time): the 4th bad one of 8 trips.
        let mut trips = Vec::new();
        for k in 0..8 {
            let i = if k % 2 == 0 { 0.05 } else { 0.0 };
            trips.push(s.update(&at(6000.0, 0.1, i)));
        }
        assert_eq!(
            trips,
            [false, false, false, false, false, false, true, false]
        );
        assert_eq!(s.trips(), 1);
        // Isolated bad samples among good ones never trip.
        let mut s = sup();
        for k in 0..100 {
            let duty = if k % 4 == 0 { 0.1 } else { 0.5 };
            assert!(!s.update(&at(6000.0, duty, 0.05)));
        }
    }

    fn coast(meter_rpm: Option<f64>, current_a: f64) -> Update {
        Update {
            shifter_rpm: meter_rpm.unwrap_or(3000.0),
            meter_rpm,
            duty_eff: 0.0,
            current_a,
            torque_asked: false,
            twelve_step: false,
        }
    }

    #[test]
    fn a_coast_that_speeds_up_trips() {
        let mut s = sup();
        // A genuine coast: measurements fall (with 2 % jitter), no current.
        for k in 0..50 {
            let rpm = 8000.0 - 100.0 * k as f64 + if k % 2 == 0 { 80.0 } else { -80.0 };
            assert!(!s.update(&coast(Some(rpm), 0.0)), "k = {k}");
        }
        // Then 30 % above the lowest (3020 rpm): impossible without torque.
        assert!(s.update(&coast(Some(3020.0 * 1.3), 0.0)));
        // Current flowing or torque asked: not a coast, nothing compared.
        let mut s = sup();
        assert!(!s.update(&coast(Some(3000.0), 0.0)));
        assert!(!s.update(&coast(Some(3000.0), 0.0)));
        assert!(!s.update(&coast(Some(1000.0), 0.0)));
        assert!(!s.update(&coast(None, 0.02)));
        assert!(!s.update(&coast(Some(5000.0), 0.0)), "coast restarted");
        assert!(
            !s.update(&coast(Some(5000.0), 0.0)),
            "its first measurement"
        );
        assert!(s.update(&coast(Some(6300.0), 0.0)));
    }
    #[test]
    fn a_run_of_crossings_the_comparator_never_showed_trips() {
        let mut s = Supervisor::new(&ControlParams {
            supervisor_blind_sectors: 12,
            ..ControlParams::default()
        });
        // Runs of 11 unseen crossings, each ended by a seen one: never.
        for _ in 0..10 {
            for _ in 0..11 {
                assert!(!s.crossing(false));
            }
            assert!(!s.crossing(true));
        }
        // The 12th in a row trips, and the count starts afresh.
        for k in 1..=24 {
            assert_eq!(s.crossing(false), k % 12 == 0, "k = {k}");
        }
        assert_eq!(s.trips(), 2);
        // A restart forgets a run in progress.
        for _ in 0..11 {
            s.crossing(false);
        }
        s.reset();
        assert!(!s.crossing(false));
    }

    #[test]
    fn disabled_never_trips() {
        let mut s = Supervisor::new(&ControlParams {
            supervisor: false,
            ..ControlParams::default()
        });
        for k in 0..100 {
            assert!(!s.update(&at(10_000.0, 0.0, 1.0)));
            assert!(!s.update(&coast(Some(1000.0 * f64::from(k)), 0.0)));
            assert!(!s.crossing(false));
        }
    }
}

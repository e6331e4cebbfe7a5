//! Commutation tables (docs/chip.md) and the sector view the phase shifter works in.
//!
//! Both strategies are driven crossing to crossing. Sector k (k = 0..5) starts at the
//! back-EMF zero crossing at θe = 60°·k. After the crossing the drive applies a *post*
//! pattern for a fixed fraction of the last 60° interval, then a *pre* pattern in which one
//! phase floats and its comparator is watched for the next crossing, at 60°·(k+1).
//!
//! - Twelve-step with conduction angle α: post = the 3-phase state 2k+1 for (α − 120)°,
//!   pre = the 2-phase state 2k+2 for (180 − α)°. At α = 150° this is the published table.
//! - Six-step 120°: the crossing falls mid-state, so post = six-step state k+1 (its second
//!   half, 30°) and pre = state k+2 (its first half, 30°).

use drive_core::bridge::{ALL_FLOAT, Gates, LegState, SIX_STEP_120};
use drive_core::{Abc, Pattern, Phase};

/// One row of the chip's twelve-step table.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct TwelveStepRow {
    /// State number 1..12; it spans θe = 30°·(state − 1) .. +30° at 150° conduction.
    pub state: u8,
    /// Leg states u, v, w.
    pub pattern: Pattern,
    /// The chip's 4-bit bridge flag.
    pub flag: u8,
    /// Speed pulse FG_c.
    pub fg: bool,
}

/// The chip's "off" flag: every leg floating.
pub const OFF_FLAG: u8 = 0b0110;

/// docs/chip.md, 150° twelve-step, states 1..12 (index 0..11).
pub const TWELVE_STEP: [TwelveStepRow; 12] = {
    use LegState::{Float as F, High as V, Low as G};
    const fn row(
        state: u8,
        u: LegState,
        v: LegState,
        w: LegState,
        flag: u8,
        fg: bool,
    ) -> TwelveStepRow {
        TwelveStepRow {
            state,
            pattern: Abc { u, v, w },
            flag,
            fg,
        }
    }
    [
        row(1, V, G, V, 0b1000, false),
        row(2, V, G, F, 0b0100, false),
        row(3, V, G, G, 0b1001, false),
        row(4, V, F, G, 0b0101, false),
        row(5, V, V, G, 0b1010, false),
        row(6, F, V, G, 0b0000, true),
        row(7, G, V, G, 0b1011, true),
        row(8, G, V, F, 0b0001, true),
        row(9, G, V, V, 0b1100, true),
        row(10, G, F, V, 0b0010, true),
        row(11, G, G, V, 0b1101, true),
        row(12, F, G, V, 0b0011, false),
    ]
};

/// The chip's bridge flag of a pattern (0110 for all-floating), or `None` for a pattern
/// the table does not contain.
pub fn flag_of(pattern: &Pattern) -> Option<u8> {
    if *pattern == ALL_FLOAT {
        return Some(OFF_FLAG);
    }
    TWELVE_STEP
        .iter()
        .find(|r| r.pattern == *pattern)
        .map(|r| r.flag)
}

/// The chip's gate signals Tr1..Tr6 of a pattern held without chopping.
pub fn chip_signals(pattern: &Pattern) -> [u8; 6] {
    Gates::from_pattern(pattern).to_chip_signals()
}

/// Which commutation table a strategy steps through.
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum Table {
    /// 120° six-step, commutating 30° after each crossing.
    SixStep,
    /// Twelve-step with the given conduction angle [electrical degrees, 120 ≤ α < 180].
    TwelveStep {
        /// Conduction angle α.
        conduction_deg: f64,
    },
}

/// What the drive applies in one sector (crossing to crossing).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct Sector {
    /// Pattern from the crossing until the post delay has elapsed.
    pub post: Pattern,
    /// Pattern from then until the next crossing; exactly one phase floats.
    pub pre: Pattern,
    /// State number (1..12 or 1..6) of `post` and of `pre`.
    pub states: (u8, u8),
    /// The floating phase of `pre`, whose comparator signals the next crossing.
    pub sensed: Phase,
    /// Whether that comparator goes 0 → 1 at the crossing (the phase was tied low before).
    pub rising: bool,
}

/// Each table's six sectors, built at compile time: the shifter asks for its sector several
/// times a controller tick, and decoding the floating phase each time cost ≈ 200
/// instructions a tick.
const SIX_STEP_SECTORS: [Sector; 6] = sectors(false);
const TWELVE_STEP_SECTORS: [Sector; 6] = sectors(true);

/// The sectors of six-step (`twelve` false) or twelve-step: post = six-step state k+1 and
/// pre = state k+2, or post = twelve-step state 2k+1 and pre = 2k+2.
const fn sectors(twelve: bool) -> [Sector; 6] {
    let mut out = [sector_of(ALL_FLOAT, ALL_FLOAT, (0, 0)); 6];
    let mut k = 0;
    while k < 6 {
        out[k] = if twelve {
            sector_of(
                TWELVE_STEP[2 * k].pattern,
                TWELVE_STEP[2 * k + 1].pattern,
                (2 * k as u8 + 1, 2 * k as u8 + 2),
            )
        } else {
            sector_of(
                SIX_STEP_120[k],
                SIX_STEP_120[(k + 1) % 6],
                (k as u8 + 1, ((k + 1) % 6) as u8 + 1),
            )
        };
        k += 1;
    }
    out
}

/// One sector from its patterns and state numbers. The table guarantees one floating phase
/// in every pre pattern (tested below); u stands in where there is none.
const fn sector_of(post: Pattern, pre: Pattern, states: (u8, u8)) -> Sector {
    const fn floats(l: LegState) -> bool {
        matches!(l, LegState::Float)
    }
    let (sensed, post_leg) = if floats(pre.u) && !floats(pre.v) && !floats(pre.w) {
        (Phase::U, post.u)
    } else if floats(pre.v) && !floats(pre.u) && !floats(pre.w) {
        (Phase::V, post.v)
    } else if floats(pre.w) && !floats(pre.u) && !floats(pre.v) {
        (Phase::W, post.w)
    } else {
        (Phase::U, post.u)
    };
    Sector {
        post,
        pre,
        states,
        sensed,
        rising: matches!(post_leg, LegState::Low),
    }
}

impl Table {
    /// Sector `k` (0..5, starting at θe = 60°·k; taken modulo 6).
    pub fn sector(&self, k: usize) -> Sector {
        self.sectors()[k % 6]
    }

    /// The six sectors, from θe = 0.
    pub fn sectors(&self) -> &'static [Sector; 6] {
        match self {
            Table::SixStep => &SIX_STEP_SECTORS,
            Table::TwelveStep { .. } => &TWELVE_STEP_SECTORS,
        }
    }

    /// Commutation states per electrical turn: 6 or 12.
    pub fn states_per_turn(&self) -> u32 {
        match self {
            Table::SixStep => 6,
            Table::TwelveStep { .. } => 12,
        }
    }

    /// Length of the post part as a fraction num/den of the last 60° interval: 1/2 for
    /// six-step, (α − 120)/60 for twelve-step, with α in hundredths of a degree.
    pub fn post_fraction(&self) -> (u64, u64) {
        match self {
            Table::SixStep => (1, 2),
            Table::TwelveStep { conduction_deg } => {
                (((conduction_deg - 120.0) * 100.0).round() as u64, 6000)
            }
        }
    }

    /// Start of state `state` in electrical degrees at nominal timing (the table boundary a
    /// commutation into that state should coincide with), in 0..360.
    pub fn state_start_deg(&self, state: u8) -> f64 {
        let k = f64::from(state.max(1) - 1);
        match self {
            Table::SixStep => (k * 60.0 - 30.0).rem_euclid(360.0),
            Table::TwelveStep { conduction_deg } => {
                let sector = (k / 2.0).floor();
                if state % 2 == 1 {
                    sector * 60.0
                } else {
                    sector * 60.0 + conduction_deg - 120.0
                }
            }
        }
    }

    /// FG_c of a state: high for θe in 150..330 (the published FG column, and the same
    /// half-turn split for six-step states 4..6), so one FG period is one electrical turn.
    pub fn fg(&self, state: u8) -> bool {
        match self {
            Table::SixStep => (4..=6).contains(&state),
            Table::TwelveStep { .. } => TWELVE_STEP[usize::from(state.clamp(1, 12) - 1)].fg,
        }
    }
}

/// Six-step: a placeholder to restore a saved table into.
impl Default for Table {
    fn default() -> Self {
        Table::SixStep
    }
}

/// Six-step as code 0, twelve-step as code 1, then the conduction angle (by its rule).
impl drive_core::Persist for Table {
    fn save(&self, w: &mut drive_core::Writer) {
        // Fixed size: six-step writes its 120° too.
        let (code, deg) = match *self {
            Table::SixStep => (0, 120.0),
            Table::TwelveStep { conduction_deg } => (1, conduction_deg),
        };
        w.u8(code);
        drive_core::Persist::save(&deg, w);
    }
    fn restore(&mut self, r: &mut drive_core::Reader) -> Result<(), String> {
        let code = r.u8()?;
        let mut deg = 0.0;
        r.field("conduction_deg", &mut deg)?;
        *self = match code {
            0 if deg == 120.0 => Table::SixStep,
            0 => {
                return Err(format!(
                    "conduction_deg = {deg} (rule: 120 for six-step, as saved)"
                ));
            }
            1 => {
                if !(120.0..180.0).contains(&deg) {
                    return Err(format!(
                        "conduction_deg = {deg} (rule: 120 <= x < 180 electrical degrees)"
                    ));
                }
                Table::TwelveStep {
                    conduction_deg: deg,
                }
            }
            k => return Err(format!("= {k} (rule: a table code 0 or 1)")),
        };
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The published Tr1..Tr6 per state (state 1 first), and the θe range each starts at.
    const PRINTED_TR: [[u8; 6]; 12] = [
        [0, 0, 1, 1, 0, 0],
        [0, 0, 1, 1, 1, 0],
        [0, 0, 1, 1, 1, 1],
        [0, 0, 1, 0, 1, 1],
        [0, 0, 0, 0, 1, 1],
        [1, 0, 0, 0, 1, 1],
        [1, 1, 0, 0, 1, 1],
        [1, 1, 0, 0, 1, 0],
        [1, 1, 0, 0, 0, 0],
        [1, 1, 1, 0, 0, 0],
        [1, 1, 1, 1, 0, 0],
        [1, 0, 1, 1, 0, 0],
    ];

    #[test]
    fn twelve_step_gate_signals_flags_and_fg_match_the_printed_table() {
        let flags = [
            0b1000, 0b0100, 0b1001, 0b0101, 0b1010, 0b0000, 0b1011, 0b0001, 0b1100, 0b0010, 0b1101,
            0b0011,
        ];
        let fg = [0, 0, 0, 0, 0, 1, 1, 1, 1, 1, 1, 0];
        for (i, row) in TWELVE_STEP.iter().enumerate() {
            assert_eq!(row.state as usize, i + 1);
            assert_eq!(chip_signals(&row.pattern), PRINTED_TR[i], "state {}", i + 1);
            assert_eq!(row.flag, flags[i], "state {}", i + 1);
            assert_eq!(row.fg, fg[i] == 1, "state {}", i + 1);
            assert_eq!(flag_of(&row.pattern), Some(flags[i]));
        }
        assert_eq!(chip_signals(&ALL_FLOAT), [1, 0, 1, 0, 1, 0]);
        assert_eq!(flag_of(&ALL_FLOAT), Some(OFF_FLAG));
        // Flags are distinct, so the flag alone selects the state.
        let mut f: Vec<u8> = TWELVE_STEP.iter().map(|r| r.flag).collect();
        f.push(OFF_FLAG);
        f.sort();
        f.dedup();
        assert_eq!(f.len(), 13);
    }

    /// Over a full electrical turn the twelve-step table is the 180° table with the 30°
    /// before each crossing floated: each phase conducts 150° per half cycle, starting at
    /// its own back-EMF crossing (u: 0°, v: 120°, w: 240°).
    #[test]
    fn each_phase_conducts_150_degrees_per_half_cycle_from_its_crossing() {
        for (x, crossing) in [(Phase::U, 0), (Phase::V, 120), (Phase::W, 240)] {
            for half in 0..2 {
                let want = if half == 0 {
                    LegState::High
                } else {
                    LegState::Low
                };
                let start = (crossing + 180 * half) % 360;
                for deg in (0..360).step_by(30) {
                    let rel = (deg + 360 - start) % 360;
                    let s = TWELVE_STEP[deg / 30].pattern.get(x);
                    if rel < 150 {
                        assert_eq!(s, want, "phase {x:?} at {deg}°");
                    } else if rel < 180 {
                        assert_eq!(s, LegState::Float, "phase {x:?} at {deg}°");
                    }
                }
            }
        }
    }

    #[test]
    fn sectors_sense_the_phase_whose_back_emf_crosses_at_the_sector_end() {
        // e_u = sin θ, e_v = sin(θ − 120°), e_w = sin(θ + 120°): at the end of sector k
        // (θ = 60°·(k+1)) the sensed phase's back-EMF must be zero and going the stated way.
        for table in [
            Table::SixStep,
            Table::TwelveStep {
                conduction_deg: 150.0,
            },
        ] {
            for k in 0..6 {
                let s = table.sector(k);
                let th = (60.0 * (k as f64 + 1.0)).to_radians();
                let off = [0.0, -120f64.to_radians(), 120f64.to_radians()][s.sensed.index()];
                assert!((th + off).sin().abs() < 1e-9, "{table:?} sector {k}");
                assert_eq!((th + off).cos() > 0.0, s.rising, "{table:?} sector {k}");
                assert_eq!(drive_core::bridge::floating_phase(&s.pre), Some(s.sensed));
                assert_eq!(s.rising, s.post.get(s.sensed) == LegState::Low);
            }
        }
    }

    #[test]
    fn sectors_are_the_tables_rows() {
        for k in 0..12 {
            let (s6, s12) = (
                Table::SixStep.sector(k),
                Table::TwelveStep {
                    conduction_deg: 150.0,
                }
                .sector(k),
            );
            let j = k % 6;
            assert_eq!(s6.post, SIX_STEP_120[j]);
            assert_eq!(s6.pre, SIX_STEP_120[(j + 1) % 6]);
            assert_eq!(s6.states, (j as u8 + 1, ((j + 1) % 6) as u8 + 1));
            assert_eq!(s12.post, TWELVE_STEP[2 * j].pattern);
            assert_eq!(s12.pre, TWELVE_STEP[2 * j + 1].pattern);
            assert_eq!(s12.states, (2 * j as u8 + 1, 2 * j as u8 + 2));
        }
    }

    #[test]
    fn post_fractions_and_state_boundaries() {
        assert_eq!(Table::SixStep.post_fraction(), (1, 2));
        let t150 = Table::TwelveStep {
            conduction_deg: 150.0,
        };
        assert_eq!(t150.post_fraction(), (3000, 6000));
        for s in 1..=12u8 {
            assert_eq!(t150.state_start_deg(s), 30.0 * f64::from(s - 1));
        }
        let t165 = Table::TwelveStep {
            conduction_deg: 165.0,
        };
        assert_eq!(t165.state_start_deg(2), 45.0);
        assert_eq!(t165.state_start_deg(3), 60.0);
        assert_eq!(Table::SixStep.state_start_deg(1), 330.0);
        assert_eq!(Table::SixStep.state_start_deg(2), 30.0);
    }
}

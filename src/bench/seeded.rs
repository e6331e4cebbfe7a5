//! The runs a bisection turns from one seed speed share their start-up: the drive started
//! at the seed and run to the turn ([`range::TURN_DOWN_S`]) is simulated once, and each
//! turned run forks from it ([`Run::fork`]). A fork's summary is the run's from standstill,
//! bit for bit, so the floors and tops found are the same; only the start-up's CPU time
//! is saved (a strategy that cannot copy itself runs each from standstill).

use super::range::{self, TURN_DOWN_S};
use crate::config::DriveConfig;
use crate::scenario::{ForkError, Outcome, Run, RunError, Scenario, Summary, run, settled};
use strategies::PluginLibrary;

/// A drive started at a seed speed, for the runs turned from it at [`TURN_DOWN_S`].
pub struct Seeded<'a> {
    config: &'a DriveConfig,
    plugin: Option<&'a PluginLibrary>,
    seed_rpm: f64,
    /// The run standing at the turn, made by the first turned run; `None` before, and
    /// for good once the strategy refused to copy itself.
    at_turn: Option<Run>,
    copies: bool,
}

impl<'a> Seeded<'a> {
    /// `config`'s strategy (or `plugin`'s) started at `seed_rpm`; nothing runs yet.
    pub fn new(config: &'a DriveConfig, plugin: Option<&'a PluginLibrary>, seed_rpm: f64) -> Self {
        Seeded {
            config,
            plugin,
            seed_rpm,
            at_turn: None,
            copies: true,
        }
    }

    /// The seed speed \[rpm\].
    pub fn seed_rpm(&self) -> f64 {
        self.seed_rpm
    }

    /// Whether the drive holds `rpm` after being turned to it ([`range::turned`]), with
    /// the run's summary (lengthened while its window falls in the settling, as
    /// [`range::held_after_turn_down`] does).
    pub fn held(&mut self, rpm: f64) -> Result<(bool, Summary), RunError> {
        let s = self.settled(rpm)?.summary;
        Ok((range::holds(&s), s))
    }

    /// The turned run to `rpm`, lengthened as [`settled`] does.
    pub fn settled(&mut self, rpm: f64) -> Result<Outcome, RunError> {
        let mut sc = range::turned(self.config, self.seed_rpm, rpm, TURN_DOWN_S);
        sc.plugin = self.plugin.cloned();
        // Held at the seed, the command has no setting at the turn to fork at.
        if rpm == self.seed_rpm {
            return Ok(settled(&sc, |s| run(s, |_| {}))?.1);
        }
        Ok(settled(&sc, |s| self.outcome(s))?.1)
    }

    /// `sc` (turned from the seed at [`TURN_DOWN_S`]) forked from the run at the turn.
    fn outcome(&mut self, sc: &Scenario) -> Result<Outcome, RunError> {
        if !self.copies {
            return run(sc, |_| {});
        }
        let at_turn = match self.at_turn.take() {
            Some(r) => r,
            None => {
                let mut r = Run::start(sc)?;
                r.advance_to(TURN_DOWN_S, |_| {}, |_| {})?;
                r
            }
        };
        let forked = at_turn.fork(sc);
        self.at_turn = Some(at_turn);
        match forked {
            Ok(r) => r.finish(|_| {}, |_| {}),
            Err(RunError::Fork(ForkError::Copy(_))) => {
                (self.copies, self.at_turn) = (false, None);
                run(sc, |_| {})
            }
            Err(e) => Err(e),
        }
    }
}

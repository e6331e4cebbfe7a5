//! The gate driver: turns commanded gates into effective gates with dead time.
//!
//! A switch turns off at once; a turn-on is delayed by the dead time, so the complementary
//! switch that was just turned off has time to stop conducting. During that gap the leg's
//! current flows through a diode, which is exactly the effect dead time has on a real bridge.

use crate::bridge::{GateMask, Gates, ShootThrough};
use crate::time::Ticks;

/// Dead-time gate driver for the six switches.
#[derive(Clone, Debug)]
pub struct GateDriver {
    dead_time: Ticks,
    commanded: GateMask,
    effective: GateMask,
    /// Turn-on instants still waiting out the dead time, in order Tr1..Tr6.
    pending_on: [Ticks; 6],
}

impl GateDriver {
    /// A driver with every switch off. `dead_time` = 0 passes commands straight through.
    pub fn new(dead_time: Ticks) -> Self {
        GateDriver {
            dead_time,
            commanded: GateMask::OFF,
            effective: GateMask::OFF,
            pending_on: [Ticks::NEVER; 6],
        }
    }

    /// The gates the bridge actually sees.
    pub fn effective(&self) -> Gates {
        self.effective.into()
    }

    /// [`GateDriver::effective`] as a mask.
    pub fn effective_mask(&self) -> GateMask {
        self.effective
    }

    /// The dead time \[ticks\].
    pub fn dead_time(&self) -> Ticks {
        self.dead_time
    }

    /// Takes a new command at `now`; refuses a shoot-through command.
    pub fn command(&mut self, now: Ticks, gates: GateMask) -> Result<(), ShootThrough> {
        gates.validate()?;
        self.commanded = gates;
        if self.dead_time == Ticks::ZERO {
            // Every turn-on is released at once: what the loop below and `release` would
            // do, without them (no turn-on is ever left pending).
            self.effective = gates;
            return Ok(());
        }
        let mut eff = self.effective;
        for (k, pending) in self.pending_on.iter_mut().enumerate() {
            if !gates.is_on(k) {
                eff = eff.with(k, false);
                *pending = Ticks::NEVER;
            } else if !eff.is_on(k) && *pending == Ticks::NEVER {
                *pending = now + self.dead_time;
            }
        }
        self.effective = eff;
        self.release(now);
        Ok(())
    }

    /// Applies every turn-on whose dead time has elapsed by `now`; true if anything changed.
    pub fn release(&mut self, now: Ticks) -> bool {
        let mut changed = false;
        for (k, pending) in self.pending_on.iter_mut().enumerate() {
            if *pending <= now {
                self.effective = self.effective.with(k, true);
                *pending = Ticks::NEVER;
                changed = true;
            }
        }
        changed
    }

    /// The next pending turn-on, or [`Ticks::NEVER`].
    pub fn next_release(&self) -> Ticks {
        if self.dead_time == Ticks::ZERO {
            // Without dead time nothing is ever pending (see `command`).
            return Ticks::NEVER;
        }
        self.pending_on
            .iter()
            .copied()
            .min()
            .unwrap_or(Ticks::NEVER)
    }
}

// The gates and pending turn-ons; the dead time is a parameter.
crate::persist_fields!(GateDriver { commanded, effective, pending_on } then GateDriver::check_restored);

impl GateDriver {
    /// Restored gates never short a leg; without dead time no turn-on waits (a driver
    /// without it never holds one: see `command`).
    fn check_restored(&self) -> Result<(), String> {
        for g in [self.commanded, self.effective] {
            g.validate().map_err(|e| format!(" {e}"))?;
        }
        if self.dead_time == Ticks::ZERO && self.pending_on != [Ticks::NEVER; 6] {
            return Err(format!(
                "pending_on = {:?} (rule: none pending without dead time)",
                self.pending_on.map(|t| t.0)
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn turn_on_waits_dead_time_turn_off_is_immediate() {
        let mut d = GateDriver::new(Ticks(10));
        let mut g = Gates::OFF;
        g.high.u = true;
        d.command(Ticks(0), g.into()).unwrap();
        assert!(!d.effective().high.u);
        assert_eq!(d.next_release(), Ticks(10));
        assert!(d.release(Ticks(10)));
        assert!(d.effective().high.u);
        // complementary switch-over: high off now, low on after the dead time
        let mut g2 = Gates::OFF;
        g2.low.u = true;
        d.command(Ticks(20), g2.into()).unwrap();
        assert!(!d.effective().high.u && !d.effective().low.u);
        d.release(Ticks(29));
        assert!(!d.effective().low.u);
        d.release(Ticks(30));
        assert!(d.effective().low.u);
    }

    #[test]
    fn zero_dead_time_passes_through() {
        let mut d = GateDriver::new(Ticks(0));
        let mut g = Gates::OFF;
        g.low.w = true;
        d.command(Ticks(5), g.into()).unwrap();
        assert_eq!(d.effective(), g);
        assert_eq!(d.next_release(), Ticks::NEVER);
    }
}

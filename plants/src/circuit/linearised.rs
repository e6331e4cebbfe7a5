//! The network in one conduction state as an affine map, for the integrators that step
//! within a topology.

use super::{Circuit, Conduction, Powers};
use drive_core::Abc;

/// The network for one conduction state as an affine map (the topology is constant between
/// events): di/dt = c + K·i + Q·e, with the loss weights of each leg. Built from
/// [`Circuit::solve`] on basis vectors, so it cannot drift from it.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct Linearised {
    c: [f64; 3],
    k: [[f64; 3]; 3],
    q: [[f64; 3]; 3],
    supply: [f64; 3],
    switch_r: [f64; 3],
    diode_r: [f64; 3],
    diode_vf: [f64; 3],
    low: [f64; 3],
    /// How each leg conducts: which of the weights above it has (see
    /// [`Linearised::drawn`]).
    legs: [Conduction; 3],
    r: f64,
    r_sh: f64,
}

impl Linearised {
    /// di/dt and the powers for currents `i` and back-EMFs `e`.
    #[inline]
    pub fn eval(&self, i: &[f64; 3], e: &[f64; 3]) -> ([f64; 3], Powers) {
        let mut di = self.c;
        for (r, d) in di.iter_mut().enumerate() {
            for j in 0..3 {
                *d += self.k[r][j] * i[j] + self.q[r][j] * e[j];
            }
        }
        (di, self.powers(i, e))
    }

    /// The powers for currents `i` and back-EMFs `e`.
    #[inline]
    pub fn powers(&self, i: &[f64; 3], e: &[f64; 3]) -> Powers {
        let mut p = Powers::default();
        let mut i_sh = 0.0;
        for j in 0..3 {
            let (x, x2) = (i[j], i[j] * i[j]);
            p.supply += self.supply[j] * x;
            p.copper += self.r * x2;
            p.switch += self.switch_r[j] * x2;
            p.diode += self.diode_vf[j] * x.abs() + self.diode_r[j] * x2;
            p.airgap += e[j] * x;
            i_sh -= self.low[j] * x;
        }
        p.shunt = self.r_sh * i_sh * i_sh;
        p
    }

    /// [`Linearised::powers`] at two sets of currents, `a` and `b`, without the airgap
    /// power (left 0; the modal step makes it from the torque), adding only the terms each
    /// leg's kind weights: for finite currents the same values bit for bit, since a leg's
    /// zero weight adds ±0.0 to a sum that starts at +0.0 and so is never −0.0. The two
    /// sets side by side share the legs' decoding.
    #[inline(always)]
    pub fn drawn(&self, a: &[f64; 3], b: &[f64; 3]) -> (Powers, Powers) {
        let (mut supply, mut copper, mut switch, mut diode, mut i_sh) =
            ([0.0; 2], [0.0; 2], [0.0; 2], [0.0; 2], [0.0; 2]);
        for j in 0..3 {
            let x = [a[j], b[j]];
            let x2 = [x[0] * x[0], x[1] * x[1]];
            for l in 0..2 {
                copper[l] += self.r * x2[l];
            }
            let m = self.legs[j];
            if m.is_high() {
                for l in 0..2 {
                    supply[l] += self.supply[j] * x[l];
                }
            }
            if m.is_diode() {
                for l in 0..2 {
                    diode[l] += self.diode_vf[j] * x[l].abs() + self.diode_r[j] * x2[l];
                }
            } else if m.conducts() {
                for l in 0..2 {
                    switch[l] += self.switch_r[j] * x2[l];
                }
            }
            if m.is_low() {
                for l in 0..2 {
                    i_sh[l] -= self.low[j] * x[l];
                }
            }
        }
        let p = |l: usize| Powers {
            supply: supply[l],
            copper: copper[l],
            switch: switch[l],
            diode: diode[l],
            shunt: self.r_sh * i_sh[l] * i_sh[l],
            airgap: 0.0,
        };
        (p(0), p(1))
    }

    /// c, K and Q of di/dt = c + K·i + Q·e.
    pub fn parts(&self) -> (&[f64; 3], &[[f64; 3]; 3], &[[f64; 3]; 3]) {
        (&self.c, &self.k, &self.q)
    }
}

impl Circuit {
    /// The affine form of [`Circuit::solve`] for fixed `modes`.
    pub fn linearise(&self, modes: &Abc<Conduction>) -> Linearised {
        let zero = Abc::splat(0.0);
        let unit = |k: usize| Abc::from_fn(|p| if p.index() == k { 1.0 } else { 0.0 });
        let c = self.solve(modes, &zero, &zero).di.to_array();
        let mut lin = Linearised {
            c,
            r: self.r,
            r_sh: self.r_sh,
            ..Linearised::default()
        };
        for j in 0..3 {
            let di_i = self.solve(modes, &unit(j), &zero).di.to_array();
            let di_e = self.solve(modes, &zero, &unit(j)).di.to_array();
            for r in 0..3 {
                lin.k[r][j] = di_i[r] - c[r];
                lin.q[r][j] = di_e[r] - c[r];
            }
        }
        lin.legs = modes.to_array();
        for (j, m) in modes.to_array().into_iter().enumerate() {
            lin.supply[j] = if m.is_high() { self.vdd } else { 0.0 };
            lin.low[j] = if m.is_low() { 1.0 } else { 0.0 };
            if m.is_diode() {
                lin.diode_r[j] = self.r_d;
                lin.diode_vf[j] = self.vf;
            } else if m.conducts() {
                lin.switch_r[j] = self.r_on;
            }
        }
        lin
    }
}

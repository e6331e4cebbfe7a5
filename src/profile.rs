//! A quantity over time: piecewise linear through points, the way a drive engineer draws
//! a command or a load on paper.
//!
//! Through points (t₀, v₀), (t₁, v₁), … in time order the value is v₀ before t₀, linear
//! between neighbours, and the last value after the last point. Two points at one instant
//! make a step (the second value applies from that instant). In TOML a profile is a
//! number (constant) or a list of `[t_s, value]` pairs:
//!
//! ```toml
//! speed_rpm = [[0, 3000], [2, 3000], [2.5, 6000]]   # hold, then a 0.5 s ramp
//! supply_v = 12                                       # constant
//! ```
//!
//! A simulation applies a profile as a sequence of settings: each step at its instant,
//! and each ramp as a staircase of `update_s` stairs, each holding the ramp's mean over
//! its stair (so the staircase has the ramp's area: no lag of half a stair).

use drive_core::error::ParamError;
use plants::Load;
use serde::{Deserialize, Serialize};

/// A piecewise-linear function of time.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(from = "Repr", into = "Repr")]
pub struct Profile {
    points: Vec<(f64, f64)>,
}

#[derive(Serialize, Deserialize)]
#[serde(untagged)]
enum Repr {
    Constant(f64),
    Points(Vec<[f64; 2]>),
}

impl From<Repr> for Profile {
    fn from(r: Repr) -> Self {
        match r {
            Repr::Constant(v) => Profile::constant(v),
            Repr::Points(p) => Profile {
                points: p.into_iter().map(|[t, v]| (t, v)).collect(),
            },
        }
    }
}

impl From<Profile> for Repr {
    fn from(p: Profile) -> Self {
        match p.points.as_slice() {
            [(t, v)] if *t == 0.0 => Repr::Constant(*v),
            pts => Repr::Points(pts.iter().map(|&(t, v)| [t, v]).collect()),
        }
    }
}

impl Profile {
    /// `v` at all times.
    pub fn constant(v: f64) -> Self {
        Profile {
            points: vec![(0.0, v)],
        }
    }

    /// Through `points` (time \[s\], value), which [`Profile::validate`] checks.
    pub fn from_points(points: Vec<(f64, f64)>) -> Self {
        Profile { points }
    }

    /// Holds the value in force until `t_s`, then steps to `v`.
    pub fn step_to(mut self, t_s: f64, v: f64) -> Self {
        let last = self.last();
        self.points.push((t_s, last));
        self.points.push((t_s, v));
        self
    }

    /// Holds the value in force until `from_s`, then ramps linearly to `v` at `to_s`.
    pub fn ramp_to(mut self, from_s: f64, to_s: f64, v: f64) -> Self {
        let last = self.last();
        self.points.push((from_s, last));
        self.points.push((to_s, v));
        self
    }

    /// The points.
    pub fn points(&self) -> &[(f64, f64)] {
        &self.points
    }

    fn last(&self) -> f64 {
        self.points.last().map_or(0.0, |p| p.1)
    }

    /// The value at `t_s` (at a step, the value after it).
    pub fn value_at(&self, t_s: f64) -> f64 {
        let p = &self.points;
        // The first point later than t: the segment before it holds t.
        let k = p.partition_point(|q| q.0 <= t_s);
        match k {
            0 => p.first().map_or(0.0, |q| q.1),
            k if k == p.len() => p[k - 1].1,
            k => {
                let ((t0, v0), (t1, v1)) = (p[k - 1], p[k]);
                v0 + (v1 - v0) * (t_s - t0) / (t1 - t0)
            }
        }
    }

    /// The mean over [a, b] (the value at `a` when b <= a).
    fn mean_over(&self, a: f64, b: f64) -> f64 {
        if b <= a {
            return self.value_at(a);
        }
        // Linear within a segment: the mean of the ends, once split at the points inside.
        let mut cuts: Vec<f64> = self
            .points
            .iter()
            .map(|q| q.0)
            .filter(|&t| t > a && t < b)
            .collect();
        cuts.insert(0, a);
        cuts.push(b);
        let area: f64 = cuts
            .windows(2)
            .map(|w| {
                let (l, r) = (w[0], w[1]);
                // Just inside the piece: a step at its ends belongs to its neighbours.
                let eps = (r - l) * 1e-12;
                0.5 * (self.value_at(l + eps) + self.value_at(r - eps)) * (r - l)
            })
            .sum();
        area / (b - a)
    }

    /// Checks the points: at least one; finite times `0..=max_t_s` in order, at most two at
    /// one instant; each value passing `rule` (intervals are convex, so the values between
    /// points pass too). Errors name `key`.
    pub fn validate(
        &self,
        key: &str,
        max_t_s: f64,
        rule: impl Fn(f64) -> Result<(), ParamError>,
    ) -> Result<(), ParamError> {
        if self.points.is_empty() {
            return Err(ParamError::new(
                key,
                f64::NAN,
                "must be a number or a non-empty list of [t_s, value] pairs",
            ));
        }
        let mut prev: Option<f64> = None;
        let mut same = 0;
        for (k, &(t, v)) in self.points.iter().enumerate() {
            let at = format!("{key}[{k}]");
            drive_core::error::check_range(
                &format!("{at} time [s]"),
                t,
                0.0,
                max_t_s,
                "must be within 0..=duration_s",
            )?;
            if let Some(p) = prev {
                if t < p {
                    return Err(ParamError::new(
                        format!("{at} time [s]"),
                        t,
                        "must not precede the point before it (points in time order)",
                    ));
                }
                same = if t == p { same + 1 } else { 0 };
                if same > 1 {
                    return Err(ParamError::new(
                        format!("{at} time [s]"),
                        t,
                        "at most two points at one instant (a step)",
                    ));
                }
            }
            prev = Some(t);
            rule(v).map_err(|e| ParamError::new(&at, v, e.rule))?;
        }
        Ok(())
    }

    /// The settings that reproduce the profile over [0, `end_s`): (instant \[s\], value), the
    /// first at 0, then one at each step and one per `update_s` stair along each ramp.
    pub fn settings(&self, end_s: f64, update_s: f64) -> Vec<(f64, f64)> {
        let mut out = vec![(0.0, self.value_at(0.0))];
        let mut t = 0.0f64;
        // A setting at the instant of the last replaces it; an unchanged value is dropped.
        let push = |at: f64, v: f64, out: &mut Vec<(f64, f64)>| {
            if at >= end_s {
                return;
            }
            match out.last() {
                Some(l) if l.0 == at => *out.last_mut().expect("matched") = (at, v),
                Some(l) if l.1 == v => {}
                _ => out.push((at, v)),
            }
        };
        for w in self.points.windows(2) {
            let ((t0, v0), (t1, v1)) = (w[0], w[1]);
            if t1 <= 0.0 || t0 >= end_s {
                continue;
            }
            if t1 == t0 {
                push(t0, v1, &mut out);
                continue;
            }
            if v1 == v0 {
                continue;
            }
            t = t.max(t0);
            while t < t1 && t < end_s {
                let stair = (t + update_s).min(t1);
                push(t, self.mean_over(t, stair), &mut out);
                t = stair;
            }
            // The value after the ramp, held from its end.
            push(t1, v1, &mut out);
        }
        out
    }
}

impl Default for Profile {
    /// Zero at all times.
    fn default() -> Self {
        Profile::constant(0.0)
    }
}

/// The driven machine over time: each torque term of [`Load`] a profile, and the inertia
/// coupled to the rotor. Every term defaults to 0 (no load); each value passes [`Load`]'s
/// rule for its term.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LoadProfile {
    /// Active torque T_a [N·m], positive opposing positive rotation: it turns a stopped
    /// rotor backwards.
    pub active_nm: Profile,
    /// Coulomb load T_c [N·m]: opposes motion, never drives a rotor at rest.
    pub coulomb_nm: Profile,
    /// Viscous load B_L [N·m·s/rad].
    pub viscous_nms: Profile,
    /// Fan/pump coefficient K_f [N·m·s²/rad²]: T = K_f·ωm·|ωm|.
    pub fan_nms2: Profile,
    /// Inertia coupled to the rotor for the whole run J_L [kg·m²].
    pub inertia_kgm2: f64,
}

impl LoadProfile {
    /// A Coulomb (passive) load of `nm` from t = 0.
    pub fn coulomb(nm: f64) -> Self {
        LoadProfile {
            coulomb_nm: Profile::constant(nm),
            ..LoadProfile::default()
        }
    }

    /// The terms in [`Load::validate`]'s order, with their keys.
    pub fn terms(&self) -> [(&'static str, &Profile); 4] {
        [
            ("load.active_nm", &self.active_nm),
            ("load.coulomb_nm", &self.coulomb_nm),
            ("load.viscous_nms", &self.viscous_nms),
            ("load.fan_nms2", &self.fan_nms2),
        ]
    }

    /// The load at `t_s`.
    pub fn at(&self, t_s: f64) -> Load {
        let mut l = Load {
            inertia_kgm2: self.inertia_kgm2,
            ..Load::default()
        };
        for (k, (_, p)) in self.terms().iter().enumerate() {
            l.set_term(k, p.value_at(t_s));
        }
        l
    }

    /// Checks every point of every term by [`Load`]'s rules, times within `0..=max_t_s`.
    pub fn validate(&self, max_t_s: f64) -> Result<(), ParamError> {
        Load {
            inertia_kgm2: self.inertia_kgm2,
            ..Load::default()
        }
        .validate()?;
        for (k, (key, p)) in self.terms().iter().enumerate() {
            p.validate(key, max_t_s, |v| {
                let mut l = Load::default();
                l.set_term(k, v);
                l.validate()
            })?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_between_points_steps_and_ends() {
        let p = Profile::from_points(vec![(1.0, 10.0), (2.0, 20.0), (2.0, 5.0), (4.0, 5.0)]);
        assert_eq!(p.value_at(0.0), 10.0);
        assert_eq!(p.value_at(1.5), 15.0);
        assert_eq!(p.value_at(2.0), 5.0, "at a step the later value applies");
        assert_eq!(p.value_at(9.0), 5.0);
        assert_eq!(Profile::constant(3.0).value_at(7.0), 3.0);
    }

    #[test]
    fn a_ramp_becomes_stairs_with_the_ramps_area() {
        // 0 → 100 over 1..2 s in 0.25 s stairs: means 12.5, 37.5, 62.5, 87.5, then 100.
        let p = Profile::constant(0.0).ramp_to(1.0, 2.0, 100.0);
        let s = p.settings(3.0, 0.25);
        let want = [
            (0.0, 0.0),
            (1.0, 12.5),
            (1.25, 37.5),
            (1.5, 62.5),
            (1.75, 87.5),
            (2.0, 100.0),
        ];
        assert_eq!(s.len(), want.len(), "{s:?}");
        for (a, b) in s.iter().zip(want) {
            assert!(
                (a.0 - b.0).abs() < 1e-12 && (a.1 - b.1).abs() < 1e-9,
                "{s:?}"
            );
        }
    }

    #[test]
    fn steps_are_set_at_their_instant_and_nothing_after_the_end() {
        let p = Profile::constant(3000.0)
            .step_to(1.0, 6000.0)
            .step_to(5.0, 1000.0);
        assert_eq!(p.settings(4.0, 1e-3), vec![(0.0, 3000.0), (1.0, 6000.0)]);
    }

    #[test]
    fn toml_takes_a_number_or_pairs() {
        #[derive(Deserialize)]
        struct D {
            a: Profile,
            b: Profile,
        }
        let d: D = toml::from_str("a = 12\nb = [[0, 1], [2, 3.5]]").unwrap();
        assert_eq!(d.a, Profile::constant(12.0));
        assert_eq!(d.b.points(), &[(0.0, 1.0), (2.0, 3.5)]);
    }

    #[test]
    fn rules_name_the_point() {
        let ok = |v: f64| drive_core::error::check_range("x", v, 0.0, 10.0, "must be 0..=10");
        let p = Profile::from_points(vec![(0.0, 1.0), (2.0, 11.0)]);
        let e = p.validate("speed_rpm", 5.0, ok).unwrap_err().to_string();
        assert!(e.contains("speed_rpm[1]") && e.contains("0..=10"), "{e}");
        let p = Profile::from_points(vec![(1.0, 1.0), (0.5, 1.0)]);
        let e = p.validate("speed_rpm", 5.0, ok).unwrap_err().to_string();
        assert!(e.contains("time order"), "{e}");
        let p = Profile::from_points(vec![(1.0, 1.0), (9.0, 1.0)]);
        assert!(p.validate("speed_rpm", 5.0, ok).is_err());
        let p = Profile::from_points(vec![(1.0, 1.0), (1.0, 2.0), (1.0, 3.0)]);
        assert!(p.validate("speed_rpm", 5.0, ok).is_err());
        assert!(Profile::from_points(vec![]).validate("s", 5.0, ok).is_err());
    }
}

//! Stage 3: the ground (traction, lateral friction, slip moduli, rolling resistance) from
//! the body velocity the localization measured against the one the simulated ground gives
//! for the measured wheel speeds, and the steady-state slip of four regions of the input
//! space.

use super::*;
use rayon::prelude::*;

#[derive(Clone)]
pub(super) struct TerrainProblem<'a> {
    pub(super) steady: &'a [Steady],
    pub(super) transients: &'a [Transient],
    pub(super) params: VehicleParams,
    pub(super) dt: f64,
    /// The spread of the measured forward speeds and yaw rates: the errors' units.
    pub(super) scale: [f64; 2],
    /// The measured slip per region of the input space ([`region_slips`]).
    pub(super) slips: RegionSlips,
}

/// Regions of the input space by turn share (`|w| b / 2 / (|v| + |w| b / 2)` of the body
/// velocity the wheels give: 0 driving straight, 1 turning in place): quarters.
pub(super) const REGIONS: usize = 4;

/// Per region, the share of the windows in it and the slopes of the forward speed and yaw
/// rate on the wheels' (through the origin): the steady-state slip of that region.
pub(super) type RegionSlips = [(f64, [f64; 2]); REGIONS];

/// How much the region slips count in the ground's cost, against the per-window errors in
/// units of their spread: a slope off by 0.1 in every region weighs as a per-window error
/// of 0.2 spreads.
pub(super) const REGION_WEIGHT: f64 = 4.0;

/// The steady-state slip per region, for windows whose wheels give the body velocity
/// `wheels[i]` and which moved at `moved[i]` (forward speed, yaw rate).
pub(super) fn region_slips(wheels: &[[f64; 2]], moved: &[[f64; 2]], baseline: f64) -> RegionSlips {
    let mut sums = [([0.0; 2], [0.0; 2], 0usize); REGIONS];
    for (&[v, w], m) in wheels.iter().zip(moved) {
        let turn = w.abs() * baseline / 2.0;
        let share = turn / (v.abs() + turn).max(1e-9);
        let r = ((share * REGIONS as f64) as usize).min(REGIONS - 1);
        let (xy, xx, n) = &mut sums[r];
        for (axis, x) in [v, w].into_iter().enumerate() {
            xy[axis] += x * m[axis];
            xx[axis] += x * x;
        }
        *n += 1;
    }
    let total = wheels.len().max(1) as f64;
    sums.map(|(xy, xx, n)| {
        (
            n as f64 / total,
            [0, 1].map(|a| if xx[a] > 1e-12 { xy[a] / xx[a] } else { 0.0 }),
        )
    })
}

/// The physics step of the terrain stage (s).
pub(super) const TERRAIN_STEP_S: f64 = 1e-3;

impl TerrainProblem<'_> {
    pub(super) fn terrain(p: &[f64]) -> Terrain {
        Terrain {
            name: "fit".into(),
            traction: p[0].exp().clamp(TRACTION_RANGE.0, TRACTION_RANGE.1),
            lateral: p[1].exp().clamp(TRACTION_RANGE.0, TRACTION_RANGE.1),
            slip_modulus: p[2].exp().clamp(SLIP_MODULUS_RANGE.0, SLIP_MODULUS_RANGE.1),
            lateral_slip_modulus: Some(
                p[4].exp().clamp(SLIP_MODULUS_RANGE.0, SLIP_MODULUS_RANGE.1),
            ),
            rolling: p[3].exp().clamp(0.0, MAX_ROLLING),
            contact_spread: None,
            powertrain: None,
            controller: None,
            sensors: None,
            variability: None,
            turn_stall: None,
            protocol: None,
            fitted_for: None,
        }
    }

    /// The steady body velocity (forward speed, yaw rate) of the plant with its wheels held
    /// at `wheels`: settled for 1.5 s from the no-slip velocity, averaged over 0.5 s.
    pub(super) fn steady_body(&self, terrain: &Terrain, wheels: Input) -> [f64; 2] {
        let p = &self.params;
        let mut state = VehicleState::without_slip(p, wheels);
        let (mut v, mut w, mut n) = (0.0, 0.0, 0usize);
        for k in 0..2000 {
            // The wheels held at the measured speeds (reset after each step: the motors'
            // loop is not what this stage fits).
            step_body(p, terrain, &mut state, wheels, TERRAIN_STEP_S);
            state.wheels = wheels;
            if k >= 1500 {
                v += state.velocity[0];
                w += state.velocity[2];
                n += 1;
            }
        }
        [v / n as f64, w / n as f64]
    }

    /// A transient window replayed: the body from the previous window's velocity, the
    /// wheels made to follow the measured speeds; its mean forward speed and yaw rate.
    pub(super) fn transient_body(&self, terrain: &Terrain, t: &Transient) -> [f64; 2] {
        let p = &self.params;
        let [v0, w0] = t.start_body;
        let mut state = VehicleState {
            pose: Pose::zeros(),
            velocity: [v0, 0.0, w0],
            wheels: t.encoders[0],
        };
        let per_tick = (self.dt / TERRAIN_STEP_S).round().max(1.0) as usize;
        let h = self.dt / per_tick as f64;
        let mut poses = vec![state.pose];
        for k in 1..t.encoders.len() {
            for j in 0..per_tick {
                let f = (j + 1) as f64 / per_tick as f64;
                let wheels = t.encoders[k - 1] * (1.0 - f) + t.encoders[k] * f;
                step_body(p, terrain, &mut state, wheels, h);
                state.wheels = wheels;
            }
            poses.push(state.pose);
        }
        window_motion(&poses, self.dt)
    }

    /// [`steady_body`](Self::steady_body) of every steady window, in their order. The
    /// windows are simulated on rayon's threads (each alone: the result is the same on any
    /// number of threads); this stage is most of `sim-fit`'s time.
    pub(super) fn steady_bodies(&self, terrain: &Terrain) -> Vec<[f64; 2]> {
        self.steady
            .par_iter()
            .map(|s| self.steady_body(terrain, s.encoders))
            .collect()
    }

    /// [`transient_body`](Self::transient_body) of every transient window, in their order,
    /// on rayon's threads like [`steady_bodies`](Self::steady_bodies).
    pub(super) fn transient_bodies(&self, terrain: &Terrain) -> Vec<[f64; 2]> {
        self.transients
            .par_iter()
            .map(|t| self.transient_body(terrain, t))
            .collect()
    }

    /// The body velocity (forward speed, yaw rate) the wheel speeds `u` give.
    pub(super) fn wheel_body(&self, u: Input) -> [f64; 2] {
        let p = &self.params;
        [
            p.wheel_radius * (u.x + u.y) / 2.0,
            p.wheel_radius * (u.y - u.x) / p.baseline,
        ]
    }

    /// The cost of a ground: the per-window errors of the steady and transient windows in
    /// units of the measured spread, and the region slips' errors (weighted by
    /// [`REGION_WEIGHT`]).
    pub(super) fn cost_of(&self, terrain: &Terrain) -> f64 {
        let sims = self.steady_bodies(terrain);
        // Squared error in units of the spread.
        let error = |sim: [f64; 2], real: [f64; 2]| {
            (0..2)
                .map(|a| ((sim[a] - real[a]) / self.scale[a]).powi(2))
                .sum::<f64>()
        };
        let mut c = sims
            .iter()
            .zip(self.steady)
            .map(|(&sim, s)| error(sim, s.body))
            .sum::<f64>()
            / self.steady.len().max(1) as f64;
        c += self
            .transient_bodies(terrain)
            .into_iter()
            .zip(self.transients)
            .map(|(sim, tr)| error(sim, tr.body))
            .sum::<f64>()
            / self.transients.len().max(1) as f64;
        let wheels: Vec<[f64; 2]> = self
            .steady
            .iter()
            .map(|s| self.wheel_body(s.encoders))
            .collect();
        let simulated = region_slips(&wheels, &sims, self.params.baseline);
        for ((share, real), (_, sim)) in self.slips.iter().zip(simulated) {
            c += REGION_WEIGHT * share * ((sim[0] - real[0]).powi(2) + (sim[1] - real[1]).powi(2));
        }
        c
    }

    /// RMS errors of the forward speed and yaw rate over the steady windows, then over the
    /// transient windows.
    pub(super) fn errors(&self, terrain: &Terrain) -> [[f64; 2]; 2] {
        let rms = |rows: &mut dyn Iterator<Item = ([f64; 2], [f64; 2])>| {
            let (mut ev, mut ew, mut n) = (0.0, 0.0, 0usize);
            for (sim, real) in rows {
                ev += (sim[0] - real[0]).powi(2);
                ew += (sim[1] - real[1]).powi(2);
                n += 1;
            }
            let n = n.max(1) as f64;
            [(ev / n).sqrt(), (ew / n).sqrt()]
        };
        [
            rms(&mut self
                .steady_bodies(terrain)
                .into_iter()
                .zip(self.steady.iter().map(|s| s.body))),
            rms(&mut self
                .transient_bodies(terrain)
                .into_iter()
                .zip(self.transients.iter().map(|t| t.body))),
        ]
    }
}

impl CostFunction for TerrainProblem<'_> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, p: &Vec<f64>) -> Result<f64, argmin::core::Error> {
        let c = self.cost_of(&Self::terrain(p));
        // A terrain too stiff for the step diverges: the worst cost, not a NaN.
        Ok(if c.is_finite() { c } else { 1e12 })
    }
}

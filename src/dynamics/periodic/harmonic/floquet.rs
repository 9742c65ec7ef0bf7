//! The Floquet multipliers of a harmonic-balance orbit: the monodromy of the
//! balance's variational equations along the series, advanced interval by
//! interval with the tangents frozen, cut at the contact switches located
//! on the series, with the damping jump's saltation where a whole mesh
//! separates or touches ([`HarmonicBalance::floquet_multipliers`]).

use super::jacobian::project;
use super::{HarmonicBalance, HarmonicOrbit, SCAN_INTERVALS_PER_STEP};
use crate::dynamics::periodic::switches::{illinois, series_state};
use crate::dynamics::periodic::{floquet_multipliers, Multiplier, PeriodicError};
use crate::dynamics::rigid_frame::RigidFrame;
use crate::dynamics::solver::{SecondOrderSystem, TangentSystem};

/// An instant on a harmonic-balance orbit where a whole mesh separates or
/// touches again, so that its damping force jumps.
#[derive(Clone, Copy, Debug)]
struct DampingSwitch {
    /// Time in the period \[s\].
    time: f64,
    /// The mesh.
    mesh: usize,
    /// Whether it touches after the instant.
    on: bool,
    /// The event (tooth pair and flank) whose value crosses zero there.
    event: usize,
    /// Whether the mesh touches on both sides: a pair entering or leaving
    /// a mesh in contact, a jump of the damping force under Rayleigh damping
    /// only.
    within: bool,
}

/// The monodromy of the balance's variational equations, built interval by
/// interval ([`HarmonicBalance::floquet_multipliers`]): Φ in the balanced
/// state (y, ẏ/w) of the unknowns' coordinates.
struct Propagation<'o> {
    orbit: &'o HarmonicOrbit,
    p: &'o [f64],
    q_scale: f64,
    m: usize,
    n: usize,
    /// (PᵀMP)⁻¹.
    mass_inverse: nalgebra::DMatrix<f64>,
    /// Φ, 2m × 2m column-major, from the identity.
    phi: Vec<f64>,
    /// w: the balancing scale, the square root of the size of the first
    /// interval's stiffness block.
    scale: Option<f64>,
    q: Vec<f64>,
    v: Vec<f64>,
    y: Vec<f64>,
    yd: Vec<f64>,
    kt: nalgebra::DMatrix<f64>,
    ct: nalgebra::DMatrix<f64>,
    kp: Vec<f64>,
    reduced: Vec<f64>,
    lower: Vec<f64>,
    x: Vec<f64>,
    ax: Vec<f64>,
    exponential: Vec<f64>,
    events: Vec<f64>,
}

/// out = a b for s × s column-major matrices.
fn multiply(s: usize, a: &[f64], b: &[f64], out: &mut [f64]) {
    faer::linalg::matmul::matmul(
        faer::MatMut::from_column_major_slice_mut(out, s, s),
        faer::Accum::Replace,
        faer::MatRef::from_column_major_slice(a, s, s),
        faer::MatRef::from_column_major_slice(b, s, s),
        1.0,
        faer::Par::Seq,
    );
}

impl<'o> Propagation<'o> {
    fn new(
        orbit: &'o HarmonicOrbit,
        p: &'o [f64],
        q_scale: f64,
        (m, n): (usize, usize),
        mass_inverse: nalgebra::DMatrix<f64>,
    ) -> Self {
        let s = 2 * m;
        let mut phi = vec![0.0; s * s];
        (0..s).for_each(|i| phi[i + s * i] = 1.0);
        Self {
            orbit,
            p,
            q_scale,
            m,
            n,
            mass_inverse,
            phi,
            scale: None,
            q: vec![0.0; n],
            v: vec![0.0; n],
            y: vec![0.0; m],
            yd: vec![0.0; m],
            kt: nalgebra::DMatrix::zeros(n, n),
            ct: nalgebra::DMatrix::zeros(n, n),
            kp: vec![0.0; n * m],
            reduced: vec![0.0; m * m],
            lower: vec![0.0; m * s],
            x: vec![0.0; s * s],
            ax: vec![0.0; s * s],
            exponential: vec![0.0; s * s],
            events: Vec::new(),
        }
    }

    /// The orbit's relative state at `t` into `q`, `v`.
    fn state_at(&mut self, t: f64) {
        let (orbit, p, q_scale) = (self.orbit, self.p, self.q_scale);
        let nu = 2.0 * std::f64::consts::PI / orbit.period;
        series_state(
            &orbit.coefficients,
            nu,
            p,
            q_scale,
            t,
            (&mut self.y, &mut self.yd, None),
            (&mut self.q, &mut self.v),
        );
    }

    /// Φ ← exp(length · A(t_mid)) Φ, A = [0 wI; G/w D] with K and C taken at
    /// `t_mid` on the orbit.
    fn advance(&mut self, frame: &mut RigidFrame<'_>, t_mid: f64, length: f64) {
        let m = self.m;
        let s = 2 * m;
        self.state_at(t_mid);
        frame.jacobian(t_mid, &self.q, &self.v, &mut self.kt, &mut self.ct);
        // The lower blocks of A = [0 I; G D]: G = −(PᵀMP)⁻¹PᵀKP, D = −(PᵀMP)⁻¹PᵀCP.
        let (p, kp, reduced, mass_inverse) = (self.p, &mut self.kp, &mut self.reduced, &self.mass_inverse);
        let mut lower_block = |mat: &nalgebra::DMatrix<f64>| {
            project(p, mat, m, kp, reduced);
            -(mass_inverse * nalgebra::DMatrix::from_column_slice(m, m, reduced))
        };
        let (g, d) = (lower_block(&self.kt), lower_block(&self.ct));
        // In the balanced state (y, ẏ/w), w² the size of G, A = [0 wI; G/w D] has a norm
        // of the order of its largest frequency; the multipliers are the same.
        let w = *self.scale.get_or_insert_with(|| {
            (0..m)
                .fold(0.0_f64, |acc, a| acc.max((0..m).map(|b| g[(a, b)].abs()).sum::<f64>()))
                .sqrt()
                .max(1.0)
        });
        // The lower block row [G/w D], column-major m × 2m.
        let lower = &mut self.lower;
        for b in 0..m {
            for a in 0..m {
                lower[a + m * b] = g[(a, b)] / w;
                lower[a + m * (m + b)] = d[(a, b)];
            }
        }
        let norm = (0..m).fold(w, |acc, a| acc.max((0..s).map(|b| lower[a + m * b].abs()).sum::<f64>()));
        // Scaling and squaring: exp(hA) = exp(hA/2^j)^(2^j) with ‖hA‖/2^j ≤ ½.
        let squarings = if length * norm <= 0.5 { 0 } else { (2.0 * length * norm).log2().ceil() as i32 };
        let hs = length / 2f64.powi(squarings);
        // The Taylor degree whose first omitted term (h‖A‖)^(p+1)/(p+1)! is below 1e-11.
        let (mut degree, mut term) = (1usize, hs * norm);
        while term > 1e-11 && degree < 20 {
            degree += 1;
            term *= hs * norm / degree as f64;
        }
        let taylor = |base: &[f64], x: &mut [f64], ax: &mut [f64]| {
            // Σ_{k ≤ p} (hA)^k/k! B by Horner: X = B + (h/k) A X, k = p … 1.
            x.copy_from_slice(base);
            for k in (1..=degree).rev() {
                let f = hs / k as f64;
                // A X: its upper rows w X's lower rows, its lower rows [G/w D] X.
                for col in 0..s {
                    let c = &x[col * s..][..s];
                    for a in 0..m {
                        ax[col * s + a] = w * c[m + a];
                    }
                }
                faer::linalg::matmul::matmul(
                    faer::MatMut::from_column_major_slice_with_stride_mut(&mut ax[m..], m, s, s),
                    faer::Accum::Replace,
                    faer::MatRef::from_column_major_slice(lower, m, s),
                    faer::MatRef::from_column_major_slice(x, s, s),
                    1.0,
                    faer::Par::Seq,
                );
                for ((xi, bi), ai) in x.iter_mut().zip(base).zip(ax.iter()) {
                    *xi = bi + f * ai;
                }
            }
        };
        let (phi, x, ax, e) = (&mut self.phi, &mut self.x, &mut self.ax, &mut self.exponential);
        if squarings == 0 {
            taylor(phi, x, ax);
            phi.copy_from_slice(x);
            return;
        }
        // E = exp(hA/2^j) from the identity, squared j times, then Φ ← E Φ.
        e.iter_mut().for_each(|v| *v = 0.0);
        (0..s).for_each(|i| e[i + s * i] = 1.0);
        taylor(e, x, ax);
        for _ in 0..squarings {
            multiply(s, x, x, ax);
            x.copy_from_slice(ax);
        }
        multiply(s, x, phi, ax);
        phi.copy_from_slice(ax);
    }

    /// The model's event values at `t` on the orbit into `events`.
    fn events_at(&mut self, frame: &mut RigidFrame<'_>, t: f64) {
        self.state_at(t);
        frame.events(t, &self.q, &self.v, &mut self.events);
    }

    /// The largest event value of each mesh at `t` on the orbit, with the
    /// event that gives it (a mesh touches where its largest value is
    /// positive).
    fn mesh_events(&mut self, frame: &mut RigidFrame<'_>, t: f64) -> Vec<(f64, usize)> {
        self.events_at(frame, t);
        let model = frame.model();
        let mut largest = vec![(f64::NEG_INFINITY, usize::MAX); model.mesh_count()];
        for (e, &g) in self.events.iter().enumerate() {
            if let Some(i) = model.event_mesh(e) {
                if g > largest[i].0 {
                    largest[i] = (g, e);
                }
            }
        }
        largest
    }

    /// Event `e`'s value at `t` on the orbit.
    fn event_value(&mut self, frame: &mut RigidFrame<'_>, t: f64, e: usize) -> f64 {
        self.events_at(frame, t);
        self.events[e]
    }

    /// The instants in the period where the tangents jump: a tooth pair
    /// starts or stops touching where its event value changes sign between
    /// the ends of one of the `intervals` intervals of length `h`, each located
    /// by [`Self::switch_at`]. Two changes of one event within one interval
    /// cancel and are not seen.
    fn switches(
        &mut self,
        frame: &mut RigidFrame<'_>,
        h: f64,
        intervals: usize,
    ) -> (Vec<f64>, Vec<DampingSwitch>) {
        let (mut pairs, mut switches) = (Vec::new(), Vec::new());
        self.events_at(frame, 0.0);
        let mut values_before = self.events.clone();
        let mut values_after = Vec::new();
        for j in 0..intervals {
            let (a, b) = (j as f64 * h, (j + 1) as f64 * h);
            self.events_at(frame, b);
            values_after.clone_from(&self.events);
            for (e, (&ga, &gb)) in values_before.iter().zip(&values_after).enumerate() {
                if (ga > 0.0) != (gb > 0.0) {
                    self.switch_at(frame, e, [(a, ga), (b, gb)], h, (&mut pairs, &mut switches));
                }
            }
            std::mem::swap(&mut values_before, &mut values_after);
        }
        (pairs, switches)
    }

    /// The instants of [`Self::switches`] found from `seeds`, the crossings the
    /// solve located (time, event) a Newton step of at most the tolerance
    /// away: each event's sign change is bracketed within 1e-4 of an interval
    /// `h` of its seed (1e-2 if not there) and located by [`Self::switch_at`].
    /// `None` (search the whole period) where a seed's sign change is in
    /// neither bracket.
    fn seeded_switches(
        &mut self,
        frame: &mut RigidFrame<'_>,
        h: f64,
        seeds: &[(f64, usize)],
    ) -> Option<(Vec<f64>, Vec<DampingSwitch>)> {
        let period = self.orbit.period;
        let (mut pairs, mut switches) = (Vec::with_capacity(seeds.len()), Vec::new());
        for &(seed, e) in seeds {
            let bracket = [1e-4 * h, 1e-2 * h].into_iter().find_map(|w| {
                let (a, b) = ((seed - w).max(0.0), (seed + w).min(period));
                let (ga, gb) = (self.event_value(frame, a, e), self.event_value(frame, b, e));
                ((ga > 0.0) != (gb > 0.0)).then_some([(a, ga), (b, gb)])
            })?;
            self.switch_at(frame, e, bracket, h, (&mut pairs, &mut switches));
        }
        Some((pairs, switches))
    }

    /// The sign change of event `e` inside `bracket` (times and the event's
    /// values, of opposite signs), located by the Illinois method to 1e-12 of
    /// `h` in at most 100 evaluations, into `pairs`; where the event's mesh
    /// separates or touches there (its largest event value changes sign across
    /// the located bracket) a damping switch at the same instant into
    /// `switches`, once per mesh and instant.
    fn switch_at(
        &mut self,
        frame: &mut RigidFrame<'_>,
        e: usize,
        bracket: [(f64, f64); 2],
        h: f64,
        (pairs, switches): (&mut Vec<f64>, &mut Vec<DampingSwitch>),
    ) {
        let [(ta, _), (tb, _)] = illinois(|t| self.event_value(frame, t, e), bracket, 1e-12 * h, 100);
        let time = 0.5 * (ta + tb);
        pairs.push(time);
        let Some(i) = frame.model().event_mesh(e) else { return };
        let (was, is) = (self.mesh_events(frame, ta)[i], self.mesh_events(frame, tb)[i]);
        let within = was.0 > 0.0 && is.0 > 0.0 && frame.model().rayleigh_meshes();
        if ((was.0 > 0.0) != (is.0 > 0.0) || within)
            && !switches.iter().any(|s| s.mesh == i && (s.time - time).abs() <= 1e-9 * h)
        {
            switches.push(DampingSwitch {
                time,
                mesh: i,
                on: is.0 > 0.0,
                event: if within { e } else { is.1 },
                within,
            });
        }
    }

    /// Φ ← S Φ for the saltation S of `switch`: in physical coordinates
    /// δv⁺ = δv⁻ + M⁻¹Δf (∂h/∂q · δq)/ḣ (Δf the jump of the generalized
    /// forces, h the crossing event's value), here in the unknowns'
    /// coordinates, δẏ⁺ = δẏ⁻ + (PᵀMP)⁻¹PᵀΔf (∂h/∂q · P δy)/ḣ, and in the
    /// balanced state divided by w. ∂h/∂q · P and ḣ are central
    /// differences (along each column of P, and along the series in time).
    fn saltation(&mut self, frame: &mut RigidFrame<'_>, switch: &DampingSwitch) {
        let (m, n) = (self.m, self.n);
        let s = 2 * m;
        let t = switch.time;
        let tau = 1e-6 * self.orbit.period;
        let value = |walk: &mut Self, frame: &mut RigidFrame<'_>, t: f64, q: &[f64], v: &[f64]| {
            frame.events(t, q, v, &mut walk.events);
            walk.events[switch.event]
        };
        let ahead = self.event_value(frame, t + tau, switch.event);
        let behind = self.event_value(frame, t - tau, switch.event);
        let rate = (ahead - behind) / (2.0 * tau);
        if !(rate.is_finite() && rate != 0.0) {
            return;
        }
        self.state_at(t);
        let (q0, v0) = (self.q.clone(), self.v.clone());
        // ∂h/∂q · P, column by column.
        let mut slope = vec![0.0; m];
        let mut qp = q0.clone();
        for (b, out) in slope.iter_mut().enumerate() {
            let column = &self.p[n * b..][..n];
            let size = column.iter().fold(0.0_f64, |a, x| a.max(x.abs()));
            if size == 0.0 {
                continue;
            }
            let eps = 1e-6 * self.q_scale / size;
            for k in 0..n {
                qp[k] = q0[k] + eps * column[k];
            }
            let plus = value(self, frame, t, &qp, &v0);
            for k in 0..n {
                qp[k] = q0[k] - eps * column[k];
            }
            let minus = value(self, frame, t, &qp, &v0);
            *out = (plus - minus) / (2.0 * eps);
        }
        // Under Rayleigh damping, within a mesh in contact: the tangent
        // stiffness on either side of the instant.
        let stiffness = if switch.within {
            let mut at = |walk: &mut Self, t: f64| {
                walk.state_at(t);
                let (q, v) = (walk.q.clone(), walk.v.clone());
                frame.events(t, &q, &v, &mut walk.events);
                frame.model().meshes[switch.mesh].stiffness
            };
            [at(self, t - tau), at(self, t + tau)]
        } else {
            [0.0; 2]
        };
        // The jump at the switch's own state: the mesh's approach rate of this evaluation.
        frame.events(t, &q0, &v0, &mut self.events);
        let mut jump = vec![0.0; n];
        if switch.within {
            frame.model().add_rayleigh_jump(switch.mesh, stiffness, &mut jump);
        } else {
            frame.model().add_damping_switch(switch.mesh, switch.on, &mut jump);
        }
        let projected: Vec<f64> = (0..m).map(|a| (0..n).map(|i| self.p[i + n * a] * jump[i]).sum()).collect();
        let w = self.scale.unwrap_or(1.0);
        let kick: Vec<f64> = (0..m)
            .map(|a| (0..m).map(|b| self.mass_inverse[(a, b)] * projected[b]).sum::<f64>() / (w * rate))
            .collect();
        for col in 0..s {
            let c = &mut self.phi[col * s..][..s];
            let dot: f64 = slope.iter().zip(&c[..m]).map(|(g, y)| g * y).sum();
            for (a, k) in kick.iter().enumerate() {
                c[m + a] += k * dot;
            }
        }
    }
}

impl HarmonicBalance {
    /// Floquet multipliers of `orbit`, largest modulus first: the eigenvalues
    /// of the monodromy of the variational equations along the orbit in the
    /// unknowns' coordinates (the free rotation excluded, as in shooting),
    /// PᵀMP δÿ + PᵀCP δẏ + PᵀKP δy = 0 (K, C the tangent stiffness and
    /// damping). The contact switches are found on `intervals` equal
    /// intervals of the period: where a tooth pair starts or stops touching
    /// its tangents jump, and where a whole mesh does its damping force jumps
    /// (sign changes of the event values between the intervals' ends, located
    /// on the series to 1e-12 of an interval). The period is advanced in
    /// `intervals` / [`SCAN_INTERVALS_PER_STEP`] equal steps, each cut at the
    /// switches inside it, with K and C frozen at the middle of each piece and
    /// the piece's exponential taken by scaling and squaring of its Taylor
    /// series (to the degree whose first omitted term is below 1e-11); at a
    /// mesh's switch the columns take the damping jump's saltation term, as
    /// shooting's variational flow does. No flow is integrated. The error
    /// against shooting's variational monodromy is measured
    /// (docs/PERIODIC.md §2).
    pub fn floquet_multipliers(
        &mut self,
        orbit: &HarmonicOrbit,
        intervals: usize,
    ) -> Result<Vec<Multiplier>, PeriodicError> {
        if intervals == 0 {
            return Err(PeriodicError::invalid("multiplier intervals", 0.0, "must be at least 1"));
        }
        let omega = orbit.speed;
        let (m, n) = (self.m, self.n);
        let mass_inverse = nalgebra::DMatrix::from_column_slice(m, m, &self.reduced_mass)
            .try_inverse()
            .ok_or_else(|| PeriodicError::invalid("reduced mass", 0.0, "must be invertible"))?;
        self.problem.model.set_drive_speed(omega);
        let rigid = self.problem.model.rigid_velocity_at(omega);
        let mut frame = RigidFrame::new(&mut self.problem.model, rigid);
        let mut walk = Propagation::new(orbit, &self.p, self.problem.q_scale, (m, n), mass_inverse);
        // From the crossings the solve located where it has them; the whole period searched
        // otherwise, or where one of them is not found again.
        let h_scan = orbit.period / intervals as f64;
        let seeded = if orbit.crossings.is_empty() {
            None
        } else {
            walk.seeded_switches(&mut frame, h_scan, &orbit.crossings)
        };
        let (mut pairs, mut switches) = match seeded {
            Some(found) => found,
            None => walk.switches(&mut frame, h_scan, intervals),
        };
        pairs.sort_by(f64::total_cmp);
        switches.sort_by(|x, y| x.time.total_cmp(&y.time));
        // Every step is cut where a pair's tangents jump; where a whole mesh touches or
        // separates the columns also take the damping's saltation.
        let mut cuts: Vec<(f64, Option<&DampingSwitch>)> = pairs.iter().map(|t| (*t, None)).collect();
        cuts.extend(switches.iter().map(|s| (s.time, Some(s))));
        cuts.sort_by(|x, y| x.0.total_cmp(&y.0));
        let steps = (intervals / SCAN_INTERVALS_PER_STEP).max(1);
        let h = orbit.period / steps as f64;
        let mut next = 0;
        for j in 0..steps {
            let end = (j + 1) as f64 * h;
            // A step without a switch is advanced whole, its midpoint and length written as
            // (j + ½)h and h rather than from its ends (which round differently).
            if cuts.get(next).is_none_or(|c| c.0 > end) {
                walk.advance(&mut frame, (j as f64 + 0.5) * h, h);
                continue;
            }
            let mut from = j as f64 * h;
            while let Some(&(time, damping)) = cuts.get(next).filter(|c| c.0 <= end) {
                if time > from {
                    walk.advance(&mut frame, 0.5 * (from + time), time - from);
                    from = time;
                }
                if let Some(switch) = damping {
                    walk.saltation(&mut frame, switch);
                }
                next += 1;
            }
            if end > from {
                walk.advance(&mut frame, 0.5 * (from + end), end - from);
            }
        }
        floquet_multipliers(&walk.phi, 2 * m)
    }
}

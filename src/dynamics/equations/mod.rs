//! The nonlinear tooth-by-tooth dynamic model of the planetary set.
//!
//! Coordinates: Lin & Parker's, reduced to the scene's fidelity with the held
//! member's rotation removed ([`crate::model::lumped`]). Equations:
//!
//! M q̈ + C_b q̇ + K_b q + Σ_meshes b (F(s, δ) + c_m δ̇ [in contact]) = f_ext(t) + f_frame
//!
//! with f_frame the gyroscopic, centripetal and centrifugal forces of a
//! turning carrier at its mean speed
//! ([`CarrierFrame`]; zero for a
//! held carrier and in the torsional model),
//! with δ = bᵀq the mesh approach along the line of action, F the tooth
//! forces of all pairs of that mesh at their real positions
//! ([`MeshModel::force_with_derivatives`](crate::contact::ltca::MeshModel::force_with_derivatives)), c_m the viscous mesh damping of
//! the mesh mode (damping ratio ζ_m on the mean stiffness and the two gears'
//! rotational masses), acting only while a pair touches. Positions follow
//! from the gears' rotations relative to the carrier:
//! s_sn = u_s − (r_b,s/a) u_c − r_b,s ψ_n and s_rn = −u_r + (r_b,r/a) u_c − r_b,s ψ_n + Δ
//! (Δ the geometric offset of [`SetModel::ring_shift`]), so planet phasing
//! is geometry, not a prescribed phase. External forces: the input torque
//! (or a torsional shaft from a source at constant speed) and the balancing
//! torque on the output member, both as generalised forces on u.
//!
//! Rayleigh damping (`dynamics.damping = "rayleigh"`, [`Damping::Rayleigh`](crate::model::gear::Damping::Rayleigh))
//! replaces the damping ratios by C = μ M_v + η K (Chopra,
//! Dynamics of Structures, §11.4.1): each mesh's damping
//! is η ∂F/∂δ, its current tangent stiffness (zero out of contact, and
//! following the time-varying stiffness), each bearing's η k, and the
//! mass-proportional part acts on the motion relative to the train's
//! rigid-body rotation only,
//!
//! M_v = M − M r rᵀ M / (rᵀ M r),
//!
//! r the rigid-body velocity pattern ([`PlanetaryDynamics::rigid_velocity`]).
//! M_v r = 0, so a train turning freely is not braked (a drag μ M q̇ on the
//! whole velocity would take μ·(rᵀMr)·ω² of power from it), and every elastic
//! mode φ, being M-orthogonal to the rigid-body mode r, sees M_v φ = M φ: a
//! classical mode of circular frequency ω decays at ζ = μ/(2ω) + ηω/2. The
//! speed drive's shaft and the load balance keep their own damping: they
//! are a test bench's, not the gear set's structure.

mod assembly;

pub use assembly::{rigid_speeds, BALANCE_DAMPING, BALANCE_FREQUENCY};

use nalgebra::DMatrix;

use std::sync::Arc;

use crate::contact::deformable::set::DeformableSet;
use crate::contact::ltca::MeshLaw;
use crate::contact::ltca::{MeshModel, SetModel};
use crate::contact::mesh_law::MeshContact;
use crate::dynamics::solver::{
    LowRankJacobian, RankOneTerm, SecondOrderSystem, TangentSystem, TermCoefficients,
};
use crate::model::carrier_frame::CarrierFrame;
use crate::model::gear::MeshKind;
use crate::model::lumped::{LumpedSet, Reduction};

/// One mesh of one planet in the dynamic model.
#[derive(Clone, Debug)]
struct Link {
    planet: usize,
    kind: MeshKind,
    /// Nonzero entries of the reduced mesh vector b (δ = bᵀq).
    b_nz: Vec<(usize, f64)>,
    /// Position s = Σ p_i q_i + s0.
    p_nz: Vec<(usize, f64)>,
    s0: f64,
    /// Viscous mesh damping of the ratio model [N·s/m] (0 under Rayleigh damping).
    damping: f64,
}

impl Link {
    /// The mesh's viscous damping [N·s/m] at tangent stiffness `stiffness`
    /// [N/m]: the ratio model's constant plus Rayleigh's η ∂F/∂δ (`eta` \[s\],
    /// 0 under the ratio model).
    fn damping_at(&self, eta: f64, stiffness: f64) -> f64 {
        self.damping + eta * stiffness
    }
}

/// Where a mesh reads the model's coordinates q ([`PlanetaryDynamics::mesh_coordinates`]).
#[derive(Clone, Copy, Debug)]
pub struct MeshCoordinates<'a> {
    /// Nonzero entries of the mesh vector b: approach δ = bᵀq.
    pub approach: &'a [(usize, f64)],
    /// Nonzero entries of the position vector p: position s = pᵀq + s₀.
    pub position: &'a [(usize, f64)],
    /// s₀ \[m\].
    pub offset: f64,
}

/// Per-mesh state of the last force evaluation.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MeshState {
    /// Position of the reference pair \[m\].
    pub position: f64,
    /// Approach along the line of action \[m\].
    pub approach: f64,
    /// Rate of the approach [m/s].
    pub approach_rate: f64,
    /// Elastic mesh force (sum of the tooth forces) \[N\].
    pub force: f64,
    /// Tangent stiffness ∂F/∂δ [N/m].
    pub stiffness: f64,
    /// ∂F/∂s [N/m].
    pub position_derivative: f64,
    /// Damping force \[N\] (zero out of contact).
    pub damping_force: f64,
    /// The largest tooth-pair force in magnitude \[N\].
    pub peak_pair_force: f64,
}

/// The dynamic model of a gear set.
#[derive(Clone, Debug)]
pub struct PlanetaryDynamics {
    /// The contact models and phasing.
    pub contact: SetModel,
    /// The deformable law of both meshes when the set asks for it
    /// ([`GearSet::contact_model`](crate::model::gear::GearSet::contact_model)); the pair models of `contact` then serve
    /// only the phasing and the quasi-static start.
    deformable: Option<Arc<DeformableSet>>,
    /// The mean-stiffness linear model (masses, supports).
    pub lumped: LumpedSet,
    /// Reduction of the fidelity level.
    pub reduction: Reduction,
    mass: Vec<f64>,
    k_support: DMatrix<f64>,
    c_support: DMatrix<f64>,
    /// Nonzero entries (i, j, k_ij, c_ij) of the support matrices.
    support_nz: Vec<(usize, usize, f64, f64)>,
    links: Vec<Link>,
    f_ext: Vec<f64>,
    speed_drive: Option<SpeedDrive>,
    /// The load balance: a speed controller on the output member
    /// ([`GearSet::load_balance`](crate::model::gear::GearSet::load_balance)), with the index of the output's rotation.
    balance: Option<(usize, SpeedDrive)>,
    /// The held member's reaction ([`Self::reaction_torque`]).
    reaction: Reaction,
    /// Index of the input member's rotation among the reduced coordinates.
    pub input_index: usize,
    /// Lever of the input member's rotation: u = lever·θ \[m\].
    pub input_lever: f64,
    /// Rigid-body velocity pattern: reduced velocities per rad/s of the input member.
    pub rigid_velocity: Vec<f64>,
    /// Mesh frequency per rad/s of input speed [Hz·s/rad].
    pub mesh_frequency_per_input_speed: f64,
    /// Index of the rotation u of carrier, ring, sun (`central_index` order) among the reduced
    /// coordinates (None when held) and its lever, u = lever·θ \[m\].
    pub rotations: [(Option<usize>, f64); 3],
    /// State of every mesh after the last force evaluation (planet-major: sun, ring).
    pub meshes: Vec<MeshState>,
    slots: Vec<usize>,
    events_scratch: Vec<f64>,
    /// The state of the last mesh evaluation (with or without events), so a
    /// Jacobian or an output request at the state just evaluated costs nothing.
    cache: Option<(Vec<f64>, Vec<f64>, bool)>,
    /// The inertial terms of the turning carrier's frame (None when the
    /// carrier is held or the model torsional).
    frame: Option<CarrierFrame>,
    /// Rayleigh's stiffness-proportional coefficient η on each mesh's
    /// tangent stiffness \[s\] (0 under the ratio model).
    mesh_stiffness_damping: f64,
    /// Each mesh's tangent stiffness at its last evaluation in contact
    /// [N/m]: the stiffness-proportional damping that switches off when the
    /// mesh's last pair leaves contact ([`Self::add_damping_switch`]).
    touch_stiffness: Vec<f64>,
}

#[derive(Clone, Copy, Debug)]
struct SpeedDrive {
    /// Index of the driven rotation u among the reduced coordinates.
    index: usize,
    /// Lever of the driven rotation, u = lever·θ \[m\].
    lever: f64,
    /// Source speed on u per rad/s of input speed \[m\]: the driven member's
    /// rigid-body speed (its lever for the input member).
    rate: f64,
    /// Shaft stiffness on u [N/m].
    stiffness: f64,
    /// Shaft damping on u [N·s/m].
    damping: f64,
    /// Source speed on u [m/s].
    speed: f64,
    /// Source position on u at t = 0 \[m\].
    offset: f64,
    /// Mean generalised input force the shaft carries \[N\].
    preload: f64,
}

/// How the held member's support reacts: the held rotation's share of each
/// mesh force and planet-bearing force.
#[derive(Clone, Debug, Default)]
struct Reaction {
    /// Lever of the held member's rotation, u = lever·θ \[m\].
    lever: f64,
    /// dᵀb of each mesh (d: the held rotation in full coordinates).
    links: Vec<f64>,
    /// The planet-bearing deflections with a share in the held rotation.
    bearings: Vec<ReactionBearing>,
}

/// A planet-bearing deflection v·q in [`Reaction`].
#[derive(Clone, Debug)]
struct ReactionBearing {
    /// dᵀv: the held rotation's share.
    share: f64,
    /// The deflection's reduced vector (nonzero entries).
    vector: Vec<(usize, f64)>,
    /// Stiffness \[N/m\].
    stiffness: f64,
    /// Damping [N·s/m].
    damping: f64,
}

/// Errors of the dynamic model.
#[derive(Debug, thiserror::Error)]
pub enum DynamicsError {
    /// A parameter or request cannot be used.
    #[error("{name} = {value}: {reason}")]
    InvalidParameter {
        /// Parameter.
        name: String,
        /// Value.
        value: String,
        /// What is allowed.
        reason: String,
    },
    /// The deformable contact law could not be built.
    #[error("deformable contact: {0}")]
    Contact(String),
}

impl PlanetaryDynamics {
    /// The constant external generalised forces: the input torque (or the
    /// mean torque the speed drive's shaft carries) and the output's
    /// balancing torque.
    pub fn external_force(&self, f: &mut [f64]) {
        f.copy_from_slice(&self.f_ext);
        if let Some(d) = self.speed_drive {
            f[d.index] += d.preload;
        }
        if let Some((o, b)) = self.balance {
            f[o] += b.preload;
        }
    }

    /// Places the speed drive's source so that at t = 0 the shaft's wind-up
    /// carries the mean input torque for coordinates `q`.
    pub fn rebase_drive(&mut self, q: &[f64]) {
        if let Some(d) = &mut self.speed_drive {
            d.offset = q[d.index] + d.preload / d.stiffness;
        }
        if let Some((o, b)) = &mut self.balance {
            b.offset = q[*o] + b.preload / b.stiffness;
        }
    }

    /// Energy bookkeeping at a state: kinetic energy, elastic energy of the
    /// supports (and the speed drive's shaft), elastic energy of the tooth
    /// contacts \[J\], and the work rate of the time-varying mesh stiffness and
    /// separation, Σ ∂V/∂s · ṡ \[W\].
    pub fn energy(&self, t: f64, q: &[f64], v: &[f64]) -> (f64, f64, f64, f64) {
        let kinetic: f64 = 0.5 * self.mass.iter().zip(v).map(|(m, v)| m * v * v).sum::<f64>();
        let mut support = 0.0;
        for (i, qi) in q.iter().enumerate() {
            for (j, qj) in q.iter().enumerate() {
                support += 0.5 * qi * self.k_support[(i, j)] * qj;
            }
        }
        if let Some(d) = self.speed_drive {
            let w = d.offset + d.speed * t - q[d.index];
            support += 0.5 * d.stiffness * w * w;
        }
        if let Some((o, b)) = self.balance {
            let w = b.offset + b.speed * t - q[o];
            support += 0.5 * b.stiffness * w * w;
        }
        let (mut contact, mut power) = (0.0, 0.0);
        for link in &self.links {
            let delta: f64 = link.b_nz.iter().map(|(j, b)| b * q[*j]).sum();
            let s: f64 = link.p_nz.iter().map(|(j, p)| p * q[*j]).sum::<f64>() + link.s0;
            let s_rate: f64 = link.p_nz.iter().map(|(j, p)| p * v[*j]).sum();
            let (e, de) = match &self.deformable {
                Some(d) => d.mesh(link.kind).contact_energy(s, delta).unwrap_or((f64::NAN, f64::NAN)),
                None => self.model(link.kind).contact_energy(s, delta),
            };
            contact += e;
            power += de * s_rate;
        }
        (kinetic, support, contact, power)
    }

    /// Work rate of the constant external forces at velocities `v` \[W\].
    pub fn external_power(&self, v: &[f64]) -> f64 {
        self.f_ext.iter().zip(v).map(|(f, v)| f * v).sum()
    }

    /// Sets the external torques on sun, ring and carrier [N·m],
    /// counter-clockwise positive; a held member's torque is its reaction and
    /// is ignored, and so is the speed-driven member's under the speed drive (its
    /// shaft carries the torque) and the output member's under the load
    /// balance (its controller does). The generalised force on u = lever·θ
    /// is T/lever.
    pub fn set_torques(&mut self, sun: f64, ring: f64, carrier: f64) {
        self.f_ext.iter_mut().for_each(|f| *f = 0.0);
        for ((index, lever), torque) in self.rotations.iter().zip([carrier, ring, sun]) {
            if let Some(i) = index {
                if self.speed_drive.is_some_and(|d| d.index == *i) {
                    continue;
                }
                if self.balance.is_some_and(|(o, _)| o == *i) {
                    continue;
                }
                self.f_ext[*i] = torque / lever;
            }
        }
        self.cache = None;
    }

    /// The same model with its members free under the external torques `torques` on sun,
    /// ring and carrier [N·m]: no speed drive and no load balance, so every turning
    /// member takes its torque. The `steady` response's periodic states are this model's
    /// (docs/STEADY.md): its drive acts on the rigid-body rotation between communication
    /// points, not within one mesh cycle.
    pub fn free_under(&self, torques: [f64; 3]) -> Self {
        let mut free = self.clone();
        free.speed_drive = None;
        free.balance = None;
        free.set_torques(torques[0], torques[1], torques[2]);
        free
    }

    /// The kinetic energy of the rigid-body rotation per unit input speed squared, doubled:
    /// the train's inertia referred to the input member, J = Σ m_i r_i² [kg·m²], with r the
    /// rigid-body velocity per rad/s of input speed.
    pub fn rigid_inertia(&self) -> f64 {
        self.mass.iter().zip(&self.rigid_velocity).map(|(m, r)| m * r * r).sum()
    }

    /// The inertia of the input member's own rotation [kg·m²].
    pub fn input_member_inertia(&self) -> f64 {
        self.mass[self.input_index] * self.input_lever * self.input_lever
    }

    /// The generalised torque of external torques `torques` on sun, ring and carrier [N·m]
    /// on the rigid-body rotation, referred to the input member: Σ T_m ω_m / ω_input [N·m]
    /// (the held member's torque does no work).
    pub fn rigid_torque(&self, torques: [f64; 3]) -> f64 {
        self.rotations
            .iter()
            .zip([torques[2], torques[1], torques[0]])
            .filter_map(|((index, lever), t)| index.map(|i| t * self.rigid_velocity[i] / lever))
            .sum()
    }

    /// Torque of the speed drive's shaft on the speed-driven member
    /// ([`GearSet::speed_driven_member`](crate::model::gear::GearSet::speed_driven_member), the input member by default)
    /// [N·m], counter-clockwise positive, under the speed drive.
    pub fn shaft_torque(&self, t: f64, q: &[f64], v: &[f64]) -> Option<f64> {
        self.speed_drive.map(|d| {
            let i = d.index;
            (d.stiffness * (d.offset + d.speed * t - q[i]) + d.damping * (d.speed - v[i])) * d.lever
        })
    }

    /// Torque of the load balance's controller on the output member [N·m],
    /// counter-clockwise positive, if the load balance is on.
    pub fn balancing_torque(&self, t: f64, q: &[f64], v: &[f64]) -> Option<f64> {
        self.balance.map(|(o, b)| {
            let lever = self.rotations.iter().find(|(i, _)| *i == Some(o)).map_or(1.0, |(_, l)| *l);
            (b.stiffness * (b.offset + b.speed * t - q[o]) + b.damping * (b.speed - v[o])) * lever
        })
    }

    /// Torque the support exerts on the held member [N·m], counter-clockwise
    /// positive (the sign of the input torques), at the state of the last
    /// force evaluation (`q`, `v` must be that state): what holds it at rest
    /// against the mesh forces (with their damping) and, for a held carrier,
    /// the planet bearings' forces. In a steady state it balances the other
    /// members' torques on average: T_sun + T_ring + T_carrier = 0 with the
    /// held member's torque replaced by this one.
    pub fn reaction_torque(&self, q: &[f64], v: &[f64]) -> f64 {
        let r = &self.reaction;
        let meshes: f64 =
            r.links.iter().zip(&self.meshes).map(|(c, m)| c * (m.force + m.damping_force)).sum();
        let bearings: f64 = r
            .bearings
            .iter()
            .map(|b| {
                let dq: f64 = b.vector.iter().map(|(j, x)| x * q[*j]).sum();
                let dv: f64 = b.vector.iter().map(|(j, x)| x * v[*j]).sum();
                b.share * (b.stiffness * dq + b.damping * dv)
            })
            .sum();
        r.lever * (meshes + bearings)
    }

    /// Number of meshes (2 per planet).
    pub fn mesh_count(&self) -> usize {
        self.links.len()
    }

    /// Planet and kind of mesh `i`.
    pub fn mesh_identity(&self, i: usize) -> (usize, MeshKind) {
        (self.links[i].planet, self.links[i].kind)
    }

    /// Sets the speed of the speed drive's source from the input speed
    /// `omega` [rad/s of the input member]: the speed-driven member's source
    /// turns at its kinematic speed for that input speed.
    pub fn set_drive_speed(&mut self, omega: f64) {
        if let Some(frame) = &mut self.frame {
            frame.set_input_speed(omega);
        }
        if let Some(d) = &mut self.speed_drive {
            d.speed = omega * d.rate;
        }
        if let Some((o, b)) = &mut self.balance {
            b.speed = omega * self.rigid_velocity[*o];
        }
    }

    /// The speed drive's source state (angle offset \[m\] and speed [m/s] on
    /// u), then the load balance's source state, each only if present: empty
    /// for the torque drive without load balance.
    pub fn drive_state(&self) -> Vec<f64> {
        let mut state = self.speed_drive.map_or(Vec::new(), |d| vec![d.offset, d.speed]);
        if let Some((_, b)) = self.balance {
            state.extend([b.offset, b.speed]);
        }
        state
    }

    /// Restores a state from [`Self::drive_state`] (ignored when its length
    /// does not fit this model's drive and load balance).
    pub fn set_drive_state(&mut self, state: &[f64]) {
        let sources = usize::from(self.speed_drive.is_some()) + usize::from(self.balance.is_some());
        if state.len() != 2 * sources {
            return;
        }
        let mut rest = state;
        if let Some(d) = &mut self.speed_drive {
            (d.offset, d.speed) = (rest[0], rest[1]);
            rest = &rest[2..];
        }
        if let Some((_, b)) = &mut self.balance {
            (b.offset, b.speed) = (rest[0], rest[1]);
        }
    }

    /// Sets the carrier frame's mean speed to the carrier's kinematic speed
    /// for the input speed `omega` \[rad/s\], the drive's sources untouched
    /// ([`Self::set_drive_speed`] sets both).
    pub fn set_frame_speed(&mut self, omega: f64) {
        if let Some(frame) = &mut self.frame {
            frame.set_input_speed(omega);
        }
    }

    /// The carrier frame's mean speed Ω_c [rad/s] (0 for a held carrier or
    /// the torsional model, whose equations have no carrier-frame terms).
    pub fn carrier_frame_speed(&self) -> f64 {
        self.frame.as_ref().map_or(0.0, CarrierFrame::speed)
    }

    /// The steady centrifugal load m_p Ω_c² r_c of one planet on its bearing
    /// \[N\], radially outward (0 when the carrier is held). The dynamics
    /// carry it: it shifts each planet's radial bearing deflection.
    pub fn planet_centrifugal_force(&self) -> f64 {
        self.frame.as_ref().map_or(0.0, CarrierFrame::planet_centrifugal_force)
    }

    /// Whether the output member is held at its kinematic speed by the load balance.
    pub fn has_load_balance(&self) -> bool {
        self.balance.is_some()
    }

    /// Changes the speed drive's source speed at time `t` \[s\] keeping the
    /// source's angle continuous (no jump in the shaft's wind-up).
    pub fn change_drive_speed(&mut self, omega: f64, t: f64) {
        if let Some(frame) = &mut self.frame {
            frame.set_input_speed(omega);
        }
        if let Some(d) = &mut self.speed_drive {
            let new = omega * d.rate;
            d.offset += (d.speed - new) * t;
            d.speed = new;
        }
        if let Some((o, b)) = &mut self.balance {
            let new = omega * self.rigid_velocity[*o];
            b.offset += (b.speed - new) * t;
            b.speed = new;
        }
    }

    /// Rigid-body initial state at input speed `omega` [rad/s], elastic
    /// deflection from the static load: q = 0 but for a uniform approach.
    pub fn rigid_velocity_at(&self, omega: f64) -> Vec<f64> {
        self.rigid_velocity.iter().map(|v| v * omega).collect()
    }

    /// The contact law of a mesh, pair or deformable.
    pub fn mesh_model(&self, kind: MeshKind) -> MeshContact<'_> {
        MeshContact::of(&self.contact, self.deformable.as_deref(), kind)
    }

    /// Full Lin–Parker coordinates of a reduced coordinate vector.
    pub fn full_coordinates(&self, q: &[f64]) -> Vec<f64> {
        let mut full = vec![0.0; self.reduction.full];
        for (row, entries) in self.reduction.t.iter().enumerate() {
            for (col, f) in entries {
                full[row] += f * q[*col];
            }
        }
        full
    }

    /// The mesh whose tooth pair event function `index` belongs to (the
    /// event values are laid out mesh by mesh, each mesh's pair slots in
    /// turn: [`SecondOrderSystem::events`]); `None` past the last.
    pub fn event_mesh(&self, index: usize) -> Option<usize> {
        let mut end = 0;
        for (i, link) in self.links.iter().enumerate() {
            end += 2 * self.slots[Self::slot_kind(link.kind)];
            if index < end {
                return Some(i);
            }
        }
        None
    }

    /// Adds to `f` the change of the generalized forces [N or N·m] when the
    /// damping force of mesh `i` switches on (`on`: a pair starts to touch in
    /// a mesh that had none) or off, at the state of the last evaluation: the
    /// force c·δ̇ acts along the mesh's line while a pair touches, so it jumps
    /// there while the elastic force does not. Under Rayleigh damping the
    /// jump is η times the mesh's tangent stiffness at its last evaluation
    /// in contact; the damping η ∂F/∂δ δ̇ also jumps where a pair enters or
    /// leaves a mesh that stays in contact (the tangent stiffness jumps
    /// there): [`Self::add_rayleigh_jump`] gives those, which the saltations
    /// of shooting and of the harmonic balance's multipliers carry too.
    pub fn add_damping_switch(&self, i: usize, on: bool, f: &mut [f64]) {
        let link = &self.links[i];
        let c = link.damping_at(self.mesh_stiffness_damping, self.touch_stiffness[i]);
        let jump = c * self.meshes[i].approach_rate;
        let sign = if on { -1.0 } else { 1.0 };
        for (j, b) in &link.b_nz {
            f[*j] += sign * b * jump;
        }
    }

    /// Adds to `f` the change of the generalized forces [N or N·m] where a
    /// pair enters or leaves mesh `i` while the mesh stays in contact, under
    /// Rayleigh damping: the damping force η K_t δ̇ jumps with the tangent
    /// stiffness, from η `before` δ̇ to η `after` δ̇ (N/m), δ̇ of the last
    /// evaluation. Nothing under the ratio model, whose damping does not
    /// change while a pair touches.
    pub fn add_rayleigh_jump(&self, i: usize, [before, after]: [f64; 2], f: &mut [f64]) {
        let eta = self.mesh_stiffness_damping;
        if eta == 0.0 || before <= 0.0 || after <= 0.0 {
            return;
        }
        let jump = eta * (after - before) * self.meshes[i].approach_rate;
        for (j, b) in &self.links[i].b_nz {
            f[*j] -= b * jump;
        }
    }

    /// Whether the damping is Rayleigh's (η > 0 on the meshes), whose force
    /// jumps at every pair switch ([`Self::add_rayleigh_jump`]).
    pub fn rayleigh_meshes(&self) -> bool {
        self.mesh_stiffness_damping > 0.0
    }

    fn model(&self, kind: MeshKind) -> &MeshModel {
        match kind {
            MeshKind::SunPlanet => &self.contact.sun_planet,
            MeshKind::RingPlanet => &self.contact.ring_planet,
        }
    }

    /// Index of a mesh kind's event slot count in `slots`.
    fn slot_kind(kind: MeshKind) -> usize {
        if kind == MeshKind::SunPlanet {
            0
        } else {
            1
        }
    }

    fn evaluate_meshes(&mut self, q: &[f64], v: &[f64], with_events: bool) {
        if let Some((cq, cv, ce)) = &self.cache {
            if cq.as_slice() == q && cv.as_slice() == v && (*ce || !with_events) {
                return;
            }
        }
        match &mut self.cache {
            Some((cq, cv, ce)) => {
                cq.clear();
                cq.extend_from_slice(q);
                cv.clear();
                cv.extend_from_slice(v);
                *ce = with_events;
            }
            None => self.cache = Some((q.to_vec(), v.to_vec(), with_events)),
        }
        let mut events = std::mem::take(&mut self.events_scratch);
        // The event values are only read after an evaluation with events, which writes every
        // slot: the buffer keeps its length (2·slots per mesh) between evaluations.
        if with_events {
            let total: usize = self.links.iter().map(|l| 2 * self.slots[Self::slot_kind(l.kind)]).sum();
            events.resize(total, 0.0);
        }
        let mut start = 0;
        for (i, link) in self.links.iter().enumerate() {
            // The sums of `Iterator::sum` (from −0.0, in order), in one pass for δ and its rate.
            let (mut delta, mut rate) = (-0.0, -0.0);
            for &(j, b) in &link.b_nz {
                delta += b * q[j];
                rate += b * v[j];
            }
            let mut s = -0.0;
            for &(j, p) in &link.p_nz {
                s += p * q[j];
            }
            s += link.s0;
            let law = if let Some(d) = &self.deformable {
                if with_events {
                    events[start..start + 2].copy_from_slice(&d.mesh(link.kind).events(s, delta));
                    start += 2;
                }
                self.law_at(link.kind, s, delta)
            } else if with_events {
                let end = start + 2 * self.slots[Self::slot_kind(link.kind)];
                let law = self.model(link.kind).force_with_derivatives(s, delta, &mut events[start..end]);
                start = end;
                law
            } else {
                self.law_at(link.kind, s, delta)
            };
            if law.approach_stiffness > 0.0 {
                self.touch_stiffness[i] = law.approach_stiffness;
            }
            self.meshes[i] = self.state_of(link, law, s, delta, rate);
        }
        self.events_scratch = events;
    }

    /// The law of a mesh of kind `kind` at position `s` and approach `delta`
    /// (no event values). A law that cannot be evaluated (a non-finite state)
    /// gives NaN, which the integrator and the periodic solvers refuse.
    fn law_at(&self, kind: MeshKind, s: f64, delta: f64) -> MeshLaw {
        match &self.deformable {
            Some(d) => d.mesh(kind).force_tangents(s, delta).unwrap_or(MeshLaw {
                force: f64::NAN,
                approach_stiffness: f64::NAN,
                position_derivative: f64::NAN,
                peak_pair_force: f64::NAN,
            }),
            None => self.model(kind).force_tangents(s, delta),
        }
    }

    /// Rayleigh damping's change of a touching mesh's damping force
    /// η K_t(s, δ) δ̇ with its approach and position: η δ̇ ∂K_t/∂δ and
    /// η δ̇ ∂K_t/∂s, which add to the tangent's stiffness and cross
    /// coefficients. The laws give both derivatives of their interpolated
    /// stiffness exactly, contact status frozen (a pair entering or leaving
    /// contact is a switch, which the saltation carries), in one evaluation.
    /// Where the deformable law's approach lies beyond its table (solved
    /// there, not interpolated) they are central differences of its tangent
    /// stiffness ([`Self::rayleigh_tangent_by_differences`]). Both are 0 under
    /// the ratio model, and for a mesh that does not touch.
    fn rayleigh_tangent(&self, kind: MeshKind, state: &MeshState) -> (f64, f64) {
        let eta = self.mesh_stiffness_damping;
        if eta == 0.0 || state.stiffness <= 0.0 || state.approach_rate == 0.0 {
            return (0.0, 0.0);
        }
        let (s, delta) = (state.position, state.approach);
        let exact = match &self.deformable {
            Some(d) => d.mesh(kind).stiffness_derivatives(s, delta).unwrap_or(Some((f64::NAN, f64::NAN))),
            None => Some(self.model(kind).stiffness_derivatives(s, delta)),
        };
        let (d_delta, d_s) = exact.unwrap_or_else(|| self.rayleigh_tangent_by_differences(kind, state));
        let scale = eta * state.approach_rate;
        (scale * d_delta, scale * d_s)
    }

    /// (∂K_t/∂δ, ∂K_t/∂s) of a touching mesh by central differences of its
    /// tangent stiffness, at 1e-4 of the mesh's elastic deflection F/K_t in δ
    /// and 10 nm in s. Where the two sides' stiffness differs by more than
    /// 5 % a pair enters or leaves contact between them (a switch, which the
    /// saltation carries): 0 there.
    fn rayleigh_tangent_by_differences(&self, kind: MeshKind, state: &MeshState) -> (f64, f64) {
        let k = state.stiffness;
        let slope = |plus: MeshLaw, minus: MeshLaw, h: f64| {
            let (a, b) = (plus.approach_stiffness, minus.approach_stiffness);
            if a > 0.0 && b > 0.0 && (a - b).abs() <= 0.05 * k {
                (a - b) / (2.0 * h)
            } else {
                0.0
            }
        };
        let (s, delta) = (state.position, state.approach);
        let h_delta = 1e-4 * (state.force / k).abs().max(1e-9);
        let h_s = 1e-8;
        let d_delta =
            slope(self.law_at(kind, s, delta + h_delta), self.law_at(kind, s, delta - h_delta), h_delta);
        let d_s = slope(self.law_at(kind, s + h_s, delta), self.law_at(kind, s - h_s, delta), h_s);
        (d_delta, d_s)
    }

    /// A mesh's state from its law: the damping force acts while a pair touches.
    fn state_of(&self, link: &Link, law: MeshLaw, s: f64, delta: f64, rate: f64) -> MeshState {
        let damping_force = if law.approach_stiffness > 0.0 {
            link.damping_at(self.mesh_stiffness_damping, law.approach_stiffness) * rate
        } else {
            0.0
        };
        MeshState {
            position: s,
            approach: delta,
            approach_rate: rate,
            force: law.force,
            stiffness: law.approach_stiffness,
            position_derivative: law.position_derivative,
            damping_force,
            peak_pair_force: law.peak_pair_force,
        }
    }

    /// Mesh `i` alone at position `s` \[m\], approach `delta` \[m\] and approach
    /// rate `rate` [m/s], with its viscous damping coefficient [N·s/m] at that
    /// state (0 out of contact): what a solver that samples the contact
    /// coordinates instead of the whole state evaluates. The model's last
    /// evaluation is left as it was.
    pub fn mesh_at(&self, i: usize, s: f64, delta: f64, rate: f64) -> (MeshState, f64) {
        let link = &self.links[i];
        let law = self.law_at(link.kind, s, delta);
        self.state_and_damping(link, law, (s, delta, rate))
    }

    /// [`Self::mesh_at`] with mesh `i`'s event values written into `events`
    /// ([`Self::mesh_events_at`], [`Self::mesh_event_count`] of them): the
    /// tabulated law evaluated once for both.
    pub fn mesh_at_with_events(
        &self,
        i: usize,
        (s, delta, rate): (f64, f64, f64),
        events: &mut [f64],
    ) -> (MeshState, f64) {
        let link = &self.links[i];
        let law = match &self.deformable {
            Some(d) => {
                events.copy_from_slice(&d.mesh(link.kind).events(s, delta));
                self.law_at(link.kind, s, delta)
            }
            None => self.model(link.kind).force_with_derivatives(s, delta, events),
        };
        self.state_and_damping(link, law, (s, delta, rate))
    }

    /// The state of `link` under `law` at (position, approach, rate), and its damping
    /// coefficient (0 out of contact).
    fn state_and_damping(
        &self,
        link: &Link,
        law: MeshLaw,
        (s, delta, rate): (f64, f64, f64),
    ) -> (MeshState, f64) {
        let damping = if law.approach_stiffness > 0.0 {
            link.damping_at(self.mesh_stiffness_damping, law.approach_stiffness)
        } else {
            0.0
        };
        (self.state_of(link, law, s, delta, rate), damping)
    }

    /// Number of event values of mesh `i` ([`Self::mesh_events_at`]).
    pub fn mesh_event_count(&self, i: usize) -> usize {
        if self.deformable.is_some() {
            2
        } else {
            2 * self.slots[Self::slot_kind(self.links[i].kind)]
        }
    }

    /// The event values of mesh `i` alone at position `s` \[m\] and approach
    /// `delta` \[m\] into `out` ([`Self::mesh_event_count`] of them): their
    /// sign changes are where its tooth pairs start or stop touching, as the
    /// model's events.
    pub fn mesh_events_at(&self, i: usize, s: f64, delta: f64, out: &mut [f64]) {
        let kind = self.links[i].kind;
        match &self.deformable {
            Some(d) => out.copy_from_slice(&d.mesh(kind).events(s, delta)),
            None => {
                self.model(kind).force_with_derivatives(s, delta, out);
            }
        }
    }

    /// Where mesh `i` reads its coordinates.
    pub fn mesh_coordinates(&self, i: usize) -> MeshCoordinates<'_> {
        let link = &self.links[i];
        MeshCoordinates { approach: &link.b_nz, position: &link.p_nz, offset: link.s0 }
    }
}

impl PlanetaryDynamics {
    /// The generalized force at (`t`, `q`, `v`) without the meshes' forces: the loads, the
    /// supports, the carrier frame's terms and the drives, the part of
    /// [`SecondOrderSystem::force`] that is linear in the state. No mesh law is evaluated.
    pub fn force_but_meshes(&self, t: f64, q: &[f64], v: &[f64], f: &mut [f64]) {
        f.copy_from_slice(&self.f_ext);
        for &(i, j, k, c) in &self.support_nz {
            f[i] -= k * q[j] + c * v[j];
        }
        if let Some(frame) = &self.frame {
            frame.add_force(q, v, f);
        }
        if let Some(d) = self.speed_drive {
            let i = d.index;
            f[i] += d.stiffness * (d.offset + d.speed * t - q[i]) + d.damping * (d.speed - v[i]);
        }
        if let Some((o, b)) = self.balance {
            f[o] += b.stiffness * (b.offset + b.speed * t - q[o]) + b.damping * (b.speed - v[o]);
        }
    }
}

impl SecondOrderSystem for PlanetaryDynamics {
    fn dim(&self) -> usize {
        self.mass.len()
    }

    fn mass(&self) -> &[f64] {
        &self.mass
    }

    fn force(&mut self, t: f64, q: &[f64], v: &[f64], f: &mut [f64]) {
        self.evaluate_meshes(q, v, false);
        self.force_but_meshes(t, q, v, f);
        for (link, state) in self.links.iter().zip(&self.meshes) {
            let total = state.force + state.damping_force;
            for (j, b) in &link.b_nz {
                f[*j] -= b * total;
            }
        }
    }

    fn events(&mut self, _t: f64, q: &[f64], v: &[f64], out: &mut Vec<f64>) {
        self.evaluate_meshes(q, v, true);
        out.clear();
        out.extend_from_slice(&self.events_scratch);
    }
}

impl TangentSystem for PlanetaryDynamics {
    fn jacobian(&mut self, _t: f64, q: &[f64], v: &[f64], k: &mut DMatrix<f64>, c: &mut DMatrix<f64>) {
        self.evaluate_meshes(q, v, false);
        k.copy_from(&self.k_support);
        c.copy_from(&self.c_support);
        if let Some(frame) = &self.frame {
            frame.add_jacobian(k, c);
        }
        for (link, state) in self.links.iter().zip(&self.meshes) {
            if state.stiffness == 0.0 {
                continue;
            }
            // Under Rayleigh damping the damping force's own change with the
            // approach and the position (`rayleigh_tangent`).
            let (rayleigh_delta, rayleigh_s) = self.rayleigh_tangent(link.kind, state);
            let damping = link.damping_at(self.mesh_stiffness_damping, state.stiffness);
            let stiffness = state.stiffness + rayleigh_delta;
            for &(i, bi) in &link.b_nz {
                for &(j, bj) in &link.b_nz {
                    k[(i, j)] += stiffness * bi * bj;
                    c[(i, j)] += damping * bi * bj;
                }
            }
            // ∂F/∂s · ∂s/∂q: a rank-one, non-symmetric term.
            let cross = state.position_derivative + rayleigh_s;
            for (i, b) in &link.b_nz {
                for (j, p) in &link.p_nz {
                    k[(*i, *j)] += b * cross * p;
                }
            }
        }
        if let Some(d) = self.speed_drive {
            let i = d.index;
            k[(i, i)] += d.stiffness;
            c[(i, i)] += d.damping;
        }
        if let Some((o, b)) = self.balance {
            k[(o, o)] += b.stiffness;
            c[(o, o)] += b.damping;
        }
    }

    fn low_rank_jacobian(&self) -> Option<LowRankJacobian> {
        // Bearings and the drive shaft are constant; each mesh adds u = b (δ = bᵀq) with the
        // contact's tangent stiffness and damping, and the rank-one term b ∂F/∂s pᵀ.
        let (mut k0, mut c0) = (self.k_support.clone(), self.c_support.clone());
        if let Some(frame) = &self.frame {
            frame.add_jacobian(&mut k0, &mut c0);
        }
        if let Some(d) = self.speed_drive {
            let i = d.index;
            k0[(i, i)] += d.stiffness;
            c0[(i, i)] += d.damping;
        }
        if let Some((o, b)) = self.balance {
            k0[(o, o)] += b.stiffness;
            c0[(o, o)] += b.damping;
        }
        let terms = self.links.iter().map(|l| RankOneTerm { u: l.b_nz.clone(), p: l.p_nz.clone() }).collect();
        Some(LowRankJacobian { k0, c0, terms })
    }

    fn jacobian_coefficients(&mut self, _t: f64, q: &[f64], v: &[f64], out: &mut [TermCoefficients]) {
        self.evaluate_meshes(q, v, false);
        for ((link, state), c) in self.links.iter().zip(&self.meshes).zip(out.iter_mut()) {
            *c = if state.stiffness == 0.0 {
                TermCoefficients::default()
            } else {
                let (rayleigh_delta, rayleigh_s) = self.rayleigh_tangent(link.kind, state);
                TermCoefficients {
                    stiffness: state.stiffness + rayleigh_delta,
                    damping: link.damping_at(self.mesh_stiffness_damping, state.stiffness),
                    cross: state.position_derivative + rayleigh_s,
                }
            };
        }
    }
}

//! The dynamic model built from a gear set and its contact models: the
//! mean mesh stiffnesses, the lumped set and its reduction, the support
//! damping, the mesh links, the rigid-body velocity pattern, the speed
//! drive, the held member's reaction and the load balance.

use std::sync::Arc;

use nalgebra::DMatrix;

use super::{DynamicsError, Link, MeshState, PlanetaryDynamics, Reaction, ReactionBearing, SpeedDrive};
use crate::contact::deformable::set::DeformableSet;
use crate::contact::ltca::{CycleStats, SetModel};
use crate::contact::mesh_law::MeshContact;
use crate::model::carrier_frame::CarrierFrame;
use crate::model::gear::{Damping, Drive, GearSet, Member, MeshKind};
use crate::model::lumped::{
    add_outer, full_index, planet_bearing_vectors, ring_mesh_vector, sun_mesh_vector, Coordinate, Fidelity,
    LumpedSet, Reduction,
};

pub use crate::model::kinematics::rigid_speeds;

/// Natural frequency of the load balance's controlled rigid-body mode \[Hz\].
pub const BALANCE_FREQUENCY: f64 = 50.0;
/// Damping ratio of the load balance's controlled rigid-body mode [-].
pub const BALANCE_DAMPING: f64 = 1.0;

fn lever(set: &GearSet, m: Member) -> f64 {
    match m {
        Member::Sun => set.sun().base_radius(),
        Member::Ring => set.ring().base_radius(),
        Member::Carrier => set.centre_distance(),
    }
}

/// The mean tangent stiffness of a mesh over one cycle at `load` \[N\] [N/m]
/// (64 positions): the stiffness the damping ratio and the linear model read.
fn mean_stiffness(mesh: MeshContact<'_>, load: f64) -> Result<f64, DynamicsError> {
    let p = mesh.path().clone();
    let mut samples = Vec::with_capacity(64);
    for i in 0..64 {
        let s = p.start + p.base_pitch * f64::from(i) / 64.0;
        samples.push(match mesh {
            MeshContact::Pair(m) => m.force(s, m.approach_for(s, load), None).1,
            MeshContact::Deformable(t) => {
                let solved = t.mesh.approach_for(s, load).and_then(|d| t.mesh.solve(s, d));
                solved.map_err(|e| DynamicsError::Contact(e.to_string()))?.law.approach_stiffness
            }
        });
    }
    Ok(CycleStats::of(&samples).mean)
}

/// The deformable law (when the set asks for it) and the mean tangent
/// stiffnesses of the sun–planet and ring–planet meshes [N/m].
type ContactLaws = (Option<Arc<DeformableSet>>, f64, f64);

/// The deformable law when the set asks for it, and the mean tangent
/// stiffness of the sun–planet and ring–planet meshes on the law read.
fn contact_laws(set: &GearSet, contact: &SetModel) -> Result<ContactLaws, DynamicsError> {
    let load = set.mesh_load_per_planet().max(1.0);
    let deformable =
        DeformableSet::of_set_model(set, contact).map_err(|e| DynamicsError::Contact(e.to_string()))?;
    let view = |kind: MeshKind| MeshContact::of(contact, deformable.as_deref(), kind);
    let k_sp = mean_stiffness(view(MeshKind::SunPlanet), load)?;
    let k_rp = mean_stiffness(view(MeshKind::RingPlanet), load)?;
    Ok((deformable, k_sp, k_rp))
}

impl PlanetaryDynamics {
    /// The dynamic model of a validated gear set with its contact models.
    pub fn new(set: &GearSet, contact: SetModel) -> Result<Self, DynamicsError> {
        let alpha = [
            set.operating_pressure_angle(MeshKind::SunPlanet),
            set.operating_pressure_angle(MeshKind::RingPlanet),
        ];
        let (deformable, k_sp, k_rp) = contact_laws(set, &contact)?;
        let lumped = lumped_set(set, [k_sp, k_rp], alpha);
        let reduction = lumped.reduction();
        let mass = lumped.mass();
        let k_support = lumped.support_stiffness();
        let parts = Parts { set, lumped: &lumped, reduction: &reduction, alpha };
        let mut c_support = parts.bearing_damping();
        let (zeta_m, eta) = match set.damping() {
            Damping::Ratio => (set.mesh_damping_ratio(), 0.0),
            Damping::Rayleigh { stiffness, .. } => (0.0, stiffness),
        };
        let links = parts.links([k_sp, k_rp], zeta_m, contact.ring_shift);
        // External torques: the set's balance ([`GearSet::balanced_torques`]),
        // applied through `set_torques` once the model stands.
        let torques = set.balanced_torques();
        let input_index = parts.u(set.input()).ok_or_else(|| DynamicsError::InvalidParameter {
            name: "operation.input".into(),
            value: set.input().name().into(),
            reason: "the input member cannot be the held member".into(),
        })?;
        let input_lever = lever(set, set.input());
        let rigid = parts.rigid_velocity();
        let (ws, _, wc) = rigid_speeds(set);
        let mesh_frequency_per_input_speed =
            ((ws - wc) * f64::from(set.sun().teeth) / (2.0 * std::f64::consts::PI)).abs();
        let a = set.centre_distance();
        let rotations = [
            (parts.u(Member::Carrier), a),
            (parts.u(Member::Ring), set.ring().base_radius()),
            (parts.u(Member::Sun), set.sun().base_radius()),
        ];
        let speed_drive = parts.speed_drive(torques, &mass, &rigid)?;
        let reaction = parts.reaction();
        let balance = parts.balance(torques, &mass, &rigid);
        if let Damping::Rayleigh { mass: mu, stiffness } = set.damping() {
            c_support = rayleigh_support_damping(&mass, &rigid, &k_support, mu, stiffness);
        }
        // The deformable law has one event per flank and mesh: where the mesh starts or stops carrying load.
        let slots = deformable.as_ref().map_or_else(
            || vec![contact.sun_planet.event_slots(), contact.ring_planet.event_slots()],
            |_| vec![1, 1],
        );
        let support_nz = support_nonzeros(&k_support, &c_support);
        let meshes = vec![MeshState::default(); links.len()];
        let frame = CarrierFrame::new(&lumped, a, &rigid, wc);
        let n = set.planet_angles().len();
        let dim = reduction.dim();
        let mut model = Self {
            contact,
            deformable,
            lumped,
            reduction,
            mass,
            k_support,
            c_support,
            support_nz,
            links,
            f_ext: vec![0.0; dim],
            speed_drive,
            balance,
            reaction,
            input_index,
            input_lever,
            rigid_velocity: rigid,
            mesh_frequency_per_input_speed,
            rotations,
            meshes,
            slots,
            events_scratch: Vec::new(),
            cache: None,
            frame,
            mesh_stiffness_damping: eta,
            touch_stiffness: vec![0.0; 2 * n],
        };
        model.set_torques(torques[0], torques[1], torques[2]);
        Ok(model)
    }
}

/// The mean-stiffness linear model of the set: the bodies' masses (the
/// rotational masses on the base radii, the carrier's on the centre
/// distance), the supports, and the meshes' mean stiffnesses `k` and
/// operating pressure angles `alpha` (sun–planet, ring–planet).
fn lumped_set(set: &GearSet, k: [f64; 2], alpha: [f64; 2]) -> LumpedSet {
    let b = &set.bodies();
    let (rbs, rbr, rbp, a) = (
        set.sun().base_radius(),
        set.ring().base_radius(),
        set.planet().base_radius(),
        set.centre_distance(),
    );
    LumpedSet {
        central_mass: [b.carrier.mass, b.ring.mass, b.sun.mass],
        central_rotational_mass: [
            b.carrier.inertia / (a * a),
            b.ring.inertia / (rbr * rbr),
            b.sun.inertia / (rbs * rbs),
        ],
        planet_mass: b.planet.mass,
        planet_rotational_mass: b.planet.inertia / (rbp * rbp),
        central_bearing: [
            set.supports().carrier_radial,
            set.supports().ring_radial,
            set.supports().sun_radial,
        ],
        central_torsional: [0.0; 3],
        planet_bearing: set.supports().planet_bearing,
        planet_bearings: set.supports().planet_bearings.clone(),
        sun_mesh: k[0],
        ring_mesh: k[1],
        sun_pressure_angle: alpha[0],
        ring_pressure_angle: alpha[1],
        planet_angles: set.planet_angles().to_vec(),
        held: Some(set.held()),
        fidelity: set.fidelity(),
    }
}

/// The balanced torque of member `m` among `torques` (sun, ring, carrier).
fn torque_of(torques: [f64; 3], m: Member) -> f64 {
    torques[m.index()]
}

/// The nonzero entries (i, j, k_ij, c_ij) of the support matrices.
fn support_nonzeros(k_support: &DMatrix<f64>, c_support: &DMatrix<f64>) -> Vec<(usize, usize, f64, f64)> {
    let dim = k_support.nrows();
    let mut support_nz = Vec::new();
    for i in 0..dim {
        for j in 0..dim {
            let (k, c) = (k_support[(i, j)], c_support[(i, j)]);
            if k != 0.0 || c != 0.0 {
                support_nz.push((i, j, k, c));
            }
        }
    }
    support_nz
}

/// What the model's parts are built from: the set, its lumped model and
/// reduction, and the operating pressure angles (sun–planet, ring–planet).
struct Parts<'a> {
    set: &'a GearSet,
    lumped: &'a LumpedSet,
    reduction: &'a Reduction,
    alpha: [f64; 2],
}

impl Parts<'_> {
    /// The index of member `m`'s rotation u among the reduced coordinates
    /// (None when held).
    fn u(&self, m: Member) -> Option<usize> {
        self.reduction.position(Coordinate::U(m))
    }

    /// Bearing damping: c = 2ζ√(k m) of each body on its own bearing, with
    /// the damping ratio of that member (carrier, ring, sun, planets).
    fn bearing_damping(&self) -> DMatrix<f64> {
        let (set, lumped, reduction) = (self.set, self.lumped, self.reduction);
        let dim = reduction.dim();
        let mut c_support = DMatrix::zeros(dim, dim);
        let zeta = set.supports().damping_ratios;
        let members = [Member::Carrier, Member::Ring, Member::Sun];
        for (j, m) in members.iter().enumerate() {
            let c = 2.0 * zeta[j] * (lumped.central_bearing[j] * lumped.central_mass[j]).sqrt();
            for coord in [Coordinate::X(*m), Coordinate::Y(*m)] {
                if let Some(i) = reduction.position(coord) {
                    c_support[(i, i)] += c;
                }
            }
        }
        let n = set.planet_angles().len();
        for (p, psi) in set.planet_angles().iter().enumerate() {
            let cp = 2.0 * zeta[3] * (lumped.planet_bearing_of(p) * lumped.planet_mass).sqrt();
            for bv in planet_bearing_vectors(n, p, *psi) {
                add_outer(&mut c_support, &reduction.reduce_vector(&bv), cp);
            }
        }
        c_support
    }

    /// The two meshes of every planet: where each reads q, its offset, and
    /// the ratio model's viscous damping 2ζ_m√(k m) on the mean stiffness
    /// `k` (sun–planet, ring–planet) and the two gears' rotational masses
    /// (`zeta_m` 0 under Rayleigh damping).
    fn links(&self, k: [f64; 2], zeta_m: f64, ring_shift: f64) -> Vec<Link> {
        let (set, lumped) = (self.set, self.lumped);
        let (k_sp, k_rp) = (k[0], k[1]);
        let (rbs, rbr, a) = (set.sun().base_radius(), set.ring().base_radius(), set.centre_distance());
        let m_rot = |x: f64, y: f64| x * y / (x + y);
        let c_sp = 2.0
            * zeta_m
            * (k_sp * m_rot(lumped.central_rotational_mass[2], lumped.planet_rotational_mass)).sqrt();
        let c_rp = 2.0
            * zeta_m
            * (k_rp * m_rot(lumped.central_rotational_mass[1], lumped.planet_rotational_mass)).sqrt();
        let u = |m: Member| self.u(m);
        let mut links = Vec::new();
        for (p, (bs, br)) in lumped.mesh_vectors().into_iter().enumerate() {
            let psi = set.planet_angles()[p];
            let nz =
                |v: &[f64]| v.iter().enumerate().filter(|(_, x)| **x != 0.0).map(|(i, x)| (i, *x)).collect();
            let mut ps = Vec::new();
            if let Some(i) = u(Member::Sun) {
                ps.push((i, 1.0));
            }
            if let Some(i) = u(Member::Carrier) {
                ps.push((i, -rbs / a));
            }
            let mut pr = Vec::new();
            if let Some(i) = u(Member::Ring) {
                pr.push((i, -1.0));
            }
            if let Some(i) = u(Member::Carrier) {
                pr.push((i, rbr / a));
            }
            links.push(Link {
                planet: p,
                kind: MeshKind::SunPlanet,
                b_nz: nz(&bs),
                p_nz: ps,
                s0: -rbs * psi,
                damping: c_sp,
            });
            links.push(Link {
                planet: p,
                kind: MeshKind::RingPlanet,
                b_nz: nz(&br),
                p_nz: pr,
                s0: -rbs * psi + ring_shift,
                damping: c_rp,
            });
        }
        links
    }

    /// Rigid-body velocity at unit input speed. Willis: (ω_s − ω_c) =
    /// R (ω_r − ω_c) with R = −Z_r/Z_s; the held member at rest.
    fn rigid_velocity(&self) -> Vec<f64> {
        let (set, reduction) = (self.set, self.reduction);
        let (rbs, rbr, a) = (set.sun().base_radius(), set.ring().base_radius(), set.centre_distance());
        let (ws, wr, wc) = rigid_speeds(set);
        let mut rigid = vec![0.0; reduction.dim()];
        if let Some(i) = self.u(Member::Sun) {
            rigid[i] = ws * rbs;
        }
        if let Some(i) = self.u(Member::Ring) {
            rigid[i] = wr * rbr;
        }
        if let Some(i) = self.u(Member::Carrier) {
            rigid[i] = wc * a;
        }
        for p in 0..set.planet_angles().len() {
            // δ_sn = u_s + u_n − η_n cos α_s = 0 with η_n = u_c for rigid motion.
            if let Some(i) = reduction.position(Coordinate::PlanetU(p)) {
                rigid[i] = -ws * rbs + wc * a * self.alpha[0].cos();
            }
            if let Some(i) = reduction.position(Coordinate::Eta(p)) {
                rigid[i] = wc * a;
            }
        }
        rigid
    }

    /// The speed drive, under `dynamics.drive = "speed"`: the speed-driven
    /// member (the input member unless the scene names another), preloaded
    /// with its balanced torque. Shaft stiffness on u: k_θ / lever²; damping
    /// ratio 0.05 of the driven body on the shaft.
    fn speed_drive(
        &self,
        torques: [f64; 3],
        mass: &[f64],
        rigid: &[f64],
    ) -> Result<Option<SpeedDrive>, DynamicsError> {
        let set = self.set;
        match set.drive() {
            Drive::Torque | Drive::SpeedSteps => Ok(None),
            Drive::Speed => {
                let driven = set.speed_driven_member();
                let index = self.u(driven).ok_or_else(|| DynamicsError::InvalidParameter {
                    name: "dynamics.speed_driven_member".into(),
                    value: driven.name().into(),
                    reason: "the held member cannot be speed-driven".into(),
                })?;
                let driven_lever = lever(set, driven);
                let torque = torque_of(torques, driven);
                let k = set.shaft_stiffness() / (driven_lever * driven_lever);
                let c = 2.0 * 0.05 * (k * mass[index]).sqrt();
                Ok(Some(SpeedDrive {
                    index,
                    lever: driven_lever,
                    rate: rigid[index],
                    stiffness: k,
                    damping: c,
                    speed: 0.0,
                    offset: torque / driven_lever / k,
                    preload: torque / driven_lever,
                }))
            }
        }
    }

    /// The held member's reaction: its rotation in full coordinates (its u,
    /// and in the torsional model with the carrier held the planets' η
    /// pinned to it), and that rotation's share of each mesh and
    /// planet-bearing force.
    fn reaction(&self) -> Reaction {
        let (set, lumped, reduction) = (self.set, self.lumped, self.reduction);
        let [alpha_s, alpha_r] = self.alpha;
        let n = set.planet_angles().len();
        let zeta = set.supports().damping_ratios;
        let held = set.held();
        let mut d = vec![0.0; reduction.full];
        d[full_index(Coordinate::U(held))] = 1.0;
        if set.fidelity() == Fidelity::Torsional && held == Member::Carrier {
            for p in 0..n {
                d[full_index(Coordinate::Eta(p))] = 1.0;
            }
        }
        let dot = |b: &[f64]| b.iter().zip(&d).map(|(x, y)| x * y).sum::<f64>();
        let mut reaction = Reaction { lever: lever(set, held), links: Vec::new(), bearings: Vec::new() };
        for (p, psi) in set.planet_angles().iter().enumerate() {
            reaction.links.push(dot(&sun_mesh_vector(n, p, *psi, alpha_s)));
            reaction.links.push(dot(&ring_mesh_vector(n, p, *psi, alpha_r)));
            let kp = lumped.planet_bearing_of(p);
            let cp = match set.damping() {
                Damping::Ratio => 2.0 * zeta[3] * (kp * lumped.planet_mass).sqrt(),
                Damping::Rayleigh { stiffness, .. } => stiffness * kp,
            };
            for bv in planet_bearing_vectors(n, p, *psi) {
                let e = dot(&bv);
                let reduced: Vec<(usize, f64)> =
                    reduction.reduce_vector(&bv).into_iter().enumerate().filter(|(_, x)| *x != 0.0).collect();
                if e != 0.0 && !reduced.is_empty() {
                    reaction.bearings.push(ReactionBearing {
                        share: e,
                        vector: reduced,
                        stiffness: kp,
                        damping: cp,
                    });
                }
            }
        }
        reaction
    }

    /// The load balance: a torsional spring and damper from a source
    /// turning at the output's kinematic speed, a PI controller of the
    /// output's speed (the spring the integral, the damper the
    /// proportional part), tuned to [`BALANCE_FREQUENCY`] and
    /// [`BALANCE_DAMPING`] on the rigid-body inertia reduced to the
    /// output, and preloaded with the set's balancing torque; with the
    /// index of the output's rotation.
    fn balance(&self, torques: [f64; 3], mass: &[f64], rigid: &[f64]) -> Option<(usize, SpeedDrive)> {
        let set = self.set;
        let (true, Some(o)) = (set.load_balance(), self.u(set.output())) else { return None };
        let out_lever = lever(set, set.output());
        let r_out = rigid[o];
        let inertia: f64 = if r_out != 0.0 {
            mass.iter().zip(rigid).map(|(m, r)| m * (r / r_out) * (r / r_out)).sum()
        } else {
            mass[o]
        };
        let w = 2.0 * std::f64::consts::PI * BALANCE_FREQUENCY;
        let k = inertia * w * w;
        let output_torque = torque_of(torques, set.output());
        Some((
            o,
            SpeedDrive {
                index: o,
                lever: out_lever,
                rate: r_out,
                stiffness: k,
                damping: 2.0 * BALANCE_DAMPING * inertia * w,
                speed: 0.0,
                offset: output_torque / out_lever / k,
                preload: output_torque / out_lever,
            },
        ))
    }
}

/// The support damping of Rayleigh's model, η K_b + μ M_v with
/// M_v = M − M r rᵀ M / (rᵀ M r) (module docs): `mass` the diagonal of M
/// \[kg\], `rigid` the rigid-body velocity pattern r, `k_support` the supports'
/// stiffness K_b [N/m], `mu` \[1/s\] and `eta` \[s\] the coefficients.
fn rayleigh_support_damping(
    mass: &[f64],
    rigid: &[f64],
    k_support: &DMatrix<f64>,
    mu: f64,
    eta: f64,
) -> DMatrix<f64> {
    let mut c = k_support * eta;
    let mr: Vec<f64> = mass.iter().zip(rigid).map(|(m, r)| m * r).collect();
    let rmr: f64 = mr.iter().zip(rigid).map(|(a, r)| a * r).sum();
    for (i, m) in mass.iter().enumerate() {
        c[(i, i)] += mu * m;
    }
    // A model without a rigid-body motion (all velocities zero at unit
    // input speed cannot happen for a valid set) would keep μM whole.
    if rmr > 0.0 {
        for (i, a) in mr.iter().enumerate() {
            for (j, b) in mr.iter().enumerate() {
                c[(i, j)] -= mu * a * b / rmr;
            }
        }
    }
    c
}

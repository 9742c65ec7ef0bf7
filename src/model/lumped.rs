//! The lumped-parameter planetary model in Lin & Parker's coordinates
//! (Lin & Parker 1999, J. Vib. Acoust. 121:316; docs/FORMULAS.md).
//!
//! Full coordinates, carrier frame: for each central member j ∈ {carrier,
//! ring, sun} the translations x_j, y_j and the rotation u_j = r_j θ_j
//! (r = base radius for sun and ring, the centre distance for the carrier);
//! for each planet n its radial ζ_n, tangential η_n and rotation u_n = r_b,p θ_n.
//! Mesh deflections along the lines of action:
//!
//! - δ_sn = −x_s sin ψ_sn + y_s cos ψ_sn − ζ_n sin α_s − η_n cos α_s + u_s + u_n, ψ_sn = ψ_n − α_s
//! - δ_rn = −x_r sin ψ_rn + y_r cos ψ_rn + ζ_n sin α_r − η_n cos α_r + u_r − u_n, ψ_rn = ψ_n + α_r
//!
//! planet bearing deflections: radial ζ_n − (x_c cos ψ_n + y_c sin ψ_n),
//! tangential η_n − (−x_c sin ψ_n + y_c cos ψ_n) − u_c. A fidelity level is a
//! linear map from reduced to full coordinates, q_full = T q: the
//! transverse–torsional level keeps every coordinate; the torsional level
//! keeps the rotations with the planets pinned to the carrier (ζ_n = 0,
//! η_n = u_c). A held member's rotation is removed. Reduced matrices are
//! Tᵀ M T, Tᵀ K T, and reduced mesh vectors Tᵀ b: one formulation serves both
//! fidelities. The gyroscopic and centripetal terms of a turning carrier are
//! in [`crate::model::carrier_frame`].

use serde::{Deserialize, Serialize};

pub use crate::scene::Fidelity;

use crate::model::gear::Member;
use crate::scene::units::{rad_to_deg, DEG};

/// The constants of a linear (mean-stiffness) lumped planetary model.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LumpedSet {
    /// Masses of carrier, ring, sun \[kg\].
    pub central_mass: [f64; 3],
    /// Rotational masses I/r² of carrier, ring, sun \[kg\].
    pub central_rotational_mass: [f64; 3],
    /// Planet mass \[kg\].
    pub planet_mass: f64,
    /// Planet rotational mass I/r_b² \[kg\].
    pub planet_rotational_mass: f64,
    /// Bearing stiffness of carrier, ring, sun per translation direction [N/m].
    pub central_bearing: [f64; 3],
    /// Torsional support stiffness of carrier, ring, sun, as k_u on u [N/m]
    /// (0 = free; a held member is removed instead).
    pub central_torsional: [f64; 3],
    /// Planet bearing stiffness, radial and tangential [N/m].
    pub planet_bearing: f64,
    /// Per-planet bearing stiffnesses [N/m]; empty means `planet_bearing` for all.
    #[serde(default)]
    pub planet_bearings: Vec<f64>,
    /// Sun–planet mesh stiffness (mean) [N/m].
    pub sun_mesh: f64,
    /// Ring–planet mesh stiffness (mean) [N/m].
    pub ring_mesh: f64,
    /// Sun–planet pressure angle α_s \[rad\].
    pub sun_pressure_angle: f64,
    /// Ring–planet pressure angle α_r \[rad\].
    pub ring_pressure_angle: f64,
    /// Planet angles ψ_n \[rad\].
    pub planet_angles: Vec<f64>,
    /// The held member, if any (its rotation removed).
    pub held: Option<Member>,
    /// Degrees of freedom.
    pub fidelity: Fidelity,
}

/// Index of a central member in the full coordinate vector's blocks.
pub fn central_index(m: Member) -> usize {
    match m {
        Member::Carrier => 0,
        Member::Ring => 1,
        Member::Sun => 2,
    }
}

/// What a reduced coordinate is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Coordinate {
    /// Translation x of a central member.
    X(Member),
    /// Translation y of a central member.
    Y(Member),
    /// Rotation u of a central member.
    U(Member),
    /// Radial translation ζ of planet n.
    Zeta(usize),
    /// Tangential translation η of planet n.
    Eta(usize),
    /// Rotation u of planet n.
    PlanetU(usize),
}

/// The reduction of a fidelity level: full = T·reduced.
#[derive(Clone, Debug, PartialEq)]
pub struct Reduction {
    /// Number of full coordinates, 9 + 3n.
    pub full: usize,
    /// Meaning of each reduced coordinate.
    pub coordinates: Vec<Coordinate>,
    /// T, full × reduced, column-major rows: `t[full_index]` lists (reduced index, factor).
    pub t: Vec<Vec<(usize, f64)>>,
}

/// Index of a coordinate in the full vector.
pub fn full_index(c: Coordinate) -> usize {
    match c {
        Coordinate::X(m) => 3 * central_index(m),
        Coordinate::Y(m) => 3 * central_index(m) + 1,
        Coordinate::U(m) => 3 * central_index(m) + 2,
        Coordinate::Zeta(n) => 9 + 3 * n,
        Coordinate::Eta(n) => 9 + 3 * n + 1,
        Coordinate::PlanetU(n) => 9 + 3 * n + 2,
    }
}

impl Reduction {
    /// The reduction for a number of planets, fidelity and held member.
    pub fn new(planets: usize, fidelity: Fidelity, held: Option<Member>) -> Self {
        let full = 9 + 3 * planets;
        let mut coordinates = Vec::new();
        let members = [Member::Carrier, Member::Ring, Member::Sun];
        for m in members {
            if fidelity == Fidelity::TransverseTorsional {
                coordinates.push(Coordinate::X(m));
                coordinates.push(Coordinate::Y(m));
            }
            if held != Some(m) {
                coordinates.push(Coordinate::U(m));
            }
        }
        for n in 0..planets {
            if fidelity == Fidelity::TransverseTorsional {
                coordinates.push(Coordinate::Zeta(n));
                coordinates.push(Coordinate::Eta(n));
            }
            coordinates.push(Coordinate::PlanetU(n));
        }
        let mut t = vec![Vec::new(); full];
        for (i, c) in coordinates.iter().enumerate() {
            t[full_index(*c)].push((i, 1.0));
        }
        if fidelity == Fidelity::Torsional {
            // Planets pinned to the carrier: η_n = u_c (0 when the carrier is held).
            if let Some(ic) = coordinates.iter().position(|c| *c == Coordinate::U(Member::Carrier)) {
                for n in 0..planets {
                    t[full_index(Coordinate::Eta(n))].push((ic, 1.0));
                }
            }
        }
        Self { full, coordinates, t }
    }

    /// Number of reduced coordinates.
    pub fn dim(&self) -> usize {
        self.coordinates.len()
    }

    /// Reduced vector Tᵀ·b of a full vector b.
    pub fn reduce_vector(&self, b: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; self.dim()];
        for (row, entries) in self.t.iter().enumerate() {
            for (col, f) in entries {
                out[*col] += f * b[row];
            }
        }
        out
    }

    /// Reduced diagonal matrix Tᵀ·diag(d)·T; diagonal because every full
    /// coordinate maps to at most one reduced coordinate.
    pub fn reduce_diagonal(&self, d: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; self.dim()];
        for (row, entries) in self.t.iter().enumerate() {
            for (col, f) in entries {
                out[*col] += f * f * d[row];
            }
        }
        out
    }

    /// Index of a coordinate among the reduced ones.
    pub fn position(&self, c: Coordinate) -> Option<usize> {
        self.coordinates.iter().position(|x| *x == c)
    }
}

/// Full-coordinate vector b of the sun–planet mesh of planet `n`: δ_sn = bᵀq.
pub fn sun_mesh_vector(planets: usize, n: usize, psi: f64, alpha_s: f64) -> Vec<f64> {
    let mut b = vec![0.0; 9 + 3 * planets];
    let psi_sn = psi - alpha_s;
    b[full_index(Coordinate::X(Member::Sun))] = -psi_sn.sin();
    b[full_index(Coordinate::Y(Member::Sun))] = psi_sn.cos();
    b[full_index(Coordinate::U(Member::Sun))] = 1.0;
    b[full_index(Coordinate::Zeta(n))] = -alpha_s.sin();
    b[full_index(Coordinate::Eta(n))] = -alpha_s.cos();
    b[full_index(Coordinate::PlanetU(n))] = 1.0;
    b
}

/// Full-coordinate vector b of the ring–planet mesh of planet `n`: δ_rn = bᵀq.
pub fn ring_mesh_vector(planets: usize, n: usize, psi: f64, alpha_r: f64) -> Vec<f64> {
    let mut b = vec![0.0; 9 + 3 * planets];
    let psi_rn = psi + alpha_r;
    b[full_index(Coordinate::X(Member::Ring))] = -psi_rn.sin();
    b[full_index(Coordinate::Y(Member::Ring))] = psi_rn.cos();
    b[full_index(Coordinate::U(Member::Ring))] = 1.0;
    b[full_index(Coordinate::Zeta(n))] = alpha_r.sin();
    b[full_index(Coordinate::Eta(n))] = -alpha_r.cos();
    b[full_index(Coordinate::PlanetU(n))] = -1.0;
    b
}

/// Full-coordinate vectors of the radial and tangential planet-bearing
/// deflections of planet `n`.
pub fn planet_bearing_vectors(planets: usize, n: usize, psi: f64) -> [Vec<f64>; 2] {
    let mut radial = vec![0.0; 9 + 3 * planets];
    radial[full_index(Coordinate::Zeta(n))] = 1.0;
    radial[full_index(Coordinate::X(Member::Carrier))] = -psi.cos();
    radial[full_index(Coordinate::Y(Member::Carrier))] = -psi.sin();
    let mut tangential = vec![0.0; 9 + 3 * planets];
    tangential[full_index(Coordinate::Eta(n))] = 1.0;
    tangential[full_index(Coordinate::X(Member::Carrier))] = psi.sin();
    tangential[full_index(Coordinate::Y(Member::Carrier))] = -psi.cos();
    tangential[full_index(Coordinate::U(Member::Carrier))] = -1.0;
    [radial, tangential]
}

/// Adds k·b·bᵀ (b reduced, dense) into a dense column-major n×n matrix.
pub fn add_outer(k: &mut nalgebra::DMatrix<f64>, b: &[f64], factor: f64) {
    for (i, bi) in b.iter().enumerate() {
        if *bi == 0.0 {
            continue;
        }
        for (j, bj) in b.iter().enumerate() {
            if *bj != 0.0 {
                k[(i, j)] += factor * bi * bj;
            }
        }
    }
}

impl LumpedSet {
    /// The reduction of this set.
    pub fn reduction(&self) -> Reduction {
        Reduction::new(self.planet_angles.len(), self.fidelity, self.held)
    }

    /// Bearing stiffness of planet `p` [N/m].
    pub fn planet_bearing_of(&self, p: usize) -> f64 {
        self.planet_bearings.get(p).copied().unwrap_or(self.planet_bearing)
    }

    /// Diagonal of the full mass matrix.
    pub fn full_mass(&self) -> Vec<f64> {
        let n = self.planet_angles.len();
        let mut m = vec![0.0; 9 + 3 * n];
        for j in 0..3 {
            m[3 * j] = self.central_mass[j];
            m[3 * j + 1] = self.central_mass[j];
            m[3 * j + 2] = self.central_rotational_mass[j];
        }
        for p in 0..n {
            m[9 + 3 * p] = self.planet_mass;
            m[9 + 3 * p + 1] = self.planet_mass;
            m[9 + 3 * p + 2] = self.planet_rotational_mass;
        }
        m
    }

    /// Reduced mass diagonal.
    pub fn mass(&self) -> Vec<f64> {
        self.reduction().reduce_diagonal(&self.full_mass())
    }

    /// Reduced support (bearing) stiffness matrix, dense.
    pub fn support_stiffness(&self) -> nalgebra::DMatrix<f64> {
        let red = self.reduction();
        let n = self.planet_angles.len();
        let mut k = nalgebra::DMatrix::zeros(red.dim(), red.dim());
        let members = [Member::Carrier, Member::Ring, Member::Sun];
        for (j, m) in members.iter().enumerate() {
            for (c, kk) in [
                (Coordinate::X(*m), self.central_bearing[j]),
                (Coordinate::Y(*m), self.central_bearing[j]),
                (Coordinate::U(*m), self.central_torsional[j]),
            ] {
                if let Some(i) = red.position(c) {
                    k[(i, i)] += kk;
                }
            }
        }
        for (p, psi) in self.planet_angles.iter().enumerate() {
            for b in planet_bearing_vectors(n, p, *psi) {
                add_outer(&mut k, &red.reduce_vector(&b), self.planet_bearing_of(p));
            }
        }
        k
    }

    /// Reduced mesh vectors: (sun mesh, ring mesh) of every planet.
    pub fn mesh_vectors(&self) -> Vec<(Vec<f64>, Vec<f64>)> {
        let red = self.reduction();
        let n = self.planet_angles.len();
        self.planet_angles
            .iter()
            .enumerate()
            .map(|(p, psi)| {
                (
                    red.reduce_vector(&sun_mesh_vector(n, p, *psi, self.sun_pressure_angle)),
                    red.reduce_vector(&ring_mesh_vector(n, p, *psi, self.ring_pressure_angle)),
                )
            })
            .collect()
    }

    /// Reduced linear stiffness matrix with the mean mesh stiffnesses.
    pub fn stiffness(&self) -> nalgebra::DMatrix<f64> {
        let mut k = self.support_stiffness();
        for (bs, br) in self.mesh_vectors() {
            add_outer(&mut k, &bs, self.sun_mesh);
            add_outer(&mut k, &br, self.ring_mesh);
        }
        k
    }
}

impl crate::scene::lumped::LumpedScene {
    /// Validates into the linear model.
    pub fn validate(&self) -> Result<LumpedSet, crate::scene::SceneError> {
        let l = &self.lumped;
        let mut problems = Vec::new();
        let mut positive = |name: &str, v: f64, zero_ok: bool| {
            let ok = v.is_finite() && (v > 0.0 || (zero_ok && v == 0.0));
            if !ok {
                problems.push(crate::scene::Problem {
                    name: name.into(),
                    value: v.to_string(),
                    reason: if zero_ok {
                        "must be zero or a finite positive number"
                    } else {
                        "must be a finite number greater than zero"
                    }
                    .into(),
                });
            }
        };
        for (key, c) in [("carrier", &l.carrier), ("ring", &l.ring), ("sun", &l.sun)] {
            positive(&format!("lumped.{key}.mass_kg"), c.mass_kg, false);
            positive(&format!("lumped.{key}.rotational_mass_kg"), c.rotational_mass_kg, false);
            positive(&format!("lumped.{key}.bearing_n_per_m"), c.bearing_n_per_m, true);
            positive(&format!("lumped.{key}.torsional_n_per_m"), c.torsional_n_per_m, true);
        }
        positive("lumped.planet.mass_kg", l.planet.mass_kg, false);
        positive("lumped.planet.rotational_mass_kg", l.planet.rotational_mass_kg, false);
        positive("lumped.planet.bearing_n_per_m", l.planet.bearing_n_per_m, false);
        positive("lumped.sun_mesh_n_per_m", l.sun_mesh_n_per_m, false);
        positive("lumped.ring_mesh_n_per_m", l.ring_mesh_n_per_m, false);
        for (name, a) in [
            ("lumped.sun_pressure_angle_deg", rad_to_deg(l.sun_pressure_angle)),
            ("lumped.ring_pressure_angle_deg", rad_to_deg(l.ring_pressure_angle)),
        ] {
            if !(a.is_finite() && a > 0.0 && a < 45.0) {
                problems.push(crate::scene::Problem {
                    name: name.into(),
                    value: a.to_string(),
                    reason: "must lie strictly between 0 and 45".into(),
                });
            }
        }
        let n = l.planet.count;
        let angles: Vec<f64> = match &l.planet.angles {
            None => (0..n).map(|i| 2.0 * std::f64::consts::PI * f64::from(i) / f64::from(n.max(1))).collect(),
            Some(a) => a.clone(),
        };
        if !(1..=32).contains(&n) {
            problems.push(crate::scene::Problem {
                name: "lumped.planet.count".into(),
                value: n.to_string(),
                reason: "must be between 1 and 32".into(),
            });
        } else if angles.len() != n as usize || angles.iter().any(|a| !a.is_finite()) {
            problems.push(crate::scene::Problem {
                name: "lumped.planet.angles_deg".into(),
                value: format!("{:?}", DEG.written(&l.planet.angles)),
                reason: format!("must list exactly lumped.planet.count = {n} finite angles"),
            });
        }
        if !problems.is_empty() {
            return Err(crate::scene::SceneError::Invalid { problems });
        }
        Ok(LumpedSet {
            central_mass: [l.carrier.mass_kg, l.ring.mass_kg, l.sun.mass_kg],
            central_rotational_mass: [
                l.carrier.rotational_mass_kg,
                l.ring.rotational_mass_kg,
                l.sun.rotational_mass_kg,
            ],
            planet_mass: l.planet.mass_kg,
            planet_rotational_mass: l.planet.rotational_mass_kg,
            central_bearing: [l.carrier.bearing_n_per_m, l.ring.bearing_n_per_m, l.sun.bearing_n_per_m],
            central_torsional: [
                l.carrier.torsional_n_per_m,
                l.ring.torsional_n_per_m,
                l.sun.torsional_n_per_m,
            ],
            planet_bearing: l.planet.bearing_n_per_m,
            planet_bearings: Vec::new(),
            sun_mesh: l.sun_mesh_n_per_m,
            ring_mesh: l.ring_mesh_n_per_m,
            sun_pressure_angle: l.sun_pressure_angle,
            ring_pressure_angle: l.ring_pressure_angle,
            planet_angles: angles,
            held: l.held,
            fidelity: l.fidelity,
        })
    }
}

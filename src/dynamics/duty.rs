//! The load duty a run produced: for each mesh, the input revolutions spent
//! in each bin of load torque × input speed (a load-duration distribution in
//! the sense of ISO 6336-6, kept per mesh so that unequal load sharing
//! between the planets shows).
//!
//! A mesh's load torque is its mean mesh force over a communication step
//! times the input torque one newton of each planet's mesh force balances
//! ([`input_torque_per_mesh_force`]): under equal load sharing and at
//! steady speed every mesh's torque is the input torque. The speed is the
//! input member's mean speed over the step, the revolutions its angle turned
//! in the step over 2π (the input revolutions the wear stepper counts).
//!
//! Bins are half-open, `[e_k, e_{k+1})`, the last closed: a value on the
//! last edge is in the last bin. Revolutions outside every bin are kept per
//! mesh ([`LoadDuty::outside`]), so the bins and the outside add up to every
//! revolution recorded.

use serde::{Deserialize, Serialize};

use crate::model::gear::{GearSet, MeshKind};

/// Most edges of either axis (1000 bins).
pub const MAX_EDGES: usize = 1001;
/// Bins of each axis of [`DutyBins::around`].
pub const DEFAULT_BINS: usize = 11;
/// Most bins (torque bins × speed bins) per mesh.
pub const MAX_BINS: usize = 10_000;

/// Why bins or a record were refused.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum DutyError {
    /// The bin edges of an axis are not usable.
    #[error("{name} = {value}: {allowed}")]
    Edges {
        /// The axis: `torque_edges` or `speed_edges`.
        name: &'static str,
        /// The edges given.
        value: String,
        /// What is allowed.
        allowed: String,
    },
    /// A recorded value is not finite, or revolutions or duration negative.
    #[error("load duty record: {name} = {value} ({allowed})")]
    Record {
        /// The value's name.
        name: &'static str,
        /// The value.
        value: f64,
        /// What is allowed.
        allowed: &'static str,
    },
    /// Two duties with different bins or meshes cannot be added.
    #[error("load duties with different {0} cannot be added")]
    Mismatch(&'static str),
    /// A duty read back whose counts do not fit its bins and planets.
    #[error("{planets} planets need {revolutions} revolutions and {outside} outside values, found {found_revolutions} and {found_outside}")]
    Sizes {
        /// Planets of the duty.
        planets: usize,
        /// Revolutions the bins need.
        revolutions: usize,
        /// Outside values the meshes need.
        outside: usize,
        /// Revolutions found.
        found_revolutions: usize,
        /// Outside values found.
        found_outside: usize,
    },
    /// A duty read back with a negative or non-finite count.
    #[error("a count of {0}: revolutions and time are finite and non-negative")]
    Count(f64),
    /// A mesh whose bins and outside do not add up to the duty's total.
    #[error("mesh {mesh} has {sum} revolutions in its bins and outside, the duty {total}")]
    Unbalanced {
        /// The mesh, 1-based.
        mesh: usize,
        /// Its bins and outside.
        sum: f64,
        /// The duty's total.
        total: f64,
    },
}

/// The bin edges: load torque \[N·m\] × input speed \[rad/s\].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DutyBins {
    torque: Vec<f64>,
    speed: Vec<f64>,
}

/// The edges of a comma-separated list (`"0, 150, 300"`), checked as [`check_edges`] does;
/// `name` names the list in the message.
pub fn parse_edges(name: &'static str, text: &str) -> Result<Vec<f64>, DutyError> {
    let fail = |allowed: String| DutyError::Edges { name, value: format!("\"{text}\""), allowed };
    let edges = text
        .split(',')
        .map(|p| {
            p.trim()
                .parse::<f64>()
                .map_err(|_| fail(format!("comma-separated numbers (\"{}\" is not one)", p.trim())))
        })
        .collect::<Result<Vec<f64>, DutyError>>()?;
    check_edges(name, &edges)?;
    Ok(edges)
}

/// Checks one axis's edges (`name` in the message): from 2 to [`MAX_EDGES`] finite, strictly
/// increasing values.
pub fn check_edges(name: &'static str, edges: &[f64]) -> Result<(), DutyError> {
    let fail = |allowed: String| DutyError::Edges { name, value: format!("{edges:?}"), allowed };
    if edges.len() < 2 || edges.len() > MAX_EDGES {
        return Err(fail(format!("from 2 to {MAX_EDGES} edges (1 to {} bins)", MAX_EDGES - 1)));
    }
    if let Some(bad) = edges.iter().find(|e| !e.is_finite()) {
        return Err(fail(format!("finite numbers only ({bad} is not)")));
    }
    if let Some(w) = edges.windows(2).find(|w| w[1] <= w[0]) {
        return Err(fail(format!("strictly increasing edges ({} is followed by {})", w[0], w[1])));
    }
    Ok(())
}

/// The bin of `x` among `edges` (half-open bins, the last closed).
fn bin_of(edges: &[f64], x: f64) -> Option<usize> {
    let last = edges.len() - 1;
    if !(x >= edges[0] && x <= edges[last]) {
        return None;
    }
    Some(edges.partition_point(|e| *e <= x).saturating_sub(1).min(last - 1))
}

impl DutyBins {
    /// Bins with torque edges `torque` \[N·m\] and speed edges `speed` \[rad/s\]: each from 2 to
    /// [`MAX_EDGES`] finite, strictly increasing values.
    pub fn new(torque: Vec<f64>, speed: Vec<f64>) -> Result<Self, DutyError> {
        check_edges("torque_edges", &torque)?;
        check_edges("speed_edges", &speed)?;
        let bins = (torque.len() - 1) * (speed.len() - 1);
        if bins > MAX_BINS {
            return Err(DutyError::Edges {
                name: "speed_edges",
                value: format!("{} edges with {} torque edges", speed.len(), torque.len()),
                allowed: format!("at most {MAX_BINS} bins in all ({bins} asked)"),
            });
        }
        Ok(Self { torque, speed })
    }

    /// The default bins around an operating point: 0 to twice `torque` \[N·m\] and 0 to twice
    /// `speed` \[rad/s\] (their magnitudes; 1 where one is 0 or not finite), in
    /// [`DEFAULT_BINS`] bins each, an odd number so that the point lies mid-bin, not on an edge.
    pub fn around(torque: f64, speed: f64) -> Self {
        let axis = |x: f64| {
            let top = if x.is_finite() && x != 0.0 { 2.0 * x.abs() } else { 2.0 };
            (0..=DEFAULT_BINS).map(|k| top * k as f64 / DEFAULT_BINS as f64).collect()
        };
        Self { torque: axis(torque), speed: axis(speed) }
    }

    /// The torque edges \[N·m\].
    pub fn torque_edges(&self) -> &[f64] {
        &self.torque
    }

    /// The speed edges \[rad/s\].
    pub fn speed_edges(&self) -> &[f64] {
        &self.speed
    }

    /// Torque bins × speed bins.
    pub fn shape(&self) -> (usize, usize) {
        (self.torque.len() - 1, self.speed.len() - 1)
    }

    /// The (torque, speed) bin of a load torque and speed; `None` outside.
    pub fn bin(&self, torque: f64, speed: f64) -> Option<(usize, usize)> {
        Some((bin_of(&self.torque, torque)?, bin_of(&self.speed, speed)?))
    }

    /// Whether `self` can be checked again after a round trip: the edges re-validated.
    pub fn check(&self) -> Result<(), DutyError> {
        Self::new(self.torque.clone(), self.speed.clone()).map(|_| ())
    }
}

/// The input torque \[N·m\] that one newton of mesh force on every planet balances:
/// n r_b of the input member's lever ([`GearSet::input_lever`]).
pub fn input_torque_per_mesh_force(set: &GearSet) -> f64 {
    set.planet_angles().len() as f64 * set.input_lever()
}

/// The input revolutions each mesh spent in each bin (module documentation).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LoadDuty {
    bins: DutyBins,
    planets: usize,
    /// Per mesh (planet-major: planet 1's sun–planet, its ring–planet, planet 2's, …), torque
    /// bin-major, speed bins within: input revolutions.
    revolutions: Vec<f64>,
    /// Per mesh: input revolutions outside every bin.
    outside: Vec<f64>,
    /// Input revolutions recorded (every mesh saw them all).
    total: f64,
    /// Time recorded \[s\].
    duration: f64,
}

impl LoadDuty {
    /// An empty duty of `planets` planets' meshes on `bins`.
    pub fn new(bins: DutyBins, planets: usize) -> Self {
        let (nt, ns) = bins.shape();
        let meshes = 2 * planets;
        Self {
            bins,
            planets,
            revolutions: vec![0.0; meshes * nt * ns],
            outside: vec![0.0; meshes],
            total: 0.0,
            duration: 0.0,
        }
    }

    fn mesh_index(&self, p: usize, kind: MeshKind) -> Option<usize> {
        (p < self.planets).then_some(kind.of_planet(p))
    }

    /// Records a step of `duration` \[s\] in which the input turned `revolutions` at mean
    /// speed `speed` \[rad/s\] with the meshes' load torques `torques` \[N·m\] (planet-major,
    /// sun then ring). Refuses non-finite values and negative revolutions or duration (nothing
    /// is recorded then).
    pub fn record(
        &mut self,
        torques: &[f64],
        speed: f64,
        revolutions: f64,
        duration: f64,
    ) -> Result<(), DutyError> {
        let record = |name, value: f64, allowed| DutyError::Record { name, value, allowed };
        if !(revolutions.is_finite() && revolutions >= 0.0) {
            return Err(record("revolutions", revolutions, "finite and non-negative"));
        }
        if !(duration.is_finite() && duration >= 0.0) {
            return Err(record("duration", duration, "finite and non-negative"));
        }
        if !speed.is_finite() {
            return Err(record("speed", speed, "finite"));
        }
        if let Some(t) = torques.iter().find(|t| !t.is_finite()) {
            return Err(record("mesh torque", *t, "finite"));
        }
        if torques.len() != 2 * self.planets {
            return Err(DutyError::Mismatch("numbers of meshes"));
        }
        let (nt, ns) = self.bins.shape();
        for (m, &t) in torques.iter().enumerate() {
            match self.bins.bin(t, speed) {
                Some((i, j)) => self.revolutions[(m * nt + i) * ns + j] += revolutions,
                None => self.outside[m] += revolutions,
            }
        }
        self.total += revolutions;
        self.duration += duration;
        Ok(())
    }

    /// The counts as one array (revolutions, outside, total, time), as a serialized state
    /// keeps them.
    pub fn counts(&self) -> Vec<f64> {
        let mut c = self.revolutions.clone();
        c.extend_from_slice(&self.outside);
        c.extend([self.total, self.duration]);
        c
    }

    /// Sets the counts from [`Self::counts`]' array of a duty on the same bins and planets;
    /// an empty array clears them. Refuses another length or a count that is not finite and
    /// non-negative (nothing changes then).
    pub fn set_counts(&mut self, counts: &[f64]) -> Result<(), DutyError> {
        let (r, o) = (self.revolutions.len(), self.outside.len());
        if counts.is_empty() {
            self.revolutions.fill(0.0);
            self.outside.fill(0.0);
            (self.total, self.duration) = (0.0, 0.0);
            return Ok(());
        }
        if counts.len() != r + o + 2 {
            return Err(DutyError::Mismatch("numbers of counts"));
        }
        if let Some(x) = counts.iter().find(|x| !(x.is_finite() && **x >= 0.0)) {
            return Err(DutyError::Record { name: "count", value: *x, allowed: "finite and non-negative" });
        }
        self.revolutions.copy_from_slice(&counts[..r]);
        self.outside.copy_from_slice(&counts[r..r + o]);
        (self.total, self.duration) = (counts[r + o], counts[r + o + 1]);
        Ok(())
    }

    /// Adds `other`'s revolutions and time (the same bins and planets).
    pub fn add(&mut self, other: &LoadDuty) -> Result<(), DutyError> {
        if other.bins != self.bins {
            return Err(DutyError::Mismatch("bins"));
        }
        if other.planets != self.planets {
            return Err(DutyError::Mismatch("numbers of planets"));
        }
        for (a, b) in self.revolutions.iter_mut().zip(&other.revolutions) {
            *a += b;
        }
        for (a, b) in self.outside.iter_mut().zip(&other.outside) {
            *a += b;
        }
        self.total += other.total;
        self.duration += other.duration;
        Ok(())
    }

    /// The bins.
    pub fn bins(&self) -> &DutyBins {
        &self.bins
    }

    /// Number of planets.
    pub fn planets(&self) -> usize {
        self.planets
    }

    /// Planet `p`'s (0-based) mesh of kind `kind`: input revolutions per bin, torque bin-major
    /// ([`DutyBins::shape`]); `None` beyond the planets.
    pub fn mesh(&self, p: usize, kind: MeshKind) -> Option<&[f64]> {
        let m = self.mesh_index(p, kind)?;
        let (nt, ns) = self.bins.shape();
        Some(&self.revolutions[m * nt * ns..(m + 1) * nt * ns])
    }

    /// Planet `p`'s mesh of kind `kind`: input revolutions outside every bin.
    pub fn outside(&self, p: usize, kind: MeshKind) -> Option<f64> {
        Some(self.outside[self.mesh_index(p, kind)?])
    }

    /// Input revolutions recorded.
    pub fn total_revolutions(&self) -> f64 {
        self.total
    }

    /// Time recorded \[s\].
    pub fn duration(&self) -> f64 {
        self.duration
    }

    /// Checks a duty read back: bins, sizes, finite non-negative counts, and each mesh's bins
    /// and outside adding up to the total (to a relative 1e-9).
    pub fn check(&self) -> Result<(), DutyError> {
        self.bins.check()?;
        let (nt, ns) = self.bins.shape();
        let meshes = 2 * self.planets;
        if self.planets == 0 || self.revolutions.len() != meshes * nt * ns || self.outside.len() != meshes {
            return Err(DutyError::Sizes {
                planets: self.planets,
                revolutions: meshes * nt * ns,
                outside: meshes,
                found_revolutions: self.revolutions.len(),
                found_outside: self.outside.len(),
            });
        }
        let values = self.revolutions.iter().chain(&self.outside).chain([&self.total, &self.duration]);
        if let Some(v) = values.into_iter().find(|v| !(v.is_finite() && **v >= 0.0)) {
            return Err(DutyError::Count(*v));
        }
        for m in 0..meshes {
            let sum: f64 =
                self.revolutions[m * nt * ns..(m + 1) * nt * ns].iter().sum::<f64>() + self.outside[m];
            if (sum - self.total).abs() > 1e-9 * self.total.max(1.0) {
                return Err(DutyError::Unbalanced { mesh: m + 1, sum, total: self.total });
            }
        }
        Ok(())
    }
}

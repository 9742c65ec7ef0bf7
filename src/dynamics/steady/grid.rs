//! The cache of steady states on a grid of input speed and input torque, and the
//! interpolation between its nodes (docs/STEADY.md, "The cache").
//!
//! Nodes lie at speed ±(ω_floor + i Δω / 2^L) and torque j ΔT / 2^L (i ≥ 0, j signed, L
//! the refinements). A request is interpolated bilinearly in the coarsest cell whose error,
//! estimated at its centre and at the midpoint of its edge nearest the request (nodes: the
//! corners' mean, or the edge's two corners' mean, against the node's own state, each
//! mesh's largest, smallest and mean force and planet 1's F^(rms) over the node's static
//! mesh load, each mesh's separation fraction), is at most the agreement. A cell whose
//! estimate is larger is halved, down to L times; the finest cell takes a quarter of its
//! parent's estimate, and a request whose estimate is still larger is counted as
//! unresolved. Cells on the unloaded row (the low-load strip) and cells with a node whose
//! march did not settle are interpolated without an estimate and counted apart.

use std::collections::{BTreeMap, HashMap};
use std::sync::Arc;

use crate::dynamics::equations::PlanetaryDynamics;
use crate::dynamics::periodic::PeriodicError;
use crate::dynamics::spectrum::Harmonics;
use crate::dynamics::steady::point::{Found, MeshSummary, SteadyPoint, TorqueLevel, MARCH_SETTLED};
use crate::model::run::SteadyValues;

/// A node: the speed's sign, its finest-grid speed index, its finest-grid torque index.
type Node = (i8, i64, i64);

/// An interpolated steady state: the corners and their weights.
#[derive(Clone, Debug)]
pub struct Blend {
    /// Corner points and their bilinear weights (weights sum to 1).
    pub corners: Vec<(Arc<SteadyPoint>, f64)>,
    /// Input speed [rad/s] and input torque [N·m] asked for.
    pub speed: f64,
    /// See `speed`.
    pub torque: f64,
    /// Refinement level of the cell interpolated in (0 the coarsest).
    pub level: u32,
    /// The interpolation's estimated error: the largest difference, normalised by the
    /// static mesh load, between the cell's centre node and its corners' mean, or the
    /// midpoint node of the edge nearest the request and that edge's corners' mean [-]
    /// (at the finest level, a quarter of the parent cell's); NaN
    /// where there is no estimate (a low-load or unsettled cell).
    pub estimate: f64,
}

impl Blend {
    /// The interpolated summary of mesh `k`.
    pub fn mesh(&self, k: usize) -> MeshSummary {
        let mut m = MeshSummary { min: 0.0, ..MeshSummary::default() };
        for (p, w) in &self.corners {
            let c = p.meshes[k];
            m.min += w * c.min;
            m.max += w * c.max;
            m.mean += w * c.mean;
            m.peak_pair += w * c.peak_pair;
            m.separation += w * c.separation;
        }
        m
    }

    /// The interpolated harmonics and separation fraction of planet 1's mesh `k` (0 sun, 1 ring).
    pub fn window(&self, k: usize) -> (Harmonics, f64) {
        let mut h = Harmonics { mean: 0.0, amplitude: vec![0.0; 6], rms: 0.0 };
        let mut separation = 0.0;
        for (p, w) in &self.corners {
            let (c, s) = &p.window[k];
            h.mean += w * c.mean;
            h.rms += w * c.rms;
            for (a, b) in h.amplitude.iter_mut().zip(&c.amplitude) {
                *a += w * b;
            }
            separation += w * s;
        }
        (h, separation)
    }

    /// The interpolated state relative to the rigid-body motion at input angle `angle`
    /// \[rad\] into `q` and `v` (each corner read at its own phase, linearly between samples).
    pub fn relative_state(&self, angle: f64, q: &mut [f64], v: &mut [f64]) {
        let n = q.len();
        q.iter_mut().chain(v.iter_mut()).for_each(|x| *x = 0.0);
        for (p, w) in &self.corners {
            let phase = ((angle / p.angle_period).rem_euclid(1.0) * p.samples as f64 - p.phase)
                .rem_euclid(p.samples as f64);
            let j0 = (phase.floor() as usize).min(p.samples - 1);
            let j1 = (j0 + 1) % p.samples;
            let f = phase - j0 as f64;
            for i in 0..n {
                let (q0, q1) = (f64::from(p.q[j0 * n + i]), f64::from(p.q[j1 * n + i]));
                let (v0, v1) = (f64::from(p.v[j0 * n + i]), f64::from(p.v[j1 * n + i]));
                q[i] += w * ((1.0 - f) * q0 + f * q1);
                v[i] += w * ((1.0 - f) * v0 + f * v1);
            }
        }
    }

    /// How many corners were found by each way.
    pub fn found(&self) -> impl Iterator<Item = Found> + '_ {
        self.corners.iter().map(|(p, _)| p.found)
    }
}

/// What the cache has done.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GridStats {
    /// Requests answered.
    pub requests: u64,
    /// Steady states solved (nodes).
    pub solved: u64,
    /// Interpolation errors estimated (at a cell's centre or an edge's midpoint); each is
    /// kept, so a request in a cell already read estimates none.
    pub estimated: u64,
    /// Of those, found by a march past a fold.
    pub marched: u64,
    /// Of those, found from the static state.
    pub cold: u64,
    /// Requests interpolated in a finest cell whose estimated error is above the agreement.
    pub unresolved: u64,
    /// Requests in a cell with a node whose march did not settle within its periods (no
    /// periodic steady state), interpolated without an error estimate.
    pub unsettled: u64,
    /// Requests in the low-load strip (a cell with a corner at no torque), interpolated
    /// without an error estimate.
    pub low_load: u64,
    /// The largest estimated error of an unresolved request [-].
    pub worst_estimate: f64,
    /// Nodes no way could solve, which took their torque row's nearest node
    /// ([`Found::Failed`]).
    pub failed: u64,
}

/// The cache of one model (one worn state): its nodes and torque levels.
pub struct SteadyGrid {
    settings: SteadyValues,
    base: PlanetaryDynamics,
    /// Balanced torques on sun, ring, carrier per N·m of input torque.
    torques_per_nm: [f64; 3],
    /// Static mesh force per N·m of input torque \[N/(N·m)\].
    load_per_nm: f64,
    samples_per_cycle: usize,
    /// Ordered, so that what is read from them does not depend on a hash seed.
    nodes: BTreeMap<Node, Arc<SteadyPoint>>,
    levels: HashMap<i64, TorqueLevel>,
    unloaded: HashMap<(i8, i64), Arc<SteadyPoint>>,
    /// The interpolation error estimated at a cell's centre or an edge's midpoint, by
    /// (sign, that node's speed and torque index, the cell's size): nodes are never
    /// replaced, so an estimate holds for every later request that reads it.
    estimates: HashMap<(i8, i64, i64, i64), f64>,
    stats: GridStats,
}

impl SteadyGrid {
    /// The cache of `base` (the simulation's model), its balanced torques
    /// `torques_per_nm` per N·m of input torque, its static mesh force `load_per_nm` per
    /// N·m, `samples_per_cycle` output samples per mesh cycle.
    pub fn new(
        settings: SteadyValues,
        base: PlanetaryDynamics,
        torques_per_nm: [f64; 3],
        load_per_nm: f64,
        samples_per_cycle: usize,
    ) -> Self {
        Self {
            settings,
            base,
            torques_per_nm,
            load_per_nm,
            samples_per_cycle,
            nodes: BTreeMap::new(),
            levels: HashMap::new(),
            unloaded: HashMap::new(),
            estimates: HashMap::new(),
            stats: GridStats::default(),
        }
    }

    /// The settings.
    pub fn settings(&self) -> &SteadyValues {
        &self.settings
    }

    /// What the cache has done so far.
    pub fn stats(&self) -> GridStats {
        self.stats
    }

    /// Nodes solved and kept.
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// Whether no node is kept.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    fn finest(&self) -> (f64, f64) {
        let scale = f64::from(1u32 << self.settings.refinements);
        (self.settings.speed_step / scale, self.settings.torque_step / scale)
    }

    fn speed_of(&self, (sign, i, _): Node) -> f64 {
        f64::from(sign) * (self.settings.speed_floor + i as f64 * self.finest().0)
    }

    /// The steady state at input speed `speed` [rad/s] and input torque `torque` [N·m],
    /// interpolated between cached nodes (solving the nodes it needs).
    pub fn lookup(&mut self, speed: f64, torque: f64) -> Result<Blend, PeriodicError> {
        for (name, x) in [("speed", speed), ("torque", torque)] {
            if !x.is_finite() {
                return Err(PeriodicError::invalid(name, x, "must be finite"));
            }
        }
        self.stats.requests += 1;
        let sign: i8 = if speed < 0.0 { -1 } else { 1 };
        let (ds, dt) = self.finest();
        let a = ((speed.abs() - self.settings.speed_floor) / ds).max(0.0);
        let b = torque / dt;
        let top = self.settings.refinements;
        let (mut parent, mut on_strip) = (f64::INFINITY, false);
        for level in 0..=top {
            let c = 1i64 << (top - level);
            let i0 = (a / c as f64).floor() as i64 * c;
            let j0 = (b / c as f64).floor() as i64 * c;
            let (wa, wb) = ((a - i0 as f64) / c as f64, (b - j0 as f64) / c as f64);
            // A cell on the unloaded row is halved down to the finest level: there (the
            // low-load strip between no torque and the first torque node, where the teeth
            // rattle) it is interpolated without an error estimate, and the request is
            // counted as a low-load one.
            let unloaded_row = j0 == 0 || j0 + c == 0;
            if unloaded_row && level < top {
                on_strip = true;
                continue;
            }
            // Without an estimate to make (the low-load strip; the finest level, which takes
            // its parent's), a corner of no weight is not needed, and not solved.
            let finest = level == top;
            let mut corners = Vec::with_capacity(4);
            for (di, dj, w) in [
                (0, 0, (1.0 - wa) * (1.0 - wb)),
                (c, 0, wa * (1.0 - wb)),
                (0, c, (1.0 - wa) * wb),
                (c, c, wa * wb),
            ] {
                if w > 0.0 || !finest {
                    corners.push((self.node((sign, i0 + di, j0 + dj))?, w));
                }
            }
            // The finest row above the strip has no coarser cell with an estimate (each
            // has a corner on the unloaded row): it is interpolated without one, as the
            // strip is.
            if unloaded_row || (finest && on_strip && parent.is_infinite()) {
                self.stats.low_load += 1;
                corners.retain(|(_, w)| *w > 0.0);
                return Ok(Blend { corners, speed, torque, level, estimate: f64::NAN });
            }
            // A cell with a corner whose march did not settle (no periodic steady state:
            // the teeth rattle) is not refined: its error cannot be estimated.
            if corners.iter().any(|(p, _)| p.settled > MARCH_SETTLED) {
                self.stats.unsettled += 1;
                corners.retain(|(_, w)| *w > 0.0);
                return Ok(Blend { corners, speed, torque, level, estimate: f64::NAN });
            }
            // The bilinear interpolation's error estimated at the cell's centre and at the
            // midpoint of the cell's edge nearest the request (on an edge the interpolation
            // is linear between that edge's corners alone, and a peak that moves with the
            // torque can be missed at the centre); the finest cell (no nodes inside) takes
            // a quarter of its parent's (the error of a bilinear interpolation goes with
            // the square of the cell).
            let error = if !finest {
                let at_centre = self.estimate((sign, i0 + c / 2, j0 + c / 2), c, &corners)?;
                let (ends, middle) = nearest_edge(wa, wb);
                let edge = [corners[ends[0]].clone(), corners[ends[1]].clone()];
                at_centre.max(self.estimate(
                    (sign, i0 + middle.0 * c / 2, j0 + middle.1 * c / 2),
                    c,
                    &edge,
                )?)
            } else {
                parent / 4.0
            };
            if error <= self.settings.agreement || level == top {
                if error > self.settings.agreement {
                    self.stats.unresolved += 1;
                    self.stats.worst_estimate = self.stats.worst_estimate.max(error);
                }
                corners.retain(|(_, w)| *w > 0.0);
                return Ok(Blend { corners, speed, torque, level, estimate: error });
            }
            parent = error;
        }
        unreachable!("the finest level always answers")
    }

    /// The interpolation error of a cell of size `c` estimated at node `at` (its centre, or
    /// the midpoint of the edge whose corners are `ends`), solving `at` where it is not
    /// cached; kept, so that later requests in the cell read it back
    /// ([`Self::interpolation_error`]).
    fn estimate(&mut self, at: Node, c: i64, ends: &[(Arc<SteadyPoint>, f64)]) -> Result<f64, PeriodicError> {
        let key = (at.0, at.1, at.2, c);
        if let Some(e) = self.estimates.get(&key) {
            return Ok(*e);
        }
        let middle = self.node(at)?;
        let e = self.interpolation_error(ends, &middle);
        self.stats.estimated += 1;
        self.estimates.insert(key, e);
        Ok(e)
    }

    /// The largest difference between the mean of `ends` (the cell's corners, or an edge's
    /// two: the bilinear interpolation at the cell's centre or the edge's midpoint) and
    /// the steady state of the node `centre` there, of each mesh's largest, smallest and
    /// mean force and planet 1's F^(rms) over the node's static mesh load, and of each
    /// mesh's separation fraction.
    fn interpolation_error(&self, ends: &[(Arc<SteadyPoint>, f64)], centre: &SteadyPoint) -> f64 {
        let measures = |p: &SteadyPoint| -> Vec<f64> {
            let mut m: Vec<f64> = p.meshes.iter().flat_map(|s| [s.max, s.min, s.mean]).collect();
            m.extend(p.window.iter().map(|(h, _)| h.rms));
            m
        };
        let separations = |p: &SteadyPoint| -> Vec<f64> { p.meshes.iter().map(|s| s.separation).collect() };
        let load = (centre.torque * self.load_per_nm).abs().max(f64::MIN_POSITIVE);
        let share = 1.0 / ends.len() as f64;
        let mean = |f: &dyn Fn(&SteadyPoint) -> Vec<f64>| -> Vec<f64> {
            let mut sum = vec![0.0; f(centre).len()];
            for (p, _) in ends {
                sum.iter_mut().zip(f(p)).for_each(|(s, x)| *s += share * x);
            }
            sum
        };
        let (forces, separation) = (mean(&measures), mean(&separations));
        let forces = forces.iter().zip(measures(centre)).map(|(a, b)| (a - b).abs() / load);
        let separation = separation.iter().zip(separations(centre)).map(|(a, b)| (a - b).abs());
        forces.chain(separation).fold(0.0, f64::max)
    }

    /// The node's steady state, solved where it is not cached yet: by continuation from
    /// the nearest cached node of its torque (in speed), else cold.
    fn node(&mut self, node: Node) -> Result<Arc<SteadyPoint>, PeriodicError> {
        if let Some(p) = self.nodes.get(&node) {
            return Ok(p.clone());
        }
        let speed = self.speed_of(node);
        let (sign, i, j) = node;
        if j == 0 {
            let samples = self.samples_per_cycle;
            let base = &self.base;
            let p = self
                .unloaded
                .entry((sign, i))
                .or_insert_with(|| Arc::new(SteadyPoint::unloaded(speed, base, samples)));
            return Ok(p.clone());
        }
        let torque = j as f64 * self.finest().1;
        let neighbour = nearest_in_row(&self.nodes, node);
        if !self.levels.contains_key(&j) {
            let torques = self.torques_per_nm.map(|t| t * torque);
            let level = TorqueLevel::new(
                &self.base,
                (torque, self.load_per_nm * torque),
                torques,
                speed,
                (self.samples_per_cycle, self.settings.sample_phase),
            )?;
            self.levels.insert(j, level);
        }
        let level = self.levels.get_mut(&j).expect("inserted above");
        let point = match level.solve(speed, neighbour.as_deref()) {
            Ok(p) => Arc::new(p),
            // A node no way solves (a march's period fails to integrate) takes its row's
            // nearest node, not settled, rather than stopping the run; without one, it stops.
            Err(e) => {
                let near = neighbour.ok_or(e)?;
                let found = Found::Failed;
                Arc::new(SteadyPoint { speed, torque, found, settled: f64::INFINITY, ..(*near).clone() })
            }
        };
        self.stats.solved += 1;
        match point.found {
            Found::Marched => self.stats.marched += 1,
            Found::Cold => self.stats.cold += 1,
            Found::Failed => self.stats.failed += 1,
            _ => {}
        }
        self.nodes.insert(node, point.clone());
        Ok(point)
    }
}

/// The cell's edge nearest the point at fractions `wa` of the speed and `wb` of the torque
/// across it: the indices of its two corners (in the order (0, 0), (1, 0), (0, 1), (1, 1))
/// and its midpoint in half-cells. Of edges at the same distance the first of bottom, top,
/// left, right, so that the same request reads the same nodes in every run.
fn nearest_edge(wa: f64, wb: f64) -> ([usize; 2], (i64, i64)) {
    let edges =
        [(wb, [0, 1], (1, 0)), (1.0 - wb, [2, 3], (1, 2)), (wa, [0, 2], (0, 1)), (1.0 - wa, [1, 3], (2, 1))];
    let (_, corners, middle) = edges.into_iter().min_by(|a, b| a.0.total_cmp(&b.0)).expect("four edges");
    (corners, middle)
}

/// The cached node of `node`'s torque row and side nearest to it in speed: of two at the
/// same distance the lower column, so that the same requests continue from the same node
/// and give the same outputs, bit for bit, in every run.
fn nearest_in_row<T: Clone>(nodes: &BTreeMap<Node, T>, (sign, i, j): Node) -> Option<T> {
    nodes
        .iter()
        .filter(|((s, _, jj), _)| *s == sign && *jj == j)
        .min_by_key(|((_, ii, _), _)| ((ii - i).abs(), *ii))
        .map(|(_, p)| p.clone())
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;

    use crate::dynamics::steady::grid::{nearest_edge, nearest_in_row};

    #[test]
    fn the_nearest_edge_holds_the_request() {
        // On the bottom edge (the torque row of corners 0 and 1): its midpoint one half-cell
        // along the speed.
        assert_eq!(nearest_edge(0.5, 0.0), ([0, 1], (1, 0)));
        assert_eq!(nearest_edge(0.3, 0.9), ([2, 3], (1, 2)));
        assert_eq!(nearest_edge(0.1, 0.4), ([0, 2], (0, 1)));
        assert_eq!(nearest_edge(0.8, 0.6), ([1, 3], (2, 1)));
        // At the centre all four are as near: the bottom one, in every run.
        assert_eq!(nearest_edge(0.5, 0.5), ([0, 1], (1, 0)));
    }

    #[test]
    fn the_nearest_node_of_a_tie_is_the_lower_column() {
        let mut nodes = BTreeMap::new();
        for (k, node) in [(1, 2, 5), (1, 6, 5), (1, 4, 7), (-1, 4, 5), (1, 9, 5)].into_iter().enumerate() {
            nodes.insert(node, k);
        }
        // Columns 2 and 6 are both 2 from 4: the lower one.
        assert_eq!(nearest_in_row(&nodes, (1, 4, 5)), Some(0));
        assert_eq!(nearest_in_row(&nodes, (1, 8, 5)), Some(4));
        assert_eq!(nearest_in_row(&nodes, (1, 4, 7)), Some(2));
        assert_eq!(nearest_in_row(&nodes, (-1, 0, 5)), Some(3));
        assert_eq!(nearest_in_row(&nodes, (1, 4, 6)), None);
    }
}

//! The Archard wear model of a gear set and its stepper.
//!
//! Wear per input revolution of a flank is its wear per cycle times its
//! gear's tooth cycles per input revolution ([`cycles_per_input_revolution`]:
//! carrier held, sun driven: sun n, planet Z_sun/Z_planet, ring n·Z_sun/Z_ring).
//! An update runs the input revolutions that make the largest new wear on
//! any wearing flank reach ε^κ, or fewer when a total depth of ε_tot or a
//! given number of revolutions ends it first; every flank wears with its own
//! gear's cycles for those revolutions. The deviations enter the next
//! cycle's separation tables ([`WornState::mesh_flanks`]).

use crate::contact::deformable::set::DeformableSet;
use crate::contact::hertz::{contact_modulus, line_contact};
use crate::contact::ltca::{loaded_span, MeshForce, Refine, SetEquilibrium, SetModel};
use crate::geometry::profile::ProfileDeviation;
use crate::model::gear::{GearKind, GearSet, MeshKind};
use crate::model::run::RunSettings;
use crate::wear::archard::{
    passage_wear, Band, CycleWear, FlankWear, Limit, MeshPassage, PairLoads, PressureSource, Stop, WearError,
    WearSettings,
};
use crate::wear::dynamic::{record_pair_loads, DynamicPairLoads};
use crate::wear::flank::{
    contact_rolls, cycles_per_input_revolution, involute_arc, Flank, GearCycles, UpdateEnd,
};
use crate::wear::state::{FlankExtreme, UpdateRecord, WornState};

/// The pair loads of the whole-set quasi-static LTCA on a set's contact
/// models, and on the deformable law when the set asks for it.
struct QuasiStaticLoads<'a> {
    wear: &'a WearModel,
    model: &'a SetModel,
    law: Option<&'a DeformableSet>,
}
impl PairLoads for QuasiStaticLoads<'_> {
    fn engagement(&self, mesh: MeshKind) -> (f64, f64) {
        self.wear.engagement(self.model, self.law, mesh)
    }

    fn slice_loads(&self, mesh: MeshKind, position: &[f64]) -> Vec<Vec<Vec<f64>>> {
        self.wear.quasi_static_loads(self.model, self.law, mesh, position)
    }
}

/// The Archard wear model of a gear set.
#[derive(Clone, Debug)]
pub struct WearModel {
    set: GearSet,
    run: Option<RunSettings>,
    settings: WearSettings,
    cycles_per_revolution: GearCycles,
    contact_modulus: f64,
}
/// Coarse samples per base pitch when searching the first and last contact.
const ENGAGEMENT_SCAN: usize = 40;
/// Bisection steps refining the first and last contact.
const ENGAGEMENT_BISECTIONS: usize = 40;
impl WearModel {
    /// The wear model of a validated gear set with checked settings, for the
    /// quasi-static tooth-pair loads, which need the gear set alone; a
    /// dynamic source is refused here (it runs the dynamic model, which
    /// needs run settings: [`Self::with_run`]).
    pub fn new(set: &GearSet, settings: WearSettings) -> Result<Self, WearError> {
        settings.validate()?;
        if let PressureSource::Dynamic { .. } = settings.source {
            return Err(WearError::NoRunSettings);
        }
        Self::build(set, None, settings)
    }

    /// The wear model of a validated gear set with checked settings and the
    /// run settings of its dynamic runs (the dynamic source, and
    /// [`dynamic_cycle`] and the source comparison on any settings).
    pub fn with_run(set: &GearSet, run: &RunSettings, settings: WearSettings) -> Result<Self, WearError> {
        Self::build(set, Some(*run), settings)
    }

    fn build(set: &GearSet, run: Option<RunSettings>, settings: WearSettings) -> Result<Self, WearError> {
        settings.validate()?;
        // The total wear limit must keep every state it leads to readable:
        // no deeper than the shallowest plausible depth of a wearing gear.
        let shallowest = settings
            .wearing
            .flanks()
            .iter()
            .map(|f| (f.gear(), WornState::plausible_depth(set, f.gear())))
            .min_by(|a, b| a.1 .0.total_cmp(&b.1 .0));
        if let Some((gear, (limit, basis))) = shallowest {
            if settings.total_depth > limit {
                return Err(WearError::TotalDepthImplausible {
                    total: settings.total_depth,
                    limit,
                    gear: gear.name(),
                    basis,
                });
            }
        }
        let m = &set.material();
        Ok(Self {
            set: set.clone(),
            run,
            settings,
            cycles_per_revolution: cycles_per_input_revolution(set),
            contact_modulus: contact_modulus(
                m.youngs_modulus,
                m.poisson_ratio,
                m.youngs_modulus,
                m.poisson_ratio,
            ),
        })
    }

    /// The settings.
    pub fn settings(&self) -> &WearSettings {
        &self.settings
    }

    /// The gear set.
    pub fn set(&self) -> &GearSet {
        &self.set
    }

    /// The run settings of the dynamic runs, when the model was made with
    /// them ([`Self::with_run`]).
    pub fn run_settings(&self) -> Option<&RunSettings> {
        self.run.as_ref()
    }

    /// Tooth cycles per input revolution [-].
    pub fn cycles_per_revolution(&self) -> GearCycles {
        self.cycles_per_revolution
    }

    /// The unworn state (κ = 0) on the settings' grids.
    pub fn unworn(&self) -> WornState {
        WornState::unworn(&self.set, self.settings.profile_points, self.settings.face_slices)
            .with_profile_ends(self.settings.profile_ends)
    }

    /// Refuses a state of another gear set, with unusable grids or with
    /// another number of face slices.
    pub(crate) fn check(&self, state: &WornState) -> Result<(), WearError> {
        state.check_gear_set(&self.set)?;
        state.validate()?;
        let slices = state.face_slices();
        if slices != self.settings.face_slices {
            return Err(WearError::SliceCount { state: slices, settings: self.settings.face_slices });
        }
        Ok(())
    }

    /// One wear cycle on the state's geometry: each wearing flank's wear per
    /// tooth cycle on its grid, with the pressures and sliding distances,
    /// from the tooth-pair loads of the settings' source.
    pub fn cycle(&self, state: &WornState) -> Result<CycleWear, WearError> {
        self.cycle_with(state, self.settings.source)
    }

    /// One wear cycle on the state's geometry with the tooth-pair loads of
    /// `source`: the bands, sliding distances and Archard wear are the same
    /// for every source; only the pair loads per position differ.
    pub fn cycle_with(&self, state: &WornState, source: PressureSource) -> Result<CycleWear, WearError> {
        match source {
            PressureSource::QuasiStatic => {
                self.check(state)?;
                let model = state.set_model(&self.set);
                let law = DeformableSet::of_set_model(&self.set, &model)
                    .map_err(|e| WearError::Contact(e.to_string()))?;
                let loads = QuasiStaticLoads { wear: self, model: &model, law: law.as_deref() };
                let cycle = self.cycle_on(state, &model, &loads, source);
                let finite = cycle.meshes.iter().all(|m| m.pair_load.iter().flatten().all(|f| f.is_finite()));
                if !finite {
                    return Err(WearError::Contact(
                        "a tooth pair's load on the deformable law could not be solved (not finite)".into(),
                    ));
                }
                Ok(cycle)
            }
            PressureSource::Dynamic { speed } => {
                crate::wear::stepper::dynamic_cycle(self, state, speed).map(|(cycle, _)| cycle)
            }
        }
    }

    /// One wear cycle on `model` (the state's contact models) with the pair
    /// loads of `loads`, labelled with `source`.
    pub(crate) fn cycle_on(
        &self,
        state: &WornState,
        model: &SetModel,
        loads: &dyn PairLoads,
        source: PressureSource,
    ) -> CycleWear {
        let wearing = self.settings.wearing;
        let mut out = CycleWear {
            kappa: state.kappa,
            source,
            cycles_per_revolution: self.cycles_per_revolution,
            meshes: Vec::new(),
            flanks: Vec::new(),
        };
        for mesh in MeshKind::ALL {
            let (f1, f2) = match mesh {
                MeshKind::SunPlanet => (Flank::SunDrive, Flank::PlanetSunSide),
                MeshKind::RingPlanet => (Flank::PlanetRingSide, Flank::RingDrive),
            };
            if !wearing.contains(f1) && !wearing.contains(f2) {
                continue;
            }
            let (passage, slice_loads) = self.passage(model, mesh, loads);
            for (flank, gear1) in [(f1, true), (f2, false)] {
                if !wearing.contains(flank) {
                    continue;
                }
                for (j, dev) in state.flanks.get(flank).iter().enumerate() {
                    out.flanks.push(self.flank_wear(model, &passage, &slice_loads, flank, gear1, j, dev));
                }
            }
            out.meshes.push(passage);
        }
        out
    }

    /// Sun travel \[m\] at which planet `planet`'s pair of `mesh` sits at `s`.
    fn travel(model: &SetModel, set: &GearSet, mesh: MeshKind, planet: usize, s: f64) -> f64 {
        let own = set.sun().base_radius() * model.planet_angles[planet];
        match mesh {
            MeshKind::SunPlanet => s + own,
            MeshKind::RingPlanet => s - model.ring_shift + own,
        }
    }

    /// Per-slice forces \[N\] of planet `planet`'s pair of `mesh` at `s`, the
    /// set solved from `guess` (updated to the new equilibrium).
    #[allow(clippy::too_many_arguments)]
    fn pair_at(
        &self,
        model: &SetModel,
        law: Option<&DeformableSet>,
        mesh: MeshKind,
        planet: usize,
        s: f64,
        guess: &mut SetEquilibrium,
        forces: &mut Vec<f64>,
    ) {
        let total = self.set.mesh_load_per_planet() * model.planet_angles.len() as f64;
        let lambda = Self::travel(model, &self.set, mesh, planet, s);
        // The set's equilibrium on the law the scene chose: the planets' shares and each
        // mesh's approach.
        let (sp, rp): (&dyn MeshForce, &dyn MeshForce) = match law {
            Some(d) => (&d.sun_planet, &d.ring_planet),
            None => (&model.sun_planet, &model.ring_planet),
        };
        *guess = model.equilibrium_on(sp, rp, total, lambda, guess);
        let (m, delta) = match mesh {
            MeshKind::SunPlanet => (&model.sun_planet, guess.sun_mesh_approach[planet]),
            MeshKind::RingPlanet => {
                (&model.ring_planet, guess.sun_approach - guess.sun_mesh_approach[planet])
            }
        };
        match law {
            None => m.pair_slice_forces(s, delta, forces),
            Some(d) => {
                // The pair's share of its mesh by the deformable law's joint solution at that
                // approach, spread evenly over the slices (a transverse law).
                let pair = d.mesh(mesh).mesh.solve(s, delta).map_or(f64::NAN, |st| st.pair_force(0));
                let n = model.flanks(mesh).len();
                forces.clear();
                forces.resize(n, pair / n as f64);
            }
        }
        for f in forces.iter_mut() {
            // Under the drive load only the drive flanks touch; a back-flank
            // force (negative) would wear the coast flanks, which do not wear here.
            // (A NaN stays NaN: the cycle refuses it.)
            if *f < 0.0 {
                *f = 0.0;
            }
        }
    }

    /// First and last loaded position of the pairs of `mesh` over all planets \[m\].
    fn engagement(&self, model: &SetModel, law: Option<&DeformableSet>, mesh: MeshKind) -> (f64, f64) {
        let path = match mesh {
            MeshKind::SunPlanet => model.sun_planet.path(),
            MeshKind::RingPlanet => model.ring_planet.path(),
        };
        let planets = model.planet_angles.len();
        let mut guesses = vec![SetEquilibrium::unloaded(planets); planets];
        let mut forces = Vec::new();
        let loaded = |s: f64| {
            (0..planets).any(|p| {
                self.pair_at(model, law, mesh, p, s, &mut guesses[p], &mut forces);
                forces.iter().any(|f| *f > 0.0)
            })
        };
        let pb = path.base_pitch;
        let (lo, hi) = (path.start - pb / 2.0, path.end + pb / 2.0);
        let n = ((hi - lo) / pb * ENGAGEMENT_SCAN as f64).ceil() as usize;
        loaded_span(lo, hi, n, loaded, Refine::Steps(ENGAGEMENT_BISECTIONS)).unwrap_or((path.start, path.end))
    }

    /// The pair's passage through `mesh` and its per-slice loads
    /// `[planet][slice][r]` \[N\], from the pair loads of `loads`.
    fn passage(
        &self,
        model: &SetModel,
        mesh: MeshKind,
        loads: &dyn PairLoads,
    ) -> (MeshPassage, Vec<Vec<Vec<f64>>>) {
        let path = match mesh {
            MeshKind::SunPlanet => model.sun_planet.path().clone(),
            MeshKind::RingPlanet => model.ring_planet.path().clone(),
        };
        let (first, last) = loads.engagement(mesh);
        let r_steps = self.settings.positions;
        let position: Vec<f64> =
            (0..=r_steps).map(|r| first + (last - first) * r as f64 / r_steps as f64).collect();
        let rolls: Vec<(f64, f64)> = position.iter().map(|s| contact_rolls(&path, *s)).collect();
        // Arc coordinates run the same way along the common tangent for the
        // internal pair and opposite ways for the external one.
        let orientation = match path.kind {
            GearKind::External => -1.0,
            GearKind::Internal => 1.0,
        };
        let slip: Vec<f64> = rolls
            .windows(2)
            .map(|w| {
                let d1 = involute_arc(path.base_radius_1, w[1].0) - involute_arc(path.base_radius_1, w[0].0);
                let d2 = involute_arc(path.base_radius_2, w[1].1) - involute_arc(path.base_radius_2, w[0].1);
                (d1 - orientation * d2).abs()
            })
            .collect();
        let loads = loads.slice_loads(mesh, &position);
        let pair_load = loads
            .iter()
            .map(|slices| (0..position.len()).map(|r| slices.iter().map(|v| v[r]).sum()).collect())
            .collect();
        let passage = MeshPassage {
            mesh,
            roll_gear1: rolls.iter().map(|r| r.0).collect(),
            roll_gear2: rolls.iter().map(|r| r.1).collect(),
            position,
            slip,
            pair_load,
        };
        (passage, loads)
    }

    #[allow(clippy::too_many_arguments)]
    fn flank_wear(
        &self,
        model: &SetModel,
        passage: &MeshPassage,
        slice_loads: &[Vec<Vec<f64>>],
        flank: Flank,
        gear1: bool,
        slice: usize,
        dev: &ProfileDeviation,
    ) -> FlankWear {
        let m = match passage.mesh {
            MeshKind::SunPlanet => &model.sun_planet,
            MeshKind::RingPlanet => &model.ring_planet,
        };
        let path = m.path();
        let slice_width = m.face_width() / self.settings.face_slices as f64;
        let base = if gear1 { path.base_radius_1 } else { path.base_radius_2 };
        let arc: Vec<f64> = dev.roll.iter().map(|xi| involute_arc(base, *xi)).collect();
        let centres: Vec<f64> = (if gear1 { &passage.roll_gear1 } else { &passage.roll_gear2 })
            .iter()
            .map(|xi| involute_arc(base, *xi))
            .collect();
        let internal = path.kind == GearKind::Internal;
        let mut out = FlankWear {
            flank,
            slice,
            roll: dev.roll.clone(),
            arc: arc.clone(),
            wear_per_cycle: vec![0.0; arc.len()],
            wear_per_planet: Vec::new(),
            sliding: Vec::new(),
            bands: Vec::new(),
            slip: passage.slip.clone(),
        };
        for loads in slice_loads {
            let bands: Vec<Band> = passage
                .position
                .iter()
                .zip(&loads[slice])
                .zip(&centres)
                .map(|((s, f), centre)| {
                    // Curvatures at the nearest end of the involute path in
                    // corner contact, as the LTCA's Hertz figures.
                    let sc = s.clamp(path.start, path.end);
                    let contact = line_contact(
                        f / slice_width,
                        path.rho_1(sc),
                        path.rho_2(sc),
                        internal,
                        self.contact_modulus,
                    );
                    Band { centre: *centre, contact }
                })
                .collect();
            let p = passage_wear(&arc, &bands, &passage.slip, self.settings.archard_coefficient);
            out.wear_per_planet.push(p.wear);
            out.sliding.push(p.sliding);
            out.bands.push(bands);
        }
        let planets = out.wear_per_planet.len().max(1) as f64;
        for w in &out.wear_per_planet {
            for (acc, h) in out.wear_per_cycle.iter_mut().zip(w) {
                *acc += h / planets;
            }
        }
        out
    }

    /// Per-slice loads `[planet][slice][r]` \[N\] of each planet's pair of
    /// `mesh` at `position` \[m\] from the whole-set quasi-static LTCA.
    fn quasi_static_loads(
        &self,
        model: &SetModel,
        law: Option<&DeformableSet>,
        mesh: MeshKind,
        position: &[f64],
    ) -> Vec<Vec<Vec<f64>>> {
        let planets = model.planet_angles.len();
        let mut loads = vec![Vec::new(); planets];
        let mut forces = Vec::new();
        for (p, planet_loads) in loads.iter_mut().enumerate() {
            let mut guess = SetEquilibrium::unloaded(planets);
            let mut per_slice = vec![Vec::with_capacity(position.len()); self.settings.face_slices];
            for s in position {
                self.pair_at(model, law, mesh, p, *s, &mut guess, &mut forces);
                for (j, f) in forces.iter().enumerate() {
                    if let Some(v) = per_slice.get_mut(j) {
                        v.push(*f);
                    }
                }
            }
            *planet_loads = per_slice;
        }
        loads
    }

    /// Applies one update to `state` from the wear of one `cycle` on it
    /// (see the module doc), limited by `limit`.
    pub fn apply(&self, state: &WornState, cycle: &CycleWear, limit: Limit) -> Result<WornState, WearError> {
        self.check(state)?;
        let cpr = self.cycles_per_revolution;
        let eps = self.settings.update_depth;
        let eps_total = self.settings.total_depth;
        let deepest = state.deepest();
        if deepest.depth >= eps_total * (1.0 - 1e-12) {
            return Err(WearError::TotalWearReached { depth: deepest.depth, limit: eps_total });
        }
        let limit_revolutions = match limit {
            Limit::Update => f64::INFINITY,
            Limit::Revolutions(r) => {
                if !(r.is_finite() && r > 0.0) {
                    return Err(WearError::InvalidLimit {
                        name: "revolutions",
                        value: r.to_string(),
                        allowed: "a finite positive number of input revolutions",
                    });
                }
                r
            }
        };
        for fw in &cycle.flanks {
            let grid = state.flanks.get(fw.flank).get(fw.slice).map(|d| &d.roll);
            if cycle.kappa != state.kappa || grid != Some(&fw.roll) {
                return Err(WearError::CycleMismatch {
                    cycle_kappa: cycle.kappa,
                    state_kappa: state.kappa,
                    flank: fw.flank.name(),
                });
            }
        }
        // Wear per input revolution at every grid point of every wearing flank.
        let mut max_rate = 0.0_f64;
        let mut limiting = cycle.flanks.first().map(|f| f.flank).unwrap_or(Flank::SunDrive);
        let mut to_total = f64::INFINITY;
        for fw in &cycle.flanks {
            let per_rev = cpr.of(fw.flank.gear());
            let current = &state.flanks.get(fw.flank)[fw.slice];
            for (h, depth) in fw.wear_per_cycle.iter().zip(&current.depth) {
                let rate = h * per_rev;
                if rate > max_rate {
                    max_rate = rate;
                    limiting = fw.flank;
                }
                if rate > 0.0 {
                    to_total = to_total.min((eps_total - depth) / rate);
                }
            }
        }
        if !(max_rate > 0.0 && max_rate.is_finite()) {
            return Err(WearError::NoWear { rate: max_rate });
        }
        let to_update = eps / max_rate;
        let (revolutions, ended_by) = [
            (to_update, UpdateEnd::UpdateDepth),
            (to_total, UpdateEnd::TotalDepth),
            (limit_revolutions, UpdateEnd::Revolutions),
        ]
        .into_iter()
        .fold((f64::INFINITY, UpdateEnd::UpdateDepth), |a, b| if b.0 < a.0 { b } else { a });
        let mut next = state.clone();
        let mut new_wear: Vec<FlankExtreme> = Vec::new();
        for fw in &cycle.flanks {
            let cycles = revolutions * cpr.of(fw.flank.gear());
            let dev = &mut next.flanks.get_mut(fw.flank)[fw.slice];
            let mut top = FlankExtreme { flank: fw.flank, slice: fw.slice, depth: 0.0, roll: fw.roll[0] };
            for ((d, h), xi) in dev.depth.iter_mut().zip(&fw.wear_per_cycle).zip(&fw.roll) {
                let added = cycles * h;
                *d += added;
                if added > top.depth {
                    top = FlankExtreme { flank: fw.flank, slice: fw.slice, depth: added, roll: *xi };
                }
            }
            match new_wear.iter_mut().find(|e| e.flank == fw.flank) {
                Some(e) if top.depth > e.depth => *e = top,
                Some(_) => {}
                None => new_wear.push(top),
            }
        }
        let cycles = cpr.scaled(revolutions);
        next.kappa += 1;
        next.revolutions += revolutions;
        next.cycles = next.cycles.plus(&cycles);
        let total_wear = Flank::ALL.iter().map(|f| next.deepest_on(*f)).collect();
        next.history.push(UpdateRecord {
            kappa: next.kappa,
            revolutions,
            cycles,
            limiting_flank: limiting,
            ended_by,
            new_wear,
            total_wear,
        });
        Ok(next)
    }

    /// One update: a wear cycle on the state's geometry, then [`Self::apply`].
    pub fn step(&self, state: &WornState, limit: Limit) -> Result<WornState, WearError> {
        self.step_with(state, limit, self.settings.source)
    }

    /// One update with the tooth-pair loads of `source`: a wear cycle on the
    /// state's geometry ([`Self::cycle_with`]), then [`Self::apply`].
    pub fn step_with(
        &self,
        state: &WornState,
        limit: Limit,
        source: PressureSource,
    ) -> Result<WornState, WearError> {
        let cycle = self.cycle_with(state, source)?;
        self.apply(state, &cycle, limit)
    }

    /// Updates until `stop` or until a point's total wear reaches ε_tot,
    /// whichever comes first (a state already there is returned as it is).
    pub fn run(&self, state: &WornState, stop: Stop) -> Result<WornState, WearError> {
        self.check(state)?;
        let start_revolutions = state.revolutions;
        let mut current = state.clone();
        loop {
            if current.deepest().depth >= self.settings.total_depth * (1.0 - 1e-12) {
                return Ok(current);
            }
            let limit = match stop {
                Stop::Kappa(k) if current.kappa >= k => return Ok(current),
                Stop::Kappa(_) | Stop::TotalWear => Limit::Update,
                Stop::Revolutions(r) => {
                    if !(r.is_finite() && r >= 0.0) {
                        return Err(WearError::InvalidLimit {
                            name: "revolutions",
                            value: r.to_string(),
                            allowed: "a finite non-negative number of input revolutions",
                        });
                    }
                    let left = start_revolutions + r - current.revolutions;
                    if left <= r * 1e-12 {
                        return Ok(current);
                    }
                    Limit::Revolutions(left)
                }
            };
            current = self.step(&current, limit)?;
        }
    }

    /// Updates until the geometry state reaches `kappa` (or ε_tot first).
    pub fn run_to_kappa(&self, state: &WornState, kappa: u32) -> Result<WornState, WearError> {
        self.run(state, Stop::Kappa(kappa))
    }
}
/// One wear cycle on the state's geometry with the tooth-pair loads of the
/// dynamic steady state at input speed `speed` [rad/s], and those loads.
pub fn dynamic_cycle(
    wear: &WearModel,
    state: &WornState,
    speed: f64,
) -> Result<(CycleWear, DynamicPairLoads), WearError> {
    let source = PressureSource::Dynamic { speed };
    source.validate()?;
    let run = wear.run_settings().ok_or(WearError::NoRunSettings)?;
    wear.check(state)?;
    let contact = state.set_model(wear.set());
    let (loads, contact) = record_pair_loads(wear.set(), run, contact, speed, wear.settings().positions)?;
    let cycle = wear.cycle_on(state, &contact, &loads, source);
    Ok((cycle, loads))
}

//! One FMU instance, in safe Rust: variable values by value reference,
//! the parameters turned into a scene and a [`Simulation`], outputs read from
//! it, the FMI 2.0 co-simulation phases, and FMU states. The FMI calls
//! (`core.rs`) report what this returns; the C boundary (`export.rs`) only
//! converts arguments. Beside it: the parameters → scene (`parameters.rs`),
//! the numerical guards of a step (`guard.rs`) and the plausibility
//! warnings (`warnings.rs`).

pub mod guard;
mod parameters;
pub mod warnings;

pub use parameters::scene_values;

/// The scene an FMU packed with `planetwear fmu pack --scene` carries in
/// resources/: when it is there, it is sceneFile's start value and the other
/// parameters start at its values ([`scene_values`]), as that FMU's
/// modelDescription.xml says.
pub const DEFAULT_SCENE: &str = "default-scene.toml";

/// The start values of an instance whose resources/ holds
/// [`DEFAULT_SCENE`]: sceneFile names it and every parameter with a
/// counterpart in it starts at its value. A scene that cannot be read or is
/// invalid leaves the table's start values (sceneFile still names it, so
/// initialization says why it is refused).
fn packed_starts(resources: Option<&std::path::Path>) -> Vec<(u32, Start)> {
    let Some(path) = resources.map(|r| r.join(DEFAULT_SCENE)).filter(|p| p.is_file()) else {
        return Vec::new();
    };
    let mut out = vec![(vr::SCENE_FILE, Start::String(DEFAULT_SCENE))];
    let scene = crate::files::read_input(&path, crate::files::InputKind::Scene)
        .ok()
        .and_then(|b| String::from_utf8(b).ok())
        .and_then(|t| Scene::from_toml(&t).ok());
    if let Some(values) = scene.and_then(|s| scene_values(&s).ok()) {
        out.extend(values.into_iter().map(|(p, v)| (p.variable().value_reference(), v)));
    }
    out
}

use std::collections::{BTreeMap, BTreeSet};
use std::path::PathBuf;

use crate::contact::ltca::SetModel;
use crate::dynamics::duty::{parse_edges, DutyBins, DutyError};
use crate::dynamics::equations::PlanetaryDynamics;
use crate::dynamics::simulation::{Bearing, MeshExtremes, Simulation, Snapshot};
use crate::dynamics::spectrum::Harmonics;
use crate::dynamics::state_format;
use crate::fmi::variables::{vr, Causality, Kind, Reading, Settable, Start, Variable, GUID, VARIABLES};
use crate::model::gear::MeshKind;
use crate::scene::Scene;
use crate::wear::duty::DutyCycle;

/// An output's value: each quantity's one line of physics. Window values
/// are 0 until the window is full; step values are 0 beyond the number of
/// planets.
fn read(s: &Simulation, reading: Reading) -> Result<Value, Refusal> {
    use Reading as R;
    let real = Value::Real;
    let flag = |b: bool| Value::Integer(i32::from(b));
    let window =
        |m: MeshKind, f: fn(&Harmonics, f64) -> f64| s.window_harmonics(m).map_or(0.0, |(h, sep)| f(&h, sep));
    let extreme = |p: usize, m: MeshKind, f: fn(&MeshExtremes) -> f64| {
        s.step_extremes().mesh(p, m).as_ref().map_or(0.0, f)
    };
    Ok(match reading {
        R::Speed { member } => real(s.speed(member)),
        R::Angle { member } => real(s.angle(member)),
        R::InputShaftTorque => real(s.input_torque()),
        R::MeshForce { planet, mesh } => real(s.mesh_force(planet, mesh)),
        R::TrackedPairForce { mesh } => real(s.tracked_pair_force(mesh)),
        R::TransmissionError { planet, mesh } => real(s.transmission_error(planet, mesh)),
        R::StaticTransmissionError { planet, mesh } => real(s.static_transmission_error(planet, mesh)),
        R::BearingForce { member } => real(s.bearing_force(Bearing::Member(member))),
        R::PlanetBearingForce { planet } => real(s.bearing_force(Bearing::Planet(planet))),
        R::WindowAmplitude { mesh, order } => real(
            s.window_harmonics(mesh).map_or(0.0, |(h, _)| h.amplitude.get(order - 1).copied().unwrap_or(0.0)),
        ),
        R::WindowRms { mesh } => real(window(mesh, |h, _| h.rms)),
        R::WindowSeparation { mesh } => real(window(mesh, |_, sep| sep)),
        R::WindowMean { mesh } => real(window(mesh, |h, _| h.mean)),
        R::WindowCycles => Value::Integer(s.window_cycles() as i32),
        R::PairsInContact { planet, mesh } => Value::Integer(s.pairs_in_contact(planet, mesh) as i32),
        R::MeshForceMax { planet, mesh } => real(extreme(planet, mesh, |e| e.max)),
        R::MeshForceMin { planet, mesh } => real(extreme(planet, mesh, |e| e.min)),
        R::ToothForceMax { planet, mesh } => real(extreme(planet, mesh, |e| e.peak_pair)),
        R::Separated { planet, mesh } => {
            flag(s.step_extremes().mesh(planet, mesh).is_some_and(|e| e.separated))
        }
        R::AnyMeshForceMax { mesh } => real(s.step_extremes().any_max(mesh)),
        R::AnyToothForceMax { mesh } => real(s.step_extremes().any_peak_pair(mesh)),
        R::AnySeparated { mesh } => flag(s.step_extremes().any_separated(mesh)),
        R::DutyCycle => Value::String(duty_document(s)?),
        R::ReactionTorque => real(s.reaction_torque()),
        R::BalancingTorque => real(s.balancing_torque()),
    })
}

/// FMI status of a refused or partial call.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Status {
    /// fmi2Warning.
    Warning,
    /// fmi2Discard.
    Discard,
    /// fmi2Error.
    Error,
    /// fmi2Fatal.
    Fatal,
}

/// A refusal: its status, the log category and the message.
#[derive(Clone, Debug, PartialEq)]
pub struct Refusal {
    /// Status to return.
    pub status: Status,
    /// Message for the logger.
    pub message: String,
}

impl Refusal {
    fn error(message: impl Into<String>) -> Self {
        Self { status: Status::Error, message: message.into() }
    }
}

/// A variable's value, of its base type.
enum Value {
    Real(f64),
    Integer(i32),
    Boolean(bool),
    String(String),
}

/// The phases of the FMI 2.0 co-simulation state machine that this FMU
/// can be in (it never runs asynchronous steps).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Phase {
    /// After fmi2Instantiate or fmi2Reset.
    Instantiated,
    /// Between fmi2EnterInitializationMode and fmi2ExitInitializationMode.
    InitializationMode,
    /// Initialized; the last step (if any) completed.
    StepComplete,
    /// A step was discarded.
    StepFailed,
    /// After fmi2Terminate.
    Terminated,
    /// After an fmi2Error.
    Error,
    /// After an fmi2Fatal.
    Fatal,
}

/// A saved FMU state (fmi2GetFMUstate).
#[derive(Clone, Debug)]
pub struct SavedState {
    phase: Phase,
    reals: BTreeMap<u32, f64>,
    integers: BTreeMap<u32, i32>,
    strings: BTreeMap<u32, String>,
    explicitly_set: BTreeSet<u32>,
    snapshot: Option<Snapshot>,
    terminated: bool,
    last_successful_time: f64,
}

/// One instance.
pub struct Instance {
    /// Instance name given by the importer.
    pub name: String,
    /// Current phase.
    pub phase: Phase,
    resources: Option<PathBuf>,
    /// Start values that differ from the table's ([`packed_starts`]).
    packed: Vec<(u32, Start)>,
    reals: BTreeMap<u32, f64>,
    integers: BTreeMap<u32, i32>,
    booleans: BTreeMap<u32, bool>,
    strings: BTreeMap<u32, String>,
    explicitly_set: BTreeSet<u32>,
    start_time: f64,
    stop_time: Option<f64>,
    sim: Option<Simulation>,
    /// The parameters `sim` was built from ([`Instance::build_key`]).
    built_from: String,
    /// What the last build accepted and the importer should be told.
    build_warnings: Vec<String>,
    /// Set when a step was discarded and the simulation cannot go on.
    pub terminated: bool,
    /// Time of the last completed step \[s\].
    pub last_successful_time: f64,
}

impl Instance {
    /// A new instance with every variable at its start value (those of
    /// [`DEFAULT_SCENE`] when `resources` holds one).
    pub fn new(name: &str, resources: Option<PathBuf>) -> Self {
        let mut i = Self {
            name: name.to_string(),
            phase: Phase::Instantiated,
            packed: packed_starts(resources.as_deref()),
            resources,
            reals: BTreeMap::new(),
            integers: BTreeMap::new(),
            booleans: BTreeMap::new(),
            strings: BTreeMap::new(),
            explicitly_set: BTreeSet::new(),
            start_time: 0.0,
            stop_time: None,
            sim: None,
            built_from: String::new(),
            build_warnings: Vec::new(),
            terminated: false,
            last_successful_time: 0.0,
        };
        i.reset_values();
        i
    }

    fn reset_values(&mut self) {
        self.reals.clear();
        self.integers.clear();
        self.booleans.clear();
        self.strings.clear();
        let starts = VARIABLES.iter().map(|v| (v.vr, v.start)).chain(self.packed.iter().copied());
        for (vr, start) in starts {
            match start {
                Start::Real(x) => {
                    self.reals.insert(vr, x);
                }
                Start::Integer(x) => {
                    self.integers.insert(vr, x);
                }
                Start::Boolean(x) => {
                    self.booleans.insert(vr, x);
                }
                Start::String(x) => {
                    self.strings.insert(vr, x.to_string());
                }
                Start::None => {}
            }
        }
        self.explicitly_set.clear();
    }

    /// fmi2Reset: back to the instantiated phase with start values.
    pub fn reset(&mut self) {
        self.reset_values();
        self.sim = None;
        self.phase = Phase::Instantiated;
        self.terminated = false;
        self.start_time = 0.0;
        self.stop_time = None;
        self.last_successful_time = 0.0;
    }

    /// fmi2SetupExperiment.
    pub fn setup_experiment(&mut self, start: f64, stop: Option<f64>) -> Result<(), Refusal> {
        if !start.is_finite() {
            return Err(Refusal::error(format!("startTime = {start}: must be finite")));
        }
        if let Some(s) = stop {
            if !(s.is_finite() && s >= start) {
                return Err(Refusal::error(format!(
                    "stopTime = {s}: must be finite and not before startTime {start}"
                )));
            }
        }
        self.start_time = start;
        self.stop_time = stop;
        self.last_successful_time = start;
        Ok(())
    }

    fn real(&self, v: u32) -> f64 {
        self.reals.get(&v).copied().unwrap_or(0.0)
    }

    fn int(&self, v: u32) -> i32 {
        self.integers.get(&v).copied().unwrap_or(0)
    }

    /// The values the importer holds, for [`parameters`].
    fn values(&self) -> parameters::Values<'_> {
        parameters::Values { reals: &self.reals, integers: &self.integers }
    }

    /// Whether a settable variable acts on the scene: every one for the
    /// built-in example, only those the importer set for a scene file.
    fn applies(&self, p: Settable) -> bool {
        self.strings.get(&vr::SCENE_FILE).is_none_or(|f| f.is_empty())
            || self.explicitly_set.contains(&p.variable().value_reference())
    }

    /// The scene the parameters describe: the scene file (or the built-in
    /// example) with every parameter applied — all of them for the built-in
    /// example, only those set by the importer for a scene file.
    pub fn scene(&self) -> Result<Scene, Refusal> {
        let file = self.strings.get(&vr::SCENE_FILE).cloned().unwrap_or_default();
        let mut scene = if file.is_empty() {
            Scene::example_2004()
        } else {
            let path = self.resolve(&file);
            let bytes = crate::files::read_input(&path, crate::files::InputKind::Scene)
                .map_err(|e| Refusal::error(format!("sceneFile = {file}: cannot read {e}")))?;
            let text = String::from_utf8(bytes).map_err(|_| {
                Refusal::error(format!("sceneFile = {file}: {} is not UTF-8 text", path.display()))
            })?;
            Scene::from_toml(&text).map_err(|e| Refusal::error(format!("sceneFile = {file}: {e}")))?
        };
        let values = self.values();
        for p in Settable::ALL.iter().copied().filter(|p| self.applies(*p)) {
            parameters::apply(p, &values, &mut scene).map_err(Refusal::error)?;
        }
        let torque = parameters::input_torque(scene.operation.input);
        if self.applies(torque) {
            scene.operation.input_torque_nm = self.real(torque.variable().value_reference());
        }
        Ok(scene)
    }

    /// The contact model: unworn, or with the flanks of the worn-profile
    /// state named by wearStateFile (a path, or a file in resources/ such as
    /// `wear/example-2004/kappa-2.json`), which must belong to this gear set.
    ///
    /// A state whose gear set differs only in kinds wearStateAccept names is
    /// taken, and what was accepted is returned as a warning. Also returns the
    /// file's bytes (none without a file), which key the steady cache.
    fn contact_model(
        &self,
        set: &crate::model::gear::GearSet,
    ) -> Result<(SetModel, Option<String>, Vec<u8>), Refusal> {
        use crate::wear::state::{parse_worn_state_accepting, StateFileError};
        let file = self.strings.get(&vr::WEAR_STATE_FILE).cloned().unwrap_or_default();
        let accept_text = self.strings.get(&vr::WEAR_STATE_ACCEPT).cloned().unwrap_or_default();
        let accept = crate::wear::state::StateDifference::parse_list(&accept_text)
            .map_err(|e| Refusal::error(format!("wearStateAccept = {accept_text}: {e}")))?;
        if file.is_empty() {
            return Ok((SetModel::new(set), None, Vec::new()));
        }
        let path = self.resolve(&file);
        let refused = |e: StateFileError| Refusal::error(format!("wearStateFile = {file}: {e}"));
        let bytes = crate::files::read_input(&path, crate::files::InputKind::WornState)
            .map_err(|e| refused(e.into()))?;
        let (state, accepted) = parse_worn_state_accepting(&path, &bytes, set, &accept).map_err(refused)?;
        let warning = (!accepted.is_empty()).then(|| {
            format!(
                "wearStateFile = {file}: {} (wearStateAccept = {accept_text})",
                crate::wear::state::describe_accepted(&accepted)
            )
        });
        Ok((state.set_model(set), warning, bytes))
    }

    /// The file a sceneFile or wearStateFile value names: an absolute path
    /// as it is; a relative one in the current working directory when it
    /// exists there, else in the FMU's resources/ directory.
    fn resolve(&self, file: &str) -> PathBuf {
        let path = PathBuf::from(file);
        match &self.resources {
            Some(r) if !path.is_absolute() && !path.exists() => r.join(file),
            _ => path,
        }
    }

    /// Warnings of the last build (an accepted wear-state difference), for
    /// the caller to log; taken, so each is said once.
    pub fn take_build_warnings(&mut self) -> Vec<String> {
        std::mem::take(&mut self.build_warnings)
    }

    /// A refused scene said in the importer's terms: each problem named by
    /// the variable that set it, with its value in the variable's unit, or
    /// by the scene file it came from.
    fn scene_refusal(&self, e: crate::scene::SceneError) -> Refusal {
        match e {
            crate::scene::SceneError::Invalid { problems } => {
                let file = self.strings.get(&vr::SCENE_FILE).cloned().unwrap_or_default();
                let values = self.values();
                // One variable that sets several scene keys (`module` sets
                // the three gears' modules) is named once, with each key.
                let mut merged: Vec<(String, Vec<String>)> = Vec::new();
                for p in &problems {
                    let line = parameters::describe_problem(p, &values, |s| self.applies(s), &file);
                    let (head, key) = match line.split_once(" (the scene's ") {
                        Some((head, key)) => (head.to_string(), Some(key.trim_end_matches(')').to_string())),
                        None => (line, None),
                    };
                    match merged.iter_mut().find(|(h, _)| *h == head) {
                        Some((_, keys)) => keys.extend(key),
                        None => merged.push((head, key.into_iter().collect())),
                    }
                }
                let lines: Vec<String> = merged
                    .into_iter()
                    .map(|(head, keys)| match keys.is_empty() {
                        true => format!("  - {head}"),
                        false => format!("  - {head} (the scene's {})", keys.join(", ")),
                    })
                    .collect();
                Refusal::error(format!("the parameters describe an invalid gear set:\n{}", lines.join("\n")))
            }
            other => Refusal::error(format!("the parameters describe an invalid gear set: {other}")),
        }
    }

    /// Builds the simulation from the parameters.
    fn build(&mut self) -> Result<(), Refusal> {
        let scene = self.scene()?;
        let (set, run) = scene.validate_with_run().map_err(|e| self.scene_refusal(e))?;
        if set.planet_angles().len() > 8 {
            return Err(Refusal::error(format!(
                "planets = {}: this FMU has outputs for at most 8 planets",
                set.planet_angles().len()
            )));
        }
        let (contact, warning, state) = self.contact_model(&set)?;
        let model = PlanetaryDynamics::new(&set, contact).map_err(|e| Refusal::error(e.to_string()))?;
        self.build_warnings = warning.into_iter().collect();
        // initialSpeed when it applies (always without a scene file), else
        // the scene file's dynamics.input_speed_rpm.
        let (speed, name) = if self.applies(Settable::InitialSpeed) {
            (self.real(vr::INITIAL_SPEED), "initialSpeed".to_string())
        } else {
            (
                run.input_speed(),
                format!(
                    "sceneFile = {}: the input speed",
                    self.strings.get(&vr::SCENE_FILE).cloned().unwrap_or_default()
                ),
            )
        };
        let mut sim = Simulation::new(&set, &run, model, self.start_time, speed).map_err(|e| {
            Refusal::error(format!("{name} = {speed} rad/s: the simulation cannot start: {e}"))
        })?;
        let cycles = usize::try_from(self.int(vr::HARMONIC_WINDOW_CYCLES)).unwrap_or(0);
        sim.set_window(cycles, run.samples_per_mesh_cycle()).map_err(|e| Refusal::error(e.to_string()))?;
        sim.record_duty(self.duty_bins(set.input_torque(), speed)?);
        if run.response() == crate::scene::Response::Steady {
            // The process's cache of this scene (its operating point aside) and worn state.
            let mut keyed = scene.clone();
            keyed.operation.input_torque_nm = 0.0;
            keyed.dynamics.input_speed = 0.0;
            let key = crate::files::hash::fnv1a64(
                format!(
                    "{}|{}",
                    keyed.to_toml(),
                    self.strings.get(&vr::WEAR_STATE_ACCEPT).cloned().unwrap_or_default()
                )
                .as_bytes(),
            ) ^ crate::files::hash::fnv1a64(&state).rotate_left(1);
            sim.use_steady(Some(key)).map_err(|e| {
                Refusal::error(format!(
                    "fidelity = {}: the steady response cannot start: {e}",
                    self.int(vr::FIDELITY)
                ))
            })?;
        }
        self.sim = Some(sim);
        self.built_from = self.build_key();
        self.push_inputs()
    }

    /// The load duty's bins from dutyTorqueEdges \[N·m\] and dutySpeedEdges \[rad/s\]; an empty
    /// one: that axis of [`DutyBins::around`] the input torque and the initial speed `speed`.
    fn duty_bins(&self, torque: f64, speed: f64) -> Result<DutyBins, Refusal> {
        let around = DutyBins::around(torque, speed);
        let axis = |v: u32, name: &'static str, default: &[f64]| {
            let text = self.strings.get(&v).map_or("", String::as_str);
            if text.trim().is_empty() {
                return Ok(default.to_vec());
            }
            parse_edges(name, text).map_err(|e| Refusal::error(e.to_string()))
        };
        let torque = axis(vr::DUTY_TORQUE_EDGES, "dutyTorqueEdges", around.torque_edges())?;
        let speed = axis(vr::DUTY_SPEED_EDGES, "dutySpeedEdges", around.speed_edges())?;
        DutyBins::new(torque, speed).map_err(|e| {
            Refusal::error(match e {
                DutyError::Edges { name: "speed_edges", value, allowed } => {
                    format!("dutySpeedEdges = {value}: {allowed}")
                }
                DutyError::Edges { value, allowed, .. } => format!("dutyTorqueEdges = {value}: {allowed}"),
                other => other.to_string(),
            })
        })
    }

    fn push_inputs(&mut self) -> Result<(), Refusal> {
        let (s, r, c, w) = (
            self.real(vr::SUN_TORQUE),
            self.real(vr::RING_TORQUE),
            self.real(vr::CARRIER_TORQUE),
            self.real(vr::INPUT_SPEED_REFERENCE),
        );
        if let Some(sim) = &mut self.sim {
            sim.set_torques(s, r, c).map_err(|e| Refusal::error(e.to_string()))?;
            sim.set_speed_reference(w).map_err(|e| Refusal::error(e.to_string()))?;
        }
        Ok(())
    }

    /// fmi2EnterInitializationMode.
    pub fn enter_initialization(&mut self) {
        self.phase = Phase::InitializationMode;
    }

    /// fmi2ExitInitializationMode: builds the simulation.
    pub fn exit_initialization(&mut self) -> Result<(), Refusal> {
        if self.sim.is_none() {
            self.build()?;
        }
        self.phase = Phase::StepComplete;
        Ok(())
    }

    fn check_set(&self, kind: Kind, v: u32) -> Result<Variable, Refusal> {
        let variable = Variable::from_value_reference(kind, v).ok_or_else(|| {
            Refusal::error(format!("value reference {v} is not a {kind:?} variable of this FMU"))
        })?;
        let info = variable.info();
        match (info.causality, self.phase) {
            (Causality::Output, _) => {
                Err(Refusal::error(format!("{} is an output and cannot be set", info.name)))
            }
            (Causality::Parameter, Phase::Instantiated | Phase::InitializationMode) => Ok(variable),
            (Causality::Parameter, phase) => Err(Refusal::error(format!(
                "{} is a fixed parameter and cannot be set in phase {phase:?}",
                info.name
            ))),
            (Causality::Input, _) => Ok(variable),
        }
    }

    fn changed(&mut self, v: u32) {
        self.explicitly_set.insert(v);
        if self.phase != Phase::StepComplete {
            // Parameters changed before the end of initialization: rebuild then.
            self.sim = None;
        }
    }

    fn store(&mut self, v: u32, value: Value) {
        match value {
            Value::Real(x) => {
                self.reals.insert(v, x);
            }
            Value::Integer(x) => {
                self.integers.insert(v, x);
            }
            Value::Boolean(x) => {
                self.booleans.insert(v, x);
            }
            Value::String(x) => {
                self.strings.insert(v, x);
            }
        }
    }

    /// Sets a variable [`Instance::check_set`] accepted: a parameter is
    /// stored (the simulation is rebuilt from it), an input is stored and,
    /// once the simulation exists, passed on to it.
    fn set(&mut self, variable: Variable, value: Value) -> Result<(), Refusal> {
        let v = variable.value_reference();
        match variable.info().causality {
            Causality::Parameter => {
                self.store(v, value);
                self.changed(v);
                Ok(())
            }
            Causality::Input => {
                self.store(v, value);
                if self.sim.is_some() {
                    self.explicitly_set.insert(v);
                    return self.push_inputs();
                }
                self.changed(v);
                Ok(())
            }
            Causality::Output => {
                Err(Refusal::error(format!("{} is an output and cannot be set", variable.name())))
            }
        }
    }

    /// fmi2SetReal for one variable.
    pub fn set_real(&mut self, v: u32, value: f64) -> Result<(), Refusal> {
        let variable = self.check_set(Kind::Real, v)?;
        if !value.is_finite() {
            return Err(Refusal::error(format!("{} = {value}: must be finite", variable.name())));
        }
        self.set(variable, Value::Real(value))
    }

    /// fmi2SetInteger for one variable.
    pub fn set_integer(&mut self, v: u32, value: i32) -> Result<(), Refusal> {
        let variable = self.check_set(Kind::Integer, v)?;
        self.set(variable, Value::Integer(value))
    }

    /// fmi2SetBoolean for one variable (this FMU has none).
    pub fn set_boolean(&mut self, v: u32, value: bool) -> Result<(), Refusal> {
        let variable = self.check_set(Kind::Boolean, v)?;
        self.set(variable, Value::Boolean(value))
    }

    /// fmi2SetString for one variable.
    pub fn set_string(&mut self, v: u32, value: &str) -> Result<(), Refusal> {
        let variable = self.check_set(Kind::String, v)?;
        self.set(variable, Value::String(value.to_string()))
    }

    fn sim(&mut self) -> Result<&Simulation, Refusal> {
        if self.sim.is_none() {
            self.build()?;
        }
        self.sim.as_ref().ok_or_else(|| Refusal::error("no simulation"))
    }

    /// The value of a variable: a parameter's or an input's as set, an
    /// output's read from the simulation (built first if need be).
    fn get(&mut self, variable: Variable) -> Result<Value, Refusal> {
        let v = variable.value_reference();
        let Some(reading) = variable.reading() else {
            return Ok(match variable.info().kind {
                Kind::Real => Value::Real(self.real(v)),
                Kind::Integer => Value::Integer(self.int(v)),
                Kind::Boolean => Value::Boolean(self.booleans.get(&v).copied().unwrap_or(false)),
                Kind::String => Value::String(self.strings.get(&v).cloned().unwrap_or_default()),
            });
        };
        let sim = self.sim()?;
        read(sim, reading)
    }

    /// The variable of a base type with a value reference; `a` is the
    /// article before the type's name in the refusal.
    fn lookup(kind: Kind, v: u32, a: &str) -> Result<Variable, Refusal> {
        Variable::from_value_reference(kind, v).ok_or_else(|| {
            Refusal::error(format!("value reference {v} is not {a} {kind:?} variable of this FMU"))
        })
    }

    /// fmi2GetReal for one variable. An output that is not finite (a state
    /// driven to overflow) is refused, never returned.
    pub fn get_real(&mut self, v: u32) -> Result<f64, Refusal> {
        let variable = Self::lookup(Kind::Real, v, "a")?;
        let Value::Real(x) = self.get(variable)? else {
            return Err(Refusal::error(format!("{} is not a Real variable", variable.name())));
        };
        if variable.info().causality == Causality::Output && !x.is_finite() {
            return Err(Refusal::error(format!(
                "{} = {x} is not finite: the simulation state has overflowed; reset or restore an earlier FMU state",
                variable.name()
            )));
        }
        Ok(x)
    }

    /// fmi2GetInteger for one variable.
    pub fn get_integer(&mut self, v: u32) -> Result<i32, Refusal> {
        let variable = Self::lookup(Kind::Integer, v, "an")?;
        let Value::Integer(x) = self.get(variable)? else {
            return Err(Refusal::error(format!("{} is not an Integer variable", variable.name())));
        };
        Ok(x)
    }

    /// fmi2GetBoolean for one variable (this FMU has none).
    pub fn get_boolean(&mut self, v: u32) -> Result<bool, Refusal> {
        let variable = Self::lookup(Kind::Boolean, v, "a")?;
        let Value::Boolean(x) = self.get(variable)? else {
            return Err(Refusal::error(format!("{} is not a Boolean variable", variable.name())));
        };
        Ok(x)
    }

    /// fmi2GetString for one variable.
    pub fn get_string(&mut self, v: u32) -> Result<String, Refusal> {
        let variable = Self::lookup(Kind::String, v, "a")?;
        let Value::String(x) = self.get(variable)? else {
            return Err(Refusal::error(format!("{} is not a String variable", variable.name())));
        };
        Ok(x)
    }

    /// fmi2DoStep.
    pub fn do_step(&mut self, t: f64, h: f64) -> Result<(), Refusal> {
        if let Some(stop) = self.stop_time {
            if t + h > stop * (1.0 + 1e-12) + 1e-12 {
                return Err(Refusal::error(format!(
                    "communicationStepSize = {h}: the step to {} passes the stop time {stop}",
                    t + h
                )));
            }
        }
        let torques = [self.real(vr::SUN_TORQUE), self.real(vr::RING_TORQUE), self.real(vr::CARRIER_TORQUE)];
        let sim = self
            .sim
            .as_mut()
            .ok_or_else(|| Refusal::error("no simulation: exit initialization mode first"))?;
        // The numerical guards (fmi/instance/guard.rs): a step that would overflow is
        // discarded at once, an overflowed state is never fmi2OK.
        let guarded = guard::before_step(sim, torques, h).map(|()| sim.do_step(t, h)).and_then(|r| match r {
            Ok(()) => guard::after_step(sim).map(|()| Ok(())),
            Err(e) => Ok(Err(e)),
        });
        let stepped = match guarded {
            Ok(r) => r,
            Err(why) => {
                // The step's start; a non-finite `t` (refused by the guard
                // before the step's own check) is not a time: where the
                // simulation stood.
                self.last_successful_time = if t.is_finite() { t } else { sim.time() };
                self.terminated = true;
                self.phase = Phase::StepFailed;
                return Err(Refusal {
                    status: Status::Discard,
                    message: format!("the step was discarded: {why}"),
                });
            }
        };
        match stepped {
            Ok(()) => {
                self.last_successful_time = sim.time();
                Ok(())
            }
            Err(crate::dynamics::simulation::SimulationError::InvalidInput { name, value, reason }) => {
                Err(Refusal::error(format!("{name} = {value}: {reason}")))
            }
            Err(e) => {
                self.last_successful_time = sim.time();
                self.terminated = true;
                self.phase = Phase::StepFailed;
                Err(Refusal { status: Status::Discard, message: format!("the step was discarded: {e}") })
            }
        }
    }

    /// The simulation, once built (for the plausibility warnings).
    pub fn simulation(&self) -> Option<&Simulation> {
        self.sim.as_ref()
    }

    /// fmi2Terminate.
    pub fn terminate(&mut self) {
        self.phase = Phase::Terminated;
    }

    /// fmi2GetFMUstate.
    pub fn save(&self) -> SavedState {
        SavedState {
            phase: self.phase,
            reals: self.reals.clone(),
            integers: self.integers.clone(),
            strings: self.strings.clone(),
            explicitly_set: self.explicitly_set.clone(),
            snapshot: self.sim.as_ref().map(Simulation::snapshot),
            terminated: self.terminated,
            last_successful_time: self.last_successful_time,
        }
    }

    /// fmi2SetFMUstate.
    pub fn restore(&mut self, s: &SavedState) -> Result<(), Refusal> {
        self.reals = s.reals.clone();
        self.integers = s.integers.clone();
        self.strings = s.strings.clone();
        self.explicitly_set = s.explicitly_set.clone();
        match &s.snapshot {
            Some(snap) => {
                // A simulation built from other parameters (the instance was
                // reset and set up again since the state was saved) is
                // rebuilt from the state's.
                if self.sim.is_none() || self.built_from != self.build_key() {
                    self.sim = None;
                    self.build()?;
                }
                if let Some(sim) = &mut self.sim {
                    sim.restore(snap).map_err(|e| {
                        Refusal::error(format!("the FMU state does not fit this instance: {e}"))
                    })?;
                }
            }
            None => self.sim = None,
        }
        self.phase = s.phase;
        self.terminated = s.terminated;
        self.last_successful_time = s.last_successful_time;
        Ok(())
    }

    /// The parameters a build reads: every value, and which ones the
    /// importer set (with a scene file only those override it). Inputs are
    /// left out: setting one between saving and restoring a state must not
    /// rebuild the simulation.
    fn build_key(&self) -> String {
        let set: Vec<&u32> = self
            .explicitly_set
            .iter()
            .filter(|v| VARIABLES.iter().any(|x| x.vr == **v && x.causality == Causality::Parameter))
            .collect();
        format!("{}|set: {set:?}", self.fingerprint())
    }

    /// Fingerprint of a serialized state: the GUID and every parameter value.
    fn fingerprint(&self) -> String {
        let mut f = GUID.to_string();
        for v in VARIABLES.iter().filter(|v| v.causality == Causality::Parameter) {
            let value = match v.kind {
                Kind::Real => format!("{:?}", self.real(v.vr)),
                Kind::Integer => self.int(v.vr).to_string(),
                Kind::Boolean => String::new(),
                Kind::String => self.strings.get(&v.vr).cloned().unwrap_or_default(),
            };
            f.push_str(&format!("|{}={value}", v.name));
        }
        f
    }

    /// fmi2SerializeFMUstate of a saved state.
    pub fn serialize(&self, s: &SavedState) -> Result<Vec<u8>, Refusal> {
        let snap = s
            .snapshot
            .as_ref()
            .ok_or_else(|| Refusal::error("the FMU state holds no simulation yet: initialize first"))?;
        Ok(state_format::encode(snap, &self.fingerprint()))
    }

    /// fmi2DeSerializeFMUstate into a saved state for this instance.
    pub fn deserialize(&mut self, bytes: &[u8]) -> Result<SavedState, Refusal> {
        let snap = state_format::decode(bytes, &self.fingerprint())
            .map_err(|e| Refusal::error(format!("cannot restore the FMU state: {e}")))?;
        let mut saved = self.save();
        saved.phase = Phase::StepComplete;
        saved.snapshot = Some(snap);
        saved.terminated = false;
        Ok(saved)
    }
}

/// The duty-cycle document of the load duty `sim` recorded (the dutyCycle output).
fn duty_document(sim: &Simulation) -> Result<String, Refusal> {
    let duty = sim.duty().ok_or_else(|| Refusal::error("dutyCycle: no load duty is recorded"))?;
    DutyCycle::new(sim.gear_set(), "fmu", duty.clone())
        .to_json()
        .map_err(|e| Refusal::error(format!("dutyCycle: {e}")))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::gear::Member;

    #[test]
    fn parameters_change_the_build_key_and_inputs_do_not() {
        // A restore rebuilds the simulation when the key differs: never for
        // an input (a sweep sets inputs between states), always for a
        // parameter (the simulation would not match the state's parameters).
        let mut i = Instance::new("key", None);
        let unset = i.build_key();
        i.set_real(vr::SUN_TORQUE, 500.0).unwrap();
        i.set_real(vr::INPUT_SPEED_REFERENCE, 400.0).unwrap();
        assert_eq!(i.build_key(), unset);
        i.set_real(vr::FACE_WIDTH, 0.02).unwrap();
        let narrower = i.build_key();
        assert_ne!(narrower, unset);
        // Setting a parameter to the value it had still counts: with a scene
        // file, only the parameters the importer set override it.
        let mut j = Instance::new("key", None);
        let width = j.real(vr::FACE_WIDTH);
        j.set_real(vr::FACE_WIDTH, width).unwrap();
        assert_ne!(j.build_key(), unset);
    }

    /// A validation problem reaches the importer named by the variable it
    /// set, with the value in the variable's unit, and every problem at once.
    #[test]
    fn a_refused_gear_set_names_the_variables_the_importer_set() {
        let mut i = Instance::new("names", None);
        i.enter_initialization();
        i.set_real(vr::SUN_TIP_RADIUS, -0.02).unwrap();
        i.set_real(vr::MODULE, 0.0).unwrap();
        let e = i.exit_initialization().unwrap_err();
        let m = e.message;
        assert!(m.contains("  - sun.tipRadius = -0.02 m: must be a finite number greater than zero"), "{m}");
        assert!(m.contains("(the scene's sun.tip_radius_mm = -20)"), "{m}");
        assert!(m.contains("  - module = 0 m: must be a finite number greater than zero"), "{m}");
        assert!(!m.contains("  - sun.tip_radius_mm"), "{m}");
        // `module` sets the three gears' modules: one line names it, with
        // the three scene keys.
        assert_eq!(m.matches("  - module = 0 m").count(), 1, "{m}");
        assert!(
            m.contains("(the scene's sun.module_mm = 0, planet.module_mm = 0, ring.module_mm = 0)"),
            "{m}"
        );
    }

    /// A refused initial speed is named by its variable, with its value and unit.
    #[test]
    fn a_refused_initial_speed_names_the_variable_and_its_value() {
        let mut i = Instance::new("speed", None);
        i.enter_initialization();
        i.set_real(vr::INITIAL_SPEED, 0.0).unwrap();
        let m = i.exit_initialization().unwrap_err().message;
        assert!(m.starts_with("initialSpeed = 0 rad/s: "), "{m}");
        assert!(m.contains("must be finite and non-zero"), "{m}");
    }

    /// The scene keys of every settable variable are keys of the scene: a
    /// key that no problem could ever carry would leave a refusal named by
    /// the scene instead of the variable.
    #[test]
    fn every_scene_key_of_a_variable_is_a_key_of_the_scene_file() {
        // The example with its derived defaults written out (chamfers,
        // masses), in the radii form and in the gear-data form.
        let docs: Vec<toml::Table> = [Scene::example_2004(), Scene::example_2004_gear_data()]
            .iter()
            .map(|s| toml::from_str(&s.explicit().unwrap().to_toml()).unwrap())
            .collect();
        let has = |key: &str| docs.iter().any(|doc| has_key(doc, key));
        fn has_key(doc: &toml::Table, key: &str) -> bool {
            let mut t = doc;
            let parts: Vec<&str> = key.split('.').collect();
            for (n, part) in parts.iter().enumerate() {
                match t.get(*part) {
                    Some(toml::Value::Table(inner)) if n + 1 < parts.len() => t = inner,
                    Some(_) if n + 1 == parts.len() => return true,
                    _ => return false,
                }
            }
            false
        }
        // Keys that are optional in a scene file: the planets' own angles
        // and bearing stiffnesses (the example spaces them equally, alike).
        // The load balance is written only when on; a tip diameter only
        // when the gear data give one (the example's planet has none); the
        // speed-driven member only when it is not the input member; the
        // response only when steady, the steady grid's keys only when not
        // their defaults; the damping model only when Rayleigh's, its
        // coefficients only when not 0.
        let optional = [
            "dynamics.damping",
            "dynamics.rayleigh_mass_per_s",
            "dynamics.rayleigh_stiffness_s",
            "planets.angles_deg",
            "supports.planet_bearings_n_per_m",
            "dynamics.load_balance",
            "planet.gear_data.tip_diameter_mm",
            "dynamics.speed_driven_member",
            "dynamics.response",
            "dynamics.steady_speed_step_rpm",
            "dynamics.steady_torque_step_nm",
            "dynamics.steady_agreement",
        ];
        for p in Settable::ALL {
            for key in p.scene_keys() {
                assert!(
                    has(key) || optional.contains(key),
                    "{}: scene key {key} is not in the scene file",
                    p.variable().name()
                );
            }
        }
    }

    /// The run-away: an unbalanced sun torque (1.5 times the
    /// default) with loadBalance 1 keeps the speed, and the new outputs are
    /// finite and in their relations; loadBalance 2 is refused by name.
    #[test]
    fn the_load_balance_and_the_step_outputs_through_the_fmu() {
        let mut i = Instance::new("balance", None);
        i.enter_initialization();
        i.set_integer(vr::FIDELITY, 0).unwrap();
        i.set_integer(vr::LOAD_BALANCE, 1).unwrap();
        i.exit_initialization().unwrap();
        let reference = i.get_real(vr::INPUT_SPEED_REFERENCE).unwrap();
        let sun = i.get_real(vr::SUN_TORQUE).unwrap();
        i.set_real(vr::SUN_TORQUE, 1.5 * sun).unwrap();
        let h = 1e-3;
        let mut angle = i.get_real(vr::SUN_ANGLE).unwrap();
        for k in 0..150 {
            i.do_step(k as f64 * h, h).unwrap();
            let a = i.get_real(vr::SUN_ANGLE).unwrap();
            let mean = (a - angle) / h;
            angle = a;
            assert!(mean > 0.9 * reference && mean < 1.5 * reference, "mean speed {mean} at step {k}");
            let (max, min, end) = (
                i.get_real(vr::PLANET_1_SUN_MESH_FORCE_MAX).unwrap(),
                i.get_real(vr::PLANET_1_SUN_MESH_FORCE_MIN).unwrap(),
                i.get_real(vr::PLANET_1_SUN_MESH_FORCE).unwrap(),
            );
            assert!(min <= end && end <= max && max <= i.get_real(vr::SUN_MESH_FORCE_MAX).unwrap());
        }
        assert!(i.get_real(vr::BALANCING_TORQUE).unwrap() > 0.0);
        assert!(i.get_real(vr::REACTION_TORQUE).unwrap() < 0.0);
        assert_eq!(i.get_integer(vr::PLANET_1_SUN_SEPARATED).unwrap(), 0);
        let mut j = Instance::new("bad", None);
        j.enter_initialization();
        j.set_integer(vr::LOAD_BALANCE, 2).unwrap();
        let e = j.exit_initialization().unwrap_err();
        assert!(e.message.contains("loadBalance = 2: allowed are 0"), "{}", e.message);
    }

    /// speedDrivenMember writes dynamics.speed_driven_member (-1, its start
    /// value, the input member); the held member and an unknown code are
    /// refused by the variable's name.
    #[test]
    fn the_speed_driven_member_maps_to_its_scene_key() {
        let i = Instance::new("driven", None);
        assert_eq!(i.int(vr::SPEED_DRIVEN_MEMBER), -1);
        assert_eq!(i.scene().unwrap().dynamics.speed_driven_member, None);
        for (code, member) in [(0, Member::Sun), (1, Member::Ring), (2, Member::Carrier)] {
            let mut j = Instance::new("driven", None);
            j.set_integer(vr::SPEED_DRIVEN_MEMBER, code).unwrap();
            assert_eq!(j.scene().unwrap().dynamics.speed_driven_member, Some(member));
        }
        let mut j = Instance::new("driven", None);
        j.set_integer(vr::SPEED_DRIVEN_MEMBER, 3).unwrap();
        let m = j.scene().unwrap_err().message;
        assert!(m.contains("speedDrivenMember = 3: allowed are 0 (sun), 1 (ring), 2 (carrier)"), "{m}");
        // The ring, speed-driven under the speed drive (the carrier held): accepted.
        let mut k = Instance::new("driven", None);
        k.enter_initialization();
        k.set_integer(vr::DRIVE_MODE, 1).unwrap();
        k.set_integer(vr::SPEED_DRIVEN_MEMBER, 1).unwrap();
        k.exit_initialization().unwrap();
        // The held carrier: refused, named by the variable.
        let mut h = Instance::new("driven", None);
        h.enter_initialization();
        h.set_integer(vr::DRIVE_MODE, 1).unwrap();
        h.set_integer(vr::SPEED_DRIVEN_MEMBER, 2).unwrap();
        let m = h.exit_initialization().unwrap_err().message;
        assert!(
            m.contains("speedDrivenMember") && m.contains("the held member (carrier) cannot be speed-driven"),
            "{m}"
        );
    }

    #[test]
    fn the_default_parameters_are_the_built_in_example() {
        // With no scene file every parameter applies: their start values
        // must describe the calibrated example exactly.
        let scene = Instance::new("key", None).scene().unwrap();
        let mut example = Scene::example_2004();
        // The FMU samples its outputs; the example's sampling is the CLI's.
        example.dynamics.samples_per_mesh_cycle = scene.dynamics.samples_per_mesh_cycle;
        let (a, b) = (scene.validate().unwrap(), example.validate().unwrap());
        // Everything but the last digit of the angles written to 15 digits.
        let close = |x: f64, y: f64| (x - y).abs() <= 1e-12 * y.abs().max(1e-300);
        assert_eq!(format!("{:?}", a.bodies()), format!("{:?}", b.bodies()));
        assert_eq!(format!("{:?}", a.supports()), format!("{:?}", b.supports()));
        assert_eq!(a.mesh_damping_ratio(), b.mesh_damping_ratio());
        assert_eq!((a.held(), a.input(), a.input_torque()), (b.held(), b.input(), b.input_torque()));
        for (x, y) in [(&a.sun(), &b.sun()), (&a.planet(), &b.planet()), (&a.ring(), &b.ring())] {
            assert!(close(x.pressure_angle, y.pressure_angle) && close(x.tooth_thickness, y.tooth_thickness));
            match (x.chamfer, y.chamfer) {
                (Some(c), Some(d)) => {
                    assert!(close(c.height, d.height) && close(c.angle, d.angle));
                    assert_eq!(c.edge_carries_load, d.edge_carries_load);
                }
                (None, None) => {}
                other => panic!("chamfers differ: {other:?}"),
            }
        }
    }
}

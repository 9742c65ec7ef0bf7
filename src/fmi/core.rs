//! The FMI 2.0 co-simulation calls in safe Rust: the component an importer
//! holds (the [`Instance`], its logger and logging settings, the strings it
//! lends out), the call-order table ([`allowed`]), the entry path every call
//! takes ([`Component::call`]: call order, panics caught as fmi2Fatal,
//! refusals mapped to their status and logged) and one function per fmi2*
//! call, taking its arguments as Rust values. The C boundary (`export.rs`)
//! turns the raw arguments into these values and does nothing else.

// bindgen's constant names (fmi2Status_fmi2OK, ...) are used as they are.
#![allow(non_upper_case_globals)]

use std::collections::{BTreeMap, BTreeSet};
use std::ffi::{CStr, CString};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::PathBuf;

use fmi_sys::fmi2::*;

use super::instance::warnings::{Inputs, Watch};
use super::instance::{Instance, Phase, Refusal, SavedState, Status};
use super::variables::{vr, GUID, LOG_CATEGORIES};

/// Every call the table knows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Call {
    /// fmi2SetDebugLogging.
    SetDebugLogging,
    /// fmi2FreeInstance.
    FreeInstance,
    /// fmi2SetupExperiment.
    SetupExperiment,
    /// fmi2EnterInitializationMode.
    EnterInitializationMode,
    /// fmi2ExitInitializationMode.
    ExitInitializationMode,
    /// fmi2Terminate.
    Terminate,
    /// fmi2Reset.
    Reset,
    /// fmi2GetReal, fmi2GetInteger, fmi2GetBoolean, fmi2GetString.
    Get,
    /// fmi2SetReal, fmi2SetInteger, fmi2SetBoolean, fmi2SetString.
    Set,
    /// The FMU-state functions.
    FmuState,
    /// fmi2GetDirectionalDerivative.
    DirectionalDerivative,
    /// fmi2SetRealInputDerivatives.
    SetRealInputDerivatives,
    /// fmi2GetRealOutputDerivatives.
    GetRealOutputDerivatives,
    /// fmi2DoStep.
    DoStep,
    /// fmi2CancelStep.
    CancelStep,
    /// The fmi2Get*Status functions.
    Status,
}

/// The FMI 2.0 co-simulation call-order table (FMI 2.0.x, section 4.2.4):
/// whether `call` is allowed in `phase`.
pub fn allowed(call: Call, phase: Phase) -> bool {
    use Phase::*;
    match call {
        Call::FreeInstance => true,
        Call::SetDebugLogging | Call::Reset | Call::FmuState => phase != Fatal,
        Call::SetupExperiment | Call::EnterInitializationMode => phase == Instantiated,
        Call::ExitInitializationMode => phase == InitializationMode,
        Call::Terminate => matches!(phase, StepComplete | StepFailed),
        Call::Get | Call::DirectionalDerivative => {
            matches!(phase, InitializationMode | StepComplete | StepFailed | Terminated | Error)
        }
        Call::Set | Call::SetRealInputDerivatives => {
            matches!(phase, Instantiated | InitializationMode | StepComplete)
        }
        Call::GetRealOutputDerivatives => matches!(phase, StepComplete | StepFailed | Terminated | Error),
        Call::DoStep => phase == StepComplete,
        Call::CancelStep => false,
        Call::Status => matches!(phase, StepComplete | StepFailed | Terminated),
    }
}

/// The importer's logger callback with its component environment: called
/// with the status, the instance name, the category and the message (passed
/// on as `"%s", message`).
pub type Logger = Box<dyn Fn(fmi2Status, &CStr, &CStr, &CStr)>;

/// One instance as the importer holds it (behind its fmi2Component).
pub struct Component {
    instance: Instance,
    logger: Option<Logger>,
    logging_on: bool,
    enabled: BTreeSet<&'static str>,
    name: CString,
    /// The strings of the last fmi2GetString, valid until the next one.
    strings: Vec<CString>,
    serialized: Vec<u8>,
    /// The FMU states this instance handed out, by the address the
    /// importer's fmi2FMUstate holds: the instance owns them, so a state is
    /// looked up here (never dereferenced from the importer's pointer), a
    /// freed or foreign pointer is refused, and fmi2FreeInstance frees every
    /// state still held.
    states: BTreeMap<usize, Box<SavedState>>,
    /// The plausibility conditions in force (fmi/instance/warnings.rs).
    watch: Watch,
    /// Warnings of the call under way: the call returns fmi2Warning and
    /// each is logged under logStatusWarning.
    warnings: Vec<String>,
}

fn category_of(status: Status) -> &'static str {
    match status {
        Status::Warning => "logStatusWarning",
        Status::Discard => "logStatusDiscard",
        Status::Error => "logStatusError",
        Status::Fatal => "logStatusFatal",
    }
}

/// Whether a log category carries a status (always logged) rather than
/// debug detail.
fn is_status_category(category: &str) -> bool {
    category.starts_with("logStatus")
}

fn code(status: Status) -> fmi2Status {
    match status {
        Status::Warning => fmi2Status_fmi2Warning,
        Status::Discard => fmi2Status_fmi2Discard,
        Status::Error => fmi2Status_fmi2Error,
        Status::Fatal => fmi2Status_fmi2Fatal,
    }
}

fn error(message: String) -> Refusal {
    Refusal { status: Status::Error, message }
}

/// The refusal of a NULL pointer given for `n` elements.
pub fn null_array(what: &str, n: usize) -> Refusal {
    error(format!("{what} is NULL with {n} elements"))
}

fn unsupported(what: &str) -> Result<(), Refusal> {
    Err(error(format!("{what} is not supported by this FMU (see modelDescription.xml capabilities)")))
}

/// Writes `v` to an out-argument, refusing a NULL one.
fn write_out<T>(out: Option<&mut T>, v: T, what: &str) -> Result<(), Refusal> {
    let out = out.ok_or_else(|| error(format!("{what} is NULL")))?;
    *out = v;
    Ok(())
}

/// fmi2Instantiate: a new component, or `None` (the reason logged) for a
/// missing or empty instance name, another FMU type, a GUID of another build
/// or a resource location that is not a `file:` URI; also `None` if building
/// it panics. The status messages reach the logger whatever `logging_on`
/// says; debug detail only with it true (or after fmi2SetDebugLogging).
pub fn instantiate(
    name: Option<String>,
    fmu_type: fmi2Type,
    guid: Option<String>,
    resource_location: Option<String>,
    logger: Option<Logger>,
    logging_on: bool,
) -> Option<Box<Component>> {
    catch_unwind(AssertUnwindSafe(|| {
        let name = name.unwrap_or_default();
        let mut comp = Box::new(Component {
            instance: Instance::new(if name.is_empty() { "?" } else { &name }, None),
            logger,
            logging_on: true,
            enabled: ["logStatusWarning", "logStatusDiscard", "logStatusError", "logStatusFatal"]
                .into_iter()
                .collect(),
            name: CString::new(if name.is_empty() { "?".to_string() } else { name.clone() })
                .unwrap_or_default(),
            strings: Vec::new(),
            serialized: Vec::new(),
            states: BTreeMap::new(),
            watch: Watch::default(),
            warnings: Vec::new(),
        });
        let refuse = |comp: &Component, why: String| {
            comp.log(fmi2Status_fmi2Error, "logStatusError", &format!("fmi2Instantiate: {why}"));
            None
        };
        if name.is_empty() {
            return refuse(&comp, "the instance name is missing or empty".into());
        }
        if fmu_type != fmi2Type_fmi2CoSimulation {
            return refuse(&comp, format!("fmuType {fmu_type}: this FMU implements co-simulation only"));
        }
        let guid = guid.unwrap_or_default();
        if guid != GUID {
            return refuse(&comp, format!("GUID {guid} does not match this FMU's {GUID}: the modelDescription.xml belongs to another build"));
        }
        let resources = match resource_location {
            None => None,
            Some(uri) => match resource_path(&uri) {
                Some(p) => Some(p),
                None => return refuse(&comp, format!("resource location {uri} is not a file: URI")),
            },
        };
        comp.instance = Instance::new(&name, resources);
        // Status messages always reach the logger; debug detail is quiet
        // by default: with loggingOn false none until fmi2SetDebugLogging,
        // with it true every category but the per-call trace.
        comp.logging_on = logging_on;
        comp.enabled = LOG_CATEGORIES.iter().map(|(n, _)| *n).filter(|n| *n != "logCalls").collect();
        Some(comp)
    }))
    .ok()
    .flatten()
}

/// fmi2FreeInstance: drops the component with every FMU state it still
/// holds (FMI 2.0: the instance frees all it allocated; a panic in doing so
/// is caught).
pub fn free_instance(comp: Option<Box<Component>>) {
    if let Some(comp) = comp {
        let _ = catch_unwind(AssertUnwindSafe(|| drop(comp)));
    }
}

/// fmi2GetTypesPlatform.
pub fn types_platform() -> &'static CStr {
    c"default"
}

/// fmi2GetVersion.
pub fn version() -> &'static CStr {
    c"2.0"
}

impl Component {
    /// Passes a message to the importer's logger. The status categories
    /// (`logStatus*`: every Warning, Discard, Error and Fatal the FMU
    /// returns) always reach it, whatever loggingOn and the enabled
    /// categories say (FMI 2.0 lets an FMU log status messages regardless):
    /// a refusal is never silent. The debug categories (`logCalls`,
    /// `logModel`) need loggingOn and the category enabled.
    fn log(&self, status: fmi2Status, category: &'static str, message: &str) {
        if !(is_status_category(category) || self.logging_on && self.enabled.contains(category)) {
            return;
        }
        let Some(logger) = &self.logger else { return };
        let text = CString::new(message.replace('\0', " ")).unwrap_or_default();
        let category = CString::new(category).unwrap_or_default();
        logger(status, &self.name, &category, &text);
    }

    /// The entry path of every call on a component: the call-order table
    /// (a forbidden call is fmi2Error, logged, and changes nothing), the
    /// per-call trace, then `f` with panics caught (fmi2Fatal, the phase
    /// Fatal); a refusal returns its status, moves the phase to Error or
    /// Fatal for those statuses and is logged under its category.
    pub fn call(
        &mut self,
        call: Call,
        name: &str,
        f: impl FnOnce(&mut Component) -> Result<(), Refusal>,
    ) -> fmi2Status {
        let phase = self.instance.phase;
        if !allowed(call, phase) {
            self.log(
                fmi2Status_fmi2Error,
                "logStatusError",
                &format!("{name} is not allowed in phase {phase:?}"),
            );
            return fmi2Status_fmi2Error;
        }
        self.log(fmi2Status_fmi2OK, "logCalls", name);
        self.warnings.clear();
        let result = catch_unwind(AssertUnwindSafe(|| f(self)));
        let warnings = std::mem::take(&mut self.warnings);
        for w in &warnings {
            self.log(fmi2Status_fmi2Warning, "logStatusWarning", &format!("{name}: {w}"));
        }
        match result {
            Ok(Ok(())) if !warnings.is_empty() => fmi2Status_fmi2Warning,
            Ok(Ok(())) => fmi2Status_fmi2OK,
            Ok(Err(refusal)) => {
                match refusal.status {
                    Status::Error => self.instance.phase = Phase::Error,
                    Status::Fatal => self.instance.phase = Phase::Fatal,
                    Status::Warning | Status::Discard => {}
                }
                self.log(
                    code(refusal.status),
                    category_of(refusal.status),
                    &format!("{name}: {}", refusal.message),
                );
                code(refusal.status)
            }
            Err(panic) => {
                let what = panic
                    .downcast_ref::<&str>()
                    .map(|s| s.to_string())
                    .or_else(|| panic.downcast_ref::<String>().cloned())
                    .unwrap_or_else(|| "unknown panic".into());
                self.instance.phase = Phase::Fatal;
                self.log(fmi2Status_fmi2Fatal, "logStatusFatal", &format!("{name}: internal error: {what}"));
                fmi2Status_fmi2Fatal
            }
        }
    }

    /// fmi2SetDebugLogging: with no categories every declared one is
    /// enabled. Every name is checked before anything changes: a call naming
    /// an undeclared category (or a NULL name) is a warning and leaves the
    /// settings as they were. The categories filter the debug detail only:
    /// status messages (`logStatus*`) are logged whatever is enabled.
    pub fn set_debug_logging(
        &mut self,
        logging_on: bool,
        categories: &[Option<String>],
    ) -> Result<(), Refusal> {
        let mut enabled = BTreeSet::new();
        for wanted in categories {
            let wanted = wanted.as_deref().unwrap_or_default();
            match LOG_CATEGORIES.iter().find(|(n, _)| *n == wanted) {
                Some((n, _)) => {
                    enabled.insert(*n);
                }
                None => {
                    return Err(Refusal {
                        status: Status::Warning,
                        message: format!(
                            "log category '{wanted}' is not declared in <LogCategories> (declared: {}); the logging settings are unchanged",
                            LOG_CATEGORIES.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", ")
                        ),
                    });
                }
            }
        }
        self.logging_on = logging_on;
        self.enabled =
            if categories.is_empty() { LOG_CATEGORIES.iter().map(|(n, _)| *n).collect() } else { enabled };
        Ok(())
    }

    /// fmi2SetupExperiment (the tolerance is not used).
    pub fn setup_experiment(&mut self, start: f64, stop: Option<f64>) -> Result<(), Refusal> {
        self.instance.setup_experiment(start, stop)
    }

    /// fmi2EnterInitializationMode.
    pub fn enter_initialization_mode(&mut self) -> Result<(), Refusal> {
        self.instance.enter_initialization();
        Ok(())
    }

    /// fmi2ExitInitializationMode: builds the simulation; an initial speed
    /// past the overspeed limit is a warning (fmi/instance/warnings.rs).
    pub fn exit_initialization_mode(&mut self) -> Result<(), Refusal> {
        self.instance.exit_initialization()?;
        let initial_speed = self.instance.get_real(vr::INITIAL_SPEED)?;
        self.warnings = self.instance.take_build_warnings();
        if let Some(sim) = self.instance.simulation() {
            self.warnings.extend(self.watch.at_start(sim, initial_speed));
        }
        Ok(())
    }

    /// fmi2Terminate.
    pub fn terminate(&mut self) -> Result<(), Refusal> {
        self.instance.terminate();
        Ok(())
    }

    /// fmi2Reset.
    pub fn reset(&mut self) -> Result<(), Refusal> {
        self.instance.reset();
        self.watch = Watch::default();
        Ok(())
    }

    /// fmi2GetReal: one value per reference, stopping at the first refused.
    pub fn get_real(&mut self, refs: &[fmi2ValueReference], out: &mut [fmi2Real]) -> Result<(), Refusal> {
        for (r, o) in refs.iter().zip(out.iter_mut()) {
            *o = self.instance.get_real(*r)?;
        }
        Ok(())
    }

    /// fmi2GetInteger, as [`Component::get_real`].
    pub fn get_integer(
        &mut self,
        refs: &[fmi2ValueReference],
        out: &mut [fmi2Integer],
    ) -> Result<(), Refusal> {
        for (r, o) in refs.iter().zip(out.iter_mut()) {
            *o = self.instance.get_integer(*r)?;
        }
        Ok(())
    }

    /// fmi2GetBoolean, as [`Component::get_real`].
    pub fn get_boolean(
        &mut self,
        refs: &[fmi2ValueReference],
        out: &mut [fmi2Boolean],
    ) -> Result<(), Refusal> {
        for (r, o) in refs.iter().zip(out.iter_mut()) {
            *o = fmi2Boolean::from(self.instance.get_boolean(*r)?);
        }
        Ok(())
    }

    /// fmi2GetString: every value is read before any is handed out; the
    /// strings stay valid until the next fmi2GetString on this component.
    pub fn get_string(&mut self, refs: &[fmi2ValueReference], out: &mut [fmi2String]) -> Result<(), Refusal> {
        self.strings.clear();
        for r in refs {
            let s = self.instance.get_string(*r)?;
            self.strings.push(CString::new(s.replace('\0', " ")).unwrap_or_default());
        }
        for (o, s) in out.iter_mut().zip(&self.strings) {
            *o = s.as_ptr();
        }
        Ok(())
    }

    /// fmi2SetReal: one value per reference, stopping at the first refused.
    pub fn set_real(&mut self, refs: &[fmi2ValueReference], values: &[fmi2Real]) -> Result<(), Refusal> {
        for (r, v) in refs.iter().zip(values) {
            self.instance.set_real(*r, *v)?;
        }
        Ok(())
    }

    /// fmi2SetInteger, as [`Component::set_real`].
    pub fn set_integer(
        &mut self,
        refs: &[fmi2ValueReference],
        values: &[fmi2Integer],
    ) -> Result<(), Refusal> {
        for (r, v) in refs.iter().zip(values) {
            self.instance.set_integer(*r, *v)?;
        }
        Ok(())
    }

    /// fmi2SetBoolean, as [`Component::set_real`] (any non-zero value is true).
    pub fn set_boolean(
        &mut self,
        refs: &[fmi2ValueReference],
        values: &[fmi2Boolean],
    ) -> Result<(), Refusal> {
        for (r, v) in refs.iter().zip(values) {
            self.instance.set_boolean(*r, *v != 0)?;
        }
        Ok(())
    }

    /// fmi2SetString, as [`Component::set_real`]; a NULL string is refused.
    pub fn set_string(
        &mut self,
        refs: &[fmi2ValueReference],
        values: &[Option<String>],
    ) -> Result<(), Refusal> {
        for (r, v) in refs.iter().zip(values) {
            let s = v.as_deref().ok_or_else(|| error(format!("value for reference {r} is NULL")))?;
            self.instance.set_string(*r, s)?;
        }
        Ok(())
    }

    /// fmi2GetDirectionalDerivative: not supported.
    pub fn directional_derivative(&mut self) -> Result<(), Refusal> {
        unsupported("fmi2GetDirectionalDerivative")
    }

    /// fmi2SetRealInputDerivatives: not supported.
    pub fn set_real_input_derivatives(&mut self) -> Result<(), Refusal> {
        unsupported("interpolating inputs")
    }

    /// fmi2GetRealOutputDerivatives: not supported.
    pub fn real_output_derivatives(&mut self) -> Result<(), Refusal> {
        unsupported("output derivatives")
    }

    /// fmi2DoStep; a completed step whose state sets off a plausibility
    /// condition (fmi/instance/warnings.rs) returns fmi2Warning.
    pub fn do_step(&mut self, t: f64, h: f64) -> Result<(), Refusal> {
        self.instance.do_step(t, h)?;
        let inputs = Inputs {
            torques: [
                self.instance.get_real(vr::SUN_TORQUE)?,
                self.instance.get_real(vr::RING_TORQUE)?,
                self.instance.get_real(vr::CARRIER_TORQUE)?,
            ],
            speed_reference: self.instance.get_real(vr::INPUT_SPEED_REFERENCE)?,
        };
        if let Some(sim) = self.instance.simulation() {
            self.warnings = self.watch.after_step(sim, inputs);
        }
        Ok(())
    }

    /// fmi2CancelStep: not supported (steps are never asynchronous).
    pub fn cancel_step(&mut self) -> Result<(), Refusal> {
        unsupported("asynchronous steps")
    }

    /// fmi2GetStatus: fmi2DoStepStatus only (Discard once terminated).
    pub fn status(&mut self, kind: fmi2StatusKind, out: Option<&mut fmi2Status>) -> Result<(), Refusal> {
        match kind {
            fmi2StatusKind_fmi2DoStepStatus => {
                let st = if self.instance.terminated { fmi2Status_fmi2Discard } else { fmi2Status_fmi2OK };
                write_out(out, st, "value")
            }
            _ => Err(Refusal {
                status: Status::Discard,
                message: format!("status kind {kind} is not available from fmi2GetStatus"),
            }),
        }
    }

    /// fmi2GetRealStatus: fmi2LastSuccessfulTime only.
    pub fn real_status(&mut self, kind: fmi2StatusKind, out: Option<&mut fmi2Real>) -> Result<(), Refusal> {
        match kind {
            fmi2StatusKind_fmi2LastSuccessfulTime => {
                write_out(out, self.instance.last_successful_time, "value")
            }
            _ => Err(Refusal {
                status: Status::Discard,
                message: format!("status kind {kind} is not a Real status"),
            }),
        }
    }

    /// fmi2GetIntegerStatus: no kind is an Integer status.
    pub fn integer_status(&mut self, kind: fmi2StatusKind) -> Result<(), Refusal> {
        Err(Refusal {
            status: Status::Discard,
            message: format!("status kind {kind} is not an Integer status"),
        })
    }

    /// fmi2GetBooleanStatus: fmi2Terminated only.
    pub fn boolean_status(
        &mut self,
        kind: fmi2StatusKind,
        out: Option<&mut fmi2Boolean>,
    ) -> Result<(), Refusal> {
        match kind {
            fmi2StatusKind_fmi2Terminated => {
                write_out(out, fmi2Boolean::from(self.instance.terminated), "value")
            }
            _ => Err(Refusal {
                status: Status::Discard,
                message: format!("status kind {kind} is not a Boolean status"),
            }),
        }
    }

    /// fmi2GetStringStatus: no kind is a String status.
    pub fn string_status(&mut self, kind: fmi2StatusKind) -> Result<(), Refusal> {
        Err(Refusal {
            status: Status::Discard,
            message: format!("status kind {kind} is not a String status"),
        })
    }

    /// The address an FMUstate pointer holds (what the instance's table is
    /// keyed by).
    fn key(state: fmi2FMUstate) -> usize {
        state as usize
    }

    /// The state behind a pointer the importer holds: one this instance
    /// handed out and has not freed; NULL, a freed state or another
    /// instance's is refused.
    fn held(&self, state: fmi2FMUstate) -> Result<&SavedState, Refusal> {
        if state.is_null() {
            return Err(error("FMUstate is NULL".into()));
        }
        self.states.get(&Self::key(state)).map(|b| &**b).ok_or_else(|| {
            error(format!(
                "FMUstate {state:p} is not a state of this instance (freed, or from another instance); \
                 it holds {} states",
                self.states.len()
            ))
        })
    }

    /// Stores `saved` in the importer's handle: in place when the handle
    /// holds a state of this instance (the importer's pointer stays the
    /// same), else as a new state the instance keeps until it is freed.
    fn store(&mut self, handle: &mut fmi2FMUstate, saved: SavedState) -> Result<(), Refusal> {
        if handle.is_null() {
            let boxed = Box::new(saved);
            let key = &*boxed as *const SavedState as usize;
            self.states.insert(key, boxed);
            *handle = key as fmi2FMUstate;
            return Ok(());
        }
        let held = handle.to_owned();
        match self.states.get_mut(&Self::key(held)) {
            Some(b) => {
                **b = saved;
                Ok(())
            }
            None => Err(error(format!(
                "FMUstate {held:p} is not a state of this instance (freed, or from another instance): \
                 pass a handle holding NULL for a new state"
            ))),
        }
    }

    /// The number of FMU states the instance holds (handed out, not freed).
    pub fn held_states(&self) -> usize {
        self.states.len()
    }

    /// fmi2GetFMUstate: the current state into the handle, overwriting in
    /// place the state an occupied handle holds; a NULL handle is refused.
    pub fn get_fmu_state(&mut self, handle: Option<&mut fmi2FMUstate>) -> Result<(), Refusal> {
        let handle = handle.ok_or_else(|| error("FMUstate is NULL".into()))?;
        let saved = self.instance.save();
        self.store(handle, saved)
    }

    /// fmi2SetFMUstate.
    pub fn set_fmu_state(&mut self, state: fmi2FMUstate) -> Result<(), Refusal> {
        let s = self.held(state)?.clone();
        self.instance.restore(&s)?;
        self.watch.forget(self.instance.last_successful_time);
        Ok(())
    }

    /// fmi2FreeFMUstate: frees the state a handle holds and sets the handle
    /// to NULL; a NULL handle, or one holding NULL, is no error.
    pub fn free_fmu_state(&mut self, handle: Option<&mut fmi2FMUstate>) -> Result<(), Refusal> {
        let Some(handle) = handle else { return Ok(()) };
        if handle.is_null() {
            return Ok(());
        }
        self.held(*handle)?;
        self.states.remove(&Self::key(*handle));
        *handle = std::ptr::null_mut();
        Ok(())
    }

    /// fmi2SerializedFMUstateSize: the size of the state's bytes.
    pub fn serialized_fmu_state_size(
        &mut self,
        state: fmi2FMUstate,
        size: Option<&mut usize>,
    ) -> Result<(), Refusal> {
        let bytes = self.instance.serialize(self.held(state)?)?;
        write_out(size, bytes.len(), "size")?;
        self.serialized = bytes;
        Ok(())
    }

    /// fmi2SerializeFMUstate: the state's bytes into the importer's buffer
    /// of `size` bytes (`buffer` is `None` for a NULL pointer).
    pub fn serialize_fmu_state(
        &mut self,
        state: fmi2FMUstate,
        size: usize,
        buffer: Option<&mut [u8]>,
    ) -> Result<(), Refusal> {
        let data = self.instance.serialize(self.held(state)?)?;
        if size < data.len() {
            return Err(error(format!("size {size} is smaller than the state's {} bytes", data.len())));
        }
        match buffer {
            Some(out) => out[..data.len()].copy_from_slice(&data),
            None if data.is_empty() => {}
            None => return Err(null_array("serializedState", data.len())),
        }
        Ok(())
    }

    /// fmi2DeSerializeFMUstate: the state of `bytes` into the handle, an
    /// occupied handle overwritten in place (so the importer's handle stays
    /// the one it holds); a NULL handle is refused before the bytes are
    /// looked at. `bytes` is the boundary's refusal of a NULL pointer with
    /// a non-zero size.
    pub fn deserialize_fmu_state(
        &mut self,
        bytes: Result<&[u8], Refusal>,
        handle: Option<&mut fmi2FMUstate>,
    ) -> Result<(), Refusal> {
        let handle = handle.ok_or_else(|| error("FMUstate is NULL".into()))?;
        let s = self.instance.deserialize(bytes?)?;
        self.store(handle, s)
    }
}

/// Converts an FMU resource location URI to a directory: `file:///abs/path`,
/// `file:/abs/path` or `file://localhost/abs/path`, with or without a
/// trailing slash, percent-encoded characters decoded.
pub fn resource_path(uri: &str) -> Option<PathBuf> {
    let rest = uri.strip_prefix("file:")?;
    let path = if let Some(r) = rest.strip_prefix("//") {
        let r = r.strip_prefix("localhost").unwrap_or(r);
        if !r.starts_with('/') {
            return None;
        }
        r
    } else {
        rest
    };
    if !path.starts_with('/') {
        return None;
    }
    let bytes = path.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' && i + 2 < bytes.len() {
            let hex = std::str::from_utf8(&bytes[i + 1..i + 3]).ok()?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    let s = String::from_utf8(out).ok()?;
    let trimmed = if s.len() > 1 { s.trim_end_matches('/') } else { &s };
    Some(PathBuf::from(trimmed))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn instance() -> Box<Component> {
        instantiate(Some("unit".into()), fmi2Type_fmi2CoSimulation, Some(GUID.into()), None, None, false)
            .expect("instantiated")
    }

    type Log = std::rc::Rc<std::cell::RefCell<Vec<(fmi2Status, String, String)>>>;

    /// An instance with logging off whose logger keeps (status, category,
    /// message) of every message.
    fn logged() -> (Box<Component>, Log) {
        let log: Log = Default::default();
        let keep = log.clone();
        let logger: Logger = Box::new(move |status, _name, category, message| {
            keep.borrow_mut().push((
                status,
                category.to_string_lossy().into_owned(),
                message.to_string_lossy().into_owned(),
            ))
        });
        let c = instantiate(
            Some("log".into()),
            fmi2Type_fmi2CoSimulation,
            Some(GUID.into()),
            None,
            Some(logger),
            false,
        )
        .expect("instantiated");
        (c, log)
    }

    fn initialize(c: &mut Component, reals: &[(u32, f64)]) -> fmi2Status {
        let (refs, values): (Vec<u32>, Vec<f64>) = reals.iter().copied().unzip();
        assert_eq!(c.call(Call::Set, "fmi2SetReal", |c| c.set_real(&refs, &values)), fmi2Status_fmi2OK);
        assert_eq!(
            c.call(Call::SetupExperiment, "fmi2SetupExperiment", |c| c.setup_experiment(0.0, None)),
            0
        );
        let enter = c.call(Call::EnterInitializationMode, "fmi2EnterInitializationMode", |c| {
            c.enter_initialization_mode()
        });
        assert_eq!(enter, fmi2Status_fmi2OK);
        c.call(Call::ExitInitializationMode, "fmi2ExitInitializationMode", |c| c.exit_initialization_mode())
    }

    /// Steps of `h` from t = 0 to `stop`: the statuses returned and the
    /// warnings logged, with the time of each.
    fn steps(c: &mut Component, log: &Log, h: f64, stop: f64) -> Vec<(f64, String)> {
        let mut warned = Vec::new();
        let n = (stop / h).round() as usize;
        for k in 0..n {
            let before = log.borrow().len();
            let status = c.call(Call::DoStep, "fmi2DoStep", |c| c.do_step(k as f64 * h, h));
            let new: Vec<_> = log.borrow()[before..].to_vec();
            assert!(status == fmi2Status_fmi2OK || status == fmi2Status_fmi2Warning, "{status}: {new:?}");
            assert_eq!(status == fmi2Status_fmi2Warning, !new.is_empty(), "{new:?}");
            for (st, cat, m) in new {
                assert_eq!((st, cat.as_str()), (fmi2Status_fmi2Warning, "logStatusWarning"), "{m}");
                warned.push(((k + 1) as f64 * h, m));
            }
        }
        warned
    }

    #[test]
    fn with_logging_off_a_refusal_reaches_the_logger_and_debug_detail_does_not() {
        let (mut c, log) = logged();
        let status = initialize(&mut c, &[(vr::MODULE, -0.0015)]);
        assert_eq!(status, fmi2Status_fmi2Error);
        let log = log.borrow();
        assert_eq!(log.len(), 1, "{log:?}");
        let (st, cat, m) = &log[0];
        assert_eq!((*st, cat.as_str()), (fmi2Status_fmi2Error, "logStatusError"));
        assert!(m.starts_with("fmi2ExitInitializationMode: "), "{m}");
        assert!(m.contains("module = -0.0015 m: must be a finite number greater than zero"), "{m}");
    }

    #[test]
    fn enabled_categories_filter_debug_detail_and_never_a_status() {
        let (mut c, log) = logged();
        // Only the per-call trace enabled: the Error is logged all the same.
        let names = [Some("logCalls".to_string())];
        assert_eq!(
            c.call(Call::SetDebugLogging, "fmi2SetDebugLogging", |c| c.set_debug_logging(true, &names)),
            0
        );
        let status = c.call(Call::Set, "fmi2SetReal", |c| c.set_real(&[vr::SUN_SPEED], &[1.0]));
        assert_eq!(status, fmi2Status_fmi2Error);
        let cats: Vec<String> = log.borrow().iter().map(|(_, c, _)| c.clone()).collect();
        // (fmi2SetDebugLogging itself ran with logging off: no trace of it.)
        assert_eq!(cats, ["logCalls", "logStatusError"]);
        assert!(log.borrow()[1].2.contains("sun.speed is an output and cannot be set"), "{:?}", log.borrow());
        // Logging off: the trace stops, the statuses do not.
        assert_eq!(
            c.call(Call::SetDebugLogging, "fmi2SetDebugLogging", |c| c.set_debug_logging(false, &names)),
            0
        );
        log.borrow_mut().clear();
        c.call(Call::Reset, "fmi2Reset", Component::reset);
        assert_eq!(c.call(Call::DoStep, "fmi2DoStep", |c| c.do_step(0.0, 1e-3)), fmi2Status_fmi2Error);
        let log = log.borrow();
        assert_eq!(log.len(), 1, "{log:?}");
        assert_eq!(log[0].1, "logStatusError");
        assert!(log[0].2.contains("fmi2DoStep is not allowed in phase Instantiated"), "{log:?}");
    }

    #[test]
    fn the_default_run_warns_of_nothing() {
        let (mut c, log) = logged();
        assert_eq!(initialize(&mut c, &[]), fmi2Status_fmi2OK);
        assert_eq!(steps(&mut c, &log, 1e-3, 0.03), []);
    }

    #[test]
    fn unbalanced_torques_warn_once_of_the_run_away() {
        let (mut c, log) = logged();
        assert_eq!(initialize(&mut c, &[(vr::SUN_TORQUE, 300.0)]), fmi2Status_fmi2OK);
        let warned = steps(&mut c, &log, 1e-3, 0.05);
        let runaway: Vec<_> = warned.iter().filter(|(_, m)| m.contains("run-away")).collect();
        assert_eq!(runaway.len(), 1, "{warned:?}");
        let (t, m) = runaway[0];
        assert_eq!(*t, 1e-3, "{m}");
        assert!(m.contains("sunTorque = 300 N·m"), "{m}");
        assert!(m.contains("net torque of -450.0000 N·m"), "{m}");
        assert!(m.contains("changed the sun's speed by -942.4 rpm from the 3000.0 rpm"), "{m}");
        // The sun then runs past the overspeed limit: said once too.
        let over: Vec<_> = warned.iter().filter(|(_, m)| m.contains("overspeed")).collect();
        assert_eq!(over.len(), 1, "{warned:?}");
        // Running away through the speeds, the meshes start to separate:
        // each onset said once, with the figure over the window.
        let sep = |mesh: &str| -> Vec<&(f64, String)> {
            warned
                .iter()
                .filter(|(_, m)| m.contains(&format!("tooth separation: planet 1's {mesh}")))
                .collect()
        };
        let (sun, ring) = (sep("sun_planet"), sep("ring_planet"));
        assert!(!sun.is_empty() && !ring.is_empty(), "{warned:?}");
        assert!(sun[0].0 > over[0].0 && sun[0].1.contains("above the threshold of 5 %"), "{warned:?}");
        // 50 steps, of which the meshes separate in most after the onset:
        // the onsets are few.
        assert!(sun.len() <= 3 && ring.len() <= 3, "{warned:?}");
    }

    /// With the load balance on, the output's torque is the one that keeps
    /// its mean speed: the same unbalanced input runs nowhere and is not
    /// called a run-away.
    #[test]
    fn the_load_balance_keeps_unbalanced_torques_from_being_called_a_run_away() {
        let (mut c, log) = logged();
        assert_eq!(
            c.call(Call::Set, "fmi2SetInteger", |c| c.set_integer(&[vr::LOAD_BALANCE], &[1])),
            fmi2Status_fmi2OK
        );
        assert_eq!(initialize(&mut c, &[(vr::SUN_TORQUE, 1125.0)]), fmi2Status_fmi2OK);
        let warned = steps(&mut c, &log, 1e-3, 0.05);
        assert!(warned.iter().all(|(_, m)| !m.contains("run-away")), "{warned:?}");
    }

    /// A worn-profile state of another material, accepted through
    /// wearStateAccept, is logged once as a logStatusWarning naming what
    /// differs; without wearStateAccept it is refused.
    #[test]
    fn an_accepted_wear_state_difference_is_a_logged_warning() {
        let set = crate::scene::Scene::example_2004().validate().unwrap();
        let state = crate::wear::state::WornState::unworn(&set, 20, 1);
        let dir = std::env::temp_dir().join(format!("planetwear-accept-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("kappa-0.json");
        crate::wear::state::write_worn_state(&path, &state).unwrap();
        let file = Some(path.display().to_string());
        for accept in ["", "material"] {
            let (mut c, log) = logged();
            let refs = [vr::WEAR_STATE_FILE, vr::WEAR_STATE_ACCEPT];
            let set = c.call(Call::Set, "fmi2SetString", |c| {
                c.set_string(&refs, &[file.clone(), Some(accept.into())])
            });
            assert_eq!(set, fmi2Status_fmi2OK);
            let status = initialize(&mut c, &[(vr::YOUNGS_MODULUS, 2.1e11)]);
            let log = log.borrow().clone();
            if accept.is_empty() {
                assert_eq!(status, fmi2Status_fmi2Error, "{log:?}");
                assert!(
                    log.iter().any(|(_, _, m)| m.contains(
                        "material.youngs_modulus is 207000000000 in the state and 210000000000 here"
                    )),
                    "{log:?}"
                );
            } else {
                assert_eq!(status, fmi2Status_fmi2Warning, "{log:?}");
                let warned: Vec<_> = log.iter().filter(|(_, cat, _)| cat == "logStatusWarning").collect();
                assert_eq!(warned.len(), 1, "{log:?}");
                assert!(
                    warned[0].2.contains("accepted a worn-profile state whose gear set differs in material"),
                    "{log:?}"
                );
                assert!(warned[0].2.contains("(wearStateAccept = material)"), "{log:?}");
            }
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn an_initial_speed_given_in_rpm_warns_at_initialization_and_not_again() {
        let (mut c, log) = logged();
        assert_eq!(initialize(&mut c, &[(vr::INITIAL_SPEED, 3000.0)]), fmi2Status_fmi2Warning);
        let first = log.borrow().clone();
        assert_eq!(first.len(), 1);
        assert_eq!(first[0].1, "logStatusWarning");
        assert!(first[0].2.contains("initialSpeed = 3000 rad/s"), "{first:?}");
        assert!(first[0].2.contains("give initialSpeed = 314.159"), "{first:?}");
        let warned = steps(&mut c, &log, 1e-4, 2e-3);
        assert!(warned.iter().all(|(_, m)| !m.contains("overspeed")), "{warned:?}");
    }

    #[test]
    fn a_torque_past_the_allowable_pressure_warns_once() {
        let (mut c, log) = logged();
        let scale = 4.0;
        let set = crate::scene::Scene::example_2004().validate().unwrap();
        let [s, r, _] = set.balanced_torques();
        let status = initialize(&mut c, &[(vr::SUN_TORQUE, scale * s), (vr::RING_TORQUE, scale * r)]);
        assert_eq!(status, fmi2Status_fmi2OK);
        let warned = steps(&mut c, &log, 1e-3, 0.02);
        let pressure: Vec<_> = warned.iter().filter(|(_, m)| m.contains("contact pressure")).collect();
        assert!(!pressure.is_empty() && pressure.len() <= 2, "{warned:?}");
        assert!(pressure.iter().all(|(_, m)| m.contains("above the static limit of 2400 MPa")), "{warned:?}");
    }

    #[test]
    fn an_undeclared_log_category_is_a_warning_and_changes_no_setting() {
        let mut c = instance();
        let before = c.enabled.clone();
        let names = [Some("logCalls".to_string()), Some("logNothing".to_string())];
        let status =
            c.call(Call::SetDebugLogging, "fmi2SetDebugLogging", |c| c.set_debug_logging(true, &names));
        assert_eq!(status, fmi2Status_fmi2Warning);
        assert!(!c.logging_on, "instantiated with logging off, and still off");
        assert_eq!(c.enabled, before);
        let names = [Some("logCalls".to_string()), Some("logStatusError".to_string())];
        let status =
            c.call(Call::SetDebugLogging, "fmi2SetDebugLogging", |c| c.set_debug_logging(true, &names));
        assert_eq!(status, fmi2Status_fmi2OK);
        assert!(c.logging_on);
        assert_eq!(c.enabled, ["logCalls", "logStatusError"].into_iter().collect());
    }

    #[test]
    fn a_panic_inside_a_call_is_answered_with_fatal_and_only_free_is_allowed_after() {
        let mut c = instance();
        assert_eq!(c.call(Call::SetupExperiment, "test", |_| panic!("forced")), fmi2Status_fmi2Fatal);
        assert_eq!(c.call(Call::Reset, "fmi2Reset", Component::reset), fmi2Status_fmi2Error);
        assert!(allowed(Call::FreeInstance, c.instance.phase));
    }

    #[test]
    fn resource_locations_in_every_legal_form() {
        for uri in [
            "file:///tmp/fmu/resources",
            "file:///tmp/fmu/resources/",
            "file:/tmp/fmu/resources",
            "file://localhost/tmp/fmu/resources/",
        ] {
            assert_eq!(resource_path(uri), Some(PathBuf::from("/tmp/fmu/resources")), "{uri}");
        }
        assert_eq!(resource_path("file:///tmp/a%20b/res%2Fx"), Some(PathBuf::from("/tmp/a b/res/x")));
        assert_eq!(resource_path("http://host/x"), None);
        assert_eq!(resource_path("file://otherhost/x"), None);
        assert_eq!(resource_path("file:///bad%zz"), None);
    }

    #[test]
    fn the_call_order_table_matches_the_standard_at_its_corners() {
        assert!(allowed(Call::DoStep, Phase::StepComplete));
        assert!(!allowed(Call::DoStep, Phase::InitializationMode));
        assert!(!allowed(Call::DoStep, Phase::StepFailed));
        assert!(allowed(Call::Get, Phase::Error));
        assert!(!allowed(Call::Get, Phase::Instantiated));
        assert!(!allowed(Call::Set, Phase::Terminated));
        assert!(allowed(Call::FreeInstance, Phase::Fatal));
        assert!(!allowed(Call::Reset, Phase::Fatal));
        assert!(!allowed(Call::CancelStep, Phase::StepComplete));
    }
}

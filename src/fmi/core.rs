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

use super::instance::{Instance, Phase, Refusal, SavedState, Status};
use super::variables::{GUID, LOG_CATEGORIES};

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
}

fn category_of(status: Status) -> &'static str {
    match status {
        Status::Warning => "logStatusWarning",
        Status::Discard => "logStatusDiscard",
        Status::Error => "logStatusError",
        Status::Fatal => "logStatusFatal",
    }
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
/// it panics. With `logging_on` false nothing reaches the logger until
/// fmi2SetDebugLogging.
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
        // Quiet by default: with loggingOn false nothing reaches the logger
        // until fmi2SetDebugLogging; with it true every category but the
        // per-call trace.
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
    fn log(&self, status: fmi2Status, category: &'static str, message: &str) {
        if !self.logging_on || !self.enabled.contains(category) {
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
        match catch_unwind(AssertUnwindSafe(|| f(self))) {
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
    /// settings as they were, so its warning is logged under the settings
    /// the importer had.
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

    /// fmi2ExitInitializationMode: builds the simulation.
    pub fn exit_initialization_mode(&mut self) -> Result<(), Refusal> {
        self.instance.exit_initialization()
    }

    /// fmi2Terminate.
    pub fn terminate(&mut self) -> Result<(), Refusal> {
        self.instance.terminate();
        Ok(())
    }

    /// fmi2Reset.
    pub fn reset(&mut self) -> Result<(), Refusal> {
        self.instance.reset();
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

    /// fmi2DoStep.
    pub fn do_step(&mut self, t: f64, h: f64) -> Result<(), Refusal> {
        self.instance.do_step(t, h)
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
        self.instance.restore(&s)
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

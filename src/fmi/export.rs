//! The exported FMI 2.0 co-simulation functions: the only `unsafe` code of
//! the project. Every function goes through `guard`, which checks the
//! component pointer, checks the call against the call-order table
//! ([`allowed`]), catches panics (answering fmi2Fatal), maps refusals to
//! their status and logs through the importer's callback — only there, only
//! for enabled categories, the message always passed as `"%s", msg`.

#![allow(non_snake_case)]
// The fmi2* functions and their arguments are specified by the FMI 2.0 standard.
#![allow(missing_docs)]
// bindgen's constant names (fmi2Status_fmi2OK, ...) are used as they are.
#![allow(non_upper_case_globals)]
// The standard fixes these safe-looking C signatures; every pointer is
// null-checked before use and its validity is the importer's FMI contract.
#![allow(clippy::not_unsafe_ptr_arg_deref)]

use std::collections::BTreeSet;
use std::ffi::{c_char, CStr, CString};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::PathBuf;

use fmi_sys::fmi2::*;

use super::instance::{Instance, Phase, Refusal, SavedState, Status};
use super::variables::{GUID, LOG_CATEGORIES};

/// Every call the table knows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Call {
    SetDebugLogging,
    FreeInstance,
    SetupExperiment,
    EnterInitializationMode,
    ExitInitializationMode,
    Terminate,
    Reset,
    Get,
    Set,
    FmuState,
    DirectionalDerivative,
    SetRealInputDerivatives,
    GetRealOutputDerivatives,
    DoStep,
    CancelStep,
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

struct Component {
    instance: Instance,
    logger: fmi2CallbackLogger,
    environment: fmi2ComponentEnvironment,
    logging_on: bool,
    enabled: BTreeSet<&'static str>,
    name: CString,
    strings: Vec<CString>,
    serialized: Vec<u8>,
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

impl Component {
    fn log(&self, status: fmi2Status, category: &'static str, message: &str) {
        if !self.logging_on || !self.enabled.contains(category) {
            return;
        }
        let Some(logger) = self.logger else { return };
        let text = CString::new(message.replace('\0', " ")).unwrap_or_default();
        let category = CString::new(category).unwrap_or_default();
        // SAFETY: the importer gave this callback for this component; every
        // string passed is a valid NUL-terminated C string that outlives the
        // call, and the format is "%s" with exactly one string argument.
        unsafe {
            logger(
                self.environment,
                self.name.as_ptr(),
                status,
                category.as_ptr(),
                c"%s".as_ptr(),
                text.as_ptr(),
            );
        }
    }
}

/// The single entry guard: pointer, call order, panics, status and logging.
fn guard(
    c: fmi2Component,
    call: Call,
    name: &str,
    f: impl FnOnce(&mut Component) -> Result<(), Refusal>,
) -> fmi2Status {
    if c.is_null() {
        return fmi2Status_fmi2Error;
    }
    // SAFETY: a non-null fmi2Component comes from fmi2Instantiate, which
    // returns a leaked Box<Component>; the importer must not use it after
    // fmi2FreeInstance, and FMI forbids concurrent calls on one instance.
    let comp = unsafe { &mut *(c as *mut Component) };
    let phase = comp.instance.phase;
    if !allowed(call, phase) {
        comp.log(
            fmi2Status_fmi2Error,
            "logStatusError",
            &format!("{name} is not allowed in phase {phase:?}"),
        );
        return fmi2Status_fmi2Error;
    }
    comp.log(fmi2Status_fmi2OK, "logCalls", name);
    match catch_unwind(AssertUnwindSafe(|| f(comp))) {
        Ok(Ok(())) => fmi2Status_fmi2OK,
        Ok(Err(refusal)) => {
            match refusal.status {
                Status::Error => comp.instance.phase = Phase::Error,
                Status::Fatal => comp.instance.phase = Phase::Fatal,
                Status::Warning | Status::Discard => {}
            }
            comp.log(
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
            comp.instance.phase = Phase::Fatal;
            comp.log(fmi2Status_fmi2Fatal, "logStatusFatal", &format!("{name}: internal error: {what}"));
            fmi2Status_fmi2Fatal
        }
    }
}

/// Reads `n` elements from `ptr`, refusing a null pointer with a non-zero
/// count and never touching the pointer for a zero count.
fn slice<'a, T>(ptr: *const T, n: usize, what: &str) -> Result<&'a [T], Refusal> {
    if n == 0 {
        return Ok(&[]);
    }
    if ptr.is_null() {
        return Err(Refusal { status: Status::Error, message: format!("{what} is NULL with {n} elements") });
    }
    // SAFETY: non-null, and the FMI caller guarantees n valid elements.
    Ok(unsafe { std::slice::from_raw_parts(ptr, n) })
}

fn slice_mut<'a, T>(ptr: *mut T, n: usize, what: &str) -> Result<&'a mut [T], Refusal> {
    if n == 0 {
        return Ok(&mut []);
    }
    if ptr.is_null() {
        return Err(Refusal { status: Status::Error, message: format!("{what} is NULL with {n} elements") });
    }
    // SAFETY: non-null, and the FMI caller guarantees n writable elements.
    Ok(unsafe { std::slice::from_raw_parts_mut(ptr, n) })
}

fn c_str(p: fmi2String) -> Option<String> {
    if p.is_null() {
        return None;
    }
    // SAFETY: FMI strings are NUL-terminated and valid for the call.
    Some(unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned())
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

#[no_mangle]
pub extern "C" fn fmi2GetTypesPlatform() -> *const c_char {
    c"default".as_ptr()
}

#[no_mangle]
pub extern "C" fn fmi2GetVersion() -> *const c_char {
    c"2.0".as_ptr()
}

#[no_mangle]
pub extern "C" fn fmi2Instantiate(
    instanceName: fmi2String,
    fmuType: fmi2Type,
    fmuGUID: fmi2String,
    fmuResourceLocation: fmi2String,
    functions: *const fmi2CallbackFunctions,
    _visible: fmi2Boolean,
    loggingOn: fmi2Boolean,
) -> fmi2Component {
    let made = catch_unwind(|| {
        // SAFETY: a non-null callbacks pointer points to the importer's struct for this call.
        let callbacks = if functions.is_null() { None } else { Some(unsafe { &*functions }) };
        let name = c_str(instanceName).unwrap_or_default();
        let mut comp = Box::new(Component {
            instance: Instance::new(if name.is_empty() { "?" } else { &name }, None),
            logger: callbacks.and_then(|c| c.logger),
            environment: callbacks.map_or(std::ptr::null_mut(), |c| c.componentEnvironment),
            logging_on: true,
            enabled: ["logStatusWarning", "logStatusDiscard", "logStatusError", "logStatusFatal"]
                .into_iter()
                .collect(),
            name: CString::new(if name.is_empty() { "?".to_string() } else { name.clone() })
                .unwrap_or_default(),
            strings: Vec::new(),
            serialized: Vec::new(),
        });
        let refuse = |comp: &Component, why: String| {
            comp.log(fmi2Status_fmi2Error, "logStatusError", &format!("fmi2Instantiate: {why}"));
            None
        };
        if name.is_empty() {
            return refuse(&comp, "the instance name is missing or empty".into());
        }
        if fmuType != fmi2Type_fmi2CoSimulation {
            return refuse(&comp, format!("fmuType {fmuType}: this FMU implements co-simulation only"));
        }
        let guid = c_str(fmuGUID).unwrap_or_default();
        if guid != GUID {
            return refuse(&comp, format!("GUID {guid} does not match this FMU's {GUID}: the modelDescription.xml belongs to another build"));
        }
        let resources = match c_str(fmuResourceLocation) {
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
        comp.logging_on = loggingOn != 0;
        comp.enabled = LOG_CATEGORIES.iter().map(|(n, _)| *n).filter(|n| *n != "logCalls").collect();
        Some(Box::into_raw(comp) as fmi2Component)
    });
    made.ok().flatten().unwrap_or(std::ptr::null_mut())
}

#[no_mangle]
pub extern "C" fn fmi2FreeInstance(c: fmi2Component) {
    if c.is_null() {
        return;
    }
    let _ = catch_unwind(|| {
        // SAFETY: the pointer came from fmi2Instantiate (a leaked Box) and the
        // importer frees it exactly once.
        drop(unsafe { Box::from_raw(c as *mut Component) });
    });
}

#[no_mangle]
pub extern "C" fn fmi2SetDebugLogging(
    c: fmi2Component,
    loggingOn: fmi2Boolean,
    n: usize,
    categories: *const fmi2String,
) -> fmi2Status {
    guard(c, Call::SetDebugLogging, "fmi2SetDebugLogging", |comp| {
        let names = slice(categories, n, "categories")?;
        // Every name is checked before anything changes: a call naming an
        // undeclared category leaves the settings as they were, so its
        // warning is logged under the settings the importer had.
        let mut enabled = BTreeSet::new();
        for p in names {
            let wanted = c_str(*p).unwrap_or_default();
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
        comp.logging_on = loggingOn != 0;
        comp.enabled = if n == 0 { LOG_CATEGORIES.iter().map(|(n, _)| *n).collect() } else { enabled };
        Ok(())
    })
}

#[no_mangle]
pub extern "C" fn fmi2SetupExperiment(
    c: fmi2Component,
    _toleranceDefined: fmi2Boolean,
    _tolerance: fmi2Real,
    startTime: fmi2Real,
    stopTimeDefined: fmi2Boolean,
    stopTime: fmi2Real,
) -> fmi2Status {
    guard(c, Call::SetupExperiment, "fmi2SetupExperiment", |comp| {
        comp.instance.setup_experiment(startTime, (stopTimeDefined != 0).then_some(stopTime))
    })
}

#[no_mangle]
pub extern "C" fn fmi2EnterInitializationMode(c: fmi2Component) -> fmi2Status {
    guard(c, Call::EnterInitializationMode, "fmi2EnterInitializationMode", |comp| {
        comp.instance.enter_initialization();
        Ok(())
    })
}

#[no_mangle]
pub extern "C" fn fmi2ExitInitializationMode(c: fmi2Component) -> fmi2Status {
    guard(c, Call::ExitInitializationMode, "fmi2ExitInitializationMode", |comp| {
        comp.instance.exit_initialization()
    })
}

#[no_mangle]
pub extern "C" fn fmi2Terminate(c: fmi2Component) -> fmi2Status {
    guard(c, Call::Terminate, "fmi2Terminate", |comp| {
        comp.instance.terminate();
        Ok(())
    })
}

#[no_mangle]
pub extern "C" fn fmi2Reset(c: fmi2Component) -> fmi2Status {
    guard(c, Call::Reset, "fmi2Reset", |comp| {
        comp.instance.reset();
        Ok(())
    })
}

macro_rules! getter {
    ($fn:ident, $ty:ty, $method:ident, $conv:expr) => {
        #[no_mangle]
        pub extern "C" fn $fn(
            c: fmi2Component,
            vr: *const fmi2ValueReference,
            n: usize,
            value: *mut $ty,
        ) -> fmi2Status {
            guard(c, Call::Get, stringify!($fn), |comp| {
                let refs = slice(vr, n, "vr")?;
                let out = slice_mut(value, n, "value")?;
                for (r, o) in refs.iter().zip(out.iter_mut()) {
                    let v = comp.instance.$method(*r)?;
                    *o = $conv(v);
                }
                Ok(())
            })
        }
    };
}

getter!(fmi2GetReal, fmi2Real, get_real, |v: f64| v);
getter!(fmi2GetInteger, fmi2Integer, get_integer, |v: i32| v);
getter!(fmi2GetBoolean, fmi2Boolean, get_boolean, |v: bool| fmi2Boolean::from(v));

#[no_mangle]
pub extern "C" fn fmi2GetString(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    n: usize,
    value: *mut fmi2String,
) -> fmi2Status {
    guard(c, Call::Get, "fmi2GetString", |comp| {
        let refs = slice(vr, n, "vr")?;
        let out = slice_mut(value, n, "value")?;
        comp.strings.clear();
        for r in refs {
            let s = comp.instance.get_string(*r)?;
            comp.strings.push(CString::new(s.replace('\0', " ")).unwrap_or_default());
        }
        for (o, s) in out.iter_mut().zip(&comp.strings) {
            *o = s.as_ptr();
        }
        Ok(())
    })
}

macro_rules! setter {
    ($fn:ident, $ty:ty, $method:ident, $conv:expr) => {
        #[no_mangle]
        pub extern "C" fn $fn(
            c: fmi2Component,
            vr: *const fmi2ValueReference,
            n: usize,
            value: *const $ty,
        ) -> fmi2Status {
            guard(c, Call::Set, stringify!($fn), |comp| {
                let refs = slice(vr, n, "vr")?;
                let vals = slice(value, n, "value")?;
                for (r, v) in refs.iter().zip(vals) {
                    comp.instance.$method(*r, $conv(*v))?;
                }
                Ok(())
            })
        }
    };
}

setter!(fmi2SetReal, fmi2Real, set_real, |v: f64| v);
setter!(fmi2SetInteger, fmi2Integer, set_integer, |v: i32| v);
setter!(fmi2SetBoolean, fmi2Boolean, set_boolean, |v: i32| v != 0);

#[no_mangle]
pub extern "C" fn fmi2SetString(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    n: usize,
    value: *const fmi2String,
) -> fmi2Status {
    guard(c, Call::Set, "fmi2SetString", |comp| {
        let refs = slice(vr, n, "vr")?;
        let vals = slice(value, n, "value")?;
        for (r, v) in refs.iter().zip(vals) {
            let s = c_str(*v).ok_or_else(|| Refusal {
                status: Status::Error,
                message: format!("value for reference {r} is NULL"),
            })?;
            comp.instance.set_string(*r, &s)?;
        }
        Ok(())
    })
}

fn unsupported(what: &str) -> Result<(), Refusal> {
    Err(Refusal {
        status: Status::Error,
        message: format!("{what} is not supported by this FMU (see modelDescription.xml capabilities)"),
    })
}

#[no_mangle]
pub extern "C" fn fmi2GetDirectionalDerivative(
    c: fmi2Component,
    _u: *const fmi2ValueReference,
    _nu: usize,
    _z: *const fmi2ValueReference,
    _nz: usize,
    _dv: *const fmi2Real,
    _dz: *mut fmi2Real,
) -> fmi2Status {
    guard(c, Call::DirectionalDerivative, "fmi2GetDirectionalDerivative", |_| {
        unsupported("fmi2GetDirectionalDerivative")
    })
}

#[no_mangle]
pub extern "C" fn fmi2SetRealInputDerivatives(
    c: fmi2Component,
    _vr: *const fmi2ValueReference,
    _n: usize,
    _order: *const fmi2Integer,
    _value: *const fmi2Real,
) -> fmi2Status {
    guard(c, Call::SetRealInputDerivatives, "fmi2SetRealInputDerivatives", |_| {
        unsupported("interpolating inputs")
    })
}

#[no_mangle]
pub extern "C" fn fmi2GetRealOutputDerivatives(
    c: fmi2Component,
    _vr: *const fmi2ValueReference,
    _n: usize,
    _order: *const fmi2Integer,
    _value: *mut fmi2Real,
) -> fmi2Status {
    guard(c, Call::GetRealOutputDerivatives, "fmi2GetRealOutputDerivatives", |_| {
        unsupported("output derivatives")
    })
}

#[no_mangle]
pub extern "C" fn fmi2DoStep(
    c: fmi2Component,
    currentCommunicationPoint: fmi2Real,
    communicationStepSize: fmi2Real,
    _noSetFMUStatePriorToCurrentPoint: fmi2Boolean,
) -> fmi2Status {
    guard(c, Call::DoStep, "fmi2DoStep", |comp| {
        comp.instance.do_step(currentCommunicationPoint, communicationStepSize)
    })
}

#[no_mangle]
pub extern "C" fn fmi2CancelStep(c: fmi2Component) -> fmi2Status {
    guard(c, Call::CancelStep, "fmi2CancelStep", |_| unsupported("asynchronous steps"))
}

fn write_out<T>(p: *mut T, v: T, what: &str) -> Result<(), Refusal> {
    if p.is_null() {
        return Err(Refusal { status: Status::Error, message: format!("{what} is NULL") });
    }
    // SAFETY: non-null pointer to a value the caller owns for this call.
    unsafe { p.write(v) };
    Ok(())
}

#[no_mangle]
pub extern "C" fn fmi2GetStatus(c: fmi2Component, s: fmi2StatusKind, value: *mut fmi2Status) -> fmi2Status {
    guard(c, Call::Status, "fmi2GetStatus", |comp| match s {
        fmi2StatusKind_fmi2DoStepStatus => {
            let st = if comp.instance.terminated { fmi2Status_fmi2Discard } else { fmi2Status_fmi2OK };
            write_out(value, st, "value")
        }
        _ => Err(Refusal {
            status: Status::Discard,
            message: format!("status kind {s} is not available from fmi2GetStatus"),
        }),
    })
}

#[no_mangle]
pub extern "C" fn fmi2GetRealStatus(c: fmi2Component, s: fmi2StatusKind, value: *mut fmi2Real) -> fmi2Status {
    guard(c, Call::Status, "fmi2GetRealStatus", |comp| match s {
        fmi2StatusKind_fmi2LastSuccessfulTime => {
            write_out(value, comp.instance.last_successful_time, "value")
        }
        _ => {
            Err(Refusal { status: Status::Discard, message: format!("status kind {s} is not a Real status") })
        }
    })
}

#[no_mangle]
pub extern "C" fn fmi2GetIntegerStatus(
    c: fmi2Component,
    s: fmi2StatusKind,
    _value: *mut fmi2Integer,
) -> fmi2Status {
    guard(c, Call::Status, "fmi2GetIntegerStatus", |_| {
        Err(Refusal { status: Status::Discard, message: format!("status kind {s} is not an Integer status") })
    })
}

#[no_mangle]
pub extern "C" fn fmi2GetBooleanStatus(
    c: fmi2Component,
    s: fmi2StatusKind,
    value: *mut fmi2Boolean,
) -> fmi2Status {
    guard(c, Call::Status, "fmi2GetBooleanStatus", |comp| match s {
        fmi2StatusKind_fmi2Terminated => {
            write_out(value, fmi2Boolean::from(comp.instance.terminated), "value")
        }
        _ => Err(Refusal {
            status: Status::Discard,
            message: format!("status kind {s} is not a Boolean status"),
        }),
    })
}

#[no_mangle]
pub extern "C" fn fmi2GetStringStatus(
    c: fmi2Component,
    s: fmi2StatusKind,
    _value: *mut fmi2String,
) -> fmi2Status {
    guard(c, Call::Status, "fmi2GetStringStatus", |_| {
        Err(Refusal { status: Status::Discard, message: format!("status kind {s} is not a String status") })
    })
}

#[no_mangle]
pub extern "C" fn fmi2GetFMUstate(c: fmi2Component, state: *mut fmi2FMUstate) -> fmi2Status {
    guard(c, Call::FmuState, "fmi2GetFMUstate", |comp| {
        if state.is_null() {
            return Err(Refusal { status: Status::Error, message: "FMUstate is NULL".into() });
        }
        let saved = comp.instance.save();
        // SAFETY: state is non-null; a non-null *state came from this FMU
        // (fmi2GetFMUstate or fmi2DeSerializeFMUstate) as a leaked Box.
        unsafe {
            let old = *state;
            if old.is_null() {
                *state = Box::into_raw(Box::new(saved)) as fmi2FMUstate;
            } else {
                *(old as *mut SavedState) = saved;
            }
        }
        Ok(())
    })
}

fn saved<'a>(state: fmi2FMUstate) -> Result<&'a SavedState, Refusal> {
    if state.is_null() {
        return Err(Refusal { status: Status::Error, message: "FMUstate is NULL".into() });
    }
    // SAFETY: a non-null FMUstate comes from this FMU as a leaked Box<SavedState>.
    Ok(unsafe { &*(state as *const SavedState) })
}

#[no_mangle]
pub extern "C" fn fmi2SetFMUstate(c: fmi2Component, state: fmi2FMUstate) -> fmi2Status {
    guard(c, Call::FmuState, "fmi2SetFMUstate", |comp| {
        let s = saved(state)?.clone();
        comp.instance.restore(&s)
    })
}

#[no_mangle]
pub extern "C" fn fmi2FreeFMUstate(c: fmi2Component, state: *mut fmi2FMUstate) -> fmi2Status {
    guard(c, Call::FmuState, "fmi2FreeFMUstate", |_| {
        if state.is_null() {
            return Ok(());
        }
        // SAFETY: state points to the importer's handle; a non-null handle is
        // a leaked Box<SavedState> from this FMU, freed once and nulled.
        unsafe {
            let s = *state;
            if !s.is_null() {
                drop(Box::from_raw(s as *mut SavedState));
                *state = std::ptr::null_mut();
            }
        }
        Ok(())
    })
}

#[no_mangle]
pub extern "C" fn fmi2SerializedFMUstateSize(
    c: fmi2Component,
    state: fmi2FMUstate,
    size: *mut usize,
) -> fmi2Status {
    guard(c, Call::FmuState, "fmi2SerializedFMUstateSize", |comp| {
        let bytes = comp.instance.serialize(saved(state)?)?;
        write_out(size, bytes.len(), "size")?;
        comp.serialized = bytes;
        Ok(())
    })
}

#[no_mangle]
pub extern "C" fn fmi2SerializeFMUstate(
    c: fmi2Component,
    state: fmi2FMUstate,
    bytes: *mut fmi2Byte,
    size: usize,
) -> fmi2Status {
    guard(c, Call::FmuState, "fmi2SerializeFMUstate", |comp| {
        let data = comp.instance.serialize(saved(state)?)?;
        if size < data.len() {
            return Err(Refusal {
                status: Status::Error,
                message: format!("size {size} is smaller than the state's {} bytes", data.len()),
            });
        }
        let out = slice_mut(bytes as *mut u8, data.len(), "serializedState")?;
        out.copy_from_slice(&data);
        Ok(())
    })
}

#[no_mangle]
pub extern "C" fn fmi2DeSerializeFMUstate(
    c: fmi2Component,
    bytes: *const fmi2Byte,
    size: usize,
    state: *mut fmi2FMUstate,
) -> fmi2Status {
    guard(c, Call::FmuState, "fmi2DeSerializeFMUstate", |comp| {
        if state.is_null() {
            return Err(Refusal { status: Status::Error, message: "FMUstate is NULL".into() });
        }
        let data = slice(bytes as *const u8, size, "serializedState")?;
        let s = comp.instance.deserialize(data)?;
        // SAFETY: state is non-null; a non-null *state came from this FMU
        // (a leaked Box<SavedState>) and is overwritten in place, as
        // fmi2GetFMUstate does, so the importer's handle stays the one it holds.
        unsafe {
            let old = *state;
            if old.is_null() {
                *state = Box::into_raw(Box::new(s)) as fmi2FMUstate;
            } else {
                *(old as *mut SavedState) = s;
            }
        }
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn instantiate(guid: &CStr) -> fmi2Component {
        fmi2Instantiate(
            c"unit".as_ptr(),
            fmi2Type_fmi2CoSimulation,
            guid.as_ptr(),
            std::ptr::null(),
            std::ptr::null(),
            0,
            0,
        )
    }

    #[test]
    fn a_panic_inside_a_call_is_answered_with_fatal_and_only_free_is_allowed_after() {
        let guid = CString::new(GUID).unwrap();
        let c = instantiate(&guid);
        assert!(!c.is_null());
        let status = guard(c, Call::SetupExperiment, "test", |_| panic!("forced"));
        assert_eq!(status, fmi2Status_fmi2Fatal);
        assert_eq!(fmi2Reset(c), fmi2Status_fmi2Error, "nothing but fmi2FreeInstance after a fatal error");
        fmi2FreeInstance(c);
    }

    fn component<'a>(c: fmi2Component) -> &'a Component {
        // SAFETY: a live component from fmi2Instantiate in this test.
        unsafe { &*(c as *const Component) }
    }

    #[test]
    fn an_undeclared_log_category_is_a_warning_and_changes_no_setting() {
        let guid = CString::new(GUID).unwrap();
        let c = instantiate(&guid);
        let before = component(c).enabled.clone();
        let names = [c"logCalls".as_ptr(), c"logNothing".as_ptr()];
        assert_eq!(fmi2SetDebugLogging(c, 1, 2, names.as_ptr()), fmi2Status_fmi2Warning);
        assert!(!component(c).logging_on, "instantiated with logging off, and still off");
        assert_eq!(component(c).enabled, before);
        let names = [c"logCalls".as_ptr(), c"logStatusError".as_ptr()];
        assert_eq!(fmi2SetDebugLogging(c, 1, 2, names.as_ptr()), fmi2Status_fmi2OK);
        assert!(component(c).logging_on);
        assert_eq!(component(c).enabled, ["logCalls", "logStatusError"].into_iter().collect());
        fmi2FreeInstance(c);
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

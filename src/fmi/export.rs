//! The exported FMI 2.0 co-simulation functions: the C boundary, and the
//! only `unsafe` code of the project.
//!
//! Every `fmi2*` function is `unsafe`: it relies on the importer keeping the
//! FMI 2.0 contract, which each one states under "Safety" — a component comes
//! from fmi2Instantiate and is not used after fmi2FreeInstance; an array
//! argument holds the number of elements passed with it; a string is NULL or
//! NUL-terminated; an out-argument is NULL or writable; an FMU state comes
//! from this FMU and is not used after it is freed; no two calls run on one
//! instance at once. Its body is one call: the raw arguments are turned into
//! Rust values by the `unsafe fn`s below (`component`, `owned`, `slice`,
//! `slice_mut`, `buffer`, `c_str`, `c_strs`, `out`, `saved_state`,
//! `state_handle`, `logger`), each with the part of the contract it needs,
//! and handed to the safe code of [`super::core`]. Every call on a component goes through
//! `guard`: a NULL component is fmi2Error, anything else is
//! [`Component::call`] (the call-order table, panics caught as fmi2Fatal,
//! refusals mapped to their status and logged through the importer's
//! callback — only there, only for enabled categories, the message always
//! passed as `"%s", msg`).

#![allow(non_snake_case)]
// The fmi2* functions and their arguments are specified by the FMI 2.0 standard.
#![allow(missing_docs)]

use std::ffi::{c_char, CStr};

use fmi_sys::fmi2::*;

use super::core::{free_instance, instantiate, null_array, types_platform, version, Call, Component, Logger};
use super::instance::Refusal;

/// The component behind an fmi2Component, `None` for NULL.
///
/// # Safety
///
/// `c` is NULL or was returned by fmi2Instantiate and not yet passed to
/// fmi2FreeInstance, and nothing else uses the instance while the reference
/// lives (FMI allows no concurrent calls on one instance).
unsafe fn component<'a>(c: fmi2Component) -> Option<&'a mut Component> {
    // SAFETY: a non-null fmi2Component is the Box<Component> leaked by
    // fmi2Instantiate (`handle`), live and not aliased (the contract above).
    unsafe { c.cast::<Component>().as_mut() }
}

/// The component behind an fmi2Component, taken back from the importer;
/// `None` for NULL.
///
/// # Safety
///
/// `c` is NULL or was returned by fmi2Instantiate and is given back once:
/// the importer does not use it afterwards.
unsafe fn owned(c: fmi2Component) -> Option<Box<Component>> {
    if c.is_null() {
        return None;
    }
    // SAFETY: the Box<Component> leaked by fmi2Instantiate, owned by the
    // importer until now and never used again (the contract above).
    Some(unsafe { Box::from_raw(c.cast::<Component>()) })
}

/// A new component handed to the importer as its fmi2Component (NULL for
/// none); `component` and `owned` take it back.
fn handle(comp: Option<Box<Component>>) -> fmi2Component {
    comp.map_or(std::ptr::null_mut(), |c| Box::into_raw(c).cast())
}

/// The single entry path of every call on a component: NULL is fmi2Error,
/// anything else goes through [`Component::call`] (call order, panics,
/// status and logging).
///
/// # Safety
///
/// That of [`component`].
unsafe fn guard(
    c: fmi2Component,
    call: Call,
    name: &str,
    f: impl FnOnce(&mut Component) -> Result<(), Refusal>,
) -> fmi2Status {
    // SAFETY: the contract of `guard` is that of `component`.
    match unsafe { component(c) } {
        Some(comp) => comp.call(call, name, f),
        None => fmi2Status_fmi2Error,
    }
}

/// `n` elements from `ptr`: a zero count never touches the pointer, a NULL
/// pointer with a non-zero count is refused.
///
/// # Safety
///
/// A non-null `ptr` with a non-zero `n` points to `n` initialized, aligned
/// elements not written during `'a`.
unsafe fn slice<'a, T>(ptr: *const T, n: usize, what: &str) -> Result<&'a [T], Refusal> {
    if n == 0 {
        return Ok(&[]);
    }
    if ptr.is_null() {
        return Err(null_array(what, n));
    }
    // SAFETY: non-null, and n valid elements (the contract above).
    Ok(unsafe { std::slice::from_raw_parts(ptr, n) })
}

/// `n` writable elements at `ptr`, `None` for NULL; a zero count never
/// touches the pointer.
///
/// # Safety
///
/// A non-null `ptr` with a non-zero `n` points to `n` aligned elements,
/// writable and not otherwise accessed during `'a`.
unsafe fn buffer<'a, T>(ptr: *mut T, n: usize) -> Option<&'a mut [T]> {
    if ptr.is_null() {
        return None;
    }
    if n == 0 {
        return Some(&mut []);
    }
    // SAFETY: non-null, and n writable elements used by nothing else (the
    // contract above).
    Some(unsafe { std::slice::from_raw_parts_mut(ptr, n) })
}

/// `n` writable elements at `ptr`: a zero count never touches the pointer,
/// a NULL pointer with a non-zero count is refused.
///
/// # Safety
///
/// That of [`buffer`].
unsafe fn slice_mut<'a, T>(ptr: *mut T, n: usize, what: &str) -> Result<&'a mut [T], Refusal> {
    if n == 0 {
        return Ok(&mut []);
    }
    // SAFETY: the contract of `slice_mut` is that of `buffer`.
    unsafe { buffer(ptr, n) }.ok_or_else(|| null_array(what, n))
}

/// A C string as Rust text (invalid UTF-8 replaced), `None` for NULL.
///
/// # Safety
///
/// `p` is NULL or points to a NUL-terminated string valid for the call.
unsafe fn c_str(p: fmi2String) -> Option<String> {
    if p.is_null() {
        return None;
    }
    // SAFETY: non-null and NUL-terminated (the contract above).
    Some(unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned())
}

/// An array of `n` C strings as Rust text, as [`slice()`] and [`c_str`].
///
/// # Safety
///
/// That of [`slice()`] for the array, and of [`c_str`] for each element.
unsafe fn c_strs(ptr: *const fmi2String, n: usize, what: &str) -> Result<Vec<Option<String>>, Refusal> {
    // SAFETY: the contract of `c_strs` covers the array.
    let strings = unsafe { slice(ptr, n, what) }?;
    // SAFETY: the contract of `c_strs` covers every element.
    Ok(strings.iter().map(|p| unsafe { c_str(*p) }).collect())
}

/// An out-argument, `None` for NULL.
///
/// # Safety
///
/// `p` is NULL or points to an aligned `T`, writable and not otherwise
/// accessed during `'a`.
unsafe fn out<'a, T>(p: *mut T) -> Option<&'a mut T> {
    // SAFETY: NULL or valid and unaliased (the contract above).
    unsafe { p.as_mut() }
}

/// The importer's FMUstate handle, `None` for a NULL pointer. The state it
/// holds is only an address to the instance, which looks it up among the
/// states it handed out (`Component`'s table) and never dereferences it.
///
/// # Safety
///
/// `handle` is NULL or points to the importer's fmi2FMUstate, writable and
/// not otherwise accessed during `'a`.
unsafe fn state_handle<'a>(handle: *mut fmi2FMUstate) -> Option<&'a mut fmi2FMUstate> {
    // SAFETY: NULL or valid and unaliased (the contract above).
    unsafe { handle.as_mut() }
}

/// The importer's logger with its component environment, as a Rust
/// callable; `None` without callbacks or without a logger.
///
/// # Safety
///
/// `functions` is NULL or points to the importer's callback functions,
/// readable for the call; a logger given there may be called with its
/// componentEnvironment whenever a call on the instance runs, until
/// fmi2FreeInstance.
unsafe fn logger(functions: *const fmi2CallbackFunctions) -> Option<Logger> {
    // SAFETY: NULL or readable for the call (the contract above).
    let callbacks = unsafe { functions.as_ref() }?;
    let log = callbacks.logger?;
    let environment = callbacks.componentEnvironment;
    Some(Box::new(move |status: fmi2Status, name: &CStr, category: &CStr, message: &CStr| {
        // SAFETY: the importer's logger for this instance, callable while it
        // lives (the contract of `logger`); every string passed is a valid
        // NUL-terminated C string that outlives the call, and the format is
        // "%s" with exactly one string argument.
        unsafe {
            log(environment, name.as_ptr(), status, category.as_ptr(), c"%s".as_ptr(), message.as_ptr())
        }
    }))
}

/// fmi2GetTypesPlatform: `"default"`.
///
/// # Safety
///
/// No precondition; the caller neither writes nor frees the static string
/// returned.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetTypesPlatform() -> *const c_char {
    types_platform().as_ptr()
}

/// fmi2GetVersion: `"2.0"`.
///
/// # Safety
///
/// No precondition; the caller neither writes nor frees the static string
/// returned.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetVersion() -> *const c_char {
    version().as_ptr()
}

/// fmi2Instantiate: a new co-simulation instance, or NULL (the reason
/// logged when there is a logger).
///
/// # Safety
///
/// `instanceName`, `fmuGUID` and `fmuResourceLocation` are NULL or
/// NUL-terminated strings; `functions` is NULL or points to readable
/// callback functions whose logger, if any, may be called with its
/// componentEnvironment until fmi2FreeInstance of the returned instance.
#[no_mangle]
pub unsafe extern "C" fn fmi2Instantiate(
    instanceName: fmi2String,
    fmuType: fmi2Type,
    fmuGUID: fmi2String,
    fmuResourceLocation: fmi2String,
    functions: *const fmi2CallbackFunctions,
    _visible: fmi2Boolean,
    loggingOn: fmi2Boolean,
) -> fmi2Component {
    // SAFETY: strings and callbacks as this function's contract states.
    handle(unsafe {
        instantiate(
            c_str(instanceName),
            fmuType,
            c_str(fmuGUID),
            c_str(fmuResourceLocation),
            logger(functions),
            loggingOn != 0,
        )
    })
}

/// fmi2FreeInstance (NULL is ignored).
///
/// # Safety
///
/// `c` is NULL or an instance from fmi2Instantiate, freed once and not used
/// afterwards, with no other call on it running.
#[no_mangle]
pub unsafe extern "C" fn fmi2FreeInstance(c: fmi2Component) {
    // SAFETY: `c` is given back once (this function's contract).
    free_instance(unsafe { owned(c) })
}

/// fmi2SetDebugLogging.
///
/// # Safety
///
/// `c` is NULL or a live instance from fmi2Instantiate (not freed) with no
/// other call on it running; `categories` holds `n` NULL or NUL-terminated
/// strings (it is not read for `n` = 0).
#[no_mangle]
pub unsafe extern "C" fn fmi2SetDebugLogging(
    c: fmi2Component,
    loggingOn: fmi2Boolean,
    n: usize,
    categories: *const fmi2String,
) -> fmi2Status {
    // SAFETY: the instance and the category names as this function's contract states.
    unsafe {
        guard(c, Call::SetDebugLogging, "fmi2SetDebugLogging", |comp| {
            comp.set_debug_logging(loggingOn != 0, &c_strs(categories, n, "categories")?)
        })
    }
}

/// fmi2SetupExperiment (the tolerance is not used).
///
/// # Safety
///
/// `c` is NULL or a live instance from fmi2Instantiate (not freed) with no
/// other call on it running.
#[no_mangle]
pub unsafe extern "C" fn fmi2SetupExperiment(
    c: fmi2Component,
    _toleranceDefined: fmi2Boolean,
    _tolerance: fmi2Real,
    startTime: fmi2Real,
    stopTimeDefined: fmi2Boolean,
    stopTime: fmi2Real,
) -> fmi2Status {
    // SAFETY: the instance as this function's contract states.
    unsafe {
        guard(c, Call::SetupExperiment, "fmi2SetupExperiment", |comp| {
            comp.setup_experiment(startTime, (stopTimeDefined != 0).then_some(stopTime))
        })
    }
}

/// The exported functions whose only pointer argument is the instance.
macro_rules! instance_call {
    ($fn:ident, $call:ident, $method:ident, $doc:literal) => {
        #[doc = $doc]
        ///
        /// # Safety
        ///
        /// `c` is NULL or a live instance from fmi2Instantiate (not freed)
        /// with no other call on it running.
        #[no_mangle]
        pub unsafe extern "C" fn $fn(c: fmi2Component) -> fmi2Status {
            // SAFETY: the instance as this function's contract states.
            unsafe { guard(c, Call::$call, stringify!($fn), Component::$method) }
        }
    };
}

instance_call!(
    fmi2EnterInitializationMode,
    EnterInitializationMode,
    enter_initialization_mode,
    "fmi2EnterInitializationMode."
);
instance_call!(
    fmi2ExitInitializationMode,
    ExitInitializationMode,
    exit_initialization_mode,
    "fmi2ExitInitializationMode: builds the simulation."
);
instance_call!(fmi2Terminate, Terminate, terminate, "fmi2Terminate.");
instance_call!(fmi2Reset, Reset, reset, "fmi2Reset.");
instance_call!(fmi2CancelStep, CancelStep, cancel_step, "fmi2CancelStep: not supported.");

macro_rules! getter {
    ($fn:ident, $ty:ty, $method:ident) => {
        #[doc = concat!(stringify!($fn), ": one value per value reference.")]
        ///
        /// # Safety
        ///
        /// `c` is NULL or a live instance from fmi2Instantiate (not freed)
        /// with no other call on it running; `vr` holds `n` value
        /// references and `value` has room for `n` values, used by nothing
        /// else during the call (neither is read for `n` = 0).
        #[no_mangle]
        pub unsafe extern "C" fn $fn(
            c: fmi2Component,
            vr: *const fmi2ValueReference,
            n: usize,
            value: *mut $ty,
        ) -> fmi2Status {
            // SAFETY: the instance and the arrays as this function's contract states.
            unsafe {
                guard(c, Call::Get, stringify!($fn), |comp| {
                    comp.$method(slice(vr, n, "vr")?, slice_mut(value, n, "value")?)
                })
            }
        }
    };
}

getter!(fmi2GetReal, fmi2Real, get_real);
getter!(fmi2GetInteger, fmi2Integer, get_integer);
getter!(fmi2GetBoolean, fmi2Boolean, get_boolean);
getter!(fmi2GetString, fmi2String, get_string);

macro_rules! setter {
    ($fn:ident, $ty:ty, $method:ident) => {
        #[doc = concat!(stringify!($fn), ": one value per value reference.")]
        ///
        /// # Safety
        ///
        /// `c` is NULL or a live instance from fmi2Instantiate (not freed)
        /// with no other call on it running; `vr` and `value` each hold `n`
        /// elements (neither is read for `n` = 0).
        #[no_mangle]
        pub unsafe extern "C" fn $fn(
            c: fmi2Component,
            vr: *const fmi2ValueReference,
            n: usize,
            value: *const $ty,
        ) -> fmi2Status {
            // SAFETY: the instance and the arrays as this function's contract states.
            unsafe {
                guard(c, Call::Set, stringify!($fn), |comp| {
                    comp.$method(slice(vr, n, "vr")?, slice(value, n, "value")?)
                })
            }
        }
    };
}

setter!(fmi2SetReal, fmi2Real, set_real);
setter!(fmi2SetInteger, fmi2Integer, set_integer);
setter!(fmi2SetBoolean, fmi2Boolean, set_boolean);

/// fmi2SetString: one value per value reference.
///
/// # Safety
///
/// `c` is NULL or a live instance from fmi2Instantiate (not freed) with no
/// other call on it running; `vr` holds `n` value references and `value`
/// `n` NULL or NUL-terminated strings (neither is read for `n` = 0).
#[no_mangle]
pub unsafe extern "C" fn fmi2SetString(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    n: usize,
    value: *const fmi2String,
) -> fmi2Status {
    // SAFETY: the instance, the array and the strings as this function's contract states.
    unsafe {
        guard(c, Call::Set, "fmi2SetString", |comp| {
            comp.set_string(slice(vr, n, "vr")?, &c_strs(value, n, "value")?)
        })
    }
}

/// fmi2GetDirectionalDerivative: not supported (its arrays are not read).
///
/// # Safety
///
/// `c` is NULL or a live instance from fmi2Instantiate (not freed) with no
/// other call on it running.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetDirectionalDerivative(
    c: fmi2Component,
    _u: *const fmi2ValueReference,
    _nu: usize,
    _z: *const fmi2ValueReference,
    _nz: usize,
    _dv: *const fmi2Real,
    _dz: *mut fmi2Real,
) -> fmi2Status {
    // SAFETY: the instance as this function's contract states.
    unsafe {
        guard(
            c,
            Call::DirectionalDerivative,
            "fmi2GetDirectionalDerivative",
            Component::directional_derivative,
        )
    }
}

/// fmi2SetRealInputDerivatives: not supported (its arrays are not read).
///
/// # Safety
///
/// `c` is NULL or a live instance from fmi2Instantiate (not freed) with no
/// other call on it running.
#[no_mangle]
pub unsafe extern "C" fn fmi2SetRealInputDerivatives(
    c: fmi2Component,
    _vr: *const fmi2ValueReference,
    _n: usize,
    _order: *const fmi2Integer,
    _value: *const fmi2Real,
) -> fmi2Status {
    // SAFETY: the instance as this function's contract states.
    unsafe {
        guard(
            c,
            Call::SetRealInputDerivatives,
            "fmi2SetRealInputDerivatives",
            Component::set_real_input_derivatives,
        )
    }
}

/// fmi2GetRealOutputDerivatives: not supported (its arrays are not touched).
///
/// # Safety
///
/// `c` is NULL or a live instance from fmi2Instantiate (not freed) with no
/// other call on it running.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetRealOutputDerivatives(
    c: fmi2Component,
    _vr: *const fmi2ValueReference,
    _n: usize,
    _order: *const fmi2Integer,
    _value: *mut fmi2Real,
) -> fmi2Status {
    // SAFETY: the instance as this function's contract states.
    unsafe {
        guard(
            c,
            Call::GetRealOutputDerivatives,
            "fmi2GetRealOutputDerivatives",
            Component::real_output_derivatives,
        )
    }
}

/// fmi2DoStep.
///
/// # Safety
///
/// `c` is NULL or a live instance from fmi2Instantiate (not freed) with no
/// other call on it running.
#[no_mangle]
pub unsafe extern "C" fn fmi2DoStep(
    c: fmi2Component,
    currentCommunicationPoint: fmi2Real,
    communicationStepSize: fmi2Real,
    _noSetFMUStatePriorToCurrentPoint: fmi2Boolean,
) -> fmi2Status {
    // SAFETY: the instance as this function's contract states.
    unsafe {
        guard(c, Call::DoStep, "fmi2DoStep", |comp| {
            comp.do_step(currentCommunicationPoint, communicationStepSize)
        })
    }
}

macro_rules! status_getter {
    ($fn:ident, $ty:ty, $method:ident) => {
        #[doc = concat!(stringify!($fn), ".")]
        ///
        /// # Safety
        ///
        /// `c` is NULL or a live instance from fmi2Instantiate (not freed)
        /// with no other call on it running; `value` is NULL or writable and
        /// used by nothing else during the call.
        #[no_mangle]
        pub unsafe extern "C" fn $fn(c: fmi2Component, s: fmi2StatusKind, value: *mut $ty) -> fmi2Status {
            // SAFETY: the instance and the out-argument as this function's contract states.
            unsafe { guard(c, Call::Status, stringify!($fn), |comp| comp.$method(s, out(value))) }
        }
    };
}

status_getter!(fmi2GetStatus, fmi2Status, status);
status_getter!(fmi2GetRealStatus, fmi2Real, real_status);
status_getter!(fmi2GetBooleanStatus, fmi2Boolean, boolean_status);

/// fmi2GetIntegerStatus: no status kind is an Integer one.
///
/// # Safety
///
/// `c` is NULL or a live instance from fmi2Instantiate (not freed) with no
/// other call on it running (`value` is not touched).
#[no_mangle]
pub unsafe extern "C" fn fmi2GetIntegerStatus(
    c: fmi2Component,
    s: fmi2StatusKind,
    _value: *mut fmi2Integer,
) -> fmi2Status {
    // SAFETY: the instance as this function's contract states.
    unsafe { guard(c, Call::Status, "fmi2GetIntegerStatus", |comp| comp.integer_status(s)) }
}

/// fmi2GetStringStatus: no status kind is a String one.
///
/// # Safety
///
/// `c` is NULL or a live instance from fmi2Instantiate (not freed) with no
/// other call on it running (`value` is not touched).
#[no_mangle]
pub unsafe extern "C" fn fmi2GetStringStatus(
    c: fmi2Component,
    s: fmi2StatusKind,
    _value: *mut fmi2String,
) -> fmi2Status {
    // SAFETY: the instance as this function's contract states.
    unsafe { guard(c, Call::Status, "fmi2GetStringStatus", |comp| comp.string_status(s)) }
}

/// fmi2GetFMUstate: a new state into a handle holding NULL, or the held
/// state overwritten in place.
///
/// # Safety
///
/// `c` is NULL or a live instance from fmi2Instantiate (not freed) with no
/// other call on it running; `state` is NULL or points to a writable
/// fmi2FMUstate holding NULL or a state of this FMU that is not freed.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetFMUstate(c: fmi2Component, state: *mut fmi2FMUstate) -> fmi2Status {
    // SAFETY: the instance and the state handle as this function's contract states.
    unsafe { guard(c, Call::FmuState, "fmi2GetFMUstate", |comp| comp.get_fmu_state(state_handle(state))) }
}

/// fmi2SetFMUstate.
///
/// # Safety
///
/// `c` is NULL or a live instance from fmi2Instantiate (not freed) with no
/// other call on it running; `state` is NULL or a state of this FMU that is
/// not freed.
#[no_mangle]
pub unsafe extern "C" fn fmi2SetFMUstate(c: fmi2Component, state: fmi2FMUstate) -> fmi2Status {
    // SAFETY: the instance and the state as this function's contract states.
    unsafe { guard(c, Call::FmuState, "fmi2SetFMUstate", |comp| comp.set_fmu_state(state)) }
}

/// fmi2FreeFMUstate: frees the held state and sets the handle to NULL.
///
/// # Safety
///
/// `c` is NULL or a live instance from fmi2Instantiate (not freed) with no
/// other call on it running; `state` is NULL or points to a writable
/// fmi2FMUstate holding NULL or a state of this FMU that is not freed, and
/// not used once freed.
#[no_mangle]
pub unsafe extern "C" fn fmi2FreeFMUstate(c: fmi2Component, state: *mut fmi2FMUstate) -> fmi2Status {
    // SAFETY: the instance and the state handle as this function's contract states.
    unsafe { guard(c, Call::FmuState, "fmi2FreeFMUstate", |comp| comp.free_fmu_state(state_handle(state))) }
}

/// fmi2SerializedFMUstateSize.
///
/// # Safety
///
/// `c` is NULL or a live instance from fmi2Instantiate (not freed) with no
/// other call on it running; `state` is NULL or a state of this FMU that is
/// not freed; `size` is NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn fmi2SerializedFMUstateSize(
    c: fmi2Component,
    state: fmi2FMUstate,
    size: *mut usize,
) -> fmi2Status {
    // SAFETY: the instance, the state and the out-argument as this function's contract states.
    unsafe {
        guard(c, Call::FmuState, "fmi2SerializedFMUstateSize", |comp| {
            comp.serialized_fmu_state_size(state, out(size))
        })
    }
}

/// fmi2SerializeFMUstate: the state's bytes into a buffer of `size` bytes.
///
/// # Safety
///
/// `c` is NULL or a live instance from fmi2Instantiate (not freed) with no
/// other call on it running; `state` is NULL or a state of this FMU that is
/// not freed; `bytes` is NULL or has room for `size` bytes, used by nothing
/// else during the call.
#[no_mangle]
pub unsafe extern "C" fn fmi2SerializeFMUstate(
    c: fmi2Component,
    state: fmi2FMUstate,
    bytes: *mut fmi2Byte,
    size: usize,
) -> fmi2Status {
    // SAFETY: the instance, the state and the buffer as this function's contract states.
    unsafe {
        guard(c, Call::FmuState, "fmi2SerializeFMUstate", |comp| {
            comp.serialize_fmu_state(state, size, buffer(bytes.cast::<u8>(), size))
        })
    }
}

/// fmi2DeSerializeFMUstate: a new state into a handle holding NULL, or the
/// held state overwritten in place (the importer's handle stays the one it
/// holds).
///
/// # Safety
///
/// `c` is NULL or a live instance from fmi2Instantiate (not freed) with no
/// other call on it running; `bytes` holds `size` bytes (it is not read for
/// `size` = 0); `state` is NULL or points to a writable fmi2FMUstate holding
/// NULL or a state of this FMU that is not freed.
#[no_mangle]
pub unsafe extern "C" fn fmi2DeSerializeFMUstate(
    c: fmi2Component,
    bytes: *const fmi2Byte,
    size: usize,
    state: *mut fmi2FMUstate,
) -> fmi2Status {
    // SAFETY: the instance, the bytes and the state handle as this function's contract states.
    unsafe {
        guard(c, Call::FmuState, "fmi2DeSerializeFMUstate", |comp| {
            comp.deserialize_fmu_state(
                slice(bytes.cast::<u8>(), size, "serializedState"),
                state_handle(state),
            )
        })
    }
}

#[cfg(test)]
mod tests {
    use std::ffi::CString;

    use super::*;
    use crate::fmi::variables::GUID;

    fn instantiate() -> fmi2Component {
        let guid = CString::new(GUID).unwrap();
        // SAFETY: the strings are NUL-terminated and outlive the call; no callbacks.
        unsafe {
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
    }

    #[test]
    fn a_panic_inside_a_call_is_answered_with_fatal_and_only_free_is_allowed_after() {
        let c = instantiate();
        assert!(!c.is_null());
        // SAFETY: `c` is live until fmi2FreeInstance and used by this thread only.
        unsafe {
            assert_eq!(guard(c, Call::SetupExperiment, "test", |_| panic!("forced")), fmi2Status_fmi2Fatal);
            assert_eq!(
                fmi2Reset(c),
                fmi2Status_fmi2Error,
                "nothing but fmi2FreeInstance after a fatal error"
            );
            fmi2FreeInstance(c);
        }
    }

    #[test]
    fn an_undeclared_log_category_through_the_c_interface_is_a_warning() {
        let c = instantiate();
        // SAFETY: `c` is live until fmi2FreeInstance; the name arrays are
        // locals of the length passed, of NUL-terminated strings.
        unsafe {
            let names = [c"logCalls".as_ptr(), c"logNothing".as_ptr()];
            assert_eq!(fmi2SetDebugLogging(c, 1, 2, names.as_ptr()), fmi2Status_fmi2Warning);
            let names = [c"logCalls".as_ptr(), std::ptr::null()];
            assert_eq!(fmi2SetDebugLogging(c, 1, 2, names.as_ptr()), fmi2Status_fmi2Warning);
            let names = [c"logCalls".as_ptr(), c"logStatusError".as_ptr()];
            assert_eq!(fmi2SetDebugLogging(c, 1, 2, names.as_ptr()), fmi2Status_fmi2OK);
            assert_eq!(fmi2SetDebugLogging(c, 0, 0, std::ptr::null()), fmi2Status_fmi2OK);
            fmi2FreeInstance(c);
        }
    }
}

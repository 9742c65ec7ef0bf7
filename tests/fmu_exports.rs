//! The exported FMI functions called in-process, as an importer would.
//!
//! The calls keep the FMI 2.0 contract the functions state: a component is
//! used from its fmi2Instantiate to its fmi2FreeInstance by one thread only,
//! every array holds the count passed with it, every string is
//! NUL-terminated, and an FMU state comes from its instance and is not used
//! once freed.

use std::ffi::{CStr, CString};

use fmi_sys::fmi2::*;
use planetwear::fmi::export::*;
use planetwear::fmi::variables::{vr, GUID};

fn instantiate(guid: &str, name: &CStr) -> fmi2Component {
    let guid = CString::new(guid).unwrap();
    // SAFETY: the strings are NUL-terminated and outlive the call; no callbacks.
    unsafe {
        fmi2Instantiate(
            name.as_ptr(),
            fmi2Type_fmi2CoSimulation,
            guid.as_ptr(),
            c"file:///tmp/resources/".as_ptr(),
            std::ptr::null(),
            0,
            0,
        )
    }
}

fn initialized() -> fmi2Component {
    let c = instantiate(GUID, c"life");
    assert!(!c.is_null());
    // SAFETY: `c` is the live instance just made.
    unsafe {
        assert_eq!(fmi2SetupExperiment(c, 0, 0.0, 0.0, 1, 0.01), fmi2Status_fmi2OK);
        assert_eq!(fmi2EnterInitializationMode(c), fmi2Status_fmi2OK);
        assert_eq!(fmi2ExitInitializationMode(c), fmi2Status_fmi2OK);
    }
    c
}

/// fmi2GetFMUstate, then its serialized bytes (fmi2SerializedFMUstateSize,
/// fmi2SerializeFMUstate), each asserted OK.
///
/// # Safety
///
/// `c` is a live instance, used by no other thread meanwhile.
unsafe fn get_and_serialize(c: fmi2Component) -> (fmi2FMUstate, Vec<fmi2Byte>) {
    let mut state: fmi2FMUstate = std::ptr::null_mut();
    let mut size = 0usize;
    // SAFETY: `c` is live (the contract above); the state handle, the size
    // and the buffer of `size` bytes are locals that outlive the calls.
    unsafe {
        assert_eq!(fmi2GetFMUstate(c, &mut state), fmi2Status_fmi2OK);
        assert_eq!(fmi2SerializedFMUstateSize(c, state, &mut size), fmi2Status_fmi2OK);
        let mut bytes = vec![0 as fmi2Byte; size];
        assert_eq!(fmi2SerializeFMUstate(c, state, bytes.as_mut_ptr(), size), fmi2Status_fmi2OK);
        (state, bytes)
    }
}

#[test]
fn the_full_life_cycle() {
    // SAFETY: every instance is live from `initialized` to fmi2FreeInstance;
    // the arrays and out-arguments are locals of the lengths passed.
    unsafe {
        // Both return pointers to static NUL-terminated strings.
        let version = CStr::from_ptr(fmi2GetVersion());
        let platform = CStr::from_ptr(fmi2GetTypesPlatform());
        assert_eq!(version.to_str().unwrap(), "2.0");
        assert_eq!(platform.to_str().unwrap(), "default");
        let c = initialized();
        let refs = [vr::PLANET_1_SUN_MESH_FORCE, vr::SUN_SPEED];
        let mut out = [0.0; 2];
        let h = 1e-4;
        for k in 0..20 {
            assert_eq!(fmi2DoStep(c, k as f64 * h, h, 1), fmi2Status_fmi2OK);
        }
        assert_eq!(fmi2GetReal(c, refs.as_ptr(), 2, out.as_mut_ptr()), fmi2Status_fmi2OK);
        assert!(out[0] > 0.0 && out[1] > 300.0, "{out:?}");
        let mut t = 0.0;
        assert_eq!(fmi2GetRealStatus(c, fmi2StatusKind_fmi2LastSuccessfulTime, &mut t), fmi2Status_fmi2OK);
        assert!((t - 20.0 * h).abs() < 1e-15);
        let mut terminated = 1;
        assert_eq!(
            fmi2GetBooleanStatus(c, fmi2StatusKind_fmi2Terminated, &mut terminated),
            fmi2Status_fmi2OK
        );
        assert_eq!(terminated, 0);
        // Passing the stop time is refused.
        assert_eq!(fmi2DoStep(c, 20.0 * h, 1.0, 1), fmi2Status_fmi2Error);
        fmi2FreeInstance(c);
        let c = initialized();
        assert_eq!(fmi2Terminate(c), fmi2Status_fmi2OK);
        assert_eq!(fmi2Reset(c), fmi2Status_fmi2OK);
        assert_eq!(fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0), fmi2Status_fmi2OK);
        fmi2FreeInstance(c);
    }
}

#[test]
fn illegal_call_sequences_are_errors_and_leave_the_phase() {
    // SAFETY: `c` is live until fmi2FreeInstance; the out-argument is a local.
    unsafe {
        let c = instantiate(GUID, c"order");
        assert_eq!(fmi2DoStep(c, 0.0, 1e-4, 1), fmi2Status_fmi2Error, "doStep before initialization");
        assert_eq!(fmi2ExitInitializationMode(c), fmi2Status_fmi2Error, "exit before enter");
        let mut x = 0.0;
        assert_eq!(
            fmi2GetReal(c, &vr::SUN_SPEED, 1, &mut x),
            fmi2Status_fmi2Error,
            "get before initialization"
        );
        // The phase is unchanged: the proper sequence still works.
        assert_eq!(fmi2EnterInitializationMode(c), fmi2Status_fmi2OK);
        assert_eq!(fmi2ExitInitializationMode(c), fmi2Status_fmi2OK);
        assert_eq!(
            fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0),
            fmi2Status_fmi2Error,
            "setup after initialization"
        );
        assert_eq!(fmi2CancelStep(c), fmi2Status_fmi2Error);
        fmi2FreeInstance(c);
    }
}

#[test]
fn null_pointers_are_errors_and_zero_counts_never_read_them() {
    // SAFETY: NULL is a valid component and a valid array with a zero count
    // (never read); the non-NULL arrays and components are live locals.
    unsafe {
        assert_eq!(fmi2DoStep(std::ptr::null_mut(), 0.0, 1e-4, 1), fmi2Status_fmi2Error);
        fmi2FreeInstance(std::ptr::null_mut());
        let c = initialized();
        assert_eq!(fmi2GetReal(c, std::ptr::null(), 0, std::ptr::null_mut()), fmi2Status_fmi2OK);
        assert_eq!(fmi2SetReal(c, std::ptr::null(), 0, std::ptr::null()), fmi2Status_fmi2OK);
        assert_eq!(fmi2GetReal(c, std::ptr::null(), 1, std::ptr::null_mut()), fmi2Status_fmi2Error);
        fmi2FreeInstance(c);
        let c = initialized();
        let mut x = 0.0;
        assert_eq!(fmi2GetReal(c, &vr::SUN_SPEED, 1, std::ptr::null_mut()), fmi2Status_fmi2Error);
        fmi2FreeInstance(c);
        let c = initialized();
        assert_eq!(fmi2GetReal(c, &99_999, 1, &mut x), fmi2Status_fmi2Error, "unknown value reference");
        fmi2FreeInstance(c);
    }
}

#[test]
fn a_wrong_guid_or_name_gives_no_instance() {
    assert!(instantiate("{00000000-0000-0000-0000-000000000000}", c"guid").is_null());
    assert!(instantiate(GUID, c"").is_null());
    let guid = CString::new(GUID).unwrap();
    // SAFETY: the strings are NUL-terminated and outlive the call; no callbacks.
    let me = unsafe {
        fmi2Instantiate(
            c"me".as_ptr(),
            fmi2Type_fmi2ModelExchange,
            guid.as_ptr(),
            std::ptr::null(),
            std::ptr::null(),
            0,
            0,
        )
    };
    assert!(me.is_null(), "model exchange is refused");
}

#[test]
fn states_get_set_and_round_trip_through_bytes() {
    // SAFETY: `c` is live until fmi2FreeInstance; the states come from it and
    // are not used once freed; arrays and buffers are locals of the lengths passed.
    unsafe {
        let c = initialized();
        let h = 1e-4;
        for k in 0..10 {
            assert_eq!(fmi2DoStep(c, k as f64 * h, h, 1), fmi2Status_fmi2OK);
        }
        let (mut state, bytes) = get_and_serialize(c);
        let mut after = [0.0; 1];
        for k in 10..15 {
            assert_eq!(fmi2DoStep(c, k as f64 * h, h, 1), fmi2Status_fmi2OK);
        }
        assert_eq!(fmi2GetReal(c, &vr::PLANET_1_RING_MESH_FORCE, 1, after.as_mut_ptr()), fmi2Status_fmi2OK);
        // Roll back twice: from the state handle and from its bytes.
        assert_eq!(fmi2SetFMUstate(c, state), fmi2Status_fmi2OK);
        for k in 10..15 {
            assert_eq!(fmi2DoStep(c, k as f64 * h, h, 1), fmi2Status_fmi2OK);
        }
        let mut again = [0.0; 1];
        assert_eq!(fmi2GetReal(c, &vr::PLANET_1_RING_MESH_FORCE, 1, again.as_mut_ptr()), fmi2Status_fmi2OK);
        assert_eq!(after[0].to_bits(), again[0].to_bits());
        let mut restored: fmi2FMUstate = std::ptr::null_mut();
        assert_eq!(fmi2DeSerializeFMUstate(c, bytes.as_ptr(), bytes.len(), &mut restored), fmi2Status_fmi2OK);
        assert_eq!(fmi2SetFMUstate(c, restored), fmi2Status_fmi2OK);
        for k in 10..15 {
            assert_eq!(fmi2DoStep(c, k as f64 * h, h, 1), fmi2Status_fmi2OK);
        }
        assert_eq!(fmi2GetReal(c, &vr::PLANET_1_RING_MESH_FORCE, 1, again.as_mut_ptr()), fmi2Status_fmi2OK);
        assert_eq!(after[0].to_bits(), again[0].to_bits());
        assert_eq!(fmi2FreeFMUstate(c, &mut state), fmi2Status_fmi2OK);
        assert!(state.is_null());
        assert_eq!(fmi2FreeFMUstate(c, &mut restored), fmi2Status_fmi2OK);
        fmi2FreeInstance(c);
    }
}

#[test]
fn an_invalid_parameter_makes_initialization_fail() {
    // SAFETY: both instances are live until fmi2FreeInstance; the values are locals.
    unsafe {
        let c = instantiate(GUID, c"bad");
        let module = -1.5e-3;
        assert_eq!(fmi2SetReal(c, &vr::MODULE, 1, &module), fmi2Status_fmi2OK);
        assert_eq!(fmi2EnterInitializationMode(c), fmi2Status_fmi2OK);
        assert_eq!(fmi2ExitInitializationMode(c), fmi2Status_fmi2Error);
        let nan = f64::NAN;
        let c2 = instantiate(GUID, c"nan");
        assert_eq!(fmi2SetReal(c2, &vr::SUN_TORQUE, 1, &nan), fmi2Status_fmi2Error);
        fmi2FreeInstance(c);
        fmi2FreeInstance(c2);
    }
}

#[test]
fn a_scene_or_wear_state_file_that_is_a_pipe_a_device_or_a_directory_is_refused_at_once() {
    // SAFETY: each thread makes, uses and frees its own instance; the string
    // is NUL-terminated and outlives the call.
    unsafe {
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("fifo");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status().is_ok_and(|s| s.success());
        assert!(made, "mkfifo {}", fifo.display());
        let fifo = fifo.to_str().unwrap().to_string();
        let directory = dir.path().to_str().unwrap().to_string();
        for (v, path) in [
            (vr::SCENE_FILE, fifo.clone()),
            (vr::SCENE_FILE, "/dev/zero".to_string()),
            (vr::SCENE_FILE, directory),
            (vr::WEAR_STATE_FILE, fifo),
            (vr::WEAR_STATE_FILE, "/dev/zero".to_string()),
        ] {
            // In a thread: a regression blocks on the pipe (or reads /dev/zero
            // until memory runs out) instead of returning.
            let (tx, rx) = std::sync::mpsc::channel();
            let p = path.clone();
            std::thread::spawn(move || {
                let c = instantiate(GUID, c"pipe");
                let text = CString::new(p).unwrap();
                assert_eq!(fmi2SetString(c, &v, 1, &text.as_ptr()), fmi2Status_fmi2OK);
                assert_eq!(fmi2EnterInitializationMode(c), fmi2Status_fmi2OK);
                let status = fmi2ExitInitializationMode(c);
                fmi2FreeInstance(c);
                let _ = tx.send(status);
            });
            let status = rx
                .recv_timeout(std::time::Duration::from_secs(30))
                .unwrap_or_else(|_| panic!("fmi2ExitInitializationMode with {v} = {path} did not return"));
            assert_eq!(status, fmi2Status_fmi2Error, "{v} = {path}");
        }
    }
}

#[test]
fn a_communication_step_of_more_internal_steps_than_the_bound_is_refused_at_once() {
    // SAFETY: the thread makes, uses and frees its own instance.
    unsafe {
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            let c = instantiate(GUID, c"long");
            assert_eq!(fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0), fmi2Status_fmi2OK);
            assert_eq!(fmi2EnterInitializationMode(c), fmi2Status_fmi2OK);
            assert_eq!(fmi2ExitInitializationMode(c), fmi2Status_fmi2OK);
            // No stop time: 1e20 s would be ~1e28 internal steps.
            let huge = fmi2DoStep(c, 0.0, 1e20, 1);
            fmi2FreeInstance(c);
            let _ = tx.send(huge);
        });
        let status =
            rx.recv_timeout(std::time::Duration::from_secs(60)).expect("fmi2DoStep(h = 1e20) returns");
        // Discarded (the step is too long, not the call wrong), before any work.
        assert_eq!(status, fmi2Status_fmi2Discard);
    }
}

#[test]
fn deserializing_into_a_held_state_overwrites_it_in_place() {
    // SAFETY: `c` is live until fmi2FreeInstance; the states come from it and
    // are not used once freed; the byte buffer is a local of the length passed.
    unsafe {
        let c = initialized();
        let h = 1e-6;
        assert_eq!(fmi2DoStep(c, 0.0, h, 1), fmi2Status_fmi2OK);
        let (mut state, bytes) = get_and_serialize(c);
        let mut before = 0.0;
        assert_eq!(fmi2GetReal(c, &vr::SUN_ANGLE, 1, &mut before), fmi2Status_fmi2OK);
        // A later state in the same handle, then the earlier bytes into it: the
        // handle is kept (a new one would leave the old allocation unreachable).
        assert_eq!(fmi2DoStep(c, h, h, 1), fmi2Status_fmi2OK);
        assert_eq!(fmi2GetFMUstate(c, &mut state), fmi2Status_fmi2OK);
        let held = state;
        assert_eq!(fmi2DeSerializeFMUstate(c, bytes.as_ptr(), bytes.len(), &mut state), fmi2Status_fmi2OK);
        assert_eq!(state, held);
        assert_eq!(fmi2SetFMUstate(c, state), fmi2Status_fmi2OK);
        let mut after = 0.0;
        assert_eq!(fmi2GetReal(c, &vr::SUN_ANGLE, 1, &mut after), fmi2Status_fmi2OK);
        assert_eq!(before.to_bits(), after.to_bits(), "the state is the deserialized one");
        // A NULL out-pointer is refused before anything is allocated.
        assert_eq!(
            fmi2DeSerializeFMUstate(c, bytes.as_ptr(), bytes.len(), std::ptr::null_mut()),
            fmi2Status_fmi2Error
        );
        assert_eq!(fmi2FreeFMUstate(c, &mut state), fmi2Status_fmi2OK);
        fmi2FreeInstance(c);
    }
}

#[test]
fn a_step_under_a_huge_finite_torque_ends_promptly_without_a_nan() {
    // SAFETY: the thread makes, uses and frees its own instance; the arrays are
    // locals of the lengths passed.
    unsafe {
        // Newton iterates under a ring torque of 6.3e190 N·m put the mesh travel
        // beyond 2^53 pitches, where a loop stepped by k += 1 never ended; now
        // the step is discarded (or refused) at once, and the outputs stay finite.
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            let c = initialized();
            let refs = [vr::SUN_TORQUE, vr::RING_TORQUE, vr::CARRIER_TORQUE];
            let torques = [1023.1, 6.289697328524668e190, 0.0];
            assert_eq!(fmi2SetReal(c, refs.as_ptr(), 3, torques.as_ptr()), fmi2Status_fmi2OK);
            let status = fmi2DoStep(c, 0.0, 1e-7, 0);
            let mut out = [f64::NAN; 2];
            let read =
                fmi2GetReal(c, [vr::SUN_SPEED, vr::PLANET_1_SUN_MESH_FORCE].as_ptr(), 2, out.as_mut_ptr());
            fmi2FreeInstance(c);
            let _ = tx.send((status, read, out));
        });
        let (status, read, out) =
            rx.recv_timeout(std::time::Duration::from_secs(60)).expect("fmi2DoStep returns");
        assert!(status == fmi2Status_fmi2Discard || status == fmi2Status_fmi2Error, "{status}");
        if read == fmi2Status_fmi2OK {
            assert!(out.iter().all(|x| x.is_finite()), "{out:?}");
        }
    }
}

/// Replaces the f64 at `at` in a serialized state and recomputes its FNV-1a
/// checksum (the format of src/dynamics/state_format.rs), as a forger would.
fn forge(bytes: &[fmi2Byte], at: usize, value: f64) -> Vec<fmi2Byte> {
    let mut b: Vec<u8> = bytes.iter().map(|x| *x as u8).collect();
    b[at..at + 8].copy_from_slice(&value.to_le_bytes());
    let n = b.len();
    let h = planetwear::files::hash::fnv1a64(&b[..n - 8]);
    b[n - 8..].copy_from_slice(&h.to_le_bytes());
    b.into_iter().map(|x| x as fmi2Byte).collect()
}

#[test]
fn a_forged_state_with_a_valid_checksum_never_brings_a_nan_or_an_infinity() {
    // SAFETY: `c` is live until fmi2FreeInstance; the states come from it and
    // are not used once freed; arrays and buffers are locals of the lengths passed.
    unsafe {
        let c = instantiate(GUID, c"forged");
        let one = 1;
        assert_eq!(fmi2SetInteger(c, &vr::HARMONIC_WINDOW_CYCLES, 1, &one), fmi2Status_fmi2OK);
        assert_eq!(fmi2EnterInitializationMode(c), fmi2Status_fmi2OK);
        assert_eq!(fmi2ExitInitializationMode(c), fmi2Status_fmi2OK);
        // Two mesh cycles (f_m ≈ 1.7 kHz): the one-cycle window is full.
        let h = 1e-4;
        for k in 0..12 {
            assert_eq!(fmi2DoStep(c, k as f64 * h, h, 1), fmi2Status_fmi2OK);
        }
        let (mut state, bytes) = get_and_serialize(c);
        let u32_at = |i: usize| u32::from_le_bytes(std::array::from_fn(|j| bytes[i + j] as u8)) as usize;
        let time = 16 + u32_at(12);
        // State format 2: eight arrays, the last the load duty's counts.
        let lens: Vec<usize> = (0..8).map(|j| u32_at(time + 8 + 4 * j)).collect();
        let array = |k: usize| time + 8 + 4 * 8 + 8 * lens[..k].iter().sum::<usize>();
        assert!(lens[7] > 0, "the state holds the load duty");
        assert!(lens[3] > 0, "the window holds samples");
        let window_outputs = [vr::WINDOW_SUN_MESH_F1, vr::WINDOW_SUN_MESH_FRMS];
        for (what, at, value) in [
            ("time", time, f64::NAN),
            ("integrator state", array(2), f64::INFINITY),
            ("window sample", array(3), f64::NAN),
            ("speed drive or last window point", array(5), f64::NEG_INFINITY),
            ("load duty count", array(7), f64::NAN),
        ] {
            let forged = forge(&bytes, at, value);
            let mut s: fmi2FMUstate = std::ptr::null_mut();
            assert_eq!(
                fmi2DeSerializeFMUstate(c, forged.as_ptr(), forged.len(), &mut s),
                fmi2Status_fmi2OK,
                "{what}"
            );
            assert_eq!(fmi2SetFMUstate(c, s), fmi2Status_fmi2Error, "{what} = {value} is refused");
            assert_eq!(fmi2FreeFMUstate(c, &mut s), fmi2Status_fmi2OK);
            assert_eq!(fmi2SetFMUstate(c, state), fmi2Status_fmi2OK);
        }
        // A finite but huge sample: accepted, but its square overflows the RMS,
        // which is then refused rather than returned as inf.
        let forged = forge(&bytes, array(3), 1e300);
        let mut s: fmi2FMUstate = std::ptr::null_mut();
        assert_eq!(fmi2DeSerializeFMUstate(c, forged.as_ptr(), forged.len(), &mut s), fmi2Status_fmi2OK);
        assert_eq!(fmi2SetFMUstate(c, s), fmi2Status_fmi2OK);
        let mut out = [0.0; 2];
        assert_eq!(fmi2GetReal(c, window_outputs.as_ptr(), 2, out.as_mut_ptr()), fmi2Status_fmi2Error);
        assert_eq!(fmi2FreeFMUstate(c, &mut s), fmi2Status_fmi2OK);
        assert_eq!(fmi2FreeFMUstate(c, &mut state), fmi2Status_fmi2OK);
        fmi2FreeInstance(c);
    }
}

#[test]
fn a_state_restored_after_the_parameters_changed_continues_with_its_own_parameters() {
    // SAFETY: `c` is live until fmi2FreeInstance; the state comes from it and
    // is not used once freed; the values are locals.
    unsafe {
        let h = 1e-5;
        let force_after_step = |c: fmi2Component, t: f64| {
            assert_eq!(fmi2DoStep(c, t, h, 1), fmi2Status_fmi2OK);
            let mut f = 0.0;
            assert_eq!(fmi2GetReal(c, &vr::PLANET_1_SUN_MESH_FORCE, 1, &mut f), fmi2Status_fmi2OK);
            f
        };
        let c = initialized();
        for k in 0..5 {
            assert_eq!(fmi2DoStep(c, k as f64 * h, h, 1), fmi2Status_fmi2OK);
        }
        let mut state: fmi2FMUstate = std::ptr::null_mut();
        assert_eq!(fmi2GetFMUstate(c, &mut state), fmi2Status_fmi2OK);
        let reference = force_after_step(c, 5.0 * h);
        let mut width = 0.0;
        assert_eq!(fmi2GetReal(c, &vr::FACE_WIDTH, 1, &mut width), fmi2Status_fmi2OK);
        // The same instance rebuilt with another face width (same degrees of
        // freedom, other mesh stiffness), then the earlier state set back: it
        // must continue with the parameters it was saved with.
        assert_eq!(fmi2Reset(c), fmi2Status_fmi2OK);
        let narrower = 0.8 * width;
        assert_eq!(fmi2SetReal(c, &vr::FACE_WIDTH, 1, &narrower), fmi2Status_fmi2OK);
        assert_eq!(fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0), fmi2Status_fmi2OK);
        assert_eq!(fmi2EnterInitializationMode(c), fmi2Status_fmi2OK);
        assert_eq!(fmi2ExitInitializationMode(c), fmi2Status_fmi2OK);
        assert_eq!(fmi2SetFMUstate(c, state), fmi2Status_fmi2OK);
        let mut restored_width = 0.0;
        assert_eq!(fmi2GetReal(c, &vr::FACE_WIDTH, 1, &mut restored_width), fmi2Status_fmi2OK);
        assert_eq!(restored_width, width);
        let again = force_after_step(c, 5.0 * h);
        assert_eq!(again.to_bits(), reference.to_bits(), "{again} N against {reference} N");
        // An input set between saving and restoring: the state's torque comes back.
        let torque = 500.0;
        assert_eq!(fmi2SetReal(c, &vr::SUN_TORQUE, 1, &torque), fmi2Status_fmi2OK);
        assert_eq!(fmi2SetFMUstate(c, state), fmi2Status_fmi2OK);
        assert_eq!(force_after_step(c, 5.0 * h).to_bits(), reference.to_bits());
        assert_eq!(fmi2FreeFMUstate(c, &mut state), fmi2Status_fmi2OK);
        fmi2FreeInstance(c);
    }
}

/// `gearData = 1` with the start values of the gear-data parameters gives
/// the example (its gear data, docs/GEAR_DATA.md): the same mesh force after
/// the same steps as the radius parameters; a bad gear datum or switch value
/// makes initialization fail.
#[test]
fn gear_data_parameters_give_the_example_and_bad_ones_are_refused() {
    // SAFETY: every instance is live until fmi2FreeInstance; values are locals.
    unsafe {
        let force = |gear_data: i32| {
            let c = instantiate(GUID, c"gear-data");
            assert_eq!(fmi2SetInteger(c, &vr::GEAR_DATA, 1, &gear_data), fmi2Status_fmi2OK);
            assert_eq!(fmi2SetupExperiment(c, 0, 0.0, 0.0, 1, 0.01), fmi2Status_fmi2OK);
            assert_eq!(fmi2EnterInitializationMode(c), fmi2Status_fmi2OK);
            assert_eq!(fmi2ExitInitializationMode(c), fmi2Status_fmi2OK);
            for i in 0..5 {
                assert_eq!(fmi2DoStep(c, f64::from(i) * 1e-4, 1e-4, 1), fmi2Status_fmi2OK);
            }
            let mut f = 0.0;
            assert_eq!(fmi2GetReal(c, &vr::PLANET_1_SUN_MESH_FORCE, 1, &mut f), fmi2Status_fmi2OK);
            fmi2FreeInstance(c);
            f
        };
        let (radii, data) = (force(0), force(1));
        assert!(radii > 0.0 && (data / radii - 1.0).abs() < 1e-9, "mesh force {radii} vs {data}");
        for (reference, value) in [(vr::ADDENDUM_FACTOR, -1.0), (vr::SUN_PROFILE_SHIFT, 0.3)] {
            let c = instantiate(GUID, c"bad-gear-data");
            let one = 1;
            assert_eq!(fmi2SetInteger(c, &vr::GEAR_DATA, 1, &one), fmi2Status_fmi2OK);
            assert_eq!(fmi2SetReal(c, &reference, 1, &value), fmi2Status_fmi2OK);
            assert_eq!(fmi2EnterInitializationMode(c), fmi2Status_fmi2OK);
            assert_eq!(fmi2ExitInitializationMode(c), fmi2Status_fmi2Error);
            fmi2FreeInstance(c);
        }
        let c = instantiate(GUID, c"bad-switch");
        let two = 2;
        assert_eq!(fmi2SetInteger(c, &vr::GEAR_DATA, 1, &two), fmi2Status_fmi2OK);
        assert_eq!(fmi2EnterInitializationMode(c), fmi2Status_fmi2OK);
        assert_eq!(fmi2ExitInitializationMode(c), fmi2Status_fmi2Error);
        fmi2FreeInstance(c);
    }
}

//! FMU states still held when their instance is freed are freed with it
//! (FMI 2.0: fmi2FreeInstance frees all the FMU allocated), counted exactly:
//! this test binary's allocator keeps the live bytes, and it runs this one
//! test alone in its process. 10 000 cycles of instantiate, four
//! fmi2GetFMUstate held (one overwritten in place), fmi2FreeInstance,
//! through the C interface as an importer calls it; the live bytes after
//! the last cycle must equal those after the first hundred (each held state
//! is about 2.7 kB: a leak would be 100 MB). Part of the hostile-input suite
//! (tests/hostile_input.rs).

use std::alloc::{GlobalAlloc, Layout, System};
use std::ffi::CString;
use std::sync::atomic::{AtomicIsize, Ordering};

use fmi_sys::fmi2::{fmi2FMUstate, fmi2Status_fmi2OK, fmi2Type_fmi2CoSimulation};
use planetwear::fmi::export::{fmi2FreeFMUstate, fmi2FreeInstance, fmi2GetFMUstate, fmi2Instantiate};
use planetwear::fmi::variables::GUID;

struct Counting;

static LIVE: AtomicIsize = AtomicIsize::new(0);

// SAFETY: every call is passed on to the system allocator unchanged; the
// counter only adds and subtracts the sizes.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        LIVE.fetch_add(layout.size() as isize, Ordering::Relaxed);
        // SAFETY: the caller's contract is GlobalAlloc::alloc's.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        LIVE.fetch_sub(layout.size() as isize, Ordering::Relaxed);
        // SAFETY: `ptr` came from `alloc` with this layout.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        LIVE.fetch_add(new_size as isize - layout.size() as isize, Ordering::Relaxed);
        // SAFETY: the caller's contract is GlobalAlloc::realloc's.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// One cycle: an instance, four states held, the instance freed with them.
/// Returns how many of the calls returned fmi2OK.
fn cycle(guid: &CString) -> usize {
    let mut ok = 0;
    // SAFETY: NUL-terminated strings that outlive the calls; no callbacks;
    // the component is used by this thread only and freed last; the state
    // handles are locals holding NULL or states of this instance.
    unsafe {
        let c = fmi2Instantiate(
            c"held".as_ptr(),
            fmi2Type_fmi2CoSimulation,
            guid.as_ptr(),
            std::ptr::null(),
            std::ptr::null(),
            0,
            0,
        );
        assert!(!c.is_null());
        let mut held: [fmi2FMUstate; 4] = [std::ptr::null_mut(); 4];
        for h in held.iter_mut() {
            ok += usize::from(fmi2GetFMUstate(c, h) == fmi2Status_fmi2OK);
        }
        // Overwriting a held state in place allocates no new one.
        ok += usize::from(fmi2GetFMUstate(c, &mut held[0]) == fmi2Status_fmi2OK);
        fmi2FreeInstance(c);
    }
    ok
}

#[test]
fn states_held_at_free_instance_are_freed_with_it_over_10000_cycles() {
    let guid = CString::new(GUID).unwrap();
    for _ in 0..100 {
        assert_eq!(cycle(&guid), 5);
    }
    let before = LIVE.load(Ordering::Relaxed);
    for _ in 0..10_000 {
        cycle(&guid);
    }
    let grown = LIVE.load(Ordering::Relaxed) - before;
    assert!(
        grown.abs() < 16 * 1024,
        "live bytes grew by {grown} over 10 000 cycles with four states held each"
    );
    // A state freed by the importer before the instance is freed once, and
    // a freed or foreign pointer is refused rather than read.
    // SAFETY: as in `cycle`; `stale` is only compared, never dereferenced
    // (the instance looks states up by address).
    unsafe {
        let c = fmi2Instantiate(
            c"held".as_ptr(),
            fmi2Type_fmi2CoSimulation,
            guid.as_ptr(),
            std::ptr::null(),
            std::ptr::null(),
            0,
            0,
        );
        let mut s: fmi2FMUstate = std::ptr::null_mut();
        assert_eq!(fmi2GetFMUstate(c, &mut s), fmi2Status_fmi2OK);
        let stale = s;
        assert_eq!(fmi2FreeFMUstate(c, &mut s), fmi2Status_fmi2OK);
        assert!(s.is_null());
        let mut again = stale;
        assert_ne!(fmi2FreeFMUstate(c, &mut again), fmi2Status_fmi2OK, "a freed state was freed twice");
        assert_ne!(planetwear::fmi::export::fmi2SetFMUstate(c, stale), fmi2Status_fmi2OK);
        fmi2FreeInstance(c);
    }
}

//! The FMU's C interface driven the way an importer drives it, and worse:
//! the shared library is loaded with libloading (fmi-sys's `Fmi2Binding`
//! resolves the 34 `fmi2*` symbols), and a seeded PRNG calls every function
//! in random orders (illegal ones included) with random and hostile
//! arguments — NaN, ±inf, huge, negative, subnormal reals, wrong and
//! duplicated value references, null pointers where the standard forbids
//! them, non-UTF-8, long and special-file strings, random communication
//! steps, corrupted and forged serialized FMU states. The logger is fmi-sys's
//! C variadic handler (`callback_logger_handler`), whose messages arrive
//! through the `log` facade and are recorded per call.
//!
//! After every call the harness checks: the status is a valid fmi2Status;
//! a call the FMI 2.0 state machine forbids (in the phase this harness
//! tracks independently) returns fmi2Error; a call with an invalid argument
//! never returns fmi2OK; no call returns fmi2Fatal (the FMU answers Fatal
//! only for a caught panic); every fmi2Warning, fmi2Discard and fmi2Error is
//! logged with a message naming the function whether logging is on or off
//! (status messages always reach the logger), and no debug detail is
//! logged with logging off or for a disabled category; every Real read after a successful call is finite.
//! Calling anything on a freed instance or state is undefined behaviour by
//! the standard and is never done.
//!
//! The leak checks count the C allocator's live bytes (`mallinfo2`) over
//! many instantiate/free and FMU-state get/serialize/deserialize/free
//! cycles.
//!
//! Shared by `tests/fmi_fuzz.rs` (native, in `cargo test --release`) and
//! `examples/fmi_fuzz.rs` (the binary `scripts/test.sh` runs under valgrind).

// bindgen's constant names (fmi2Status_fmi2OK, ...) are used as they are.
#![allow(non_upper_case_globals)]

use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::ffi::{CStr, CString};
use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use fmi_sys::fmi2::logger::callback_logger_handler;
use fmi_sys::fmi2::*;
use planetwear::fmi::variables::{vr, Causality, Kind, Start, GUID, LOG_CATEGORIES, VARIABLES};

/// Calls one function of the loaded library.
macro_rules! ffi {
    ($api:expr, $f:ident($($arg:expr),* $(,)?)) => {{
        // SAFETY: the FMI 2.0 contract is kept while everything else varies:
        // every pointer passed is null or points to live memory of at least
        // the length the call is told (arrays of n elements, NUL-terminated
        // strings, a state buffer of `size` bytes); a component comes from
        // fmi2Instantiate and is never used after fmi2FreeInstance; an FMU
        // state comes from this instance and is never used after it is freed.
        unsafe { $api.$f($($arg),*) }
    }};
}

// ---------------------------------------------------------------------------
// The library.

/// The 34 functions of FMI 2.0 co-simulation (common and co-simulation).
pub const EXPORTED: [&str; 34] = [
    "fmi2GetTypesPlatform",
    "fmi2GetVersion",
    "fmi2SetDebugLogging",
    "fmi2Instantiate",
    "fmi2FreeInstance",
    "fmi2SetupExperiment",
    "fmi2EnterInitializationMode",
    "fmi2ExitInitializationMode",
    "fmi2Terminate",
    "fmi2Reset",
    "fmi2GetReal",
    "fmi2GetInteger",
    "fmi2GetBoolean",
    "fmi2GetString",
    "fmi2SetReal",
    "fmi2SetInteger",
    "fmi2SetBoolean",
    "fmi2SetString",
    "fmi2GetFMUstate",
    "fmi2SetFMUstate",
    "fmi2FreeFMUstate",
    "fmi2SerializedFMUstateSize",
    "fmi2SerializeFMUstate",
    "fmi2DeSerializeFMUstate",
    "fmi2GetDirectionalDerivative",
    "fmi2SetRealInputDerivatives",
    "fmi2GetRealOutputDerivatives",
    "fmi2DoStep",
    "fmi2CancelStep",
    "fmi2GetStatus",
    "fmi2GetRealStatus",
    "fmi2GetIntegerStatus",
    "fmi2GetBooleanStatus",
    "fmi2GetStringStatus",
];

/// The FMU's shared library, loaded, with its resources directory.
pub struct Fmu {
    api: Fmi2Binding,
    /// The shared library loaded.
    pub library: PathBuf,
    /// The resources directory the instances are given (a file: URI of it).
    pub resources: PathBuf,
    _dir: tempfile::TempDir,
}

impl Fmu {
    /// The cdylib cargo built with the running test or example binary:
    /// `target/<profile>/deps/libplanetwear.so`, which cargo rebuilds with
    /// every test or example (the copy in `target/<profile>/` is refreshed
    /// only by `cargo build`).
    pub fn built_library() -> Result<PathBuf, String> {
        let exe = std::env::current_exe().map_err(|e| format!("current_exe: {e}"))?;
        let mut dir = exe.parent();
        while let Some(d) = dir {
            for candidate in [d.join("deps/libplanetwear.so"), d.join("libplanetwear.so")] {
                if candidate.is_file() {
                    return Ok(candidate);
                }
            }
            if d.file_name().is_some_and(|n| n == "target") {
                break;
            }
            dir = d.parent();
        }
        Err(format!(
            "libplanetwear.so not found beside {}: build the cdylib first (`cargo build --release`)",
            exe.display()
        ))
    }

    /// Loads a shared library; its resources are a fresh directory holding
    /// the example scene and its unworn wear state.
    pub fn load(library: &Path) -> Result<Self, String> {
        let dir = tempfile::tempdir().map_err(|e| format!("temporary directory: {e}"))?;
        let resources = dir.path().join("resources");
        write_example_resources(&resources)?;
        Self::open(library, resources, dir)
    }

    /// Unpacks a `.fmu` and loads its `binaries/linux64/planetwear.so` with
    /// its own `resources/` (the program's `--fmu`; the test loads the cdylib).
    #[cfg_attr(test, allow(dead_code))]
    pub fn unpack(fmu: &Path) -> Result<Self, String> {
        let dir = tempfile::tempdir().map_err(|e| format!("temporary directory: {e}"))?;
        let file = std::fs::File::open(fmu).map_err(|e| format!("{}: {e}", fmu.display()))?;
        let mut zip = zip::ZipArchive::new(file).map_err(|e| format!("{}: {e}", fmu.display()))?;
        zip.extract(dir.path()).map_err(|e| format!("unpacking {}: {e}", fmu.display()))?;
        let library = dir.path().join("binaries/linux64/planetwear.so");
        let resources = dir.path().join("resources");
        Self::open(&library, resources, dir)
    }

    fn open(library: &Path, resources: PathBuf, dir: tempfile::TempDir) -> Result<Self, String> {
        // SAFETY: loading runs the library's initialisers, which are the Rust
        // standard library's only; the symbols are typed by the FMI headers.
        let api = unsafe { Fmi2Binding::new(library) }
            .map_err(|e| format!("cannot load {}: {e}", library.display()))?;
        let fmu = Self { api, library: library.to_path_buf(), resources, _dir: dir };
        let missing = fmu.missing();
        if !missing.is_empty() {
            return Err(format!("{} does not export {}", library.display(), missing.join(", ")));
        }
        Ok(fmu)
    }

    /// The functions of [`EXPORTED`] the library lacks.
    pub fn missing(&self) -> Vec<&'static str> {
        let a = &self.api;
        let found = [
            a.fmi2GetTypesPlatform.is_ok(),
            a.fmi2GetVersion.is_ok(),
            a.fmi2SetDebugLogging.is_ok(),
            a.fmi2Instantiate.is_ok(),
            a.fmi2FreeInstance.is_ok(),
            a.fmi2SetupExperiment.is_ok(),
            a.fmi2EnterInitializationMode.is_ok(),
            a.fmi2ExitInitializationMode.is_ok(),
            a.fmi2Terminate.is_ok(),
            a.fmi2Reset.is_ok(),
            a.fmi2GetReal.is_ok(),
            a.fmi2GetInteger.is_ok(),
            a.fmi2GetBoolean.is_ok(),
            a.fmi2GetString.is_ok(),
            a.fmi2SetReal.is_ok(),
            a.fmi2SetInteger.is_ok(),
            a.fmi2SetBoolean.is_ok(),
            a.fmi2SetString.is_ok(),
            a.fmi2GetFMUstate.is_ok(),
            a.fmi2SetFMUstate.is_ok(),
            a.fmi2FreeFMUstate.is_ok(),
            a.fmi2SerializedFMUstateSize.is_ok(),
            a.fmi2SerializeFMUstate.is_ok(),
            a.fmi2DeSerializeFMUstate.is_ok(),
            a.fmi2GetDirectionalDerivative.is_ok(),
            a.fmi2SetRealInputDerivatives.is_ok(),
            a.fmi2GetRealOutputDerivatives.is_ok(),
            a.fmi2DoStep.is_ok(),
            a.fmi2CancelStep.is_ok(),
            a.fmi2GetStatus.is_ok(),
            a.fmi2GetRealStatus.is_ok(),
            a.fmi2GetIntegerStatus.is_ok(),
            a.fmi2GetBooleanStatus.is_ok(),
            a.fmi2GetStringStatus.is_ok(),
        ];
        EXPORTED.iter().zip(found).filter(|(_, ok)| !ok).map(|(n, _)| *n).collect()
    }

    fn resource_uri(&self) -> String {
        format!("file://{}", self.resources.display())
    }
}

/// The example scene and its unworn wear state, as `planetwear fmu pack`
/// ships them (`example-2004.toml`, `wear/example-2004/kappa-0.json`).
fn write_example_resources(dir: &Path) -> Result<(), String> {
    use planetwear::scene::Scene;
    use planetwear::wear::archard::WearSettings;
    use planetwear::wear::state::WornState;
    let scene = Scene::example_2004();
    let set = scene.validate().map_err(|e| format!("example scene: {e}"))?;
    let settings = WearSettings::for_set(&set);
    let state = WornState::unworn(&set, settings.profile_points, settings.face_slices);
    let wear = dir.join("wear/example-2004");
    std::fs::create_dir_all(&wear).map_err(|e| format!("{}: {e}", wear.display()))?;
    std::fs::write(dir.join("example-2004.toml"), scene.to_toml()).map_err(|e| format!("scene: {e}"))?;
    let json = state.to_json().map_err(|e| format!("wear state: {e}"))?;
    std::fs::write(wear.join("kappa-0.json"), json).map_err(|e| format!("wear state: {e}"))?;
    Ok(())
}

// ---------------------------------------------------------------------------
// The logger: fmi-sys's C handler formats the message and hands it to the
// `log` facade with the instance name as target; levels map the status
// (OK → Info, Warning → Warn, Discard → Trace, Error and Fatal → Error).

/// One logged message.
#[derive(Clone, Debug)]
pub struct Message {
    /// The status, as fmi-sys maps it.
    pub level: log::Level,
    /// The message.
    pub text: String,
}

static MESSAGES: Mutex<Vec<Message>> = Mutex::new(Vec::new());

struct Recorder;

impl log::Log for Recorder {
    fn enabled(&self, _: &log::Metadata) -> bool {
        true
    }
    fn log(&self, record: &log::Record) {
        if record.module_path() == Some("logger") {
            let m = Message { level: record.level(), text: record.args().to_string() };
            MESSAGES.lock().unwrap_or_else(|e| e.into_inner()).push(m);
        }
    }
    fn flush(&self) {}
}

static RECORDER: Recorder = Recorder;

fn install_recorder() {
    let _ = log::set_logger(&RECORDER);
    log::set_max_level(log::LevelFilter::Trace);
}

fn take_messages() -> Vec<Message> {
    std::mem::take(&mut *MESSAGES.lock().unwrap_or_else(|e| e.into_inner()))
}

fn callbacks(logger: bool) -> Box<fmi2CallbackFunctions> {
    Box::new(fmi2CallbackFunctions {
        logger: if logger { Some(callback_logger_handler) } else { None },
        allocateMemory: None,
        freeMemory: None,
        stepFinished: None,
        componentEnvironment: std::ptr::null_mut(),
    })
}

// ---------------------------------------------------------------------------
// A deterministic PRNG (SplitMix64).

/// SplitMix64: a seed reproduces a run exactly.
pub struct Rng(u64);

impl Rng {
    /// A generator from a seed.
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n.max(1) as u64) as usize
    }
    fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    fn chance(&mut self, p: f64) -> bool {
        self.unit() < p
    }
    fn pick<T: Copy>(&mut self, items: &[T]) -> T {
        items[self.below(items.len())]
    }
    fn weighted<T: Copy>(&mut self, items: &[(T, f64)]) -> T {
        let total: f64 = items.iter().map(|i| i.1).sum();
        let mut x = self.unit() * total;
        for (item, w) in items {
            if x < *w {
                return *item;
            }
            x -= w;
        }
        items[items.len() - 1].0
    }
}

/// Reals no model should accept silently, and a few it should.
const SPECIAL_REALS: [f64; 20] = [
    f64::NAN,
    -f64::NAN,
    f64::INFINITY,
    f64::NEG_INFINITY,
    1e300,
    -1e300,
    f64::MAX,
    f64::MIN,
    1e20,
    -1e20,
    f64::MIN_POSITIVE,
    5e-324,
    -5e-324,
    1e-300,
    0.0,
    -0.0,
    -1.0,
    1.0,
    1e-9,
    -1e9,
];

const SPECIAL_INTEGERS: [i32; 16] =
    [0, 1, -1, 2, 3, 4, 5, 8, 9, 33, 100, 100_000, 100_001, i32::MAX, i32::MIN, -100_000];

/// Communication steps an importer may ask for that stay cheap [s].
const SMALL_STEPS: [f64; 7] = [1e-9, 1e-8, 1e-7, 1e-6, 2e-6, 5e-6, 1e-5];

/// Communication steps no FMU should take (or take at once) [s].
const HOSTILE_STEPS: [f64; 14] = [
    0.0,
    -0.0,
    -1e-6,
    f64::NAN,
    f64::INFINITY,
    f64::NEG_INFINITY,
    1e300,
    f64::MAX,
    1e20,
    1e9,
    5e-324,
    1e-300,
    f64::MIN_POSITIVE,
    -1e300,
];

// ---------------------------------------------------------------------------
// The FMI 2.0 co-simulation state machine, written from the standard
// (FMI 2.0.x §4.2.4), independently of the FMU's own table.

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    Instantiated,
    InitializationMode,
    StepComplete,
    StepFailed,
    Terminated,
    Error,
    Fatal,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Call {
    SetDebugLogging,
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

fn allowed(call: Call, phase: Phase) -> bool {
    use Phase::*;
    match call {
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
        // Only in stepInProgress, which this FMU (no asynchronous steps) never enters.
        Call::CancelStep => false,
        Call::Status => matches!(phase, StepComplete | StepFailed | Terminated),
    }
}

// ---------------------------------------------------------------------------
// The harness's model of each instance.

/// An FMU state the harness holds.
struct StateRec {
    handle: fmi2FMUstate,
    phase: Phase,
    sim: bool,
    poisoned: bool,
    dirty: bool,
    /// Holds huge finite inputs: its next step runs the integrator's whole
    /// work budget (seconds), so rollbacks mostly pick other states.
    hostile: bool,
    time: f64,
    /// Forged with a non-finite number and a valid checksum: setting it must fail.
    non_finite: bool,
}

/// A serialized state the harness holds.
#[derive(Clone)]
struct Blob {
    bytes: Vec<u8>,
    hostile: bool,
}

struct Inst {
    c: fmi2Component,
    id: u64,
    _callbacks: Box<fmi2CallbackFunctions>,
    logger: bool,
    logging_on: bool,
    enabled: BTreeSet<&'static str>,
    phase: Phase,
    /// Whether the FMU may hold a built simulation (false when unsure).
    sim: bool,
    /// Whether the parameters surely fail before the costly contact tables
    /// are built (an invalid `fidelity`; false when unsure).
    poisoned: bool,
    /// Whether a parameter was set since instantiation or reset (a build
    /// then mostly fails early, so build tokens go mostly to clean ones).
    dirty: bool,
    /// An input was set to a huge finite value (see [`StateRec::hostile`]).
    hostile: bool,
    start: f64,
    time: f64,
    states: Vec<StateRec>,
    /// `states[0]` is a checkpoint (a built simulation between steps) that
    /// random frees and overwrites spare, so a failed instance can be rolled
    /// back without building again.
    checkpoint: bool,
    blobs: Vec<Blob>,
}

impl Inst {
    /// Slots a random free or overwrite may take.
    fn spare(&self) -> std::ops::Range<usize> {
        usize::from(self.checkpoint)..self.states.len()
    }
}

#[derive(Clone)]
struct Logging {
    logger: bool,
    on: bool,
    enabled: BTreeSet<&'static str>,
}

impl Logging {
    fn of(i: &Inst) -> Self {
        Self { logger: i.logger, on: i.logging_on, enabled: i.enabled.clone() }
    }
    /// Whether a message of `category` reaches the logger: a status
    /// message always, debug detail with logging on and its category enabled.
    fn shows(&self, category: &str) -> bool {
        self.logger && (category.starts_with("logStatus") || self.on && self.enabled.contains(category))
    }
    /// Whether a message at `level` may appear (some enabled category logs at it).
    fn admits(&self, level: log::Level) -> bool {
        match level {
            log::Level::Info => self.shows("logCalls") || self.shows("logModel"),
            log::Level::Warn => self.shows("logStatusWarning"),
            log::Level::Trace => self.shows("logStatusDiscard"),
            log::Level::Error => self.shows("logStatusError") || self.shows("logStatusFatal"),
            log::Level::Debug => false,
        }
    }
}

fn status_category(status: fmi2Status) -> Option<(&'static str, log::Level)> {
    match status {
        fmi2Status_fmi2Warning => Some(("logStatusWarning", log::Level::Warn)),
        fmi2Status_fmi2Discard => Some(("logStatusDiscard", log::Level::Trace)),
        fmi2Status_fmi2Error => Some(("logStatusError", log::Level::Error)),
        fmi2Status_fmi2Fatal => Some(("logStatusFatal", log::Level::Error)),
        _ => None,
    }
}

/// Status names in fmi2Status order.
pub const STATUS_NAMES: [&str; 5] = ["OK", "Warning", "Discard", "Error", "Fatal"];

// ---------------------------------------------------------------------------
// Configuration, report, failure.

/// What a fuzz run does.
#[derive(Clone, Debug)]
pub struct FuzzConfig {
    /// PRNG seed.
    pub seed: u64,
    /// Calls to make.
    pub calls: u64,
    /// How many calls may build a simulation from valid parameters (each
    /// builds the contact tables, about 0.8 s natively and 20 s under
    /// valgrind); beyond, the harness makes the parameters fail early.
    pub builds: u32,
    /// Share of those builds the harness makes cheap (`fidelity` 0 or 2, half each;
    /// force evaluations about 10 times cheaper: a run-away step that uses
    /// its whole work budget costs 0.2 s instead of 2 s).
    pub torsional: f64,
    /// A call that takes longer than this is reported as a hang.
    pub hang_after: Duration,
}

/// What a fuzz run did.
#[derive(Clone, Debug, Default)]
pub struct FuzzReport {
    /// PRNG seed.
    pub seed: u64,
    /// Calls made into the library.
    pub calls: u64,
    /// Returned statuses, in [`STATUS_NAMES`] order.
    pub statuses: [u64; 5],
    /// Statuses per function.
    pub per_function: BTreeMap<&'static str, [u64; 5]>,
    /// Time spent in each function [s], and its slowest call [s].
    pub time: BTreeMap<&'static str, (f64, f64)>,
    /// Instances created (fmi2Instantiate returned non-NULL).
    pub instances: u64,
    /// fmi2Instantiate calls refused (NULL) as the harness expected.
    pub instantiations_refused: u64,
    /// Calls allowed to build from valid parameters.
    pub builds: u32,
    /// Messages the logger received.
    pub messages: u64,
    /// Warning/Discard/Error returns, each logged.
    pub refusals_logged: u64,
    /// Warning/Discard/Error returns of instances without a logger callback, each silent.
    pub refusals_silent: u64,
    /// Calls with an argument the harness knows to be invalid (each refused).
    pub invalid_arguments: u64,
    /// Calls the state machine forbids in the current phase (each fmi2Error).
    pub forbidden_calls: u64,
    /// Reals read after successful calls (each finite).
    pub reals_checked: u64,
    /// Wall time [s].
    pub seconds: f64,
}

impl fmt::Display for FuzzReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "seed {:#x}, calls {}, {:.1} s", self.seed, self.calls, self.seconds)?;
        let s: Vec<String> =
            STATUS_NAMES.iter().zip(self.statuses).map(|(n, c)| format!("{n} {c}")).collect();
        writeln!(f, "statuses: {}", s.join(", "))?;
        writeln!(f, "crashes 0, fmi2Fatal {}, invariant violations 0", self.statuses[4])?;
        writeln!(
            f,
            "instances {} (+{} instantiations refused), builds from valid parameters {}",
            self.instances, self.instantiations_refused, self.builds
        )?;
        writeln!(
            f,
            "forbidden calls {} (all fmi2Error), invalid arguments {} (all refused)",
            self.forbidden_calls, self.invalid_arguments
        )?;
        writeln!(
            f,
            "refusals logged {}, silent (no logger callback) {}, messages {}, reals checked finite {}",
            self.refusals_logged, self.refusals_silent, self.messages, self.reals_checked
        )?;
        writeln!(
            f,
            "per function (OK/Warning/Discard/Error/Fatal, time [s], slowest call [s]; fmi2Instantiate: \
             an instance as OK, NULL as Error):"
        )?;
        for (name, c) in &self.per_function {
            let (t, slowest) = self.time.get(name).copied().unwrap_or_default();
            writeln!(
                f,
                "  {name:<30} {:>7} {:>5} {:>5} {:>7} {:>3} {t:>8.2} {slowest:>7.3}",
                c[0], c[1], c[2], c[3], c[4]
            )?;
        }
        Ok(())
    }
}

/// An invariant broken: what, and the calls that led to it.
#[derive(Debug)]
pub struct Failure {
    /// The seed that reproduces it.
    pub seed: u64,
    /// Calls made before it.
    pub calls: u64,
    /// What broke.
    pub what: String,
    /// The last calls, oldest first.
    pub trace: Vec<String>,
}

impl fmt::Display for Failure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "invariant broken at call {} (seed {:#x}): {}", self.calls, self.seed, self.what)?;
        writeln!(f, "last calls:")?;
        for t in &self.trace {
            writeln!(f, "  {t}")?;
        }
        Ok(())
    }
}

/// The calls made last and the one under way.
#[derive(Default)]
struct Calls {
    trace: VecDeque<String>,
    current: Option<Instant>,
}

/// Keeps the last calls and reports a call that does not return in time,
/// with the calls before it, then ends the process (a hang cannot be
/// unwound).
struct Watchdog {
    calls: Arc<Mutex<Calls>>,
}

impl Watchdog {
    fn start(limit: Duration, seed: u64) -> Self {
        let calls: Arc<Mutex<Calls>> = Arc::default();
        let watched = Arc::downgrade(&calls);
        std::thread::spawn(move || loop {
            std::thread::sleep(Duration::from_millis(250));
            let Some(cell) = watched.upgrade() else { return };
            let c = cell.lock().unwrap_or_else(|e| e.into_inner());
            if c.current.is_some_and(|since| since.elapsed() > limit) {
                eprintln!(
                    "fmi fuzz: a call hangs (more than {} s, seed {seed:#x}); last calls:",
                    limit.as_secs()
                );
                for t in &c.trace {
                    eprintln!("  {t}");
                }
                std::process::exit(3);
            }
        });
        Self { calls }
    }
    fn lock(&self) -> std::sync::MutexGuard<'_, Calls> {
        self.calls.lock().unwrap_or_else(|e| e.into_inner())
    }
    fn record(&self, what: &str) {
        let mut c = self.lock();
        c.trace.push_back(what.to_string());
        if c.trace.len() > 40 {
            c.trace.pop_front();
        }
    }
    fn enter(&self, what: &str) {
        self.record(what);
        self.lock().current = Some(Instant::now());
    }
    fn leave(&self) {
        self.lock().current = None;
    }
    fn trace(&self) -> Vec<String> {
        self.lock().trace.iter().cloned().collect()
    }
}

// ---------------------------------------------------------------------------
// Hostile inputs.

/// Files and names for the string parameters, made once per run.
struct Files {
    _dir: tempfile::TempDir,
    choices: Vec<Vec<u8>>,
}

impl Files {
    fn new(resources: &Path) -> Result<Self, String> {
        let dir = tempfile::tempdir().map_err(|e| format!("temporary directory: {e}"))?;
        let d = dir.path();
        let write = |name: &str, data: &[u8]| {
            let p = d.join(name);
            std::fs::write(&p, data).map(|()| p).map_err(|e| format!("{name}: {e}"))
        };
        let garbage_toml = write("garbage.toml", b"[sun\nteeth = = 3\n\xff\xfe")?;
        let garbage_json = write("garbage.json", b"{\"kappa\": [1, 2,")?;
        let scene = std::fs::read(resources.join("example-2004.toml")).unwrap_or_default();
        let bad_scene = String::from_utf8_lossy(&scene).replacen("teeth = 34", "teeth = -34", 1);
        let bad_scene = write("bad-scene.toml", bad_scene.as_bytes())?;
        let wear = std::fs::read(resources.join("wear/example-2004/kappa-0.json")).unwrap_or_default();
        let truncated_wear = write("truncated-wear.json", &wear[..wear.len() / 2])?;
        let fifo = d.join("fifo");
        let fifo_made =
            std::process::Command::new("mkfifo").arg(&fifo).status().map(|s| s.success()).unwrap_or(false);
        let path = |p: &Path| p.as_os_str().as_encoded_bytes().to_vec();
        let mut choices: Vec<Vec<u8>> = vec![
            b"".to_vec(),
            b"/nonexistent/planetwear/scene.toml".to_vec(),
            b"no/such/file.json".to_vec(),
            b"\xff\xfe\xfd/scene\x80.toml".to_vec(),
            "a/".repeat(3000).into_bytes(),
            "x".repeat(300).into_bytes(),
            b"%s%s%n%x%p".to_vec(),
            b"/".to_vec(),
            b"/tmp".to_vec(),
            b"/dev/null".to_vec(),
            b"/dev/zero".to_vec(),
            b"/proc/self/status".to_vec(),
            b"lumped-benchmark.toml".to_vec(),
            b"wear/example-2004/kappa-99.json".to_vec(),
            path(&garbage_toml),
            path(&garbage_json),
            path(&bad_scene),
            path(&truncated_wear),
        ];
        if fifo_made {
            choices.push(path(&fifo));
        }
        for name in ["example-2004.toml", "wear/example-2004/kappa-0.json", "wear/example-2004/kappa-3.json"]
        {
            if resources.join(name).is_file() {
                choices.push(name.as_bytes().to_vec());
            }
        }
        Ok(Self { _dir: dir, choices })
    }
}

/// Where the numbers of a serialized state are: (offset of the time,
/// offset of the seven array lengths, number of f64 after the time).
/// Arrays of the serialized state (format version 2: the load duty's counts are the eighth).
const ARRAYS: usize = 8;

fn blob_layout(b: &[u8]) -> Option<(usize, usize, usize)> {
    if b.len() < 16 + 8 + 4 * ARRAYS + 40 {
        return None;
    }
    let flen = u32::from_le_bytes(b[12..16].try_into().ok()?) as usize;
    let time = 16 + flen;
    let lens = time + 8;
    let floats = b.len().checked_sub(lens + 4 * ARRAYS + 8)? / 8;
    Some((time, lens, floats))
}

fn fix_checksum(b: &mut [u8]) {
    let n = b.len();
    let sum = planetwear::files::hash::fnv1a64(&b[..n - 8]);
    b[n - 8..].copy_from_slice(&sum.to_le_bytes());
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Forgery {
    /// As serialized.
    None,
    /// Refused by the format: cut, flipped, random, another version,
    /// another fingerprint, a wrong length.
    Refused,
    /// A valid checksum over a non-finite number: refused at the latest by fmi2SetFMUstate.
    NonFinite,
    /// A valid checksum over finite but hostile numbers or swapped array
    /// lengths: anything but a crash or a NaN.
    Hostile,
}

fn forge(rng: &mut Rng, blob: &[u8]) -> (Vec<u8>, Forgery, &'static str) {
    let mut b = blob.to_vec();
    let layout = blob_layout(&b);
    match rng.below(10) {
        0 => {
            let n = rng.below(b.len());
            b.truncate(n);
            (b, Forgery::Refused, "truncated")
        }
        1 if !b.is_empty() => {
            let i = rng.below(b.len());
            b[i] ^= 1 << rng.below(8);
            (b, Forgery::Refused, "bit-flipped")
        }
        2 => {
            let n = rng.below(600);
            let mut r: Vec<u8> = (0..n).map(|_| rng.next_u64() as u8).collect();
            if rng.chance(0.5) && r.len() >= 8 {
                r[..8].copy_from_slice(b"PWSTATE\0");
            }
            (r, Forgery::Refused, "random bytes")
        }
        3 if b.len() > 12 => {
            b[8] = b[8].wrapping_add(1);
            fix_checksum(&mut b);
            (b, Forgery::Refused, "another version")
        }
        4 if b.len() > 24 => {
            b[20] ^= 0x20;
            fix_checksum(&mut b);
            (b, Forgery::Refused, "another fingerprint")
        }
        5 => match layout {
            Some((_, lens, _)) => {
                let k = lens + 4 * rng.below(ARRAYS);
                let v = u32::from_le_bytes(b[k..k + 4].try_into().unwrap_or([0; 4]));
                let w = rng.pick(&[v.wrapping_add(1), v.wrapping_sub(1), 0, u32::MAX]);
                if w == v {
                    return (b, Forgery::None, "as serialized");
                }
                b[k..k + 4].copy_from_slice(&w.to_le_bytes());
                fix_checksum(&mut b);
                (b, Forgery::Refused, "a wrong array length")
            }
            None => (b, Forgery::None, "as serialized"),
        },
        6 => match layout {
            Some((_, lens, _)) => {
                // Moves one element from one array to another: the total
                // length (and so the format's check) still holds.
                let (i, j) = (rng.below(ARRAYS), rng.below(ARRAYS));
                let (ki, kj) = (lens + 4 * i, lens + 4 * j);
                let vi = u32::from_le_bytes(b[ki..ki + 4].try_into().unwrap_or([0; 4]));
                let vj = u32::from_le_bytes(b[kj..kj + 4].try_into().unwrap_or([0; 4]));
                if i == j || vi == 0 {
                    return (b, Forgery::None, "as serialized");
                }
                b[ki..ki + 4].copy_from_slice(&(vi - 1).to_le_bytes());
                b[kj..kj + 4].copy_from_slice(&(vj + 1).to_le_bytes());
                fix_checksum(&mut b);
                (b, Forgery::Hostile, "array lengths shifted")
            }
            None => (b, Forgery::None, "as serialized"),
        },
        7..=8 => match layout {
            Some((time, _, floats)) => {
                // One number replaced: the time (index 0), an array element
                // or a torque, with the checksum recomputed.
                let index = rng.below(floats + 1);
                let at = if index == 0 { time } else { time + 8 + 4 * ARRAYS + 8 * (index - 1) };
                let v = rng.pick(&SPECIAL_REALS);
                b[at..at + 8].copy_from_slice(&v.to_le_bytes());
                fix_checksum(&mut b);
                let kind = if v.is_finite() { Forgery::Hostile } else { Forgery::NonFinite };
                (b, kind, if index == 0 { "a forged time" } else { "a forged number" })
            }
            None => (b, Forgery::None, "as serialized"),
        },
        _ => (b, Forgery::None, "as serialized"),
    }
}

fn blob_time(b: &[u8]) -> f64 {
    blob_layout(b)
        .and_then(|(t, _, _)| b.get(t..t + 8))
        .and_then(|s| s.try_into().ok())
        .map(f64::from_le_bytes)
        .unwrap_or(0.0)
}

// ---------------------------------------------------------------------------
// The engine.

#[derive(Clone, Copy, Debug, PartialEq)]
enum Op {
    Free,
    SetDebugLogging,
    SetupExperiment,
    Enter,
    Exit,
    Terminate,
    Reset,
    GetReal,
    GetInteger,
    GetBoolean,
    GetString,
    SetReal,
    SetInteger,
    SetBoolean,
    SetString,
    GetState,
    SetState,
    FreeState,
    SerializeState,
    DeserializeState,
    DirectionalDerivative,
    SetInputDerivatives,
    GetOutputDerivatives,
    DoStep,
    CancelStep,
    GetStatus,
    NullComponent,
    Platform,
}

const ALL_OPS: [Op; 28] = [
    Op::Free,
    Op::SetDebugLogging,
    Op::SetupExperiment,
    Op::Enter,
    Op::Exit,
    Op::Terminate,
    Op::Reset,
    Op::GetReal,
    Op::GetInteger,
    Op::GetBoolean,
    Op::GetString,
    Op::SetReal,
    Op::SetInteger,
    Op::SetBoolean,
    Op::SetString,
    Op::GetState,
    Op::SetState,
    Op::FreeState,
    Op::SerializeState,
    Op::DeserializeState,
    Op::DirectionalDerivative,
    Op::SetInputDerivatives,
    Op::GetOutputDerivatives,
    Op::DoStep,
    Op::CancelStep,
    Op::GetStatus,
    Op::NullComponent,
    Op::Platform,
];

/// How a call is judged.
struct Expect {
    /// The harness's state-machine call kind (None: no component involved).
    call: Option<Call>,
    /// Why the call must not return fmi2OK, if it must not.
    invalid: Option<String>,
}

struct Engine<'a> {
    fmu: &'a Fmu,
    rng: Rng,
    insts: Vec<Inst>,
    next_id: u64,
    /// Calls to make and builds allowed in the run.
    calls: u64,
    builds: u32,
    tokens: u32,
    torsional: f64,
    report: FuzzReport,
    files: Files,
    /// States of instances that ended in fmi2Fatal: the standard allows no
    /// call to free them.
    stranded: Vec<fmi2FMUstate>,
    watchdog: Watchdog,
    /// Every call, its status and messages to stderr (`PLANETWEAR_FUZZ_VERBOSE`).
    verbose: bool,
}

/// Runs the fuzzer; every instance and state is freed at the end.
pub fn fuzz(fmu: &Fmu, cfg: &FuzzConfig) -> Result<FuzzReport, Box<Failure>> {
    install_recorder();
    take_messages();
    let started = Instant::now();
    let files = Files::new(&fmu.resources)
        .map_err(|what| Box::new(Failure { seed: cfg.seed, calls: 0, what, trace: Vec::new() }))?;
    let mut e = Engine {
        fmu,
        rng: Rng::new(cfg.seed),
        insts: Vec::new(),
        next_id: 0,
        calls: cfg.calls,
        builds: cfg.builds,
        tokens: cfg.builds,
        torsional: cfg.torsional,
        report: FuzzReport { seed: cfg.seed, ..FuzzReport::default() },
        files,
        stranded: Vec::new(),
        watchdog: Watchdog::start(cfg.hang_after, cfg.seed),
        verbose: std::env::var_os("PLANETWEAR_FUZZ_VERBOSE").is_some(),
    };
    let run = e.run(cfg.calls).and_then(|()| e.teardown());
    e.report.builds = cfg.builds - e.tokens;
    e.report.seconds = started.elapsed().as_secs_f64();
    run.map(|()| e.report.clone()).map_err(|what| {
        Box::new(Failure { seed: cfg.seed, calls: e.report.calls, what, trace: e.watchdog.trace() })
    })
}

type Check = Result<(), String>;

impl Engine<'_> {
    fn run(&mut self, calls: u64) -> Check {
        while self.report.calls < calls {
            if self.insts.is_empty() || (self.insts.len() < 3 && self.rng.chance(0.01)) {
                self.instantiate()?;
                continue;
            }
            // Half the calls go to built instances, where steps and states are.
            let built: Vec<usize> = (0..self.insts.len()).filter(|&k| self.insts[k].sim).collect();
            let k = if !built.is_empty() && self.rng.chance(0.5) {
                self.rng.pick(&built)
            } else {
                self.rng.below(self.insts.len())
            };
            let op = self.choose(k);
            self.apply(k, op)?;
        }
        Ok(())
    }

    fn teardown(&mut self) -> Check {
        while !self.insts.is_empty() {
            self.free(0)?;
        }
        Ok(())
    }

    fn choose(&mut self, k: usize) -> Op {
        let op = self.choose_any(k);
        // A built instance cost a build: it is kept for long runs of calls.
        if matches!(op, Op::Free | Op::Reset) && self.insts[k].sim && !self.rng.chance(0.02) {
            return Op::DoStep;
        }
        op
    }

    fn choose_any(&mut self, k: usize) -> Op {
        if self.rng.chance(0.12) {
            return self.rng.pick(&ALL_OPS);
        }
        let i = &self.insts[k];
        use Op::*;
        let table: &[(Op, f64)] = match i.phase {
            Phase::Instantiated => &[
                (SetupExperiment, 2.0),
                (Enter, 4.0),
                (SetReal, 3.0),
                (SetInteger, 2.0),
                (SetString, 1.5),
                (SetBoolean, 0.2),
                (SetDebugLogging, 1.0),
                (GetState, 0.5),
                (SetState, 0.5),
                (SerializeState, 0.3),
                (DeserializeState, 0.3),
                (Reset, 0.3),
                (Free, 0.3),
            ],
            Phase::InitializationMode => &[
                (SetReal, 2.0),
                (SetInteger, 1.0),
                (SetString, 0.7),
                (GetReal, 1.0),
                (GetInteger, 0.5),
                (GetString, 0.5),
                (Exit, 4.0),
                (GetState, 0.5),
                (SetState, 0.3),
                (SetDebugLogging, 0.3),
                (Reset, 0.2),
                (Free, 0.2),
            ],
            Phase::StepComplete => &[
                (DoStep, 8.0),
                (GetReal, 4.0),
                (GetInteger, 1.5),
                (GetString, 0.5),
                (SetReal, 3.0),
                (SetInteger, 0.3),
                (GetState, 1.0),
                (SetState, 1.0),
                (FreeState, 0.5),
                (SerializeState, 1.0),
                (DeserializeState, 1.5),
                (GetStatus, 1.0),
                (Terminate, 0.2),
                (Reset, 0.1),
                (Free, 0.05),
                (SetDebugLogging, 0.3),
                (DirectionalDerivative, 0.1),
                (SetInputDerivatives, 0.1),
                (GetOutputDerivatives, 0.1),
            ],
            Phase::StepFailed => &[
                (SetState, 4.0),
                (GetStatus, 2.0),
                (GetReal, 1.0),
                (Terminate, 0.5),
                (Reset, 0.3),
                (Free, 0.2),
                (GetState, 0.3),
            ],
            Phase::Terminated => {
                &[(SetState, 3.0), (GetReal, 1.0), (GetStatus, 1.0), (Reset, 0.5), (Free, 0.5)]
            }
            Phase::Error => &[
                (SetState, 4.0),
                (GetReal, 1.0),
                (GetState, 0.3),
                (SerializeState, 0.3),
                (Reset, 0.5),
                (Free, 0.3),
                (SetDebugLogging, 0.2),
            ],
            Phase::Fatal => &[(Free, 3.0), (DoStep, 0.3), (GetReal, 0.3), (Reset, 0.3)],
        };
        let held = !i.states.is_empty();
        let hostile = i.hostile;
        let weights: Vec<(Op, f64)> = table
            .iter()
            .map(|&(op, w)| match op {
                SetState if !held => (op, 0.1),
                // A step with huge inputs runs the integrator's work budget.
                DoStep if hostile => (op, 0.3),
                _ => (op, w),
            })
            .collect();
        self.rng.weighted(&weights)
    }

    fn apply(&mut self, k: usize, op: Op) -> Check {
        match op {
            Op::Free => self.free(k),
            Op::SetDebugLogging => self.set_debug_logging(k),
            Op::SetupExperiment => self.setup_experiment(k),
            Op::Enter => self.simple(k, Op::Enter),
            Op::Exit => self.exit(k),
            Op::Terminate => self.simple(k, Op::Terminate),
            Op::Reset => self.simple(k, Op::Reset),
            Op::GetReal | Op::GetInteger | Op::GetBoolean | Op::GetString => self.get(k, op),
            Op::SetReal | Op::SetInteger | Op::SetBoolean | Op::SetString => self.set(k, op),
            Op::GetState => self.get_state(k),
            Op::SetState => self.set_state(k),
            Op::FreeState => self.free_state(k),
            Op::SerializeState => self.serialize(k),
            Op::DeserializeState => self.deserialize(k),
            Op::DirectionalDerivative | Op::SetInputDerivatives | Op::GetOutputDerivatives => {
                self.derivatives(k, op)
            }
            Op::DoStep => self.do_step(k),
            Op::CancelStep => self.simple(k, Op::CancelStep),
            Op::GetStatus => self.status(k),
            Op::NullComponent => self.null_component(),
            Op::Platform => self.platform(),
        }
    }

    // -- the call wrapper and its checks ----------------------------------

    /// Makes one call on instance `k` (or none), checks it, and returns
    /// its status. `after` updates the model from the status before the
    /// logging checks.
    fn call(
        &mut self,
        k: Option<usize>,
        name: &'static str,
        desc: String,
        expect: Expect,
        f: impl FnOnce(&Fmi2Binding) -> fmi2Status,
        after: impl FnOnce(&mut Self, fmi2Status),
    ) -> Result<fmi2Status, String> {
        let line = format!("{name}({desc})");
        let before = k.map(|k| (Logging::of(&self.insts[k]), self.insts[k].phase));
        take_messages();
        let api = &self.fmu.api;
        self.watchdog.enter(&line);
        let started = Instant::now();
        let status = f(api);
        let took = started.elapsed().as_secs_f64();
        self.watchdog.leave();
        let spent = self.report.time.entry(name).or_default();
        spent.0 += took;
        spent.1 = spent.1.max(took);
        if self.verbose && took > 0.1 {
            eprintln!("slow ({took:.2} s): {line}");
        }
        let messages = take_messages();
        self.report.calls += 1;
        self.report.messages += messages.len() as u64;
        if self.verbose {
            eprintln!("{line} -> {}", STATUS_NAMES.get(status as usize).unwrap_or(&"?"));
            for m in &messages {
                eprintln!("    {:?}: {}", m.level, m.text);
            }
        }
        if status > fmi2Status_fmi2Fatal {
            return Err(format!("{line} returned {status}, not a valid fmi2Status"));
        }
        let counts = self.report.per_function.entry(name).or_default();
        counts[status as usize] += 1;
        self.report.statuses[status as usize] += 1;
        if let Some(m) = messages.iter().find(|m| m.text.is_empty()) {
            return Err(format!("{line}: an empty message was logged at {:?}", m.level));
        }
        let Some((logging, phase)) = before else {
            if let Some(m) = messages.first() {
                return Err(format!("{line}: logged '{}' without an instance", m.text));
            }
            return Ok(status);
        };
        let k = k.unwrap_or(0);
        let forbidden = expect.call.is_some_and(|c| !allowed(c, phase));
        if forbidden {
            self.report.forbidden_calls += 1;
            if status != fmi2Status_fmi2Error {
                return Err(format!(
                    "{line} in phase {phase:?}: the state machine forbids it, returned {}",
                    STATUS_NAMES[status as usize]
                ));
            }
        } else if let Some(why) = &expect.invalid {
            self.report.invalid_arguments += 1;
            if status == fmi2Status_fmi2OK {
                return Err(format!("{line}: returned OK though {why}"));
            }
        }
        if status == fmi2Status_fmi2Fatal {
            return Err(format!("{line}: fmi2Fatal (a panic inside the FMU): {messages:?}"));
        }
        if forbidden {
            // The phase is left as it was.
        } else if status == fmi2Status_fmi2Error {
            self.insts[k].phase = Phase::Error;
        }
        if !forbidden {
            after(self, status);
        }
        let now = Logging::of(&self.insts[k]);
        for m in &messages {
            if !logging.admits(m.level) && !now.admits(m.level) {
                return Err(format!(
                    "{line}: '{}' logged at {:?} with logging {} and categories {:?}",
                    m.text,
                    m.level,
                    if logging.on { "on" } else { "off" },
                    logging.enabled
                ));
            }
        }
        if !forbidden
            && logging.shows("logCalls")
            && !messages.iter().any(|m| m.level == log::Level::Info && m.text.contains(name))
        {
            return Err(format!("{line}: logCalls is enabled but the call was not logged"));
        }
        if let Some((category, level)) = status_category(status) {
            if now.shows(category) {
                // The message names the function and says why: more than the name.
                let explained =
                    |m: &Message| m.level == level && m.text.contains(name) && m.text.len() > name.len() + 8;
                if !messages.iter().any(explained) {
                    return Err(format!(
                        "{line} returned {} with {category} enabled, but logged no message naming {name} and the reason: {messages:?}",
                        STATUS_NAMES[status as usize]
                    ));
                }
                self.report.refusals_logged += 1;
            } else {
                self.report.refusals_silent += 1;
            }
        }
        Ok(status)
    }

    fn c(&self, k: usize) -> fmi2Component {
        self.insts[k].c
    }

    fn describe(&self, k: usize) -> String {
        let i = &self.insts[k];
        format!("#{} {:?}", i.id, i.phase)
    }

    // -- instances ---------------------------------------------------------

    fn instantiate(&mut self) -> Check {
        let id = self.next_id;
        self.next_id += 1;
        let r = &mut self.rng;
        let (name, name_ok, name_desc): (Option<CString>, bool, String) = match r.below(20) {
            0 => (None, false, "NULL".into()),
            1 => (Some(CString::default()), false, "\"\"".into()),
            2 => (
                Some(CString::new(b"\xff\xfeinstance".to_vec()).unwrap_or_default()),
                true,
                "non-UTF-8".into(),
            ),
            3 => (Some(CString::new("n".repeat(10_000)).unwrap_or_default()), true, "10000 chars".into()),
            _ => (Some(CString::new(format!("fuzz-{id}")).unwrap_or_default()), true, format!("fuzz-{id}")),
        };
        let (kind, kind_ok) = match r.below(20) {
            0 => (fmi2Type_fmi2ModelExchange, false),
            1 => (7, false),
            _ => (fmi2Type_fmi2CoSimulation, true),
        };
        let (guid, guid_ok, guid_desc): (Option<CString>, bool, &str) = match r.below(20) {
            0 => (None, false, "NULL"),
            1 => (Some(CString::default()), false, "\"\""),
            2 => (Some(c"{00000000-0000-0000-0000-000000000000}".to_owned()), false, "another"),
            _ => (Some(CString::new(GUID).unwrap_or_default()), true, "right"),
        };
        let res = self.fmu.resources.display().to_string();
        let (uri, uri_ok): (Option<String>, bool) = match r.below(20) {
            0..=4 => (None, true),
            5 => (Some(format!("file://{res}/")), true),
            6 => (Some(format!("file:{res}")), true),
            7 => (Some(format!("file://localhost{res}")), true),
            8 => (Some("http://example.com/resources".into()), false),
            9 => (Some("file://otherhost/resources".into()), false),
            10 => (Some("file:///bad%zz/%ff%fe".into()), false),
            11 => (Some("file:///nonexistent/resources/".into()), true),
            12 => (Some("resources".into()), false),
            _ => (Some(self.fmu.resource_uri()), true),
        };
        let uri_c = uri.as_ref().map(|u| CString::new(u.as_str()).unwrap_or_default());
        let (cb, logger, cb_desc) = match r.below(10) {
            0 => (None, false, "NULL"),
            1 => (Some(callbacks(false)), false, "no logger"),
            _ => (Some(callbacks(true)), true, "logger"),
        };
        let visible = r.pick(&[0, 1, 2]);
        let logging_on = r.pick(&[0, 1, 1, 5]);
        let expected = name_ok && kind_ok && guid_ok && uri_ok;
        let desc = format!(
            "name {name_desc}, type {kind}, GUID {guid_desc}, resources {:?}, callbacks {cb_desc}, visible {visible}, loggingOn {logging_on}",
            uri.as_deref().unwrap_or("NULL")
        );
        let line = format!("fmi2Instantiate({desc})");
        take_messages();
        let ptr = |s: &Option<CString>| s.as_ref().map_or(std::ptr::null(), |s| s.as_ptr());
        let cb_ptr = cb.as_ref().map_or(std::ptr::null(), |b| &**b as *const fmi2CallbackFunctions);
        self.watchdog.enter(&line);
        let started = Instant::now();
        let c = ffi!(
            self.fmu.api,
            fmi2Instantiate(ptr(&name), kind, ptr(&guid), ptr(&uri_c), cb_ptr, visible, logging_on)
        );
        let took = started.elapsed().as_secs_f64();
        self.watchdog.leave();
        let messages = take_messages();
        self.report.calls += 1;
        self.report.messages += messages.len() as u64;
        // In the table an instance counts as OK, a NULL as Error.
        self.report.per_function.entry("fmi2Instantiate").or_default()[if c.is_null() { 3 } else { 0 }] += 1;
        let spent = self.report.time.entry("fmi2Instantiate").or_default();
        spent.0 += took;
        spent.1 = spent.1.max(took);
        if c.is_null() {
            if expected {
                return Err(format!("{line}: NULL for valid arguments: {messages:?}"));
            }
            self.report.instantiations_refused += 1;
            if logger
                && !messages
                    .iter()
                    .any(|m| m.level == log::Level::Error && m.text.contains("fmi2Instantiate"))
            {
                return Err(format!("{line}: refused without a logged reason: {messages:?}"));
            }
            return Ok(());
        }
        if !expected {
            // Freed at once: the harness does not use an instance it expected refused.
            ffi!(self.fmu.api, fmi2FreeInstance(c));
            return Err(format!("{line}: an instance for invalid arguments"));
        }
        if let Some(m) = messages.first() {
            return Err(format!("{line}: a successful instantiation logged '{}'", m.text));
        }
        self.report.instances += 1;
        self.insts.push(Inst {
            c,
            id,
            _callbacks: cb.unwrap_or_else(|| callbacks(false)),
            logger,
            logging_on: logging_on != 0,
            enabled: LOG_CATEGORIES.iter().map(|(n, _)| *n).filter(|n| *n != "logCalls").collect(),
            phase: Phase::Instantiated,
            sim: false,
            poisoned: false,
            dirty: false,
            hostile: false,
            start: 0.0,
            time: 0.0,
            states: Vec::new(),
            checkpoint: false,
            blobs: Vec::new(),
        });
        Ok(())
    }

    fn free(&mut self, k: usize) -> Check {
        while !self.insts[k].states.is_empty() {
            if self.insts[k].phase == Phase::Fatal {
                let stranded: Vec<fmi2FMUstate> = self.insts[k].states.drain(..).map(|s| s.handle).collect();
                self.stranded.extend(stranded);
                break;
            }
            let last = self.insts[k].states.len() - 1;
            self.free_state_at(k, last)?;
        }
        let c = self.c(k);
        let line = format!("fmi2FreeInstance({})", self.describe(k));
        take_messages();
        self.watchdog.enter(&line);
        ffi!(self.fmu.api, fmi2FreeInstance(c));
        self.watchdog.leave();
        self.report.calls += 1;
        let counts = self.report.per_function.entry("fmi2FreeInstance").or_default();
        counts[0] += 1;
        self.insts.remove(k);
        if let Some(m) = take_messages().first() {
            return Err(format!("{line}: logged '{}'", m.text));
        }
        Ok(())
    }

    /// Makes the parameters fail before the contact tables are built
    /// (`fidelity` = 99 is refused by the first check of a build).
    fn poison(&mut self, k: usize) -> Check {
        self.set_fidelity(k, 99, "harness: no builds left")
    }

    /// Sets `fidelity` (0: torsional, cheap steps; 99: fails every build).
    fn set_fidelity(&mut self, k: usize, x: i32, why: &str) -> Check {
        let c = self.c(k);
        let v = vr::FIDELITY;
        let desc = format!("{}, [fidelity], [{x}] ({why})", self.describe(k));
        let status = self.call(
            Some(k),
            "fmi2SetInteger",
            desc,
            Expect { call: Some(Call::Set), invalid: None },
            |a| ffi!(a, fmi2SetInteger(c, &v, 1, &x)),
            |e, s| {
                if s == fmi2Status_fmi2OK {
                    e.insts[k].poisoned = x == 99;
                    e.insts[k].sim = false;
                }
            },
        )?;
        if status != fmi2Status_fmi2OK {
            return Err(format!(
                "setting fidelity = {x} before initialization returned {}",
                STATUS_NAMES[status as usize]
            ));
        }
        Ok(())
    }

    /// Whether a call that may build the simulation from parameters
    /// (`poisoned` tells whether those fail early) may go ahead: with a
    /// build token (spread over the run, mostly for parameters left at
    /// their start values), most of them made torsional; without, the
    /// parameters are made to fail early where they can be set, else the
    /// call is skipped.
    fn may_build(&mut self, k: usize, poisoned: bool, dirty: bool, settable: bool) -> Result<bool, String> {
        if poisoned {
            return Ok(true);
        }
        let worth = !dirty || self.rng.chance(0.3);
        let spent = f64::from(self.builds - self.tokens);
        let due = self.report.calls as f64 / self.calls.max(1) as f64 * f64::from(self.builds);
        let settable =
            settable && matches!(self.insts[k].phase, Phase::Instantiated | Phase::InitializationMode);
        if worth && self.tokens > 0 && spent <= due + 1.0 {
            self.tokens -= 1;
            if settable && self.rng.chance(self.torsional) {
                // Half of the cheap builds torsional, half steady torsional (fidelity 2).
                let fidelity = if self.rng.chance(0.5) { 2 } else { 0 };
                self.set_fidelity(k, fidelity, "harness: a cheap build")?;
            }
            return Ok(true);
        }
        if settable {
            self.poison(k)?;
            return Ok(true);
        }
        Ok(false)
    }

    fn simple(&mut self, k: usize, op: Op) -> Check {
        let c = self.c(k);
        let desc = self.describe(k);
        let (name, call): (&'static str, Call) = match op {
            Op::Enter => ("fmi2EnterInitializationMode", Call::EnterInitializationMode),
            Op::Terminate => ("fmi2Terminate", Call::Terminate),
            Op::Reset => ("fmi2Reset", Call::Reset),
            _ => ("fmi2CancelStep", Call::CancelStep),
        };
        let invalid = (op == Op::CancelStep).then(|| "there is no step in progress".to_string());
        self.call(
            Some(k),
            name,
            desc,
            Expect { call: Some(call), invalid },
            |a| match op {
                Op::Enter => ffi!(a, fmi2EnterInitializationMode(c)),
                Op::Terminate => ffi!(a, fmi2Terminate(c)),
                Op::Reset => ffi!(a, fmi2Reset(c)),
                _ => ffi!(a, fmi2CancelStep(c)),
            },
            |e, s| {
                if s != fmi2Status_fmi2OK {
                    return;
                }
                let i = &mut e.insts[k];
                match op {
                    Op::Enter => i.phase = Phase::InitializationMode,
                    Op::Terminate => i.phase = Phase::Terminated,
                    Op::Reset => {
                        i.phase = Phase::Instantiated;
                        i.sim = false;
                        i.poisoned = false;
                        i.dirty = false;
                        i.hostile = false;
                        i.start = 0.0;
                        i.time = 0.0;
                    }
                    _ => {}
                }
            },
        )?;
        Ok(())
    }

    fn exit(&mut self, k: usize) -> Check {
        let i = &self.insts[k];
        let (phase, sim, poisoned, dirty) = (i.phase, i.sim, i.poisoned, i.dirty);
        if phase == Phase::InitializationMode && !sim && !self.may_build(k, poisoned, dirty, true)? {
            return Ok(());
        }
        let c = self.c(k);
        let desc = self.describe(k);
        self.call(
            Some(k),
            "fmi2ExitInitializationMode",
            desc,
            Expect { call: Some(Call::ExitInitializationMode), invalid: None },
            |a| ffi!(a, fmi2ExitInitializationMode(c)),
            |e, s| {
                if s == fmi2Status_fmi2OK {
                    let i = &mut e.insts[k];
                    if !i.sim {
                        i.time = i.start;
                    }
                    i.phase = Phase::StepComplete;
                    i.sim = true;
                }
            },
        )?;
        if self.insts[k].phase == Phase::StepComplete && !self.insts[k].checkpoint {
            self.checkpoint(k)?;
        }
        Ok(())
    }

    /// Saves the instance's state as its protected checkpoint.
    fn checkpoint(&mut self, k: usize) -> Check {
        let c = self.c(k);
        let mut handle: fmi2FMUstate = std::ptr::null_mut();
        let desc = format!("{}, new (harness: checkpoint)", self.describe(k));
        let status = self.call(
            Some(k),
            "fmi2GetFMUstate",
            desc,
            Expect { call: Some(Call::FmuState), invalid: None },
            |a| ffi!(a, fmi2GetFMUstate(c, &mut handle)),
            |_, _| {},
        )?;
        if status != fmi2Status_fmi2OK || handle.is_null() {
            return Err(format!(
                "fmi2GetFMUstate after initialization returned {}",
                STATUS_NAMES[status as usize]
            ));
        }
        let i = &mut self.insts[k];
        let rec = StateRec {
            handle,
            phase: i.phase,
            sim: true,
            poisoned: i.poisoned,
            dirty: i.dirty,
            hostile: i.hostile,
            time: i.time,
            non_finite: false,
        };
        i.states.insert(0, rec);
        i.checkpoint = true;
        Ok(())
    }

    fn set_debug_logging(&mut self, k: usize) -> Check {
        let c = self.c(k);
        let r = &mut self.rng;
        let on = r.pick(&[0, 1, 1, 3]);
        let known: Vec<&'static str> = LOG_CATEGORIES.iter().map(|(n, _)| *n).collect();
        let mut names: Vec<Option<CString>> = Vec::new();
        let mut unknown = false;
        let variant = r.below(10);
        match variant {
            0..=1 => {}
            2..=7 => {
                for _ in 0..1 + r.below(4) {
                    names.push(CString::new(r.pick(&known)).ok());
                }
            }
            8 => {
                names.push(CString::new(r.pick(&known)).ok());
                names.push(Some(
                    CString::new(r.pick(&[&b"logNothing"[..], b"", b"\xfflog"])).unwrap_or_default(),
                ));
                unknown = true;
            }
            _ => {
                names.push(None);
                unknown = true;
            }
        }
        let null_array = r.chance(0.05);
        let n = if null_array { 1 + names.len() } else { names.len() };
        let ptrs: Vec<fmi2String> =
            names.iter().map(|s| s.as_ref().map_or(std::ptr::null(), |s| s.as_ptr())).collect();
        let array =
            if null_array || (ptrs.is_empty() && variant == 0) { std::ptr::null() } else { ptrs.as_ptr() };
        let chosen: BTreeSet<&'static str> = names
            .iter()
            .filter_map(|s| s.as_ref().and_then(|s| s.to_str().ok()))
            .filter_map(|s| known.iter().find(|k| **k == s).copied())
            .collect();
        let invalid = if null_array {
            Some("the categories array is NULL".to_string())
        } else if unknown {
            Some("a category is not declared".to_string())
        } else {
            None
        };
        let desc = format!(
            "{}, loggingOn {on}, n {n}, {:?}{}",
            self.describe(k),
            chosen,
            if null_array {
                ", NULL array"
            } else if unknown {
                ", with an undeclared name"
            } else {
                ""
            }
        );
        self.call(
            Some(k),
            "fmi2SetDebugLogging",
            desc,
            Expect { call: Some(Call::SetDebugLogging), invalid },
            |a| ffi!(a, fmi2SetDebugLogging(c, on, n, array)),
            move |e, s| {
                if s == fmi2Status_fmi2OK {
                    let i = &mut e.insts[k];
                    i.logging_on = on != 0;
                    i.enabled = if n == 0 { known.into_iter().collect() } else { chosen };
                }
            },
        )?;
        Ok(())
    }

    fn setup_experiment(&mut self, k: usize) -> Check {
        let c = self.c(k);
        let r = &mut self.rng;
        let tol_defined = r.pick(&[0, 1]);
        let tol = if r.chance(0.5) { 1e-6 } else { r.pick(&SPECIAL_REALS) };
        let start = if r.chance(0.8) { 0.0 } else { r.pick(&SPECIAL_REALS) };
        let stop_defined = r.pick(&[0, 0, 1, 2]);
        let stop = match r.below(4) {
            0 => 1.0,
            1 => 0.01,
            2 => start - 1.0,
            _ => r.pick(&SPECIAL_REALS),
        };
        let invalid = if !start.is_finite() {
            Some(format!("startTime {start}"))
        } else if stop_defined != 0 && !(stop.is_finite() && stop >= start) {
            Some(format!("stopTime {stop} with startTime {start}"))
        } else {
            None
        };
        let desc = format!(
            "{}, tol {tol_defined}/{tol:e}, start {start:e}, stop {stop_defined}/{stop:e}",
            self.describe(k)
        );
        self.call(
            Some(k),
            "fmi2SetupExperiment",
            desc,
            Expect { call: Some(Call::SetupExperiment), invalid },
            |a| ffi!(a, fmi2SetupExperiment(c, tol_defined, tol, start, stop_defined, stop)),
            |e, s| {
                if s == fmi2Status_fmi2OK {
                    e.insts[k].start = start;
                }
            },
        )?;
        Ok(())
    }

    // -- values ------------------------------------------------------------

    /// Value references for a call on variables of `kind`: mostly of that
    /// kind (`settable` picks parameters or inputs as the phase allows),
    /// some of another kind, unknown, or repeated.
    fn pick_refs(&mut self, kind: Kind, want: Option<Causality>, k: usize) -> Vec<u32> {
        let poisoned = self.insts[k].poisoned;
        let n = match self.rng.below(10) {
            0 => 0,
            1..=6 => 1,
            _ => 2 + self.rng.below(5),
        };
        let of_kind: Vec<&_> =
            VARIABLES.iter().filter(|v| v.kind == kind && want.is_none_or(|c| v.causality == c)).collect();
        let mut refs = Vec::with_capacity(n);
        for _ in 0..n {
            let r = match self.rng.below(20) {
                0 => self.rng.pick(&[99_999, u32::MAX, 0, 1000, 299]),
                1 => VARIABLES[self.rng.below(VARIABLES.len())].vr,
                2 if !refs.is_empty() => refs[self.rng.below(refs.len())],
                _ if !of_kind.is_empty() => of_kind[self.rng.below(of_kind.len())].vr,
                _ => self.rng.pick(&[99_999, 7]),
            };
            // A poisoned instance keeps its failing fidelity.
            refs.push(if poisoned && kind == Kind::Integer && r == vr::FIDELITY { 99_999 } else { r });
        }
        refs
    }

    fn get(&mut self, k: usize, op: Op) -> Check {
        let c = self.c(k);
        let kind = match op {
            Op::GetReal => Kind::Real,
            Op::GetInteger => Kind::Integer,
            Op::GetBoolean => Kind::Boolean,
            _ => Kind::String,
        };
        let mut refs = self.pick_refs(kind, None, k);
        let is_output = |r: &u32| {
            planetwear::fmi::variables::find(kind, *r).is_some_and(|v| v.causality == Causality::Output)
        };
        let i = &self.insts[k];
        let (phase, sim, poisoned, dirty) = (i.phase, i.sim, i.poisoned, i.dirty);
        if refs.iter().any(is_output) && !sim && allowed(Call::Get, phase) {
            // A read of an output builds the simulation: only with a token
            // or failing parameters, and then with every reference valid so
            // the model knows whether it was built.
            if self.may_build(k, poisoned, dirty, true)? {
                refs.retain(|r| planetwear::fmi::variables::find(kind, *r).is_some());
            } else {
                refs.retain(|r| planetwear::fmi::variables::find(kind, *r).is_some() && !is_output(r));
            }
        }
        let n = refs.len();
        let null_refs = n > 0 && self.rng.chance(0.04);
        let null_values = n > 0 && self.rng.chance(0.04);
        let unknown = refs.iter().find(|r| planetwear::fmi::variables::find(kind, **r).is_none());
        let invalid = if null_refs {
            Some("vr is NULL".to_string())
        } else if null_values {
            Some("value is NULL".to_string())
        } else {
            unknown.map(|r| format!("{r} is not a {kind:?} variable"))
        };
        let built = refs.iter().any(is_output);
        let vr_ptr = if null_refs { std::ptr::null() } else { refs.as_ptr() };
        let desc = format!(
            "{}, {refs:?}{}{}",
            self.describe(k),
            if null_refs { ", vr NULL" } else { "" },
            if null_values { ", value NULL" } else { "" }
        );
        let name: &'static str = match op {
            Op::GetReal => "fmi2GetReal",
            Op::GetInteger => "fmi2GetInteger",
            Op::GetBoolean => "fmi2GetBoolean",
            _ => "fmi2GetString",
        };
        let mut reals = vec![f64::NAN; n];
        let mut ints = vec![i32::MIN; n];
        let mut strings: Vec<fmi2String> = vec![std::ptr::null(); n];
        let (rp, ip, sp) = if null_values {
            (std::ptr::null_mut(), std::ptr::null_mut(), std::ptr::null_mut())
        } else {
            (reals.as_mut_ptr(), ints.as_mut_ptr(), strings.as_mut_ptr())
        };
        let expect = Expect { call: Some(Call::Get), invalid };
        let status = self.call(
            Some(k),
            name,
            desc,
            expect,
            |a| match op {
                Op::GetReal => ffi!(a, fmi2GetReal(c, vr_ptr, n, rp)),
                Op::GetInteger => ffi!(a, fmi2GetInteger(c, vr_ptr, n, ip)),
                Op::GetBoolean => ffi!(a, fmi2GetBoolean(c, vr_ptr, n, ip)),
                _ => ffi!(a, fmi2GetString(c, vr_ptr, n, sp)),
            },
            |e, s| {
                let i = &mut e.insts[k];
                if s == fmi2Status_fmi2OK && built {
                    if !i.sim {
                        i.time = i.start;
                    }
                    i.sim = true;
                }
            },
        )?;
        if status == fmi2Status_fmi2OK && !null_values {
            match op {
                Op::GetReal => {
                    for (r, x) in refs.iter().zip(&reals) {
                        if !x.is_finite() {
                            return Err(format!("fmi2GetReal returned OK with {r} = {x}"));
                        }
                    }
                    self.report.reals_checked += n as u64;
                }
                Op::GetString => {
                    for (r, p) in refs.iter().zip(&strings) {
                        if p.is_null() {
                            return Err(format!("fmi2GetString returned OK with a NULL string for {r}"));
                        }
                        // SAFETY: the FMU returned this pointer for this call; it stays valid
                        // until the next call on the instance.
                        let _ = unsafe { CStr::from_ptr(*p) }.to_bytes().len();
                    }
                }
                _ => {}
            }
        }
        Ok(())
    }

    fn real_value(&mut self, start: Option<f64>) -> f64 {
        match self.rng.below(10) {
            0..=3 => self.rng.pick(&SPECIAL_REALS),
            4 => f64::from_bits(self.rng.next_u64()),
            _ => start.unwrap_or(0.0) * (0.5 + self.rng.unit()),
        }
    }

    fn set(&mut self, k: usize, op: Op) -> Check {
        let c = self.c(k);
        let kind = match op {
            Op::SetReal => Kind::Real,
            Op::SetInteger => Kind::Integer,
            Op::SetBoolean => Kind::Boolean,
            _ => Kind::String,
        };
        let phase = self.insts[k].phase;
        let want = if phase == Phase::StepComplete || self.rng.chance(0.2) {
            Causality::Input
        } else {
            Causality::Parameter
        };
        let want = if kind == Kind::Real { Some(want) } else { None };
        let refs = self.pick_refs(kind, want, k);
        let n = refs.len();
        let info = |r: u32| planetwear::fmi::variables::find(kind, r);
        let mut reals = Vec::with_capacity(n);
        let mut ints = Vec::with_capacity(n);
        let mut strings: Vec<Option<CString>> = Vec::with_capacity(n);
        for r in &refs {
            let start = info(*r).map(|v| v.start);
            reals.push(self.real_value(match start {
                Some(Start::Real(x)) => Some(x),
                _ => None,
            }));
            ints.push(match (self.rng.below(3), start) {
                (0, Some(Start::Integer(x))) => x,
                (1, Some(Start::Integer(x))) => x.saturating_add(self.rng.pick(&[-1, 1, 2])),
                _ => self.rng.pick(&SPECIAL_INTEGERS),
            });
            if *r == planetwear::fmi::variables::vr::WEAR_STATE_ACCEPT && kind == Kind::String {
                // Kinds of difference, not files: mostly valid lists, some refused.
                const ACCEPT: [&str; 6] = ["", "", "material", "material,mesh_stiffness", "geometry", "load"];
                strings.push(CString::new(self.rng.pick(&ACCEPT)).ok());
                continue;
            }
            let duty = [
                planetwear::fmi::variables::vr::DUTY_TORQUE_EDGES,
                planetwear::fmi::variables::vr::DUTY_SPEED_EDGES,
            ];
            if duty.contains(r) && kind == Kind::String {
                // Bin edges, not files: mostly valid lists, some refused (too few, not
                // increasing, not numbers, not finite, too many bins).
                const EDGES: [&str; 9] =
                    ["", "", "0,500,1000", " 0, 300 ,400", "-1e3,0,1e3", "1,1", "5", "x,1", "0,1e400"];
                let many = (0..=2000).map(|k| k.to_string()).collect::<Vec<_>>().join(",");
                let value = if self.rng.chance(0.05) { many } else { self.rng.pick(&EDGES).to_string() };
                strings.push(CString::new(value).ok());
                continue;
            }
            let choice = self.rng.below(self.files.choices.len() + 1);
            strings.push(self.files.choices.get(choice).map(|b| CString::new(b.clone()).unwrap_or_default()));
        }
        let settable = |r: u32| {
            info(r).is_some_and(|v| match v.causality {
                Causality::Output => false,
                Causality::Input => true,
                Causality::Parameter => matches!(phase, Phase::Instantiated | Phase::InitializationMode),
            })
        };
        let null_refs = n > 0 && self.rng.chance(0.04);
        let null_values = n > 0 && self.rng.chance(0.04);
        let invalid = if null_refs {
            Some("vr is NULL".to_string())
        } else if null_values {
            Some("value is NULL".to_string())
        } else if let Some(r) = refs.iter().find(|r| !settable(**r)) {
            Some(format!("{r} cannot be set as {kind:?} in phase {phase:?}"))
        } else if kind == Kind::Real && reals.iter().any(|x| !x.is_finite()) {
            Some("a value is not finite".to_string())
        } else if kind == Kind::String && strings.iter().any(|s| s.is_none()) {
            Some("a string is NULL".to_string())
        } else {
            None
        };
        // What the set may change in the model: parameters or strings reset
        // the simulation before initialization ends; fidelity poisons.
        let touches_params =
            refs.iter().any(|r| info(*r).is_some_and(|v| v.causality == Causality::Parameter));
        let hostile_input = kind == Kind::Real
            && refs.iter().zip(&reals).any(|(r, x)| {
                info(*r).is_some_and(|v| v.causality == Causality::Input) && x.is_finite() && x.abs() > 1e5
            });
        let fidelity_set: Option<i32> =
            refs.iter().position(|r| kind == Kind::Integer && *r == vr::FIDELITY).map(|p| ints[p]);
        let vr_ptr = if null_refs { std::ptr::null() } else { refs.as_ptr() };
        let string_ptrs: Vec<fmi2String> =
            strings.iter().map(|s| s.as_ref().map_or(std::ptr::null(), |s| s.as_ptr())).collect();
        let bools: Vec<fmi2Boolean> = ints.iter().map(|x| x & 3).collect();
        let (rp, ip, bp, sp) = if null_values {
            (std::ptr::null(), std::ptr::null(), std::ptr::null(), std::ptr::null())
        } else {
            (reals.as_ptr(), ints.as_ptr(), bools.as_ptr(), string_ptrs.as_ptr())
        };
        let shown = match kind {
            Kind::Real => format!("{reals:?}"),
            Kind::Integer => format!("{ints:?}"),
            Kind::Boolean => format!("{bools:?}"),
            Kind::String => format!(
                "{:?}",
                strings
                    .iter()
                    .map(|s| s.as_ref().map(|s| s.to_string_lossy().chars().take(60).collect::<String>()))
                    .collect::<Vec<_>>()
            ),
        };
        let desc = format!(
            "{}, {refs:?}, {shown}{}{}",
            self.describe(k),
            if null_refs { ", vr NULL" } else { "" },
            if null_values { ", value NULL" } else { "" }
        );
        let name: &'static str = match op {
            Op::SetReal => "fmi2SetReal",
            Op::SetInteger => "fmi2SetInteger",
            Op::SetBoolean => "fmi2SetBoolean",
            _ => "fmi2SetString",
        };
        self.call(
            Some(k),
            name,
            desc,
            Expect { call: Some(Call::Set), invalid },
            |a| match op {
                Op::SetReal => ffi!(a, fmi2SetReal(c, vr_ptr, n, rp)),
                Op::SetInteger => ffi!(a, fmi2SetInteger(c, vr_ptr, n, ip)),
                Op::SetBoolean => ffi!(a, fmi2SetBoolean(c, vr_ptr, n, bp)),
                _ => ffi!(a, fmi2SetString(c, vr_ptr, n, sp)),
            },
            |e, s| {
                let i = &mut e.insts[k];
                // The FMU drops its simulation when a parameter changes before
                // initialization ends (the phase at the call counts).
                if (touches_params || kind == Kind::String || kind == Kind::Integer)
                    && phase != Phase::StepComplete
                {
                    i.sim = false;
                }
                if touches_params || kind == Kind::String || kind == Kind::Integer {
                    i.dirty = true;
                }
                if hostile_input {
                    i.hostile = true;
                }
                if let Some(f) = fidelity_set {
                    // Unsure whether it was applied unless the call succeeded.
                    i.poisoned = s == fmi2Status_fmi2OK && !(0..=3).contains(&f);
                }
            },
        )?;
        Ok(())
    }

    // -- FMU states ----------------------------------------------------------

    fn get_state(&mut self, k: usize) -> Check {
        let c = self.c(k);
        let i = &self.insts[k];
        // The checkpoint may be renewed from a running simulation.
        let renew = i.checkpoint && i.phase == Phase::StepComplete && i.sim && !i.hostile;
        let spare = if renew { 0..i.states.len() } else { i.spare() };
        let variant = if self.rng.chance(0.08) {
            2
        } else if !spare.is_empty() && (self.insts[k].states.len() >= 4 || self.rng.chance(0.3)) {
            1
        } else {
            0
        };
        let slot = if variant == 1 { spare.start + self.rng.below(spare.len()) } else { 0 };
        let mut handle: fmi2FMUstate =
            if variant == 1 { self.insts[k].states[slot].handle } else { std::ptr::null_mut() };
        let out: *mut fmi2FMUstate = if variant == 2 { std::ptr::null_mut() } else { &mut handle };
        let invalid = (variant == 2).then(|| "the FMUstate pointer is NULL".to_string());
        let desc =
            format!("{}, {}", self.describe(k), ["new", &format!("overwrite state {slot}"), "NULL"][variant]);
        let status = self.call(
            Some(k),
            "fmi2GetFMUstate",
            desc,
            Expect { call: Some(Call::FmuState), invalid },
            |a| ffi!(a, fmi2GetFMUstate(c, out)),
            |_, _| {},
        )?;
        if status == fmi2Status_fmi2OK && variant != 2 {
            if handle.is_null() {
                return Err("fmi2GetFMUstate returned OK and a NULL state".into());
            }
            let i = &self.insts[k];
            let rec = StateRec {
                handle,
                phase: i.phase,
                sim: i.sim,
                poisoned: i.poisoned,
                dirty: i.dirty,
                hostile: i.hostile,
                time: i.time,
                non_finite: false,
            };
            if variant == 1 {
                if handle != self.insts[k].states[slot].handle {
                    return Err("fmi2GetFMUstate replaced a held state instead of overwriting it".into());
                }
                self.insts[k].states[slot] = rec;
            } else {
                self.insts[k].states.push(rec);
            }
        }
        Ok(())
    }

    fn set_state(&mut self, k: usize) -> Check {
        let c = self.c(k);
        let held = self.insts[k].states.len();
        if held == 0 || self.rng.chance(0.05) {
            let desc = format!("{}, NULL", self.describe(k));
            self.call(
                Some(k),
                "fmi2SetFMUstate",
                desc,
                Expect { call: Some(Call::FmuState), invalid: Some("the FMUstate is NULL".into()) },
                |a| ffi!(a, fmi2SetFMUstate(c, std::ptr::null_mut())),
                |_, _| {},
            )?;
            return Ok(());
        }
        // Mostly a state that continues a simulation.
        let good: Vec<usize> = (0..held)
            .filter(|&s| {
                let r = &self.insts[k].states[s];
                r.sim && r.phase == Phase::StepComplete && !r.hostile
            })
            .collect();
        let p = if self.insts[k].sim { 0.97 } else { 0.8 };
        let slot =
            if !good.is_empty() && self.rng.chance(p) { self.rng.pick(&good) } else { self.rng.below(held) };
        let (phase, sim) = (self.insts[k].phase, self.insts[k].sim);
        let r = &self.insts[k].states[slot];
        let (state_sim, state_poisoned, state_dirty) = (r.sim, r.poisoned, r.dirty);
        if state_sim
            && !sim
            && allowed(Call::FmuState, phase)
            && !self.may_build(k, state_poisoned, state_dirty, false)?
        {
            return Ok(());
        }
        let i = &self.insts[k];
        let s = &i.states[slot];
        let (handle, phase, sim, poisoned, dirty, hostile, time) =
            (s.handle, s.phase, s.sim, s.poisoned, s.dirty, s.hostile, s.time);
        let invalid = s.non_finite.then(|| "the state holds a forged non-finite number".to_string());
        let desc = format!("{}, state {slot} ({phase:?}, t = {time:e})", self.describe(k));
        self.call(
            Some(k),
            "fmi2SetFMUstate",
            desc,
            Expect { call: Some(Call::FmuState), invalid },
            |a| ffi!(a, fmi2SetFMUstate(c, handle)),
            |e, st| {
                let i = &mut e.insts[k];
                if st == fmi2Status_fmi2OK {
                    i.phase = phase;
                    i.sim = sim;
                    i.poisoned = poisoned;
                    i.dirty = dirty;
                    i.hostile = hostile;
                    i.time = time;
                } else {
                    i.sim = i.sim && sim;
                    i.poisoned = i.poisoned && poisoned;
                    i.dirty = i.dirty || dirty;
                    i.hostile = i.hostile || hostile;
                }
            },
        )?;
        Ok(())
    }

    fn free_state_at(&mut self, k: usize, slot: usize) -> Check {
        let c = self.c(k);
        let mut handle = self.insts[k].states[slot].handle;
        let desc = format!("{}, state {slot}", self.describe(k));
        let status = self.call(
            Some(k),
            "fmi2FreeFMUstate",
            desc,
            Expect { call: Some(Call::FmuState), invalid: None },
            |a| ffi!(a, fmi2FreeFMUstate(c, &mut handle)),
            |_, _| {},
        )?;
        if status == fmi2Status_fmi2OK {
            if !handle.is_null() {
                return Err("fmi2FreeFMUstate returned OK but did not set the state to NULL".into());
            }
            self.insts[k].states.remove(slot);
            if slot == 0 {
                self.insts[k].checkpoint = false;
            }
        } else if self.insts[k].phase == Phase::Fatal {
            let s = self.insts[k].states.remove(slot);
            self.stranded.push(s.handle);
        } else {
            return Err(format!(
                "fmi2FreeFMUstate of a held state returned {}",
                STATUS_NAMES[status as usize]
            ));
        }
        Ok(())
    }

    fn free_state(&mut self, k: usize) -> Check {
        let c = self.c(k);
        match self.rng.below(10) {
            0 | 1 => {
                let desc = format!("{}, NULL", self.describe(k));
                self.call(
                    Some(k),
                    "fmi2FreeFMUstate",
                    desc,
                    Expect { call: Some(Call::FmuState), invalid: None },
                    |a| ffi!(a, fmi2FreeFMUstate(c, std::ptr::null_mut())),
                    |_, _| {},
                )?;
            }
            2 | 3 => {
                let mut none: fmi2FMUstate = std::ptr::null_mut();
                let desc = format!("{}, &NULL", self.describe(k));
                self.call(
                    Some(k),
                    "fmi2FreeFMUstate",
                    desc,
                    Expect { call: Some(Call::FmuState), invalid: None },
                    |a| ffi!(a, fmi2FreeFMUstate(c, &mut none)),
                    |_, _| {},
                )?;
            }
            _ if !self.insts[k].spare().is_empty() && self.insts[k].phase != Phase::Fatal => {
                let spare = self.insts[k].spare();
                let slot = spare.start + self.rng.below(spare.len());
                self.free_state_at(k, slot)?;
            }
            _ => {}
        }
        Ok(())
    }

    fn serialize(&mut self, k: usize) -> Check {
        let c = self.c(k);
        let held = self.insts[k].states.len();
        let slot = (held > 0 && !self.rng.chance(0.08)).then(|| self.rng.below(held));
        let handle = slot.map_or(std::ptr::null_mut(), |s| self.insts[k].states[s].handle);
        let hostile = slot.is_some_and(|s| self.insts[k].states[s].hostile);
        let null_size = self.rng.chance(0.05);
        let mut size = usize::MAX;
        let size_ptr: *mut usize = if null_size { std::ptr::null_mut() } else { &mut size };
        let invalid = if slot.is_none() {
            Some("the FMUstate is NULL".to_string())
        } else if null_size {
            Some("size is NULL".to_string())
        } else {
            None
        };
        let desc =
            format!("{}, state {slot:?}{}", self.describe(k), if null_size { ", size NULL" } else { "" });
        let status = self.call(
            Some(k),
            "fmi2SerializedFMUstateSize",
            desc,
            Expect { call: Some(Call::FmuState), invalid },
            |a| ffi!(a, fmi2SerializedFMUstateSize(c, handle, size_ptr)),
            |_, _| {},
        )?;
        if status != fmi2Status_fmi2OK || null_size || slot.is_none() {
            return Ok(());
        }
        if size > 1 << 30 {
            return Err(format!("fmi2SerializedFMUstateSize returned OK with size {size}"));
        }
        let (len, null_buffer) = match self.rng.below(10) {
            0 => (size.saturating_sub(1), false),
            1 => (size + 1 + self.rng.below(64), false),
            2 => (size, true),
            _ => (size, false),
        };
        let mut buffer = vec![0x5a as fmi2Byte; len.max(1)];
        let ptr = if null_buffer { std::ptr::null_mut() } else { buffer.as_mut_ptr() };
        let invalid = if null_buffer && size > 0 {
            Some("the buffer is NULL".to_string())
        } else if len < size {
            Some(format!("size {len} is smaller than the state's {size} bytes"))
        } else {
            None
        };
        let desc = format!(
            "{}, state {slot:?}, size {len}{}",
            self.describe(k),
            if null_buffer { ", buffer NULL" } else { "" }
        );
        let status = self.call(
            Some(k),
            "fmi2SerializeFMUstate",
            desc,
            Expect { call: Some(Call::FmuState), invalid },
            |a| ffi!(a, fmi2SerializeFMUstate(c, handle, ptr, len)),
            |_, _| {},
        )?;
        if status == fmi2Status_fmi2OK && !null_buffer {
            let bytes: Vec<u8> = buffer[..size].iter().map(|b| *b as u8).collect();
            let i = &mut self.insts[k];
            if i.blobs.len() >= 4 {
                i.blobs.remove(0);
            }
            i.blobs.push(Blob { bytes, hostile });
        }
        Ok(())
    }

    fn deserialize(&mut self, k: usize) -> Check {
        let c = self.c(k);
        // A blob of this instance, mostly; sometimes another instance's.
        let other = self.rng.below(self.insts.len());
        let source = if self.rng.chance(0.85) || self.insts[other].blobs.is_empty() { k } else { other };
        let blobs = &self.insts[source].blobs;
        let (original, blob_hostile) = if blobs.is_empty() {
            (Vec::new(), false)
        } else {
            let b = &blobs[self.rng.below(blobs.len())];
            // Another instance's inputs are unknown here.
            (b.bytes.clone(), b.hostile || source != k)
        };
        let (bytes, forgery, how) = if original.is_empty() {
            (Vec::new(), Forgery::Refused, "empty")
        } else {
            forge(&mut self.rng, &original)
        };
        let spare = self.insts[k].spare();
        let variant = if self.rng.chance(0.08) {
            2
        } else if !spare.is_empty() && (self.insts[k].states.len() >= 4 || self.rng.chance(0.2)) {
            1
        } else {
            0
        };
        let slot = if variant == 1 { spare.start + self.rng.below(spare.len()) } else { 0 };
        let mut handle: fmi2FMUstate =
            if variant == 1 { self.insts[k].states[slot].handle } else { std::ptr::null_mut() };
        let out: *mut fmi2FMUstate = if variant == 2 { std::ptr::null_mut() } else { &mut handle };
        let null_bytes = bytes.is_empty() && self.rng.chance(0.5);
        let data: *const fmi2Byte =
            if null_bytes { std::ptr::null() } else { bytes.as_ptr() as *const fmi2Byte };
        let invalid = if variant == 2 {
            Some("the FMUstate pointer is NULL".to_string())
        } else if forgery == Forgery::Refused {
            Some(format!("the bytes are {how}"))
        } else {
            None
        };
        let desc = format!(
            "{}, {} bytes {how}{} of #{}, into {}",
            self.describe(k),
            bytes.len(),
            if null_bytes { " (NULL)" } else { "" },
            self.insts[source].id,
            ["a new state", "a held state", "NULL"][variant]
        );
        let n = bytes.len();
        let status = self.call(
            Some(k),
            "fmi2DeSerializeFMUstate",
            desc,
            Expect { call: Some(Call::FmuState), invalid },
            |a| ffi!(a, fmi2DeSerializeFMUstate(c, data, n, out)),
            |_, _| {},
        )?;
        if status == fmi2Status_fmi2OK && variant != 2 {
            if handle.is_null() {
                return Err("fmi2DeSerializeFMUstate returned OK and a NULL state".into());
            }
            let i = &self.insts[k];
            let rec = StateRec {
                handle,
                phase: Phase::StepComplete,
                sim: true,
                poisoned: i.poisoned,
                dirty: i.dirty,
                hostile: blob_hostile || forgery == Forgery::Hostile,
                time: blob_time(&bytes),
                non_finite: forgery == Forgery::NonFinite,
            };
            if variant == 1 {
                if handle != self.insts[k].states[slot].handle {
                    return Err(
                        "fmi2DeSerializeFMUstate replaced a held state instead of overwriting it".into()
                    );
                }
                self.insts[k].states[slot] = rec;
            } else {
                self.insts[k].states.push(rec);
            }
        }
        Ok(())
    }

    // -- stepping and status ---------------------------------------------

    fn do_step(&mut self, k: usize) -> Check {
        let c = self.c(k);
        let now = self.insts[k].time;
        let t = match self.rng.below(20) {
            0 => self.rng.pick(&SPECIAL_REALS),
            1 => now + 1e-3,
            _ => now,
        };
        let h =
            if self.rng.chance(0.8) { self.rng.pick(&SMALL_STEPS) } else { self.rng.pick(&HOSTILE_STEPS) };
        let flag = self.rng.pick(&[0, 1, 1, 7]);
        let invalid = if !(h.is_finite() && h > 0.0) {
            Some(format!("communicationStepSize {h}"))
        } else if !t.is_finite() {
            Some(format!("currentCommunicationPoint {t}"))
        } else {
            None
        };
        let desc = format!("{}, t {t:e}, h {h:e}, noSetFMUStatePriorToCurrentPoint {flag}", self.describe(k));
        self.call(
            Some(k),
            "fmi2DoStep",
            desc,
            Expect { call: Some(Call::DoStep), invalid },
            |a| ffi!(a, fmi2DoStep(c, t, h, flag)),
            |e, s| {
                let i = &mut e.insts[k];
                if s == fmi2Status_fmi2OK {
                    i.time = t + h;
                    i.phase = Phase::StepComplete;
                } else if s == fmi2Status_fmi2Discard {
                    i.phase = Phase::StepFailed;
                }
            },
        )?;
        Ok(())
    }

    fn status(&mut self, k: usize) -> Check {
        let c = self.c(k);
        let kind: fmi2StatusKind = self.rng.pick(&[0, 1, 2, 3, 3, 2, 99, u32::MAX]);
        let null = self.rng.chance(0.1);
        let which = self.rng.below(5);
        let (name, supported): (&'static str, Option<fmi2StatusKind>) = match which {
            0 => ("fmi2GetStatus", Some(fmi2StatusKind_fmi2DoStepStatus)),
            1 => ("fmi2GetRealStatus", Some(fmi2StatusKind_fmi2LastSuccessfulTime)),
            2 => ("fmi2GetIntegerStatus", None),
            3 => ("fmi2GetBooleanStatus", Some(fmi2StatusKind_fmi2Terminated)),
            _ => ("fmi2GetStringStatus", None),
        };
        let invalid = if supported != Some(kind) {
            Some(format!("status kind {kind} is not provided by {name}"))
        } else if null {
            Some("value is NULL".to_string())
        } else {
            None
        };
        let mut st: fmi2Status = 99;
        let mut real = f64::NAN;
        let mut int: fmi2Integer = 0;
        let mut boolean: fmi2Boolean = 99;
        let mut string: fmi2String = std::ptr::null();
        let desc = format!("{}, kind {kind}{}", self.describe(k), if null { ", value NULL" } else { "" });
        let (sp, rp, ip, bp, tp): (
            *mut fmi2Status,
            *mut f64,
            *mut fmi2Integer,
            *mut fmi2Boolean,
            *mut fmi2String,
        ) = if null {
            (
                std::ptr::null_mut(),
                std::ptr::null_mut(),
                std::ptr::null_mut(),
                std::ptr::null_mut(),
                std::ptr::null_mut(),
            )
        } else {
            (&mut st, &mut real, &mut int, &mut boolean, &mut string)
        };
        let status = self.call(
            Some(k),
            name,
            desc,
            Expect { call: Some(Call::Status), invalid },
            |a| match which {
                0 => ffi!(a, fmi2GetStatus(c, kind, sp)),
                1 => ffi!(a, fmi2GetRealStatus(c, kind, rp)),
                2 => ffi!(a, fmi2GetIntegerStatus(c, kind, ip)),
                3 => ffi!(a, fmi2GetBooleanStatus(c, kind, bp)),
                _ => ffi!(a, fmi2GetStringStatus(c, kind, tp)),
            },
            |_, _| {},
        )?;
        if status == fmi2Status_fmi2OK && !null {
            match which {
                0 if st != fmi2Status_fmi2OK && st != fmi2Status_fmi2Discard => {
                    return Err(format!("fmi2GetStatus(DoStepStatus) returned OK with status {st}"));
                }
                1 if !real.is_finite() => {
                    return Err(format!("fmi2GetRealStatus(LastSuccessfulTime) returned OK with {real}"));
                }
                3 if boolean != 0 && boolean != 1 => {
                    return Err(format!("fmi2GetBooleanStatus(Terminated) returned OK with {boolean}"));
                }
                1 => self.report.reals_checked += 1,
                _ => {}
            }
        }
        Ok(())
    }

    fn derivatives(&mut self, k: usize, op: Op) -> Check {
        let c = self.c(k);
        let null = self.rng.chance(0.5);
        let refs = [vr::SUN_TORQUE, vr::SUN_SPEED];
        let orders: [fmi2Integer; 2] = [1, 2];
        let mut values = [1.0, f64::NAN];
        let n = if null { 0 } else { self.rng.below(3) };
        let (rp, op_, vp, vm) = if null {
            (std::ptr::null(), std::ptr::null(), std::ptr::null(), std::ptr::null_mut())
        } else {
            (refs.as_ptr(), orders.as_ptr(), values.as_ptr(), values.as_mut_ptr())
        };
        let (name, call) = match op {
            Op::DirectionalDerivative => ("fmi2GetDirectionalDerivative", Call::DirectionalDerivative),
            Op::SetInputDerivatives => ("fmi2SetRealInputDerivatives", Call::SetRealInputDerivatives),
            _ => ("fmi2GetRealOutputDerivatives", Call::GetRealOutputDerivatives),
        };
        let desc = format!("{}, n {n}{}", self.describe(k), if null { ", NULL arrays" } else { "" });
        let mut dz = [0.0; 2];
        let dzp = if null { std::ptr::null_mut() } else { dz.as_mut_ptr() };
        self.call(
            Some(k),
            name,
            desc,
            Expect { call: Some(call), invalid: Some("this FMU does not provide derivatives".into()) },
            |a| match op {
                Op::DirectionalDerivative => ffi!(a, fmi2GetDirectionalDerivative(c, rp, n, rp, n, vp, dzp)),
                Op::SetInputDerivatives => ffi!(a, fmi2SetRealInputDerivatives(c, rp, n, op_, vp)),
                _ => ffi!(a, fmi2GetRealOutputDerivatives(c, rp, n, op_, vm)),
            },
            |_, _| {},
        )?;
        Ok(())
    }

    /// A call on a NULL component: fmi2Error, nothing logged.
    fn null_component(&mut self) -> Check {
        let z: fmi2Component = std::ptr::null_mut();
        let which = self.rng.below(8);
        let v = vr::SUN_SPEED;
        let mut x = 0.0;
        let mut state: fmi2FMUstate = std::ptr::null_mut();
        let name: &'static str = [
            "fmi2DoStep",
            "fmi2GetReal",
            "fmi2SetReal",
            "fmi2SetDebugLogging",
            "fmi2Reset",
            "fmi2GetFMUstate",
            "fmi2ExitInitializationMode",
            "fmi2GetRealStatus",
        ][which];
        let status = self.call(
            None,
            name,
            "NULL component".into(),
            Expect { call: None, invalid: None },
            |a| match which {
                0 => ffi!(a, fmi2DoStep(z, 0.0, 1e-6, 1)),
                1 => ffi!(a, fmi2GetReal(z, &v, 1, &mut x)),
                2 => ffi!(a, fmi2SetReal(z, &v, 1, &x)),
                3 => ffi!(a, fmi2SetDebugLogging(z, 1, 0, std::ptr::null())),
                4 => ffi!(a, fmi2Reset(z)),
                5 => ffi!(a, fmi2GetFMUstate(z, &mut state)),
                6 => ffi!(a, fmi2ExitInitializationMode(z)),
                _ => ffi!(a, fmi2GetRealStatus(z, fmi2StatusKind_fmi2LastSuccessfulTime, &mut x)),
            },
            |_, _| {},
        )?;
        if status != fmi2Status_fmi2Error || !state.is_null() {
            return Err(format!("{name} on a NULL component returned {}", STATUS_NAMES[status as usize]));
        }
        if self.rng.chance(0.3) {
            self.watchdog.record("fmi2FreeInstance(NULL)");
            ffi!(self.fmu.api, fmi2FreeInstance(z));
            self.report.calls += 1;
            self.report.per_function.entry("fmi2FreeInstance").or_default()[0] += 1;
        }
        Ok(())
    }

    fn platform(&mut self) -> Check {
        self.watchdog.record("fmi2GetTypesPlatform(), fmi2GetVersion()");
        let (p, v) = (ffi!(self.fmu.api, fmi2GetTypesPlatform()), ffi!(self.fmu.api, fmi2GetVersion()));
        self.report.calls += 2;
        for (name, ptr, want) in [("fmi2GetTypesPlatform", p, "default"), ("fmi2GetVersion", v, "2.0")] {
            self.report.per_function.entry(name).or_default()[0] += 1;
            if ptr.is_null() {
                return Err(format!("{name} returned NULL"));
            }
            // SAFETY: the FMU returns a pointer to a static NUL-terminated string.
            let s = unsafe { CStr::from_ptr(ptr) };
            if s.to_bytes() != want.as_bytes() {
                return Err(format!("{name} returned {s:?}, not {want}"));
            }
        }
        Ok(())
    }
}

// ---------------------------------------------------------------------------
// Leak checks.

/// glibc's `struct mallinfo2`.
#[repr(C)]
struct Mallinfo2 {
    _arena: usize,
    _ordblks: usize,
    _smblks: usize,
    _hblks: usize,
    hblkhd: usize,
    _usmblks: usize,
    _fsmblks: usize,
    uordblks: usize,
    _fordblks: usize,
    _keepcost: usize,
}

extern "C" {
    fn mallinfo2() -> Mallinfo2;
}

/// Bytes the C allocator has handed out and not had back (glibc's
/// `mallinfo2`: in-use chunks of every arena plus mmapped blocks); the
/// library's Rust code allocates through it. 0 when another allocator
/// (valgrind's) answers.
pub fn live_bytes() -> usize {
    // SAFETY: mallinfo2 takes no argument and returns a plain struct.
    let m = unsafe { mallinfo2() };
    m.uordblks + m.hblkhd
}

/// Resident set size [KiB] from /proc/self/status.
pub fn rss_kib() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmRSS:"))
                .and_then(|l| l.split_whitespace().nth(1).and_then(|x| x.parse().ok()))
        })
        .unwrap_or(0)
}

/// Memory over a run of cycles.
#[derive(Clone, Debug)]
pub struct LeakFigures {
    /// What a cycle does.
    pub what: &'static str,
    /// Cycles after the warm-up.
    pub cycles: usize,
    /// Time per cycle [s].
    pub seconds_per_cycle: f64,
    /// Live bytes after the warm-up.
    pub live_start: usize,
    /// Live bytes at each tenth of the cycles.
    pub live_checkpoints: Vec<usize>,
    /// RSS after the warm-up and at the end [KiB].
    pub rss_kib: (u64, u64),
}

impl LeakFigures {
    /// Largest growth of the live bytes over the warm-up figure [bytes].
    pub fn growth(&self) -> i64 {
        self.live_checkpoints.iter().map(|&b| b as i64 - self.live_start as i64).max().unwrap_or(0)
    }
    /// Whether every checkpoint is above the one before (a steady leak).
    pub fn monotonic(&self) -> bool {
        let mut last = self.live_start;
        for &b in &self.live_checkpoints {
            if b <= last {
                return false;
            }
            last = b;
        }
        !self.live_checkpoints.is_empty()
    }
}

impl fmt::Display for LeakFigures {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}: {} cycles, {:.2e} s per cycle, live bytes {} after warm-up, checkpoints {:?}, growth {} B, RSS {} → {} KiB",
            self.what,
            self.cycles,
            self.seconds_per_cycle,
            self.live_start,
            self.live_checkpoints,
            self.growth(),
            self.rss_kib.0,
            self.rss_kib.1
        )
    }
}

fn measure(
    what: &'static str,
    cycles: usize,
    mut cycle: impl FnMut(usize) -> Check,
) -> Result<LeakFigures, String> {
    // The allocator settles within about a thousand state cycles (a state with its load duty
    // holds some 8 kB): 100 000 cycles grow the live bytes by 14 kB, all of it in the first
    // 10 000, the same as 10 000 cycles after this warm-up (docs/FUZZING.md).
    let warm = (cycles / 5).clamp(1, 2000);
    for n in 0..warm {
        cycle(n)?;
    }
    let live_start = live_bytes();
    let rss_start = rss_kib();
    let started = Instant::now();
    let mut live_checkpoints = Vec::new();
    let step = (cycles / 10).max(1);
    for n in 0..cycles {
        cycle(warm + n)?;
        if (n + 1) % step == 0 {
            live_checkpoints.push(live_bytes());
        }
    }
    Ok(LeakFigures {
        what,
        cycles,
        seconds_per_cycle: started.elapsed().as_secs_f64() / cycles.max(1) as f64,
        live_start,
        live_checkpoints,
        rss_kib: (rss_start, rss_kib()),
    })
}

fn instantiate_quietly(
    fmu: &Fmu,
    name: &CStr,
    cb: &fmi2CallbackFunctions,
    logging: bool,
) -> Result<fmi2Component, String> {
    let guid = CString::new(GUID).unwrap_or_default();
    let uri = CString::new(fmu.resource_uri()).unwrap_or_default();
    let c = ffi!(
        fmu.api,
        fmi2Instantiate(
            name.as_ptr(),
            fmi2Type_fmi2CoSimulation,
            guid.as_ptr(),
            uri.as_ptr(),
            cb,
            0,
            fmi2Boolean::from(logging)
        )
    );
    if c.is_null() {
        return Err("fmi2Instantiate returned NULL for valid arguments".into());
    }
    Ok(c)
}

fn ok(status: fmi2Status, what: &str) -> Check {
    if status == fmi2Status_fmi2OK {
        Ok(())
    } else {
        Err(format!("{what} returned {}", STATUS_NAMES.get(status as usize).unwrap_or(&"an invalid status")))
    }
}

/// `cycles` × (fmi2Instantiate, a parameter, a scene file name, logging
/// categories, fmi2FreeInstance), with the logger on every eighth.
pub fn leak_instantiate(fmu: &Fmu, cycles: usize) -> Result<LeakFigures, String> {
    install_recorder();
    let with_logger = callbacks(true);
    let without = callbacks(false);
    let name = c"leak";
    let scene = CString::new("example-2004.toml").unwrap_or_default();
    let categories = [c"logStatusError".as_ptr(), c"logCalls".as_ptr()];
    let figures = measure("fmi2Instantiate/fmi2FreeInstance", cycles, |n| {
        let logged = n % 8 == 0;
        let c = instantiate_quietly(fmu, name, if logged { &with_logger } else { &without }, logged)?;
        let torque = 100.0 + n as f64;
        let statuses = [
            ffi!(fmu.api, fmi2SetReal(c, &vr::SUN_TORQUE, 1, &torque)),
            ffi!(fmu.api, fmi2SetString(c, &vr::SCENE_FILE, 1, &scene.as_ptr())),
            ffi!(fmu.api, fmi2SetDebugLogging(c, fmi2Boolean::from(logged), 2, categories.as_ptr())),
        ];
        ffi!(fmu.api, fmi2FreeInstance(c));
        take_messages();
        for s in statuses {
            ok(s, "a set after fmi2Instantiate")?;
        }
        Ok(())
    })?;
    Ok(figures)
}

/// `cycles` × (fmi2GetFMUstate, fmi2SerializedFMUstateSize,
/// fmi2SerializeFMUstate, a doStep, fmi2DeSerializeFMUstate,
/// fmi2SetFMUstate back to before the step, both states freed) on one
/// initialized instance: a rollback, so every cycle starts from the same
/// simulation state (a run that went on would grow its harmonic window, not
/// leak).
pub fn leak_states(fmu: &Fmu, cycles: usize) -> Result<LeakFigures, String> {
    let cb = callbacks(false);
    let c = instantiate_quietly(fmu, c"leak-states", &cb, false)?;
    let torsional = 0;
    let run = (|| {
        ok(ffi!(fmu.api, fmi2SetInteger(c, &vr::FIDELITY, 1, &torsional)), "fmi2SetInteger(fidelity)")?;
        ok(ffi!(fmu.api, fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0)), "fmi2SetupExperiment")?;
        ok(ffi!(fmu.api, fmi2EnterInitializationMode(c)), "fmi2EnterInitializationMode")?;
        ok(ffi!(fmu.api, fmi2ExitInitializationMode(c)), "fmi2ExitInitializationMode")?;
        let h = 1e-5;
        let mut buffer: Vec<fmi2Byte> = Vec::new();
        measure(
            "fmi2GetFMUstate/fmi2SerializeFMUstate/fmi2DeSerializeFMUstate/fmi2FreeFMUstate",
            cycles,
            |_| {
                let mut state: fmi2FMUstate = std::ptr::null_mut();
                ok(ffi!(fmu.api, fmi2GetFMUstate(c, &mut state)), "fmi2GetFMUstate")?;
                let mut size = 0;
                ok(
                    ffi!(fmu.api, fmi2SerializedFMUstateSize(c, state, &mut size)),
                    "fmi2SerializedFMUstateSize",
                )?;
                buffer.clear();
                buffer.resize(size, 0);
                ok(
                    ffi!(fmu.api, fmi2SerializeFMUstate(c, state, buffer.as_mut_ptr(), size)),
                    "fmi2SerializeFMUstate",
                )?;
                ok(ffi!(fmu.api, fmi2DoStep(c, 0.0, h, 0)), "fmi2DoStep")?;
                let mut copy: fmi2FMUstate = std::ptr::null_mut();
                ok(
                    ffi!(fmu.api, fmi2DeSerializeFMUstate(c, buffer.as_ptr(), size, &mut copy)),
                    "fmi2DeSerializeFMUstate",
                )?;
                ok(ffi!(fmu.api, fmi2SetFMUstate(c, copy)), "fmi2SetFMUstate")?;
                ok(ffi!(fmu.api, fmi2FreeFMUstate(c, &mut copy)), "fmi2FreeFMUstate")?;
                ok(ffi!(fmu.api, fmi2FreeFMUstate(c, &mut state)), "fmi2FreeFMUstate")?;
                Ok(())
            },
        )
    })();
    ffi!(fmu.api, fmi2FreeInstance(c));
    run
}

/// The seed of the recorded runs (docs/FUZZING.md).
pub const DEFAULT_SEED: u64 = 0x2004_5eed;

/// `PLANETWEAR_FUZZ_SEED` (decimal or 0x hex) if set, else `default`.
pub fn seed_from_env(default: u64) -> Result<u64, String> {
    match std::env::var("PLANETWEAR_FUZZ_SEED") {
        Err(_) => Ok(default),
        Ok(v) => {
            let parsed = match v.strip_prefix("0x") {
                Some(hex) => u64::from_str_radix(hex, 16),
                None => v.parse(),
            };
            parsed.map_err(|_| format!("PLANETWEAR_FUZZ_SEED = {v}: must be an integer (decimal or 0x hex)"))
        }
    }
}

/// Largest growth of the allocator's live bytes over a leak run [bytes].
pub const FLAT_BOUND: i64 = 64 * 1024;

/// Flat memory: the live bytes never grow by more than [`FLAT_BOUND`]
/// over the warm-up figure and do not rise at every checkpoint. Passes
/// without a figure when the allocator reports none (under valgrind, whose
/// leak checker then judges).
pub fn check_flat(f: &LeakFigures) -> Result<(), String> {
    if f.live_start == 0 {
        return Ok(());
    }
    if f.growth() > FLAT_BOUND {
        return Err(format!("{}: live bytes grew by {} B (bound {FLAT_BOUND} B): {f}", f.what, f.growth()));
    }
    if f.monotonic() && f.growth() > 0 {
        return Err(format!("{}: live bytes rose at every checkpoint: {f}", f.what));
    }
    Ok(())
}

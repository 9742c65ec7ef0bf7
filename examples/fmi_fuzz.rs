//! The FMU's C interface fuzzed and its memory checked, as a program that
//! runs under valgrind (scripts/test.sh) or natively:
//!
//! ```sh
//! cargo build --release --example fmi_fuzz
//! target/release/examples/fmi_fuzz --fmu fmu/planetwear.fmu --calls 100000 --builds 30
//! valgrind --error-exitcode=1 --leak-check=full --errors-for-leak-kinds=definite \
//!     target/release/examples/fmi_fuzz --fmu fmu/planetwear.fmu --calls 3000 --builds 3 --leak-cycles 500
//! ```
//!
//! Options: `--lib PATH` (a shared library; default the cdylib cargo built
//! beside this program) or `--fmu PATH` (a packed FMU, unpacked with its
//! resources), `--calls N`, `--seed S` (the environment variable
//! `PLANETWEAR_FUZZ_SEED` overrides it), `--builds N` (calls allowed to
//! build a simulation from valid parameters), `--torsional P` (the share of
//! those builds made torsional, default 0.7), `--leak-cycles N` (0: no leak
//! check), `--hang-seconds N`. Exit status 0 when every invariant held, 2
//! when one broke (the report names it and the calls before it).

#[path = "../tests/fmi_fuzz/harness.rs"]
mod harness;

use std::path::PathBuf;
use std::time::Duration;

use harness::{Fmu, FuzzConfig};

struct Args {
    lib: Option<PathBuf>,
    fmu: Option<PathBuf>,
    calls: u64,
    seed: u64,
    builds: u32,
    torsional: f64,
    leak_cycles: usize,
    hang_seconds: u64,
}

fn parse_number(flag: &str, value: Option<String>) -> Result<u64, String> {
    let v = value.ok_or_else(|| format!("{flag} needs a value"))?;
    let parsed = match v.strip_prefix("0x") {
        Some(hex) => u64::from_str_radix(hex, 16),
        None => v.parse(),
    };
    parsed.map_err(|_| format!("{flag} = {v}: must be a non-negative integer (decimal or 0x hex)"))
}

fn parse() -> Result<Args, String> {
    let mut a = Args {
        lib: None,
        fmu: None,
        calls: 20_000,
        seed: harness::DEFAULT_SEED,
        builds: 10,
        torsional: 0.7,
        leak_cycles: 10_000,
        hang_seconds: 120,
    };
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        match flag.as_str() {
            "--lib" => a.lib = Some(it.next().ok_or("--lib needs a path")?.into()),
            "--fmu" => a.fmu = Some(it.next().ok_or("--fmu needs a path")?.into()),
            "--calls" => a.calls = parse_number(&flag, it.next())?,
            "--seed" => a.seed = parse_number(&flag, it.next())?,
            "--builds" => {
                a.builds =
                    u32::try_from(parse_number(&flag, it.next())?).map_err(|e| format!("--builds: {e}"))?
            }
            "--torsional" => {
                let v = it.next().ok_or("--torsional needs a value")?;
                a.torsional = v
                    .parse::<f64>()
                    .ok()
                    .filter(|x| (0.0..=1.0).contains(x))
                    .ok_or_else(|| format!("--torsional = {v}: must be a share between 0 and 1"))?;
            }
            "--leak-cycles" => a.leak_cycles = parse_number(&flag, it.next())? as usize,
            "--hang-seconds" => a.hang_seconds = parse_number(&flag, it.next())?,
            other => return Err(format!("unknown option {other}: see the header of examples/fmi_fuzz.rs")),
        }
    }
    a.seed = harness::seed_from_env(a.seed)?;
    Ok(a)
}

fn run() -> Result<bool, String> {
    let a = parse()?;
    let fmu = match (&a.fmu, &a.lib) {
        (Some(f), _) => Fmu::unpack(f)?,
        (None, Some(l)) => Fmu::load(l)?,
        (None, None) => Fmu::load(&Fmu::built_library()?)?,
    };
    println!("fmi fuzz: {} (resources {})", fmu.library.display(), fmu.resources.display());
    let cfg = FuzzConfig {
        seed: a.seed,
        calls: a.calls,
        builds: a.builds,
        torsional: a.torsional,
        hang_after: Duration::from_secs(a.hang_seconds),
    };
    match harness::fuzz(&fmu, &cfg) {
        Ok(report) => print!("{report}"),
        Err(failure) => {
            eprint!("{failure}");
            return Ok(false);
        }
    }
    if a.leak_cycles > 0 {
        for figures in
            [harness::leak_instantiate(&fmu, a.leak_cycles)?, harness::leak_states(&fmu, a.leak_cycles)?]
        {
            println!("{figures}");
            if let Err(why) = harness::check_flat(&figures) {
                eprintln!("{why}");
                return Ok(false);
            }
        }
    }
    Ok(true)
}

fn main() {
    match run() {
        Ok(true) => {}
        Ok(false) => std::process::exit(2),
        Err(e) => {
            eprintln!("fmi_fuzz: {e}");
            std::process::exit(2);
        }
    }
}

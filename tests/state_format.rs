//! The serialized state: versioned, self-checking, pointer-free, bit-identical.

use planetwear::contact::ltca::SetModel;
use planetwear::dynamics::equations::PlanetaryDynamics;
use planetwear::dynamics::simulation::{Simulation, Snapshot};
use planetwear::dynamics::state_format::{decode, encode, StateFormatError};
use planetwear::model::gear::MeshKind;
use planetwear::scene::{Fidelity, Scene};
use proptest::prelude::*;

const FP: &str = "{20162229-bf0e-39e4-7185-1218fde35b69}|example-2004";

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

fn snapshot(values: Vec<f64>, n: usize) -> Snapshot {
    let take = |k: usize| values.iter().cycle().skip(k).take(n).cloned().collect::<Vec<f64>>();
    Snapshot {
        time: values.first().copied().unwrap_or(0.0),
        q: take(1),
        v: take(2),
        integrator: take(3),
        torques: [1.5, -0.0, f64::MIN_POSITIVE],
        speed_reference: 314.159,
        window_sun: take(4),
        window_ring: take(5),
        window_last: take(6).into_iter().take(3).collect(),
        drive: take(7).into_iter().take(2).collect(),
        duty: take(8),
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    #[test]
    fn round_trips_bit_identically(values in prop::collection::vec(any::<f64>().prop_filter("finite", |x| x.is_finite()), 1..40), n in 0usize..30) {
        let s = snapshot(values, n);
        let back = decode(&encode(&s, FP), FP).unwrap();
        prop_assert_eq!(back.time.to_bits(), s.time.to_bits());
        prop_assert_eq!(bits(&back.q), bits(&s.q));
        prop_assert_eq!(bits(&back.v), bits(&s.v));
        prop_assert_eq!(bits(&back.integrator), bits(&s.integrator));
        prop_assert_eq!(bits(&back.torques), bits(&s.torques));
        prop_assert_eq!(bits(&back.window_sun), bits(&s.window_sun));
        prop_assert_eq!(bits(&back.window_ring), bits(&s.window_ring));
        prop_assert_eq!(bits(&back.window_last), bits(&s.window_last));
        prop_assert_eq!(bits(&back.drive), bits(&s.drive));
        prop_assert_eq!(bits(&back.duty), bits(&s.duty));
    }

    #[test]
    fn any_flipped_byte_is_refused(pos in any::<prop::sample::Index>(), bit in 0u8..8) {
        let blob = encode(&snapshot(vec![1.0, 2.0, 3.0], 5), FP);
        let mut bad = blob.clone();
        let i = pos.index(bad.len());
        bad[i] ^= 1 << bit;
        prop_assert!(decode(&bad, FP).is_err(), "flip at byte {} accepted", i);
    }
}

#[test]
fn every_truncation_and_extension_is_refused() {
    let blob = encode(&snapshot(vec![1.0, 2.0], 4), FP);
    for len in 0..blob.len() {
        assert!(decode(&blob[..len], FP).is_err(), "truncated to {len} accepted");
    }
    let mut longer = blob.clone();
    longer.push(0);
    assert!(matches!(decode(&longer, FP), Err(StateFormatError::Length { .. })));
}

#[test]
fn foreign_and_future_states_are_refused_by_name() {
    let blob = encode(&snapshot(vec![1.0], 3), FP);
    match decode(&blob, "{other-guid}|other-scene") {
        Err(StateFormatError::Foreign { found, expected }) => {
            assert_eq!(found, FP);
            assert_eq!(expected, "{other-guid}|other-scene");
        }
        other => panic!("{other:?}"),
    }
    let mut future = blob.clone();
    future[8] = 9;
    assert_eq!(decode(&future, FP), Err(StateFormatError::Version { found: 9 }));
    assert_eq!(decode(b"not a state at all", FP), Err(StateFormatError::NotAState));
    let msg = StateFormatError::Checksum.to_string();
    assert!(msg.contains("altered"), "{msg}");
}

#[test]
fn a_simulation_continues_bit_identically_from_a_state_file() {
    let mut s = Scene::example_2004();
    s.dynamics.fidelity = Fidelity::Torsional;
    let (set, run) = s.validate_with_run().unwrap();
    let model = PlanetaryDynamics::new(&set, SetModel::new(&set)).unwrap();
    let mut sim = Simulation::new(&set, &run, model.clone(), 0.0, 314.159).unwrap();
    for _ in 0..30 {
        sim.do_step(sim.time(), 3e-5).unwrap();
    }
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("state.bin");
    std::fs::write(&path, encode(&sim.snapshot(), FP)).unwrap();
    for _ in 0..30 {
        sim.do_step(sim.time(), 3e-5).unwrap();
    }
    // A fresh simulation (as after a process restart) restores from the file.
    let mut other = Simulation::new(&set, &run, model, 0.0, 314.159).unwrap();
    other.restore(&decode(&std::fs::read(&path).unwrap(), FP).unwrap()).unwrap();
    for _ in 0..30 {
        other.do_step(other.time(), 3e-5).unwrap();
    }
    assert_eq!(other.snapshot(), sim.snapshot());
    assert_eq!(
        other.mesh_force(1, MeshKind::SunPlanet).to_bits(),
        sim.mesh_force(1, MeshKind::SunPlanet).to_bits()
    );
}

/// A state of format version 1 (before the load duty's counts) is still read, with no counts:
/// the version 2 layout of a state without a duty, less its eighth length.
#[test]
fn a_version_1_state_is_read_without_a_duty() {
    let mut s = snapshot(vec![1.0, 2.0, 3.0], 5);
    s.duty.clear();
    let v2 = encode(&s, FP);
    let header = 8 + 4 + 4 + FP.len() + 8;
    let mut v1 = v2[..8].to_vec();
    v1.extend_from_slice(&1u32.to_le_bytes());
    v1.extend_from_slice(&v2[12..header + 4 * 7]);
    v1.extend_from_slice(&v2[header + 4 * 8..v2.len() - 8]);
    let sum = planetwear::files::hash::fnv1a64(&v1);
    v1.extend_from_slice(&sum.to_le_bytes());
    let back = decode(&v1, FP).unwrap();
    assert_eq!(bits(&back.q), bits(&s.q));
    assert_eq!(bits(&back.drive), bits(&s.drive));
    assert!(back.duty.is_empty());
    let mut v3 = v2.clone();
    v3[8..12].copy_from_slice(&3u32.to_le_bytes());
    assert_eq!(decode(&v3, FP).unwrap_err(), StateFormatError::Version { found: 3 });
}
